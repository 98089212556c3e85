"""What the block report says, worked out from a hand-written results.json (no PDF here)."""

from __future__ import annotations

import csv
import io
import re
import string
from html import unescape
from pathlib import Path

import pytest
from fontTools.ttLib import TTFont
from report_helpers import make_summary, summary_entry

from blockqc.report import write_block_report, write_summary_report
from blockqc.report.build import Formatter, block_context
from blockqc.report.contents import content_rows
from blockqc.report.html import FONT_FILE, render_block
from blockqc.report.messages import LANGUAGES, MESSAGES, catalogue_characters
from blockqc.results import BlockResults, RuleResult
from blockqc.rules import load_pack

# DOMAIN §2: three quality elements and the inspection contents, with their Chinese names as the
# Chinese quality-inspection method names them.
QUALITY_ELEMENTS_ZH = {"data": "数据质量", "layout": "布局质量", "attachment": "附件质量"}
ITEMS_ZH = {
    "mathematical_basis": "数学基础",
    "plane_accuracy": "平面精度",
    "height_accuracy": "高程精度",
    "edge_accuracy": "接边精度",
    "report": "报告",
    "points_distribution": "点位分布",
    "documents": "文档资料",
}
CONTENTS_ZH = {
    "coordinate_system": "坐标系统",
    "geodetic_datum": "大地基准",
    "height_datum": "高程基准",
    "projection": "地图投影",
    "cp_plane": "检查点平面精度",
    "pan_ms": "全色多光谱相对定向精度",
    "cp_height": "检查点高程精度",
    "between_blocks": "区域网间相对定向精度",
    "within_block": "区域网内相对定向精度（相邻影像）",
    "ro_report": "相对定向精度报告",
    "ao_report": "绝对定向精度报告",
    "tp_number": "连接点数量",
    "tp_distribution": "连接点分布",
    "documents": "文档资料完整性与规范性",
}
TERMS_ZH = {
    "method_high_precision": "高精度数据法",
    "method_same_accuracy": "同精度数据法",
    "method_recalculation": "其他软件重新计算法",
    "n_gross": "粗差个数",
    "gross_rate": "粗差率",
}


def test_every_command_offers_the_catalogues_languages():
    from blockqc import cli

    assert cli.LANGUAGES == LANGUAGES  # --lang of inspect, report, rfm-accuracy, adjust, factors


def test_catalogue_has_both_languages_with_the_same_placeholders():
    fields = string.Formatter()
    for key, (en, zh) in MESSAGES.items():
        assert en.strip() and zh.strip(), key
        names_en = {f for _, f, _, _ in fields.parse(en) if f}
        names_zh = {f for _, f, _, _ in fields.parse(zh) if f}
        assert names_en == names_zh, key


def _pack_titles_zh() -> dict[str, str]:
    out = {}
    for e in load_pack("global-project").elements:
        out[f"element:{e.id}"] = e.title_zh
        for i in e.items:
            out[f"item:{i.id}"] = i.title_zh
            out.update({f"content:{c.id}": c.title_zh for c in i.contents})
    return out


@pytest.mark.parametrize(
    ("kind", "table"),
    [("element", QUALITY_ELEMENTS_ZH), ("item", ITEMS_ZH), ("content", CONTENTS_ZH)],
)
def test_chinese_names_of_the_method_in_the_pack(kind, table):
    titles = _pack_titles_zh()
    assert {k.split(":")[1] for k in titles if k.startswith(kind)} == set(table)
    for key, zh in table.items():
        assert titles[f"{kind}:{key}"] == zh


def test_chinese_terms_of_the_method():
    for key, zh in TERMS_ZH.items():
        assert MESSAGES[key][1] == zh
    assert "中误差" in MESSAGES["medium_error"][1] and "最大误差" in MESSAGES["max_error"][1]


