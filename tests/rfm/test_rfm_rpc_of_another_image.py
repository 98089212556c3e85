"""`rfm-accuracy` given an RPC that does not describe its image: another scene's, its offsets
swapped, a scale or a coefficient mistyped. Each was refused as the DEM's fault ("the DEM does
not cover lon 44.0357..44.0601, lat 5.3429..5.3675"); the message now names the RPC file, the
image, where its footprint falls against the RPC's own domains and the DEM, and the likely cause.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from rfm_helpers import DATA, VENTOUX, ventoux_config

from blockqc.rfm.footprint import crop_problem, footprint_at, implausible_problem
from blockqc.rfm.pipeline import _footprint_bounds, dem_under
from blockqc.rfm.readers import read_rpc

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")

GEOM = VENTOUX / "left_image.geom"
LEFT = read_rpc(GEOM)
IMAGE = VENTOUX / "left_image.tif"
DEM = VENTOUX / "srtm_N44E005_crop.tif"
SAMPLE = DATA / "rpc_formats" / "sample.RPB"  # ASP's sample, San Francisco, 1062 × 2556 px
CROP = (5000.0, 5000.0)  # left_image.tif: 500 × 500 px at row, col 5000 of the full image
SHAPE = (500, 500)
#: the crop DEM's extent (srtm_N44E005_crop.tif: 67 × 55 cells of 3" from 5.169583°, 44.230417°)
DEM_COVERS = "covers lon 5.1696..5.2254, lat 44.1846..44.2304"
#: left_image.geom: LONG_OFF 5.28464655928485 ± 2·0.12870115852264, LAT_OFF 44.1371659937345 ±
#: 2·0.0989506933075148
GROUND_DOMAIN = "lon 5.0272..5.5420, lat 43.9393..44.3351: LONG_OFF ± 2·LONG_SCALE"


def edited(tmp_path: Path, name: str, old: str, new: str, source: Path = GEOM) -> Path:
    """A copy of `source` with one line replaced."""
    text = source.read_text()
    assert old in text
    out = tmp_path / name
    out.write_text(text.replace(old, new, 1))
    return out


def refused(
    tmp_path: Path,
    capsys,
    *options: str,
    rpc: Path = GEOM,
    reference_rpc: Path = VENTOUX / "right_image.geom",
) -> str:
    """`rfm-accuracy` on the Ventoux pair with these RPCs and `options`: exit 2, no traceback,
    nothing written; its stderr."""
    from blockqc.cli import main

    args = [
        str(IMAGE), "--rpc", str(rpc), "--dem", str(DEM), "--geoid", "egm96",
        "--reference", str(VENTOUX / "right_image.tif"), "--reference-rpc", str(reference_rpc),
        "--out", str(tmp_path / "out"), *options,
    ]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert "Traceback" not in err and "internal error" not in err, err
    assert not (tmp_path / "out").exists()
    return err


def footprint_in(err: str) -> tuple[float, ...]:
    """West, east, south, north of the footprint a message gives."""
    found = re.search(r"lies at lon (\S+)\.\.(\S+), lat (\S+)\.\.([-\d.]+)", err)
    assert found, err
    return tuple(float(v) for v in found.groups())


def test_swapped_lat_and_lon_offsets_are_named_not_the_dem(tmp_path: Path, capsys):
    """LAT_OFF and LONG_OFF exchanged: the normalized ground of each pixel is unchanged, so the
    footprint moves by LAT_OFF − LONG_OFF = 38.8525° in longitude and back in latitude, onto
    lon ~44°, lat ~5°: on the Earth, inside the RPC's (swapped) ground domain, off the DEM."""
    text = GEOM.read_text()
    swapped = tmp_path / "swapped.geom"
    swapped.write_text(
        text.replace("lat_off:  44.1371659937345", "lat_off:  5.28464655928485").replace(
            "long_off:  5.28464655928485", "long_off:  44.1371659937345"
        )
    )
    err = refused(tmp_path, capsys, rpc=swapped)
    assert err.startswith(f"error: {swapped}: the footprint of {IMAGE} by this RPC lies at lon ")
    west, south, east, north = _footprint_bounds(LEFT, SHAPE, CROP, pad_deg=0.0)
    shift = 44.1371659937345 - 5.28464655928485
    expected = (west + shift, east + shift, south - shift, north - shift)
    assert footprint_in(err) == pytest.approx(expected, abs=1e-4)
    assert "(the RPC's ground domain: lon 43.8798..44.3946, lat 5.0867..5.4825" in err
    assert f"the DEM {DEM} {DEM_COVERS}" in err
    assert "LAT_OFF 5.28465 and LONG_OFF 44.1372 look swapped" in err
    assert "does not cover" not in err


