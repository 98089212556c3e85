"""Rasters GDAL opens but cannot read (cut short, damaged): refused naming the file."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin
from rfm_helpers import VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.command import command
from blockqc.rfm.dem import load_dem
from blockqc.rfm.ortho import orthorectify
from blockqc.rfm.readers import read_rpc

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def cut_short(source: Path, target: Path, keep: float = 0.4) -> Path:
    """`target`: the first `keep` of `source`'s bytes (its header kept, most pixels gone)."""
    data = source.read_bytes()
    target.write_bytes(data[: int(len(data) * keep)])
    with rasterio.open(target) as ds:  # GDAL still opens it: the header is whole
        assert ds.width > 0
    return target


def write_geotiff(path: Path, values: np.ndarray, west: float, north: float, step: float) -> Path:
    """An uncompressed one-band lon/lat GeoTIFF, its header first."""
    profile = {"driver": "GTiff", "width": values.shape[1], "height": values.shape[0]}
    profile |= {"count": 1, "dtype": "float32", "crs": "EPSG:4326"}
    profile |= {"transform": from_origin(west, north, step, step)}
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(values.astype(np.float32), 1)
    return path


def test_a_dem_cut_short_is_named(tmp_path: Path):
    dem = write_geotiff(tmp_path / "dem.tif", np.full((400, 400), 500.0), 5.0, 44.5, 0.001)
    cut = cut_short(dem, tmp_path / "dem_cut.tif")
    with pytest.raises(InputError) as exc:
        load_dem(cut, geoid_offset=50.0)
    message = str(exc.value)
    assert message.startswith(f"{cut}: cannot read the DEM's pixels")
    assert "cut short or damaged" in message and "\n" not in message


def test_an_image_cut_short_is_named(tmp_path: Path):
    image = cut_short(VENTOUX / "left_image.tif", tmp_path / "left_image.tif")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid_offset=50.8)
    with pytest.raises(InputError) as exc:
        orthorectify(image, read_rpc(VENTOUX / "left_image.geom"), dem, tmp_path / "o.tif")
    assert str(exc.value).startswith(f"{image}: cannot read the image's pixels")
    assert not (tmp_path / "o.tif").exists()


def test_a_georeferenced_reference_cut_short_is_named(tmp_path: Path):
    """rasterio's reprojection raised WarpOperationError, shown as an internal error."""
    reference = write_geotiff(
        tmp_path / "ref.tif", np.full((300, 300), 100.0), 5.19, 44.21, 0.00002
    )
    cut = cut_short(reference, tmp_path / "ref_cut.tif", keep=0.2)
    shutil.copy(VENTOUX / "left_image.tif", tmp_path / "left_image.tif")
    args = [
        str(tmp_path / "left_image.tif"),
        "--rpc",
        str(VENTOUX / "left_image.geom"),
        "--dem",
        str(VENTOUX / "srtm_N44E005_crop.tif"),
        "--geoid-offset",
        "50.8",
        "--reference",
        str(cut),
        "--out",
        str(tmp_path / "out"),
    ]
    result = CliRunner().invoke(command, args)
    assert isinstance(result.exception, InputError)  # exit 2
    assert str(result.exception).startswith(f"{cut}: cannot read the reference's pixels")


def test_a_geoid_grid_cut_short_is_refused_not_read_as_zeros(tmp_path: Path):
    """GDAL reads the rows missing from a small .gtx as 0 without a word: the Ventoux crop
    (7 × 7 nodes, 40 + 196 bytes) cut to 150 bytes gave N = 0 on its three northern rows."""
    geoid = tmp_path / "egm96_15_crop.gtx"
    geoid.write_bytes((VENTOUX / "egm96_15_crop.gtx").read_bytes()[:150])
    with pytest.raises(InputError) as exc:
        load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=geoid)
    message = str(exc.value)
    assert message.startswith(f"{geoid}: the geoid grid is cut short: 150 bytes")
    assert "expected at least 236 (40 of header and 7 × 7 × 1 values of 4 bytes)" in message


def test_an_envi_dem_cut_short_is_refused_not_read_as_zeros(tmp_path: Path):
    values = np.full((100, 100), 500.0, np.float32)
    profile = {"driver": "ENVI", "width": 100, "height": 100, "count": 1, "dtype": "float32"}
    profile |= {"crs": "EPSG:4326", "transform": from_origin(5.0, 44.5, 0.001, 0.001)}
    with rasterio.open(tmp_path / "dem.img", "w", **profile) as ds:
        ds.write(values, 1)
    data = (tmp_path / "dem.img").read_bytes()
    (tmp_path / "dem.img").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError) as exc:
        load_dem(tmp_path / "dem.img", geoid_offset=50.0)
    assert "the DEM is cut short: 20000 bytes, expected at least 40000" in str(exc.value)


def test_whole_raw_grids_are_read():
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    assert np.isfinite(dem.mean_height)
