"""The PDF: its text holds the block, the verdict and the Chinese labels in the packaged font."""

from __future__ import annotations

import re
import subprocess

import pytest
from report_helpers import require_tool

from blockqc.report import write_block_report


@pytest.fixture(scope="module")
def zh_pdf(tmp_path_factory):
    from report_helpers import make_results

    folder = tmp_path_factory.mktemp("pdf") / "T-B01"
    written = write_block_report(folder, make_results(), lang="zh")
    assert folder / "report.pdf" in written
    return folder / "report.pdf"


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
    pdffonts = require_tool("pdffonts")
    out = subprocess.run([pdffonts, str(zh_pdf)], capture_output=True, text=True, check=True).stdout
    rows = [line.split() for line in out.splitlines()[2:] if line.strip()]
    ours = [r for r in rows if "Blockqc-Sans-SC" in r[0]]
    assert ours, out
    # columns: name type… encoding emb sub uni: every font of the PDF is embedded
    assert all("yes" == r[-5] for r in rows), out
    assert not [r for r in rows if "CJK" in r[0]], "a system CJK font was used instead: " + out


def test_pdf_pages_are_a4_with_page_numbers(zh_pdf):
    pdfinfo = require_tool("pdfinfo")
    info = subprocess.run([pdfinfo, str(zh_pdf)], capture_output=True, text=True, check=True).stdout
    assert re.search(r"Page size:\s+595\.\d+ x 841\.\d+ pts \(A4\)", info), info
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
    titles and axis labels are in the PDF's text), no picture of them, no missing glyph."""
    text = subprocess.run(
        [require_tool("pdftotext"), str(zh_pdf), "-"], capture_output=True, text=True, check=True
    ).stdout
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
