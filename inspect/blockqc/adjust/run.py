"""`blockqc adjust` end to end (§RC-3): read, fix the datum, adjust, compare, write.

Every output is made from the solution; the HTML page is rendered from adjust.json and the
tables written beside it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from blockqc.adjust.geometry import RPCStack, intersect, ray_tilts
from blockqc.adjust.inputs import AdjustInput, load_adjust_input
from blockqc.adjust.solver import BLOCK, Observations, Priors, Settings, Solution, adjust
from blockqc.errors import InputError, Problem
from blockqc.grouped import Groups
from blockqc.metrics.checkpoints import AccuracyParams
from blockqc.outputs import check_out_dir
from blockqc.report.messages import translator
from blockqc.rfm.model import lon_extent, wrap_lon

if TYPE_CHECKING:
    from blockqc.rfm.dem import DEM

#: the catalogue's English: the run's warnings are its texts (Formatter.sentence translates them)
EN = translator("en")

DEFAULT_DEM_SIGMA_M = 10.0
"""σ of a DEM height prior: SRTM's ~16 m absolute LE90 is ≈ 10 m at 1σ."""


@dataclass
class AdjustConfig:
    delivery: Path
    out: Path
    dem: Path | None = None
    geoid: Path | None = None
    dem_vertical: str = "geoid"
    dem_sigma_m: float = DEFAULT_DEM_SIGMA_M
    fix: tuple[str, ...] = ()
    sigma_shift_px: float = 10.0
    sigma_linear_px: float = 2.0
    settings: Settings = field(default_factory=Settings)
    checkpoints: int = 30
    lang: str = "en"
    """Language of adjust.html and the figures (en, zh); adjust.json is the same in either."""

    def inputs(self) -> list[Path]:
        """The delivery, the DEM and the geoid grid given (--out must lie outside them)."""
        return [p for p in (self.delivery, self.dem, self.geoid) if p is not None]


@dataclass
class Block:
    """The delivery read, observations indexed and sorted by scene."""

    data: AdjustInput
    stack: RPCStack
    obs: Observations
    rows: np.ndarray  # tie_points row of each (sorted) observation
    point_ids: np.ndarray
    lines: np.ndarray
    samples: np.ndarray


def index_block(data: AdjustInput) -> Block:
    """Scene and point indices per observation, sorted by scene (stable)."""
    ties = data.tie_points
    scene_ids = [str(s) for s in data.scenes["scene_id"]]
    scene_of = {s: i for i, s in enumerate(scene_ids)}
    scene = ties["scene_id"].astype(str).map(scene_of).to_numpy(np.int64)
    point, point_ids = pd.factorize(ties["point_id"].astype(str))
    order = np.argsort(scene, kind="stable")
    obs = Observations(
        scene=scene[order],
        point=point[order].astype(np.int64),
        line=ties["line"].to_numpy(np.float64)[order],
        sample=ties["sample"].to_numpy(np.float64)[order],
        n_scenes=len(scene_ids),
        n_points=len(point_ids),
    )
    lines = data.scenes["lines"].to_numpy(np.float64)
    samples = data.scenes["samples"].to_numpy(np.float64)
    stack = RPCStack.from_models(data.models)
    return Block(data, stack, obs, order, np.asarray(point_ids), lines, samples)


def weak_height_prior(stack: RPCStack, n_points: int) -> tuple[np.ndarray, np.ndarray, str]:
    """The height prior of n points without a DEM: the block's mean height at the mean RPC
    HEIGHT_OFF ± the largest HEIGHT_SCALE, as one observation. Each point gets σ·√n, so that
    the n priors together weigh as that one: a prior of σ on every point, summed over thousands
    of points, outweighed the affine priors and pulled the block to HEIGHT_OFF."""
    h0 = float(np.mean(stack.offsets[:, 4]))
    sig = float(np.max(np.abs(stack.scales[:, 4])))
    each = sig * np.sqrt(max(n_points, 1))
    text = (
        f"weak height prior: the block's mean height {h0:.1f} ± {sig:.1f} m (mean HEIGHT_OFF ± "
        f"largest HEIGHT_SCALE), ± {each:.1f} m at each of its {n_points} points"
    )
    return np.full(n_points, h0), np.full(n_points, each), text


