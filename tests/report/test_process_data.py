"""The block report says where the process data came from (results.json's `process_data`):
what blockqc computed from the delivered geometry (§RC-1, §RC-2) and the inspector's own
checkpoints, in English and Chinese, with nothing of it left out."""

from __future__ import annotations

import re

import pytest

from blockqc.report.html import render_block


def _process_table(html: str) -> list[tuple[str, str]]:
    """The (label, value) rows of the report's process-data table; [] when there is none."""
    found = re.search(r'<table class="meta" id="process-data">(.*?)</table>', html, re.S)
    if not found:
        return []
    rows = re.findall(r"<tr><th[^>]*>(.*?)</th><td>(.*?)</td></tr>", found[1], re.S)
    return [(label.strip(), value.strip()) for label, value in rows]


def _with_process_data(doc: dict) -> dict:
    doc["process_data"] = {
        "geometry": "adjustment.csv",
        "n_points": 1200,
        "n_points_single_ray": 3,
        "n_points_not_intersected": 2,
        "n_points_height_undetermined": 0,
        "iterations": 4,
        "tie_point_residuals": (
            "tie-point residuals computed by blockqc from the delivered geometry (§RC-1)"
        ),
        "observations_single_ray": 3,
        "overlaps": (
            "adjacent-image discrepancies derived by blockqc from the delivered geometry (§RC-2)"
        ),
        "n_overlap_discrepancies": 2417,
        "inspector_checkpoints": {"/home/centre/cps/field_3.csv": 30},
        "a_later_key": 7,
    }
    return doc


def test_rows_in_english_with_every_entry(results_doc):
    rows = _process_table(render_block(_with_process_data(results_doc), lang="en"))
    assert rows == [
        ("Geometry used", "adjustment.csv"),
        (
            "Tie-point residuals",
            "tie-point residuals computed by blockqc from the delivered geometry (§RC-1)",
        ),
        ("Tie points", "1200"),
        ("seen on one scene only (not intersected)", "3"),
        ("whose rays do not intersect", "2"),
        ("whose rays fix no height (nearly parallel)", "0"),
        ("Intersection iterations", "4"),
        ("Observations of single-ray points, left out of the tie-point rules", "3"),
        (
            "Adjacent-image discrepancies",
            "adjacent-image discrepancies derived by blockqc from the delivered geometry (§RC-2)",
        ),
        ("Adjacent-image discrepancies derived", "2417"),
        ("Inspector&#39;s checkpoints", "field_3.csv: 30 rows"),  # the file by its name only
        ("a_later_key", "7"),  # a key this version does not know is shown, not dropped
    ]


def test_rows_in_chinese(results_doc):
    rows = dict(_process_table(render_block(_with_process_data(results_doc), lang="zh")))
    assert rows["所用几何模型"] == "adjustment.csv"
    assert rows["连接点残差"] == "连接点残差由 blockqc 依据所交几何模型计算（§RC-1）"
    assert rows["相邻影像接边差"] == "相邻影像接边差由 blockqc 依据所交几何模型推算（§RC-2）"
    assert rows["检查员检查点"] == "field_3.csv: 30 行"


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_no_table_when_the_delivery_gave_everything(results_doc, lang):
    results_doc["process_data"] = {}
    html = render_block(results_doc, lang=lang)
    assert _process_table(html) == []
    assert "process-data" not in html


def test_a_result_judged_on_derived_data_says_so(results_doc):
    rule = next(r for r in results_doc["results"] if r["rule"].startswith("RO-"))
    rule["detail"]["computed_by_blockqc"] = (
        "adjacent-image discrepancies derived by blockqc from the delivered geometry (§RC-2)"
    )
    title_cell = re.compile(
        rf'<td class="id">{rule["rule"]}</td><td>[^<]*<div class="note">(.*?)</div>', re.S
    )
    assert "derived by blockqc from the delivered geometry (§RC-2)" in "".join(
        title_cell.findall(render_block(results_doc, lang="en"))
    )
    assert "相邻影像接边差由 blockqc 依据所交几何模型推算（§RC-2）" in "".join(
        title_cell.findall(render_block(results_doc, lang="zh"))
    )
