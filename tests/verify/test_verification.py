"""Verification of process data from delivered geometry (§RC-1, §RC-2), contract v1.1."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from geokit import (
    FILES,
    KEYS,
    RPCS,
    adjusted_models,
    ground_points,
    observe,
    reference_residuals,
    write_v11,
)
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Geod

from blockqc import verification
from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.metrics.geometry import GROUND_COLUMNS
from blockqc.results import dump
from blockqc.rules import load_pack
from blockqc.verification import COMPUTED_RESIDUALS, DERIVED_OVERLAPS

N_POINTS = 60


@pytest.fixture(scope="module")
def observations() -> tuple[pd.DataFrame, pd.DataFrame]:
    ground = ground_points(N_POINTS, seed=7)
    obs = observe(ground, noise_px=0.3, seed=7)
    return ground, reference_residuals(obs, ground)


def _results(folder: Path) -> dict:
    return dump(inspect_delivery(load_delivery(folder), load_pack("global-project")))


def _rule(doc: dict, rule_id: str) -> list[dict]:
    return [r for r in doc["results"] if r["rule"] == rule_id]


def test_residuals_computed_when_absent(tmp_path, observations) -> None:
    """No v_line/v_sample: blockqc computes them, the TP rules judge them, results say so."""
    _, ref = observations
    folder = write_v11(tmp_path / "d", ref.drop(columns=["v_line", "v_sample"]))
    d = load_delivery(folder)
    doc = dump(inspect_delivery(d, load_pack("global-project")))
    got = d.tie_points.set_index(["point_id", "scene_id"])
    want = ref.set_index(["point_id", "scene_id"]).loc[got.index]
    # the independent solver (scipy, point by point) gives the same residuals
    assert np.allclose(got["v_line"], want["v_line"], atol=2e-3)
    assert np.allclose(got["v_sample"], want["v_sample"], atol=2e-3)
    assert doc["process_data"]["tie_point_residuals"] == COMPUTED_RESIDUALS
    tp1 = _rule(doc, "TP-1")[0]
    assert tp1["detail"]["computed_by_blockqc"] == COMPUTED_RESIDUALS
    err = np.hypot(want["v_line"], want["v_sample"])
    assert tp1["value"] == pytest.approx(float(np.median(err)), abs=2e-3)
    assert _rule(doc, "RC-1")[0]["status"] == "not_applicable"


def test_a_point_seen_once_is_not_judged_on_its_zero_residual(tmp_path, observations) -> None:
    """Residuals computed: a point seen on one scene lies on its ray, a residual of 0 that
    measures nothing. Left out of TP-1..3 (counted), it does not pull the median down."""
    _, ref = observations
    once = ref.iloc[:1].assign(point_id="ONCE")  # one observation of a point of its own
    ties = pd.concat([ref, once], ignore_index=True).drop(columns=["v_line", "v_sample"])
    doc = _results(write_v11(tmp_path / "d", ties))
    tp1 = _rule(doc, "TP-1")[0]
    assert tp1["detail"]["observations_single_ray"] == 1
    err = np.hypot(ref["v_line"], ref["v_sample"])
    assert tp1["value"] == pytest.approx(float(np.median(err)), abs=2e-3)


def test_delivered_residuals_reproduce(tmp_path, observations) -> None:
    _, ref = observations
    doc = _results(write_v11(tmp_path / "d", ref))
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "pass"
    assert rc1["value"] < 0.01
    assert "computed_by_blockqc" not in _rule(doc, "TP-1")[0]["detail"]


def test_doctored_residuals_fail_naming_the_worst(tmp_path, observations) -> None:
    _, ref = observations
    doctored = ref.copy()
    first = doctored.index[:2]  # both observations of one point, halved
    doctored.loc[first, ["v_line", "v_sample"]] *= 0.5
    doctored.loc[doctored.index[10], "v_sample"] += 0.8  # one observation made up
    doc = _results(write_v11(tmp_path / "d", doctored))
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "fail"
    worst = rc1["evidence"][0]
    row = doctored.loc[doctored.index[10]]
    assert (worst["point_id"], worst["scene_id"]) == (row["point_id"], row["scene_id"])
    assert worst["difference_px"] == pytest.approx(0.8, abs=2e-3)
    assert rc1["value"] == pytest.approx(0.8, abs=2e-3)
    named = {(e["point_id"], e["scene_id"]) for e in rc1["evidence"]}
    halved = ref.loc[first]
    big = halved[np.hypot(halved["v_line"], halved["v_sample"]) * 0.5 > 0.1]
    assert set(zip(big["point_id"], big["scene_id"], strict=True)) <= named


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(np.square(v), axis=1))))


@pytest.mark.parametrize(
    "convention, sign, swap",
    [
        ("the opposite sign (measured − computed)", -1.0, False),
        ("line and sample swapped", 1.0, True),
        ("the opposite sign, line and sample swapped", -1.0, True),
    ],
)
def test_residuals_in_another_convention_fail_rc1_and_it_is_named(
    tmp_path, observations, convention, sign, swap
) -> None:
    """The independent solver's residuals written measured − computed, or line and sample
    swapped: RC-1 fails as the contract reads them (computed − measured, line then sample), and
    says in which convention they reproduce, with both RMS differences (by hand from the
    solver's residuals: about 0 and √(Σ(v ∓ v')²/n))."""
    _, ref = observations
    v = ref[["v_line", "v_sample"]].to_numpy()
    written = sign * (v[:, ::-1] if swap else v)
    doc = _results(
        write_v11(tmp_path / "d", ref.assign(v_line=written[:, 0], v_sample=written[:, 1]))
    )
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "fail"
    hint = rc1["detail"]["hint"]
    assert doc["process_data"]["residual_convention"] == hint
    found = re.fullmatch(
        rf"the delivered residuals reproduce with {re.escape(convention)}: RMS difference "
        r"(\S+) px, against (\S+) px read as the contract writes them \(computed − measured, "
        r"line then sample\)",
        hint,
    )
    assert found, hint
    assert float(found[1]) < 2e-3  # the solver's residuals agree with blockqc's to 2e-3 px
    assert float(found[2]) == pytest.approx(_rms(written - v), rel=2e-3, abs=2e-3)


def test_no_convention_is_named_for_residuals_right_or_made_up(tmp_path, observations) -> None:
    """Residuals as the contract writes them, and residuals that no reading reproduces (each
    observation's made up): no convention is named."""
    _, ref = observations
    doc = _results(write_v11(tmp_path / "right", ref))
    assert "residual_convention" not in doc["process_data"]
    assert "hint" not in _rule(doc, "RC-1")[0]["detail"]
    made_up = np.random.default_rng(3).normal(0.0, 0.5, (len(ref), 2))
    doc = _results(
        write_v11(tmp_path / "made_up", ref.assign(v_line=made_up[:, 0], v_sample=made_up[:, 1]))
    )
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "fail" and "hint" not in rc1["detail"]
    assert "residual_convention" not in doc["process_data"]


def test_discrepancies_derived_from_a_geometry_rc1_fails_say_so(tmp_path, observations) -> None:
    """Scene R given L's RPC (one file wrong): RC-1 fails by kilometres' worth of pixels, and
    RO-3/RO-4, judged on the discrepancies derived from that geometry (§RC-2), fail too; each of
    their plane results says that it rests on a geometry RC-1 fails, with RC-1's worst
    difference. With the right RPCs, RC-1 passes and none says it."""
    _, ref = observations
    right = _results(write_v11(tmp_path / "right", ref))
    derived = [r for r in right["results"] if r["rule"] in ("RO-3", "RO-4")]
    assert derived and all("hint" not in r["detail"] for r in derived)
    folder = write_v11(tmp_path / "wrong", ref)
    shutil.copy(FILES["L"], folder / "rpc" / "R.geom")
    doc = _results(folder)
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "fail" and rc1["value"] > 100
    plane = [r for r in doc["results"] if r["rule"] in ("RO-3", "RO-4") and r["status"] == "fail"]
    assert {r["rule"] for r in plane} == {"RO-3", "RO-4"}
    for r in plane:
        assert r["detail"]["hint"] == verification.ON_FAILED_GEOMETRY.format(
            value=f"{rc1['value']:.3g}"
        )
    height = [r for r in doc["results"] if r["rule"] in ("RO-3", "RO-4") and r not in plane]
    assert height and all(r["status"] == "not_applicable" for r in height)
    assert all("hint" not in r["detail"] for r in height)  # not judged: nothing rests on it


def test_the_convention_is_said_in_the_pages_language() -> None:
    """The sentence results.json keeps in English, on a Chinese page: the convention nested in
    it translated too; its words are the catalogue's."""
    from blockqc.report.format import Formatter
    from blockqc.report.messages import MESSAGES

    assert MESSAGES["rc_convention"][0] == verification.RC_CONVENTION
    assert MESSAGES["rc_on_failed_geometry"][0] == verification.ON_FAILED_GEOMETRY
    assert Formatter("zh").sentence(verification.ON_FAILED_GEOMETRY.format(value="∞")) == (
        "所交几何模型未通过 RC-1（所交残差与其复算残差之差最大 ∞ 像素）："
        "据其推算的这些接边差（§RC-2）可能基于有误的几何模型"
    )
    keys = ("rc_sign", "rc_swapped", "rc_sign_swapped")
    assert [MESSAGES[k][0] for k in keys] == list(verification.CONVENTIONS)
    hint = verification.RC_CONVENTION.format(
        convention="line and sample swapped", rms="0.00012", as_read="0.734"
    )
    assert Formatter("zh").sentence(hint) == (
        "所交残差按行列互换可以复现：差值均方根 0.00012 像素，"
        "按合同约定（计算值 − 量测值，先行后列）解读则为 0.734 像素"
    )


GROUND_DELIVERED = """pack: project
version: "1.0"
extends: global-project
overrides:
  RC-1: {params: {ground: delivered}}
"""


def _with_ground(tmp_path: Path, name: str, ties: pd.DataFrame) -> dict:
    """RC-1 of the delivery, judged with the producer's ground points back-projected."""
    from blockqc.rules.loader import load_pack as load_pack_file

    pack = tmp_path / "project.yaml"
    pack.write_text(GROUND_DELIVERED)
    doc = dump(
        inspect_delivery(load_delivery(write_v11(tmp_path / name, ties)), load_pack_file(pack))
    )
    return _rule(doc, "RC-1")[0]


def _held_to_truth(ground: pd.DataFrame, obs: pd.DataFrame) -> pd.DataFrame:
    """The observations as a producer delivers them that held every point to its true position:
    the residuals of the true ground points (RefinedRFM, by hand), and those points."""
    at = ground.set_index("point_id").loc[obs["point_id"]]
    v = np.empty((len(obs), 2))
    for sid, m in adjusted_models().items():
        on = (obs["scene_id"] == sid).to_numpy()
        line, sample = m.ground_to_image(at["lon"][on], at["lat"][on], at["h"][on])
        v[on] = np.column_stack([line - obs["line"][on], sample - obs["sample"][on]])
    points = {c: at[c].to_numpy() for c in GROUND_COLUMNS}
    return obs.assign(v_line=v[:, 0], v_sample=v[:, 1], **points)


def test_residuals_of_a_height_prior_reproduce_from_the_delivered_ground_points(tmp_path) -> None:
    """A producer that held each point to its true height (a DEM prior) and its plane position
    to the truth: its residuals are those of the true ground points (RefinedRFM, by hand), not
    of an unweighted intersection (scipy's, point by point). Intersected, RC-1 fails by their
    difference; back-projected from the delivered ground points (`ground: delivered`), every
    observation reproduces, those of a point seen once too."""
    ground = ground_points(N_POINTS, seed=11)
    obs = observe(ground, noise_px=0.3, seed=11)
    ties = _held_to_truth(ground, obs)
    unweighted = reference_residuals(obs, ground).set_index(["point_id", "scene_id"])
    by_hand = ties.set_index(["point_id", "scene_id"]).loc[unweighted.index]
    gap = np.hypot(*(by_hand[c] - unweighted[c] for c in ("v_line", "v_sample")))
    assert gap.max() > 0.1  # as RC-1's tolerance sees it
    intersected = _rule(_results(write_v11(tmp_path / "i", ties)), "RC-1")[0]
    assert intersected["status"] == "fail"
    assert intersected["value"] == pytest.approx(gap.max(), abs=2e-3)
    once = ties.iloc[:1].assign(point_id="ONCE", v_line=0.0, v_sample=0.0)
    line, sample = adjusted_models()[once["scene_id"].iloc[0]].ground_to_image(
        once["lon"], once["lat"], once["h"]
    )
    once = once.assign(line=line, sample=sample)  # on its ray: residual 0
    rc1 = _with_ground(tmp_path, "d", pd.concat([ties, once], ignore_index=True))
    assert rc1["status"] == "pass" and rc1["value"] < 1e-6
    assert rc1["detail"]["n_units"] == len(ties) + 1


def test_a_residual_made_up_fails_against_the_delivered_ground_points(tmp_path) -> None:
    """The same, one residual off by 0.3 px: that observation is the evidence."""
    ground = ground_points(20, seed=12)
    obs = observe(ground, noise_px=0.3, seed=12).reset_index(drop=True)
    ties = _held_to_truth(ground, obs)
    ties.loc[7, "v_sample"] += 0.3
    rc1 = _with_ground(tmp_path, "d", ties)
    assert rc1["status"] == "fail" and rc1["value"] == pytest.approx(0.3, abs=1e-6)
    worst = rc1["evidence"][0]
    assert (worst["point_id"], worst["scene_id"]) == (obs["point_id"][7], obs["scene_id"][7])
    assert rc1["detail"]["n_offending"] == 1


@pytest.mark.parametrize("gone", ["h", "some"])
def test_delivered_ground_points_absent_put_rc1_in_error(tmp_path, observations, gone) -> None:
    """`ground: delivered` without the columns, or with a row without its point: RC-1 is in
    error saying so (not judged on the others, not passed over)."""
    ground, ref = observations
    at = ground.set_index("point_id").loc[ref["point_id"]]
    ties = ref.assign(**{c: at[c].to_numpy() for c in GROUND_COLUMNS})
    if gone == "h":
        ties = ties.drop(columns=["h"])
        said = "tie_points gives no h (contract v1.1: lon, lat, h ellipsoidal)"
    else:
        ties.loc[ties.index[3], list(GROUND_COLUMNS)] = np.nan  # part of them is refused
        row = ties.loc[ties.index[3]]
        first = f"the first {row['point_id']} on {row['scene_id']}"
        said = f"1 of {len(ties)} observations give no ground point (lon, lat, h), {first}"
    rc1 = _with_ground(tmp_path, "d", ties)
    assert rc1["status"] == "error"
    assert said in rc1["detail"]["reason"]


def test_rays_the_geometry_cannot_intersect_fail_rc1(tmp_path) -> None:
    """A shift of 80 000 pixels in one scene's adjustment (a four-scene synthetic block; about
    twice the image's 40 836 lines, within what adjustment.csv is read with): rays that no
    longer meet under the delivered geometry. RC-1 does not pass over what is left: their
    observations are judged (not reproduced, an infinite difference: null in JSON), the worst
    of its evidence."""
    from geokit import FILES

    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    models = [read_rpc(f) for f in FILES.values()]
    cfg = SyntheticConfig(scenes=4, observations_per_scene=300, checkpoints=25, seed=21)
    _, folder = synthetic_block(models, cfg, tmp_path / "d")
    adjustment = pd.read_csv(folder / "adjustment.csv")
    adjustment.loc[1, "a0"] = 8e4
    adjustment.to_csv(folder / "adjustment.csv", index=False)
    doc = _results(folder)
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "fail"
    detail = next(m for m in doc["measurements"] if m["key"] == "residual_reproduction")["detail"]
    lost = detail["not_intersected_observations"]
    judged = len(pd.read_csv(folder / "tie_points.csv")) - detail["single_ray_observations"]
    assert lost > 0 and rc1["detail"]["n_units"] == judged  # none left out
    first = rc1["evidence"][: min(lost, len(rc1["evidence"]))]  # infinite: the worst, first
    assert all(e["intersected"] is False and e["difference_px"] is None for e in first)
    # its value, infinite, is null in JSON ("–" on the page): the result says why, in the
    # page's language
    from blockqc.report.format import Formatter

    points = doc["process_data"]["n_points_not_intersected"]
    assert rc1["value"] is None and rc1["detail"]["note"] == (
        f"{points} tie points whose rays the delivered geometry cannot intersect: their "
        "observations are not reproduced (difference ∞, shown as –)"
    )
    assert Formatter("zh").text(rc1["detail"]["note"]) == (
        f"{points} 个连接点的光线无法由所交几何模型前方交会：其观测未能复现（差值为 ∞，显示为 –）"
    )


def test_without_residuals_rays_that_do_not_intersect_put_the_residual_rules_in_error(
    tmp_path,
) -> None:
    """The same broken adjustment, no residuals delivered: the observations of the points not
    intersected have no residual. TP-1..3 were judged on the others as if complete (and with
    every point lost, the block could pass with TP-4/TP-5 waived); they are now in error,
    naming the count, while TP-4 counts every delivered observation."""
    from geokit import FILES

    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    models = [read_rpc(f) for f in FILES.values()]
    cfg = SyntheticConfig(scenes=4, observations_per_scene=300, checkpoints=25, seed=21)
    _, folder = synthetic_block(models, cfg, tmp_path)
    tie_points = pd.read_csv(folder / "tie_points.csv").drop(columns=["v_line", "v_sample"])
    tie_points.to_csv(folder / "tie_points.csv", index=False)
    adjustment = pd.read_csv(folder / "adjustment.csv")
    adjustment.loc[1, "a0"] = 8e4
    adjustment.to_csv(folder / "adjustment.csv", index=False)
    doc = _results(folder)
    lost = doc["process_data"]["n_points_not_intersected"]
    assert lost > 0
    for rule in ("TP-1", "TP-2", "TP-3"):
        (res,) = _rule(doc, rule)
        assert res["status"] == "error", rule
        assert "observations have no residual" in res["detail"]["reason"]
    counts = tie_points.groupby("point_id")["scene_id"].transform("size")
    kept = tie_points[counts >= 2]["scene_id"].value_counts()  # single rays left out
    assert doc["summary"]["tie_point_observations"] == len(tie_points[counts >= 2])
    assert _rule(doc, "TP-4")[0]["value"] == kept.min()


def test_rays_of_one_pass_are_intersected_at_a_weak_height(tmp_path, observations) -> None:
    """Two scenes of one pass (PAN and MS: the same line of sight) see a point along parallel
    rays, which fix no height. Their residuals are still defined: both observations project to
    their mean, v = ±(difference)/2 by hand. RC-1 failed them as not intersected."""
    ground, _ = observations
    on_l = observe(ground, noise_px=0.0, seed=7).query("scene_id == 'L'")
    rng = np.random.default_rng(5)
    d_line, d_sample = rng.normal(0, 0.3, len(on_l)), rng.normal(0, 0.3, len(on_l))
    on_r = on_l.assign(scene_id="R", line=on_l["line"] + d_line, sample=on_l["sample"] + d_sample)
    ties = pd.concat(
        [
            on_l.assign(v_line=d_line / 2, v_sample=d_sample / 2),
            on_r.assign(v_line=-d_line / 2, v_sample=-d_sample / 2),
        ],
        ignore_index=True,
    )
    folder = write_v11(tmp_path / "d", ties)
    shutil.copy(folder / "rpc" / "L.geom", folder / "rpc" / "R.geom")  # one pass: one geometry
    adjustment = pd.read_csv(folder / "adjustment.csv")
    adjustment.loc[adjustment["scene_id"] == "R", list(KEYS)] = adjustment.loc[
        adjustment["scene_id"] == "L", list(KEYS)
    ].to_numpy()
    adjustment.to_csv(folder / "adjustment.csv", index=False)
    doc = _results(folder)
    assert doc["process_data"]["n_points_not_intersected"] == 0
    assert doc["process_data"]["n_points_height_undetermined"] == N_POINTS
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "pass" and rc1["value"] < 1e-3, rc1


def test_overlaps_derived_from_geometry(tmp_path, observations) -> None:
    """RO-3/RO-4 run without overlaps.csv; values checked by an independent computation."""
    ground, _ = observations
    obs = observe(ground, noise_px=0.0, seed=7)
    # move point G0003's observation on R by 30 px in line: the two single-ray positions differ
    bad = (obs["point_id"] == "G0003") & (obs["scene_id"] == "R")
    obs.loc[bad, "line"] += 30.0
    d = load_delivery(write_v11(tmp_path / "d", obs.assign(v_line=0.0, v_sample=0.0)))
    doc = dump(inspect_delivery(d, load_pack("global-project")))
    assert doc["process_data"]["overlaps"] == DERIVED_OVERLAPS
    ro3 = [r for r in _rule(doc, "RO-3") if r["group"]["component"] == "plane"][0]
    assert ro3["detail"]["computed_by_blockqc"] == DERIVED_OVERLAPS
    ro4 = [r for r in _rule(doc, "RO-4") if r["group"]["component"] == "plane"][0]
    assert ro4["status"] in ("pass", "fail")
    for rule in ("RO-3", "RO-4"):  # heights aside: said, not "nothing measured"
        (height,) = [r for r in _rule(doc, rule) if r["group"]["component"] == "height"]
        assert (height["status"], height["detail"]["reason"]) == (
            "not_applicable",
            "the discrepancies derived from the geometry are plane only (§RC-2)",
        )
    # independent: each observation put on the ground alone (rfm.model's Newton) at the point's
    # height, the geodesic distance between the two positions (pyproj)
    h = d.process_data["data"].points.set_index("point_id")["h"]
    models = adjusted_models()
    pos = {}
    for sid, g in obs.groupby("scene_id"):
        lon, lat, _ = models[sid].image_to_ground(g["line"], g["sample"], h.loc[g["point_id"]])
        pos[sid] = pd.DataFrame({"lon": lon, "lat": lat}, index=g["point_id"].to_numpy())
    _, _, dist = Geod(ellps="WGS84").inv(
        pos["L"]["lon"],
        pos["L"]["lat"],
        pos["R"].loc[pos["L"].index, "lon"],
        pos["R"].loc[pos["L"].index, "lat"],
    )
    expected = pd.Series(dist, index=pos["L"].index)
    table = d.overlaps.set_index("point_id")
    plane = np.hypot(table["dx_m"], table["dy_m"])
    assert np.allclose(plane, expected.loc[plane.index], rtol=1e-4, atol=1e-4)
    assert ro3["status"] == ("fail" if expected.max() >= 20 * np.sqrt(2) else "pass")
    assert ro3["value"] == pytest.approx(expected.max(), rel=1e-4)
    rms = float(np.sqrt(np.mean(expected**2)))
    assert ro4["value"] == pytest.approx(rms, rel=1e-4)


def test_results_json_says_what_was_computed(tmp_path, observations, blockqc) -> None:
    _, ref = observations
    folder = write_v11(tmp_path / "d", ref.drop(columns=["v_line", "v_sample"]))
    out = tmp_path / "out"
    proc = blockqc("inspect", folder, "--out", out, "--no-pdf")
    assert proc.returncode in (0, 1), proc.stderr
    doc = json.loads((out / "CASE" / "results.json").read_text())
    assert doc["process_data"]["tie_point_residuals"] == COMPUTED_RESIDUALS
    assert doc["process_data"]["geometry"] == "adjustment.csv"


def test_synthetic_v11_delivery(tmp_path) -> None:
    """The synthetic block writer's delivery (rpc/ JSON, adjustment.csv) reads and verifies:
    delivered residuals reproduce; without them the computed ones equal them; overlaps derived."""
    from geokit import FILES

    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    models = [read_rpc(f) for f in FILES.values()]
    cfg = SyntheticConfig(scenes=4, observations_per_scene=300, outlier_rate=0.0, seed=3)
    _, folder = synthetic_block(models, cfg, tmp_path / "with")
    doc = _results(folder)
    rc1 = _rule(doc, "RC-1")[0]
    assert rc1["status"] == "pass" and rc1["value"] < 1e-3  # delivered rounded to 1e-4 px
    assert doc["process_data"]["overlaps"] == DERIVED_OVERLAPS
    delivered = load_delivery(folder).tie_points
    bare = tmp_path / "without"
    _, bare = synthetic_block(models, dataclasses.replace(cfg, producer_residuals=False), bare)
    d = load_delivery(bare)
    inspect_delivery(d, load_pack("global-project"))
    assert np.allclose(d.tie_points["v_line"], delivered["v_line"], atol=1e-3)
    assert np.allclose(d.tie_points["v_sample"], delivered["v_sample"], atol=1e-3)


def test_observations_the_geometry_cannot_reproduce_fail_and_single_rays_are_left_out() -> None:
    """A point seen once (its ray fixes it) is not compared; one whose rays the delivered
    geometry cannot intersect (no computed residual) is not reproduced: its observations are
    kept at an infinite difference, so RC-1 fails on them. The counts say which is which."""
    from types import SimpleNamespace

    from blockqc.metrics.geometry import _verifiable
    from blockqc.verification import _with_computed_residuals

    nan = float("nan")
    table = pd.DataFrame(
        {
            "point_id": ["A", "A", "S", "X", "X"],
            "v_line_computed": [0.1, -0.1, 0.0, nan, nan],
            "v_sample_computed": [0.2, -0.2, 0.0, nan, nan],
            "n_rays": [2, 2, 1, 2, 2],
        }
    )
    kept, unverified = _verifiable(table.assign(difference_px=[0.0, 0.0, 0.0, nan, nan]))
    assert kept["point_id"].tolist() == ["A", "A", "X", "X"]
    assert kept["difference_px"].tolist() == [0.0, 0.0, float("inf"), float("inf")]
    assert unverified["single_ray_observations"] == 1
    assert unverified["not_intersected_observations"] == 2
    assert "not compared" in unverified["not_verified"]
    assert "not reproduced" in unverified["not_reproduced"]
    # residuals to compute: point S's one observation a zero that measures nothing (its one
    # ray fixes it), left out of the tie-point rules; point X's two have none, kept (the rules
    # judging residuals are in error with them, the counting ones count them); both counted
    d = SimpleNamespace(tie_points=table[["point_id"]].copy())
    notes: dict = {}
    _with_computed_residuals(d, table, notes)
    assert d.tie_points["point_id"].tolist() == ["A", "A", "X", "X"]
    assert d.tie_points["v_sample"].tolist()[:2] == [0.2, -0.2]
    assert d.tie_points["v_sample"].isna().tolist() == [False, False, True, True]
    assert notes["observations_without_residual"] == 2
    assert notes["observations_single_ray"] == 1


def test_no_derived_overlap_is_said_for_what_it_is() -> None:
    """Overlaps derived from the geometry, none found: not 'no overlaps.csv in the delivery'.
    With points whose rays do not intersect, RO-3/RO-4 cannot be judged (an error)."""
    from types import SimpleNamespace

    from blockqc.metrics.discrepancies import overlap_discrepancy

    empty = pd.DataFrame(columns=["scene_a", "scene_b", "point_id", "dx_m", "dy_m"])
    notes = {"overlaps": DERIVED_OVERLAPS, "n_points_not_intersected": 0}
    d = SimpleNamespace(overlaps=empty, process_data={"notes": notes})
    reason = overlap_discrepancy(d, None, None).not_applicable
    assert reason.startswith("no overlaps table (overlaps.csv), and no tie point seen on two")
    notes["n_points_not_intersected"] = 7
    with pytest.raises(ValueError, match="the rays of 7 tie points do not intersect"):
        overlap_discrepancy(d, None, None)


def test_the_overlap_map_names_millimetre_discrepancies(tmp_path, observations) -> None:
    """Overlaps derived from a well-adjusted pair (§RC-2): the mean discrepancy vector of the pair
    is about a millimetre and its RMS about two decimetres; the map drew the vector and captioned
    it 'longest 0.0 m'. The caption now gives it to three decimals, from the same table an
    inspector reads in results.json."""
    import re

    from blockqc.report import write_block_report

    _, ref = observations
    doc = _results(write_v11(tmp_path / "d", ref))
    table = next(m for m in doc["measurements"] if m["metric"] == "overlap_discrepancy")
    rows = pd.DataFrame(table["tables"]["point"]).query("component == 'plane'")
    mean = float(np.hypot(rows["dx_m"].mean(), rows["dy_m"].mean()))
    assert 0.0005 < mean < 0.05  # the case: below what one decimal shows
    write_block_report(tmp_path / "out", doc, pdf=False)
    page = (tmp_path / "out" / "report.html").read_text()
    shown = re.findall(r"mean vector \(longest ([0-9.]+) m\)", page)
    assert shown  # the figure's title (and its text alternative)
    for value in shown:
        assert float(value) > 0 and abs(float(value) - mean) <= 0.0005  # to 3 decimals


def test_the_overlap_map_of_one_pair_draws_its_vector(tmp_path, observations, monkeypatch) -> None:
    """A block of two scenes (a stereo pair) has one pair of overlapping scenes: its mean vector
    was scaled to 15 % of the spread of the pairs' centres, nil for one pair, so it was drawn
    about 0.0002° long on a map 0.25° across, a dot under its RMS label. It is drawn at 15 % of
    the map's extent."""
    from blockqc.report import maps, svgplot
    from blockqc.report.format import Formatter
    from blockqc.results import BlockResults

    drawn = []
    real = svgplot.arrows
    monkeypatch.setattr(svgplot, "arrows", lambda t, v, *a: drawn.append(v) or real(t, v, *a))
    _, ref = observations
    doc = _results(write_v11(tmp_path / "d", ref))
    assert maps.overlap_map(BlockResults.model_validate(doc), Formatter("en")) is not None
    (vec,) = drawn
    lon = [
        float(x) for sc in doc["scenes"] for x in re.findall(r"(\d+\.\d+) \d", sc["footprint_wkt"])
    ]
    extent = max(lon) - min(lon)  # about 0.25° of longitude
    assert np.hypot(*vec[0]) == pytest.approx(0.15 * extent, rel=0.2)


def test_the_overlap_maps_rms_labels_do_not_overlap(tmp_path) -> None:
    """Six scenes in a 3 × 2 grid: the two diagonal pairs of each four scenes share the centre
    of their overlap, and their RMS labels were printed one over the other ('0.302' over
    '0.330'). Every label is now clear of the others (boxes of 0.6 em a character, 1 em high)."""
    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.report import maps
    from blockqc.report.format import Formatter
    from blockqc.results import BlockResults
    from blockqc.rfm.readers import read_rpc

    models = [read_rpc(f) for f in FILES.values()]
    cfg = SyntheticConfig(scenes=6, observations_per_scene=300, checkpoints=0, seed=21)
    _, folder = synthetic_block(models, cfg, tmp_path / "blk")
    doc = _results(folder)
    page = maps.overlap_map(BlockResults.model_validate(doc), Formatter("en"))
    labels = re.findall(r'<text x="([\d.]+)" y="([\d.]+)" font-size="6"[^>]*>([\d.]+)</text>', page)
    assert len(labels) >= 9  # one per pair of overlapping scenes
    boxes = [(float(x), float(x) + 3.6 * len(s), float(y)) for x, y, s in labels]
    for i, (a0, a1, ay) in enumerate(boxes):
        for b0, b1, by in boxes[i + 1 :]:
            assert not (a0 < b1 and b0 < a1 and abs(ay - by) < 6.0), labels


def test_the_overlap_map_without_a_mean_vector_says_zero(tmp_path, observations) -> None:
    """Every pair with a zero mean discrepancy: no arrow to draw, and the caption said 'longest
    1.0 m' (the fallback of the arrows' scale); it says 0 m."""
    from blockqc.report import maps
    from blockqc.report.format import Formatter
    from blockqc.results import BlockResults

    _, ref = observations
    doc = _results(write_v11(tmp_path / "d", ref))
    table = next(m for m in doc["measurements"] if m["metric"] == "overlap_discrepancy")
    for row in table["tables"]["point"]:
        row.update(dx_m=0.0, dy_m=0.0)
    page = maps.overlap_map(BlockResults.model_validate(doc), Formatter("en"))
    assert set(re.findall(r"mean vector \(longest ([0-9.]+) m\)", page)) == {"0"}


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 6), st.integers(0, 4), st.booleans()), max_size=60))
def test_pairs_are_every_two_kept_rows_of_a_point_in_scene_order(rows):
    """Points of any number of rows (one of them on a scene twice, or left out), against every
    two rows tried: (a, b) with scene[a] < scene[b], in the order of a then b."""
    point, scene, kept = (np.array([r[k] for r in rows], dtype=int) for k in range(3))
    kept = kept.astype(bool)
    a, b = verification._pairs(point, scene, kept)
    n = len(rows)
    want = [
        (i, j)
        for i in range(n)
        for j in range(n)
        if kept[i] and kept[j] and point[i] == point[j] and scene[i] < scene[j]
    ]
    assert list(zip(a.tolist(), b.tolist(), strict=True)) == want


