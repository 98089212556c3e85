"""Rendering results.json into the acceptance report: HTML, PDF from the same HTML, CSV exports."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import jinja2

from blockqc.outputs import write_bytes_atomic, write_text_atomic
from blockqc.report.acceptance import filed_context
from blockqc.report.build import block_context, summary_context
from blockqc.report.checkpoints import checkpoint_rows
from blockqc.report.exports import checkpoints_csv, evidence_csv, summary_csv, summary_parquet
from blockqc.report.html import environment, render_page
from blockqc.report.messages import LANGUAGES
from blockqc.results import BlockResults, Summary


@lru_cache(maxsize=8)
def _environment(templates: Path | None) -> jinja2.Environment:
    """One template environment per templates folder and process: templates are compiled once
    for a batch, not once per block (Jinja still reloads a template whose file changed)."""
    return environment(templates)


def write_block_report(
    folder: Path,
    results: BlockResults | dict,
    *,
    lang: str = "en",
    templates: Path | None = None,
    pdf: bool = True,
    pdf_engine: str = "weasyprint",
) -> list[Path]:
    """report.html, report.pdf (made by `pdf_engine`), checkpoints.csv and evidence.csv of one
    block, from its results."""
    if lang not in LANGUAGES:
        raise ValueError(f"language {lang!r}: choose one of {', '.join(LANGUAGES)}")
    folder = Path(folder)
    results = BlockResults.model_validate(results)
    env = _environment(templates)
    ctx = block_context(results, lang)
    written = []
    html = render_page("block.html.j2", ctx, env)
    write_text_atomic(folder / "report.html", html)
    written.append(folder / "report.html")
    if pdf:
        from blockqc.report.pdf import html_to_pdf

        page = render_page("block.html.j2", ctx, env, for_pdf=pdf_engine)
        data = html_to_pdf(page, folder, pdf_engine)
        write_bytes_atomic(folder / "report.pdf", data)
        written.append(folder / "report.pdf")
    for name, text in (
        ("checkpoints.csv", checkpoints_csv(results)),
        ("evidence.csv", evidence_csv(results)),
    ):
        write_text_atomic(folder / name, text)
        written.append(folder / name)
    return written


def write_summary_report(
    out: Path,
    summary: Summary | dict,
    *,
    lang: str = "en",
    templates: Path | None = None,
    pdf: bool = True,
    jobs: int = 1,
    pdf_engine: str = "weasyprint",
) -> list[Path]:
    """summary.html and summary.pdf of a batch, linking each block's report; with an acceptance,
    acceptance.html and .pdf too, laid out beside the summary's PDF when `jobs` > 1."""
    if lang not in LANGUAGES:
        raise ValueError(f"language {lang!r}: choose one of {', '.join(LANGUAGES)}")
    out = Path(out)
    summary = Summary.model_validate(summary)
    env = _environment(templates)
    pages = [("summary", "summary.html.j2", summary_context(summary, lang, pdf=pdf))]
    if summary.acceptance is not None:
        pages.append(("acceptance", "acceptance.html.j2", filed_context(summary, lang)))
    written = []
    for name, template, context in pages:
        write_text_atomic(out / f"{name}.html", render_page(template, context, env))
        written.append(out / f"{name}.html")
    if pdf:
        prints = [render_page(t, ctx, env, for_pdf=pdf_engine) for _, t, ctx in pages]
        for (name, _, _), data in zip(pages, _pdfs(prints, out, jobs, pdf_engine), strict=True):
            write_bytes_atomic(out / f"{name}.pdf", data)
            written.append(out / f"{name}.pdf")
    write_text_atomic(out / "summary.csv", summary_csv(summary))
    write_bytes_atomic(out / "summary.parquet", summary_parquet(summary))
    written += [out / "summary.csv", out / "summary.parquet"]
    return written


def _pdfs(pages: list[str], base_url: Path, jobs: int, engine: str) -> list[bytes]:
    """The PDF of each HTML page; with WeasyPrint and `jobs` > 1 the pages after the first are
    laid out in other processes while this one lays out the first (a batch's summary and
    acceptance)."""
    from blockqc.report.pdf import html_to_pdf

    if jobs < 2 or len(pages) < 2 or engine != "weasyprint":
        return [html_to_pdf(page, base_url, engine) for page in pages]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=min(jobs - 1, len(pages) - 1)) as pool:
        others = [pool.submit(html_to_pdf, page, base_url) for page in pages[1:]]
        first = html_to_pdf(pages[0], base_url)
        return [first] + [f.result() for f in others]


__all__ = ["LANGUAGES", "checkpoint_rows", "write_block_report", "write_summary_report"]
