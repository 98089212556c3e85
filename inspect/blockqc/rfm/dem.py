"""Digital elevation models as ellipsoidal heights for the RFM (§MB-2, §RA-1).

RPC heights are ellipsoidal (WGS-84). SRTM and most national DEMs give heights above a geoid
(SRTM: EGM96), so h_ellipsoid = h_DEM + N, with N the geoid undulation (`blockqc.rfm.geoid`: a
grid file, the shipped EGM96 grid or a constant). `load_dem` makes that conversion from what the
DEM declares or the caller states, refuses an unknown reference, and records it in
`DEM.vertical`, so reports can say which heights were used.

Sampling is bilinear between pixel centres, vectorized; points outside the DEM (or on voids) give
NaN. A DEM in a projected CRS (e.g. a UTM DSM) is sampled after converting lon/lat to its CRS.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Transformer
from rasterio.transform import Affine

from blockqc.errors import InputError, Problem
from blockqc.rfm import geoid as geoid_mod
from blockqc.rfm.readers import check_whole, reading_pixels

if TYPE_CHECKING:
    from rasterio.io import DatasetReader
    from rasterio.windows import Window

FloatArray = NDArray[np.float64]


WGS84 = CRS.from_epsg(4326)


def wgs84_lonlat(crs: CRS) -> bool:
    """Whether a grid's x, y are WGS-84 longitude and latitude in degrees. A lon/lat CRS on
    another datum (ED50, Pulkovo 1942, Beijing 1954) is not: its coordinates of a place differ
    from WGS-84's by up to a few hundred metres, and are transformed as a projected CRS's are."""
    return crs.is_geographic and crs.equals(WGS84, ignore_axis_order=True)


@dataclass(frozen=True, eq=False)
class Grid:
    """A north-up raster of values with its GDAL geotransform (pixel corner) and CRS."""

    values: FloatArray
    transform: Affine
    crs: CRS
    source: str = ""
    wraps: bool = False
    """A lon/lat grid round the globe, its first column repeated as its last (CLOSED)."""
    unit: str = ""
    """The unit the file's values were converted from to metres (e.g. 'US survey foot'), or ''."""

    def sample(self, x: ArrayLike, y: ArrayLike) -> FloatArray:
        """Bilinear value at (x, y) in the grid's CRS; NaN outside the outermost pixel centres
        (a half-pixel border is sampled from the edge pixels). A lon/lat grid takes longitudes
        of either convention (−180…180, 0…360); one that wraps takes every longitude round the
        globe, between its first and last column."""
        x = np.asarray(x, np.float64)
        y = np.asarray(y, np.float64)
        t = self.transform  # north-up (checked at load): pixel-centre indices
        if self.crs.is_geographic:
            first = t.c + t.a / 2 if self.wraps else t.c
            x = first + np.mod(x - first, 360.0)
        col = (x - t.c) / t.a - 0.5
        row = (y - t.f) / t.e - 0.5
        nr, nc = self.values.shape
        inside = (row >= -0.5) & (row <= nr - 0.5) & (col >= -0.5) & (col <= nc - 0.5)
        row = np.clip(np.where(np.isfinite(row), row, 0.0), 0.0, nr - 1.0)
        col = np.clip(np.where(np.isfinite(col), col, 0.0), 0.0, nc - 1.0)
        r0 = np.floor(row).astype(np.intp)
        c0 = np.floor(col).astype(np.intp)
        r1 = np.minimum(r0 + 1, nr - 1)
        c1 = np.minimum(c0 + 1, nc - 1)
        fr = row - r0
        fc = col - c0
        v = self.values
        out = np.zeros(row.shape)
        # a neighbour of weight 0 (a point on a node or an edge) must not bring its NaN in
        for rr, cc, w in (
            (r0, c0, (1 - fr) * (1 - fc)),
            (r0, c1, (1 - fr) * fc),
            (r1, c0, fr * (1 - fc)),
            (r1, c1, fr * fc),
        ):
            out += np.where(w > 0, v[rr, cc] * w, 0.0)
        return np.where(inside, out, np.nan)


