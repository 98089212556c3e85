"""`blockqc report`: re-render acceptance reports from results.json, without recomputing."""

from __future__ import annotations

from pathlib import Path

import click

from blockqc.cli import (
    GivenPath,
    TemplatesPath,
    check_pdf_engine,
    echo,
    lang_option,
    pdf_engine_option,
)
from blockqc.errors import UsageError
from blockqc.outputs import refuse_block_folders, refuse_delivery
from blockqc.report.documents import gather
from blockqc.results import (
    BlockResults,
    Summary,
)


def _check_out(out: Path, named: tuple[Path, ...], docs: list, summary: tuple | None) -> None:
    """Refuse --out inside (or equal to) a folder named or holding a named file, unless the
    reports are re-rendered in place: every results file (and the summary) is already where
    it would be written, `<out>/<block_id>/results.json` (`<out>/summary.json`). Never inside a
    delivery."""
    refuse_delivery(out)
    refuse_block_folders(out, [d.block_id for _, d, _ in docs])
    here = [(out / d.block_id / "results.json", p) for p, d, _ in docs]
    here += [(out / "summary.json", summary[0])] if summary is not None else []
    if all(target.resolve() == p.resolve() for target, p in here):
        return
    out_r = out.resolve()
    for p in named:
        folder = p if p.is_dir() else p.parent
        if folder.resolve() in (out_r, *out_r.parents):
            raise UsageError(
                f"--out {out} lies inside the input folder {folder}: choose an output folder "
                "outside the inputs (or, to re-render in place, the folder that holds "
                "<block_id>/results.json)"
            )


@click.command("report")
@click.argument(
    "results", nargs=-1, required=True, type=GivenPath("a results.json or a folder of them")
)
@click.option(
    "--out",
    required=True,
    type=GivenPath(file_okay=False),
    help="Output folder: <out>/<block_id>/report.html, report.pdf, CSV exports; "
    "<out>/summary.html for a batch. Never inside an input, unless it is the folder the "
    "results are in (<out>/<block_id>/results.json): the reports are then re-rendered in place.",
)
@lang_option("the report")
@click.option(
    "--templates",
    type=TemplatesPath(),
    help="Folder of templates that take precedence over the stock ones.",
)
@click.option("--pdf/--no-pdf", default=True, show_default=True, help="Also write the PDFs.")
@pdf_engine_option
def command(
    results: tuple[Path, ...],
    out: Path,
    lang: str,
    templates: Path | None,
    pdf: bool,
    pdf_engine: str,
) -> int:
    """Re-render reports from results.json files (or folders holding them), not recomputing.

    A batch folder (or its summary.json) re-renders the batch summary as well.
    """
    from blockqc.outputs import empty_removed, make_out_dir, out_lock

    check_pdf_engine(pdf_engine, pdf)
    docs, summary, repeated, left_out, unchecked = gather(list(results))
    for f in repeated:
        echo(f"warning: {f}: named more than once, rendered once", err=True)
    for f in left_out:
        echo(
            f"warning: {f}: a block the summary beside it does not list (an earlier run's, of "
            "a delivery since withdrawn?): not rendered",
            err=True,
        )
    for note in unchecked + (_untranslated_titles(docs) if lang == "zh" else []):
        echo(f"warning: {note}", err=True)
    _check_out(out, results, docs, summary)
    with empty_removed(out):  # a folder made for pages none of which could be rendered
        make_out_dir(out, out.resolve())
        with out_lock(out):  # one run at a time writes into a folder, as inspect's
            written = _render(out, docs, summary, lang, templates, pdf, pdf_engine)
    echo(f"{len(written)} files written in {out}")
    return 0


def _untranslated_titles(docs: list[tuple[Path, BlockResults, bytes]]) -> list[str]:
    """Per pack the results were judged by, once: its rules, elements, items and contents
    without a Chinese title, which the Chinese pages show in English (results.json names the
    pack's files, not their lines), in the words of `rules lint`."""
    from blockqc.rules.lint import untitled_parts, untranslated

    by_pack: dict[tuple[str, ...], dict[tuple[str, str], None]] = {}
    for _, doc, _ in docs:
        pack = (doc.rule_pack, doc.rule_pack_version, *doc.rule_pack_files)
        parts = by_pack.setdefault(pack, {})
        parts.update(dict.fromkeys(("rule", r.rule) for r in doc.results if not r.title_zh.strip()))
        parts.update(dict.fromkeys(untitled_parts(doc.elements)))
    return [
        f"{files[0] + ': ' if files else ''}"
        + untranslated([(k, pid, None) for k, pid in parts], f"{name} {version}")
        for (name, version, *files), parts in by_pack.items()
        if parts
    ]