def test_packaged_font_covers_the_catalogue_and_gb2312_level_1():
    cmap = TTFont(FONT_FILE, lazy=True).getBestCmap()
    missing = [c for c in catalogue_characters() if not c.isspace() and ord(c) not in cmap]
    assert not missing, f"characters of the catalogue missing from the font: {missing}"
    level1 = [
        bytes([hi, lo]).decode("gb2312")
        for hi in range(0xB0, 0xD8)
        for lo in range(0xA1, 0xFF)
        if (hi, lo) < (0xD7, 0xFA)
    ]
    assert len(level1) == 3755
    assert all(ord(c) in cmap for c in level1)
    assert (FONT_FILE.parent / "OFL.txt").read_text().count("SIL OPEN FONT LICENSE") >= 1
    assert FONT_FILE.stat().st_size < 3_200_000


def test_every_inspection_content_is_listed_with_the_rules_deciding_it(results_doc):
    rows, others = content_rows(BlockResults.model_validate(results_doc))
    by = {r.content: r for r in rows}
    assert set(by) == set(CONTENTS_ZH) and len(rows) == len(CONTENTS_ZH)
    elements = {r.content: r.element.id for r in rows}
    assert elements["tp_distribution"] == "layout"
    assert elements["ro_report"] == elements["documents"] == "attachment"
    assert elements["projection"] == elements["within_block"] == "data"
    assert by["tp_number"].status == "fail"  # TP-4 fails on the sparse scene
    assert by["tp_distribution"].status == "fail"
    assert by["cp_plane"].status == "fail"  # CP-2 high-precision 10.4 m > 10 m
    assert by["cp_height"].status == "pass"  # CP-3 only; the plane CP-4 is not a height rule
    assert [r.rule for r in by["cp_height"].results] == ["CP-3"]
    assert by["within_block"].status == "fail"
    assert by["documents"].status == "waived"  # DOC-1 waived, DOC-3 passed by the inspector
    assert by["pan_ms"].status is None  # no RO-1 result: not checked
    assert by["coordinate_system"].status == by["geodetic_datum"].status == "pass"
    assert others == []


def _project_result(rule: str, status: str, content: list[str]) -> dict:
    return {
        "rule": rule,
        "title": "Project rule",
        "title_zh": "项目规则",
        "clause": "§X",
        "content": content,
        "status": status,
        "value": 1,
        "threshold": 0,
        "comparison": "<=",
    }


def test_results_naming_their_content_are_placed_there(results_doc):
    results_doc["results"].append(_project_result("X-9", "fail", ["pan_ms"]))
    results_doc["results"].append(_project_result("X-10", "pass", []))
    rows, others = content_rows(BlockResults.model_validate(results_doc))
    pan_ms = next(r for r in rows if r.content == "pan_ms")
    assert pan_ms.status == "fail" and [r.rule for r in pan_ms.results] == ["X-9"]
    assert [r.rule for r in others] == ["X-10"]
    zh = block_context(results_doc, "zh", figures=False)
    plane = next(i for e in zh["elements"] for i in e["items"] if i["key"] == "plane_accuracy")
    assert plane["name"] == "平面精度"
    assert [x["title"] for c in plane["contents"] for x in c["results"]][-1] == "项目规则"


def _th(comparison: str, threshold, unit: str) -> RuleResult:
    return RuleResult(
        rule="X-1",
        title="x",
        clause="§X",
        status="pass",
        comparison=comparison,
        threshold=threshold,
        unit=unit,
    )


def test_formatter_thresholds_and_groups():
    f = Formatter("en")
    assert f.threshold(_th("<=", 10.0, "m")) == "≤ 10 m"
    assert f.threshold(_th("<", 28.284271247461902, "m")) == "< 28.28 m"
    assert f.threshold(_th("between", [20.0, 50.0], "points")) == "20 … 50 points"
    # a range without its bounds (inclusive: false): 20 points fail it, so it does not read as
    # the inclusive one ("20 … 50 points" beside a failing 20)
    assert f.threshold(_th("strictly_between", [20.0, 50.0], "points")) == "20 <…< 50 points"
    z = Formatter("zh")
    assert z.group({"component": "plane", "method": "same_accuracy"}) == "平面 · 同精度数据法"
    assert z.status("fail") == "不合格" and z.verdict("pass") == "合格"
    assert z.threshold(_th(">=", 100.0, "points")) == "≥ 100 个"


