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
    finite = np.isfinite(numeric.to_numpy(dtype=float))
    complete = finite.all(axis=1)
    ids = (
        table["experiment"].astype(str)
        if "experiment" in table
        else pd.Series([str(i + 1) for i in range(len(table))])
    )
    excluded = [
        {
            "experiment": ids.iloc[i],
            "missing": [c for c, ok in zip(factors + indicators, finite[i], strict=True) if not ok],
        }
        for i in np.flatnonzero(~complete)
    ]
    used = numeric[complete].reset_index(drop=True)
    n = len(used)
    stats = pd.DataFrame(
        {
            "n": numeric.notna().sum(),
            "mean": numeric.mean(),
            "sd": numeric.std(ddof=1),
            "min": numeric.min(),
            "max": numeric.max(),
        }
    )
    results: dict[str, Any] = {
        "source": source,
        "n_rows": int(len(table)),
        "n_used": int(n),
        "excluded": excluded,
        "factors": factors,
        "indicators": indicators,
        "labels": {c: LABELS[c] for c in factors + indicators},
        "descriptive": _matrix(stats),
        "table_columns": [c for c in TABLE_COLUMNS if c in table.columns],
        "extra_columns": [str(c) for c in table.columns if c not in TABLE_COLUMNS],
        "table": [
            {k: jsonable(v) for k, v in row.items()} for row in table.to_dict(orient="records")
        ],
        "correlation": None,
        "correlation_note": None,
        "cca": None,
        "cca_not_computed": [],
    }
    corr = pearson(numeric, factors, indicators)
    if corr.r.notna().to_numpy().any():
        n_cells = corr.n.to_numpy()
        results["correlation"] = {
            "r": _matrix(corr.r),
            "p_value": _matrix(corr.p_value),
            "n": _matrix(corr.n),
            "n_min": int(n_cells.min()),
            "n_max": int(n_cells.max()),
        }
    notes = []
    few = [c for c in factors + indicators if numeric[c].notna().sum() < MIN_CORRELATION_ROWS]
    if few:
        notes.append(f"fewer than {MIN_CORRELATION_ROWS} values, no correlation: {', '.join(few)}")
    const = [c for c in factors + indicators if c not in few and not numeric[c].std(ddof=1) > 0]
    if const:
        notes.append("constant over the experiments, no correlation: " + ", ".join(const))
    mean_abs = numeric.mean().abs()
    nearly = [
        c
        for c in factors + indicators
        if c not in few + const and numeric[c].std(ddof=1) < NEARLY_CONSTANT * mean_abs[c]
    ]
    if nearly:
        notes.append(
            "varying by less than 0.1 % of their mean, so their correlations rest on very small "
            "differences: " + ", ".join(nearly)
        )
    results["correlation_note"] = "; ".join(notes) or None
    reasons = (
        cca_requirements(used, factors, indicators)
        if n >= 2
        else [f"the table has {n} complete rows"]
    )
    if reasons:
        results["cca_not_computed"] = reasons
    else:
        try:
            results["cca"] = cca(used, factors, indicators).to_dict()
        except AnalysisError as exc:
            results["cca_not_computed"] = [str(exc)]
    return results
