"""Verification of process data from the delivered geometry (§RC-1, §RC-2).

With each scene's RPC and the producer's adjustment, every tie point's rays are intersected and
back-projected: the residuals so computed (computed − measured, pixels) are compared with the
delivered ones, or stand in for them when the delivery gives none; when `overlaps.csv` is absent,
each observation intersected alone at its point's adjusted height gives the adjacent-image
discrepancies. `prepare` runs once per delivery, before any metric.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from blockqc import grouped, memory, pieces
from blockqc.adjust.geometry import (
    Intersection,
    RPCStack,
    intersect,
    intersect_at_height,
    radii_of_curvature,
    wrap_lon,
)
from blockqc.delivery import Delivery, scene_positions

#: what the results say about inputs blockqc computed itself, by the metrics that use them
COMPUTED_RESIDUALS = "tie-point residuals computed by blockqc from the delivered geometry (§RC-1)"
DERIVED_OVERLAPS = (
    "adjacent-image discrepancies derived by blockqc from the delivered geometry (§RC-2)"
)
VERIFIED_RESIDUALS = "delivered; verified against the geometry (§RC-1)"
SOURCES = {
    "tie_point_errors": "tie_point_residuals",
    "reported_figures": "tie_point_residuals",
    "overlap_discrepancy": "overlaps",
}


@dataclass
class ProcessData:
    """What the geometry gave: per-observation residuals, ground points, derived overlaps."""

    observations: pd.DataFrame
    points: pd.DataFrame
    overlaps: pd.DataFrame | None
    notes: dict[str, Any] = field(default_factory=dict)


def compute(d: Delivery) -> ProcessData:
    """Intersect every tie point with the producer's adjusted models and back-project (§RC-1);
    derive the adjacent-image discrepancies when the delivery gives none (§RC-2)."""
    geo = d.geometry
    assert geo is not None and geo.adjusted is not None and geo.affine is not None
    stack = RPCStack.from_models(geo.adjusted)
    scene = scene_positions(d.tie_points["scene_id"], geo.scene_ids)
    obs, points, counts, h_obs = _reproduced(d.tie_points, stack, geo.affine, scene)
    notes = {"geometry": geo.source, **counts}
    overlaps = None
    if d.overlaps is None:
        line, sample = (obs[c].to_numpy(dtype=float) for c in ("line", "sample"))
        lon_a, lat_a, _ = intersect_at_height(stack, geo.affine, scene, line, sample, h_obs)
        memory.release()  # the intersections' temporaries: freed in pieces the pairs cannot use
        overlaps = derive_overlaps(obs, scene, lon_a, lat_a, h_obs, _bands(d, geo.scene_ids))
    return ProcessData(obs, points, overlaps, notes)


def _bands(d: Delivery, scene_ids: list[str]) -> np.ndarray | None:
    """A band code per scene of `scene_ids` (None when the scenes give no band)."""
    if d.scenes is None or "band" not in d.scenes.columns:
        return None
    return pd.factorize(d.scenes.set_index("scene_id")["band"].reindex(scene_ids))[0]


def _reproduced(
    tp: pd.DataFrame, stack: RPCStack, affine: np.ndarray, scene: np.ndarray
) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, int], np.ndarray]:
    """The observations with their computed residuals, the points intersected, their counts,
    and each observation's point height (NaN where not intersected). The point codes and the
    intersection's own points are not held past it (while the overlaps are derived)."""
    point, point_ids = pd.factorize(tp["point_id"])
    line = tp["line"].to_numpy(dtype=float)
    sample = tp["sample"].to_numpy(dtype=float)
    n_rays = np.bincount(point, minlength=len(point_ids))
    x, weak = _intersected(stack, affine, scene, point, line, sample, n_rays)
    ok = x.converged & (n_rays >= 2)
    h = np.where(ok, x.h, np.nan)
    # a point seen once reproduces its observation exactly: residual 0 (nothing to intersect)
    single = n_rays[point] < 2
    for v in (x.v_line, x.v_sample):  # the intersection's own arrays, set in place
        v[~ok[point]] = np.nan
        v[single] = 0.0
    obs = _observations(tp, x.v_line, x.v_sample, n_rays[point])
    points = pd.DataFrame(
        {
            "point_id": point_ids,
            "lon": np.where(ok, x.lon, np.nan),
            "lat": np.where(ok, x.lat, np.nan),
            "h": h,
            "n_rays": n_rays,
        }
    )
    counts = {
        "n_points": int(len(point_ids)),
        "n_points_single_ray": int((n_rays < 2).sum()),
        "n_points_not_intersected": int(((n_rays >= 2) & ~ok).sum()),
        "n_points_height_undetermined": int((weak & ok).sum()),
        "iterations": int(x.iterations),
    }
    return obs, points, counts, h[point]


