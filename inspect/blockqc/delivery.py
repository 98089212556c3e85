"""Reading a delivery (contract v1) into typed tables; a delivery is never written to."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, ValidationError, model_validator

from blockqc.errors import InputError, Problem
from blockqc.geometry_inputs import BlockGeometry, load_geometry, residual_column_problems
from blockqc.schema import TABLES, TableSchema, report_rows, validate_table
from blockqc.yamlio import load_yaml, pydantic_problems

MANIFEST = "block.yaml"


class GSD(BaseModel):
    model_config = ConfigDict(extra="forbid")
    pan: PositiveFloat | None = None
    ms: PositiveFloat | None = None

    @model_validator(mode="after")
    def _one(self) -> GSD:
        if self.pan is None and self.ms is None:
            raise ValueError("give the GSD of at least one band (pan, ms)")
        return self


class SpatialReference(BaseModel):
    model_config = ConfigDict(extra="allow")
    geodetic_datum: str | None = None
    height_datum: str | None = None
    projection: str | None = None
    epsg: int | None = None


class Manifest(BaseModel):
    """block.yaml: the block's identity, GSDs, spatial reference, documents, reported figures."""

    model_config = ConfigDict(extra="allow")
    block_id: str = Field(min_length=1)
    sensor: str | None = None
    gsd_m: GSD
    spatial_reference: SpatialReference | None = None
    documents: dict[str, str] = Field(default_factory=dict)
    reported: dict[str, float] = Field(default_factory=dict)


@dataclass
class Delivery:
    """One block's delivery, read and validated: the manifest and its tables as DataFrames."""

    path: Path
    manifest: Manifest
    scenes: pd.DataFrame
    tie_points: pd.DataFrame
    pan_ms: pd.DataFrame | None = None
    overlaps: pd.DataFrame | None = None
    edges: pd.DataFrame | None = None
    checkpoints: pd.DataFrame | None = None
    files: dict[str, Path] = field(default_factory=dict)
    # contract v1.1: the producer's adjustment table, the geometry read from rpc/ (and
    # rpc_adjusted/), and what blockqc computed from it (blockqc.verification)
    adjustment: pd.DataFrame | None = None
    geometry: BlockGeometry | None = None
    process_data: dict[str, Any] = field(default_factory=dict)

    @property
    def block_id(self) -> str:
        return self.manifest.block_id


def is_delivery(path: Path) -> bool:
    return (path / MANIFEST).is_file()


def find_deliveries(path: Path) -> list[Path]:
    """A delivery folder gives itself; a batch folder gives its delivery sub-folders, sorted."""
    path = Path(path)
    if not path.exists():
        raise InputError(Problem(str(path), "no such file or folder"))
    if not path.is_dir():
        raise InputError(
            Problem(
                str(path),
                "expected a delivery folder (with block.yaml) or a batch folder of deliveries",
            )
        )
    if is_delivery(path):
        return [path]
    found = sorted(p for p in path.iterdir() if p.is_dir() and is_delivery(p))
    if not found:
        raise InputError(
            Problem(
                str(path),
                f"neither a delivery (no {MANIFEST}) nor a batch "
                f"(no sub-folder holds a {MANIFEST})",
            )
        )
    return found


def _table_file(folder: Path, name: str) -> Path | None:
    csv, parquet = folder / f"{name}.csv", folder / f"{name}.parquet"
    if csv.is_file() and parquet.is_file():
        raise InputError(
            Problem(
                str(folder), f"both {csv.name} and {parquet.name} are present; give the table once"
            )
        )
    return csv if csv.is_file() else parquet if parquet.is_file() else None


def _read_csv(path: Path, schema: TableSchema) -> pd.DataFrame:
    """Read a CSV fast with pyarrow; text-like columns stay text (ids keep leading zeros)."""
    text_cols = {
        c.name: pa.string() for c in schema.columns if c.kind in ("str", "enum", "date", "wkt")
    }
    try:
        table = pacsv.read_csv(
            path,
            read_options=pacsv.ReadOptions(use_threads=True),
            convert_options=pacsv.ConvertOptions(
                column_types=text_cols,
                strings_can_be_null=False,
                null_values=["", "NA", "NaN", "nan", "null"],
            ),
        )
    except pa.ArrowInvalid as exc:
        return _read_csv_slow(path, str(exc))
    if table.num_columns and table.num_rows == 0 and len(table.column_names) == 0:
        raise InputError(Problem(str(path), "the file is empty: expected a header row"))
    return table.to_pandas(types_mapper=None)


