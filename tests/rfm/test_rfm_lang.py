"""The rfm-accuracy page in Chinese (--lang zh): every label, heading and fixed phrase of its
results.json in Chinese, nothing English left but the run's warnings; English as it was."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from blockqc.rfm.report import render_html
from casekit import english_left, page_overflow_px

RESULTS = Path(__file__).resolve().parents[1] / "data" / "rfm" / "ventoux_results.json"
#: abbreviations, symbols and ids a Chinese page shows as they are
ALLOWED = {"RFM", "RPC", "DEM", "GEV", "RMSE", "EPSG", "WGS", "GDAL", "RA", "geom", "dx", "dy"}
ALLOWED |= {"cps", "html", "ortho", "png", "csv", "tif", "gtx", "egm", "srtm", "crop"}


@pytest.fixture
def results() -> dict:
    doc = json.loads(RESULTS.read_text(encoding="utf-8"))
    doc["warnings"] = []  # stderr's warnings, English on either page
    return doc


def test_the_page_in_chinese(results):
    html = render_html(results, lang="zh")
    assert '<html lang="zh-CN">' in html
    for text in (
        "有理函数模型（RFM）几何精度",
        "整景影像精度（§RA-4）",
        "局部几何畸变（§RA-5）",
        "以 k 个控制点精化的 RFM（§RA-6）",
        "控制点数",
        "6.865 像素（3.426 m）",
        '<td class="fail">不合格</td>',
        "检查方法：同精度数据法",
        "用其 RPC 和同一 DEM 正射纠正",
        "波段 1（单波段）",
        "的大地水准面差距 N（N 50.82..50.90 m）= 椭球高（WGS-84）",
        "27 像素格网仅得 38 个控制点，故以 24 像素重新匹配",
        "<th>检核点数</th><th>抽样次数</th><th>RMSE 平均值（像素）</th>",
        "精化 RFM（像方仿射变换），留出的控制点",
        "二次多项式：解释方差的 0.988",
        "是：p = 3.1e-71",
        "a0 = 494.691 像素，a1",
        "约定：像素中心",
    ):
        assert text in html, text
    assert english_left(html, ALLOWED) == set()


def test_phrases_of_fewer_cps_and_another_dem_in_chinese(results):
    """The notes of a k the CPs cannot support, a field not computed, a DEM in ellipsoidal
    heights declared by its CRS and converted from feet, and a reference of three bands."""
    doc = copy.deepcopy(results)
    doc["refined_rfm"]["rows"][1]["note"] = "needs 3 ≤ k < n CPs (n = 5)"
    doc["refined_rfm"]["rows"][2]["note"] = (
        "refined RFM (image-space affine), held-out CPs; only 4 check CPs; "
        "2 draws with collinear CPs left out"
    )
    doc["distortion"].update(model="not computed: fewer than 4 CPs", explained_share=None)
    doc["dem"]["heights"] = (
        "ellipsoidal (WGS-84) heights from dsm.tif (declared by its CRS 'WGS 84 (G1762) + "
        "height', in foot converted to metres)"
    )
    doc["reference"]["bands"]["matched_on"] = "mean of bands 1, 2, 3 (red, green, blue) of 4"
    doc["matching"]["grid_choice"] = "given"
    html = render_html(doc, lang="zh")
    for text in (
        "需要 3 ≤ k &lt; n 个控制点（n = 5）",
        "留出的控制点；仅 4 个检核点；剔除控制点共线的抽样 2 次",
        "未计算：控制点少于 4 个（仿射误差场每个分量有 3 项）",
        "dsm.tif 的椭球高（WGS-84）（由其坐标参考系“WGS 84 (G1762) + height”声明，"
        "由 foot 换算为米）",
        "4 个波段中波段 1, 2, 3（红、绿、蓝）的平均值",
        "（由 --grid 指定）",
    ):
        assert text in html, text
    assert english_left(html, ALLOWED | {"foot", "height", "G1762", "grid"}) == set()


def test_the_english_page_is_unchanged_by_the_option(results):
    html = render_html(results, lang="en")
    assert html == render_html(results)
    assert '<html lang="en">' in html
    assert "<h2>Accuracy of the whole image (§RA-4)</h2>" in html
    assert "Matched on the image's band 1 (one band) and the reference's band 1 (one band)." in html
    assert '<tr><th class="text">RMSE</th><td>6.865 px (3.426 m)</td></tr>' in html


@pytest.mark.browser
def test_the_chinese_page_stays_within_the_window(results, tmp_path):
    assert page_overflow_px(render_html(results, lang="zh"), tmp_path) <= 0


@pytest.mark.slow
def test_the_command_writes_the_page_in_chinese_and_the_same_results(tmp_path):
    """--lang zh: report.html in Chinese; results.json, cps.csv and the other tables as in
    English (the language is the page's and its figures', never the results')."""
    from click.testing import CliRunner
    from rfm_helpers import VENTOUX

    from blockqc.rfm.command import command

    args = [str(VENTOUX / "left_image.tif"), "--rpc", str(VENTOUX / "left_image.geom")]
    args += ["--dem", str(VENTOUX / "srtm_N44E005_crop.tif"), "--geoid", "egm96"]
    args += ["--reference", str(VENTOUX / "right_image.tif")]
    args += ["--reference-rpc", str(VENTOUX / "right_image.geom"), "--grid", "40"]
    outs = {}
    for lang in ("en", "zh"):
        outs[lang] = tmp_path / lang
        result = CliRunner().invoke(command, [*args, "--out", str(outs[lang]), "--lang", lang])
        assert isinstance(result.exception, SystemExit | None), result.output
    for name in ("results.json", "cps.csv", "refined_rfm.csv"):
        assert (outs["zh"] / name).read_bytes() == (outs["en"] / name).read_bytes(), name
    page = (outs["zh"] / "report.html").read_text(encoding="utf-8")
    assert '<html lang="zh-CN">' in page and "整景影像精度（§RA-4）" in page
    assert (outs["zh"] / "gev_histogram.png").read_bytes() != (
        outs["en"] / "gev_histogram.png"
    ).read_bytes()
