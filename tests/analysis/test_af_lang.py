"""The factors page in Chinese (--lang zh): every label, heading, figure text and fixed phrase of
factors.json in Chinese; English as it was."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from blockqc.analysis.analyse import analyse
from blockqc.analysis.command import command
from blockqc.analysis.render import correlation_heatmap, render_html, structure_plot
from blockqc.analysis.table import read_table
from casekit import english_left, page_overflow_px

APPENDIX = (
    Path(__file__).resolve().parents[2] / "samples" / "factors" / "gf7_adjustment_experiments.csv"
)
#: names, abbreviations and units a Chinese page shows as they are
ALLOWED = {"AF", "DOMAIN", "Pearson", "Bartlett", "Wilks", "Clark", "Evans", "Horn", "CCA"}
ALLOWED |= {"DEM", "HZ", "MS", "TJ", "km", "df", "ln"}


def _page(results: dict, lang: str) -> str:
    figures = {}
    for name, plot in (("correlation", correlation_heatmap), ("structure", structure_plot)):
        made = plot(results, lang)
        if made is not None:
            figures[name] = made[0]
    return render_html(results, figures, lang=lang)


@pytest.fixture(scope="module")
def full() -> dict:
    return analyse(read_table(APPENDIX), "gf7_adjustment_experiments.csv")


@pytest.fixture(scope="module")
def partial() -> dict:
    """Six experiments, two of them without checkpoints, one constant factor, and the extra
    columns of a batch: no CCA, the rows left out and the note on the correlations."""
    table = read_table(APPENDIX).iloc[:6].copy()
    table.loc[[1, 4], ["x_rmse_m", "y_rmse_m", "h_rmse_m"]] = np.nan
    table["images_periods"] = 3
    table["residual_band"] = ["pan", "pan", "all", "ms", "pan", "pan"]
    table["plane_method"] = ["high_precision"] * 6
    table["overlapping_pairs"] = range(6)
    return analyse(table, "/data/batch")


def test_the_full_analysis_in_chinese(full):
    html = _page(full, "zh")
    assert '<html lang="zh-CN">' in html
    for text in (
        "<h1>区域网精度的影响因素</h1>",
        "表中共 20 个试验，其中 20 个数据完整并参与分析。",
        "<h2>1. 各因素与各指标的 Pearson 相关系数</h2>",
        '<th class="name">因素</th><th>δ_l（像素）</th>',
        '<td class="name">Clark–Evans 系数 R</td>',
        "<h2>2. 典型相关分析：因素（U）与指标（V）</h2>",
        "由 n = 20 个试验、p = 10 个因素和 q = 5 个指标得到 5 对典型变量。",
        "<th>第 k 对</th><th>典型相关系数 r</th>",
        "<th>在 U1 上</th><th>在 V1 上</th><th>U1 的标准化系数</th>",
        "<h2>3. 试验数据</h2>",
        '<th class="name">试验</th><th class="name">区域</th>',
        "<h2>定义</h2>",
        "Pearson 相关系数 r",  # the heatmap's colour bar
        "第一对典型变量，r₁ = 0.991",  # the structure plot's title
        "平均粗糙度（m）",  # its tick labels
    ):
        assert text in html, text
    assert english_left(html, ALLOWED) == set()


def test_rows_left_out_and_no_cca_in_chinese(partial):
    html = _page(partial, "zh")
    for text in (
        "<li><b>2</b>：缺少 δ_X（m）、δ_Y（m）、δ_H（m）</li>",
        "在各试验中为常数，无相关系数：images_periods",
        "<b>未进行典型相关分析。</b>",
        "表中有 n = 4 个完整的行，但 p = 10 个因素与 q = 5 个指标的典型相关分析需要",
        "为常数的因素列：images_periods",
        "<th>残差所用波段</th><th>平面检查方法</th><th>重叠像对数</th>",
        "<td>全色</td><td>高精度数据法</td>",
        "<td>全部波段</td>",
        "每格 n = 4–6",
    ):
        assert text in html, text
    assert english_left(html, ALLOWED) == set()


def test_the_english_page_is_unchanged_by_the_option(partial):
    html = _page(partial, "en")
    assert html == render_html(partial, {"correlation": correlation_heatmap(partial)[0]})
    assert '<html lang="en">' in html
    assert "<h1>What drives a block's accuracy</h1>" in html
    assert "<li><b>2</b>: no δ_X (m), δ_Y (m), δ_H (m)</li>" in html
    assert "<th>residual band</th><th>plane method</th>" in html
    assert "<td>pan</td><td>high_precision</td>" in html


@pytest.mark.browser
def test_the_chinese_page_stays_within_the_window(full, tmp_path):
    assert page_overflow_px(_page(full, "zh"), tmp_path) <= 0


@pytest.mark.slow
def test_the_command_writes_the_page_in_chinese_and_the_same_results(tmp_path):
    outs = {lang: tmp_path / lang for lang in ("en", "zh")}
    for lang, out in outs.items():
        args = ["--table", str(APPENDIX), "--out", str(out), "--lang", lang]
        assert CliRunner().invoke(command, args).exit_code == 0
    for name in ("factors.json", "experiments.csv", "correlation.csv", "cca_tests.csv"):
        assert (outs["zh"] / name).read_bytes() == (outs["en"] / name).read_bytes(), name
    page = (outs["zh"] / "factors.html").read_text(encoding="utf-8")
    assert '<html lang="zh-CN">' in page and "<h2>3. 试验数据</h2>" in page
    svg = (outs["zh"] / "structure.svg").read_text(encoding="utf-8")
    assert "结构系数" in svg
    assert json.loads((outs["zh"] / "factors.json").read_text())["n_used"] == 20
    assert pd.read_csv(outs["zh"] / "experiments.csv").shape[0] == 20
