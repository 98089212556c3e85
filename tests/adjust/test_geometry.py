"""Stacked RFM geometry checked against the single-scene model and finite differences."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares

from blockqc.adjust import geometry
from blockqc.adjust.geometry import (
    RPCStack,
    intersect,
    intersect_at_height,
    project_adjusted,
)
from blockqc.errors import InputError
from blockqc.rfm.model import ImageAffine, RefinedRFM
from blockqc.rfm.readers import read_rpc

DATA = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
LEFT = read_rpc(DATA / "left_image.geom")
RIGHT = read_rpc(DATA / "right_image.geom")
STACK = RPCStack.from_models([LEFT, RIGHT])
AFFINE = np.array([[3.0, 1e-4, -2e-4, -5.0, 3e-5, 1e-4], [1.0, 2e-5, 3e-5, 2.0, -1e-4, 2e-5]])


def _ground(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return (
        5.285 + rng.uniform(-0.05, 0.05, n),
        44.137 + rng.uniform(-0.05, 0.05, n),
        rng.uniform(300.0, 1800.0, n),
    )


def test_stack_matches_single_models_in_any_scene_order():
    lon, lat, h = _ground(50)
    idx = np.random.default_rng(1).integers(0, 2, 50)
    line, samp, _ = STACK.project(idx, lon, lat, h)
    for k, model in enumerate((LEFT, RIGHT)):
        l1, s1 = model.ground_to_image(lon, lat, h)
        np.testing.assert_allclose(line[idx == k], l1[idx == k], atol=1e-9)
        np.testing.assert_allclose(samp[idx == k], s1[idx == k], atol=1e-9)


def test_partials_agree_with_central_differences():
    lon, lat, h = _ground(20)
    idx = np.arange(20) % 2
    _, _, jac = STACK.project(idx, lon, lat, h, partials=True)
    steps = (1e-6, 1e-6, 1e-2)
    for axis, eps in enumerate(steps):
        plus = [lon, lat, h]
        minus = [lon, lat, h]
        plus[axis] = plus[axis] + eps
        minus[axis] = minus[axis] - eps
        lp, sp, _ = STACK.project(idx, *plus)
        lm, sm, _ = STACK.project(idx, *minus)
        np.testing.assert_allclose(jac[:, 0, axis], (lp - lm) / (2 * eps), rtol=1e-5, atol=1e-4)
        np.testing.assert_allclose(jac[:, 1, axis], (sp - sm) / (2 * eps), rtol=1e-5, atol=1e-4)


def test_adjusted_projection_satisfies_the_contract_equation_and_imageaffine():
    lon, lat, h = _ground(30)
    idx = np.arange(30) % 2
    line, samp = project_adjusted(STACK, AFFINE, idx, lon, lat, h)
    rl, rs, _ = STACK.project(idx, lon, lat, h)
    a = AFFINE[idx]
    # l = RFM_l + a0 + a1·s + a2·l, s = RFM_s + b0 + b1·s + b2·l (contract v1.1)
    np.testing.assert_allclose(line, rl + a[:, 0] + a[:, 1] * samp + a[:, 2] * line, atol=1e-8)
    np.testing.assert_allclose(samp, rs + a[:, 3] + a[:, 4] * samp + a[:, 5] * line, atol=1e-8)
    # the same model as ImageAffine with negated parameters
    for k, model in enumerate((LEFT, RIGHT)):
        refined = RefinedRFM(model, ImageAffine(*(-AFFINE[k])))
        lr, sr = refined.ground_to_image(lon[idx == k], lat[idx == k], h[idx == k])
        np.testing.assert_allclose(line[idx == k], lr, atol=1e-8)
        np.testing.assert_allclose(samp[idx == k], sr, atol=1e-8)


@settings(max_examples=25, deadline=None)
@given(
    st.floats(-0.04, 0.04),
    st.floats(-0.04, 0.04),
    st.floats(200.0, 2000.0),
    st.floats(-20.0, 20.0),
    st.floats(-20.0, 20.0),
)
def test_intersection_recovers_the_ground_point(dlon, dlat, h, a0, b0):
    affine = AFFINE.copy()
    affine[0, 0], affine[1, 3] = a0, b0
    lon, lat = np.array([5.285 + dlon]), np.array([44.137 + dlat])
    idx = np.array([0, 1])
    line, samp = project_adjusted(STACK, affine, idx, np.r_[lon, lon], np.r_[lat, lat], [h, h])
    res = intersect(STACK, affine, idx, np.array([0, 0]), line, samp)
    assert res.converged.all()
    assert abs(res.lon[0] - lon[0]) < 1e-9 and abs(res.lat[0] - lat[0]) < 1e-9
    assert abs(res.h[0] - h) < 1e-4
    assert np.abs(res.v_line).max() < 1e-6 and np.abs(res.v_sample).max() < 1e-6


def test_intersection_residuals_are_computed_minus_measured():
    lon, lat, h = _ground(1, seed=3)
    idx = np.array([0, 1])
    line, samp = project_adjusted(STACK, AFFINE, idx, np.r_[lon, lon], np.r_[lat, lat], np.r_[h, h])
    line[0] += 1.0  # one measurement moved: the two rays no longer meet
    res = intersect(STACK, AFFINE, idx, np.array([0, 0]), line, samp)
    ground = (np.r_[res.lon, res.lon], np.r_[res.lat, res.lat], np.r_[res.h, res.h])
    comp_l, comp_s = project_adjusted(STACK, AFFINE, idx, *ground)
    np.testing.assert_allclose(res.v_line, comp_l - line, atol=1e-6)
    np.testing.assert_allclose(res.v_sample, comp_s - samp, atol=1e-6)
    assert np.hypot(res.v_line, res.v_sample).max() > 0.01


def test_one_ray_needs_a_height_prior():
    lon, lat, h = _ground(1, seed=4)
    line, samp = project_adjusted(STACK, AFFINE, [0], lon, lat, h)
    res = intersect(STACK, AFFINE, [0], [0], line, samp)
    assert not res.converged[0] and np.isnan(res.h[0])
    res = intersect(STACK, AFFINE, [0], [0], line, samp, height_prior=(h, 1.0))
    assert res.converged[0]
    assert abs(res.lon[0] - lon[0]) < 1e-9 and abs(res.h[0] - h[0]) < 1e-6


def test_intersect_at_height_inverts_the_adjusted_projection():
    lon, lat, h = _ground(40, seed=5)
    idx = np.arange(40) % 2
    line, samp = project_adjusted(STACK, AFFINE, idx, lon, lat, h)
    lo, la, ok = intersect_at_height(STACK, AFFINE, idx, line, samp, h)
    assert ok.all()
    np.testing.assert_allclose(lo, lon, atol=1e-10)
    np.testing.assert_allclose(la, lat, atol=1e-10)


def test_intersect_at_height_in_batches_keeps_each_observation_its_own(monkeypatch):
    """Batches of scene-sorted observations put back in the caller's order, NaN heights kept."""
    monkeypatch.setattr(geometry, "BATCH", 7)
    lon, lat, h = _ground(40, seed=6)
    idx = np.random.default_rng(6).integers(0, 2, 40)
    line, samp = project_adjusted(STACK, AFFINE, idx, lon, lat, h)
    h[[3, 17]] = np.nan
    lo, la, ok = intersect_at_height(STACK, AFFINE, idx, line, samp, h)
    assert ok.sum() == 38 and not ok[[3, 17]].any() and np.isnan(lo[[3, 17]]).all()
    np.testing.assert_allclose(lo[ok], lon[ok], atol=1e-10)
    np.testing.assert_allclose(la[ok], lat[ok], atol=1e-10)