def test_checkpoint_tables_put_methods_side_by_side(results_doc):
    ctx = block_context(results_doc, "en", figures=False)
    plane = next(t for t in ctx["cp_tables"] if t["key"] == "plane")
    assert plane["methods"] == ["High-precision data", "Same-accuracy data"]
    rows = dict(plane["rows"])
    assert rows["Medium error (m)"] == ["* 10.40", "* 2.10"]  # the mean replaced it (§CP-7)
    assert rows["Gross errors"] == ["3", "0"]
    assert rows["Gross-error rate"] == ["37.50 %", "0 %"]  # as the CP-4 results read them
    assert rows["Mean used"] == ["yes", "yes"]
    assert [s for s, _ in plane["statuses"]] == ["fail", "pass"]
    assert plane["agreement"][0]["agree"] is False


def test_html_escapes_scene_ids_notes_and_names(results_doc):
    html = render_block(results_doc, lang="en")
    assert "<script>alert(1)</script>" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    # the scene id reaches the failure evidence, the note the manual items, the reason the waivers
    assert "S-003&lt;script&gt;" in html
    assert "follows the template &lt;script&gt;" in html
    assert "delivered later &lt;script&gt;" in html
    assert "<script" not in html.lower().replace("&lt;script", "")


def test_block_report_sections_in_chinese(results_doc):
    html = render_block(results_doc, lang="zh")
    for text in (
        "区域网 T-B01 验收报告",
        "不合格",
        "数据质量",
        "布局质量",
        "附件质量",
        "检查点平面精度",
        "连接点数量",
        "人机交互检查项",
        "豁免与例外",
        "不合格项及其依据",
        "高精度数据法",
        "同精度数据法",
        "粗差率",
    ):
        assert text in html, text
    assert '<html lang="zh-CN">' in html
    assert html.count("<svg") >= 6  # residuals, counts, footprints, 2 error plots, vectors, map


def test_block_files_and_csv_exports(tmp_path, results_doc):
    written = write_block_report(tmp_path / "T-B01", results_doc, pdf=False)
    assert sorted(p.name for p in written) == ["checkpoints.csv", "evidence.csv", "report.html"]
    text = (tmp_path / "T-B01" / "checkpoints.csv").read_text(encoding="utf-8-sig")
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == 16  # 8 high-precision plane, 4 same-accuracy plane, 4 height
    gross = [r["point_id"] for r in rows if r["gross"] == "true"]
    assert gross == ["C05", "C06", "C07"]  # 21, 25 and 30 m beyond 2·10 m
    ev = list(
        csv.DictReader(
            io.StringIO((tmp_path / "T-B01" / "evidence.csv").read_text(encoding="utf-8-sig"))
        )
    )
    by_rule = {}
    for r in ev:
        by_rule.setdefault(r["rule"], []).append(r)
    assert [r["point_id"] for r in by_rule["RO-3"]] == ["O7", "O9"]  # worst first
    assert by_rule["TP-4"][0]["scene_id"] == "S-003<script>alert(1)</script>"
    assert {r["status"] for r in by_rule["DOC-1"]} == {"waived"}
    assert (
        "CP-2" in by_rule and by_rule["CP-2"][0]["group"] == "component=plane;method=high_precision"
    )


def test_user_templates_take_precedence(tmp_path, results_doc):
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "base.css.j2").write_text("body { color: #123456; }\n", encoding="utf-8")
    write_block_report(tmp_path / "out", results_doc, templates=mine, pdf=False)
    html = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "#123456" in html and "--accent" not in html


