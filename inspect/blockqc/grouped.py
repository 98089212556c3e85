"""Statistics of values grouped by integer codes (a scene's code per tie point), in passes over
whole columns: no loop over groups, and rows already grouped (runs of one code, as in a table
ordered by scene) reduced run by run first.

Codes are 0..k−1; a negative code belongs to no group. `Groups` finds the rows of no group and
the runs once for every statistic taken over the same codes.
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


class Groups:
    """k groups given by a code per row; its statistics take values row for row."""

    def __init__(self, codes: np.ndarray, k: int):
        self.k = k
        ok = codes >= 0
        self.ok = None if ok.all() else ok  # the rows that belong to a group (None: every row)
        self.codes = codes if self.ok is None else codes[ok]
        found = runs(self.codes)  # reduced run by run when the runs are few enough
        self.runs = found if len(found[0]) <= RUN_SHARE * len(self.codes) else None

    def _in(self, values: np.ndarray) -> np.ndarray:
        return values if self.ok is None else values[self.ok]

    def counts(self) -> np.ndarray:
        """How many rows each group holds."""
        if self.runs is None:
            return np.bincount(self.codes, minlength=self.k)
        starts, codes = self.runs
        lengths = np.diff(starts, append=len(self.codes))
        return np.bincount(codes, weights=lengths, minlength=self.k).astype(np.int64)

    def sums(self, values: np.ndarray) -> np.ndarray:
        """The sum of each group's values."""
        values, codes = self._in(values), self.codes
        if self.runs is not None:
            starts, codes = self.runs
            values = np.add.reduceat(values, starts, dtype=np.float64)
        return np.bincount(codes, weights=values, minlength=self.k)

    def extremes(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest and largest value of each group (+inf and −inf where it has none); NaN
        values are passed over."""
        low = high = values = self._in(values)
        codes = self.codes
        if self.runs is not None:
            starts, codes = self.runs
            low, high = np.fmin.reduceat(values, starts), np.fmax.reduceat(values, starts)
        lo, hi = np.full(self.k, np.inf), np.full(self.k, -np.inf)
        np.fmin.at(lo, codes, low)
        np.fmax.at(hi, codes, high)
        return lo, hi

    def medians(self, values: np.ndarray) -> np.ndarray:
        """The median of each group's values (NaN where it has none), as pandas gives it (the
        mean of the two middle values of an even count), grouped by the codes as categories
        (no hash of the codes)."""
        groups = pd.Categorical.from_codes(
            self.codes, categories=pd.RangeIndex(self.k), validate=False
        )
        found = pd.Series(self._in(values), copy=False).groupby(groups, observed=False).median()
        return found.to_numpy(dtype=float)


def counts(codes: np.ndarray, k: int) -> np.ndarray:
    """How many rows each group holds."""
    return Groups(codes, k).counts()


def sums(values: np.ndarray, codes: np.ndarray, k: int) -> np.ndarray:
    """The sum of each group's values."""
    return Groups(codes, k).sums(values)


def extremes(values: np.ndarray, codes: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest value of each group (+inf and −inf where it has none)."""
    return Groups(codes, k).extremes(values)


def medians(values: np.ndarray, codes: np.ndarray, k: int) -> np.ndarray:
    """The median of each group's values (NaN where it has none)."""
    return Groups(codes, k).medians(values)


__all__ = ["Groups", "counts", "extremes", "medians", "runs", "sums"]
