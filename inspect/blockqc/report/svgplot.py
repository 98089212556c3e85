"""A small SVG chart drawn directly: data mapped to the page with numpy, all the marks of one
kind and colour in one path, text as text in the report's fonts.

A figure of a block report costs milliseconds whatever its number of scenes, and WeasyPrint draws
the same SVG in the PDF; only a layer of very many marks is an image (`raster`). Coordinates
are in points (1/72 in), y down, as in SVG.
"""

from __future__ import annotations

import math
import unicodedata
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

#: the packaged font first (the PDF declares it), then what a browser is likely to have
FONT_FAMILY = "'Blockqc Sans SC', 'DejaVu Sans', sans-serif"
TEXT = "#222"
AXIS = "#555"
GRID = "#e3e3e3"
TICK_PT = 3.5
TITLE_PT, LABEL_PT, TICK_LABEL_PT, LEGEND_PT = 9.0, 8.0, 7.0, 7.0
PAD_PT = 4.0


@lru_cache(maxsize=1)
def _font():
    """DejaVu Sans (shipped with matplotlib, found without importing it) to measure Latin text,
    the widest of the fonts a figure is likely shown in; else the packaged font."""
    from importlib.util import find_spec

    from PIL import ImageFont

    spec = find_spec("matplotlib")
    here = Path(spec.origin).parent if spec and spec.origin else Path("/nonexistent")
    dejavu = here / "mpl-data" / "fonts" / "ttf" / "DejaVuSans.ttf"
    packaged = Path(__file__).resolve().parent / "fonts" / "BlockqcSansSC-Regular.otf"
    return ImageFont.truetype(str(dejavu if dejavu.is_file() else packaged), 100)


@lru_cache(maxsize=4096)
def text_width(text: str, size: float) -> float:
    """The advance of `text` at `size` pt, as DejaVu Sans sets it (CJK: one em per character)."""
    wide = sum(unicodedata.east_asian_width(c) in "WF" for c in text)
    narrow = "".join(c for c in text if unicodedata.east_asian_width(c) not in "WF")
    return (_font().getlength(narrow) / 100 + wide) * size


#: a vertex of a path by how it starts (M) or ends (Z) a subpath; 0.1 pt is finer than print
_VERTEX = np.array(
    ["L{:.1f},{:.1f}", "M{:.1f},{:.1f}", "L{:.1f},{:.1f}Z", "M{:.1f},{:.1f}Z"], object
)


def path_d(xy: np.ndarray, starts: np.ndarray, close: bool = False) -> str:
    """The `d` of a path through `xy` (n × 2, points) that starts a new subpath at each index of
    `starts`, closing each subpath when `close`. Formatted by str.format mapped over the
    columns (C-level iteration, no Python loop)."""
    n = len(xy)
    if n == 0:
        return ""
    kind = np.zeros(n, np.int8)
    kind[starts] = 1
    if close:
        kind[np.r_[np.asarray(starts)[1:], n] - 1] += 2
    xy = np.asarray(xy, float)
    return "".join(map(str.format, _VERTEX[kind].tolist(), xy[:, 0].tolist(), xy[:, 1].tolist()))


