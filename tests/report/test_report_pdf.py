"""The PDF, by either engine: its text holds the block, the verdict and the Chinese labels in the
packaged font; A4 pages with a running head and page numbers; the figures as vectors."""

from __future__ import annotations

import re
import subprocess

import pytest
from report_helpers import require_chromium, require_tool

from blockqc.report import write_block_report


@pytest.fixture(scope="module", params=["weasyprint", "chromium"])
def zh_pdf(request, tmp_path_factory):
    from report_helpers import make_results

    if request.param == "chromium":
        require_chromium()
    folder = tmp_path_factory.mktemp(f"pdf-{request.param}") / "T-B01"
    written = write_block_report(folder, make_results(), lang="zh", pdf_engine=request.param)
    assert folder / "report.pdf" in written
    return folder / "report.pdf"


def _engine(pdf) -> str:
    return pdf.parent.parent.name.split("-")[1].rstrip("0123456789")


def test_pdf_text_has_block_verdict_and_chinese_labels(zh_pdf):
    pdftotext = require_tool("pdftotext")
    text = subprocess.run(
        [pdftotext, "-layout", str(zh_pdf), "-"], capture_output=True, text=True, check=True
    ).stdout
    assert zh_pdf.read_bytes().startswith(b"%PDF-")
    assert "T-B01" in text
    assert "不合格" in text  # the verdict, in Chinese
    for label in (
        "验收报告",
        "数据质量",
        "布局质量",
        "附件质量",
        "检查点平面精度",
        "连接点分布",
        "中误差",
        "最大误差",
        "粗差个数",
        "粗差率",
        "高精度数据法",
        "同精度数据法",
    ):
        assert label in text, label
    assert "<script>alert(1)</script>" in text  # shown as text, never run
    assert "\ufffd" not in text and "□" not in text


def test_pdf_embeds_the_packaged_cjk_font(zh_pdf):
    """WeasyPrint embeds the font by name; Chromium (Skia) writes an OpenType CFF font as Type 3
    glyphs without a name, whose text still reads back (the test above)."""
    pdffonts = require_tool("pdffonts")
    out = subprocess.run([pdffonts, str(zh_pdf)], capture_output=True, text=True, check=True).stdout
    rows = [line.split() for line in out.splitlines()[2:] if line.strip()]
    if _engine(zh_pdf) == "weasyprint":
        assert [r for r in rows if "Blockqc-Sans-SC" in r[0]], out
    else:
        assert [r for r in rows if r[0] == "[none]" and r[1:3] == ["Type", "3"]], out
    # columns: name type… encoding emb sub uni: every font of the PDF is embedded
    assert all("yes" == r[-5] for r in rows), out
    assert not [r for r in rows if "CJK" in r[0]], "a system CJK font was used instead: " + out