@dataclass(frozen=True, eq=False)
class DEM:
    """Ellipsoidal heights (WGS-84) sampled at lon/lat; `vertical` says how they were obtained."""

    grid: Grid
    vertical: str
    """e.g. 'ellipsoidal (WGS-84)' or 'SRTM geoid heights + EGM96 undulation (egm96_15.gtx)'."""
    mean_height: float = field(init=False)
    """Mean of the heights read (m): where image→ground iterations on this DEM start."""
    height_range: tuple[float, float] = field(init=False)
    """Lowest and highest height read (m): the span searched along a line of sight."""

    def __post_init__(self) -> None:
        finite = self.grid.values[np.isfinite(self.grid.values)]
        object.__setattr__(self, "mean_height", float(finite.mean()) if finite.size else np.nan)
        object.__setattr__(
            self,
            "height_range",
            (float(finite.min()), float(finite.max())) if finite.size else (np.nan, np.nan),
        )
        crs = self.grid.crs
        object.__setattr__(
            self,
            "_to_grid",
            None if wgs84_lonlat(crs) else Transformer.from_crs(WGS84, crs, always_xy=True),
        )

    def height(self, lon: ArrayLike, lat: ArrayLike) -> FloatArray:
        """Ellipsoidal height (m) at lon/lat (degrees), bilinear; NaN off the DEM."""
        lon = np.asarray(lon, np.float64)
        lat = np.asarray(lat, np.float64)
        to_grid = self._to_grid  # type: ignore[attr-defined]
        if to_grid is None:
            return self.grid.sample(lon, lat)
        x, y = to_grid.transform(lon, lat)
        return self.grid.sample(x, y)

    __call__ = height


LOWEST_HEIGHT_M = -12_000.0
"""Below any height on Earth (the Challenger Deep is about −10 994 m): a DEM value under it
is a no-data marker the file does not declare (SRTM's −32768), not a height."""
HIGHEST_HEIGHT_M = 9_000.0
"""Above any height on Earth (Everest, 8 849 m): a no-data marker such as 32767 or 3.4e38."""


def check_heights(
    path: Path | str,
    values: FloatArray,
    transform: Affine,
    what: str = "DEM",
    origin: tuple[int, int] | None = None,
) -> None:
    """Refuse heights no terrain has (LOWEST_HEIGHT_M … HIGHEST_HEIGHT_M): an undeclared
    no-data value taken as a height would pull every mean, slope and intersection with it.
    The first such cell is named by its centre in the grid's CRS (`transform`) and, given the
    (row, column) in the file of `values`' first cell (`origin`), by its row and column."""
    with np.errstate(invalid="ignore"):
        beyond = (values < LOWEST_HEIGHT_M) | (values > HIGHEST_HEIGHT_M)
    if not beyond.any():
        return
    row, col = np.argwhere(beyond)[0]
    value = float(values[row, col])
    x, y = transform * (col + 0.5, row + 0.5)
    where = f"x {x:.6g}, y {y:.7g} in the {what}'s CRS"
    if origin is not None:
        where = f"row {row + origin[0]}, column {col + origin[1]} ({where})"
    raise InputError(
        Problem(
            file=str(path),
            message=f"the {what} holds {int(beyond.sum())} cell(s) beyond any height on Earth "
            f"(expected {LOWEST_HEIGHT_M:g} to {HIGHEST_HEIGHT_M:g} m), the first {value:g} at "
            f"{where}: a no-data value the file does not declare? Declare it "
            f"(gdal_edit.py -a_nodata {value:g} FILE) or fill those cells",
        )
    )


def check_one_band(path: Path | str, count: int, what: str = "DEM") -> None:
    """Refuse a raster of several bands: which one holds the heights is not for blockqc to guess."""
    if count != 1:
        raise InputError(
            Problem(
                file=str(path),
                message=f"the {what} has {count} bands: expected one band of heights "
                "(extract it first, e.g. gdal_translate -b N)",
            )
        )


MIN_PIXEL = 1e-9
"""Smallest pixel size accepted, in the grid's CRS units (1e-9° is 0.1 mm): below it the
geotransform is degenerate (e.g. a file read by the wrong GDAL driver)."""


