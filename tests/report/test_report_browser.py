"""The HTML pages in headless Chromium: they render, run their scripts without console errors."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from report_helpers import require_tool

from blockqc.report import write_block_report, write_summary_report

pytestmark = pytest.mark.browser

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--enable-logging=stderr",
    "--v=1",
]


def chromium(url: str, tmp_path: Path, *extra: str) -> tuple[str, list[str]]:
    """The DOM after the page's scripts ran, and the console messages Chromium logged."""
    exe = require_tool("chromium")
    profile = tmp_path / f"profile-{len(list(tmp_path.glob('profile-*')))}"
    proc = subprocess.run(
        [exe, *FLAGS, f"--user-data-dir={profile}", *extra, url],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    console = [
        line for line in proc.stderr.splitlines() if ":CONSOLE" in line or "Uncaught" in line
    ]
    return proc.stdout, console


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    from report_helpers import make_results, make_summary, summary_entry

    out = tmp_path_factory.mktemp("html")
    doc = make_results()
    write_block_report(out / "T-B01", doc, pdf=False)
    other = {**doc, "block_id": "T-B02", "verdict": "pass", "results": [], "measurements": []}
    write_block_report(out / "T-B02", other, pdf=False)
    summary = make_summary(
        [
            summary_entry("T-B02", "pass"),
            summary_entry("T-B01", "fail", sampled=True, failed_rules=["TP-4"]),
        ]
    )
    write_summary_report(out, summary, pdf=False)
    return out


def test_block_report_renders_without_console_errors(pages, tmp_path):
    dom, console = chromium((pages / "T-B01" / "report.html").as_uri(), tmp_path, "--dump-dom")
    assert console == []
    verdict = re.search(r'<span class="verdict fail" id="verdict"[^>]*>([^<]+)</span>', dom)
    assert verdict and verdict.group(1) == "FAIL"
    assert "<script>alert(1)</script>" not in dom  # the DOM holds it as text only
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in dom
    assert dom.count("<svg") >= 6


def test_block_report_screenshot(pages, tmp_path):
    shot = tmp_path / "block.png"
    _, console = chromium(
        (pages / "T-B01" / "report.html").as_uri(),
        tmp_path,
        f"--screenshot={shot}",
        "--window-size=1280,2000",
        "--hide-scrollbars",
    )
    assert console == []
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20_000


def test_summary_sorts_and_filters_offline(pages, tmp_path):
    url = (pages / "summary.html").as_uri()
    dom, console = chromium(url, tmp_path, "--dump-dom")
    assert console == []
    assert re.search(r'id="shown">2<', dom)
    body = dom[
        dom.index('id="blocks-table"') : dom.index("</table>", dom.index('id="blocks-table"'))
    ]
    assert body.index("T-B02") < body.index("T-B01")  # as the summary lists them
    # sort by the block column, and keep only failing blocks, through the page's own script
    dom, console = chromium(url + "#sort=0&verdict=fail", tmp_path, "--dump-dom")
    assert console == []
    body = dom[
        dom.index('id="blocks-table"') : dom.index("</table>", dom.index('id="blocks-table"'))
    ]
    assert body.index("T-B01") < body.index("T-B02")
    assert re.search(r'<tr data-verdict="pass" hidden="">', body)
    assert re.search(r'id="shown">1<', dom)
    assert 'aria-sort="ascending"' in body


def test_a_hand_typed_filter_link_is_taken_as_typed(pages, tmp_path):
    """`#filter=100%` (a '%' that is no escape) threw in the page's script and the whole view
    was ignored; `#filter=a=b` was cut at its second '='."""
    url = (pages / "summary.html").as_uri()
    dom, console = chromium(url + "#filter=100%&verdict=fail", tmp_path, "--dump-dom")
    assert console == []
    assert re.search(r'id="shown">0<', dom)  # the verdict applied, and no block holds '100%'
    dom, console = chromium(url + "#filter=T-B01=x", tmp_path, "--dump-dom")
    assert console == [] and re.search(r'id="shown">0<', dom)  # 'T-B01=x' matches no block
