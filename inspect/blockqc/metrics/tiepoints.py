"""Tie-point measurements from the adjustment's residuals (§TP-1..4)."""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, model_validator

from blockqc.delivery import Delivery, distinct_count, scene_positions
from blockqc.metrics import Measure, Measurement, Scope, Table, metric, not_applicable
from blockqc.outputs import records
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
    # the Clark–Evans R of every scene (one nearest-neighbour query over all observations): only
    # when a rule asks for it, since it costs more than everything else of this metric together
    clark_evans: bool = False


def tie_point_error_px(v_line: np.ndarray, v_sample: np.ndarray) -> np.ndarray:
    """Error of one observation: √(v_l² + v_s²), in its scene's pixels (Reading of §TP)."""
    return np.hypot(v_line, v_sample)


def _select(d: Delivery, bands: list[str] | None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The scenes of the bands given (None: all) and their tie points; the tie points are
    taken once per delivery and bands (the same rows serve every measurement), and not copied
    when they are all of them."""
    scenes = d.scenes if bands is None else d.scenes[d.scenes["band"].isin(bands)]
    key = None if bands is None else tuple(sorted(set(bands)))
    (tie_points, all_scenes), tp = d.selections.get(key, ((None, None), None))
    if tie_points is not d.tie_points or all_scenes is not d.scenes or tp is None:
        on = d.tie_points["scene_id"].isin(scenes["scene_id"]).to_numpy()
        tp = d.tie_points if on.all() else d.tie_points[on]
        d.selections[key] = ((d.tie_points, d.scenes), tp)
    return scenes, tp


def _image_size(scenes: pd.DataFrame) -> pd.DataFrame:
    """Each scene's lines and samples (floats), by scene id."""
    return scenes.set_index("scene_id")[["lines", "samples"]].astype(float)


def _stats(err: pd.Series, by: pd.Series | None, lo: float, hi: float) -> pd.DataFrame:
    """n, median, RMS, mean, max and share (%) in (lo, hi], overall or per group.

    Groups by integer codes (a Categorical's own, else factorized), so a key of millions of
    rows is never turned into Python strings; the index holds the groups' labels.
    """
    if by is None:
        return _block_stats(err.to_numpy(), lo, hi)
    if isinstance(by.dtype, pd.CategoricalDtype):
        codes, labels = by.cat.codes.to_numpy(), pd.Index(by.cat.categories, dtype=object)
    else:
        codes, labels = pd.factorize(by, sort=False)
    e = err.to_numpy()
    if codes.min(initial=0) < 0:  # rows of no group (a missing key) are left out
        e, codes = e[codes >= 0], codes[codes >= 0]
    scale = _square_scale(e, codes)
    # one Series per statistic's input, grouped by the codes: no frame of them is stacked
    g = pd.Series(e, copy=False).groupby(codes, sort=False)
    e2 = e**2 if scale is None else (e / scale[codes]) ** 2
    rms = np.sqrt(pd.Series(e2, copy=False).groupby(codes, sort=False).mean())
    del e2
    n = g.size()
    inside = np.bincount(codes[(e > lo) & (e <= hi)], minlength=int(codes.max(initial=0)) + 1)
    out = pd.DataFrame(
        {
            "n": n,
            "median": g.median(),
            "rms": rms if scale is None else rms * scale[rms.index.to_numpy()],
            "mean": g.mean(),
            "max": g.max(),
            "n_in_interval": inside[n.index.to_numpy()],
        }
    )
    out.index = pd.Index(np.asarray(labels, dtype=object)[out.index.to_numpy()])
    out["share_in_interval"] = 100.0 * out["n_in_interval"] / out["n"]
    return out


#: errors above this overflow when squared: the RMS is then taken of errors divided by the
#: largest of their group (only then, so that ordinary RMS values are computed as written)
SQUARE_SAFE = 1e150


def _square_scale(e: np.ndarray, codes: np.ndarray) -> np.ndarray | None:
    """Per group code: the divisor that keeps its squared errors finite (1, or its largest
    error); None when no error needs one."""
    if not e.size or e.max() <= SQUARE_SAFE:
        return None
    top = np.zeros(int(codes.max()) + 1)
    np.maximum.at(top, codes[codes >= 0], e[codes >= 0])
    return np.where(top > SQUARE_SAFE, top, 1.0)


def _block_stats(e: np.ndarray, lo: float, hi: float) -> pd.DataFrame:
    """The statistics of `_stats` over every observation at once (numpy, no grouping)."""
    n = int(e.size)
    inside = int(np.count_nonzero((e > lo) & (e <= hi)))
    top = float(e.max())
    s = top if top > SQUARE_SAFE else 1.0  # as _square_scale, for the one group
    row = {
        "n": n,
        "median": float(np.median(e)),
        "rms": float(s * np.sqrt(np.mean((e / s) ** 2))),
        "mean": float(e.mean()),
        "max": top,
        "n_in_interval": inside,
        "share_in_interval": 100.0 * inside / n,
    }
    return pd.DataFrame([row], index=pd.Index([0]))


_ERROR_STATS = {
    "n": "observations",
    "median": "px",
    "rms": "px",
    "mean": "px",
    "max": "px",
    "share_in_interval": "%",
}

#: residual histogram: bins of this width up to HIST_MAX_PX, larger errors in one last bin
HIST_BIN_PX = 0.05
HIST_MAX_PX = 10.0


def histogram_edges(largest: float) -> np.ndarray:
    """Bin edges for the residual histogram: 0.05 px bins over [0, 2 px] at least, to at most
    10 px; one last bin gathers every larger error, so the count of bins stays bounded."""
    top = min(max(2.0, np.ceil(largest * 10) / 10), HIST_MAX_PX)
    edges = np.linspace(0.0, top, int(round(top / HIST_BIN_PX)) + 1)
    return np.append(edges, largest) if largest > top else edges


def histogram_counts(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """np.histogram's counts over `edges` (bins [a, b), the last one closed) of values inside
    [edges[0], edges[-1]], in one pass: the uniform bins are found by division, then moved by
    one where rounding put a value on the wrong side of an edge."""
    top = len(edges) - 1
    step = (edges[1] - edges[0]) if top else 1.0
    i = np.clip((values - edges[0]) / step, 0, top - 1).astype(np.int64)  # clipped, then cast
    i -= values < edges[i]
    i += (values >= edges[np.minimum(i + 1, top)]) & (i < top - 1)
    inside = (values >= edges[0]) & (values <= edges[-1])
    return np.bincount(i[inside], minlength=top)


#: scenes above this many keep no residual cells in the results (they are for a map)
MAX_SCENES_FOR_CELLS = 500


def residual_cells(tp: pd.DataFrame, scenes: pd.DataFrame, k: int = 4) -> list[dict]:
    """Mean residual (v_line, v_sample) per scene and cell of a k×k grid, for the vector map.

    Cells are given by their centre as fractions of the scene's lines (u) and samples (w), in
    the order of scene id (as text), u and w. One bincount per sum over integer cell keys.
    """
    if not 0 < scenes["scene_id"].nunique() <= MAX_SCENES_FOR_CELLS:
        return []
    size = _image_size(scenes)
    names = np.asarray(size.index.astype(str), dtype=object)
    order = np.argsort(names, kind="stable")
    size, names = size.iloc[order], names[order]
    at = scene_positions(tp["scene_id"], size.index)  # the scene's rank by its id as text
    lines = size["lines"].to_numpy()[at]
    samples = size["samples"].to_numpy()[at]
    i = np.clip(np.floor(tp["line"].to_numpy(dtype=float) / lines * k), 0, k - 1)
    j = np.clip(np.floor(tp["sample"].to_numpy(dtype=float) / samples * k), 0, k - 1)
    valid = (at >= 0) & np.isfinite(i) & np.isfinite(j)
    key = (at[valid] * k + i[valid].astype(np.int64)) * k + j[valid].astype(np.int64)
    cells = len(size) * k * k
    n = np.bincount(key, minlength=cells)
    means = {
        c: _cell_means(key, tp[c].to_numpy(dtype=float)[valid], cells)
        for c in ("v_line", "v_sample")
    }
    used = np.flatnonzero(n)
    table = pd.DataFrame(
        {
            "scene_id": names[used // (k * k)],
            "u": ((used // k) % k + 0.5) / k,
            "w": (used % k + 0.5) / k,
            "n": n[used],
            "v_line": means["v_line"][used],
            "v_sample": means["v_sample"][used],
        }
    )
    return records(table.round(6))


def _cell_means(key: np.ndarray, values: np.ndarray, cells: int) -> np.ndarray:
    """Mean of the finite values per cell key (NaN where a cell has none), as pandas' mean."""
    ok = np.isfinite(values)
    count = np.bincount(key[ok], minlength=cells)
    total = np.bincount(key[ok], weights=values[ok], minlength=cells)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count


@metric(
    "tie_point_errors",
    params=ErrorParams,
    scopes={
        "block": Scope({**_ERROR_STATS, "n_in_interval": "observations"}, columns=("n_points",)),
        "scene": Scope(_ERROR_STATS, keys=("scene_id",), columns=("n_in_interval",)),
        "observation": Scope(
            {"error_px": "px"},
            keys=("point_id", "scene_id"),
            columns=("line", "sample", "v_line", "v_sample"),
        ),
    },
    param_units={"interval_px": "px"},
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
    block.insert(0, "n_points", distinct_count(tp["point_id"]))
    per_scene = _stats(err, tp["scene_id"], lo, hi).rename_axis("scene_id").reset_index()
    per_scene = scenes[["scene_id"]].merge(per_scene, on="scene_id", how="left")
    per_scene["n"] = per_scene["n"].fillna(0).astype(int)
    obs = tp[["point_id", "scene_id", "line", "sample", "v_line", "v_sample"]].assign(
        error_px=err.to_numpy()
    )
    hist_edges = histogram_edges(float(err.max()))
    counts = histogram_counts(err.to_numpy(), hist_edges)
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


METRIC_DISTRIBUTION = "tie_point_distribution"
NO_R = {"clark_evans": False}


@metric(
    METRIC_DISTRIBUTION,
    params=DistributionParams,
    scopes={
        "scene": Scope(
            {
                "n_points": "points",
                "coverage": "share of cells",
                "clark_evans": "R",
                "cells_covered": "cells",
            },
            keys=("scene_id",),
            columns=("band", "water_fraction", "cells_expected", "exempt", "exempt_reason"),
        )
    },
    param_units={
        "grid": "cells per side",
        "min_points_per_cell": "points",
        "exempt_water_fraction": "fraction",
    },
)
def tie_point_distribution(d: Delivery, p: DistributionParams, measure: Measure) -> Measurement:
    """Per scene: tie-point count, k×k grid coverage of its land, Clark–Evans R (§TP-4)."""
    if p.clark_evans:  # the counts and cells as measured without R (once for both), R added
        return _with_clark_evans(d, p, measure(METRIC_DISTRIBUTION, p.model_dump() | NO_R))
    scenes, tp = _select(d, p.bands)
    if scenes.empty:
        return not_applicable("no scenes of the bands checked")
    geo = _image_size(scenes)
    out = _per_scene_cells(scenes, tp, p)
    water = np.nan_to_num(out["water_fraction"].to_numpy(), nan=0.0)
    exempt = water >= p.exempt_water_fraction
    out["exempt"] = exempt
    reason = np.full(len(out), "", dtype=object)
    reason[exempt] = [
        f"water_fraction {w:.2f} ≥ {p.exempt_water_fraction:g} (mostly sea)" for w in water[exempt]
    ]
    out["exempt_reason"] = reason
    out = out.drop(columns=["lines", "samples"])

    def scene_points(scene_ids: list[str], cap: int = 2000) -> dict:
        """Tie-point positions of the scenes named (at most `cap` each), for maps."""
        sub = tp[tp["scene_id"].isin(scene_ids)]
        sub = sub.groupby("scene_id", sort=False, observed=True).head(cap)
        return {
            sid: {
                "lines": int(geo.loc[sid, "lines"]),
                "samples": int(geo.loc[sid, "samples"]),
                "line": g["line"].round(1).tolist(),
                "sample": g["sample"].round(1).tolist(),
            }
            for sid, g in sub.groupby("scene_id", sort=False, observed=True)
        }

    return Measurement(
        tables={"scene": Table(out, keys=["scene_id"], sort="n_points")},
        detail={"grid": p.grid, "exempt_water_fraction": p.exempt_water_fraction},
        unit_points=scene_points,
    )


def _with_clark_evans(d: Delivery, p: DistributionParams, base: Measurement) -> Measurement:
    """The distribution measured without R, its scene table given each scene's Clark–Evans R
    (placed after the coverage)."""
    if base.not_applicable:
        return base
    table = base.tables["scene"]
    scenes, tp = _select(d, p.bands)
    geo = _image_size(scenes)
    r = table.df["scene_id"].map(_clark_evans_per_scene(tp, geo)).astype(float)
    out = table.df.copy()
    out.insert(out.columns.get_loc("coverage") + 1, "clark_evans", r.to_numpy())
    return replace(base, tables={"scene": replace(table, df=out)})


def _per_scene_cells(scenes: pd.DataFrame, tp: pd.DataFrame, p: DistributionParams) -> pd.DataFrame:
    """Per scene: observations, k×k cells holding at least the minimum, land cells expected.

    One bincount over (scene, cell) codes; an observation is one tie point on one scene (the
    contract's unique key), so the count of observations is the count of tie points.
    """
    k = p.grid
    out = scenes[["scene_id", "band", "lines", "samples"]].reset_index(drop=True)
    code = scene_positions(tp["scene_id"], out["scene_id"])
    cell = code * (k * k)  # the (scene, row, column) cell of each observation, summed in place
    cell += k * _cell_along(tp["line"].to_numpy(), out["lines"].to_numpy(dtype=float), code, k)
    cell += _cell_along(tp["sample"].to_numpy(), out["samples"].to_numpy(dtype=float), code, k)
    n_cells = len(out) * k * k
    per_cell = np.bincount(cell, minlength=n_cells).reshape(len(out), -1)
    water = (
        scenes["water_fraction"].to_numpy(dtype=float)
        if "water_fraction" in scenes
        else np.full(len(out), np.nan)
    )
    out["water_fraction"] = water
    out["n_points"] = per_cell.sum(axis=1)
    out["cells_covered"] = (per_cell >= p.min_points_per_cell).sum(axis=1)
    # land cells expected to hold points: k² scaled by the scene's land share (Reading, §TP-4)
    land = 1.0 - np.nan_to_num(water, nan=0.0)
    out["cells_expected"] = np.maximum(1, np.round(k * k * land)).astype(int)
    out["coverage"] = np.minimum(1.0, out["cells_covered"] / out["cells_expected"])
    return out


def _cell_along(position: np.ndarray, extent: np.ndarray, code: np.ndarray, k: int) -> np.ndarray:
    """The cell (0..k-1) of each position along one image axis of k cells: position / its
    scene's extent × k, truncated, clipped; computed in place over the rows."""
    x = extent[code]
    np.divide(position, x, out=x)
    x *= k
    i = x.astype(np.int64)
    del x
    return np.clip(i, 0, k - 1, out=i)


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