def _check_transform(path: Path, t: Affine, what: str) -> None:
    """Refuse a grid that is not north-up or whose pixel size is (near) zero or not finite."""
    if not all(np.isfinite(v) for v in (t.a, t.b, t.c, t.d, t.e, t.f)):
        message = f"the {what} has a geotransform that is not finite: {tuple(t)[:6]}"
    elif t.b != 0 or t.d != 0 or t.a <= 0 or t.e >= 0:
        message = f"the {what} must be a north-up grid, got {t}"
    elif t.a < MIN_PIXEL or -t.e < MIN_PIXEL or t.is_degenerate:
        message = (
            f"the {what} has a degenerate geotransform: pixel size {t.a:.3g} × {-t.e:.3g} "
            f"(expected pixel sizes of at least {MIN_PIXEL:g} CRS units; is the file in the "
            "format its name says, e.g. not an SRTM .hgt renamed .gtx?)"
        )
    else:
        return
    raise InputError(Problem(file=str(path), message=message))


class NotCovered(InputError):
    """The lon/lat window asked of a grid lies outside it. `what` is the grid's role ('DEM',
    'geoid grid') and `extent` what it covers (west, south, east, north in degrees; None when
    its CRS cannot say), for a caller that knows why the window was asked to say so."""

    def __init__(
        self,
        problem: Problem,
        *,
        what: str,
        extent: tuple[float, float, float, float] | None,
    ):
        super().__init__(problem)
        self.what = what
        self.extent = extent


def _lonlat_extent(
    crs: CRS, t: Affine, width: int, height: int
) -> tuple[float, float, float, float] | None:
    """West, south, east, north (degrees) of a north-up grid; None when its CRS cannot be
    taken to lon/lat (for messages only)."""
    from pyproj.exceptions import ProjError

    west, south, east, north = t.c, t.f + height * t.e, t.c + width * t.a, t.f
    if not wgs84_lonlat(crs):
        try:
            west, south, east, north = Transformer.from_crs(
                crs, WGS84, always_xy=True
            ).transform_bounds(west, south, east, north, densify_pts=21)
        except ProjError:
            return None
    box = (float(west), float(south), float(east), float(north))
    return box if np.all(np.isfinite(box)) else None


def _read_grid(path: Path, bounds: tuple[float, float, float, float] | None, what: str) -> Grid:
    """Read a raster (or the window of it covering lon/lat `bounds`) as float64 with NaN voids."""
    import rasterio
    from rasterio.errors import RasterioIOError
    from rasterio.windows import Window

    try:
        ds = rasterio.open(path)
    except RasterioIOError as exc:
        raise InputError(Problem(file=str(path), message=f"cannot open {what}: {exc}")) from None
    with ds:
        check_whole(ds, path, what)
        if ds.crs is None:
            raise InputError(Problem(file=str(path), message=f"the {what} has no CRS"))
        check_one_band(path, ds.count, what)
        t = ds.transform
        _check_transform(path, t, what)
        crs = CRS.from_wkt(ds.crs.to_wkt())
        if len(crs.axis_info) > 2:
            crs = crs.to_2d()  # heights are the values; the grid is horizontal
        window = Window(0, 0, ds.width, ds.height)
        closing = _round_the_globe(crs, t, ds.width)
        if bounds is not None:
            window = _covering_window(ds, crs, bounds, closing, path, what)
        with reading_pixels(path, what):
            values = ds.read(1, window=window, masked=True).astype(np.float64).filled(np.nan)
        values = values * ds.scales[0] + ds.offsets[0]  # a band stored scaled (dm, cm)
        metres, unit = height_unit(path, what)
        values *= metres
        transform = ds.window_transform(window)
        check_heights(path, values, transform, what, (int(window.row_off), int(window.col_off)))
        wraps = closing is not None and window.width == ds.width
        if wraps and closing:
            values = np.concatenate([values, values[:, :1]], axis=1)
        return Grid(values, transform, crs, str(path), wraps=wraps, unit=unit)


