"""Verification of process data from the delivered geometry: residuals reproduced (§RC-1)."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from blockqc.adjust.geometry import RPCStack, project_adjusted
from blockqc.delivery import Delivery, scene_positions
from blockqc.metrics import Measure, Measurement, Scope, Table, metric, not_applicable

_BLOCK = {
    "n": "observations",
    "n_points": "points",
    "rms_px": "px",
    "max_px": "px",
    "median_px": "px",
}
_OBSERVATION_COLUMNS = (
    "line",
    "sample",
    "v_line",
    "v_sample",
    "v_line_computed",
    "v_sample_computed",
    "n_rays",
    "intersected",
)


#: the ground points the delivered residuals are back-projected from (§RC-1, Reading)
INTERSECTED = "intersected"
DELIVERED = "delivered"
GROUND_COLUMNS = ("lon", "lat", "h")


class ReproductionParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    ground: Literal["intersected", "delivered"] = Field(
        default=INTERSECTED,
        description=(
            "intersected: each point's rays intersected by blockqc, unweighted (§RC-1); "
            "delivered: the producer's own ground point (tie_points lon, lat, h), which "
            "reproduces residuals of an adjustment that weighted its observations or held "
            "heights to a DEM"
        ),
    )


def _reason(d: Delivery) -> str | None:
    """Why the delivered residuals cannot be verified, or None when they can."""
    geo = d.geometry
    if geo is None:
        return "no geometry in the delivery (rpc/ with adjustment.csv, or rpc_adjusted/)"
    if geo.adjusted is None:
        return "rpc/ is given but not the producer's adjustment (adjustment.csv or rpc_adjusted/)"
    if "data" not in d.process_data:
        return "the process data were not computed"
    return None


@metric(
    "residual_reproduction",
    params=ReproductionParams,
    tie_points=(),  # it reads the process data; a delivery with geometry is read whole
    scopes={
        "observation": Scope(
            {"difference_px": "px"},
            keys=("point_id", "scene_id"),
            columns=_OBSERVATION_COLUMNS,
            table="tie_points",
        ),
        "block": Scope(_BLOCK),
    },
)
def residual_reproduction(d: Delivery, p: ReproductionParams, measure: Measure) -> Measurement:
    """Delivered tie-point residuals against those the delivered geometry gives (§RC-1)."""
    reason = _reason(d)
    if reason:
        return not_applicable(reason)
    notes = d.process_data["notes"]
    if notes.get("tie_point_residuals", "").startswith("tie-point residuals computed"):
        return not_applicable("the delivery gives no residuals: blockqc computed them (§RC-1)")
    obs = d.process_data["data"].observations
    tp = d.tie_points
    if p.ground == DELIVERED:
        v_line, v_sample = _from_delivered_ground(d)
    else:
        v_line, v_sample = obs["v_line_computed"].to_numpy(), obs["v_sample_computed"].to_numpy()
    table = obs[["point_id", "scene_id", "line", "sample"]].assign(
        v_line=tp["v_line"].to_numpy(),
        v_sample=tp["v_sample"].to_numpy(),
        v_line_computed=v_line,
        v_sample_computed=v_sample,
        n_rays=obs["n_rays"].to_numpy(),
    )
    table["difference_px"] = np.hypot(
        table["v_line"] - table["v_line_computed"], table["v_sample"] - table["v_sample_computed"]
    )
    table, unverified = _verifiable(table, every=p.ground == DELIVERED)
    if table.empty:
        return not_applicable(
            "no tie point is seen on two or more scenes "
            f"({unverified['single_ray_observations']} observations of single-ray points)"
        )
    diff = table["difference_px"]
    block = pd.DataFrame(
        {
            "n": [len(table)],
            "n_points": [table["point_id"].nunique()],
            "rms_px": [float(np.sqrt(np.mean(diff**2)))],
            "max_px": [diff.max()],
            "median_px": [diff.median()],
        }
    )
    return Measurement(
        tables={
            "observation": Table(table, keys=["point_id", "scene_id"], sort="difference_px"),
            "block": Table(block),
        },
        detail={**notes, **unverified, "ground": p.ground},
    )


def _from_delivered_ground(d: Delivery) -> tuple[np.ndarray, np.ndarray]:
    """Each observation's residual back-projected from its point's delivered ground point
    (tie_points lon, lat, h) through the producer's adjusted model: computed − measured."""
    tp, geo = d.tie_points, d.geometry
    assert geo is not None and geo.adjusted is not None and geo.affine is not None
    missing = [c for c in GROUND_COLUMNS if c not in tp.columns]
    if missing:
        raise ValueError(
            f"ground: {DELIVERED} back-projects the producer's ground points, but tie_points "
            f"gives no {', '.join(missing)} (contract v1.1: lon, lat, h ellipsoidal)"
        )
    ground = [tp[c].to_numpy(dtype=float) for c in GROUND_COLUMNS]
    given = np.isfinite(ground[0]) & np.isfinite(ground[1]) & np.isfinite(ground[2])
    if not given.all():
        first = int(np.flatnonzero(~given)[0])
        raise ValueError(
            f"ground: {DELIVERED}: {int((~given).sum())} of {given.size} observations give no "
            f"ground point (lon, lat, h), the first {tp['point_id'].iloc[first]} on "
            f"{tp['scene_id'].iloc[first]}: each must give one to be back-projected"
        )
    scene = scene_positions(tp["scene_id"], geo.scene_ids)
    line, sample = project_adjusted(RPCStack.from_models(geo.adjusted), geo.affine, scene, *ground)
    line -= tp["line"].to_numpy(dtype=float)
    sample -= tp["sample"].to_numpy(dtype=float)
    return line, sample


def _verifiable(table: pd.DataFrame, every: bool = False) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The observations whose residuals the geometry must give (points on two or more scenes;
    `every` one when back-projected from delivered ground points), and how many are left out: a
    point seen once is fixed by its one ray (nothing to reproduce). A point whose rays the
    delivered geometry cannot intersect has no computed residual: its observations are not
    reproduced, at an infinite difference (they fail, as evidence)."""
    multi = np.ones(len(table), dtype=bool) if every else (table["n_rays"] >= 2).to_numpy()
    computed = np.isfinite(table[["v_line_computed", "v_sample_computed"]].to_numpy()).all(axis=1)
    unverified = {
        "single_ray_observations": int((~multi).sum()),
        "not_intersected_observations": int((multi & ~computed).sum()),
    }
    if unverified["single_ray_observations"]:
        unverified["not_verified"] = (
            "observations of points seen on one scene only are not compared (their one ray "
            "fixes the point)"
        )
    if unverified["not_intersected_observations"]:
        unverified["not_reproduced"] = (
            "observations of points whose rays the delivered geometry cannot intersect: no "
            "residual is computed, so the delivered one is not reproduced (difference ∞)"
        )
    table = table[multi].reset_index(drop=True)
    table["intersected"] = computed[multi]
    table.loc[~table["intersected"], "difference_px"] = np.inf
    return table, unverified
