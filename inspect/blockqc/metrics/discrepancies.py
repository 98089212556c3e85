"""Relative-orientation discrepancies: PAN–MS, adjacent images, adjacent blocks (§RO-1..3)."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from blockqc.delivery import Delivery
from blockqc.metrics import (
    Measure,
    Measurement,
    NoParams,
    Scope,
    Table,
    metric,
    not_applicable,
)
from blockqc.verification import DERIVED_OVERLAPS

COMPONENTS = ("plane", "height")
#: the component of a discrepancy table's rows, a code each (no text repeated per row)
COMPONENT = pd.CategoricalDtype(list(COMPONENTS))
_STATS = {"n": "points", "rms_m": "m", "max_m": "m", "mean_m": "m"}


def plane_discrepancy(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """√(dx² + dy²) (§RO)."""
    return np.hypot(dx, dy)


def _long(df: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """One row per point and component: plane √(dx²+dy²), height |dz| where dz is given."""
    dx, dy = df["dx_m"].to_numpy(), df["dy_m"].to_numpy()
    plane = _beside(
        df[keys],
        component=_component("plane", len(df)),
        value_m=plane_discrepancy(dx, dy),
        dx_m=dx,
        dy_m=dy,
    )
    parts = [plane]
    if "dz_m" in df.columns:
        has = df["dz_m"].notna().to_numpy()
        dz = df.loc[has, "dz_m"].to_numpy()
        height = _beside(
            df.loc[has, keys],
            component=_component("height", int(has.sum())),
            value_m=np.abs(dz),
            dz_m=dz,
        )
        parts.append(height)
    return pd.concat(parts, ignore_index=True)


def _beside(keys: pd.DataFrame, **columns: Any) -> pd.DataFrame:
    """The key columns with the columns given after them, neither copied (assign copies each
    array: three of the rows of the 8.2 M derived overlaps, 196 MB)."""
    return pd.DataFrame({**{c: keys[c] for c in keys.columns}, **columns}, copy=False)


def _component(name: str, n: int) -> pd.Categorical:
    """The component `name` for n rows."""
    codes = np.full(n, COMPONENTS.index(name), dtype=np.int8)
    return pd.Categorical.from_codes(codes, dtype=COMPONENT)


def _agg(long: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    value = long["value_m"]
    columns = {**{c: long[c] for c in by}, "value_m": value, "v2": value.to_numpy() ** 2}
    g = pd.DataFrame(columns, copy=False).groupby(by, sort=False)  # (assign copies v2)
    return pd.DataFrame(
        {
            "n": g["value_m"].size(),
            "rms_m": np.sqrt(g["v2"].mean()),
            "max_m": g["value_m"].max(),
            "mean_m": g["value_m"].mean(),
        }
    ).reset_index()


def _measure(
    df: pd.DataFrame | None, unit: list[str], what: str, no_heights: str | None
) -> Measurement:
    """Per point, unit and component; `no_heights`: why the table gives no height (None: it
    gives some), said for the height groups."""
    if df is None or df.empty:
        return not_applicable(f"no {what} in the delivery")
    long = _long(df, unit + ["point_id"])
    groups = [{"component": c} for c in COMPONENTS]
    empty = (({"component": "height"}, no_heights),) if no_heights else ()
    by_component = partial(Table, group=["component"], groups=groups, empty=empty)
    return Measurement(
        tables={
            "point": by_component(long, keys=unit + ["point_id"], sort="value_m"),
            "pair": by_component(_agg(long, ["component"] + unit), keys=unit, sort="rms_m"),
            "component": by_component(_agg(long, ["component"])),
        }
    )


def _no_heights(df: pd.DataFrame | None, file: str) -> str | None:
    """Why a discrepancy table gives no height discrepancy (None: it gives some, or is none)."""
    if df is None:
        return None
    if "dz_m" not in df.columns:
        return f"{file}: {NO_DZ_COLUMN}"
    if df["dz_m"].isna().all():
        return f"{file}: {DZ_EMPTY}"
    return None


#: why the height group of a discrepancy table holds nothing (fixed phrases, translated)
NO_DZ_COLUMN = "no dz_m column, so no height discrepancies are given"
DZ_EMPTY = "dz_m empty in every row, so no height discrepancies are given"
PLANE_ONLY = "the discrepancies derived from the geometry are plane only (§RC-2)"


def _scopes(unit: tuple[str, ...], table: str) -> dict[str, Scope]:
    """Per point, per unit (pair of scenes or neighbour block) and per component."""
    groups = {"component": COMPONENTS}
    return {
        "point": Scope(
            {"value_m": "m"},
            groups=groups,
            keys=(*unit, "point_id"),
            columns=("dx_m", "dy_m", "dz_m"),
            table=table,
        ),
        "pair": Scope(_STATS, groups=groups, keys=unit, table=table),
        "component": Scope(_STATS, groups=groups),
    }


@metric("overlap_discrepancy", scopes=_scopes(("scene_a", "scene_b"), "overlaps"), tie_points=())
def overlap_discrepancy(d: Delivery, p: NoParams, measure: Measure) -> Measurement:
    """Discrepancies between adjacent overlapping images, per point and pair (§RO-3)."""
    notes = d.process_data.get("notes", {})
    if notes.get("overlaps") == DERIVED_OVERLAPS and d.overlaps is not None and d.overlaps.empty:
        if notes.get("n_points_not_intersected"):
            raise ValueError(
                "no adjacent-image discrepancy could be derived from the delivered geometry: "
                f"the rays of {notes['n_points_not_intersected']} tie points do not intersect "
                "(process_data.n_points_not_intersected)"
            )
        return not_applicable(
            "no overlaps table (overlaps.csv), and no tie point seen on two scenes to derive "
            "the adjacent-image discrepancies from"
        )
    derived = notes.get("overlaps") == DERIVED_OVERLAPS
    why = PLANE_ONLY if derived else _no_heights(d.overlaps, "overlaps.csv")
    return _measure(d.overlaps, ["scene_a", "scene_b"], "overlaps table (overlaps.csv)", why)


@metric("edge_discrepancy", scopes=_scopes(("neighbour_block",), "edges"), tie_points=())
def edge_discrepancy(d: Delivery, p: NoParams, measure: Measure) -> Measurement:
    """Discrepancies against adjacent blocks, per point and neighbour (§RO-2)."""
    why = _no_heights(d.edges, "edges.csv")
    return _measure(d.edges, ["neighbour_block"], "edges table (edges.csv)", why)


_PAN_MS = ("pan_scene_id", "ms_scene_id")


@metric(
    "pan_ms_discrepancy",
    tie_points=(),
    scopes={
        "point": Scope(
            {"value_m": "m"},
            keys=(*_PAN_MS, "point_id"),
            columns=("component", "dx_m", "dy_m"),
            table="pan_ms",
        ),
        "pair": Scope(_STATS, keys=_PAN_MS, table="pan_ms"),
        "block": Scope(_STATS),
    },
)
def pan_ms_discrepancy(d: Delivery, p: NoParams, measure: Measure) -> Measurement:
    """PAN–MS registration discrepancies, plane, per point, per scene pair and block (§RO-1)."""
    if d.pan_ms is None or d.pan_ms.empty:
        return not_applicable("no PAN–MS registration table (pan_ms.csv) in the delivery")
    unit = ["pan_scene_id", "ms_scene_id"]
    # plane only: a dz_m column (the overlaps' layout) is not the contract's, kept and ignored
    # as any extra column; its heights would otherwise be averaged in with the plane values
    long = _long(d.pan_ms.drop(columns="dz_m", errors="ignore"), unit + ["point_id"])
    return Measurement(
        tables={
            "point": Table(long, keys=unit + ["point_id"], sort="value_m"),
            "pair": Table(_agg(long, unit), keys=unit, sort="rms_m"),
            "block": Table(_agg(long.assign(all=0), ["all"]).drop(columns="all")),
        }
    )
