"""The block adjustment against a synthetic truth, and its datum in a two-image block."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from blockqc.adjust.geometry import RPCStack, project_adjusted
from blockqc.adjust.run import weak_height_prior
from blockqc.adjust.solver import Observations, Priors, Settings, adjust
from blockqc.adjust.synthetic import SyntheticConfig, simulate_truth
from blockqc.errors import InputError
from blockqc.rfm.readers import read_rpc

DATA = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
MODELS = [read_rpc(DATA / "left_image.geom"), read_rpc(DATA / "right_image.geom")]


def _problem(truth, cfg, fixed=None):
    order = np.argsort(truth.obs_scene, kind="stable")
    n = len(truth.scene_ids)
    obs = Observations(
        truth.obs_scene[order],
        truth.obs_point[order],
        truth.line[order],
        truth.sample[order],
        n,
        truth.point_lon.size,
    )
    stack = RPCStack.from_models(truth.models)
    h0, hs, text = weak_height_prior(stack, obs.n_points)
    fixed = np.zeros(n, bool) if fixed is None else fixed
    priors = Priors(cfg.sigma_shift_px, cfg.sigma_linear_px, fixed, h0, hs, text)
    return stack, obs, priors, order


def test_synthetic_truth_sigma0_and_coverage():
    """σ0 within 5 % of the simulated noise; ≥ 93 % of the true affine parameters within 2σ
    (pooled over four blocks: without GCPs each block's datum is one draw of the priors)."""
    inside = []
    for seed in range(100, 104):
        cfg = SyntheticConfig(scenes=16, observations_per_scene=1000, noise_px=0.3, seed=seed)
        truth = simulate_truth(MODELS, cfg)
        stack, obs, priors, order = _problem(truth, cfg)
        sol, v0l, v0s = adjust(stack, obs, truth.lines, truth.samples, priors, Settings())
        assert sol.converged
        assert abs(sol.sigma0_px - 0.3) < 0.05 * 0.3
        inside.append(np.abs(sol.affine - truth.affine) <= 2 * sol.affine_sigma)
        gross = truth.gross[order]
        assert sol.outlier[gross].mean() > 0.8  # gross errors are found
        assert sol.outlier[~gross].mean() < 0.02
        kept = ~sol.outlier
        after = np.sqrt(np.mean(sol.v_line[kept] ** 2 + sol.v_sample[kept] ** 2))
        before = np.sqrt(np.mean(v0l[kept] ** 2 + v0s[kept] ** 2))
        assert after < 0.3 < 3.0 < before
    assert np.mean(inside) >= 0.93


def test_fixed_scene_keeps_its_rpc():
    cfg = SyntheticConfig(scenes=6, observations_per_scene=500, seed=7)
    truth = simulate_truth(MODELS, cfg)
    fixed = np.zeros(6, bool)
    fixed[2] = True
    stack, obs, priors, _ = _problem(truth, cfg, fixed=fixed)
    sol, _, _ = adjust(stack, obs, truth.lines, truth.samples, priors, Settings())
    assert sol.converged
    assert np.all(sol.affine[2] == 0.0) and np.all(sol.affine_sigma[2] == 0.0)
    assert np.all(sol.affine_sigma[[0, 1, 3, 4, 5]] > 0.0)


def test_noise_free_block_is_reproduced_exactly():
    cfg = SyntheticConfig(
        scenes=6, observations_per_scene=500, noise_px=0.0, outlier_rate=0.0, seed=8
    )
    truth = simulate_truth(MODELS, cfg)
    stack, obs, priors, _ = _problem(truth, cfg)
    # almost free affines: the fit is then exact whatever the datum
    priors = Priors(1e2, 1e2, priors.fixed, priors.height, priors.height_sigma, "weak")
    sol, _, _ = adjust(stack, obs, truth.lines, truth.samples, priors, Settings())
    assert np.abs(sol.v_line).max() < 1e-3 and np.abs(sol.v_sample).max() < 1e-3
    assert not sol.outlier.any()
    ground = sol.lon[obs.point], sol.lat[obs.point], sol.h[obs.point]
    line, samp = project_adjusted(stack, sol.affine, obs.scene, *ground)
    np.testing.assert_allclose(line, obs.line, atol=1e-3)
    np.testing.assert_allclose(samp, obs.sample, atol=1e-3)


def test_two_image_block_without_heights_stays_bounded():
    """Two scenes, no DEM: the affine priors and the weak height prior keep the parallax
    direction (heights) bounded; the heights' σ stay finite and the truth is inside 3σ."""
    cfg = SyntheticConfig(scenes=2, observations_per_scene=800, noise_px=0.3, seed=11)
    truth = simulate_truth(MODELS, cfg)
    stack, obs, priors, _ = _problem(truth, cfg)
    sol, _, _ = adjust(stack, obs, truth.lines, truth.samples, priors, Settings())
    assert sol.converged
    used = sol.point_used
    sig_h = sol.ground_sigma[used, 2]
    assert np.all(np.isfinite(sig_h)) and sig_h.max() < 200.0
    assert np.mean(np.abs(sol.h[used] - truth.point_h[used]) <= 3 * sig_h) > 0.95


def test_weak_height_prior_keeps_the_heights_of_the_rays():
    """No DEM, the ground 600 m above the RPCs' HEIGHT_OFF, thousands of points: the weak
    prior weighs as one observation of the block's mean height, so the heights and the shifts
    stay those the rays and the affine priors give (a prior at HEIGHT_OFF on every point, summed
    over the points, pulled the block hundreds of metres down and the shifts far beyond their
    a-priori σ)."""
    cfg = SyntheticConfig(
        scenes=2, observations_per_scene=3000, outlier_rate=0.0, terrain_above_m=600.0, seed=13
    )
    truth = simulate_truth(MODELS, cfg)
    stack, obs, priors, _ = _problem(truth, cfg)
    sol, _, _ = adjust(stack, obs, truth.lines, truth.samples, priors, Settings())
    assert sol.converged
    used = sol.point_used
    error = sol.h[used] - truth.point_h[used]
    assert abs(np.mean(error)) <= 3 * np.median(sol.ground_sigma[used, 2])
    assert np.all(np.abs(sol.affine[:, [0, 3]]) <= 3 * cfg.sigma_shift_px)  # a0, b0


def test_free_datum_is_reported_singular():
    cfg = SyntheticConfig(scenes=2, observations_per_scene=300, seed=12)
    truth = simulate_truth(MODELS, cfg)
    stack, obs, priors, _ = _problem(truth, cfg)
    free = Priors(np.inf, np.inf, priors.fixed, priors.height, priors.height_sigma, "none")
    with pytest.raises(InputError, match="singular"):
        adjust(stack, obs, truth.lines, truth.samples, free, Settings())


def test_estimate_is_linear_in_the_image_noise():
    """Least squares is linear in the observations' noise: the estimates from +noise and −noise
    average to the noise-free one. A misclosure weighted by the affine's own M (measured
    positions in the affine terms) is not: the noise pulled every scene's scale terms one way,
    a bias of the datum about as large as its σ."""
    cfg = SyntheticConfig(
        scenes=16, observations_per_scene=1000, noise_px=0.0, outlier_rate=0.0, seed=7
    )
    truth = simulate_truth(MODELS, cfg)
    stack, obs, priors, order = _problem(truth, cfg)
    noise = np.random.default_rng(3).normal(0.0, 0.3, (2, obs.line.size))
    settings = Settings(tol_px=1e-7, max_iterations=40, sigma_image_px=0.3, min_sigma_px=0.3)

    def solve(sign: float):
        o = Observations(
            obs.scene, obs.point, obs.line + sign * noise[0], obs.sample + sign * noise[1],
            obs.n_scenes, obs.n_points,
        )  # fmt: skip
        sol, _, _ = adjust(stack, o, truth.lines, truth.samples, priors, settings)
        assert sol.converged
        return sol

    zero, plus, minus = solve(0.0), solve(1.0), solve(-1.0)
    even = (plus.normalized + minus.normalized - 2 * zero.normalized) / plus.normalized_sigma
    assert np.abs(even).max() < 0.05
