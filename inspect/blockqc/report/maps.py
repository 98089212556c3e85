"""A map of the overlap discrepancies between adjacent images (§RO-3), from results.json alone.

Each overlapping scene pair is drawn where the two footprints meet, as the mean discrepancy
vector (dx, dy) of its points, coloured red when any of its plane discrepancies fails the rule
that judged them, with its RMS written beside it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from blockqc.report import plots
from blockqc.report.format import Formatter
from blockqc.results import BlockResults


def _overlap_points(results: BlockResults) -> tuple[list[dict[str, Any]], float | None]:
    """The plane rows of the overlap measurement, and the bound a rule judged them against."""
    for res in results.results:
        m = results.measurement(res.measurement)
        if m is None or m.metric != "overlap_discrepancy" or "point" not in m.tables:
            continue
        rows = [r for r in m.tables["point"] if r.get("component") == "plane"]
        bound = next(
            (
                float(x.threshold)
                for x in results.results
                if x.measurement == m.key
                and x.group.get("component") == "plane"
                and isinstance(x.threshold, (int, float))
                and x.comparison in ("<", "<=")
                and x.statistic == "value_m"
            ),
            None,
        )
        return rows, bound
    return [], None


def _pair_places(results: BlockResults) -> dict[str, Any]:
    from shapely import wkt
    from shapely.errors import ShapelyError

    out = {}
    for s in results.scenes:
        try:
            out[str(s["scene_id"])] = wkt.loads(s["footprint_wkt"])
        except (ShapelyError, TypeError, KeyError, ValueError):
            continue
    return out


def _pairs(rows: list[dict[str, Any]]) -> dict[tuple[str, str], dict[str, float]]:
    """Per scene pair: mean dx, mean dy, RMS and largest discrepancy (a handful of pairs)."""
    keys = sorted({(str(r["scene_a"]), str(r["scene_b"])) for r in rows})
    out = {}
    for a, b in keys:
        sel = [r for r in rows if (str(r["scene_a"]), str(r["scene_b"])) == (a, b)]
        dx = np.array([r.get("dx_m") for r in sel], dtype=float)
        dy = np.array([r.get("dy_m") for r in sel], dtype=float)
        v = np.hypot(dx, dy)
        out[(a, b)] = {
            "dx": float(np.nanmean(dx)),
            "dy": float(np.nanmean(dy)),
            "rms": float(np.sqrt(np.nanmean(v**2))),
            "max": float(np.nanmax(v)),
        }
    return out


def overlap_map(results: BlockResults, f: Formatter) -> str | None:
    """The map as SVG, or None when the results keep no overlap points or footprints."""
    rows, bound = _overlap_points(results)
    places = _pair_places(results)
    pairs = {k: v for k, v in _pairs(rows).items() if k[0] in places and k[1] in places}
    if not pairs:
        return None
    fig, ax = plots._figure(4.4, 5.6)
    for geom in places.values():
        for poly in getattr(geom, "geoms", [geom]):
            if hasattr(poly, "exterior"):
                xy = np.asarray(poly.exterior.coords)[:, :2]
                ax.plot(xy[:, 0], xy[:, 1], color="#9e9e9e", lw=0.5, zorder=1)
    lon = np.array([g.centroid.x for g in places.values()])
    lat = np.array([g.centroid.y for g in places.values()])
    span = max(float(np.ptp(lon)), float(np.ptp(lat)), 1e-3)
    biggest = max(math.hypot(p["dx"], p["dy"]) for p in pairs.values()) or 1.0
    scale = 0.15 * span / biggest  # degrees per metre of mean discrepancy
    for (a, b), p in pairs.items():
        inter = places[a].intersection(places[b])
        c = inter.centroid if not inter.is_empty else places[a].union(places[b]).centroid
        bad = bound is not None and p["max"] >= bound
        colour = plots.STATUS_COLOURS["fail" if bad else "pass"]
        ax.annotate(
            "",
            xy=(c.x + p["dx"] * scale, c.y + p["dy"] * scale),
            xytext=(c.x, c.y),
            arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.2},
            zorder=3,
        )
        ax.text(c.x, c.y, f" {p['rms']:.1f}", fontsize=6, color=colour, zorder=4)
    ax.set_aspect(1 / max(math.cos(math.radians(float(lat.mean()))), 0.05))
    ax.set_xlabel(f.t("ax_lon"))
    ax.set_ylabel(f.t("ax_lat"))
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_title(f.t("fig_overlap_map", m=f"{biggest:.1f}"))
    return plots._svg(fig, "overlap-map")


def _corners(results: BlockResults) -> dict[str, np.ndarray]:
    """Each scene's image corners (0,0), (0,S), (L,S), (L,0) in lon/lat: its footprint's first four
    vertices (contract v1 extension)."""
    from shapely import wkt
    from shapely.errors import ShapelyError

    out = {}
    for s in results.scenes:
        try:
            xy = np.asarray(wkt.loads(s["footprint_wkt"]).exterior.coords)[:4, :2]
        except (ShapelyError, TypeError, KeyError, ValueError, AttributeError):
            continue
        if xy.shape == (4, 2):
            out[str(s["scene_id"])] = xy
    return out


def residual_vectors(cells: list[dict[str, Any]], corners: dict[str, np.ndarray]) -> np.ndarray:
    """Per cell: position (lon, lat) and mean residual direction on the ground (dlon, dlat),
    by the bilinear map of the image corners: P(u, w) = Σ corner weights; d = ∂P/∂u·v_l/L + …
    (only the direction is drawn, so L and S cancel to the fractions used here)."""
    rows = [c for c in cells if str(c["scene_id"]) in corners]
    if not rows:
        return np.empty((0, 4))
    c = np.stack([corners[str(r["scene_id"])] for r in rows])  # (n, 4, 2)
    u = np.array([r["u"] for r in rows])[:, None]
    w = np.array([r["w"] for r in rows])[:, None]
    p = (
        (1 - u) * (1 - w) * c[:, 0]
        + (1 - u) * w * c[:, 1]
        + u * w * c[:, 2]
        + u * (1 - w) * c[:, 3]
    )
    du = (1 - w) * (c[:, 3] - c[:, 0]) + w * (c[:, 2] - c[:, 1])
    dw = (1 - u) * (c[:, 1] - c[:, 0]) + u * (c[:, 2] - c[:, 3])
    vl = np.array([r["v_line"] for r in rows])[:, None]
    vs = np.array([r["v_sample"] for r in rows])[:, None]
    size = np.hypot(vl, vs)
    d = du * vl + dw * vs
    norm = np.hypot(d[:, 0], d[:, 1])[:, None]
    d = np.where(norm > 0, d / np.where(norm > 0, norm, 1) * size, 0.0)
    return np.hstack([p, d])


def residual_map(results: BlockResults, f: Formatter) -> str | None:
    """Mean tie-point residual vectors per scene cell over the block's footprints (SVG)."""
    m = next((x for x in results.measurements if x.metric == "tie_point_errors"), None)
    cells = (m.detail.get("residual_cells") if m else None) or []
    v = residual_vectors(cells, _corners(results))
    if not len(v):
        return None
    fig, ax = plots._figure(4.4, 5.6)
    span = max(float(np.ptp(v[:, 0])), float(np.ptp(v[:, 1])), 1e-3)
    biggest = float(np.max(np.hypot(v[:, 2], v[:, 3]))) or 1.0
    scale = 0.04 * span / biggest
    ax.quiver(
        v[:, 0], v[:, 1], v[:, 2] * scale, v[:, 3] * scale, angles="xy", scale_units="xy",
        scale=1, width=0.003, color="#1f4e99",
    )  # fmt: skip
    ax.set_aspect(1 / max(math.cos(math.radians(float(v[:, 1].mean()))), 0.05))
    ax.set_xlabel(f.t("ax_lon"))
    ax.set_ylabel(f.t("ax_lat"))
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_title(f.t("fig_residual_map", px=f"{biggest:.2f}"))
    return plots._svg(fig, "residual-map")
