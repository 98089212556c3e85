"""The RPC00B model: round trips, agreement with GDAL, the §3 affine refinement."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rfm_helpers import REAL_RPC_FILES, VENTOUX, domain, gdal_transformer

from blockqc.errors import InputError
from blockqc.rfm.model import ImageAffine, RefinedRFM, fit_affine
from blockqc.rfm.readers import read_rpc

LEFT = read_rpc(VENTOUX / "left_image.geom")


@pytest.fixture(params=REAL_RPC_FILES, ids=lambda p: p.name)
def real_rpc(request: pytest.FixtureRequest):
    """Every real RPC file of tests/data/rfm, read by `read_rpc`."""
    return request.param, read_rpc(request.param)


M_PER_DEG_LAT = 110_574.0  # WGS-84 metres per degree of latitude near 45°, to express errors in m


def image_sample(m, n, seed, extent):
    """Image points over the model's image domain (offset ± scale) at heights in its range."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-extent, extent, (3, n))
    return (
        m.line_off + u[0] * abs(m.line_scale),
        m.samp_off + u[1] * abs(m.samp_scale),
        m.height_off + u[2] * abs(m.height_scale),
    )


def ground_error_m(lon_a, lat_a, lon_b, lat_b):
    east = (lon_a - lon_b) * M_PER_DEG_LAT * np.cos(np.radians(lat_a))
    north = (lat_a - lat_b) * M_PER_DEG_LAT
    return np.hypot(east, north)


def test_round_trips_on_every_real_rpc(real_rpc):
    path, m = real_rpc
    row, col, h = image_sample(m, 500, seed=1, extent=domain(path))
    lon, lat, h_out = m.image_to_ground(row, col, h)
    assert np.all(np.isfinite(lon)) and np.array_equal(h_out, h)
    # image → ground → image
    row2, col2 = m.ground_to_image(lon, lat, h)
    assert np.max(np.hypot(row2 - row, col2 - col)) < 1e-6
    # ground → image → ground
    lon2, lat2, _ = m.image_to_ground(row2, col2, h)
    assert np.max(ground_error_m(lon2, lat2, lon, lat)) < 1e-3


def test_ground_to_image_agrees_with_gdal(real_rpc):
    """GDAL's RPC transformer counts pixel corners: GDAL (row, col) = ours + 0.5."""
    path, m = real_rpc
    row, col, h = image_sample(m, 200, seed=2, extent=domain(path))
    lon, lat, _ = m.image_to_ground(row, col, h)
    with gdal_transformer(m) as t:
        g_row, g_col = t.rowcol(lon, lat, h, op=float)
    ours_row, ours_col = m.ground_to_image(lon, lat, h)
    assert np.max(np.abs(np.asarray(g_row) - 0.5 - ours_row)) < 0.01
    assert np.max(np.abs(np.asarray(g_col) - 0.5 - ours_col)) < 0.01


def test_image_to_ground_agrees_with_gdal(real_rpc):
    path, m = real_rpc
    row, col, h = image_sample(m, 100, seed=3, extent=domain(path))
    lon, lat, _ = m.image_to_ground(row, col, h)
    # GDAL iterates to RPC_PIXEL_ERROR_THRESHOLD (0.1 px by default); ask it for more
    with gdal_transformer(m, RPC_PIXEL_ERROR_THRESHOLD=1e-6) as t:
        g_lon, g_lat = t.xy(row, col, h)  # offset="center" adds GDAL's half pixel
    # 0.01 px expressed on the ground through the model itself
    row_g, col_g = m.ground_to_image(np.asarray(g_lon), np.asarray(g_lat), h)
    assert np.max(np.hypot(row_g - row, col_g - col)) < 0.01


@settings(max_examples=60, deadline=None)
@given(
    u=st.floats(-1, 1),
    v=st.floats(-1, 1),
    w=st.floats(-1, 1),
)
def test_round_trip_property_pleiades(u, v, w):
    m = LEFT
    lon = m.lon_off + u * m.lon_scale
    lat = m.lat_off + v * m.lat_scale
    h = m.height_off + w * m.height_scale
    row, col = m.ground_to_image(lon, lat, h)
    lon2, lat2, _ = m.image_to_ground(row, col, h)
    assert ground_error_m(lon2, lat2, lon, lat) < 1e-3


def test_image_to_ground_on_a_dem_lands_on_the_dem():
    """On a sloping surface h(lon, lat), the point found lies on it and projects back."""
    m = LEFT

    def surface(lon, lat):
        return 500.0 + 4000.0 * (lon - 5.19) - 2500.0 * (lat - 44.2)

    row = np.array([5000.0, 5200.0, 5499.0])
    col = np.array([5000.0, 5300.0, 5100.0])
    lon, lat, h = m.image_to_ground(row, col, surface)
    assert np.max(np.abs(h - surface(lon, lat))) < 1e-4
    r2, c2 = m.ground_to_image(lon, lat, h)
    assert np.max(np.hypot(r2 - row, c2 - col)) < 1e-6


def test_steep_surface_is_intersected_where_iteration_cannot_converge():
    """A surface at 85° slope: the fixed-point iteration diverges (tan 85° · tan 8.6° > 1); the
    line-of-sight search still finds the crossing."""
    m = LEFT

    def cliff(lon, lat):
        return 500.0 + 1.0e6 * (lon - 5.2)

    row, col = m.ground_to_image(np.array([5.2, 5.2001]), np.array([44.14, 44.15]), 500.0)
    lon, lat, h = m.image_to_ground(row, col, cliff)
    assert np.all(np.isfinite(h))
    assert np.max(np.abs(h - cliff(lon, lat))) < 1e-4
    r2, c2 = m.ground_to_image(lon, lat, h)
    assert np.max(np.hypot(r2 - row, c2 - col)) < 1e-6


