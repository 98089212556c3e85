"""Terrain factors (§AF-1..3): planes and cones with known answers, real SRTM against
independent computations, tiles and coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rasterio
import shapely
from pyproj import Geod, Transformer
from rasterio.transform import from_origin
from rasterio.warp import Resampling, calculate_default_transform, reproject
from scipy import ndimage

from blockqc.analysis.terrain import DemSet, horn_slope, pixel_sizes_m, roughness
from blockqc.errors import InputError

GEOD = Geod(ellps="WGS84")


def test_plane_arrays():
    dx = dy = 30.0
    yy, xx = np.mgrid[0:50, 0:60]
    z = 0.1 * xx * dx - 0.05 * yy * dy + 500.0
    s = horn_slope(z, dx, dy)
    rough = roughness(z)
    expected = math.degrees(math.atan(math.hypot(0.1, 0.05)))  # 6.379°
    inner = (slice(1, -1), slice(1, -1))
    np.testing.assert_allclose(s[inner], expected, atol=1e-10)
    # on a plane the 3×3 range is 2·dx·|gx| + 2·dy·|gy|
    np.testing.assert_allclose(rough[inner], 2 * 30 * 0.1 + 2 * 30 * 0.05, atol=1e-9)
    assert np.isnan(s[0]).all() and np.isnan(rough[:, -1]).all()


def test_void_blanks_its_neighbours():
    z = np.arange(100.0).reshape(10, 10)
    z[5, 5] = np.nan
    s, r = horn_slope(z, 1.0, 1.0), roughness(z)
    assert np.isnan(s[4:7, 4:7]).all() and np.isnan(r[4:7, 4:7]).all()
    assert np.isfinite(s[2, 2]) and np.isfinite(r[7, 7])


def test_cone_arrays():
    dx = 10.0
    k = math.tan(math.radians(30.0))
    yy, xx = np.mgrid[-200:201, -200:201] * dx
    rr = np.hypot(xx, yy)
    z = 2000.0 - k * rr
    ring = (rr > 20 * dx) & (rr < 180 * dx)
    s = horn_slope(z, dx, dx)
    assert np.mean(s[ring]) == pytest.approx(30.0, abs=0.02)
    assert np.abs(s[ring] - 30.0).max() < 0.3
    # far from the apex the 3×3 range is k·2·dx·(|cos θ| + |sin θ|), whose mean over θ is 8·k·dx/π
    assert np.mean(roughness(z)[ring]) == pytest.approx(8 * k * dx / math.pi, rel=0.01)


@pytest.mark.parametrize("lat", [0.0, 39.5, 60.0, 80.0])
def test_geographic_cell_sizes_against_geodesics(lat):
    res = 1.0 / 1200.0
    t = from_origin(20.0, lat + res / 2, res, res)  # row 0 centred on `lat`
    dx, dy = pixel_sizes_m(t, rasterio.crs.CRS.from_epsg(4326), 1)
    _, _, ew = GEOD.inv(20.0, lat, 20.0 + res, lat)
    _, _, ns = GEOD.inv(20.0, lat - res / 2, 20.0, lat + res / 2)
    assert dx[0] == pytest.approx(ew, rel=1e-7)
    assert dy[0] == pytest.approx(ns, rel=1e-7)


def test_geographic_plane_at_60_north(tmp_path, dem_writer):
    """A plane tilted east and north on a geographic grid at 60° N: cos φ matters (×2)."""
    res, lon0, lat0, n = 1 / 1200, 10.0, 60.1, 150
    rows, cols = np.mgrid[0:n, 0:n]
    lat = lat0 - (rows + 0.5) * res
    lon = lon0 + (cols + 0.5) * res
    # east and north distances from the grid centre along geodesics (independent of the code)
    _, _, de = GEOD.inv(np.full(lon.shape, lon0 + n * res / 2), lat, lon, lat)
    _, _, dn = GEOD.inv(lon, np.full(lat.shape, lat0 - n * res / 2), lon, lat)
    de = np.where(lon < lon0 + n * res / 2, -de, de)
    dn = np.where(lat < lat0 - n * res / 2, -dn, dn)
    z = 300.0 + 0.2 * de + 0.1 * dn
    path = dem_writer(tmp_path / "plane60.tif", z, lon0, lat0, res, "EPSG:4326")
    poly = shapely.box(lon0 + 0.02, lat0 - 0.1, lon0 + 0.1, lat0 - 0.02)
    f = DemSet([path]).factors(poly)
    assert f.mean_slope_deg == pytest.approx(
        math.degrees(math.atan(math.hypot(0.2, 0.1))), abs=2e-3
    )
    assert f.dem_coverage == pytest.approx(1.0)


def test_projected_plane_through_demset(tmp_path, dem_writer):
    """A plane in UTM 37N; the block polygon is given in lon/lat."""
    res, x0, y0, n = 30.0, 400_000.0, 4_400_000.0, 200
    rows, cols = np.mgrid[0:n, 0:n]
    x = x0 + (cols + 0.5) * res
    y = y0 - (rows + 0.5) * res
    z = 1000.0 + 0.3 * (x - x0) - 0.4 * (y - y0)
    path = dem_writer(tmp_path / "plane_utm.tif", z, x0, y0, res, "EPSG:32637")
    to_ll = Transformer.from_crs(32637, 4326, always_xy=True)
    lo, la = to_ll.transform([x0 + 1000, x0 + 5000], [y0 - 5000, y0 - 1000])
    poly = shapely.box(lo[0], la[0], lo[1], la[1])
    f = DemSet([path]).factors(poly)
    assert f.mean_slope_deg == pytest.approx(math.degrees(math.atan(0.5)), abs=1e-6)
    assert f.mean_roughness_m == pytest.approx(2 * res * 0.3 + 2 * res * 0.4, abs=1e-6)
    # mean elevation: the plane over the cells whose centres fall in the projected polygon
    to_utm = Transformer.from_crs(4326, 32637, always_xy=True)
    poly_utm = shapely.transform(
        shapely.segmentize(poly, 1e-3),
        lambda c: np.column_stack(to_utm.transform(c[:, 0], c[:, 1])),
    )
    inside = shapely.contains_xy(poly_utm, x, y)
    assert f.mean_elevation_m == pytest.approx(z[inside].mean(), abs=1e-3)


def test_geographic_dem_on_another_datum_through_demset(tmp_path, dem_writer):
    """A lon/lat DEM on ED50 (EPSG:4230), whose longitudes over Provence are ~0.0011° (90 m)
    east of WGS-84's: the block's lon/lat polygon is taken to the DEM's datum, as to a projected
    DEM's CRS. A plane z = 5000·(lon_ED50 − 5) over cells of 0.0005°: the means are over the
    cells whose centres fall in the polygon on ED50 (read on WGS-84 degrees: 5.5 m low)."""
    res, lon0, lat0, n = 0.0005, 5.2, 44.2, 400
    rows, cols = np.mgrid[0:n, 0:n]
    lon = lon0 + (cols + 0.5) * res
    lat = lat0 - (rows + 0.5) * res
    z = 5000.0 * (lon - 5.0)
    path = dem_writer(tmp_path / "plane_ed50.tif", z, lon0, lat0, res, "EPSG:4230")
    poly = shapely.box(5.25, 44.05, 5.35, 44.15)
    f = DemSet([path]).factors(poly)
    to_ed50 = Transformer.from_crs(4326, 4230, always_xy=True)
    poly_ed50 = shapely.transform(
        shapely.segmentize(poly, 1e-3),
        lambda c: np.column_stack(to_ed50.transform(c[:, 0], c[:, 1])),
    )
    inside = shapely.contains_xy(poly_ed50, lon, lat)
    weights = np.cos(np.radians(lat))  # cell areas shrink with cos φ
    expected = np.average(z[inside], weights=weights[inside])
    assert abs(expected - 5000.0 * 0.3) > 4.0  # the datums differ here by ~90 m
    assert f.mean_elevation_m == pytest.approx(expected, abs=0.05)


@pytest.mark.parametrize(
    ("dtype", "unit", "scale", "to_metres"),
    [("float32", "ft", 1.0, 0.3048), ("int16", "", 0.1, 0.1), ("int16", "ft", 0.5, 0.1524)],
)
def test_heights_in_feet_or_stored_scaled_are_read_in_metres(
    tmp_path, dtype, unit, scale, to_metres
):
    """A UTM plane rising 0.3 per metre east, stored in feet or as scaled integers (decimetres):
    its heights are the stored values × the band's scale × metres per unit. Read as stored, the
    mean elevation and roughness were 3.28 (or 10) times too large, and the slope steeper."""
    res, x0, y0, n = 30.0, 400_000.0, 4_400_000.0, 200
    cols = np.arange(n)
    metres = np.tile(1000.0 + 0.3 * (cols + 0.5) * res, (n, 1))
    path = tmp_path / "plane.tif"
    with rasterio.open(
        path, "w", driver="GTiff", width=n, height=n, count=1, dtype=dtype,
        crs="EPSG:32637", transform=from_origin(x0, y0, res, res), nodata=-9999,
    ) as ds:  # fmt: skip
        ds.write(np.round(metres / to_metres).astype(dtype), 1)
        ds.scales = (scale,)
        if unit:
            ds.units = (unit,)
    to_ll = Transformer.from_crs(32637, 4326, always_xy=True)
    lo, la = to_ll.transform([x0 + 1000, x0 + 5000], [y0 - 5000, y0 - 1000])
    f = DemSet([path]).factors(shapely.box(lo[0], la[0], lo[1], la[1]))
    assert f.mean_slope_deg == pytest.approx(math.degrees(math.atan(0.3)), abs=0.05)
    assert f.mean_roughness_m == pytest.approx(2 * res * 0.3, abs=0.5)
    assert 1000 + 0.3 * 1000 < f.mean_elevation_m < 1000 + 0.3 * 5000


def _srtm(data_dir):
    with rasterio.open(data_dir / "srtm_turkey_crop.tif") as src:
        z = src.read(1).astype(float)
        return z, src.transform, src.crs


def test_real_srtm_against_geodesic_horn(data_dir):
    """Mean slope/roughness/elevation of real SRTM: an independent Horn with geodesic cell sizes."""
    z, t, _ = _srtm(data_dir)
    poly = shapely.box(40.28, 39.59, 40.42, 39.72)
    f = DemSet([data_dir / "srtm_turkey_crop.tif"]).factors(poly)

    rows, cols = np.mgrid[0 : z.shape[0], 0 : z.shape[1]]
    lon = t.c + (cols + 0.5) * t.a
    lat = t.f + (rows + 0.5) * t.e
    _, _, ew = GEOD.inv(lon[:, 0] - t.a, lat[:, 0], lon[:, 0] + t.a, lat[:, 0])
    _, _, ns = GEOD.inv(lon[:, 0], lat[:, 0] + t.e, lon[:, 0], lat[:, 0] - t.e)
    ew, ns = ew[:, None] / 2, ns[:, None] / 2
    kx = np.array([[-1, 0, 1], [-2, 0, 2], [-1, 0, 1]]) / 8.0
    gx = ndimage.correlate(z, kx, mode="nearest") / ew
    gy = ndimage.correlate(z, kx.T, mode="nearest") / ns
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    rough = ndimage.maximum_filter(z, 3) - ndimage.minimum_filter(z, 3)
    inside = shapely.contains_xy(poly, lon, lat)
    w = (ew * ns * np.ones_like(z))[inside]
    assert f.mean_slope_deg == pytest.approx(np.average(slope[inside], weights=w), rel=1e-6)
    assert f.mean_roughness_m == pytest.approx(np.average(rough[inside], weights=w), rel=1e-9)
    assert f.mean_elevation_m == pytest.approx(np.average(z[inside], weights=w), rel=1e-9)
    assert f.dem_coverage == pytest.approx(1.0)
    assert f.n_pixels == inside.sum()
    assert 5.0 < f.mean_slope_deg < 25.0  # mountainous terrain (about 9.9°)


def test_real_srtm_against_utm_reprojection(tmp_path, data_dir):
    """The same block's mean slope from the DEM reprojected to UTM and central differences."""
    z, t, crs = _srtm(data_dir)
    dst_crs = "EPSG:32637"
    tr, w, h = calculate_default_transform(
        crs,
        dst_crs,
        z.shape[1],
        z.shape[0],
        *rasterio.transform.array_bounds(*z.shape, t),
        resolution=90.0,
    )
    out = np.full((h, w), np.nan)
    reproject(
        z,
        out,
        src_transform=t,
        src_crs=crs,
        dst_transform=tr,
        dst_crs=dst_crs,
        resampling=Resampling.bilinear,
        src_nodata=-32768,
        dst_nodata=np.nan,
    )
    gy, gx = np.gradient(out, 90.0)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    poly = shapely.box(40.28, 39.59, 40.42, 39.72)
    rows, cols = np.mgrid[0:h, 0:w]
    xs, ys = rasterio.transform.xy(tr, rows.ravel(), cols.ravel())
    lon, lat = Transformer.from_crs(32637, 4326, always_xy=True).transform(xs, ys)
    inside = shapely.contains_xy(poly, np.asarray(lon), np.asarray(lat)).reshape(h, w)
    expected = np.nanmean(slope[inside])
    f = DemSet([data_dir / "srtm_turkey_crop.tif"]).factors(poly)
    # resampling smooths a little: agreement within 5 %
    assert f.mean_slope_deg == pytest.approx(expected, rel=0.05)