def height_priors(block: Block, cfg: AdjustConfig) -> tuple[np.ndarray, np.ndarray, str]:
    """Per point height prior: the DEM under the point (two passes of intersection on the
    DEM), or the weak prior from the RPC height range where there is no DEM value. A DEM that
    gives no height at any point is refused, as `rfm-accuracy` refuses one under no pixel; when
    no point's rays intersect at all, the weak prior is kept and the adjustment refuses the
    block for its RPCs (`solver.refuse_without_intersection`), not the DEM."""
    h, sig, text = weak_height_prior(block.stack, block.obs.n_points)
    if cfg.dem is None:
        return h, sig, text
    obs = block.obs
    on = np.zeros(obs.n_points, bool)
    box = None
    for _ in range(2):
        res = intersect(
            block.stack,
            np.zeros((obs.n_scenes, 6)),
            obs.scene,
            obs.point,
            obs.line,
            obs.sample,
            height_prior=(h, sig),
        )
        if box is None and not res.converged.any():  # no rays meet: the RPCs are refused
            return h, sig, text
        ok = np.isfinite(res.lon) & np.isfinite(res.lat)
        if not ok.any():
            break
        box = _points_box(res.lon[ok], res.lat[ok])
        dem = _load_dem(cfg, box)
        dem_h = dem.height(np.where(ok, res.lon, 0.0), np.where(ok, res.lat, 0.0))
        here = ok & np.isfinite(dem_h)
        h = np.where(here, dem_h, h)
        sig = np.where(here, cfg.dem_sigma_m, sig)
        on |= here
    if not on.any():
        raise InputError(Problem(str(cfg.dem), _no_height(obs.n_points, box)))
    rest = int(np.count_nonzero(~on))  # the points the weak prior is left to
    _, weak, text = weak_height_prior(block.stack, rest)
    sig = np.where(on, sig, weak[0] if rest else 0.0)
    text = (
        f"DEM height prior ± {cfg.dem_sigma_m:g} m from {Path(cfg.dem).name} ({dem.vertical}) "
        f"at {int(on.sum())} of {obs.n_points} points" + (f"; elsewhere {text}" if rest else "")
    )
    return h, sig, text


def _points_box(lon: np.ndarray, lat: np.ndarray) -> tuple[float, float, float, float]:
    """West, south, east, north of the points with a margin of 0.05°: the shortest arc of
    longitude (a block across ±180° spans 179.9…180.1, east beyond 180, not the globe)."""
    west, east = lon_extent(lon)
    return west - 0.05, float(lat.min()) - 0.05, east + 0.05, float(lat.max()) + 0.05


def _load_dem(cfg: AdjustConfig, bounds: tuple[float, float, float, float]) -> DEM:
    """The DEM over `bounds` as ellipsoidal heights (adjust has no --geoid-offset)."""
    from blockqc.rfm.dem import load_dem

    return load_dem(
        cfg.dem, geoid=cfg.geoid, vertical=cfg.dem_vertical, bounds=bounds, offset_option=None
    )


def _no_height(n_points: int, box: tuple[float, ...] | None) -> str:
    where = (
        ""
        if box is None
        else (
            f" (lon {box[0] + 0.05:.4f}..{wrap_lon(box[2] - 0.05):.4f}, lat {box[1] + 0.05:.4f}.."
            f"{box[3] - 0.05:.4f})"
        )
    )
    return (
        f"the DEM gives a height at none of the block's {n_points} tie points{where}: it is void "
        "there or does not cover the block (expected a DEM with heights under the block)"
    )


def datum(block: Block, cfg: AdjustConfig) -> tuple[Priors, dict]:
    """The priors that fix the datum without GCPs, and their description for adjust.json."""
    scene_ids = [str(s) for s in block.data.scenes["scene_id"]]
    _check_fixed(block, cfg.fix, scene_ids)
    for name, value in (("shift", cfg.sigma_shift_px), ("linear", cfg.sigma_linear_px)):
        if not value > 0:
            raise InputError(Problem("<options>", f"--sigma-{name} must be > 0, got {value}"))
    fixed = np.array([s in cfg.fix for s in scene_ids])
    _check_free_scenes(block, cfg, fixed, scene_ids)
    h, sig, text = height_priors(block, cfg)
    priors = Priors(cfg.sigma_shift_px, cfg.sigma_linear_px, fixed, h, sig, text)
    desc = {
        "affine_priors": (
            f"a-priori RPC accuracy: σ {cfg.sigma_shift_px:g} px for a0, b0 (shift at the image "
            f"centre), σ {cfg.sigma_linear_px:g} px at the image edge for the linear terms"
        ),
        "sigma_shift_px": cfg.sigma_shift_px,
        "sigma_linear_px": cfg.sigma_linear_px,
        "fixed_scenes": list(cfg.fix),
        "height_prior": text,
        "ground_control_points": 0,
    }
    return priors, desc