def _covering_window(
    ds: DatasetReader,
    crs: CRS,
    bounds: tuple[float, float, float, float],
    closing: int | None,
    path: Path,
    what: str,
) -> Window:
    """The window of the open raster `ds` (horizontal CRS `crs`) that covers lon/lat `bounds`
    with two pixels to spare, every column of a grid that closes round the globe (`closing` not
    None) when it reaches the seam; NotCovered when the raster does not reach the bounds."""
    from rasterio.windows import Window, from_bounds

    t = ds.transform
    west, south, east, north = bounds
    if not wgs84_lonlat(crs):
        tr = Transformer.from_crs(WGS84, crs, always_xy=True)
        west, south, east, north = tr.transform_bounds(west, south, east, north)
    if crs.is_geographic:  # the RPCs' and the grid's longitudes: −180…180 or 0…360
        shift = _lon_shift(west, east, t.c, t.c + ds.width * t.a)
        west, east = west + shift, east + shift
    w = from_bounds(west, south, east, north, transform=t)
    col0 = max(int(np.floor(w.col_off)) - 2, 0)
    row0 = max(int(np.floor(w.row_off)) - 2, 0)
    col1 = min(int(np.ceil(w.col_off + w.width)) + 2, ds.width)
    row1 = min(int(np.ceil(w.row_off + w.height)) + 2, ds.height)
    if closing is not None and (col0 == 0 or col1 == ds.width):
        col0, col1 = 0, ds.width  # at the seam: every column, to close the globe
    if col1 <= col0 or row1 <= row0:
        raise NotCovered(
            Problem(
                file=str(path),
                message=f"the {what} does not cover lon {bounds[0]:.4f}..{bounds[2]:.4f}, "
                f"lat {bounds[1]:.4f}..{bounds[3]:.4f}",
            ),
            what=what,
            extent=_lonlat_extent(crs, t, ds.width, ds.height),
        )
    return Window(col0, row0, col1 - col0, row1 - row0)


_US_FOOT = 1200.0 / 3937.0
#: metres per unit of the unit words a band or a vertical CRS may give its heights in
METRES_PER = {
    "m": 1.0, "metre": 1.0, "meter": 1.0, "metres": 1.0, "meters": 1.0,
    "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "international foot": 0.3048,
    "us survey foot": _US_FOOT, "ftus": _US_FOOT, "us-ft": _US_FOOT, "foot_us": _US_FOOT,
}  # fmt: skip


def unit_factor(name: str) -> float | None:
    """Metres per unit of a band's unit word, which may carry a description after it ('meters
    above sea level', 'Meter (m)', 'ft (US survey)'); None for any other unit."""
    words = re.split(r"[\s(),;:\[\]]+", name.lower().replace("_", " ").strip())
    for n in range(len(words), 0, -1):  # the longest known start: 'us survey foot' before 'us'
        factor = METRES_PER.get(" ".join(words[:n]))
        if factor is not None:
            return _US_FOOT if factor == 0.3048 and "us" in words[n:] else factor
    return None


def height_unit(path: Path, what: str = "DEM") -> tuple[float, str]:
    """Metres per unit of a raster's values, from its band unit and its vertical CRS (a compound
    or 3-D CRS), and the unit's name ('' for metres or none said); a unit other than metres or
    feet, or a band and a CRS that disagree, is refused: heights in feet read as metres are
    3.28 times too large."""
    import rasterio

    with rasterio.Env(GTIFF_REPORT_COMPD_CS=True), rasterio.open(path) as ds:
        said = [("its band unit", (ds.units[0] or "").strip(), None)]
        if ds.crs is not None:
            said.append(_vertical_unit(CRS.from_wkt(ds.crs.to_wkt())))
    found = {}
    for where, name, factor in said:
        if not name:
            continue
        factor = factor if factor is not None else unit_factor(name)
        if factor is None:
            raise InputError(
                Problem(
                    file=str(path),
                    message=f"the {what}'s heights are in {name!r} ({where}): expected metres "
                    "or feet",
                )
            )
        found[where] = (name, factor)
    factors = {round(f, 9) for _, f in found.values()}
    if len(factors) > 1:
        shown = ", ".join(f"{n!r} ({w})" for w, (n, _) in found.items())
        raise InputError(
            Problem(
                file=str(path),
                message=f"the {what} gives its heights in {shown}: expected one unit",
            )
        )
    name, factor = next(iter(found.values()), ("", 1.0))
    return factor, "" if factor == 1.0 else name


