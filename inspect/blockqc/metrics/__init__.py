"""The registry of measurements: pure, vectorized functions of a delivery (they know no rules).

A metric returns a Measurement: named tables ("block", "scene", "pair", "point", ...) whose
columns are statistics a rule can judge. `group` columns split a table into separately judged
results (e.g. component, method); `keys` identify the units inside a group (scene, pair, point).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import pandas as pd
from pydantic import BaseModel

from blockqc.delivery import Delivery


@dataclass
class Table:
    """One table of a measurement: units (rows) with statistics (columns)."""

    df: pd.DataFrame
    group: list[str] = field(default_factory=list)
    keys: list[str] = field(default_factory=list)
    sort: str | None = None  # default order of evidence rows (descending), e.g. "error_px"
    groups: list[dict[str, Any]] | None = None  # groups to report even when they hold no rows
    # why some of those groups hold no rows, where the delivery says it (no dz_m column: no
    # heights); each a group's values and the reason
    empty: tuple[tuple[Mapping[str, Any], str], ...] = ()
    # columns left out of `df` because the delivery's columns behind them were not read (a pack
    # with `columns: used`), and how to add them to some of its rows (those shown as evidence)
    lazy: tuple[str, ...] = ()
    fill: Callable[[pd.DataFrame], pd.DataFrame] | None = None

    def empty_reason(self, group: Mapping[str, Any]) -> str | None:
        """Why `group` holds no rows, when the metric knows (None: nothing measured)."""
        return next((why for g, why in self.empty if g.items() <= group.items()), None)

    def complete(self, rows: pd.DataFrame, columns: Iterable[str] | None = None) -> pd.DataFrame:
        """`rows` of this table with its lazy columns added (those of `columns`, or all)."""
        wanted = set(self.lazy if columns is None else columns) & set(self.lazy)
        if self.fill is None or not wanted or wanted <= set(rows.columns):
            return rows
        return self.fill(rows)


@dataclass
class Measurement:
    """What a metric measured: tables by scope name, plus block-level detail for the report."""

    tables: dict[str, Table]
    not_applicable: str | None = None  # why nothing could be measured (input absent)
    detail: dict[str, Any] = field(default_factory=dict)
    # the raw positions behind offending units (e.g. a failing scene's tie points), on demand
    unit_points: Callable[[list[str]], dict[str, Any]] | None = None


class NoParams(BaseModel):
    model_config = {"extra": "forbid"}


Measure = Callable[[str, Mapping[str, Any]], Measurement]
MetricFunc = Callable[[Delivery, Any, Measure], Measurement]
#: the tie_points columns a metric reads: a fixed list, one computed from its parameters, or
#: None for every column of the table
TiePointColumns = tuple[str, ...] | Callable[[Any], Iterable[str]] | None


@dataclass(frozen=True)
class Scope:
    """What a metric offers at one scope: statistics (with units), groups, keys, other columns.

    A rule names a statistic; `where` and `evidence_where` may filter on any column; a rule's
    `thresholds:` give one threshold per value of a group column.
    """

    statistics: Mapping[str, str]  # statistic -> unit ("" when it has none)
    groups: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # column -> its values
    keys: tuple[str, ...] = ()  # what identifies a unit (scene, pair, point) inside a group
    columns: tuple[str, ...] = ()  # further columns of the table (some only when input has them)
    # the delivery table whose rows hold the keys (the units a waiver names are checked in it)
    table: str = ""
    # further columns whose values are fixed (a scene's band): `where` is checked against them
    values: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    # group columns whose values are contents of their own (checkpoint plane and height
    # accuracy, DOMAIN §2): a rule gives each value judged its own content
    apart: tuple[str, ...] = ()
    # statistics that may be below 0 (a signed error, a bias); every other number is never
    # negative (magnitudes, their RMS and medians, counts, shares), checked against its bounds
    signed: tuple[str, ...] = ()
    # statistic -> the column holding what its results say beside the value (their detail's
    # `note`); the results of the other statistics leave that column out
    notes: Mapping[str, str] = field(default_factory=dict)

    def values_of(self, column: str) -> tuple[str, ...]:
        """The values a column takes, when they are fixed (a group's, a band's); else ()."""
        return tuple(self.groups.get(column) or self.values.get(column) or ())

    def all_columns(self) -> tuple[str, ...]:
        """Every column the scope's table may carry."""
        names = [*self.groups, *self.keys, *self.statistics, *self.columns]
        return tuple(dict.fromkeys(names))


@dataclass(frozen=True)
class MetricSpec:
    name: str
    func: MetricFunc
    params: type[BaseModel]
    scopes: Mapping[str, Scope]  # scope name -> what it offers
    description: str
    param_units: Mapping[str, str] = field(default_factory=dict)  # parameter -> unit
    tie_points: TiePointColumns = None
    # measured on the blocks sampled for detailed inspection (checkpoints, DOMAIN §2): a rule
    # over it that does not say `inspection:` is of the detailed inspection
    detailed: bool = False

    def tie_point_columns(self, params: BaseModel | None) -> set[str] | None:
        """The tie_points columns this metric reads with these parameters (None: all)."""
        if self.tie_points is None:
            return None
        cols = self.tie_points(params) if callable(self.tie_points) else self.tie_points
        return None if cols is None else set(cols)


REGISTRY: dict[str, MetricSpec] = {}


def metric(
    name: str,
    *,
    params: type[BaseModel] = NoParams,
    scopes: Mapping[str, Scope],
    param_units: Mapping[str, str] | None = None,
    tie_points: TiePointColumns = None,
    detailed: bool = False,
) -> Callable[[MetricFunc], MetricFunc]:
    """Register a measurement under `name`, declaring its parameters, the scopes it offers,
    the tie_points columns it reads (None: every column; `()` for a metric that reads none)
    and whether it measures the sampled blocks' checkpoints (`detailed`)."""

    def register(func: MetricFunc) -> MetricFunc:
        doc = (func.__doc__ or "").strip().splitlines()
        unknown = set(param_units or {}) - set(params.model_fields)
        if unknown:
            raise TypeError(f"metric {name}: units for unknown parameters {sorted(unknown)}")
        REGISTRY[name] = MetricSpec(
            name,
            func,
            params,
            dict(scopes),
            doc[0] if doc else "",
            dict(param_units or {}),
            tie_points,
            detailed,
        )
        return func

    return register


#: why a checkpoint metric measures nothing on a block without checkpoints (the reports'
#: catalogue translates it: `ph_no_cps_not_sampled`)
NO_CHECKPOINTS = "no checkpoints: the block was not sampled for detailed inspection"


def not_applicable(reason: str) -> Measurement:
    return Measurement(tables={}, not_applicable=reason)


def _load_all() -> None:
    # importing the families registers their metrics
    from blockqc.metrics import (  # noqa: F401
        asprs,
        checkpoints,
        discrepancies,
        documents,
        geometry,
        reported,
        spatial_ref,
        tiepoints,
    )


_load_all()
