"""The adjust page in Chinese (--lang zh): every label, heading and fixed phrase of adjust.json
in Chinese, nothing English left but the run's warnings; English as it was."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from blockqc.adjust.report import render_html
from casekit import english_left, page_overflow_px

RESULTS = Path(__file__).resolve().parents[1] / "data" / "adjust" / "syn_adjust.json"
#: abbreviations, symbols, ids and the keys of files a Chinese page shows as they are
ALLOWED = {"RFM", "RPC", "SYN", "EPSG", "HEIGHT", "OFF", "SCALE", "RC", "CP", "lon", "lat"}
ALLOWED |= {"adjustment", "checkpoints", "convergence", "ground", "points", "residual"}
ALLOWED |= {"histogram", "vectors", "scene", "precision", "tie"}


@pytest.fixture
def summary() -> dict:
    return json.loads(RESULTS.read_text(encoding="utf-8"))


def _text(html: str) -> str:
    """The page without its list of files (their keys are adjust.json's)."""
    return html.split("<h2>文件</h2>")[0]


def test_the_page_in_chinese(summary):
    html = render_html(summary, lang="zh")
    assert '<html lang="zh-CN">' in html
    for text in (
        "<h1>RFM 仿射区域网平差 — SYN-B01</h1>",
        "<h2>平差结果</h2>",
        '<td class="pass">是</td>',
        "验后单位权中误差 σ0（像点量测）</th><td>0.305 像素</td>",
        "<td>3.2 秒</td>",
        "<h2>平差基准（无地面控制点）</h2>",
        "RPC 先验精度：a0、b0（影像中心处的平移）σ 10 像素",
        "高程：弱高程先验：区域网平均高程 1075.0 ± 885.0 m",
        "固定的影像：无",
        "<h2>其他软件重新计算法检查点（§CP-1、§RC-3）</h2>",
        "20 个分布均匀的点：生产单位的平差位置（tie_points.csv 的 lon、lat、h（成果所给））",
        "（block.yaml 的 spatial_reference.epsg）",
        '写入 <a href="checkpoints.csv">checkpoints.csv</a>，供 <code>blockqc inspect',
        "<th>影像中心平移量的 σ（像素）</th>",
        'alt="各影像残差矢量图，均方根最大者在前"',
    ):
        assert text in html, text
    assert english_left(_text(html), ALLOWED) == set()


def test_phrases_of_a_dem_prior_and_few_points_in_chinese(summary):
    """A DEM height prior at some points (the weak one elsewhere), the producer's positions
    intersected from its adjustment in a UTM zone, and too few points to compare."""
    doc = copy.deepcopy(summary)
    weak = doc["datum"]["height_prior"]
    doc["datum"]["height_prior"] = (
        "DEM height prior ± 5 m from srtm.tif (ellipsoidal (WGS-84) heights from srtm.tif "
        f"(as stated by the user)) at 700 of 771 points; elsewhere {weak}"
    )
    doc["datum"]["fixed_scenes"] = ["S0001", "S0002"]
    doc["checkpoints"].update(
        producer_positions="intersection with the producer's adjustment (adjustment.csv)",
        crs_source="UTM zone of the block centre (block.yaml gives no projected EPSG)",
        warning="only 12 points could be compared (§CP-1 asks for 20–50)",
    )
    html = render_html(doc, lang="zh")
    for text in (
        "DEM 高程先验 ± 5 m，取自 srtm.tif（srtm.tif 的椭球高（WGS-84）（按用户指定））"
        "，用于 771 个点中的 700 个；其余点：弱高程先验",
        "固定的影像：S0001，S0002",
        "按生产单位的平差结果（adjustment.csv）前方交会",
        "区域网中心所在的 UTM 投影带（block.yaml 未给出投影坐标系的 EPSG）",
        "<strong>仅 12 个点可比较（§CP-1 要求 20–50 个）</strong>",
    ):
        assert text in html, text
    assert english_left(_text(html), ALLOWED | {"DEM", "WGS", "UTM", "srtm"}) == set()


def test_the_english_page_is_unchanged_by_the_option(summary):
    html = render_html(summary, lang="en")
    assert html == render_html(summary)
    assert '<html lang="en">' in html
    assert '<tr><th class="text">converged</th><td class="pass">yes</td></tr>' in html
    assert "<li>Fixed scenes: none</li>" in html
    assert "<h2>Checkpoints for the recalculation method (§CP-1, §RC-3)</h2>" in html


@pytest.mark.browser
def test_the_chinese_page_stays_within_the_window(summary, tmp_path):
    assert page_overflow_px(render_html(summary, lang="zh"), tmp_path) <= 0


@pytest.mark.slow
def test_the_command_writes_the_page_in_chinese_and_the_same_results(tmp_path, blockqc):
    """--lang zh: adjust.html in Chinese; adjust.json (but for its timings) and the tables as
    in English."""
    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    ventoux = RESULTS.parents[1] / "rfm" / "phr_ventoux"
    models = [read_rpc(ventoux / f"{side}_image.geom") for side in ("left", "right")]
    cfg = SyntheticConfig(scenes=2, observations_per_scene=150, checkpoints=0, seed=5)
    _, block = synthetic_block(models, cfg, tmp_path / "blk")
    for lang in ("en", "zh"):
        r = blockqc("adjust", block, "--out", tmp_path / lang, "--lang", lang, "--checkpoints", 5)
        assert r.returncode == 0, r.stderr
    docs = [json.loads((tmp_path / lang / "adjust.json").read_text()) for lang in ("en", "zh")]
    for doc in docs:
        del doc["seconds"], doc["timings"]
    assert docs[0] == docs[1]
    for name in ("adjustment.csv", "tie_points.csv", "ground_points.csv", "checkpoints.csv"):
        assert (tmp_path / "zh" / name).read_bytes() == (tmp_path / "en" / name).read_bytes()
    page = (tmp_path / "zh" / "adjust.html").read_text(encoding="utf-8")
    assert '<html lang="zh-CN">' in page and "<h2>平差结果</h2>" in page
