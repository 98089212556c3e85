"""A map of the overlap discrepancies between adjacent images (§RO-3), from results.json alone.

Each overlapping scene pair is drawn where the two footprints meet, as the mean discrepancy
vector (dx, dy) of its points, coloured red when its largest plane discrepancy fails the rule
that judged them (§RO-3 judges each single discrepancy), with that largest discrepancy written
beside it: the number a red label shows is the one that fails.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from blockqc.report import plots, svg, svgplot
from blockqc.report.documents import meets
from blockqc.report.format import Formatter, number
from blockqc.results import BlockResults, RuleResult


def _overlap_points(results: BlockResults) -> tuple[list[dict[str, Any]], RuleResult | None]:
    """The plane rows of the overlap measurement, and the rule result that judged them against
    a bound."""
    for res in results.results:
        m = results.measurement(res.measurement)
        if m is None or m.metric != "overlap_discrepancy" or "point" not in m.tables:
            continue
        rows = [r for r in m.tables["point"] if r.get("component") == "plane"]
        judge = next(
            (
                x
                for x in results.results
                if x.measurement == m.key
                and x.group.get("component") == "plane"
                and isinstance(x.threshold, (int, float))
                and x.comparison in ("<", "<=")
                and x.statistic == "value_m"
            ),
            None,
        )
        return rows, judge
    return [], None


def _footprints(results: BlockResults) -> tuple[list[str], np.ndarray]:
    """Scene ids and their footprint geometries (None where unreadable), parsed in one call."""
    ids = [str(sc["scene_id"]) for sc in results.scenes]
    return ids, plots.geometries([sc.get("footprint_wkt") for sc in results.scenes])


def _pairs(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """Per scene pair: mean dx, mean dy, RMS and largest plane discrepancy (one groupby)."""
    df = pd.DataFrame(rows, columns=["scene_a", "scene_b", "dx_m", "dy_m"])
    df = df.astype({"scene_a": str, "scene_b": str, "dx_m": float, "dy_m": float})
    df["v2"] = df["dx_m"] ** 2 + df["dy_m"] ** 2
    g = df.groupby(["scene_a", "scene_b"], sort=True)
    out = g.agg(dx=("dx_m", "mean"), dy=("dy_m", "mean"), ms=("v2", "mean"), mx=("v2", "max"))
    out["rms"], out["max"] = np.sqrt(out.pop("ms")), np.sqrt(out.pop("mx"))
    return out.reset_index()


#: every pair is labelled on a map of at most this many pairs; on a larger one, the failing
#: pairs (MAX_FAILING_LABELS at most) and the pairs of largest RMS, up to this many in all
MAX_PAIR_LABELS = 24
MAX_FAILING_LABELS = 60


def overlap_map(results: BlockResults, f: Formatter) -> str | None:
    """The map as SVG, or None when the results keep no overlap points or footprints."""
    import shapely

    rows, judge = _overlap_points(results)
    ids, geoms = _footprints(results)
    at = {sid: k for k, sid in enumerate(ids) if geoms[k] is not None}
    pairs = _pairs(rows)
    pairs = pairs[pairs["scene_a"].isin(at.keys()) & pairs["scene_b"].isin(at.keys())]
    if pairs.empty:
        return None
    ga = geoms[pairs["scene_a"].map(at).to_numpy()]
    gb = geoms[pairs["scene_b"].map(at).to_numpy()]
    meet = shapely.intersection(shapely.make_valid(ga), shapely.make_valid(gb))
    meet = np.where(shapely.is_empty(meet), shapely.union(ga, gb), meet)
    xy = shapely.get_coordinates(shapely.centroid(meet))
    rings = plots.rings_of(geoms)
    vec = pairs[["dx", "dy"]].to_numpy()
    longest = float(np.nanmax(np.hypot(vec[:, 0], vec[:, 1]), initial=0.0))
    x0, y0, x1, y1 = shapely.total_bounds(geoms[list(at.values())])
    span = max(x1 - x0, y1 - y0, 1e-3)  # the map's extent (one pair: its centres do not spread)
    scale = 0.15 * span / (longest or 1.0)  # degrees per metre of mean discrepancy
    bad = np.array(  # as the rule judges them: a bound inclusive or not, ON_BOUND
        [
            judge is not None and meets(v, judge.threshold, judge.comparison) is False
            for v in pairs["max"]
        ],
        dtype=bool,
    )
    colours = np.where(bad, plots.STATUS_COLOURS["fail"], plots.STATUS_COLOURS["pass"])
    largest = pairs["max"].to_numpy()
    labelled = _labelled(largest, bad)
    title = _title(f, longest, len(pairs), bad, labelled, _red(f, judge))
    plot = plots.lonlat_plot(rings, f.t, title)
    outline = np.full(len(rings.owner), "#9e9e9e", dtype=object)
    plot.add(svgplot.polygons(rings, outline, 0.0, 0.5))
    plot.add(svgplot.arrows(xy, vec * scale, colours.astype(object), 0.8), z=3)
    moved = bad[labelled] | (len(labelled) == len(pairs))  # kept: every label of a small map
    plot.add(_labels(xy[labelled], largest[labelled], colours[labelled], moved), z=4)
    return plot.svg("overlap-map")


def _labelled(largest: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """The pairs whose largest discrepancy is written: all of a small map; else the failing
    pairs (worst first, MAX_FAILING_LABELS at most), then the others of largest discrepancy,
    MAX_PAIR_LABELS in all."""
    if len(largest) <= MAX_PAIR_LABELS:
        return np.arange(len(largest))
    worst = np.lexsort((-np.nan_to_num(largest, nan=-np.inf), ~bad))  # failing first, worst
    failing = worst[: min(int(bad.sum()), MAX_FAILING_LABELS)]
    others = worst[int(bad.sum()) :][: max(MAX_PAIR_LABELS - len(failing), 0)]
    return np.concatenate([failing, others])


def _red(f: Formatter, judge: RuleResult | None) -> str:
    """What a red pair means: its largest discrepancy fails the rule, named with its bound
    ('; red: the largest fails RO-3 (< 28.28 m)'); nothing when no rule judges the discrepancies."""
    return "" if judge is None else f.t("overlap_red", rule=judge.rule, bound=f.threshold(judge))


def _title(
    f: Formatter, longest: float, n: int, bad: np.ndarray, labelled: np.ndarray, red: str
) -> str:
    """The map's title: what its labels and colours are, and which pairs are labelled when
    not every pair is."""
    if len(labelled) == n:
        return f.t("fig_overlap_map", m=f.num(longest), red=red)
    others, shown, failing = int((~bad[labelled]).sum()), int(bad[labelled].sum()), int(bad.sum())
    key = "none" if not failing else "failing" if shown == failing else "worst"
    failing = f.t(f"overlap_labels_{key}", n=shown, of=failing)
    return f.t("fig_overlap_map_some", m=f.num(longest), failing=failing, others=others, red=red)


def _labels(xy: np.ndarray, largest: np.ndarray, colours: np.ndarray, moved: np.ndarray):
    """The largest discrepancy beside each pair on a white ground: a `moved` label (a failing
    pair's, or any of a small map) is moved off the labels before it, another left out where
    it would cover one (the two diagonal pairs of four scenes in a grid share the centre of
    their overlap)."""
    texts = [number(v) for v in largest]

    def draw(fr: svg.Frame) -> str:
        page, kept = _unstacked(fr.xy(xy) + [2.0, 0.0], texts, moved, 6.0)
        grounds = [
            [x - 0.5, y - 5.0, x + svg.text_width(texts[i], 6.0) + 0.5, y + 1.5]
            for i, (x, y) in zip(kept, page[kept].tolist(), strict=True)
        ]
        ground = np.array(grounds, float).reshape(-1, 4)[:, [0, 1, 2, 1, 2, 3, 0, 3]]
        d = svg.path_d(ground.reshape(-1, 2), np.arange(0, 4 * len(kept), 4), close=True)
        back = f'<path d="{d}" fill="#fff" fill-opacity="0.8"/>' if kept else ""
        return back + "".join(
            svg.text(x, y, texts[i], 6, colour=colours[i])
            for i, (x, y) in zip(kept, page[kept].tolist(), strict=True)
        )

    return draw


def _unstacked(
    page: np.ndarray, texts: list[str], moved: np.ndarray, size: float
) -> tuple[np.ndarray, list[int]]:
    """Label baselines (points) each clear of the labels placed before it: a `moved` one moved
    down a line at a time until it is, another left out where it is not. The baselines and
    the labels kept (at most MAX_FAILING_LABELS + MAX_PAIR_LABELS labels)."""
    out = np.array(page, float)
    placed: list[tuple[float, float, float]] = []  # x from, x to, baseline
    kept: list[int] = []
    for i, s in enumerate(texts):
        x, y = out[i]
        right = x + svg.text_width(s, size)
        while any(x < b and a < right and abs(y - by) < size for a, b, by in placed):
            if not moved[i]:
                break
            y += 1.2 * size
        else:
            out[i, 1] = y
            placed.append((x, right, y))
            kept.append(i)
    return out, kept


def _corners(results: BlockResults) -> tuple[np.ndarray, np.ndarray]:
    """Each scene's image corners (0,0), (0,S), (L,S), (L,0) in lon/lat: its footprint's first four
    vertices (contract v1 extension). The scene ids and their corners (k × 4 × 2)."""
    import shapely

    ids, geoms = _footprints(results)
    ok = shapely.get_type_id(geoms) == 3  # polygons
    rings = shapely.get_exterior_ring(geoms[ok])
    coords, owner = shapely.get_coordinates(rings, return_index=True)
    first = np.searchsorted(owner, np.arange(len(rings)))
    enough = np.flatnonzero(np.bincount(owner, minlength=len(rings)) >= 4)
    corners = coords[first[enough, None] + np.arange(4), :2]
    return np.asarray(ids, dtype=object)[ok][enough], corners.reshape(-1, 4, 2)


def residual_vectors(
    cells: list[dict[str, Any]], ids: np.ndarray, corners: np.ndarray
) -> np.ndarray:
    """Per cell: position (lon, lat) and mean residual direction on the ground (dlon, dlat),
    by the bilinear map of the image corners of its scene (`corners[k]` of `ids[k]`):
    P(u, w) = Σ corner weights; d = ∂P/∂u·v_l/L + … (only the direction is drawn, so L and S
    cancel to the fractions used here)."""
    table = pd.DataFrame(cells, columns=["scene_id", "u", "w", "v_line", "v_sample"])
    at = pd.Index(np.asarray(ids, dtype=object)).get_indexer(table["scene_id"].astype(str))
    table, at = table[at >= 0], at[at >= 0]
    if table.empty:
        return np.empty((0, 4))
    c = corners[at]  # (n, 4, 2)
    u, w = (table[k].to_numpy(float)[:, None] for k in ("u", "w"))
    p = (
        (1 - u) * (1 - w) * c[:, 0]
        + (1 - u) * w * c[:, 1]
        + u * w * c[:, 2]
        + u * (1 - w) * c[:, 3]
    )
    du = (1 - w) * (c[:, 3] - c[:, 0]) + w * (c[:, 2] - c[:, 1])
    dw = (1 - u) * (c[:, 1] - c[:, 0]) + u * (c[:, 2] - c[:, 3])
    vl, vs = (table[k].to_numpy(float)[:, None] for k in ("v_line", "v_sample"))
    size = np.hypot(vl, vs)
    d = du * vl + dw * vs
    norm = np.hypot(d[:, 0], d[:, 1])[:, None]
    d = np.where(norm > 0, d / np.where(norm > 0, norm, 1) * size, 0.0)
    return np.hstack([p, d])


def residual_map(results: BlockResults, f: Formatter) -> str | None:
    """Mean tie-point residual vectors per scene cell over the block's footprints (SVG)."""
    m = next(iter(results.measurements_of("tie_point_errors")), None)
    cells = (m.detail.get("residual_cells") if m else None) or []
    v = residual_vectors(cells, *_corners(results))
    v = v[np.isfinite(v).all(axis=1)]  # a cell whose residuals are all missing has no arrow
    if not len(v):
        return None
    span = max(float(np.ptp(v[:, 0])), float(np.ptp(v[:, 1])), 1e-3)
    biggest = float(np.max(np.hypot(v[:, 2], v[:, 3]))) or 1.0
    scale = 0.04 * span / biggest
    tail, vec = v[:, :2], v[:, 2:] * scale
    plot = svgplot.Plot(4.4, 5.6, title=f.t("fig_residual_map", px=f"{biggest:.2f}"))
    plot.xlabel, plot.ylabel, plot.grid, plot.lon_x = f.t("ax_lon"), f.t("ax_lat"), "xy", True
    plot.aspect = 1 / max(math.cos(math.radians(float(v[:, 1].mean()))), 0.05)
    ends = np.concatenate([tail, tail + vec])
    plot.xlim, plot.ylim = svgplot.data_range(ends[:, 0]), svgplot.data_range(ends[:, 1])
    colours = np.full(len(v), "#1f4e99", dtype=object)
    plot.add(svgplot.arrows(tail, vec, colours, 0.5))
    return plot.svg("residual-map")
