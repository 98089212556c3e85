"""A metric parameter that stands for a constant of the pack takes the pack's value when a rule
leaves it out: a project that tightens the plane norm to 2.4 m judges the gross errors of its own
checkpoint rule at 2·2.4 m, as the stock CP-4 does, not at the metric's default 2·10 m."""

from __future__ import annotations

from pathlib import Path

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack, lint_messages

# the base delivery: 27 high-precision checkpoints, plane Δ = 5 m, height Δ = 2 m (casebase.py)
PA3 = """\
  - id: PA-3
    title: Gross-error rate below 5 %
    clause: §CP-6
    content: {cp_plane: {component: plane}, cp_height: {component: height}}
    metric: checkpoint_accuracy
    scope: component_method
    statistic: gross_rate
    threshold: {max: 5, inclusive: false}
    unit: "%"
"""
PA4 = """\
  - id: PA-4
    title: Plane medium error within 6 m
    clause: §CP-5
    content: cp_plane
    metric: checkpoint_accuracy
    scope: component_method
    where: {component: plane}
    statistic: medium_error
    threshold: {max: 6}
    unit: m
"""
RULE = PA3 + PA4


def _results(tmp_path: Path, body: str) -> dict[tuple[str, str], object]:
    pack = load_pack(extension_pack(tmp_path, body))
    delivery = load_delivery(write_delivery(tmp_path / "delivery"))
    return {
        (r.rule, r.group.get("component", "")): r
        for r in inspect_delivery(delivery, pack).results
        if r.rule in ("PA-3", "PA-4", "CP-4")
    }


def test_the_norms_the_project_sets_bound_the_gross_errors(tmp_path: Path) -> None:
    """norm 2.4 m plane, 0.9 m height: bounds 4.8 m and 1.8 m, below every Δ (5 m, 2 m): all
    27 checkpoints are gross errors of both components, 100 % (before: bounds 20 m and 12 m,
    0 %), as CP-4 finds."""
    body = "constants:\n  norm: {plane_m: 2.4, height_m: 0.9}\nrules:\n" + RULE
    got = _results(tmp_path, body)
    for component, bound in (("plane", 4.8), ("height", 1.8)):
        own, stock = got[("PA-3", component)], got[("CP-4", component)]
        assert own.status == "fail"
        assert own.value == 100.0
        assert own.detail["n_gross"] == 27
        assert abs(own.detail["bound_m"] - bound) < 1e-12
        assert (stock.value, stock.detail["bound_m"]) == (own.value, own.detail["bound_m"])


def test_the_count_below_which_the_mean_is_used_follows_the_project(tmp_path: Path) -> None:
    """cp.min_points 30: 27 checkpoints are fewer, so the mean error replaces M1 (§CP-7): the
    mean of |Δ| = 5 m (before: M1, as with the default 20)."""
    got = _results(tmp_path, "constants:\n  cp: {min_points: 30}\nrules:\n" + RULE)
    pa4 = got[("PA-4", "plane")]
    assert pa4.status == "pass"
    assert abs(pa4.value - 5.0) < 1e-12
    assert pa4.detail["statistic"] == "mean"
    assert pa4.detail["used_mean"] is True


def test_a_parameter_the_rule_gives_is_kept(tmp_path: Path) -> None:
    """plane_norm_m: 10 given: bound 20 m whatever the pack's norm; 5 m is no gross error."""
    body = "constants:\n  norm: {plane_m: 2.4}\nrules:\n" + RULE.replace(
        "    where: {component: plane}\n",
        "    where: {component: plane}\n    params: {plane_norm_m: 10}\n",
    )
    pa4 = _results(tmp_path, body)[("PA-4", "plane")]
    assert pa4.detail["n_gross"] == 0
    assert pa4.detail["bound_m"] == 20.0


def test_a_pack_of_its_own_uses_its_norm_through_the_default(tmp_path: Path) -> None:
    """A pack written from scratch setting norm.plane_m, read only by the parameter left out:
    the constant is used (not refused as used by no rule)."""
    path = tmp_path / "own.yaml"
    path.write_text(
        "pack: own\nconstants:\n  norm: {plane_m: 2.4}\nelements:\n  - id: data\n"
        "    title: Data quality\n    items:\n      - id: plane_accuracy\n"
        "        title: Plane accuracy\n        contents:\n"
        "          - {id: cp_plane, title: Checkpoint plane accuracy}\n"
        "rules:\n" + PA4,
        "utf-8",
    )
    messages = lint_messages(path)
    assert not [m for m in messages if "used by no rule" in m], messages


def test_the_report_names_the_project_count_below_which_the_mean_is_used(tmp_path: Path) -> None:
    """cp.min_points 30, 27 checkpoints: the report's §CP-7 note reads 'fewer than 30', the
    count that put the mean in place of M1 (it read 'fewer than 20', the stock count, which 27
    checkpoints are not), in the result and under the checkpoint table, in both languages."""
    from blockqc.report.build import block_context

    pack = load_pack(
        extension_pack(tmp_path, "constants:\n  cp: {min_points: 30}\nrules:\n" + RULE)
    )
    results = inspect_delivery(load_delivery(write_delivery(tmp_path / "delivery")), pack)
    for lang, note in (("en", "Fewer than 30 checkpoints"), ("zh", "检查点少于 30 个")):
        ctx = block_context(results, lang=lang, figures=False)
        notes = [n for row in ctx["detailed"] if row["rule"] == "CP-2" for n in row["notes"]]
        assert any(note in n for n in notes) and not any("20" in n for n in notes)
        (plane,) = [tb for tb in ctx["cp_tables"] if tb["key"] == "plane"]
        assert plane["any_mean"] and note in plane["mean_note"]


def test_the_mean_error_is_labelled_with_its_divisor(tmp_path: Path) -> None:
    """§CP-7: the mean error in place of M2 is divided by √2 as M2 is, and the table says so
    beside the value (it read 'mean error' alone, which a reader takes for Σ|Δ|/n): 27
    checkpoints of plane Δ = 5 m under cp.min_points 30 give 5 m high-precision (Σ|Δ|/n) and
    5/√2 = 3.54 m same-accuracy (Σ|Δ|/(√2·n))."""
    from blockqc.report.build import block_context

    pack = load_pack(
        extension_pack(tmp_path, "constants:\n  cp: {min_points: 30}\nrules:\n" + RULE)
    )
    base = write_delivery(tmp_path / "delivery")
    for method, label, value in (
        ("high_precision", "mean error = Σ|Δ|/n", "5.00"),
        ("same_accuracy", "mean error = Σ|Δ|/(√2·n)", "3.54"),
    ):
        table = base / "checkpoints.csv"
        text = table.read_text("utf-8")
        table.write_text(text.replace("high_precision", method), "utf-8")
        ctx = block_context(inspect_delivery(load_delivery(base), pack), figures=False)
        (plane,) = [tb for tb in ctx["cp_tables"] if tb["key"] == "plane"]
        rows = dict(plane["rows"])
        assert rows["Statistic"] == [label] and rows["Medium error (m)"] == [f"* {value}"]
