"""Point-pattern measures: the Clark–Evans nearest-neighbour coefficient R (§AF-10, §TP-4).

Nearest neighbours are found exactly on a uniform grid laid over each pattern (cell side from the
pattern's mean spacing, about one point per cell). Every pair of points in the same or adjacent
cells is measured once; a nearest distance d so found is final when no cell farther out can hold
a nearer point (d ≤ the distance to the cells not searched). The few points not settled are
searched again ring by ring, and those still unsettled after a few rings, with the patterns too
clustered for their grid, are measured with a k-d tree over those patterns only. Patterns are
handled in batches of about `_Sizes.batch` points, so that the work stays in cache and memory
bounded; the batches are shared among the cores (`blockqc.pieces`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from blockqc import pieces

T = TypeVar("T")

_OCCUPANCY = 1.0  # mean points per grid cell over a pattern's bounding box
_MAX_RING = 3  # rings of cells searched before the k-d tree takes over
_DENSE = 8.0  # a pattern whose points share their cell with more points on average → k-d tree
_SLACK = 1e-12  # relative allowance for round-off in the cell assignment


@dataclass(frozen=True)
class _Sizes:
    """How much of the work each numpy call takes on."""

    batch: int  # points of whole patterns searched at once
    chunk: int  # points whose blocks of cells are laid out at once
    pairs: int  # candidate pairs measured at once


#: on one thread, small enough to stay in a core's cache; on several (`blockqc.pieces`), four
#: times larger, so that each call runs long enough for the threads not to queue for the
#: interpreter between calls. 10.8 M points in 2,048 patterns, 2 cores, medians of 5: two
#: threads 1.52 s with THREADED against 1.90 s with ONE_THREAD; one thread 1.85 s with
#: ONE_THREAD against 2.5 s with THREADED. The distances are the same whichever.
ONE_THREAD = _Sizes(batch=1 << 15, chunk=1 << 13, pairs=1 << 15)
THREADED = _Sizes(batch=1 << 17, chunk=1 << 15, pairs=1 << 17)


def _sizes() -> _Sizes:
    return THREADED if pieces.THREADS > 1 else ONE_THREAD


@dataclass(frozen=True)
class _Grid:
    """One uniform grid per pattern (arrays indexed by pattern code)."""

    x0: np.ndarray  # origin
    y0: np.ndarray
    side: np.ndarray  # cell side
    nx: np.ndarray  # columns and rows covering the pattern
    ny: np.ndarray
    width: np.ndarray  # columns with the empty border
    base: np.ndarray  # first cell (one more entry than patterns)
    margin: np.ndarray  # allowance for round-off in the cell assignment

    def cells(self, x: np.ndarray, y: np.ndarray, g: np.ndarray, edge: bool = False) -> tuple:
        """Column and row of each point (with `edge`, also its distance to its cell's nearest
        edge, in cells)."""
        side = self.side[g]
        u, v = (x - self.x0[g]) / side, (y - self.y0[g]) / side
        cx = np.minimum(u.astype(np.int64), self.nx[g] - 1)
        cy = np.minimum(v.astype(np.int64), self.ny[g] - 1)
        if not edge:
            return cx, cy
        u -= cx
        v -= cy
        near = np.minimum(np.minimum(u, 1.0 - u), np.minimum(v, 1.0 - v))
        return cx, cy, np.maximum(near, 0.0)


@dataclass(frozen=True)
class _Sorted:
    """The points sorted by cell, with the grids."""

    grid: _Grid
    starts: np.ndarray  # first sorted point of each cell (one more entry than cells)
    xs: np.ndarray
    ys: np.ndarray
    gs: np.ndarray  # pattern codes
    cell: np.ndarray
    order: np.ndarray  # sorted position → position among the points given


def nearest_neighbour_distances(
    x: np.ndarray, y: np.ndarray, group: np.ndarray, k: int | None = None
) -> np.ndarray:
    """Each point's distance to the nearest other point of its pattern (group code 0..k−1).

    Exact; NaN for a point alone in its pattern; coincident points are at distance 0.
    """
    group = np.asarray(group, dtype=np.int64)
    k = int(group.max(initial=-1)) + 1 if k is None else k
    out = np.full(len(group), np.nan)

    def keep(pos: np.ndarray, codes: np.ndarray, dist: np.ndarray) -> None:
        out[pos] = dist  # the batches' points are apart: written from any thread

    _nearest_by_batch(x, y, group, k, keep)
    return out


def _nearest_by_batch(
    x: np.ndarray, y: np.ndarray, group: np.ndarray, k: int, keep: Callable[..., T]
) -> list[T]:
    """keep(positions, pattern codes, nearest distances) of the points of patterns of ≥ 2
    points, for each batch of whole patterns of about `_Sizes.batch` points (small enough to stay in
    cache); the batches are shared among the cores (`blockqc.pieces`), their results come back
    in order."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("point coordinates must be finite")
    count = np.bincount(group, minlength=k)
    if len(count) > k:
        raise ValueError(f"group codes must be below {k}")
    index = None
    if not np.all(group[1:] >= group[:-1]):  # patterns mixed: bring each one's points together
        index = np.argsort(group.astype(np.uint16) if k <= 1 << 16 else group, kind="stable")
        x, y, group = x[index], y[index], group[index]
    begin = np.concatenate([[0], np.cumsum(count)])
    n = np.where(count >= 2, count, 0)
    ends = np.cumsum(n)

    def batch(span: tuple[int, int]) -> T:
        first, last = span
        pos = np.arange(begin[first], begin[last])
        if (count[first:last] == 1).any():
            pos = pos[count[group[pos]] >= 2]
        order, dist = _nearest_sorted(x[pos], y[pos], group[pos] - first, n[first:last])
        pos = pos[order]
        return keep(pos if index is None else index[pos], group[pos], dist)

    return pieces.shared(batch, _batches(ends, k))


