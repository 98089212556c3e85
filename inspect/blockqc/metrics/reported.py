"""The figures the producer's reports state against the same figures recomputed (§DOC-2)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from blockqc.delivery import Delivery
from blockqc.metrics import (
    REGISTRY,
    Measure,
    Measurement,
    Scope,
    Table,
    metric,
    not_applicable,
)

# relative slack on the agreement bound for the binary rounding of decimal figures
ROUNDING = 1e-9


class Figure(BaseModel):
    """Where a reported figure is recomputed: a metric, its parameters, a scope and statistic."""

    model_config = ConfigDict(extra="forbid")
    metric: str
    params: dict[str, Any] = Field(default_factory=dict)
    scope: str = "block"
    statistic: str
    where: dict[str, str | float | bool] = Field(default_factory=dict)
    # when several rows remain, take the first by this preference, e.g. {method: [high_precision]}
    prefer: dict[str, list[str]] = Field(default_factory=dict)


class ReportedParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    figures: dict[str, Figure] = Field(default_factory=dict)
    rel_tol: float = Field(default=0.05, ge=0)  # agreement: |Δ| ≤ max(abs_tol, rel_tol·|value|)
    abs_tol: float = Field(default=0.005, ge=0)  # half a unit of the second decimal


def recompute(fig: Figure, measure: Measure) -> tuple[float, str]:
    """The recomputed value of one figure, or NaN and why it could not be recomputed."""
    m = measure(fig.metric, fig.params)
    if m.not_applicable:
        return float("nan"), m.not_applicable
    df = m.tables[fig.scope].df
    for col, val in fig.where.items():
        df = df[df[col] == val]
    for col, order in fig.prefer.items():
        rank = df[col].map({v: i for i, v in enumerate(order)}).fillna(len(order))
        df = df.assign(_rank=rank.to_numpy()).sort_values("_rank", kind="stable")
    if df.empty:
        return float("nan"), "nothing to recompute it from"
    return float(df[fig.statistic].iloc[0]), ""


def _agree(diff: float, value_r: float, p: ReportedParams) -> bool:
    """|Δ| ≤ max(abs_tol, rel_tol·|recomputed|), the bound included: a difference within
    ROUNDING of the bound counts as on it (0.315 − 0.30 is 0.015000000000000013 in binary, 5 %
    of 0.30 is 0.015); a difference that is not a finite number (an infinite recomputed value)
    never agrees."""
    bound = max(p.abs_tol, p.rel_tol * abs(value_r))
    return bool(math.isfinite(diff) and abs(diff) <= bound * (1.0 + ROUNDING))


def _undefined(name: str, value: float, figures: dict, reported: dict) -> dict[str, Any]:
    """A figure the pack defines no recomputation for: exempt, unless it is meant for a defined
    figure that is not reported under its own name (`_meant`), which does not agree: a figure
    is never left unchecked by a typo."""
    row = {"figure": name, "reported": value, "recomputed": np.nan, "difference": np.nan}
    close = [f for f in figures if f not in reported and _meant(name, f)]
    if close:
        note = f"no figure is named {name}: did you mean {close[0]}? (not recomputed)"
        return row | {"agrees": False, "exempt": False, "exempt_reason": "", "note": note}
    why = "no recomputation is defined for this figure"
    return row | {"agrees": True, "exempt": True, "exempt_reason": why, "note": ""}


def _meant(name: str, figure: str) -> bool:
    """Whether `name` is a slip for `figure`: one edit from it (`tie_point_max_eror_px`), or
    it without its last word, the unit (`tie_point_max_error` for `tie_point_max_error_px`).
    `tie_point_mean_error_px` is two edits from `tie_point_max_error_px`: another figure."""
    unit = figure[len(name) + 1 :]
    without_unit = figure.startswith(name + "_") and unit.isalnum()
    return without_unit or edit_distance(name, figure) == 1


def edit_distance(a: str, b: str) -> int:
    """Edits (insert, delete, substitute, swap of neighbours) that turn `a` into `b`: the
    optimal string alignment distance, row by row."""
    before, row = None, list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        now = [i]
        for j, cb in enumerate(b, 1):
            d = min(row[j] + 1, now[j - 1] + 1, row[j - 1] + (ca != cb))
            if before is not None and j > 1 and ca == b[j - 2] and a[i - 2] == cb:
                d = min(d, before[j - 2] + 1)
            now.append(d)
        before, row = row, now
    return row[-1]


def _tie_point_columns(p: ReportedParams) -> set[str] | None:
    """The tie_points columns the figures' recomputations read (None: every column)."""
    out: set[str] = set()
    for fig in p.figures.values():
        spec = REGISTRY.get(fig.metric)
        if spec is None or callable(spec.tie_points) or spec.tie_points is None:
            return None  # read whole rather than guess (an unknown metric is refused anyway)
        out |= set(spec.tie_points)
    return out


@metric(
    "reported_figures",
    params=ReportedParams,
    tie_points=_tie_point_columns,
    scopes={
        "figure": Scope(
            {"agrees": "true/false", "difference": "the figure's unit"},
            keys=("figure",),
            columns=("reported", "recomputed", "exempt", "exempt_reason", "note"),
            signed=("difference",),
        )
    },
    param_units={"rel_tol": "fraction", "abs_tol": "the figure's unit"},
)
def reported_figures(d: Delivery, p: ReportedParams, measure: Measure) -> Measurement:
    """Each figure in block.yaml `reported` against its recomputation (§DOC-2)."""
    reported = d.manifest.reported
    if not reported:
        return not_applicable("block.yaml states no reported figures")
    rows = []
    for name, value in reported.items():
        fig = p.figures.get(name)
        if fig is None:
            rows.append(_undefined(name, value, p.figures, reported))
            continue
        value_r, why = recompute(fig, measure)
        diff = value - value_r
        agrees = _agree(diff, value_r, p) if not why else True
        rows.append(
            {
                "figure": name,
                "reported": value,
                "recomputed": value_r,
                "difference": diff,
                "agrees": agrees,
                "exempt": bool(why),
                "exempt_reason": f"cannot be recomputed: {why}" if why else "",
                "note": "",
            }
        )
    table = pd.DataFrame(rows)
    return Measurement(
        tables={"figure": Table(table, keys=["figure"], sort="difference")},
        detail={"rel_tol": p.rel_tol, "abs_tol": p.abs_tol},
    )