def test_the_rpc_of_another_scene_on_the_dem_s_area_is_said(tmp_path: Path, capsys):
    """ASP's sample.RPB (San Francisco) at crop offset 0,0 (inside its 1062 × 2556 px image):
    the footprint at lon −122°, lat 37.6° is the RPC's own; the DEM is at Mont Ventoux."""
    err = refused(tmp_path, capsys, "--crop-offset", "0,0", rpc=SAMPLE)
    assert err.startswith(f"error: {SAMPLE}: the footprint of {IMAGE} by this RPC lies at lon ")
    west, east, south, north = footprint_in(err)
    assert -122.4145 < west < east < -122.3321 and 37.5968 < south < north < 37.6428
    assert "(the RPC's ground domain: lon -122.4145..-122.3321, lat 37.5968..37.6428" in err
    assert f"the DEM {DEM} {DEM_COVERS}: the RPC may belong to another image" in err
    assert "look swapped" not in err


def test_a_crop_outside_the_rpc_s_image_domain_is_named(tmp_path: Path, capsys):
    """sample.RPB for left_image.tif at its own crop offset (5000, 5000): the RPC's image is
    LINE_OFF 531 ± 2·531 lines, SAMP_OFF 1278 ± 2·1278 samples; the run used to read the RPC
    far outside it and then blame the DEM."""
    err = refused(tmp_path, capsys, rpc=SAMPLE)
    assert err.startswith(
        f"error: {SAMPLE}: the RPC's image domain (lines -531..1593, samples -1278..3834: "
        f"LINE_OFF ± 2·LINE_SCALE, SAMP_OFF ± 2·SAMP_SCALE) does not hold the image {IMAGE} "
        "(rows 5000..5499, columns 5000..5499: 500 × 500 px at crop offset 5000, 5000 read from "
        "its geotransform (--crop-offset auto)): expected the RPC of this image"
    )


def test_a_reference_s_crop_outside_its_rpc_s_image_domain_is_named(tmp_path: Path, capsys):
    """The same check of a sensor-geometry reference: right_image.tif is 498 × 495 px at
    column 4915, row 5162 of the image sample.RPB is given for; it ran the whole ortho and
    ended in 'no control point found' naming the image."""
    err = refused(tmp_path, capsys, reference_rpc=SAMPLE)
    assert f"error: {SAMPLE}: the RPC's image domain (lines -531..1593" in err
    assert (
        f"does not hold the image {VENTOUX / 'right_image.tif'} (rows 5162..5656, columns "
        "4915..5412: 495 × 498 px at crop offset 5162, 4915 read from its geotransform "
        "(--reference-crop-offset auto))"
    ) in err


def test_the_crop_may_reach_the_image_domain_s_edge_not_beyond():
    """left_image.geom: lines 21109.5 ± 2·21137.5 = −21165.5..63384.5, samples 19207.5 ±
    2·19999.5 = −20791.5..59206.5; the whole full image (41801 × 39182) is inside."""
    assert crop_problem(LEFT, IMAGE, (41801, 39182), (0.0, 0.0), "--crop-offset", True) is None
    assert crop_problem(LEFT, IMAGE, (2, 2), (63383.5, 59205.5), "--crop-offset", True) is None
    assert crop_problem(LEFT, IMAGE, (2, 2), (-21165.5, -20791.5), "--crop-offset", True) is None
    beyond = crop_problem(LEFT, IMAGE, (2, 2), (63384.0, 0.0), "--crop-offset", True)
    assert beyond is not None and beyond.file == str(GEOM)
    assert "(lines -21166..63384, samples -20792..59206" in beyond.message
    assert "rows 63384..63385, columns 0..1: 2 × 2 px at crop offset 63384, 0 given by " in (
        beyond.message
    )


@pytest.mark.parametrize("scale", ["1e-6", "1e-9"])
def test_a_mistyped_height_scale_is_named_not_the_dem(tmp_path: Path, capsys, scale: str):
    """HEIGHT_SCALE 885 m typed 1e-6 (or 1e-9): the footprint over the RPC's height range is
    the right one and the DEM is read there, but at the DEM's heights (~560 m, normalized
    −5e8) the footprint went to lon −2.6e5 and the DEM was said not to cover it."""
    bad = edited(tmp_path, "h.geom", "height_scale:  885\n", f"height_scale:  {scale}\n")
    err = refused(tmp_path, capsys, rpc=bad)
    assert err.startswith(
        f"error: {bad}: the footprint of {IMAGE} by this RPC at the DEM's mean height ("
    )
    assert footprint_in(err)[0] < -180.0
    assert f"off the Earth (the RPC's ground domain: {GROUND_DOMAIN}" in err
    domain = f"(1075 ± {2 * float(scale):g} m: HEIGHT_OFF ± 2·HEIGHT_SCALE)"
    assert f"outside the RPC's height domain {domain}" in err
    assert f"(HEIGHT_SCALE {float(scale):g} m mistyped?)" in err


def test_a_mistyped_coefficient_sending_the_footprint_away_is_named(tmp_path: Path, capsys):
    """LINE_NUM's latitude term −1.032 typed −0.0103: the image's lines give latitudes 100
    times too far from LAT_OFF; the footprint spread over more than 100° of longitude, which
    the DEM was said not to cover."""
    bad = edited(
        tmp_path, "c.geom", "line_num_coeff_02:  -1.03205102244059",
        "line_num_coeff_02:  -0.0103205102244059",
    )  # fmt: skip
    err = refused(tmp_path, capsys, rpc=bad)
    assert err.startswith(f"error: {bad}: the footprint of {IMAGE} by this RPC")
    assert f"reaching outside the RPC's ground domain ({GROUND_DOMAIN}" in err
    assert "coefficients mistyped?" in err


