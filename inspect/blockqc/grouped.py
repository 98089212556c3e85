"""Statistics of values grouped by integer codes (a scene's code per tie point), in passes over
whole columns: no loop over groups, and rows already grouped (runs of one code, as in a table
ordered by scene) reduced run by run first.

Codes are 0..k−1; a negative code belongs to no group.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: runs of equal codes are reduced first when they are at most this share of the rows
RUN_SHARE = 0.25


def runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first row of each run of equal codes, and its code."""
    if not len(codes):
        return np.zeros(0, dtype=np.intp), codes[:0]
    starts = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    starts = np.concatenate([np.zeros(1, dtype=starts.dtype), starts])
    return starts, codes[starts]


def _few_runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The runs of the codes when they are few enough to be worth reducing first."""
    found = runs(codes)
    return found if len(found[0]) <= RUN_SHARE * len(codes) else None


def _in_groups(values: np.ndarray, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The values and codes of the rows that belong to a group."""
    ok = codes >= 0
    return (values, codes) if ok.all() else (values[ok], codes[ok])


def extremes(values: np.ndarray, codes: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest value of each group (+inf and −inf where it has none); NaN values
    are passed over."""
    values, codes = _in_groups(values, codes)
    low, high = values, values
    found = _few_runs(codes)
    if found is not None:
        starts, codes = found
        low, high = np.fmin.reduceat(values, starts), np.fmax.reduceat(values, starts)
    lo, hi = np.full(k, np.inf), np.full(k, -np.inf)
    np.fmin.at(lo, codes, low)
    np.fmax.at(hi, codes, high)
    return lo, hi


def sums(values: np.ndarray, codes: np.ndarray, k: int) -> np.ndarray:
    """The sum of each group's values."""
    values, codes = _in_groups(values, codes)
    found = _few_runs(codes)
    if found is not None:
        starts, codes = found
        values = np.add.reduceat(values, starts, dtype=np.float64)
    return np.bincount(codes, weights=values, minlength=k)


def counts(codes: np.ndarray, k: int) -> np.ndarray:
    """How many rows each group holds."""
    found = _few_runs(codes)
    if found is None:
        return np.bincount(codes[codes >= 0] if (codes < 0).any() else codes, minlength=k)
    starts, run_codes = found
    lengths = np.diff(starts, append=len(codes))
    ok = run_codes >= 0
    return np.bincount(run_codes[ok], weights=lengths[ok], minlength=k).astype(np.int64)


def medians(values: np.ndarray, codes: np.ndarray, k: int) -> np.ndarray:
    """The median of each group's values (NaN where it has none), as pandas gives it (the mean
    of the two middle values of an even count), grouped by the codes as categories (no hash
    of the codes)."""
    values, codes = _in_groups(values, codes)
    groups = pd.Categorical.from_codes(codes, categories=pd.RangeIndex(k), validate=False)
    found = pd.Series(values, copy=False).groupby(groups, observed=False).median()
    return found.to_numpy(dtype=float)


__all__ = ["counts", "extremes", "medians", "runs", "sums"]