def _render(
    out: Path,
    docs: list[tuple[Path, BlockResults, bytes]],
    summary: tuple[Path, Summary, bytes] | None,
    lang: str,
    templates: Path | None,
    pdf: bool,
    pdf_engine: str,
) -> list[Path]:
    """Each block's report, and the batch summary's pages, written apart
    (`<out>/.blockqc-staging`) and put in place once every page is made: a page that cannot be
    rendered (a template failing on one block, or on the summary) leaves no page written; the
    files written."""
    from blockqc.outputs import clear_staging, staged_folder

    clear_staging(out)  # what a run stopped half-way left
    try:
        staged = staged_folder(out, "report")
        blocks = [_stage_block(staged, out, d, lang, templates, pdf, pdf_engine) for d in docs]
        batch = None
        if summary is not None:
            batch = _stage_summary(staged, out, summary, lang, templates, pdf, pdf_engine)
        written: list[Path] = []
        for doc, folder, names in blocks:
            written += _put_block(staged / doc.block_id, folder, names)
            echo(f"{doc.block_id:12} {doc.verdict.upper():5}  {folder}")
        if batch is not None:
            written += _put_summary(staged, out, batch)
            echo(f"summary      {out / 'summary.html'}")
    finally:
        clear_staging(out)
    return written


def _stage_block(
    staged: Path,
    out: Path,
    given: tuple[Path, BlockResults, bytes],
    lang: str,
    templates: Path | None,
    pdf: bool,
    pdf_engine: str,
) -> tuple[BlockResults, Path, list[str]]:
    """A block's outputs written into `staged`/<block_id>: its report, and its results file
    unless it is already where it would be written; the block, its folder, the names written."""
    from blockqc.outputs import safe_child, write_bytes_atomic
    from blockqc.report import write_block_report

    path, doc, raw = given
    folder = safe_child(out, doc.block_id, source=path)
    if folder.exists() and not folder.is_dir():
        raise UsageError(
            f"{folder}: a file where the outputs of block {doc.block_id} go: move it away, or "
            "choose another --out"
        )
    here = staged / doc.block_id
    here.mkdir()
    names = []
    if (folder / "results.json").resolve() != path.resolve():
        write_bytes_atomic(here / "results.json", raw)
        names.append("results.json")
    made = write_block_report(
        here, doc, lang=lang, templates=templates, pdf=pdf, pdf_engine=pdf_engine
    )
    return doc, folder, names + [p.name for p in made]


def _put_block(staged: Path, folder: Path, names: list[str]) -> list[Path]:
    """The block's staged outputs moved into its folder (`publish`: results.json removed first
    and put back last; a PDF not made now removed, never left beside); a results file that is
    already there is left as it is."""
    from blockqc.outputs import BLOCK_OUTPUTS, publish

    if "results.json" in names:
        publish(staged, folder, BLOCK_OUTPUTS, last="results.json")
    else:
        publish(staged, folder, [n for n in BLOCK_OUTPUTS if n != "results.json"], "report.html")
    return [folder / name for name in names]


def _stage_summary(
    staged: Path,
    out: Path,
    summary: tuple[Path, Summary, bytes],
    lang: str,
    templates: Path | None,
    pdf: bool,
    pdf_engine: str,
) -> list[str]:
    """The batch summary's pages written into `staged`, and its summary.json unless it is
    already there as it would be written; the names written."""
    from blockqc.outputs import write_bytes_atomic, write_json_atomic
    from blockqc.report import write_summary_report

    path, doc, raw = summary
    doc = _with_pdfs(doc, pdf)
    names = []
    if doc is not summary[1]:  # its PDF links say what is now beside each report
        write_json_atomic(staged / "summary.json", doc)
        names.append("summary.json")
    elif (out / "summary.json").resolve() != path.resolve():
        write_bytes_atomic(staged / "summary.json", raw)
        names.append("summary.json")
    made = write_summary_report(
        staged, doc, lang=lang, templates=templates, pdf=pdf, pdf_engine=pdf_engine
    )
    return names + [p.name for p in made]


def _put_summary(staged: Path, out: Path, names: list[str]) -> list[Path]:
    """The summary's staged outputs moved into `out` as a block's are (`publish`: summary.json
    last; an earlier run's summary PDF or acceptance page not made again removed); a
    summary.json that is already there is left as it is."""
    from blockqc.outputs import BATCH_OUTPUTS, publish

    if "summary.json" in names:
        publish(staged, out, BATCH_OUTPUTS, last="summary.json")
    else:
        publish(staged, out, [n for n in BATCH_OUTPUTS if n != "summary.json"], "summary.html")
    return [out / name for name in names]


def _with_pdfs(summary: Summary, pdf: bool) -> Summary:
    """The summary with each block's PDF flag as the re-rendering left it (every summary's
    block is rendered: each has its report.pdf with --pdf, none with --no-pdf); the summary
    itself when no flag changes."""
    if all(b.pdf == pdf for b in summary.blocks):
        return summary
    blocks = [b.model_copy(update={"pdf": pdf}) for b in summary.blocks]
    return summary.model_copy(update={"blocks": blocks})


__all__ = ["command"]
