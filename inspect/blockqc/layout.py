"""Whether the scenes of a block lie together: a footprint far from all the others.

A block is scenes side by side, each overlapping or near its neighbours. A footprint whose
coordinates are in error (a longitude's sign lost, a row copied from another block) puts its
scene far from the rest. No rule is about it, but it is not harmless: MB-3 reads the block's
zone from the extent of every footprint, and a scene 140° away made a block at 40° E
"straddle a zone edge" with zones 1N, 37N and 49N. It is said as an input warning.

Reading: two scenes are neighbours when their footprints' boxes lie within GAP_SIZES times
either one's size (the diagonal of its box) of each other; the block's scenes are those
connected to the largest group of neighbours. Distances are taken on a plane about the block
(longitudes east of the block's widest gap, so that a block across ±180° is one piece;
kilometres at the block's middle latitude): rough far from the block, which is all a warning
needs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import shapely

from blockqc.errors import Problem
from blockqc.rfm.model import lon_extent
from blockqc.schema import MAX_ROWS_LISTED

#: neighbours lie within this many of the larger one's sizes: strips side by side overlap, and
#: a gap of two scene sizes is none that a block adjusted as one has
GAP_SIZES = 2.0
KM_PER_DEGREE = 111.32  # a degree of latitude, and of longitude at the equator


def _on_plane(geoms: np.ndarray) -> np.ndarray:
    """Footprints (lon/lat) on a plane about the block, in km."""
    xy = shapely.get_coordinates(geoms)
    west, _ = lon_extent(xy[:, 0])
    south, north = xy[:, 1].min(), xy[:, 1].max()
    scale = np.cos(np.radians((south + north) / 2)) * KM_PER_DEGREE

    def plane(c: np.ndarray) -> np.ndarray:
        x = (np.mod(c[:, 0] - west, 360.0)) * scale
        return np.column_stack([x, (c[:, 1] - south) * KM_PER_DEGREE])

    return shapely.transform(geoms, plane)


def _groups(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A label per scene, the same for scenes joined by the pairs (a, b): the smallest index
    of each group, found by passing labels along the pairs and jumping to the label's label
    until none changes."""
    label = np.arange(n)
    while True:
        new = label.copy()
        np.minimum.at(new, a, label[b])
        np.minimum.at(new, b, label[a])
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new


def apart_scenes(scenes: pd.DataFrame, file: Path | str) -> list[Problem]:
    """The scenes whose footprints lie apart from the block's (`GAP_SIZES`), each named with
    its row, the distance to the nearest scene of the block and its own size; or, when no group
    holds more than half the scenes, one problem saying how the footprints fall apart."""
    if "footprint_wkt" not in scenes.columns or len(scenes) < 2:
        return []
    geoms = shapely.from_wkt(scenes["footprint_wkt"].to_numpy(dtype=object), on_invalid="ignore")
    rows = np.flatnonzero(~shapely.is_missing(geoms) & ~shapely.is_empty(geoms))
    if rows.size < 2:
        return []
    plane = _on_plane(geoms[rows])
    x0, y0, x1, y1 = shapely.bounds(plane).T
    size = np.hypot(x1 - x0, y1 - y0)
    reach = GAP_SIZES * size  # boxes widened by it meet (a box's gap is at most the shapes')
    a, b = shapely.STRtree(plane).query(shapely.box(x0 - reach, y0 - reach, x1 + reach, y1 + reach))
    label = _groups(rows.size, a, b)
    counts = np.bincount(label, minlength=rows.size)
    block = int(np.argmax(counts))
    if counts[block] == rows.size:
        return []
    if 2 * counts[block] <= rows.size:
        return [_fallen_apart(file, int((counts > 0).sum()), int(counts[block]), rows.size)]
    inside = np.flatnonzero(label == block)
    outside = np.flatnonzero(label != block)
    near, gap = shapely.STRtree(plane[inside]).query_nearest(
        plane[outside], return_distance=True, all_matches=False
    )
    ids = scenes["scene_id"].to_numpy(dtype=object)
    return [
        _apart(file, rows[outside[i]], ids, rows[inside[j]], gap[k], size[outside[i]])
        for k, (i, j) in enumerate(zip(*near, strict=True))
    ][:MAX_ROWS_LISTED]


def _apart(
    file: Path | str, row: int, ids: np.ndarray, nearest: int, gap_km: float, size_km: float
) -> Problem:
    return Problem.at_row(
        file,
        row,
        f"scene '{ids[row]}' lies apart from the block: its footprint is {gap_km:,.0f} km from "
        f"the nearest of the block's other scenes ('{ids[nearest]}'), more than "
        f"{GAP_SIZES:g} times its own size ({size_km:,.1f} km): expected the footprints of one "
        "block side by side (its coordinates in error?)",
        column="footprint_wkt",
    )


def _fallen_apart(file: Path | str, groups: int, largest: int, n: int) -> Problem:
    return Problem(
        str(file),
        f"the scenes' footprints fall into {groups} groups apart from each other (the largest "
        f"{largest} of {n} scenes), each more than {GAP_SIZES:g} scene sizes from the others: "
        "expected the footprints of one block side by side (coordinates in error?)",
        column="footprint_wkt",
    )
