"""A per-unit rule whose failing units include one without a value (a PAN scene holding no
tie point has no median error) gives as its value the worst of those that have one; the one
without is listed in the evidence, and the value is None only when no failing unit has one."""

from __future__ import annotations

import math
from pathlib import Path

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack

RULE = """\
rules:
  - id: PA-2
    title: Tie-point median error of every PAN scene within 0.5 px
    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    params: {bands: [pan]}
    scope: scene
    statistic: median
    threshold: {max: 0.5}
    unit: px
"""

# the base delivery: 121 observations on each of S1..S4, every error 0.3 px (casebase.py)
S1_WITHOUT_TIE_POINTS = {"tie_points": [{"where": {"scene_id": "S1"}}]}
S2_DOUBLED = {
    "tie_points": [
        {"where": {"scene_id": "S2"}, "column": c, "from": c, "times": 2}
        for c in ("v_line", "v_sample")
    ]
}


def _pa2(tmp_path: Path, case: dict):
    pack = load_pack(extension_pack(tmp_path, RULE))
    delivery = load_delivery(write_delivery(tmp_path / "delivery", case))
    (result,) = [r for r in inspect_delivery(delivery, pack).results if r.rule == "PA-2"]
    return result


def test_the_value_is_the_worst_measured_unit(tmp_path: Path) -> None:
    """S2's errors doubled to 0.6 px, S1 without tie points: the value is 0.6 px (before:
    None), the evidence S2 (median 0.6) then S1 (no observation, no median)."""
    got = _pa2(tmp_path, {"drop": S1_WITHOUT_TIE_POINTS, "derive": S2_DOUBLED})
    assert got.status == "fail"
    assert math.isclose(got.value, 0.6, rel_tol=1e-12)
    assert [e["scene_id"] for e in got.evidence] == ["S2", "S1"]
    assert got.evidence[1]["n"] == 0 and got.evidence[1]["median"] is None
    assert got.detail["n_offending"] == 2


def test_no_value_when_no_failing_unit_has_one(tmp_path: Path) -> None:
    """S1 alone fails, holding no tie point: no value to give (S2..S4's 0.3 px pass)."""
    got = _pa2(tmp_path, {"drop": S1_WITHOUT_TIE_POINTS})
    assert got.status == "fail"
    assert got.value is None
    assert [e["scene_id"] for e in got.evidence] == ["S1"]
