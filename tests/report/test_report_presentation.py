"""Presentation for people: long ids wrap inside the page, evidence columns carry labels and
units, block-level failures show what was measured, conditional passes and fixed phrases read in
the page's language, the §CP-7 note only where the medium error is judged."""

from __future__ import annotations

import copy
import re
import subprocess

import pytest
from report_helpers import make_results, make_summary, require_chromium, require_tool, summary_entry

from blockqc.metrics import REGISTRY
from blockqc.report import write_block_report, write_summary_report
from blockqc.report.build import block_context, summary_context
from blockqc.report.format import Formatter
from blockqc.report.html import environment, render_block

LONG = "C01-" + "P" * 90


def _with_long_point_ids(doc: dict) -> dict:
    doc = copy.deepcopy(doc)
    for m in doc["measurements"]:
        for row in m["tables"].get("point", []):
            if str(row.get("point_id", "")).startswith("C"):
                row["point_id"] = f"{row['point_id']}-{'P' * 90}"
    return doc


def _result(doc: dict, rule: str, **where) -> dict:
    return next(
        r
        for r in doc["results"]
        if r["rule"] == rule and all(r["group"].get(k) == v for k, v in where.items())
    )


def _text(html: str) -> str:
    html = re.sub(r"<(style|script|svg)\b.*?</\1>", " ", html, flags=re.S)
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))


# ------------------------------------------------------------------------- 1 long ids
def test_css_wraps_long_ids_and_keeps_headings_whole():
    css = environment().get_template("base.css.j2").render(font_url="")
    assert re.search(r"td\.ident[^{]*\{[^}]*overflow-wrap: anywhere", css)
    assert re.search(r"figcaption[^{]*\{[^}]*overflow-wrap: anywhere", css)
    assert re.search(r"\bth \{ overflow-wrap: normal", css)
    assert re.search(r"td\.grp \{[^}]*min-width", css)