def test_summary_lists_sampled_blocks_and_links(tmp_path, results_doc):
    from blockqc.report import checkpoint_rows

    cps = checkpoint_rows(BlockResults.model_validate(results_doc))
    counts = dict.fromkeys(("pass", "fail", "warn", "waived", "manual", "not_applicable"), 0)
    summary = make_summary(
        [
            summary_entry("T-B01", "fail", sampled=True, failed_rules=["CP-2", "TP-4"],
                          checkpoints=cps),
            summary_entry("T-B02", "pass", pending_manual=["DOC-3"]),
        ],
        {"CP-2": {**counts, "pass": 1, "fail": 1, "error": 0}},
    )  # fmt: skip
    written = write_summary_report(tmp_path, summary, pdf=False)
    assert [p.name for p in written] == ["summary.html", "summary.csv", "summary.parquet"]
    html = written[0].read_text(encoding="utf-8")
    assert 'href="T-B01/report.html"' in html and 'href="T-B02/report.html"' in html
    sampled = html[html.index('id="sampled-table"') : html.index('id="rules"')]
    assert sampled.count("<tr>") == 1 + 3  # heading + plane hp, plane sa, height sa of T-B01
    assert "T-B02" not in sampled
    assert not re.search(r"<(script|link)[^>]+src=|https?://", html)  # no network


def test_unknown_language_is_refused(tmp_path, results_doc):
    with pytest.raises(ValueError, match="en, zh"):
        write_block_report(Path(tmp_path), results_doc, lang="fr", pdf=False)


def test_figures_carry_no_input_text_as_markup(results_doc):
    """Labels in the figures are SVG text, escaped: an id is shown, never parsed as markup."""
    sneaky = "S-9--><script>alert(2)</script>"
    results_doc["scenes"][0]["scene_id"] = sneaky
    results_doc["results"][6]["evidence"][0]["scene_a"] = sneaky  # RO-3: the map marks it
    html = render_block(results_doc, lang="en")
    assert "<script>alert(2)</script>" not in html
    assert "<!--" not in html
    figures = block_context(results_doc, "en")["figures"]["general"]
    # the label is cut (with an ellipsis) to its footprint's width: its escaped start is shown
    labelled = [svg for svg in figures if ">S-9--&gt;&lt;script&gt;" in svg]
    assert labelled, "the failing scene is named on the footprint map"
    assert all("<script>" not in svg and "-->" not in svg for svg in labelled)


def test_failing_scenes_get_a_distribution_map(results_doc):
    maps = block_context(results_doc, "en")["figures"]["scene_maps"]
    assert [m["scene"] for m in maps] == ["S-003<script>alert(1)</script>"]
    assert maps[0]["svg"].startswith("<svg") and "40 points shown" in maps[0]["caption"]
    distribution = next(
        m for m in results_doc["measurements"] if m["metric"] == "tie_point_distribution"
    )
    distribution["failing_scene_points"] = None
    maps = block_context(results_doc, "en")["figures"]["scene_maps"]
    assert maps[0]["svg"] is None and "not in results.json" in maps[0]["caption"]


def test_scenes_failing_beyond_the_evidence_shown_are_marked_on_the_scene_figures(results_doc):
    """TP-4 failing on 199 of 200 scenes keeps the 50 worst as evidence; the other failing scenes
    were drawn as passing (plain bars, green footprints). Here TP-4 keeps one of two failing
    scenes (S-002 with 60 points, under 100, cut from the evidence): both are marked failing,
    the exempt sea scene and a waived scene are not, a scene at the minimum (100) passes (the
    statuses of TP-4 alone, as the tie points per scene figure takes them)."""
    from blockqc.report.figures import scene_statuses

    distribution = next(
        m for m in results_doc["measurements"] if m["metric"] == "tie_point_distribution"
    )
    scene_table = distribution["tables"]["scene"]
    scene_table[1]["n_points"] = 60  # S-002
    scene_table += [
        {"scene_id": "S-WAIVED", "n_points": 70, "coverage": 1.0, "exempt": False},
        {"scene_id": "S-EDGE", "n_points": 100, "coverage": 1.0, "exempt": False},
    ]
    tp4 = next(r for r in results_doc["results"] if r["rule"] == "TP-4")
    tp4["statistic"] = "n_points"  # as the engine writes it
    tp4["detail"].update({"n_offending": 3, "evidence_truncated": 1, "waived": ["S-WAIVED"]})
    results = BlockResults.model_validate(results_doc)
    statuses = scene_statuses(results, [r for r in results.results if r.rule == "TP-4"])
    bad = "S-003<script>alert(1)</script>"
    assert statuses[bad] == "fail" and statuses["S-002"] == "fail"
    assert statuses["S-SEA"] == "exempt" and statuses["S-WAIVED"] == "waived"
    assert "S-EDGE" not in statuses and "S-001" not in statuses
    # without a cut, the evidence is the whole list: nothing is added from the table
    del tp4["detail"]["evidence_truncated"]
    results = BlockResults.model_validate(results_doc)
    assert "S-002" not in scene_statuses(results, [r for r in results.results if r.rule == "TP-4"])


