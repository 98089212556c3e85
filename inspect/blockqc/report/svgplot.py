"""A small SVG chart: axes with round ticks, a legend at the right, and marks given in data
coordinates (bars, arrows, rings, lines, markers, labels), every mark of one kind and colour
one path, text as text in the report's fonts.

A figure of a block report costs milliseconds whatever its number of scenes, and WeasyPrint draws
the same SVG in the PDF; only a layer of very many marks is an image (`svg.raster`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from blockqc.report.svg import (
    FONT_FAMILY,
    RASTER_ABOVE,
    Frame,
    Rings,
    arrow_outlines,
    cut,
    disc_outlines,
    markers_path,
    outlines_d,
    path_d,
    raster,
    segments_d,
    text,
    text_width,
    wrap,
    xml_text,
)
from blockqc.rfm.model import wrap_lon

AXIS = "#555"
GRID = "#e3e3e3"
TICK_PT = 3.5
TITLE_PT, LABEL_PT, TICK_LABEL_PT, LEGEND_PT = 9.0, 8.0, 7.0, 7.0
PAD_PT = 4.0
COLUMN_LABEL_PT = 90.0  # the longest a column label may reach below the axes


def nice_ticks(lo: float, hi: float, target: int = 6) -> np.ndarray:
    """Round tick values (1, 2, 2.5, 5 × 10^k apart) inside [lo, hi], about `target` of them,
    each the float nearest its decimal value (0.3, not 0.30000000000000004)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo]) if math.isfinite(lo) else np.array([])
    parts = max(target - 1, 1)
    raw = hi / parts - lo / parts  # (hi - lo) / parts without overflow near ±1.8e308
    if not raw > 0:  # the span underflows: one tick
        return np.array([lo])
    e = math.floor(math.log10(raw)) - 1  # step = tenths × 10^e, tenths one of 10, 20, 25, 50, 100
    tenths = next(m for m in (10, 20, 25, 50, 100) if _decimal(m, e) >= raw * 0.999)
    step = _decimal(tenths, e)
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    return np.array([_decimal(i * tenths, e) for i in range(first, last + 1)]) + 0.0


def _decimal(n: int, e: int) -> float:
    """n × 10^e correctly rounded (Python's integers are exact, their quotient rounded once)."""
    return float(n * 10**e) if e >= 0 else n / 10**-e


def tick_labels(ticks: np.ndarray, lon: bool = False) -> list[str]:
    """Plain labels with the decimals the step needs (a hyphen for minus: every font has it);
    `lon`: longitudes, those beyond ±180° (a map across the antimeridian) written within."""
    shown = np.where(np.abs(ticks) > 180.0, wrap_lon(ticks), ticks) if lon else ticks
    if len(ticks) < 2:
        return [f"{v:g}" for v in shown]
    step = float(np.min(np.diff(ticks)))
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    if not np.allclose(np.round(ticks, decimals), ticks, rtol=0, atol=step * 1e-6):
        decimals += 1
    return [f"{v:.{decimals}f}" for v in shown]


Mark = Callable[[Frame], str]


@dataclass
class LegendEntry:
    """One line of a legend: a swatch (a patch, a line, a disc or a cross) and its label."""

    label: str
    colour: str
    kind: Literal["patch", "line", "marker-o", "marker-x"] = "patch"
    dash: str = ""
    alpha: float = 1.0