def _check_fixed(block: Block, fix: tuple[str, ...], scene_ids: list[str]) -> None:
    """Refuse --fix naming a scene the block does not have, or one left out of it (no
    tie-point observation: it takes no part in the adjustment)."""
    unknown = [s for s in fix if s not in scene_ids and s not in block.data.left_out]
    out = [s for s in fix if s in block.data.left_out]
    problems = [Problem(str(block.data.path / "scenes.csv"), f"--fix: unknown scene(s) {unknown}")]
    problems = problems if unknown else []
    if out:
        problems.append(
            Problem(
                str(block.data.tie_points_file or block.data.path),
                f"--fix: scene(s) {', '.join(out)} have no tie-point observation: they take no "
                "part in the adjustment (left out), so there is nothing to hold",
            )
        )
    if problems:
        raise InputError(problems)


def _check_free_scenes(
    block: Block, cfg: AdjustConfig, fixed: np.ndarray, scene_ids: list[str]
) -> None:
    """With an infinite a-priori σ, a scene's free terms are fixed by its observations alone: a
    scene (not held by --fix) with fewer observations of points on two or more scenes than
    they need (a shift 1, the six terms 3) makes the block singular; name it."""
    free_linear = not np.isfinite(cfg.sigma_linear_px)
    if np.isfinite(cfg.sigma_shift_px) and not free_linear:
        return
    obs = block.obs
    multi = np.bincount(obs.point, minlength=obs.n_points)[obs.point] >= 2
    count = np.bincount(obs.scene[multi], minlength=obs.n_scenes)
    need = 3 if free_linear else 1
    short = np.flatnonzero((count < need) & ~fixed)
    if short.size == 0:
        return
    listed = ", ".join(f"{scene_ids[k]} ({count[k]})" for k in short[:10])
    more = f" and {short.size - 10} more" if short.size > 10 else ""
    option = "--sigma-linear" if free_linear else "--sigma-shift"
    raise InputError(
        Problem(
            str(block.data.tie_points_file or block.data.path),
            f"scene(s) {listed}{more} have too few observations of points seen on two or more "
            f"scenes to fix their affine, which {option} inf leaves free: expected at least "
            f"{need} per scene; give a finite {option} or --fix these scenes",
        )
    )


def delivered_ground(block: Block) -> tuple[np.ndarray, ...] | None:
    """The producer's ground point per point from tie_points lon/lat/h, if delivered: the first
    value given on the point's rows (they agree: `inputs` refuses rows that do not)."""
    obs, ties = block.obs, block.data.tie_points
    if not all(c in ties.columns for c in ("lon", "lat", "h")):
        return None
    out = []
    for c in ("lon", "lat", "h"):
        v = ties[c].to_numpy(np.float64)[block.rows]
        given = np.flatnonzero(np.isfinite(v))
        points, first = np.unique(obs.point[given], return_index=True)
        value = np.full(obs.n_points, np.nan)
        value[points] = v[given[first]]
        out.append(value)
    return tuple(out) if np.isfinite(out[2]).any() else None


