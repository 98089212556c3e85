"""`blockqc rfm-accuracy`: its options refused with a message (exit 2) before any output, few
CPs rendered, and a failed run leaving an earlier run's outputs as they were."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner
from pyproj import CRS
from rfm_helpers import VENTOUX, ventoux_config

from blockqc.errors import InputError
from blockqc.rfm.accuracy import distortion_summary
from blockqc.rfm.command import command
from blockqc.rfm.ortho import OrthoGrid, check_grid_size
from blockqc.rfm.pipeline import run_rfm_accuracy

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def ventoux_args(out: str | Path) -> list[str]:
    """The Ventoux pair, the right image orthorectified as a same-accuracy reference."""
    return [
        str(VENTOUX / "left_image.tif"),
        "--rpc", str(VENTOUX / "left_image.geom"),
        "--dem", str(VENTOUX / "srtm_N44E005_crop.tif"),
        "--geoid", "egm96",
        "--reference", str(VENTOUX / "right_image.tif"),
        "--reference-rpc", str(VENTOUX / "right_image.geom"),
        "--repeats", "5",
        "--out", str(out),
    ]  # fmt: skip


def refused(args: list[str], capsys) -> str:
    """Run the command line; it must stop with exit status 2 and no traceback: its stderr."""
    from blockqc.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["rfm-accuracy", *args])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert "Traceback" not in err and "internal error" not in err, err
    return err


def one_cell_config(out: Path):
    """The Ventoux pair matched in one cell (one CP), five draws per k."""
    return ventoux_config(out, match_grid=100_000, repeats=5)


def filled(folder: Path, files: dict[str, str]) -> dict[str, str]:
    """`folder` made and holding `files` (name: text); the files."""
    folder.mkdir(exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text, encoding="utf-8")
    return files


# -- 1. fewer than 4 CPs; a run that fails leaves the earlier outputs ---------------------------
def test_fewer_than_four_cps_leave_the_field_not_computed():
    """3 CPs: the shift is the mean vector, the field needs 4 CPs. dx 1, 2, 3 m and dy 0 at
    0.5 m: mean dx 2 m = 4 px, RMS about the mean √((4 + 0 + 4)/3) = 1.633 px."""
    s = distortion_summary([0, 100, 200], [0, 50, 0], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0], 0.5)
    assert s["n"] == 3 and s["mean_dx_px"] == pytest.approx(4.0) and s["mean_dx_m"] == 2.0
    assert s["local_rms_px"] == pytest.approx((8 / 3) ** 0.5)
    assert s["model"] == "not computed: fewer than 4 CPs" and s["significant"] is False
    for key in ("explained_share", "affine_explained_share", "f_statistic", "p_value"):
        assert s[key] is None, key


def test_one_cp_renders_the_page_saying_the_field_is_not_computed(tmp_path: Path):
    """--grid 100000 on the 500 × 500 px crop: one cell, one CP. The stock page failed on the
    missing explained share (exit 2) after results.json was written."""
    out = tmp_path / "out"
    result = CliRunner().invoke(command, ventoux_args(out) + ["--grid", "100000"])
    assert result.exit_code == 1, result.output  # 1 CP of ~8 px: a failed verdict
    assert json.loads((out / "results.json").read_text())["accuracy"]["n"] == 1
    page = (out / "report.html").read_text()
    assert "not computed: fewer than 4 CPs" in page and "not tested" in page


def test_a_run_failing_at_its_page_leaves_the_earlier_outputs(tmp_path: Path, monkeypatch):
    """The page fails to render: no new results.json is left without its page, and the
    earlier run's outputs are there as they were (nothing of the failed run beside them)."""
    out = tmp_path / "out"
    earlier = filled(
        out,
        {
            "results.json": '{"kind": "rfm_accuracy", "run": "earlier"}',
            "report.html": "earlier page",
            "cps.csv": "earlier cps",
        },
    )

    def broken(results: dict, **options: object) -> str:
        raise RuntimeError("the page fails")

    monkeypatch.setattr("blockqc.rfm.report.render_html", broken)
    with pytest.raises(RuntimeError, match="the page fails"):
        run_rfm_accuracy(one_cell_config(out))
    assert sorted(p.name for p in out.iterdir()) == sorted(earlier)
    for name, text in earlier.items():
        assert (out / name).read_text(encoding="utf-8") == text, name