def _observations(
    tp: pd.DataFrame, v_line: np.ndarray, v_sample: np.ndarray, n_rays: np.ndarray
) -> pd.DataFrame:
    """The delivery's observations with their computed residuals and rays: the delivery's
    columns and the arrays given, neither copied (setting a column copies its array)."""
    columns = {c: tp[c] for c in ("point_id", "scene_id", "line", "sample")}
    computed = {"v_line_computed": v_line, "v_sample_computed": v_sample, "n_rays": n_rays}
    return pd.DataFrame({**columns, **computed}, copy=False)


#: σ of the height prior given to the points whose rays alone fix no height (parallel rays: PAN
#: and MS of one pass): weak enough to leave any height the rays measure to them
WEAK_HEIGHT_SIGMA_M = 1e4


def _intersected(
    stack: RPCStack,
    affine: np.ndarray,
    scene: np.ndarray,
    point: np.ndarray,
    line: np.ndarray,
    sample: np.ndarray,
    n_rays: np.ndarray,
) -> tuple[Intersection, np.ndarray]:
    """Each point intersected from its rays; the points of ≥ 2 rays that fix no height (rays
    parallel within round-off, as the PAN and MS images of one pass see a point) intersected
    again with a weak prior at their scenes' mean HEIGHT_OFF: their residuals hardly depend on
    the height. The intersection, and which points took the prior."""
    x = intersect(stack, affine, scene, point, line, sample)
    weak = (n_rays >= 2) & ~x.converged
    if not weak.any():
        return x, weak
    rows = weak[point]
    again, sub = np.unique(point[rows], return_inverse=True)
    h0 = np.bincount(sub, stack.offsets[scene[rows], 4]) / np.bincount(sub)
    y = intersect(
        stack, affine, scene[rows], sub, line[rows], sample[rows], (h0, WEAK_HEIGHT_SIGMA_M)
    )
    fields = {
        n: getattr(x, n).copy() for n in ("lon", "lat", "h", "converged", "v_line", "v_sample")
    }
    for n in ("lon", "lat", "h", "converged"):  # per point
        fields[n][again] = getattr(y, n)
    for n in ("v_line", "v_sample"):  # per observation
        fields[n][rows] = getattr(y, n)
    return replace(x, **fields), weak


def derive_overlaps(
    obs: pd.DataFrame,
    scene: np.ndarray,
    lon: np.ndarray,
    lat: np.ndarray,
    h: np.ndarray,
    band: np.ndarray | None = None,
) -> pd.DataFrame:
    """Differences between the scenes of each observation's position at its point's height.

    Each observation is intersected alone at its point's adjusted height (§RC-2); dx_m, dy_m are
    the east and north differences (scene_b − scene_a) in metres on the WGS-84 ellipsoid (as a
    map projection measures them, heights aside), for every two scenes seeing the same point:
    one row per two observations of a point (scene_a before scene_b in `scene` order), in the
    order of the first's row, then the second's. The ids are the observations' own: Categoricals
    over the tie points' categories when they are so held (codes, no text per pair). `band`
    (a code per scene): only scenes of one band are paired, a PAN–MS pair being a registration
    (§RO-1), not two adjacent images (§RO-3).
    """
    a, b = _pairs(grouped.key_codes(obs["point_id"])[0], scene, np.isfinite(h))
    if band is not None:
        same = band[scene[a]] == band[scene[b]]
        a, b = a[same], b[same]
    memory.release()  # the pairing's sorts of every row: not held through the differences
    dx_m, dy_m = _differences(lon, lat, a, b)
    return pd.DataFrame(
        {
            "scene_a": _ids(obs["scene_id"], a),
            "scene_b": _ids(obs["scene_id"], b),
            "point_id": _ids(obs["point_id"], a),
            "dx_m": dx_m,
            "dy_m": dy_m,
        },
        copy=False,  # the columns as made: neither copied nor gathered into blocks
    )


