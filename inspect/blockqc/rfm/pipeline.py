"""§RA end to end: correct the image (§RA-1), bring the reference onto its grid (§RA-2), match
(§RA-3, one call), measure (§RA-4..6) and write the CP table, results.json, plots and HTML.

Every output is made from the results of the step before: the HTML page is rendered from
results.json only (`blockqc.rfm.report`).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from pyproj import CRS, Transformer

from blockqc.errors import InputError, Problem
from blockqc.matching.settings import MatchSettings
from blockqc.outputs import write_bytes_atomic, write_json_atomic, write_text_atomic
from blockqc.report.messages import translator
from blockqc.rfm import accuracy
from blockqc.rfm.dem import DEM, NotCovered, load_dem
from blockqc.rfm.footprint import (
    crop_problem,
    footprint_at,
    implausible_problem,
    off_dem_problem,
)
from blockqc.rfm.model import RefinedRFM, RPCModel, fit_affine
from blockqc.rfm.ortho import (
    OrthoGrid,
    band_mean,
    bands_used,
    centre_gsd,
    crop_offset_from_file,
    grey_bands,
    image_border,
    ortho_grid,
    orthorectify,
    read_ortho,
)
from blockqc.rfm.readers import (
    NO_RPCS,
    open_raster,
    read_rpc,
    read_rpc_gdal,
    reading_pixels,
    sniff_format,
)

Matcher = Callable[..., pd.DataFrame]

#: the catalogue's English: the run's warnings are its texts (Formatter.sentence translates them)
EN = translator("en")

CP_COLUMNS = [
    "cp_id",
    "kind",
    "score",
    "row",
    "col",
    "ref_row",
    "ref_col",
    "x_m",
    "y_m",
    "ref_x_m",
    "ref_y_m",
    "lon",
    "lat",
    "h_m",
    "ref_lon",
    "ref_lat",
    "ref_h_m",
    "line",
    "sample",
    "dx_m",
    "dy_m",
    "gev_px",
]
CHECKPOINT_COLUMNS = [
    "point_id",
    "method",
    "reference_id",
    "x_m",
    "y_m",
    "z_m",
    "ref_x_m",
    "ref_y_m",
    "ref_z_m",
]
METHODS = ("high_precision", "same_accuracy", "recalculation")
#: every file a run writes into its output folder (`_files`, results.json)
OUTPUT_NAMES = (
    "cps.csv",
    "refined_rfm.csv",
    "ortho.tif",
    "ortho_refined.tif",
    "reference_on_grid.tif",
    "error_vectors.png",
    "gev_histogram.png",
    "checkpoints.csv",
    "results.json",
    "report.html",
)


#: §RA-2 asks for a reference "of better accuracy": its pixels, at most this many times the
#: image's GSD, before the run warns that they limit what the matching can measure (the source
#: matched 2–6 m images against a reference of about 3 m)
REFERENCE_GSD_RATIO = 3.0


@dataclass
class RfmAccuracyConfig:
    """Everything one run needs; paths are the user's, the output folder must lie outside them."""

    image: Path
    dem: Path
    reference: Path
    out: Path
    rpc: Path | None = None
    geoid: str | Path | None = None
    """'egm96' (the shipped grid) or a geoid grid file."""
    geoid_offset: float | None = None
    """A constant geoid undulation N (m)."""
    dem_vertical: str = "auto"
    dem_fill: int = 0
    reference_rpc: Path | None = None
    crs: CRS | None = None
    gsd: float | None = None
    crop_offset: tuple[float, float] | None = None
    reference_crop_offset: tuple[float, float] | None = None
    ortho_chunk: int = 1024
    margin: int = 32
    match_chunk: int = 5000
    match_grid: int | None = None
    """Homogenization cell (px); None: chosen from the image size (`choose_cell`)."""
    ks: tuple[int, ...] = (6, 12, 16, 20)
    repeats: int = 100
    seed: int = 0
    requirement_px: float = accuracy.REQUIREMENT_PX
    distortion_threshold_px: float = accuracy.DISTORTION_THRESHOLD_PX
    reference_gsd_ratio: float = REFERENCE_GSD_RATIO
    """A warning when the reference's pixels are more than this many times the image's GSD."""
    method: str = "same_accuracy"
    export_checkpoints: bool = False
    refined_ortho: bool = False
    lang: str = "en"
    """Language of the page and the figures (en, zh); results.json is the same in either."""
    match_settings: dict[str, object] = field(default_factory=dict)


def default_matcher() -> Matcher:
    """The §RA-3 matcher of `blockqc.matching`."""
    from blockqc.matching import match_images

    return match_images


def _footprint_bounds(
    rpc: RPCModel, shape: tuple[int, int], offset: tuple[float, float], pad_deg: float
) -> tuple[float, float, float, float]:
    """lon/lat box of the image over the RPC's whole height range, padded (for DEM windows)."""
    br, bc = image_border(*shape, per_edge=16)
    lons, lats = [], []
    for h in (rpc.height_off - abs(rpc.height_scale), rpc.height_off + abs(rpc.height_scale)):
        lon, lat, _ = rpc.image_to_ground(br + offset[0], bc + offset[1], h)
        lons.append(lon)
        lats.append(lat)
    lon = np.concatenate(lons)
    lat = np.concatenate(lats)
    if not np.any(np.isfinite(lon)):
        raise InputError(Problem(file=rpc.source, message=_no_ground(rpc, shape, offset)))
    return (
        float(np.nanmin(lon)) - pad_deg,
        float(np.nanmin(lat)) - pad_deg,
        float(np.nanmax(lon)) + pad_deg,
        float(np.nanmax(lat)) + pad_deg,
    )


def _no_ground(rpc: RPCModel, shape: tuple[int, int], offset: tuple[float, float]) -> str:
    """Why the RPCs give the image no ground position: where its pixels fall in the model's
    image, against the part of it the RPCs describe (offset ± scale)."""

    def span(start: float, end: float) -> str:
        return f"{start:.10g}..{end:.10g}"

    line, samp = abs(rpc.line_scale), abs(rpc.samp_scale)
    return (
        "the RPCs give no ground position for the image: its rows "
        f"{span(offset[0], offset[0] + shape[0] - 1)}, columns "
        f"{span(offset[1], offset[1] + shape[1] - 1)} (crop offset {offset[0]:.10g}, "
        f"{offset[1]:.10g}), where the RPCs describe rows "
        f"{span(rpc.line_off - line, rpc.line_off + line)}, columns "
        f"{span(rpc.samp_off - samp, rpc.samp_off + samp)}: a wrong --crop-offset, or RPCs of "
        "another image?"
    )


