"""Tie-point measurements from the adjustment's residuals (§TP-1..4)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any, ClassVar, Literal, get_args

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator

from blockqc import grouped, pieces
from blockqc.delivery import Delivery, distinct_count, scene_lookup, scene_positions
from blockqc.metrics import Measure, Measurement, Scope, Table, metric, not_applicable
from blockqc.outputs import records
from blockqc.spatial import clark_evans_grouped

Band = Literal["pan", "ms"]
#: the scenes a tie-point rule judges when its `bands` are not given (`measured_bands`)
MEASURED_BANDS = "the bands the tie points are measured on"


class ErrorParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    # left out, the interval is the pack's tp.share_interval_px when it sets one (§TP-3)
    CONSTANTS: ClassVar[dict[str, str]] = {"interval_px": "tp.share_interval_px"}
    bands: list[Band] | None = Field(default=None, description=MEASURED_BANDS)
    interval_px: tuple[float, float] = (1.0, 1.5)  # share of errors in (lo, hi] (§TP-3)

    @field_validator("interval_px", mode="before")
    @classmethod
    def _two(cls, value: Any) -> Any:
        """Two numbers, the interval's ends: one or three were refused as a missing item."""
        if isinstance(value, list | tuple) and len(value) != 2:
            raise ValueError(f"expected two numbers [lower, upper], got {len(value)}: {value}")
        return value

    @field_validator("interval_px")
    @classmethod
    def _order(cls, value: tuple[float, float]) -> tuple[float, float]:
        if not value[0] < value[1]:
            lo, hi = value
            raise ValueError(f"expected [lower, upper] with lower < upper, got [{lo:g}, {hi:g}]")
        return value


class DistributionParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    bands: list[Band] | None = Field(default=None, description=MEASURED_BANDS)
    grid: int = Field(default=3, ge=1, le=50)  # k×k cells over each scene (§TP-4 uniformity)
    min_points_per_cell: int = Field(default=1, ge=1)
    exempt_water_fraction: float = Field(default=0.5, ge=0.0, le=1.0)
    # the Clark–Evans R of every scene (one nearest-neighbour query over all observations): only
    # when a rule asks for it, since it costs more than everything else of this metric together
    clark_evans: bool = False


def tie_point_error_px(
    v_line: np.ndarray, v_sample: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """Error of one observation: √(v_l² + v_s²), in its scene's pixels (Reading of §TP),
    evaluated as written, in place in `out`; np.hypot (about ten times slower) only where a
    square overflows (residuals above 1e154 px, which a delivery's are not: they are read up
    to 1e15)."""
    with np.errstate(over="ignore"):
        out = np.square(v_line, out=out)
        out += np.square(v_sample)
    np.sqrt(out, out=out)
    if np.isinf(out).any():
        np.hypot(v_line, v_sample, out=out)
    return out


def _select(
    d: Delivery, bands: list[str] | None, columns: list[str] | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The scenes of the bands given (None: all) and their tie points' `columns` (None: every
    column read), taken once per delivery, bands and columns, and not copied when they are
    every row; the index keeps each row's position in the delivery's table."""
    scenes, on = _on(d, bands)

    def take() -> pd.DataFrame:
        frame = d.tie_points if columns is None else d.tie_points[columns]
        return frame if on is None else frame[on]

    return scenes, _cached(d, (_bands(bands), columns and tuple(columns)), take)


def _on(d: Delivery, bands: list[str] | None) -> tuple[pd.DataFrame, np.ndarray | None]:
    """The scenes of the bands given (None: all), and which tie points lie on them (None: every
    one), found once per delivery and bands."""
    scenes = _scenes(d, bands)

    def on() -> np.ndarray | None:
        codes, lookup = scene_lookup(d.tie_points["scene_id"], scenes["scene_id"])
        found = lookup >= 0
        if found[:-1].all() and codes.min(initial=0) >= 0:  # every row on a scene checked
            return None
        found = found[codes]
        return None if found.all() else found

    return scenes, _cached(d, (_bands(bands), "on"), on)


def _scenes(d: Delivery, bands: list[str] | None) -> pd.DataFrame:
    """The delivery's scenes of the bands given (None: of the bands its tie points are measured
    on, `measured_bands`)."""
    if bands is None:
        bands = measured_bands(d)
        if set(d.scenes["band"]) <= set(bands):
            return d.scenes
    return d.scenes[d.scenes["band"].isin(bands)]


def measured_bands(d: Delivery) -> tuple[str, ...]:
    """The bands of the scenes that hold tie points (every band when none does): a band whose
    scenes hold none, such as the MS band of a block adjusted on its PAN scenes (the MS scenes
    are registered to them, §RO-1), takes no part in the tie-point network, and its scenes are
    not judged by a rule whose `bands` is not given. One count over the rows' scene codes."""

    def bands() -> tuple[str, ...]:
        codes, lookup = scene_lookup(d.tie_points["scene_id"], d.scenes["scene_id"])
        held = np.bincount(codes[codes >= 0], minlength=len(lookup) - 1) > 0
        at = lookup[:-1][held]
        names = d.scenes["band"].to_numpy()[at[at >= 0]]
        return tuple(sorted(set(names))) or tuple(sorted(set(d.scenes["band"])))

    return _cached(d, "measured_bands", bands)