def test_a_second_run_replaces_the_outputs_it_does_not_make_again(tmp_path: Path):
    """An earlier run's checkpoints.csv (--export-checkpoints) is removed by a run without it:
    two runs never mix; a file that is no output is left alone; no hidden folder stays."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text('{"kind": "rfm_accuracy"}', encoding="utf-8")
    (out / "checkpoints.csv").write_text("earlier", encoding="utf-8")
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    run_rfm_accuracy(one_cell_config(out))
    names = sorted(p.name for p in out.iterdir())
    assert "checkpoints.csv" not in names and "notes.txt" in names
    assert not [n for n in names if n.startswith(".")]
    assert json.loads((out / "results.json").read_text())["matching"]["grid"] == 100_000


# -- 2. --repeats ------------------------------------------------------------------------------
def test_repeats_are_bounded(tmp_path: Path, capsys):
    args = ventoux_args(tmp_path / "out")
    args[args.index("--repeats") + 1] = "10001"
    err = refused(args, capsys)
    assert "--repeats" in err and "10001" in err and "1<=x<=10000" in err
    assert not (tmp_path / "out").exists()
    help_text = CliRunner().invoke(command, ["--help"]).output
    assert "at most 10000" in help_text


# -- 3. --out ----------------------------------------------------------------------------------
def test_an_empty_out_is_refused(tmp_path: Path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    err = refused(ventoux_args(""), capsys)
    assert "--out" in err and "empty path" in err
    assert list(tmp_path.iterdir()) == []


def test_an_out_holding_an_inspect_blocks_results_is_refused(tmp_path: Path, capsys):
    """An `inspect` block folder: its results.json (block_id), report.html and checkpoints.csv
    would be replaced by this run's."""
    block = tmp_path / "F4-B01"
    files = filled(
        block,
        {
            "results.json": '{"block_id": "F4-B01", "status": "pass"}',
            "report.html": "inspect page",
            "checkpoints.csv": "point_id,method\n",
        },
    )
    err = refused(ventoux_args(block), capsys)
    assert str(block / "results.json") in err and "not the results of an rfm-accuracy" in err
    assert sorted(p.name for p in block.iterdir()) == sorted(files)
    for name, text in files.items():
        assert (block / name).read_text(encoding="utf-8") == text


def test_an_out_holding_a_results_json_that_is_no_json_is_refused(tmp_path: Path, capsys):
    (tmp_path / "results.json").write_text("not json", encoding="utf-8")
    err = refused(ventoux_args(tmp_path), capsys)
    assert str(tmp_path / "results.json") in err


# -- 4. option checks --------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--seed", "-100"),
        ("--gsd", "inf"),
        ("--gsd", "nan"),
        ("--gsd", "0"),
        ("--gsd", "-2"),
        ("--dem-fill-voids", "-1"),
        ("--chunk", "0"),
        ("--chunk", "47"),
    ],
)
def test_a_number_out_of_its_range_is_refused(tmp_path: Path, capsys, option: str, value: str):
    err = refused(ventoux_args(tmp_path / "out") + [option, value], capsys)
    assert f"'{option}'" in err and value in err
    assert not (tmp_path / "out").exists()


def test_an_empty_crs_is_refused(tmp_path: Path, capsys):
    err = refused(ventoux_args(tmp_path / "out") + ["--crs", ""], capsys)
    assert "--crs is empty" in err


@pytest.mark.parametrize("crs", ["EPSG:2263", "+proj=utm +zone=31 +datum=WGS84 +units=ft"])
def test_a_crs_in_feet_is_refused(tmp_path: Path, capsys, crs: str):
    """The grid's CRS gives the CPs' positions and shifts in metres (dx_m, cps.csv, the exported
    checkpoints): in feet, a 2.43 m shift was reported as 8.01 m."""
    err = refused(ventoux_args(tmp_path / "out") + ["--crs", crs], capsys)
    assert "--crs" in err and "metre" in err and "foot" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("crs", ["EPSG:3857", "EPSG:32661"])
def test_a_crs_whose_metres_are_not_the_ground_s_is_refused(tmp_path: Path, capsys, crs: str):
    """Web Mercator at 44.2° N stretches every length by 1/cos(44.2°) = 1.39: its metres gave the
    Ventoux image a GSD of 0.705 m (0.505 m) and a shift of −0.75 m (−0.53 m); UPS north of a
    scene at 44° N, 1.17."""
    err = refused(ventoux_args(tmp_path / "out") + ["--crs", crs], capsys)
    assert "--crs" in err and "scale" in err and "ground" in err
    if crs == "EPSG:3857":
        assert f"{1 / np.cos(np.radians(44.2)):.2f}" in err
    assert not (tmp_path / "out").exists()


def test_a_neighbouring_utm_zone_is_taken(tmp_path: Path):
    """UTM zone 30 at 5.2° E, 2.2° beyond its edge: its scale there is 1.005, within 1 %."""
    cfg = ventoux_config(tmp_path / "out", crs=CRS.from_epsg(32630), repeats=2)
    results = run_rfm_accuracy(cfg)
    assert results["grid"]["crs"] == "EPSG:32630"


