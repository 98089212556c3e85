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


def test_the_overview_legend_names_the_verdicts_drawn() -> None:
    """A batch whose only red block is in error (a rule could not be judged) was keyed FAIL;
    the legend names the verdicts shown: ERROR for it, FAIL only beside a failing block."""
    from types import SimpleNamespace

    from blockqc.report.overview import overview_map

    def block(bid: str, verdict: str, wkt: str) -> SimpleNamespace:
        return SimpleNamespace(block_id=bid, verdict=verdict, extent_wkt=wkt)

    def legend(blocks: list) -> list[str]:
        svg = overview_map(blocks, lambda key, **kw: key, "o")
        return [k for k in ("verdict_pass", "verdict_fail", "verdict_error") if f">{k}<" in svg]

    assert legend([block("A", "pass", SQUARE_A), block("B", "error", FAR)]) == [
        "verdict_pass",
        "verdict_error",
    ]
    assert legend([block("A", "fail", SQUARE_A), block("B", "error", FAR)]) == [
        "verdict_fail",
        "verdict_error",
    ]