def nice_ticks(lo: float, hi: float, target: int = 6) -> np.ndarray:
    """Round tick values (1, 2, 2.5, 5 × 10^k apart) inside [lo, hi], about `target` of them."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo]) if math.isfinite(lo) else np.array([])
    raw = (hi - lo) / max(target - 1, 1)
    k = 10 ** math.floor(math.log10(raw))
    step = next(m * k for m in (1, 2, 2.5, 5, 10) if m * k >= raw * 0.999)
    first = math.ceil(lo / step - 1e-9)
    ticks = (first + np.arange(int(math.floor(hi / step + 1e-9)) - first + 1)) * step
    return np.round(ticks, 12) + 0.0


def tick_labels(ticks: np.ndarray) -> list[str]:
    """Plain labels with the decimals the step needs (a hyphen for minus: every font has it)."""
    if len(ticks) < 2:
        return [f"{v:g}" for v in ticks]
    step = float(np.min(np.diff(ticks)))
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    if not np.allclose(np.round(ticks, decimals), ticks, rtol=0, atol=step * 1e-6):
        decimals += 1
    return [f"{v:.{decimals}f}" for v in ticks]


@dataclass
class Frame:
    """The plot area on the page (points) and the data window it shows."""

    left: float
    top: float
    width: float
    height: float
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    invert_y: bool = False

    def x(self, v: np.ndarray | float) -> np.ndarray:
        lo, hi = self.xlim
        return self.left + (np.asarray(v, float) - lo) / (hi - lo) * self.width

    def y(self, v: np.ndarray | float) -> np.ndarray:
        lo, hi = self.ylim
        frac = (np.asarray(v, float) - lo) / (hi - lo)
        return self.top + (frac if self.invert_y else 1 - frac) * self.height

    def xy(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, float).reshape(-1, 2)
        return np.column_stack([self.x(xy[:, 0]), self.y(xy[:, 1])])


Mark = Callable[[Frame], str]


@dataclass
class LegendEntry:
    label: str
    colour: str
    kind: str = "patch"  # patch | line | marker-o | marker-x
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
    column_labels: tuple[np.ndarray, list[str], float] | None = None
    legend: list[LegendEntry] = field(default_factory=list)
    marks: list[tuple[int, Mark]] = field(default_factory=list)

    def add(self, mark: Mark, z: int = 2) -> None:
        self.marks.append((z, mark))

    # layout -----------------------------------------------------------------------------------

    def _ticks(self) -> tuple[np.ndarray, list[str], np.ndarray, list[str]]:
        xt = nice_ticks(*self.xlim) if self.xticks and not self.column_labels else np.array([])
        yt = nice_ticks(*self.ylim) if self.yticks else np.array([])
        return xt, tick_labels(xt), yt, tick_labels(yt)

    def _legend_width(self) -> float:
        if not self.legend:
            return PAD_PT * 2
        return 8 + 18 + max(text_width(e.label, LEGEND_PT) for e in self.legend) + PAD_PT

    def _column_extent(self) -> float:
        """How far the column labels reach below the axes (the figure grows by it)."""
        if self.column_labels is None:
            return 0.0
        _, labels, size = self.column_labels
        return TICK_PT + max((text_width(s, size) for s in labels), default=0)

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
        label = escape(self.title, quote=True)
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
            xs, labels, lsize = self.column_labels
            px = fr.x(np.asarray(xs, float)) + lsize * 0.35
            out += [
                text(p, y0 + TICK_PT, s, lsize, anchor="end", rotate=-90)
                for p, s in zip(px, labels, strict=True)
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
                out.append(markers_path(np.array([[x + 7, mid]]), e.kind[-1], e.colour, 5.0))
            out.append(text(x + 18, y + LEGEND_PT * 0.35 + 0.5, e.label, LEGEND_PT))
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


def wrap(s: str, size: float, width: float) -> list[str]:
    """Lines of `s` (its own line breaks kept) no wider than `width` pt, broken at spaces."""
    lines: list[str] = []
    for para in s.split("\n"):
        line = ""
        for word in para.split(" "):
            trial = f"{line} {word}" if line else word
            if line and text_width(trial, size) > width:
                lines.append(line)
                trial = word
            line = trial
        lines.append(line)
    return lines


def text(
    x: float,
    y: float,
    s: str,
    size: float,
    *,
    anchor: str = "start",
    rotate: float = 0.0,
    colour: str = TEXT,
) -> str:
    """One text element, its baseline at (x, y); the text escaped (ids come from deliveries)."""
    turn = f' transform="rotate({rotate:g} {x:.2f} {y:.2f})"' if rotate else ""
    return (
        f'<text x="{x:.2f}" y="{y:.2f}" font-size="{size:g}" text-anchor="{anchor}" '
        f'fill="{colour}"{turn}>'
        f"{escape(s, quote=False)}</text>"
    )


def segments_d(seg: np.ndarray) -> str:
    """The `d` of straight segments x0, y0, x1, y1 (n × 4, points)."""
    seg = np.asarray(seg, float).reshape(-1, 4)
    xy = seg.reshape(-1, 2)
    return path_d(xy, np.arange(0, len(xy), 2))


def markers_path(xy: np.ndarray, shape: str, colour: str, size: float) -> str:
    """Markers at `xy` (points): "o" filled discs, "x" crosses, `size` their width."""
    if len(xy) == 0:
        return ""
    r = size / 2
    if shape == "x":
        seg = np.column_stack(
            [xy - r, xy + r, xy[:, 0] - r, xy[:, 1] + r, xy[:, 0] + r, xy[:, 1] - r]
        )
        d = segments_d(seg.reshape(-1, 4))
        return f'<path d="{d}" stroke="{colour}" stroke-width="1.5" fill="none"/>'
    arc = f"a{r:g},{r:g} 0 1,0 {2 * r:g},0a{r:g},{r:g} 0 1,0 {-2 * r:g},0"
    d = "".join(map(("M{:.1f},{:.1f}" + arc).format, (xy[:, 0] - r).tolist(), xy[:, 1].tolist()))
    return f'<path d="{d}" fill="{colour}"/>'


def arrow_outlines(tail: np.ndarray, tip: np.ndarray, width: float) -> np.ndarray:
    """Outlines (n × 7 × 2, points) of arrows from `tail` to `tip` (n × 2): a shaft `width` pt
    wide, a head 3× as wide and 4.5× as long, both shrunk on arrows shorter than the head."""
    tail = np.asarray(tail, float)
    v = np.asarray(tip, float) - tail
    length = np.hypot(v[:, 0], v[:, 1])
    keep = length > 1e-6
    tail, v, length = tail[keep], v[keep], length[keep]
    u = v / length[:, None]
    n = np.column_stack([-u[:, 1], u[:, 0]])
    head = np.minimum(4.5 * width, length)[:, None]
    shrink = head / (4.5 * width)
    half, head_half = width / 2 * shrink, 1.5 * width * shrink
    neck = tail + u * (length[:, None] - head)
    return np.stack(
        [tail + n * half, neck + n * half, neck + n * head_half, tail + v, neck - n * head_half,
         neck - n * half, tail - n * half],
        axis=1,
    )  # fmt: skip


def disc_outlines(xy: np.ndarray, diameter: float, sides: int = 12) -> np.ndarray:
    """Regular polygons (n × sides × 2, points) standing for discs at `xy`."""
    a = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = np.column_stack([np.cos(a), np.sin(a)]) * diameter / 2
    return np.asarray(xy, float)[:, None, :] + ring[None, :, :]


def outlines_d(outlines: np.ndarray) -> str:
    """The `d` of closed outlines (n × k × 2, points)."""
    n, k = outlines.shape[:2]
    return path_d(outlines.reshape(-1, 2), np.arange(0, n * k, k), close=True)


#: above this many items (arrows, points), a layer is drawn as an image inside the SVG
RASTER_ABOVE = 400
RASTER_DPI = 150
LEVELS = 15  # coverage levels of an antialiased edge kept in the image's palette


def raster(fr: Frame, layers: list[tuple[str, np.ndarray]]) -> str:
    """Filled outlines (colour, n × k × 2 points) drawn as one antialiased image over the frame
    at RASTER_DPI, later layers over earlier ones: one image instead of thousands of shapes, in
    the browser and in the PDF alike. A palette image: each colour at LEVELS coverages."""
    import base64
    import io

    import cv2
    from PIL import Image

    px = RASTER_DPI / 72
    w, h = max(1, math.ceil(fr.width * px)), max(1, math.ceil(fr.height * px))
    index = np.zeros((h, w), np.uint8)
    origin = np.array([fr.left, fr.top])
    for k, (_, outlines) in enumerate(layers[: 255 // LEVELS]):
        mask = np.zeros((h, w), np.uint8)
        fixed = np.round((outlines - origin) * px * 16).astype(np.int32)  # 4 bits of subpixel
        cv2.fillPoly(mask, list(fixed), 255, lineType=cv2.LINE_AA, shift=4)
        level = (mask.astype(np.uint16) * LEVELS + 127) // 255
        np.copyto(index, (k * LEVELS + level).astype(np.uint8), where=level > 0)
    steps = np.arange(1, LEVELS + 1) / LEVELS
    palette = [(0, 0, 0)] + [tuple(_rgb(c)) for c, _ in layers for _ in steps]
    alpha = bytes([0] + [round(a * 255) for _ in layers for a in steps])
    image = Image.fromarray(index, "P")
    image.putpalette([v for rgb in palette for v in rgb])
    buf = io.BytesIO()
    image.save(buf, format="PNG", transparency=alpha, compress_level=6)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return (
        f'<image x="{fr.left:.2f}" y="{fr.top:.2f}" width="{fr.width:.2f}" '
        f'height="{fr.height:.2f}" preserveAspectRatio="none" href="data:image/png;base64,{data}"/>'
    )


def _rgb(colour: str) -> tuple[int, int, int]:
    """#rrggbb as three integers 0..255."""
    return int(colour[1:3], 16), int(colour[3:5], 16), int(colour[5:7], 16)


