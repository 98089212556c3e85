"""Blocks lying far apart grouped into clusters of nearby blocks, for the batch overview map.

Single linkage on the blocks' outlines: the gap between two blocks is the distance between their
nearest outline vertices (lon scaled by cos(lat), in degrees of latitude), found among the edges
of one Delaunay triangulation of all vertices; the minimum spanning tree of the blocks is cut at
its longest edges. A cut into k groups is kept when the narrowest gap it cuts is at least
GAP_RATIO times the widest group's own extent, the k whose ratio is greatest; else the blocks
stay one group. Vectorized throughout: no loop over blocks or vertices.
"""

from __future__ import annotations

import numpy as np

#: groups are drawn apart when the gaps between them are this many times their own extent
GAP_RATIO = 3.0
#: at most this many groups (panels)
MAX_GROUPS = 6
#: the gap of blocks that share a vertex: more than nothing (a sparse graph drops zeros)
TOUCHING = 1e-12


def ground(xy: np.ndarray) -> np.ndarray:
    """Lon/lat scaled to about equal ground units (lon × cos(lat), lat)."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    return np.column_stack([xy[:, 0] * np.cos(np.radians(xy[:, 1])), xy[:, 1]])


def _near_pairs(pts: np.ndarray) -> np.ndarray:
    """Pairs of points (e × 2) holding every nearest-neighbour link: the edges of a Delaunay
    triangulation (joggled, so collinear points are triangulated too); all pairs of 3 or fewer."""
    if len(pts) < 4:
        return np.column_stack(np.triu_indices(len(pts), 1))
    from scipy.spatial import Delaunay

    tri = Delaunay(pts, qhull_options="QJ").simplices
    return np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]])


def _block_edges(xy: np.ndarray, block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Between distinct blocks: pairs (e × 2) and their least vertex distance, once a pair."""
    pts, vertex = np.unique(ground(xy), axis=0, return_inverse=True)
    vertex = vertex.ravel()
    first = np.full(len(pts), -1)
    first[vertex[::-1]] = block[::-1]  # the first block having each point
    pairs = _near_pairs(pts)
    gap = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
    shared = np.column_stack([first[vertex], block])  # blocks sharing a point: touching
    ends = np.concatenate([first[pairs], shared])
    gap = np.concatenate([gap, np.full(len(shared), TOUCHING)])
    keep = ends[:, 0] != ends[:, 1]
    ends, gap = np.sort(ends[keep], axis=1), np.maximum(gap[keep], TOUCHING)
    order = np.lexsort((gap, ends[:, 1], ends[:, 0]))  # the least gap of a pair first
    ends, gap = ends[order], gap[order]
    once = np.r_[True, (np.diff(ends, axis=0) != 0).any(axis=1)][: len(ends)]
    return ends[once], gap[once]


def group_bounds(xy: np.ndarray, group: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The lower and upper corners (k × 2) of the box of each of k groups, from its points `xy`
    and the group of each (±inf for a group without a point)."""
    lo = np.full((k, 2), np.inf)
    hi = np.full((k, 2), -np.inf)
    np.minimum.at(lo, group, xy)
    np.maximum.at(hi, group, xy)
    return lo, hi


def _extents(xy: np.ndarray, group: np.ndarray, k: int) -> np.ndarray:
    """The largest side of each group's box (ground units) from its vertices' groups."""
    lo, hi = group_bounds(ground(xy), group, k)
    return np.max(hi - lo, axis=1)


def clusters(xy: np.ndarray, block: np.ndarray, n_blocks: int) -> np.ndarray:
    """A group number (0, 1, …) for each of `n_blocks` blocks from their outline vertices `xy`
    (lon/lat) and the block of each vertex; -1 for a block without a vertex."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import minimum_spanning_tree

    labels = np.full(n_blocks, -1)
    block = np.asarray(block, int)
    if not len(block):
        return labels
    ends, gap = _block_edges(xy, block)
    tree = minimum_spanning_tree(coo_matrix((gap, ends.T), shape=(n_blocks,) * 2)).tocoo()
    order = np.argsort(tree.data)[::-1]  # the longest edge first
    links, lengths = np.column_stack([tree.row, tree.col])[order], tree.data[order]
    best, best_ratio = 0, GAP_RATIO
    for cut in range(1, min(MAX_GROUPS, len(lengths) + 1)):  # at most MAX_GROUPS - 1 cuts
        group = _cut(links[cut:], n_blocks)
        widest = float(_extents(xy, group[block], n_blocks).max(initial=0.0))
        ratio = lengths[cut - 1] / max(widest, TOUCHING)
        if ratio >= best_ratio:
            best, best_ratio = cut, ratio
    group = _cut(links[best:], n_blocks)
    used = np.unique(group[block])  # renumbered 0..k-1 over the blocks with vertices
    labels[np.unique(block)] = np.searchsorted(used, group[np.unique(block)])
    return labels


def _cut(links: np.ndarray, n: int) -> np.ndarray:
    """The component of each of n blocks joined by the links left."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(links)), links.T.reshape(2, -1)), shape=(n, n))
    return connected_components(graph, directed=False)[1]