def _vertical_unit(crs: CRS) -> tuple[str, str, float | None]:
    """(where, unit name, metres per unit) of a CRS's vertical axis ('' when it has none)."""
    if crs.is_compound:
        axes = crs.sub_crs_list[-1].axis_info
    elif len(crs.axis_info) == 3:
        axes = crs.axis_info[2:]
    else:
        return "its CRS", "", None
    axis = axes[0]
    return f"its CRS '{crs.name}'", axis.unit_name, axis.unit_conversion_factor


def _lon_shift(west: float, east: float, grid_west: float, grid_east: float) -> float:
    """The turn (−360, 0 or 360°) that brings longitudes west…east onto a lon/lat grid spanning
    grid_west…grid_east: the one of most overlap, 0 on a tie."""
    return max(
        (0.0, -360.0, 360.0),
        key=lambda turn: min(east + turn, grid_east) - max(west + turn, grid_west),
    )


def _round_the_globe(crs: CRS, t: Affine, width: int) -> int | None:
    """For a lon/lat grid whose columns go round the globe, the columns to add to close it:
    0 when its last repeats its first (nodes at both −180° and 180°), 1 when not (−180° to
    179.75° on a 15' grid); None for any other grid."""
    if not crs.is_geographic:
        return None
    span = width * t.a
    for closing, full in ((1, 360.0), (0, 360.0 + t.a)):
        if abs(span - full) <= 1e-6 * full:
            return closing
    return None


def fill_voids(values: FloatArray, max_steps: int) -> FloatArray:
    """Close the holes of a DEM: the voids (NaN) within `max_steps` cells of data everywhere
    (holes up to ~2·max_steps cells across, however long), each cell from the mean of its
    known 8-neighbours, growing inwards; larger voids and those reaching the grid's edge (the
    outside) stay NaN, whole."""
    from scipy.ndimage import convolve

    out = values.copy()
    hole = _holes(np.isnan(out), max_steps)
    kernel = np.ones((3, 3))
    kernel[1, 1] = 0.0
    for _ in range(max_steps):
        void = np.isnan(out)
        fill_here = hole & void
        if not fill_here.any():
            break
        total = convolve(np.where(void, 0.0, out), kernel, mode="constant")
        count = convolve((~void).astype(np.float64), kernel, mode="constant")
        fill = fill_here & (count > 0)
        out[fill] = total[fill] / count[fill]
    return out


def _holes(void: np.ndarray, max_steps: int) -> np.ndarray:
    """The void cells of the voids (8-connected) that do not touch the grid's edge and whose
    every cell lies within `max_steps` cells (8-neighbour steps) of a known one."""
    from scipy import ndimage

    if max_steps <= 0 or not void.any() or void.all():
        return np.zeros(void.shape, bool)
    depth = ndimage.distance_transform_cdt(void, metric="chessboard")
    labels, n = ndimage.label(void, structure=np.ones((3, 3)))
    index = np.arange(1, n + 1)
    deepest = np.asarray(ndimage.maximum(depth, labels, index))
    edge = np.zeros(n + 1, bool)
    edge[np.unique(np.concatenate([labels[[0, -1], :].ravel(), labels[:, [0, -1]].ravel()]))] = True
    closed = index[(deepest <= max_steps) & ~edge[1:]]
    return np.isin(labels, closed)


def _node_lonlat(grid: Grid) -> tuple[FloatArray, FloatArray]:
    """lon/lat (degrees) of every DEM node centre."""
    nr, nc = grid.values.shape
    cols, rows = np.meshgrid(np.arange(nc) + 0.5, np.arange(nr) + 0.5)
    xs = grid.transform.c + cols * grid.transform.a
    ys = grid.transform.f + rows * grid.transform.e
    if wgs84_lonlat(grid.crs):
        return np.asarray(xs), np.asarray(ys)
    tr = Transformer.from_crs(grid.crs, WGS84, always_xy=True)
    lon, lat = tr.transform(xs, ys)
    return np.asarray(lon), np.asarray(lat)