@pytest.mark.parametrize("dtype", [object, "category"])
def test_derived_overlaps_pair_every_two_scenes_of_a_point_in_row_order(dtype):
    """Each two observations of a point (scene order a < b), rows in the order of a then b,
    points interleaved across rows; an observation without height is in no pair."""
    rng = np.random.default_rng(3)
    n = 60
    point = rng.integers(0, 12, n)
    scene = rng.integers(0, 6, n)
    keep = ~pd.DataFrame({"p": point, "s": scene}).duplicated().to_numpy()
    point, scene = point[keep], scene[keep]
    obs = pd.DataFrame(
        {"point_id": [f"P{p}" for p in point], "scene_id": [f"S{s}" for s in scene]}
    ).astype(dtype)
    lon, lat = 5.0 + rng.uniform(0, 0.1, point.size), 44.0 + rng.uniform(0, 0.1, point.size)
    h = np.where(np.arange(point.size) % 7 == 3, np.nan, 500.0)
    got = verification.derive_overlaps(obs, scene, lon, lat, h)
    want = [
        (f"S{scene[i]}", f"S{scene[j]}", f"P{point[i]}", i, j)
        for i in range(point.size)
        for j in range(point.size)
        if point[i] == point[j] and scene[i] < scene[j] and np.isfinite(h[i] + h[j])
    ]
    assert list(zip(got.scene_a, got.scene_b, got.point_id, strict=True)) == [w[:3] for w in want]
    ids = {"scene_a": "scene_id", "scene_b": "scene_id", "point_id": "point_id"}
    text = pd.Series(["S0"]).dtype  # as pandas holds text
    want_dtype = {c: obs[ids[c]].dtype if dtype == "category" else text for c in ids}
    assert all(got[c].dtype == want_dtype[c] for c in ids)  # Categoricals kept, else text
    i, j = np.array([w[3] for w in want]), np.array([w[4] for w in want])
    geod = Geod(ellps="WGS84")
    _, _, east = geod.inv(lon[i], lat[i], lon[j], lat[i])
    np.testing.assert_allclose(np.abs(got.dx_m), east, rtol=1e-3)


