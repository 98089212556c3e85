"""DEM and geoid grids that cannot be used, and DEMs that cover only part of the image."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import CRS
from rasterio.transform import from_origin
from rfm_helpers import VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.dem import DEM, Grid, load_dem
from blockqc.rfm.pipeline import (
    RfmAccuracyConfig,
    image_without_height,
    no_cp_cause,
    run_warnings,
)
from blockqc.rfm.readers import read_rpc

SRTM = VENTOUX / "srtm_N44E005_crop.tif"
LEFT = read_rpc(VENTOUX / "left_image.geom")
CROP = (5000.0, 5000.0)  # left_image.tif: 500 × 500 px of the full image at row, col 5000
SHAPE = (500, 500)


def write_tif(path: Path, values: np.ndarray, west: float, north: float, step: float) -> Path:
    with rasterio.open(
        path, "w", driver="GTiff", width=values.shape[1], height=values.shape[0], count=1,
        dtype="float32", crs="EPSG:4326", transform=from_origin(west, north, step, step),
        nodata=-9999,
    ) as ds:  # fmt: skip
        ds.write(values.astype(np.float32), 1)
    return path


def test_degenerate_geotransform_is_an_input_error_naming_the_file(tmp_path: Path):
    """An SRTM tile renamed .gtx is read by GDAL's GTX driver with pixel sizes ~1e-305°."""
    bad = write_tif(tmp_path / "tiny.tif", np.full((20, 20), 500.0), 5.0, 45.0, 1e-300)
    with pytest.raises(InputError) as exc:
        load_dem(bad, vertical="ellipsoid", bounds=(5.1, 44.1, 5.2, 44.2))
    text = str(exc.value)
    assert text.startswith(str(bad)) and "the DEM has a degenerate geotransform" in text
    assert "pixel size 1e-300 × 1e-300" in text
    with pytest.raises(InputError) as exc:
        load_dem(SRTM, geoid=bad)
    text = str(exc.value)
    assert text.startswith(str(bad)) and "the geoid grid has a degenerate geotransform" in text


def test_unknown_reference_names_only_the_options_the_command_has():
    """`adjust` has no --geoid-offset: its message must not send the user to it."""
    with pytest.raises(InputError) as exc:
        load_dem(SRTM, offset_option=None)
    text = str(exc.value)
    assert "--geoid-offset" not in text
    assert "--geoid egm96" in text and "--geoid FILE" in text and "--dem-vertical ellipsoid" in text


def _centre_lon() -> float:
    lon, _, _ = LEFT.image_to_ground(np.array([5250.0]), np.array([5250.0]), 500.0)
    return float(lon[0])


def test_share_of_the_image_outside_the_dem_and_on_its_voids(tmp_path: Path):
    """A flat DEM ending at the image centre's longitude: half the image is outside it; a void
    over the northern half of what it covers adds a quarter on voids."""
    east = _centre_lon()
    step = 0.0001  # 11 m: bilinear sampling widens a void by up to a cell, the image is 250 m
    n_cols = round((east - 5.1) / step)
    values = np.full((1000, n_cols), 500.0)
    half = write_tif(tmp_path / "half.tif", values, east - n_cols * step, 44.3, step)
    dem = load_dem(half, vertical="ellipsoid")
    outside, void = image_without_height(LEFT, SHAPE, CROP, dem)
    assert outside == pytest.approx(0.5, abs=0.03) and void == 0.0
    _, lat, _ = LEFT.image_to_ground(np.array([5250.0]), np.array([5250.0]), 500.0)
    values[: round((44.3 - lat[0]) / step)] = np.nan  # north of the image centre
    holed = DEM(Grid(values, dem.grid.transform, dem.grid.crs, str(half)), "test")
    outside, void = image_without_height(LEFT, SHAPE, CROP, holed)
    assert outside == pytest.approx(0.5, abs=0.03) and void == pytest.approx(0.25, abs=0.03)


def test_run_warns_of_the_image_without_heights(tmp_path: Path):
    cfg = RfmAccuracyConfig(
        image=Path("a.tif"), dem=Path("dem/partial.tif"), reference=Path("r.tif"), out=tmp_path
    )
    dem = load_dem(SRTM, geoid="egm96")
    warnings = run_warnings(cfg, dem, 60, 25, (0.5, 0.02))
    assert warnings == [
        "52.0% of the image has no height from the DEM partial.tif (50.0% outside it, 2.0% on "
        "its voids (--dem-fill-voids N closes small ones)): those pixels stay empty in ortho.tif "
        "and give no CP"
    ]
    assert run_warnings(cfg, dem, 60, 25, (0.0, 0.0)) == []


