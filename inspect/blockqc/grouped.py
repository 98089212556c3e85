"""Statistics of values grouped by integer codes (a scene's code per tie point), in passes over
whole columns: no loop over groups, and rows already grouped (runs of one code, as in a table
ordered by scene) reduced run by run first.

Codes are 0..k−1; a negative code belongs to no group. `Groups` finds the rows of no group and
the runs once for every statistic taken over the same codes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
import pandas as pd

from blockqc import pieces

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

    def sums(
        self, values: np.ndarray, of: Callable[[np.ndarray], np.ndarray] | None = None
    ) -> np.ndarray:
        """The sum of each group's values, or of `of` (say np.square) of them: `of` is taken
        of the rows a piece at a time (`blockqc.pieces`), so that it makes no row-sized
        temporary."""
        values = self._in(values)
        if of is None:
            return self._sums(values, 0)
        piece = pieces.CHUNK
        return pieces.total(
            lambda a: self._sums(of(values[a : a + piece]), a), len(values), np.zeros(self.k)
        )

    def _sums(self, values: np.ndarray, at: int) -> np.ndarray:
        """The sums per group of the values of rows at, at + 1, …"""
        codes = self.codes[at : at + len(values)]
        if self.runs is not None and len(values):  # the runs met here, the first maybe begun before
            starts = self.runs[0]
            starts = starts[(starts > at) & (starts < at + len(values))] - at
            starts = np.concatenate([np.zeros(1, dtype=starts.dtype), starts])
            values, codes = np.add.reduceat(values, starts, dtype=np.float64), codes[starts]
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
        """The median of each group's values, NaN values passed over (NaN where it has none),
        as pandas gives it (the mean of the two middle values of an even count).

        Selection by bins, in two passes over the rows a piece at a time: the values' bits
        ordered as integers give each value a bin (`_Window`); the first pass counts the
        values per (group, bin) cell and keeps each row's cell, which tells each group the
        bins of its middle ranks; the second takes the values of those cells alone (one
        look-up per row), and only they are sorted."""
        values, codes, k = self._in(values), self.codes, self.k
        window = _Window.about(values, k)
        width, cells = window.width, k * window.width
        keys = np.empty(len(values), dtype=np.int32 if cells < 1 << 31 else np.int64)
        count = partial(window.count, values, codes, keys, k)
        cum = pieces.total(count, len(values), np.zeros(cells + 1, dtype=np.int64))
        cum = np.cumsum(cum[:cells].reshape(k, width), axis=1)  # the last cell: NaN values
        n = cum[:, -1]
        ranks = np.stack([(n - 1) // 2, n // 2])  # the middle ranks of each group
        middle = (cum[None] <= ranks[..., None]).sum(axis=2)  # their bins
        before = np.where(middle[0] > 0, cum[np.arange(k), np.maximum(middle[0] - 1, 0)], 0)
        has = n > 0
        picked = np.zeros(cells + 1, dtype=bool)  # the cells of the middle ranks
        first = np.flatnonzero(has) * width  # each group's first cell
        picked[first + middle[0][has]] = picked[first + middle[1][has]] = True
        taken = pieces.each(partial(_picked, values, codes, keys, picked), len(values))
        v = np.concatenate([t[0] for t in taken]) if taken else values[:0]
        c = np.concatenate([t[1] for t in taken]) if taken else codes[:0]
        v = v[np.lexsort((v, c))]  # by group, then value
        start = np.concatenate([[0], np.cumsum(np.bincount(c, minlength=k))[:-1]]) - before
        lower, upper = v[(start + ranks[0])[has]], v[(start + ranks[1])[has]]
        out = np.full(k, np.nan)
        with np.errstate(over="ignore"):  # as pandas: the sum of two middle values may overflow
            out[has] = np.where(n[has] % 2, lower, (lower + upper) / 2)
        return out


def _picked(
    values: np.ndarray, codes: np.ndarray, keys: np.ndarray, picked: np.ndarray, a: int
) -> tuple[np.ndarray, np.ndarray]:
    """The values, and their groups, of the piece of rows from a whose cell is picked."""
    pick = picked[keys[a : a + pieces.CHUNK]]
    return values[a : a + pieces.CHUNK][pick], codes[a : a + pieces.CHUNK][pick]


#: the median's bins: 2**BIN_BITS per octave of the values, at most BINS of them about their
#: middle, and at most CELLS (group, bin) counts (fewer bins for many groups)
BIN_BITS = 5
BINS = 512
CELLS = 1 << 22


@dataclass(frozen=True)
class _Window:
    """`width` bins from `low` (in `_bins` units), the values outside gathered in its end
    bins: the values' order is kept, so a group's middle values lie in the bins of its
    middle ranks whatever the window."""

    low: int
    width: int

    @classmethod
    def about(cls, values: np.ndarray, k: int) -> _Window:
        """A window about the middle of a sample of the values, narrower for many groups."""
        sample = values[:: max(1, len(values) // 4096)]
        with np.errstate(over="ignore"):  # the middle of values near ±1e308 may overflow
            centre = np.nanmedian(sample) if np.isfinite(sample).any() else 0.0
        width = int(np.clip(CELLS // max(k, 1), 2, BINS))
        return cls(int(_bins(np.array([centre]))[0]) - width // 2, width)

    def bins(self, v: np.ndarray) -> np.ndarray:
        b = _bins(v)
        b -= self.low
        return np.clip(b, 0, self.width - 1, out=b)

    def count(
        self, values: np.ndarray, codes: np.ndarray, keys: np.ndarray, k: int, a: int
    ) -> np.ndarray:
        """The values per (group, bin) cell of the piece of rows from a, each row's cell kept
        in `keys`; NaN values are given the cell after the last (k × width)."""
        v, c = values[a : a + pieces.CHUNK], codes[a : a + pieces.CHUNK]
        key = self.bins(v)
        key += c.astype(np.int64) * self.width
        nan = np.isnan(v)
        if nan.any():
            key[nan] = k * self.width
        keys[a : a + len(key)] = key
        return np.bincount(key, minlength=k * self.width + 1)


def _bins(values: np.ndarray) -> np.ndarray:
    """Each float's bin: its bits as an integer that orders as the floats do (negative values
    with their other bits flipped), shifted down to the exponent and BIN_BITS bits more."""
    bits = np.asarray(values, dtype=np.float64).view(np.int64)
    ordered = bits ^ ((bits >> 63) & np.int64(0x7FFF_FFFF_FFFF_FFFF))
    return ordered >> (52 - BIN_BITS)


def key_codes(key: pd.Series) -> tuple[np.ndarray, int]:
    """A code per row of a key column (a point's id), the same for equal keys, and the number
    of codes k: a Categorical's own codes (no copy) over its categories, other keys factorized."""
    if isinstance(key.dtype, pd.CategoricalDtype):
        return key.array.codes, len(key.cat.categories)
    codes, uniques = pd.factorize(key)
    return codes, len(uniques)


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
