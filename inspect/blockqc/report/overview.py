"""The batch overview map: every block's footprint, coloured by its verdict (offline SVG)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from blockqc.report import plots, svgplot

#: a block's outline is simplified to about this many degrees (~100 m), enough for a map
SIMPLIFY_DEG = 0.001


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


def overview_map(blocks: list[Any], t: Callable[..., str], name: str) -> str | None:
    """One map of the batch: block outlines filled by verdict (pass, fail, error)."""
    rings = plots.rings_of(plots.geometries([b.extent_wkt for b in blocks]))
    if not len(rings.owner):
        return None
    verdict = np.array([b.verdict for b in blocks], dtype=object)[rings.owner]
    colours = np.where(
        verdict == "pass", plots.STATUS_COLOURS["pass"], plots.STATUS_COLOURS["fail"]
    )
    plot = plots.lonlat_plot(rings, t, t("fig_overview"), 4.8, 6.2)
    plot.add(svgplot.polygons(rings, colours.astype(object), 0.45, 0.6))
    if len(blocks) <= plots.MAX_FOOTPRINT_LABELS:  # few blocks: name them
        ids = np.array([b.block_id for b in blocks], dtype=object)
        plot.add(plots.ring_labels(rings, ids, plots.MAX_FOOTPRINT_LABELS), z=4)
    present = set(verdict.tolist())
    plot.legend += [  # an error (a rule not judged) red as a failure, and named so
        svgplot.LegendEntry(t(f"verdict_{k}"), plots.STATUS_COLOURS[k], alpha=0.6)
        for k in ("pass", "fail", "error")
        if k in present
    ]
    return plot.svg(name)
