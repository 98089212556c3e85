"""The hand-computable base delivery rule cases change, and the edits a case may make.

The base block passes every automatic rule of the stock pack, with figures one can check by
hand: 4 PAN scenes of 1000×1000 px, each with an 11×11 grid of tie points whose errors are all
exactly 0.3 px; PAN–MS discrepancies √2 m; overlap and edge discrepancies 5 m plane, 2 m height;
27 high-precision checkpoints on 9 reference images with plane Δ = 5 m and height Δ = 2 m.
Its block id is CASE.

A case changes it with explicit edits (no expression is evaluated):
  manifest: {...}                        deep-merged into block.yaml
  set:    {table: [{where, any, values: {column: value}}]}        values written
  derive: {table: [{where, any, column: c, from: d, add: a, times: t}]}   c = d·t + a
  drop:   {table: [{where, any, keep_first: N}]}                  rows removed (N kept)
  append: {table: [{...row...}]}
  remove_tables: [name]
  files:  {relative/path: "text" | null}  written or deleted inside the delivery
A row is selected when every `where` condition holds and, if `any` is given, one of its
mappings does; a condition is a value (equality) or {eq|ne|lt|le|gt|ge: value, in: [values]}.
An edit that would change nothing (a selection of no row, a drop keeping every row selected, a
column the table does not have) is refused (EditError).
"""

from __future__ import annotations

import copy
import difflib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from blockqc.schema import TABLES
from blockqc.simulate import DOCUMENTS, minimal_pdf

LON0, LAT0, SIZE = 116.30, 39.90, 0.02  # Beijing area: UTM zone 50N (EPSG:32650)


def _footprint(i: int, j: int) -> str:
    x0, y1 = LON0 + j * SIZE * 0.8, LAT0 - i * SIZE * 0.8
    x1, y0 = x0 + SIZE, y1 - SIZE
    return f"POLYGON(({x0} {y1}, {x1} {y1}, {x1} {y0}, {x0} {y0}, {x0} {y1}))"


def _scenes() -> pd.DataFrame:
    """4 PAN scenes of 1000×1000 px on a 2×2 layout and one MS scene over S1."""
    return pd.DataFrame(
        {
            "scene_id": ["S1", "S2", "S3", "S4", "M1"],
            "band": ["pan"] * 4 + ["ms"],
            "acquired": ["2022-05-01", "2022-05-01", "2022-06-10", "2022-06-10", "2022-05-01"],
            "lines": [1000] * 4 + [250],
            "samples": [1000] * 4 + [250],
            "footprint_wkt": [
                _footprint(i, j) for i, j in ((0, 0), (0, 1), (1, 0), (1, 1), (0, 0))
            ],
            "water_fraction": [0.0] * 5,
        }
    )


def _tie_points() -> pd.DataFrame:
    """An 11×11 grid of observations per PAN scene, each with an error of exactly 0.3 px."""
    grid = 45.0 + 91.0 * np.arange(11)
    line, sample = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))
    k = np.arange(121)
    theta = k * 0.7
    parts = [
        pd.DataFrame(
            {
                "point_id": [f"P{s}-{i:03d}" for i in k],
                "scene_id": s,
                "line": line,
                "sample": sample,
                "v_line": 0.3 * np.cos(theta),
                "v_sample": 0.3 * np.sin(theta),
            }
        )
        for s in ("S1", "S2", "S3", "S4")
    ]
    return pd.concat(parts, ignore_index=True)


def _discrepancies(unit: dict[str, str], prefix: str, dz: bool = True) -> pd.DataFrame:
    """5 points of one unit: dx 3 m, dy 4 m (plane 5 m), dz 2 m — or dx = dy = 1 m (√2 m)."""
    values = {"dx_m": 3.0, "dy_m": 4.0, "dz_m": 2.0} if dz else {"dx_m": 1.0, "dy_m": 1.0}
    return pd.DataFrame({**unit, "point_id": [f"{prefix}{i}" for i in range(5)], **values})


def _checkpoints(n: int = 27) -> pd.DataFrame:
    """n high-precision checkpoints, 3 per reference image, plane Δ 5 m and height Δ 2 m."""
    x = 440000.0 + 100.0 * np.arange(n)
    y = 4410000.0 + 50.0 * np.arange(n)
    z = 50.0 + np.arange(n, dtype=float)
    return pd.DataFrame(
        {
            "point_id": [f"C{i:02d}" for i in range(n)],
            "method": "high_precision",
            "reference_id": [f"WV{i // 3 + 1}" for i in range(n)],
            "x_m": x,
            "y_m": y,
            "z_m": z,
            "ref_x_m": x - 3.0,
            "ref_y_m": y - 4.0,
            "ref_z_m": z - 2.0,
        }
    )