def test_derived_overlaps_pair_scenes_of_one_band_only():
    """A point seen on PAN and MS scenes (an MS scene observed in the tie-point network): a
    PAN–MS pair is a registration (§RO-1, bound 1 MS pixel), not two adjacent images (§RO-3);
    every two observations of a point on scenes of one band are paired, no other."""
    rng = np.random.default_rng(5)
    n = 80
    point = rng.integers(0, 10, n)
    scene = rng.integers(0, 6, n)
    keep = ~pd.DataFrame({"p": point, "s": scene}).duplicated().to_numpy()
    point, scene = point[keep], scene[keep]
    band = np.array([0, 0, 1, 0, 1, 1])  # per scene: pan, pan, ms, pan, ms, ms
    obs = pd.DataFrame({"point_id": [f"P{p}" for p in point], "scene_id": [f"S{s}" for s in scene]})
    lon, lat, h = np.full(point.size, 5.0), np.full(point.size, 44.0), np.full(point.size, 500.0)
    got = verification.derive_overlaps(obs, scene, lon, lat, h, band=band)
    want = [
        (f"S{scene[i]}", f"S{scene[j]}", f"P{point[i]}")
        for i in range(point.size)
        for j in range(point.size)
        if point[i] == point[j] and scene[i] < scene[j] and band[scene[i]] == band[scene[j]]
    ]
    assert want and len(want) < len(verification.derive_overlaps(obs, scene, lon, lat, h))
    assert list(zip(got.scene_a, got.scene_b, got.point_id, strict=True)) == want


