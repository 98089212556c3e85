"""`blockqc rfm-accuracy` end to end on the real Pléiades pair, and its checkpoints in `inspect`."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import rasterio
from click.testing import CliRunner
from rfm_helpers import VENTOUX, ventoux_config

from blockqc.errors import InputError
from blockqc.rfm.command import command, console_line
from blockqc.rfm.dem import load_dem
from blockqc.rfm.model import ImageAffine
from blockqc.rfm.ortho import orthorectify, read_ortho
from blockqc.rfm.pipeline import RfmAccuracyConfig, run_rfm_accuracy
from blockqc.rfm.readers import read_rpc

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "batch"
CONTRACT_V1 = [
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
pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def base_args(out: Path) -> list[str]:
    return [
        str(VENTOUX / "left_image.tif"),
        "--rpc",
        str(VENTOUX / "left_image.geom"),
        "--dem",
        str(VENTOUX / "srtm_N44E005_crop.tif"),
        "--geoid",
        str(VENTOUX / "egm96_15_crop.gtx"),
        "--out",
        str(out),
    ]


@pytest.fixture(scope="module")
def real_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """Left image against the right image orthorectified as a same-accuracy reference."""
    out = tmp_path_factory.mktemp("rfm") / "run"
    args = base_args(out) + [
        "--reference",
        str(VENTOUX / "right_image.tif"),
        "--reference-rpc",
        str(VENTOUX / "right_image.geom"),
        "--grid",
        "25",
        "--export-checkpoints",
        "--refined-ortho",
    ]
    result = CliRunner().invoke(command, args)
    return out, result


def test_command_writes_every_output(real_run):
    out, result = real_run
    assert result.exception is None or isinstance(result.exception, SystemExit), result.output
    for name in (
        "cps.csv",
        "results.json",
        "error_vectors.png",
        "gev_histogram.png",
        "refined_rfm.csv",
        "report.html",
        "ortho.tif",
        "reference_on_grid.tif",
        "checkpoints.csv",
        "ortho_refined.tif",
    ):
        assert (out / name).is_file(), name
    assert (out / "error_vectors.png").read_bytes()[:4] == b"\x89PNG"
    assert "§RA-4" in (out / "report.html").read_text()


def test_real_pair_gives_a_believable_rmse_and_a_failing_verdict(real_run):
    """The README of the pair measured ~5 px relative error with the original RPCs."""
    out, result = real_run
    results = json.loads((out / "results.json").read_text())
    acc = results["accuracy"]
    assert acc["n"] >= 20
    assert 2.0 < acc["rmse_px"] < 15.0
    assert acc["verdict"] == "fail" and result.exit_code == 1
    assert results["grid"]["crs"] == "EPSG:32631"
    assert "egm96" in results["dem"]["heights"].lower()
    cps = pd.read_csv(out / "cps.csv")
    assert len(cps) == acc["n"]
    # GEV per CP recomputed by hand from the coordinates
    gev = np.hypot(cps.x_m - cps.ref_x_m, cps.y_m - cps.ref_y_m) / results["grid"]["gsd_m"]
    np.testing.assert_allclose(cps.gev_px, gev, atol=1e-5)


def test_cps_geographic_coordinates_give_back_every_gev(real_run):
    """§RA-4 takes (x, y) and (x′, y′) as geographic coordinates: the ellipsoidal distance
    between a CP's lon/lat on the image and on the reference, over d_s, is its GEV to a
    thousandth of a pixel (written to 1e-6 degree, 0.11 m in latitude, they gave it to only
    0.2 px on this 0.5 m image), and the RMSE of those distances is the run's."""
    from pyproj import Geod

    out, _ = real_run
    acc = json.loads((out / "results.json").read_text())["accuracy"]
    cps = pd.read_csv(out / "cps.csv")
    _, _, dist = Geod(ellps="WGS84").inv(cps.ref_lon, cps.ref_lat, cps.lon, cps.lat)
    np.testing.assert_allclose(dist / acc["image_gsd_m"], cps.gev_px, atol=1e-3)
    rmse = np.sqrt(np.mean(dist**2)) / acc["image_gsd_m"]
    assert rmse == pytest.approx(acc["rmse_px"], abs=1e-3)


def test_the_affine_of_every_cp_is_given_at_the_image_centre(real_run):
    """The §3 affine is in full-image coordinates: on the Ventoux crop (rows and columns 5000 to
    5499 of the scene) a0 is hundreds of pixels where the correction over the image is a few;
    the page gave a0 alone. Δl, Δs at the crop's centre (line, sample 5249.5) are now given,
    a0 + a1·s + a2·l and b0 + b1·s + b2·l by hand."""
    out, _ = real_run
    all_cps = json.loads((out / "results.json").read_text())["refined_rfm"]["all_cps"]
    a = all_cps["affine"]
    line = sample = 5249.5
    d_line = a["a0"] + a["a1"] * sample + a["a2"] * line
    d_sample = a["b0"] + a["b1"] * sample + a["b2"] * line
    centre = all_cps["centre"]
    assert (centre["line"], centre["sample"]) == (line, sample)
    assert centre["d_line_px"] == pytest.approx(d_line, abs=1e-9)
    assert centre["d_sample_px"] == pytest.approx(d_sample, abs=1e-9)
    assert abs(d_line) < 20 < abs(a["a0"])
    page = (out / "report.html").read_text(encoding="utf-8")
    assert f"Δl = {d_line:.2f} px, Δs = {d_sample:.2f} px" in page


def test_refined_rfm_table_falls_below_the_original(real_run):
    out, _ = real_run
    table = pd.read_csv(out / "refined_rfm.csv").set_index("k")
    assert list(table.index) == [0, 6, 12, 16, 20]
    assert (
        table.loc[20, "rmse_px_mean"] < table.loc[6, "rmse_px_mean"] < table.loc[0, "rmse_px_mean"]
    )


def test_exported_checkpoints_are_contract_v1(real_run):
    out, _ = real_run
    ckp = pd.read_csv(out / "checkpoints.csv", keep_default_na=False)
    assert list(ckp.columns) == CONTRACT_V1
    assert set(ckp.method) == {"same_accuracy"} and set(ckp.reference_id) == {"right_image"}
    assert (ckp.ref_z_m == "").all() and ckp.point_id.is_unique