def test_a_k_given_twice_is_refused(tmp_path: Path, capsys):
    err = refused(ventoux_args(tmp_path / "out") + ["--k", "6,12,6,20,12"], capsys)
    assert "--k gives 6, 12 more than once" in err


def test_grid_size_is_bounded_with_the_margin():
    """2e9 px at most, the reference's margin included: 40000 × 50000 = 2e9 is taken,
    40000 × 50001 not; 39998 × 49999 px with 1 px of margin is 40000 × 50001."""
    utm = CRS.from_epsg(32631)

    def grid(width: int, height: int) -> OrthoGrid:
        return OrthoGrid(utm, Affine(0.5, 0, 600_000, 0, -0.5, 4_900_000), width, height)

    check_grid_size(grid(40_000, 50_000), 0, gsd_given=True)
    check_grid_size(grid(39_998, 49_998), 1, gsd_given=True)
    with pytest.raises(InputError, match=r"40000 × 50001 px \(2e\+09 px\)") as exc:
        check_grid_size(grid(40_000, 50_001), 0, gsd_given=True)
    assert str(exc.value).endswith("give a larger --gsd")
    with pytest.raises(InputError, match="--gsd 0.5 m and --margin 1 px") as exc:
        check_grid_size(grid(39_998, 49_999), 1, gsd_given=True)
    assert "39998 × 49999 px" in str(exc.value) and "40000 × 50001 px" in str(exc.value)
    assert str(exc.value).endswith("give a smaller --margin")  # 1.99986e9 px without it
    with pytest.raises(InputError, match="the image's GSD 0.5 m and --margin 1 px"):
        check_grid_size(grid(39_998, 49_999), 1, gsd_given=False)


def test_a_gsd_too_fine_is_refused_naming_it(tmp_path: Path, capsys):
    """1e-6 m over the ~250 m crop: ~2.5e8 px a side. GDAL said "File too large regarding tile
    size" of a hidden temporary file."""
    err = refused(ventoux_args(tmp_path / "out") + ["--gsd", "1e-6"], capsys)
    assert "--gsd 1e-06 m" in err and "give a larger --gsd" in err
    assert ".partial" not in err and not (tmp_path / "out").exists()


def test_a_gsd_too_coarse_for_a_matching_window_is_refused_naming_it(tmp_path: Path, capsys):
    """5 m over the 500 px crop at 0.505 m: the image covers 50.5 px of the grid, and no CP
    was found "the image is too small"; at 1e6 m the run said the image had no data on the
    grid, after a RuntimeWarning of numpy."""
    err = refused(ventoux_args(tmp_path / "out") + ["--gsd", "5"], capsys)
    assert err == (
        "error: <arguments>: --gsd 5 m puts the image (500 × 500 px at 0.505 m) on 50.5 × 50.5 "
        "px of the output grid: at least 51 px each way is expected (a matching window); give "
        "a smaller --gsd\n"
    )
    assert not (tmp_path / "out").exists()
    err = refused(ventoux_args(tmp_path / "out") + ["--gsd", "1e6"], capsys)
    assert "error: <arguments>: --gsd 1e+06 m puts the image" in err and "Warning" not in err


def test_a_gsd_coarser_than_the_image_s_is_taken(tmp_path: Path):
    """1 m, about twice the image's 0.505 m: the grid is at 1 m, the errors in the image's
    pixels."""
    out = tmp_path / "out"
    result = CliRunner().invoke(command, ventoux_args(out) + ["--gsd", "1"])
    assert result.exit_code in (0, 1), result.output  # 1: the RMSE misses the requirement
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    assert results["grid"]["gsd_m"] == 1.0 and results["accuracy"]["image_gsd_m"] == 0.505


def test_an_image_smaller_than_a_matching_window_is_refused_naming_it(tmp_path: Path, capsys):
    """A 1 × 1 px crop of the left image: it was said not to overlap the reference."""
    import rasterio

    image = tmp_path / "one_pixel.tif"
    with rasterio.open(VENTOUX / "left_image.tif") as src:
        profile = src.profile | {"width": 1, "height": 1}
        pixel = src.read(window=((0, 1), (0, 1)))
    with rasterio.open(image, "w", **profile) as dst:
        dst.write(pixel)
    args = ventoux_args(tmp_path / "out")
    args[0] = str(image)
    err = refused(args, capsys)
    assert err == (
        f"error: {image}: the image is 1 × 1 px, too small to match: at least 51 px each way "
        "is expected (a matching window)\n"
    )
    assert not (tmp_path / "out").exists()