def test_derived_overlaps_keys_are_codes_into_the_tie_points_categories():
    """Point P1 on scenes S2, S1, S3 (rows 0, 1, 3), P2 on S1, S2 (rows 2, 4); scene order S1,
    S2, S3. P1 gives (S2, S3), (S1, S2), (S1, S3) from rows (0, 3), (1, 0), (1, 3), P2 (S1,
    S2) from rows (2, 4), in the order of a then b. The key columns are Categoricals over the
    tie points' categories, unused ones (S9, P9) kept: codes, no text per pair."""
    scenes = pd.CategoricalDtype(["S2", "S1", "S3", "S9"])
    points = pd.CategoricalDtype(["P1", "P2", "P9"])
    obs = pd.DataFrame(
        {
            "point_id": pd.Series(["P1", "P1", "P2", "P1", "P2"], dtype=points),
            "scene_id": pd.Series(["S2", "S1", "S1", "S3", "S2"], dtype=scenes),
        }
    )
    scene = np.array([1, 0, 0, 2, 1])
    lon, lat, h = np.full(5, 5.0), np.full(5, 44.0), np.full(5, 500.0)
    got = verification.derive_overlaps(obs, scene, lon, lat, h)
    assert got["scene_a"].dtype == scenes and got["scene_b"].dtype == scenes
    assert got["point_id"].dtype == points
    assert got["scene_a"].cat.codes.tolist() == [0, 1, 1, 1]  # S2, S1, S1, S1
    assert got["scene_b"].cat.codes.tolist() == [2, 0, 2, 0]  # S3, S2, S3, S2
    assert got["point_id"].cat.codes.tolist() == [0, 0, 0, 1]  # P1, P1, P1, P2
    assert got["dx_m"].tolist() == [0.0] * 4 and got["dy_m"].tolist() == [0.0] * 4


