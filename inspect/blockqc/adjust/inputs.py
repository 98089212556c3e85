"""Reading what the adjustment needs from a delivery: contract v1 tables and the v1.1 geometry.

The v1 tables (block.yaml, scenes, tie_points) are read and validated with `blockqc.delivery`;
tie_points may lack `v_line`/`v_sample` when geometry is present (contract v1.1) and may carry
the producer's ground point `lon`, `lat`, `h`. The v1.1 parts read here: `rpc/<scene_id>.<ext>`
(one file per scene, any format `blockqc.rfm.readers.read_rpc` reads), and the producer's
adjustment, `adjustment.csv` (scene_id, a0, a1, a2, b0, b1, b2) or `rpc_adjusted/<scene_id>.<ext>`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from blockqc.delivery import MANIFEST, Manifest, load_manifest, read_table
from blockqc.errors import InputError, Problem
from blockqc.rfm.model import RPCModel
from blockqc.rfm.readers import read_rpc
from blockqc.schema import SCENES, TIE_POINTS, Column, TableSchema

AFFINE_KEYS = ("a0", "a1", "a2", "b0", "b1", "b2")

#: tie_points as contract v1.1 reads it: residuals optional, producer's height optional
TIE_POINTS_V11 = dataclasses.replace(
    TIE_POINTS,
    columns=tuple(
        dataclasses.replace(c, required=False, nullable=True)
        if c.name in ("v_line", "v_sample")
        else c
        for c in TIE_POINTS.columns
    )
    + (Column("h", "float", required=False, nullable=True),),
)

ADJUSTMENT = TableSchema(
    "adjustment",
    (Column("scene_id", "str"), *(Column(k, "float") for k in AFFINE_KEYS)),
    unique=("scene_id",),
)


@dataclass
class AdjustInput:
    """A delivery's block as the adjustment sees it."""

    path: Path
    manifest: Manifest
    scenes: pd.DataFrame
    tie_points: pd.DataFrame
    models: list[RPCModel]
    producer_affine: np.ndarray | None
    producer_models: list[RPCModel] | None
    producer_source: str


def _table(path: Path, schema: TableSchema) -> pd.DataFrame:
    csv, parquet = path / f"{schema.name}.csv", path / f"{schema.name}.parquet"
    f = csv if csv.is_file() else parquet if parquet.is_file() else None
    if f is None:
        raise InputError(Problem(str(csv), f"required table {schema.name} is missing"))
    df, problems = read_table(f, schema)
    if problems:
        raise InputError(problems)
    return df


def scene_file(folder: Path, scene_id: str) -> Path:
    """The one file `folder/<scene_id>.<ext>`; InputError naming the scene when absent or twice."""
    found = sorted(p for p in folder.glob(f"{scene_id}.*") if p.is_file())
    found = [p for p in found if p.stem == scene_id]
    if not found:
        raise InputError(
            Problem(str(folder), f"no RPC file for scene {scene_id} (expected {scene_id}.<ext>)")
        )
    if len(found) > 1:
        names = ", ".join(p.name for p in found)
        raise InputError(Problem(str(folder), f"scene {scene_id} has several RPC files: {names}"))
    return found[0]


def read_models(folder: Path, scene_ids: list[str]) -> list[RPCModel]:
    """Every scene's RPC from `folder`; all problems listed together."""
    if not folder.is_dir():
        raise InputError(Problem(str(folder), "missing folder: the scenes' RPCs are needed"))
    models, problems = [], []
    for sid in scene_ids:
        try:
            models.append(read_rpc(scene_file(folder, sid)))
        except InputError as exc:
            problems.extend(exc.problems)
    if problems:
        raise InputError(problems)
    return models


def read_adjustment(path: Path, scene_ids: list[str]) -> np.ndarray:
    """adjustment.csv as an (n_scenes, 6) array in the scenes' order; every scene once."""
    df, problems = read_table(path, ADJUSTMENT)
    if problems:
        raise InputError(problems)
    index = {s: i for i, s in enumerate(df["scene_id"].astype(str))}
    unknown = sorted(set(index) - set(scene_ids))
    missing = [s for s in scene_ids if s not in index]
    if unknown:
        problems.append(Problem(str(path), f"unknown scene_id(s): {', '.join(unknown[:5])}"))
    if missing:
        problems.append(Problem(str(path), f"no row for scene(s): {', '.join(missing[:5])}"))
    if problems:
        raise InputError(problems)
    values = df[list(AFFINE_KEYS)].to_numpy(np.float64)
    return values[[index[s] for s in scene_ids]]


def _check_ties(path: Path, ties: pd.DataFrame, scene_ids: list[str]) -> None:
    known = ties["scene_id"].astype(str).isin(set(scene_ids)).to_numpy()
    if not known.all():
        rows = np.flatnonzero(~known)[:5]
        raise InputError(
            [
                Problem(
                    str(path),
                    "unknown scene_id (not in scenes.csv)",
                    row=int(r) + 1,
                    line=int(r) + 2,
                    column="scene_id",
                )
                for r in rows
            ]
        )


def load_adjust_input(path: str | Path) -> AdjustInput:
    """Read a delivery for the adjustment; InputError naming the file, row or scene on problems."""
    path = Path(path)
    if not (path / MANIFEST).is_file():
        raise InputError(Problem(str(path), f"not a delivery folder (no {MANIFEST})"))
    manifest = load_manifest(path / MANIFEST)
    scenes = _table(path, SCENES)
    ties = _table(path, TIE_POINTS_V11)
    scene_ids = [str(s) for s in scenes["scene_id"]]
    _check_ties(path / "tie_points.csv", ties, scene_ids)
    models = read_models(path / "rpc", scene_ids)
    affine, producer_models, source = None, None, "none"
    if (path / "adjustment.csv").is_file():
        affine = read_adjustment(path / "adjustment.csv", scene_ids)
        producer_models, source = models, "adjustment.csv"
    elif (path / "rpc_adjusted").is_dir():
        producer_models = read_models(path / "rpc_adjusted", scene_ids)
        affine, source = np.zeros((len(scene_ids), 6)), "rpc_adjusted/"
    return AdjustInput(path, manifest, scenes, ties, models, affine, producer_models, source)
