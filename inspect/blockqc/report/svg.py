"""Drawing on an SVG page: text, paths built over whole arrays, arrows, discs, rings and
antialiased raster layers, in points (1/72 in) with y down, as SVG has them.

Every path is formatted by str.format mapped over numpy columns: no Python loop per point.
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass
from functools import lru_cache
from html import escape
from pathlib import Path

import numpy as np

#: the packaged font first (the PDF declares it), then what a browser is likely to have
FONT_FAMILY = "'Blockqc Sans SC', 'DejaVu Sans', sans-serif"
TEXT = "#222"

#: characters XML 1.0 allows nowhere, not even escaped: C0 controls but tab, newline and
#: carriage return, lone surrogates, U+FFFE and U+FFFF
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_text(s: str, *, quote: bool = False) -> str:
    """`s` escaped for SVG text (`quote`: for an attribute's value), a character XML allows
    nowhere (an escape or NUL inside a delivered id) shown as U+FFFD: kept, it leaves the figure
    not well-formed, and WeasyPrint, which reads each figure of a PDF as an XML image, drops it."""
    return escape(_NOT_XML.sub("\ufffd", s), quote=quote)


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


#: texts are measured on this many characters at most: wider than any figure already, and
#: PIL refuses to lay out very long strings ("too many characters in string")
MAX_MEASURED = 2000


@lru_cache(maxsize=4096)
def text_width(text: str, size: float) -> float:
    """The advance of `text` at `size` pt, as DejaVu Sans sets it (CJK: one em per character).
    Control characters (a newline or NUL inside a delivered id) count as spaces: raqm cannot
    lay them out."""
    text = "".join(c if c.isprintable() else " " for c in text[:MAX_MEASURED])
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


def wrap(s: str, size: float, width: float) -> list[str]:
    """Lines of `s` (its own line breaks kept) no wider than `width` pt, broken at spaces; a word
    wider than a line (a run of Chinese, a long id) is cut where the line is full."""
    lines: list[str] = []
    for para in s.split("\n"):
        line = ""
        for word in para.split(" "):
            trial = f"{line} {word}" if line else word
            if line and text_width(trial, size) > width:
                lines.append(line)
                trial = word
            line = trial
            while len(line) > 1 and text_width(line, size) > width:
                k = _fitting(line, size, width)
                lines.append(line[:k])
                line = line[k:]
        lines.append(line)
    return lines


def cut(s: str, size: float, width: float) -> str:
    """`s`, or as much of it as fits in `width` pt followed by an ellipsis."""
    if text_width(s, size) <= width:
        return s
    return s[: _fitting(s, size, width - text_width("…", size))] + "…"


def _fitting(line: str, size: float, width: float) -> int:
    """How many leading characters of `line` fit in `width` pt (one at least)."""
    lo, hi = 1, min(len(line) - 1, MAX_MEASURED)  # the width grows with k: bisect
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if text_width(line[:mid], size) <= width:
            lo = mid
        else:
            hi = mid - 1
    return lo


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
        f"{xml_text(s)}</text>"
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

    layers = layers[: 255 // LEVELS]  # a palette holds 255 colours besides transparency
    px = RASTER_DPI / 72
    w, h = max(1, math.ceil(fr.width * px)), max(1, math.ceil(fr.height * px))
    index = np.zeros((h, w), np.uint8)
    origin = np.array([fr.left, fr.top])
    for k, (_, outlines) in enumerate(layers):
        outlines = outlines[np.isfinite(outlines).all(axis=(1, 2))]
        mask = np.zeros((h, w), np.uint8)
        fixed = np.clip((outlines - origin) * px * 16, -(2**26), 2**26)  # 4 bits of subpixel
        fixed = np.round(fixed).astype(np.int32)
        cv2.fillPoly(mask, list(fixed), 255, lineType=cv2.LINE_AA, shift=4)
        level = (mask.astype(np.uint16) * LEVELS + 127) // 255
        np.copyto(index, (k * LEVELS + level).astype(np.uint8), where=level > 0)
    steps = np.arange(1, LEVELS + 1) / LEVELS
    palette = [(0, 0, 0)] + [tuple(_rgb(c)) for c, _ in layers for _ in steps]
    alpha = bytes([0] + [round(a * 255) for _ in layers for a in steps])
    image = Image.fromarray(index, "P")
    image.putpalette([v for rgb in palette for v in rgb])
    buf = io.BytesIO()
    image.save(buf, format="PNG", transparency=alpha, compress_level=1)  # 4× faster, 8 % larger
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


__all__ = [
    "FONT_FAMILY",
    "RASTER_ABOVE",
    "Frame",
    "Rings",
    "arrow_outlines",
    "cut",
    "disc_outlines",
    "markers_path",
    "outlines_d",
    "path_d",
    "raster",
    "segments_d",
    "text",
    "text_width",
    "wrap",
]
