"""The rfm-accuracy page in Chinese (--lang zh): every label, heading, fixed phrase and warning
of its results.json in Chinese, nothing English left; English as it was."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from markupsafe import escape

from blockqc.rfm.report import render_html
from casekit import english_left, page_overflow_px

RESULTS = Path(__file__).resolve().parents[1] / "data" / "rfm" / "ventoux_results.json"
#: abbreviations, symbols and ids a Chinese page shows as they are
ALLOWED = {"RFM", "RPC", "DEM", "GEV", "RMSE", "EPSG", "WGS", "GDAL", "RA", "geom", "dx", "dy"}
ALLOWED |= {"cps", "html", "ortho", "png", "csv", "tif", "gtx", "egm", "srtm", "crop"}
#: command-line options a warning names, as they are on either page
OPTIONS = {"grid", "dem", "fill", "voids", "vertical", "ellipsoid"}


@pytest.fixture
def results() -> dict:
    """The Ventoux pair's results, with the run's one warning (§RA-3, 45 CPs)."""
    return json.loads(RESULTS.read_text(encoding="utf-8"))


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
        "<li>§RA-3：24 像素格网（自动选取）仅得到 45 个控制点：",
    ):
        assert text in html, text
    assert english_left(html, ALLOWED | OPTIONS) == set()


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
    """With every kind of warning too."""
    doc = {**results, "warnings": _rfm_warnings(tmp_path)}
    assert page_overflow_px(render_html(doc, lang="zh"), tmp_path) <= 0


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


def _rfm_warnings(tmp_path: Path) -> list[str]:
    """One warning of every kind the run gives, from its producers."""
    from types import SimpleNamespace

    from blockqc.rfm import accuracy
    from blockqc.rfm.pipeline import RfmAccuracyConfig, reference_warning, run_warnings

    dem = SimpleNamespace(
        vertical="ellipsoidal (WGS-84) heights from d.tif (as stated by the user)"
    )
    out = []
    for grid, no_height in ((None, (0.5, 0.02)), (40, (0.0, 0.123)), (None, (0.25, 0.0))):
        paths = {"image": Path("a.tif"), "reference": Path("r.tif"), "out": tmp_path}
        cfg = RfmAccuracyConfig(dem=Path("dem/partial (v2).tif"), match_grid=grid, **paths)
        out += run_warnings(cfg, dem, 12, 24, no_height)
    out += reference_warning(SimpleNamespace(reference_gsd_ratio=3.0), 2.5, 0.5)
    return out + accuracy.k_warnings((6, 12, 16, 20), 18)


def _warnings_section(html: str) -> str:
    start = html.index("<h2>警告</h2>")
    return html[start : html.index("</ul>", start)]


def test_the_run_warnings_in_chinese(results, tmp_path):
    """Every kind of warning of the run is shown in Chinese on a Chinese page, its numbers and
    file name kept; results.json keeps them in English (and the English page shows them so)."""
    warnings = _rfm_warnings(tmp_path)
    assert len(warnings) == 13
    doc = {**results, "warnings": warnings}
    html = render_html(doc, lang="zh")
    for text in (
        "影像的 52.0% 在 DEM partial (v2).tif 上没有高程（50.0% 在其范围之外，2.0% 位于其数据空洞处"
        "（--dem-fill-voids N 可填补较小的空洞））：这些像素在 ortho.tif 中为空，不产生控制点",
        "影像的 12.3% 在 DEM partial (v2).tif 上没有高程（12.3% 位于其数据空洞处",
        "影像的 25.0% 在 DEM partial (v2).tif 上没有高程（25.0% 在其范围之外）",
        "§RA-3：24 像素格网（自动选取）仅得到 12 个控制点：",
        "§RA-3：24 像素格网（由 --grid 指定）仅得到 12 个控制点：",
        "仅凭 --dem-vertical ellipsoid 将 DEM 视为椭球高：",
        "§RA-2：参考影像的像素大小为 2.5 m，是影像地面采样距离（0.5 m）的 5.0 倍（超过 3 倍）：",
        "§RA-6：k = 12 仅留下 6 个检核点（&lt; 10）：其 RMSE 仅供粗略参考",
        "§RA-6：k = 20 需要多于 20 个控制点，仅找到 18 个：该行留空",
    ):
        assert text in html, text
    section = _warnings_section(html)
    assert section.count("<li>") == len(warnings)
    assert english_left(section, ALLOWED | OPTIONS | {"partial"}) == set()  # its file name
    english = render_html(doc, lang="en")
    assert all(f"<li>{escape(w)}</li>" in english for w in warnings)
    assert english == render_html(doc)
