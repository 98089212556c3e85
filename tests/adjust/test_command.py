"""`blockqc adjust` end to end: real Pléiades pair, synthetic delivery, and bad input."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from blockqc.adjust.stereo import match_pair, write_pair_delivery
from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
from blockqc.delivery import read_table
from blockqc.rfm.dem import load_dem
from blockqc.rfm.readers import read_rpc
from blockqc.schema import CHECKPOINTS

VENTOUX = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
MODELS = [read_rpc(VENTOUX / "left_image.geom"), read_rpc(VENTOUX / "right_image.geom")]


@pytest.fixture(scope="module")
def small_block(tmp_path_factory) -> Path:
    cfg = SyntheticConfig(scenes=4, observations_per_scene=400, checkpoints=0, seed=21)
    _, folder = synthetic_block(MODELS, cfg, tmp_path_factory.mktemp("syn") / "blk")
    return folder


def _copy(block: Path, tmp_path: Path) -> Path:
    dst = tmp_path / "blk"
    shutil.copytree(block, dst)
    return dst


def test_ventoux_pair_relative_error_goes_well_under_a_pixel(tmp_path, blockqc):
    """Pléiades Ventoux stereo pair, tie points from blockqc's matcher, SRTM + EGM96 heights:
    the pair's published ~5 px relative error (the misclosure between the two rays) goes to
    well under 1 px."""
    dem = load_dem(VENTOUX / "srtm_N44E005_crop.tif", geoid=VENTOUX / "egm96_15_crop.gtx")
    matches = match_pair(
        (VENTOUX / "left_image.tif", VENTOUX / "right_image.tif"), (MODELS[0], MODELS[1]), dem
    )
    assert len(matches) >= 40
    folder = write_pair_delivery(
        tmp_path / "pair", matches, (MODELS[0], MODELS[1]), ("left", "right"), "PHR-V", 0.5
    )
    out = tmp_path / "out"
    r = blockqc(
        "adjust", folder, "--out", out, "--dem", VENTOUX / "srtm_N44E005_crop.tif",
        "--geoid", VENTOUX / "egm96_15_crop.gtx",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    res = json.loads((out / "adjust.json").read_text())
    assert res["converged"] and res["n_scenes"] == 2
    # two rays: the misclosure splits evenly, |v| ≈ misclosure / 2 on each observation
    assert 2.0 < res["rms_px_before"] < 3.5  # 4–7 px between the rays
    assert res["rms_px_after"] < 0.3
    assert "DEM height prior" in res["datum"]["height_prior"]
    ties = pd.read_csv(out / "tie_points.csv")
    assert len(ties) == 2 * len(matches)
    assert {"v_line", "v_sample", "outlier"} <= set(ties.columns)
    assert (out / "adjust.html").is_file() and (out / "residual_vectors.png").is_file()
    assert (out / "scene_vectors.png").is_file()


def test_synthetic_delivery_outputs(tmp_path, blockqc):
    cfg = SyntheticConfig(scenes=6, observations_per_scene=600, checkpoints=25, seed=22)
    _, folder = synthetic_block(MODELS, cfg, tmp_path / "blk")
    out = tmp_path / "out"
    r = blockqc("adjust", folder, "--out", out, "--checkpoints", 30)
    assert r.returncode == 0, r.stderr
    res = json.loads((out / "adjust.json").read_text())
    for key in ("n_scenes", "n_points", "n_observations", "iterations", "converged",
                "sigma0_px", "rms_px_before", "rms_px_after", "n_outliers", "datum"):  # fmt: skip
        assert key in res
    assert abs(res["sigma0_px"] - cfg.noise_px) < 0.05 * cfg.noise_px
    cps, problems = read_table(out / "checkpoints.csv", CHECKPOINTS)
    assert not problems and 20 <= len(cps) <= 30
    assert set(cps["method"]) == {"recalculation"}
    assert res["checkpoints"]["producer_positions"].startswith("tie_points.csv")
    # well spread: the chosen points span most of the block
    x, y = cps["ref_x_m"], cps["ref_y_m"]
    ground = pd.read_csv(out / "ground_points.csv")
    assert ground["used"].sum() == res["n_points"]
    assert (x.max() - x.min()) > 0.6 * np.ptp(ground["lon"]) * 111e3 * np.cos(np.radians(44))
    assert (y.max() - y.min()) > 0.6 * np.ptp(ground["lat"]) * 111e3
    adj = pd.read_csv(out / "adjustment.csv")
    assert list(adj.columns[:7]) == ["scene_id", "a0", "a1", "a2", "b0", "b1", "b2"]
    assert (adj[[c for c in adj.columns if c.startswith("sigma_")]] > 0).all().all()


def test_missing_rpc_names_the_scene_and_folder(small_block, tmp_path, blockqc):
    blk = _copy(small_block, tmp_path)
    (blk / "rpc" / "S0003.json").unlink()
    r = blockqc("adjust", blk, "--out", tmp_path / "out")
    assert r.returncode == 2
    assert "S0003" in r.stderr and "rpc" in r.stderr and "Traceback" not in r.stderr


def test_unreadable_rpc_is_an_input_error(small_block, tmp_path, blockqc):
    blk = _copy(small_block, tmp_path)
    (blk / "rpc" / "S0002.json").write_text("{not json")
    r = blockqc("adjust", blk, "--out", tmp_path / "out")
    assert r.returncode == 2 and "S0002.json" in r.stderr and "Traceback" not in r.stderr


def test_free_datum_is_refused_as_singular(small_block, tmp_path, blockqc):
    """Refused once the inputs are read and --out made, naming the delivery (not a stand-in
    for the block): the folder the run made is removed again (it was left empty), one that was
    there before is kept."""
    out = tmp_path / "out"
    free = ["--sigma-shift", "inf", "--sigma-linear", "inf"]
    r = blockqc("adjust", small_block, "--out", out, *free)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"error: {small_block}: the block adjustment is singular: the datum is not fixed" in (
        r.stderr
    )
    assert "<block>" not in r.stderr
    assert not out.exists()
    out.mkdir()
    r = blockqc("adjust", small_block, "--out", out, *free)
    assert r.returncode == 2 and out.is_dir()


def test_no_convergence_is_reported(small_block, tmp_path, blockqc):
    out = tmp_path / "out"
    r = blockqc("adjust", small_block, "--out", out, "--max-iterations", 1)
    assert r.returncode == 1 and "did not converge" in r.stderr
    assert json.loads((out / "adjust.json").read_text())["converged"] is False


def test_unknown_scene_in_adjustment_csv(small_block, tmp_path, blockqc):
    blk = _copy(small_block, tmp_path)
    adj = pd.read_csv(blk / "adjustment.csv")
    adj.loc[0, "scene_id"] = "S9999"
    adj.to_csv(blk / "adjustment.csv", index=False)
    r = blockqc("adjust", blk, "--out", tmp_path / "out")
    assert r.returncode == 2 and "S9999" in r.stderr


def test_output_inside_the_delivery_is_refused(small_block, blockqc):
    r = blockqc("adjust", small_block, "--out", small_block / "out")
    assert r.returncode == 2 and "never writes into a delivery" in r.stderr


@pytest.mark.parametrize(
    "option, value, expected",
    [
        ("--reject", "0", "'0' is not a number from 1e-06 to 1e+06"),
        ("--reject", "-1", "'-1' is not a number from 1e-06 to 1e+06"),
        ("--reject", "nan", "'nan' is not a number from 1e-06 to 1e+06"),
        ("--dem-sigma", "-5", "'-5' is not a number from 1e-06 to 100000"),
        ("--dem-sigma", "0", "'0' is not a number from 1e-06 to 100000"),
        ("--sigma-image", "0", "'0' is not a number from 1e-06 to 10000"),
        ("--sigma-image", "inf", "'inf' is not a number from 1e-06 to 10000"),
        ("--sigma-image", "1e-300", "'1e-300' is not a number from 1e-06 to 10000"),
        # an overflowing square gave an internal error, 1e100 blamed the tie points
        ("--sigma-image", "1e200", "'1e200' is not a number from 1e-06 to 10000"),
        ("--sigma-image", "1e100", "'1e100' is not a number from 1e-06 to 10000"),
        ("--sigma-shift", "nan", "'nan' is not a number from 1e-06 to 1e+06 (inf: a free"),
        ("--sigma-shift", "1e-300", "'1e-300' is not a number from 1e-06 to 1e+06 (inf: a free"),
        ("--sigma-shift", "1e300", "'1e300' is not a number from 1e-06 to 1e+06 (inf: a free"),
        ("--sigma-linear", "0", "'0' is not a number from 1e-06 to 1e+06 (inf: a free"),
        ("--dem-sigma", "1e300", "'1e300' is not a number from 1e-06 to 100000"),
    ],
)
def test_bad_numeric_option_is_refused_up_front(small_block, tmp_path, blockqc, option, value,
                                                 expected):  # fmt: skip
    out = tmp_path / "out"
    r = blockqc("adjust", small_block, "--out", out, option, value)
    assert r.returncode == 2, r.stderr
    assert f"Invalid value for '{option}': {expected}" in r.stderr, r.stderr
    assert "internal error" not in r.stderr and not out.exists()


def test_no_output_folder_when_the_delivery_is_unreadable(small_block, tmp_path, blockqc):
    blk = _copy(small_block, tmp_path)
    shutil.rmtree(blk / "rpc")
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 2 and "rpc/ is missing" in r.stderr
    assert not out.exists()
    r = blockqc("adjust", tmp_path / "nothing", "--out", out)
    assert r.returncode == 2 and "nothing: no such file or folder: expected a delivery" in r.stderr
    assert not out.exists()
    r = blockqc("adjust", blk / "block.yaml", "--out", out)
    assert r.returncode == 2
    assert "block.yaml: a file, not a delivery folder (the folder holding block.yaml)" in r.stderr
    (tmp_path / "empty").mkdir()
    r = blockqc("adjust", tmp_path / "empty", "--out", out)
    assert r.returncode == 2 and "empty: not a delivery folder (no block.yaml)" in r.stderr
    assert not out.exists()


def test_empty_out_is_refused(small_block, tmp_path, blockqc):
    r = blockqc("adjust", small_block, "--out", "", cwd=tmp_path)
    assert r.returncode == 2
    assert "Invalid value for '--out': an empty path: give an output folder" in r.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("keep", ["one scene", "one observation per point"])
def test_no_point_seen_on_two_scenes_is_refused(small_block, tmp_path, blockqc, keep):
    """Without a point on two scenes there is nothing to intersect: refused before any output
    (it wrote every output, 'converged', then failed on its console line)."""
    blk = _copy(small_block, tmp_path)
    ties = pd.read_csv(blk / "tie_points.csv", dtype={"point_id": str})
    if keep == "one scene":
        ties = ties[ties["scene_id"] == "S0001"]
    else:
        ties = ties.drop_duplicates("point_id")
    ties.to_csv(blk / "tie_points.csv", index=False)
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 2, r.stderr
    assert "tie_points.csv" in r.stderr and "observed on two or more scenes" in r.stderr
    assert f"none of the {len(ties)} tie points" in r.stderr
    assert "internal error" not in r.stderr and not out.exists()


def test_observations_without_a_second_ray_are_not_counted_as_outliers(
    small_block, tmp_path, blockqc
):
    """With scene S0001's observations removed, the points it shared with one other scene are
    left with one ray: their observations are counted apart from the outliers the rule
    |v| > k·σ0 rejects (all were counted as outliers: hundreds, where the simulated block has a
    few gross errors)."""
    blk = _copy(small_block, tmp_path)
    ties = pd.read_csv(blk / "tie_points.csv", dtype={"point_id": str})
    ties = ties[ties["scene_id"] != "S0001"]
    ties.to_csv(blk / "tie_points.csv", index=False)
    one_ray = int((ties.groupby("point_id")["scene_id"].transform("size") == 1).sum())
    assert one_ray > 100  # the case: many observations lose their second ray
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 0, r.stderr
    res = json.loads((out / "adjust.json").read_text())
    left_out = len(ties) - res["n_observations"]
    assert res["n_outliers"] + res["n_without_second_ray"] == left_out
    # one ray from the start, plus at most the second ray of each rejected observation
    assert one_ray <= res["n_without_second_ray"] <= one_ray + res["n_outliers"]
    assert res["n_outliers"] <= 10  # 0.2 % gross errors of ~1,200 observations, and a few more
    flagged = pd.read_csv(out / "tie_points.csv")["outlier"]
    assert int(flagged.sum()) == left_out  # the table still flags every observation left out
    scenes = res["scenes"]
    assert sum(s["n_outliers"] for s in scenes) == res["n_outliers"]
    assert sum(s["n_without_second_ray"] for s in scenes) == res["n_without_second_ray"]
    assert (
        f"{res['n_outliers']} outliers, {res['n_without_second_ray']} observations left without "
        "a second ray" in r.stdout
    )
    page = (out / "adjust.html").read_text()
    assert (
        "observations left without a second ray</th><td>" + str(res["n_without_second_ray"]) in page
    )


def test_a_rejection_that_leaves_no_redundancy_is_refused_without_outputs(tmp_path, blockqc):
    """--reject 0.01 rejects every observation of a block whose points all have two rays: σ0
    cannot be estimated. Exit 2 saying so, and no adjust.json with a null σ0 presented as
    converged."""
    cfg = SyntheticConfig(scenes=4, observations_per_scene=300, checkpoints=25, seed=21)
    _, block = synthetic_block(MODELS, cfg, tmp_path / "blk")
    out = tmp_path / "out"
    r = blockqc("adjust", block, "--out", out, "--reject", "0.01")
    assert r.returncode == 2, r.stdout + r.stderr
    assert re.search(r"σ0 cannot be estimated: [0-2] of \d+ observations", r.stderr), r.stderr
    assert "(--reject 0.01)" in r.stderr
    assert "internal error" not in r.stderr and not out.exists()


def test_a_rejection_that_leaves_less_than_one_redundancy_is_refused(tmp_path, blockqc):
    """--reject 0.01 on a block without gross errors keeps 2 of 1,622 observations: a
    redundancy of about 5e-4, whose σ0 (0.115 px) was printed as converged with exit 0."""
    cfg = SyntheticConfig(
        scenes=4, observations_per_scene=400, outlier_rate=0.0, seed=3, checkpoints=30
    )
    _, block = synthetic_block(MODELS, cfg, tmp_path / "blk")
    out = tmp_path / "out"
    r = blockqc("adjust", block, "--out", out, "--reject", "0.01")
    assert r.returncode == 2, r.stdout + r.stderr
    assert "σ0 cannot be estimated:" in r.stderr and "(--reject 0.01)" in r.stderr
    assert not out.exists()


def test_a_fit_that_is_no_estimate_is_warned_of(small_block, tmp_path, blockqc):
    """One scene given another's RPC: the adjustment converges on nonsense (σ0 of kilopixels,
    residuals larger after than before). Said on the console and in adjust.json in English, on
    a Chinese page in Chinese."""
    blk = _copy(small_block, tmp_path)
    shutil.copy(blk / "rpc" / "S0004.json", blk / "rpc" / "S0001.json")
    r = blockqc("adjust", blk, "--out", tmp_path / "out", "--lang", "zh")
    assert r.returncode == 0, r.stderr
    assert "px, far above a tie-point measurement precision (above 5 px)" in r.stderr
    assert "warning: the residual RMS grew in the adjustment" in r.stderr
    warnings = json.loads((tmp_path / "out" / "adjust.json").read_text())["warnings"]
    assert any("far above a tie-point measurement precision" in w for w in warnings)
    page = (tmp_path / "out" / "adjust.html").read_text(encoding="utf-8")
    assert "像素，远高于连接点的量测精度（超过 5 像素）：" in page
    assert "<li>平差后残差均方根反而增大（" in page
    assert not any(w in page for w in warnings)


@pytest.mark.parametrize("points", [1, 5])
def test_too_few_tie_points_are_named_not_blamed_on_the_rejection(
    small_block, tmp_path, blockqc, points
):
    """Points on two scenes too few for the unknowns (1 point: 4 equations against 3 + 12
    unknowns), none rejected: the message named '<options>' and told to raise --reject; it names
    tie_points.csv and what is short."""
    blk = _copy(small_block, tmp_path)
    ties = pd.read_csv(blk / "tie_points.csv", dtype={"point_id": str})
    ties = ties[ties["point_id"].isin(ties["point_id"].unique()[:points])]
    assert (ties.groupby("point_id").size() >= 2).all()
    ties.to_csv(blk / "tie_points.csv", index=False)
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"error: {blk / 'tie_points.csv'}: σ0 cannot be estimated: the {len(ties)} " in r.stderr
    assert "expected more tie points" in r.stderr
    assert "<options>" not in r.stderr and "--reject" not in r.stderr
    assert "internal error" not in r.stderr and not out.exists()


def test_rows_of_one_point_giving_two_ground_points_are_refused(small_block, tmp_path, blockqc):
    """The producer's lon/lat/h of a point differ between its rows (one row 0.01° east): the
    checkpoint took their mean, 400 m from either, with exit 0. Refused, naming the row, the
    column and both values; a difference of round-off (h 4 mm) is read."""
    blk = _copy(small_block, tmp_path)
    ties = pd.read_csv(blk / "tie_points.csv", dtype={"point_id": str})
    second = ties.index[ties["point_id"].duplicated()][0]
    first = ties.index[ties["point_id"] == ties.at[second, "point_id"]][0]
    ties.loc[second, "h"] += 0.004
    ties.to_csv(blk / "tie_points.csv", index=False)
    r = blockqc("adjust", blk, "--out", tmp_path / "read")
    assert r.returncode == 0, r.stderr
    ties.loc[second, "lon"] += 0.01
    ties.to_csv(blk / "tie_points.csv", index=False)
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 2, r.stdout + r.stderr
    where = f"{blk / 'tie_points.csv'}, row {second + 1} (line {second + 2}), column 'lon'"
    assert where in r.stderr
    point, lon = ties.at[second, "point_id"], ties.at[second, "lon"]
    assert f"point '{point}' is given lon {lon:.10g} here" in r.stderr
    assert f"and {ties.at[first, 'lon']:.10g} on row {first + 1}" in r.stderr
    assert "internal error" not in r.stderr and not out.exists()
    # a point of three rows, its first without a ground point: the row named is the one whose
    # lon is given (a row without lat, lon and h gives none; part of them is refused apart)
    rows = ties.groupby("point_id").groups
    a, b, c = next(ix for ix in rows.values() if len(ix) >= 3)[:3]
    ties = pd.read_csv(small_block / "tie_points.csv", dtype={"point_id": str})
    ties.loc[a, ["lon", "lat", "h"]] = float("nan")
    ties.loc[c, "lon"] += 0.01
    ties.to_csv(blk / "tie_points.csv", index=False)
    r = blockqc("adjust", blk, "--out", out)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"and {ties.at[b, 'lon']:.10g} on row {b + 1}: expected" in r.stderr


def test_a_scene_an_infinite_prior_leaves_free_without_observations_is_named(
    small_block, tmp_path, blockqc
):
    """--sigma-shift inf --sigma-linear inf --fix S0001 on a block where S0004 keeps 2 tie
    observations: its affine is free, the block singular, refused as '<block>: … or some scene
    has too few tie observations' without saying which; the refusal names tie_points.csv and
    S0004. (A scene without any observation is left out of the adjustment.)"""
    blk = _copy(small_block, tmp_path)
    ties = pd.read_csv(blk / "tie_points.csv", dtype={"point_id": str})
    multi = ties["point_id"].map(ties["point_id"].value_counts()) >= 2
    on_s4 = ties["scene_id"] == "S0004"
    kept = ties.index[on_s4 & multi][:2]
    ties[~on_s4 | ties.index.isin(kept)].to_csv(blk / "tie_points.csv", index=False)
    free = ["--sigma-shift", "inf", "--sigma-linear", "inf", "--fix", "S0001"]
    out = tmp_path / "out"
    r = blockqc("adjust", blk, "--out", out, *free)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"error: {blk / 'tie_points.csv'}: scene(s) S0004 (2) have too few" in r.stderr
    assert "--sigma-linear inf leaves free: expected at least 3 per scene" in r.stderr
    assert "internal error" not in r.stderr and not out.exists()
    r = blockqc("adjust", blk, "--out", out, *free, "--fix", "S0004")
    assert r.returncode == 0, r.stderr


@pytest.mark.browser
def test_long_ids_and_paths_wrap_within_the_page(small_block, tmp_path, blockqc):
    """A block id of 106 characters, a delivery path of 240 and a scene id of 90, none with a
    space: the title, the paragraph naming the delivery and the per-scene table ran past the
    page's right edge (cut off, the page scrolled sideways); they now wrap."""
    from blockqc.adjust.report import render_html
    from casekit import page_overflow_px

    out = tmp_path / "out"
    assert blockqc("adjust", small_block, "--out", out).returncode == 0
    summary = json.loads((out / "adjust.json").read_text())
    summary["block_id"] = "BLOCK_" + "X" * 100
    summary["delivery"] = "/data/" + "deliveries_of_the_project_" * 9 + "/SYN-B01"
    summary["scenes"][0]["scene_id"] = "PHR1B_P_201308051042194_SEN_690908101-001_" + "Z" * 48
    html = render_html(summary)
    assert summary["delivery"] in html and summary["scenes"][0]["scene_id"] in html
    assert page_overflow_px(html, tmp_path) <= 0


