"""Grouped statistics (blockqc.grouped) against a pandas groupby of the same rows, as the
independent reference: rows in runs of one group or interleaved, rows of no group, NaN."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc import grouped, pieces

VALUES = st.floats(-1e6, 1e6, allow_nan=False) | st.sampled_from([0.0, -0.0, 1e-300, 5e-324])


@st.composite
def rows(draw, nan: bool = False):
    """(values, codes, k): codes -1..k−1, in runs (as a table ordered by scene) or not."""
    k = draw(st.integers(1, 6))
    n = draw(st.integers(0, 120))
    codes = np.array(draw(st.lists(st.integers(-1, k - 1), min_size=n, max_size=n)), dtype=int)
    if draw(st.booleans()):
        codes = np.sort(codes)
    value = VALUES | st.just(float("nan")) if nan else VALUES
    values = np.array(draw(st.lists(value, min_size=n, max_size=n)), dtype=float)
    return values, codes.astype(draw(st.sampled_from([np.int8, np.int16, np.int64]))), k


def _frame(values: np.ndarray, codes: np.ndarray, k: int):
    ok = codes >= 0
    return pd.Series(values[ok]).groupby(codes[ok]), np.arange(k)


@given(rows(nan=True))
@settings(max_examples=300, deadline=None)
def test_extremes_as_pandas(case) -> None:
    values, codes, k = case
    g, groups = _frame(values, codes, k)
    lo, hi = grouped.extremes(values, codes, k)
    assert np.array_equal(lo, g.min().reindex(groups).fillna(np.inf).to_numpy())
    assert np.array_equal(hi, g.max().reindex(groups).fillna(-np.inf).to_numpy())


@given(rows())
@settings(max_examples=300, deadline=None)
def test_sums_counts_and_medians_as_pandas(case) -> None:
    values, codes, k = case
    g, groups = _frame(values, codes, k)
    assert grouped.counts(codes, k).tolist() == g.size().reindex(groups, fill_value=0).tolist()
    want = g.sum().reindex(groups, fill_value=0.0).to_numpy()
    assert grouped.sums(values, codes, k) == pytest.approx(want, rel=1e-12, abs=1e-6)
    medians = grouped.medians(values, codes, k)
    assert np.array_equal(medians, g.median().reindex(groups).to_numpy(), equal_nan=True)


@given(rows(nan=True), st.sampled_from([1, 3, 1 << 20]), st.sampled_from([4, 24, 1 << 22]))
@settings(max_examples=300, deadline=None)
def test_medians_as_pandas(case, chunk: int, cells: int) -> None:
    """Medians with NaN values passed over, groups with none, the rows worked through a few
    at a time or all at once, in windows of 2 to 512 bins (fewer for many groups)."""
    values, codes, k = case
    g, groups = _frame(values, codes, k)
    old, pieces.CHUNK, grouped.CELLS = (pieces.CHUNK, grouped.CELLS), chunk, cells
    try:
        medians = grouped.medians(values, codes, k)
    finally:
        pieces.CHUNK, grouped.CELLS = old
    assert np.array_equal(medians, g.median().reindex(groups).to_numpy(), equal_nan=True)


@given(
    st.lists(
        st.floats(allow_nan=False) | st.sampled_from([1e-300, 1e300, -1e300, 0.25]),
        min_size=1,
        max_size=60,
    ),
    st.integers(1, 3),
)
@settings(max_examples=300, deadline=None)
def test_medians_of_values_far_apart(values: list[float], k: int) -> None:
    """Values from 1e−300 to ±1e300 and infinities: the bins outside the window gather the
    tails, and the medians stay pandas' (the middle values may lie in an end bin)."""
    v = np.array(values)
    codes = np.arange(len(v)) % k
    want = pd.Series(v).groupby(codes).median().reindex(np.arange(k)).to_numpy()
    assert np.array_equal(grouped.medians(v, codes, k), want, equal_nan=True)


def test_medians_by_hand() -> None:
    """Group 0: 1, 2, 10, 40 → (2 + 10) / 2 = 6; group 1: 3 and a NaN → 3; group 2: none."""
    v = np.array([10.0, 3.0, 1.0, np.nan, 40.0, 2.0])
    codes = np.array([0, 1, 0, 1, 0, 0])
    assert np.array_equal(grouped.medians(v, codes, 3), [6.0, 3.0, np.nan], equal_nan=True)


@given(rows(), st.sampled_from([1, 2, 5, 1 << 20]))
@settings(max_examples=300, deadline=None)
def test_sums_of_a_function_a_piece_at_a_time(case, chunk: int) -> None:
    """Sums of the squares and of a condition, taken a few rows at a time (runs of one group
    cut between pieces), as pandas sums them over the whole frame."""
    values, codes, k = case
    g, groups = _frame(values, codes, k)
    old, pieces.CHUNK = pieces.CHUNK, chunk
    try:
        squares = grouped.Groups(codes, k).sums(values, of=np.square)
        positive = grouped.Groups(codes, k).sums(values, of=lambda v: v > 0)
    finally:
        pieces.CHUNK = old
    want = (g.obj**2).groupby(g.keys).sum().reindex(groups, fill_value=0.0).to_numpy()
    assert squares == pytest.approx(want, rel=1e-12)
    want = (g.obj > 0).groupby(g.keys).sum().reindex(groups, fill_value=0).to_numpy()
    assert positive.tolist() == want.tolist()


def test_runs_by_hand() -> None:
    starts, codes = grouped.runs(np.array([2, 2, 0, 0, 0, 2, 1]))
    assert starts.tolist() == [0, 2, 5, 6] and codes.tolist() == [2, 0, 2, 1]
    assert grouped.runs(np.array([], dtype=int))[0].size == 0
