"""RANSAC per chunk rejects planted outliers (§RA-3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.matching.ransac import false_alarms, fit_model, ransac_inliers


def planted(seed: int, n_in: int, n_out: int, affine: bool):
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, 5000, (n_in + n_out, 2))
    a = np.array([[1.0005, 0.0003], [-0.0002, 0.9996]]) if affine else np.eye(2)
    dst = src @ a.T + [2.7, -1.9] + rng.normal(0, 0.15, src.shape)
    # Outliers: 4 to 30 px off in a random direction (wrong matches in the search window).
    angle = rng.uniform(0, 2 * np.pi, n_out)
    direction = np.column_stack([np.cos(angle), np.sin(angle)])
    dst[n_in:] += rng.uniform(4, 30, n_out)[:, None] * direction
    truth = np.zeros(n_in + n_out, dtype=bool)
    truth[:n_in] = True
    order = rng.permutation(n_in + n_out)
    return src[order], dst[order], truth[order]


@given(st.integers(0, 10_000), st.sampled_from(["affine", "translation"]))
@settings(max_examples=25, deadline=None)
def test_planted_outliers_are_rejected(seed, model):
    src, dst, truth = planted(seed, 200, 120, affine=(model == "affine"))
    keep = ransac_inliers(src, dst, model=model, threshold=1.5, iterations=500, seed=0)
    assert not (keep & ~truth).any()
    assert keep[truth].mean() > 0.99


def test_too_few_correspondences_are_all_rejected():
    src = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    keep = ransac_inliers(src, src + 1, model="affine", threshold=1.0, iterations=50, seed=0)
    assert not keep.any()
    keep = ransac_inliers(
        src[:1], src[:1], model="translation", threshold=1.0, iterations=5, seed=0
    )
    assert not keep.any()


def test_result_repeats_with_the_seed():
    src, dst, _ = planted(5, 300, 300, affine=True)
    a = ransac_inliers(src, dst, model="affine", threshold=1.5, iterations=300, seed=4)
    b = ransac_inliers(src, dst, model="affine", threshold=1.5, iterations=300, seed=4)
    assert np.array_equal(a, b)


def test_fit_model_recovers_an_exact_affine():
    rng = np.random.default_rng(1)
    src = rng.uniform(-100, 100, (10, 2))
    coef = np.array([[1.01, 0.02], [-0.03, 0.99], [5.0, -7.0]])
    dst = np.column_stack([src, np.ones(10)]) @ coef
    assert fit_model(src, dst, "affine") == pytest.approx(coef)
    assert fit_model(src, src + [3.0, 4.0], "translation")[2] == pytest.approx([3.0, 4.0])


def test_false_alarms_by_hand():
    # (n − need) · C(n, k) · C(k, need) · chance^(k − need)
    assert false_alarms(4, 4, 3, 0.02) == pytest.approx(1 * 1 * 4 * 0.02)
    assert false_alarms(10, 5, 3, 0.1) == pytest.approx(7 * 252 * 10 * 0.1**2)
    assert false_alarms(5, 3, 1, 1.0) == np.inf


@pytest.mark.parametrize(
    ("model", "n"),
    [("affine", 20), ("affine", 50), ("affine", 300), ("translation", 50), ("translation", 300)],
)
def test_a_consensus_that_chance_gives_is_not_kept(model, n):
    """Every correspondence wrong, spread over the ±8 px search window (17 px side): the best
    consensus is one chance gives (5 to 28 of them for an affine without the window), so none
    is kept."""
    for seed in range(20):
        rng = np.random.default_rng(seed)
        src = rng.uniform(0, 5000, (n, 2))
        dst = src + rng.uniform(-8.5, 8.5, (n, 2))
        keep = ransac_inliers(
            src, dst, model=model, threshold=1.5, iterations=500, seed=0, window=17
        )
        assert not keep.any(), (seed, int(keep.sum()))


@pytest.mark.parametrize("model", ["affine", "translation"])
def test_a_few_right_matches_among_as_many_wrong_are_kept(model):
    """8 right correspondences among 8 wrong ones in the window: far beyond chance, kept."""
    rng = np.random.default_rng(2)
    src = rng.uniform(0, 5000, (16, 2))
    dst = src + [2.7, -1.9] + rng.normal(0, 0.15, src.shape)
    dst[8:] = src[8:] + [[6.0, 6.0], [-6.0, 5.0], [7.0, -7.0], [-5.0, -6.0]] * 2
    keep = ransac_inliers(src, dst, model=model, threshold=1.5, iterations=500, seed=0, window=17)
    assert keep.tolist() == [True] * 8 + [False] * 8