def _batches(ends: np.ndarray, k: int) -> list[tuple[int, int]]:
    """The patterns [first, last) of each batch of about `_Sizes.batch` points that holds some."""
    out, first, size = [], 0, _sizes().batch
    while first < k:
        done = ends[first - 1] if first else 0
        last = max(first + 1, int(np.searchsorted(ends, done + size, side="right")))
        if ends[last - 1] > done:
            out.append((first, last))
        first = last
    return out


def _nearest_sorted(x: np.ndarray, y: np.ndarray, g: np.ndarray, n: np.ndarray) -> tuple:
    """Sorted order of the points (patterns 0..k−1 of n ≥ 2 points or none) and their nearest
    distances in that order."""
    pts = _make_grid(x, y, g, len(n))
    d2 = np.full(len(x), np.inf)
    dense = _dense_patterns(pts, n)[pts.gs]
    todo = np.flatnonzero(~dense)
    _search_neighbours(pts, todo, d2)
    for ring in range(1, _MAX_RING + 1):
        if ring > 1:
            _search_block(pts, todo, ring, d2)
        todo = todo[~_settled(pts, todo, ring, d2)]
        if len(todo) == 0:
            break
    dense[todo] = True
    if dense.any():
        d2[dense] = _tree_nearest(pts, np.flatnonzero(dense)) ** 2
    return pts.order, np.sqrt(d2)