def test_positions_measured_in_a_dimap_rpc_s_own_convention(tmp_path, observations) -> None:
    """Scene L's RPC given as its DIMAP XML, whose first pixel is (1, 1), and its tie points
    measured in that convention ("in the convention of the scene's RPC", contract v1.1): one
    pixel more in line and sample than on the OSSIM .geom of the same model. The reader turns
    DIMAP's offsets to a first pixel of 0, and every residual of L came out about 1.2 px off
    (RC-1 failing a delivery whose residuals are right); they are the independent solver's."""
    _, ref = observations
    on_l = ref["scene_id"] == "L"
    dimap = ref.assign(
        line=ref["line"].where(~on_l, ref["line"] + 1.0),
        sample=ref["sample"].where(~on_l, ref["sample"] + 1.0),
    )
    folder = write_v11(tmp_path / "d", dimap.drop(columns=["v_line", "v_sample"]))
    (folder / "rpc" / "L.geom").unlink()
    shutil.copy(
        RPCS / "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML", folder / "rpc" / "L.XML"
    )
    d = load_delivery(folder)
    dump(inspect_delivery(d, load_pack("global-project")))
    got = d.tie_points.set_index(["point_id", "scene_id"])
    want = ref.set_index(["point_id", "scene_id"]).loc[got.index]
    assert np.allclose(got["v_line"], want["v_line"], atol=2e-3)
    assert np.allclose(got["v_sample"], want["v_sample"], atol=2e-3)
