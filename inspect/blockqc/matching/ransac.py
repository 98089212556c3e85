"""RANSAC per chunk (§RA-3): keep the matches that agree with one translation or affine map.

Own vectorized implementation: all hypotheses are solved and scored at once, with a seeded
generator so a run repeats exactly. The best hypothesis is refitted by least squares on its
inliers, and inliers are recounted against the refit.
"""

from __future__ import annotations

import math

import numpy as np

_MIN_SAMPLES = {"translation": 1, "affine": 3}
_SCORED = 2000


def _design(points: np.ndarray) -> np.ndarray:
    return np.column_stack([points, np.ones(len(points))])


def fit_model(src: np.ndarray, dst: np.ndarray, model: str) -> np.ndarray:
    """Least-squares fit of dst ≈ A·[src, 1]; returns the 3×2 matrix A (translation: A[:2]=I)."""
    if model == "translation":
        coef = np.zeros((3, 2))
        coef[:2] = np.eye(2)
        coef[2] = (dst - src).mean(axis=0)
        return coef
    coef, *_ = np.linalg.lstsq(_design(src), dst, rcond=None)
    return coef


def false_alarms(n: int, k: int, need: int, chance: float) -> float:
    """Expected number of consensus sets of k among n correspondences as good as the one found
    if every correspondence were wrong (a-contrario RANSAC, Moisan & Stival 2004): (n − need)
    sizes × C(n, k) sets × C(k, need) samples × chance^(k − need), `chance` being the
    probability that a wrong correspondence falls within the threshold of the model."""
    if chance >= 1:
        return math.inf
    log_nfa = (
        math.log(n - need) + _log_comb(n, k) + _log_comb(k, need) + (k - need) * math.log(chance)
    )
    return math.exp(min(log_nfa, 700.0))


def _log_comb(n: int, k: int) -> float:
    return math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1)


def ransac_inliers(
    src: np.ndarray,
    dst: np.ndarray,
    *,
    model: str,
    threshold: float,
    iterations: int,
    seed: int,
    window: float | None = None,
) -> np.ndarray:
    """Return a boolean inlier mask of the correspondences src → dst, (n, 2) each.

    With fewer correspondences than the model needs plus one (a check needs redundancy),
    nothing can be verified and all are rejected. `window`: the side (px) of the square where a
    wrong correspondence falls (the matcher's search window); the consensus is then kept only
    when fewer than one as large is expected by chance among as many wrong ones (`false_alarms`).
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 2)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 2)
    n = len(src)
    need = _MIN_SAMPLES[model]
    if n < need + 1:
        return np.zeros(n, dtype=bool)
    # Centre the coordinates so the affine solves are well conditioned.
    centre = src.mean(axis=0)
    s = src - centre
    d = dst - centre
    rng = np.random.default_rng(seed)
    # Hypotheses are scored on at most _SCORED correspondences; the winner is then checked on all.
    scored = np.sort(rng.choice(n, _SCORED, replace=False)) if n > _SCORED else np.arange(n)
    if model == "translation":
        coefs, resid = _translation_hypotheses(s, d, scored, iterations, rng)
    else:
        hypotheses = _affine_hypotheses(s, d, scored, iterations, rng)
        if hypotheses is None:
            return np.zeros(n, dtype=bool)
        coefs, resid = hypotheses
    counts = (resid <= threshold).sum(axis=1)
    best = _refitted_inliers(s, d, coefs[np.argmax(counts)], model, threshold)
    if best is None or best.sum() < need + 1:
        return np.zeros(n, dtype=bool)
    if window is not None:
        chance = math.pi * threshold**2 / window**2
        if false_alarms(n, int(best.sum()), need, chance) >= 1:
            return np.zeros(n, dtype=bool)
    return best


def _translation_hypotheses(
    s: np.ndarray, d: np.ndarray, scored: np.ndarray, iterations: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The shifts of `iterations` correspondences drawn at random (of every one when there are
    no more): their (h, 3, 2) matrices and their residuals on the `scored` ones, (h, m)."""
    n = len(s)
    picks = rng.integers(0, n, size=iterations) if n > iterations else np.arange(n)
    shifts = d[picks] - s[picks]  # (h, 2)
    ss, ds = s[scored], d[scored]
    resid = np.hypot(*np.moveaxis(ss[None] + shifts[:, None] - ds[None], 2, 0))
    coefs = np.zeros((len(picks), 3, 2))
    coefs[:, :2] = np.eye(2)
    coefs[:, 2] = shifts
    return coefs, resid


def _affine_hypotheses(
    s: np.ndarray, d: np.ndarray, scored: np.ndarray, iterations: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray] | None:
    """The affine maps through `iterations` triples drawn at random, the degenerate ones left
    out: their (h, 3, 2) matrices and their residuals on the `scored` correspondences, (h, m);
    None when every triple is degenerate."""
    n = len(s)
    samples = rng.integers(0, n, size=(iterations, 3))  # repeated picks are degenerate
    a = np.concatenate([s[samples], np.ones((iterations, 3, 1))], axis=2)  # (h, 3, 3)
    b = d[samples]  # (h, 3, 2)
    ok = np.abs(np.linalg.det(a)) > 1e-6
    if not ok.any():
        return None
    coefs = np.linalg.solve(a[ok], b[ok])  # (h', 3, 2)
    pred = np.einsum("nk,hkj->hnj", _design(s[scored]), coefs)
    resid = np.hypot(*np.moveaxis(pred - d[scored][None], 2, 0))
    return coefs, resid


def _refitted_inliers(
    s: np.ndarray, d: np.ndarray, winner: np.ndarray, model: str, threshold: float
) -> np.ndarray | None:
    """The inliers of the winning hypothesis among all correspondences, refitted by least
    squares on them and recounted (twice, while enough are left); None when too few agree
    with the winner for a fit."""
    need = _MIN_SAMPLES[model]
    best = np.hypot(*(_design(s) @ winner - d).T) <= threshold
    if best.sum() < need:
        return None
    for _ in range(2):  # refit on the inliers, recount
        coef = fit_model(s[best], d[best], model)
        refined = np.hypot(*(_design(s) @ coef - d).T) <= threshold
        if refined.sum() < need:
            break
        best = refined
    return best