def plane_per_height(rpc: RPCModel, shape: tuple[int, int], offset: tuple[float, float]) -> float:
    """Plane metres the image centre's ground position moves per metre of height error."""
    from pyproj import Geod

    row = np.array([shape[0] / 2.0 + offset[0]] * 2)
    col = np.array([shape[1] / 2.0 + offset[1]] * 2)
    lon, lat, _ = rpc.image_to_ground(row, col, np.array([rpc.height_off, rpc.height_off + 100.0]))
    _, _, dist = Geod(ellps="WGS84").inv(lon[0], lat[0], lon[1], lat[1])
    return float(dist) / 100.0


def image_without_height(
    rpc: RPCModel, shape: tuple[int, int], offset: tuple[float, float], dem: DEM, n: int = 64
) -> tuple[float, float]:
    """Shares of the image (n×n positions, taken to the ground at the DEM's mean height) outside
    the DEM and on its voids: those pixels stay empty in the ortho and give no CP."""
    rows, cols = np.meshgrid(
        np.linspace(0.0, shape[0] - 1.0, n) + offset[0],
        np.linspace(0.0, shape[1] - 1.0, n) + offset[1],
    )
    lon, lat, _ = rpc.image_to_ground(rows.ravel(), cols.ravel(), dem.mean_height)
    ok = np.isfinite(lon) & np.isfinite(lat)
    if not ok.any() or not np.isfinite(dem.mean_height):
        return 0.0, 0.0
    lon, lat = lon[ok], lat[ok]
    g = dem.grid
    cover = DEM(replace(g, values=np.ones_like(g.values)), "coverage")
    outside = ~np.isfinite(cover.height(lon, lat))
    void = ~outside & ~np.isfinite(dem.height(lon, lat))
    return float(outside.mean()), float(void.mean())


def _raster_shape(path: Path) -> tuple[tuple[int, int], bool]:
    with open_raster(path) as ds:
        return (ds.height, ds.width), ds.crs is not None


def rpcs_of(path: Path, rpc_file: Path | None, missing: str) -> RPCModel:
    """The RPCs of a raster: its `rpc_file`, else those GDAL finds for it (`missing`: the
    message when it has none)."""
    if rpc_file is not None:
        return read_rpc(rpc_file)
    if sniff_format(path) != "gdal":
        return read_rpc(path)  # not a raster: read as an RPC file, refused naming it
    return read_rpc_gdal(path, missing)


def reference_model(cfg: RfmAccuracyConfig) -> RPCModel | None:
    """The reference's RPCs when it is in sensor geometry or `reference_rpc` is given (None: a
    georeferenced reference, reprojected)."""
    _, georeferenced = _raster_shape(cfg.reference)
    if cfg.reference_rpc is not None or not georeferenced:
        missing = (
            "the reference carries no RPCs (no RPC tags, no RPC sidecar found by GDAL) and no "
            "CRS: expected a georeferenced orthoimage (with its CRS), or an image in sensor "
            "geometry with its RPCs (--reference-rpc FILE)"
        )
        return rpcs_of(cfg.reference, cfg.reference_rpc, missing)
    return None


def check_reference_crs(path: Path, grid_crs: CRS) -> None:
    """A georeferenced reference must be in a CRS that can be taken to the image's grid (an
    engineering CRS, or one of another body, cannot)."""
    from pyproj.exceptions import ProjError

    with open_raster(path) as ds:
        crs = CRS.from_wkt(ds.crs.to_wkt())
    try:
        Transformer.from_crs(crs, grid_crs, always_xy=True)
    except ProjError:
        raise InputError(
            Problem(
                file=str(path),
                message=f"its CRS ({crs.name}) cannot be transformed to the image grid's "
                f"({grid_crs.name}): a reference georeferenced on the Earth (a projected CRS "
                "such as a UTM zone, or EPSG:4326) is expected",
            )
        ) from None


def alpha_band(ds: Any) -> int:
    """The band a raster declares alpha (its transparent pixels have no data), 0 if none."""
    from rasterio.enums import ColorInterp

    alpha = [i for i, c in zip(ds.indexes, ds.colorinterp, strict=True) if c == ColorInterp.alpha]
    return alpha[0] if alpha else 0


def reference_gsd(cfg: RfmAccuracyConfig, grid: OrthoGrid, dem: DEM, rpc: RPCModel | None) -> float:
    """What one pixel of the reference covers (m, in the grid's CRS) at the grid's centre: the
    geometric mean of its two sides for a georeferenced reference, the GSD at its centre for
    one in sensor geometry (`rpc`)."""
    import rasterio

    if rpc is not None:
        shape, _ = _raster_shape(cfg.reference)
        offset = cfg.reference_crop_offset
        offset = crop_offset_from_file(cfg.reference) if offset is None else offset
        return float(centre_gsd(rpc, shape, offset, dem, grid))
    with rasterio.open(cfg.reference) as src:
        crs, t = CRS.from_wkt(src.crs.to_wkt()), src.transform
    x0, y0 = grid.transform * (grid.width / 2, grid.height / 2)
    there = Transformer.from_crs(grid.crs, crs, always_xy=True)
    back = Transformer.from_crs(crs, grid.crs, always_xy=True)
    col, row = ~t * there.transform(x0, y0)
    cols, rows = np.array([col, col + 1, col]), np.array([row, row, row + 1])
    x, y = back.transform(*(t * (cols, rows)))
    sides = np.hypot(x[1:] - x[0], y[1:] - y[0])
    return float(np.sqrt(sides[0] * sides[1]))


def reference_meets(path: Path, grid: OrthoGrid) -> bool:
    """Whether a georeferenced reference's extent meets the grid (its bounds taken to the grid's
    CRS), whatever its pixels hold."""
    import rasterio
    from rasterio.warp import transform_bounds

    with rasterio.open(path) as src:
        crs, bounds = src.crs, src.bounds
    west, south, east, north = transform_bounds(
        crs, rasterio.crs.CRS.from_wkt(grid.crs.to_wkt()), *bounds, densify_pts=21
    )
    x0, y1 = grid.transform * (0, 0)
    x1, y0 = grid.transform * (grid.width, grid.height)
    return bool(west < x1 and east > x0 and south < y1 and north > y0)


