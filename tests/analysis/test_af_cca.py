"""CCA against independent implementations; invariances; clear errors on unfit tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats
from sklearn.cross_decomposition import CCA

from blockqc.analysis.cca import AnalysisError, cca, cca_requirements
from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS

F, IND = list(FACTOR_COLUMNS), list(INDICATOR_COLUMNS)


def reference_cca(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Textbook CCA: r² are the eigenvalues of Rxx⁻¹ Rxy Ryy⁻¹ Ryx; Bartlett χ² and df per k."""
    n, p = x.shape
    q = y.shape[1]
    r = np.corrcoef(np.hstack([x, y]), rowvar=False)
    rxx, rxy, ryy = r[:p, :p], r[:p, p:], r[p:, p:]
    m = np.linalg.solve(rxx, rxy) @ np.linalg.solve(ryy, rxy.T)
    eig = np.sort(np.linalg.eigvals(m).real)[::-1][: min(p, q)]
    rc = np.sqrt(np.clip(eig, 0, 1))
    chi2 = np.array(
        [-(n - 1 - (p + q + 1) / 2) * np.sum(np.log(1 - rc[k:] ** 2)) for k in range(len(rc))]
    )
    df = np.array([(p - k) * (q - k) for k in range(len(rc))])
    return rc, chi2, df


@pytest.fixture
def result(appendix):
    return cca(appendix, F, IND)


def test_against_textbook_eigenproblem(appendix, result):
    rc, chi2, df = reference_cca(appendix[F].to_numpy(float), appendix[IND].to_numpy(float))
    np.testing.assert_allclose(result.correlations, rc, atol=1e-8)
    np.testing.assert_allclose(result.chi2, chi2, rtol=1e-6)
    np.testing.assert_array_equal(result.df, df)
    np.testing.assert_allclose(result.p_value, stats.chi2.sf(chi2, df), rtol=1e-5)
    assert list(result.df) == [50, 36, 24, 14, 6]


def test_against_scikit_learn(appendix, result):
    x, y = appendix[F].to_numpy(float), appendix[IND].to_numpy(float)
    model = CCA(n_components=2, max_iter=100_000, tol=1e-14).fit(x, y)
    u, v = model.transform(x, y)
    sk = [abs(np.corrcoef(u[:, k], v[:, k])[0, 1]) for k in range(2)]
    np.testing.assert_allclose(result.correlations[:2], sk, atol=1e-8)


def test_variates_and_structure(appendix, result):
    x, y = appendix[F].to_numpy(float), appendix[IND].to_numpy(float)
    zx = (x - x.mean(0)) / x.std(0, ddof=1)
    zy = (y - y.mean(0)) / y.std(0, ddof=1)
    u = zx @ result.coef_x.to_numpy()
    v = zy @ result.coef_y.to_numpy()
    # unit-variance variates, correlated pairwise by r_k, uncorrelated across pairs
    np.testing.assert_allclose(np.cov(u, rowvar=False), np.eye(5), atol=1e-8)
    np.testing.assert_allclose(np.cov(v, rowvar=False), np.eye(5), atol=1e-8)
    np.testing.assert_allclose(
        np.diag(np.corrcoef(u.T, v.T)[:5, 5:]), result.correlations, atol=1e-8
    )
    # structure coefficients: direct correlations with the first variates
    sx = [np.corrcoef(zx[:, j], u[:, 0])[0, 1] for j in range(10)]
    sxv = [np.corrcoef(zx[:, j], v[:, 0])[0, 1] for j in range(10)]
    sy = [np.corrcoef(zy[:, j], v[:, 0])[0, 1] for j in range(5)]
    syu = [np.corrcoef(zy[:, j], u[:, 0])[0, 1] for j in range(5)]
    np.testing.assert_allclose(result.structure_x["U1"], sx, atol=1e-8)
    np.testing.assert_allclose(result.structure_x["V1"], sxv, atol=1e-8)
    np.testing.assert_allclose(result.structure_y["V1"], sy, atol=1e-8)
    np.testing.assert_allclose(result.structure_y["U1"], syu, atol=1e-8)
    # cross-structure = own structure × r₁
    np.testing.assert_allclose(
        result.structure_x["V1"], result.structure_x["U1"] * result.correlations[0], atol=1e-10
    )


def test_appendix_figures(result):
    # the first pair is significant, the second is not at 5 % (Bartlett)
    assert result.correlations[0] == pytest.approx(0.99066, abs=5e-5)
    assert result.p_value[0] < 0.001
    assert result.p_value[1] > 0.05
    assert np.all(np.diff(result.correlations) <= 0)


@settings(max_examples=25, deadline=None)
@given(
    col=st.sampled_from(F + IND),
    scale=st.floats(min_value=1e-3, max_value=1e3).flatmap(lambda s: st.sampled_from([s, -s])),
    shift=st.floats(min_value=-1e4, max_value=1e4),
    seed=st.integers(0, 2**16),
)
def test_invariance(appendix, col, scale, shift, seed):
    """Rescaling or shifting a column, or shuffling the rows, leaves the CCA unchanged."""
    base = cca(appendix, F, IND)
    t = appendix.copy()
    t[col] = t[col] * scale + shift
    t = t.sample(frac=1.0, random_state=seed).reset_index(drop=True)
    other = cca(t, F, IND)
    np.testing.assert_allclose(other.correlations, base.correlations, atol=1e-7)
    np.testing.assert_allclose(other.chi2, base.chi2, rtol=1e-5)
    # structure coefficients keep their size; a negative scale flips that variable's sign
    flip = np.where(np.array(F) == col, np.sign(scale), 1.0)
    own = base.structure_x["U1"].to_numpy()
    assert np.allclose(other.structure_x["U1"].to_numpy(), own * flip, atol=1e-6) or np.allclose(
        other.structure_x["U1"].to_numpy(), -own * flip, atol=1e-6
    )


def test_too_few_rows_is_explained(appendix):
    small = appendix.iloc[:8]
    reasons = cca_requirements(small, F, IND)
    assert any("n = 8" in r and "p = 10" in r and "q = 5" in r and "17" in r for r in reasons)
    with pytest.raises(AnalysisError, match="at least 17 rows"):
        cca(small, F, IND)


def test_constant_and_collinear_columns_are_named(appendix):
    t = appendix.copy()
    t["images_periods"] = 4.0
    t["tp_density_per_km2"] = t["tp_number"] / 250.0
    with pytest.raises(AnalysisError) as err:
        cca(t, F, IND)
    msg = str(err.value)
    assert "constant factor column(s): images_periods" in msg
    assert "tp_density_per_km2" in msg and "tp_number" in msg and "linear combination" in msg


def test_perfectly_related_groups(appendix):
    t = appendix.copy()
    t["h_rmse_m"] = 2 * t["mean_slope_deg"] + 1
    with pytest.raises(AnalysisError, match="first canonical correlation is 1"):
        cca(t, F, IND)


def test_json_ready(result):
    d = result.to_dict()
    assert d["n"] == 20 and d["p"] == 10 and d["q"] == 5
    assert len(d["tests"]) == 5 and set(d["structure_factors"]) == set(F)
    pd.Series(d["tests"][0])  # plain scalars