def _bands(bands: list[str] | None) -> tuple[str, ...] | None:
    return None if bands is None else tuple(sorted(set(bands)))


def _cached(d: Delivery, key: Any, make: Callable[[], Any]) -> Any:
    """What `make` gives, kept in the delivery until its tie points or scenes are replaced."""
    (tie_points, scenes), value = d.selections.get(key, ((None, None), None))
    if tie_points is not d.tie_points or scenes is not d.scenes:
        value = make()
        d.selections[key] = ((d.tie_points, d.scenes), value)
    return value


def _rows(on: np.ndarray | None, labels: np.ndarray) -> np.ndarray:
    """Positions in the delivery's tie points of the rows `labels` of a selection `on`."""
    return labels if on is None else np.flatnonzero(on)[labels]


def _image_size(scenes: pd.DataFrame) -> pd.DataFrame:
    """Each scene's lines and samples (floats), by scene id."""
    return scenes.set_index("scene_id")[["lines", "samples"]].astype(float)


def _stats(err: pd.Series, by: pd.Series | None, lo: float, hi: float) -> pd.DataFrame:
    """n, median, RMS, mean, max and share (%) in (lo, hi], overall or per group.

    Groups by integer codes (a Categorical's own, else factorized), so a key of millions of
    rows is never turned into Python strings; each statistic is one grouped pass
    (`blockqc.grouped`); the index holds the groups' labels.
    """
    if by is None:
        return _block_stats(err.to_numpy(), lo, hi)
    if isinstance(by.dtype, pd.CategoricalDtype):
        codes, labels = by.array.codes, pd.Index(by.cat.categories, dtype=object)
    else:
        codes, labels = pd.factorize(by, sort=False)
    e = err.to_numpy()
    g = grouped.Groups(codes, len(labels))
    n = g.counts()
    top = g.extremes(e)[1]
    big = top.max(initial=-np.inf) > SQUARE_SAFE
    scale = np.where(top > SQUARE_SAFE, top, 1.0) if big else None
    if scale is None:
        squares = g.sums(e, of=np.square)
    else:
        squares = g.sums(np.square(e / scale[np.maximum(codes, 0)]))
    rms = np.sqrt(squares / np.maximum(n, 1))
    inside = g.sums(e, of=partial(_in_interval, lo=lo, hi=hi)).astype(np.int64)
    used = np.flatnonzero(n)
    out = pd.DataFrame(
        {
            "n": n[used],
            "median": g.medians(e)[used],
            "rms": rms[used] if scale is None else rms[used] * scale[used],
            "mean": g.sums(e)[used] / n[used],
            "max": top[used],
            "n_in_interval": inside[used],
        },
        index=pd.Index(np.asarray(labels, dtype=object)[used]),
    )
    out["share_in_interval"] = 100.0 * out["n_in_interval"] / out["n"]
    return out


