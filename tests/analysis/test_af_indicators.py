"""Accuracy indicators (§AF): RMSE about the mean with m − 1, one method per component."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from blockqc.analysis.indicators import block_indicators, object_indicators, rmse_about_mean


def test_rmse_about_mean_by_hand():
    # values 1, 2, 3, 4: mean 2.5, squared deviations 2.25 + 0.25 + 0.25 + 2.25 = 5, / (4 − 1)
    assert rmse_about_mean(np.array([1.0, 2.0, 3.0, 4.0])) == pytest.approx(math.sqrt(5 / 3))
    # a constant offset does not count (unlike the medium error of §CP-5)
    assert rmse_about_mean(np.array([10.0, 10.0, 10.0])) == 0.0
    assert math.isnan(rmse_about_mean(np.array([3.0])))
    assert rmse_about_mean(np.array([1.0, np.nan, 3.0])) == pytest.approx(math.sqrt(2))


def _cp(method, dx, dy, dz):
    n = len(dx)
    return pd.DataFrame(
        {
            "point_id": [f"{method}{i}" for i in range(n)],
            "method": method,
            "reference_id": "r",
            "x_m": np.zeros(n),
            "y_m": np.zeros(n),
            "z_m": np.zeros(n),
            "ref_x_m": -np.asarray(dx, float),
            "ref_y_m": -np.asarray(dy, float),
            "ref_z_m": -np.asarray(dz, float),
        }
    )


def test_one_method_per_component():
    hp = _cp("high_precision", [1, 2, 3], [0, 0, 2], [np.nan, np.nan, np.nan])  # plane only
    sa = _cp("same_accuracy", [9, -9, 9], [9, -9, 9], [1, 2, 4])
    dx, dy, dh, n_p, n_h, pm, hm = object_indicators(pd.concat([hp, sa], ignore_index=True))
    assert (pm, hm, n_p, n_h) == ("high_precision", "same_accuracy", 3, 3)
    assert dx == pytest.approx(1.0)
    assert dy == pytest.approx(np.std([0, 0, 2], ddof=1))
    assert dh == pytest.approx(np.std([1, 2, 4], ddof=1))
    # the order is a reading the user may change
    assert object_indicators(pd.concat([hp, sa]), ("same_accuracy",))[5] == "same_accuracy"


def test_block_indicators():
    rng = np.random.default_rng(3)
    tp = pd.DataFrame({"v_line": rng.normal(0.2, 0.3, 500), "v_sample": rng.normal(0, 0.5, 500)})
    ind = block_indicators(tp, None)
    assert ind.l_rmse_px == pytest.approx(tp["v_line"].std(ddof=1))
    assert ind.s_rmse_px == pytest.approx(tp["v_sample"].std(ddof=1))
    assert math.isnan(ind.x_rmse_m) and ind.plane_method is None and ind.n_tie_observations == 500
