"""The report's figures: matplotlib (Agg) drawn to SVG strings inlined in the HTML and the PDF.

Text is drawn as paths with the packaged CJK font as fallback, so a figure looks the same in every
browser and in the PDF, whatever fonts the reader's machine has.
"""

from __future__ import annotations

import contextvars
import io
import math
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib import font_manager  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.patches import Circle, Patch  # noqa: E402

FONT_FILE = Path(__file__).resolve().parent / "fonts" / "BlockqcSansSC-Regular.otf"
FONT_FAMILY = "Blockqc Sans SC"

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

_registered = False


def _setup() -> None:
    global _registered
    if not _registered:
        font_manager.fontManager.addfont(str(FONT_FILE))
        _registered = True
    matplotlib.rcParams.update(
        {
            "font.family": ["DejaVu Sans", FONT_FAMILY],
            "font.size": 8,
            "axes.titlesize": 9,
            "axes.titley": 1.0,  # titles sit above the axes; matplotlib need not measure overlaps
            "axes.labelsize": 8,
            "legend.fontsize": 7,
            "xtick.labelsize": 7,
            "ytick.labelsize": 7,
            "svg.fonttype": "path",
            "axes.spines.top": False,
            "axes.spines.right": False,
            "axes.grid": True,
            "grid.color": "#e3e3e3",
            "grid.linewidth": 0.6,
            "axes.axisbelow": True,
            "svg.hashsalt": "blockqc",
            "axes.unicode_minus": True,
            "text.parse_math": False,  # ids and labels are plain text: "$x$" is not mathtext
            "text.usetex": False,
        }
    )


#: set while a report for print is built: figures then also carry a PNG at print resolution
FOR_PRINT: contextvars.ContextVar[bool] = contextvars.ContextVar("for_print", default=False)
PRINT_DPI = 200


class Drawn(str):
    """A figure's SVG element; `png` holds the same figure at print resolution when FOR_PRINT."""

    png: bytes | None = None


PAD_IN = 0.04  # white margin around a figure's tight bounding box
#: resolution of the layers rasterized inside an SVG (RASTER_ABOVE): sharp on a screen
SVG_RASTER_DPI = 150


def _png(fig: plt.Figure, bbox: Any) -> bytes:
    """The print PNG framed on `bbox`: RGB (the figure is opaque), quickly compressed, so the
    PDF writer takes it without splitting off an alpha mask."""
    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, format="rgba", dpi=PRINT_DPI, bbox_inches=bbox)
    size = (int(bbox.width * PRINT_DPI), int(bbox.height * PRINT_DPI))
    raw = buf.getvalue()
    if len(raw) != size[0] * size[1] * 4:  # not the frame expected: let matplotlib encode it
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=PRINT_DPI, bbox_inches=bbox)
        return buf.getvalue()
    out = io.BytesIO()
    image = Image.frombuffer("RGBA", size, raw, "raw", "RGBA", 0, 1).convert("RGB")
    image.save(out, format="PNG", compress_level=1, dpi=(PRINT_DPI, PRINT_DPI))
    return out.getvalue()


_SVG_FRAME = re.compile(r'width="[0-9.]+pt" height="[0-9.]+pt" viewBox="[^"]*"')


def _crop(text: str, fig: plt.Figure, bbox: Any) -> str:
    """The SVG framed on `bbox` (inches, figure coordinates from the bottom left) by its
    viewBox: what bbox_inches="tight" frames, without laying the figure out a second time."""
    x0, w, h = bbox.x0 * 72, bbox.width * 72, bbox.height * 72
    y0 = (fig.get_figheight() - bbox.y1) * 72
    frame = f'width="{w:f}pt" height="{h:f}pt" viewBox="{x0:f} {y0:f} {w:f} {h:f}"'
    return _SVG_FRAME.sub(frame, text, count=1)