def test_the_scene_maps_note_counts_the_failing_scenes_beyond_the_evidence(results_doc):
    """The maps note counted the scenes of the evidence kept: 'The first 24 of 55 failing scenes
    are drawn' of a block where 199 scenes fail TP-4 (50 kept); it counts every failing scene,
    and says so when fewer maps than that are drawn. Here TP-4 keeps S-003 of two failing
    scenes (S-002, 60 points, cut from the evidence): one map of two failing scenes."""
    distribution = next(
        m for m in results_doc["measurements"] if m["metric"] == "tie_point_distribution"
    )
    distribution["tables"]["scene"][1]["n_points"] = 60  # S-002
    tp4 = next(r for r in results_doc["results"] if r["rule"] == "TP-4")
    tp4["statistic"] = "n_points"  # as the engine writes it
    tp4["detail"].update({"n_offending": 2, "evidence_truncated": 1})
    figures = block_context(results_doc, "en")["figures"]
    assert [m["scene"] for m in figures["scene_maps"]] == ["S-003<script>alert(1)</script>"]
    assert "The first 1 of 2 failing scenes are drawn." in figures["general_notes"]


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_a_value_just_past_its_threshold_does_not_read_as_the_threshold(tmp_path, lang):
    """RC-1 failing by 0.0004 px (worst difference 0.1004 px against ≤ 0.1 px) read 'Value: 0.100
    px; Threshold: ≤ 0.1 px' beside its red 'fail'; it shows 0.1004 px wherever the rule is."""
    from report_helpers import make_results

    results = make_results()
    rc1 = {
        "rule": "RC-1", "title": "Delivered tie-point residuals reproduce", "clause": "§RC-1",
        "quality_element": "attachment", "status": "fail", "statistic": "difference_px",
        "value": 0.1004, "threshold": 0.1, "comparison": "<=", "unit": "px",
        "severity": "fail", "detail": {"n_units": 120, "n_offending": 1},
    }  # fmt: skip
    results["results"].append(rc1)
    write_block_report(tmp_path / "T-B01", results, lang=lang, pdf=False)
    page = (tmp_path / "T-B01" / "report.html").read_text()
    unit = "px" if lang == "en" else "像素"
    rows = re.findall(r"RC-1.*?</tr>|RC-1 — .*?</p>", page, re.S)
    assert len(rows) >= 3  # failed items on page 1, the rule tables, the failure itself
    for row in rows:
        assert f"0.1004 {unit}" in row and f"0.100 {unit}" not in row


def _near(value: float, threshold: float, comparison: str) -> RuleResult:
    return RuleResult(
        rule="RO-4", title="x", clause="§RO-3", status="pass", value=value,
        threshold=threshold, comparison=comparison, unit="m",
    )  # fmt: skip


def test_a_value_beside_a_bound_of_more_decimals_compares_with_it_as_shown():
    """RO-4's plane bound √2·10 m = 14.14214 m and RO-3's height bound 2√2·6 m = 16.97056 m are
    shown to two decimals: an RMS of 14.1425 m (fail) read '14.14 m, ≤ 14.14 m' and a single
    16.9702 m (pass) '16.97 m, < 16.97 m'. Value and bound now take the decimals that set them
    apart, in the order they have; away from the bound both read as before."""
    f = Formatter("en")
    root2 = 2**0.5
    over = _near(14.1425, root2 * 10, "<=")  # 14.1425 > 14.14214: fails
    assert (f.value(over), f.threshold(over)) == ("14.143 m", "≤ 14.142 m")
    under = _near(16.9702, 2 * root2 * 6, "<")  # 16.9702 < 16.97056: passes
    assert (f.value(under), f.threshold(under)) == ("16.970 m", "< 16.971 m")
    on = _near(2 * root2 * 10, 2 * root2 * 10, "<")  # on the strict bound: fails, reads equal
    assert (f.value(on), f.threshold(on)) == ("28.28 m", "< 28.28 m")
    far = _near(11.59, root2 * 10, "<=")
    assert (f.value(far), f.threshold(far)) == ("11.59 m", "≤ 14.14 m")
    third = _near(0.3332, 1 / 3, "<=")  # 0.333 against 0.33 read as above a bound it is under
    assert (f.value(third), f.threshold(third)) == ("0.3332 m", "≤ 0.3333 m")
    on = _near(root2 * 10 * (1 + 5e-10), root2 * 10, "<=")  # judged on the bound: reads so
    assert (f.value(on), f.threshold(on)) == ("14.14 m", "≤ 14.14 m")


