"""Longitudes in either convention (−180…180 or 0…360) in the RPCs and in the DEM."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine
from rfm_helpers import VENTOUX, gdal_transformer

from blockqc.rfm.dem import load_dem
from blockqc.rfm.model import RPCModel
from blockqc.rfm.ortho import orthorectify, read_ortho
from blockqc.rfm.pipeline import _footprint_bounds
from blockqc.rfm.readers import read_rpc

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")

CROP = (5000.0, 5000.0)  # left_image.tif: 500 × 500 px of the full image at row, col 5000


def west_of_greenwich(tmp_path: Path, turn: float) -> RPCModel:
    """The Ventoux left model moved 10° west (LONG_OFF −4.715°), read from a .geom whose
    LONG_OFF is written `turn` degrees round (0: −180…180, 360: 0…360 → 355.285°)."""
    text = (VENTOUX / "left_image.geom").read_text()
    lon_off = float(re.search(r"long_off:\s*(\S+)", text).group(1)) - 10.0
    path = tmp_path / f"left_{turn:g}.geom"
    path.write_text(re.sub(r"long_off:\s*\S+", f"long_off:  {lon_off + turn!r}", text))
    return read_rpc(path)


def moved_dem(tmp_path: Path, turn: float) -> Path:
    """The SRTM crop moved 10° west, its longitudes written `turn` degrees round."""
    with rasterio.open(VENTOUX / "srtm_N44E005_crop.tif") as ds:
        profile, values, t = ds.profile, ds.read(1), ds.transform
    profile["transform"] = Affine(t.a, 0.0, t.c - 10.0 + turn, 0.0, t.e, t.f)
    path = tmp_path / f"dem_{turn:g}.tif"
    with rasterio.open(path, "w", **profile) as out:
        out.write(values, 1)
    return path


def test_an_rpc_in_0_to_360_projects_longitudes_of_either_convention(tmp_path: Path):
    """LONG_OFF 355.285° took −4.8° as 360° away from the scene; GDAL takes both the same."""
    m360, m180 = west_of_greenwich(tmp_path, 360.0), west_of_greenwich(tmp_path, 0.0)
    lon, lat, h = np.array([-4.80, -4.79]), np.array([44.207, 44.200]), np.array([600.0, 700.0])
    expected = m180.ground_to_image(lon, lat, h)
    for given in (lon, lon + 360.0):
        np.testing.assert_allclose(m360.ground_to_image(given, lat, h), expected, atol=1e-9)
        with gdal_transformer(m360) as t:
            g_row, g_col = t.rowcol(given, lat, h, op=float)
        np.testing.assert_allclose(np.asarray(g_row) - 0.5, expected[0], atol=1e-6)
        np.testing.assert_allclose(np.asarray(g_col) - 0.5, expected[1], atol=1e-6)


@pytest.mark.parametrize(("rpc_turn", "dem_turn"), [(360.0, 0.0), (0.0, 360.0), (360.0, 360.0)])
def test_rpcs_and_a_dem_of_either_convention_give_the_same_ortho(
    tmp_path: Path, rpc_turn: float, dem_turn: float
):
    """An RPC in 0…360 with a DEM in −180…180 was refused ('the DEM does not cover lon
    355.18..355.21'); a DEM in 0…360 with an RPC in −180…180 was read but gave no height
    ('the DEM does not cover the image footprint')."""
    m180 = west_of_greenwich(tmp_path, 0.0)
    dem180 = load_dem(moved_dem(tmp_path, 0.0), geoid_offset=50.8)
    grid = orthorectify(
        VENTOUX / "left_image.tif", m180, dem180, tmp_path / "ref.tif", crop_offset=CROP
    )
    m = west_of_greenwich(tmp_path, rpc_turn)
    bounds = _footprint_bounds(m, (500, 500), CROP, pad_deg=0.01)
    dem = load_dem(moved_dem(tmp_path, dem_turn), geoid_offset=50.8, bounds=bounds)
    orthorectify(
        VENTOUX / "left_image.tif", m, dem, tmp_path / "o.tif", grid=grid, crop_offset=CROP
    )
    expected, _ = read_ortho(tmp_path / "ref.tif")
    got, _ = read_ortho(tmp_path / "o.tif")
    assert np.isfinite(got).mean() > 0.9
    np.testing.assert_allclose(got, expected, atol=1e-3, equal_nan=True)