def test_intersection_in_batches_gives_each_point_and_observation_its_own(monkeypatch):
    """Points whose rows are shuffled and cut across batches: each point recovered, and the
    one moved measurement's misclosure on its own point's two rows only."""
    monkeypatch.setattr(geometry, "BATCH", 7)
    lon, lat, h = _ground(30, seed=7)
    rows = np.random.default_rng(7).permutation(60)
    pidx, idx = rows % 30, rows // 30
    line, samp = project_adjusted(STACK, AFFINE, idx, lon[pidx], lat[pidx], h[pidx])
    moved = int(np.flatnonzero(pidx == 11)[0])
    line[moved] += 1.0
    res = intersect(STACK, AFFINE, idx, pidx, line, samp)
    assert res.converged.all()
    others = np.arange(30) != 11
    np.testing.assert_allclose(res.lon[others], lon[others], atol=1e-9)
    np.testing.assert_allclose(res.lat[others], lat[others], atol=1e-9)
    np.testing.assert_allclose(res.h[others], h[others], atol=1e-4)
    off = np.hypot(res.v_line, res.v_sample) > 0.01
    assert set(np.flatnonzero(off)) == set(np.flatnonzero(pidx == 11))


def test_intersection_minimizes_the_image_residuals():
    """The residuals are those of least squares in image space (Σ|computed − measured|²), as a
    producer computes them, checked with scipy over RefinedRFM; the RFM-space misclosure M·v
    has another minimum when the scenes' affine terms differ (here 0.02, 0.03 per pixel)."""
    affine = np.array([[3.0, 0.02, -0.01, -5.0, 0.01, 0.03], [1.0, -0.01, 0.02, 2.0, -0.03, 0.01]])
    models = [RefinedRFM(m, ImageAffine(*(-affine[k]))) for k, m in enumerate((LEFT, RIGHT))]
    lon, lat, h = _ground(1, seed=8)
    idx = np.array([0, 1, 0, 1])
    line, samp = project_adjusted(
        STACK, affine, idx, np.repeat(lon, 4), np.repeat(lat, 4), [h[0]] * 4
    )
    line[0] += 15.0  # a gross error: large residuals
    samp[3] -= 9.0
    res = intersect(STACK, affine, idx, np.zeros(4, int), line, samp)

    def residuals(x):
        pos = [models[k].ground_to_image(x[0], x[1], x[2]) for k in idx]
        return np.ravel([[p[0] - ln, p[1] - sm] for p, ln, sm in zip(pos, line, samp, strict=True)])

    ref = least_squares(residuals, [lon[0], lat[0], h[0]], x_scale=[1e-5, 1e-5, 1.0], xtol=1e-15)
    want = ref.fun.reshape(-1, 2)
    assert np.abs(want).max() > 3.0
    np.testing.assert_allclose(res.v_line, want[:, 0], atol=1e-5)
    np.testing.assert_allclose(res.v_sample, want[:, 1], atol=1e-5)