def test_exported_checkpoints_run_through_inspect(real_run, tmp_path: Path):
    """Put the CPs into a same-accuracy sample delivery (UTM 31N) and inspect it."""
    from blockqc.cli import cli

    out, _ = real_run
    delivery = tmp_path / "F4-B01"
    shutil.copytree(SAMPLES / "F4-B01", delivery)
    shutil.copy(out / "checkpoints.csv", delivery / "checkpoints.csv")
    n = len(pd.read_csv(out / "checkpoints.csv"))
    result = CliRunner().invoke(cli, ["inspect", str(delivery), "--out", str(tmp_path / "insp")])
    assert result.exit_code in (0, 1), result.output
    found = list((tmp_path / "insp").rglob("results.json"))
    results = json.loads(found[0].read_text())
    plane = [
        r
        for r in results["results"]
        if r["rule"] == "CP-2" and r.get("group", {}).get("method") == "same_accuracy"
    ]
    assert plane and plane[0]["detail"]["n"] + plane[0]["detail"].get("n_gross", 0) == n
    assert plane[0]["status"] == "pass"  # ~3.5 m plane differences against a 10 m norm


# -- the pipeline's geometry with a known shift and an independent stand-in matcher ------------
def phase_correlation_matcher(
    image, reference, *, image_valid, reference_valid, offset, chunk, grid
):
    """One global shift by phase correlation (OpenCV) of the central, fully valid part of the
    image, applied at the centre of each cell."""
    oy, ox = int(round(offset[0])), int(round(offset[1]))
    h, w = image.shape
    r0, r1, c0, c1 = h // 4, 3 * h // 4, w // 4, 3 * w // 4
    a = image[r0:r1, c0:c1].astype(np.float64)
    b = reference[oy + r0 : oy + r1, ox + c0 : ox + c1].astype(np.float64)
    assert np.isfinite(a).all() and np.isfinite(b).all()
    window = cv2.createHanningWindow((a.shape[1], a.shape[0]), cv2.CV_64F)
    (sx, sy), _ = cv2.phaseCorrelate(a, b, window)
    both = np.isfinite(image) & np.isfinite(reference[oy : oy + h, ox : ox + w])
    rows, cols = np.mgrid[grid // 2 : image.shape[0] : grid, grid // 2 : image.shape[1] : grid]
    rows, cols = rows.ravel().astype(float), cols.ravel().astype(float)
    keep = both[rows.astype(int), cols.astype(int)]
    rows, cols = rows[keep], cols[keep]
    return pd.DataFrame(
        {
            "row": rows,
            "col": cols,
            "ref_row": rows + offset[0] + round(sy),
            "ref_col": cols + offset[1] + round(sx),
            "kind": "ncc",
            "score": 1.0,
            "cell_row": (rows // grid).astype(int),
            "cell_col": (cols // grid).astype(int),
        }
    )


def _shifted_config(tmp_path: Path, east_px: int, south_px: int, **options) -> tuple:
    """The image's own ortho georeferenced `east_px` east and `south_px` south as the reference:
    the run's configuration (`options` added) and the ortho's GSD."""
    rpc = read_rpc(VENTOUX / "left_image.geom")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    grid = orthorectify(VENTOUX / "left_image.tif", rpc, dem, tmp_path / "own.tif")
    g = grid.gsd
    with rasterio.open(tmp_path / "own.tif") as src:
        profile, data = src.profile, src.read()
    t = grid.transform
    profile["transform"] = rasterio.Affine(t.a, 0, t.c + east_px * g, 0, t.e, t.f - south_px * g)
    with rasterio.open(tmp_path / "reference.tif", "w", **profile) as dst:
        dst.write(data)
    cfg = RfmAccuracyConfig(
        image=VENTOUX / "left_image.tif",
        rpc=VENTOUX / "left_image.geom",
        dem=VENTOUX / "srtm_N44E005_crop.tif",
        geoid=VENTOUX / "egm96_15_crop.gtx",
        reference=tmp_path / "reference.tif",
        out=tmp_path / "out",
        **options,
    )
    return cfg, g


def test_pipeline_measures_a_known_reference_shift(tmp_path: Path):
    """Reference = the image's own ortho georeferenced 3 px east and 2 px south: every CP must
    show dx = −3 px, dy = +2 px, so RMSE = √13 px; a refined RFM removes the shift."""
    cfg, g = _shifted_config(tmp_path, 3, 2, match_grid=50, refined_ortho=True, repeats=3)
    results = run_rfm_accuracy(cfg, matcher=phase_correlation_matcher)
    cps = pd.read_csv(tmp_path / "out" / "cps.csv")
    assert len(cps) > 50
    np.testing.assert_allclose(cps.dx_m / g, -3.0, atol=1e-6)
    np.testing.assert_allclose(cps.dy_m / g, 2.0, atol=1e-6)
    assert results["accuracy"]["rmse_px"] == pytest.approx(np.sqrt(13.0), abs=1e-6)
    assert results["distortion"]["significant"] is False
    rows = {r["k"]: r for r in results["refined_rfm"]["rows"]}
    assert rows[0]["rmse_px_mean"] == pytest.approx(np.sqrt(13.0), abs=0.05)
    # a ground shift is affine in image space only up to relief: the DEM height at the shifted
    # position differs (slopes of ~20 %), which moves the image position by ~0.1 px here
    assert rows[6]["rmse_px_max"] < 0.2
    # §RA-1 with the refined RFM: the corrected image moves by the shift, (+2 rows, +3 cols)
    original, _ = read_ortho(tmp_path / "out" / "ortho.tif")
    refined, _ = read_ortho(tmp_path / "out" / "ortho_refined.tif")
    moved = np.nanmedian(np.abs(refined[2:, 3:] - original[:-2, :-3]))
    unmoved = np.nanmedian(np.abs(refined - original))
    assert moved < 0.2 * unmoved
    # in image space, at the crop's centre, the correction is the same shift: ~(+2 lines,
    # +3 samples) for a near north-up image at ~the ortho's GSD
    affine = ImageAffine(**results["refined_rfm"]["all_cps"]["affine"])
    d_line, d_sample = affine.delta(5250.0, 5250.0)
    assert d_line == pytest.approx(2.0, abs=0.3) and d_sample == pytest.approx(3.0, abs=0.3)


def test_rmse_is_in_image_pixels_whatever_the_output_grid(tmp_path: Path):
    """§RA-4 divides by d_s, the image's GSD: a shift of about 4 px east, 4 px south found on a
    grid of twice the image's GSD (--gsd) is about √32 image pixels, not √8 grid pixels (a
    coarse grid turned a failing image into a passing one)."""
    cfg, g = _shifted_config(tmp_path, 4, 4, match_grid=25, repeats=2)
    cfg.gsd = 2 * g
    results = run_rfm_accuracy(cfg, matcher=phase_correlation_matcher)
    assert results["grid"]["gsd_m"] == pytest.approx(2 * g)
    assert results["accuracy"]["image_gsd_m"] == pytest.approx(g)
    cps = pd.read_csv(tmp_path / "out" / "cps.csv")
    # the shift found (whole grid pixels: the stand-in matcher rounds) is about the one made
    assert np.hypot(cps.dx_m.median(), cps.dy_m.median()) == pytest.approx(
        np.sqrt(32) * g, abs=2.5 * g
    )
    rmse_m = np.sqrt(np.mean(cps.dx_m**2 + cps.dy_m**2))
    assert results["accuracy"]["rmse_m"] == pytest.approx(rmse_m, rel=1e-5)
    assert results["accuracy"]["rmse_px"] == pytest.approx(rmse_m / g, rel=1e-5)
    np.testing.assert_allclose(cps.gev_px, np.hypot(cps.dx_m, cps.dy_m) / g, rtol=1e-5)


def _four_bands(single: Path, path: Path, colour: bool) -> None:
    """`single` as four bands. Colour: red 0 wherever there is data, green and blue 1.5×
    `single` (the mean of the three is `single` itself) and alpha (255 where there is data).
    Multispectral (no colours declared): band 1 `single`, bands 2–4 `single` upside down
    (their texture is not the image's)."""
    with rasterio.open(single) as src:
        profile = src.profile
        x = src.read(1, masked=True).astype(np.float32).filled(np.nan)
    valid = np.isfinite(x)
    if colour:
        bands = np.stack([np.where(valid, 0.0, np.nan), 1.5 * x, 1.5 * x, 255.0 * valid])
        profile.update(photometric="RGB", alpha="YES")
    else:
        bands = np.stack([x, x[::-1], x[::-1], x[::-1]])
        profile.update(photometric="MINISBLACK")
    profile.update(count=4, dtype="float32", nodata=None)
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(bands.astype(np.float32))


ONE_BAND = {"count": 1, "used": [1], "matched_on": "band 1 (one band)"}
RGBA = {
    "count": 4,
    "used": [1, 2, 3],
    "matched_on": "mean of bands 1, 2, 3 (red, green, blue) of 4",
}
MS = {"count": 4, "used": [1], "matched_on": "band 1 of 4 (no bands declared red, green, blue)"}


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
@pytest.mark.parametrize(
    ("several", "colour"),
    [("image", True), ("reference", True), ("image", False), ("reference", False)],
)
def test_inputs_of_several_bands_are_matched_on_their_grey(tmp_path: Path, several, colour):
    """An image or a reference of four bands is matched on the mean of the bands it declares
    red, green and blue (alpha left out), else on band 1, and says which: built so that this
    grey is the one-band input, the run gives the one-band answer (RMSE √13 px for the
    reference shifted 3 px east, 2 px south), where band 1 of the colour file is flat and the
    mean of the multispectral one is not the image."""
    rpc = read_rpc(VENTOUX / "left_image.geom")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    grid = orthorectify(VENTOUX / "left_image.tif", rpc, dem, tmp_path / "own.tif")
    g, t = grid.gsd, grid.transform
    with rasterio.open(tmp_path / "own.tif") as src:
        profile, data = src.profile, src.read()
    profile["transform"] = rasterio.Affine(t.a, 0, t.c + 3 * g, 0, t.e, t.f - 2 * g)
    with rasterio.open(tmp_path / "reference.tif", "w", **profile) as dst:
        dst.write(data)
    image, reference = VENTOUX / "left_image.tif", tmp_path / "reference.tif"
    if several == "image":
        image = tmp_path / "four_band_image.tif"
        _four_bands(VENTOUX / "left_image.tif", image, colour)
    else:
        reference = tmp_path / "four_band_reference.tif"
        _four_bands(tmp_path / "reference.tif", reference, colour)
    cfg = RfmAccuracyConfig(
        image=image,
        rpc=VENTOUX / "left_image.geom",
        dem=VENTOUX / "srtm_N44E005_crop.tif",
        geoid=VENTOUX / "egm96_15_crop.gtx",
        reference=reference,
        out=tmp_path / "out",
        match_grid=50,
        repeats=3,
    )
    results = run_rfm_accuracy(cfg, matcher=phase_correlation_matcher)
    assert results["accuracy"]["rmse_px"] == pytest.approx(np.sqrt(13.0), abs=1e-6)
    ortho, _ = read_ortho(tmp_path / "out" / "ortho.tif")
    own, _ = read_ortho(tmp_path / "own.tif")
    np.testing.assert_allclose(ortho, own, rtol=1e-6)  # NaN where the image has no data
    four = RGBA if colour else MS
    image_bands, reference_bands = (four, ONE_BAND) if several == "image" else (ONE_BAND, four)
    assert results["image_bands"] == image_bands
    assert results["reference"]["bands"] == reference_bands
    line = console_line("x.tif", results, 1.0, tmp_path)
    assert f"matched on the image's {image_bands['matched_on']} and the reference's " in line
    page = (tmp_path / "out" / "report.html").read_text()
    assert four["matched_on"] in page


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
@pytest.mark.parametrize("paletted", ["image", "reference"])
def test_a_paletted_input_is_refused_before_anything_is_made(tmp_path: Path, capsys, paletted):
    """A colour-mapped (paletted) 8-bit raster holds indices into its colour table: matched
    as grey levels, a reference whose table lists its greys out of order gave 'no control
    point found: no texture ... check its georeferencing' after the whole ortho was made."""
    from blockqc.cli import main

    rpc = read_rpc(VENTOUX / "left_image.geom")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    orthorectify(VENTOUX / "left_image.tif", rpc, dem, tmp_path / "own.tif")
    source = tmp_path / "own.tif" if paletted == "reference" else VENTOUX / "left_image.tif"
    with rasterio.open(source) as src:
        profile, grey = src.profile, src.read(1)
    index = np.nan_to_num(grey / np.nanmax(grey) * 254.0).astype(np.uint8)
    profile.update(dtype="uint8", nodata=None, photometric="palette", count=1)
    path = tmp_path / "paletted.tif"
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(index, 1)
        dst.write_colormap(1, {i: ((37 * i) % 256,) * 3 + (255,) for i in range(256)})
    image = path if paletted == "image" else VENTOUX / "left_image.tif"
    reference = path if paletted == "reference" else tmp_path / "own.tif"
    args = [
        str(image), "--rpc", str(VENTOUX / "left_image.geom"),
        "--dem", str(VENTOUX / "srtm_N44E005_crop.tif"),
        "--geoid", str(VENTOUX / "egm96_15_crop.gtx"),
        "--reference", str(reference), "--out", str(tmp_path / "out"),
    ]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"error: {path}: band 1 holds indices into a colour table (a paletted image), not grey "
        "levels: matched as they are, neighbouring colours would be far apart; expand it first "
        "(gdal_translate -expand rgb IN OUT) and give the expanded file"
    )
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_geoid_dem_without_geoid_is_an_input_error(tmp_path: Path, capsys):
    from blockqc.cli import main

    args = base_args(tmp_path / "out")
    i = args.index("--geoid")
    del args[i : i + 2]
    args += [
        "--reference",
        str(VENTOUX / "right_image.tif"),
        "--reference-rpc",
        str(VENTOUX / "right_image.geom"),
    ]
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2
    assert "ellipsoidal" in capsys.readouterr().err


# -- issue 13: geoid options, the console line, the chosen cell, no CPs -----------------------
def _hgt_args(tmp_path: Path, out: str, *geoid: str) -> list[str]:
    from test_rfm_geoid import write_hgt

    hgt = tmp_path / "N44E005.hgt"
    if not hgt.exists():
        write_hgt(hgt)
    args = base_args(tmp_path / out)
    i = args.index("--dem")
    args[i + 1] = str(hgt)
    j = args.index("--geoid")
    del args[j : j + 2]
    return args + [
        *geoid,
        "--reference",
        str(VENTOUX / "right_image.tif"),
        "--reference-rpc",
        str(VENTOUX / "right_image.geom"),
        "--grid",
        "25",
        "--repeats",
        "10",
    ]


def test_srtm_tile_with_shipped_egm96_agrees_with_a_constant_offset(tmp_path: Path):
    """An SRTM .hgt with `--geoid egm96` needs no other file; `--geoid-offset N` (N of EGM96 at
    the scene) gives the same result to within the grid's resolution (N varies by < 0.1 m over
    the scene: ~0.01 m of plane shift for this view)."""
    from blockqc.rfm.geoid import egm96

    runner = CliRunner()
    a = runner.invoke(command, _hgt_args(tmp_path, "egm96", "--geoid", "egm96"))
    n = float(egm96().undulation(5.195, 44.207))
    b = runner.invoke(command, _hgt_args(tmp_path, "offset", "--geoid-offset", f"{n:.3f}"))
    assert a.exit_code == 1 and b.exit_code == 1, a.output + b.output
    ra = json.loads((tmp_path / "egm96" / "results.json").read_text())
    rb = json.loads((tmp_path / "offset" / "results.json").read_text())
    assert "EGM96" in ra["dem"]["heights"] and "--geoid-offset" in rb["dem"]["heights"]
    assert ra["accuracy"]["n"] == rb["accuracy"]["n"] >= 20
    assert abs(ra["accuracy"]["rmse_px"] - rb["accuracy"]["rmse_px"]) < 0.02
    ca, cb = (
        pd.read_csv(tmp_path / "egm96" / "cps.csv"),
        pd.read_csv(tmp_path / "offset" / "cps.csv"),
    )
    assert np.max(np.abs(ca.h_m - cb.h_m)) < 0.1


def test_srtm_tile_refuses_being_declared_ellipsoidal(tmp_path: Path, capsys):
    from blockqc.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *_hgt_args(tmp_path, "out", "--dem-vertical", "ellipsoid")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "declares EGM96" in err and "Traceback" not in err


def test_unknown_dem_reference_names_both_options(tmp_path: Path, capsys):
    from blockqc.cli import main

    args = base_args(tmp_path / "out")
    i = args.index("--geoid")
    del args[i : i + 2]
    args += ["--reference", str(VENTOUX / "right_image.tif")]
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for words in ("--geoid egm96", "--geoid FILE", "--geoid-offset", "m of plane error"):
        assert words in err


def test_console_line_gives_the_systematic_shift(real_run):
    out, result = real_run
    d = json.loads((out / "results.json").read_text())["distortion"]
    cps = pd.read_csv(out / "cps.csv")
    gsd = json.loads((out / "results.json").read_text())["grid"]["gsd_m"]
    assert d["mean_dx_m"] == pytest.approx(cps.dx_m.mean(), abs=1e-6)
    assert d["mean_dy_px"] == pytest.approx(cps.dy_m.mean() / gsd, abs=1e-6)
    line = (
        f"shift dx {d['mean_dx_m']:+.2f} m ({d['mean_dx_px']:+.2f} px) "
        f"dy {d['mean_dy_m']:+.2f} m ({d['mean_dy_px']:+.2f} px)"
    )
    assert line in result.output


@pytest.mark.parametrize(
    ("rmse", "verdict", "shown"),
    [(0.99962, "pass", "0.9996"), (0.999999, "pass", "0.999999"), (1.0004, "fail", "1.000")],
)
def test_the_rmse_shown_is_on_the_side_of_the_requirement_its_verdict_is(
    real_run, tmp_path: Path, rmse: float, verdict: str, shown: str
):
    """An RMSE of 0.99962 px passes (< 1 px): the console line and the page read 0.9996 px,
    not the "1.000 px → pass" they gave, which the requirement "< 1 px" contradicts."""
    from blockqc.rfm.report import render_html

    out, _ = real_run
    results = json.loads((out / "results.json").read_text())
    results["accuracy"].update(rmse_px=rmse, verdict=verdict, requirement_px=1.0)
    line = console_line("x.tif", results, 1.0, tmp_path)
    assert f"RMSE {shown} px" in line and f"→ {verdict}" in line
    for lang in ("en", "zh"):
        page = render_html(results, lang=lang)
        assert f"<td>{shown} " in page


def test_no_overlap_is_an_input_error_with_its_reason(tmp_path: Path, capsys):
    """A reference placed elsewhere (wrong crop offset): 0 CPs is exit 2, not a failed verdict."""
    from blockqc.cli import main

    args = base_args(tmp_path / "out") + [
        "--reference",
        str(VENTOUX / "right_image.tif"),
        "--reference-rpc",
        str(VENTOUX / "right_image.geom"),
        "--reference-crop-offset",
        "20000,20000",
    ]
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "no control point found" in err and "overlap" in err
    assert not (tmp_path / "out" / "results.json").exists()


def test_a_reference_without_data_over_the_image_is_named(tmp_path: Path):
    """A georeferenced reference over the image whose pixels there are all no data: the run said
    "the reference does not overlap the image" and named the image; it is the reference that
    holds nothing there. The same reference placed 10 km east does not overlap, as before."""
    cfg, _ = _shifted_config(tmp_path, 0, 0)
    with rasterio.open(cfg.reference, "r+") as ds:
        ds.write(np.full((ds.height, ds.width), np.nan, np.float32), 1)
    with pytest.raises(InputError) as exc:
        run_rfm_accuracy(cfg)
    message = str(exc.value)
    assert str(cfg.reference) in message and str(cfg.image) not in message
    assert "no control point found: the reference has no data over the image" in message
    with rasterio.open(cfg.reference, "r+") as ds:
        t = ds.transform
        ds.transform = rasterio.Affine(t.a, 0, t.c + 10_000, 0, t.e, t.f)
    with pytest.raises(InputError) as exc:
        run_rfm_accuracy(cfg)
    assert "the reference does not overlap the image" in str(exc.value)


def test_the_image_s_own_ortho_as_its_reference_is_refused(tmp_path: Path):
    """The image's own ortho on the run's grid (an earlier run's ortho.tif) as the reference:
    every pixel of the overlap the image's value, RMSE 0.045 px, "pass", of resampling alone."""
    cfg, _ = _shifted_config(tmp_path, 0, 0)
    with pytest.raises(InputError) as exc:
        run_rfm_accuracy(cfg)
    message = str(exc.value)
    assert message.startswith(f"{cfg.reference}: ")
    assert "the image's own pixels" in message and "independent of the image" in message
    assert not (tmp_path / "out" / "results.json").exists()


def test_no_texture_is_an_input_error_with_its_reason(tmp_path: Path):

    def nothing(image, reference, **_):
        return pd.DataFrame(columns=["row", "col", "ref_row", "ref_col", "kind", "score"])

    cfg = ventoux_config(tmp_path / "out")
    with pytest.raises(InputError, match="no control point found: no texture"):
        run_rfm_accuracy(cfg, matcher=nothing)


def test_cell_is_chosen_from_the_image_size(tmp_path: Path):
    """No --grid on a 500 × 500 px crop: the cell gives ≥ 50 CPs (the old 400 px cell gave 4)."""
    from blockqc.rfm.pipeline import choose_cell

    assert choose_cell(250_000)[0] == 50  # √(250000 / 100)
    assert choose_cell(10_000**2)[0] == 400 and choose_cell(900)[0] == 24
    rpc = read_rpc(VENTOUX / "left_image.geom")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid="egm96")
    orthorectify(VENTOUX / "left_image.tif", rpc, dem, tmp_path / "own.tif")
    with rasterio.open(tmp_path / "own.tif", "r+") as ds:  # one pixel east: not the image's
        t = ds.transform
        ds.transform = rasterio.Affine(t.a, 0, t.c + t.a, 0, t.e, t.f)
    cfg = ventoux_config(
        tmp_path / "out", reference=tmp_path / "own.tif", reference_rpc=None, repeats=3
    )
    results = run_rfm_accuracy(cfg, matcher=phase_correlation_matcher)
    m = results["matching"]
    assert m["grid"] < 400 and "chosen from the image size" in m["grid_choice"]
    assert m["n_cps"] >= 50 and results["warnings"] == []


def test_too_few_cps_on_a_small_image_match_again_with_a_smaller_cell(tmp_path: Path):
    """A chosen cell that gives < 50 matches is shrunk once in proportion to √(n / 60)."""
    from blockqc.rfm.pipeline import match_cps

    cells = []

    def sparse(image, reference, *, grid, **_):
        cells.append(grid)
        n = 30 if len(cells) == 1 else 55
        return pd.DataFrame({"row": np.arange(n, dtype=float), "col": 0.0})

    cfg = RfmAccuracyConfig(image=Path("a"), dem=Path("b"), reference=Path("c"), out=tmp_path)
    image = np.zeros((400, 400), np.float32)
    overlap = np.ones((400, 400), bool)
    matches, cell, how = match_cps(cfg, image, image, overlap, sparse)
    # 160000 px → 40 px cells; 30 matches → 40·√(30/60) = 28.3 → 28 px
    assert cells == [40, 28] and cell == 28 and len(matches) == 55 and "again at 28 px" in how


def test_no_cp_reasons_name_dem_voids_and_overlap():
    from pyproj import CRS
    from rasterio.transform import from_origin

    from blockqc.rfm.dem import DEM, Grid
    from blockqc.rfm.pipeline import no_cp_cause

    holes = np.full((10, 10), np.nan)
    holes[:2] = 500.0  # 80 % voids
    dem = DEM(Grid(holes, from_origin(5.0, 45.0, 0.01, 0.01), CRS.from_epsg(4326)), "test")
    image = np.where(np.arange(100)[:, None] < 10, 1.0, np.nan) * np.ones((100, 100))
    overlap = np.isfinite(image)
    assert "DEM voids" in no_cp_cause(image, overlap, dem, 0)[1]
    assert "does not overlap" in no_cp_cause(image, np.zeros_like(overlap), dem, 0)[1]
    assert "every match fell on a DEM void" in no_cp_cause(image, overlap, dem, 12)[1]


def test_an_earlier_runs_outputs_do_not_stay_beside_a_failed_run(tmp_path: Path, capsys):
    """A run that finds no CP in a folder holding an earlier run's outputs: the earlier
    results.json, cps.csv and checkpoints.csv stay as they were, and nothing of the failed run
    (its ortho.tif) is put beside them as if they were its results."""
    from blockqc.cli import main

    out = tmp_path / "out"
    out.mkdir()
    earlier = '{"kind": "rfm_accuracy", "run": "earlier"}'
    (out / "results.json").write_text(earlier, encoding="utf-8")
    for name in ("cps.csv", "checkpoints.csv", "report.html", "notes.txt"):
        (out / name).write_text("earlier run", encoding="utf-8")
    args = base_args(out) + [
        "--reference", str(VENTOUX / "right_image.tif"),
        "--reference-rpc", str(VENTOUX / "right_image.geom"),
        "--reference-crop-offset", "20000,20000",
    ]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2 and "no control point found" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [
        "checkpoints.csv",
        "cps.csv",
        "notes.txt",  # not an output: left alone
        "report.html",
        "results.json",
    ]
    assert (out / "results.json").read_text(encoding="utf-8") == earlier
    assert (out / "cps.csv").read_text(encoding="utf-8") == "earlier run"


def test_an_input_an_output_would_replace_is_refused(tmp_path: Path, capsys):
    """The image named ortho.tif in the output folder: it was overwritten by the ortho."""
    from blockqc.cli import main

    folder = tmp_path / "work"
    folder.mkdir()
    shutil.copy(VENTOUX / "left_image.tif", folder / "ortho.tif")
    before = (folder / "ortho.tif").read_bytes()
    args = [str(folder / "ortho.tif")] + base_args(folder)[1:] + [
        "--reference", str(VENTOUX / "right_image.tif"),
        "--reference-rpc", str(VENTOUX / "right_image.geom"),
    ]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    assert exc.value.code == 2
    assert capsys.readouterr().err == (
        f"error: --out {folder}: its ortho.tif would replace the input {folder / 'ortho.tif'}; "
        "choose another output folder (or rename the input)\n"
    )
    assert (folder / "ortho.tif").read_bytes() == before
    assert sorted(p.name for p in folder.iterdir()) == ["ortho.tif"]


def test_an_input_error_leaves_no_empty_out_it_made(tmp_path: Path):
    """An RPC file that is no RPC: exit 2, and the --out the run made is removed again (it was
    left empty); an --out that was there before is kept."""
    bad = tmp_path / "bad.RPB"
    bad.write_text("garbage\n")
    out = tmp_path / "out"
    args = base_args(out) + ["--reference", str(VENTOUX / "right_image.tif")]
    args[args.index("--rpc") + 1] = str(bad)
    result = CliRunner().invoke(command, args)
    assert isinstance(result.exception, InputError)  # exit 2
    assert "not a known RPC format" in str(result.exception)
    assert not out.exists()
    out.mkdir()
    assert isinstance(CliRunner().invoke(command, args).exception, InputError) and out.is_dir()


def test_a_reference_without_rpcs_is_refused_before_any_output(tmp_path: Path):
    """A reference in sensor geometry that carries no RPCs, none given: exit 2 before the image
    is orthorectified, so the --out the run made is removed again (no ortho.tif left in it)."""
    out = tmp_path / "out"
    args = base_args(out) + ["--reference", str(VENTOUX / "right_image.tif")]
    result = CliRunner().invoke(command, args)
    assert isinstance(result.exception, InputError)  # exit 2
    assert "carries no RPCs" in str(result.exception)
    assert not out.exists()


@pytest.mark.parametrize(
    ("spoil", "fragment"),
    [
        ("scattered", "the reference has empty pixels (no data or NaN) scattered"),
        ("flat", "the reference is flat (one grey level) over the image"),
    ],
)
def test_a_reference_that_cannot_be_matched_is_named_as_the_cause(tmp_path: Path, spoil, fragment):
    """A reference with 2 % of its pixels empty at random (no 37 px search window is free of
    them) or of one grey level: no CP, and the message names the reference and why, where it
    named the image and blamed its texture."""
    cfg, _ = _shifted_config(tmp_path, 3, 2, repeats=2)
    with rasterio.open(cfg.reference, "r+") as ds:
        data = ds.read(1)
        if spoil == "scattered":
            data[np.random.default_rng(0).random(data.shape) < 0.02] = np.nan
        else:
            data[np.isfinite(data)] = 500.0
        ds.write(data, 1)
    with pytest.raises(InputError) as info:
        run_rfm_accuracy(cfg)
    problem = info.value.problems[0]
    assert problem.file == str(cfg.reference)
    assert problem.message.startswith(f"no control point found: {fragment}")


def test_an_overlap_narrower_than_a_matching_window_is_named():
    """The reference covers a 40 px strip of a textured image (8 % of it): no 50 px matching
    window fits in the overlap, which the message says, where it blamed the texture."""
    from pyproj import CRS
    from rasterio.transform import from_origin

    from blockqc.rfm.dem import DEM, Grid
    from blockqc.rfm.pipeline import no_cp_cause

    dem = DEM(
        Grid(np.full((10, 10), 500.0), from_origin(5.0, 45.0, 0.01, 0.01), CRS.from_epsg(4326)),
        "test",
    )
    image = np.random.default_rng(0).uniform(0, 100, (500, 500))
    overlap = np.zeros(image.shape, bool)
    overlap[:, 200:240] = True
    reason = no_cp_cause(image, overlap, dem, 0)[1]
    assert reason.startswith(
        "no control point found: the image and the reference overlap on 20000 px only, nowhere "
        "on a whole 50 px matching window"
    )
    overlap[:, 200:250] = True  # 50 px wide: a window fits, the texture is blamed again
    assert "no texture" in no_cp_cause(image, overlap, dem, 0)[1]


def test_a_reference_off_by_far_more_than_the_search_gives_no_verdict(tmp_path: Path):
    """The image's own ortho georeferenced 100 px east and 100 px south: every match in the
    ±8 px search is wrong. It gave 8 CPs agreeing by chance and a 'fail' verdict (RMSE 4.1 px,
    exit 1) on the image's RPCs; now no CP is found (exit 2)."""
    cfg, _ = _shifted_config(tmp_path, 100, 100, repeats=2)
    with pytest.raises(InputError, match="no control point found: no texture or too little") as e:
        run_rfm_accuracy(cfg)
    assert "the reference lies further from the image than the matcher searches" in str(e.value)
    assert not (cfg.out / "results.json").exists()


def _full_dem():
    from pyproj import CRS
    from rasterio.transform import from_origin

    from blockqc.rfm.dem import DEM, Grid

    grid = Grid(np.full((10, 10), 500.0), from_origin(5.0, 45.0, 0.01, 0.01), CRS.from_epsg(4326))
    return DEM(grid, "test")


def _texture(shape):
    return np.random.default_rng(0).uniform(0, 100, shape)


@pytest.mark.parametrize(
    ("case", "start"),
    [
        ("all empty", "the image has no data on the grid: every pixel is no data or NaN"),
        ("one row", "the image's data hold no whole 51 px matching window: the image is too small"),
        ("16 px", "the image's data hold no whole 51 px matching window: the image is too small"),
        ("50 px", "the image's data hold no whole 51 px matching window: the image is too small"),
        ("scattered", "the image has empty pixels (no data or NaN) scattered over it"),
    ],
)
def test_no_cp_for_the_image_itself_is_not_put_on_the_reference_or_the_dem(case, start):
    """A DEM without a void and a reference over the whole grid, so the cause is the image's:
    it was put on the reference (an image without data: "does not overlap") or on DEM voids
    (an image one row high or 16 px wide: "most of the image has no height"; 2 % of its pixels
    empty at random: "DEM voids scattered", to be closed with --dem-fill-voids)."""
    from blockqc.rfm.pipeline import no_cp_cause

    image = np.full((500, 500), np.nan)
    if case == "one row":
        image[250] = _texture(500)
    elif case == "16 px":
        image[200:216, 300:316] = _texture((16, 16))
    elif case == "50 px":  # a corner needs 25 px of data on every side: 51 px, none fits in 50
        image[200:250, 300:350] = _texture((50, 50))
    elif case == "scattered":
        image = _texture((500, 500))
        image[np.random.default_rng(1).random(image.shape) < 0.02] = np.nan
    reference = _texture((500, 500))
    reason = no_cp_cause(image, np.isfinite(image), _full_dem(), 0, reference)[1]
    assert reason.startswith(f"no control point found: {start}")


def test_an_image_of_50_px_is_too_small_and_one_of_60_px_is_not():
    """The matcher takes a corner only 25 px from any empty pixel (its BRIEF patch and NCC
    template): an image whose data are 50 × 50 px holds no corner, and was said to lack texture
    ("a 50 px window fits"); one of 60 × 60 px holds 10 × 10 corner positions."""
    from blockqc.matching.matcher import _image_chunk
    from blockqc.matching.settings import MatchSettings
    from blockqc.rfm.pipeline import no_cp_cause

    reference = _texture((500, 500))
    for side, corners, cause in ((50, 0, "the image is too small"), (60, 100, "no texture")):
        image = np.full((500, 500), np.nan)
        image[200 : 200 + side, 300 : 300 + side] = reference[200 : 200 + side, 300 : 300 + side]
        valid = np.isfinite(image)
        usable = _image_chunk(image, valid, (0, 500, 0, 500), MatchSettings().margin)[1]
        assert usable.sum() == corners
        reason = no_cp_cause(image, valid, _full_dem(), 0, reference)[1]
        assert cause in reason, reason


def test_a_colour_references_transparent_pixels_have_no_data(tmp_path: Path):
    """An RGBA reference (8 bits, black where its alpha is 0, as colour orthophotos are
    exported) transparent over its west half: those pixels have no data on the image's grid.
    They were taken as black data (42 % of the grid), which counted as overlap and set the
    cell (56 CPs against 91 for the same reference with a mask)."""
    from blockqc.rfm.pipeline import reference_on_grid

    rpc = read_rpc(VENTOUX / "left_image.geom")
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    grid = orthorectify(VENTOUX / "left_image.tif", rpc, dem, tmp_path / "own.tif")
    own, _ = read_ortho(tmp_path / "own.tif")
    visible = np.isfinite(own)
    visible[:, : own.shape[1] // 2] = False
    grey = np.where(visible, own / 5, 0).astype(np.uint8)
    with rasterio.open(tmp_path / "own.tif") as src:
        profile = src.profile
    profile.update(count=4, dtype="uint8", nodata=None, photometric="RGB", alpha="YES")
    with rasterio.open(tmp_path / "rgba.tif", "w", **profile) as dst:
        dst.write(np.stack([grey, grey, grey, np.where(visible, 255, 0).astype(np.uint8)]))
    cfg = ventoux_config(tmp_path / "out", reference=tmp_path / "rgba.tif", reference_rpc=None)
    reference_on_grid(cfg, grid, dem, tmp_path / "on_grid.tif", None)
    on_grid, _ = read_ortho(tmp_path / "on_grid.tif")
    m = cfg.margin
    inner = on_grid[m:-m, m:-m]
    np.testing.assert_array_equal(np.isfinite(inner), visible)
    np.testing.assert_allclose(inner[visible], grey[visible], atol=1e-3)


@pytest.mark.parametrize(
    ("wkt", "name"),
    [
        ('LOCAL_CS["site grid",UNIT["metre",1]]', "site grid"),
        (
            'GEOGCS["Moon 2000",DATUM["D_Moon_2000",SPHEROID["Moon_2000_IAU_IAG",1737400.0,0.0]],'
            'PRIMEM["Greenwich",0],UNIT["Decimal_Degree",0.0174532925199433]]',
            "Moon 2000",
        ),
    ],
)
def test_a_reference_crs_that_cannot_reach_the_grid_is_an_input_error(
    tmp_path: Path, capsys, wkt, name
):
    """A reference georeferenced in an engineering CRS, or on another body: exit 2 naming the
    file and both CRSs, before the image is orthorectified; it stopped as an 'internal error'
    (GDAL's CPLE_NotSupportedError, 'please report it') after the image's ortho was made."""
    from blockqc.cli import main

    reference = tmp_path / "reference.tif"
    with rasterio.open(
        reference, "w", driver="GTiff", width=64, height=64, count=1, dtype="float32",
        crs=rasterio.crs.CRS.from_wkt(wkt), transform=rasterio.Affine(1, 0, 0, 0, -1, 64),
    ) as ds:  # fmt: skip
        ds.write(np.ones((1, 64, 64), np.float32))
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *base_args(out), "--reference", str(reference)])
    assert exc.value.code == 2
    assert capsys.readouterr().err == (
        f"error: {reference}: its CRS ({name}) cannot be transformed to the image grid's "
        "(WGS 84 / UTM zone 31N): a reference georeferenced on the Earth (a projected CRS such "
        "as a UTM zone, or EPSG:4326) is expected\n"
    )
    assert not out.exists()


