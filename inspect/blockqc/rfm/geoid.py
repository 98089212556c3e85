"""Geoid undulations N for turning geoid heights H into ellipsoidal heights h = H + N (§MB-2).

Three sources: a geoid grid file (e.g. NGA's EGM96 15' `egm96_15.gtx`), the global EGM96 grid
shipped with blockqc (`--geoid egm96`: the 15' grid subsampled to 30', int16 centimetres, see
`data/README.md` for its interpolation error), or a constant undulation (`--geoid-offset`).
`declared_reference` reads the height reference a DEM states itself (compound or 3-D CRS, SRTM).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS

from blockqc.errors import InputError, Problem

FloatArray = NDArray[np.float64]

EGM96_GRID = Path(__file__).resolve().parent / "data" / "egm96_30.tif"
"""The shipped global EGM96 grid: 30' nodes from 90°N to 90°S, 180°W to 180°E (wrapped)."""
EGM96_STEP = 2
"""Every second node of the 15' grid is kept (15' → 30')."""
ELLIPSOID = "ellipsoid"
"""`declared_reference` of a DEM whose CRS states ellipsoidal heights."""
_EPSG_MODEL = {5773: "EGM96", 3855: "EGM2008", 5798: "EGM84"}


@dataclass(frozen=True)
class Geoid:
    """Undulation N (m) at lon/lat from a grid or a constant; `model` e.g. 'EGM96' when known."""

    description: str
    grid: object | None = None  # blockqc.rfm.dem.Grid in lon/lat, or None for a constant
    offset: float = 0.0
    model: str | None = None

    def undulation(self, lon: ArrayLike, lat: ArrayLike) -> FloatArray:
        """N (m) at lon/lat (degrees); NaN where a grid does not reach."""
        lon = np.asarray(lon, np.float64)
        lat = np.asarray(lat, np.float64)
        if self.grid is None:
            return np.full(np.broadcast(lon, lat).shape, self.offset)
        t = self.grid.transform  # type: ignore[attr-defined]
        west = t.c  # a 0..360° grid or a −180..180° one: bring lon into its span
        lon = west + np.mod(lon - west, 360.0)
        return self.grid.sample(lon, lat)  # type: ignore[attr-defined]


def constant_geoid(offset_m: float) -> Geoid:
    """A constant undulation (`--geoid-offset`), e.g. the EGM96 N at the scene."""
    if not np.isfinite(offset_m) or abs(offset_m) > 150.0:
        raise InputError(
            Problem(
                file="--geoid-offset",
                message=f"a geoid undulation is a finite number of metres within ±150 "
                f"(Earth's geoid spans −107..+86 m), got {offset_m!r}",
            )
        )
    return Geoid(f"constant geoid undulation {offset_m:+.3f} m (--geoid-offset)", offset=offset_m)


def egm96() -> Geoid:
    """The shipped global EGM96 grid (30', bilinear; see data/README.md)."""
    import rasterio

    with rasterio.open(EGM96_GRID) as ds:
        values = ds.read(1).astype(np.float64) * ds.scales[0] + ds.offsets[0]
        transform = ds.transform
    from blockqc.rfm.dem import Grid

    grid = Grid(values, transform, CRS.from_epsg(4326), str(EGM96_GRID), wraps=True)
    return Geoid("EGM96 (blockqc's 30' global grid, bilinear)", grid=grid, model="EGM96")


def geoid_from_file(path: Path, bounds: tuple[float, float, float, float]) -> Geoid:
    """A geoid grid file (GDAL raster in lon/lat, e.g. a .gtx), read over `bounds` only."""
    from blockqc.rfm.dem import _read_grid

    grid = _read_grid(path, bounds, "geoid grid")
    if not grid.crs.is_geographic:
        raise InputError(Problem(file=str(path), message="the geoid grid must be in lon/lat"))
    _check_undulations(path, grid)
    name = path.name.lower()
    model = "EGM96" if "egm96" in name else "EGM2008" if "egm08" in name or "2008" in name else None
    return Geoid(f"geoid grid {path.name}", grid=grid, model=model)