def _svg(fig: plt.Figure, name: str) -> Drawn:
    """The figure as an SVG element, ids prefixed with `name` so several can share a page.

    The figure is drawn once as SVG at full size and framed on its tight bounding box (taken
    from that layout); the print PNG, when wanted, is drawn once on the same frame."""
    buf = io.StringIO()
    fig.savefig(buf, format="svg", dpi=SVG_RASTER_DPI, metadata={"Date": None, "Creator": None})
    bbox = fig.get_tightbbox().padded(PAD_IN)
    png = _png(fig, bbox) if FOR_PRINT.get() else None
    plt.close(fig)
    text = _crop(buf.getvalue(), fig, bbox)
    text = text[text.index("<svg") :]
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)  # matplotlib echoes every label here
    text = re.sub(r'\bid="([^"]+)"', lambda m: f'id="{name}-{m.group(1)}"', text)
    text = re.sub(
        r'(xlink:href|href)="#([^"]+)"', lambda m: f'{m.group(1)}="#{name}-{m.group(2)}"', text
    )
    text = re.sub(r"url\(#([^)]+)\)", lambda m: f"url(#{name}-{m.group(1)})", text)
    drawn = Drawn(text.replace("<svg ", '<svg class="figure" role="img" ', 1))
    drawn.png = png
    return drawn


def _column_labels(ax: Any, xs: Iterable[float], labels: list[str]) -> None:
    """A label under each column (a checkpoint's stem, a scene's bar), upright as tick labels
    are, drawn as plain text: a tick per label would cost matplotlib five artists each."""
    from matplotlib.transforms import ScaledTranslation

    ax.set_xticks([])
    below = ax.get_xaxis_transform() + ScaledTranslation(0, -3.5 / 72, ax.figure.dpi_scale_trans)
    size = 5.5 if len(labels) > 40 else 6.5
    for x, label in zip(xs, labels, strict=True):
        ax.text(x, 0, label, transform=below, rotation=90, ha="center", va="top", fontsize=size)


def _figure(height_in: float, width_in: float = WIDTH_IN) -> tuple[plt.Figure, Any]:
    _setup()
    fig, ax = plt.subplots(figsize=(width_in, height_in))
    return fig, ax


def checkpoint_errors(
    points: list[dict[str, Any]],
    stats: list[dict[str, Any]],
    component: str,
    t: Callable[..., str],
    name: str,
) -> str:
    """Error of every checkpoint, norm ±m and tolerance drawn, like the published error figures."""
    fig, ax = _figure(2.5)
    rows = [p for p in points if p.get("component") == component and p.get("error_m") is not None]
    methods = list(dict.fromkeys(p["method"] for p in rows))
    x0 = 0
    ticks, labels = [], []
    for method in methods:
        mine = [p for p in rows if p["method"] == method]
        xs = np.arange(x0, x0 + len(mine))
        err = np.array([p["error_m"] for p in mine], dtype=float)
        gross = np.array([bool(p.get("gross")) for p in mine])
        colour = METHOD_COLOURS.get(method, "#444")
        ax.vlines(xs, 0, err, color=colour, linewidth=1.2)
        ax.plot(
            xs[~gross], err[~gross], "o", color=colour, markersize=3.2, label=_method(t, method)
        )
        if gross.any():
            ax.plot(
                xs[gross],
                err[gross],
                "x",
                color=STATUS_COLOURS["fail"],
                markersize=6,
                markeredgewidth=1.5,
            )
        st = next((s for s in stats if s["component"] == component and s["method"] == method), None)
        if st is not None:
            span = (x0 - 0.5, x0 + len(mine) - 0.5)
            for sign in (1, -1) if component == "height" else (1,):
                if st.get("norm_m") is not None:
                    ax.hlines(
                        sign * st["norm_m"], *span, colors="#555", linestyles="--", linewidth=0.9
                    )
                if st.get("bound_m") is not None:
                    ax.hlines(
                        sign * st["bound_m"],
                        *span,
                        colors=STATUS_COLOURS["fail"],
                        linestyles=":",
                        linewidth=1.1,
                    )
        ticks += list(xs)
        labels += [str(p["point_id"]) for p in mine]
        x0 += len(mine) + 1
    ax.axhline(0, color="#333", linewidth=0.6)
    ax.plot([], [], "--", color="#555", linewidth=0.9, label=t("lg_norm"))
    ax.plot([], [], ":", color=STATUS_COLOURS["fail"], linewidth=1.1, label=t("lg_tolerance"))
    if any(p.get("gross") for p in rows):
        ax.plot([], [], "x", color=STATUS_COLOURS["fail"], label=t("lg_gross"))
    _column_labels(ax, ticks, labels)
    ax.set_xlim(-0.8, max(x0 - 0.2, 1))
    ax.set_ylabel(t("ax_error_m"))
    ax.set_title(t("fig_cp_errors", component=t(f"component_{component}")))
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    ax.grid(axis="x", visible=False)
    return _svg(fig, name)