def _make_grid(x: np.ndarray, y: np.ndarray, g: np.ndarray, k: int) -> _Sorted:
    """A grid over each pattern's bounding box, `_OCCUPANCY` points per cell; points (given
    pattern after pattern) sorted by cell.

    Each grid has a border of `_MAX_RING` empty cells, so that a block of cells never leaves it.
    """
    n = np.bincount(g, minlength=k)
    x0, x1 = _group_extremes(x, n)
    y0, y1 = _group_extremes(y, n)
    wx, wy = x1 - x0, y1 - y0
    n = np.maximum(n, 1)
    side = np.maximum(np.sqrt(_OCCUPANCY * wx * wy / n), (wx + wy) / n)
    side = np.where(side > 0, side, 1.0)
    nx = (wx / side).astype(np.int64) + 1
    ny = (wy / side).astype(np.int64) + 1
    width = nx + 2 * _MAX_RING
    base = np.concatenate([[0], np.cumsum(width * (ny + 2 * _MAX_RING))])
    grid = _Grid(x0, y0, side, nx, ny, width, base, _SLACK * (wx + wy + side))
    cx, cy = grid.cells(x, y, g)
    cell = base[g] + (cy + _MAX_RING) * width[g] + (cx + _MAX_RING)
    order = _cell_order(cell, int(base[-1]))
    starts = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=base[-1]))])
    return _Sorted(grid, starts, x[order], y[order], g[order], cell[order], order)


def _cell_order(cell: np.ndarray, cells: int) -> np.ndarray:
    """The order sorting the points by cell: a radix sort on one or two 16-bit digits."""
    if cells <= 1 << 16:
        return np.argsort(cell.astype(np.uint16), kind="stable")
    if cells > 1 << 32:
        return np.argsort(cell, kind="stable")
    order = np.argsort((cell & 0xFFFF).astype(np.uint16), kind="stable")
    return order[np.argsort((cell[order] >> 16).astype(np.uint16), kind="stable")]


