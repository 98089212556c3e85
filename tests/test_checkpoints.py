"""Checkpoint accuracy (§CP-3..7) against hand computation, on and around the inclusive bounds."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.metrics.checkpoints import (
    AccuracyParams,
    accuracy_by_group,
    checkpoint_errors,
    method_agreement,
)

P = AccuracyParams()
TOL = 1e-9  # far below any real difference


def frame(method: str, dx, dy, dz=None) -> pd.DataFrame:
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    n = len(dx)
    dz = np.full(n, np.nan) if dz is None else np.asarray(dz, float)
    return pd.DataFrame(
        {
            "point_id": [f"P{i}" for i in range(n)],
            "method": method,
            "reference_id": "R",
            "x_m": 1000.0 + dx,
            "y_m": 2000.0 + dy,
            "z_m": 100.0 + np.nan_to_num(dz),
            "ref_x_m": 1000.0,
            "ref_y_m": 2000.0,
            "ref_z_m": np.where(np.isnan(dz), np.nan, 100.0),
        }
    )


def stats(df: pd.DataFrame, component: str = "plane") -> pd.Series:
    groups, _ = accuracy_by_group(checkpoint_errors(df), P)
    return groups.set_index("component").loc[component]


def test_high_precision_bound_20m_is_retained_20_001_is_gross() -> None:
    # 25 points: one on the bound (dx 12, dy 16 → Δ = 20 m exactly), one just beyond, 23 at 3 m
    dx = [12.0, 20.001] + [3.0] * 23
    dy = [16.0, 0.0] + [0.0] * 23
    s = stats(frame("high_precision", dx, dy))
    assert s["n_total"] == 25 and s["n_gross"] == 1 and s["n"] == 24
    m1 = math.sqrt((20.0**2 + 23 * 3.0**2) / 24)  # M1 = √(ΣΔ²/n), gross excluded
    assert s["medium_error"] == pytest.approx(m1, abs=TOL)
    assert s["max_error"] == pytest.approx(20.0, abs=TOL)
    assert s["statistic"] == "M1"
    assert s["gross_rate"] == pytest.approx(100 / 25, abs=TOL)


def test_same_accuracy_bound_2_sqrt2_m_inclusive() -> None:
    # dx = dy = 20 m is exactly 2√2·10 m: retained; 1e-6 m more is a gross error
    d = 20.0 + 1e-6 / math.sqrt(2)
    dx = [20.0, d] + [4.0] * 20
    dy = [20.0, d] + [0.0] * 20
    s = stats(frame("same_accuracy", dx, dy))
    assert s["n_gross"] == 1 and s["n"] == 21
    m2 = math.sqrt((800.0 + 20 * 16.0) / (2 * 21))  # M2 = √(ΣΔ²/(2n))
    assert s["medium_error"] == pytest.approx(m2, abs=TOL)
    assert s["max_error"] == pytest.approx(math.sqrt(800.0), abs=TOL)
    assert s["statistic"] == "M2"


def test_recalculation_uses_m2_and_2_sqrt2_bound() -> None:
    s = stats(frame("recalculation", [6.0] * 20, [8.0] * 20))
    assert s["medium_error"] == pytest.approx(10.0 / math.sqrt(2), abs=TOL)
    assert s["bound_m"] == pytest.approx(2 * math.sqrt(2) * 10, abs=TOL)


def test_fewer_than_20_points_use_the_mean_error() -> None:
    # 8 high-precision points, 3 gross (> 20 m): mean of |Δ| over the 5 retained (§CP-7)
    deltas = [18.25, 16.0, 15.0, 14.5, 14.75, 25.0, 30.0, 21.0]
    s = stats(frame("high_precision", deltas, [0.0] * 8))
    assert s["used_mean"] and s["statistic"] == "mean"
    assert s["medium_error"] == pytest.approx(np.mean(deltas[:5]), abs=TOL)  # 15.7
    assert s["n_gross"] == 3 and s["gross_rate"] == pytest.approx(37.5)
    sa = stats(frame("same_accuracy", [3.0, 5.0], [4.0, 12.0]))
    assert sa["medium_error"] == pytest.approx((5.0 + 13.0) / 2 / math.sqrt(2), abs=TOL)


def test_height_error_is_signed_dz_and_judged_by_magnitude() -> None:
    dz = [-12.0, 12.0, 12.5] + [1.0] * 20
    s = stats(frame("high_precision", [0.0] * 23, [0.0] * 23, dz), "height")
    assert s["n_gross"] == 1  # |−12| and 12 are on the bound 2·6 m
    assert s["max_error"] == pytest.approx(12.0)
    assert s["medium_error"] == pytest.approx(math.sqrt((144 * 2 + 20) / 22), abs=TOL)


def test_agreement_has_no_spread_when_a_method_has_no_medium_error() -> None:
    # §CP-8: 20 high-precision points at 25 m, all beyond 2·10 m, leave no medium error; the
    # same-accuracy method's M2 is 3/√2 = 2.121 m. The spread between them is undefined (it
    # read 0.00 m, as if the methods had found the same error), and they do not agree.
    df = pd.concat(
        [
            frame("high_precision", [25.0] * 20, [0.0] * 20),
            frame("same_accuracy", [3.0] * 20, [0.0] * 20),
        ]
    )
    groups, _ = accuracy_by_group(checkpoint_errors(df), P)
    (plane,) = method_agreement(groups)
    assert plane["methods"] == ["high_precision", "same_accuracy"]
    assert math.isnan(plane["medium_error"][0])
    assert plane["medium_error"][1] == pytest.approx(3.0 / math.sqrt(2), abs=1e-3)
    assert plane["spread_m"] is None and plane["agree"] is False
    # both defined: the spread is the difference, 2.121 − 1.0 (a 1 m high-precision M1)
    df = pd.concat(
        [
            frame("high_precision", [1.0] * 20, [0.0] * 20),
            frame("same_accuracy", [3.0] * 20, [0.0] * 20),
        ]
    )
    (plane,) = method_agreement(accuracy_by_group(checkpoint_errors(df), P)[0])
    assert plane["spread_m"] == pytest.approx(3.0 / math.sqrt(2) - 1.0, abs=1e-3)
    assert plane["agree"] is True


def test_plane_only_reference_gives_no_height_rows() -> None:
    pts = checkpoint_errors(frame("high_precision", [1.0], [1.0]))
    assert set(pts["component"]) == {"plane"}


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-25, 25), st.floats(-25, 25)), min_size=1, max_size=60),
    st.sampled_from(["high_precision", "same_accuracy"]),
    st.randoms(use_true_random=False),
)
def test_statistics_ignore_row_order(pairs, method, rnd) -> None:
    dx, dy = (list(v) for v in zip(*pairs, strict=True))
    a = stats(frame(method, dx, dy))
    order = list(range(len(dx)))
    rnd.shuffle(order)
    b = stats(frame(method, [dx[i] for i in order], [dy[i] for i in order]))
    for col in ("medium_error", "max_error", "n_gross", "gross_rate"):
        if isinstance(a[col], float) and math.isnan(a[col]):
            assert math.isnan(b[col])
        else:
            assert b[col] == pytest.approx(a[col], rel=1e-12, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 9.0), min_size=20, max_size=50), st.floats(0.1, 1.0))
def test_medium_error_scales_with_the_errors(deltas, k) -> None:
    # all below 2·m even after scaling by k ≤ 1: M scales linearly
    a = stats(frame("high_precision", deltas, [0.0] * len(deltas)))
    b = stats(frame("high_precision", [k * d for d in deltas], [0.0] * len(deltas)))
    assert b["medium_error"] == pytest.approx(k * a["medium_error"], rel=1e-9, abs=1e-12)