@pytest.mark.parametrize("lang", ["en", "zh"])
@pytest.mark.parametrize("statistic", ["median", "rms"])
def test_the_other_tie_point_statistic_is_shown_beside_the_one_judged(tmp_path, lang, statistic):
    """§TP-1: the stock TP-1 judges the median of the tie-point errors and the RMS (中误差) is
    always reported beside it; results.json kept it in TP-1's detail, but no page showed it.
    Under TP-1's title, in every table of results, the other statistic now reads as the detail
    gives it (median 0.332 px judged: RMS 0.412 px; a pack judging the RMS: median 0.332 px)."""
    from report_helpers import make_results

    results = make_results()
    tp1 = next(r for r in results["results"] if r["rule"] == "TP-1")
    other = "rms" if statistic == "median" else "median"
    tp1.update(
        statistic=statistic, measurement="tie_point_errors",
        value={"median": 0.332, "rms": 0.412}[statistic],
        detail={"n": 1378, other: {"median": 0.332, "rms": 0.412}[other]},
    )  # fmt: skip
    write_block_report(tmp_path / "T-B01", results, lang=lang, pdf=False)
    page = (tmp_path / "T-B01" / "report.html").read_text()
    beside = {
        ("en", "rms"): "RMS (medium error) 0.412 px",
        ("zh", "rms"): "中误差（均方根）0.412 像素",
        ("en", "median"): "Median 0.332 px",
        ("zh", "median"): "中位数 0.332 像素",
    }[lang, other]
    rows = re.findall(r'<tr><td class="id">TP-1</td><td>.*?</tr>', page, re.S)  # with title
    assert rows and all(beside in row for row in rows)


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_the_summary_says_how_many_of_the_failing_blocks_are_in_error(tmp_path, lang):
    """summary.json counts a block in error (a rule it could not judge) among those that fail;
    its page read '3 blocks: 1 pass, 2 fail, 0 unreadable' beside a table of one FAIL and one
    ERROR block. It now says that one of the two is in error, and nothing more when none is."""
    entries = [
        summary_entry("T-B01", "pass"),
        summary_entry("T-B02", "fail", failed_rules=["TP-4"]),
        summary_entry("T-B03", "error", failed_rules=["RO-1"]),
    ]
    summary = make_summary(entries)
    summary["counts"]["error"] = 1
    page = write_summary_report(tmp_path / "one", summary, lang=lang, pdf=False)[0].read_text()
    said = {
        "en": "3 blocks: 1 pass, 2 fail (of which 1 ERROR: a rule could not be judged), "
        "0 unreadable",
        "zh": "区域网 3 个：合格 1，不合格 2（其中“错误”1 个：有规则无法判定），无法读取 0",
    }[lang]
    assert said in unescape(page)
    none = write_summary_report(tmp_path / "none", make_summary(entries[:2]), lang=lang, pdf=False)
    assert {"en": "ERROR: a rule", "zh": "有规则无法判定"}[lang] not in none[0].read_text()


