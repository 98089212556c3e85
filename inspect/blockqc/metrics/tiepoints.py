"""Tie-point measurements from the adjustment's residuals (§TP-1..4)."""

from __future__ import annotations

from typing import Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, model_validator

from blockqc.delivery import Delivery
from blockqc.metrics import Measure, Measurement, Table, metric, not_applicable
from blockqc.spatial import clark_evans_grouped

Band = Literal["pan", "ms"]


class ErrorParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    bands: list[Band] | None = None  # None: every scene
    interval_px: tuple[float, float] = (1.0, 1.5)  # share of errors in (lo, hi] (§TP-3)

    @model_validator(mode="after")
    def _order(self) -> ErrorParams:
        if not self.interval_px[0] < self.interval_px[1]:
            raise ValueError("interval_px must be (lower, upper) with lower < upper")
        return self


class DistributionParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    bands: list[Band] | None = None
    grid: int = Field(default=3, ge=1, le=50)  # k×k cells over each scene (§TP-4 uniformity)
    min_points_per_cell: int = Field(default=1, ge=1)
    exempt_water_fraction: float = Field(default=0.5, ge=0.0, le=1.0)


def tie_point_error_px(v_line: np.ndarray, v_sample: np.ndarray) -> np.ndarray:
    """Error of one observation: √(v_l² + v_s²), in its scene's pixels (Reading of §TP)."""
    return np.hypot(v_line, v_sample)


def _select(d: Delivery, bands: list[str] | None) -> tuple[pd.DataFrame, pd.DataFrame]:
    scenes = d.scenes if bands is None else d.scenes[d.scenes["band"].isin(bands)]
    tp = d.tie_points[d.tie_points["scene_id"].isin(scenes["scene_id"])]
    return scenes, tp


def _stats(err: pd.Series, by: pd.Series | None, lo: float, hi: float) -> pd.DataFrame:
    """n, median, RMS, mean, max and share (%) in (lo, hi], overall or per group."""
    frame = pd.DataFrame(
        {
            "e": err.to_numpy(),
            "e2": err.to_numpy() ** 2,
            "inside": ((err > lo) & (err <= hi)).to_numpy(),
            "g": by.to_numpy() if by is not None else 0,
        }
    )
    g = frame.groupby("g", sort=False)
    out = pd.DataFrame(
        {
            "n": g["e"].size(),
            "median": g["e"].median(),
            "rms": np.sqrt(g["e2"].mean()),
            "mean": g["e"].mean(),
            "max": g["e"].max(),
            "n_in_interval": g["inside"].sum(),
        }
    )
    out["share_in_interval"] = 100.0 * out["n_in_interval"] / out["n"]
    return out


#: scenes above this many keep no residual cells in the results (they are for a map)
MAX_SCENES_FOR_CELLS = 500


def residual_cells(tp: pd.DataFrame, scenes: pd.DataFrame, k: int = 4) -> list[dict]:
    """Mean residual (v_line, v_sample) per scene and cell of a k×k grid, for the vector map.

    Cells are given by their centre as fractions of the scene's lines (u) and samples (w).
    """
    if scenes["scene_id"].nunique() > MAX_SCENES_FOR_CELLS:
        return []
    size = scenes.set_index("scene_id")[["lines", "samples"]].astype(float)
    lines = tp["scene_id"].map(size["lines"]).to_numpy(dtype=float)
    samples = tp["scene_id"].map(size["samples"]).to_numpy(dtype=float)
    i = np.clip(np.floor(tp["line"].to_numpy(dtype=float) / lines * k), 0, k - 1)
    j = np.clip(np.floor(tp["sample"].to_numpy(dtype=float) / samples * k), 0, k - 1)
    frame = pd.DataFrame(
        {"scene_id": tp["scene_id"].to_numpy(), "u": (i + 0.5) / k, "w": (j + 0.5) / k}
    ).assign(v_line=tp["v_line"].to_numpy(), v_sample=tp["v_sample"].to_numpy())
    frame = frame[np.isfinite(frame["u"]) & np.isfinite(frame["w"])]
    g = frame.groupby(["scene_id", "u", "w"], sort=True)
    out = g.agg(n=("v_line", "size"), v_line=("v_line", "mean"), v_sample=("v_sample", "mean"))
    return out.reset_index().round(6).to_dict("records")


@metric(
    "tie_point_errors",
    params=ErrorParams,
    scopes={
        "block": ("n", "median", "rms", "mean", "max", "share_in_interval", "n_in_interval"),
        "scene": ("n", "median", "rms", "mean", "max", "share_in_interval"),
        "observation": ("error_px",),
    },
)
def tie_point_errors(d: Delivery, p: ErrorParams, measure: Measure) -> Measurement:
    """Tie-point error statistics: per observation, per scene and over the block (§TP-1..3)."""
    scenes, tp = _select(d, p.bands)
    if tp.empty:
        return not_applicable("no tie-point observations on the scenes checked")
    lo, hi = p.interval_px
    err = pd.Series(
        tie_point_error_px(tp["v_line"].to_numpy(), tp["v_sample"].to_numpy()), index=tp.index
    )
    block = _stats(err, None, lo, hi).reset_index(drop=True)
    block.insert(0, "n_points", tp["point_id"].nunique())
    per_scene = _stats(err, tp["scene_id"], lo, hi).rename_axis("scene_id").reset_index()
    per_scene = scenes[["scene_id"]].merge(per_scene, on="scene_id", how="left")
    per_scene["n"] = per_scene["n"].fillna(0).astype(int)
    obs = tp[["point_id", "scene_id", "line", "sample", "v_line", "v_sample"]].assign(
        error_px=err.to_numpy()
    )
    hist_edges = np.arange(0.0, max(2.0, float(np.ceil(err.max() * 10) / 10)) + 0.05, 0.05)
    counts, _ = np.histogram(err.to_numpy(), bins=hist_edges)
    return Measurement(
        tables={
            "block": Table(block),
            "scene": Table(per_scene, keys=["scene_id"], sort="median"),
            "observation": Table(obs, keys=["point_id", "scene_id"], sort="error_px"),
        },
        detail={
            "histogram": {"edges_px": hist_edges.round(4).tolist(), "counts": counts.tolist()},
            "interval_px": [lo, hi],
            "residual_cells": residual_cells(tp, scenes),
        },
    )