def base_tables() -> dict[str, pd.DataFrame]:
    """The base delivery's tables (it passes every automatic rule of the stock pack)."""
    return {
        "scenes": _scenes(),
        "tie_points": _tie_points(),
        "pan_ms": _discrepancies({"pan_scene_id": "S1", "ms_scene_id": "M1"}, "R", dz=False),
        "overlaps": _discrepancies({"scene_a": "S1", "scene_b": "S2"}, "O"),
        "edges": _discrepancies({"neighbour_block": "B2"}, "E"),
        "checkpoints": _checkpoints(),
    }


def base_manifest() -> dict[str, Any]:
    return {
        "block_id": "CASE",
        "sensor": "GF-7",
        "gsd_m": {"pan": 1.0, "ms": 4.0},
        "spatial_reference": {
            "geodetic_datum": "WGS84",
            "height_datum": "ellipsoidal",
            "projection": "UTM",
            "epsg": 32650,
        },
        "documents": dict(DOCUMENTS),
        "reported": {},
    }


def _merge(a: dict, b: dict) -> dict:
    out = copy.deepcopy(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


class EditError(ValueError):
    """An edit that names an unknown table or column, or is malformed."""


_OPS = {
    "eq": lambda s, v: s == v,
    "ne": lambda s, v: s != v,
    "lt": lambda s, v: s < v,
    "le": lambda s, v: s <= v,
    "gt": lambda s, v: s > v,
    "ge": lambda s, v: s >= v,
    "in": lambda s, v: s.isin(v if isinstance(v, list) else [v]),
}


def _column(df: pd.DataFrame, col: str, table: str) -> pd.Series:
    if col not in df.columns:
        raise EditError(f"{table} has no column '{col}' (columns: {', '.join(df.columns)})")
    return df[col]


def _condition(df: pd.DataFrame, cond: dict[str, Any], table: str) -> np.ndarray:
    """Rows meeting every condition of a mapping column -> value | {op: value}."""
    m = np.ones(len(df), dtype=bool)
    for col, test in cond.items():
        s = _column(df, col, table)
        ops = test if isinstance(test, dict) else {"eq": test}
        for op, val in ops.items():
            if op not in _OPS:
                raise EditError(f"unknown comparison '{op}' (use {', '.join(_OPS)})")
            try:
                m &= np.asarray(_OPS[op](s, val), dtype=bool)
            except TypeError as exc:
                raise EditError(f"cannot compare {table}.{col} with {val!r}: {exc}") from None
    return m


def select(df: pd.DataFrame, op: dict[str, Any], table: str) -> np.ndarray:
    """The rows an edit applies to: its `where` and one of its `any` mappings."""
    m = _condition(df, op.get("where") or {}, table)
    alternatives = op.get("any") or []
    if alternatives:
        m &= np.logical_or.reduce([_condition(df, a, table) for a in alternatives])
    return m


def _table(tables: dict[str, pd.DataFrame], name: str) -> pd.DataFrame:
    if name not in tables:
        raise EditError(f"no table '{name}' (tables: {', '.join(tables)})")
    return tables[name]


def _selected(df: pd.DataFrame, op: dict[str, Any], edit: str, table: str) -> np.ndarray:
    """The rows an edit selects; EditError when its where/any selects none, since the edit
    would then change nothing and its case judge the delivery unedited."""
    m = select(df, op, table)
    if (op.get("where") or op.get("any")) and not m.any():
        raise EditError(f"{edit} {table}: where/any matches no row")
    return m


def _writable(df: pd.DataFrame, col: str, edit: str, table: str) -> None:
    """A column an edit writes: one of the table's (or one the contract gives the table): a
    misspelt name would add a column the delivery's reader ignores."""
    known = [*df.columns, *(c.name for c in TABLES[table].columns if c.name not in df.columns)]
    if col not in known:
        hint = difflib.get_close_matches(col, known, n=1)
        mean = f" (did you mean {hint[0]}?)" if hint else ""
        raise EditError(f"{table} has no column '{col}'{mean} (columns: {', '.join(known)})")


def _write(df: pd.DataFrame, m: np.ndarray, col: str, value: Any, what: str) -> None:
    """Values written on the rows selected; EditError when the column cannot hold them (a
    number in a column of texts, a text in one of numbers)."""
    try:
        df.loc[m, col] = value
    except (TypeError, ValueError):
        kind = "numbers" if pd.api.types.is_numeric_dtype(df[col]) else "texts"
        if not pd.api.types.is_numeric_dtype(df[col]) and not pd.api.types.is_string_dtype(df[col]):
            kind = f"values of type {df[col].dtype.name}"
        raise EditError(
            f"{what}: column {col} holds {kind} (to give a table a value of another kind, "
            "write its file under files:)"
        ) from None


def _numbers(df: pd.DataFrame, col: str, table: str, target: str) -> np.ndarray:
    """The numbers of the column a `derive` reads; EditError for a column of texts."""
    src = _column(df, col, table)
    try:
        return src.to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise EditError(
            f"derive {table}.{target}: from: {col} holds texts ({src.iloc[0]!r} …), not "
            "numbers: derive from a number column"
        ) from None


def _edit_rows(tables: dict[str, pd.DataFrame], case: dict[str, Any]) -> None:
    for name, ops in (case.get("set") or {}).items():
        df = _table(tables, name)
        for op in ops:
            m = _selected(df, op, "set", name)
            for col, val in op["values"].items():
                _writable(df, col, "set", name)
                _write(df, m, col, val, f"set {name}.{col}: cannot write {val!r}")
    for name, ops in (case.get("derive") or {}).items():
        df = _table(tables, name)
        for op in ops:
            m = _selected(df, op, "derive", name)
            _writable(df, op["column"], "derive", name)
            src = _numbers(df, op["from"], name, op["column"])
            value = src * float(op.get("times", 1.0)) + float(op.get("add", 0.0))
            col = op["column"]
            _write(df, m, col, value[m], f"derive {name}.{col}: cannot write numbers")
    for name, ops in (case.get("drop") or {}).items():
        df = _table(tables, name)
        for op in ops:
            m = _selected(df, op, "drop", name)
            keep = op.get("keep_first")
            if keep is not None and keep >= np.count_nonzero(m):
                raise EditError(
                    f"drop {name}: keep_first {keep} keeps every one of the "
                    f"{np.count_nonzero(m)} rows selected: nothing is removed"
                )
            if keep is not None:
                m[np.flatnonzero(m)[:keep]] = False
            df = df[~m]
        tables[name] = df.reset_index(drop=True)


def _appended(tables: dict[str, pd.DataFrame], name: str, rows: list[dict]) -> pd.DataFrame:
    """The table with the rows added, each naming columns of the table."""
    df = _table(tables, name)
    for row in rows:
        for col in row:
            _writable(df, col, "append", name)
    return pd.concat([df, pd.DataFrame(rows)], ignore_index=True)


def edited_tables(case: dict[str, Any]) -> dict[str, pd.DataFrame]:
    """The base tables changed by a case's row edits, appended rows and removed tables."""
    tables = base_tables()
    _edit_rows(tables, case)
    for name, rows in (case.get("append") or {}).items():
        tables[name] = _appended(tables, name, rows)
    for name in case.get("remove_tables") or []:
        _table(tables, name)
        tables.pop(name)
    return tables


def inside(folder: Path, rel: str) -> Path:
    """`folder / rel`, refused (EditError) when it leads outside the folder."""
    path = (folder / rel).resolve()
    if folder.resolve() not in path.parents:
        raise EditError(f"files: '{rel}' is outside the delivery")
    return path


def write_delivery(folder: Path, case: dict[str, Any] | None = None) -> Path:
    """Write the base delivery changed by a case's edits into `folder`."""
    case = case or {}
    tables = edited_tables(case)
    folder.mkdir(parents=True, exist_ok=True)
    for name, df in tables.items():
        df.to_csv(folder / f"{name}.csv", index=False)
    manifest = _merge(base_manifest(), case.get("manifest") or {})
    (folder / "block.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False), "utf-8")
    for rel in DOCUMENTS.values():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(minimal_pdf(["test document"]))
    for rel, content in (case.get("files") or {}).items():
        path = inside(folder, rel)
        if content is None:
            path.unlink(missing_ok=True)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(content, "utf-8")
    return folder
