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
    expected = 0.5 * np.sqrt(area / n)
    if perimeter is not None:
        expected += (0.0514 + 0.041 / np.sqrt(n)) * perimeter / n
    return float(observed / expected)
