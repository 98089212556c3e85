"""The adjust page in Chinese (--lang zh): every label, heading, fixed phrase and warning of
adjust.json in Chinese, nothing English left; English as it was."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from markupsafe import escape

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
    """With every kind of warning too."""
    doc = {**summary, "warnings": _adjust_warnings()}
    assert page_overflow_px(render_html(doc, lang="zh"), tmp_path) <= 0


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


def _adjust_warnings() -> list[str]:
    """One warning of every kind the run gives, from its producers."""
    from types import SimpleNamespace

    from blockqc.adjust.run import checkpoint_warning, fit_warnings, height_warnings, scene_warnings

    rows = [
        {"scene_id": "S1", "n_observations": 0, "n_outliers": 100, "n_without_second_ray": 20},
        {
            "scene_id": "S 02 (copy)",
            "n_observations": 0,
            "n_outliers": 0,
            "n_without_second_ray": 0,
        },
    ]
    out = scene_warnings(rows)
    fit = {"sigma0_px": 6.123, "rms_px_before": 1.0, "rms_px_after": 2.0}
    out += fit_warnings({**fit, "checkpoints": {"warning": checkpoint_warning(12)}})
    out.append(checkpoint_warning(0))
    sol = SimpleNamespace(
        point_used=np.array([True, True, True, False, True]),
        ground_sigma=np.array([[1.0, 1.0, 400.0]] * 5),
    )
    priors = SimpleNamespace(height_sigma=np.full(5, 885.0))
    ids = np.array(["p0", "p1", "p2", "p3", "p4"])
    bh = np.array([0.01, 0.02, 0.5, np.nan, 0.03])
    cps = pd.DataFrame({"point_id": ["p0", "p4", "p2"]})
    return out + height_warnings(bh, sol, priors, 10.0, cps, ids)


def test_the_run_warnings_in_chinese(summary):
    """Every kind of warning of the run is shown in Chinese on a Chinese page, its numbers and
    scene ids kept; adjust.json keeps them in English (and the English page shows them so)."""
    warnings = _adjust_warnings()
    assert len(warnings) == 7
    doc = {**summary, "warnings": warnings}
    html = render_html(doc, lang="zh")
    for text in (
        "<li>影像 S1 经粗差剔除后，其 120 个观测仅保留 0 个（少于 3 个；粗差 100 个，"
        "20 个失去第二条光线）：其仿射参数仅由先验确定，而非由数据确定；请检查其 RPC（rpc/）"
        "及其连接点</li>",
        "<li>影像 S 02 (copy) 没有连接点观测：",
        "<li>σ0 为 6.12 像素，远高于连接点的量测精度（超过 5 像素）：",
        "<li>平差后残差均方根反而增大（1.000 → 2.000 像素）：",
        "<li>仅 12 个点可比较（§CP-1 要求 20–50 个）</li>",
        "<li>没有可比较的点，checkpoints.csv 只有表头：",
        "<li>4 个点中有 3 个点的光线基高比小于 0.05（中位数 0.020；观测方向几乎相同）："
        "影像无法确定这些点的高程（σ_h 中位数 400 m），其高程取决于弱高程先验，"
        "其中的 2 个检查点不能检查高程；请用 --dem 给出高程先验</li>",
    ):
        assert text in html, text
    start = html.index("<h2>警告</h2>")
    section = html[start : html.index("</ul>", start)]
    assert section.count("<li>") == len(warnings)
    assert english_left(section, ALLOWED | {"dem", "rpc", "copy"}) == set()  # option, folder, id
    english = render_html(doc, lang="en")
    assert all(f"<li>{escape(w)}</li>" in english for w in warnings)
    assert english == render_html(doc)
