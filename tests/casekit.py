"""A tiny hand-computable delivery and the patches rule cases apply to it.

The base block passes every automatic rule of the stock pack, with figures one can check by
hand: 4 PAN scenes of 1000×1000 px, each with an 11×11 grid of tie points whose errors are all
exactly 0.3 px; PAN–MS discrepancies √2 m; overlap and edge discrepancies 5 m plane, 2 m height;
27 high-precision checkpoints on 9 reference images with plane Δ = 5 m and height Δ = 2 m.

A case (YAML) changes it with:
  manifest: {...}                      deep-merged into block.yaml
  set:   {table: [{where: {...}, query: "...", values: {...}}]}
  drop:  {table: [{where: {...}, query: "...", keep_first: N}]}   rows removed
  set_expr: {table: {column: "pandas expression over the row's columns"}}
  append: {table: [{...row...}]}
  remove_tables: [name]
  files: {relative/path: "text" | null}  written or deleted in the delivery
  verdicts: {...}                      the inspector's file
  pack: {...}                          a pack extending global-project (constants, overrides …)
"""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from blockqc.simulate import DOCUMENTS, minimal_pdf

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"


def run_blockqc(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the real command line in a child process (exit status, stdout, stderr)."""
    return subprocess.run(
        [sys.executable, "-m", "blockqc", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )


LON0, LAT0, SIZE = 116.30, 39.90, 0.02  # Beijing area: UTM zone 50N (EPSG:32650)


def _footprint(i: int, j: int) -> str:
    x0, y1 = LON0 + j * SIZE * 0.8, LAT0 - i * SIZE * 0.8
    x1, y0 = x0 + SIZE, y1 - SIZE
    return f"POLYGON(({x0} {y1}, {x1} {y1}, {x1} {y0}, {x0} {y0}, {x0} {y1}))"


def base_tables() -> dict[str, pd.DataFrame]:
    scenes = pd.DataFrame(
        {
            "scene_id": ["S1", "S2", "S3", "S4", "M1"],
            "band": ["pan"] * 4 + ["ms"],
            "acquired": ["2022-05-01", "2022-05-01", "2022-06-10", "2022-06-10", "2022-05-01"],
            "lines": [1000] * 4 + [250],
            "samples": [1000] * 4 + [250],
            "footprint_wkt": [
                _footprint(0, 0),
                _footprint(0, 1),
                _footprint(1, 0),
                _footprint(1, 1),
                _footprint(0, 0),
            ],
            "water_fraction": [0.0] * 5,
        }
    )
    grid = 45.0 + 91.0 * np.arange(11)
    line, sample = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))
    k = np.arange(121)
    theta = k * 0.7
    parts = []
    for s in ("S1", "S2", "S3", "S4"):
        parts.append(
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
        )
    tie_points = pd.concat(parts, ignore_index=True)
    pan_ms = pd.DataFrame(
        {
            "pan_scene_id": "S1",
            "ms_scene_id": "M1",
            "point_id": [f"R{i}" for i in range(5)],
            "dx_m": 1.0,
            "dy_m": 1.0,
        }
    )
    overlaps = pd.DataFrame(
        {
            "scene_a": "S1",
            "scene_b": "S2",
            "point_id": [f"O{i}" for i in range(5)],
            "dx_m": 3.0,
            "dy_m": 4.0,
            "dz_m": 2.0,
        }
    )
    edges = pd.DataFrame(
        {
            "neighbour_block": "B2",
            "point_id": [f"E{i}" for i in range(5)],
            "dx_m": 3.0,
            "dy_m": 4.0,
            "dz_m": 2.0,
        }
    )
    n = 27
    x = 440000.0 + 100.0 * np.arange(n)
    y = 4410000.0 + 50.0 * np.arange(n)
    z = 50.0 + np.arange(n, dtype=float)
    checkpoints = pd.DataFrame(
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
    return {
        "scenes": scenes,
        "tie_points": tie_points,
        "pan_ms": pan_ms,
        "overlaps": overlaps,
        "edges": edges,
        "checkpoints": checkpoints,
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


def _mask(df: pd.DataFrame, op: dict[str, Any]) -> np.ndarray:
    m = np.ones(len(df), dtype=bool)
    for col, val in (op.get("where") or {}).items():
        m &= (df[col] == val).to_numpy()
    if op.get("query"):
        m &= df.eval(op["query"], engine="python").to_numpy(dtype=bool)
    return m


def write_delivery(folder: Path, case: dict[str, Any] | None = None) -> Path:
    """Write the base delivery changed by a case's patches into `folder`."""
    case = case or {}
    tables = base_tables()
    for name, ops in (case.get("set") or {}).items():
        df = tables[name]
        for op in ops:
            m = _mask(df, op)
            for col, val in op["values"].items():
                df.loc[m, col] = val
    for name, exprs in (case.get("set_expr") or {}).items():
        df = tables[name]
        for col, expr in exprs.items():
            df[col] = df.eval(expr, engine="python").astype(float)
    for name, ops in (case.get("drop") or {}).items():
        df = tables[name]
        for op in ops:
            m = _mask(df, op)
            if "keep_first" in op:
                idx = np.flatnonzero(m)[: op["keep_first"]]
                m[idx] = False
            df = df[~m]
        tables[name] = df.reset_index(drop=True)
    for name, rows in (case.get("append") or {}).items():
        tables[name] = pd.concat([tables[name], pd.DataFrame(rows)], ignore_index=True)
    for name in case.get("remove_tables") or []:
        tables.pop(name)
    folder.mkdir(parents=True, exist_ok=True)
    for name, df in tables.items():
        df.to_csv(folder / f"{name}.csv", index=False)
    manifest = _merge(base_manifest(), case.get("manifest") or {})
    (folder / "block.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    for rel in DOCUMENTS.values():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(minimal_pdf(["test document"]))
    for rel, content in (case.get("files") or {}).items():
        path = folder / rel
        if content is None:
            path.unlink(missing_ok=True)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(content)
    return folder


def write_pack(path: Path, extra: dict[str, Any]) -> Path:
    pack = {"pack": "case-pack", "version": "1", "extends": "global-project", **extra}
    path.write_text(yaml.safe_dump(pack, sort_keys=False, allow_unicode=True))
    return path


def aggregate_status(results: list[dict[str, Any]], group: dict[str, Any] | None = None) -> str:
    """The rule's overall status: the most severe over its results (groups)."""
    if group:
        results = [r for r in results if all(r["group"].get(k) == v for k, v in group.items())]
    order = ["error", "fail", "warn", "waived", "manual", "pass", "not_applicable"]
    statuses = {r["status"] for r in results}
    return next((s for s in order if s in statuses), "none")