def test_an_accuracy_beside_its_norm_reads_in_the_order_it_has():
    """§QE-3's line 'm/m0 → score' showed RO-4's plane RMS of 14.1425 m, beyond its norm
    √2·10 = 14.14214 m (an A-class error), as '14.14/14.14 → A'; both now take the decimals
    that set them apart (14.143/14.142), and read as before away from the norm."""
    from blockqc.acceptance.model import AccuracyRecord, ItemScore
    from blockqc.report.acceptance import _part

    def line(value: float, norm: float, score: float | None) -> str:
        record = AccuracyRecord(rule="RO-4", value=value, norm=norm, score=score)
        item = ItemScore(id="edge_accuracy", weight=0.2, inspected=True, accuracy=[record])
        return _part(item, Formatter("en"), level="item")["accuracy"]

    assert line(14.1425, 2**0.5 * 10, None) == "RO-4: 14.143/14.142 → A"
    assert line(11.59, 2**0.5 * 10, 70.31) == "RO-4: 11.59/14.14 → 70.3"


def test_gross_error_rate_reads_alike_in_the_tables_and_its_rule(results_doc):
    """The statistical table and the summary's sampled blocks showed a gross-error rate of
    '37.5 %' where the CP-4 result beside it read '37.50 %' (and '0.0 %' beside '0 %'): they
    now show it as the result does."""
    from report_helpers import results_entry

    from blockqc.report.build import summary_context

    ctx = block_context(results_doc, "en", figures=False)
    plane = next(t for t in ctx["cp_tables"] if t["key"] == "plane")
    assert dict(plane["rows"])["Gross-error rate"][0] == "37.50 %"
    cp4 = next(r for r in ctx["detailed"] if r["rule"] == "CP-4")
    assert cp4["value"] == "37.50 %"
    sampled = summary_context(make_summary([results_entry(results_doc)]), "en")["sampled"]
    assert [r["gross_rate"] for r in sampled][:2] == ["37.50 %", "0 %"]


def _figure_texts(doc: dict, figure: str, pattern: str) -> list[str]:
    """The texts matching `pattern` in the block page's general figure `figure` (its SVG id)."""
    import re

    figures = block_context(doc, "en")["figures"]
    (svg,) = [x for x in figures["general"] if figure in x]
    return re.findall(pattern, svg)


def _counts_legend(doc: dict) -> list[str]:
    return _figure_texts(doc, "tp-counts", r"minimum [^<]*")


@pytest.mark.parametrize(
    ("threshold", "comparison", "drawn"),
    [
        (100.0, ">=", ["minimum 100"]),
        ([80.0, 5000.0], "between", ["minimum 80"]),  # a range: its lower bound
        (5000.0, "<=", []),  # a maximum alone is no minimum
        (121.0, "equals", []),
    ],
)
def test_the_scene_counts_draw_the_rules_lower_bound_only(
    results_doc, threshold, comparison, drawn
) -> None:
    """A TP-4 judged by a range (min 80, max 5000) lost its minimum line on the per-scene
    counts, and one judged by a maximum alone had that maximum drawn as 'minimum 5000'."""
    tp4 = next(r for r in results_doc["results"] if r["rule"] == "TP-4")
    tp4.update(threshold=threshold, comparison=comparison)
    assert _counts_legend(results_doc) == drawn


def _histogram_marks(doc: dict) -> list[str]:
    return _figure_texts(doc, "tp-hist", r">([0-9.]+) px<")


@pytest.mark.parametrize(
    ("threshold", "comparison", "drawn"),
    [
        ([0.2, 0.8], "between", ["0.2", "0.8"]),  # {min: 0.2, max: 0.8}: both bounds
        ([0.25, 0.75], "strictly_between", ["0.25", "0.75"]),
        (0.8, "<=", ["0.8"]),
        (0.2, ">", ["0.2"]),
    ],
)
def test_the_residual_histogram_marks_every_bound_of_a_hinted_rule(
    results_doc, threshold, comparison, drawn
) -> None:
    """A TP-1 judged by a range (min 0.2, max 0.8 px) drew no mark on the residual histogram,
    its two bounds read as no number; each is marked as a single bound is. The measurement's
    own interval marks (1 and 1.5 px) are drawn beside them."""
    tp1 = next(r for r in results_doc["results"] if r["rule"] == "TP-1")
    assert "residual_histogram" in tp1["figures"]
    tp1.update(threshold=threshold, comparison=comparison)
    assert _histogram_marks(results_doc) == [*drawn, "1", "1.5"]
