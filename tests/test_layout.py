"""Scenes whose footprints lie apart from the block's: said as input warnings, with the
distances worked out by hand on the plane the reading describes."""

from __future__ import annotations

import json
import math
import shutil

import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.layout import apart_scenes
from blockqc.report.format import Formatter
from casekit import SAMPLES


def _square(lon: float, lat: float, side: float = 0.1) -> str:
    """A lon/lat square of `side` degrees whose south-west corner is (lon, lat), longitudes
    written in −180..180."""
    w, e = (lon + 180) % 360 - 180, (lon + side + 180) % 360 - 180
    return f"POLYGON(({w} {lat}, {e} {lat}, {e} {lat + side}, {w} {lat + side}, {w} {lat}))"


def _grid(lon0: float, lat0: float, n: int = 3) -> list[str]:
    """n × n squares of 0.1° side by side (touching)."""
    return [_square(lon0 + 0.1 * i, lat0 + 0.1 * j) for j in range(n) for i in range(n)]


def _scenes(wkts: list[str]) -> pd.DataFrame:
    return pd.DataFrame({"scene_id": [f"S{i}" for i in range(len(wkts))], "footprint_wkt": wkts})


def test_a_block_side_by_side_gives_nothing() -> None:
    assert apart_scenes(_scenes(_grid(40.0, 39.5)), "scenes.csv") == []


def test_a_block_across_the_antimeridian_is_one_piece() -> None:
    """Squares from 179.9° E to 180.2° (written −179.8°): side by side across ±180°."""
    assert apart_scenes(_scenes(_grid(179.9, -16.0)), "scenes.csv") == []


def test_a_scene_moved_far_is_named_with_its_distance() -> None:
    """Nine squares at lon 0..0.3, lat 0..0.3 and a tenth moved to lon 10..10.1, lat 0..0.1: the
    plane's scale is cos(0.15°)·111.32 km per degree of longitude (the block's middle latitude:
    0.15°), 111.32 km per degree of latitude. The gap to the nearest square (its east edge at
    0.3°) is 9.7° of longitude; the moved square's size its diagonal."""
    scale = math.cos(math.radians(0.15)) * 111.32
    gap = 9.7 * scale
    size = math.hypot(0.1 * scale, 0.1 * 111.32)
    (found,) = apart_scenes(_scenes([*_grid(0.0, 0.0), _square(10.0, 0.0)]), "scenes.csv")
    assert (found.row, found.line, found.column) == (10, 11, "footprint_wkt")
    assert found.message == (
        f"scene 'S9' lies apart from the block: its footprint is {gap:,.0f} km from the nearest "
        f"of the block's other scenes ('S2'), more than 2 times its own size ({size:,.1f} km): "
        "expected the footprints of one block side by side (its coordinates in error?)"
    )
    assert f"{gap:,.0f}" == "1,080"


def test_a_scene_just_within_two_sizes_is_a_neighbour() -> None:
    """A square 0.25° east of the grid: its gap (0.25° of longitude, about 27.8 km) lies within
    twice its size (about 2 × 15.74 km), so it is the block's."""
    assert apart_scenes(_scenes([*_grid(0.0, 0.0), _square(0.55, 0.0)]), "scenes.csv") == []


def test_two_groups_of_equal_size_are_said_once() -> None:
    wkts = [*_grid(0.0, 0.0, 2), *_grid(20.0, 0.0, 2)]
    (found,) = apart_scenes(_scenes(wkts), "scenes.parquet")
    assert found.row is None and found.line is None
    assert found.message.startswith(
        "the scenes' footprints fall into 2 groups apart from each other (the largest 4 of 8 "
        "scenes), each more than 2 scene sizes from the others"
    )


@given(st.floats(-179.0, 179.0), st.floats(-60.0, 60.0), st.integers(2, 5), st.floats(-170, 170))
@settings(max_examples=50, deadline=None)
def test_only_the_moved_scene_is_named(lon: float, lat: float, n: int, shift: float) -> None:
    """A block of n × n squares anywhere; one more square moved at least 20° of longitude (on the
    other side of the globe as well): that one is named, and only it."""
    moved = lon + 0.05 * n + (20.0 if shift >= 0 else -20.0) + shift * 0.5
    found = apart_scenes(_scenes([*_grid(lon, lat, n), _square(moved, lat)]), "scenes.csv")
    assert [p.row for p in found] == [n * n + 1]


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_the_warning_is_a_catalogue_sentence(lang: str) -> None:
    (found,) = apart_scenes(_scenes([*_grid(0.0, 0.0), _square(10.0, 0.0)]), "scenes.csv")
    shown = Formatter(lang).sentence(str(found), ("iw_scene_apart",))
    if lang == "en":
        assert shown == str(found)
    else:
        assert shown.startswith("scenes.csv, row 10 (line 11), column 'footprint_wkt'：影像 'S9'")
        assert "1,080 千米" in shown and "（'S2'）" in shown


def test_inspect_says_it(tmp_path, blockqc) -> None:
    """The sample block with one scene's footprint moved to the other side of the globe: said on
    the console and kept in results.json; the delivery is judged as given."""
    block = tmp_path / "F1-B01"
    shutil.copytree(SAMPLES / "batch" / "F1-B01", block)
    scenes = pd.read_csv(block / "scenes.csv", dtype=str, keep_default_na=False)
    scenes.loc[1, "footprint_wkt"] = _square(-140.0, 39.6)
    scenes.to_csv(block / "scenes.csv", index=False)
    r = blockqc("inspect", block, "--out", tmp_path / "out", "--no-pdf")
    assert r.returncode in (0, 1), r.stderr
    said = f"{block / 'scenes.csv'}, row 2 (line 3), column 'footprint_wkt': scene '"
    assert f"warning: {said}" in r.stderr
    doc = json.loads((tmp_path / "out" / "F1-B01" / "results.json").read_text(encoding="utf-8"))
    assert [w for w in doc["input_warnings"] if w.startswith(said)]
