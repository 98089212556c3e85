"""The overlap-discrepancy map: per scene pair mean vector, RMS and largest discrepancy."""

from __future__ import annotations

import math

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.report.format import Formatter
from blockqc.report.maps import _overlap_points, _pairs, overlap_map
from blockqc.rules import load_pack
from casekit import write_delivery


def test_pairs_by_hand() -> None:
    rows = [
        {"scene_a": "A", "scene_b": "B", "dx_m": 3.0, "dy_m": 4.0},
        {"scene_a": "A", "scene_b": "B", "dx_m": -3.0, "dy_m": 4.0},
    ]
    (p,) = _pairs(rows).values()
    # mean (0, 4); both discrepancies 5 m: RMS 5, max 5
    assert (p["dx"], p["dy"], p["rms"], p["max"]) == (0.0, 4.0, 5.0, 5.0)


def test_map_of_a_delivery(tmp_path) -> None:
    # the case delivery: 5 overlap points S1/S2 with dx 3, dy 4 → one pair, RMS 5 m
    res = inspect_delivery(
        load_delivery(write_delivery(tmp_path / "d")), load_pack("global-project")
    )
    rows, bound = _overlap_points(res)
    assert len(rows) == 5 and math.isclose(bound, 2 * math.sqrt(2) * 10)
    svg = overlap_map(res, Formatter("en"))
    assert svg is not None and svg.startswith("<svg")