@dataclass
class Plot:
    """One chart: axes, marks in data coordinates, a legend at the right."""

    height_in: float
    width_in: float = 6.7
    title: str = ""
    xlabel: str = ""
    ylabel: str = ""
    xlim: tuple[float, float] = (0.0, 1.0)
    ylim: tuple[float, float] = (0.0, 1.0)
    #: y data units per x data unit on the page (1: equal; 1/cos(lat) for lon/lat); None: free
    aspect: float | None = None
    invert_y: bool = False
    grid: str = "y"  # which axes draw grid lines: "", "x", "y", "xy"
    box: bool = False  # all four sides drawn (an image frame), else left and bottom only
    xticks: bool = True
    xtick_rotation: float = 0.0
    yticks: bool = True
    tick_size: float = TICK_LABEL_PT
    lon_x: bool = False  # x is longitude: ticks beyond ±180° labelled within (`tick_labels`)
    column_labels: tuple[np.ndarray, list[str], float] | None = None
    legend: list[LegendEntry] = field(default_factory=list)
    marks: list[tuple[int, Mark]] = field(default_factory=list)

    def add(self, mark: Mark, z: int = 2) -> None:
        self.marks.append((z, mark))

    # layout -----------------------------------------------------------------------------------

    def _ticks(self) -> tuple[np.ndarray, list[str], np.ndarray, list[str]]:
        xt = nice_ticks(*self.xlim) if self.xticks and not self.column_labels else np.array([])
        yt = nice_ticks(*self.ylim) if self.yticks else np.array([])
        return xt, tick_labels(xt, self.lon_x), yt, tick_labels(yt)

    def _legend_width(self) -> float:
        if not self.legend:
            return PAD_PT * 2
        labels = (text_width(self._legend_label(e), LEGEND_PT) for e in self.legend)
        return 8 + 18 + max(labels) + PAD_PT

    def _legend_label(self, e: LegendEntry) -> str:
        """The label, cut with an ellipsis to a third of the figure's width."""
        return cut(e.label, LEGEND_PT, self.width_in * 72 / 3)

    def _column_texts(self) -> list[str]:
        """The column labels, each cut with an ellipsis to COLUMN_LABEL_PT."""
        if self.column_labels is None:
            return []
        _, labels, size = self.column_labels
        return [cut(s, size, COLUMN_LABEL_PT) for s in labels]

    def _column_extent(self) -> float:
        """How far the column labels reach below the axes (the figure grows by it)."""
        if self.column_labels is None:
            return 0.0
        size = self.column_labels[2]
        return TICK_PT + max((text_width(s, size) for s in self._column_texts()), default=0)

    def _bottom(self, xlabels: list[str]) -> float:
        below = PAD_PT + self._column_extent()
        if xlabels:
            w = max(text_width(s, self.tick_size) for s in xlabels)
            a = math.radians(self.xtick_rotation)
            below += TICK_PT + 2 + w * math.sin(a) + self.tick_size * math.cos(a)
        return below + (LABEL_PT + 6 if self.xlabel else 2)

    def _title_lines(self) -> list[str]:
        return wrap(self.title, TITLE_PT, self.width_in * 72 - 2 * PAD_PT) if self.title else []

    def _frame(self, xlabels: list[str], ylabels: list[str]) -> tuple[Frame, float, float]:
        """The plot area; with an aspect, shrunk to the data's shape (the figure with it)."""
        width, height = self.width_in * 72, self.height_in * 72 + self._column_extent()
        left = PAD_PT + (LABEL_PT + 5 if self.ylabel else 0)
        left += max((text_width(s, self.tick_size) for s in ylabels), default=0) + TICK_PT + 3
        top = PAD_PT + (len(self._title_lines()) * (TITLE_PT + 2) + 5 if self.title else 2)
        w = width - left - self._legend_width()
        h = height - top - self._bottom(xlabels)
        if self.aspect:
            xr, yr = self.xlim[1] - self.xlim[0], (self.ylim[1] - self.ylim[0]) * self.aspect
            scale = min(w / xr, h / yr)
            width, height = width - (w - xr * scale), height - (h - yr * scale)
            w, h = xr * scale, yr * scale
            need = max(text_width(line, TITLE_PT) for line in self._title_lines() or [""])
            if width < need + 2 * PAD_PT:  # never narrower than the title: the frame centred
                left += (need + 2 * PAD_PT - width) / 2
                width = need + 2 * PAD_PT
        return Frame(left, top, w, h, self.xlim, self.ylim, self.invert_y), width, height

    # drawing ----------------------------------------------------------------------------------

    def svg(self, name: str) -> str:
        """The figure as an SVG element; `name` prefixes its ids (several share a page)."""
        self.xlim, self.ylim = _window(self.xlim), _window(self.ylim)
        xt, xl, yt, yl = self._ticks()
        fr, width, height = self._frame(xl, yl)
        clip = f"{name}-clip"
        body = [
            f'<rect width="{width:.2f}" height="{height:.2f}" fill="#fff"/>',
            f'<clipPath id="{clip}"><rect x="{fr.left:.2f}" y="{fr.top:.2f}" '
            f'width="{fr.width:.2f}" height="{fr.height:.2f}"/></clipPath>',
            self._grid(fr, xt, yt),
            f'<g clip-path="url(#{clip})">',
            *(mark(fr) for _, mark in sorted(self.marks, key=lambda m: m[0])),
            "</g>",
            self._axes(fr, xt, xl, yt, yl),
            self._titles(fr, xl, width),
            self._legend_svg(fr),
        ]
        label = xml_text(self.title, quote=True)
        return (
            f'<svg class="figure" role="img" aria-label="{label}" '
            f'xmlns="http://www.w3.org/2000/svg" width="{width:.2f}pt" height="{height:.2f}pt" '
            f'viewBox="0 0 {width:.2f} {height:.2f}" font-family="{FONT_FAMILY}">'
            + "".join(body)
            + "</svg>"
        )

    def _grid(self, fr: Frame, xt: np.ndarray, yt: np.ndarray) -> str:
        segs = []
        if "x" in self.grid and len(xt):
            x = fr.x(xt)
            segs.append(
                np.column_stack([x, np.full_like(x, fr.top), x, x * 0 + fr.top + fr.height])
            )
        if "y" in self.grid and len(yt):
            y = fr.y(yt)
            segs.append(np.column_stack([y * 0 + fr.left, y, y * 0 + fr.left + fr.width, y]))
        if not segs:
            return ""
        d = segments_d(np.concatenate(segs))
        return f'<path d="{d}" stroke="{GRID}" stroke-width="0.6" fill="none"/>'

    def _axes(self, fr: Frame, xt: np.ndarray, xl: list[str], yt: np.ndarray, yl: list[str]) -> str:
        x0, y0, x1, y1 = fr.left, fr.top + fr.height, fr.left + fr.width, fr.top
        sides = [(x0, y0, x1, y0), (x0, y0, x0, y1)]
        if self.box:
            sides += [(x0, y1, x1, y1), (x1, y0, x1, y1)]
        segs = [np.array(sides, float)]
        if len(xt):
            x = fr.x(xt)
            segs.append(np.column_stack([x, x * 0 + y0, x, x * 0 + y0 + TICK_PT]))
        if len(yt):
            y = fr.y(yt)
            segs.append(np.column_stack([y * 0 + x0 - TICK_PT, y, y * 0 + x0, y]))
        out = [
            f'<path d="{segments_d(np.concatenate(segs))}" stroke="{AXIS}" stroke-width="0.8" '
            'fill="none" stroke-linecap="square"/>'
        ]
        size = self.tick_size
        if self.xtick_rotation:
            ty = y0 + TICK_PT + 2 + size * 0.7
            out += [
                text(px, ty, s, size, anchor="end", rotate=-self.xtick_rotation)
                for px, s in zip(fr.x(xt), xl, strict=True)
            ]
        else:
            ty = y0 + TICK_PT + 2 + size * 0.75
            out += [
                text(px, ty, s, size, anchor="middle") for px, s in zip(fr.x(xt), xl, strict=True)
            ]
        out += [
            text(x0 - TICK_PT - 2, py + size * 0.35, s, size, anchor="end")
            for py, s in zip(fr.y(yt), yl, strict=True)
        ]
        if self.column_labels is not None:
            xs, _, lsize = self.column_labels
            px = fr.x(np.asarray(xs, float)) + lsize * 0.35
            out += [
                text(p, y0 + TICK_PT, s, lsize, anchor="end", rotate=-90)
                for p, s in zip(px, self._column_texts(), strict=True)
                if fr.left - 1 <= p <= fr.left + fr.width + 1
            ]
        return "".join(out)

    def _titles(self, fr: Frame, xlabels: list[str], width: float) -> str:
        out = []
        lines = self._title_lines()
        half = max((text_width(line, TITLE_PT) for line in lines), default=0) / 2 + PAD_PT
        middle = min(max(fr.left + fr.width / 2, half), width - half)  # inside the figure
        for i, line in enumerate(lines):
            y = PAD_PT + TITLE_PT + i * (TITLE_PT + 2)
            out.append(text(middle, y, line, TITLE_PT, anchor="middle"))
        middle = fr.left + fr.width / 2
        if self.xlabel:
            y = fr.top + fr.height + self._bottom(xlabels) - PAD_PT - 1
            out.append(text(middle, y, self.xlabel, LABEL_PT, anchor="middle"))
        if self.ylabel:
            cx, cy = PAD_PT + LABEL_PT * 0.8, fr.top + fr.height / 2
            out.append(text(cx, cy, self.ylabel, LABEL_PT, anchor="middle", rotate=-90))
        return "".join(out)

    def _legend_svg(self, fr: Frame) -> str:
        out = []
        x = fr.left + fr.width + 8
        for i, e in enumerate(self.legend):
            y = fr.top + 4 + i * (LEGEND_PT + 5)
            mid = y + LEGEND_PT * 0.35 - 2.5
            if e.kind == "patch":
                out.append(
                    f'<rect x="{x:.2f}" y="{mid - 3.5:.2f}" width="14" height="7" '
                    f'fill="{e.colour}" fill-opacity="{e.alpha:g}"/>'
                )
            elif e.kind == "line":
                dash = f' stroke-dasharray="{e.dash}"' if e.dash else ""
                out.append(
                    f'<path d="M{x:.2f},{mid:.2f}h14" stroke="{e.colour}" '
                    f'stroke-width="1.1"{dash}/>'
                )
            else:
                shape = "x" if e.kind == "marker-x" else "o"
                out.append(markers_path(np.array([[x + 7, mid]]), shape, e.colour, 5.0))
            out.append(text(x + 18, y + LEGEND_PT * 0.35 + 0.5, self._legend_label(e), LEGEND_PT))
        return "".join(out)