def test_rays_that_fix_no_height_are_warned_of(tmp_path, blockqc):
    """Every scene with the left image's RPC (one viewing direction, moved on the ground): the
    rays of a point meet at a base-to-height ratio of a few hundredths, so the heights are the
    weak prior's. Said on the console and in adjust.json; each point's ratio is in
    ground_points.csv."""
    cfg = SyntheticConfig(scenes=4, observations_per_scene=400, checkpoints=0, seed=21)
    _, folder = synthetic_block(MODELS[:1], cfg, tmp_path / "same")
    r = blockqc("adjust", folder, "--out", tmp_path / "out", "--lang", "zh")
    assert r.returncode == 0, r.stderr
    assert "points are seen along rays with a base-to-height ratio below 0.05" in r.stderr
    summary = json.loads((tmp_path / "out" / "adjust.json").read_text())
    assert any("give --dem for a height prior" in w for w in summary["warnings"])
    page = (tmp_path / "out" / "adjust.html").read_text(encoding="utf-8")
    assert "个点的光线基高比小于 0.05（中位数 " in page and "请用 --dem 给出高程先验</li>" in page
    ground = pd.read_csv(tmp_path / "out" / "ground_points.csv")
    used = ground[ground.used]
    assert used.base_to_height.max() < 0.05
    assert summary["base_to_height"]["max"] == pytest.approx(used.base_to_height.max(), abs=1e-4)


def test_a_stereo_pair_fixes_its_heights_without_a_warning(small_block, tmp_path, blockqc):
    """The Pléiades pair's rays meet at B/H ≈ 0.36 (the two images' tilts, tested apart in
    test_geometry): no height warning."""
    r = blockqc("adjust", small_block, "--out", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert "base-to-height" not in r.stderr
    used = pd.read_csv(tmp_path / "out" / "ground_points.csv").query("used")
    assert used.base_to_height.between(0.3, 0.4).all()