@dataclass
class Rings:
    """Closed rings in data coordinates: their vertices in one array, ring by ring."""

    xy: np.ndarray  # (m, 2)
    ring: np.ndarray  # (m,) the ring of each vertex, non-decreasing
    owner: np.ndarray  # (k,) what each ring belongs to (a scene's position)

    def select(self, keep: np.ndarray) -> Rings:
        """The rings where `keep` (one flag per ring) holds."""
        on = np.asarray(keep, bool)[self.ring]
        kept = np.flatnonzero(keep)
        return Rings(self.xy[on], np.searchsorted(kept, self.ring[on]), self.owner[kept])

    def starts(self) -> np.ndarray:
        if not len(self.ring):
            return np.zeros(0, int)
        return np.flatnonzero(np.r_[True, np.diff(self.ring) != 0])

    def centres(self) -> np.ndarray:
        """Mean of each ring's vertices, its closing vertex left out (k × 2)."""
        k = len(self.owner)
        if not len(self.ring):
            return np.zeros((0, 2))
        last = np.r_[self.starts()[1:], len(self.ring)] - 1
        n = np.bincount(self.ring, minlength=k) - 1.0
        sums = np.column_stack(
            [np.bincount(self.ring, self.xy[:, i], minlength=k) - self.xy[last, i] for i in (0, 1)]
        )
        return sums / np.maximum(n, 1)[:, None]

    def d(self, fr: Frame) -> str:
        return path_d(fr.xy(self.xy), self.starts(), close=True) if len(self.xy) else ""


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
    """Markers ("o" discs, "x" crosses) `size` pt wide; many discs drawn as an image."""
    xy = np.column_stack([np.asarray(x, float), np.asarray(y, float)])
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
    "bars",
    "arrows",
    "polygons",
    "segments",
    "hline",
    "vline",
    "markers",
    "label",
    "circle",
    "data_range",
    "Frame",
    "LegendEntry",
    "Plot",
    "RASTER_ABOVE",
    "arrow_outlines",
    "disc_outlines",
    "outlines_d",
    "raster",
    "markers_path",
    "nice_ticks",
    "path_d",
    "Rings",
    "segments_d",
    "text",
    "text_width",
    "tick_labels",
    "wrap",
]