def test_tiles_and_coverage(tmp_path, data_dir):
    z, t, crs = _srtm(data_dir)
    folder = tmp_path / "tiles"
    folder.mkdir()
    for name, sl, off in (("west.tif", slice(0, 120), 0), ("east.tif", slice(120, 240), 120)):
        with rasterio.open(
            folder / name,
            "w",
            driver="GTiff",
            width=120,
            height=240,
            count=1,
            dtype="int16",
            crs=crs,
            nodata=-32768,
            transform=t @ rasterio.Affine.translation(off, 0),
        ) as dst:
            dst.write(z[:, sl].astype("int16"), 1)
    (folder / "notes.txt").write_text("not a DEM")
    poly = shapely.box(40.30, 39.60, 40.40, 39.70)  # straddles the seam at 40.35
    one = DemSet([data_dir / "srtm_turkey_crop.tif"]).factors(poly)
    two = DemSet([folder]).factors(poly)
    assert len(two.dem_files) == 2
    assert two.mean_slope_deg == pytest.approx(one.mean_slope_deg, rel=1e-12)
    assert two.mean_roughness_m == pytest.approx(one.mean_roughness_m, rel=1e-12)
    assert two.mean_elevation_m == pytest.approx(one.mean_elevation_m, rel=1e-12)
    # only the west tile: the block is half covered (geodesic areas, computed independently)
    west = DemSet([folder / "west.tif"]).factors(poly)
    covered = shapely.intersection(poly, shapely.box(40.25, 39.55, 40.35, 39.75))
    share = abs(GEOD.geometry_area_perimeter(covered)[0]) / abs(
        GEOD.geometry_area_perimeter(poly)[0]
    )
    assert west.dem_coverage == pytest.approx(share, abs=0.01)
    # a block off every tile: no factors, no coverage
    off = DemSet([folder]).factors(shapely.box(10, 10, 11, 11))
    assert off.dem_coverage == 0.0 and math.isnan(off.mean_slope_deg)


