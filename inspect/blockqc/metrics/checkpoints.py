"""Checkpoint (absolute) accuracy per component and method, exactly per §CP-2..8."""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from blockqc import metrics
from blockqc.delivery import Delivery
from blockqc.metrics import Measure, Measurement, Scope, Table, metric, not_applicable
from blockqc.schema import METHODS

Method = Literal["high_precision", "same_accuracy", "recalculation"]


class AccuracyParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    # a parameter a rule leaves out takes the pack's constant standing for it, when the pack
    # sets one (the norms of §CP-N, the count of §CP-1/§CP-7), else the default below
    CONSTANTS: ClassVar[dict[str, str]] = {
        "plane_norm_m": "norm.plane_m",
        "height_norm_m": "norm.height_m",
        "min_points_for_medium_error": "cp.min_points",
    }
    plane_norm_m: float = Field(default=10.0, gt=0)  # §CP-N
    height_norm_m: float = Field(default=6.0, gt=0)
    # gross-error bound = factor·norm, inclusive (§CP-4)
    tolerance_factor: dict[Method, float] = Field(
        default_factory=lambda: {
            "high_precision": 2.0,
            "same_accuracy": 2 * math.sqrt(2),
            "recalculation": 2 * math.sqrt(2),
        }
    )
    # M = ±√(ΣΔ² / (divisor·n)): M1 with 1, M2 with 2 (§CP-5)
    divisor: dict[Method, float] = Field(
        default_factory=lambda: {"high_precision": 1.0, "same_accuracy": 2.0, "recalculation": 2.0}
    )
    # below this many checkpoints the mean error replaces the medium error (§CP-7)
    min_points_for_medium_error: int = Field(default=20, ge=1)
    # Reading of §CP-7's "fewer than 20 checkpoints": all of the method's points (N), gross included
    count_for_mean: Literal["all", "retained"] = "all"
    # |Δ| ≤ bound + this counts as on the bound: far below any real difference, above rounding
    bound_tolerance_m: float = Field(default=1e-9, ge=0, le=1e-4)


class CoverageParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    method: Method = "high_precision"
    min_reference_images: int = 8  # "more than 7 reference images" (§CP-2)
    points_per_reference: int = 3


def checkpoint_errors(cp: pd.DataFrame) -> pd.DataFrame:
    """Per checkpoint and component: plane Δ = √(dx² + dy²), height Δ = dz (§CP-3)."""
    dx = (cp["x_m"] - cp["ref_x_m"]).to_numpy(dtype=float)
    dy = (cp["y_m"] - cp["ref_y_m"]).to_numpy(dtype=float)
    dz = (cp["z_m"] - cp["ref_z_m"]).to_numpy(dtype=float)
    base = cp[["point_id", "method", "reference_id", "x_m", "y_m"]].reset_index(drop=True)
    plane = base.assign(component="plane", dx_m=dx, dy_m=dy, dz_m=np.nan, error_m=np.hypot(dx, dy))
    height = base.assign(component="height", dx_m=np.nan, dy_m=np.nan, dz_m=dz, error_m=dz)
    out = pd.concat([plane, height], ignore_index=True)
    out = out[np.isfinite(out["error_m"].to_numpy())].reset_index(drop=True)
    out["abs_error_m"] = out["error_m"].abs()
    return out[
        [
            "component",
            "method",
            "point_id",
            "reference_id",
            "x_m",
            "y_m",
            "dx_m",
            "dy_m",
            "dz_m",
            "error_m",
            "abs_error_m",
        ]
    ]


#: the columns of `accuracy_by_group`'s table, in order
_GROUP_COLUMNS = [
    "component",
    "method",
    "n_total",
    "n",
    "n_gross",
    "gross_rate",
    "medium_error",
    "statistic",
    "used_mean",
    "min_points_for_medium_error",
    "max_error",
    "norm_m",
    "bound_m",
]


