"""Tie-point statistics in one pass, checked against numpy and pandas as independent references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st


@given(
    st.lists(st.floats(0, 30, allow_nan=False), min_size=1, max_size=300),
    st.sampled_from([0.0, 0.05, 0.1, 1.0, 2.0, 2.05, 9.95, 10.0, 1e6, 1e300]),
)
@settings(max_examples=300, deadline=None)
def test_histogram_counts_as_numpy(values: list[float], on_edge: float) -> None:
    """The one-pass residual histogram counts exactly as np.histogram over the same edges,
    values lying on edges included."""
    from blockqc.metrics.tiepoints import histogram_counts, histogram_edges

    v = np.array([*values, on_edge])
    edges = histogram_edges(float(v.max()))
    v = np.concatenate([v, edges, np.nextafter(edges, 0), np.nextafter(edges, 99)])
    v = v[(v >= 0) & (v <= edges[-1])]
    expected, _ = np.histogram(v, bins=edges)
    assert histogram_counts(v, edges).tolist() == expected.tolist()


def test_rms_of_errors_too_large_to_square_by_hand() -> None:
    """An error of 1e300 px: its scene's and the block's RMS stay finite (1e300/√n), the
    other scene's RMS is computed as usual."""
    import pandas as pd

    from blockqc.metrics.tiepoints import _stats

    err = pd.Series([3.0, 4.0, 1e300, 0.0])
    scene = pd.Series(["a", "a", "b", "b"], dtype="category")
    block = _stats(err, None, 1.0, 1.5).iloc[0]
    assert block["rms"] == pytest.approx(1e300 / 2.0, rel=1e-12)  # √(1e600 / 4)
    per = _stats(err, scene, 1.0, 1.5)
    assert per.loc["a", "rms"] == np.sqrt(12.5)  # √((9 + 16) / 2), unscaled
    assert per.loc["b", "rms"] == pytest.approx(1e300 / np.sqrt(2.0), rel=1e-12)
    assert per.loc["b", "max"] == 1e300 and per.loc["a", "n"] == 2