def _read_csv_slow(path: Path, reason: str) -> pd.DataFrame:
    """Fallback reader whose errors carry the line number of a malformed row."""
    try:
        return pd.read_csv(
            path, dtype=str, keep_default_na=False, skipinitialspace=True, encoding="utf-8-sig"
        )
    except pd.errors.EmptyDataError:
        raise InputError(Problem(str(path), "the file is empty: expected a header row")) from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(Problem(str(path), f"not a readable CSV table: {exc}")) from None
    except Exception:  # pragma: no cover - report the original reader's reason
        raise InputError(Problem(str(path), f"not a readable CSV table: {reason}")) from None


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        return pq.read_table(path).to_pandas()
    except (pa.ArrowException, OSError) as exc:
        raise InputError(Problem(str(path), f"not a readable Parquet table: {exc}")) from None


def read_table(path: Path, schema: TableSchema) -> tuple[pd.DataFrame, list[Problem]]:
    """Read and validate one table file (CSV or Parquet) against its schema."""
    csv = path.suffix.lower() == ".csv"
    raw = _read_csv(path, schema) if csv else _read_parquet(path)
    return validate_table(raw, schema, str(path), csv=csv)


def load_manifest(path: Path) -> Manifest:
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping of keys (block_id, gsd_m, ...)", line=1)
        )
    try:
        return Manifest.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data)) from None


def load_delivery(path: Path) -> Delivery:
    """Read a delivery folder; raise InputError listing every problem found (file, row, column)."""
    path = Path(path)
    problems: list[Problem] = []
    manifest: Manifest | None = None
    try:
        manifest = load_manifest(path / MANIFEST)
    except InputError as exc:
        problems.extend(exc.problems)

    tables: dict[str, pd.DataFrame] = {}
    files: dict[str, Path] = {}
    for name, schema in TABLES.items():
        try:
            f = _table_file(path, name)
            if f is None:
                if schema.required:
                    problems.append(
                        Problem(
                            str(path / f"{name}.csv"),
                            f"required table {name} is missing (expected "
                            f"{name}.csv or {name}.parquet)",
                        )
                    )
                continue
            files[name] = f
            df, found = read_table(f, schema)
        except InputError as exc:
            problems.extend(exc.problems)
            continue
        problems.extend(found)
        tables[name] = df

    problems.extend(_check_references(tables, files))
    geometry, found = load_geometry(path, tables, files)  # contract v1.1
    problems.extend(found)
    problems.extend(
        residual_column_problems(tables.get("tie_points"), files.get("tie_points"), geometry)
    )
    if problems:
        raise InputError(problems)
    assert manifest is not None
    return Delivery(path=path, manifest=manifest, files=files, geometry=geometry, **tables)


def _check_references(tables: dict[str, pd.DataFrame], files: dict[str, Path]) -> list[Problem]:
    """Every reference between tables must resolve (e.g. a tie point's scene_id is a scene)."""
    problems: list[Problem] = []
    for name, df in tables.items():
        for ref in TABLES[name].references:
            target = tables.get(ref.table)
            if target is None or ref.column not in df.columns or ref.key not in target.columns:
                continue
            missing = ~df[ref.column].isin(target[ref.key]).to_numpy(dtype=bool)
            f = files[name]
            report_rows(
                problems,
                str(f),
                ref.column,
                missing,
                f"unknown {ref.key} (not in {files[ref.table].name})",
                df[ref.column],
                f.suffix == ".csv",
            )
    return problems


def summary(d: Delivery) -> dict[str, Any]:
    """Counts for messages and reports."""
    return {
        "scenes": len(d.scenes),
        "tie_point_observations": len(d.tie_points),
        "tie_points": int(d.tie_points["point_id"].nunique()),
        "checkpoints": 0 if d.checkpoints is None else int(d.checkpoints["point_id"].nunique()),
    }
