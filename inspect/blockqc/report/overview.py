"""The batch overview map: every block's footprint, coloured by its verdict (offline SVG)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from blockqc.report import plots

#: a block's outline is simplified to about this many degrees (~100 m), enough for a map
SIMPLIFY_DEG = 0.001


def block_extent(scenes: list[dict[str, Any]]) -> str | None:
    """The union of a block's scene footprints (lon/lat) as WKT, simplified; None without any."""
    import shapely

    wkts = np.array([s.get("footprint_wkt") for s in scenes], dtype=object)
    wkts = np.where([isinstance(w, str) for w in wkts], wkts, None)
    geoms = shapely.from_wkt(wkts, on_invalid="ignore")
    geoms = geoms[~shapely.is_missing(geoms)]
    geoms = shapely.make_valid(geoms[shapely.get_type_id(geoms) >= 0])
    if len(geoms) == 0:
        return None
    union = shapely.union_all(geoms).simplify(SIMPLIFY_DEG)
    return None if union.is_empty else union.wkt


def overview_map(blocks: list[Any], t: Callable[..., str], name: str) -> str | None:
    """One map of the batch: block outlines filled by verdict (pass, fail, error)."""
    wkts = [b.extent_wkt for b in blocks]
    rings, owner = plots._rings(wkts)
    if not rings:
        return None
    verdict = np.array([blocks[i].verdict for i in owner], dtype=object)
    fig, ax = plots._figure(4.8, 6.2)
    colours = [plots.STATUS_COLOURS["fail" if v != "pass" else "pass"] for v in verdict]
    col = plots.PolyCollection(rings, facecolors=colours, edgecolors=colours, alpha=0.45, lw=0.6)
    col.set_rasterized(len(rings) > plots.RASTER_ABOVE)
    ax.add_collection(col)
    if len(blocks) <= plots.MAX_FOOTPRINT_LABELS:  # few blocks: name them
        ids = [b.block_id for b in blocks]
        plots._label_footprints(ax, rings, owner, ids, np.ones(len(rings), dtype=bool))
    plots.lonlat_axes(ax, rings, t, t("fig_overview"))
    present = set(verdict)
    handles = [
        plots.Patch(fc=plots.STATUS_COLOURS[k], alpha=0.6, label=t(f"verdict_{k}"))
        for k in ("pass", "fail")
        if k in present or (k == "fail" and "error" in present)
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return plots._svg(fig, name)
