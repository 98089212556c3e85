"""Point-pattern measures: the Clark–Evans nearest-neighbour coefficient R (§AF-10, §TP-4)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def mean_nearest_neighbour_distance(x: np.ndarray, y: np.ndarray) -> float:
    """Mean distance from each point to its nearest other point (k-d tree); NaN with < 2 points."""
    pts = np.column_stack([np.asarray(x, dtype=float), np.asarray(y, dtype=float)])
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) < 2:
        return float("nan")
    dist, _ = cKDTree(pts).query(pts, k=2)
    return float(dist[:, 1].mean())


def clark_evans(x: np.ndarray, y: np.ndarray, area: float, perimeter: float | None = None) -> float:
    """Clark–Evans R = r̄_observed / r̄_expected in any planar unit (metres, pixels …).

    r̄_expected = 0.5 / √(n / area) for a Poisson pattern of the same density (§AF-10). With
    `perimeter` given, Donnelly's edge-corrected expectation is used instead:
    0.5·√(area / n) + (0.0514 + 0.041 / √n)·perimeter / n. R ≈ 1 random, → 2.149 hexagonal,
    2 square lattice, → 0 clustered. Coincident points (distance 0) count as they are.
    """
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    ok = np.isfinite(xa) & np.isfinite(ya)
    n = int(ok.sum())
    if n < 2 or not area > 0:
        return float("nan")
    observed = mean_nearest_neighbour_distance(xa[ok], ya[ok])
    return float(observed / expected_nearest_neighbour_distance(n, area, perimeter))


def expected_nearest_neighbour_distance(n, area, perimeter=None):
    """r̄ of a Poisson pattern of n points on `area` (Donnelly's edge correction with perimeter).

    Vectorized: n, area and perimeter may be arrays (one value per pattern).
    """
    n = np.asarray(n, dtype=float)
    expected = 0.5 * np.sqrt(np.asarray(area, dtype=float) / n)
    if perimeter is not None:
        expected = expected + (0.0514 + 0.041 / np.sqrt(n)) * np.asarray(perimeter) / n
    return expected


def clark_evans_grouped(
    x: np.ndarray,
    y: np.ndarray,
    group: np.ndarray,
    area: np.ndarray,
    perimeter: np.ndarray | None = None,
) -> np.ndarray:
    """Clark–Evans R of many patterns at once (one per group code 0..k−1), with one k-d tree.

    Each pattern is shifted far from the others, so that every point's nearest neighbour lies
    in its own pattern; groups with fewer than 2 points give NaN.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    group = np.asarray(group, dtype=np.int64)
    k = len(area)
    n = np.bincount(group, minlength=k)
    r = np.full(k, np.nan)
    keep = n[group] >= 2
    if not keep.any():
        return r
    x, y, g = x[keep], y[keep], group[keep]
    span = 4.0 * (max(np.ptp(x), np.ptp(y)) + 1.0)
    m = int(np.ceil(np.sqrt(k)))  # patterns on an m×m grid of cells, `span` apart
    pts = np.column_stack([x - x.min() + (g % m) * span, y - y.min() + (g // m) * span])
    dist, _ = cKDTree(pts, balanced_tree=False).query(pts, k=2, workers=-1)
    observed = np.bincount(g, weights=dist[:, 1], minlength=k) / np.maximum(n, 1)
    ok = n >= 2
    per = None if perimeter is None else np.asarray(perimeter, dtype=float)[ok]
    r[ok] = observed[ok] / expected_nearest_neighbour_distance(n[ok], np.asarray(area)[ok], per)
    return r
