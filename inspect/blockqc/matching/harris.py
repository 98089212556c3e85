"""Harris corners (§RA-3), spread over the grid cells so every textured cell gets candidates."""

from __future__ import annotations

import cv2
import numpy as np


def harris_corners(
    image: np.ndarray,
    usable: np.ndarray,
    *,
    block: int,
    ksize: int,
    k: float,
    quality: float,
    min_distance: int,
    cell_of: tuple[int, int, int],
    per_cell: int,
) -> np.ndarray:
    """Return (n, 2) int64 (row, col) Harris corners of `image` where `usable` is True.

    Corners are local maxima of the Harris response within a (2·min_distance+1)² window whose
    response exceeds `quality` times the 99.9th percentile of the usable responses; at most
    `per_cell` of the strongest are kept per grid cell, the cell of (row, col) being
    ((row + cell_of[0]) // cell_of[2], (col + cell_of[1]) // cell_of[2]).
    """
    if not usable.any():
        return np.empty((0, 2), dtype=np.int64)
    response = cv2.cornerHarris(np.ascontiguousarray(image, dtype=np.float32), block, ksize, k)
    size = 2 * min_distance + 1
    kernel = np.ones((size, size), np.uint8)
    local_max = cv2.dilate(response, kernel)
    level = np.percentile(response[usable], 99.9)
    if not np.isfinite(level) or level <= 0:
        return np.empty((0, 2), dtype=np.int64)
    keep = usable & (response >= local_max) & (response > quality * level)
    rows, cols = np.nonzero(keep)
    strength = response[rows, cols]
    row_off, col_off, grid = cell_of
    cell_r = (rows + row_off) // grid
    cell_c = (cols + col_off) // grid
    # Strongest first within each cell: sort by cell, then by decreasing response.
    order = np.lexsort((-strength, cell_c, cell_r))
    cell_r, cell_c = cell_r[order], cell_c[order]
    new_cell = np.ones(order.size, dtype=bool)
    new_cell[1:] = (cell_r[1:] != cell_r[:-1]) | (cell_c[1:] != cell_c[:-1])
    start = np.maximum.accumulate(np.where(new_cell, np.arange(order.size), 0))
    rank = np.arange(order.size) - start
    chosen = order[rank < per_cell]
    return np.column_stack([rows[chosen], cols[chosen]]).astype(np.int64)
