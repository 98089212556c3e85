"""Point-pattern measures: the Clark–Evans nearest-neighbour coefficient R (§AF-10, §TP-4).

Nearest neighbours are found exactly on a uniform grid laid over each pattern (cell side from the
pattern's mean spacing): each point searches the block of cells around its own, ring by ring, and
a neighbour at distance d is final once d is no more than the distance to the unsearched cells.
The few points not settled after a few rings, and patterns too clustered for their grid, are
resolved with a k-d tree over those patterns only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

_OCCUPANCY = 1.0  # mean points per grid cell over a pattern's bounding box
_MAX_RING = 3  # rings of cells searched before the k-d tree takes over
_DENSE = 8.0  # a pattern whose points share their cell with more points on average → k-d tree
_CHUNK = 1 << 16  # points whose blocks of cells are laid out at once
_PAIR_BUDGET = 1 << 18  # candidate pairs measured at once (small enough to stay in cache)
_SLACK = 1e-12  # relative allowance for round-off in the cell assignment


@dataclass(frozen=True)
class _Grid:
    """One uniform grid per pattern, and the points sorted by cell."""

    x0: np.ndarray  # per pattern: origin, cell side, columns, rows, first cell, round-off margin
    y0: np.ndarray
    side: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    base: np.ndarray
    margin: np.ndarray
    starts: np.ndarray  # first sorted point of each cell (one more entry than cells)
    xs: np.ndarray  # the points sorted by cell, and their pattern codes
    ys: np.ndarray
    gs: np.ndarray
    cell: np.ndarray
    order: np.ndarray  # sorted position → input position


def nearest_neighbour_distances(
    x: np.ndarray, y: np.ndarray, group: np.ndarray, k: int | None = None
) -> np.ndarray:
    """Each point's distance to the nearest other point of its pattern (group code 0..k−1).

    Exact; NaN for a point alone in its pattern; coincident points are at distance 0.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    group = np.asarray(group, dtype=np.int64)
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("point coordinates must be finite")
    k = int(group.max(initial=-1)) + 1 if k is None else k
    n = np.bincount(group, minlength=k)
    out = np.full(len(x), np.nan)
    keep = np.flatnonzero(n[group] >= 2)
    if len(keep) == 0:
        return out
    grid = _make_grid(x[keep], y[keep], group[keep], k)
    d2 = np.full(len(keep), np.inf)
    dense = _dense_patterns(grid, n)
    todo = np.flatnonzero(~dense[grid.gs])
    for ring in range(1, _MAX_RING + 1):
        if len(todo) == 0:
            break
        d2[todo], settled = _search_block(grid, todo, ring)
        todo = todo[~settled]
    tree = dense[grid.gs]
    tree[todo] = True
    if tree.any():
        d2[tree] = _tree_nearest(grid, np.flatnonzero(tree)) ** 2
    out[keep[grid.order]] = np.sqrt(d2)
    return out


def _make_grid(x: np.ndarray, y: np.ndarray, g: np.ndarray, k: int) -> _Grid:
    """A grid over each pattern's bounding box, `_OCCUPANCY` points per cell; points sorted."""
    x0, x1 = _group_extremes(x, g, k)
    y0, y1 = _group_extremes(y, g, k)
    wx, wy = np.nan_to_num(x1 - x0, posinf=0.0), np.nan_to_num(y1 - y0, posinf=0.0)
    x0, y0 = np.nan_to_num(x0, posinf=0.0), np.nan_to_num(y0, posinf=0.0)
    n = np.maximum(np.bincount(g, minlength=k), 1)
    side = np.maximum(np.sqrt(_OCCUPANCY * wx * wy / n), (wx + wy) / n)
    side = np.where(side > 0, side, 1.0)
    nx = (wx / side).astype(np.int64) + 1
    ny = (wy / side).astype(np.int64) + 1
    base = np.concatenate([[0], np.cumsum(nx * ny)])
    cx = np.minimum(((x - x0[g]) / side[g]).astype(np.int64), nx[g] - 1)
    cy = np.minimum(((y - y0[g]) / side[g]).astype(np.int64), ny[g] - 1)
    cell = base[g] + cy * nx[g] + cx
    order = np.argsort(cell)
    starts = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=base[-1]))])
    margin = _SLACK * (wx + wy + side)
    return _Grid(
        x0, y0, side, nx, ny, base, margin, starts, x[order], y[order], g[order], cell[order], order
    )


