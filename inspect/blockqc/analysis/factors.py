"""One experiments-table row per delivery: the ten §AF factors and five indicators of a block."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import shapely

from blockqc.analysis.footprints import (
    FootprintFactors,
    block_transformer,
    footprint_factors,
    project,
    scene_polygons,
    select_images,
    tie_point_lonlat,
)
from blockqc.analysis.indicators import DEFAULT_METHOD_ORDER, Indicators, block_indicators
from blockqc.analysis.table import TABLE_COLUMNS
from blockqc.analysis.terrain import DemSet
from blockqc.spatial import clark_evans


@dataclass(frozen=True)
class FactorOptions:
    """The readings of §AF that a user may change (see docs/factors.md)."""

    images_band: str = "pan"  # 'pan', 'ms' or 'all': which scenes count as images (§AF-5)
    period_gap_days: float = 0.0  # dates at most this far apart form one period (§AF-6)
    overlap: str = "union"  # 'union' (area seen twice or more) or 'pairwise_sum' (§AF-7)
    stereo_iou: float = 0.8  # same-day scenes overlapping this much are one stereo unit (§AF-7)
    edge_correction: bool = False  # Donnelly's correction in Clark–Evans R (§AF-10)
    method_order: tuple[str, ...] = DEFAULT_METHOD_ORDER  # checkpoint method per component


@dataclass(frozen=True)
class TiePointFactors:
    """§AF-8..10 of one block."""

    tp_number: int
    tp_density_per_km2: float
    tp_nn_coefficient: float


def tie_point_factors(
    tie_points: pd.DataFrame,
    scenes: pd.DataFrame,
    covered_area_km2: float,
    transformer: Any,
    perimeter_m: float | None = None,
) -> TiePointFactors:
    """Number of distinct tie points, density per km² of covered area, Clark–Evans R in metres."""
    pos = tie_point_lonlat(tie_points, scenes)
    n = len(pos)
    x, y = transformer.transform(pos["lon"].to_numpy(), pos["lat"].to_numpy())
    area_m2 = covered_area_km2 * 1e6
    density = n / covered_area_km2 if covered_area_km2 > 0 else float("nan")
    r = clark_evans(np.asarray(x), np.asarray(y), area_m2, perimeter_m)
    return TiePointFactors(n, density, r)


def _residual_observations(
    tie_points: pd.DataFrame, scenes: pd.DataFrame, band: str
) -> tuple[pd.DataFrame, str]:
    """The observations whose residuals make δ_l, δ_s: those on the counted band's scenes, so
    that pixels of one size are pooled; all observations when that band has none."""
    if band == "all":
        return tie_points, "all"
    sc = scenes.drop_duplicates("scene_id")
    band_of = pd.Series(sc["band"].to_numpy(), index=sc["scene_id"].astype(str).to_numpy())
    obs_band = tie_points["scene_id"].astype(str).map(band_of).astype(str).str.strip().str.lower()
    on_band = (obs_band == band).to_numpy()
    if on_band.any():
        return tie_points[on_band], band
    return tie_points, "all"


def block_row(delivery: Any, dems: DemSet | None, options: FactorOptions) -> dict[str, Any]:
    """The experiments-table row of one delivery (appendix columns, then extra columns)."""
    scenes_file = str(Path(delivery.path) / "scenes.csv")
    images = select_images(delivery.scenes, options.images_band, scenes_file)
    geoms = scene_polygons(images, scenes_file)
    tr = block_transformer(geoms)
    fp: FootprintFactors = footprint_factors(
        delivery.scenes,
        options.images_band,
        options.period_gap_days,
        tr,
        scenes_file,
        options.stereo_iou,
    )
    union_lonlat = shapely.union_all(geoms)
    perimeter = float(shapely.union_all(project(geoms, tr)).length)
    tp = tie_point_factors(
        delivery.tie_points,
        delivery.scenes,
        fp.covered_area_km2,
        tr,
        perimeter if options.edge_correction else None,
    )
    residuals, residual_band = _residual_observations(
        delivery.tie_points, delivery.scenes, options.images_band
    )
    ind = block_indicators(residuals, delivery.checkpoints, options.method_order)
    t = _terrain_columns(dems, union_lonlat)
    return _row(delivery, options, fp, tp, ind, t, residual_band)


def _terrain_columns(dems: DemSet | None, union_lonlat: shapely.Geometry) -> dict[str, Any]:
    """The terrain factors over the block's footprint (none without DEMs)."""
    if dems is not None:
        terrain = dems.factors(union_lonlat)
        return terrain.as_dict()
    nan = float("nan")
    return {
        "mean_elevation_m": nan,
        "mean_slope_deg": nan,
        "mean_roughness_m": nan,
        "dem_coverage": 0.0,
        "dem_files": [],
    }


def _row(
    delivery: Any,
    options: FactorOptions,
    fp: FootprintFactors,
    tp: TiePointFactors,
    ind: Indicators,
    t: dict[str, Any],
    residual_band: str,
) -> dict[str, Any]:
    """The row of the factors and indicators measured: appendix columns, then extra columns."""
    m = delivery.manifest
    block_id = str(m.block_id)
    overlap = fp.overlap_degree if options.overlap == "union" else fp.overlap_pairwise_sum
    row: dict[str, Any] = {
        "experiment": block_id,
        "region": block_id.split("-")[0],
        "periods": " ".join(fp.periods),
        "image_pairs": fp.footprint_units,
        "mean_elevation_m": t["mean_elevation_m"],
        "mean_slope_deg": t["mean_slope_deg"],
        "mean_roughness_m": t["mean_roughness_m"],
        "images_area_km2": fp.covered_area_km2,
        "images_number": fp.images_number,
        "images_periods": fp.images_periods,
        "overlap_degree": overlap,
        "tp_number": tp.tp_number,
        "tp_density_per_km2": tp.tp_density_per_km2,
        "tp_nn_coefficient": tp.tp_nn_coefficient,
        "l_rmse_px": ind.l_rmse_px,
        "s_rmse_px": ind.s_rmse_px,
        "x_rmse_m": ind.x_rmse_m,
        "y_rmse_m": ind.y_rmse_m,
        "h_rmse_m": ind.h_rmse_m,
        # extra columns: what the figures rest on
        "sensor": str(getattr(m, "sensor", "")),
        "dem_coverage": t["dem_coverage"],
        "dem_files": ";".join(Path(f).name for f in t["dem_files"]),
        "overlap_union": fp.overlap_degree,
        "overlap_pairwise_sum": fp.overlap_pairwise_sum,
        "overlapping_pairs": fp.overlapping_pairs,
        "n_tie_observations": ind.n_tie_observations,
        "residual_band": residual_band,
        "n_plane_checkpoints": ind.n_plane_checkpoints,
        "n_height_checkpoints": ind.n_height_checkpoints,
        "plane_method": ind.plane_method or "",
        "height_method": ind.height_method or "",
        "delivery": Path(delivery.path).name,
    }
    return row


def experiments_table(
    deliveries: Sequence[Any], dems: DemSet | None, options: FactorOptions
) -> pd.DataFrame:
    """The experiments table of a batch: one row per delivery, appendix columns first."""
    rows = [block_row(d, dems, options) for d in deliveries]
    frame = pd.DataFrame(rows)
    extra = [c for c in frame.columns if c not in TABLE_COLUMNS]
    return frame[list(TABLE_COLUMNS) + extra]
