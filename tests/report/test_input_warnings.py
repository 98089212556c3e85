"""results.json's input_warnings on the block page: in the page's language, each file named
within the delivery, none of them left out."""

from __future__ import annotations

import html as htmllib
import re
from pathlib import Path

import pandas as pd

from blockqc.engine import GROUND_POINTS_DIFFER
from blockqc.geometry_inputs import ground_disagreements, scenes_without_rpc
from blockqc.report.html import render_block

DELIVERY = "/data/batch/B-01"


def _warnings() -> list[str]:
    """The warnings of a table whose point P1 is given lon 5.2801 on its second row (line 3)
    and 5.28 on its first: made by the inspection's own check, so that the page reads its
    words."""
    rows = [("P1", "L", 5.28, 44.1), ("P1", "R", 5.2801, 44.1), ("P2", "L", 5.3, 44.2)]
    table = pd.DataFrame(rows, columns=["point_id", "scene_id", "lon", "lat"])
    file = Path(DELIVERY) / "tie_points.csv"
    found = ground_disagreements(file, table, GROUND_POINTS_DIFFER)
    return [str(p) for p in found]


def _shown(page: str) -> list[str]:
    cell = re.search(r'<td id="input-warnings">(.*?)</td>', page, re.S)
    return (
        []
        if cell is None
        else [htmllib.unescape(p) for p in re.findall(r"<p[^>]*>(.*?)</p>", cell[1])]
    )


def test_in_english_named_within_the_delivery(results_doc):
    results_doc["delivery"] = DELIVERY
    results_doc["input_warnings"] = _warnings()
    assert _shown(render_block(results_doc, lang="en")) == [
        "tie_points.csv, row 2 (line 3), column 'lon': point 'P1' is given lon 5.2801 here and "
        "5.28 on row 1: expected one ground point per point (the producer's), the same on each "
        "of its rows; judged as given (RC-1 with ground: delivered back-projects each row's own "
        "ground point)"
    ]


def test_in_chinese(results_doc):
    results_doc["delivery"] = DELIVERY
    results_doc["input_warnings"] = _warnings()
    (shown,) = _shown(render_block(results_doc, lang="zh"))
    assert shown == (
        "tie_points.csv, row 2 (line 3), column 'lon'：点 'P1' 在此给出 lon 5.2801，"
        "在第 1 行给出 5.28：每个点应只有一个地面点（生产方的），在其各行上相同；"
        "按所给评判（RC-1 取 ground: delivered 时按各行自己的地面点反投影）"
    )


def test_rows_beyond_those_listed_in_chinese(results_doc):
    more = (
        f"{DELIVERY}/tie_points.csv, column 'h': 3 more rows give their point another h than its "
        f"first row: {GROUND_POINTS_DIFFER}"
    )
    results_doc["delivery"] = DELIVERY
    results_doc["input_warnings"] = [more]
    (shown,) = _shown(render_block(results_doc, lang="zh"))
    assert shown.startswith("tie_points.csv, column 'h'：另有 3 行给出的 h 与其点的第一行不同：")


def test_no_row_without_warnings(results_doc):
    results_doc["input_warnings"] = []
    assert 'id="input-warnings"' not in render_block(results_doc, lang="en")


def test_scenes_without_rpc_in_chinese(results_doc):
    found = scenes_without_rpc(Path(DELIVERY) / "rpc", ["M1", "M2"], {})
    results_doc["delivery"] = DELIVERY
    results_doc["input_warnings"] = [str(p) for p in found]
    (shown,) = _shown(render_block(results_doc, lang="zh"))
    assert shown == (
        "rpc：影像表中的影像 'M1', 'M2' 没有 RPC 文件，也没有连接点观测（每景影像应有 "
        "rpc/<scene_id>.<ext>）：检查时不计这些影像；blockqc adjust 亦不计这些影像，不对其作平差"
    )