def _unknown_reference(
    why: str, n_here: float, plane_per_m: float | None, offset_option: str | None
) -> str:
    """The message for a DEM whose height reference is not known: the options the command has,
    and what declaring it ellipsoidal would cost if it is not."""
    cost = f"tens of metres (EGM96: N = {n_here:.1f} m here)"
    moved = "metres of plane error wherever the view is oblique"
    if plane_per_m is not None and np.isfinite(plane_per_m) and np.isfinite(n_here):
        moved = f"{abs(n_here) * plane_per_m:.1f} m of plane error for this image's view"
    grid = "--geoid FILE (a geoid grid, e.g. egm96_15.gtx or a national one)"
    if offset_option:
        grid += f" or {offset_option} METRES (a constant undulation N)"
    return (
        f"{why}; RPC heights are WGS-84 ellipsoidal, so the DEM must be converted. Most DEMs "
        "(SRTM, ASTER, Copernicus, national DEMs) give heights above a geoid: pass --geoid egm96 "
        f"(the EGM96 grid shipped with blockqc) or {grid}. Use --dem-vertical "
        "ellipsoid only for a DEM known to hold ellipsoidal heights: a geoid DEM taken as "
        f"ellipsoidal has every height off by N, {cost}, which moves the corrected image by "
        f"N·tan(view angle): {moved}"
    )


def _check_choice(
    path: Path,
    declared: str | None,
    how: str,
    geoid: str | Path | None,
    geoid_offset: float | None,
    vertical: str,
    offset_option: str | None,
) -> None:
    """Refuse contradictory statements about the DEM's height reference (`offset_option`: the
    command's option of a constant undulation, None when it has none)."""

    def refuse(message: str) -> None:
        raise InputError(Problem(file=str(path), message=message))

    if vertical not in ("auto", "geoid", "ellipsoid"):
        refuse(f"vertical must be 'auto', 'geoid' or 'ellipsoid', got {vertical!r}")
    given = geoid is not None or geoid_offset is not None
    if geoid is not None and geoid_offset is not None:
        refuse("give either a geoid (--geoid) or a constant undulation (--geoid-offset), not both")
    geoid_options = f"--geoid/{offset_option}" if offset_option else "--geoid"
    if vertical == "ellipsoid" and given:
        refuse(f"--dem-vertical ellipsoid contradicts {geoid_options} (geoid heights)")
    if declared == geoid_mod.ELLIPSOID and (given or vertical == "geoid"):
        refuse(f"the DEM declares ellipsoidal heights ({how}): no geoid conversion applies")
    if declared not in (None, geoid_mod.ELLIPSOID) and vertical == "ellipsoid":
        refuse(
            f"the DEM declares {declared} geoid heights ({how}); --dem-vertical ellipsoid would "
            "leave every height off by the geoid undulation (tens of metres)"
        )
    named = "EGM96" if str(geoid).lower() == "egm96" else None
    if declared not in (None, geoid_mod.ELLIPSOID, "EGM96") and named == "EGM96":
        offset = f", or its undulation here with {offset_option}" if offset_option else ""
        refuse(
            f"the DEM declares {declared} heights ({how}), not EGM96: pass that model's grid "
            f"with --geoid FILE{offset}"
        )


def _check_model(
    path: Path, declared: str | None, how: str, g: geoid_mod.Geoid, grid_file: Path
) -> None:
    """Refuse a geoid grid of another model than the one the DEM declares, both being known
    (an EGM96 grid for EGM2008 heights is off by up to metres)."""
    unknown = (None, geoid_mod.ELLIPSOID, "an unnamed vertical datum")  # `vertical_model`'s
    if declared in unknown or g.model is None or g.model == declared:
        return
    raise InputError(
        Problem(
            file=str(path),
            message=f"the DEM declares {declared} heights ({how}), but the geoid grid "
            f"{grid_file.name} is {g.model}: give a {declared} grid with --geoid FILE",
        )
    )