#: errors above this overflow when squared: the RMS is then taken of errors divided by the
#: largest of their group (only then, so that ordinary RMS values are computed as written)
SQUARE_SAFE = 1e150


def _in_interval(e: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Whether each error lies in (lo, hi]."""
    inside = e > lo
    inside &= e <= hi
    return inside


def _block_stats(e: np.ndarray, lo: float, hi: float, median: float | None = None) -> pd.DataFrame:
    """The statistics of `_stats` over every observation at once (numpy, no grouping, the rows
    a piece at a time); the median when already known (`histogram_median`)."""
    n = int(e.size)
    top = float(e.max())
    s = top if top > SQUARE_SAFE else 1.0  # as in _stats, for the one group

    def sums(a: int) -> np.ndarray:  # the errors in (lo, hi] (exact below 2**53), the squares
        piece = e[a : a + pieces.CHUNK]
        squares = np.sum(np.square(piece if s == 1.0 else piece / s))
        return np.array([np.count_nonzero(_in_interval(piece, lo, hi)), squares])

    inside, squares = pieces.total(sums, n, np.zeros(2))  # in the order of the pieces
    inside = int(inside)
    row = {
        "n": n,
        "median": float(np.median(e)) if median is None else median,
        "rms": float(s * np.sqrt(squares / n)),
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
    """np.histogram's counts over `edges` (bins [a, b), the last one closed) of the values.

    The uniform bins (all but a last one gathering the largest errors) are counted by
    np.histogram's own uniform path, which works through the values in pieces that stay in
    cache, its edges being those of `histogram_edges`; the last bin is counted apart."""
    uniform = len(edges) - 1
    if uniform > 1 and not _uniform(edges[: uniform + 1]):
        uniform -= 1  # the last bin, from the uniform bins' end to the largest error
    if not _uniform(edges[: uniform + 1]):
        return np.histogram(values, bins=edges)[0]
    counts = np.histogram(values, bins=uniform, range=(edges[0], edges[uniform]))[0]
    if uniform == len(edges) - 1:
        return counts
    end = edges[uniform]
    on_end = np.count_nonzero(values == end)  # the uniform range's closed end: the next bin's
    last = np.count_nonzero((values >= end) & (values <= edges[-1]))
    counts[-1] -= on_end
    return np.append(counts, last)


def histogram_median(values: np.ndarray, edges: np.ndarray, counts: np.ndarray) -> float:
    """The median of the values (np.median's: the mean of the two middle values of an even
    count) found from their histogram over `edges`: the middle values are taken from the values
    of the one or two bins that hold them, so only those are partitioned, not a copy of all."""
    n = int(values.size)
    if not n or int(counts.sum()) != n:  # values outside the edges (or NaN): numpy's own
        return float(np.median(values))
    ranks = np.array([(n - 1) // 2, n // 2])
    cum = np.cumsum(counts)
    first, last = np.searchsorted(cum, ranks, side="right")  # the bins of the middle ranks
    before = int(cum[first - 1]) if first else 0
    low, high, closed = edges[first], edges[last + 1], last + 1 == len(edges) - 1

    def taken(a: int) -> np.ndarray:  # the values of these bins in the piece from a
        v = values[a : a + pieces.CHUNK]
        inside = v >= low
        inside &= v <= high if closed else v < high
        return v[inside]

    middle = np.concatenate(pieces.each(taken, n))
    middle = np.partition(middle, ranks - before)[ranks - before]
    return float(middle[0]) if n % 2 else float((middle[0] + middle[1]) / 2)


def _uniform(edges: np.ndarray) -> bool:
    """Whether the edges are those np.histogram lays over their range in equal bins."""
    n = len(edges) - 1
    return n >= 1 and np.array_equal(np.linspace(edges[0], edges[-1], n + 1), edges)


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


def _residual_cells(d: Delivery, bands: list[str] | None, scenes: pd.DataFrame) -> list[dict]:
    """`residual_cells` of the tie points on the scenes of the bands given (none are taken from
    the delivery when the scenes are too many for a map)."""
    if not 0 < scenes["scene_id"].nunique() <= MAX_SCENES_FOR_CELLS:
        return []
    return residual_cells(_select(d, bands, list(ERROR_COLUMNS))[1], scenes)


def _cell_means(key: np.ndarray, values: np.ndarray, cells: int) -> np.ndarray:
    """Mean of the finite values per cell key (NaN where a cell has none), as pandas' mean."""
    ok = np.isfinite(values)
    count = np.bincount(key[ok], minlength=cells)
    total = np.bincount(key[ok], weights=values[ok], minlength=cells)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count


#: the tie_points columns the error statistics read; the point ids are read when another rule
#: needs them (or the pack reads every column), else only for the observations shown
ERROR_COLUMNS = ("scene_id", "line", "sample", "v_line", "v_sample")
OBSERVATION_COLUMNS = ("point_id", "scene_id", "line", "sample", "v_line", "v_sample")


def _errors(tp: pd.DataFrame, on: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The scene codes and errors of the tie points `on` (None: all), a piece at a time."""
    codes = tp["scene_id"].array.codes
    vl, vs = tp["v_line"].to_numpy(), tp["v_sample"].to_numpy()
    n = len(vl)
    taken = (
        [np.count_nonzero(on[a : a + pieces.CHUNK]) for a in pieces.starts(n)]
        if on is not None
        else []
    )
    at = np.cumsum([0, *taken])  # where each piece's errors go
    err = np.empty(int(at[-1]) if on is not None else n)

    def errors(a: int) -> None:
        piece = slice(a, a + pieces.CHUNK)
        if on is None:
            tie_point_error_px(vl[piece], vs[piece], out=err[piece])
        else:
            i = a // pieces.CHUNK
            m = on[piece]
            err[at[i] : at[i + 1]] = tie_point_error_px(vl[piece][m], vs[piece][m])

    pieces.each(errors, n)
    return (codes if on is None else codes[on]), err


def _fill_observations(
    d: Delivery, on: np.ndarray | None, lazy: tuple[str, ...], rows: pd.DataFrame
) -> pd.DataFrame:
    """Observations (rows of the selection `on`) with their other columns added, from the
    delivery's table (or its file, for a column not read), in the order of
    OBSERVATION_COLUMNS."""
    at = _rows(on, rows.index.to_numpy())
    added = {c: d.tie_point_values(c, at).to_numpy() for c in lazy if c not in rows}
    out = rows.assign(**added)
    return out[[c for c in OBSERVATION_COLUMNS if c in out] + ["error_px"]]


def _all_residuals(err: np.ndarray) -> None:
    """Refuse to judge the errors when some observations have none: blockqc computed the
    residuals from the delivered geometry (the delivery gives none), and the rays of their
    tie points did not intersect (delivered residuals are never missing)."""
    missing = int(np.count_nonzero(np.isnan(err)))
    if missing:
        raise ValueError(
            f"{missing} of {err.size} observations have no residual: the delivery gives none, "
            "and the rays of their tie points do not intersect with the delivered geometry "
            "(process_data.n_points_not_intersected); the errors of the others alone would "
            "be judged as if complete"
        )


@metric(
    "tie_point_errors",
    params=ErrorParams,
    scopes={
        "block": Scope(
            {**_ERROR_STATS, "n_in_interval": "observations"},
            columns=("n_points", "n_other_bands"),
        ),
        "scene": Scope(_ERROR_STATS, keys=("scene_id",), columns=("n_in_interval",)),
        "observation": Scope(
            {"error_px": "px"},
            keys=("point_id", "scene_id"),
            columns=("line", "sample", "v_line", "v_sample"),
            table="tie_points",
        ),
    },
    param_units={"interval_px": "px"},
    tie_points=ERROR_COLUMNS,
)
def tie_point_errors(d: Delivery, p: ErrorParams, measure: Measure) -> Measurement:
    """Tie-point error statistics: per observation, per scene and over the block (§TP-1..3)."""
    scenes, on = _on(d, p.bands)
    codes, err = _errors(d.tie_points, on)
    _all_residuals(err)
    if not err.size:
        others = 0 if on is None else int(on.size)
        return not_applicable(
            f"no tie-point observations on the scenes checked (bands "
            f"{', '.join(p.bands or ['all'])}; {others} on scenes of other bands, not judged)"
        )
    lo, hi = p.interval_px
    scene_id = pd.Categorical.from_codes(
        codes, dtype=d.tie_points["scene_id"].dtype, validate=False
    )
    hist_edges = histogram_edges(float(err.max()))
    step = pieces.CHUNK
    counts = pieces.total(lambda a: histogram_counts(err[a : a + step], hist_edges), err.size, 0)
    block = _block_stats(err, lo, hi, histogram_median(err, hist_edges, counts))
    # observations on scenes of other bands than those checked: not judged, and said so
    block["n_other_bands"] = 0 if on is None else int(on.size - np.count_nonzero(on))
    if "point_id" in d.tie_points:  # not when the pack reads only the columns its rules use
        ids = d.tie_points["point_id"]
        block.insert(0, "n_points", distinct_count(ids if on is None else ids[on]))
    per_scene = _stats(pd.Series(err, copy=False), pd.Series(scene_id, copy=False), lo, hi)
    per_scene = per_scene.rename_axis("scene_id").reset_index()
    per_scene = scenes[["scene_id"]].merge(per_scene, on="scene_id", how="left")
    per_scene["n"] = per_scene["n"].fillna(0).astype(int)
    # the observations' other columns are taken from the delivery for the rows shown
    obs = pd.DataFrame({"scene_id": scene_id, "error_px": err}, copy=False)
    lazy = tuple(c for c in OBSERVATION_COLUMNS if c not in obs)
    return Measurement(
        tables={
            "block": Table(block),
            "scene": Table(per_scene, keys=["scene_id"], sort="median"),
            "observation": Table(
                obs,
                keys=["point_id", "scene_id"],
                sort="error_px",
                lazy=lazy,
                fill=partial(_fill_observations, d, on, lazy),
            ),
        },
        detail={
            "histogram": {"edges_px": hist_edges.round(4).tolist(), "counts": counts.tolist()},
            "interval_px": [lo, hi],
            "bands": list(p.bands or measured_bands(d)),
            "residual_cells": _residual_cells(d, p.bands, scenes),
        },
    )


METRIC_DISTRIBUTION = "tie_point_distribution"
DISTRIBUTION_COLUMNS = ("scene_id", "line", "sample")
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
            values={"band": get_args(Band)},
        )
    },
    param_units={
        "grid": "cells per side",
        "min_points_per_cell": "points",
        "exempt_water_fraction": "fraction",
    },
    tie_points=DISTRIBUTION_COLUMNS,
)
def tie_point_distribution(d: Delivery, p: DistributionParams, measure: Measure) -> Measurement:
    """Per scene: tie-point count, k×k grid coverage of its land, Clark–Evans R (§TP-4)."""
    if p.clark_evans:  # the counts and cells as measured without R (once for both), R added
        return _with_clark_evans(d, p, measure(METRIC_DISTRIBUTION, p.model_dump() | NO_R))
    scenes = _scenes(d, p.bands)
    if scenes.empty:
        return not_applicable("no scenes of the bands checked")
    geo = _image_size(scenes)
    tp = d.tie_points
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
        """Tie-point positions of the scenes named (at most `cap` each, `_spread`), for maps."""
        on = scene_positions(tp["scene_id"], pd.Index(scene_ids)) >= 0
        sub = tp.loc[on, list(DISTRIBUTION_COLUMNS)]
        kept = {
            sid: _spread(g, cap) for sid, g in sub.groupby("scene_id", sort=False, observed=True)
        }
        return {
            sid: {
                "lines": int(geo.loc[sid, "lines"]),
                "samples": int(geo.loc[sid, "samples"]),
                "line": g["line"].round(1).tolist(),
                "sample": g["sample"].round(1).tolist(),
            }
            for sid, g in kept.items()
        }

    return Measurement(
        tables={"scene": Table(out, keys=["scene_id"], sort="n_points")},
        detail={
            "grid": p.grid,
            "exempt_water_fraction": p.exempt_water_fraction,
            "bands": list(p.bands or measured_bands(d)),
        },
        unit_points=scene_points,
    )


def _spread(rows: pd.DataFrame, cap: int) -> pd.DataFrame:
    """At most `cap` of a scene's rows for its map: every ⌈n / cap⌉-th of its n, in the table's
    order, so that they spread over the scene as all do (its first `cap` rows, of a table in
    the order of line, lay in the top of the scene alone, its other cells drawn empty)."""
    return rows.iloc[:: max(1, -(-len(rows) // cap))]


def _with_clark_evans(d: Delivery, p: DistributionParams, base: Measurement) -> Measurement:
    """The distribution measured without R, its scene table given each scene's Clark–Evans R
    (placed after the coverage)."""
    if base.not_applicable:
        return base
    table = base.tables["scene"]
    scenes, on = _on(d, p.bands)
    geo = _image_size(scenes)
    r = table.df["scene_id"].map(_clark_evans_per_scene(d.tie_points, on, geo)).astype(float)
    out = table.df.copy()
    out.insert(out.columns.get_loc("coverage") + 1, "clark_evans", r.to_numpy())
    return replace(base, tables={"scene": replace(table, df=out)})


def _per_scene_cells(scenes: pd.DataFrame, tp: pd.DataFrame, p: DistributionParams) -> pd.DataFrame:
    """Per scene: observations, k×k cells holding at least the minimum, land cells expected.

    Bincounts over (scene, cell) codes, a piece of the tie points at a time (those of other
    scenes left out); an observation is one tie point on one scene (the contract's unique
    key), so the count of observations is the count of tie points.
    """
    k = p.grid
    out = scenes[["scene_id", "band", "lines", "samples"]].reset_index(drop=True)
    lines, samples = out["lines"].to_numpy(dtype=float), out["samples"].to_numpy(dtype=float)
    codes, lookup = scene_lookup(tp["scene_id"], out["scene_id"])  # positions piece by piece
    every = bool((lookup[:-1] >= 0).all()) and codes.min(initial=0) >= 0  # all rows on them
    line, sample = tp["line"].to_numpy(), tp["sample"].to_numpy()
    n_cells = len(out) * k * k

    def count(a: int) -> np.ndarray:  # the observations per cell of these rows
        piece = slice(a, a + pieces.CHUNK)
        c, along, across = lookup[codes[piece]], line[piece], sample[piece]
        if not every:
            on = c >= 0
            c, along, across = c[on], along[on], across[on]
        cell = _cell_along(along, lines, c, k)  # the (scene, row, column) cell, in place
        cell *= k
        cell += _cell_along(across, samples, c, k)
        cell += c * np.int64(k * k)
        return np.bincount(cell, minlength=n_cells)

    per_cell = pieces.total(count, len(codes), np.zeros(n_cells, dtype=np.int64))
    per_cell = per_cell.reshape(len(out), -1)
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


def _clark_evans_per_scene(tp: pd.DataFrame, on: np.ndarray | None, geo: pd.DataFrame) -> pd.Series:
    """Clark–Evans R of each scene's observations (the tie points `on`, None: all) in pixel
    space, Donnelly edge-corrected."""
    scene_id = tp["scene_id"] if on is None else tp["scene_id"][on]
    codes, scene_ids = pd.factorize(scene_id)
    g = geo.reindex(scene_ids)
    lines, samples = g["lines"].to_numpy(), g["samples"].to_numpy()
    line, sample = tp["line"].to_numpy(), tp["sample"].to_numpy()
    r = clark_evans_grouped(
        sample if on is None else sample[on],
        line if on is None else line[on],
        codes,
        area=lines * samples,
        perimeter=2 * (lines + samples),
    )
    return pd.Series(r, index=scene_ids, dtype=float)