def _differences(
    lon: np.ndarray, lat: np.ndarray, a: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """East and north differences b − a (m) of the pairs of rows (a, b), at their mean radii;
    a piece of rows at a time (`blockqc.pieces`): no row-sized temporaries."""
    e_m, n_m = np.empty(lat.size), np.empty(lat.size)
    dx_m, dy_m = np.empty(a.size), np.empty(a.size)

    def at_rows(start: int) -> None:
        rows = slice(start, start + pieces.CHUNK)
        m, n = radii_of_curvature(lat[rows])  # metres per radian: N·cos φ east, M north
        e_m[rows], n_m[rows] = n * np.cos(np.radians(lat[rows])), m

    def of_pairs(start: int) -> None:
        p = slice(start, start + pieces.CHUNK)
        pa, pb = a[p], b[p]
        dx_m[p] = np.radians(wrap_lon(lon[pb] - lon[pa])) * (0.5 * (e_m[pa] + e_m[pb]))
        dy_m[p] = np.radians(lat[pb] - lat[pa]) * (0.5 * (n_m[pa] + n_m[pb]))

    pieces.each(at_rows, lat.size)
    pieces.each(of_pairs, a.size)
    return dx_m, dy_m


def _ids(column: pd.Series, rows: np.ndarray) -> Any:
    """A key column's values at rows: a categorical's codes at rows over its categories (one
    small integer per row, no text), any other column's values."""
    if not isinstance(column.dtype, pd.CategoricalDtype):
        return column.to_numpy()[rows]
    codes = column.cat.codes.to_numpy()[rows]
    return pd.Categorical.from_codes(codes, dtype=column.dtype, validate=False)


def _pairs(point: np.ndarray, scene: np.ndarray, kept: np.ndarray) -> tuple[np.ndarray, ...]:
    """Rows (a, b) of every two kept observations of one point with scene[a] < scene[b],
    ordered by a then b: each two rows of a point taken once (the points of s kept rows, s·(s −
    1)/2 pairs each, at once), put in scene order, and those of one scene dropped."""
    rows = np.flatnonzero(kept).astype(_row_type(kept.size))
    rows = rows[np.argsort(point[rows], kind="stable")]  # by point, each point's rows in order
    first = np.flatnonzero(np.r_[True, np.diff(point[rows]) != 0])
    size = np.diff(np.r_[first, rows.size])
    parts = [_two_of(rows, first[size == s], s) for s in np.unique(size[size > 1])]
    a = np.concatenate([np.empty(0, rows.dtype), *(p[0] for p in parts)])
    b = np.concatenate([np.empty(0, rows.dtype), *(p[1] for p in parts)])
    del parts
    swap = scene[a] > scene[b]  # a before b in row order: put them in scene order
    a[swap], b[swap] = b[swap], a[swap]
    keep = scene[a] != scene[b]
    a, b = a[keep], b[keep]
    key = np.multiply(a, scene.size, dtype=np.int64)
    key += b
    order = np.argsort(key)  # by a then b (each pair is once)
    del key
    return a[order], b[order]


def _row_type(n: int) -> type:
    """The integer type of row numbers below n: 32 bits when they fit (half the memory)."""
    return np.int32 if n < np.iinfo(np.int32).max else np.int64


def _two_of(rows: np.ndarray, first: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Every two of the s rows from each of `first` (positions in rows), earlier one first."""
    group = rows[first[:, None] + np.arange(s)]
    i, j = np.triu_indices(s, 1)
    return group[:, i].ravel(), group[:, j].ravel()


def _with_computed_residuals(d: Delivery, obs: pd.DataFrame, notes: dict[str, Any]) -> None:
    """The residuals blockqc computed stand in for the delivery's. Observations of points seen
    on one scene only have a zero by construction (the point lies on its ray): they are left out
    of the tie-point rules. Those of points whose rays do not intersect (no convergence) have
    none (NaN): the rules judging residuals are in error with them, the others count them. The
    notes count both (`observations_single_ray`, `observations_without_residual`)."""
    v_l, v_s = obs["v_line_computed"].to_numpy(), obs["v_sample_computed"].to_numpy()
    tp = _assigned(d.tie_points, v_line=v_l, v_sample=v_s)
    computed = np.isfinite(v_l) & np.isfinite(v_s)
    single = obs["n_rays"].to_numpy() < 2
    if single.any():
        tp = tp[~single].reset_index(drop=True)
    if not computed.all():
        notes["observations_without_residual"] = int((~computed).sum())
    if single.any():
        notes["observations_single_ray"] = int(single.sum())
    d.tie_points = tp
    notes["tie_point_residuals"] = COMPUTED_RESIDUALS


def _assigned(df: pd.DataFrame, **arrays: np.ndarray) -> pd.DataFrame:
    """df.assign(**arrays) without copying the arrays (assign copies each): added at the end,
    or, where df has a column of that name, assigned so."""
    if any(c in df.columns for c in arrays):
        return df.assign(**arrays)
    return pd.concat([df, pd.DataFrame(arrays, index=df.index, copy=False)], axis=1)


def prepare(d: Delivery) -> dict[str, Any]:
    """Compute the process data once; fill absent residuals and overlaps; say what was done."""
    if d.process_data.get("prepared"):
        return d.process_data["notes"]
    notes = d.process_data.setdefault("notes", {})
    d.process_data["prepared"] = True
    if d.geometry is None or d.geometry.adjusted is None or d.tie_points.empty:
        return notes
    memory.release()  # the read's freed temporaries: not held through the intersections
    with np.errstate(all="ignore"):  # a geometry that overflows: its points are not intersected
        pdata = compute(d)
    memory.release()  # the verification's, not held through the rules
    notes.update(pdata.notes)
    if "v_line" not in d.tie_points.columns:
        _with_computed_residuals(d, pdata.observations, notes)
    else:
        notes["tie_point_residuals"] = VERIFIED_RESIDUALS
        convention = residual_convention(d.tie_points, pdata.observations)
        if convention:
            notes["residual_convention"] = convention
    if pdata.overlaps is not None:
        d.overlaps = pdata.overlaps
        notes["overlaps"] = DERIVED_OVERLAPS
        notes["n_overlap_discrepancies"] = int(len(pdata.overlaps))
    d.process_data["data"] = pdata
    return notes


#: other ways of writing the residuals than the contract's (computed − measured, line then
#: sample), each as the sign of the computed residuals and whether line and sample are swapped;
#: their words, and RC_CONVENTION's, are those of the report's catalogue (rc_sign … rc_convention)
CONVENTIONS = {
    "the opposite sign (measured − computed)": (-1.0, False),
    "line and sample swapped": (1.0, True),
    "the opposite sign, line and sample swapped": (-1.0, True),
}
RC_CONVENTION = (
    "the delivered residuals reproduce with {convention}: RMS difference {rms} px, against "
    "{as_read} px read as the contract writes them (computed − measured, line then sample)"
)
#: a convention is named when it reproduces the delivered residuals this many times closer
#: (RMS difference) than the contract's reading does, which differs by more than CONVENTION_FLOOR_PX
CONVENTION_GAIN = 10.0
CONVENTION_FLOOR_PX = 0.01


def residual_convention(tp: pd.DataFrame, obs: pd.DataFrame) -> str | None:
    """The convention other than the contract's in which the delivered residuals reproduce
    (RC_CONVENTION), or None: residuals written measured − computed, or line and sample
    swapped, fail RC-1 as they stand, and the inspector is told why. Over the observations of
    points on two or more scenes that have both residuals."""
    given = [tp[c].to_numpy(dtype=float) for c in ("v_line", "v_sample")]
    computed = [obs[c].to_numpy(dtype=float) for c in ("v_line_computed", "v_sample_computed")]
    multi = obs["n_rays"].to_numpy() >= 2
    readings = {"as read": (1.0, False), **CONVENTIONS}

    def sums(a: int) -> np.ndarray:  # observations used, squared differences of each reading
        piece = slice(a, a + pieces.CHUNK)
        vl, vs, cl, cs = (v[piece] for v in (*given, *computed))
        use = multi[piece] & np.isfinite(vl) & np.isfinite(vs) & np.isfinite(cl) & np.isfinite(cs)
        vl, vs, cl, cs = vl[use], vs[use], cl[use], cs[use]
        squares = [
            np.sum((vl - k * (cs if swap else cl)) ** 2 + (vs - k * (cl if swap else cs)) ** 2)
            for k, swap in readings.values()
        ]
        return np.array([np.count_nonzero(use), *squares])

    n, *squares = pieces.total(sums, len(multi), np.zeros(len(readings) + 1))
    if not n:
        return None
    as_read, *others = np.sqrt(np.array(squares) / n)
    if not as_read > CONVENTION_FLOOR_PX:
        return None
    closest = int(np.argmin(others))
    if others[closest] * CONVENTION_GAIN >= as_read:
        return None
    return RC_CONVENTION.format(
        convention=list(CONVENTIONS)[closest],
        rms=f"{others[closest]:.3g}",
        as_read=f"{as_read:.3g}",
    )


#: said of RC-1 (after the count of points) when some points' rays do not intersect
NOT_REPRODUCED = (
    "tie points whose rays the delivered geometry cannot intersect: their observations are "
    "not reproduced (difference ∞, shown as –)"
)


#: said of the adjacent-image discrepancies derived from a geometry that RC-1 fails (§RC-2); its
#: words are those of the report's catalogue (rc_on_failed_geometry)
ON_FAILED_GEOMETRY = (
    "RC-1 fails on the delivered geometry (the delivered residuals differ from those it gives "
    "by up to {value} px): these discrepancies, derived from it (§RC-2), may rest on a geometry "
    "in error"
)


def annotated_keys(metric: str) -> tuple[str, ...]:
    """The keys `annotate` may add to the detail of a result of that metric."""
    note = ("note", "hint") if metric == "residual_reproduction" else ()
    source = SOURCES.get(metric)
    computed = ("computed_by_blockqc",) if source else ()
    rays = ("observations_without_residual", "observations_single_ray")
    hint = ("hint",) if source == "overlaps" else ()
    return (*note, *computed, *(rays if source == "tie_point_residuals" else ()), *hint)


def annotate(results: list[Any], metric_of: dict[str, str], notes: dict) -> None:
    """Say in each result judged on inputs blockqc computed itself where they came from (and, of
    discrepancies derived from a geometry RC-1 fails, that they rest on it); in RC-1's why its
    value is infinite (no number in JSON) when rays do not intersect, and in which other
    convention the delivered residuals reproduce (`residual_convention`)."""
    computed = {k: v for k, v in notes.items() if v in (COMPUTED_RESIDUALS, DERIVED_OVERLAPS)}
    lost = notes.get("n_points_not_intersected", 0)
    convention = notes.get("residual_convention")
    rc1 = [
        r.value
        for r in results
        if metric_of.get(r.rule) == "residual_reproduction" and r.status == "fail"
    ]
    for res in results:
        if metric_of.get(res.rule) == "residual_reproduction":
            if lost:
                res.detail["note"] = f"{lost} {NOT_REPRODUCED}"
            if convention:
                res.detail["hint"] = convention
        source = SOURCES.get(metric_of.get(res.rule, ""))
        if source in computed:
            res.detail["computed_by_blockqc"] = computed[source]
            if source == "tie_point_residuals":
                for key in ("observations_without_residual", "observations_single_ray"):
                    if key in notes:
                        res.detail[key] = notes[key]
            if source == "overlaps" and rc1 and res.status not in ("not_applicable", "error"):
                worst = rc1[0] if isinstance(rc1[0], float | int) else float("inf")
                value = "∞" if worst == float("inf") else f"{worst:.3g}"
                res.detail["hint"] = ON_FAILED_GEOMETRY.format(value=value)
