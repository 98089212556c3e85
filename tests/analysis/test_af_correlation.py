"""Pearson correlation of the appendix table, hand-checked against direct computations."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats

from blockqc.analysis.cca import pearson
from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS, read_table

F, IND = list(FACTOR_COLUMNS), list(INDICATOR_COLUMNS)


@pytest.fixture
def corr(appendix_path):
    return pearson(read_table(appendix_path), F, IND)


def _hand_r(x: np.ndarray, y: np.ndarray) -> float:
    """r = Σ(x − x̄)(y − ȳ) / √(Σ(x − x̄)² Σ(y − ȳ)²), written out."""
    dx, dy = x - x.sum() / len(x), y - y.sum() / len(y)
    return float((dx * dy).sum() / np.sqrt((dx * dx).sum() * (dy * dy).sum()))


@pytest.mark.parametrize(
    ("factor", "indicator"),
    [
        ("tp_nn_coefficient", "l_rmse_px"),
        ("mean_elevation_m", "x_rmse_m"),
        ("overlap_degree", "h_rmse_m"),
        ("images_area_km2", "y_rmse_m"),
    ],
)
def test_cells_by_hand(appendix, corr, factor, indicator):
    x = appendix[factor].to_numpy(float)
    y = appendix[indicator].to_numpy(float)
    assert corr.r.loc[factor, indicator] == pytest.approx(_hand_r(x, y), abs=1e-12)
    res = stats.pearsonr(x, y)
    assert corr.r.loc[factor, indicator] == pytest.approx(res.statistic, abs=1e-12)
    assert corr.p_value.loc[factor, indicator] == pytest.approx(res.pvalue, rel=1e-9)


def test_matrix_against_numpy(appendix, corr):
    full = np.corrcoef(appendix[F + IND].to_numpy(float), rowvar=False)
    np.testing.assert_allclose(corr.r.to_numpy(), full[:10, 10:], atol=1e-12)
    assert corr.r.shape == (10, 5) and (corr.n == 20).all().all()


def test_strongest_cell(corr):
    # Clark–Evans R against δ_l is the strongest association in the table: r = −0.765
    flat = corr.r.abs().stack()
    assert flat.idxmax() == ("tp_nn_coefficient", "l_rmse_px")
    assert corr.r.loc["tp_nn_coefficient", "l_rmse_px"] == pytest.approx(-0.765, abs=5e-4)


def test_constant_column_has_no_correlation(appendix):
    t = appendix.copy()
    t["images_periods"] = 3.0
    c = pearson(t, F, IND)
    assert c.r.loc["images_periods"].isna().all()
    assert c.r.drop(index="images_periods").notna().all().all()


def test_pairwise_deletion(appendix):
    """A missing value drops that row from the cells it takes part in, and only from those."""
    t = appendix.copy()
    t.loc[[0, 5, 9], "x_rmse_m"] = np.nan
    t.loc[[2], "mean_slope_deg"] = np.nan
    c = pearson(t, F, IND)
    keep = ~np.isin(np.arange(20), [0, 5, 9, 2])
    x, y = t.loc[keep, "mean_slope_deg"], t.loc[keep, "x_rmse_m"]
    assert c.n.loc["mean_slope_deg", "x_rmse_m"] == 16
    assert c.r.loc["mean_slope_deg", "x_rmse_m"] == pytest.approx(
        stats.pearsonr(x, y).statistic, abs=1e-12
    )
    assert c.n.loc["tp_number", "l_rmse_px"] == 20
    assert c.r.loc["tp_number", "l_rmse_px"] == pytest.approx(
        stats.pearsonr(t["tp_number"], t["l_rmse_px"]).statistic, abs=1e-12
    )
    # fewer than three rows: no correlation
    few = appendix.copy()
    few.loc[2:, "h_rmse_m"] = np.nan
    assert pearson(few, F, IND).r["h_rmse_m"].isna().all()


def test_an_indicator_never_given_is_nan_without_a_warning(appendix_path):
    """An indicator missing on every row (no checkpoints in any block) gives NaN, and numpy's
    'Mean of empty slice' does not reach the user's console."""
    t = read_table(appendix_path)
    t["h_rmse_m"] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = pearson(t, F, IND)
    assert c.r["h_rmse_m"].isna().all()
    assert c.r["l_rmse_px"].notna().all()