def checkpoint_vectors(
    points: list[dict[str, Any]], stats: list[dict[str, Any]], t: Callable[..., str], name: str
) -> str:
    """Plane error vectors at the checkpoints (or from one origin when positions are missing)."""
    rows = [p for p in points if p.get("component") == "plane" and p.get("dx_m") is not None]
    placed = [p for p in rows if p.get("x_m") is not None and p.get("y_m") is not None]
    if placed:
        fig, ax = _figure(4.2, 5.2)
        x = np.array([p["x_m"] for p in placed], float)
        y = np.array([p["y_m"] for p in placed], float)
        dx = np.array([p["dx_m"] for p in placed], float)
        dy = np.array([p["dy_m"] for p in placed], float)
        extent = max(np.ptp(x), np.ptp(y), 1.0)
        longest = max(float(np.max(np.hypot(dx, dy))), 1e-9)
        scale = 0.12 * extent / longest  # the longest arrow is 12 % of the extent
        for method in dict.fromkeys(p["method"] for p in placed):
            sel = np.array([p["method"] == method for p in placed])
            gross = np.array([bool(p.get("gross")) for p in placed]) & sel
            ok = sel & ~gross
            colour = METHOD_COLOURS.get(method, "#444")
            q = ax.quiver(
                x[ok],
                y[ok],
                dx[ok] * scale,
                dy[ok] * scale,
                angles="xy",
                scale_units="xy",
                scale=1,
                color=colour,
                width=0.004,
                label=_method(t, method),
            )
            if gross.any():
                ax.quiver(
                    x[gross],
                    y[gross],
                    dx[gross] * scale,
                    dy[gross] * scale,
                    angles="xy",
                    scale_units="xy",
                    scale=1,
                    color=STATUS_COLOURS["fail"],
                    width=0.004,
                )
            ax.plot(x[sel], y[sel], "o", color=colour, markersize=2.5)
        ref = _nice(longest / 2)
        ax.quiverkey(
            q,
            0.06,
            0.05,
            ref * scale,
            t("lg_vector_scale", m=_num(ref)),
            labelpos="E",
            coordinates="axes",
            color="#333",
            fontproperties={"size": 7},
        )
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(t("ax_easting"))
        ax.set_ylabel(t("ax_northing"))
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.tick_params(axis="x", labelrotation=30)
        ax.set_title(t("fig_cp_vectors"))
        if any(p.get("gross") for p in placed):
            ax.plot([], [], "-", color=STATUS_COLOURS["fail"], label=t("lg_gross"))
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
        return _svg(fig, name)
    fig, ax = _figure(3.6, 4.6)
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
        ax.plot(dx[~gross], dy[~gross], "o", color=colour, markersize=3.5, label=_method(t, method))
        if gross.any():
            ax.plot(dx[gross], dy[gross], "x", color=STATUS_COLOURS["fail"], markersize=6)
        lim = max(lim, float(np.max(np.abs(np.r_[dx, dy]))) * 1.1)
    if norm is not None:
        ax.add_patch(
            Circle((0, 0), norm, fill=False, ls="--", ec="#555", lw=0.9, label=t("lg_norm"))
        )
        lim = max(lim, norm * 1.1)
    for b in bounds:
        ax.add_patch(Circle((0, 0), b, fill=False, ls=":", ec=STATUS_COLOURS["fail"], lw=1.1))
        lim = max(lim, b * 1.1)
    if bounds:
        ax.plot([], [], ":", color=STATUS_COLOURS["fail"], label=t("lg_tolerance"))
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.axhline(0, color="#999", lw=0.5)
    ax.axvline(0, color="#999", lw=0.5)
    ax.set_xlabel(t("ax_dx"))
    ax.set_ylabel(t("ax_dy"))
    ax.set_title(t("fig_cp_scatter"))
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _svg(fig, name)


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


