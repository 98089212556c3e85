"""`--pdf-engine chromium`: the browser kept open, its failures named, the running head's text."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
import tinycss2
from report_helpers import require_chromium, require_tool

from blockqc.report import chromium
from blockqc.report.html import _css_string
from blockqc.report.pdf import FontProblem

PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><style>
@page { size: A4; margin: 20mm; @bottom-right { content: counter(page) " / " counter(pages); } }
{extra}</style></head><body>{body}</body></html>"""


def page(body: str, extra: str = "") -> str:
    return PAGE.replace("{extra}", extra).replace("{body}", body)


def pdf_text(data: bytes, tmp_path) -> str:
    path = tmp_path / "t.pdf"
    path.write_bytes(data)
    out = subprocess.run([require_tool("pdftotext"), str(path), "-"], capture_output=True)
    return out.stdout.decode()


@pytest.mark.parametrize(
    "text",
    ['区域网 "B-01" 验收报告', "a\\b</style><script>x</script>", "line\nbreak\ttab", "'&'"],
)
def test_css_string_reads_back_as_the_same_text(text):
    """Parsed by a CSS tokenizer (tinycss2), the quoted string is the text given, and it holds
    nothing that could end the <style> element."""
    quoted = str(_css_string(text))
    tokens = [t for t in tinycss2.parse_component_value_list(quoted) if t.type != "whitespace"]
    assert [t.type for t in tokens] == ["string"]
    assert tokens[0].value == text
    assert "<" not in quoted and ">" not in quoted and "\n" not in quoted


def test_css_string_by_hand():
    assert str(_css_string('a"b')) == '"a\\22 b"'
    assert str(_css_string("</")) == '"\\3c /"'


def test_pages_from_one_browser_and_a_new_one_after_it_stopped(tmp_path):
    require_chromium()
    first = chromium.html_to_pdf(page("<p>first page</p>"))
    browser = chromium._browser
    second = chromium.html_to_pdf(page("<p>second page</p>"))
    assert chromium._browser is browser  # one browser for the process
    assert "first page" in pdf_text(first, tmp_path)
    assert "second page" in pdf_text(second, tmp_path)
    browser.process.kill()
    browser.process.wait()
    third = chromium.html_to_pdf(page("<p>third page</p>"))
    assert chromium._browser is not browser and browser.closed
    assert "third page" in pdf_text(third, tmp_path)


def test_a_font_that_cannot_load_is_an_error_not_a_fallback(tmp_path):
    require_chromium()
    missing = (tmp_path / "missing.otf").as_uri()
    css = f'@font-face {{ font-family: "Gone"; src: url("{missing}"); }}'
    css += ' body { font-family: "Gone"; }'
    with pytest.raises(FontProblem, match="Gone"):
        chromium.html_to_pdf(page("<p>text</p>", css))


def _tagged(data: bytes, tmp_path) -> str:
    path = tmp_path / "t.pdf"
    path.write_bytes(data)
    out = subprocess.run([require_tool("pdfinfo"), str(path)], capture_output=True, text=True)
    return next(line.split()[-1] for line in out.stdout.splitlines() if line.startswith("Tagged:"))


def test_pdfs_are_untagged_unless_asked(tmp_path, monkeypatch):
    """Like WeasyPrint's by default; BLOCKQC_PDF_TAGGED=1 asks for the structure tree."""
    require_chromium()
    monkeypatch.delenv(chromium.TAGGED, raising=False)
    assert _tagged(chromium.html_to_pdf(page("<h1>Title</h1><p>text</p>")), tmp_path) == "no"
    monkeypatch.setenv(chromium.TAGGED, "1")
    assert _tagged(chromium.html_to_pdf(page("<h1>Title</h1><p>text</p>")), tmp_path) == "yes"


def test_relative_links_lead_from_the_output_folder(tmp_path):
    require_chromium()
    data = chromium.html_to_pdf(page('<p><a href="B-01/report.html">B-01</a></p>'), tmp_path)
    assert (tmp_path / "B-01" / "report.html").as_uri().encode() in data


def test_no_chromium_is_a_clear_error(monkeypatch):
    monkeypatch.setenv("BLOCKQC_CHROMIUM", "/nonexistent/chromium")
    with pytest.raises(chromium.ChromiumProblem, match="BLOCKQC_CHROMIUM=/nonexistent/chromium"):
        chromium.find_chromium()


def test_cli_stops_before_inspecting_without_chromium(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from blockqc.cli import cli

    monkeypatch.setenv("BLOCKQC_CHROMIUM", "no-such-chromium-program")
    sample = Path(__file__).parents[2] / "samples" / "batch" / "F1-B01"
    out = tmp_path / "out"
    args = ["inspect", str(sample), "--out", str(out), "--pdf-engine", "chromium"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2
    assert "--pdf-engine" in result.output and "no-such-chromium-program" in result.output
    assert not out.exists()
    ok = CliRunner().invoke(cli, [*args[:4], "--pdf", "none", "--pdf-engine", "chromium"])
    assert ok.exit_code == 0, ok.output  # without PDFs, no Chromium is needed


def _browsers_of_blockqc() -> list[str]:
    out = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True).stdout
    return [line for line in out.splitlines() if "blockqc-chromium-" in line]


def test_a_batch_in_worker_processes_prints_with_chromium_and_leaves_no_browser(tmp_path):
    """Two worker processes, each with its own browser; the summary's PDF by the main process;
    no browser left running once blockqc has exited."""
    import os
    import sys

    require_chromium()
    require_tool("ps")
    batch = Path(__file__).parents[2] / "samples" / "batch"
    out = tmp_path / "out"
    before = _browsers_of_blockqc()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run(
        [sys.executable, "-m", "blockqc", "inspect", str(batch / "F3-B01"), str(batch / "F3-B02"),
         str(batch / "F1-B01"), "--out", str(out), "--jobs", "2", "--pdf", "failing",
         "--pdf-engine", "chromium", "--no-progress"],
        capture_output=True, text=True, env=env,
    )  # fmt: skip
    assert run.returncode == 1, run.stderr  # F3-B01 and F3-B02 fail
    for pdf in (out / "F3-B01" / "report.pdf", out / "F3-B02" / "report.pdf", out / "summary.pdf"):
        assert b"Skia/PDF" in pdf.read_bytes()  # the producer Chromium names
    assert not (out / "F1-B01" / "report.pdf").exists()
    assert _browsers_of_blockqc() == before


def test_a_program_that_cannot_start_is_a_clear_error(tmp_path):
    program = tmp_path / "chromium"
    program.write_text("not a program\n")  # not executable
    with pytest.raises(chromium.ChromiumProblem, match="could not be started"):
        chromium.Browser(str(program))