def test_the_image_s_own_rpc_passes_every_check(tmp_path: Path):
    """left_image.geom for its crop: the footprint over its height range and at the DEM's mean
    height inside its ground domain, the crop inside its image domain, the DEM under it."""
    dem = dem_under(ventoux_config(tmp_path / "out"), LEFT, SHAPE, CROP)
    assert 500.0 < dem.mean_height < 700.0
    at = footprint_at(LEFT, SHAPE, CROP, dem.mean_height)
    assert at is not None and implausible_problem(LEFT, IMAGE, at, dem.mean_height) is None
    box = _footprint_bounds(LEFT, SHAPE, CROP, pad_deg=0.0)
    assert implausible_problem(LEFT, IMAGE, box) is None
    assert crop_problem(LEFT, IMAGE, SHAPE, CROP, "--crop-offset", False) is None
    assert np.all(np.isfinite(box))


def renormalised_to_crop(model, crop, offsets, scale):
    """`model` rewritten for the pixels of a crop at `crop` (row, col), its image side
    normalised with LINE_OFF, SAMP_OFF = `offsets` and both scales `scale`, as s2p writes the
    RPCs of its crops of a Pléiades scene (img_01.tif of its Réunion pair: LINE_OFF 19403.5,
    SAMP_OFF 19999.5, scales 512 for a 1024 × 1024 px crop). row = P/Q·LINE_SCALE + LINE_OFF,
    so P' = (P·LINE_SCALE + (LINE_OFF − crop row − LINE_OFF')·Q) / LINE_SCALE'."""
    from dataclasses import replace

    line_num = (
        model.line_num * model.line_scale + (model.line_off - crop[0] - offsets[0]) * model.line_den
    ) / scale
    samp_num = (
        model.samp_num * model.samp_scale + (model.samp_off - crop[1] - offsets[1]) * model.samp_den
    ) / scale
    return replace(
        model, line_num=line_num, samp_num=samp_num, line_off=offsets[0], samp_off=offsets[1],
        line_scale=scale, samp_scale=scale,
    )  # fmt: skip


def test_an_rpc_of_the_crop_s_pixels_with_offsets_beyond_them_is_held(tmp_path: Path):
    """An RPC fitted to a crop's own pixels whose LINE/SAMP offsets and scales do not span them
    (s2p's Réunion pair: rows 0..1023 against LINE_OFF 19403.5 ± 2·512) describes its image:
    its ground domain maps onto the crop. It was refused ("the RPC's image domain (lines
    18380..20428, …) does not hold the image"), where the docs' 95 CPs came from."""
    crop_rpc = renormalised_to_crop(LEFT, CROP, (19403.5, 19999.5), 512.0)
    lon, lat, h = np.array([5.195, 5.196]), np.array([44.206, 44.207]), np.array([560.0, 600.0])
    row, col = crop_rpc.ground_to_image(lon, lat, h)
    full_row, full_col = LEFT.ground_to_image(lon, lat, h)
    np.testing.assert_allclose(row, full_row - 5000.0, atol=1e-6)
    np.testing.assert_allclose(col, full_col - 5000.0, atol=1e-6)
    assert crop_problem(crop_rpc, IMAGE, SHAPE, (0.0, 0.0), "--crop-offset", True) is None
    dem = dem_under(
        ventoux_config(tmp_path / "out", crop_offset=(0.0, 0.0)), crop_rpc, SHAPE, (0, 0)
    )
    assert 500.0 < dem.mean_height < 700.0
    # the image positions of the ground domain (LONG_OFF, LAT_OFF ± one scale) end near
    # row 43322 − 5000 of the full image: a crop beyond them is still refused
    beyond = crop_problem(crop_rpc, IMAGE, SHAPE, (60000.0, 0.0), "--crop-offset", True)
    assert beyond is not None
    assert "the RPC's image domain (lines 18380..20428, samples 18976..21024" in beyond.message


def test_an_rpc_whose_offsets_are_its_image_s_still_holds_the_crop_to_them():
    """SkySat's RPCs give a ground domain of ±1° (LAT_SCALE, LONG_SCALE 1), whose image
    positions span a million lines: their LINE/SAMP offsets are the image's (the ground
    domain's centre maps inside LINE_OFF 658.76 ± 2·675.12), so a crop beyond them is still
    refused, not held by the image positions of the ground domain."""
    skysat = read_rpc(
        DATA / "rpc_formats" / "20200413_151408_ssc4d2_0011_basic_panchromatic_dn.rpc"
    )
    assert crop_problem(skysat, IMAGE, (500, 500), (1000.0, 1000.0), "--crop-offset", True) is None
    beyond = crop_problem(skysat, IMAGE, (500, 500), (5000.0, 0.0), "--crop-offset", True)
    assert beyond is not None
    assert "the RPC's image domain (lines -691..2009, samples -1623..4778" in beyond.message
