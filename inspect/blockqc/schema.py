"""Contract v1: the typed schemas of a delivery's tables and their vectorized validation."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd
import shapely

from blockqc.errors import Problem

Kind = Literal["str", "float", "int", "date", "enum", "wkt"]

#: how many offending rows of one column and one kind of problem are listed one by one
MAX_ROWS_LISTED = 5


@dataclass(frozen=True)
class Column:
    """One column of a table: its type, whether it must be there and filled, and its range."""

    name: str
    kind: Kind
    required: bool = True
    nullable: bool = False
    min: float | None = None
    max: float | None = None
    choices: tuple[str, ...] = ()


@dataclass(frozen=True)
class Reference:
    """A column whose values must be keys of another table (e.g. a tie point's `scene_id`)."""

    column: str
    table: str
    key: str


@dataclass(frozen=True)
class TableSchema:
    name: str
    columns: tuple[Column, ...]
    unique: tuple[str, ...] = ()
    references: tuple[Reference, ...] = field(default_factory=tuple)
    required: bool = False

    def column(self, name: str) -> Column:
        return next(c for c in self.columns if c.name == name)


METHODS = ("high_precision", "same_accuracy", "recalculation")

SCENES = TableSchema(
    "scenes",
    (
        Column("scene_id", "str"),
        Column("band", "enum", choices=("pan", "ms")),
        Column("acquired", "date"),
        Column("lines", "int", min=1),
        Column("samples", "int", min=1),
        Column("footprint_wkt", "wkt"),
        Column("water_fraction", "float", required=False, nullable=True, min=0.0, max=1.0),
    ),
    unique=("scene_id",),
    required=True,
)

TIE_POINTS = TableSchema(
    "tie_points",
    (
        Column("point_id", "str"),
        Column("scene_id", "str"),
        Column("line", "float"),
        Column("sample", "float"),
        # contract v1.1: the residuals may be absent when the delivery gives its geometry
        # (blockqc.geometry_inputs checks that); lon/lat/h is the producer's ground point
        Column("v_line", "float", required=False),
        Column("v_sample", "float", required=False),
        Column("lon", "float", required=False, nullable=True, min=-180.0, max=180.0),
        Column("lat", "float", required=False, nullable=True, min=-90.0, max=90.0),
        Column("h", "float", required=False, nullable=True),
    ),
    unique=("point_id", "scene_id"),
    references=(Reference("scene_id", "scenes", "scene_id"),),
    required=True,
)

PAN_MS = TableSchema(
    "pan_ms",
    (
        Column("pan_scene_id", "str"),
        Column("ms_scene_id", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float"),
        Column("dy_m", "float"),
    ),
    unique=("pan_scene_id", "ms_scene_id", "point_id"),
    references=(
        Reference("pan_scene_id", "scenes", "scene_id"),
        Reference("ms_scene_id", "scenes", "scene_id"),
    ),
)

OVERLAPS = TableSchema(
    "overlaps",
    (
        Column("scene_a", "str"),
        Column("scene_b", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float"),
        Column("dy_m", "float"),
        Column("dz_m", "float", required=False, nullable=True),
    ),
    unique=("scene_a", "scene_b", "point_id"),
    references=(
        Reference("scene_a", "scenes", "scene_id"),
        Reference("scene_b", "scenes", "scene_id"),
    ),
)

EDGES = TableSchema(
    "edges",
    (
        Column("neighbour_block", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float"),
        Column("dy_m", "float"),
        Column("dz_m", "float", required=False, nullable=True),
    ),
    unique=("neighbour_block", "point_id"),
)

CHECKPOINTS = TableSchema(
    "checkpoints",
    (
        Column("point_id", "str"),
        Column("method", "enum", choices=METHODS),
        Column("reference_id", "str"),
        Column("x_m", "float"),
        Column("y_m", "float"),
        Column("z_m", "float", nullable=True),
        # Extension of contract v1: ref_x_m/ref_y_m may be empty for height-only references
        # (e.g. laser altimetry); such a row checks the height component only.
        Column("ref_x_m", "float", nullable=True),
        Column("ref_y_m", "float", nullable=True),
        Column("ref_z_m", "float", nullable=True),
    ),
    unique=("point_id", "method"),
)

# contract v1.1: the producer's adjustment per scene (blockqc.geometry_inputs gives its form)
ADJUSTMENT = TableSchema(
    "adjustment",
    (
        Column("scene_id", "str"),
        *(Column(k, "float") for k in ("a0", "a1", "a2", "b0", "b1", "b2")),
    ),
    unique=("scene_id",),
    references=(Reference("scene_id", "scenes", "scene_id"),),
)

TABLES: dict[str, TableSchema] = {
    t.name: t for t in (SCENES, TIE_POINTS, PAN_MS, OVERLAPS, EDGES, CHECKPOINTS, ADJUSTMENT)
}


def _rows(mask: np.ndarray) -> np.ndarray:
    return np.flatnonzero(mask)


def report_rows(
    problems: list[Problem],
    file: str,
    column: str | None,
    mask: np.ndarray,
    message: str,
    values: pd.Series | None,
    csv: bool,
) -> None:
    """Add one problem per offending row (the first few) and a count of the rest."""
    rows = _rows(mask)
    for i in rows[:MAX_ROWS_LISTED]:
        got = f", got {_show(values.iloc[i])}" if values is not None else ""
        problems.append(
            Problem(
                file,
                f"{message}{got}",
                row=int(i) + 1,
                line=int(i) + 2 if csv else None,
                column=column,
            )
        )
    if len(rows) > MAX_ROWS_LISTED:
        problems.append(
            Problem(
                file, f"{message}: {len(rows) - MAX_ROWS_LISTED} more rows like this", column=column
            )
        )


def _show(value: object) -> str:
    if isinstance(value, str):
        return repr(value if len(value) <= 80 else value[:77] + "...")
    return str(value.item() if hasattr(value, "item") else value)


def _blank(s: pd.Series) -> np.ndarray:
    """Cells that are missing or hold only white space."""
    if pd.api.types.is_numeric_dtype(s.dtype) or pd.api.types.is_datetime64_any_dtype(s.dtype):
        return s.isna().to_numpy()
    return (s.isna() | (s.astype("string").str.strip() == "")).to_numpy(dtype=bool)


def validate_table(
    df: pd.DataFrame, schema: TableSchema, file: str, csv: bool = True
) -> tuple[pd.DataFrame, list[Problem]]:
    """Check and convert a raw table (strings or typed) column by column; list every problem."""
    problems: list[Problem] = []
    df = df.rename(columns=lambda c: str(c).strip())
    out: dict[str, pd.Series] = {}
    for col in schema.columns:
        if col.name not in df.columns:
            if col.required:
                problems.append(
                    Problem(
                        file,
                        f"missing column '{col.name}' (expected a {col.kind} column; "
                        f"columns found: {', '.join(map(str, df.columns))})",
                    )
                )
            continue
        raw = df[col.name]
        blank = _blank(raw)
        if not col.nullable:
            report_rows(
                problems, file, col.name, blank, "empty value where one is required", None, csv
            )
        conv, bad = _convert(raw, col, blank)
        if bad is not None:
            report_rows(problems, file, col.name, bad, _expected(col), raw, csv)
        ok = ~blank & (~bad if bad is not None else True)
        if col.kind in ("float", "int"):
            vals = conv.to_numpy(dtype=float, na_value=np.nan)
            if col.min is not None:
                report_rows(
                    problems,
                    file,
                    col.name,
                    ok & (vals < col.min),
                    f"value below the allowed minimum {col.min:g}",
                    raw,
                    csv,
                )
            if col.max is not None:
                report_rows(
                    problems,
                    file,
                    col.name,
                    ok & (vals > col.max),
                    f"value above the allowed maximum {col.max:g}",
                    raw,
                    csv,
                )
            if col.kind == "float":
                report_rows(
                    problems,
                    file,
                    col.name,
                    ok & ~np.isfinite(np.nan_to_num(vals, nan=0.0)),
                    "value is not finite",
                    raw,
                    csv,
                )
        out[col.name] = conv
    extra = [c for c in df.columns if c not in out and c not in {x.name for x in schema.columns}]
    for c in extra:  # extra columns are kept, untouched
        out[c] = df[c]
    table = pd.DataFrame(out, index=pd.RangeIndex(len(df)))
    bad_keys = any(p.column in schema.unique for p in problems)
    if schema.unique and not bad_keys and all(k in table.columns for k in schema.unique):
        dup = table.duplicated(list(schema.unique), keep=False).to_numpy()
        if dup.any():
            key = ", ".join(schema.unique)
            report_rows(
                problems,
                file,
                schema.unique[0] if len(schema.unique) == 1 else None,
                dup,
                f"duplicated key ({key})",
                table[list(schema.unique)].astype(str).agg("/".join, axis=1),
                csv,
            )
    return table, problems


def _expected(col: Column) -> str:
    return {
        "str": "expected text",
        "float": "expected a number",
        "int": "expected a whole number",
        "date": "expected an ISO date (YYYY-MM-DD)",
        "enum": f"expected one of {', '.join(col.choices)}",
        "wkt": "expected a WKT polygon in lon/lat degrees",
    }[col.kind]


def _convert(raw: pd.Series, col: Column, blank: np.ndarray) -> tuple[pd.Series, np.ndarray | None]:
    """Convert one column to its kind; return the converted series and the unconvertible cells."""
    if col.kind == "str":
        s = raw.astype("string").str.strip()
        return s.astype(object).where(~blank, None), None
    if col.kind == "enum":
        s = raw.astype("string").str.strip().str.lower()
        bad = ~blank & ~s.isin(col.choices).to_numpy(dtype=bool)
        return s.astype(object).where(~blank, None), bad
    if col.kind in ("float", "int"):
        if pd.api.types.is_numeric_dtype(raw.dtype) and not pd.api.types.is_bool_dtype(raw.dtype):
            num = raw.astype(float)
        else:
            num = pd.to_numeric(raw.astype("string").str.strip(), errors="coerce").astype(float)
        bad = ~blank & num.isna().to_numpy()
        if col.kind == "int":
            v = num.to_numpy()
            frac = ~blank & ~bad & (np.nan_to_num(v) != np.round(np.nan_to_num(v)))
            bad = bad | frac
            return num.round().astype("Int64"), bad
        return num, bad
    if col.kind == "date":
        if pd.api.types.is_datetime64_any_dtype(raw.dtype):
            return raw, None
        d = pd.to_datetime(raw.astype("string").str.strip(), errors="coerce", format="ISO8601")
        return d, ~blank & d.isna().to_numpy()
    if col.kind == "wkt":
        text = raw.astype("string").str.strip().fillna("").to_numpy(dtype=object)
        geoms = shapely.from_wkt(text, on_invalid="ignore")
        poly = shapely.get_type_id(geoms) == 3  # Polygon
        bad = ~blank & ~poly
        bounds = shapely.bounds(geoms)
        inside = (
            (bounds[:, 0] >= -180)
            & (bounds[:, 2] <= 180)
            & (bounds[:, 1] >= -90)
            & (bounds[:, 3] <= 90)
        )
        bad = bad | (~blank & poly & ~np.nan_to_num(inside, nan=0).astype(bool))
        return pd.Series(raw.astype("string").str.strip().astype(object), index=raw.index), bad
    raise AssertionError(col.kind)
