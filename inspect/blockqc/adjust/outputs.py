"""The files `blockqc adjust` writes into --out, each atomically (never into the delivery)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv

from blockqc.outputs import write_bytes_atomic, write_json_atomic, write_text_atomic

if TYPE_CHECKING:
    from blockqc.adjust.run import Block
    from blockqc.adjust.solver import Solution

AFFINE_KEYS = ("a0", "a1", "a2", "b0", "b1", "b2")


def write_csv_atomic(path: Path, table: pa.Table | pd.DataFrame) -> None:
    """A table as CSV (pyarrow's writer: fast on millions of rows), atomically."""
    if isinstance(table, pd.DataFrame):
        table = pa.Table.from_pandas(table, preserve_index=False)
    buf = io.BytesIO()
    pacsv.write_csv(table, buf)
    write_bytes_atomic(path, buf.getvalue())


def adjustment_table(block: Block, sol: Solution) -> pa.Table:
    """adjustment.csv: the contract's columns and the σ of each; the scenes left out of the
    adjustment (no tie-point observation) follow, their cells empty and `adjusted` false."""
    left_out = block.data.left_out
    ids = block.data.scenes["scene_id"].astype(str).tolist() + left_out
    adjusted = np.arange(len(ids)) < len(sol.affine)
    empty = np.zeros((len(left_out), len(AFFINE_KEYS)))
    affine = np.vstack([sol.affine, empty])
    sigma = np.vstack([sol.affine_sigma, empty])
    cols: dict[str, object] = {"scene_id": ids}
    for i, k in enumerate(AFFINE_KEYS):
        cols[k] = pa.array(affine[:, i], mask=~adjusted)
    for i, k in enumerate(AFFINE_KEYS):
        cols[f"sigma_{k}"] = pa.array(sigma[:, i], mask=~adjusted)
    cols["adjusted"] = adjusted
    return pa.table(cols)


def tie_table(block: Block, sol: Solution) -> pa.Table:
    """tie_points.csv in the delivery's row order, residuals recomputed, outlier flag."""
    ties = block.data.tie_points
    n = len(ties)
    vl, vs, out = np.empty(n), np.empty(n), np.empty(n, bool)
    vl[block.rows], vs[block.rows], out[block.rows] = sol.v_line, sol.v_sample, sol.outlier
    return pa.table(
        {
            "point_id": ties["point_id"].astype(str).to_numpy(),
            "scene_id": ties["scene_id"].astype(str).to_numpy(),
            "line": ties["line"].to_numpy(np.float64),
            "sample": ties["sample"].to_numpy(np.float64),
            "v_line": np.round(vl, 4),
            "v_sample": np.round(vs, 4),
            "outlier": out,
        }
    )


def ground_table(block: Block, sol: Solution, base_to_height: np.ndarray) -> pa.Table:
    """ground_points.csv: the recalculated point, its σ (east, north, h m), the base-to-height
    ratio of its rays and usage."""
    kept = np.bincount(block.obs.point, (~sol.outlier).astype(float), block.obs.n_points)
    sig = np.where(sol.point_used[:, None], sol.ground_sigma, np.nan)
    return pa.table(
        {
            "point_id": block.point_ids.astype(str),
            "lon": np.round(sol.lon, 9),
            "lat": np.round(sol.lat, 9),
            "h": np.round(sol.h, 4),
            "sigma_east_m": np.round(sig[:, 0], 4),
            "sigma_north_m": np.round(sig[:, 1], 4),
            "sigma_h_m": np.round(sig[:, 2], 4),
            "base_to_height": np.round(base_to_height, 4),
            "n_observations": kept.astype(np.int64),
            "used": sol.point_used,
        }
    )


def write_outputs(
    out: Path,
    block: Block,
    sol: Solution,
    checkpoints: pd.DataFrame,
    summary: dict,
    v_before: np.ndarray,
    base_to_height: np.ndarray,
    lang: str = "en",
) -> None:
    """Every table, adjust.json, the figures and adjust.html (`base_to_height` per point; the
    page and the figures in `lang`)."""
    from blockqc.adjust.report import render_html, write_figures

    out.mkdir(parents=True, exist_ok=True)
    write_csv_atomic(out / "adjustment.csv", adjustment_table(block, sol))
    write_csv_atomic(out / "tie_points.csv", tie_table(block, sol))
    write_csv_atomic(out / "ground_points.csv", ground_table(block, sol, base_to_height))
    write_csv_atomic(out / "checkpoints.csv", checkpoints)
    summary["files"] = write_figures(out, block, sol, summary, v_before, lang)
    summary["files"].update(
        {
            "adjustment": "adjustment.csv",
            "tie_points": "tie_points.csv",
            "ground_points": "ground_points.csv",
            "checkpoints": "checkpoints.csv",
        }
    )
    write_json_atomic(out / "adjust.json", summary)
    write_text_atomic(out / "adjust.html", render_html(summary, lang=lang))
