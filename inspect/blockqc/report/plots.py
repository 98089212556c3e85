"""The report's figures, drawn as SVG by blockqc.report.svgplot: inline in the HTML, drawn as
they are by WeasyPrint in the PDF.

Each figure is a function of results.json alone; every mark of one kind and colour is one path,
so a figure of a 3,000-scene block costs milliseconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pandas as pd

from blockqc.lonlat import unwrapped
from blockqc.report.svg import Frame, Rings, arrow_outlines, cut, outlines_d, text, text_width
from blockqc.report.svgplot import (
    LegendEntry,
    Mark,
    Plot,
    arrows,
    bars,
    circle,
    data_range,
    hline,
    label,
    markers,
    polygons,
    segments,
    vline,
)

STATUS_COLOURS = {
    "pass": "#2e7d32",
    "fail": "#c62828",
    "error": "#c62828",
    "warn": "#e07b00",
    "waived": "#7b1fa2",
    "exempt": "#1565c0",
    "other": "#9e9e9e",
}
METHOD_COLOURS = {
    "high_precision": "#1f4e99",
    "same_accuracy": "#e07b00",
    "recalculation": "#2e7d32",
}
WIDTH_IN = 6.7  # the A4 text width (170 mm)
#: residual histogram bars: 0.05 px wide, drawn up to 10 px (as the tie-point metric bins them)
HIST_BIN_PX = 0.05
HIST_MAX_PX = 10.0
DASHED, DOTTED = "3.7,1.6", "1,1.65"
MAX_FOOTPRINT_LABELS = 40


def _column_size(labels: list[str]) -> float:
    return 5.5 if len(labels) > 40 else 6.5


def _method(t: Callable[..., str], method: str) -> str:
    from blockqc.report.messages import MESSAGES

    return t(f"method_{method}") if f"method_{method}" in MESSAGES else method


def _nice(v: float) -> float:
    """A round number near v (1, 2, 5 × 10^k)."""
    if v <= 0:
        return 1.0
    k = 10 ** math.floor(math.log10(v))
    return min((1, 2, 5, 10), key=lambda m: abs(m * k - v)) * k


def _num(v: float) -> str:
    return f"{v:g}"


def _bounded_bins(hist: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, float]:
    """The histogram's bins up to 10 px (at most a few hundred bars, whatever results.json
    holds) and the count of errors beyond them."""
    edges = np.asarray(hist.get("edges_px") or [0.0, HIST_BIN_PX], float)
    counts = np.asarray(hist.get("counts") or [0], float)
    if edges.size != counts.size + 1 or not (np.isfinite(edges).all() & np.isfinite(counts).all()):
        edges, counts = np.array([0.0, HIST_BIN_PX]), np.zeros(1)  # not a histogram: none drawn
    inside = edges[1:] <= HIST_MAX_PX + 1e-9
    n = int(inside.sum())
    return edges[: n + 1], counts[:n], float(counts[~inside].sum())


def checkpoint_errors(
    points: list[dict[str, Any]],
    stats: list[dict[str, Any]],
    component: str,
    t: Callable[..., str],
    name: str,
) -> str:
    """Error of every checkpoint, norm ±m and tolerance drawn, like the published error figures."""
    rows = [p for p in points if p.get("component") == component and p.get("error_m") is not None]
    methods = list(dict.fromkeys(p["method"] for p in rows))
    plot = Plot(2.5, title=t("fig_cp_errors", component=t(f"component_{component}")))
    plot.ylabel = t("ax_error_m")
    x0, ticks, labels, reach = 0, [], [], [0.0]
    for method in methods:
        mine = [p for p in rows if p["method"] == method]
        xs = np.arange(x0, x0 + len(mine), dtype=float)
        err = np.array([p["error_m"] for p in mine], dtype=float)
        gross = np.array([bool(p.get("gross")) for p in mine])
        colour = METHOD_COLOURS.get(method, "#444")
        plot.add(segments(np.column_stack([xs, xs * 0, xs, err]), colour, 1.2))
        plot.add(markers(xs[~gross], err[~gross], "o", colour, 3.2), z=3)
        plot.add(markers(xs[gross], err[gross], "x", STATUS_COLOURS["fail"], 6.0), z=3)
        plot.legend.append(LegendEntry(_method(t, method), colour, "marker-o"))
        reach += err.tolist()
        st = next((s for s in stats if s["component"] == component and s["method"] == method), None)
        span = (x0 - 0.5, x0 + len(mine) - 0.5)
        for sign in (1, -1) if component == "height" else (1,):
            for key, line_colour, width, dash in (
                ("norm_m", "#555", 0.9, DASHED),
                ("bound_m", STATUS_COLOURS["fail"], 1.1, DOTTED),
            ):
                if st is not None and st.get(key) is not None:
                    plot.add(hline(sign * st[key], line_colour, width, dash, span))
                    reach.append(sign * st[key])
        ticks += xs.tolist()
        labels += [str(p["point_id"]) for p in mine]
        x0 += len(mine) + 1
    plot.add(hline(0.0, "#333", 0.6))
    plot.legend += [
        # a plane error is a length: its norm is drawn at +m only, a height's at ±m
        LegendEntry(
            t("lg_norm" if component == "height" else "lg_norm_plane"), "#555", "line", DASHED
        ),
        LegendEntry(t("lg_tolerance"), STATUS_COLOURS["fail"], "line", DOTTED),
    ]
    if any(p.get("gross") for p in rows):
        plot.legend.append(LegendEntry(t("lg_gross"), STATUS_COLOURS["fail"], "marker-x"))
    plot.column_labels = (np.asarray(ticks, float), labels, _column_size(labels))
    plot.xlim, plot.ylim = (-0.8, max(x0 - 0.2, 1)), data_range(reach)
    return plot.svg(name)


def checkpoint_vectors(
    points: list[dict[str, Any]], stats: list[dict[str, Any]], t: Callable[..., str], name: str
) -> str:
    """Plane error vectors at the checkpoints (or from one origin when positions are missing)."""
    rows = [p for p in points if p.get("component") == "plane" and p.get("dx_m") is not None]
    placed = [p for p in rows if p.get("x_m") is not None and p.get("y_m") is not None]
    if placed:
        return _placed_vectors(placed, t, name)
    plot = Plot(3.6, 4.6, title=t("fig_cp_scatter"), xlabel=t("ax_dx"), ylabel=t("ax_dy"))
    plot.aspect, plot.grid = 1.0, "xy"
    norm = next((s.get("norm_m") for s in stats if s["component"] == "plane"), None)
    bounds = sorted(
        {s["bound_m"] for s in stats if s["component"] == "plane" and s.get("bound_m") is not None}
    )
    lim = 1.0
    for method in dict.fromkeys(p["method"] for p in rows):
        mine = [p for p in rows if p["method"] == method]
        dx = np.array([p["dx_m"] for p in mine], float)
        dy = np.array([p["dy_m"] for p in mine], float)
        gross = np.array([bool(p.get("gross")) for p in mine])
        colour = METHOD_COLOURS.get(method, "#444")
        plot.add(markers(dx[~gross], dy[~gross], "o", colour, 3.5), z=3)
        plot.add(markers(dx[gross], dy[gross], "x", STATUS_COLOURS["fail"], 6.0), z=3)
        plot.legend.append(LegendEntry(_method(t, method), colour, "marker-o"))
        lim = max(lim, float(np.max(np.abs(np.r_[dx, dy]))) * 1.1)
    if norm is not None:
        plot.add(circle(norm, "#555", 0.9, DASHED))
        plot.legend.append(LegendEntry(t("lg_norm"), "#555", "line", DASHED))
        lim = max(lim, norm * 1.1)
    for b in bounds:
        plot.add(circle(b, STATUS_COLOURS["fail"], 1.1, DOTTED))
        lim = max(lim, b * 1.1)
    if bounds:
        plot.legend.append(LegendEntry(t("lg_tolerance"), STATUS_COLOURS["fail"], "line", DOTTED))
    plot.add(hline(0.0, "#999", 0.5))
    plot.add(vline(0.0, "#999", 0.5))
    plot.xlim = plot.ylim = (-lim, lim)
    return plot.svg(name)


def _placed_vectors(placed: list[dict[str, Any]], t: Callable[..., str], name: str) -> str:
    """The plane error vectors drawn at the checkpoints, the longest 12 % of the extent."""
    plot = Plot(4.2, 5.2, title=t("fig_cp_vectors"), xlabel=t("ax_easting"))
    plot.ylabel, plot.aspect, plot.grid, plot.xtick_rotation = t("ax_northing"), 1.0, "xy", 30.0
    x = np.array([p["x_m"] for p in placed], float)
    y = np.array([p["y_m"] for p in placed], float)
    d = np.array([[p["dx_m"], p["dy_m"]] for p in placed], float)
    extent = max(np.ptp(x), np.ptp(y), 1.0)
    longest = max(float(np.max(np.hypot(d[:, 0], d[:, 1]))), 1e-9)
    scale = 0.12 * extent / longest
    xy, vec = np.column_stack([x, y]), d * scale
    methods = np.array([p["method"] for p in placed], dtype=object)
    gross = np.array([bool(p.get("gross")) for p in placed])
    colours = np.array([METHOD_COLOURS.get(m, "#444") for m in methods], dtype=object)
    colours[gross] = STATUS_COLOURS["fail"]
    plot.add(arrows(xy, vec, colours, 1.3), z=3)
    for method in dict.fromkeys(methods.tolist()):
        colour = METHOD_COLOURS.get(method, "#444")
        sel = methods == method
        plot.add(markers(x[sel], y[sel], "o", colour, 2.5), z=4)
        plot.legend.append(LegendEntry(_method(t, method), colour))
    if gross.any():
        plot.legend.append(LegendEntry(t("lg_gross"), STATUS_COLOURS["fail"], "line"))
    ref = _nice(longest / 2)
    plot.add(_key_arrow(ref * scale, t("lg_vector_scale", m=_num(ref))), z=5)
    ends = np.r_[x, x + vec[:, 0]], np.r_[y, y + vec[:, 1]]
    plot.xlim, plot.ylim = data_range(ends[0], 0.08), data_range(ends[1], 0.08)
    return plot.svg(name)


def _key_arrow(length: float, caption: str) -> Mark:
    """A reference arrow of `length` data units at the lower left of the frame, captioned."""

    def draw(fr: Frame) -> str:
        x0, y0 = fr.left + 0.06 * fr.width, fr.top + 0.95 * fr.height
        w = float(fr.x(fr.xlim[0] + length) - fr.left)
        tail, tip = np.array([[x0, y0]]), np.array([[x0 + w, y0]])
        arrow = f'<path d="{outlines_d(arrow_outlines(tail, tip, 1.3))}" fill="#333"/>'
        return arrow + text(x0 + w + 4, y0 + 2.5, caption, 7)

    return draw


def residual_histogram(
    hist: dict[str, Any], marks: Sequence[float], t: Callable[..., str], name: str
) -> str:
    """Tie-point residual histogram with the 0.5 / 1.0 / 1.5 px marks (§TP-1..3)."""
    plot = Plot(2.3, title=t("fig_tp_hist"), xlabel=t("ax_residual_px"))
    plot.ylabel = t("ax_observations")
    px = t("unit_px")
    edges, counts, over = _bounded_bins(hist)
    blue = np.full(len(counts), "#7a9cc6", dtype=object)
    edge = ' stroke="#4f6f99" stroke-width="0.4"'
    plot.add(bars(edges[:-1], np.diff(edges), counts, blue, edge))
    top = max(counts.max() if counts.size else 1, over, 1)
    if over:  # errors beyond the drawn range: one grey bar at its end, with their count
        grey = np.array(["#d9d9d9"], dtype=object)
        plot.add(bars(edges[-1:], np.array([HIST_BIN_PX]), np.array([over]), grey, edge))
        beyond = f"> {edges[-1]:g} {px}: {over:g}"
        plot.add(label(edges[-1], over, beyond, 7, anchor="end"), z=4)
        edges = np.append(edges, edges[-1] + HIST_BIN_PX)
    for m in marks:
        red = m >= 1.5
        colour = STATUS_COLOURS["fail"] if red else "#555"
        plot.add(vline(m, colour, 0.9, "" if red else DASHED), z=3)
        plot.add(label(m, top * 1.02, f"{m:g} {px}", 7, anchor="middle"), z=4)
    plot.ylim = (0, top * 1.15)
    plot.xlim = (0, max(float(edges[-1]) if edges.size else 2.0, max(marks, default=0) + 0.1))
    return plot.svg(name)


def scene_counts(
    scenes: list[dict[str, Any]],
    minimum: float | None,
    status: dict[str, str],
    t: Callable[..., str],
    name: str,
) -> str:
    """Tie points per scene, the minimum drawn; failing scenes red, exempt scenes blue."""
    n = len(scenes)
    plot = Plot(2.6 if n <= 60 else 3.0, title=t("fig_tp_counts"), ylabel=t("ax_tie_points"))
    table = pd.DataFrame(scenes).reindex(columns=["scene_id", "n_points"])
    ids = table["scene_id"].astype(str)
    counts = pd.to_numeric(table["n_points"], errors="coerce").fillna(0).to_numpy(float)
    marks = ids.map(status).astype(object)
    colours = marks.map(STATUS_COLOURS).astype(object).fillna("#7a9cc6").to_numpy(object)
    plot.add(bars(np.arange(n) - 0.4, np.full(n, 0.8), counts, colours))
    top = max(float(counts.max(initial=0)) * 1.08, 1.0)
    if minimum is not None:
        plot.add(hline(minimum, STATUS_COLOURS["fail"], 1.0, DASHED), z=3)
        plot.legend.append(
            LegendEntry(t("lg_minimum", n=_num(minimum)), STATUS_COLOURS["fail"], "line", DASHED)
        )
        top = max(top, minimum * 1.15)
    present = set(marks.dropna())
    for st, key in (
        ("exempt", "lg_exempt"),
        ("waived", "status_waived"),
        ("warn", "status_warn"),
        ("fail", "status_fail"),
    ):
        if st in present or (st == "fail" and "error" in present):
            plot.legend.append(LegendEntry(t(key), STATUS_COLOURS[st]))
    if n <= 60:
        plot.column_labels = (np.arange(n, dtype=float), ids.tolist(), _column_size(ids.tolist()))
    else:
        plot.xlabel = t("ax_scene") + f" (1–{n})"
    plot.xlim, plot.ylim = (-0.8, n - 0.2), (0.0, top)
    return plot.svg(name)


FOOTPRINT_ORDER = {
    "pass": 0,
    "other": 0,
    "exempt": 1,
    "waived": 2,
    "warn": 3,
    "fail": 4,
    "error": 4,
}


def geometries(wkts: list[Any]) -> np.ndarray:
    """Footprint WKTs parsed in one call, their longitudes on one side of ±180° (`lonlat`: a
    block across it is drawn as one piece, not round the globe); None where a value is no text
    or cannot be read."""
    import shapely

    text = np.array([w if isinstance(w, str) else None for w in wkts], dtype=object)
    return unwrapped(shapely.from_wkt(text, on_invalid="ignore"))


def rings_of(geoms: np.ndarray) -> Rings:
    """Exterior rings of every polygon (parts of multipolygons too), each with the position of
    its geometry in `geoms`."""
    import shapely

    parts, owner = shapely.get_parts(geoms, return_index=True)
    polygon = shapely.get_type_id(parts) == 3
    parts, owner = parts[polygon], owner[polygon]
    coords, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
    used = np.unique(ring)  # rings with vertices, renumbered 0..k-1
    return Rings(coords, np.searchsorted(used, ring), owner[used])


def footprints(
    scenes: list[dict[str, Any]], status: dict[str, str], t: Callable[..., str], name: str
) -> str:
    """A map of the scene footprints (lon/lat) coloured by the worst status found per scene."""
    rings = rings_of(geometries([s.get("footprint_wkt") for s in scenes]))
    ids = np.asarray([str(s["scene_id"]) for s in scenes], dtype=object)
    st = pd.Series(ids[rings.owner]).map(status).astype(object).fillna("pass")
    highlight = ~st.isin(["pass", "other"]).to_numpy()
    colours = st.map(STATUS_COLOURS).fillna(STATUS_COLOURS["other"]).to_numpy(object)
    plot = lonlat_plot(rings, t, t("fig_footprints"))
    for layer, alpha, lw, z in ((~highlight, 0.12, 0.6, 2), (highlight, 0.35, 1.3, 3)):
        plot.add(polygons(rings.select(layer), colours[layer], alpha, lw), z)
    plot.add(ring_labels(rings.select(highlight), ids, MAX_FOOTPRINT_LABELS), z=4)
    shown = set(st)
    plot.legend += [
        LegendEntry(
            t("lg_exempt") if x == "exempt" else t(f"status_{x}"), STATUS_COLOURS[x], alpha=0.5
        )
        for x in ("pass", "fail", "warn", "waived", "exempt")
        if x in shown
    ]
    return plot.svg(name)


def lonlat_plot(
    rings: Rings, t: Callable[..., str], title: str, height_in: float = 4.4, width_in: float = 5.6
) -> Plot:
    """A lon/lat map framed on the rings, with equal ground scale at their mean latitude."""
    plot = Plot(height_in, width_in, title=title, xlabel=t("ax_lon"), ylabel=t("ax_lat"))
    plot.grid, plot.lon_x = "xy", True
    if len(rings.xy):
        (lon_lo, lat_lo), (lon_hi, lat_hi) = rings.xy.min(axis=0), rings.xy.max(axis=0)
        pad = 0.03 * max(lon_hi - lon_lo, lat_hi - lat_lo, 1e-3)
        plot.xlim, plot.ylim = (lon_lo - pad, lon_hi + pad), (lat_lo - pad, lat_hi + pad)
        plot.aspect = 1 / max(math.cos(math.radians((lat_lo + lat_hi) / 2)), 0.05)
    return plot


def ring_labels(rings: Rings, ids: np.ndarray, most: int) -> Mark:
    """The ids of the first `most` rings' owners at their centres, each cut (with an ellipsis) to
    its footprint's width and kept inside the frame, and left out where it would overlap one
    already written (adjacent failing scenes)."""
    centres = rings.centres()[:most]
    names = ids[rings.owner[:most]].tolist()
    spans = _x_spans(rings)[:most]

    def draw(fr: Frame) -> str:
        page = fr.xy(centres)
        room = np.minimum(0.8 * np.abs(fr.x(spans[:, 1]) - fr.x(spans[:, 0])), fr.width - 2)
        shown = [cut(s, 6, max(float(w), 12.0)) for s, w in zip(names, room, strict=True)]
        half = np.array([text_width(s, 6) / 2 + 1 for s in shown])
        low, high = fr.left + half, np.maximum(fr.left + fr.width - half, fr.left + half)
        page[:, 0] = np.clip(page[:, 0], low, high)  # a label stays inside the frame
        kept = _apart(page, half, 4.5)
        return "".join(
            text(x, y + 2, shown[i], 6, anchor="middle", colour="#111")
            for i, (x, y) in zip(kept, page[kept].tolist(), strict=True)
        )

    return draw


def _x_spans(rings: Rings) -> np.ndarray:
    """Each ring's least and greatest x (k × 2)."""
    if not len(rings.xy):
        return np.zeros((0, 2))
    starts = rings.starts()
    x = rings.xy[:, 0]
    return np.column_stack([np.minimum.reduceat(x, starts), np.maximum.reduceat(x, starts)])