def test_missing_dem_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="not found"):
        DemSet([tmp_path / "nothing.tif"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no DEM file"):
        DemSet([tmp_path / "empty"])


def test_voids_reduce_coverage(tmp_path, dem_writer):
    """A void (nodata) square inside the block: coverage drops by its area share, and the means
    skip it and its neighbours."""
    res, x0, y0, n = 30.0, 500_000.0, 4_500_000.0, 100
    z = np.full((n, n), 800.0)
    z[40:60, 40:60] = -9999.0  # the file's nodata
    path = dem_writer(tmp_path / "void.tif", z, x0, y0, res, "EPSG:32637")
    to_ll = Transformer.from_crs(32637, 4326, always_xy=True)
    lo, la = to_ll.transform([x0 + 300, x0 + 2700], [y0 - 2700, y0 - 300])
    f = DemSet([path]).factors(shapely.box(lo[0], la[0], lo[1], la[1]))
    assert f.dem_coverage == pytest.approx(1 - 400 / 80**2, abs=0.01)
    assert f.mean_elevation_m == pytest.approx(800.0)
    assert f.mean_slope_deg == pytest.approx(0.0) and f.mean_roughness_m == pytest.approx(0.0)


def test_undeclared_no_data_value_is_refused(tmp_path, dem_writer):
    """−32768 in a file whose nodata is −9999: not a height (it gave a mean elevation of
    −205 m and roughness of 8,900 m over the sample batch)."""
    z = np.full((20, 20), 800.0)
    z[5, 7] = -32768.0
    path = dem_writer(tmp_path / "dem.tif", z, 10.0, 51.0, 0.01, "EPSG:4326")
    with pytest.raises(InputError) as err:
        DemSet([path]).factors(shapely.box(10.02, 50.82, 10.18, 50.98))
    # the cell's centre: lon 10 + 7.5·0.01 = 10.075, lat 51 − 5.5·0.01 = 50.945
    assert "dem.tif" in str(err.value) and "1 cell(s) beyond any height on Earth" in str(err.value)
    assert "the first -32768 at x 10.075, y 50.945" in str(err.value)


def test_dem_of_several_bands_is_refused(tmp_path):
    with rasterio.open(
        tmp_path / "dem.tif", "w", driver="GTiff", width=2, height=2, count=2, dtype="float32",
        crs="EPSG:4326", transform=from_origin(10.0, 51.0, 1.0, 1.0),
    ) as ds:  # fmt: skip
        ds.write(np.full((2, 2, 2), 100.0, np.float32))
    with pytest.raises(InputError, match="the DEM has 2 bands: expected one band of heights"):
        DemSet([tmp_path / "dem.tif"])


def test_undeclared_no_data_value_is_refused_on_an_averaged_grid(tmp_path, dem_writer):
    """Read averaged over k×k cells (more cells than max_pixels), −32768 among 800 m heights
    averages to 800 − 32768·… a plausible height: the check must still see the cell itself."""
    z = np.full((20, 20), 800.0)
    z[5, 7] = -32768.0
    path = dem_writer(tmp_path / "dem.tif", z, 10.0, 51.0, 0.01, "EPSG:4326")
    # the block's extent plus two cells: 20 to 22 cells a side (400 to 484 cells); max_pixels
    # 150 → k = 2, and the 2×2 average holding −32768 is (3·800 − 32768)/4 = −7592 m, within
    # the heights on Earth
    dem = DemSet([path], max_pixels=150)
    with pytest.raises(InputError) as err:
        dem.factors(shapely.box(10.02, 50.82, 10.18, 50.98))
    # the cell's centre: lon 10 + 7.5·0.01 = 10.075, lat 51 − 5.5·0.01 = 50.945, row 5, column 7
    assert "dem.tif" in str(err.value) and "1 cell(s) beyond any height on Earth" in str(err.value)
    assert "the first -32768 at row 5, column 7 (x 10.075, y 50.945" in str(err.value)


def test_averaged_grid_of_real_heights_is_read(tmp_path, dem_writer):
    """Heights down to −400 m and up to 8,800 m are heights: not refused on an averaged grid."""
    z = np.full((20, 20), 800.0)
    z[3, 3], z[12, 14] = -400.0, 8800.0
    path = dem_writer(tmp_path / "dem.tif", z, 10.0, 51.0, 0.01, "EPSG:4326")
    f = DemSet([path], max_pixels=150).factors(shapely.box(10.02, 50.82, 10.18, 50.98))
    assert f.resolution_factor == 2 and math.isfinite(f.mean_elevation_m)


def test_a_dem_given_as_a_link_to_nothing_is_said_to_be_one(tmp_path):
    """A DEM named by a symbolic link to a file since moved was 'DEM file or folder not found'."""
    link = tmp_path / "dem.tif"
    link.symlink_to(tmp_path / "moved.tif")
    with pytest.raises(InputError) as exc:
        DemSet([link])
    assert str(exc.value.problems[0]) == (
        f"{link}: a symbolic link to {tmp_path / 'moved.tif'}, which does not exist"
    )
    with pytest.raises(InputError, match="DEM file or folder not found"):
        DemSet([tmp_path / "moved.tif"])
