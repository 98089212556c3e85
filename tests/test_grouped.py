"""Grouped statistics (blockqc.grouped) against a pandas groupby of the same rows, as the
independent reference: rows in runs of one group or interleaved, rows of no group, NaN."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc import grouped

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


def test_runs_by_hand() -> None:
    starts, codes = grouped.runs(np.array([2, 2, 0, 0, 0, 2, 1]))
    assert starts.tolist() == [0, 2, 5, 6] and codes.tolist() == [2, 0, 2, 1]
    assert grouped.runs(np.array([], dtype=int))[0].size == 0