def accuracy_by_group(points: pd.DataFrame, p: AccuracyParams) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Gross errors (§CP-4), medium or mean error (§CP-5, §CP-7), max error, gross rate (§CP-6)."""
    norm = np.where(points["component"] == "plane", p.plane_norm_m, p.height_norm_m)
    factor = points["method"].map(p.tolerance_factor).to_numpy(dtype=float)
    divisor = points["method"].map(p.divisor).to_numpy(dtype=float)
    bound = factor * norm
    gross = points["abs_error_m"].to_numpy() > bound + p.bound_tolerance_m
    points = points.assign(bound_m=bound, gross=gross)
    out = _group_sums(points, gross, divisor, norm)
    _medium_errors(out, p)
    order = {m: i for i, m in enumerate(METHODS)}
    out = out.sort_values(
        ["component", "method"], key=lambda s: s.map({"plane": 0, "height": 1} | order)
    ).reset_index(drop=True)
    return out[_GROUP_COLUMNS], points


def _group_sums(
    points: pd.DataFrame, gross: np.ndarray, divisor: np.ndarray, norm: np.ndarray
) -> pd.DataFrame:
    """Per component and method: the checkpoints, those kept (not gross errors), the sums of
    their squared and absolute errors, their max error, the divisor, norm and bound, and the
    count and rate (%) of gross errors."""
    kept = points.assign(
        sq=np.where(gross, 0.0, points["abs_error_m"] ** 2),
        ab=np.where(gross, 0.0, points["abs_error_m"]),
        mx=np.where(gross, np.nan, points["abs_error_m"]),
        keep=~gross,
        divisor=divisor,
        norm_m=norm,
    )
    g = kept.groupby(["component", "method"], sort=False)
    out = pd.DataFrame(
        {
            "n_total": g.size(),
            "n": g["keep"].sum(),
            "sum_sq": g["sq"].sum(),
            "sum_abs": g["ab"].sum(),
            "max_error": g["mx"].max(),
            "divisor": g["divisor"].first(),
            "norm_m": g["norm_m"].first(),
            "bound_m": g["bound_m"].first(),
        }
    ).reset_index()
    out["n_gross"] = out["n_total"] - out["n"]
    out["gross_rate"] = 100.0 * out["n_gross"] / out["n_total"]
    return out


def _medium_errors(out: pd.DataFrame, p: AccuracyParams) -> None:
    """Add each group's medium error (§CP-5: M1, M2 by the method's divisor) to `out`, or its
    mean error where fewer checkpoints than `min_points_for_medium_error` count (§CP-7), and
    which of the two it is."""
    counted = out["n_total"] if p.count_for_mean == "all" else out["n"]
    out["used_mean"] = counted < p.min_points_for_medium_error
    out["min_points_for_medium_error"] = p.min_points_for_medium_error
    n = out["n"].where(out["n"] > 0)
    medium = np.sqrt(out["sum_sq"] / (out["divisor"] * n))
    mean = out["sum_abs"] / n / np.sqrt(out["divisor"])
    out["medium_error"] = np.where(out["used_mean"], mean, medium)
    label = np.where(out["divisor"] == 1.0, "M1", np.where(out["divisor"] == 2.0, "M2", "M"))
    out["statistic"] = np.where(out["used_mean"], "mean", label)


def method_agreement(groups: pd.DataFrame) -> list[dict]:
    """Where two methods check the same component, whether their medium errors agree (§CP-8).
    The spread is None when a method has no medium error (every checkpoint a gross error)."""
    out = []
    for component, g in groups.groupby("component", sort=False):
        if len(g) < 2:
            continue
        errors = g["medium_error"]
        within = (errors <= g["norm_m"]).tolist()
        spread = float(errors.max() - errors.min()) if errors.notna().all() else None
        out.append(
            {
                "component": component,
                "methods": g["method"].tolist(),
                "medium_error": [round(float(v), 3) for v in errors],
                "spread_m": None if spread is None else round(spread, 3),
                "agree": len(set(within)) == 1,
            }
        )
    return out


_GROUPS = {"component": ("plane", "height"), "method": METHODS}


@metric(
    "checkpoint_accuracy",
    tie_points=(),
    detailed=True,
    params=AccuracyParams,
    scopes={
        "block": Scope({"n_points": "points", "n_rows": "rows"}),
        "component_method": Scope(
            {
                "medium_error": "m",
                "max_error": "m",
                "gross_rate": "%",
                "n_gross": "points",
                "n": "points",
                "n_total": "points",
            },
            groups=_GROUPS,
            columns=("statistic", "used_mean", "min_points_for_medium_error", "norm_m", "bound_m"),
            values={"statistic": ("M1", "M2", "M", "mean")},
            apart=("component",),
        ),
        "point": Scope(
            {"abs_error_m": "m", "error_m": "m"},
            groups=_GROUPS,
            keys=("point_id",),
            columns=("reference_id", "x_m", "y_m", "dx_m", "dy_m", "dz_m", "bound_m", "gross"),
            apart=("component",),
            signed=("error_m",),
        ),
    },
    param_units={
        "plane_norm_m": "m",
        "height_norm_m": "m",
        "tolerance_factor": "× norm",
        "min_points_for_medium_error": "points",
        "bound_tolerance_m": "m",
    },
)
def checkpoint_accuracy(d: Delivery, p: AccuracyParams, measure: Measure) -> Measurement:
    """Checkpoint accuracy per component and method: M1/M2 or mean, max, gross errors (§CP-3..8)."""
    if d.checkpoints is None or d.checkpoints.empty:
        return not_applicable(metrics.NO_CHECKPOINTS)
    beyond = beyond_block(d)
    if beyond:
        raise ValueError(beyond)
    points = checkpoint_errors(d.checkpoints)
    groups, points = accuracy_by_group(points, p)
    block = pd.DataFrame(
        {"n_points": [d.checkpoints["point_id"].nunique()], "n_rows": [len(d.checkpoints)]}
    )
    # every component of every method delivered: one with no difference (ref_z_m, or ref_x_m
    # and ref_y_m, left empty throughout) is judged not applicable, saying why
    methods = d.checkpoints["method"].drop_duplicates().tolist()
    present = [{"component": c, "method": m} for m in methods for c in ("plane", "height")]
    measured = points.groupby("component")["method"].unique()
    no_z = tuple(
        ({"component": c, "method": m}, why)
        for c, why in (("plane", NO_REF_XY), ("height", NO_REF_Z))
        for m in methods
        if m not in set(measured.get(c, []))
    )
    return Measurement(
        tables={
            "block": Table(block),
            "component_method": Table(
                groups, group=["component", "method"], groups=present, empty=no_z
            ),
            "point": Table(
                points,
                group=["component", "method"],
                keys=["point_id"],
                sort="abs_error_m",
                groups=present,
                empty=no_z,
            ),
        },
        detail={"agreement": method_agreement(groups)},
    )


#: why a method's height results judge nothing: its references give plane only (a fixed phrase)
NO_REF_Z = "ref_z_m empty on all these checkpoints (plane-only references), so no height error"
#: why a method's plane results judge nothing: its references give heights only
NO_REF_XY = (
    "ref_x_m and ref_y_m empty on all these checkpoints (height-only references), so no plane error"
)

#: checkpoints may lie this far beyond the bounding box of the block's footprints in its
#: projection (metres, or this share of the box's larger side): farther, they are in another
#: unit or CRS than the block's metres, and their differences would be judged as metres
BLOCK_MARGIN_M = 5000.0
BLOCK_MARGIN_SHARE = 0.25


def beyond_block(d: Delivery) -> str | None:
    """Why the checkpoints' positions cannot be metres in the block's projection (None when
    they lie about its scenes' footprints, or the block gives no projected CRS to say)."""
    from blockqc.metrics.spatial_ref import delivered_epsg

    box = _footprint_box(d, delivered_epsg(d.manifest.spatial_reference))
    if box is None:
        return None
    code, x0, x1, y0, y1 = box
    margin = max(BLOCK_MARGIN_M, BLOCK_MARGIN_SHARE * max(x1 - x0, y1 - y0))
    cp = d.checkpoints
    for xc, yc in (("x_m", "y_m"), ("ref_x_m", "ref_y_m")):
        if xc not in cp or yc not in cp:
            continue
        x, y = cp[xc].to_numpy(dtype=float), cp[yc].to_numpy(dtype=float)
        with np.errstate(invalid="ignore"):
            out = (x < x0 - margin) | (x > x1 + margin) | (y < y0 - margin) | (y > y1 + margin)
        if out.any():
            i = int(np.flatnonzero(out)[0])
            return (
                f"{int(out.sum())} of {len(cp)} checkpoints have {xc}, {yc} outside the block "
                f"(its scenes' footprints span x {x0:.0f} to {x1:.0f}, y {y0:.0f} to {y1:.0f} "
                f"in EPSG:{code}, {margin:.0f} m about them), e.g. point "
                f"{cp['point_id'].iloc[i]} at ({x[i]:.6g}, {y[i]:.6g}): expected metres in "
                f"EPSG:{code} (degrees, kilometres or millimetres?)"
            )
    return None


def _footprint_box(d: Delivery, code: int | None) -> tuple | None:
    """The EPSG code and the bounding box (x0, x1, y0, y1) of the scenes' footprints in that
    projection; None without a projected CRS or footprints."""
    import shapely
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    if code is None or "footprint_wkt" not in d.scenes:
        return None
    try:
        crs = CRS.from_epsg(code)
    except CRSError:
        return None
    if not crs.is_projected:
        return None
    geoms = shapely.from_wkt(d.scenes["footprint_wkt"].to_numpy(dtype=object))
    lon, lat = shapely.get_coordinates(geoms).T
    x, y = Transformer.from_crs(4326, crs, always_xy=True).transform(lon, lat)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        return None
    return code, x[ok].min(), x[ok].max(), y[ok].min(), y[ok].max()


@metric(
    "reference_coverage",
    tie_points=(),
    detailed=True,
    params=CoverageParams,
    scopes={
        "block": Scope(
            {
                "conforms": "true/false",
                "n_reference_images": "images",
                "min_points_per_reference": "points",
            },
            columns=("enough_images", "supplemented"),
        ),
        "reference": Scope(
            {"conforms": "true/false", "n_points": "points"}, keys=("reference_id",)
        ),
    },
    param_units={"min_reference_images": "images", "points_per_reference": "points"},
)
def reference_coverage(d: Delivery, p: CoverageParams, measure: Measure) -> Measurement:
    """High-precision references: > 7 images with 3 checkpoints each, else supplemented (§CP-2)."""
    cp = d.checkpoints
    if cp is None or not (cp["method"] == p.method).any():
        return not_applicable(f"no {p.method} checkpoints")
    hp = cp[cp["method"] == p.method]
    per_ref = hp.groupby("reference_id", sort=True)["point_id"].nunique().rename("n_points")
    per_ref = per_ref.reset_index()
    per_ref["conforms"] = per_ref["n_points"] >= p.points_per_reference
    errors = checkpoint_errors(cp)
    checked = errors.groupby("method")["component"].unique()
    own = set(checked.get(p.method, []))
    others = (
        set().union(*[set(v) for m, v in checked.items() if m != p.method])
        if len(checked) > 1
        else set()
    )
    enough_images = len(per_ref) >= p.min_reference_images
    supplemented = own <= others
    conforms = bool(per_ref["conforms"].all() and (enough_images or supplemented))
    block = pd.DataFrame(
        {
            "n_reference_images": [len(per_ref)],
            "min_points_per_reference": [int(per_ref["n_points"].min())],
            "enough_images": [enough_images],
            "supplemented": [supplemented],
            "conforms": [conforms],
        }
    )
    return Measurement(
        tables={
            "block": Table(block),
            "reference": Table(per_ref, keys=["reference_id"], sort="n_points"),
        }
    )