def test_pdf_pages_are_a4_with_page_numbers(zh_pdf):
    pdfinfo = require_tool("pdfinfo")
    info = subprocess.run([pdfinfo, str(zh_pdf)], capture_output=True, text=True, check=True).stdout
    assert re.search(r"Page size:\s+59[45]\.\d+ x 841\.\d+ pts \(A4\)", info), info
    pages = int(next(line.split()[-1] for line in info.splitlines() if line.startswith("Pages:")))
    assert pages >= 3
    last = subprocess.run(
        [require_tool("pdftotext"), "-f", str(pages), "-l", str(pages), str(zh_pdf), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert re.search(rf"\b{pages}\s*/\s*{pages}\b", last), last


def test_pdf_figures_are_vectors_with_their_text_in_the_packaged_font(zh_pdf):
    """The figures reach the PDF as drawn for the HTML: vector shapes and text (their Chinese
    titles and axis labels are in the PDF's text, read in content order: Chromium writes a
    rotated label glyph by glyph), no picture of them, no missing glyph."""
    text = subprocess.run(
        [require_tool("pdftotext"), "-raw", str(zh_pdf), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    text = re.sub(r"\s", "", text)
    for label in (
        "连接点残差直方图",
        "每景影像连接点数量",
        "影像范围及检查状态",
        "误差（m）",
        "观测数",
    ):
        assert label in text, label
    images = subprocess.run(
        [require_tool("pdfimages"), "-list", str(zh_pdf)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert len([line for line in images.splitlines()[2:] if line.strip()]) == 0, images


def test_pdf_pages_carry_the_title_and_verdict_as_running_head(zh_pdf):
    page_two = subprocess.run(
        [require_tool("pdftotext"), "-f", "2", "-l", "2", "-layout", str(zh_pdf), "-"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    head = next(line for line in page_two.splitlines() if line.strip())
    assert "T-B01" in head and "验收报告" in head and "不合格" in head, head


@pytest.mark.parametrize("engine", ["weasyprint", "chromium"])
def test_a_long_unbroken_particular_wraps_within_the_page(tmp_path, engine):
    """A project id of 287 characters without a space (--meta): wrapped in its cell, every
    character on the page (it ran off the A4 page, cut at 117 or 167 characters)."""
    from report_helpers import make_results

    if engine == "chromium":
        require_chromium()
    results = make_results()
    project = "Project_" + "_".join(f"seg{i:03d}" for i in range(40))
    results["meta"] = {"project": project}
    write_block_report(tmp_path / "T-B01", results, pdf_engine=engine)
    pdf = tmp_path / "T-B01" / "report.pdf"
    text = subprocess.run(
        [require_tool("pdftotext"), "-f", "1", "-l", "1", str(pdf), "-"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert project in re.sub(r"\s+", "", text)


def _rc1_failure() -> dict:
    """RC-1 failing on three observations (delivered residual against the computed one)."""
    rows = [
        ("G0105", "R", 18018.03, 17319.46, 2.0016, 0.0059, 0.0016, 0.0059, 2.0000),
        ("G0105", "L", 18878.12, 17263.14, 1.9984, -0.0058, -0.0016, -0.0058, 2.0000),
        ("G0005", "L", 24584.12, 22631.05, 0.0206, 0.8768, 0.0207, 0.0768, 0.8000),
    ]
    keys = ("point_id", "scene_id", "line", "sample", "v_line", "v_sample")
    keys += ("v_line_computed", "v_sample_computed", "difference_px")
    evidence = [dict(zip(keys, r, strict=True), n_rays=2, intersected=True) for r in rows]
    return {
        "rule": "RC-1", "title": "Delivered tie-point residuals reproduce", "title_zh": "",
        "clause": "§RC-1", "description": "", "description_zh": "",
        "quality_element": "attachment", "content": ["ro_report"], "inspection": "general",
        "figures": [], "group": {}, "status": "fail", "statistic": "difference_px",
        "value": 2.0, "threshold": 0.1, "comparison": "<=", "threshold_text": "≤ 0.1",
        "unit": "px", "severity": "fail", "measurement": "residual_reproduction",
        "detail": {"n_units": 120, "n_offending": 3}, "evidence": evidence,
    }  # fmt: skip


@pytest.mark.parametrize(
    ("engine", "rows_before"),
    [("weasyprint", 45), ("weasyprint", 48), ("weasyprint", 51), ("chromium", 33)],
)
def test_a_failures_heading_is_printed_on_the_page_of_its_evidence(tmp_path, engine, rows_before):
    """The failures before RC-1 fill the page down to its foot (TP-4 with `rows_before` scenes):
    RC-1's heading and value line were printed at the foot of one page and its evidence table
    (its worst observation G0105 first) at the top of the next, by either engine."""
    from report_helpers import make_results

    if engine == "chromium":
        require_chromium()

    results = make_results()
    tp4 = next(r for r in results["results"] if r["rule"] == "TP-4")
    tp4["evidence"] = [dict(tp4["evidence"][0], scene_id=f"S{i:03d}") for i in range(rows_before)]
    tp4["detail"]["n_offending"] = rows_before
    results["results"].append(_rc1_failure())
    write_block_report(tmp_path / "T-B01", results, pdf_engine=engine)
    text = subprocess.run(
        [require_tool("pdftotext"), str(tmp_path / "T-B01" / "report.pdf"), "-"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    pages = text.split("\f")
    heading = [i for i, p in enumerate(pages) if re.search(r"^RC-1 — ", p, re.M)]
    worst = [i for i, p in enumerate(pages) if "G0105" in p]
    assert len(heading) == 1 and worst and heading[0] == worst[0]