MAX_UNDULATION_M = 150.0
"""Beyond any geoid undulation on Earth (−107…+86 m), as for --geoid-offset."""


def _check_undulations(path: Path, grid: object) -> None:
    """Refuse a 'geoid grid' holding values no geoid has (a DEM given as --geoid FILE: its
    heights would be added to the DEM's as undulations)."""
    values = grid.values  # type: ignore[attr-defined]
    with np.errstate(invalid="ignore"):
        beyond = np.abs(values) > MAX_UNDULATION_M
    if beyond.any():
        row, col = np.argwhere(beyond)[0]
        raise InputError(
            Problem(
                file=str(path),
                message=f"the geoid grid holds {int(beyond.sum())} value(s) beyond any geoid "
                f"undulation (expected within ±{MAX_UNDULATION_M:g} m; Earth's span −107…+86 m), "
                f"the first {values[row, col]:g} m: a DEM or a grid in other units given as "
                "--geoid?",
            )
        )


def vertical_model(crs: CRS) -> str | None:
    """The height reference a CRS states: ELLIPSOID, a geoid model name, or None (2-D CRS)."""
    if crs.is_compound:
        vertical = crs.sub_crs_list[-1]
        code = vertical.to_epsg()
        if code in _EPSG_MODEL:
            return _EPSG_MODEL[code]
        return vertical.name or "an unnamed vertical datum"
    if len(crs.axis_info) == 3:
        up = crs.axis_info[2]
        if "ellipsoidal" in up.name.lower() or crs.is_geographic:
            return ELLIPSOID
    return None


def declared_reference(path: Path) -> tuple[str | None, str]:
    """What a DEM file says its heights are measured from, and how we know it."""
    import rasterio
    from rasterio.errors import RasterioIOError

    try:
        with rasterio.Env(GTIFF_REPORT_COMPD_CS=True), rasterio.open(path) as ds:
            if ds.driver == "SRTMHGT":
                return "EGM96", "SRTM .hgt tile (SRTM heights are above the EGM96 geoid)"
            if ds.crs is None:
                return None, "no CRS"
            crs = CRS.from_wkt(ds.crs.to_wkt())
    except RasterioIOError as exc:
        raise InputError(Problem(file=str(path), message=f"cannot open DEM: {exc}")) from None
    model = vertical_model(crs)
    return model, f"its CRS '{crs.name}'" if model else f"its 2-D CRS '{crs.name}'"


def build_egm96_grid(source: Path, target: Path, step: int = EGM96_STEP) -> None:
    """Write the shipped grid from NGA's 15' `egm96_15.gtx`: every `step`-th node, int16 cm,
    a wrap column at 180°E, deflate with a horizontal predictor."""
    import rasterio
    from rasterio.transform import Affine

    with rasterio.open(source) as ds:
        n = ds.read(1).astype(np.float64)
        t = ds.transform
    sub = n[::step, ::step]
    sub = np.concatenate([sub, sub[:, :1]], axis=1)  # lon −180 … +180
    a = t.a * step
    transform = Affine(a, 0.0, t.c + t.a / 2 - a / 2, 0.0, -a, t.f + t.e / 2 + a / 2)
    profile = {"driver": "GTiff", "width": sub.shape[1], "height": sub.shape[0], "count": 1}
    profile |= {"dtype": "int16", "crs": "EPSG:4326", "transform": transform}
    profile |= {"compress": "deflate", "predictor": 2, "zlevel": 9}
    with rasterio.open(target, "w", **profile) as out:
        out.write(np.round(sub * 100.0).astype(np.int16), 1)
        out.scales = (0.01,)
        out.update_tags(
            SOURCE="NGA EGM96 15' geoid grid (egm96_15.gtx), every 2nd node", UNITS="metre"
        )


if __name__ == "__main__":  # python -m blockqc.rfm.geoid egm96_15.gtx egm96_30.tif
    import sys

    build_egm96_grid(Path(sys.argv[1]), Path(sys.argv[2]))