def test_points_outside_a_dem_get_nan():
    lon, lat, h = LEFT.image_to_ground(
        np.array([5000.0]), np.array([5000.0]), lambda lo, la: np.full_like(lo, np.nan)
    )
    assert np.isnan(lon).all() and np.isnan(lat).all()


def test_rays_over_a_dem_void_get_nan_not_the_void_edge():
    """A flat DEM at 1000 m with a void of ±2e-5° (about ±2 m) around where pixel (5000, 5000)
    sees it: that ray meets no DEM value and gets NaN; its search for the surface bisected
    into the void (a void sample taken for 'below the surface') and stopped at the void's
    edge, some metres above the surface and off it. Every other pixel around lands on 1000 m."""
    m = LEFT
    lon0, lat0, _ = m.image_to_ground(np.array([5000.0]), np.array([5000.0]), 1000.0)

    def holed(lon, lat):
        void = (np.abs(lon - lon0[0]) < 2e-5) & (np.abs(lat - lat0[0]) < 2e-5)
        return np.where(void, np.nan, 1000.0)

    row, col = np.meshgrid(np.arange(4980.0, 5021.0, 2.0), np.arange(4980.0, 5021.0, 2.0))
    lon, lat, h = m.image_to_ground(row.ravel(), col.ravel(), holed)
    centre = (row.ravel() == 5000.0) & (col.ravel() == 5000.0)
    assert np.isnan(h[centre]).all() and np.isnan(lon[centre]).all()
    found = np.isfinite(h)
    assert np.array_equal(found, np.isfinite(lon)) and np.array_equal(found, np.isfinite(lat))
    np.testing.assert_allclose(holed(lon[found], lat[found]), 1000.0)  # on the surface, no void
    np.testing.assert_allclose(h[found], 1000.0, atol=1e-6)
    assert found.sum() > 0.8 * found.size


# -- §3 affine refinement ---------------------------------------------------------------------
KNOWN = ImageAffine(a0=3.2, a1=2e-5, a2=-1.5e-5, b0=-4.7, b1=-3e-5, b2=1e-5)


def test_affine_inverse_is_exact():
    row = np.array([0.0, 1000.0, 25000.0])
    col = np.array([0.0, 30000.0, 12000.0])
    rr, cc = KNOWN.to_rfm_space(row, col)
    # by hand for the second point: Δl = 3.2 + 2e-5*30000 - 1.5e-5*1000 = 3.785
    assert rr[1] == pytest.approx(1000.0 + 3.785, abs=1e-9)
    assert cc[1] == pytest.approx(30000.0 - 4.7 - 0.9 + 0.01, abs=1e-9)
    r2, c2 = KNOWN.from_rfm_space(rr, cc)
    np.testing.assert_allclose(r2, row, atol=1e-9)
    np.testing.assert_allclose(c2, col, atol=1e-9)


def test_fit_recovers_a_known_affine_exactly():
    """CPs made with a known affine: the least-squares fit returns it and leaves no residual."""
    rng = np.random.default_rng(5)
    row = rng.uniform(0, 41800, 12)
    col = rng.uniform(0, 39180, 12)
    h = rng.uniform(300, 1800, 12)
    lon, lat, _ = RefinedRFM(LEFT, KNOWN).image_to_ground(row, col, h)
    refined, residuals = fit_affine(LEFT, lon, lat, h, row, col)
    for name, value in KNOWN.as_dict().items():
        assert getattr(refined.affine, name) == pytest.approx(value, rel=1e-7, abs=1e-9), name
    assert np.max(np.abs(residuals)) < 1e-6
    r2, c2 = refined.ground_to_image(lon, lat, h)
    assert np.max(np.hypot(r2 - row, c2 - col)) < 1e-6


def test_fit_with_three_points_is_exact():
    row = np.array([100.0, 20000.0, 100.0])
    col = np.array([100.0, 100.0, 30000.0])
    h = np.full(3, 800.0)
    lon, lat, _ = RefinedRFM(LEFT, KNOWN).image_to_ground(row, col, h)
    refined, _ = fit_affine(LEFT, lon, lat, h, row, col)
    assert refined.affine.a0 == pytest.approx(KNOWN.a0, abs=1e-6)
    assert refined.affine.b1 == pytest.approx(KNOWN.b1, abs=1e-10)


def test_fit_refuses_too_few_or_collinear_points():
    with pytest.raises(InputError, match="≥ 3"):
        fit_affine(LEFT, [5.2, 5.3], [44.1, 44.2], [500, 500], [1, 2], [1, 2])
    row = np.array([0.0, 100.0, 200.0, 300.0])
    lon, lat, _ = LEFT.image_to_ground(row, row, 500.0)
    with pytest.raises(InputError, match="collinear"):
        fit_affine(LEFT, lon, lat, np.full(4, 500.0), row, row)


def test_positions_far_outside_the_model_give_nan_without_numpy_warnings():
    """Image positions 1e7 px away (a wrong --crop-offset): Newton overflows there. It gave
    NaN as it should, but printed 14 numpy RuntimeWarnings (overflow, invalid value, divide by
    zero) on stderr before the run's message."""
    import warnings

    m = LEFT
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lon, lat, _ = m.image_to_ground(np.array([1e7, 1e7 + 500]), np.array([1e7, 1e7]), 500.0)
    assert np.all(np.isnan(lon)) and np.all(np.isnan(lat))