def test_scattered_voids_are_named_as_the_cause_of_no_cp():
    """5 % of the image empty in 3 × 3 px holes every 20 px: no 50 px matching window is free of
    them although the DEM's void share is far below 20 %."""
    rng = np.random.default_rng(3)
    image = rng.uniform(0, 100, (600, 600))
    for r in range(5, 600, 20):
        for c in range(5, 600, 20):
            image[r : r + 3, c : c + 3] = np.nan
    dem_values = np.full((100, 100), 500.0)
    dem_values[::20, ::20] = np.nan
    dem = DEM(Grid(dem_values, from_origin(5.0, 45.0, 0.01, 0.01), CRS.from_epsg(4326)), "test")
    reason = no_cp_cause(image, np.isfinite(image), dem, 0)[1]
    assert reason.startswith("no control point found: DEM voids scattered across the image")
    assert "--dem-fill-voids" in reason and "100% of the 50 px matching windows" in reason
    # the same image without holes: the texture is blamed
    reason = no_cp_cause(np.nan_to_num(image), np.ones(image.shape, bool), dem, 0)[1]
    assert "no texture" in reason and "0% of the 50 px matching windows" in reason


def test_scattered_voids_are_named_also_when_the_dem_misses_half_of_the_image():
    """The s2p Réunion pair on its own DSM (721 × 739 px, 11 % voids): 52 % of img_01 lies
    outside the DSM, and every matching window of the rest touches a void. The run said "the DEM
    does not reach most of the image: give a DEM that covers the image", where closing the
    voids (--dem-fill-voids 5) gave 95 CPs. Here: the left 52 % of the grid without a height,
    3 × 3 px holes every 20 px over the rest."""
    rng = np.random.default_rng(5)
    image = rng.uniform(0, 100, (600, 600))
    image[:, :312] = np.nan
    for r in range(5, 600, 20):
        for c in range(317, 600, 20):
            image[r : r + 3, c : c + 3] = np.nan
    dem_values = np.full((100, 100), 500.0)
    dem_values[::9, ::9] = np.nan  # 1.4 % of the DSM's window
    dem = DEM(Grid(dem_values, from_origin(5.0, 45.0, 0.01, 0.01), CRS.from_epsg(4326)), "test")
    reason = no_cp_cause(image, np.isfinite(image), dem, 0, no_height=(0.52, 0.024))[1]
    assert reason.startswith("no control point found: DEM voids scattered across the image")
    assert "--dem-fill-voids" in reason and "image outside the DEM 52%" in reason
    # the covered part without holes: the DEM's reach is the cause, as before
    image[:, 312:] = np.nan_to_num(image[:, 312:])
    reason = no_cp_cause(image, np.isfinite(image), dem, 0, no_height=(0.52, 0.0))[1]
    assert "the DEM does not reach most of the image (52% of it is outside" in reason


def test_a_dem_that_misses_most_of_the_image_is_named_as_the_cause_of_no_cp(tmp_path: Path):
    """The SRTM crop cut at lon 5.1945° leaves 89 % of the image without a height: the run
    said 'DEM voids: most of the image has no height (fill voids with --dem-fill-voids?)' of a
    DEM without a void (and 'DEM voids 0 %' in the same line)."""
    from click.testing import CliRunner

    from blockqc.rfm.command import command

    with rasterio.open(SRTM) as ds:
        cols = int((5.1945 - ds.transform.c) / ds.transform.a)
        values = ds.read(1)[:, :cols].astype(np.float32)
        west, north, step = ds.transform.c, ds.transform.f, ds.transform.a
    dem = write_tif(tmp_path / "dem_west.tif", values, west, north, step)
    args = [
        str(VENTOUX / "left_image.tif"), "--rpc", str(VENTOUX / "left_image.geom"),
        "--dem", str(dem), "--geoid", "egm96",
        "--reference", str(VENTOUX / "right_image.tif"),
        "--reference-rpc", str(VENTOUX / "right_image.geom"),
        "--out", str(tmp_path / "out"),
    ]  # fmt: skip
    result = CliRunner().invoke(command, args)
    assert isinstance(result.exception, InputError)  # exit 2
    message = str(result.exception)
    assert "no control point found: the DEM does not reach most of the image (" in message
    assert "of it is outside dem_west.tif): give a DEM that covers the image" in message
    assert "--dem-fill-voids" not in message


def test_a_dem_of_voids_only_is_not_said_to_miss_the_image(tmp_path: Path):
    """A DEM of no-data only over the image was 'the DEM does not cover the image footprint'
    though it does: it has no height there."""
    from blockqc.rfm.ortho import ortho_grid

    with rasterio.open(SRTM) as ds:
        shape, t = (ds.height, ds.width), ds.transform
    dem_file = write_tif(tmp_path / "voids.tif", np.full(shape, -9999.0), t.c, t.f, t.a)
    dem = load_dem(dem_file, geoid_offset=50.8)
    with pytest.raises(InputError) as exc:
        ortho_grid(LEFT, SHAPE, dem, crop_offset=CROP)
    assert str(exc.value).startswith(
        f"{dem_file}: the DEM holds no height over the image footprint, only voids (no-data) "
        "(lon 5.19"
    )