def _resolve_geoid(
    path: Path,
    grid: Grid,
    declared: str | None,
    how: str,
    geoid: str | Path | None,
    geoid_offset: float | None,
    vertical: str,
    plane_per_m: float | None,
    offset_option: str | None,
) -> geoid_mod.Geoid | None:
    """The geoid to add to the DEM's heights (None: the heights are already ellipsoidal)."""
    _check_choice(path, declared, how, geoid, geoid_offset, vertical, offset_option)
    if geoid_offset is not None:
        return geoid_mod.constant_geoid(float(geoid_offset))
    if geoid is not None and str(geoid).lower() == "egm96":
        return geoid_mod.egm96()
    if geoid is not None:
        lon, lat = _node_lonlat(grid)
        box = (np.min(lon) - 0.5, np.min(lat) - 0.5, np.max(lon) + 0.5, np.max(lat) + 0.5)
        g = geoid_mod.geoid_from_file(Path(geoid), tuple(float(v) for v in box))
        _check_model(path, declared, how, g, Path(geoid))
        return g
    if vertical == "ellipsoid" or declared == geoid_mod.ELLIPSOID:
        return None
    if declared == "EGM96":
        return geoid_mod.egm96()
    if declared is not None:
        why = f"the DEM declares {declared} heights ({how}) and blockqc ships only EGM96"
    elif vertical == "geoid":
        why = "the DEM is said to hold geoid heights (--dem-vertical geoid) but no geoid was given"
    else:
        why = f"the DEM does not say what its heights are measured from ({how})"
    lon, lat = _node_lonlat(grid)
    n_here = float(geoid_mod.egm96().undulation(np.nanmean(lon), np.nanmean(lat)))
    message = _unknown_reference(why, n_here, plane_per_m, offset_option)
    raise InputError(Problem(file=str(path), message=message))


def load_dem(
    path: str | Path,
    *,
    geoid: str | Path | None = None,
    geoid_offset: float | None = None,
    vertical: str = "auto",
    bounds: tuple[float, float, float, float] | None = None,
    fill: int = 0,
    plane_per_m: float | None = None,
    offset_option: str | None = "--geoid-offset",
) -> DEM:
    """Load a DEM as ellipsoidal heights, h = H + N for a geoid DEM (§MB-2).

    The height reference is what the file declares (compound or 3-D CRS, SRTM .hgt: EGM96)
    unless the caller states it: `geoid` ('egm96' for the shipped grid, or a grid file),
    `geoid_offset` (constant N, m) or `vertical` 'ellipsoid'; contradictions and an unknown
    reference are refused. `plane_per_m` (plane metres per metre of height error for the image's
    view) makes that refusal say what a wrong choice would cost. `bounds` (west, south, east,
    north in degrees) restricts reading to the window needed; `fill` > 0 closes small voids.
    `offset_option` is the caller's option for a constant undulation, named in the messages
    (None: the command has none, e.g. `adjust`).
    """
    path = Path(path)
    declared, how = geoid_mod.declared_reference(path)
    grid = _read_grid(path, bounds, "DEM")
    if fill > 0:
        grid = replace(grid, values=fill_voids(grid.values, fill))
    g = _resolve_geoid(
        path, grid, declared, how, geoid, geoid_offset, vertical, plane_per_m, offset_option
    )
    unit = f", in {grid.unit} converted to metres" if grid.unit else ""
    if g is None:
        said = f"declared by {how}" if declared == geoid_mod.ELLIPSOID else "as stated by the user"
        return DEM(grid, f"ellipsoidal (WGS-84) heights from {path.name} ({said}{unit})")
    lon, lat = _node_lonlat(grid)
    n = g.undulation(lon, lat)
    if np.any(np.isnan(n) & np.isfinite(grid.values)):
        raise InputError(
            Problem(file=g.description, message=f"the geoid does not cover {path.name}")
        )
    source = f"declared by {how}" if declared not in (None, geoid_mod.ELLIPSOID) else "stated"
    return DEM(
        replace(grid, values=grid.values + n, source=str(path)),
        f"geoid heights from {path.name} ({declared or 'geoid'}, {source}{unit}) + undulation N "
        f"from {g.description} (N {np.nanmin(n):.2f}..{np.nanmax(n):.2f} m) = ellipsoidal (WGS-84)",
    )


def constant_height(h: float) -> DEM:
    """A flat 'DEM' at ellipsoidal height h over the whole globe (for tests and flat terrain)."""
    values = np.full((2, 2), float(h))
    grid = Grid(values, Affine(180.0, 0.0, -180.0, 0.0, -90.0, 90.0), CRS.from_epsg(4326), "")
    return DEM(grid, f"constant ellipsoidal height {h} m")
