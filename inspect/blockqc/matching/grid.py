"""Homogenization (§RA-3): one control point per grid cell over the image.

Preference within a cell: the BRIEF match with the smallest Hamming distance if the cell has one,
else the NCC match with the largest correlation coefficient; remaining ties go to the smaller
(row, col) so the choice does not depend on the order of the input.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

COLUMNS = ["row", "col", "ref_row", "ref_col", "kind", "score", "cell_row", "cell_col"]


def homogenize(cps: pd.DataFrame, grid: int) -> pd.DataFrame:
    """Keep one CP per `grid`×`grid` cell of the image (cells counted from pixel (0, 0))."""
    if cps.empty:
        return pd.DataFrame({c: pd.Series(dtype=_dtype(c)) for c in COLUMNS})
    row = cps["row"].to_numpy(dtype=np.float64)
    col = cps["col"].to_numpy(dtype=np.float64)
    # Pixel-centre convention: pixel k spans [k - 0.5, k + 0.5), so its cell is floor((k+0.5)/g).
    cell_row = np.floor((row + 0.5) / grid).astype(np.int64)
    cell_col = np.floor((col + 0.5) / grid).astype(np.int64)
    is_brief = cps["kind"].to_numpy() == "brief"
    score = cps["score"].to_numpy(dtype=np.float64)
    rank = np.where(is_brief, score, -score)  # smaller is better in both kinds
    order = np.lexsort((col, row, rank, ~is_brief, cell_col, cell_row))
    first = np.ones(order.size, dtype=bool)
    cr, cc = cell_row[order], cell_col[order]
    first[1:] = (cr[1:] != cr[:-1]) | (cc[1:] != cc[:-1])
    chosen = order[first]
    out = cps.iloc[chosen].copy()
    out["cell_row"] = cell_row[chosen]
    out["cell_col"] = cell_col[chosen]
    return out[COLUMNS].reset_index(drop=True)


def _dtype(column: str) -> str:
    if column == "kind":
        return "object"
    if column.startswith("cell"):
        return "int64"
    return "float64"