@pytest.mark.parametrize("engine", ["weasyprint", "chromium"])
def test_checkpoint_table_with_long_ids_fits_the_page(tmp_path, engine):
    """The last columns (Tolerance, Gross) are on the page, at full scale (Chromium would shrink
    the whole document to fit a table wider than the page)."""
    require_tool("pdftotext")
    if engine == "chromium":
        require_chromium()
    folder = tmp_path / "T-B01"
    write_block_report(folder, _with_long_point_ids(make_results()), pdf_engine=engine)
    words = subprocess.run(
        ["pdftotext", "-bbox", str(folder / "report.pdf"), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    boxes = [
        [float(v) for v in m.groups()]
        for m in re.finditer(
            r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" yMax="([\d.]+)">Gross</word>',
            words,
        )
    ]
    assert boxes, "the last column's header is not in the PDF"
    x0, y0, x1, y1 = boxes[-1]
    assert x1 <= 595.3 - 14 * 72 / 25.4 + 1  # inside the right margin of an A4 page
    assert y1 - y0 > 6  # 7 pt type at full scale, not shrunk to fit
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert 'class="id ident"' in html  # the long point ids wrap


@pytest.mark.parametrize("engine", ["weasyprint", "chromium"])
def test_the_scene_maps_heading_is_printed_on_the_page_of_its_first_maps(tmp_path, engine):
    """With 12 scene maps (more than a page), WeasyPrint printed their heading alone at the foot
    of a page and the maps from the next one (a flex box it would not start below the heading);
    the heading's page now holds the first maps."""
    require_tool("pdftotext")
    if engine == "chromium":
        require_chromium()
    doc = make_results()
    tp4 = _result(doc, "TP-4")
    distribution = next(m for m in doc["measurements"] if m["metric"] == "tie_point_distribution")
    points = next(iter(distribution["failing_scene_points"].values()))
    for i in range(11):
        sid = f"S-F{i:02d}"
        tp4["evidence"].append({**tp4["evidence"][0], "scene_id": sid})
        distribution["failing_scene_points"][sid] = points
        doc["scenes"].append({**doc["scenes"][0], "scene_id": sid})
    write_block_report(tmp_path, doc, pdf_engine=engine)
    text = subprocess.run(
        ["pdftotext", "-layout", str(tmp_path / "report.pdf"), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    page = next(p for p in text.split("\f") if "Tie-point distribution of the scenes" in p)
    assert "S-F00" in page


def test_scene_map_captions_are_cut_to_their_figure():
    f = Formatter("en")
    from blockqc.report.figures import _scene_names

    names = _scene_names("GF7-" + "X" * 200)
    assert names["scene"].endswith("X") and names["scene_short"].endswith("…")
    assert len(names["scene_short"]) < 120
    assert f.ident(["short", "GF7-" + "X" * 30]) == "ident" and f.ident("C01 C02") == ""


def test_footprint_labels_are_cut_to_their_footprint():
    from blockqc.report.plots import footprints

    square = "POLYGON((40.0 39.0, 40.1 39.0, 40.1 39.1, 40.0 39.1, 40.0 39.0))"
    scenes = [{"scene_id": "S-" + "X" * 120, "footprint_wkt": square}]
    svg = footprints(scenes, {scenes[0]["scene_id"]: "fail"}, Formatter("en").t, "fp")
    assert "S-XXXX" in svg and "…" in svg and "X" * 120 not in svg


# --------------------------------------------------------- 2 evidence labels and units
@pytest.mark.parametrize(
    ("lang", "labels"),
    [
        ("en", ["Median (px)", "RMS (px)", "Observations", "Share in the interval (%)"]),
        ("zh", ["中位数（像素）", "均方根（像素）", "观测数", "区间内比例（%）"]),
    ],
)
def test_evidence_columns_have_labels_with_the_metrics_units(lang, labels):
    f = Formatter(lang)
    units = {
        k: u for s in REGISTRY["tie_point_errors"].scopes.values() for k, u in s.statistics.items()
    }
    got = [f.evidence_column(k, units) for k in ("median", "rms", "n", "share_in_interval")]
    assert got == labels
    ro = {
        k: u
        for s in REGISTRY["pan_ms_discrepancy"].scopes.values()
        for k, u in s.statistics.items()
    }
    assert f.evidence_column("rms_m", ro).endswith(("(m)", "（m）"))
    assert f.evidence_column("required", {}) in ("Required", "必需")
    assert f.evidence_column("no_such_column", units) == "no_such_column"


def test_failure_evidence_headers_are_labelled_in_the_report():
    doc = make_results()
    tp1 = _result(doc, "TP-1")
    tp1["status"] = "fail"
    tp1["evidence"] = [{"scene_id": "S1", "n": 10, "median": 0.7, "rms": 0.8, "max": 1.6}]
    failure = next(x for x in block_context(doc)["failures"] if x["rule"] == "TP-1")
    assert failure["evidence"]["headers"] == [
        "Scene",
        "Observations",
        "Median (px)",
        "RMS (px)",
        "Maximum (px)",
    ]


# --------------------------------------------------------------------- 3 MB-3 evidence
def test_wrong_zone_is_shown_with_the_stated_and_expected_zone():
    """A block at 117.5°E (zone 50) stating EPSG:32651 (zone 51)."""
    from blockqc.metrics.spatial_ref import SpatialParams, spatial_reference, zone_name

    class Sr:
        epsg, geodetic_datum, height_datum, projection = 32651, "WGS84", "ellipsoidal", "UTM"

        def zone_epsg(self):
            return None

    class Manifest:
        spatial_reference = Sr()

    class D:
        manifest = Manifest()
        import pandas as pd

        scenes = pd.DataFrame(
            {"footprint_wkt": ["POLYGON((117.4 40, 117.6 40, 117.6 40.2, 117.4 40.2, 117.4 40))"]}
        )

    block = spatial_reference(D(), SpatialParams(), None).tables["block"].df.iloc[0]
    assert (block["epsg"], block["zone"]) == (32651, "51N")
    assert (block["expected_epsg"], block["expected_zone"]) == ("32650", "50N")
    assert zone_name(32761) == "UPS S" and zone_name(4326) is None


def test_block_failure_without_evidence_shows_its_measured_row():
    doc = make_results()
    mb3 = _result(doc, "MB-3")
    mb3.update(status="fail", value=False, evidence=[])
    mb3["detail"] = {"epsg": 32651, "zone": "51N", "expected_epsg": "32650", "expected_zone": "50N"}
    text = _text(render_block(doc, lang="en"))
    section = text[text.index("6 Failures") :]
    assert "EPSG expected from the footprints" in section and "32650" in section
    assert "Zone stated" in section and "51N" in section


# ------------------------------------------------------------------ 4 conditional pass
@pytest.mark.parametrize("lang", ["en", "zh"])
def test_conditional_pass_is_named_with_its_condition(lang):
    doc = make_results()
    doc3 = _result(doc, "DOC-3")
    doc3.update(status="pass", value="conditional_pass")
    doc3["detail"] = {
        "note": "accuracy table to be added",
        "condition": "accuracy table to be added",
        "decided_by": "inspector",
    }
    text = _text(render_block(doc, lang=lang))
    name = {"en": "conditional pass", "zh": "有条件通过"}[lang]
    assert name in text and "conditional_pass" not in text
    assert {"en": "Condition: accuracy table to be added", "zh": "条件：accuracy table"}[
        lang
    ] in text


# -------------------------------------------------------------- 5 zh fixed phrases
def test_zh_report_translates_fixed_phrases_of_the_results():
    doc = make_results()
    doc3 = _result(doc, "DOC-3")
    doc3.update(status="manual", value=None, detail={"reason": "awaiting the inspector's verdict"})
    f = Formatter("zh")
    assert "等待检查员判定" in _text(render_block(doc, lang="zh"))
    assert f.text("water_fraction 0.82 ≥ 0.5 (mostly sea)") == "水域比例 0.82 ≥ 0.5（大部分为水域）"
    assert "成果中没有几何模型" in f.text(
        "no geometry in the delivery (rpc/ with adjustment.csv, or rpc_adjusted/)"
    )
    assert f.cell("pan") == "全色" and f.cell("ellipsoidal") == "椭球高"
    assert Formatter("en").text("(mostly sea)") == "(mostly sea)"


def test_zh_report_translates_the_problems_of_the_documents(tmp_path):
    """DOC-1's evidence on a zh page read 'documents/absolute_orientation.pdf does not exist';
    each problem check_document gives is shown in Chinese, the file names kept as they are."""
    from blockqc.metrics.documents import check_document

    root = tmp_path / "delivery"
    (root / "documents" / "folder.pdf").mkdir(parents=True)
    (root / "documents" / "empty.pdf").write_bytes(b"")
    (root / "documents" / "fake.pdf").write_bytes(b"not a pdf")
    (root / "documents" / "Report.PDF").write_bytes(b"%PDF-1.4")
    (root / "documents" / "latin1.txt").write_bytes("caf\xe9".encode("latin-1"))
    (root / "documents" / "gone.pdf").symlink_to(root / "documents" / "nowhere.pdf")
    expected = {
        None: "未在 block.yaml 的 documents 中列出",
        "documents/absolute_orientation.pdf": "documents/absolute_orientation.pdf 不存在",
        "documents/report.pdf": "documents/report.pdf 不存在（成果中有 documents/Report.PDF：",
        "documents/folder.pdf": "documents/folder.pdf 是文件夹，不是文档文件",
        "documents/empty.pdf": "documents/empty.pdf 是空文件",
        "documents/fake.pdf": "documents/fake.pdf 不是有效的 PDF 文件",
        "documents/latin1.txt": "documents/latin1.txt 不是 UTF-8 文本",
        "documents/gone.pdf": "documents/gone.pdf 是指向不存在文件的符号链接",
        "../outside.pdf": "../outside.pdf 指向成果之外",
    }
    f = Formatter("zh")
    for rel, shown in expected.items():
        problem = check_document(root, rel)[3]
        assert f.cell(problem).startswith(shown), problem
    assert Formatter("en").cell("a.pdf does not exist") == "a.pdf does not exist"
    # a value that is the English of another page's text (rfm-accuracy's 'given') is input
    assert [f.cell(v) for v in ("given", "affine", "factor")] == ["given", "affine", "factor"]


def test_zh_report_translates_why_a_reported_figure_is_not_recomputed():
    """The exemptions of DOC-2 on a zh page read 'cannot be recomputed: 无检查点：…', half
    English."""
    f = Formatter("zh")
    reason = (
        "cannot be recomputed: no checkpoints: the block was not sampled for detailed inspection"
    )
    assert f.text(reason) == "无法复算：无检查点：本区域网未抽为详查样本"
    assert f.text("no recomputation is defined for this figure") == "该数值未定义复算方法"
    assert (
        f.text("cannot be recomputed: nothing to recompute it from")
        == "无法复算：无可用于复算的数据"
    )


def test_zh_report_translates_the_sampling_reasons():
    """The reasons the sampling gives a checkpoint rule (not sampled by the plan; sampled
    without checkpoints; no checkpoints at all), as results.json writes them: in Chinese on a
    zh page. They are the code's own phrases, so a phrase changed there is caught here."""
    from blockqc.acceptance.plan import NO_CHECKPOINTS, NOT_SAMPLED
    from blockqc.metrics import NO_CHECKPOINTS as NO_CPS

    f = Formatter("zh")
    assert f.text(NOT_SAMPLED) == "未抽为详查样本（抽样方案）"
    assert f.text(NO_CHECKPOINTS) == "已抽为详查样本，但成果中没有检查点：详查不完整"
    assert f.text(NO_CPS) == "无检查点：本区域网未抽为详查样本"
    doc = make_results()
    cp2 = _result(doc, "CP-2")
    cp2.update(status="not_applicable", value=None, detail={"reason": NOT_SAMPLED})
    text = _text(render_block(doc, lang="zh"))
    assert "未抽为详查样本（抽样方案）" in text and NOT_SAMPLED not in text


def test_zh_summary_translates_the_unreadable_reason():
    summary = make_summary([summary_entry("T-B01", "pass")])
    summary["counts"]["unreadable"] = 1
    summary["unreadable"] = [
        {
            "path": "stress/BROKEN",
            "problems": [
                "stress/BROKEN/block.yaml: missing: every sub-folder of a batch is a delivery "
                "and needs its block.yaml (folders named '.…' are left out)"
            ],
        }
    ]
    problem = summary_context(summary, "zh", figures=False)["unreadable"][0]["problems"][0]
    assert problem.startswith("stress/BROKEN/block.yaml: 缺失：") and "every" not in problem


# ------------------------------------------------------------------------ 6 minor layout
def test_medium_error_note_only_on_medium_error_rules():
    doc = make_results()
    for r in doc["results"]:
        if r["rule"] in ("CP-2", "CP-4"):
            r["detail"]["used_mean"] = True
            r["detail"]["min_points_for_medium_error"] = 20
            r["statistic"] = "medium_error" if r["rule"] == "CP-2" else "gross_rate"
    ctx = block_context(doc, figures=False)
    note = "Fewer than 20 checkpoints"
    rows = {(x["rule"], x["group"]): x["notes"] for x in ctx["detailed"]}
    assert any(note in n for (rule, _), ns in rows.items() if rule == "CP-2" for n in ns)
    assert not any(note in n for (rule, _), ns in rows.items() if rule == "CP-4" for n in ns)


def test_summary_headings_do_not_break_inside_words(tmp_path):
    require_tool("pdftotext")
    blocks = [
        summary_entry(
            f"B{i}",
            "pass",
            sampled=True,
            checkpoints=[
                {
                    "component": "plane",
                    "method": "high_precision",
                    "n_total": 30,
                    "n": 30,
                    "medium_error": 3.0,
                    "max_error": 8.0,
                    "n_gross": 0,
                    "gross_rate": 0.0,
                    "used_mean": False,
                    "status": "pass",
                }
            ],
        )
        for i in range(3)
    ]
    write_summary_report(tmp_path, make_summary(blocks), lang="en")
    text = subprocess.run(
        ["pdftotext", "-layout", str(tmp_path / "summary.pdf"), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "Checkpoints" in text and "Component" in text
    assert "Checkpo" not in text.replace("Checkpoints", "")


def test_scores_are_shown_rounded_down_never_onto_a_grade_bound_they_miss():
    """§QE-5: excellent ≥ 90. A score of 89.962878 is graded good and must not read 90.0."""
    from blockqc.acceptance.model import BlockGrade, Evaluation
    from blockqc.report.acceptance import _block_line, evaluation_context

    f = Formatter("en")
    shown = [f.score(v) for v in (89.962878, 90.0, 74.95, 59.999, 100.0, 0.04, None)]
    assert shown == ["89.9", "90.0", "74.9", "59.9", "100.0", "0.0", "–"]
    assert f.score(None, "A") == "A"
    line = _block_line(BlockGrade(block_id="B1", sampled=True, score=89.962878, grade="good"), f)
    assert line["score"] == "89.9" and line["grade_text"] == "Good"
    ev = Evaluation(score=89.962878, grade="good")
    assert evaluation_context(ev, f)["score"] == "89.9"


def test_batch_shares_are_shown_rounded_down_never_onto_a_bound_they_miss():
    """§QE-5: excellent needs ≥ 90 % good or better. 403 of 448 sampled units good or better is
    89.955 %: graded good, the share read "90.0 %" beside it; it reads 89.9 %."""
    from blockqc.acceptance.decision import batch_grade
    from blockqc.acceptance.model import BatchDecision
    from blockqc.report.acceptance import decision_context
    from blockqc.results import Summary
    from blockqc.rules import load_pack

    acc = load_pack("global-project").acceptance
    grades = ["excellent"] * 224 + ["good"] * 179 + ["pass"] * 45
    grade, better, top = batch_grade(acc, grades)
    assert (grade, better, top) == ("good", pytest.approx(100 * 403 / 448), 50.0)
    d = BatchDecision(
        sample_source="plan", decision="pass", batch_grade=grade, better_pct=better, top_pct=top
    )
    shown = decision_context(Summary.model_construct(acceptance=d, blocks=[]), Formatter("en"))
    assert shown["batch_grade"] == "Good"
    assert shown["shares"] == "89.9 % good or better, 50.0 % excellent"


@pytest.mark.parametrize(
    "reason",
    [
        "no high_precision checkpoints",
        "no same_accuracy checkpoints",
        "no checkpoints of the methods high_precision, same_accuracy",
        "no PAN–MS registration table (pan_ms.csv) in the delivery",
        "no overlaps table (overlaps.csv) in the delivery",
        "no edges table (edges.csv) in the delivery",
        "block.yaml states no reported figures",
        "no scenes of the bands checked",
        "the delivery gives no residuals: blockqc computed them (§RC-1)",
        "rpc/ is given but not the producer's adjustment (adjustment.csv or rpc_adjusted/)",
        "no tie-point observations on the scenes checked (bands pan; 12 on scenes of other "
        "bands, not judged)",
        "no tie point is seen on two or more scenes (305 observations of single-ray points)",
        "nothing measured for this group",
        "overlaps.csv: no dz_m column, so no height discrepancies are given",
        "edges.csv: dz_m empty in every row, so no height discrepancies are given",
        "the discrepancies derived from the geometry are plane only (§RC-2)",
        "ref_z_m empty on all these checkpoints (plane-only references), so no height error",
        "ref_x_m and ref_y_m empty on all these checkpoints (height-only references), so no "
        "plane error",
        "awaiting the inspector's verdict on DOC-3",
    ],
)
def test_not_applicable_reasons_and_notes_read_in_chinese_on_zh_pages(reason):
    """docs/report.md: the reasons of results.json (English there) are translated when a page
    is rendered; what is left is names (files, folders, bands, rules, methods' ids none)."""
    zh = Formatter("zh").text(reason)
    words = re.findall(r"[A-Za-z_]{3,}", zh)
    names = {"pan_ms", "csv", "overlaps", "edges", "block", "yaml", "blockqc", "rpc", "adjustment",
             "rpc_adjusted", "pan", "DOC", "dz_m", "ref_z_m", "ref_x_m", "ref_y_m"}  # fmt: skip
    assert set(words) <= names, (reason, zh)
    assert Formatter("en").text(reason) == reason


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_quality_evaluation_errors_show_units_and_comparison(lang):
    """§QE: the table of errors by class shows each value and threshold as its rule does, with
    unit and comparison; '37.50' against '5' left the reader to guess a share or metres."""
    from blockqc.acceptance.model import ErrorRecord, Evaluation

    doc = make_results()
    errors = [
        ErrorRecord(rule=r["rule"], error_class="A", group=r["group"], value=r["value"],
                    threshold=r["threshold"], reason="fails its threshold")
        for r in (_result(doc, "CP-4", method="high_precision"), _result(doc, "RO-3"))
    ]  # fmt: skip
    doc["evaluation"] = Evaluation(score=40.0, grade="fail", fails=True).model_dump()
    doc["evaluation"]["elements"] = [
        {"id": "data", "title": "Data quality", "weight": 1.0, "inspected": True, "score": 0.0,
         "items": [{"id": "plane_accuracy", "title": "Plane accuracy", "weight": 1.0,
                    "inspected": True, "score": 0.0,
                    "errors": [e.model_dump() for e in errors]}]}
    ]  # fmt: skip
    rows = block_context(doc, lang, figures=False)["evaluation"]["errors"]
    assert [(x["rule"], x["value"], x["threshold"]) for x in rows] == [
        ("CP-4", "37.50 %", "< 5 %"),
        ("RO-3", "38.98 m", "< 28.28 m"),
    ]


@pytest.mark.parametrize(("lang", "grid"), [("en", "4×4 grid"), ("zh", "4×4 格网")])
def test_scene_map_caption_names_the_grid_of_the_pack(lang, grid):
    """A pack judging TP-5 on a 4×4 grid: the scene maps draw it and their captions say so
    (they said 3×3 whatever the grid)."""
    doc = make_results()
    m = next(x for x in doc["measurements"] if x["metric"] == "tie_point_distribution")
    m["detail"]["grid"] = 4
    maps = block_context(doc, lang)["figures"]["scene_maps"]
    assert maps and all(grid in x["caption"] and "3×3" not in x["caption"] for x in maps)


@pytest.mark.parametrize(
    ("lang", "stop"), [("en", "&gt;. 40 points"), ("zh", "&gt; 的连接点分布。显示")]
)
def test_scene_map_caption_is_punctuated_in_the_page_language(lang, stop):
    """A zh caption's sentences end with '。', not an English full stop and space."""
    from blockqc.results import BlockResults

    page = render_block(BlockResults.model_validate(make_results()), lang=lang)
    captions = re.findall(r"<figcaption[^>]*>(.*?)</figcaption>", page, re.S)
    scene = [c for c in captions if "TP-5" in c]
    assert scene and all(stop in c for c in scene), scene
    assert lang == "en" or not any(". " in c for c in scene)


def test_scene_maps_capped_note_stands_under_the_scene_maps():
    """With more failing scenes than maps drawn, the note saying so stands under the scene maps
    (general inspection), not under the checkpoints of the detailed inspection."""
    from blockqc.report.figures import MAX_SCENE_MAPS
    from blockqc.results import BlockResults

    doc = make_results()
    tp5 = _result(doc, "TP-5")
    row = tp5["evidence"][0]
    tp5["evidence"] = [{**row, "scene_id": f"S-{i:03d}"} for i in range(MAX_SCENE_MAPS + 2)]
    page = render_block(BlockResults.model_validate(doc), lang="en")
    general = page[page.index('<section id="general">') : page.index('<section id="detailed">')]
    note = f"The first {MAX_SCENE_MAPS} of "  # TP-5's failing scenes and TP-4's
    assert note in general and page.count(note) == 1


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_maps_results_do_not_keep_are_said_to_be_left_out(lang):
    """A block of more than 500 scenes keeps no residual cells and a large overlap table is not
    kept in results.json: the report says which maps are not drawn and why, rather than
    leaving them out unsaid."""
    from blockqc.metrics.tiepoints import MAX_SCENES_FOR_CELLS

    doc = make_results()
    n = MAX_SCENES_FOR_CELLS + 1
    doc["scenes"] = [{**doc["scenes"][0], "scene_id": f"S-{i:04d}"} for i in range(n)]
    doc["measurements"].append(
        {"key": "overlap_discrepancy", "metric": "overlap_discrepancy", "params": {},
         "detail": {}, "tables": {}, "rows": {"point": 30400, "pair": 1520}}
    )  # fmt: skip
    notes = block_context(doc, lang)["figures"]["general_notes"]
    assert len(notes) == 2
    assert str(n) in notes[0] and str(MAX_SCENES_FOR_CELLS) in notes[0]
    assert "30400" in notes[1]
    kept = block_context(make_results(), lang)["figures"]["general_notes"]
    assert kept == []  # a small block: nothing left out, nothing said


@pytest.mark.parametrize(
    ("note", "zh"),
    [
        (
            "the block straddles a zone edge (lon 119.800…120.300); EPSG:32650 (UTM zone 50N) "
            "is one of the neighbours allowed",
            "区域网跨越投影带边界（经度 119.800…120.300）；EPSG:32650 (UTM zone 50N) "
            "为允许的相邻投影带之一",
        ),
        (
            "EPSG:32651 (UTM zone 51N) delivered, expected EPSG:32650 (UTM zone 50N)",
            "所交为 EPSG:32651 (UTM zone 51N)，应为 EPSG:32650 (UTM zone 50N)",
        ),
        (
            "projection 'Gauss-Kruger' stated beside EPSG:32650 (UTM zone 50N): expected UTM",
            "所述投影“Gauss-Kruger”与 EPSG:32650 (UTM zone 50N) 不符：应为 UTM",
        ),
    ],
)
def test_the_mb3_note_reads_in_chinese_on_zh_pages(note, zh):
    """§MB-3: MB-3's note (the zone edge straddled, the zone expected, the projection named
    beside the code) is in the page's language, as its rule row shows it; an inspector's own
    note is shown as written."""
    doc = make_results()
    mb3 = _result(doc, "MB-3")
    mb3["detail"]["note"] = note
    rows = {x["rule"]: x for x in block_context(doc, lang="zh", figures=False)["general"]}
    assert zh in rows["MB-3"]["notes"]
    doc3 = _result(doc, "DOC-3")
    doc3.update(status="pass", detail={"note": "stated", "decided_by": "inspector"})
    ctx = block_context(doc, lang="zh", figures=False)
    assert {x["rule"]: x for x in ctx["manual"]}["DOC-3"]["note"] == "stated"
    assert "stated" in {x["rule"]: x for x in ctx["general"]}["DOC-3"]["notes"]
    # another note of blockqc's that reads as another page's text is not taken for it
    mb3["detail"]["note"] = "stated"
    rows = {x["rule"]: x for x in block_context(doc, lang="zh", figures=False)["general"]}
    assert "stated" in rows["MB-3"]["notes"]


def _pages(pdf) -> list[list[tuple[float, float, float, float, str]]]:
    """The words of each page of a PDF with their boxes (x0, y0, x1, y1, word)."""
    out = subprocess.run(
        ["pdftotext", "-bbox", str(pdf), "-"], capture_output=True, text=True, check=True
    ).stdout
    box = r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" yMax="([\d.]+)">([^<]*)</word>'
    return [
        [(*map(float, m.groups()[:4]), m.group(5)) for m in re.finditer(box, page)]
        for page in out.split("<page ")[1:]
    ]


def _overlaps(words: list[tuple[float, float, float, float, str]]) -> list[str]:
    """The words of one line that run over the next one on it."""
    found = []
    for a in words:
        for b in words:
            same_line = abs(a[1] - b[1]) < 1 and a[0] < b[0]
            if same_line and a[2] > b[0] + 0.5:
                found.append(f"{a[4]} over {b[4]}")
    return found


@pytest.mark.parametrize("engine", ["weasyprint", "chromium"])
def test_contents_value_and_threshold_with_a_long_unit_do_not_overlap(tmp_path, engine):
    """TP-5's '0.222 share of cells' ran over its threshold '≥ 1 share of cells' in the narrow
    columns of the inspection contents ('0.222 share of cells≥ 1 share of cells'): it now wraps
    inside its column."""
    require_tool("pdftotext")
    if engine == "chromium":
        require_chromium()
    write_block_report(tmp_path, make_results(), pdf_engine=engine)
    pages = _pages(tmp_path / "report.pdf")
    words = [w for page in pages if any(w[4] == "Layout" for w in page) for w in page]
    assert any(w[4] == "0.222" for w in words)
    assert _overlaps(words) == []


def test_zh_pages_join_lists_with_the_enumeration_comma():
    """Chinese pages listed rules, blocks and checkpoint criteria with the English comma
    ('CP-2, CP-4, RO-3' in summary.html, '（F1-B01, F2-B01）' in the sample's sentence,
    '中误差（m）, 粗差率'): they now use the enumeration comma, as the acceptance report's
    reasons do."""
    from blockqc.report.acceptance import id_list

    line = summary_entry("T-B01", "fail", failed_rules=["CP-2", "CP-4"], warned_rules=["CP-5"])
    line["pending_manual"] = ["DOC-3", "DOC-4"]
    zh = summary_context(make_summary([line]), "zh", figures=False)["blocks"][0]
    assert (zh["failed"], zh["warned"], zh["pending"]) == ("CP-2、CP-4", "CP-5", "DOC-3、DOC-4")
    en = summary_context(make_summary([line]), "en", figures=False)["blocks"][0]
    assert en["failed"] == "CP-2, CP-4"
    assert id_list(["F1-B01", "F2-B01"], sep=Formatter("zh").list_sep) == "F1-B01、F2-B01"
    doc = make_results()
    doc["pending_manual"] = ["DOC-3", "DOC-4"]
    ctx = block_context(doc, "zh", figures=False)
    assert ctx["pending"] == "DOC-3、DOC-4"
    plane = next(t for t in ctx["cp_tables"] if t["key"] == "plane")
    assert plane["agreement"][0]["errors"] == "10.40、2.10"


def test_zh_pages_punctuate_labels_and_notes_full_width():
    """Chinese pages wrote English colons, semicolons and brackets in their sentences: 'CP-2
    平面 · 高精度数据法: 3.33/10.00 → 98.1; …', 'A: 1 · B: 2', '均方根 dx (m)', '差值（m） 8.30:',
    '(评价不完整)', '不合格的样本单位 (1)', '表格文件:'. They now use the full-width ones."""
    from blockqc.acceptance.model import Evaluation
    from blockqc.report.acceptance import evaluation_context
    from blockqc.report.html import render_page

    ev = Evaluation(score=82.0, grade="good", fails=False, complete=False, counts={"A": 0, "B": 1})
    ev = ev.model_dump()
    ev["elements"] = [
        {"id": "data", "title": "Data quality", "weight": 1.0, "inspected": True, "score": 82.0,
         "items": [{"id": "plane_accuracy", "title": "Plane accuracy", "weight": 1.0,
                    "inspected": True, "score": 82.0, "accuracy": [
                        {"rule": "CP-2", "group": {"component": "plane"}, "value": 3.33,
                         "norm": 10.0, "score": 98.1},
                        {"rule": "CP-3", "group": {"component": "height"}, "value": 2.69,
                         "norm": 6.0, "score": 91.5}]}]}
    ]  # fmt: skip
    zh = evaluation_context(Evaluation.model_validate(ev), Formatter("zh"))
    assert zh["counts"] == "A：0 · B：1 · C：0 · D：0"
    assert zh["rows"][1]["accuracy"] == "CP-2 平面：3.33/10.00 → 98.1；CP-3 高程：2.69/6.00 → 91.5"
    en = evaluation_context(Evaluation.model_validate(ev), Formatter("en"))
    assert (
        en["rows"][1]["accuracy"] == "CP-2 Plane: 3.33/10.00 → 98.1; CP-3 Height: 2.69/6.00 → 91.5"
    )
    doc = make_results()
    doc["evaluation"] = ev
    text = _text(render_block(doc, lang="zh"))
    assert "均方根 dx（m）" in text and "（评价尚不完整）" in text
    assert "— 10.40、2.10 m；差值（m） 8.30：" in text
    line = summary_entry("T-B01", "fail", failed_rules=["CP-2"])
    page = _text(render_page("summary.html.j2", summary_context(make_summary([line]), "zh")))
    assert "表格文件：" in page
