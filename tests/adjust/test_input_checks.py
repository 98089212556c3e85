"""`blockqc adjust`: DEM options and DEMs that cannot give heights, RPCs that do not fit their
scene, and scenes left without observations."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from blockqc.adjust.run import scene_warnings
from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
from blockqc.rfm.readers import read_rpc

VENTOUX = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
MODELS = [read_rpc(VENTOUX / "left_image.geom"), read_rpc(VENTOUX / "right_image.geom")]
GEOID = VENTOUX / "egm96_15_crop.gtx"


@pytest.fixture(scope="module")
def block(tmp_path_factory) -> Path:
    cfg = SyntheticConfig(scenes=2, observations_per_scene=100, checkpoints=0, seed=5)
    _, folder = synthetic_block(MODELS, cfg, tmp_path_factory.mktemp("syn") / "blk")
    return folder


def _dem(path: Path, value: float) -> Path:
    """A DEM over lon 4..7, lat 43..46 (0.01°), every cell `value` (-9999: all voids)."""
    with rasterio.open(
        path, "w", driver="GTiff", width=300, height=300, count=1, dtype="float32",
        crs="EPSG:4326", transform=from_origin(4.0, 46.0, 0.01, 0.01), nodata=-9999,
    ) as ds:  # fmt: skip
        ds.write(np.full((300, 300), value, np.float32), 1)
    return path


def test_geoid_without_dem_is_a_usage_error(block, tmp_path, blockqc):
    out = tmp_path / "out"
    r = blockqc("adjust", block, "--out", out, "--geoid", GEOID)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "--geoid given without --dem" in r.stderr
    assert not out.exists()
    r = blockqc("adjust", block, "--out", out, "--dem-sigma", "5")
    assert r.returncode == 2 and "--dem-sigma given without --dem" in r.stderr


ALL_HELD = (
    "all 2 scenes are held (--fix): nothing is adjusted; the points are the intersections of "
    "the RPCs as delivered, and the checkpoints compare the producer's positions with those, "
    "not with a recalculation"
)


def test_every_scene_held_is_warned_of_and_one_held_is_not(block, tmp_path, blockqc):
    """With both scenes held nothing is adjusted: said, in adjust.json and on the console; with
    one held the other is adjusted and nothing is said of it."""
    r = blockqc("adjust", block, "--out", tmp_path / "all", "--fix", "S0001", "--fix", "S0002")
    assert r.returncode == 0, r.stderr
    assert f"warning: {ALL_HELD}\n" in r.stderr
    assert ALL_HELD in json.loads((tmp_path / "all" / "adjust.json").read_text())["warnings"]
    r = blockqc("adjust", block, "--out", tmp_path / "one", "--fix", "S0001")
    assert r.returncode == 0, r.stderr
    assert "are held" not in r.stderr


def test_a_scene_fixed_twice_is_refused(block, tmp_path, blockqc):
    """`--fix S0001 --fix S0001` (S0002 meant, perhaps) was taken as one, and adjust.json
    listed S0001 twice among the fixed scenes."""
    out = tmp_path / "out"
    r = blockqc("adjust", block, "--out", out, "--fix", "S0001", "--fix", "S0001")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.endswith("Error: --fix S0001 given twice: give each --fix once\n")
    assert not out.exists()


def test_dem_with_no_height_under_the_block_is_refused(block, tmp_path, blockqc):
    dem = _dem(tmp_path / "voids.tif", -9999.0)
    r = blockqc("adjust", block, "--out", tmp_path / "out", "--dem", dem, "--geoid", GEOID)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{dem}: the DEM gives a height at none of the block's" in r.stderr
    assert "void there or does not cover the block" in r.stderr


def test_unknown_dem_reference_names_only_adjust_options(block, tmp_path, blockqc):
    dem = _dem(tmp_path / "plain.tif", 500.0)
    r = blockqc("adjust", block, "--out", tmp_path / "out", "--dem", dem)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "--geoid FILE" in r.stderr and "--dem-vertical ellipsoid" in r.stderr
    assert "--geoid-offset" not in r.stderr


def test_rpc_whose_domain_misses_the_footprint_is_refused(block, tmp_path, blockqc):
    """S0001's RPC with the lat/lon offsets and scales swapped: its domain is lon ~44°, lat ~5°,
    the scene's footprint lon ~5°, lat ~44°."""
    blk = tmp_path / "blk"
    shutil.copytree(block, blk)
    path = blk / "rpc" / "S0001.json"
    doc = json.loads(path.read_text())
    rpc = doc.get("rpc", doc)
    for a, b in (("lat_offset", "lon_offset"), ("lat_scale", "lon_scale")):
        rpc[a], rpc[b] = rpc[b], rpc[a]
    path.write_text(json.dumps(doc))
    r = blockqc("adjust", blk, "--out", tmp_path / "out")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{path}: the RPC's ground domain" in r.stderr
    assert "does not overlap the footprint_wkt of scene 'S0001' in scenes.csv" in r.stderr
    assert "S0002" not in r.stderr


