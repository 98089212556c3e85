"""A pack key or parameter refused for its value is named at its own line, with what was
expected."""

from __future__ import annotations

from pathlib import Path

from casekit import extension_pack, lint_messages


def test_an_interval_given_upper_first_is_named_at_its_line(tmp_path: Path) -> None:
    """Before: 'line 5: rule TP-3: params.: Value error, interval_px must be …' (the line of
    `params:`, no parameter named)."""
    body = "overrides:\n  TP-3:\n    params:\n      interval_px: [1.5, 1.0]\n"
    path = extension_pack(tmp_path, body)
    (found,) = lint_messages(path)
    assert found == (
        f"{path}, line 6: rule TP-3: params.interval_px: expected [lower, upper] with "
        "lower < upper, got [1.5, 1]"
    )


def test_an_unquoted_version_is_refused_with_the_quoted_form(tmp_path: Path) -> None:
    """YAML reads `version: 1.0` as a number. Before: 'version: Input should be a valid
    string', nothing said of the quotes."""
    path = tmp_path / "project.yaml"
    path.write_text("pack: project\nversion: 1.0\nextends: global-project\n", "utf-8")
    (found,) = lint_messages(path)
    assert found.startswith(f"{path}, line 2: version: a version is a text: write it in quotes")
    assert '(version: "1.0")' in found
    path.write_text('pack: project\nversion: "1.10"\nextends: global-project\n', "utf-8")
    assert lint_messages(path) == []


def test_values_of_the_wrong_kind_are_refused_in_the_words_of_yaml(tmp_path: Path) -> None:
    """Before: pydantic's 'Input should be a valid list' / 'valid dictionary', and an id or
    pack name refused with the regular expression it did not match."""
    body = (
        "disable: CP-5\n"
        "overrides:\n  TP-1:\n"
        "rules:\n"
        "  - id: pr_1\n    title: A project rule\n    clause: §TP-1\n    manual: true\n"
    )
    path = tmp_path / "project.yaml"
    path.write_text(f"pack: my project\nextends: global-project\n{body}", "utf-8")
    assert lint_messages(path) == [
        f"{path}, line 1: pack: expected a pack name of letters, digits, _, . and -, starting "
        "with a letter or digit, got text 'my project'",
        f"{path}, line 5: overrides.TP-1: expected a mapping of keys, got an empty value",
        f"{path}, line 3: disable: expected a list, got text 'CP-5' (a list of one is written "
        "[CP-5])",
    ]
    rule = body[body.index("rules:") :]
    path.write_text(f"pack: project\nextends: global-project\n{rule}", "utf-8")
    assert lint_messages(path) == [
        f"{path}, line 4: rule pr_1: id: expected a rule id such as PR-1 or TP-10: capital "
        "letters and digits starting with a capital, then one or more parts of letters and "
        "digits each after a '-', got text 'pr_1'"
    ]


def test_the_same_values_of_the_right_kind_are_read(tmp_path: Path) -> None:
    body = (
        "disable: [CP-5]\n"
        "overrides:\n  TP-1: {statistic: rms}\n"
        "rules:\n"
        "  - id: PR-1\n    title: A project rule\n    clause: §TP-1\n    manual: true\n"
    )
    path = tmp_path / "project.yaml"
    path.write_text(f"pack: my-project.v2\nextends: global-project\n{body}", "utf-8")
    assert [m for m in lint_messages(path) if "has no cases" not in m] == []


def test_a_number_beyond_its_bound_is_refused_in_words(tmp_path: Path) -> None:
    """Before: 'Input should be greater than or equal to 0' / 'Input should be greater than 0'."""
    from casekit import project_with_cases

    case = (
        "rule: TP-1\ncases:\n  - name: every error 0.3 px\n    expect: pass\n"
        "  - name: S1 cut\n    drop: {tie_points: [{where: {scene_id: S1}, keep_first: -1}]}\n"
        "    expect: fail\n"
    )
    path = project_with_cases(
        tmp_path, "overrides:\n  CP-2: {params: {plane_norm_m: -5}}\n", {"TP-1": case}
    )
    cases = tmp_path / "project.cases" / "TP-1.yaml"
    assert lint_messages(path) == [
        f"{path}, line 4: rule CP-2: params.plane_norm_m: expected a number above 0, got a "
        "number (-5)",
        f"{cases}, line 6: cases.1.drop.tie_points.0.keep_first: expected a number at least 0, "
        "got a number (-1)",
    ]