def _apart(centre: np.ndarray, half_width: np.ndarray, half_height: float) -> list[int]:
    """Greedily, the boxes (centre ± half sizes) that overlap none kept before them."""
    kept: list[int] = []
    for i in range(len(centre)):  # at most MAX_FOOTPRINT_LABELS
        dx = np.abs(centre[kept, 0] - centre[i, 0]) < half_width[kept] + half_width[i]
        dy = np.abs(centre[kept, 1] - centre[i, 1]) < 2 * half_height
        if np.isfinite(centre[i]).all() and not (dx & dy).any():
            kept.append(i)
    return kept


def scene_points(
    scene_id: str,
    line: Sequence[float],
    sample: Sequence[float],
    lines: float,
    samples: float,
    grid: int,
    t: Callable[..., str],
    name: str,
) -> str:
    """One scene's tie points on its image frame with the k×k uniformity grid (§TP-4, TP-5)."""
    plot = Plot(2.6, 3.0, title=str(scene_id), xlabel=t("ax_sample"), ylabel=t("ax_line"))
    plot.aspect, plot.invert_y, plot.grid, plot.box, plot.tick_size = 1.0, True, "", True, 6.0
    plot.xlim, plot.ylim = (0.0, float(samples)), (0.0, float(lines))
    plot.add(markers(np.asarray(sample, float), np.asarray(line, float), "o", "#1f4e99", 1.4))
    k = np.arange(1, grid, dtype=float)
    across = np.column_stack([k * 0 + np.nan, lines * k / grid, k * 0 + np.nan, lines * k / grid])
    down = np.column_stack([samples * k / grid, k * 0 + np.nan, samples * k / grid, k * 0 + np.nan])
    plot.add(segments(np.concatenate([across, down]), "#999", 0.7, DASHED), z=1)
    return plot.svg(name)
