"""Pearson correlation and canonical correlation analysis between factors and indicators (§AF)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import scipy.linalg
from scipy import stats

from blockqc.outputs import jsonable


class AnalysisError(ValueError):
    """The table cannot support the analysis (too few rows, constant or collinear columns)."""


@dataclass(frozen=True)
class Correlation:
    """Pearson correlations of every factor (rows) with every indicator (columns), with p-values
    and the number of rows behind each cell (rows where both values are present)."""

    r: pd.DataFrame
    p_value: pd.DataFrame
    n: pd.DataFrame


MIN_CORRELATION_ROWS = 3


def _present_mean(v: np.ndarray, present: np.ndarray) -> np.ndarray:
    """Each column's mean over its present values (NaN, and no warning, where none is)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(present, v, 0.0).sum(axis=0) / present.sum(axis=0)


def pearson(table: pd.DataFrame, factors: list[str], indicators: list[str]) -> Correlation:
    """Pearson r of each factor with each indicator over the rows where both are present
    (pairwise deletion), and its two-sided t-test p-value on n − 2 degrees of freedom.

    A cell with fewer than 3 rows, or whose factor or indicator is constant over them, is NaN.
    """
    x = table[factors].to_numpy(dtype=float)
    y = table[indicators].to_numpy(dtype=float)
    mx, my = np.isfinite(x), np.isfinite(y)
    # centre first (any constant per column keeps r exact) for numerical stability
    x = np.where(mx, x - _present_mean(x, mx), 0.0)
    y = np.where(my, y - _present_mean(y, my), 0.0)
    fx, fy = mx.astype(float), my.astype(float)
    n = fx.T @ fy
    sx, sy = x.T @ fy, fx.T @ y
    sxy = x.T @ y
    sxx, syy = (x * x).T @ fy, fx.T @ (y * y)
    with np.errstate(invalid="ignore", divide="ignore"):
        cxy = sxy - sx * sy / n
        vx = sxx - sx * sx / n
        vy = syy - sy * sy / n
        scale_x = (np.abs(x) ** 2).T @ fy
        scale_y = fx.T @ (np.abs(y) ** 2)
        degenerate = (vx <= 1e-24 * np.maximum(scale_x, 1e-300)) | (
            vy <= 1e-24 * np.maximum(scale_y, 1e-300)
        )
        r = np.clip(cxy / np.sqrt(vx * vy), -1.0, 1.0)
        r = np.where(degenerate | (n < MIN_CORRELATION_ROWS), np.nan, r)
        t = r * np.sqrt((n - 2) / (1.0 - r**2))
        p = np.where(np.abs(r) >= 1.0, 0.0, 2.0 * stats.t.sf(np.abs(t), n - 2))
    p = np.where(np.isnan(r), np.nan, p)
    return Correlation(
        r=pd.DataFrame(r, index=factors, columns=indicators),
        p_value=pd.DataFrame(p, index=factors, columns=indicators),
        n=pd.DataFrame(n.astype(int), index=factors, columns=indicators),
    )