def _group_extremes(v: np.ndarray, g: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest value of each group (±inf for an empty group)."""
    lo, hi = np.full(k, np.inf), np.full(k, -np.inf)
    np.minimum.at(lo, g, v)
    np.maximum.at(hi, g, v)
    return lo, hi


def _dense_patterns(grid: _Grid, n: np.ndarray) -> np.ndarray:
    """Patterns whose points share their cell with more than `_DENSE` points on average."""
    counts = np.diff(grid.starts).astype(float)
    shared = np.add.reduceat(counts * counts, grid.base[:-1])
    return shared > _DENSE * np.maximum(n, 1)


def _search_block(grid: _Grid, todo: np.ndarray, ring: int) -> tuple[np.ndarray, np.ndarray]:
    """Nearest squared distance in the (2·ring+1)² cells around each point, and whether final."""
    d2 = np.empty(len(todo))
    settled = np.empty(len(todo), dtype=bool)
    for lo in range(0, len(todo), _CHUNK):
        p = todo[lo : lo + _CHUNK]
        g = grid.gs[p]
        local = grid.cell[p] - grid.base[g]
        cy, cx = np.divmod(local, grid.nx[g])
        a, b = _block_runs(grid, g, cx, cy, ring)
        d2[lo : lo + len(p)] = _nearest_in_runs(grid, p, a, b)
        fx = (grid.xs[p] - grid.x0[g]) / grid.side[g] - cx
        fy = (grid.ys[p] - grid.y0[g]) / grid.side[g] - cy
        edge = np.clip(np.minimum(np.minimum(fx, 1 - fx), np.minimum(fy, 1 - fy)), 0.0, 1.0)
        reach = (ring + edge) * grid.side[g] - grid.margin[g]
        whole = (cx <= ring) & (cx + ring >= grid.nx[g] - 1)
        whole &= (cy <= ring) & (cy + ring >= grid.ny[g] - 1)
        settled[lo : lo + len(p)] = whole | (d2[lo : lo + len(p)] <= reach * reach)
    return d2, settled


def _block_runs(grid: _Grid, g: np.ndarray, cx: np.ndarray, cy: np.ndarray, ring: int):
    """Sorted-point ranges [a, b) of each row of the block of cells around each point."""
    nx = grid.nx[g][:, None]
    rows = cy[:, None] + np.arange(-ring, ring + 1)
    inside = (rows >= 0) & (rows < grid.ny[g][:, None])
    row0 = grid.base[g][:, None] + rows * nx
    first = np.where(inside, row0 + np.maximum(cx - ring, 0)[:, None], 0)
    last = np.where(inside, row0 + np.minimum(cx + ring + 1, nx[:, 0])[:, None], 0)
    return grid.starts[first], grid.starts[last]


def _nearest_in_runs(grid: _Grid, p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest squared distance from each sorted point p to the others in its runs [a, b)."""
    count = b - a
    per_point = count.sum(axis=1)
    ends = np.cumsum(per_point)
    d2 = np.empty(len(p))
    lo = 0
    while lo < len(p):
        done = ends[lo - 1] if lo else 0
        hi = max(lo + 1, int(np.searchsorted(ends, done + _PAIR_BUDGET, side="right")))
        c = count[lo:hi].ravel()
        j = np.repeat(a[lo:hi].ravel() - (np.cumsum(c) - c), c) + np.arange(c.sum())
        i = np.repeat(p[lo:hi], per_point[lo:hi])
        pair = (grid.xs[j] - grid.xs[i]) ** 2 + (grid.ys[j] - grid.ys[i]) ** 2
        pair[j == i] = np.inf
        d2[lo:hi] = np.minimum.reduceat(pair, ends[lo:hi] - per_point[lo:hi] - done)
        lo = hi
    return d2


def _tree_nearest(grid: _Grid, query: np.ndarray) -> np.ndarray:
    """Nearest-neighbour distance of the sorted points `query` by a k-d tree over their patterns.

    The pattern code, times a gap wider than any pattern, is a third coordinate: distances within
    a pattern are untouched and every other pattern lies farther than its own points.
    """
    member = np.zeros(len(grid.base) - 1, dtype=bool)
    member[grid.gs[query]] = True
    keep = member[grid.gs]
    gap = 2.0 * float(np.max(grid.nx * grid.side + grid.ny * grid.side)) + 1.0
    pts = np.column_stack([grid.xs, grid.ys, grid.gs * gap])
    tree = cKDTree(pts[keep], balanced_tree=False)
    dist, _ = tree.query(pts[query], k=2, workers=-1)
    return dist[:, 1]


def mean_nearest_neighbour_distance(x: np.ndarray, y: np.ndarray) -> float:
    """Mean distance from each point to its nearest other point; NaN with < 2 points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        return float("nan")
    return float(nearest_neighbour_distances(x[ok], y[ok], np.zeros(int(ok.sum()), int)).mean())


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
    """Clark–Evans R of many patterns at once (one per group code 0..k−1).

    Nearest neighbours are exact (`nearest_neighbour_distances`); groups with fewer than 2
    points give NaN.
    """
    group = np.asarray(group, dtype=np.int64)
    k = len(area)
    n = np.bincount(group, minlength=k)
    r = np.full(k, np.nan)
    ok = n >= 2
    if not ok.any():
        return r
    dist = nearest_neighbour_distances(x, y, group, k)
    seen = n[group] >= 2
    observed = np.bincount(group[seen], weights=dist[seen], minlength=k) / np.maximum(n, 1)
    per = None if perimeter is None else np.asarray(perimeter, dtype=float)[ok]
    r[ok] = observed[ok] / expected_nearest_neighbour_distance(n[ok], np.asarray(area)[ok], per)
    return r
