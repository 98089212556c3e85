"""A statistic that cannot be negative (a median of error magnitudes, an RMS, a count, a share)
passes no upper bound below 0, nor `max: 0` with `inclusive: false`: such a rule fails every
delivery whatever it holds. It is refused at the bound's line; a signed statistic (a
checkpoint's height error dz, an ASPRS bias) may be bounded below 0."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from casekit import PA1_RULE, extension_pack

RULE = """\
rules:
  - id: PA-1
    title: Tie-point median error within 0.5 px
    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    params: {bands: [pan]}
    statistic: median
    threshold: {max: -0.5}
    unit: px
"""


def _refused(path: Path) -> list[str]:
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    return [f"{p.file}, line {p.line}: {p.message}" for p in exc.value.problems]


def test_a_bound_below_zero_on_a_median_of_magnitudes_is_refused(blockqc, tmp_path: Path) -> None:
    path = extension_pack(tmp_path, RULE)
    assert _refused(path) == [
        f"{path}, line 11: rule PA-1: threshold.max: -0.5 is below 0, and statistic median (px) "
        "of tie_point_errors at scope block is never negative: nothing can pass"
    ]
    p = blockqc("rules", "lint", path)
    assert p.returncode == 2, p.stdout + p.stderr


def test_max_zero_exclusive_on_a_discrepancy_is_refused(tmp_path: Path) -> None:
    """RO-3's plane discrepancies √(dx² + dy²) are never below 0: `< 0` passes none."""
    body = (
        "overrides:\n  RO-3:\n"
        "    thresholds: {plane: {max: 0, inclusive: false}, height: {max: 8}}\n"
    )
    path = extension_pack(tmp_path, body)
    (found,) = _refused(path)
    assert found.startswith(f"{path}, line 5: rule RO-3: thresholds.plane.max: 0 with ")
    assert "inclusive: false, and statistic value_m (m) of overlap_discrepancy" in found


def test_a_constant_set_below_zero_is_named_at_the_stock_rule(tmp_path: Path) -> None:
    """TP-1's bound is tp.error_px: the project's -0.5 makes it one nothing passes."""
    path = extension_pack(tmp_path, "constants:\n  tp: {error_px: -0.5}\n")
    (found,) = _refused(path)
    assert "rule TP-1: threshold.max: -0.5 is below 0" in found
    assert f"(constants set elsewhere: tp.error_px = -0.5, set in {path}, line 4)" in found


def test_a_signed_statistic_may_be_bounded_below_zero(tmp_path: Path) -> None:
    """A checkpoint's height error dz (measured − reference) is signed."""
    rule = (
        "rules:\n  - id: PA-1\n    title: Heights below the reference\n    clause: §CP-3\n"
        "    content: cp_height\n    metric: checkpoint_accuracy\n    scope: point\n"
        "    where: {component: height}\n    statistic: error_m\n"
        "    threshold: {max: -0.1}\n    unit: m\n"
    )
    assert load_pack(extension_pack(tmp_path, rule)).rule("PA-1").threshold.max == -0.1


COUNT_RULE = "rules:\n" + PA1_RULE.replace("threshold: {min: 100}", "threshold: THRESHOLD")


def _notes(tmp_path: Path, threshold: str) -> list[str]:
    pack = load_pack(extension_pack(tmp_path, COUNT_RULE.replace("THRESHOLD", threshold)))
    return [f"line {p.line}: {p.message}" for p in pack.notes]


@pytest.mark.parametrize(
    ("threshold", "how"),
    [("{min: 0}", "0 takes 0 in"), ("{min: -5, inclusive: false}", "-5 is below 0")],
)
def test_a_lower_bound_every_count_meets_is_a_warning(
    tmp_path: Path, threshold: str, how: str
) -> None:
    """A count of tie points is never below 0: `min: 0` passes every scene, a rule that cannot
    fail (kept, said at lint)."""
    assert _notes(tmp_path, threshold) == [
        f"line 12: rule PA-1: threshold.min: {how}, and statistic n_points (points) of "
        "tie_point_distribution at scope scene is never negative: every delivery passes "
        "(the rule cannot fail)"
    ]


@pytest.mark.parametrize(
    "threshold", ["{min: 0, max: 5000}", "{min: 0, inclusive: false}", "{min: 100}"]
)
def test_lower_bounds_that_can_fail_are_not_warned(tmp_path: Path, threshold: str) -> None:
    """A range from 0, more than 0 points, or at least 100 can each fail a scene."""
    assert _notes(tmp_path, threshold) == []


def test_a_signed_statistic_bounded_below_zero_from_below_is_not_warned(tmp_path: Path) -> None:
    rule = (
        "rules:\n  - id: PA-1\n    title: Heights above a floor\n    clause: §CP-3\n"
        "    content: cp_height\n    metric: checkpoint_accuracy\n    scope: point\n"
        "    where: {component: height}\n    statistic: error_m\n"
        "    threshold: {min: -3}\n    unit: m\n"
    )
    assert load_pack(extension_pack(tmp_path, rule)).notes == []