def test_valid_block_has_no_warning(block, tmp_path, blockqc):
    out = tmp_path / "out"
    r = blockqc("adjust", block, "--out", out)
    assert r.returncode == 0 and "warning" not in r.stderr
    assert json.loads((out / "adjust.json").read_text())["warnings"] == []


def test_scene_left_without_observations_is_warned():
    rows = [
        {"scene_id": "S1", "n_observations": 0, "n_outliers": 100, "n_without_second_ray": 20},
        {"scene_id": "S2", "n_observations": 2, "n_outliers": 1, "n_without_second_ray": 0},
        {"scene_id": "S3", "n_observations": 3, "n_outliers": 50, "n_without_second_ray": 4},
        {"scene_id": "S4", "n_observations": 0, "n_outliers": 0, "n_without_second_ray": 0},
    ]
    assert scene_warnings(rows) == [
        "scene S1 keeps 0 of its 120 observations after outlier rejection (fewer than 3; 100 "
        "outliers, 20 left without a second ray): its affine is set by the priors alone, not by "
        "the data; check its RPC (rpc/) and its tie points",
        "scene S2 keeps 2 of its 3 observations after outlier rejection (fewer than 3; 1 "
        "outliers, 0 left without a second ray): its affine is set by the priors alone, not by "
        "the data; check its RPC (rpc/) and its tie points",
        "scene S4 has no tie-point observation: its affine is set by the priors alone, not by "
        "the data; check its RPC (rpc/) and its tie points",
    ]


def test_warnings_are_on_the_page(block, tmp_path, blockqc):
    from blockqc.adjust.report import render_html

    out = tmp_path / "out"
    assert blockqc("adjust", block, "--out", out).returncode == 0
    summary = json.loads((out / "adjust.json").read_text())
    assert "<h2>Warnings</h2>" not in render_html(summary)
    summary["warnings"] = ["scene S4 has no tie-point observation: check it"]
    assert "<li>scene S4 has no tie-point observation: check it</li>" in render_html(summary)


def test_the_per_scene_table_gives_the_unit_of_every_shift(block, tmp_path, blockqc):
    """The per-scene table headed its shifts and their σ 'a0', 'σ a0', 'b0', 'σ b0' with no
    unit, beside 'RMS (px)': the contract's a0 and b0 are image pixels, and so are their σ."""
    import re

    out = tmp_path / "out"
    assert blockqc("adjust", block, "--out", out).returncode == 0
    page = (out / "adjust.html").read_text()
    table = page[page.index("<h2>Per-scene precision</h2>") :]
    heads = re.findall(r"<th[^>]*>([^<]*)</th>", table[: table.index("</tr>")])
    for name in ("a0", "σ a0", "b0", "σ b0"):
        assert f"{name} (px)" in heads


def test_a_block_crs_in_feet_gives_checkpoints_in_metres_of_the_utm_zone():
    """block.yaml's EPSG:2263 (NY State Plane, US survey feet): the checkpoints' x_m, y_m, z_m
    are metres, so they are taken in the UTM zone of the block centre, and that is said (in
    feet, every plane difference was 3.28 times too large)."""
    from types import SimpleNamespace

    from blockqc.adjust.run import projected_crs
    from blockqc.report.format import Formatter

    sr = SimpleNamespace(epsg=2263)
    block = SimpleNamespace(data=SimpleNamespace(manifest=SimpleNamespace(spatial_reference=sr)))
    epsg, source = projected_crs(block, np.array([-74.0]), np.array([40.7]))
    assert epsg == 32618
    assert source == "UTM zone of the block centre (block.yaml's EPSG:2263 is not in metres)"
    assert Formatter("zh").sentence(source) == (
        "区域网中心所在的 UTM 投影带（block.yaml 的 EPSG:2263 不以米为单位）"
    )