@dataclass(frozen=True)
class CCAResult:
    """Canonical correlation analysis of a factor group X (p columns) and indicator group Y (q)."""

    n: int
    factors: list[str]
    indicators: list[str]
    correlations: np.ndarray  # r_1 ≥ r_2 ≥ … ≥ r_m, m = min(p, q)
    wilks_lambda: np.ndarray  # Λ_k = Π_{i≥k} (1 − r_i²)
    chi2: np.ndarray  # Bartlett: −(n − 1 − (p + q + 1)/2) · ln Λ_k
    df: np.ndarray  # (p − k + 1)(q − k + 1)
    p_value: np.ndarray
    coef_x: pd.DataFrame  # standardized canonical coefficients, variables × variates
    coef_y: pd.DataFrame
    structure_x: pd.DataFrame  # corr(X_j, U_k) and corr(X_j, V_k): columns "U1", "V1"
    structure_y: pd.DataFrame  # corr(Y_j, V_k) and corr(Y_j, U_k)
    scores_u: np.ndarray = field(repr=False)
    scores_v: np.ndarray = field(repr=False)

    def tests_frame(self) -> pd.DataFrame:
        """One row per canonical pair: r, r², Wilks' Λ, Bartlett's χ², df, p."""
        k = np.arange(1, len(self.correlations) + 1)
        return pd.DataFrame(
            {
                "pair": k,
                "canonical_correlation": self.correlations,
                "r_squared": self.correlations**2,
                "wilks_lambda": self.wilks_lambda,
                "chi2": self.chi2,
                "df": self.df,
                "p_value": self.p_value,
            }
        )

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        return {
            "n": self.n,
            "p": len(self.factors),
            "q": len(self.indicators),
            "tests": _records(self.tests_frame()),
            "coefficients_factors": _frame_dict(self.coef_x),
            "coefficients_indicators": _frame_dict(self.coef_y),
            "structure_factors": _frame_dict(self.structure_x),
            "structure_indicators": _frame_dict(self.structure_y),
        }


def cca_requirements(table: pd.DataFrame, factors: list[str], indicators: list[str]) -> list[str]:
    """Every reason why the CCA cannot be computed on this table (empty when it can)."""
    n, p, q = len(table), len(factors), len(indicators)
    reasons: list[str] = []
    if n - 1 <= p + q:
        reasons.append(
            f"the table has n = {n} complete rows but CCA of p = {p} factors and q = {q} "
            f"indicators needs n − 1 > p + q, i.e. at least {p + q + 2} rows (with fewer, some "
            "canonical correlation is 1 by construction and Bartlett's statistic is undefined)"
        )
    for group, cols in (("factor", factors), ("indicator", indicators)):
        data = table[cols].to_numpy(dtype=float)
        sd = _std(data)
        const = [c for c, s in zip(cols, sd, strict=True) if not s > 0]
        if const:
            reasons.append(f"constant {group} column(s): {', '.join(const)}")
        live = [c for c in cols if c not in const]
        if live and n - 1 > p + q:  # with fewer rows every group is rank-deficient anyway
            dep = _dependent_columns(_standardize(table[live].to_numpy(dtype=float)), live)
            for col, combo in dep:
                reasons.append(
                    f"{group} column {col} is (numerically) a linear combination of "
                    f"{', '.join(combo) if combo else 'the others'}"
                )
    return reasons


def cca(table: pd.DataFrame, factors: list[str], indicators: list[str]) -> CCAResult:
    """CCA via QR of each standardized group and SVD of Q_xᵀQ_y; Bartlett's χ² for each k."""
    reasons = cca_requirements(table, factors, indicators)
    if reasons:
        raise AnalysisError("; ".join(reasons))  # the callers say "CCA not computed: …"
    x = _standardize(table[factors].to_numpy(dtype=float))
    y = _standardize(table[indicators].to_numpy(dtype=float))
    n, p = x.shape
    q = y.shape[1]
    m = min(p, q)
    qx, rx = np.linalg.qr(x)
    qy, ry = np.linalg.qr(y)
    u_svd, s, vt = np.linalg.svd(qx.T @ qy)
    r = np.clip(s[:m], 0.0, 1.0)
    if r[0] > 1.0 - 1e-10:
        raise AnalysisError(
            "the first canonical correlation is 1, so a combination of the "
            "factors reproduces a combination of the indicators exactly (collinear groups)"
        )
    scale = np.sqrt(n - 1.0)
    a = scipy.linalg.solve_triangular(rx, u_svd[:, :m]) * scale
    b = scipy.linalg.solve_triangular(ry, vt.T[:, :m]) * scale
    su, sv = x @ a, y @ b  # canonical variates, unit variance
    # sign convention: each X variate correlates positively with the sum of the factors' loadings
    sx = _corr(x, su)
    sign = np.where(sx.sum(axis=0) < 0, -1.0, 1.0)
    a, b, su, sv = a * sign, b * sign, su * sign, sv * sign
    struct_x = np.column_stack([_corr(x, su)[:, 0], _corr(x, sv)[:, 0]])
    struct_y = np.column_stack([_corr(y, sv)[:, 0], _corr(y, su)[:, 0]])
    k = np.arange(1, m + 1)
    wilks_log, chi2, df, pv = _bartlett(r, k, n, p, q)
    names = [f"{i}" for i in k]
    return CCAResult(
        n=n,
        factors=list(factors),
        indicators=list(indicators),
        correlations=r,
        wilks_lambda=np.exp(wilks_log),
        chi2=chi2,
        df=df.astype(int),
        p_value=pv,
        coef_x=pd.DataFrame(a, index=factors, columns=[f"U{i}" for i in names]),
        coef_y=pd.DataFrame(b, index=indicators, columns=[f"V{i}" for i in names]),
        structure_x=pd.DataFrame(struct_x, index=factors, columns=["U1", "V1"]),
        structure_y=pd.DataFrame(struct_y, index=indicators, columns=["V1", "U1"]),
        scores_u=su,
        scores_v=sv,
    )