def residual_histogram(
    hist: dict[str, Any], marks: Sequence[float], t: Callable[..., str], name: str
) -> str:
    """Tie-point residual histogram with the 0.5 / 1.0 / 1.5 px marks (§TP-1..3)."""
    fig, ax = _figure(2.3)
    edges, counts, over = _bounded_bins(hist)
    ax.bar(
        edges[:-1],
        counts,
        width=np.diff(edges),
        align="edge",
        color="#7a9cc6",
        edgecolor="#4f6f99",
        linewidth=0.4,
    )
    top = max(counts.max() if counts.size else 1, over, 1)
    if over:  # errors beyond the drawn range: one hatched bar at its end, with their count
        ax.bar(edges[-1], over, width=HIST_BIN_PX, align="edge", color="#d9d9d9", hatch="//")
        ax.text(edges[-1], over, f"> {edges[-1]:g} px: {over:g}", ha="right", va="bottom")
        edges = np.append(edges, edges[-1] + HIST_BIN_PX)
    for m in marks:
        ax.axvline(
            m,
            color=STATUS_COLOURS["fail"] if m >= 1.5 else "#555",
            ls="--" if m < 1.5 else "-",
            lw=0.9,
        )
        ax.text(m, top * 1.02, f"{m:g} px", ha="center", va="bottom", fontsize=7)
    ax.set_ylim(0, top * 1.15)
    ax.set_xlim(0, max(float(edges[-1]) if edges.size else 2.0, max(marks) + 0.1))
    ax.set_xlabel(t("ax_residual_px"))
    ax.set_ylabel(t("ax_observations"))
    ax.set_title(t("fig_tp_hist"))
    ax.grid(axis="x", visible=False)
    return _svg(fig, name)


#: above this many scenes (points, arrows), a layer drawing one mark per item is rasterized
#: inside the SVG at SVG_RASTER_DPI (size and speed)
RASTER_ABOVE = 400


def _bars(ax: Any, heights: np.ndarray, colours: list[str], width: float = 0.8) -> None:
    """Bars as one collection of rectangles (one artist, whatever the number of bars)."""
    x0 = np.arange(len(heights)) - width / 2
    verts = np.stack(
        [
            np.column_stack([x0, np.zeros_like(heights)]),
            np.column_stack([x0, heights]),
            np.column_stack([x0 + width, heights]),
            np.column_stack([x0 + width, np.zeros_like(heights)]),
        ],
        axis=1,
    )
    bars = PolyCollection(verts, facecolors=colours, edgecolors="none")
    bars.set_rasterized(len(heights) > RASTER_ABOVE)
    ax.add_collection(bars)
    ax.set_ylim(0, max(float(heights.max(initial=0)) * 1.08, 1.0))


def _status_handles(t: Callable[..., str], present: set[str], minimum: Any = None) -> list[Any]:
    handles: list[Any] = [minimum] if minimum is not None else []
    for st, label in (
        ("exempt", "lg_exempt"),
        ("waived", "status_waived"),
        ("fail", "status_fail"),
    ):
        if st in present or (st == "fail" and "error" in present):
            handles.append(Patch(color=STATUS_COLOURS[st], label=t(label)))
    return handles


def scene_counts(
    scenes: list[dict[str, Any]],
    minimum: float | None,
    status: dict[str, str],
    t: Callable[..., str],
    name: str,
) -> str:
    """Tie points per scene, the minimum drawn; failing scenes red, exempt scenes blue."""
    n = len(scenes)
    fig, ax = _figure(2.6 if n <= 60 else 3.0)
    table = pd.DataFrame(scenes)
    ids = table["scene_id"].astype(str)
    counts = pd.to_numeric(table.get("n_points"), errors="coerce").fillna(0).to_numpy(float)
    marks = ids.map(status).astype(object)
    colours = marks.map(STATUS_COLOURS).astype(object).fillna("#7a9cc6").tolist()
    _bars(ax, counts, colours)
    line = None
    if minimum is not None:
        label = t("lg_minimum", n=_num(minimum))
        line = ax.axhline(minimum, color=STATUS_COLOURS["fail"], ls="--", lw=1, label=label)
        ax.set_ylim(0, max(ax.get_ylim()[1], minimum * 1.15))
    handles = _status_handles(t, set(marks.dropna()), line)
    if n <= 60:
        _column_labels(ax, range(n), ids.tolist())
    else:
        ax.set_xlabel(t("ax_scene") + f" (1–{n})")
    ax.set_xlim(-0.8, n - 0.2)
    ax.set_ylabel(t("ax_tie_points"))
    ax.set_title(t("fig_tp_counts"))
    ax.grid(axis="x", visible=False)
    if handles:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _svg(fig, name)


FOOTPRINT_ORDER = {
    "pass": 0,
    "other": 0,
    "exempt": 1,
    "waived": 2,
    "warn": 3,
    "fail": 4,
    "error": 4,
}


