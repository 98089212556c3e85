"""RPC correction (§RA-1): orthorectify an image with its (refined) RFM and a DEM, chunk by chunk.

The output is a north-up grid in a projected CRS (by default the UTM zone of the scene centre,
§MB-3) at the image's GSD. Each output chunk is filled by the inverse mapping: pixel centre
(x, y) → (lon, lat) → h from the DEM → (row, col) with the model's ground→image → bilinear
sampling of the source window that chunk needs. Memory stays bounded by the chunk size whatever
the image size (a 30000×30000 image is processed as ~900 chunks of 1024×1024).

Image coordinates: pixel centre, first pixel (0, 0), of the *full* image the RPCs describe. A file
that holds a crop of it stores its pixels (r, c) at full-image (r + crop_row, c + crop_col); see
`crop_offset_from_file`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Transformer
from rasterio.transform import Affine
from scipy.ndimage import gaussian_filter, map_coordinates

from blockqc.errors import InputError, Problem
from blockqc.rfm.dem import DEM
from blockqc.rfm.readers import open_raster, reading_pixels

FloatArray = NDArray[np.float64]


class GroundToImage(Protocol):
    """What orthorectification needs of a model: RPCModel and RefinedRFM both qualify."""

    def ground_to_image(
        self, lon: ArrayLike, lat: ArrayLike, h: ArrayLike
    ) -> tuple[FloatArray, FloatArray]: ...

    def image_to_ground(
        self, row: ArrayLike, col: ArrayLike, height: object
    ) -> tuple[FloatArray, FloatArray, FloatArray]: ...


@dataclass(frozen=True)
class OrthoGrid:
    """A north-up output grid: `transform` is GDAL's (pixel corner), pixels are square."""

    crs: CRS
    transform: Affine
    width: int
    height: int

    @property
    def gsd(self) -> float:
        return float(self.transform.a)

    def xy(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Map coordinates of pixel (row, col), pixel-centre convention (first centre (0, 0))."""
        row = np.asarray(row, np.float64)
        col = np.asarray(col, np.float64)
        t = self.transform
        return t.c + (col + 0.5) * t.a, t.f + (row + 0.5) * t.e

    def rowcol(self, x: ArrayLike, y: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fractional (row, col) of map point (x, y), pixel-centre convention."""
        t = self.transform
        return (np.asarray(y, np.float64) - t.f) / t.e - 0.5, (
            np.asarray(x, np.float64) - t.c
        ) / t.a - 0.5

    def expanded(self, margin: int) -> OrthoGrid:
        """The same lattice with `margin` more pixels on every side."""
        t = self.transform
        return OrthoGrid(
            self.crs,
            Affine(t.a, 0.0, t.c - margin * t.a, 0.0, t.e, t.f - margin * t.e),
            self.width + 2 * margin,
            self.height + 2 * margin,
        )

    def chunks(self, size: int) -> Iterator[tuple[int, int, int, int]]:
        """(row0, col0, rows, cols) of the output chunks, row by row."""
        for r0 in range(0, self.height, size):
            for c0 in range(0, self.width, size):
                yield r0, c0, min(size, self.height - r0), min(size, self.width - c0)


def units_not_metres(crs: CRS) -> set[str]:
    """The units of a CRS's axes that are not the metre (feet, US survey feet); empty when
    every axis is in metres."""
    return {a.unit_name for a in crs.axis_info if a.unit_conversion_factor != 1.0}


CRS_SCALE_TOLERANCE = 0.01
"""Largest departure from 1 of the grid CRS's scale at the scene: its metres are those of the
CPs' shifts, of the RMSE in metres and of the GSD (a neighbouring UTM zone: 0.5 %)."""


def scale_off(crs: CRS, lon: float, lat: float) -> str:
    """Why `crs`'s metres are not the ground's at (lon, lat): its scales along the meridian and
    the parallel there when one departs from 1 by more than CRS_SCALE_TOLERANCE, else ''."""
    from pyproj import Proj

    factors = Proj(crs).get_factors(lon, lat)
    scales = (float(factors.meridional_scale), float(factors.parallel_scale))
    if all(abs(k - 1.0) <= CRS_SCALE_TOLERANCE for k in scales):
        return ""
    return (
        f"its scale at the scene (lon {lon:.4f}, lat {lat:.4f}) is {scales[0]:.4g} along the "
        f"meridian and {scales[1]:.4g} along the parallel: one of its metres is not a metre on "
        "the ground, and the CPs' shifts, the RMSE in metres and the image's GSD would be "
        f"off by up to {max(abs(k - 1.0) for k in scales):.0%}"
    )


def utm_ups_crs(lon: float, lat: float) -> CRS:
    """WGS-84 / UTM zone containing (lon, lat), or UPS north of 84° N and south of 80° S, where
    UTM ends (§MB-3; the codes MB-3 takes for UPS, 32661 and 32761)."""
    if lat > 84.0:
        return CRS.from_epsg(32661)
    if lat < -80.0:
        return CRS.from_epsg(32761)
    zone = int(np.floor((lon + 180.0) / 6.0)) % 60 + 1
    return CRS.from_epsg((32600 if lat >= 0 else 32700) + zone)


def crop_offset_from_file(path: str | Path) -> tuple[float, float]:
    """(row, col) of a crop's first pixel in the full image, from a crop's pixel geotransform.

    Crops cut from a sensor-geometry image (CNES shareloc/cars test data) carry no CRS and store
    the crop position as geotransform (1, 0, col0, 0, 1, row0): full = crop + (row0, col0).
    Any other file (no geotransform, or a real georeferenced one) gives (0, 0).
    """
    with open_raster(path) as ds:
        t = ds.transform
        if ds.crs is None and t.a == 1 and t.e == 1 and t.b == 0 and t.d == 0:
            return float(t.f), float(t.c)
    return 0.0, 0.0


def image_border(rows: int, cols: int, per_edge: int = 32) -> tuple[FloatArray, FloatArray]:
    """Pixel-centre positions along the border of a rows×cols image (corners included)."""
    r = np.linspace(-0.5, rows - 0.5, per_edge)
    c = np.linspace(-0.5, cols - 0.5, per_edge)
    top = (np.full_like(c, -0.5), c)
    bottom = (np.full_like(c, rows - 0.5), c)
    left = (r, np.full_like(r, -0.5))
    right = (r, np.full_like(r, cols - 0.5))
    return (
        np.concatenate([top[0], bottom[0], left[0], right[0]]),
        np.concatenate([top[1], bottom[1], left[1], right[1]]),
    )


def image_gsd(
    model: GroundToImage,
    row: float,
    col: float,
    dem: DEM,
    crs: CRS,
    fallback_height: float | None = None,
) -> float:
    """Ground sampling distance (m) at image position (row, col): the geometric mean of the
    ground lengths of one-pixel steps along rows and columns, on the level surface at the DEM's
    height there (or at `fallback_height` where the DEM has no value). Level, not along the
    DEM: the slope of the DEM under one pixel would change what one pixel steps over by
    tan(view angle) × slope (0.499 m for 0.505 m on the Ventoux image, 8° off nadir)."""
    rows = np.array([row, row + 1.0, row])
    cols = np.array([col, col, col + 1.0])
    _, _, h = model.image_to_ground(rows[:1], cols[:1], dem)
    height = float(h[0]) if np.isfinite(h[0]) else fallback_height
    lon = np.full(3, np.nan)
    if height is not None:
        lon, lat, _ = model.image_to_ground(rows, cols, height)
    if not np.all(np.isfinite(lon)):
        raise InputError(
            Problem(file=dem.grid.source, message="the DEM does not cover the image centre")
        )
    x, y = Transformer.from_crs(CRS.from_epsg(4326), crs, always_xy=True).transform(lon, lat)
    d_row = np.hypot(x[1] - x[0], y[1] - y[0])
    d_col = np.hypot(x[2] - x[0], y[2] - y[0])
    return float(np.sqrt(d_row * d_col))


MAX_GRID_PIXELS = 2_000_000_000
"""Most pixels of an output grid (the reference's, margin included): a Pléiades scene, 20 km
at 0.5 m, is 1.6e9; the matching holds both grids in memory (8 GB each at this size)."""


def check_grid_size(grid: OrthoGrid, margin: int, gsd_given: bool) -> None:
    """Refuse a grid (with `margin` pixels more on every side for the reference) of more than
    MAX_GRID_PIXELS, naming --gsd and --margin, before a file that size is opened."""
    ref = grid.expanded(margin)
    if ref.width * ref.height <= MAX_GRID_PIXELS:
        return
    spacing = f"--gsd {grid.gsd:g} m" if gsd_given else f"the image's GSD {grid.gsd:g} m"
    fine = grid.width * grid.height > MAX_GRID_PIXELS  # even without the margin
    fix = "a larger --gsd" if fine else "a smaller --margin"
    raise InputError(
        Problem(
            file="<arguments>",
            message=f"{spacing} and --margin {margin} px give an output grid of {grid.width} × "
            f"{grid.height} px and a reference grid of {ref.width} × {ref.height} px "
            f"({ref.width * ref.height:.3g} px): more than {MAX_GRID_PIXELS:.0e} px (a Pléiades "
            f"scene, 20 km at 0.5 m, is 1.6e9 px); give {fix}",
        )
    )


def ortho_grid(
    model: GroundToImage,
    shape: tuple[int, int],
    dem: DEM,
    *,
    crop_offset: tuple[float, float] = (0.0, 0.0),
    crs: CRS | None = None,
    gsd: float | None = None,
    margin: int = 0,
) -> OrthoGrid:
    """The output grid covering the image footprint on the DEM, at the image GSD.

    `shape` is the (rows, cols) of the file; `crop_offset` its position in the full image.
    Where the DEM does not reach the image border, the footprint is taken at the mean DEM height
    found over the image; a DEM with no value over the image is refused.
    The CRS defaults to the UTM zone of the footprint centre; the GSD to `image_gsd` at the
    image centre, rounded to the millimetre. Grid edges are multiples of the GSD. A grid
    that, with `margin` pixels more on every side, exceeds MAX_GRID_PIXELS is refused.
    """
    rows, cols = shape
    r0, c0 = crop_offset
    br, bc = image_border(rows, cols)
    lon, lat, h = model.image_to_ground(br + r0, bc + c0, dem)
    missing = ~np.isfinite(lon)
    centre = (r0 + (rows - 1) / 2, c0 + (cols - 1) / 2)
    _, _, h_centre = model.image_to_ground(np.array([centre[0]]), np.array([centre[1]]), dem)
    heights = np.concatenate([h[~missing], h_centre[np.isfinite(h_centre)]])
    if heights.size == 0:  # a DEM inside the border, a void at the centre: look inside
        heights = _inner_heights(model, shape, crop_offset, dem)
    if heights.size == 0:
        _refuse_dem(model, br + r0, bc + c0, dem)
    mean_height = float(heights.mean())
    if missing.any():
        # the grid still spans the whole footprint (at the mean height where the DEM has no
        # value); output pixels without a DEM height stay empty (NaN)
        lon[missing], lat[missing], _ = model.image_to_ground(
            br[missing] + r0, bc[missing] + c0, mean_height
        )
    crs = _grid_crs(crs, lon, lat)
    gsd_given = gsd is not None
    if gsd is None:
        gsd = round(image_gsd(model, centre[0], centre[1], dem, crs, mean_height), 3)
    if not (np.isfinite(gsd) and gsd > 0):
        why = f"GSD must be a finite number > 0, got {gsd}"
        raise InputError(Problem(file="<arguments>", message=why))
    grid = _grid_over(lon, lat, crs, gsd)
    check_grid_size(grid, margin, gsd_given)
    return grid


def _refuse_dem(model: GroundToImage, rows: FloatArray, cols: FloatArray, dem: DEM) -> NoReturn:
    """Refuse a DEM with no height over the image, saying where the image is: its border
    (`rows`, `cols`: full-image positions) on the ground at the DEM's mean height."""
    finite = dem.grid.values[np.isfinite(dem.grid.values)]
    lon_f, lat_f, _ = model.image_to_ground(
        rows, cols, float(finite.mean()) if finite.size else 0.0
    )
    why = (
        "does not cover the image footprint"
        if finite.size
        else "holds no height over the image footprint, only voids (no-data)"
    )
    raise InputError(
        Problem(
            file=dem.grid.source,
            message=f"the DEM {why} "
            f"(lon {np.nanmin(lon_f):.4f}..{np.nanmax(lon_f):.4f}, "
            f"lat {np.nanmin(lat_f):.4f}..{np.nanmax(lat_f):.4f})",
        )
    )


def _grid_crs(crs: CRS | None, lon: FloatArray, lat: FloatArray) -> CRS:
    """The grid's CRS: the UTM (UPS) zone of the footprint's mean position, else the CRS given,
    refused where its scale there is off."""
    if crs is None:
        return utm_ups_crs(float(np.mean(lon)), float(np.mean(lat)))
    why = scale_off(crs, float(np.mean(lon)), float(np.mean(lat)))
    if why:
        why = f"--crs {crs.name}: {why}; give a CRS whose scale there is within "
        why += f"{CRS_SCALE_TOLERANCE:.0%} of 1 (leave --crs out for the UTM zone)"
        raise InputError(Problem(file="<arguments>", message=why))
    return crs


def _grid_over(lon: FloatArray, lat: FloatArray, crs: CRS, gsd: float) -> OrthoGrid:
    """The north-up grid of `gsd` in `crs` covering the footprint, its edges multiples of the
    GSD."""
    x, y = Transformer.from_crs(CRS.from_epsg(4326), crs, always_xy=True).transform(lon, lat)
    x0 = np.floor(np.min(x) / gsd) * gsd
    x1 = np.ceil(np.max(x) / gsd) * gsd
    y0 = np.floor(np.min(y) / gsd) * gsd
    y1 = np.ceil(np.max(y) / gsd) * gsd
    width = int(round((x1 - x0) / gsd))
    height = int(round((y1 - y0) / gsd))
    return OrthoGrid(crs, Affine(gsd, 0.0, x0, 0.0, -gsd, y1), width, height)


#: image positions per side of the lattice searched for heights when neither the image's
#: border nor its centre has one
INNER_LATTICE = 17


def _inner_heights(
    model: GroundToImage, shape: tuple[int, int], crop_offset: tuple[float, float], dem: DEM
) -> FloatArray:
    """The DEM heights found at an INNER_LATTICE² lattice of image positions (those with one)."""
    (rows, cols), (r0, c0) = shape, crop_offset
    r, c = np.meshgrid(
        np.linspace(r0, r0 + rows - 1, INNER_LATTICE), np.linspace(c0, c0 + cols - 1, INNER_LATTICE)
    )
    _, _, h = model.image_to_ground(r.ravel(), c.ravel(), dem)
    return h[np.isfinite(h)]


def sensor_positions(
    model: GroundToImage,
    grid: OrthoGrid,
    dem: DEM,
    window: tuple[int, int, int, int],
) -> tuple[FloatArray, FloatArray]:
    """Full-image (row, col) seen at every output pixel centre of a window (row0, col0, h, w)."""
    r0, c0, nr, nc = window
    rr, cc = np.meshgrid(
        np.arange(r0, r0 + nr, dtype=np.float64),
        np.arange(c0, c0 + nc, dtype=np.float64),
        indexing="ij",
    )
    x, y = grid.xy(rr, cc)
    to_geo = Transformer.from_crs(grid.crs, CRS.from_epsg(4326), always_xy=True)
    lon, lat = to_geo.transform(x, y)
    h = dem.height(lon, lat)
    return model.ground_to_image(lon, lat, h)


def grey_bands(ds: object) -> tuple[int, ...]:
    """The bands an image is matched on: those it declares red, green and blue (a colour
    orthophoto; an alpha band or others left out), else band 1 (one band, or multispectral
    bands whose colours are not declared: a near-infrared band would blur the mean). A band of
    colour-table indices (a paletted image) is refused, naming the file."""
    from rasterio.enums import ColorInterp

    colours = (ColorInterp.red, ColorInterp.green, ColorInterp.blue)
    interp = ds.colorinterp  # type: ignore[attr-defined]
    pairs = zip(ds.indexes, interp, strict=True)  # type: ignore[attr-defined]
    rgb = tuple(i for i, c in pairs if c in colours)
    chosen = rgb if len(rgb) == 3 else (1,)
    paletted = [i for i in chosen if interp[i - 1] == ColorInterp.palette]
    if paletted:
        message = (
            f"band {paletted[0]} holds indices into a colour table (a paletted image), not grey "
            "levels: matched as they are, neighbouring colours would be far apart; expand it "
            "first (gdal_translate -expand rgb IN OUT) and give the expanded file"
        )
        raise InputError(Problem(file=str(ds.name), message=message))  # type: ignore[attr-defined]
    return chosen


def bands_used(path: str | Path) -> dict[str, object]:
    """Which bands of a raster are matched on (`grey_bands`), said in words."""
    with open_raster(path) as ds:
        count, used = ds.count, grey_bands(ds)
    if count == 1:
        text = "band 1 (one band)"
    elif len(used) == 1:
        text = f"band 1 of {count} (no bands declared red, green, blue)"
    else:
        text = f"mean of bands {', '.join(map(str, used))} (red, green, blue)"
        if count > 3:
            text += f" of {count}"
    return {"count": count, "used": list(used), "matched_on": text}


def band_mean(values: np.ma.MaskedArray) -> NDArray[np.float32]:
    """Mean over the bands (axis 0) of those with a value at each pixel; NaN where none has."""
    return np.ma.masked_invalid(values.astype(np.float32)).mean(axis=0).filled(np.nan)


def antialiased(values: NDArray[np.float32], step: float) -> NDArray[np.float32]:
    """`values` smoothed for sampling every `step` pixels (> 1: an output pixel `step` source
    pixels wide): a Gaussian of σ = (step − 1)/2, symmetric so that nothing shifts, weighted
    over the valid pixels (NaN stays NaN). Unsmoothed for steps below 1.5."""
    if step < 1.5:
        return values
    sigma = (step - 1.0) / 2.0
    ok = np.isfinite(values)
    total = gaussian_filter(np.where(ok, values, 0.0).astype(np.float64), sigma, mode="nearest")
    weight = gaussian_filter(ok.astype(np.float64), sigma, mode="nearest")
    out = np.where(ok & (weight > 0), total / np.where(weight > 0, weight, 1.0), np.nan)
    return out.astype(np.float32)


def _resample(
    ds: object,
    bands: tuple[int, ...],
    row: FloatArray,
    col: FloatArray,
    order: int,
    step: float = 1.0,
) -> NDArray[np.float32]:
    """Sample the mean of `bands` of the open dataset at file positions (row, col), NaN outside
    (the mean of bilinear samples is the bilinear sample of the mean); `antialiased` first
    where an output pixel is `step` ≥ 1.5 source pixels wide."""
    from rasterio.windows import Window

    out = np.full(row.shape, np.nan, dtype=np.float32)
    nrows, ncols = ds.height, ds.width  # type: ignore[attr-defined]
    ok = (
        np.isfinite(row)
        & np.isfinite(col)
        & (row >= -0.5)
        & (row <= nrows - 0.5)
        & (col >= -0.5)
        & (col <= ncols - 0.5)
    )
    if not ok.any():
        return out
    pad = 2 + order + (int(np.ceil(2 * step)) if step >= 1.5 else 0)  # the smoothing's reach
    wr0 = max(int(np.floor(row[ok].min())) - pad, 0)
    wc0 = max(int(np.floor(col[ok].min())) - pad, 0)
    wr1 = min(int(np.ceil(row[ok].max())) + pad + 1, nrows)
    wc1 = min(int(np.ceil(col[ok].max())) + pad + 1, ncols)
    with reading_pixels(ds.name, "image"):  # type: ignore[attr-defined]
        values = ds.read(  # type: ignore[attr-defined]
            list(bands), window=Window(wc0, wr0, wc1 - wc0, wr1 - wr0), masked=True
        )
    src = band_mean(values)
    src = antialiased(src, step)
    coords = np.stack([row[ok] - wr0, col[ok] - wc0])
    out[ok] = map_coordinates(src, coords, order=order, mode="nearest", prefilter=order > 1)
    return out


def centre_gsd(
    model: GroundToImage,
    shape: tuple[int, int],
    crop_offset: tuple[float, float],
    dem: DEM,
    grid: OrthoGrid,
) -> float:
    """The image's GSD (m) at its centre, in the grid's CRS: what one of its pixels covers."""
    centre = (crop_offset[0] + (shape[0] - 1) / 2, crop_offset[1] + (shape[1] - 1) / 2)
    return image_gsd(model, *centre, dem, grid.crs, dem.mean_height)


def orthorectify(
    image: str | Path,
    model: GroundToImage,
    dem: DEM,
    out_path: str | Path,
    *,
    grid: OrthoGrid | None = None,
    crop_offset: tuple[float, float] | None = None,
    band: int | None = None,
    chunk: int = 1024,
    order: int = 1,
) -> OrthoGrid:
    """Orthorectify `image` onto `grid` (default: `ortho_grid`), chunk by chunk, into a float32
    GeoTIFF at `out_path` with NaN where the image gives nothing (§RA-1): band `band`, or by
    default `grey_bands` (the mean of red, green and blue, else band 1).

    `crop_offset` is the file's position in the full image (default: `crop_offset_from_file`);
    `order` is the spline order of the resampling (1 bilinear, 3 cubic).
    """
    import rasterio

    image = Path(image)
    if crop_offset is None:
        crop_offset = crop_offset_from_file(image)
    with open_raster(image) as src:
        bands = _bands_asked(src, band, image)
        if grid is None:
            grid = ortho_grid(model, (src.height, src.width), dem, crop_offset=crop_offset)
        step = grid.gsd / centre_gsd(model, (src.height, src.width), crop_offset, dem, grid)
        profile = _ortho_profile(grid)
        out_path = Path(out_path)
        tmp = out_path.with_name(f".{out_path.name}.partial.tif")
        out_path.parent.mkdir(parents=True, exist_ok=True)
        try:
            with rasterio.open(tmp, "w", **profile) as dst:
                for window in grid.chunks(chunk):
                    row, col = sensor_positions(model, grid, dem, window)
                    values = _resample(
                        src, bands, row - crop_offset[0], col - crop_offset[1], order, step
                    )
                    r0, c0, nr, nc = window
                    dst.write(values, 1, window=rasterio.windows.Window(c0, r0, nc, nr))
            tmp.replace(out_path)  # atomic rename: readers never see a half-written ortho
        finally:
            tmp.unlink(missing_ok=True)
    return grid


def _bands_asked(src: object, band: int | None, image: Path) -> tuple[int, ...]:
    """The bands of the open image `src` that are orthorectified: `band`, refused where the
    image has no such band, else `grey_bands`."""
    count = src.count  # type: ignore[attr-defined]
    if band is not None and not 1 <= band <= count:
        raise InputError(
            Problem(file=str(image), message=f"band {band} asked, the image has {count}")
        )
    return grey_bands(src) if band is None else (band,)


def _ortho_profile(grid: OrthoGrid) -> dict[str, object]:
    """The creation profile of an orthoimage on `grid`: one float32 band, NaN for no data,
    tiled 256×256, deflate-compressed, BigTIFF where it might not fit in 4 GB."""
    import rasterio

    return {
        "driver": "GTiff",
        "dtype": "float32",
        "count": 1,
        "width": grid.width,
        "height": grid.height,
        "crs": rasterio.crs.CRS.from_wkt(grid.crs.to_wkt()),
        "transform": grid.transform,
        "nodata": float("nan"),
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "deflate",
        "BIGTIFF": "IF_SAFER",
    }


def read_ortho(path: str | Path) -> tuple[NDArray[np.float32], OrthoGrid]:
    """Read an orthoimage written by `orthorectify` (or any north-up GeoTIFF) with its grid."""
    import rasterio

    with rasterio.open(path) as ds:
        t = ds.transform
        if ds.crs is None or t.b != 0 or t.d != 0:
            raise InputError(
                Problem(file=str(path), message="expected a north-up georeferenced raster")
            )
        arr = ds.read(1, masked=True).astype(np.float32).filled(np.nan)
        grid = OrthoGrid(CRS.from_wkt(ds.crs.to_wkt()), t, ds.width, ds.height)
    return arr, grid
