"""Checkpoint plane and height accuracy are contents of their own (DOMAIN §2): a checkpoint rule
that judges both components gives each its content. A project rule written for heights
(`content: cp_height`, the height norm) without `where: {component: height}` filed the plane's
results under cp_height too, judged by the height norm: a plane error of 8.9 m, within the
plane norm of 10 m, failed the block's height accuracy. Such a rule is refused at its content's
line, with the `where:` to add."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.errors import RuleError
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack

RULE = """\
rules:
  - id: PA-1
    title: Checkpoint height medium error within the norm
    clause: §CP-5
    content: cp_height
    inspection: detailed
    metric: checkpoint_accuracy
    scope: component_method
    statistic: medium_error
    threshold: {max: norm.height_m}
    unit: m
"""
WHERE = "    where: {component: height}\n"
ADVICE = "add where: {component: plane} or where: {component: height}"


def _refused(path: Path) -> str:
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    (problem,) = exc.value.problems
    assert problem.file == str(path)
    assert path.read_text("utf-8").splitlines()[problem.line - 1].lstrip().startswith("content")
    return problem.message


def test_a_height_rule_that_takes_the_plane_results_too_is_refused(blockqc, tmp_path: Path) -> None:
    path = extension_pack(tmp_path, RULE)
    message = _refused(path)
    assert message.startswith("rule PA-1: content: cp_height would take the results of ")
    assert "component plane and height" in message and ADVICE in message
    p = blockqc("rules", "lint", path)
    assert p.returncode == 2, p.stdout + p.stderr
    assert f"{path}, line 7: rule PA-1: content: cp_height" in p.stderr


THRESHOLD = "    threshold: {max: norm.height_m}\n"


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("content: cp_height", "content: [cp_plane, cp_height]"),  # both, in both contents
        (THRESHOLD, "    where: {method: high_precision}\n" + THRESHOLD),  # a method, both
        (THRESHOLD, "    thresholds: {plane: {max: 10}, height: {max: 6}}\n"),
    ],
)
def test_every_content_taking_both_components_is_refused(
    tmp_path: Path, old: str, new: str
) -> None:
    message = _refused(extension_pack(tmp_path, RULE.replace(old, new)))
    assert "component plane and height" in message and ADVICE in message


SPLIT = """\
  - id: PA-2
    title: Checkpoint medium errors within the norms
    clause: §CP-5
    content: {cp_plane: {component: plane}, cp_height: {component: height}}
    inspection: detailed
    metric: checkpoint_accuracy
    scope: component_method
    statistic: medium_error
    thresholds: {plane: {max: 10}, height: {max: 6}}
    unit: m
"""


def test_each_component_to_its_content_is_judged_apart(tmp_path: Path) -> None:
    """The base delivery's 27 high-precision checkpoints: plane Δ 5 m, height Δ 2 m, so M1 is
    5 m (within 10 m) for the plane and 2 m (within 6 m) for the height."""
    own = RULE.replace(THRESHOLD, WHERE + THRESHOLD)
    pack = load_pack(extension_pack(tmp_path, own + SPLIT))
    delivery = load_delivery(write_delivery(tmp_path / "delivery"))
    got = sorted(
        (r.rule, r.group["component"], r.content, r.value, r.status)
        for r in inspect_delivery(delivery, pack).results
        if r.rule in ("PA-1", "PA-2")
    )
    assert got == [
        ("PA-1", "height", ["cp_height"], 2.0, "pass"),
        ("PA-2", "height", ["cp_height"], 2.0, "pass"),
        ("PA-2", "plane", ["cp_plane"], 5.0, "pass"),
    ]


def test_an_asprs_rule_over_both_components_is_refused(tmp_path: Path) -> None:
    """ASPRS horizontal and vertical accuracy are contents of their own too."""
    rule = (
        "rules:\n  - id: PA-1\n    title: RMSE within 5 m\n    clause: §ASPRS-CP\n"
        "    content: vertical\n    metric: asprs_accuracy\n    scope: component\n"
        "    statistic: rmse_m\n    threshold: {max: 5}\n    unit: m\n"
    )
    message = _refused(extension_pack(tmp_path, rule, extends="asprs-2023"))
    assert "component horizontal and vertical" in message
    assert "add where: {component: horizontal} or where: {component: vertical}" in message


def test_a_height_content_given_the_plane_results_by_its_where_is_refused(
    blockqc, tmp_path: Path
) -> None:
    """A rule copied from CP-3 with `where: {component: plane}` filed plane results under
    cp_height (where CP-3 and CP-4 file the heights), judged by the height norm of 6 m."""
    path = extension_pack(
        tmp_path, RULE.replace(THRESHOLD, "    where: {component: plane}\n" + THRESHOLD)
    )
    assert _refused(path) == (
        "rule PA-1: content: cp_height would take the results of component height (CP-3, "
        "CP-4) and plane (PA-1) of checkpoint_accuracy, each component a content of its own: "
        "write content: cp_plane for this rule's component plane, or where: {component: "
        "height} to judge the other"
    )
    p = blockqc("rules", "lint", path)
    assert p.returncode == 2, p.stdout + p.stderr
    assert f"{path}, line 7: rule PA-1: content: cp_height would take" in p.stderr


def test_a_stock_rule_overridden_to_the_other_component_is_refused(tmp_path: Path) -> None:
    """CP-2 (content cp_plane) overridden to judge heights: refused at the override's line."""
    path = extension_pack(tmp_path, "overrides:\n  CP-2: {where: {component: height}}\n")
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    (problem,) = exc.value.problems
    assert (problem.file, problem.line) == (str(path), 4)
    assert problem.message.startswith(
        "rule CP-2: content: cp_plane would take the results of component height (CP-2) and "
        "plane (CP-4) of checkpoint_accuracy"
    )
    assert "write content: cp_height for this rule's component height" in problem.message


def test_each_component_to_the_content_the_stock_rules_give_it_is_kept(tmp_path: Path) -> None:
    own = RULE.replace(THRESHOLD, WHERE + THRESHOLD)
    plane = own.replace("rules:\n", "").replace("PA-1", "PA-3").replace("height", "plane")
    pack = load_pack(extension_pack(tmp_path, own + plane + SPLIT))
    assert [r.id for r in pack.rules][-3:] == ["PA-1", "PA-3", "PA-2"]
