"""The §AF analysis of an experiments table, as one JSON-ready results dictionary."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from blockqc.analysis.cca import (
    MIN_CORRELATION_ROWS,
    AnalysisError,
    cca,
    cca_requirements,
    pearson,
)
from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS, LABELS, TABLE_COLUMNS
from blockqc.outputs import jsonable

#: A column whose standard deviation is below this share of its mean is called nearly constant.
NEARLY_CONSTANT = 1e-3


def _matrix(frame: pd.DataFrame) -> dict[str, dict[str, float | None]]:
    return {str(i): {str(c): jsonable(frame.loc[i, c]) for c in frame.columns} for i in frame.index}


def analyse(table: pd.DataFrame, source: str) -> dict[str, Any]:
    """Correlation matrix and, when the table supports it, the CCA of factors and indicators.

    Correlations use, cell by cell, the rows where both values are present; the CCA uses the
    rows where all fifteen are (the others are listed with what they miss).
    """
    factors, indicators = list(FACTOR_COLUMNS), list(INDICATOR_COLUMNS)
    numeric = table[factors + indicators].apply(pd.to_numeric, errors="coerce").astype(float)
    complete = np.isfinite(numeric.to_numpy(dtype=float)).all(axis=1)
    used = numeric[complete].reset_index(drop=True)
    stats = pd.DataFrame(
        {
            "n": numeric.notna().sum(),
            "mean": numeric.mean(),
            "sd": numeric.std(ddof=1),
            "min": numeric.min(),
            "max": numeric.max(),
        }
    )
    return {
        "source": source,
        "n_rows": int(len(table)),
        "n_used": int(len(used)),
        "excluded": _excluded(table, numeric),
        "factors": factors,
        "indicators": indicators,
        "labels": {c: LABELS[c] for c in factors + indicators},
        "descriptive": _matrix(stats),
        "table_columns": [c for c in TABLE_COLUMNS if c in table.columns],
        "extra_columns": [str(c) for c in table.columns if c not in TABLE_COLUMNS],
        "table": [
            {k: jsonable(v) for k, v in row.items()} for row in table.to_dict(orient="records")
        ],
        "correlation": _correlation(numeric, factors, indicators),
        "correlation_note": _correlation_note(numeric),
        **_cca_of(used, factors, indicators),
    }


def _excluded(table: pd.DataFrame, numeric: pd.DataFrame) -> list[dict[str, Any]]:
    """The experiments left out of the CCA, each with the columns it misses."""
    finite = np.isfinite(numeric.to_numpy(dtype=float))
    ids = (
        table["experiment"].astype(str)
        if "experiment" in table
        else pd.Series([str(i + 1) for i in range(len(table))])
    )
    return [
        {
            "experiment": ids.iloc[i],
            "missing": [c for c, ok in zip(numeric.columns, finite[i], strict=True) if not ok],
        }
        for i in np.flatnonzero(~finite.all(axis=1))
    ]


def _correlation(
    numeric: pd.DataFrame, factors: list[str], indicators: list[str]
) -> dict[str, Any] | None:
    """Pearson r of every factor with every indicator, its p-value and the rows of each cell;
    None when no cell has one."""
    corr = pearson(numeric, factors, indicators)
    if not corr.r.notna().to_numpy().any():
        return None
    n_cells = corr.n.to_numpy()
    return {
        "r": _matrix(corr.r),
        "p_value": _matrix(corr.p_value),
        "n": _matrix(corr.n),
        "n_min": int(n_cells.min()),
        "n_max": int(n_cells.max()),
    }


def _correlation_note(numeric: pd.DataFrame) -> str | None:
    """Why some columns have no correlation, or one that rests on very small differences."""
    cols = list(numeric.columns)
    notes = []
    few = [c for c in cols if numeric[c].notna().sum() < MIN_CORRELATION_ROWS]
    if few:
        notes.append(f"fewer than {MIN_CORRELATION_ROWS} values, no correlation: {', '.join(few)}")
    const = [c for c in cols if c not in few and not numeric[c].std(ddof=1) > 0]
    if const:
        notes.append("constant over the experiments, no correlation: " + ", ".join(const))
    mean_abs = numeric.mean().abs()
    nearly = [
        c
        for c in cols
        if c not in few + const and numeric[c].std(ddof=1) < NEARLY_CONSTANT * mean_abs[c]
    ]
    if nearly:
        notes.append(
            "varying by less than 0.1 % of their mean, so their correlations rest on very small "
            "differences: " + ", ".join(nearly)
        )
    return "; ".join(notes) or None


def _cca_of(used: pd.DataFrame, factors: list[str], indicators: list[str]) -> dict[str, Any]:
    """The CCA of the complete rows, or why it was not computed."""
    reasons = cca_requirements(used, factors, indicators)
    if len(used) < 2:  # every column of one row (or none) reads constant: the rows are why
        reasons = reasons[:1]
    if reasons:
        return {"cca": None, "cca_not_computed": reasons}
    try:
        return {"cca": cca(used, factors, indicators).to_dict(), "cca_not_computed": []}
    except AnalysisError as exc:
        return {"cca": None, "cca_not_computed": [str(exc)]}
