"""Terrain factors of §AF-1..3 from DEM tiles: mean elevation, slope and roughness over a block."""

from __future__ import annotations

import math
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape as xml_escape

import numpy as np
import rasterio
import rasterio.features
import rasterio.merge
import rasterio.warp
import rasterio.windows
import shapely
from affine import Affine
from pyproj import CRS, Transformer
from rasterio.enums import Resampling

from blockqc.adjust.geometry import radii_of_curvature
from blockqc.errors import InputError, Problem
from blockqc.lonlat import turns_towards
from blockqc.rfm.dem import WGS84, check_heights, check_one_band, height_unit, wgs84_lonlat
from blockqc.textio import not_there

DEM_SUFFIXES = (".tif", ".tiff", ".hgt", ".vrt", ".img", ".dem")

#: Above this many pixels over a block's extent, the DEM is read at a coarser, averaged grid.
DEFAULT_MAX_PIXELS = 16_000_000


def pixel_sizes_m(transform: Affine, crs: CRS, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel width and height in metres for each row (geographic: M·Δφ and N·cos φ·Δλ)."""
    if transform.b != 0 or transform.d != 0:
        raise ValueError("rotated DEM grids are not supported")
    rows = np.arange(height) + 0.5
    if crs.is_geographic:
        lat = transform.f + transform.e * rows
        m, n = radii_of_curvature(lat)
        dx = n * np.cos(np.radians(lat)) * math.radians(abs(transform.a))
        dy = m * math.radians(abs(transform.e))
        return dx, dy
    unit = crs.axis_info[0].unit_conversion_factor if crs.axis_info else 1.0
    return (np.full(height, abs(transform.a) * unit), np.full(height, abs(transform.e) * unit))


def _neighbours(z: np.ndarray) -> list[np.ndarray]:
    """The nine 3×3 neighbours of every interior cell, a..i row by row, each (H − 2, W − 2)."""
    h, w = z.shape
    return [z[r : h - 2 + r, c : w - 2 + c] for r in range(3) for c in range(3)]


def horn_slope(z: np.ndarray, dx: np.ndarray | float, dy: np.ndarray | float) -> np.ndarray:
    """Slope in degrees (§AF-2) by Horn's 3×3 stencil; NaN on the border and next to voids.

    ∂h/∂x = ((c + 2f + i) − (a + 2d + g)) / (8·dx), ∂h/∂y = ((g + 2h + i) − (a + 2b + c)) / (8·dy)
    with a..i the window row by row and dx, dy the centre row's pixel sizes in metres.
    """
    z = np.asarray(z, dtype=float)
    out = np.full(z.shape, np.nan)
    if z.shape[0] < 3 or z.shape[1] < 3:
        return out
    dxr = np.broadcast_to(np.asarray(dx, dtype=float), (z.shape[0],))[1:-1, None]
    dyr = np.broadcast_to(np.asarray(dy, dtype=float), (z.shape[0],))[1:-1, None]
    a, b, c, d, e, f, g, h, i = _neighbours(z)
    gx = ((c + 2 * f + i) - (a + 2 * d + g)) / (8.0 * dxr)
    gy = ((g + 2 * h + i) - (a + 2 * b + c)) / (8.0 * dyr)
    # the stencil skips the centre cell; a void there leaves the slope undefined too
    out[1:-1, 1:-1] = np.where(np.isnan(e), np.nan, np.degrees(np.arctan(np.hypot(gx, gy))))
    return out


def roughness(z: np.ndarray) -> np.ndarray:
    """Max − min elevation in the 3×3 window (§AF-3); NaN on the border and next to voids."""
    z = np.asarray(z, dtype=float)
    out = np.full(z.shape, np.nan)
    if z.shape[0] < 3 or z.shape[1] < 3:
        return out
    stack = np.stack(_neighbours(z))
    out[1:-1, 1:-1] = stack.max(axis=0) - stack.min(axis=0)  # NaN propagates from voids
    return out


@dataclass(frozen=True)
class TerrainFactors:
    """§AF-1..3 over one block, with how much of the block the DEM covered."""

    mean_elevation_m: float
    mean_slope_deg: float
    mean_roughness_m: float
    dem_coverage: float  # share of the block's area with a valid DEM height
    n_pixels: int  # DEM cells inside the block with a valid height
    resolution_factor: int  # 1 when read at the DEM's own grid, k when averaged over k×k cells
    dem_files: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def find_dem_files(paths: Sequence[Path]) -> list[Path]:
    """DEM files given directly or found (non-recursively) in given folders, sorted."""
    found: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            found += sorted(q for q in p.iterdir() if q.suffix.lower() in DEM_SUFFIXES)
        elif p.is_file():
            found.append(p)
        else:
            what = not_there(p, "DEM file or folder not found")
            raise InputError(Problem(file=str(p), message=what))
    if not found:
        raise InputError(
            Problem(
                file=", ".join(str(p) for p in paths),
                message=f"no DEM file ({', '.join(DEM_SUFFIXES)}) found",
            )
        )
    return found


@dataclass(frozen=True)
class _Tile:
    path: Path
    crs: CRS
    bounds_lonlat: shapely.Polygon


def _open_tiles(paths: Sequence[Path]) -> list[_Tile]:
    tiles = []
    for p in paths:
        try:
            with rasterio.open(p) as src:
                if src.crs is None:
                    raise InputError(Problem(file=str(p), message="DEM has no coordinate system"))
                check_one_band(p, src.count)
                if src.transform.b != 0 or src.transform.d != 0:
                    raise InputError(
                        Problem(file=str(p), message="rotated DEM grids are not supported")
                    )
                crs = CRS.from_user_input(src.crs.to_wkt())
                w, s, e, n = rasterio.warp.transform_bounds(src.crs, "EPSG:4326", *src.bounds)
        except rasterio.errors.RasterioIOError as exc:
            raise InputError(
                Problem(file=str(p), message=f"not a readable raster: {exc}")
            ) from None
        tiles.append(_Tile(Path(p), crs, shapely.box(w, s, e, n)))
    return tiles


class DemSet:
    """A set of DEM tiles (one CRS per block); picks the tiles that cover each block."""

    def __init__(self, paths: Sequence[Path], max_pixels: int = DEFAULT_MAX_PIXELS):
        self.files = find_dem_files(paths)
        self.tiles = _open_tiles(self.files)
        self.max_pixels = max_pixels

    def factors(self, polygon_lonlat: shapely.Geometry) -> TerrainFactors:
        """§AF-1..3 over a lon/lat polygon (the block's covered area; across ±180° unwrapped
        as one piece, its longitudes beyond ±180 on one side: lonlat.unwrapped). A tile on
        the other side of ±180° is read turned by a whole turn to lie beside it."""
        turns = _turns(self.tiles, polygon_lonlat)
        used = [
            (t, turn)
            for t, turn in zip(self.tiles, turns, strict=True)
            if shapely.intersects(_turned_box(t.bounds_lonlat, turn), polygon_lonlat)
        ]
        if not used:
            nan = float("nan")
            return TerrainFactors(nan, nan, nan, 0.0, 0, 1, [])
        crss = {t.crs.to_wkt() for t, _ in used}
        if len(crss) > 1:
            raise InputError(
                Problem(
                    file=", ".join(str(t.path) for t, _ in used),
                    message="the DEM tiles covering this block are in different coordinate "
                    "systems; give tiles in one CRS",
                )
            )
        crs = used[0][0].crs
        tiles = [(t.path, turn if crs.is_geographic else 0.0) for t, turn in used]
        return _terrain_over(polygon_lonlat, tiles, crs, self.max_pixels)


def _turns(tiles: list[_Tile], polygon_lonlat: shapely.Geometry) -> np.ndarray:
    """The whole turns (degrees) that bring each tile's middle longitude within 180° of the
    polygon's: zero for every tile of a block away from ±180°."""
    west, _, east, _ = shapely.bounds(polygon_lonlat)
    middles = np.array([(t.bounds_lonlat.bounds[0] + t.bounds_lonlat.bounds[2]) / 2 for t in tiles])
    return turns_towards(middles, (west + east) / 2.0)


def _turned_box(box: shapely.Geometry, turn: float) -> shapely.Geometry:
    return box if turn == 0 else shapely.transform(box, lambda xy: xy + [turn, 0.0])


def _open_turned(stack: ExitStack, path: Path, turn: float) -> rasterio.DatasetReader:
    """A DEM tile opened, its longitudes turned by `turn` degrees (a lon/lat tile on the other
    side of ±180° from the block) through a VRT over the same cells: nothing is copied."""
    src = stack.enter_context(rasterio.open(path))
    if turn == 0:
        return src
    t = src.transform
    gt = ", ".join(repr(float(v)) for v in (t.c + turn, t.a, t.b, t.f, t.d, t.e))
    nodata = "" if src.nodata is None else f"<NoDataValue>{src.nodata!r}</NoDataValue>"
    kind = rasterio.dtypes.typename_fwd[rasterio.dtypes.dtype_rev[src.dtypes[0]]]  # "Int16" …
    name = xml_escape(str(Path(path).absolute()))
    vrt = (
        f'<VRTDataset rasterXSize="{src.width}" rasterYSize="{src.height}">'
        f"<SRS>{xml_escape(src.crs.to_wkt())}</SRS><GeoTransform>{gt}</GeoTransform>"
        f'<VRTRasterBand dataType="{kind}" band="1">{nodata}<SimpleSource>'
        f'<SourceFilename relativeToVRT="0">{name}</SourceFilename><SourceBand>1</SourceBand>'
        "</SimpleSource></VRTRasterBand></VRTDataset>"
    )
    return stack.enter_context(rasterio.open(vrt))


def _check_full_resolution(
    srcs: list[tuple[str, rasterio.DatasetReader]],
    bounds: tuple[float, float, float, float],
    max_pixels: int,
    gain: float = 1.0,
    offset: float = 0.0,
) -> None:
    """`check_heights` on every cell of the tiles within `bounds`, read at their own grid in
    strips of at most `max_pixels` cells: an average over k×k cells would hide a no-data value
    such as −32768 among real heights (3·800 m and −32768 m average to −7592 m)."""
    for name, src in srcs:
        win = rasterio.windows.from_bounds(*bounds, transform=src.transform)
        col0, row0 = max(math.floor(win.col_off), 0), max(math.floor(win.row_off), 0)
        col1 = min(math.ceil(win.col_off + win.width), src.width)
        row1 = min(math.ceil(win.row_off + win.height), src.height)
        if col1 <= col0:
            continue
        rows = max(1, max_pixels // (col1 - col0))
        for top in range(row0, row1, rows):
            strip = rasterio.windows.Window(col0, top, col1 - col0, min(rows, row1 - top))
            values = src.read(1, window=strip, masked=True).astype(np.float32).filled(np.nan)
            values = values * gain + offset
            check_heights(name, values, src.window_transform(strip), origin=(top, col0))


def _to_metres(paths: list[Path]) -> tuple[float, float]:
    """Gain and offset taking the tiles' stored values to metres: the band's scale and offset
    (heights stored as decimetres) and its unit (feet). Tiles that disagree are refused: one
    mosaic holds one kind of value."""
    got = {}
    for path in paths:  # the files, not the VRTs of turned tiles (which say no scale)
        with rasterio.open(path) as src:
            metres, _ = height_unit(Path(path))
            got[str(path)] = (src.scales[0] * metres, src.offsets[0] * metres)
    if len(set(got.values())) > 1:
        shown = ", ".join(f"{name} (×{g:g} + {o:g} m)" for name, (g, o) in got.items())
        raise InputError(
            Problem(
                file=", ".join(got),
                message=f"the DEM tiles covering this block store their heights in different "
                f"units or scales: {shown}; give tiles of one kind",
            )
        )
    return next(iter(got.values()))


def _terrain_over(
    polygon_lonlat: shapely.Geometry, tiles: list[tuple[Path, float]], crs: CRS, max_pixels: int
) -> TerrainFactors:
    """§AF-1..3 over a lon/lat polygon from the DEM tiles (path, turn of its longitudes), all
    in `crs`: the means of the heights, slopes and roughness inside it, weighted by each
    cell's area, and the share of its area that has a height."""
    paths = [p for p, _ in tiles]
    poly = _in_dem_crs(polygon_lonlat, crs)
    zf, transform, k = _heights_over(poly, tiles, max_pixels)
    check_heights(", ".join(str(p) for p in paths), zf, transform)
    inside = rasterio.features.geometry_mask(
        [poly], out_shape=zf.shape, transform=transform, invert=True
    )
    dx, dy = pixel_sizes_m(transform, crs, zf.shape[0])
    weight = np.broadcast_to((dx * dy)[:, None], zf.shape)
    slope = horn_slope(zf, dx, dy)
    rough = roughness(zf)
    valid = inside & np.isfinite(zf)
    w_in = weight[inside].sum()
    names = [str(p) for p in paths]
    if not valid.any() or w_in <= 0:
        nan = float("nan")
        return TerrainFactors(nan, nan, nan, 0.0, 0, k, names)
    vs = inside & np.isfinite(slope)

    def wmean(values: np.ndarray, sel: np.ndarray) -> float:
        return float(np.average(values[sel], weights=weight[sel])) if sel.any() else float("nan")

    return TerrainFactors(
        mean_elevation_m=wmean(zf, valid),
        mean_slope_deg=wmean(slope, vs),
        mean_roughness_m=wmean(rough, vs),
        dem_coverage=float(weight[valid].sum() / w_in),
        n_pixels=int(valid.sum()),
        resolution_factor=k,
        dem_files=names,
    )


def _in_dem_crs(polygon_lonlat: shapely.Geometry, crs: CRS) -> shapely.Geometry:
    """The block's lon/lat polygon in the DEM's CRS (its edges segmentized first, so that they
    follow the projection)."""
    if wgs84_lonlat(crs):
        return polygon_lonlat
    tr = Transformer.from_crs(WGS84, crs, always_xy=True)
    return shapely.transform(
        shapely.segmentize(polygon_lonlat, 0.01),
        lambda xy: np.column_stack(tr.transform(xy[:, 0], xy[:, 1])),
    )


def _heights_over(
    poly: shapely.Geometry, tiles: list[tuple[Path, float]], max_pixels: int
) -> tuple[np.ndarray, Affine, int]:
    """The heights (m, NaN for no data) of the tiles over the polygon's bounds, on the first
    tile's grid with two cells of margin, their transform and the resolution factor k: read
    averaged over k×k cells where the extent holds more than `max_pixels` cells, after every
    cell is checked at the tiles' own grid."""
    with ExitStack() as stack:
        srcs = [_open_turned(stack, p, turn) for p, turn in tiles]
        t0 = srcs[0].transform
        res_x, res_y = abs(t0.a), abs(t0.e)
        minx, miny, maxx, maxy = poly.bounds
        # snap to the first tile's grid, two cells of margin for the 3×3 windows at the edge
        left = t0.c + (math.floor((minx - t0.c) / res_x) - 2) * res_x
        right = t0.c + (math.ceil((maxx - t0.c) / res_x) + 2) * res_x
        top = t0.f - (math.floor((t0.f - maxy) / res_y) - 2) * res_y
        bottom = t0.f - (math.ceil((t0.f - miny) / res_y) + 2) * res_y
        npix = (right - left) / res_x * (top - bottom) / res_y
        k = max(1, math.ceil(math.sqrt(npix / max_pixels)))
        gain, offset = _to_metres([p for p, _ in tiles])
        if k > 1:
            named = list(zip([str(p) for p, _ in tiles], srcs, strict=True))
            _check_full_resolution(named, (left, bottom, right, top), max_pixels, gain, offset)
        z, transform = rasterio.merge.merge(
            srcs,
            bounds=(left, bottom, right, top),
            res=(res_x * k, res_y * k),
            nodata=np.nan,
            dtype="float64",
            resampling=Resampling.average if k > 1 else Resampling.nearest,
            masked=True,
        )
    return np.ma.filled(z[0].astype(float), np.nan) * gain + offset, transform, k