def producer_ground(
    block: Block, priors: Priors, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """The producer's adjusted ground position of the given points: the delivered lon/lat/h,
    else the intersection of their rays with the producer's adjusted geometry (NaN where
    neither is available)."""
    delivered = delivered_ground(block)
    if delivered is not None:
        lon, lat, h = (v[points] for v in delivered)
        return lon, lat, h, "tie_points.csv lon, lat, h (delivered)"
    data, obs = block.data, block.obs
    nan = np.full(points.size, np.nan)
    if data.producer_models is None or data.producer_affine is None or points.size == 0:
        return nan, nan, nan, "none (no lon/lat/h in tie_points and no producer adjustment)"
    local = np.full(obs.n_points, -1)
    local[points] = np.arange(points.size)
    sel = np.flatnonzero(local[obs.point] >= 0)
    res = intersect(
        RPCStack.from_models(data.producer_models),
        data.producer_affine,
        obs.scene[sel],
        local[obs.point[sel]],
        obs.line[sel],
        obs.sample[sel],
        height_prior=(priors.height[points], priors.height_sigma[points]),
    )
    ok = res.converged
    lon, lat, h = (np.where(ok, v, np.nan) for v in (res.lon, res.lat, res.h))
    return lon, lat, h, f"intersection with the producer's adjustment ({data.producer_source})"


def projected_crs(block: Block, lon: np.ndarray, lat: np.ndarray) -> tuple[int, str]:
    """The block's projected CRS (block.yaml spatial_reference.epsg), else the UTM zone."""
    from pyproj import CRS

    from blockqc.rfm.ortho import units_not_metres, utm_ups_crs

    sr = block.data.manifest.spatial_reference
    feet = None
    if sr is not None and sr.epsg is not None:
        crs = CRS.from_epsg(sr.epsg)
        metres = not units_not_metres(crs)
        if crs.is_projected and metres:
            return int(sr.epsg), "block.yaml spatial_reference.epsg"
        if crs.is_projected:  # checkpoints are x_m, y_m: not feet
            feet = sr.epsg
    # the median longitude about the block's west end: across ±180° (179.9…180.1 written as
    # 179.9 and −179.9) the longitudes' own median may fall near 0°
    west = lon_extent(lon[np.isfinite(lon)])[0]
    centre = west + float(np.nanmedian(np.mod(lon - west, 360.0)))
    epsg = int(utm_ups_crs(centre, float(np.nanmedian(lat))).to_epsg())
    key = "ad_crs_ups" if epsg in (32661, 32761) else "ad_crs_utm"
    return epsg, EN(key) if feet is None else EN(f"{key}_not_metres", epsg=feet)


def spread_points(x: np.ndarray, y: np.ndarray, weight: np.ndarray, n: int) -> np.ndarray:
    """Indices of up to n well-spread points: a g×g grid over their extent, one per cell (the
    highest weight, then the nearest the cell centre), the heaviest cells first (§CP-1)."""
    if x.size == 0 or n <= 0:
        return np.zeros(0, np.int64)
    g = int(np.ceil(np.sqrt(n)))
    x0, x1, y0, y1 = x.min(), x.max(), y.min(), y.max()
    cx = np.minimum(((x - x0) / max(x1 - x0, 1e-9) * g).astype(int), g - 1)
    cy = np.minimum(((y - y0) / max(y1 - y0, 1e-9) * g).astype(int), g - 1)
    cell = cy * g + cx
    centre_x = x0 + (cx + 0.5) * (x1 - x0) / g
    centre_y = y0 + (cy + 0.5) * (y1 - y0) / g
    dist = np.hypot(x - centre_x, y - centre_y)
    order = np.lexsort((dist, -weight, cell))
    _, first = np.unique(cell[order], return_index=True)
    chosen = order[first]
    chosen = chosen[np.lexsort((dist[chosen], -weight[chosen]))][:n]
    return np.sort(chosen)


def checkpoints(block: Block, sol: Solution, priors: Priors, n: int) -> tuple[pd.DataFrame, dict]:
    """§CP-1/§RC-3: the producer's position against the recalculated one at n spread points."""
    from pyproj import Transformer

    nobs = np.bincount(block.obs.point, (~sol.outlier).astype(float), block.obs.n_points)
    ok = sol.point_used & np.isfinite(sol.lon) & np.isfinite(sol.h)
    delivered = delivered_ground(block)
    if delivered is not None:
        ok &= np.isfinite(delivered[0]) & np.isfinite(delivered[2])
    epsg, crs_source = projected_crs(block, sol.lon[sol.point_used], sol.lat[sol.point_used])
    cand = np.flatnonzero(ok)
    tr = Transformer.from_crs(4326, epsg, always_xy=True)
    x, y = tr.transform(sol.lon[cand], sol.lat[cand])
    pick = cand[spread_points(np.asarray(x), np.asarray(y), nobs[cand], n)]
    p_lon, p_lat, p_h, source = producer_ground(block, priors, pick)
    good = np.isfinite(p_lon) & np.isfinite(p_lat) & np.isfinite(p_h)
    pick, p_lon, p_lat, p_h = pick[good], p_lon[good], p_lat[good], p_h[good]
    info = {"producer_positions": source, "epsg": epsg, "crs_source": crs_source}
    px, py = tr.transform(p_lon, p_lat)
    rx, ry = tr.transform(sol.lon[pick], sol.lat[pick])
    table = pd.DataFrame(
        {
            "point_id": block.point_ids[pick],
            "method": "recalculation",
            "reference_id": "blockqc-adjust",
            "x_m": np.round(px, 3),
            "y_m": np.round(py, 3),
            "z_m": np.round(p_h, 3),
            "ref_x_m": np.round(rx, 3),
            "ref_y_m": np.round(ry, 3),
            "ref_z_m": np.round(sol.h[pick], 3),
        }
    )
    info["n"] = int(len(table))
    if warning := checkpoint_warning(len(table)):
        info["warning"] = warning
    return table, info


def checkpoint_warning(n: int) -> str | None:
    """That too few of the points could be compared with the producer's (§CP-1 asks for 20–50),
    if so."""
    if n == 0:
        return EN("ad_cps_none")
    return EN("ad_cps_few", n=n) if n < 20 else None


@contextlib.contextmanager
def named_block(delivery: Path) -> Iterator[None]:
    """The adjustment's own problems (a singular system, a point its rays do not fix) named by
    the delivery they are of, where the solver, which sees no files, names the block."""
    try:
        yield
    except InputError as exc:
        problems = [
            dataclasses.replace(p, file=str(delivery)) if p.file == BLOCK else p
            for p in exc.problems
        ]
        raise InputError(problems) from None


def run_adjust(cfg: AdjustConfig) -> dict:
    """Read, adjust, compare and write every output; returns adjust.json's content."""
    from blockqc.adjust.outputs import write_outputs

    t0 = time.perf_counter()
    clock = Clock()
    block = index_block(load_adjust_input(cfg.delivery))
    clock.lap("read")
    priors, datum_desc = datum(block, cfg)
    out = check_out_dir(cfg.out, cfg.inputs())  # created once the inputs (DEM too) are read
    clock.lap("datum")
    with named_block(cfg.delivery):
        sol, v0l, v0s = adjust(
            block.stack, block.obs, block.lines, block.samples, priors, cfg.settings
        )
    clock.lap("adjust")
    _refuse_without_redundancy(block, sol, cfg.settings)
    cps, cp_info = checkpoints(block, sol, priors, cfg.checkpoints)
    bh = base_to_height(block, sol)
    clock.lap("checkpoints")
    summary = summarize(block, sol, v0l, v0s, datum_desc, cp_info)
    summary["base_to_height"] = _spread(bh[sol.point_used])
    summary["warnings"] += height_warnings(bh, sol, priors, cfg.dem_sigma_m, cps, block.point_ids)
    summary["warnings"] += datum_warnings(sol)
    summary["warnings"] += prior_warnings(sol, priors, summary["scenes"])
    summary["warnings"] += held_warnings(priors)
    summary["settings"] = dataclasses.asdict(cfg.settings)
    summary["settings"]["sigma_image_px_estimated"] = sol.sigma_image_px
    summary["seconds"] = round(time.perf_counter() - t0, 2)
    summary["timings"] = clock.laps
    write_outputs(out, block, sol, cps, summary, np.hypot(v0l, v0s), bh, cfg.lang)
    return summary


def _spread(values: np.ndarray) -> dict[str, float | None]:
    """Minimum, median and maximum of the finite values (None when there are none)."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return {"min": None, "median": None, "max": None}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}


#: base-to-height ratio below which a point's rays leave its height to the priors (stereo pairs:
#: 0.3–1; side overlap of neighbouring strips of one orbit: a few hundredths)
MIN_BASE_TO_HEIGHT = 0.05


def base_to_height(block: Block, sol: Solution) -> np.ndarray:
    """Per point, the base-to-height ratio of its kept rays: the span of their tilts
    (`ray_tilts`; the diagonal of their east and north ranges, exact for two rays and at most
    √2 times the widest pair's for more); NaN for a point not used."""
    obs = block.obs
    kept = ~sol.outlier & sol.point_used[obs.point]
    p = obs.point[kept]
    tilt = ray_tilts(block.stack, obs.scene[kept], sol.lon[p], sol.lat[p], sol.h[p])
    per_point = Groups(p, obs.n_points)
    (east_lo, east_hi), (north_lo, north_hi) = (per_point.extremes(t) for t in tilt.T)
    seen = per_point.counts() > 0
    return np.where(seen, np.hypot(east_hi - east_lo, north_hi - north_lo), np.nan)


def height_warnings(
    bh: np.ndarray, sol: Solution, priors: Priors, dem_sigma_m: float, cps: pd.DataFrame,
    point_ids: np.ndarray,
) -> list[str]:  # fmt: skip
    """Points whose rays meet at too narrow an angle for a height and that no DEM prior holds:
    their heights are the weak prior's, and so are the height checkpoints among them."""
    narrow = sol.point_used & (bh < MIN_BASE_TO_HEIGHT) & (priors.height_sigma > dem_sigma_m)
    if not narrow.any():
        return []
    n, used = int(narrow.sum()), int(sol.point_used.sum())
    among = int(np.isin(cps["point_id"].to_numpy(str), point_ids[narrow].astype(str)).sum())
    med_bh = float(np.median(bh[narrow]))
    med_sigma = float(np.median(sol.ground_sigma[narrow, 2]))
    values = {"median": f"{med_bh:.3f}", "sigma": f"{med_sigma:.0f}", "among": among}
    return [EN("ad_warn_narrow_rays", n=n, used=used, min=f"{MIN_BASE_TO_HEIGHT:g}", **values)]


#: §CP-N's plane norm m and §CP-4's bound of the recalculation method's checkpoints, 2√2·m, as
#: the checkpoint rules take them: recalculated points whose own plane σ is beyond the bound
#: check no producer's position
PLANE_NORM_M = AccuracyParams().plane_norm_m
DATUM_MAX_SIGMA_M = AccuracyParams().tolerance_factor["recalculation"] * PLANE_NORM_M


def datum_warnings(sol: Solution) -> list[str]:
    """A datum the priors barely hold (σ of the affine parameters very large, or infinite on all
    scenes but one fixed): the block moves freely, its points' σ run to hundreds of metres."""
    used = sol.point_used
    if not used.any():
        return []
    sigma = sol.ground_sigma[used]
    plane = float(np.median(np.hypot(sigma[:, 0], sigma[:, 1])))
    if not plane > DATUM_MAX_SIGMA_M:
        return []
    height = float(np.median(sigma[:, 2]))
    values = {"plane": f"{plane:.3g}", "height": f"{height:.3g}", "max": f"{DATUM_MAX_SIGMA_M:.1f}"}
    return [EN("ad_warn_datum", norm=f"{PLANE_NORM_M:g}", **values)]


#: an estimated affine parameter beyond this many times its a-priori σ is no RPC bias the
#: priors believe in: a scene given another's RPC, or image coordinates not in its pixels (a
#: SkySat pair with its RPC files swapped: a shift of 320 px against a σ of 10 px)
PRIOR_EXCESS = 5.0
PRIOR_NAMED = 5  # scenes the warning names, the farthest beyond first


def prior_warnings(sol: Solution, priors: Priors, scenes: list[dict]) -> list[str]:
    """Scenes whose estimated affine lies far beyond its a-priori σ (`PRIOR_EXCESS` times): the
    shift at the image centre against --sigma-shift, a linear term (px at the image edge)
    against --sigma-linear; one warning naming the farthest, each with its multiple of σ."""
    p = sol.normalized
    size = np.stack([np.hypot(p[:, 0], p[:, 3]), np.abs(p[:, [1, 2, 4, 5]]).max(axis=1)], 1)
    sigma = np.array([priors.sigma_shift_px, priors.sigma_linear_px])
    ratio = np.where(priors.fixed, 0.0, (size / sigma).max(axis=1))
    beyond = np.flatnonzero(ratio > PRIOR_EXCESS)
    if beyond.size == 0:
        return []
    beyond = beyond[np.argsort(-ratio[beyond], kind="stable")]
    named = "; ".join(f"{scenes[k]['scene_id']} ({ratio[k]:.0f} σ)" for k in beyond[:PRIOR_NAMED])
    more = beyond.size - min(beyond.size, PRIOR_NAMED)
    key = "ad_warn_prior_more" if more else "ad_warn_prior"
    return [EN(key, n=beyond.size, excess=f"{PRIOR_EXCESS:g}", named=named, more=more)]


def held_warnings(priors: Priors) -> list[str]:
    """Every scene held (--fix): nothing is adjusted, the points are the original RPCs'
    intersections and the checkpoints compare the producer with the RPCs as delivered."""
    if priors.fixed.size == 0 or not priors.fixed.all():
        return []
    return [EN("ad_warn_all_held", n=int(priors.fixed.size))]


def _refuse_without_redundancy(block: Block, sol: Solution, settings: Settings) -> None:
    """No output of an adjustment whose σ0 cannot be estimated (every observation rejected, or
    too few left for any redundancy): its figures would be no estimate. When the rule rejected
    nothing, the tie points are too few for the unknowns and their file is named."""
    if np.isfinite(sol.sigma0_px):
        return
    kept, n = int((~sol.outlier).sum()), sol.outlier.size
    if sol.rejected.any():
        raise InputError(
            Problem(
                "<options>",
                f"σ0 cannot be estimated: {kept} of {n} observations are kept after rejection "
                f"(--reject {settings.reject_k:g}), which leaves the adjustment no redundancy; "
                "--reject below about 3 rejects good observations (default 4), and a block "
                "needs points seen on two or more scenes",
            )
        )
    points, scenes = int(sol.point_used.sum()), int(np.unique(block.obs.scene[~sol.outlier]).size)
    raise InputError(
        Problem(
            str(block.data.tie_points_file or block.data.path),
            f"σ0 cannot be estimated: the {kept} observations of the {points} point(s) seen on two "
            f"or more scenes ({2 * kept} equations) leave no redundancy over their 3 coordinates "
            f"each and the 6 affine parameters of each of the {scenes} scenes they are on; "
            "expected more tie points, each on two or more scenes",
        )
    )


class Clock:
    """Wall and processor seconds of each phase (the machine may be shared)."""

    def __init__(self) -> None:
        self.laps: dict[str, dict[str, float]] = {}
        self._wall, self._cpu = time.perf_counter(), time.process_time()

    def lap(self, name: str) -> None:
        wall, cpu = time.perf_counter(), time.process_time()
        self.laps[name] = {
            "wall_s": round(wall - self._wall, 2),
            "cpu_s": round(cpu - self._cpu, 2),
        }
        self._wall, self._cpu = wall, cpu


def _rms(vl: np.ndarray, vs: np.ndarray, mask: np.ndarray) -> float | None:
    v2 = (vl**2 + vs**2)[mask]
    v2 = v2[np.isfinite(v2)]
    return float(np.sqrt(v2.mean())) if v2.size else None


def per_scene(block: Block, sol: Solution) -> list[dict]:
    """Per scene: observations kept, outliers (rejected by the rule), observations left without
    a second ray, residual RMS, the affine and its σ."""
    obs, kept = block.obs, ~sol.outlier
    ns = obs.n_scenes
    n_kept = np.bincount(obs.scene, kept.astype(float), ns)
    n_out = np.bincount(obs.scene, sol.rejected.astype(float), ns)
    n_single = np.bincount(obs.scene, (sol.outlier & ~sol.rejected).astype(float), ns)
    v2 = np.where(kept, sol.v_line**2 + sol.v_sample**2, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt(np.bincount(obs.scene, v2, ns) / n_kept)
    keys = ("a0", "a1", "a2", "b0", "b1", "b2")
    rows = []
    for k, sid in enumerate(block.data.scenes["scene_id"].astype(str)):
        row = {"scene_id": sid, "n_observations": int(n_kept[k]), "n_outliers": int(n_out[k])}
        row["n_without_second_ray"] = int(n_single[k])
        row["rms_px"] = float(rms[k]) if np.isfinite(rms[k]) else None
        row.update({key: float(sol.affine[k, i]) for i, key in enumerate(keys)})
        row.update({f"sigma_{key}": float(sol.affine_sigma[k, i]) for i, key in enumerate(keys)})
        row["sigma_shift_centre_px"] = float(np.hypot(*sol.normalized_sigma[k, [0, 3]]))
        rows.append(row)
    return rows


MIN_SCENE_OBSERVATIONS = 3
"""Kept observations a scene needs for its affine (6 parameters, 2 equations each)."""


def left_out_warnings(left_out: list[str]) -> list[str]:
    """The scenes of scenes.csv left out of the adjustment: without a tie-point observation
    nothing ties them to the block, whatever their RPC (`inputs.load_adjust_input`)."""
    if not left_out:
        return []
    shown = ", ".join(left_out[:10]) + (" …" if len(left_out) > 10 else "")
    return [EN("ad_warn_left_out", scenes=shown, n=len(left_out))]


def scene_warnings(scenes: list[dict]) -> list[str]:
    """Scenes whose affine the data do not determine: too few observations kept."""
    out = []
    for row in scenes:
        kept = row["n_observations"]
        rejected = row["n_outliers"] + row["n_without_second_ray"]
        if kept >= MIN_SCENE_OBSERVATIONS:
            continue
        if kept + rejected == 0:
            why = EN("ad_warn_scene_empty")
        else:
            counts = {"outliers": row["n_outliers"], "single": row["n_without_second_ray"]}
            total = kept + rejected
            why = EN(
                "ad_warn_scene_few", kept=kept, total=total, min=MIN_SCENE_OBSERVATIONS, **counts
            )
        out.append(EN("ad_warn_scene", scene=row["scene_id"], why=why))
    return out


#: σ0 beyond this (px) is no tie-point measurement precision (0.2–0.5 px for real blocks): the
#: RPCs and the tie points do not fit one another
MAX_SIGMA0_PX = 5.0


def fit_warnings(summary: dict) -> list[str]:
    """What makes the adjustment's figures (`summarize`'s) no estimate of the block, though it
    converged: a σ0 far above any measurement precision, residuals larger after than before, no
    checkpoint."""
    out = []
    sigma0 = summary["sigma0_px"]
    if sigma0 > MAX_SIGMA0_PX:
        out.append(EN("ad_warn_sigma0", sigma0=f"{sigma0:.3g}", max=f"{MAX_SIGMA0_PX:g}"))
    before, after = summary["rms_px_before"], summary["rms_px_after"]
    if after > before * (1 + 1e-6) + 1e-9:  # grown, not 4e-10 px of rounding (all held fixed)
        out.append(EN("ad_warn_rms_grew", before=f"{before:.3f}", after=f"{after:.3f}"))
    if summary["checkpoints"].get("warning"):
        out.append(summary["checkpoints"]["warning"])
    return out


def summarize(
    block: Block,
    sol: Solution,
    v0l: np.ndarray,
    v0s: np.ndarray,
    datum_desc: dict,
    cp_info: dict,
) -> dict:
    """adjust.json: the counts, convergence, σ0, residual RMS before/after and the datum."""
    kept = ~sol.outlier
    scenes = per_scene(block, sol)
    out = {
        "block_id": block.data.manifest.block_id,
        "delivery": str(block.data.path),
        "n_scenes": block.obs.n_scenes,
        "n_points": int(sol.point_used.sum()),
        "n_points_in_delivery": block.obs.n_points,
        "n_observations": int(kept.sum()),
        "n_observations_in_delivery": int(kept.size),
        "iterations": sol.iterations,
        "converged": bool(sol.converged),
        "sigma0_px": sol.sigma0_px,
        "rms_px_before": _rms(v0l, v0s, kept),
        "rms_px_after": _rms(sol.v_line, sol.v_sample, kept),
        "n_outliers": int(sol.rejected.sum()),
        "n_without_second_ray": int((sol.outlier & ~sol.rejected).sum()),
        "outlier_rule": "|v| > k·σ0 after a Huber IRLS pass, the largest of each point in a "
        "round, and observations of points left with fewer than two (k in settings); "
        "n_outliers counts the first, n_without_second_ray the second",
        "datum": datum_desc,
        "checkpoints": cp_info,
        "producer_adjustment": block.data.producer_source,
        "history": sol.history,
        "scenes": scenes,
        "scenes_not_adjusted": [
            {"scene_id": sid, "reason": EN("ad_warn_scene_empty")} for sid in block.data.left_out
        ],
        "warnings": [
            *block.data.read_warnings,
            *left_out_warnings(block.data.left_out),
            *scene_warnings(scenes),
        ],
        "residual_convention": "v = computed − measured, image pixels (contract v1.1)",
    }
    out["warnings"] += fit_warnings(out)
    return out
