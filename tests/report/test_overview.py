"""The batch overview's block outline: the union of the block's scene footprints."""

from __future__ import annotations

import shapely

from blockqc.report.overview import block_extent

SQUARE_A = "POLYGON((0 0, 1 0, 1 1, 0 1, 0 0))"
SQUARE_B = "POLYGON((0.5 0, 1.5 0, 1.5 1, 0.5 1, 0.5 0))"
FAR = "POLYGON((3 3, 4 3, 4 4, 3 4, 3 3))"


def test_the_outline_is_the_union_of_the_footprints_each_counted_once() -> None:
    """PAN and MS scenes of one acquisition give the same footprint twice; a scene without a
    footprint is passed over. By hand: 1.5 × 1 for the overlapping pair, 1 for the far one."""
    scenes = [
        {"footprint_wkt": SQUARE_A},
        {"footprint_wkt": SQUARE_A},
        {"footprint_wkt": SQUARE_B},
        {"footprint_wkt": None},
        {"footprint_wkt": FAR},
        {"footprint_wkt": SQUARE_B},
    ]
    outline = shapely.from_wkt(block_extent(scenes))
    assert outline.area == 2.5
    assert outline.bounds == (0.0, 0.0, 4.0, 4.0)
    assert len(shapely.get_parts(outline)) == 2


def test_no_footprint_gives_no_outline() -> None:
    assert block_extent([{"footprint_wkt": None}, {}]) is None