@pytest.mark.browser
def test_a_long_image_path_wraps_within_the_page(real_run, tmp_path: Path):
    """An image at a path of 250 characters without a space: the paragraph naming it ran past
    the page's right edge (cut off, the page scrolled sideways); it now wraps."""
    from blockqc.rfm.report import render_html
    from casekit import page_overflow_px

    out, _ = real_run
    results = json.loads((out / "results.json").read_text())
    results["image"] = "/data/" + "deliveries_of_the_project_" * 9 + "/left_image.tif"
    html = render_html(results)
    assert results["image"] in html
    assert page_overflow_px(html, tmp_path) <= 0


def test_the_affine_of_every_cp_gives_its_shifts_in_pixels(real_run):
    """§RA-6's affine fitted to every CP was written 'a0 = 487.432, a1 = …, b0 = -127.217'
    without a unit: a0 and b0 are image pixels (Δl = a0 + a1·s + a2·l), a1, a2, b1, b2 have none."""
    import re

    out, _ = real_run
    page = (out / "report.html").read_text()
    affine = json.loads((out / "results.json").read_text())["refined_rfm"]["all_cps"]["affine"]
    for key, value in affine.items():
        unit = " px" if key in ("a0", "b0") else ""
        assert re.search(rf"\b{key} = {re.escape(f'{value:.6g}')}{unit}(,|;)", page), key