def reference_warning(cfg: RfmAccuracyConfig, ref_gsd: float, image_gsd: float) -> list[str]:
    """That the reference is much coarser than the image (§RA-2), if it is."""
    ratio = ref_gsd / image_gsd if image_gsd > 0 else 0.0
    if not ratio > cfg.reference_gsd_ratio:
        return []
    values = {"ref": f"{ref_gsd:.3g}", "ratio": f"{ratio:.1f}", "gsd": f"{image_gsd:.3g}"}
    return [EN("ra_warn_reference_gsd", limit=f"{cfg.reference_gsd_ratio:g}", **values)]


def reference_on_grid(
    cfg: RfmAccuracyConfig, grid: OrthoGrid, dem: DEM, out_path: Path, rpc: RPCModel | None
) -> tuple[str, str]:
    """§RA-2: the reference on the image's CRS and GSD, `cfg.margin` px larger on every side.

    A georeferenced reference is reprojected (bilinear); a reference in sensor geometry with
    RPCs (a same-accuracy stereo mate; `rpc`, from `reference_model`) is orthorectified with its
    own RPCs and the same DEM. Either way it is matched on `grey_bands`, as the image is.
    Returns (how, rpc source).
    """
    import rasterio

    ref_grid = grid.expanded(cfg.margin)
    if rpc is not None:
        orthorectify(
            cfg.reference,
            rpc,
            dem,
            out_path,
            grid=ref_grid,
            crop_offset=cfg.reference_crop_offset,
            chunk=cfg.ortho_chunk,
        )
        return "orthorectified with its RPCs and the same DEM", rpc.source
    dst = _reprojected(cfg.reference, ref_grid)
    profile = {
        "driver": "GTiff",
        "dtype": "float32",
        "count": 1,
        "width": ref_grid.width,
        "height": ref_grid.height,
        "crs": rasterio.crs.CRS.from_wkt(ref_grid.crs.to_wkt()),
        "transform": ref_grid.transform,
        "nodata": float("nan"),
        "compress": "deflate",
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
    }
    tmp = out_path.with_name(f".{out_path.name}.partial.tif")
    try:
        with rasterio.open(tmp, "w", **profile) as ds:
            ds.write(dst, 1)
        tmp.replace(out_path)
    finally:
        tmp.unlink(missing_ok=True)
    return "reprojected (bilinear) onto the image grid", ""


def _reprojected(reference: Path, ref_grid: OrthoGrid) -> np.ndarray:
    """The mean of the reference's `grey_bands`, each reprojected (bilinear) onto `ref_grid`,
    NaN where it has no value (its no-data value, its alpha band, outside it)."""
    import rasterio
    from rasterio.warp import Resampling, reproject

    with rasterio.open(reference) as src, reading_pixels(reference, "reference"):
        bands = grey_bands(src)
        dst = np.full((len(bands), ref_grid.height, ref_grid.width), np.nan, dtype=np.float32)
        reproject(
            source=rasterio.band(src, list(bands)),
            destination=dst,
            src_nodata=src.nodata,
            src_alpha=alpha_band(src),
            dst_transform=ref_grid.transform,
            dst_crs=rasterio.crs.CRS.from_wkt(ref_grid.crs.to_wkt()),
            dst_nodata=np.nan,
            resampling=Resampling.bilinear,
        )
    return band_mean(np.ma.masked_invalid(dst))


def build_cp_table(
    matches: pd.DataFrame,
    grid: OrthoGrid,
    ref_grid: OrthoGrid,
    rpc: RPCModel,
    dem: DEM,
    image_gsd: float,
) -> pd.DataFrame:
    """Matches (ortho and reference pixels) → CPs with map, geographic and image coordinates;
    GEV in pixels of `image_gsd` (d_s, §RA-4)."""
    row, col, ref_row, ref_col = (
        matches[c].to_numpy(np.float64) for c in ("row", "col", "ref_row", "ref_col")
    )
    x, y = grid.xy(row, col)
    rx, ry = ref_grid.xy(ref_row, ref_col)
    to_geo = Transformer.from_crs(grid.crs, CRS.from_epsg(4326), always_xy=True)
    lon, lat, h = _on_ground(to_geo, x, y, dem)
    rlon, rlat, rh = _on_ground(to_geo, rx, ry, dem)
    line, sample = rpc.ground_to_image(lon, lat, h)
    dx = x - rx
    dy = y - ry
    table = pd.DataFrame(
        {
            "kind": matches["kind"].to_numpy() if "kind" in matches else "",
            "score": matches["score"].to_numpy() if "score" in matches else np.nan,
            "row": row,
            "col": col,
            "ref_row": ref_row,
            "ref_col": ref_col,
            "x_m": x,
            "y_m": y,
            "ref_x_m": rx,
            "ref_y_m": ry,
            "lon": lon,
            "lat": lat,
            "h_m": h,
            "ref_lon": rlon,
            "ref_lat": rlat,
            "ref_h_m": rh,
            "line": line,
            "sample": sample,
            "dx_m": dx,
            "dy_m": dy,
            "gev_px": accuracy.gev(dx, dy, image_gsd),
        }
    )
    table = table[np.isfinite(table["h_m"]) & np.isfinite(table["ref_h_m"])].reset_index(drop=True)
    table.insert(0, "cp_id", [f"CP{i + 1:04d}" for i in range(len(table))])
    return table[CP_COLUMNS]


