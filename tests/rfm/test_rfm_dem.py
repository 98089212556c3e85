"""DEMs as ellipsoidal heights: bilinear sampling, geoid conversion, refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin
from rfm_helpers import VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.dem import constant_height, fill_voids, load_dem

SRTM = VENTOUX / "srtm_N44E005_crop.tif"
GEOID = VENTOUX / "egm96_15_crop.gtx"


def write_grid(
    path: Path, values: np.ndarray, west: float, north: float, step: float, crs="EPSG:4326"
):
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=values.shape[1],
        height=values.shape[0],
        count=1,
        dtype="float32",
        crs=crs,
        transform=from_origin(west, north, step, step),
        nodata=-9999,
    ) as ds:
        ds.write(values.astype(np.float32), 1)


def test_bilinear_sampling_by_hand(tmp_path: Path):
    # pixel centres at lon 10.5, 11.5 and lat 50.5, 49.5 (1° pixels, north-west corner 10, 51)
    write_grid(tmp_path / "dem.tif", np.array([[100.0, 200.0], [300.0, 500.0]]), 10.0, 51.0, 1.0)
    dem = load_dem(tmp_path / "dem.tif", vertical="ellipsoid")
    h = dem.height(
        np.array([10.5, 11.5, 11.0, 10.75, 12.0, 12.2]),
        np.array([50.5, 49.5, 50.0, 50.25, 50.0, 50.0]),
    )
    # centre of the four: (100+200+300+500)/4 = 275; (10.75, 50.25): row 0.25, col 0.25:
    # 100*.75*.75 + 200*.75*.25 + 300*.25*.75 + 500*.25*.25 = 56.25 + 37.5 + 56.25 + 31.25
    # = 181.25; lon 12.0 is on the raster's edge, half a pixel beyond the last centre: the edge
    # column is used, (200 + 500)/2 = 350; lon 12.2 is outside
    np.testing.assert_allclose(h[:5], [100.0, 500.0, 275.0, 181.25, 350.0])
    assert np.isnan(h[5])


def test_voids_give_nan(tmp_path: Path):
    write_grid(tmp_path / "dem.tif", np.array([[100.0, -9999.0], [300.0, 500.0]]), 10.0, 51.0, 1.0)
    dem = load_dem(tmp_path / "dem.tif", vertical="ellipsoid")
    assert np.isnan(dem.height(11.0, 50.0)) and dem.height(10.5, 49.5) == 300.0


def test_geoid_heights_become_ellipsoidal():
    """h = H + N at an SRTM node, with N interpolated by hand from the four EGM96 nodes."""
    dem = load_dem(SRTM, geoid=GEOID)
    with rasterio.open(SRTM) as ds:
        t = ds.transform
        srtm = ds.read(1).astype(float)
    r, c = 20, 30
    lon = t.c + (c + 0.5) * t.a
    lat = t.f + (r + 0.5) * t.e
    with rasterio.open(GEOID) as ds:
        g = ds.read(1).astype(float)
        gt = ds.transform
    gc = (lon - gt.c) / gt.a - 0.5
    gr = (lat - gt.f) / gt.e - 0.5
    i, j = int(gr), int(gc)
    fr, fc = gr - i, gc - j
    n = (
        g[i, j] * (1 - fr) * (1 - fc)
        + g[i, j + 1] * (1 - fr) * fc
        + g[i + 1, j] * fr * (1 - fc)
        + g[i + 1, j + 1] * fr * fc
    )
    assert 50.0 < n < 52.0  # EGM96 over Provence, ~51 m
    assert dem.height(lon, lat) == pytest.approx(srtm[r, c] + n, abs=1e-4)
    assert "EGM96" in dem.vertical or "egm96" in dem.vertical


def test_geoid_dem_without_geoid_is_refused():
    with pytest.raises(InputError, match="ellipsoidal"):
        load_dem(SRTM)


def test_projected_dem_is_sampled_through_its_crs(tmp_path: Path):
    # a UTM 31N plane z = 0.01 * easting: the height at a lon/lat is 0.01 * its easting
    from pyproj import Transformer

    x0, y0 = 675000.0, 4898000.0
    cols = np.arange(100)
    values = np.tile(0.01 * (x0 + (cols + 0.5) * 10.0), (100, 1))
    write_grid(tmp_path / "dsm.tif", values, x0, y0, 10.0, crs="EPSG:32631")
    dem = load_dem(tmp_path / "dsm.tif", vertical="ellipsoid")
    lon, lat = Transformer.from_crs(32631, 4326, always_xy=True).transform(675333.0, 4897500.0)
    assert dem.height(lon, lat) == pytest.approx(6753.33, abs=1e-3)


def test_window_outside_the_dem_is_refused():
    with pytest.raises(InputError, match="does not cover"):
        load_dem(SRTM, geoid=GEOID, bounds=(7.0, 45.0, 7.1, 45.1))


def test_small_voids_are_filled_from_their_neighbours():
    values = np.arange(25, dtype=float).reshape(5, 5)
    values[2, 2] = np.nan  # a hole: mean of its 8 neighbours = 12 (the grid is linear)
    values[0, 4] = np.nan  # a corner cell has 3 neighbours: an edge, not a hole
    out = fill_voids(values, 3)
    assert out[2, 2] == pytest.approx(12.0)
    assert np.isnan(out[0, 4])


@pytest.mark.parametrize(
    ("rows", "cols", "steps"), [(3, 3, 2), (4, 4, 2), (5, 5, 3), (6, 6, 3), (5, 30, 3), (2, 40, 1)]
)
def test_holes_up_to_two_steps_across_are_closed_whatever_their_shape(rows, cols, steps):
    """A hole is closed by N steps when every cell of it is within N cells of a height: 2·N
    cells across. A cell was filled only with 5 of its 8 neighbours known, so a 4 × 4 hole
    (and any hole 4 or more cells across) was never closed whatever N, and a 3 × 3 one needed
    N = 3: the DSM of the s2p Réunion pair kept voids under --dem-fill-voids 5."""
    values = np.full((40, 60), 500.0)
    values[10 : 10 + rows, 10 : 10 + cols] = np.nan
    assert np.isnan(fill_voids(values, steps - 1)[10 : 10 + rows, 10 : 10 + cols]).all()
    assert np.all(fill_voids(values, steps) == 500.0)


def test_a_void_wider_than_the_steps_or_at_the_edge_stays_empty_whole():
    """A 12 × 12 void is 6 steps deep: with 3 it is left empty, not given a rim of heights
    grown 3 cells into it; a void reaching the grid's edge (the outside) is left too."""
    values = np.full((40, 40), 500.0)
    values[10:22, 10:22] = np.nan
    values[30:33, 37:40] = np.nan  # 3 × 3 at the right edge
    out = fill_voids(values, 3)
    assert np.isnan(out[10:22, 10:22]).all() and np.isnan(out[30:33, 37:40]).all()
    assert np.isfinite(out).sum() == 40 * 40 - 144 - 9
    assert np.isfinite(fill_voids(values, 6)[10:22, 10:22]).all()


