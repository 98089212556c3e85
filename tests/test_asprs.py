"""The asprs-2023 pack on a sample delivery, its figures against a computation written here.

The checkpoints of samples/batch/F1-B01 (36 high-precision points, no gross errors) are read
with the csv module and the formulas of ASPRS Edition 2 and the NSSDA applied by hand; RMSE_H and
RMSE_V also equal the published test field 1 figures (plane 3.33 m, height 2.69 m).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack

F1 = Path(__file__).resolve().parents[1] / "samples" / "batch" / "F1-B01"


def _hand() -> dict[str, float]:
    with open(F1 / "checkpoints.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["method"] == "high_precision"]
    dx = [float(r["x_m"]) - float(r["ref_x_m"]) for r in rows]
    dy = [float(r["y_m"]) - float(r["ref_y_m"]) for r in rows]
    dz = [float(r["z_m"]) - float(r["ref_z_m"]) for r in rows]
    n = len(rows)
    rx = math.sqrt(sum(v * v for v in dx) / n)
    ry = math.sqrt(sum(v * v for v in dy) / n)
    rz = math.sqrt(sum(v * v for v in dz) / n)
    rh = math.sqrt(rx**2 + ry**2)
    return {
        "n": n,
        "rmse_h": rh,
        "rmse_v": rz,
        "mean_x": abs(sum(dx) / n),
        "mean_y": abs(sum(dy) / n),
        "mean_v": abs(sum(dz) / n),
        "acc_h95": 1.7308 * rh,
        "acc_v95": 1.9600 * rz,
        "ce90": 2.1460 * rh / math.sqrt(2),
        "ratio": min(rx, ry) / max(rx, ry),
    }


def test_asprs_pack_on_sample_delivery() -> None:
    pack = load_pack("asprs-2023")
    res = inspect_delivery(load_delivery(F1), pack)
    h = _hand()
    by = {(r.rule, tuple(r.group.values())): r for r in res.results}
    assert by[("AS-1", ("horizontal",))].value == h["n"] == 36
    assert by[("AS-2", ("horizontal",))].value == pytest.approx(h["rmse_h"], rel=1e-12)
    assert by[("AS-2", ("vertical",))].value == pytest.approx(h["rmse_v"], rel=1e-12)
    assert round(h["rmse_h"], 2) == 3.33 and round(h["rmse_v"], 2) == 2.69  # published field 1
    for axis in ("x", "y", "v"):
        assert by[("AS-3", (axis,))].value == pytest.approx(h[f"mean_{axis}"], rel=1e-12)
    assert by[("AS-3", ("x",))].threshold == pytest.approx(0.25 * 10 / math.sqrt(2))
    comp = {
        row["component"]: row
        for m in res.measurements
        if m.metric == "asprs_accuracy"
        for row in m.tables["component"]
    }
    assert comp["horizontal"]["accuracy95_m"] == pytest.approx(h["acc_h95"], rel=1e-12)
    assert comp["vertical"]["accuracy95_m"] == pytest.approx(h["acc_v95"], rel=1e-12)
    assert comp["horizontal"]["ce90_m"] == pytest.approx(h["ce90"], rel=1e-12)
    assert comp["horizontal"]["axis_ratio"] == pytest.approx(h["ratio"], rel=1e-12)
    assert res.verdict == "pass" and pack.acceptance is None  # ASPRS grades no blocks
    # every axis' bias decides a content: x and y the horizontal one, v the vertical one
    contents = {r.group["axis"]: r.content for r in res.results if r.rule == "AS-3"}
    assert contents == {"x": ["horizontal"], "y": ["horizontal"], "v": ["vertical"]}