def test_bad_affine_shape_is_an_input_error():
    with pytest.raises(InputError, match="2×6"):
        project_adjusted(STACK, np.zeros((3, 6)), [0], [5.28], [44.1], [1000.0])


def test_ray_tilts_are_the_ground_shift_per_metre_of_height():
    """Each ray's tilt is where its image point lands 50 m higher and lower, by RPCModel's own
    image → ground iteration (finite differences, in metres on the WGS-84 ellipsoid; the
    adjustment's local metres are those of a sphere, 0.2 % apart at 44° N); the difference of
    the two Pléiades rays is the pair's base-to-height ratio."""
    from pyproj import Geod

    lon, lat, h = _ground(6, seed=3)
    geod = Geod(ellps="WGS84")
    tilts = []
    for k, model in enumerate((LEFT, RIGHT)):
        got = geometry.ray_tilts(STACK, np.full(lon.size, k), lon, lat, h)
        row, col = model.ground_to_image(lon, lat, h)
        lo, la, _ = model.image_to_ground(row, col, h - 50.0)
        hi_lon, hi_lat, _ = model.image_to_ground(row, col, h + 50.0)
        az, _, dist = geod.inv(lo, la, hi_lon, hi_lat)
        east, north = dist * np.sin(np.radians(az)) / 100.0, dist * np.cos(np.radians(az)) / 100.0
        np.testing.assert_allclose(got, np.column_stack([east, north]), rtol=4e-3, atol=1e-5)
        tilts.append(got)
    bh = np.hypot(*(tilts[0] - tilts[1]).T)
    assert np.all((0.3 < bh) & (bh < 0.4))  # the Ventoux pair: a stereo pair, B/H about 0.36
