"""A batch summary's lists of sampled blocks that fail and of returned blocks are folded on
screen when they are long (a batch of 1,000 blocks listed 250 failing sampled blocks before its
table of blocks), and never in print, where a folded list would be lost."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from blockqc.report.build import summary_context
from blockqc.report.html import render_page
from casekit import SAMPLES, run_blockqc


@pytest.fixture(scope="module")
def summary(tmp_path_factory) -> dict:
    """The sample batch's summary: F3-B01 is a sampled block that fails."""
    out = tmp_path_factory.mktemp("listing") / "out"
    args = ("--verdicts", SAMPLES / "verdicts.yaml", "--no-pdf", "--out", out)
    assert run_blockqc("inspect", SAMPLES / "batch", *args).returncode == 1
    return json.loads((Path(out) / "summary.json").read_text(encoding="utf-8"))


def _failing_list(summary: dict, times: int, for_pdf: str | None) -> str:
    """The rendered `<details>` opening tag and heading of the failing sampled blocks, with
    the one failing block listed `times` times."""
    doc = json.loads(json.dumps(summary))
    doc["acceptance"]["failing"] = doc["acceptance"]["failing"] * times
    html = render_page("summary.html.j2", summary_context(doc, "en", pdf=False), for_pdf=for_pdf)
    found = re.search(r'(<details class="listing"[^>]*>)\s*<summary><h3>([^<]*)</h3>', html)
    assert found, "the failing sampled blocks are not listed"
    return found[1] + found[2]


def test_a_short_list_is_open(summary):
    assert len(summary["acceptance"]["failing"]) == 1
    got = _failing_list(summary, 1, None)
    assert got == '<details class="listing" open>Sampled blocks that fail (1)'


def test_a_long_list_is_folded_on_screen_with_its_length(summary):
    got = _failing_list(summary, 11, None)
    assert got == '<details class="listing">Sampled blocks that fail (11)'


@pytest.mark.parametrize("engine", ["weasyprint", "chromium"])
def test_a_long_list_is_open_in_print(summary, engine):
    got = _failing_list(summary, 11, engine)
    assert got == '<details class="listing" open>Sampled blocks that fail (11)'


def test_short_headings_of_the_decision_tables_are_not_broken_in_chinese(summary, tmp_path):
    """Beside the long reasons of a failing block, the zh PDFs printed the headings of the
    narrow columns a character or two a line (得/分, 质量等/级, 抽/样); each is whole."""
    import subprocess

    from report_helpers import require_tool

    from blockqc.report import write_summary_report

    require_tool("pdftotext")
    write_summary_report(tmp_path, summary, lang="zh")
    for page, headings in (("summary", ("得分", "质量等级")), ("acceptance", ("抽样", "质量等级"))):
        text = subprocess.run(
            ["pdftotext", "-layout", str(tmp_path / f"{page}.pdf"), "-"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        line = next(x for x in text.splitlines() if re.search(r"区域网\s.*原因", x))
        assert all(h in line for h in headings), (page, line)