def test_a_distortion_found_not_significant_says_which_condition_failed(real_run):
    """The s2p Réunion pair: p = 0.00073 (below 0.01) but a field of 0.061 px RMS (below 0.5),
    so no significant distortion. The row read 'no (p < 0.01 and field RMS ≥ 0.5 px)', as if both
    held; it now gives the run's p and field RMS beside the criterion."""
    import re

    from blockqc.rfm.report import render_html

    out, _ = real_run
    results = json.loads((out / "results.json").read_text())
    results["distortion"].update(p_value=0.00073, field_rms_px=0.061, significant=False)
    page = render_html(results)
    row = re.search(r"significant distortion</th><td>(.*?)</td>", page).group(1)
    assert row.startswith("no: p = 0.00073, field RMS 0.061 px (")
    assert "significant when p &lt; 0.01 and field RMS ≥ 0.5 px" in row


def _coarser_reference(path: Path, factor: int) -> None:
    """The reference at `path` with pixels `factor` times as large (block means)."""
    with rasterio.open(path) as src:
        profile, data = src.profile, src.read(1)
    h, w = (data.shape[0] // factor) * factor, (data.shape[1] // factor) * factor
    blocks = data[:h, :w].reshape(h // factor, factor, w // factor, factor)
    with warnings.catch_warnings():  # blocks wholly outside the image: NaN, as they should be
        warnings.simplefilter("ignore", RuntimeWarning)
        coarse = np.nanmean(blocks, axis=(1, 3)).astype(data.dtype)
    t = profile["transform"]
    profile.update(
        width=coarse.shape[1],
        height=coarse.shape[0],
        transform=rasterio.Affine(t.a * factor, 0, t.c, 0, t.e * factor, t.f),
        blockxsize=256,
        blockysize=256,
    )
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(coarse, 1)


@pytest.mark.parametrize("factor", [1, 5])
def test_a_reference_much_coarser_than_the_image_is_warned_of(tmp_path: Path, factor: int):
    """§RA-2: a reference with pixels 5× the image's GSD is said to be too coarse (its GSD in
    results.json and on the page, in Chinese on a Chinese one); one at the image's own GSD is
    not."""
    from blockqc.rfm.report import render_html

    cfg, g = _shifted_config(tmp_path, 1, 0, match_grid=50, repeats=2)
    if factor > 1:
        _coarser_reference(cfg.reference, factor)
    results = run_rfm_accuracy(cfg, matcher=phase_correlation_matcher)
    assert results["reference"]["gsd_m"] == pytest.approx(factor * g, rel=1e-6)
    coarse = [w for w in results["warnings"] if w.startswith("§RA-2")]
    if factor == 1:
        assert coarse == []
    else:
        (warning,) = coarse
        shown = f"{results['reference']['gsd_m']:.3g}"  # 5·g, as asserted above
        assert f"{shown} m, 5.0× the image's GSD" in warning, warning
        zh = render_html(results, lang="zh")
        assert f"<li>§RA-2：参考影像的像素大小为 {shown} m，是影像地面采样距离（" in zh
        assert "<li>§RA-2: " not in zh
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert f"pixels of {factor * g:.3f} m" in page


def test_reference_gsd_of_a_geographic_reference_is_in_metres(tmp_path: Path):
    """A reference in lon/lat degrees: its pixel of 1e-4° × 1e-4° at 44.2° N is measured in
    metres on the image's UTM grid, as geodesic lengths on the WGS-84 ellipsoid give it."""
    from pyproj import CRS, Geod

    from blockqc.rfm.ortho import OrthoGrid
    from blockqc.rfm.pipeline import reference_gsd

    lon0, lat0, step = 5.2, 44.2, 1e-4
    path = tmp_path / "geo.tif"
    t = rasterio.Affine(step, 0, lon0 - 0.01, 0, -step, lat0 + 0.01)
    profile = {
        "driver": "GTiff", "dtype": "float32", "count": 1, "width": 200, "height": 200,
        "crs": "EPSG:4326", "transform": t,
    }  # fmt: skip
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(np.zeros((1, 200, 200), np.float32))
    utm = CRS.from_epsg(32631)
    from pyproj import Transformer

    x, y = Transformer.from_crs("EPSG:4326", utm, always_xy=True).transform(lon0, lat0)
    grid = OrthoGrid(utm, rasterio.Affine(0.5, 0, x - 50, 0, -0.5, y + 50), 200, 200)
    cfg = RfmAccuracyConfig(image=path, dem=path, reference=path, out=tmp_path)
    geod = Geod(ellps="WGS84")
    east = geod.inv(lon0, lat0, lon0 + step, lat0)[2]
    north = geod.inv(lon0, lat0, lon0, lat0 + step)[2]
    # UTM's point scale 2.2° east of zone 31's central meridian (3° E): k0·(1 + (Δλ·cos φ)²/2)
    k = 0.9996 * (1 + (np.radians(lon0 - 3.0) * np.cos(np.radians(lat0))) ** 2 / 2)
    got = reference_gsd(cfg, grid, None, None)
    assert got == pytest.approx(np.sqrt(east * north), rel=2e-3)
    assert got == pytest.approx(np.sqrt(east * north) * k, rel=1e-4)
