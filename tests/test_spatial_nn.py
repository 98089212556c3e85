"""Exact nearest neighbours per pattern for Clark–Evans R (§AF-10, §TP-4).

The grid search is checked against the full distance matrix of each pattern (brute force) on
random patterns of every awkward kind, and against one k-d tree per pattern on 200 000 points.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from blockqc import spatial
from blockqc.spatial import clark_evans_grouped, nearest_neighbour_distances

KINDS = ("uniform", "clustered", "duplicates", "collinear", "lattice", "outlier", "hole")


def brute_nearest(x: np.ndarray, y: np.ndarray, g: np.ndarray, k: int) -> np.ndarray:
    """Each point's nearest distance within its group from the full distance matrix."""
    out = np.full(len(x), np.nan)
    for code in range(k):
        idx = np.flatnonzero(g == code)
        if len(idx) < 2:
            continue
        dx = x[idx, None] - x[None, idx]
        dy = y[idx, None] - y[None, idx]
        d = np.sqrt(dx * dx + dy * dy)
        np.fill_diagonal(d, np.inf)
        out[idx] = d.min(axis=1)
    return out


def donnelly_r(mean_nn: float, n: int, area: float, perimeter: float) -> float:
    """Clark–Evans R with Donnelly's edge-corrected expectation, written out for the test."""
    expected = 0.5 * math.sqrt(area / n) + (0.0514 + 0.041 / math.sqrt(n)) * perimeter / n
    return mean_nn / expected


