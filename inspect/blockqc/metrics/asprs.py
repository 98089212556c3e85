"""Positional accuracy after the ASPRS Positional Accuracy Standards for Digital Geospatial Data,
Edition 2 (2023), with NSSDA reporting (FGDC-STD-007.3-1998): docs/asprs.md.

RMSE_x, RMSE_y, RMSE_H = √(RMSE_x² + RMSE_y²), RMSE_V; mean errors (bias); the checkpoints' own
survey accuracy combined in quadrature; NSSDA figures at 95 % confidence.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from blockqc import metrics
from blockqc.delivery import Delivery
from blockqc.metrics import Measure, Measurement, Scope, Table, metric, not_applicable

Method = Literal["high_precision", "same_accuracy", "recalculation"]


class AsprsParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    methods: list[Method] = Field(default_factory=lambda: ["high_precision"])
    survey_rmse_h_m: float = Field(default=0.0, ge=0)  # the checkpoints' own RMSE_H
    survey_rmse_v_m: float = Field(default=0.0, ge=0)  # and RMSE_V
    nssda_h_factor: float = Field(default=1.7308, gt=0)  # Accuracy_r = 1.7308·RMSE_r
    nssda_v_factor: float = Field(default=1.9600, gt=0)  # Accuracy_z = 1.9600·RMSE_z
    ce90_factor: float = Field(default=2.1460, gt=0)  # CE90 = 2.1460·RMSE_x (RMSE_x = RMSE_y)
    min_axis_ratio: float = Field(default=0.6, gt=0, le=1)  # NSSDA: RMSE_min/RMSE_max ≥ 0.6


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(v**2))) if v.size else math.nan


def errors(cp: pd.DataFrame, methods: list[str]) -> dict[str, np.ndarray]:
    """Per-axis errors (measured − reference) of the chosen methods' checkpoints."""
    sel = cp[cp["method"].isin(methods)]
    dx = (sel["x_m"] - sel["ref_x_m"]).to_numpy(dtype=float)
    dy = (sel["y_m"] - sel["ref_y_m"]).to_numpy(dtype=float)
    dz = (sel["z_m"] - sel["ref_z_m"]).to_numpy(dtype=float)
    h = np.isfinite(dx) & np.isfinite(dy)
    return {"x": dx[h], "y": dy[h], "v": dz[np.isfinite(dz)]}


def axis_table(e: dict[str, np.ndarray]) -> pd.DataFrame:
    """Per axis: n, mean error (bias), its magnitude, standard deviation, RMSE."""
    rows = []
    for axis, v in e.items():
        rows.append(
            {
                "axis": axis,
                "n": int(v.size),
                "mean_m": float(v.mean()) if v.size else math.nan,
                "abs_mean_m": float(abs(v.mean())) if v.size else math.nan,
                "std_m": float(v.std(ddof=1)) if v.size > 1 else math.nan,
                "rmse_m": _rms(v),
            }
        )
    return pd.DataFrame(rows)


def component_table(axes: pd.DataFrame, p: AsprsParams) -> pd.DataFrame:
    """Horizontal and vertical: measured RMSE, with the survey's in quadrature, NSSDA figures."""
    a = axes.set_index("axis")
    rx, ry, rv = a.loc["x", "rmse_m"], a.loc["y", "rmse_m"], a.loc["v", "rmse_m"]
    rh_meas = math.hypot(rx, ry)
    rh = math.hypot(rh_meas, p.survey_rmse_h_m)
    rv_all = math.hypot(rv, p.survey_rmse_v_m)
    ratio = min(rx, ry) / max(rx, ry) if max(rx, ry) > 0 else 1.0
    agree = bool(ratio >= p.min_axis_ratio)
    return pd.DataFrame(
        [
            {
                "component": "horizontal",
                "n": int(a.loc["x", "n"]),
                "rmse_measured_m": rh_meas,
                "rmse_m": rh,
                "accuracy95_m": p.nssda_h_factor * rh,
                "ce90_m": p.ce90_factor * rh / math.sqrt(2) if agree else math.nan,
                "axis_ratio": ratio,
                "axes_agree": agree,
            },
            {
                "component": "vertical",
                "n": int(a.loc["v", "n"]),
                "rmse_measured_m": rv,
                "rmse_m": rv_all,
                "accuracy95_m": p.nssda_v_factor * rv_all,
                "ce90_m": math.nan,
                "axis_ratio": math.nan,
                "axes_agree": True,
            },
        ]
    )


_GROUPS = {"component": ("horizontal", "vertical"), "axis": ("x", "y", "v")}


def _every(column: str) -> list[dict[str, str]]:
    """Every group of a scope, each reported even when it holds no checkpoint."""
    return [{column: v} for v in _GROUPS[column]]


@metric(
    "asprs_accuracy",
    tie_points=(),
    detailed=True,
    params=AsprsParams,
    scopes={
        "component": Scope(
            {
                "n": "points",
                "rmse_m": "m",
                "rmse_measured_m": "m",
                "accuracy95_m": "m",
                "axes_agree": "true/false",
            },
            groups={"component": _GROUPS["component"]},
            columns=("ce90_m", "axis_ratio"),
            apart=("component",),
        ),
        "axis": Scope(
            {"n": "points", "mean_m": "m", "abs_mean_m": "m", "std_m": "m", "rmse_m": "m"},
            groups={"axis": _GROUPS["axis"]},
            signed=("mean_m",),
        ),
    },
)
def asprs_accuracy(d: Delivery, p: AsprsParams, measure: Measure) -> Measurement:
    """ASPRS (2023) positional accuracy: RMSE_H, RMSE_V, bias, NSSDA 95 % figures."""
    if d.checkpoints is None or d.checkpoints.empty:
        return not_applicable(metrics.NO_CHECKPOINTS)
    e = errors(d.checkpoints, p.methods)
    if not any(v.size for v in e.values()):
        return not_applicable(f"no checkpoints of the methods {', '.join(p.methods)}")
    axes = axis_table(e)
    comps = component_table(axes, p)
    comps = comps[comps["n"] > 0].reset_index(drop=True)
    axes = axes[axes["n"] > 0].reset_index(drop=True)
    # a component or axis without checkpoints (no reference heights) is judged not applicable,
    # not left out unsaid
    return Measurement(
        tables={
            "component": Table(comps, group=["component"], groups=_every("component")),
            "axis": Table(axes, group=["axis"], groups=_every("axis")),
        },
        detail={"methods": p.methods, "survey_rmse_h_m": p.survey_rmse_h_m},
    )
