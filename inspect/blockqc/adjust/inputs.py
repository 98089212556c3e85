"""What the adjustment needs from a delivery, read by `blockqc.delivery` (contract v1 and v1.1).

The delivery is read and validated as `inspect` reads it: the tables (tie_points may lack
`v_line`/`v_sample` when the geometry is given, and may carry the producer's `lon`, `lat`, `h`),
`rpc/<scene_id>.<ext>` and the producer's adjustment (`adjustment.csv` or `rpc_adjusted/`),
every problem at once. The adjustment needs the RPC of every scene with tie-point observations;
a scene of scenes.csv without any takes no part in it, whatever its RPC, and is left out (said).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from blockqc.delivery import MANIFEST, Manifest, load_delivery
from blockqc.errors import InputError, Problem
from blockqc.geometry_inputs import (
    AFFINE_KEYS,
    ONE_GROUND_POINT,
    RPC_DIR,
    BlockGeometry,
    ground_disagreements,
)
from blockqc.rfm.model import RPCModel
from blockqc.textio import located, not_there


@dataclass
class AdjustInput:
    """A delivery's block as the adjustment sees it (models in the scenes table's order)."""

    path: Path
    manifest: Manifest
    scenes: pd.DataFrame
    tie_points: pd.DataFrame
    models: list[RPCModel]
    producer_affine: np.ndarray | None
    producer_models: list[RPCModel] | None
    producer_source: str
    tie_points_file: Path | None = None
    #: the scenes of scenes.csv without tie-point observations, left out of the adjustment
    left_out: list[str] = field(default_factory=list)
    #: what the tables give that is read as given but said (`Delivery.read_warnings`)
    read_warnings: list[str] = field(default_factory=list)


def _originals(path: Path, geometry: BlockGeometry | None, scene_ids: list[str]) -> list:
    """The original RPC of every scene given (those with observations); InputError naming the
    scenes that have none."""
    have = geometry.original if geometry is not None else {}
    missing = [s for s in scene_ids if s not in have]
    if missing:
        shown = ", ".join(missing[:10]) + (" …" if len(missing) > 10 else "")
        raise InputError(
            Problem(
                str(path / RPC_DIR),
                f"no RPC for scene(s) {shown}: the adjustment needs the RPC of every scene "
                f"with tie-point observations (expected {RPC_DIR}/<scene_id>.<ext>)",
            )
        )
    return [have[s] for s in scene_ids]


def _check_multi_ray(path: Path, tie_points: pd.DataFrame) -> None:
    """Refuse tie points of which none is seen on two or more scenes: there is no ray to
    intersect with another, so nothing ties the scenes and there is nothing to adjust."""
    if tie_points["point_id"].duplicated().any():  # (point_id, scene_id) is unique
        return
    raise InputError(
        Problem(
            str(path),
            f"none of the {len(tie_points)} tie points is observed on two or more scenes: "
            "the adjustment needs points seen on several scenes (expected point_id repeated "
            "on the rows of the scenes that see it)",
        )
    )


def _check_ground(file: Path, tie_points: pd.DataFrame) -> None:
    """Refuse a point whose rows give different producer's ground points (lon, lat, h): one of
    them is wrong, and a checkpoint of their mean would be neither (longitudes modulo 360°)."""
    problems = ground_disagreements(file, tie_points, ONE_GROUND_POINT)
    if problems:
        raise InputError(located(problems))


def _producer(geometry: BlockGeometry, models: list[RPCModel], scene_ids: list[str]) -> tuple:
    """The producer's adjusted models and affine in the scenes' order; scenes without
    observations (absent from the producer's adjustment) keep their original RPC, no affine."""
    if geometry.adjusted is None or geometry.affine is None:
        return None, None
    at = {s: i for i, s in enumerate(geometry.scene_ids)}
    adjusted = [
        geometry.adjusted[at[s]] if s in at else m for s, m in zip(scene_ids, models, strict=True)
    ]
    affine = np.zeros((len(scene_ids), len(AFFINE_KEYS)))
    rows = [k for k, s in enumerate(scene_ids) if s in at]
    affine[rows] = geometry.affine[[at[scene_ids[k]] for k in rows]]
    return adjusted, affine


def _not_a_delivery(path: Path) -> str:
    """Why DELIVERY is none: nothing there, a file (block.yaml itself, say), or no block.yaml."""
    if not path.exists():
        what = not_there(path, "no such file or folder")
        return f"{what}: expected a delivery folder (with block.yaml)"
    if not path.is_dir():
        return f"a file, not a delivery folder (the folder holding {MANIFEST})"
    return f"not a delivery folder (no {MANIFEST})"


def load_adjust_input(path: str | Path) -> AdjustInput:
    """Read a delivery for the adjustment; InputError naming the file, row or scene on problems."""
    path = Path(path)
    if not (path / MANIFEST).is_file():
        raise InputError(Problem(str(path), _not_a_delivery(path)))
    d = load_delivery(path, residuals=False)  # the observations alone are adjusted
    _check_multi_ray(d.files["tie_points"], d.tie_points)
    _check_ground(d.files["tie_points"], d.tie_points)
    observed = d.scenes["scene_id"].isin(d.tie_points["scene_id"].unique()).to_numpy()
    scenes = d.scenes[observed].reset_index(drop=True)
    scene_ids = [str(s) for s in scenes["scene_id"]]
    models = _originals(path, d.geometry, scene_ids)
    producer_models, affine = (None, None)
    source = "none"
    if d.geometry is not None:
        producer_models, affine = _producer(d.geometry, models, scene_ids)
        source = d.geometry.source or "none"
    return AdjustInput(
        path,
        d.manifest,
        scenes,
        d.tie_points,
        models,
        affine,
        producer_models,
        source,
        d.files["tie_points"],
        [str(s) for s in d.scenes["scene_id"][~observed]],
        [str(p) for p in d.read_warnings],
    )
