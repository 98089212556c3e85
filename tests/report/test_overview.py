"""The batch overview's block outline: the union of the block's scene footprints."""

from __future__ import annotations

import re

import numpy as np
import shapely

from blockqc.report.clusters import clusters
from blockqc.report.overview import block_extent, overview_map

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

    def block(bid: str, verdict: str, wkt: str) -> SimpleNamespace:
        return SimpleNamespace(block_id=bid, verdict=verdict, extent_wkt=wkt)

    def legend(blocks: list) -> list[str]:
        svg = "".join(overview_map(blocks, lambda key, **kw: key, "o"))
        return [k for k in ("verdict_pass", "verdict_fail", "verdict_error") if f">{k}<" in svg]

    assert legend([block("A", "pass", SQUARE_A), block("B", "error", FAR)]) == [
        "verdict_pass",
        "verdict_error",
    ]
    assert legend([block("A", "fail", SQUARE_A), block("B", "error", FAR)]) == [
        "verdict_fail",
        "verdict_error",
    ]


def _squares(
    corners: list[tuple[float, float]], side: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Outline vertices (lon/lat) of squares with lower-left corners given, and their block."""
    unit = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], float) * side
    xy = np.concatenate([unit + c for c in corners])
    return xy, np.repeat(np.arange(len(corners)), len(unit))


def test_two_groups_35_degrees_apart_are_two_clusters() -> None:
    """Fields near 5° and near 40° of longitude: the gap between them (lon × cos(lat): about
    26° of ground at these latitudes) is far more than 3 times either group's extent (2.1° at
    most), so the blocks fall into two groups, each block in its field's."""
    xy, block = _squares([(5, 44), (6.1, 44), (5, 45.1), (40, 39), (41.2, 39.1)])
    assert clusters(xy, block, 5).tolist() == [0, 0, 0, 1, 1]


def test_one_compact_group_is_one_cluster() -> None:
    """Four blocks 0.1° to 0.3° apart in a 2.2° square: one group, however uneven the gaps."""
    xy, block = _squares([(5, 44), (6.1, 44), (5, 45.3), (6.2, 45.2)])
    assert clusters(xy, block, 4).tolist() == [0, 0, 0, 0]


def test_groups_close_against_their_size_stay_one_cluster() -> None:
    """Two pairs of blocks 2° apart, each pair 2.1° wide: a gap below 3 extents, one map."""
    xy, block = _squares([(0, 0), (1.1, 0), (4.1, 0), (5.2, 0)])
    assert clusters(xy, block, 4).tolist() == [0, 0, 0, 0]


def test_three_groups_and_blocks_without_outline() -> None:
    """A pair of blocks sharing an edge at 0°, blocks at (20°, 0°) and (20°, 10°): cut into
    two, the gap of 18° is less than 3 times the eastern group's 11°; into three, the gap of 9°
    is more than 3 times the widest group's 2°: three groups. A block without an outline is in
    none (-1)."""
    xy, block = _squares([(0, 0), (1, 0), (20, 0), (20, 10)])  # blocks 0, 1 share an edge
    block = np.where(block >= 2, block + 1, block)  # block 2 has no outline
    labels = clusters(xy, block, 5)
    assert labels[2] == -1
    assert labels[0] == labels[1] and len({labels[0], labels[3], labels[4]}) == 3


def test_a_thousand_blocks_are_grouped_quickly() -> None:
    import time

    rng = np.random.default_rng(7)
    where = np.where(rng.random(1000)[:, None] < 0.5, [5.0, 44.0], [40.0, 39.0])
    corners = where + rng.uniform(-1, 1, (1000, 2))
    xy, block = _squares([tuple(c) for c in corners], side=0.1)
    start = time.perf_counter()
    labels = clusters(xy, block, 1000)
    assert time.perf_counter() - start < 2.0
    east = corners[:, 0] > 20
    assert (
        len(set(labels[east])) == len(set(labels[~east])) == 1
        and labels[east][0] != labels[~east][0]
    )


def _block(bid: str, verdict: str, wkt: str):
    from types import SimpleNamespace

    return SimpleNamespace(block_id=bid, verdict=verdict, extent_wkt=wkt)


def _square_wkt(x: float, y: float) -> str:
    return f"POLYGON(({x} {y}, {x + 1} {y}, {x + 1} {y + 1}, {x} {y + 1}, {x} {y}))"


def test_far_groups_get_a_locator_and_a_map_each_in_both_languages() -> None:
    """The batch's fields near 5° and near 40°: a locator and one map per group, west first,
    each framed on its own blocks (its ticks within them) and naming them."""
    from blockqc.report.messages import translator

    blocks = [
        _block("E-1", "fail", _square_wkt(40, 39)),
        _block("W-1", "pass", _square_wkt(5, 44)),
        _block("W-2", "pass", _square_wkt(6.1, 44)),
    ]
    for lang, group in (
        ("en", "Group A by verdict: 2 of the"),
        ("zh", "A 组区域网范围及检查结论：共 2 个"),
    ):
        maps = overview_map(blocks, translator(lang), "o")
        assert len(maps) == 3
        assert group in maps[1] and ">W-1<" in maps[1] and ">E-1<" not in maps[1]
        assert ">E-1<" in maps[2] and ">W-1<" not in maps[2]
        ticks = [float(x) for x in re.findall(r'text-anchor="middle"[^>]*>(-?[\d.]+)<', maps[1])]
        assert ticks and all(4.9 <= x <= 7.2 for x in ticks), ticks
    one = overview_map(blocks[1:], translator("en"), "o")
    assert len(one) == 1 and "Blocks of the batch by verdict<" in one[0]


def test_the_summary_page_shows_each_map_of_the_overview(tmp_path) -> None:
    """summary.html of a batch in two far groups: the locator and both groups' maps, before the
    blocks' table, which still links every block."""
    from report_helpers import make_summary, summary_entry

    from blockqc.report import write_summary_report

    blocks = [
        summary_entry("W-1", "pass", extent_wkt=_square_wkt(5, 44)),
        summary_entry("E-1", "fail", extent_wkt=_square_wkt(40, 39)),
    ]
    write_summary_report(tmp_path, make_summary(blocks), pdf=False)
    page = (tmp_path / "summary.html").read_text("utf-8")
    figure = page[page.index('<figure class="overview">') : page.index("</figure>")]
    assert figure.count("<svg") == 3
    assert "Group A by verdict: 1 of the batch" in figure
    assert "Group B by verdict: 1 of the batch" in figure
    assert 'href="W-1/report.html"' in page and 'href="E-1/report.html"' in page