@metric(
    "tie_point_distribution",
    params=DistributionParams,
    scopes={"scene": ("n_points", "coverage", "clark_evans", "cells_covered")},
)
def tie_point_distribution(d: Delivery, p: DistributionParams, measure: Measure) -> Measurement:
    """Per scene: tie-point count, k×k grid coverage of its land, Clark–Evans R (§TP-4)."""
    scenes, tp = _select(d, p.bands)
    if scenes.empty:
        return not_applicable("no scenes of the bands checked")
    k = p.grid
    geo = scenes.set_index("scene_id")[["lines", "samples"]].astype(float)
    lines = geo["lines"].reindex(tp["scene_id"]).to_numpy()
    samples = geo["samples"].reindex(tp["scene_id"]).to_numpy()
    row = np.clip((tp["line"].to_numpy() / lines * k).astype(int), 0, k - 1)
    col = np.clip((tp["sample"].to_numpy() / samples * k).astype(int), 0, k - 1)
    cells = pd.DataFrame({"scene_id": tp["scene_id"].to_numpy(), "cell": row * k + col})
    per_cell = cells.groupby(["scene_id", "cell"], sort=False).size()
    covered = (per_cell >= p.min_points_per_cell).groupby(level="scene_id").sum()
    n_points = tp.groupby("scene_id", sort=False)["point_id"].nunique()

    out = scenes[["scene_id", "band", "lines", "samples"]].copy()
    water = (
        scenes["water_fraction"]
        if "water_fraction" in scenes
        else pd.Series(np.nan, index=scenes.index)
    ).astype(float)
    out["water_fraction"] = water.to_numpy()
    out["n_points"] = n_points.reindex(out["scene_id"]).fillna(0).astype(int).to_numpy()
    out["cells_covered"] = covered.reindex(out["scene_id"]).fillna(0).astype(int).to_numpy()
    # land cells expected to hold points: k² scaled by the scene's land share (Reading, §TP-4)
    land = 1.0 - np.nan_to_num(out["water_fraction"].to_numpy(), nan=0.0)
    out["cells_expected"] = np.maximum(1, np.round(k * k * land)).astype(int)
    out["coverage"] = np.minimum(1.0, out["cells_covered"] / out["cells_expected"])
    out["clark_evans"] = out["scene_id"].map(_clark_evans_per_scene(tp, geo)).astype(float)
    exempt = np.nan_to_num(out["water_fraction"].to_numpy(), nan=0.0) >= p.exempt_water_fraction
    out["exempt"] = exempt
    out["exempt_reason"] = np.where(
        exempt,
        [
            f"water_fraction {w:.2f} ≥ {p.exempt_water_fraction:g} (mostly sea)"
            for w in np.nan_to_num(out["water_fraction"].to_numpy())
        ],
        "",
    )
    out = out.drop(columns=["lines", "samples"])

    def scene_points(scene_ids: list[str], cap: int = 2000) -> dict:
        """Tie-point positions of the scenes named (at most `cap` each), for maps."""
        sub = tp[tp["scene_id"].isin(scene_ids)]
        sub = sub.groupby("scene_id", sort=False).head(cap)
        return {
            sid: {
                "lines": int(geo.loc[sid, "lines"]),
                "samples": int(geo.loc[sid, "samples"]),
                "line": g["line"].round(1).tolist(),
                "sample": g["sample"].round(1).tolist(),
            }
            for sid, g in sub.groupby("scene_id", sort=False)
        }

    return Measurement(
        tables={"scene": Table(out, keys=["scene_id"], sort="n_points")},
        detail={"grid": k, "exempt_water_fraction": p.exempt_water_fraction},
        unit_points=scene_points,
    )


def _clark_evans_per_scene(tp: pd.DataFrame, geo: pd.DataFrame) -> pd.Series:
    """Clark–Evans R of each scene's observations in pixel space, Donnelly edge-corrected."""
    codes, scene_ids = pd.factorize(tp["scene_id"])
    g = geo.reindex(scene_ids)
    lines, samples = g["lines"].to_numpy(), g["samples"].to_numpy()
    r = clark_evans_grouped(
        tp["sample"].to_numpy(),
        tp["line"].to_numpy(),
        codes,
        area=lines * samples,
        perimeter=2 * (lines + samples),
    )
    return pd.Series(r, index=scene_ids, dtype=float)