def test_a_huge_margin_is_refused_naming_it(tmp_path: Path, capsys):
    err = refused(ventoux_args(tmp_path / "out") + ["--margin", "100000000"], capsys)
    assert "--margin 100000000 px" in err and "a smaller --margin" in err
    assert ".partial" not in err and not (tmp_path / "out").exists()


# -- 5. the image as its own reference ---------------------------------------------------------
def test_the_image_as_its_own_reference_is_refused(tmp_path: Path, capsys):
    """The same file under another name (a link): RMSE 0.04 px, "pass", measured nothing."""
    link = tmp_path / "same.tif"
    os.symlink(VENTOUX / "left_image.tif", link)
    args = ventoux_args(tmp_path / "out")
    args[args.index("--reference") + 1] = str(link)
    args[args.index("--reference-rpc") + 1] = str(VENTOUX / "left_image.geom")
    err = refused(args, capsys)
    assert "is the image" in err and "independent of the image" in err
    assert not (tmp_path / "out").exists()


def test_a_copy_of_the_image_as_its_reference_is_refused(tmp_path: Path, capsys):
    """A copy of the image (another file, the same bytes) with the image's RPCs as the
    reference: RMSE 0.045 px, "pass" (exit 0), of resampling alone."""
    import shutil

    copy = tmp_path / "copy.tif"
    shutil.copyfile(VENTOUX / "left_image.tif", copy)
    args = ventoux_args(tmp_path / "out")
    args[args.index("--reference") + 1] = str(copy)
    args[args.index("--reference-rpc") + 1] = str(VENTOUX / "left_image.geom")
    err = refused(args, capsys)
    assert "a copy of the image" in err and "independent of the image" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--crop-offset", "nan,0"),
        ("--crop-offset", "0,inf"),
        ("--reference-crop-offset", "nan,nan"),
        ("--reference-crop-offset", "1,2,3"),
    ],
)
def test_a_crop_offset_not_two_finite_numbers_is_refused_naming_the_option(
    tmp_path: Path, capsys, option: str, value: str
):
    """`nan,0` was taken: every image position went to no ground position, and the run
    stopped blaming the RPC file ("the RPCs give no ground position for the image")."""
    err = refused([*ventoux_args(tmp_path / "out"), option, value], capsys)
    assert f"{option} is 'auto' or ROW,COL in pixels (two finite numbers), got {value!r}" in err
    assert "left_image.geom" not in err
    assert not (tmp_path / "out").exists()


def test_an_image_outside_its_rpcs_says_where_it_falls(tmp_path: Path, capsys):
    """A crop offset of 1e7 px: the message blamed the RPC file alone ("the RPCs give no ground
    position for the image"); it now says where the image falls and the RPC's image domain
    (the .geom: line_off 21109.5 ± 2·21137.5, samp_off 19207.5 ± 2·19999.5), before the RPC
    is read there."""
    err = refused([*ventoux_args(tmp_path / "out"), "--crop-offset", "1e7,1e7"], capsys)
    assert f"{VENTOUX / 'left_image.geom'}: the RPC's image domain (lines -21166..63384, " in err
    assert "samples -20792..59206: LINE_OFF ± 2·LINE_SCALE, SAMP_OFF ± 2·SAMP_SCALE)" in err
    assert "(rows 10000000..10000499, columns 10000000..10000499: 500 × 500 px at crop" in err
    assert "given by --crop-offset): expected the RPC of this image" in err
    assert "or another --crop-offset" in err


def test_an_image_without_rpcs_is_told_to_give_them_with_rpc(tmp_path: Path, capsys):
    args = ventoux_args(tmp_path / "out")
    i = args.index("--rpc")
    del args[i : i + 2]  # left_image.tif carries no RPCs of its own
    err = refused(args, capsys)
    assert f"{VENTOUX / 'left_image.tif'}: the raster carries no RPCs" in err
    assert "give the image's RPC file with --rpc" in err


def test_a_reference_without_crs_or_rpcs_is_told_what_a_reference_is(tmp_path: Path, capsys):
    """The message was the image's ("the raster carries no RPCs"), not saying that a reference
    may also be a georeferenced orthoimage whose CRS is missing here."""
    args = ventoux_args(tmp_path / "out")
    i = args.index("--reference-rpc")
    del args[i : i + 2]
    err = refused(args, capsys)
    assert f"{VENTOUX / 'right_image.tif'}: the reference carries no RPCs" in err
    assert "and no CRS: expected a georeferenced orthoimage (with its CRS), or an image in " in err
    assert "sensor geometry with its RPCs (--reference-rpc FILE)" in err