def _bartlett(
    r: np.ndarray, k: np.ndarray, n: int, p: int, q: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bartlett's test that the canonical correlations from the k-th on are all zero, for each
    k of `k`, of the canonical correlations `r` of p factors and q indicators over n rows: log
    Wilks' Λ, χ², its degrees of freedom and p value."""
    with np.errstate(divide="ignore"):
        log_terms = np.log1p(-(r**2))
    wilks_log = np.cumsum(log_terms[::-1])[::-1]
    chi2 = -(n - 1 - (p + q + 1) / 2.0) * wilks_log
    df = (p - k + 1) * (q - k + 1)
    pv = stats.chi2.sf(chi2, df)
    return wilks_log, chi2, df, pv


def _std(a: np.ndarray) -> np.ndarray:
    """Column sample standard deviations; 0 for a column whose values are all (nearly) equal."""
    sd = a.std(axis=0, ddof=1) if a.shape[0] > 1 else np.zeros(a.shape[1])
    span = np.abs(a).max(axis=0) if a.shape[0] else np.zeros(a.shape[1])
    return np.where(sd <= 1e-12 * np.maximum(span, 1e-300), 0.0, sd)


def _standardize(a: np.ndarray) -> np.ndarray:
    sd = _std(a)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (a - a.mean(axis=0)) / sd


def _corr(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Correlations of each column of a with each column of b."""
    return _standardize(a).T @ _standardize(b) / (a.shape[0] - 1)


def _dependent_columns(z: np.ndarray, names: list[str]) -> list[tuple[str, list[str]]]:
    """Columns of z that are linear combinations of earlier pivots (QR with column pivoting)."""
    _, r, piv = scipy.linalg.qr(z, mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    if diag.size == 0:
        return []
    tol = max(z.shape) * np.finfo(float).eps * 1e4 * diag[0]
    rank = int((diag > tol).sum())
    out: list[tuple[str, list[str]]] = []
    if rank == z.shape[1]:
        return out
    basis = piv[:rank]
    for j in piv[rank:]:
        coef, *_ = np.linalg.lstsq(z[:, basis], z[:, j], rcond=None)
        used = [names[basis[i]] for i in np.flatnonzero(np.abs(coef) > 1e-8)]
        out.append((names[j], used))
    return out


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    return [{k: jsonable(v) for k, v in row.items()} for row in frame.to_dict(orient="records")]


def _frame_dict(frame: pd.DataFrame) -> dict[str, dict[str, float | None]]:
    return {str(i): {str(c): jsonable(frame.loc[i, c]) for c in frame.columns} for i in frame.index}