def _on_ground(
    to_geo: Transformer, x: np.ndarray, y: np.ndarray, dem: DEM
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude, latitude and DEM height of map coordinates (NaN height off the DEM)."""
    lon, lat = (np.asarray(v) for v in to_geo.transform(x, y))
    return lon, lat, dem.height(lon, lat)


GEOGRAPHIC_COLUMNS = ("lon", "lat", "ref_lon", "ref_lat")
"""The CP table's degrees, written to 1e-9° (0.1 mm): to 1e-6° (0.11 m in latitude) the GEV
recomputed from them was off by up to 0.2 px on a 0.5 m image."""


def cps_csv(cps: pd.DataFrame) -> str:
    """The CP table as written to cps.csv: metres and pixels to 1e-6, degrees to 1e-9."""
    table = cps.copy()
    for name in GEOGRAPHIC_COLUMNS:
        values = table[name].to_numpy(np.float64)
        table[name] = np.where(np.isfinite(values), np.char.mod("%.9f", values), "")
    return table.to_csv(index=False, float_format="%.6f")


def checkpoints_table(
    cps: pd.DataFrame, method: str, reference_id: str, prefix: str
) -> pd.DataFrame:
    """The CPs as contract-v1 checkpoints: plane from the reference ortho, so ref_z_m is empty."""
    return pd.DataFrame(
        {
            "point_id": [f"{prefix}-{c}" for c in cps["cp_id"]],
            "method": method,
            "reference_id": reference_id,
            "x_m": cps["x_m"].round(4),
            "y_m": cps["y_m"].round(4),
            "z_m": cps["h_m"].round(3),
            "ref_x_m": cps["ref_x_m"].round(4),
            "ref_y_m": cps["ref_y_m"].round(4),
            "ref_z_m": np.nan,
        }
    )[CHECKPOINT_COLUMNS]


def _refine_with_all(
    rpc: RPCModel, control: accuracy.ControlPoints, cps: pd.DataFrame
) -> tuple[RefinedRFM, float] | None:
    """The §3 affine fitted to every CP (None with fewer than 3 or collinear CPs)."""
    if len(cps) < 3:
        return None
    try:
        refined, residuals = fit_affine(
            rpc, control.lon, control.lat, control.h, control.row, control.col
        )
    except InputError:
        return None
    return refined, float(np.sqrt(np.mean(np.sum(residuals**2, axis=1))))


def _preview(path: Path, max_side: int = 1500) -> np.ndarray:
    """The ortho decimated to at most `max_side` pixels a side (bounded memory, for plots)."""
    import rasterio

    with rasterio.open(path) as ds:
        step = max(1, int(np.ceil(max(ds.width, ds.height) / max_side)))
        shape = (max(1, ds.height // step), max(1, ds.width // step))
        return ds.read(1, out_shape=shape, masked=True).astype(np.float32).filled(np.nan)


def _finite(value: float) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _clean(obj: object) -> object:
    """JSON-safe copy: NaN/inf → null, numpy scalars → Python."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return _finite(obj)
    return obj


MAX_CELL = 400
"""§RA-3's homogenization cell (px): the largest chosen."""
MIN_CELL = 24
"""Smallest chosen cell (px): about the matcher's NCC template (21 px)."""
TARGET_CELLS = 100
"""Cells aimed at when the cell is chosen: ≥ ~50 CPs where half the cells have texture."""
TARGET_CPS = 50


def overlap_mask(image: np.ndarray, reference: np.ndarray, margin: int) -> np.ndarray:
    """Image pixels with data in both the image and the reference (the reference is `margin`
    pixels larger on every side)."""
    h, w = image.shape
    return np.isfinite(image) & np.isfinite(reference[margin : margin + h, margin : margin + w])


OWN_PIXELS = (
    "on the image's grid the reference holds the image's own pixels (the same value at every "
    "pixel both cover: an orthoimage of the image itself, such as an earlier run's ortho.tif?): "
    "it would measure the resampling alone; a reference must be independent of the image (a "
    "reference orthoimage, or another image of the scene with its own RPCs)"
)


def own_pixels(image: np.ndarray, on_grid: np.ndarray, overlap: np.ndarray) -> bool:
    """Whether the reference on the image's grid (`on_grid`) holds the image's own values: all
    but 1 % of the pixels both cover equal, over at least one matching window (a reference
    taken independently never repeats the image's values; a flat image is left to "no
    texture")."""
    if not holds_window(overlap) or _spread(image[overlap]) <= 0:
        return False
    return bool(np.mean(image[overlap] == on_grid[overlap]) > 0.99)


def choose_cell(overlap_px: int) -> tuple[int, str]:
    """§RA-3 cell from the area both images cover: TARGET_CELLS cells, within MIN..MAX_CELL."""
    cell = int(np.clip(np.floor(np.sqrt(max(overlap_px, 1) / TARGET_CELLS)), MIN_CELL, MAX_CELL))
    return cell, (
        f"chosen from the image size: {cell} px for {overlap_px} px covered by both images "
        f"(about {overlap_px // cell**2} cells, aiming at ≥ {TARGET_CPS} CPs; "
        f"{MIN_CELL}..{MAX_CELL} px)"
    )


def match_cps(
    cfg: RfmAccuracyConfig,
    image: np.ndarray,
    reference: np.ndarray,
    overlap: np.ndarray,
    matcher: Matcher | None,
) -> tuple[pd.DataFrame, int, str]:
    """§RA-3 with the given cell, or one chosen from the image size; a chosen cell below
    MAX_CELL (a small image) that gives fewer than TARGET_CPS CPs is shrunk once, in proportion,
    and the matching repeated. Returns the matches, the cell and how it was chosen."""
    match = matcher or default_matcher()

    def run(cell: int) -> pd.DataFrame:
        return match(
            image,
            reference,
            image_valid=np.isfinite(image),
            reference_valid=np.isfinite(reference),
            offset=(float(cfg.margin), float(cfg.margin)),
            chunk=cfg.match_chunk,
            grid=cell,
            **cfg.match_settings,
        )

    if cfg.match_grid:
        return run(cfg.match_grid), cfg.match_grid, "given"
    cell, how = choose_cell(int(overlap.sum()))
    matches = run(cell)
    if len(matches) < TARGET_CPS and MIN_CELL < cell < MAX_CELL:
        smaller = max(MIN_CELL, int(cell * np.sqrt(max(len(matches), 1) / (1.2 * TARGET_CPS))))
        again = run(smaller)
        if len(again) > len(matches):
            how += f"; {len(matches)} CPs at {cell} px, so matched again at {smaller} px"
            return again, smaller, how
    return matches, cell, how


MATCH_WINDOW = 2 * MatchSettings().margin
"""Side (px) of the window a match needs free of voids: the matcher's BRIEF patch and NCC
template (`blockqc.matching.MatchSettings.margin`, 25 px, on each side of a corner)."""
CORNER_WINDOW = 2 * MatchSettings().margin + 1
"""Side (px) of the square of image data a corner needs: 25 px (`MatchSettings.margin`) on
every side of it, so 51 px; an image of 50 × 50 px of data holds no corner."""
VOIDED_WINDOWS = 0.5
"""Share of matching windows touching a void above which voids are named as the cause."""


def voided_windows(image: np.ndarray, window: int = MATCH_WINDOW) -> float:
    """Share of the window×window cells inside the image's footprint (every neighbour cell at
    least half with data, so the footprint's edge is left out) that hold an empty pixel:
    scattered voids (of the DEM, empty in the ortho) leave no window to match."""
    from scipy.ndimage import binary_erosion

    rows, cols = (n // window * window for n in image.shape)
    if rows == 0 or cols == 0:
        return 0.0
    finite = np.isfinite(image[:rows, :cols])
    count = finite.reshape(rows // window, window, cols // window, window).sum(axis=(1, 3))
    inside = binary_erosion(count >= window * window / 2, np.ones((3, 3)), border_value=0)
    return float((inside & (count < window * window)).sum() / max(inside.sum(), 1))


def _spread(values: np.ndarray) -> float:
    """Grey-level spread (2–98 %) of the finite `values`; 0 without any."""
    values = values[np.isfinite(values)]
    return float(np.subtract(*np.percentile(values, [98, 2]))) if values.size else 0.0


def holds_window(mask: np.ndarray, window: int = MATCH_WINDOW) -> bool:
    """Whether some window×window square of `mask` is True throughout."""
    import cv2

    if min(mask.shape) < window:
        return False
    kernel = np.ones((window, window), np.uint8)
    inside = cv2.erode(mask.astype(np.uint8), kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return bool(inside.any())


NO_CP_CAUSES = {
    "dem_under_matches": "every match fell on a DEM void (no height under it)",
    "empty_image": (
        "the image has no data on the grid: every pixel is no data or NaN (an image with data "
        "is expected)"
    ),
    "empty_reference": (
        "the reference has no data over the image: it covers the image, but every pixel of it "
        "there is no data or NaN (a reference with data over the image is expected)"
    ),
    "no_overlap": "the reference does not overlap the image (wrong reference, CRS or crop offset?)",
    # before the DEM's reach: the part of the image the DEM reaches would match without them
    "scattered_dem_voids": (
        "DEM voids scattered across the image: the image has no height (no pixel) on them "
        "and most matching windows touch one (close them with --dem-fill-voids N, holes up "
        "to ~2·N DEM cells across)"
    ),
    "dem_outside": (
        "the DEM does not reach most of the image ({outside:.0%} of it is outside {dem}): give a "
        "DEM that covers the image"
    ),
    "dem_voids": "DEM voids: most of the image has no height (fill voids with --dem-fill-voids?)",
    "scattered_image_voids": (
        "the image has empty pixels (no data or NaN) scattered over it and most matching "
        "windows touch one: an image with data over whole windows is expected"
    ),
    "small_image": (
        f"the image's data hold no whole {CORNER_WINDOW} px matching window: the image is "
        f"too small or too thin (at least {CORNER_WINDOW} px each way is expected)"
    ),
    "scattered_reference_voids": (
        "the reference has empty pixels (no data or NaN) scattered over the image and most "
        "matching windows touch one: a reference with data over whole windows is expected"
    ),
    "narrow_overlap": (
        "the image and the reference overlap on {n} px only, nowhere on a whole "
        f"{MATCH_WINDOW} px matching window (a reference covering the image is expected; wrong "
        "reference, CRS or crop offset?)"
    ),
    "flat_reference": (
        "the reference is flat (one grey level) over the image: it has no texture to match"
    ),
    "no_texture": (
        "no texture or too little likeness between the two images to match, or the reference "
        "lies further from the image than the matcher searches (8 px by default): check its "
        "georeferencing, CRS or crop offset"
    ),
}
"""Why a run found no CP, in the order they are tried (`no_cp_cause`)."""
REFERENCE_CAUSES = ("empty_reference", "scattered_reference_voids", "flat_reference")
"""The causes that lie in the reference: the message names the reference file."""


def no_cp_cause(
    image: np.ndarray,
    overlap: np.ndarray,
    dem: DEM,
    n_matches: int,
    reference: np.ndarray | None = None,
    no_height: tuple[float, float] = (0.0, 0.0),
    reference_covers: bool = False,
) -> tuple[bool, str]:
    """Why matching gave no CP: whether its cause lies in the reference, and the message: the
    likely cause first, then the figures behind it (`reference`: the reference on the image's
    grid, the image's shape, its empty pixels and spread then weighed too; `no_height`: the
    shares of the image outside the DEM and on its voids; `reference_covers`: the reference's
    extent meets the image's grid, so that no data from it is its pixels' doing)."""
    valid = float(np.isfinite(image).mean())
    both = float(overlap.sum() / max(np.isfinite(image).sum(), 1))
    voids = float(np.isnan(dem.grid.values).mean())
    touched = voided_windows(image)
    spread = _spread(image[overlap])
    figures = (
        f"image pixels with data {valid:.0%} of the grid, of which {both:.0%} also on the "
        f"reference; DEM voids {voids:.0%} of its window; {touched:.0%} of the "
        f"{MATCH_WINDOW} px matching windows over the image touch an empty pixel; "
        f"{n_matches} matches found; grey-level spread (2–98 %) over the overlap {spread:.4g}"
    )
    if no_height[0] > 0:
        figures = f"image outside the DEM {no_height[0]:.0%}; " + figures
    ref_touched, ref_spread, ref_figures = _reference_figures(reference, overlap, spread)
    figures += ref_figures
    found = {
        "dem_under_matches": n_matches > 0,
        "empty_image": valid == 0,
        "empty_reference": reference_covers and both == 0,
        "no_overlap": both < 0.05,
        "dem_outside": no_height[0] > 0.5 and no_height[0] > no_height[1],
        "dem_voids": voids > 0.2 or (valid < 0.2 and voids > 0),
        "small_image": not holds_window(np.isfinite(image), CORNER_WINDOW),
        "scattered_dem_voids": touched > VOIDED_WINDOWS and voids > 0,
        "scattered_image_voids": touched > VOIDED_WINDOWS,
        "scattered_reference_voids": ref_touched > VOIDED_WINDOWS,
        "narrow_overlap": not holds_window(overlap),
        "flat_reference": ref_spread <= 0 < spread,
        "no_texture": True,
    }
    cause = next(c for c in NO_CP_CAUSES if found[c])
    why = NO_CP_CAUSES[cause].format(
        n=int(overlap.sum()), outside=no_height[0], dem=Path(dem.grid.source).name
    )
    return cause in REFERENCE_CAUSES, f"no control point found: {why}. {figures}"


def _reference_figures(
    reference: np.ndarray | None, overlap: np.ndarray, spread: float
) -> tuple[float, float, str]:
    """For `no_cp_cause`, the reference on the image's grid weighed: the share of the matching
    windows over the overlap that touch an empty pixel, its grey-level spread there, and the
    figures to add to the message (none and the image's `spread` without a reference)."""
    if reference is None:
        return 0.0, spread, ""
    ref_touched = voided_windows(np.where(overlap, reference, np.nan))
    ref_spread = _spread(reference[overlap])
    figures = (
        f" (reference {ref_spread:.4g}); {ref_touched:.0%} of the matching windows over "
        "the overlap touch an empty pixel of the image or the reference"
    )
    return ref_touched, ref_spread, figures


def height_warning(dem_file: Path, no_height: tuple[float, float]) -> list[str]:
    """The share of the image without DEM heights (outside the DEM, on its voids), if any."""
    outside, void = no_height
    if outside + void <= 0:
        return []
    if outside > 0:
        key = "ra_warn_outside_voids" if void else "ra_warn_outside"
    else:
        key = "ra_warn_voids"
    parts = EN(key, outside=f"{outside:.1%}", void=f"{void:.1%}")
    share = f"{outside + void:.1%}"
    return [EN("ra_warn_no_height", share=share, dem=dem_file.name, parts=parts)]


def run_warnings(
    cfg: RfmAccuracyConfig,
    dem: DEM,
    n: int,
    cell: int,
    no_height: tuple[float, float] = (0.0, 0.0),
) -> list[str]:
    """What the user should know about the run's inputs and its CP count (`no_height`: the
    shares of the image outside the DEM and on its voids)."""
    out = height_warning(cfg.dem, no_height)
    if n < TARGET_CPS:
        how = EN("ra_grid_given" if cfg.match_grid else "ra_grid_chosen_word")
        out.append(EN("ra_warn_few_cps", n=n, cell=cell, how=how))
    if EN("ra_stated_by_user") in dem.vertical:
        out.append(EN("ra_warn_dem_ellipsoid"))
    return out


@dataclass
class _Run:
    """What the stages of one run hand on to the next."""

    cfg: RfmAccuracyConfig
    rpc: RPCModel
    offset: tuple[float, float]
    dem: DEM
    grid: OrthoGrid | None = None
    cps: pd.DataFrame | None = None
    cell: int = 0
    cell_how: str = ""
    how: str = ""
    ref_rpc: Any = None
    reference: RPCModel | None = None  # the reference's RPCs, if it is orthorectified with them
    no_height: tuple[float, float] = (0.0, 0.0)
    """Shares of the image outside the DEM and on its voids."""
    image_gsd: float = 0.0
    """d_s of §RA-4: the image's GSD at its centre (the grid's unless --gsd gives another)."""
    reference_gsd: float = 0.0
    """What one pixel of the reference covers at the grid's centre (m)."""


def described_footprint(
    rpc: RPCModel,
    image: Path,
    shape: tuple[int, int],
    offset: tuple[float, float],
    option: str,
    given: bool,
) -> tuple[float, float, float, float]:
    """The image's footprint over the RPC's height range (west, south, east, north), once the
    RPC is seen to describe the image: its pixels within the RPC's image domain, the footprint
    on the Earth and within the RPC's ground domain; else refused naming the RPC, before the
    DEM is read around a footprint that is not the image's. `option`/`given`: the crop offset's
    option and whether the user gave it."""
    found = crop_problem(rpc, image, shape, offset, option, given)
    if found is not None:
        raise InputError(found)
    box = _footprint_bounds(rpc, shape, offset, pad_deg=0.0)
    found = implausible_problem(rpc, image, box)
    if found is not None:
        raise InputError(found)
    return box


def dem_under(
    cfg: RfmAccuracyConfig,
    rpc: RPCModel,
    shape: tuple[int, int],
    offset: tuple[float, float],
    pad_deg: float = 0.01,
) -> DEM:
    """The DEM over the image's footprint (heights ellipsoidal). A DEM that does not reach the
    footprint, or heights that send it off the RPC's ground domain (a mistyped HEIGHT_SCALE),
    are refused naming the RPC and the likely cause, not the DEM alone."""
    box = described_footprint(
        rpc, cfg.image, shape, offset, "--crop-offset", cfg.crop_offset is not None
    )
    west, south, east, north = box
    try:
        dem = load_dem(
            cfg.dem,
            geoid=cfg.geoid,
            geoid_offset=cfg.geoid_offset,
            vertical=cfg.dem_vertical,
            bounds=(west - pad_deg, south - pad_deg, east + pad_deg, north + pad_deg),
            fill=cfg.dem_fill,
            plane_per_m=plane_per_height(rpc, shape, offset),
        )
    except NotCovered as exc:
        if exc.what != "DEM":
            raise
        raise InputError(off_dem_problem(rpc, cfg.image, box, cfg.dem, exc.extent)) from None
    if np.isfinite(dem.mean_height):
        at = footprint_at(rpc, shape, offset, dem.mean_height)
        found = None if at is None else implausible_problem(rpc, cfg.image, at, dem.mean_height)
        if found is not None:
            raise InputError(found)
    return dem


def check_reference_rpc(cfg: RfmAccuracyConfig, rpc: RPCModel) -> None:
    """The same checks of a sensor-geometry reference's RPC as of the image's (its pixels in the
    RPC's image domain, its footprint on the Earth and in the RPC's ground domain), before
    the image is orthorectified."""
    shape, _ = _raster_shape(cfg.reference)
    offset = cfg.reference_crop_offset
    given = offset is not None
    offset = crop_offset_from_file(cfg.reference) if offset is None else offset
    described_footprint(rpc, cfg.reference, shape, offset, "--reference-crop-offset", given)


def check_image_holds_window(
    cfg: RfmAccuracyConfig, shape: tuple[int, int], image_gsd: float
) -> None:
    """An image narrower on the output grid than a matching window can give no CP: refused
    before it is orthorectified, naming --gsd when the image itself is wide enough, else the
    image (a 1 × 1 px image was said not to overlap the reference, a --gsd of 1000 m to leave
    no data on the grid)."""
    rows, cols = shape
    scale = image_gsd / cfg.gsd if cfg.gsd is not None else 1.0
    if not math.isfinite(scale) or min(rows, cols) * scale >= CORNER_WINDOW:
        return
    need = f"at least {CORNER_WINDOW} px each way is expected (a matching window)"
    if min(rows, cols) >= CORNER_WINDOW:
        why = (
            f"--gsd {cfg.gsd:g} m puts the image ({cols} × {rows} px at {image_gsd:g} m) on "
            f"{cols * scale:.3g} × {rows * scale:.3g} px of the output grid: {need}; give a "
            "smaller --gsd"
        )
        raise InputError(Problem(file="<arguments>", message=why))
    why = f"the image is {cols} × {rows} px, too small to match: {need}"
    raise InputError(Problem(file=str(cfg.image), message=why))


def _prepare(cfg: RfmAccuracyConfig) -> _Run:
    """Read the RPC and the image size, and the DEM over the footprint (heights ellipsoidal)."""
    rpc = rpcs_of(cfg.image, cfg.rpc, f"{NO_RPCS}: give the image's RPC file with --rpc")
    shape, _ = _raster_shape(cfg.image)
    offset = cfg.crop_offset if cfg.crop_offset is not None else crop_offset_from_file(cfg.image)
    dem = dem_under(cfg, rpc, shape, offset)
    reference = reference_model(cfg)  # refused now, not after the image is orthorectified
    for raster in (cfg.image, cfg.reference):
        bands_used(raster)  # a paletted one refused now too
    if reference is not None:
        check_reference_rpc(cfg, reference)
    run = _Run(cfg, rpc, offset, dem, reference=reference)
    run.grid = ortho_grid(
        rpc, shape, dem, crop_offset=offset, crs=cfg.crs, gsd=cfg.gsd, margin=cfg.margin
    )
    if reference is None:
        check_reference_crs(cfg.reference, run.grid.crs)
    run.image_gsd = (
        run.grid.gsd if cfg.gsd is None else round(centre_gsd(rpc, shape, offset, dem, run.grid), 3)
    )
    check_image_holds_window(cfg, shape, run.image_gsd)
    run.no_height = image_without_height(rpc, shape, offset, dem)
    return run


def _correct_and_match(run: _Run, matcher: Matcher | None) -> None:
    """§RA-1 orthorectify, §RA-2 the reference on the same grid, §RA-3 match: the CP table."""
    cfg, out = run.cfg, run.cfg.out
    orthorectify(
        cfg.image, run.rpc, run.dem, out / "ortho.tif", grid=run.grid,
        crop_offset=run.offset, chunk=cfg.ortho_chunk,
    )  # fmt: skip
    run.how, run.ref_rpc = reference_on_grid(
        cfg, run.grid, run.dem, out / "reference_on_grid.tif", run.reference
    )
    run.reference_gsd = reference_gsd(cfg, run.grid, run.dem, run.reference)
    image, run.grid = read_ortho(out / "ortho.tif")
    reference, ref_grid = read_ortho(out / "reference_on_grid.tif")
    overlap = overlap_mask(image, reference, cfg.margin)
    (h, w), m = image.shape, cfg.margin
    on_grid = reference[m : m + h, m : m + w]
    if own_pixels(image, on_grid, overlap):
        raise InputError(Problem(file=str(cfg.reference), message=OWN_PIXELS))
    matches, run.cell, run.cell_how = match_cps(cfg, image, reference, overlap, matcher)
    run.cps = build_cp_table(matches, run.grid, ref_grid, run.rpc, run.dem, run.image_gsd)
    if run.cps.empty:
        covers = run.reference is None and reference_meets(cfg.reference, run.grid)
        at_reference, reason = no_cp_cause(
            image, overlap, run.dem, len(matches), on_grid, run.no_height, covers
        )
        culprit = cfg.reference if at_reference else cfg.image
        raise InputError(Problem(file=str(culprit), message=reason))
    write_text_atomic(out / "cps.csv", cps_csv(run.cps))


def _plots(run: _Run, dx: np.ndarray, dy: np.ndarray, gev: np.ndarray) -> None:
    """§RA-5 the error-vector plot over the ortho and the GEV histogram."""
    from blockqc.report.figure_lang import figure_language

    cfg, cps, grid = run.cfg, run.cps, run.grid
    t = translator(cfg.lang)
    with figure_language(cfg.lang):
        vectors = accuracy.plot_error_vectors(
            cps["col"], cps["row"], dx, dy, run.image_gsd, (grid.height, grid.width),
            title=t("ra_fig_vectors", image=cfg.image.name, reference=cfg.reference.name),
            background=_preview(cfg.out / "ortho.tif"), t=t,
        )  # fmt: skip
        histogram = accuracy.plot_gev_histogram(gev, cfg.requirement_px, t)
    write_bytes_atomic(cfg.out / "error_vectors.png", vectors)
    write_bytes_atomic(cfg.out / "gev_histogram.png", histogram)


def _refine(run: _Run) -> tuple[pd.DataFrame, Any]:
    """§RA-6 refined RFM from k CPs (held-out RMSE), and the affine fitted to every CP."""
    cfg, cps = run.cfg, run.cps
    control = accuracy.ControlPoints(
        row=cps["line"].to_numpy(), col=cps["sample"].to_numpy(),
        lon=cps["ref_lon"].to_numpy(), lat=cps["ref_lat"].to_numpy(),
        h=cps["ref_h_m"].to_numpy(),
        ref_x=cps["ref_x_m"].to_numpy(), ref_y=cps["ref_y_m"].to_numpy(),
    )  # fmt: skip
    table = accuracy.refined_rfm_table(
        run.rpc, control, run.dem, run.grid.crs, run.image_gsd,
        ks=cfg.ks, repeats=cfg.repeats, seed=cfg.seed,
    )  # fmt: skip
    write_text_atomic(cfg.out / "refined_rfm.csv", table.to_csv(index=False, float_format="%.4f"))
    refined_all = _refine_with_all(run.rpc, control, cps)
    if cfg.refined_ortho and refined_all is not None:
        # §RA-1 also with the refined RFM: same grid, so the two orthos overlay pixel for pixel
        orthorectify(
            cfg.image, refined_all[0], run.dem, cfg.out / "ortho_refined.tif", grid=run.grid,
            crop_offset=run.offset, chunk=cfg.ortho_chunk,
        )  # fmt: skip
    return table, refined_all


def _files(run: _Run, refined: bool) -> dict[str, str]:
    """The files of the run (the checkpoints export written here when asked)."""
    cfg = run.cfg
    files = {
        "cps": "cps.csv",
        "refined_rfm": "refined_rfm.csv",
        "ortho": "ortho.tif",
        "reference_on_grid": "reference_on_grid.tif",
        "error_vectors": "error_vectors.png",
        "gev_histogram": "gev_histogram.png",
        "html": "report.html",
    }
    if cfg.refined_ortho and refined:
        files["ortho_refined"] = "ortho_refined.tif"
    if cfg.export_checkpoints:
        ckp = checkpoints_table(run.cps, cfg.method, cfg.reference.stem, cfg.image.stem)
        write_text_atomic(cfg.out / "checkpoints.csv", ckp.to_csv(index=False))
        files["checkpoints"] = "checkpoints.csv"
    return files


def _accuracy(run: _Run, rmse: float, gev: np.ndarray) -> dict[str, object]:
    """§RA-4 figures of the whole image."""
    cfg, n = run.cfg, len(gev)
    return {
        "clause": "§RA-4",
        "n": n,
        "rmse_px": rmse,
        "rmse_m": rmse * run.image_gsd,
        "image_gsd_m": run.image_gsd,
        "rmse_px_per_image_if_same_accuracy": rmse / math.sqrt(2)
        if cfg.method != "high_precision"
        else None,
        "gev_mean_px": float(np.mean(gev)) if n else None,
        "gev_max_px": float(np.max(gev)) if n else None,
        "requirement_px": cfg.requirement_px,
        "verdict": accuracy.verdict(rmse, cfg.requirement_px),
    }


def _inputs(run: _Run) -> dict[str, object]:
    """Where the run's inputs came from and the conventions it used."""
    cfg, grid = run.cfg, run.grid
    rpc_path = cfg.rpc or cfg.image
    return {
        "kind": "rfm_accuracy",
        "image": str(cfg.image),
        "image_bands": bands_used(cfg.image),
        "rpc": {"file": str(rpc_path), "format": sniff_format(Path(rpc_path))},
        "crop_offset_px": list(run.offset),
        "dem": {
            "file": str(cfg.dem),
            "heights": run.dem.vertical,
            "voids_filled_steps": cfg.dem_fill,
        },
        "reference": {
            "file": str(cfg.reference),
            "how": run.how,
            "gsd_m": run.reference_gsd,
            "bands": bands_used(cfg.reference),
            "rpc": run.ref_rpc,
            "method": cfg.method,
        },
        "conventions": {
            "image": "pixel centre, first pixel (0, 0), full-image coordinates of the RPCs",
            "gdal": "GDAL's RPC transformer uses pixel corners: GDAL = ours + 0.5 px",
            "heights": "WGS-84 ellipsoidal",
        },
        "grid": {
            "crs": grid.crs.to_string(),
            "gsd_m": grid.gsd,
            "width": grid.width,
            "height": grid.height,
            "transform": list(grid.transform)[:6],
        },
    }


def _at_centre(run: _Run, refined: RefinedRFM) -> dict[str, float]:
    """The correction of the affine at the image's centre (full-image line and sample): its
    coefficients are in full-image coordinates, so a0, b0 alone can be hundreds of pixels
    where the correction over the image is a few."""
    (rows, cols), _ = _raster_shape(run.cfg.image)
    line = run.offset[0] + (rows - 1) / 2
    sample = run.offset[1] + (cols - 1) / 2
    d_line, d_sample = refined.affine.delta(line, sample)
    return {
        "line": line,
        "sample": sample,
        "d_line_px": float(d_line),
        "d_sample_px": float(d_sample),
    }


def _refined_doc(run: _Run, table: pd.DataFrame, refined_all: Any) -> dict[str, object]:
    cfg = run.cfg
    return {
        "clause": "§RA-6",
        "evaluation": "RMSE (§RA-4) on the CPs not used for fitting; "
        f"{cfg.repeats} random draws per k (seed {cfg.seed})",
        "rows": table.to_dict(orient="records"),
        "all_cps": None
        if refined_all is None
        else {
            "affine": refined_all[0].affine.as_dict(),
            "centre": _at_centre(run, refined_all[0]),
            "fit_rms_px": refined_all[1],
            "note": "image-space affine (§3) fitted to every CP; its residual is in-sample",
        },
    }


def run_rfm_accuracy(cfg: RfmAccuracyConfig, matcher: Matcher | None = None) -> dict[str, object]:
    """Run §RA-1..6 for one image and write every output into `cfg.out`; returns the results.

    The outputs are written into a hidden folder of `cfg.out` and moved into place only once
    all of them, the page included, are written (`_publish`): a run that fails leaves an
    earlier run's outputs as they were, and never a results.json without its page."""
    if cfg.method not in METHODS:
        raise InputError(Problem(file="<arguments>", message=f"method must be one of {METHODS}"))
    cfg.out.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".rfm-accuracy.", suffix=".partial", dir=cfg.out))
    try:
        results = _measure(replace(cfg, out=staging), matcher)
        _publish(staging, cfg.out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return results


def _publish(staging: Path, out: Path) -> None:
    """Move a finished run's outputs from `staging` into `out`, results.json last; an earlier
    run's outputs this run did not make are removed, so that two runs never mix. Until the new
    results.json is in place, none is there (renames within one folder: nothing to fail)."""
    (out / "results.json").unlink(missing_ok=True)
    for name in OUTPUT_NAMES:
        if name == "results.json":
            continue
        if (staging / name).exists():
            os.replace(staging / name, out / name)
        else:
            (out / name).unlink(missing_ok=True)
    os.replace(staging / "results.json", out / "results.json")


def _measure(cfg: RfmAccuracyConfig, matcher: Matcher | None) -> dict[str, object]:
    """§RA-1..6 with every output written into `cfg.out`, the page before results.json."""
    from blockqc.rfm.report import render_html

    run = _prepare(cfg)
    _correct_and_match(run, matcher)
    cps, gsd = run.cps, run.image_gsd
    dx, dy, gev = cps["dx_m"].to_numpy(), cps["dy_m"].to_numpy(), cps["gev_px"].to_numpy()
    rmse = accuracy.rmse_px(dx, dy, gsd)
    summary = accuracy.distortion_summary(
        cps["col"], cps["row"], dx, dy, gsd, cfg.distortion_threshold_px
    )
    _plots(run, dx, dy, gev)
    table, refined_all = _refine(run)
    n = len(cps)
    results: dict[str, object] = {
        **_inputs(run),
        "matching": {
            "chunk": cfg.match_chunk,
            "grid": run.cell,
            "grid_choice": run.cell_how,
            "n_cps": n,
            "by_kind": {str(k): int(v) for k, v in cps["kind"].value_counts().items()},
        },
        "accuracy": _accuracy(run, rmse, gev),
        "distortion": {"clause": "§RA-5", **summary},
        "refined_rfm": _refined_doc(run, table, refined_all),
        "files": _files(run, refined_all is not None),
        "warnings": run_warnings(cfg, run.dem, n, run.cell, run.no_height)
        + reference_warning(cfg, run.reference_gsd, run.image_gsd)
        + accuracy.k_warnings(cfg.ks, n),
    }
    results = _clean(results)  # type: ignore[assignment]
    write_text_atomic(cfg.out / "report.html", render_html(results, lang=cfg.lang))
    write_json_atomic(cfg.out / "results.json", results)
    return results
