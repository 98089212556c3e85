"""A value on a threshold's bound up to the binary rounding of decimal inputs is on it."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from blockqc.engine import passes
from blockqc.rules.model import Threshold


def _judge(value: float, **threshold) -> bool:
    th = Threshold(**threshold)
    lo = th.min if th.min is not None else None
    hi = th.max if th.max is not None else None
    return bool(passes(pd.Series([value]), th, lo, hi)[0])


def test_an_rms_of_values_all_on_the_bound_is_on_it():
    """√((1.2² + 1.2² + 1.2²) / 3) computes as 1.2000000000000002: it failed `max: 1.2`."""
    rms = math.sqrt(np.mean(np.square([1.2, 1.2, 1.2])))
    assert rms != 1.2  # the rounding this is about
    assert _judge(rms, max=1.2)
    assert not _judge(rms, max=1.2, inclusive=False)
    assert not _judge(1.2 + 1e-6, max=1.2)  # beyond the rounding: beyond the bound


def test_lower_bounds_and_zero_alike():
    assert _judge(100 * (1 - 1e-12), min=100) and not _judge(
        100 * (1 + 1e-12), min=100, inclusive=False
    )
    assert not _judge(99.999, min=100)
    assert _judge(0.0, max=0) and not _judge(1e-300, max=0)  # no slack about a bound of 0


@given(st.floats(1e-6, 1e6), st.integers(1, 50))
def test_a_mean_of_n_equal_values_is_on_their_bound(v, n):
    """A statistic of n values equal to the bound, however it rounds, is on the bound."""
    mean = float(np.mean(np.full(n, v)))
    rms = math.sqrt(float(np.mean(np.square(np.full(n, v)))))
    for x in (mean, rms):
        assert _judge(x, max=v) and _judge(x, min=v)
        assert not _judge(x, max=v, inclusive=False) and not _judge(x, min=v, inclusive=False)