def test_constant_height():
    assert np.all(
        constant_height(321.5).height(np.array([-179.0, 0.0, 179.9]), np.array([-80.0, 0.0, 80.0]))
        == 321.5
    )


def test_undeclared_no_data_value_is_refused_with_its_cell(tmp_path: Path):
    """An int16 DEM whose voids hold −32768 without a declared nodata: those are not heights
    (they were taken as −32768 m, pulling the image's heights down by kilometres)."""
    z = np.full((4, 5), 300, np.int16)
    z[2, 3] = -32768
    z[3, 4] = -32768
    with rasterio.open(
        tmp_path / "dem.tif", "w", driver="GTiff", width=5, height=4, count=1, dtype="int16",
        crs="EPSG:4326", transform=from_origin(10.0, 51.0, 0.5, 0.5),
    ) as ds:  # fmt: skip
        ds.write(z, 1)
    with pytest.raises(InputError) as err:
        load_dem(tmp_path / "dem.tif", vertical="ellipsoid")
    text = str(err.value)
    # the first cell: row 2, column 3, centre lon 10 + 3.5·0.5 = 11.75, lat 51 − 2.5·0.5 = 49.75
    assert "dem.tif" in text and "2 cell(s) beyond any height on Earth" in text
    assert "the first -32768 at row 2, column 3 (x 11.75, y 49.75" in text


def test_dem_of_several_bands_is_refused(tmp_path: Path):
    with rasterio.open(
        tmp_path / "dem.tif", "w", driver="GTiff", width=2, height=2, count=3, dtype="float32",
        crs="EPSG:4326", transform=from_origin(10.0, 51.0, 1.0, 1.0),
    ) as ds:  # fmt: skip
        ds.write(np.full((3, 2, 2), 100.0, np.float32))
    with pytest.raises(InputError, match="the DEM has 3 bands: expected one band of heights"):
        load_dem(tmp_path / "dem.tif", vertical="ellipsoid")


def write_heights(path: Path, value: float, crs: str = "EPSG:4326", unit: str = "") -> Path:
    """A 3 × 3 lon/lat DEM of one height around Ventoux, its band unit `unit`."""
    with rasterio.Env(GTIFF_REPORT_COMPD_CS=True), rasterio.open(
        path, "w", driver="GTiff", width=3, height=3, count=1, dtype="float32", crs=crs,
        transform=from_origin(5.0, 44.5, 0.25, 0.25),
    ) as ds:  # fmt: skip
        ds.write(np.full((1, 3, 3), value, np.float32))
        if unit:
            ds.units = (unit,)
    return path


