"""A tie-point rule that gives no `bands` judges the scenes of the bands the tie points are
measured on: the MS scene of the case delivery (M1, registered to the PAN scenes, no tie
point of its own) is not judged by a per-scene count or error rule written without bands."""

from __future__ import annotations

from pathlib import Path

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack

# per scene: at least 100 tie points; an RMS error of at most 0.5 px; no `bands` given
RULES = """\
rules:
  - id: PA-1
    title: At least 100 tie points in every scene
    clause: §TP-4
    content: tp_number
    metric: tie_point_distribution
    scope: scene
    statistic: n_points
    threshold: {min: 100}
    unit: points
  - id: PA-2
    title: Tie-point RMS error of every scene within 0.5 px
    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    scope: scene
    statistic: rms
    threshold: {max: 0.5}
    unit: px
"""


def _judged(tmp_path: Path, case: dict | None = None) -> dict[str, dict]:
    pack = load_pack(extension_pack(tmp_path, RULES))
    delivery = load_delivery(write_delivery(tmp_path / "delivery", case))
    results = inspect_delivery(delivery, pack).results
    return {r.rule: r for r in results if r.rule in ("PA-1", "PA-2")}


def _observations_on_m1(n: int, v_line: float) -> dict:
    """n observations on the MS scene M1 (250×250 px), each with an error of v_line px."""
    rows = [
        {"point_id": f"PS1-{i:03d}", "scene_id": "M1", "line": 10.0 + 20 * i,
         "sample": 10.0 + 20 * i, "v_line": v_line, "v_sample": 0.0}
        for i in range(n)
    ]  # fmt: skip
    return {"append": {"tie_points": rows}}


def test_an_ms_scene_without_tie_points_is_not_judged(tmp_path: Path) -> None:
    """4 PAN scenes of 121 observations at 0.3 px; M1 holds none: both rules pass, over the
    4 PAN scenes (before: M1 failed both, with 0 points and no RMS)."""
    got = _judged(tmp_path)
    assert got["PA-1"].status == "pass"
    assert got["PA-1"].value == 121
    assert got["PA-1"].detail["n_units"] == 4
    assert got["PA-2"].status == "pass"
    assert abs(got["PA-2"].value - 0.3) < 1e-12
    assert got["PA-2"].detail["n_units"] == 4


def test_a_pan_scene_short_of_tie_points_still_fails(tmp_path: Path) -> None:
    case = {"drop": {"tie_points": [{"where": {"scene_id": "S2"}, "keep_first": 99}]}}
    got = _judged(tmp_path, case)
    assert got["PA-1"].status == "fail"
    assert got["PA-1"].value == 99
    assert [e["scene_id"] for e in got["PA-1"].evidence] == ["S2"]


def test_ms_scenes_are_judged_when_tie_points_are_measured_on_them(tmp_path: Path) -> None:
    """5 observations on M1 at 0.8 px: the MS band is in the network, M1 is judged: 5 points
    (< 100), RMS 0.8 px (> 0.5)."""
    got = _judged(tmp_path, _observations_on_m1(5, 0.8))
    assert got["PA-1"].status == "fail"
    assert got["PA-1"].value == 5
    assert [e["scene_id"] for e in got["PA-1"].evidence] == ["M1"]
    assert got["PA-2"].status == "fail"
    assert abs(got["PA-2"].value - 0.8) < 1e-12
    assert got["PA-2"].detail["n_units"] == 5


def test_bands_given_are_judged_as_given(tmp_path: Path) -> None:
    """`bands: [ms]` on a block whose tie points are all on PAN scenes: M1 is judged (0)."""
    body = RULES.replace("    scope: scene\n    statistic: n_points", (
        "    params: {bands: [ms]}\n    scope: scene\n    statistic: n_points"))  # fmt: skip
    pack = load_pack(extension_pack(tmp_path, body))
    delivery = load_delivery(write_delivery(tmp_path / "delivery"))
    (pa1,) = [r for r in inspect_delivery(delivery, pack).results if r.rule == "PA-1"]
    assert pa1.status == "fail"
    assert pa1.value == 0
    assert [e["scene_id"] for e in pa1.evidence] == ["M1"]