def pattern(rng: np.random.Generator, kind: str, m: int, scale: float) -> np.ndarray:
    """m points of one kind spread over about `scale` units."""
    if kind == "uniform":
        return rng.uniform(0, scale, (m, 2))
    if kind == "clustered":  # three tight clusters
        centres = rng.uniform(0, scale, (3, 2))
        return centres[rng.integers(0, 3, m)] + rng.normal(0, scale * 1e-3, (m, 2))
    if kind == "duplicates":  # every point repeated about four times
        sites = rng.uniform(0, scale, (max(1, m // 4), 2))
        return sites[rng.integers(0, len(sites), m)]
    if kind == "collinear":  # horizontal, vertical or diagonal
        t = rng.uniform(0, scale, m)
        return np.column_stack([t, t]) * rng.choice([[1, 0], [0, 1], [1, 1]], axis=0)
    if kind == "lattice":  # equal distances everywhere: ties
        side = max(1, math.ceil(math.sqrt(m)))
        cells = np.arange(m)
        return np.column_stack([cells % side, cells // side]) * (scale / side)
    if kind == "outlier":  # a tight cloud and one point far away
        pts = rng.uniform(0, scale * 1e-3, (m, 2))
        pts[:1] = scale
        return pts
    # "hole": uniform points around an empty disc with one point at its centre
    pts = rng.uniform(0, scale, (m, 2))
    far = np.hypot(pts[:, 0] - scale / 2, pts[:, 1] - scale / 2) > 0.3 * scale
    pts = pts[far]
    return np.vstack([pts, [[scale / 2, scale / 2]]])[:m]


GROUP = st.tuples(
    st.sampled_from(KINDS),
    st.integers(0, 60),
    st.sampled_from([1e-6, 1.0, 50.0, 45_000.0, 1e7]),
    st.sampled_from([0.0, -3.5e3, 1e6]),
)


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    groups=st.lists(GROUP, min_size=1, max_size=6),
    empty_after=st.integers(0, 2),
    mixed=st.booleans(),
)
def test_equals_brute_force(seed, groups, empty_after, mixed):
    """Per-point distances and per-pattern means equal the full distance matrix's, for uniform,
    clustered, duplicated, collinear, lattice and sparse patterns, tiny to huge, given in order
    or mixed, with empty and single-point groups."""
    rng = np.random.default_rng(seed)
    parts = [pattern(rng, kind, m, scale) + offset for kind, m, scale, offset in groups]
    pts = np.vstack(parts)
    g = np.repeat(np.arange(len(parts)), [len(p) for p in parts])
    if mixed:
        order = rng.permutation(len(g))
        pts, g = pts[order], g[order]
    k = len(parts) + empty_after
    x, y = pts[:, 0], pts[:, 1]
    expected = brute_nearest(x, y, g, k)
    got = nearest_neighbour_distances(x, y, g, k)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    n = np.bincount(g, minlength=k)
    area, perimeter = np.full(k, 1e6), np.full(k, 4e3)
    r = clark_evans_grouped(x, y, g, area, perimeter)
    for code in range(k):
        if n[code] < 2:
            assert math.isnan(r[code])
        else:
            mean = expected[g == code].mean()
            want = donnelly_r(mean, n[code], 1e6, 4e3)
            assert r[code] == pytest.approx(want, rel=1e-12, abs=1e-300)


def test_matches_kd_tree_on_200k_points():
    """40 scenes of 5000 points in pixels (uniform, half water, clustered, jittered lattice, with
    repeated points), rows mixed: the same distances and R as one k-d tree per scene."""
    rng = np.random.default_rng(2026)
    size, m, k = 13_915.0, 5000, 40
    parts = []
    for code in range(k):
        kind = code % 4
        if kind == 0:
            p = rng.uniform(0, size, (m, 2))
        elif kind == 1:  # water on the right: points on the left 40 % only
            p = rng.uniform(0, size, (m, 2)) * [0.4, 1.0]
        elif kind == 2:
            centres = rng.uniform(0, size, (25, 2))
            p = centres[rng.integers(0, 25, m)] + rng.normal(0, 150.0, (m, 2))
        else:
            yy, xx = np.mgrid[0:50, 0:100] * (size / 100)
            p = np.column_stack([xx.ravel(), yy.ravel()]) + rng.normal(0, 5.0, (m, 2))
        p[rng.integers(0, m, m // 10)] = p[rng.integers(0, m, m // 10)]  # repeated points
        parts.append(np.clip(p, 0, size))
    pts = np.vstack(parts)
    g = np.repeat(np.arange(k), m)
    order = rng.permutation(len(g))
    pts, g = pts[order], g[order]
    expected = np.empty(len(g))
    for code in range(k):
        idx = np.flatnonzero(g == code)
        expected[idx] = cKDTree(pts[idx]).query(pts[idx], k=2)[0][:, 1]
    got = nearest_neighbour_distances(pts[:, 0], pts[:, 1], g, k)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    assert (got == 0).sum() >= k * 400  # the repeated points count at distance 0
    area, perimeter = np.full(k, size * size), np.full(k, 4 * size)
    r = clark_evans_grouped(pts[:, 0], pts[:, 1], g, area, perimeter)
    want = [donnelly_r(expected[g == c].mean(), m, size * size, 4 * size) for c in range(k)]
    np.testing.assert_allclose(r, want, rtol=1e-12)


def test_patterns_larger_than_a_batch():
    """A pattern of 150 000 points (more cells than one 16-bit digit) and a long line of 40 000
    points, rows mixed: the same distances as one k-d tree per pattern."""
    rng = np.random.default_rng(17)
    big = rng.uniform(0, 45_000.0, (150_000, 2))
    line = np.column_stack([rng.uniform(0, 45_000.0, 40_000), np.full(40_000, 7.0)])
    pts = np.vstack([big, line])
    g = np.repeat([1, 0], [len(big), len(line)])
    order = rng.permutation(len(g))
    pts, g = pts[order], g[order]
    got = nearest_neighbour_distances(pts[:, 0], pts[:, 1], g, 2)
    for code in (0, 1):
        idx = np.flatnonzero(g == code)
        want = cKDTree(pts[idx]).query(pts[idx], k=2)[0][:, 1]
        np.testing.assert_allclose(got[idx], want, rtol=1e-12, atol=0)


def test_hand_example():
    """A 1×2 rectangle's corners (nearest 1), three points on a line at 0, 2 and 5 (nearest 2, 2,
    3), a lone point (NaN) and an empty group, rows interleaved."""
    x = np.array([0.0, 0.0, 9.0, 1.0, 2.0, 0.0, 5.0, 1.0])
    y = np.array([0.0, 7.0, 9.0, 0.0, 7.0, 2.0, 7.0, 2.0])
    g = np.array([0, 1, 2, 0, 1, 0, 1, 0])
    got = nearest_neighbour_distances(x, y, g, 4)
    np.testing.assert_array_equal(got, [1.0, 2.0, np.nan, 1.0, 2.0, 1.0, 3.0, 1.0])
    r = clark_evans_grouped(x, y, g, np.array([100.0, 100.0, 100.0, 100.0]))
    assert r[0] == pytest.approx(1.0 / (0.5 * math.sqrt(100 / 4)))
    assert r[1] == pytest.approx((7 / 3) / (0.5 * math.sqrt(100 / 3)))
    assert math.isnan(r[2]) and math.isnan(r[3])


def test_clustered_pattern_goes_to_the_tree(monkeypatch):
    """A pattern whose points pile up in one cell is measured by the k-d tree, exactly."""
    calls = _count_tree_calls(monkeypatch)
    rng = np.random.default_rng(3)
    pts = np.vstack([np.full((300, 2), 500.0), rng.uniform(0, 1000, (50, 2))])
    x, y, g = pts[:, 0], pts[:, 1], np.zeros(350, dtype=int)
    got = nearest_neighbour_distances(x, y, g)
    assert calls and calls[0] == 350
    np.testing.assert_allclose(got, brute_nearest(x, y, g, 1), rtol=1e-12, atol=0)
    assert (got[:300] == 0).all()


def test_isolated_point_goes_to_the_tree(monkeypatch):
    """A point alone in the middle of a wide empty disc is not settled by the rings of cells
    around it; the k-d tree measures it alone, and the other pattern is untouched."""
    calls = _count_tree_calls(monkeypatch)
    rng = np.random.default_rng(5)
    ring = rng.uniform(0, 1000, (3000, 2))
    ring = ring[np.hypot(*(ring - 500).T) > 300]
    other = rng.uniform(0, 1000, (500, 2))
    pts = np.vstack([ring, [[500.0, 500.0]], other])
    g = np.repeat([0, 1], [len(ring) + 1, len(other)])
    got = nearest_neighbour_distances(pts[:, 0], pts[:, 1], g, 2)
    assert calls == [1]
    np.testing.assert_allclose(got, brute_nearest(pts[:, 0], pts[:, 1], g, 2), rtol=1e-12)
    assert got[len(ring)] > 300


def test_degenerate_inputs():
    """No points, lone points only, and non-finite coordinates."""
    empty = np.empty(0)
    assert nearest_neighbour_distances(empty, empty, np.empty(0, dtype=int), 3).shape == (0,)
    assert np.isnan(clark_evans_grouped(empty, empty, np.empty(0, dtype=int), np.ones(3))).all()
    lone = nearest_neighbour_distances(np.array([1.0, 2.0]), np.array([1.0, 2.0]), [0, 1])
    assert np.isnan(lone).all()
    with pytest.raises(ValueError, match="finite"):
        nearest_neighbour_distances(np.array([0.0, np.inf]), np.array([0.0, 1.0]), [0, 0])


def _count_tree_calls(monkeypatch) -> list[int]:
    """Record how many points each k-d tree query is asked for."""
    calls: list[int] = []
    real = spatial._tree_nearest

    def counting(pts, query):
        calls.append(len(query))
        return real(pts, query)

    monkeypatch.setattr(spatial, "_tree_nearest", counting)
    return calls


def test_batches_on_two_threads_as_on_one(monkeypatch):
    """60 patterns in batches of about 64 points shared by two threads: the distances of the
    full distance matrix, and R to the last bit as on one thread."""
    from blockqc import pieces

    rng = np.random.default_rng(5)
    g = np.repeat(np.arange(60), rng.integers(1, 40, 60))
    pts = rng.uniform(0, 1000.0, (len(g), 2))
    x, y, area, perimeter = pts[:, 0], pts[:, 1], np.full(60, 1e6), np.full(60, 4e3)
    for sizes in ("ONE_THREAD", "THREADED"):
        monkeypatch.setattr(spatial, sizes, replace(getattr(spatial, sizes), batch=64))
    monkeypatch.setattr(pieces, "THREADS", 2)
    got = nearest_neighbour_distances(x, y, g, 60)
    np.testing.assert_allclose(got, brute_nearest(x, y, g, 60), rtol=1e-12, atol=0)
    r2 = clark_evans_grouped(x, y, g, area, perimeter)
    monkeypatch.setattr(pieces, "THREADS", 1)
    r1 = clark_evans_grouped(x, y, g, area, perimeter)
    assert np.array_equal(r1, r2, equal_nan=True) and np.isfinite(r1).sum() >= 50
