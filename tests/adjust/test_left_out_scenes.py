"""`blockqc adjust` and the scenes of scenes.csv without tie-point observations: left out of the
adjustment, said, and listed as not adjusted; a scene with observations but no RPC refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

from blockqc.adjust.report import render_html
from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
from blockqc.rfm.readers import read_rpc
from casekit import run_blockqc

VENTOUX = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
MODELS = [read_rpc(VENTOUX / "left_image.geom"), read_rpc(VENTOUX / "right_image.geom")]
WARNING = (
    "1 scene(s) of scenes.csv left out of the adjustment, not adjusted: M: without a tie-point "
    "observation nothing ties a scene to the block, whatever its RPC; adjustment.csv gives them "
    "no affine (adjusted false)"
)


@pytest.fixture(scope="module")
def block(tmp_path_factory) -> Path:
    cfg = SyntheticConfig(scenes=3, observations_per_scene=100, checkpoints=0, seed=5)
    _, folder = synthetic_block(MODELS, cfg, tmp_path_factory.mktemp("syn") / "blk")
    return folder


@pytest.fixture(scope="module")
def alone(block, tmp_path_factory) -> pd.DataFrame:
    """adjustment.csv of the block as delivered (no scene M): what the others must get."""
    out = tmp_path_factory.mktemp("alone") / "out"
    assert run_blockqc("adjust", block, "--out", out).returncode == 0
    return pd.read_csv(out / "adjustment.csv")


def _with_scene_m(block: Path, to: Path, rpc: bool) -> Path:
    """The block with a scene M in scenes.csv (S0001's row under another id) on which no tie
    point is observed; `rpc`: with an RPC file (S0001's) too."""
    shutil.copytree(block, to)
    scenes = pd.read_csv(to / "scenes.csv", dtype=str, keep_default_na=False)
    pd.concat([scenes, scenes.iloc[[0]].assign(scene_id="M")]).to_csv(
        to / "scenes.csv", index=False
    )
    if rpc:
        shutil.copy(to / "rpc" / "S0001.json", to / "rpc" / "M.json")
    return to


@pytest.mark.parametrize("rpc", [False, True], ids=["no-rpc", "with-rpc"])
def test_a_scene_without_observations_is_left_out(block, alone, tmp_path, blockqc, rpc):
    """Scene M without RPC file was refused ('no RPC for scene(s) M: the adjustment needs every
    scene's RPC') where inspect went on; with one it was adjusted by its priors alone. Either
    way it is now left out, said, and listed as not adjusted; the others are adjusted as they
    are without it."""
    delivery = _with_scene_m(block, tmp_path / "blk", rpc)
    out = tmp_path / "out"
    proc = blockqc("adjust", delivery, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert f"warning: {WARNING}\n" in proc.stderr
    table = pd.read_csv(out / "adjustment.csv")
    assert table["scene_id"].tolist() == ["S0001", "S0002", "S0003", "M"]
    assert table["adjusted"].tolist() == [True, True, True, False]
    assert table.iloc[3, 1:-1].isna().all()
    pd.testing.assert_frame_equal(table.iloc[:3], alone, rtol=1e-9)
    summary = json.loads((out / "adjust.json").read_text())
    assert summary["scenes_not_adjusted"] == [
        {"scene_id": "M", "reason": "has no tie-point observation"}
    ]
    assert summary["warnings"][0] == WARNING and summary["n_scenes"] == 3
    assert [s["scene_id"] for s in summary["scenes"]] == ["S0001", "S0002", "S0003"]
    page = (out / "adjust.html").read_text()
    assert "<li>" + WARNING + "</li>" in page
    assert "<td>M</td>" in page.replace(' class="text"', "")
    assert "not adjusted: has no tie-point observation</td>" in page


def test_the_left_out_scene_is_said_in_chinese(block, tmp_path, blockqc):
    out = tmp_path / "out"
    delivery = _with_scene_m(block, tmp_path / "blk", rpc=False)
    assert blockqc("adjust", delivery, "--out", out).returncode == 0
    page = render_html(json.loads((out / "adjust.json").read_text()), lang="zh")
    assert (
        "scenes.csv 中有 1 景影像未参与平差，未作平差：M：没有连接点观测的影像与区域网之间"
        "无任何联系，无论其 RPC 如何；adjustment.csv 中没有其仿射参数（adjusted 为 false）"
    ) in page
    assert "未作平差：没有连接点观测</td>" in page


def test_a_scene_with_observations_but_no_rpc_stays_refused(block, tmp_path, blockqc):
    delivery = tmp_path / "blk"
    shutil.copytree(block, delivery)
    (delivery / "rpc" / "S0003.json").unlink()
    proc = blockqc("adjust", delivery, "--out", tmp_path / "out")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "no RPC for scene 'S0003'" in proc.stderr
    assert not (tmp_path / "out").exists()


def test_holding_a_left_out_scene_is_refused(block, tmp_path, blockqc):
    delivery = _with_scene_m(block, tmp_path / "blk", rpc=True)
    proc = blockqc("adjust", delivery, "--out", tmp_path / "out", "--fix", "M")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert (
        "--fix: scene(s) M have no tie-point observation: they take no part in the adjustment "
        "(left out), so there is nothing to hold"
    ) in proc.stderr
