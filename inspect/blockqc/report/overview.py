"""The batch overview map: every block's footprint, coloured by its verdict (offline SVG).

Blocks lying in groups far apart (fields near 5° and near 40° of longitude) would be specks on
one map: each group then has a map of its own, at its own scale, after a small locator map
showing where the groups lie (blockqc.report.clusters finds them).
"""

from __future__ import annotations

import string
from collections.abc import Callable
from typing import Any

import numpy as np

from blockqc.report import plots, svg, svgplot
from blockqc.report.clusters import clusters, group_bounds

#: a block's outline is simplified to about this many degrees (~100 m), enough for a map
SIMPLIFY_DEG = 0.001
#: the least size (pt) of a group's box on the locator map, however small the group
LOCATOR_BOX_PT = 9.0


def block_extent(scenes: list[dict[str, Any]]) -> str | None:
    """The union of a block's scene footprints (lon/lat) as WKT, simplified; None without any."""
    import shapely

    wkts = dict.fromkeys(s.get("footprint_wkt") for s in scenes)  # a PAN and MS pair once
    geoms = plots.geometries(list(wkts))
    geoms = geoms[~shapely.is_missing(geoms)]
    geoms = shapely.make_valid(geoms[shapely.get_type_id(geoms) >= 0])
    if len(geoms) == 0:
        return None
    union = shapely.union_all(geoms).simplify(SIMPLIFY_DEG)
    return None if union.is_empty else union.wkt


def overview_map(blocks: list[Any], t: Callable[..., str], name: str) -> list[str] | None:
    """The overview as one map, or a locator map and one map per group of nearby blocks; None
    when no block has a footprint."""
    rings = plots.rings_of(plots.geometries([b.extent_wkt for b in blocks]))
    if not len(rings.owner):
        return None
    verdict = np.array([b.verdict for b in blocks], dtype=object)
    ids = np.array([b.block_id for b in blocks], dtype=object)
    group = _west_to_east(clusters(rings.xy, rings.owner[rings.ring], len(blocks)), rings)
    k = int(group.max()) + 1
    if k == 1:
        return [_panel(rings, verdict, ids, t("fig_overview"), (4.8, 6.2), t).svg(name)]
    letters = list(string.ascii_uppercase[:k])
    maps = [_locator(rings, group, verdict, letters, t).svg(f"{name}-where")]
    for g, letter in enumerate(letters):
        mine = rings.select(group == g)
        n = len(np.unique(mine.owner))
        title = t("fig_overview_group", group=letter, n=n)
        maps.append(_panel(mine, verdict, ids, title, (3.0, 3.3), t).svg(f"{name}-{letter}"))
    return maps


def _west_to_east(labels: np.ndarray, rings: svg.Rings) -> np.ndarray:
    """The group of each ring, the groups numbered by their westernmost longitude."""
    group = labels[rings.owner]
    west = group_bounds(rings.xy, group[rings.ring], int(group.max()) + 1)[0][:, 0]
    return np.argsort(np.argsort(west, kind="stable"))[group]


def _colours(verdict: np.ndarray) -> np.ndarray:
    """Each ring's fill: green for a pass, red for a failure or an error."""
    red, green = plots.STATUS_COLOURS["fail"], plots.STATUS_COLOURS["pass"]
    return np.where(verdict == "pass", green, red).astype(object)


def _legend(verdict: np.ndarray, t: Callable[..., str]) -> list[svgplot.LegendEntry]:
    """The verdicts drawn: an error (a rule not judged) red as a failure, and named so."""
    present = set(verdict.tolist())
    return [
        svgplot.LegendEntry(t(f"verdict_{k}"), plots.STATUS_COLOURS[k], alpha=0.6)
        for k in ("pass", "fail", "error")
        if k in present
    ]


def _panel(
    rings: svg.Rings,
    verdict: np.ndarray,
    ids: np.ndarray,
    title: str,
    size: tuple[float, float],
    t: Callable[..., str],
) -> svgplot.Plot:
    """One map of the rings' blocks, framed on them, filled by verdict, named when few."""
    mine = verdict[rings.owner]
    plot = plots.lonlat_plot(rings, t, title, *size)
    plot.add(svgplot.polygons(rings, _colours(mine), 0.45, 0.6))
    if len(np.unique(rings.owner)) <= plots.MAX_FOOTPRINT_LABELS:  # few blocks: name them
        plot.add(plots.ring_labels(rings, ids, plots.MAX_FOOTPRINT_LABELS), z=4)
    plot.legend += _legend(mine, t)
    return plot


def _locator(
    rings: svg.Rings,
    group: np.ndarray,
    verdict: np.ndarray,
    letters: list[str],
    t: Callable[..., str],
) -> svgplot.Plot:
    """The whole batch, small: the blocks by verdict and a lettered box round each group."""
    mine = verdict[rings.owner]
    plot = plots.lonlat_plot(rings, t, t("fig_overview_where"), 2.6, 4.2)
    plot.xlim, plot.ylim = _roomy(plot.xlim, plot.ylim, plot.aspect or 1.0)
    plot.add(svgplot.polygons(rings, _colours(mine), 0.45, 0.6))
    lo, hi = group_bounds(rings.xy, group[rings.ring], len(letters))
    plot.add(_group_boxes(lo, hi, letters), z=4)
    plot.legend += _legend(mine, t)
    plot.legend.append(svgplot.LegendEntry(t("lg_overview_group"), "#333", "line"))
    return plot


def _roomy(
    xlim: tuple[float, float], ylim: tuple[float, float], aspect: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """A locator's window widened by a tenth for the boxes and letters at its edges, and at
    least 0.4 as high as wide on the page (groups far apart east-west would draw a strip)."""
    (x0, x1), (y0, y1) = xlim, ylim
    w, h = (x1 - x0) * 1.2, max((y1 - y0) * 1.2, 0.4 * (x1 - x0) * 1.2 / aspect)
    xm, ym = (x0 + x1) / 2, (y0 + y1) / 2
    return (xm - w / 2, xm + w / 2), (ym - h / 2, ym + h / 2)


def _group_boxes(lo: np.ndarray, hi: np.ndarray, letters: list[str]) -> svgplot.Mark:
    """A box round each group (lon/lat corners lo, hi), at least LOCATOR_BOX_PT on the page,
    its letter at its upper right: one path for the boxes."""

    def draw(fr: svg.Frame) -> str:
        a, b = fr.xy(lo), fr.xy(hi)  # page y grows downwards: b is the upper corner
        mid, half = (a + b) / 2, np.maximum(np.abs(b - a) / 2 + 2, LOCATOR_BOX_PT / 2)
        x0, y0, x1, y1 = (mid - half).T.tolist() + (mid + half).T.tolist()
        corners = np.stack([x0, y0, x1, y0, x1, y1, x0, y1], axis=1).reshape(-1, 2)
        d = svg.path_d(corners, np.arange(0, len(corners), 4), close=True)
        box = f'<path d="{d}" fill="none" stroke="#333" stroke-width="0.9"/>'
        return box + "".join(
            svg.text(x + 2, y - 2, s, 8, colour="#111")
            for x, y, s in zip(x1, y0, letters, strict=True)
        )

    return draw