def _window(lim: tuple[float, float]) -> tuple[float, float]:
    """A data window that can be drawn: finite, and wider than nothing."""
    lo, hi = (float(v) for v in lim)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return 0.0, 1.0
    if hi > lo:
        return lo, hi
    half = max(abs(lo), 1.0) * 0.5
    return lo - half, lo + half


# marks: functions of the frame, made from data ------------------------------------------------


def _in_order(colours: np.ndarray) -> list[str]:
    """The distinct colours in their first order (one path each, later ones on top)."""
    return list(dict.fromkeys(np.asarray(colours, dtype=object).tolist()))


def data_range(values: Sequence[float] | np.ndarray, pad: float = 0.05) -> tuple[float, float]:
    """The range of the finite values, padded by `pad` of it (a unit range when flat)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    extra = (hi - lo) * pad if hi > lo else max(abs(hi), 1.0) * 0.5
    return lo - extra, hi + extra


def _stroke(colour: str, width: float, dash: str = "") -> str:
    dashes = f' stroke-dasharray="{dash}"' if dash else ""
    return f'stroke="{colour}" stroke-width="{width:g}" fill="none"{dashes}'


def segments(seg: np.ndarray, colour: str, width: float, dash: str = "") -> Mark:
    """Segments x0, y0, x1, y1 in data coordinates (NaN: the frame's edge on that axis)."""
    seg = np.asarray(seg, float).reshape(-1, 4)

    def draw(fr: Frame) -> str:
        x = np.where(np.isnan(seg[:, [0, 2]]), np.array(fr.xlim), seg[:, [0, 2]])
        y = np.where(np.isnan(seg[:, [1, 3]]), np.array(fr.ylim), seg[:, [1, 3]])
        page = np.column_stack([fr.x(x[:, 0]), fr.y(y[:, 0]), fr.x(x[:, 1]), fr.y(y[:, 1])])
        return f'<path d="{segments_d(page)}" {_stroke(colour, width, dash)}/>'

    return draw


def hline(
    y: float,
    colour: str,
    width: float,
    dash: str = "",
    span: tuple[float, float] = (np.nan, np.nan),
) -> Mark:
    """A horizontal line at y, across the frame or over `span` (data units)."""
    return segments(np.array([span[0], y, span[1], y]), colour, width, dash)


def vline(x: float, colour: str, width: float, dash: str = "") -> Mark:
    """A vertical line at x across the frame."""
    return segments(np.array([x, np.nan, x, np.nan]), colour, width, dash)


def markers(x: Any, y: Any, shape: str, colour: str, size: float) -> Mark:
    """Markers ("o" discs, "x" crosses) `size` pt wide; many discs drawn as an image. A point
    without a finite position is left out."""
    xy = np.column_stack([np.asarray(x, float), np.asarray(y, float)])
    xy = xy[np.isfinite(xy).all(axis=1)]
    if shape == "o" and len(xy) > RASTER_ABOVE:
        return lambda fr: raster(fr, [(colour, disc_outlines(fr.xy(xy), size))])
    return lambda fr: markers_path(fr.xy(xy), shape, colour, size)


def label(x: float, y: float, s: str, size: float, **kw: Any) -> Mark:
    """Text with its anchor at (x, y) in data units."""
    return lambda fr: text(float(fr.x(x)), float(fr.y(y)), s, size, **kw)


def bars(
    left: np.ndarray, width: np.ndarray, heights: np.ndarray, colours: np.ndarray, extra: str = ""
):
    """Bars from 0 up, one path per colour."""

    def draw(fr: Frame) -> str:
        out = []
        for colour in _in_order(colours):
            on = colours == colour
            x0, x1, h = left[on], left[on] + width[on], heights[on]
            corners = np.stack([x0, h * 0, x0, h, x1, h, x1, h * 0], axis=1).reshape(-1, 2)
            d = path_d(fr.xy(corners), np.arange(0, len(corners), 4), close=True)
            out.append(f'<path d="{d}" fill="{colour}"{extra}/>')
        return "".join(out)

    return draw


def arrows(tail: np.ndarray, vec: np.ndarray, colours: np.ndarray, width: float):
    """Arrows from `tail` by `vec` (data units), `width` pt wide: one path per colour, or one
    image above RASTER_ABOVE arrows."""
    groups = [(c, np.asarray(colours == c)) for c in _in_order(colours)]

    def draw(fr: Frame) -> str:
        layers = [
            (c, arrow_outlines(fr.xy(tail[on]), fr.xy(tail[on] + vec[on]), width))
            for c, on in groups
        ]
        if len(tail) > RASTER_ABOVE:
            return raster(fr, layers)
        return "".join(f'<path d="{outlines_d(o)}" fill="{c}"/>' for c, o in layers)

    return draw


def polygons(rings: Rings, colours: np.ndarray, alpha: float, width: float):
    """Filled rings, one path per colour, outlined in their colour."""

    def draw(fr: Frame) -> str:
        out = []
        for colour in _in_order(colours):
            d = rings.select(colours == colour).d(fr)
            out.append(
                f'<path d="{d}" fill="{colour}" fill-opacity="{alpha:g}" stroke="{colour}" '
                f'stroke-width="{width:g}" stroke-linejoin="round"/>'
            )
        return "".join(out)

    return draw


def circle(r: float, colour: str, width: float, dash: str) -> Mark:
    """A circle of radius r (data units) about the origin."""

    def draw(fr: Frame) -> str:
        cx, cy = float(fr.x(0.0)), float(fr.y(0.0))
        rx, ry = float(fr.x(r)) - cx, cy - float(fr.y(r))
        return (
            f'<ellipse cx="{cx:.2f}" cy="{cy:.2f}" rx="{abs(rx):.2f}" ry="{abs(ry):.2f}" '
            f"{_stroke(colour, width, dash)}/>"
        )

    return draw


__all__ = [
    "LegendEntry",
    "Mark",
    "Plot",
    "arrows",
    "bars",
    "circle",
    "data_range",
    "hline",
    "label",
    "markers",
    "nice_ticks",
    "polygons",
    "segments",
    "tick_labels",
    "vline",
]