@pytest.mark.parametrize(
    ("crs", "unit", "metres"),
    [
        ("EPSG:4326", "ft", 1000 * 0.3048),
        ("EPSG:4326", "metre", 1000.0),
        ("EPSG:4326", "meters above sea level", 1000.0),  # a unit word and its description
        ("EPSG:4326", "Meter (m)", 1000.0),
        ("EPSG:4326", "ft (US survey)", 1000 * 1200 / 3937),
        ("EPSG:4326+6360", "", 1000 * 1200 / 3937),  # NAVD88 height (ftUS)
    ],
)
def test_heights_in_feet_are_converted_to_metres(tmp_path: Path, crs, unit, metres):
    """A DEM saying its heights are in feet (band unit, or a vertical CRS in US survey feet)
    was read as metres: 1000 ft became 1000 m, every height 3.28 times too large."""
    dem = load_dem(write_heights(tmp_path / "dem.tif", 1000.0, crs, unit), geoid_offset=50.0)
    assert dem.height(5.3, 44.2) == pytest.approx(metres + 50.0, abs=1e-4)
    assert ("converted to metres" in dem.vertical) == (metres != 1000.0)


@pytest.mark.parametrize(
    ("crs", "unit", "message"),
    [
        ("EPSG:4326", "km", "the DEM's heights are in 'km' (its band unit): expected metres or "
         "feet"),
        ("EPSG:4326+5773", "ft", "the DEM gives its heights in 'ft' (its band unit), 'metre' "
         "(its CRS 'WGS 84 + EGM96 height'): expected one unit"),
    ],
)  # fmt: skip
def test_heights_in_another_unit_or_two_units_are_refused(tmp_path: Path, crs, unit, message):
    path = write_heights(tmp_path / "dem.tif", 1000.0, crs, unit)
    with pytest.raises(InputError) as exc:
        load_dem(path, geoid_offset=50.0)
    assert str(exc.value) == f"{path}: {message}"


@pytest.mark.parametrize(("stored", "scale", "offset"), [(5000, 0.1, 0.0), (500, 1.0, 100.0)])
def test_a_band_stored_scaled_is_read_in_metres(tmp_path: Path, stored, scale, offset):
    """The band's scale and offset were not applied: heights stored in decimetres (5000 with
    scale 0.1) were read as 5000 m, and blockqc's own EGM96 grid (int16 cm) given as --geoid
    FILE gave N = 5080 m at Ventoux."""
    path = tmp_path / "dem.tif"
    with rasterio.open(
        path, "w", driver="GTiff", width=3, height=3, count=1, dtype="int16", crs="EPSG:4326",
        transform=from_origin(5.0, 44.5, 0.25, 0.25),
    ) as ds:  # fmt: skip
        ds.write(np.full((1, 3, 3), stored, np.int16))
        ds.scales, ds.offsets = (scale,), (offset,)
    dem = load_dem(path, geoid_offset=50.0)
    assert dem.height(5.3, 44.2) == pytest.approx(stored * scale + offset + 50.0)


def test_the_shipped_egm96_grid_given_as_a_file_agrees_with_egm96():
    from blockqc.rfm.geoid import EGM96_GRID, egm96, geoid_from_file

    grid = geoid_from_file(EGM96_GRID, (5.0, 44.0, 6.0, 45.0))
    assert grid.undulation(5.19, 44.2) == pytest.approx(egm96().undulation(5.19, 44.2))


def test_geographic_dem_on_another_datum_is_sampled_through_its_crs(tmp_path: Path):
    """A lon/lat DEM on ED50 (EPSG:4230): its longitudes are not WGS-84's (about 0.0011° east
    over Provence, ~90 m). A plane z = 5000·(lon_ED50 − 5) gives, at a WGS-84 lon/lat, 5000 times
    the ED50 longitude less 5: read as WGS-84 degrees it was 5.5 m off."""
    from pyproj import Transformer

    cols = np.arange(100)
    values = np.tile(5000.0 * ((cols + 0.5) * 0.01), (100, 1))
    write_grid(tmp_path / "dem.tif", values, 5.0, 44.5, 0.01, crs="EPSG:4230")
    dem = load_dem(tmp_path / "dem.tif", vertical="ellipsoid", bounds=(5.2, 44.0, 5.4, 44.2))
    lon, lat = 5.3, 44.1
    lon_ed50, _ = Transformer.from_crs(4326, 4230, always_xy=True).transform(lon, lat)
    assert abs(lon_ed50 - lon) > 5e-4  # the datums differ here by ~90 m
    assert dem.height(lon, lat) == pytest.approx(5000.0 * (lon_ed50 - 5.0), abs=1e-3)
