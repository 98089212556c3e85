"""Geoid undulations: the shipped EGM96 grid, constant offsets, declared height references."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import CRS
from rasterio.transform import from_origin
from rfm_helpers import VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.dem import load_dem
from blockqc.rfm.geoid import (
    EGM96_GRID,
    constant_geoid,
    declared_reference,
    egm96,
    geoid_from_file,
)

SRTM = VENTOUX / "srtm_N44E005_crop.tif"
GEOID_15 = VENTOUX / "egm96_15_crop.gtx"

# NGA's published EGM96 check values (F477 program, OUTPUT.DAT): lat, lon (0..360), N (m)
NGA_CHECKS = np.array(
    [
        [38.6281550, 269.7791550, -31.628],
        [-14.6212170, 305.0211140, -2.969],
        [46.8743190, 102.4487290, -43.575],
        [-23.6174460, 133.8747120, 15.871],
        [38.6254730, 359.9995000, 50.066],
        [-0.4667440, 0.0023000, 17.329],
    ]
)


def test_shipped_grid_matches_nga_check_values():
    n = egm96().undulation(NGA_CHECKS[:, 1], NGA_CHECKS[:, 0])
    np.testing.assert_allclose(n, NGA_CHECKS[:, 2], atol=0.25)


def test_shipped_grid_is_in_the_package_and_wraps_at_the_antimeridian():
    assert EGM96_GRID.is_file() and EGM96_GRID.stat().st_size < 400_000
    g = egm96()
    lat = np.array([-60.3, 0.0, 33.3, 71.9])
    np.testing.assert_allclose(g.undulation(np.full(4, 180.0), lat), g.undulation(-180.0, lat))
    np.testing.assert_allclose(g.undulation(359.75, lat), g.undulation(-0.25, lat))
    assert np.all(np.isfinite(g.undulation(np.array([179.9, -179.9, 0.0]), [90.0, -90.0, 0.0])))


def test_shipped_grid_interpolates_between_its_last_two_nodes_before_180_degrees():
    """Between the nodes at 179.5° and 180° the undulation is the linear mix of the two (it
    was the value at 180° from 179.75° on)."""
    with rasterio.open(EGM96_GRID) as ds:
        nodes = ds.read(1).astype(float) * ds.scales[0] + ds.offsets[0]
        t = ds.transform
    row = int(round((t.f - (-17.5)) / -t.e - 0.5))  # the nodes at 17.5° S
    lat = t.f + (row + 0.5) * t.e
    west, east = nodes[row, -2], nodes[row, -1]  # 179.5° and 180°
    f = np.array([0.0, 0.25, 0.5, 0.8, 0.98])
    n = egm96().undulation(179.5 + 0.5 * f, np.full(f.shape, lat))
    np.testing.assert_allclose(n, (1 - f) * west + f * east, atol=1e-9)


def test_a_geoid_file_round_the_globe_is_closed_across_180_degrees(tmp_path: Path):
    """A 2° grid with nodes from 180° W to 178° E (as egm96_15.gtx has 180° W to 179.75° E):
    N = half the node's column number (an undulation within ±150 m), so across the seam N
    goes from 89.5 to 0 and back to 0.5."""
    path = tmp_path / "global.tif"
    values = np.tile(np.arange(180.0) / 2, (91, 1))
    write_dem(path, values, "EPSG:4326", west=-181.0, north=91.0, step=2.0)
    lon = np.array([176.0, 178.0, 179.0, 179.9, 180.0, -180.0, -179.0, -178.0])
    expected = np.array([178.0, 179.0, 89.5, 0.05 * 179, 0.0, 0.0, 0.5, 1.0]) / 2
    for bounds in ((176.0, -1.0, 180.0, 1.0), (-180.0, -1.0, -178.0, 1.0)):
        geoid = geoid_from_file(path, bounds)
        np.testing.assert_allclose(geoid.undulation(lon, np.zeros(lon.shape)), expected)
    inner = geoid_from_file(path, (10.0, -1.0, 12.0, 1.0))  # away from the seam: a window
    assert inner.grid.values.shape[1] < 10
    np.testing.assert_allclose(inner.undulation([11.0], [0.0]), [95.5 / 2])


def test_shipped_grid_agrees_with_the_15_minute_grid_at_ventoux():
    """Within the 30' grid's resolution (README: RMS 0.16 m globally) over Provence."""
    lon, lat = np.meshgrid(np.linspace(5.0, 5.5, 11), np.linspace(44.0, 44.5, 11))
    with rasterio.open(GEOID_15) as ds:
        g15 = ds.read(1).astype(float)
        t = ds.transform
    from blockqc.rfm.dem import Grid

    fine = Grid(g15, t, CRS.from_epsg(4326)).sample(lon, lat)
    np.testing.assert_allclose(egm96().undulation(lon, lat), fine, atol=0.1)


def write_dem(path: Path, values: np.ndarray, crs: str, west=5.1, north=44.3, step=0.01):
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=values.shape[1],
        height=values.shape[0],
        count=1,
        dtype="float32",
        crs=rasterio.crs.CRS.from_wkt(CRS.from_user_input(crs).to_wkt()),
        transform=from_origin(west, north, step, step),
    ) as ds:
        ds.write(values.astype(np.float32), 1)


def test_dem_declaring_egm96_heights_is_converted_without_options(tmp_path: Path):
    write_dem(tmp_path / "dem.tif", np.full((20, 20), 500.0), "EPSG:4326+5773")
    assert declared_reference(tmp_path / "dem.tif")[0] == "EGM96"
    dem = load_dem(tmp_path / "dem.tif")
    lon, lat = 5.2, 44.2
    assert dem.height(lon, lat) == pytest.approx(500.0 + float(egm96().undulation(lon, lat)))
    assert "EGM96" in dem.vertical and "declared" in dem.vertical


def test_dem_declaring_ellipsoidal_heights_is_used_as_is_and_refuses_a_geoid(tmp_path: Path):
    write_dem(tmp_path / "dem.tif", np.full((20, 20), 500.0), "EPSG:4979")
    assert load_dem(tmp_path / "dem.tif").height(5.2, 44.2) == pytest.approx(500.0)
    with pytest.raises(InputError, match="declares ellipsoidal"):
        load_dem(tmp_path / "dem.tif", geoid="egm96")


def test_dem_declaring_another_geoid_needs_its_grid_or_an_offset(tmp_path: Path):
    write_dem(tmp_path / "dem.tif", np.full((20, 20), 500.0), "EPSG:4326+3855")
    with pytest.raises(InputError, match="EGM2008") as exc:
        load_dem(tmp_path / "dem.tif")
    assert "--geoid FILE" in str(exc.value) and "--geoid-offset" in str(exc.value)
    with pytest.raises(InputError, match="not EGM96"):
        load_dem(tmp_path / "dem.tif", geoid="egm96")
    with pytest.raises(InputError, match="would leave every height off"):
        load_dem(tmp_path / "dem.tif", vertical="ellipsoid")
    dem = load_dem(tmp_path / "dem.tif", geoid_offset=50.5)
    assert dem.height(5.2, 44.2) == pytest.approx(550.5)


def test_unknown_reference_names_both_options_and_the_cost_of_ellipsoidal():
    with pytest.raises(InputError) as exc:
        load_dem(SRTM, plane_per_m=0.155)
    text = str(exc.value)
    for words in ("--geoid egm96", "--geoid FILE", "--geoid-offset", "--dem-vertical ellipsoid"):
        assert words in text
    # N ≈ 50.8 m at Ventoux; 50.8 m × 0.155 = 7.9 m of plane error
    assert "N = 50.8 m here" in text and "7.9 m of plane error" in text


def test_geoid_offset_is_added_as_is():
    plain = load_dem(SRTM, vertical="ellipsoid")
    shifted = load_dem(SRTM, geoid_offset=-12.25)
    np.testing.assert_allclose(shifted.grid.values, plain.grid.values - 12.25)
    with pytest.raises(InputError, match="±150"):
        constant_geoid(float("inf"))
    with pytest.raises(InputError, match="not both"):
        load_dem(SRTM, geoid="egm96", geoid_offset=51.0)


def test_egm96_and_the_15_minute_file_and_an_offset_agree_at_ventoux():
    """--geoid egm96, --geoid egm96_15.gtx and --geoid-offset N(scene) give the same DEM to
    within the grids' resolution and the geoid's slope over the scene (a few cm)."""
    shipped = load_dem(SRTM, geoid="egm96")
    fine = load_dem(SRTM, geoid=GEOID_15)
    n_centre = float(egm96().undulation(5.195, 44.207))
    offset = load_dem(SRTM, geoid_offset=n_centre)
    finite = np.isfinite(shipped.grid.values)
    assert np.max(np.abs(shipped.grid.values - fine.grid.values)[finite]) < 0.1
    assert np.max(np.abs(shipped.grid.values - offset.grid.values)[finite]) < 0.1


def write_hgt(path: Path) -> None:
    """A full SRTM3 tile (1201², big-endian int16, voids -32768) holding the test crop."""
    with rasterio.open(SRTM) as ds:
        crop = ds.read(1)
        t = ds.transform
    row0 = round((45.0 + 1 / 2400 - t.f) * 1200)
    col0 = round((t.c - 5.0 + 1 / 2400) * 1200)
    tile = np.full((1201, 1201), -32768, dtype=">i2")
    tile[row0 : row0 + crop.shape[0], col0 : col0 + crop.shape[1]] = crop
    path.write_bytes(tile.tobytes())


def test_srtm_hgt_is_read_as_egm96_heights(tmp_path: Path):
    write_hgt(tmp_path / "N44E005.hgt")
    assert declared_reference(tmp_path / "N44E005.hgt")[0] == "EGM96"
    auto = load_dem(tmp_path / "N44E005.hgt")
    said = load_dem(tmp_path / "N44E005.hgt", geoid="egm96")
    crop = load_dem(SRTM, geoid="egm96")
    lon, lat = np.meshgrid(np.linspace(5.18, 5.21, 7), np.linspace(44.20, 44.22, 7))
    np.testing.assert_allclose(auto.height(lon, lat), crop.height(lon, lat), atol=1e-6)
    np.testing.assert_allclose(said.height(lon, lat), crop.height(lon, lat), atol=1e-6)
    with pytest.raises(InputError, match="declares EGM96"):
        load_dem(tmp_path / "N44E005.hgt", vertical="ellipsoid")


def test_a_geoid_file_of_another_model_than_the_dem_declares_is_refused(tmp_path: Path):
    """A DEM declaring EGM2008 heights (EPSG:4326+3855) with NGA's EGM96 grid file: refused as
    `--geoid egm96` is, naming both models; a grid of EGM2008 (by its name) is taken."""
    write_dem(tmp_path / "dem.tif", np.full((20, 20), 500.0), "EPSG:4326+3855")
    with pytest.raises(InputError, match="declares EGM2008 heights") as exc:
        load_dem(tmp_path / "dem.tif", geoid=GEOID_15)
    assert f"the geoid grid {GEOID_15.name} is EGM96" in str(exc.value)
    egm2008 = tmp_path / "egm08_25_crop.gtx"
    egm2008.write_bytes(GEOID_15.read_bytes())
    dem = load_dem(tmp_path / "dem.tif", geoid=egm2008)
    n = float(geoid_from_file(GEOID_15, (4.5, 43.5, 6.0, 45.0)).undulation(5.2, 44.2)[()])
    assert dem.height(5.2, 44.2) == pytest.approx(500.0 + n)


def test_a_dem_given_as_the_geoid_grid_is_refused():
    """The SRTM crop given as --geoid FILE was taken as undulations of 270…1120 m: every
    height off by as much, and the run ended with 'the reference does not overlap the image'."""
    srtm = VENTOUX / "srtm_N44E005_crop.tif"
    with pytest.raises(InputError) as exc:
        load_dem(srtm, geoid=srtm)
    message = str(exc.value)
    assert message.startswith(f"{srtm}: the geoid grid holds ")
    assert "beyond any geoid undulation (expected within ±150 m" in message
    assert message.endswith("a DEM or a grid in other units given as --geoid?")
