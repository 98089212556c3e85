"""`blockqc rules explain` and `rules list` show a pack's rules as the pack sets them."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack


def _project(tmp_path: Path) -> Path:
    pack = tmp_path / "project.yaml"
    pack.write_text(
        "pack: project\nextends: global-project\nconstants:\n  norm: {plane_m: 5}\n"
        "overrides:\n  TP-1: {statistic: rms}\n  CP-5: {severity: fail}\n",
        "utf-8",
    )
    return pack


def test_explain_reflects_the_overrides(blockqc, tmp_path: Path) -> None:
    pack = _project(tmp_path)
    p = blockqc("rules", "explain", "TP-1", "--rules", pack)
    assert p.returncode == 0, p.stderr
    assert "judges:    the rms at scope block (px)" in p.stdout
    assert f"overridden in {pack}, line 6: statistic rms" in p.stdout
    assert "before the overrides above" in p.stdout  # the stock description says "median"
    p = blockqc("rules", "explain", "CP-5", "--rules", pack)
    assert "severity:  fail (a failure fails the block)" in p.stdout
    assert "warn" not in p.stdout.split("description")[0]
    assert "implements §CP-2" in p.stdout


def test_explain_shows_thresholds_evaluated_and_as_written(blockqc, tmp_path: Path) -> None:
    p = blockqc("rules", "explain", "RO-2", "--rules", _project(tmp_path))
    assert "threshold: plane: < 10 m; height: < 12 m" in p.stdout  # 2·5 m and 2·6 m
    assert "as written: plane max: 2 * norm.plane_m; height max: 2 * norm.height_m" in p.stdout


def test_explain_is_case_insensitive(blockqc) -> None:
    p = blockqc("rules", "explain", "tp-1")
    assert p.returncode == 0 and p.stdout.startswith("TP-1 — ")
    p = blockqc("rules", "explain", "TP-10")
    assert (
        p.returncode == 2
        and "no rule TP-10 in pack global-project (did you mean TP-1?)" in p.stderr
    )


def test_explain_reads_an_id_without_the_spaces_around_it(blockqc) -> None:
    """'TP-1 ' (pasted from a table) was 'no rule TP-1  in pack … (did you mean TP-1?)'."""
    p = blockqc("rules", "explain", " TP-1 ")
    assert p.returncode == 0 and p.stdout.startswith("TP-1 — "), p.stderr
    p = blockqc("rules", "explain", " ")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "no rule id given (rules: MB-1, MB-2, MB-3, TP-1, " in p.stderr


def test_list_shows_units_and_waivable(blockqc) -> None:
    p = blockqc("rules", "list")
    lines = {ln.split()[0]: ln for ln in p.stdout.splitlines()[1:] if ln.strip()}
    pack = load_pack("global-project")
    assert set(lines) == {r.id for r in pack.rules}
    for r in pack.rules:
        assert (" yes " if r.waivable else " no ") in lines[r.id], lines[r.id]
    assert "≥ 100 points" in lines["TP-4"] and "≤ 0.5 px" in lines["TP-1"]
    assert "plane: < 28.2843 m" in lines["RO-3"]


def test_explain_of_a_disabled_rule_says_so_without_another_rule_offered(blockqc) -> None:
    """CP-5, disabled by the sample project pack, was 'no rule CP-5 … (did you mean TP-5?); CP-5
    is disabled', offering another rule; lower case (cp-5) lost the 'disabled' altogether."""
    pack = Path(__file__).parents[2] / "samples" / "packs" / "strict-project.yaml"
    for asked in ("CP-5", "cp-5"):
        p = blockqc("rules", "explain", asked, "--rules", pack)
        assert p.returncode == 2, p.stdout
        assert f"no rule {asked} in pack strict-project: CP-5 is disabled by the pack" in p.stderr
        assert "did you mean" not in p.stderr


def test_a_bar_in_a_title_stays_inside_its_markdown_cell(tmp_path, blockqc) -> None:
    """A title writing |Δ| split its row of `rules list --markdown` into two more columns."""
    pack = tmp_path / "project.yaml"
    pack.write_text(
        "pack: project\nextends: global-project\noverrides:\n"
        '  CP-2: {title: "Checkpoint plane medium error of |Δ| within the norm"}\n',
        "utf-8",
    )
    p = blockqc("rules", "list", "--rules", pack, "--markdown")
    assert p.returncode == 0, p.stderr
    (row,) = [line for line in p.stdout.splitlines() if line.startswith("| CP-2 ")]
    assert row == (
        "| CP-2 | §CP-5 | Checkpoint plane medium error of \\|Δ\\| within the norm | "
        "`checkpoint_accuracy.component_method.medium_error` | ≤ 10 m | m | fail | no |"
    )
    (tp1,) = [line for line in p.stdout.splitlines() if line.startswith("| TP-1 ")]
    assert tp1 == (
        "| TP-1 | §TP-1 | Tie-point error statistic | `tie_point_errors.block.median` | ≤ 0.5 px "
        "| px | fail | no |"
    )