def _rings(wkts: list[Any]) -> tuple[list[np.ndarray], np.ndarray]:
    """Exterior rings of every footprint polygon (parts of multipolygons too) and their scene."""
    import shapely

    geoms = shapely.from_wkt(
        np.array([w if isinstance(w, str) else None for w in wkts], dtype=object),
        on_invalid="ignore",
    )
    parts, owner = shapely.get_parts(geoms, return_index=True)
    polygon = shapely.get_type_id(parts) == 3
    parts, owner = parts[polygon], owner[polygon]
    coords, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
    if len(coords) == 0:
        return [], owner[:0]
    cuts = np.flatnonzero(np.diff(ring)) + 1
    return np.split(coords, cuts), owner[np.unique(ring)]


def footprints(
    scenes: list[dict[str, Any]], status: dict[str, str], t: Callable[..., str], name: str
) -> str:
    """A map of the scene footprints (lon/lat) coloured by the worst status found per scene."""
    fig, ax = _figure(4.4, 5.6)
    rings, owner = _rings([s.get("footprint_wkt") for s in scenes])
    ids = [str(s["scene_id"]) for s in scenes]
    st = pd.Series(np.asarray(ids, dtype=object)[owner]).map(status).astype(object).fillna("pass")
    highlight = ~st.isin(["pass", "other"]).to_numpy()
    for layer, alpha, lw, z in ((~highlight, 0.12, 0.6, 2), (highlight, 0.35, 1.3, 3)):
        idx = np.flatnonzero(layer)
        colours = st.iloc[idx].map(STATUS_COLOURS).fillna(STATUS_COLOURS["other"]).tolist()
        col = PolyCollection(
            [rings[i] for i in idx], facecolors=colours, edgecolors=colours, alpha=alpha, lw=lw
        )
        col.set_zorder(z)
        col.set_rasterized(len(idx) > RASTER_ABOVE)
        ax.add_collection(col)
    _label_footprints(ax, rings, owner, ids, highlight)
    shown = set(st)
    handles = [
        Patch(
            fc=STATUS_COLOURS[x],
            alpha=0.5,
            label=t("lg_exempt") if x == "exempt" else t(f"status_{x}"),
        )
        for x in ("pass", "fail", "warn", "waived", "exempt")
        if x in shown
    ]
    lonlat_axes(ax, rings, t, t("fig_footprints"))
    if handles:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _svg(fig, name)


def lonlat_axes(ax: Any, rings: list[np.ndarray], t: Callable[..., str], title: str) -> None:
    """A lon/lat map framed on the rings, with equal ground scale at their mean latitude."""
    if rings:
        allxy = np.concatenate(rings)
        (lon_lo, lat_lo), (lon_hi, lat_hi) = allxy.min(axis=0), allxy.max(axis=0)
        pad = 0.03 * max(lon_hi - lon_lo, lat_hi - lat_lo, 1e-3)
        ax.set_xlim(lon_lo - pad, lon_hi + pad)
        ax.set_ylim(lat_lo - pad, lat_hi + pad)
        ax.set_aspect(1 / max(math.cos(math.radians((lat_lo + lat_hi) / 2)), 0.05))
    ax.set_xlabel(t("ax_lon"))
    ax.set_ylabel(t("ax_lat"))
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_title(title)


MAX_FOOTPRINT_LABELS = 40


def _label_footprints(
    ax: Any, rings: list, owner: np.ndarray, ids: list[str], mark: np.ndarray
) -> None:
    """The ids of the highlighted footprints at their centres (at most MAX_FOOTPRINT_LABELS)."""
    for i in np.flatnonzero(mark)[:MAX_FOOTPRINT_LABELS]:
        cx, cy = rings[i][:-1].mean(axis=0)
        ax.text(cx, cy, ids[owner[i]], fontsize=6, ha="center", va="center", zorder=4,
                color="#111", parse_math=False)  # fmt: skip


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
    fig, ax = _figure(2.6, 3.0)
    (points,) = ax.plot(
        np.asarray(sample, float), np.asarray(line, float), ".", color="#1f4e99", markersize=2.2
    )
    points.set_rasterized(len(line) > RASTER_ABOVE)
    for k in range(1, grid):
        ax.axvline(samples * k / grid, color="#999", lw=0.7, ls="--")
        ax.axhline(lines * k / grid, color="#999", lw=0.7, ls="--")
    ax.set_xlim(0, samples)
    ax.set_ylim(lines, 0)
    ax.set_aspect("equal")
    ax.grid(False)
    for side in ("top", "right"):
        ax.spines[side].set_visible(True)
    ax.set_xlabel(t("ax_sample"))
    ax.set_ylabel(t("ax_line"))
    ax.set_title(str(scene_id), fontsize=8)
    ax.tick_params(labelsize=6)
    return _svg(fig, name)
