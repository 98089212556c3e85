"""Chunked orthorectification (§RA-1) checked against direct ground→image sampling with GDAL."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import CRS, Transformer
from rasterio.transform import Affine
from rfm_helpers import VENTOUX, gdal_transformer

from blockqc.errors import InputError
from blockqc.rfm.dem import DEM, Grid, constant_height, load_dem
from blockqc.rfm.ortho import (
    crop_offset_from_file,
    image_gsd,
    ortho_grid,
    orthorectify,
    read_ortho,
    utm_ups_crs,
)
from blockqc.rfm.readers import read_rpc

LEFT = read_rpc(VENTOUX / "left_image.geom")
CROP = (5000.0, 5000.0)  # the left crop's position in the full image (its geotransform)


def ramp(row, col):
    """A linear image: bilinear resampling reproduces it exactly at any position."""
    return 100.0 + 0.5 * row + 0.25 * col


@pytest.fixture(scope="module")
def dem():
    return load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")


@pytest.fixture()
def ramp_image(tmp_path: Path) -> Path:
    rows, cols = np.mgrid[0:120, 0:150].astype(np.float64)
    path = tmp_path / "ramp.tif"
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=150,
        height=120,
        count=1,
        dtype="float32",
        transform=Affine(1, 0, CROP[1], 0, 1, CROP[0]),
    ) as ds:
        ds.write(ramp(rows, cols).astype(np.float32), 1)
    return path


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_ortho_matches_direct_sampling_through_gdal(ramp_image: Path, tmp_path: Path, dem):
    assert crop_offset_from_file(ramp_image) == CROP
    grid = orthorectify(ramp_image, LEFT, dem, tmp_path / "ortho.tif", chunk=40)
    values, grid_read = read_ortho(tmp_path / "ortho.tif")
    assert grid_read.transform == grid.transform and grid_read.crs == utm_ups_crs(5.19, 44.2)
    assert 0.45 < grid.gsd < 0.55  # Pléiades PAN, ~0.5 m
    # expected value of every output pixel, computed independently: pixel centre → lon/lat
    # (pyproj) → height (DEM) → GDAL's RPC transformer (pixel corner) → file pixel → ramp
    rr, cc = np.mgrid[0 : grid.height, 0 : grid.width].astype(np.float64)
    x = grid.transform.c + (cc + 0.5) * grid.transform.a
    y = grid.transform.f + (rr + 0.5) * grid.transform.e
    lon, lat = Transformer.from_crs(grid.crs, 4326, always_xy=True).transform(x, y)
    h = dem.height(lon, lat)
    with gdal_transformer(LEFT) as t:
        g_row, g_col = t.rowcol(lon.ravel(), lat.ravel(), h.ravel(), op=float)
    row = np.asarray(g_row).reshape(lon.shape) - 0.5 - CROP[0]
    col = np.asarray(g_col).reshape(lon.shape) - 0.5 - CROP[1]
    inside = (row >= 0) & (row <= 119) & (col >= 0) & (col <= 149)
    outside = (row < -0.5) | (row > 119.5) | (col < -0.5) | (col > 149.5)
    assert inside.sum() > 0.5 * values.size
    np.testing.assert_allclose(values[inside], ramp(row, col)[inside], atol=2e-3)
    assert np.isnan(values[outside]).all()


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_chunk_size_does_not_change_the_result(ramp_image: Path, tmp_path: Path, dem):
    grid = orthorectify(ramp_image, LEFT, dem, tmp_path / "a.tif", chunk=1024)
    orthorectify(ramp_image, LEFT, dem, tmp_path / "b.tif", chunk=33, grid=grid)
    a, _ = read_ortho(tmp_path / "a.tif")
    b, _ = read_ortho(tmp_path / "b.tif")
    np.testing.assert_array_equal(a, b)


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_grid_covers_the_footprint_at_the_requested_gsd(ramp_image: Path):
    grid = ortho_grid(LEFT, (120, 150), constant_height(560.0), crop_offset=CROP, gsd=2.0)
    assert grid.gsd == 2.0 and grid.transform.c % 2.0 == 0 and grid.transform.f % 2.0 == 0
    corners = LEFT.image_to_ground(
        np.array([-0.5, -0.5, 119.5, 119.5]) + CROP[0],
        np.array([-0.5, 149.5, -0.5, 149.5]) + CROP[1],
        560.0,
    )
    x, y = Transformer.from_crs(4326, grid.crs, always_xy=True).transform(corners[0], corners[1])
    r, c = grid.rowcol(x, y)
    assert np.all((r >= -0.5) & (r <= grid.height - 0.5) & (c >= -0.5) & (c <= grid.width - 0.5))


def _plane(h0: float, north: float, east: float) -> DEM:
    """A planar DEM over the left crop: h0 at (5.1955 E, 44.207 N), rising `north` and `east`
    metres per metre (bilinear sampling reproduces a plane exactly)."""
    lon, lat = np.meshgrid(np.linspace(5.15, 5.25, 41), np.linspace(44.25, 44.15, 41))
    metres_lon, metres_lat = 79_830.0, 111_130.0  # one degree at 44.2° N
    values = h0 + east * (lon - 5.1955) * metres_lon + north * (lat - 44.207) * metres_lat
    t = Affine(0.0025, 0.0, 5.15 - 0.00125, 0.0, -0.0025, 44.25 + 0.00125)
    return DEM(Grid(values, t, CRS.from_epsg(4326), "plane"), "ellipsoidal (WGS-84)")


def test_image_gsd_is_the_image_s_not_the_slope_s():
    """d_s of §RA-4 is the image's GSD: at the left crop's centre, 0.50501 m by the .geom's
    meters_per_pixel (√(0.506057 × 0.503974)); taken along the SRTM's slope there it was
    0.4988 m (a 1.2 % larger RMSE in pixels), and along a 50 % slope it moved by up to 4 %."""
    srtm = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    crs = utm_ups_crs(5.19, 44.2)
    centre = (CROP[0] + 249.5, CROP[1] + 249.5)
    assert image_gsd(LEFT, *centre, srtm, crs) == pytest.approx(
        np.sqrt(0.506057 * 0.503974), rel=1e-3
    )
    flat = image_gsd(LEFT, *centre, constant_height(580.0), crs)
    for north, east in ((0.5, 0.0), (-0.5, 0.3), (0.0, -0.5)):
        assert image_gsd(LEFT, *centre, _plane(580.0, north, east), crs) == pytest.approx(
            flat,
            rel=1e-4,  # the plane is not at 580 m exactly under the centre
        )


def test_dem_that_misses_the_image_is_refused(tmp_path: Path):
    path = tmp_path / "far.tif"
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=2,
        height=2,
        count=1,
        dtype="float32",
        crs="EPSG:4326",
        transform=Affine(0.1, 0, 10.0, 0, -0.1, 50.0),
    ) as ds:
        ds.write(np.zeros((1, 2, 2), np.float32))
    with pytest.raises(InputError, match="does not cover"):
        ortho_grid(LEFT, (120, 150), load_dem(path, vertical="ellipsoid"), crop_offset=CROP)


def test_utm_zone():
    assert utm_ups_crs(5.19, 44.2).to_epsg() == 32631
    assert utm_ups_crs(55.7, -21.2).to_epsg() == 32740
    # UPS beyond UTM's latitudes, the codes MB-3 takes (§MB-3)
    assert [utm_ups_crs(0.0, lat).to_epsg() for lat in (84.0, 84.5, -80.0, -80.5)] == [
        32631,
        32661,
        32731,
        32761,
    ]


def test_a_finer_image_is_smoothed_before_it_is_sampled_coarser_and_nothing_shifts():
    """A reference of 0.5 m put on a 2 m grid (step 4): a checkerboard of 1-pixel squares,
    sampled every 4 pixels, aliases to all-black or all-white; smoothed (σ = 1.5) it is grey.
    A ramp keeps its values (the kernel is symmetric: no shift), a void stays a void, and an
    image on a grid of its own size is not touched."""
    from blockqc.rfm.ortho import antialiased

    rows, cols = np.mgrid[0:64, 0:64]
    board = ((rows + cols) % 2).astype(np.float32)
    assert np.all(board[::4, ::4] == 0)  # sampled as it is: black, though half is white
    smooth = antialiased(board, 4.0)
    np.testing.assert_allclose(smooth[8:-8:4, 8:-8:4], 0.5, atol=0.01)
    ramp = (3.0 * cols + 0.5 * rows).astype(np.float32)
    np.testing.assert_allclose(antialiased(ramp, 4.0)[8:-8, 8:-8], ramp[8:-8, 8:-8], atol=1e-3)
    holed = ramp.copy()
    holed[30:33, 30:33] = np.nan
    out = antialiased(holed, 4.0)
    assert np.isnan(out[30:33, 30:33]).all() and np.isfinite(out[:20]).all()
    assert antialiased(board, 1.2) is board


def test_a_dem_reaching_neither_the_border_nor_the_centre_still_gives_the_grid():
    """A DEM at 560 m over the inner part of the image's footprint, with a void under the
    image centre (as the s2p Réunion DSM under its image: 52 % outside it, voids inside): the
    border rays miss it and the centre's meets the void, yet half the image has heights. It was
    refused as "the DEM does not cover the image footprint"; the grid is the one at 560 m."""
    rows, cols = 120, 150
    lon, lat, _ = LEFT.image_to_ground(
        np.array([-0.5, -0.5, 119.5, 119.5]) + CROP[0],
        np.array([-0.5, 149.5, -0.5, 149.5]) + CROP[1],
        560.0,
    )
    step = (lon.max() - lon.min()) / 100
    west, east = np.quantile(lon, [0.0, 1.0]) + np.array([0.15, -0.15]) * np.ptp(lon)
    south, north = np.quantile(lat, [0.0, 1.0]) + np.array([0.15, -0.15]) * np.ptp(lat)
    grid_lon = np.arange(west, east, step)
    grid_lat = np.arange(north, south, -step)
    values = np.full((grid_lat.size, grid_lon.size), 560.0)
    centre_lon, centre_lat = lon.mean(), lat.mean()
    near = (np.abs(grid_lon - centre_lon) < 0.1 * np.ptp(lon))[None, :] & (
        np.abs(grid_lat - centre_lat) < 0.1 * np.ptp(lat)
    )[:, None]
    values[near] = np.nan
    t = Affine(step, 0.0, west - step / 2, 0.0, -step, north + step / 2)
    dem = DEM(Grid(values, t, CRS.from_epsg(4326), "inner"), "ellipsoidal (WGS-84)")
    grid = ortho_grid(LEFT, (rows, cols), dem, crop_offset=CROP, gsd=2.0)
    flat = ortho_grid(LEFT, (rows, cols), constant_height(560.0), crop_offset=CROP, gsd=2.0)
    assert (grid.transform, grid.width, grid.height) == (flat.transform, flat.width, flat.height)