def _group_extremes(v: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest value of each group, given one after the other (0 when empty)."""
    lo, hi = np.zeros(len(n)), np.zeros(len(n))
    some = n > 0
    first = (np.cumsum(n) - n)[some]
    lo[some], hi[some] = np.minimum.reduceat(v, first), np.maximum.reduceat(v, first)
    return lo, hi


def _dense_patterns(pts: _Sorted, n: np.ndarray) -> np.ndarray:
    """Patterns whose points share their cell with more than `_DENSE` points on average."""
    counts = np.diff(pts.starts).astype(float)
    shared = np.add.reduceat(counts * counts, pts.grid.base[:-1])
    return shared > _DENSE * np.maximum(n, 1)


def _search_neighbours(pts: _Sorted, todo: np.ndarray, d2: np.ndarray) -> None:
    """Lower d2 by every pair of points in the same or adjacent cells (each pair measured once).

    A point meets the rest of its own cell, the cell on its right and the three cells above;
    the other neighbouring cells meet it from their side.
    """
    step = _sizes().chunk
    for lo in range(0, len(todo), step):
        p = todo[lo : lo + step]
        cell = pts.cell[p]
        above = cell + pts.grid.width[pts.gs[p]]
        a = np.column_stack([p + 1, pts.starts[above - 1]])
        b = np.column_stack([pts.starts[cell + 2], pts.starts[above + 2]])
        _measure(pts, p, a, b, d2, both=True)


def _search_block(pts: _Sorted, todo: np.ndarray, ring: int, d2: np.ndarray) -> None:
    """Lower d2 of the points `todo` by the points in the (2·ring+1)² cells around each (one
    range of sorted points per row of cells)."""
    step = _sizes().chunk
    for lo in range(0, len(todo), step):
        p = todo[lo : lo + step]
        rows = pts.cell[p][:, None] + np.arange(-ring, ring + 1) * pts.grid.width[pts.gs[p], None]
        a, b = pts.starts[rows - ring], pts.starts[rows + ring + 1]
        a = np.column_stack([a, p + 1])  # the own row in two ranges, around the point itself
        b = np.column_stack([b, b[:, ring]])
        b[:, ring] = p
        _measure(pts, p, a, b, d2, both=False)


def _settled(pts: _Sorted, todo: np.ndarray, ring: int, d2: np.ndarray) -> np.ndarray:
    """Whether each point's nearest distance so far is final after searching `ring` rings.

    It is when no farther than the cells outside the block (at least `ring` cell sides away,
    more by the point's distance to its cell's edges), or when the block covers the whole
    pattern.
    """
    grid = pts.grid
    close = ((ring * grid.side - grid.margin) ** 2)[pts.gs[todo]]
    settled = d2[todo] <= close
    rest = np.flatnonzero(~settled)
    step = _sizes().chunk
    for lo in range(0, len(rest), step):
        r = rest[lo : lo + step]
        p = todo[r]
        g = pts.gs[p]
        cx, cy, edge = grid.cells(pts.xs[p], pts.ys[p], g, edge=True)
        reach = (ring + edge) * grid.side[g] - grid.margin[g]
        whole = (cx <= ring) & (cx + ring >= grid.nx[g] - 1)
        whole &= (cy <= ring) & (cy + ring >= grid.ny[g] - 1)
        settled[r] = whole | (d2[p] <= reach * reach)
    return settled


def _measure(pts: _Sorted, p: np.ndarray, a: np.ndarray, b: np.ndarray, d2, both: bool) -> None:
    """Lower d2 of each sorted point p (with `both`, also of the other) by its pairs with the
    points in its ranges [a, b), in pieces of at most `_Sizes.pairs` pairs."""
    count = b - a
    per_point = count.sum(axis=1)
    ends = np.cumsum(per_point)
    lo, budget = 0, _sizes().pairs
    while lo < len(p):
        done = ends[lo - 1] if lo else 0
        hi = max(lo + 1, int(np.searchsorted(ends, done + budget, side="right")))
        c = count[lo:hi].ravel()
        j = np.repeat(a[lo:hi].ravel() - (np.cumsum(c) - c), c)
        j += np.arange(len(j))
        i = np.repeat(p[lo:hi], per_point[lo:hi])
        dist = _squared_distances(pts, i, j)
        np.minimum.at(d2, i, dist)
        if both:
            np.minimum.at(d2, j, dist)
        lo = hi


def _squared_distances(pts: _Sorted, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Squared distance between the sorted points i and j (in place, to spare memory traffic)."""
    dx = pts.xs[j]
    dx -= pts.xs[i]
    dx *= dx
    dy = pts.ys[j]
    dy -= pts.ys[i]
    dy *= dy
    dx += dy
    return dx


def _tree_nearest(pts: _Sorted, query: np.ndarray) -> np.ndarray:
    """Nearest-neighbour distance of the sorted points `query` by a k-d tree over their patterns.

    The pattern code, times a gap wider than any pattern, is a third coordinate: distances within
    a pattern are untouched and every other pattern lies farther than its own points.
    """
    from scipy.spatial import cKDTree  # only for the few points the grid leaves undecided

    grid = pts.grid
    member = np.zeros(len(grid.base) - 1, dtype=bool)
    member[pts.gs[query]] = True
    keep = member[pts.gs]
    gap = 2.0 * float(np.max((grid.nx + grid.ny) * grid.side)) + 1.0
    xyz = np.column_stack([pts.xs, pts.ys, pts.gs * gap])
    tree = cKDTree(xyz[keep], balanced_tree=False)
    dist, _ = tree.query(xyz[query], k=2, workers=-1)
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


def _pattern_sums(pos: np.ndarray, codes: np.ndarray, dist: np.ndarray) -> tuple[int, np.ndarray]:
    """The sum of the nearest distances of each pattern of a batch (whole patterns, codes
    first..), summed point by point as over all the batches at once."""
    first = int(codes.min())
    sums = np.zeros(int(codes.max()) - first + 1)
    np.add.at(sums, codes - first, dist)
    return first, sums


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
    total = np.zeros(k)
    for first, sums in _nearest_by_batch(x, y, group, k, _pattern_sums):
        total[first : first + len(sums)] += sums
    observed = total / np.maximum(n, 1)
    per = None if perimeter is None else np.asarray(perimeter, dtype=float)[ok]
    r[ok] = observed[ok] / expected_nearest_neighbour_distance(n[ok], np.asarray(area)[ok], per)
    return r
