"""The command line: the only module that knows about the terminal and exit statuses."""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
from pathlib import Path

import click
from click.core import ParameterSource

from blockqc import __version__, memory
from blockqc.errors import BlockqcError, UsageError, shown

STATUS_STYLE = {"pass": "green", "fail": "red", "error": "red", "warn": "yellow"}


class GivenPath(click.Path):
    """A path never empty (`--out ''` would write into the current folder, a delivery '' read
    it), of outputs or inputs: a Path; `what` it names, in the message. One that must exist
    and is a symbolic link to nothing is said to be one, naming where it leads."""

    def __init__(self, what: str = "an output folder", **how) -> None:
        super().__init__(path_type=Path, **how)
        self.what = what

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail(f"an empty path: give {self.what}", param, ctx)
        if self.exists and isinstance(value, str | Path):
            from blockqc.textio import dangling_link  # numpy: not before memory.tune()

            if link := dangling_link(Path(value)):
                self.fail(f"{value}: {link}", param, ctx)
        return super().convert(value, param, ctx)


class TemplatesPath(GivenPath):
    """A folder of the user's templates, each compiled up front in the environment of the
    reports (`page="factors"`: of the factors page), so that a broken one is named with its
    line before anything runs."""

    def __init__(self, page: str = "report") -> None:
        super().__init__("a folder of templates", file_okay=False, exists=True)
        self.page = page

    def convert(self, value, param, ctx):
        folder = super().convert(value, param, ctx)
        from blockqc.report.html import PAGES, check_templates

        if self.page == "factors":
            from blockqc.analysis.render import TEMPLATE, environment

            used = check_templates(folder, environment(folder), [TEMPLATE])
        else:
            from blockqc.report.html import environment

            used = check_templates(folder, environment(folder), PAGES)
        _warn_unknown_templates(folder, used)
        return folder


def _warn_unknown_templates(folder: Path, used: set[str]) -> None:
    """A template in the folder that no page of blockqc has (a misspelt block.html.j2 would be
    left unused, the stock page rendered): said, with the name it resembles."""
    from blockqc.resources import templates_dir
    from blockqc.rules.lint import did_you_mean

    known = {p.name for p in templates_dir().iterdir()} | used
    for f in sorted(folder.glob("*.j2")):
        if f.name not in known:
            hint = did_you_mean(f.name, sorted(known))
            click.echo(
                f"warning: {f}: no page of blockqc has this template, not used{hint}", err=True
            )


class OnceGroup(click.Group):
    """A group whose commands refuse an option of one value given twice (`refuse_repeated`)."""

    def resolve_command(self, ctx: click.Context, args: list[str]):
        name, command, rest = super().resolve_command(ctx, args)
        if command is not None and not isinstance(command, click.Group):
            refuse_repeated(command, rest)
        return name, command, rest


class LazyGroup(OnceGroup):
    """Commands of the numerical methods load their (heavy) modules only when invoked."""

    lazy = {
        "rfm-accuracy": "blockqc.rfm.command",
        "factors": "blockqc.analysis.command",
        "report": "blockqc.report.command",
        "rules": "blockqc.rules.command",
        "adjust": "blockqc.adjust.command",
        "sample": "blockqc.acceptance.command",
    }

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(super().list_commands(ctx)) | set(self.lazy))

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name in self.lazy and name not in self.commands:
            import importlib

            try:
                return importlib.import_module(self.lazy[name]).command
            except ModuleNotFoundError as exc:
                if exc.name != self.lazy[name]:
                    raise
                return None
        return super().get_command(ctx, name)


def refuse_repeated(command: click.Command, args: list[str]) -> None:
    """An option taking one value given twice (`--rules a.yaml --rules b.yaml`): click keeps the
    last and drops the first unsaid, so it is refused, naming the option. So is one value of a
    repeatable option given twice (`--fix S1 --fix S1`: another value meant, most likely)."""
    once, many = _single_and_repeatable(command)
    seen: dict[str, str] = {}
    values: set[tuple[str, str]] = set()
    args = [str(a) for a in args]  # a caller of main() may pass paths
    for i, arg in enumerate(args):
        if arg == "--":
            break
        if arg.startswith("--"):
            given = arg.split("=", 1)[0]
        else:  # -j, and -j2 (a short option with its value)
            given = arg[:2] if arg.startswith("-") else arg
        if given in many:
            value = _value_of(arg, args[i + 1 : i + 2])
            if (many[given], value) in values:
                raise click.UsageError(f"{given} {value} given twice: give each {given} once")
            values.add((many[given], value))
        if given not in once:
            continue
        if once[given] in seen:
            first = seen[once[given]]
            also = "" if first == given else f" (also as {first})"
            raise click.UsageError(
                f"{given} given twice{also}: give it once, the one meant (the second would "
                "replace the first unsaid)"
            )
        seen[once[given]] = given
    refuse_both_ways(command, args)


def _value_of(arg: str, rest: list[str]) -> str:
    """The value an option string carries (`--fix=S`, `-dS`) or the argument after it."""
    if arg.startswith("--") and "=" in arg:
        return arg.split("=", 1)[1]
    if not arg.startswith("--") and len(arg) > 2:
        return arg[2:]
    return rest[0] if rest else ""


def _single_and_repeatable(command: click.Command) -> tuple[dict[str, str], dict[str, str]]:
    """The command's options taking one value, and those that may be repeated (`multiple`),
    each option string to its parameter's name."""
    options = [p for p in command.params if isinstance(p, click.Option)]
    once = {
        name: p.name for p in options if not (p.multiple or p.count or p.is_flag) for name in p.opts
    }
    many = {name: p.name for p in options if p.multiple for name in p.opts}
    return once, many  # type: ignore[return-value]


def refuse_both_ways(command: click.Command, args: list[str]) -> None:
    """A switch given both ways (`--pdf --no-pdf`, `--progress --no-progress`): click keeps the
    last unsaid, so it is refused as contradicting itself, naming both."""
    args = list(map(str, args))
    options = args[: args.index("--")] if "--" in args else args
    for p in command.params:
        if not (isinstance(p, click.Option) and p.is_flag and p.secondary_opts):
            continue
        given = [a for a in options if a in p.opts or a in p.secondary_opts]
        on = [a for a in given if a in p.opts]
        off = [a for a in given if a in p.secondary_opts]
        if on and off:
            raise click.UsageError(
                f"{given[0]} contradicts {off[0] if given[0] in p.opts else on[0]}: give one "
                "of them"
            )


@click.group(
    cls=LazyGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(__version__, prog_name="blockqc")
def cli() -> None:
    """Inspect satellite image blocks adjusted without ground control points."""


#: the languages of every page (blockqc.report.messages.LANGUAGES, named here without importing
#: the report's templates before a command runs)
LANGUAGES = ("en", "zh")


def lang_option(what: str):
    """--lang en|zh: the language `what` is written in (the results files are the same)."""
    return click.option(
        "--lang",
        type=click.Choice(LANGUAGES),
        default="en",
        show_default=True,
        help=f"Language of {what}.",
    )


def pdf_engine_option(command):
    """--pdf-engine, shared by inspect and report."""
    return click.option(
        "--pdf-engine",
        type=click.Choice(["weasyprint", "chromium"]),
        default="weasyprint",
        show_default=True,
        help="What lays out the PDFs: WeasyPrint, installed with blockqc, or the machine's "
        "Chromium, several times faster (BLOCKQC_CHROMIUM names its program).",
    )(command)


def check_pdf_engine(engine: str, pdf: bool) -> None:
    """Chromium is looked for before any block is inspected; an engine given for no PDF is
    said to be unused."""
    given = click.get_current_context().get_parameter_source("pdf_engine")
    if not pdf and given is ParameterSource.COMMANDLINE:
        click.echo(f"warning: --pdf-engine {engine}: not used, no PDF is written", err=True)
    if engine == "chromium" and pdf:
        from blockqc.report.chromium import ChromiumProblem, find_chromium

        try:
            find_chromium()
        except ChromiumProblem as exc:
            why = str(exc)
            lead = "" if why.startswith("--pdf-engine") else "--pdf-engine chromium: "
            raise click.UsageError(lead + why) from None


# ------------------------------------------------------------------------------- inspect
@cli.command("inspect")
@click.argument("paths", nargs=-1, required=True, type=GivenPath("a delivery or a batch folder"))
@click.option(
    "--rules",
    "rules_ref",
    default="global-project",
    show_default=True,
    help="Stock rule pack name or a rule pack file.",
)
@click.option(
    "--verdicts",
    type=GivenPath("the inspector's file"),
    help="Inspector's file: verdicts for manual items and waivers.",
)
@click.option(
    "--out",
    required=True,
    type=GivenPath(),
    help="Output folder (never inside a delivery).",
)
@click.option(
    "--templates",
    type=TemplatesPath(),
    help="Folder of templates that take precedence over the stock ones.",
)
@lang_option("the reports")
@click.option(
    "--pdf",
    type=click.Choice(["all", "failing", "sampled", "none"]),
    default="all",
    show_default=True,
    help="Blocks whose report.pdf is written beside report.html (summary.pdf unless none).",
)
@click.option("--no-pdf", is_flag=True, help="The same as --pdf none.")
@pdf_engine_option
@click.option(
    "--incremental",
    is_flag=True,
    help="Reuse the outputs of blocks whose delivery, verdicts, pack and options are unchanged.",
)
@click.option(
    "--scheduler",
    metavar="local|tcp://HOST:PORT",
    help="Run the blocks as tasks on dask.distributed: a LocalCluster, or a running scheduler.",
)
@click.option(
    "--jobs",
    "-j",
    type=click.IntRange(0),
    default=1,
    show_default=True,
    help="Deliveries inspected in parallel processes (0: one per CPU core).",
)
@click.option(
    "--progress/--no-progress",
    default=None,
    help="Progress bar for batches (default: when stderr is a terminal).",
)
@click.option(
    "--checkpoints",
    "checkpoint_files",
    multiple=True,
    type=GivenPath("a checkpoints table"),
    help="The inspector's checkpoints (checkpoints.csv columns [+ block_id]), merged with the "
    "delivered ones; repeat for several files.",
)
@click.option(
    "--plan",
    "plan_file",
    type=GivenPath("the sampling plan's file"),
    help="Sampling plan (blockqc sample): detailed inspection on its sampled blocks only.",
)
@click.option(
    "--meta",
    "meta_file",
    type=GivenPath("the report particulars' file"),
    help="The filed report's particulars: report number, project, producer, basis, signatures.",
)
def inspect_cmd(
    paths: tuple[Path, ...],
    rules_ref: str,
    verdicts: Path | None,
    out: Path,
    templates: Path | None,
    lang: str,
    pdf: str,
    no_pdf: bool,
    pdf_engine: str,
    incremental: bool,
    scheduler: str | None,
    jobs: int,
    progress: bool | None,
    checkpoint_files: tuple[Path, ...],
    plan_file: Path | None,
    meta_file: Path | None,
) -> int:
    """Inspect one delivery or a batch (a folder of deliveries) with a rule pack."""
    if len(paths) == 1 and scheduler is None and not incremental:
        _read_ahead(paths[0])
    from blockqc import batch
    from blockqc.inspector import load_inspector_input
    from blockqc.outputs import refuse_delivered, refuse_inside

    _refuse_conflicts(no_pdf, pdf, scheduler)
    runner = batch.Runner(jobs or os.cpu_count() or 1, scheduler)  # its scheduler checked first
    paths, templates = _as_workers_see(scheduler, paths, templates)
    pdf = "none" if no_pdf else pdf
    check_pdf_engine(pdf_engine, pdf != "none")
    refuse_inside(out, paths)
    refuse_delivered(
        [("--verdicts", verdicts), ("--plan", plan_file), ("--meta", meta_file)]
        + [("--checkpoints", f) for f in checkpoint_files]
    )
    pack = _pack(rules_ref, lang)
    inspector = load_inspector_input(verdicts) if verdicts else None
    got = _collected(paths, out, pack, inspector)
    checkpoints = _inspector_checkpoints(checkpoint_files, got)
    plan, meta, notes = _acceptance_inputs(plan_file, meta_file, got, paths, pack)
    for w in _checkpoint_warnings(got, checkpoints, plan, plan_file, pack):
        _warn(w)
    writing = {"templates": templates, "lang": lang, "pdf": pdf, "pdf_engine": pdf_engine}
    outcomes = _inspect_all(
        out, paths, writing, progress, got, pack, inspector, runner=runner,
        incremental=incremental, checkpoints=checkpoints, plan=plan, meta=meta, plan_notes=notes,
    )  # fmt: skip
    return batch.exit_status(outcomes)


def _as_workers_see(
    scheduler: str | None, paths: tuple[Path, ...], templates: Path | None
) -> tuple[tuple[Path, ...], Path | None]:
    """The paths given, absolute for the workers of a cluster on other machines (each runs in a
    folder of its own, the batch shared at the same path: README, "Beyond one machine"); as
    given otherwise."""
    if scheduler in (None, "local"):
        return paths, templates
    return tuple(p.absolute() for p in paths), None if templates is None else templates.absolute()


def _pack(rules_ref: str, lang: str):
    """The rule pack named, its rules without a Chinese title said when pages are in Chinese."""
    from blockqc.rules import load_pack
    from blockqc.rules.lint import untranslated_titles

    pack = load_pack(rules_ref)
    if lang == "zh":
        for w in untranslated_titles(pack):
            _warn(w)
    return pack


def _collected(paths: tuple[Path, ...], out: Path, pack, inspector):
    """The deliveries the paths name, refused where the output folder would be written into or
    beside one; files beside them, deliveries named twice, keys, figures and tables not read,
    said; the inspector's verdicts checked against the pack's rules and the blocks."""
    from blockqc import batch
    from blockqc.delivery import block_ids, unread_tables
    from blockqc.engine import reported_figure_names
    from blockqc.inspector import check_inspector_input
    from blockqc.outputs import refuse_block_folders, refuse_holding

    got = batch.collect(paths)
    refuse_block_folders(out, [m.block_id for m in got.manifests.values()])
    refuse_holding(out, got.deliveries)
    for f in got.files:
        _warn(f"{f}: a file beside the deliveries of a batch, not read")
    for d in got.repeated:
        _warn(f"{d}: named more than once, inspected once")
    figures = reported_figure_names(pack)
    for path, manifest in got.manifests.items():
        for w in manifest.unknown_keys + _unread_figures(manifest, figures) + unread_tables(path):
            _warn(w)
    if inspector is not None:
        ids, unread = block_ids(got.deliveries, got.manifests)
        check_inspector_input(inspector, {r.id: r for r in pack.rules}, ids, unread)
    return got


def _inspector_checkpoints(checkpoint_files: tuple[Path, ...], got):
    """--checkpoints: the inspector's checkpoints, their blocks checked against the deliveries
    (None when not given)."""
    if not checkpoint_files:
        return None
    from blockqc.checkpoint_inputs import check_blocks, load_checkpoint_files

    checkpoints = load_checkpoint_files(list(checkpoint_files))
    check_blocks(checkpoints, got.deliveries)
    return checkpoints


def _inspect_all(
    out: Path, paths, writing: dict, progress: bool | None, got, pack, inspector, **run_options
):
    """Inspect the deliveries collected into the output folder (made now that every input is
    read; removed again if left empty), then say the outcomes; returns them."""
    from blockqc import batch
    from blockqc.outputs import check_out_dir, empty_removed, out_lock

    with empty_removed(out):
        out = check_out_dir(out, paths)  # created once every input is read
        writer = batch.Writer(out, **writing)
        show = _is_terminal(sys.stderr) if progress is None else progress
        with out_lock(out), _progress(len(got.deliveries) if show else 0) as tick:
            outdated = batch.drop_outdated_summary(writer, got)
            if outdated:
                _warn(outdated)
            kept: list = []  # the blocks whose outputs are written (or reused), as they end
            with _said_if_stopped(out, kept, len(got.deliveries)):
                outcomes, summary = batch.run(
                    got, pack, writer, inspector, progress=_counted(tick, kept), **run_options
                )
    _closing_lines(outcomes, summary, out)
    return outcomes


def _counted(tick, kept: list):
    """The console's line of each outcome (`tick`), the blocks whose outputs are written or
    reused gathered in `kept`."""

    def said(o) -> None:
        if o.entry is not None:  # counted first: a signal may stop the run as its line is out
            kept.append(o.entry.block_id)
        tick(o)

    return said


@contextlib.contextmanager
def _said_if_stopped(out: Path, kept: list, total: int):
    """A batch run that stops (an output it cannot write, interrupted) says where the earlier
    run's summary is: set aside, since the blocks rewritten so far are no longer those it
    describes (`batch.run`); interrupted or terminated, how many blocks it finished (`kept`,
    of `total`), which main() says."""
    from blockqc.outputs import PREVIOUS_SUMMARY_DIR

    try:
        yield
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            exc.kept = (len(kept), total, out)
        if (out / PREVIOUS_SUMMARY_DIR).is_dir():
            echo(
                f"note: the earlier run's batch summary is kept in {out / PREVIOUS_SUMMARY_DIR}:"
                " this run stopped before writing its own (its blocks written so far are in "
                f"{out}, each whole)",
                err=True,
            )
        raise


def _unread_figures(manifest, figures: set[str] | None) -> list[str]:
    """block.yaml's reported figures that no rule of the pack recomputes (`figures`: those
    its rules do, None: no rule reads them): said, as an unknown key is."""
    from blockqc.schema import did_you_mean

    if figures is None:
        why = "not read: the rule pack has no rule recomputing reported figures (§DOC-2)"
        return [f"{at}: {why}" for at in manifest.reported_at.values()]
    hint = did_you_mean(sorted(figures - set(manifest.reported)))
    return [
        f"{at}: no rule of the pack recomputes a figure of this name (exempt in DOC-2){hint(k)}"
        for k, at in manifest.reported_at.items()
        if k not in figures
    ]


def _read_ahead(path: Path) -> None:
    """One delivery's tie points begin to be read while the modules below import (not in a
    batch, whose deliveries are read one after another or by other processes, nor when its
    earlier outputs may be reused: then they would be read for nothing). A path that cannot
    be looked at is left to the checks below, which say why."""
    try:
        delivery = (path / "block.yaml").is_file()
    except OSError:
        return
    if delivery:
        from blockqc import prefetch

        prefetch.start(path)


def _refuse_conflicts(no_pdf: bool, pdf: str, scheduler: str | None) -> None:
    """Options that contradict each other are refused rather than one silently winning."""
    given = click.get_current_context().get_parameter_source
    if no_pdf and pdf != "none" and given("pdf") is ParameterSource.COMMANDLINE:
        raise UsageError(f"--no-pdf contradicts --pdf {pdf}: give one of them")
    if scheduler is not None and given("jobs") is ParameterSource.COMMANDLINE:
        raise UsageError(
            "--jobs runs processes on this machine, --scheduler tasks on a Dask cluster's "
            "workers: give one of them"
        )


def _sampled_false_with_checkpoints(got, checkpoints) -> list[str]:
    """block.yaml's `sampled: false` of a delivery that carries checkpoints (its own, or the
    inspector's rows for it): without a plan, such a block is inspected in detail (§QE-1, the
    blocks with checkpoints are the sample) — said, never left unsaid."""
    by_block = checkpoints.block_ids() if checkpoints is not None else set()
    out = []
    for path, m in got.manifests.items():
        delivered = [
            f"checkpoints{x}" for x in (".csv", ".parquet") if (path / f"checkpoints{x}").is_file()
        ]
        given = checkpoints is not None and (m.block_id in by_block or not checkpoints.by_block)
        theirs = ["--checkpoints"] if given else []
        if m.sampled is False and delivered + theirs:
            out.append(
                f"{path / 'block.yaml'}: sampled: false, but its checkpoints are given "
                f"({', '.join(delivered + theirs)}): without a --plan a block that carries "
                "checkpoints is inspected in detail (its checkpoint rules judged) and counted in "
                "the sample"
            )
    return out


def _checkpoint_warnings(got, checkpoints, plan, plan_file: Path | None, pack) -> list[str]:
    """What the checkpoints given say against the sample, as warnings: without a plan, blocks
    marked `sampled: false` that carry checkpoints; under one, the inspector's rows of blocks
    it does not sample."""
    if plan is None:
        return _sampled_false_with_checkpoints(got, checkpoints)
    return _checkpoints_not_sampled(got, checkpoints, plan, plan_file, pack)


def _checkpoints_not_sampled(got, checkpoints, plan, plan_file: Path, pack) -> list[str]:
    """The inspector's checkpoint rows of a block the plan does not sample: under a plan only
    the sampled blocks are inspected in detail, so no rule judges them (unless a rule over the
    checkpoints is of the general inspection) — said, never dropped unsaid."""
    from blockqc.checkpoint_inputs import BLOCK
    from blockqc.metrics import REGISTRY

    readers = [r for r in pack.rules if r.metric in REGISTRY and REGISTRY[r.metric].detailed]
    if checkpoints is None or any(r.inspection == "general" for r in readers):
        return []
    rows = checkpoints.rows
    if not checkpoints.by_block:  # one delivery: the rows are its own
        ids = [m.block_id for m in got.manifests.values()]
        if not ids:
            return []  # its block.yaml could not be read: refused when it is
        rows = rows.assign(**{BLOCK: ids[0]})
    rows = rows[~rows[BLOCK].isin(plan.sampled)]
    return [
        f"{file}: {n} checkpoint(s) of block {block}, which the plan {plan_file} does not "
        "sample: not judged (under --plan only the sampled blocks are inspected in detail)"
        for (file, block), n in rows.groupby(["_file", BLOCK], sort=False).size().items()
    ]


def _acceptance_inputs(plan_file: Path | None, meta_file: Path | None, got, paths, pack):
    """§QE: the sampling plan checked against the batch inspected (where it differs without
    changing the sample: notes, each said as a warning), the report's particulars."""
    from blockqc.acceptance.plan import load_meta, load_plan
    from blockqc.acceptance.plan_check import check_blocks, check_strata, plan_notes
    from blockqc.delivery import is_delivery

    plan = load_plan(plan_file) if plan_file else None
    meta = load_meta(meta_file) if meta_file else None
    if meta is not None:
        _page_not_written(meta, meta_file, got.is_batch, pack)
    if plan is None:
        return plan, meta, []
    ids = [m.block_id for m in got.manifests.values()]
    unread = any(d not in got.manifests for d in got.deliveries)
    check_blocks(plan, plan_file, ids, got.is_batch, unread)
    blocks = {m.block_id: m.model_dump(mode="json") for m in got.manifests.values()}
    check_strata(plan, plan_file, blocks)
    if not got.is_batch:
        return plan, meta, []
    batch = paths[0].resolve().name if len(paths) == 1 and not is_delivery(paths[0]) else None
    sampling = pack.acceptance.sampling if pack.acceptance else None
    standard = pack.acceptance.standard if pack.acceptance else None
    notes, warnings = plan_notes(
        plan, plan_file, ids, batch, f"{pack.name} {pack.version}", sampling, standard
    )
    for w in warnings:
        _warn(w)
    return plan, meta, notes


#: the particulars of --meta that only the batch's acceptance page shows
ACCEPTANCE_PAGE_ONLY = (
    "inspection_unit", "inspection_unit_zh", "basis", "basis_zh", "handling", "handling_zh",
    "annexes",
)  # fmt: skip


def _page_not_written(meta, meta_file: Path, is_batch: bool, pack) -> None:
    """Warn of particulars given for the acceptance page when this run writes none (one
    delivery, or a pack without `acceptance:`): they are kept in results.json only."""
    if is_batch and pack.acceptance is not None:
        return
    given = [k for k in ACCEPTANCE_PAGE_ONLY if getattr(meta, k)]
    if given:
        why = "a batch" if pack.acceptance is not None else "a pack with an acceptance: section"
        _warn(
            f"{meta_file}: {', '.join(given)}: shown on the batch's acceptance page only, "
            f"which this run does not write (it needs {why}); kept in results.json"
        )


def _warn(message: str) -> None:
    """A warning on stderr, its input text shown escaped where a terminal would obey it."""
    echo(f"warning: {shown(str(message))}", err=True)


def _style(text: str, **how) -> str:
    """click.style, unless NO_COLOR is set (no-color.org)."""
    return text if os.environ.get("NO_COLOR") else click.style(text, **how)


def _outcome_line(o) -> str:
    """One line per delivery: the verdict and the rules behind it, or why it was not read."""
    e = o.entry
    if e is None:
        n = len(o.problems)
        problems = f"{n} problem{'' if n == 1 else 's'}"
        return _style(f"{shown(str(o.path))}  UNREADABLE  ({problems})", fg="red")
    failed = "failed or in error" if e.verdict == "error" else "failed"  # failed_rules: both
    notes = [f"{failed}: {', '.join(e.failed_rules)}"] if e.failed_rules else []
    notes += [f"warnings: {', '.join(e.warned_rules)}"] if e.warned_rules else []
    notes += [f"awaiting the inspector: {', '.join(e.pending_manual)}"] if e.pending_manual else []
    notes += ["unchanged, outputs reused"] if o.cached else []
    verdict = _style(f"{e.verdict.upper():5}", fg=STATUS_STYLE.get(e.verdict), bold=True)
    return f"{e.block_id:12} {verdict}  " + "; ".join(notes)


@contextlib.contextmanager
def _progress(total: int):
    """A progress bar on stderr for batches (total > 1), else one line per outcome on stdout."""
    if total <= 1:
        yield lambda o: echo(_outcome_line(o))
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.text import Text

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn())
    with Progress(
        *columns, TimeElapsedColumn(), console=Console(stderr=True), transient=True
    ) as bar:
        task = bar.add_task("inspecting", total=total)

        def tick(o) -> None:  # colours as rich decides: none into a pipe or with NO_COLOR
            bar.console.print(Text.from_ansi(_outcome_line(o)), highlight=False)
            bar.advance(task)

        yield tick


def _is_terminal(stream) -> bool:
    """Whether `stream` is a terminal; not when there is none (None: the process was started
    with it closed, `2>&-`)."""
    return stream is not None and stream.isatty()


def echo(line: str, err: bool = False) -> None:
    """A line on stdout (stderr with `err`); when its reader has gone (`| head -1`, `2>&1 |
    head -1`) the run goes on, silent: the stream is pointed at the null device, so that nothing
    more is lost but the lines not wanted, and the run's exit status is its own. A process
    started without the stream (`>&-`: None) writes nothing, as click.echo does."""
    try:
        click.echo(line, err=err)
        stream = sys.stderr if err else sys.stdout
        if stream is not None:
            stream.flush()
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2 if err else 1)
        os.close(devnull)


def _closing_lines(outcomes, summary, out: Path) -> None:
    """Every problem, then where the results are — or that nothing was written."""
    for o in outcomes:
        for p in o.problems:
            echo(f"error: {p}", err=True)
        for e in o.errors:  # a rule that could not be judged: why, beside the block's line
            echo(f"error: {shown(f'{o.path}: {e}')}", err=True)
        for w in o.warnings:
            _warn(w)
    if summary is not None:
        _warn_other_blocks(out, {b.block_id for b in summary.blocks})
        c = summary.counts
        error = f" (of which {c.error} ERROR: a rule could not be judged)" if c.error else ""
        echo(
            f"{c.blocks} block{'' if c.blocks == 1 else 's'}: {c.pass_} pass, {c.fail} fail"
            f"{error}, {c.unreadable} unreadable — {out / 'summary.html'}"
        )
    elif all(o.entry is None for o in outcomes):
        echo("nothing was written: the delivery could not be inspected", err=True)
    else:
        echo(f"results in {out}")


def _warn_other_blocks(out: Path, blocks: set[str]) -> None:
    """Block outputs in `out` of no block of this batch (an earlier run's, of a delivery since
    withdrawn): left as they are, never deleted, but said, since `blockqc report OUT` would
    otherwise find them beside the summary."""
    for folder in sorted(out.iterdir()):
        if folder.name not in blocks and (folder / "results.json").is_file():
            echo(
                f"warning: {folder}: outputs of block {folder.name}, which this batch does not "
                "hold (an earlier run's?): left as they are, not in the summary",
                err=True,
            )


# ---------------------------------------------------------------------------------- schema
@cli.command("schema")
@click.argument("kind", type=click.Choice(["results", "summary"]))
def schema_cmd(kind: str) -> None:
    """Print the JSON Schema of results.json or summary.json."""
    import json

    from blockqc.results import json_schema

    click.echo(json.dumps(json_schema(kind), indent=2, ensure_ascii=False))


# ------------------------------------------------------------------------------ simulate
#: footprints per side of a simulated block (3 scenes each), and tie-point observations per
#: scene: bound memory and time
MAX_GRID = 20
MAX_OBS_PER_SCENE = 100_000
#: tie-point observations per block (2 PAN scenes a footprint): 12 million (20x20 at 15000) holds
#: the 10 million of a national project's largest block; written at about 0.44 GB of memory and
#: 33 s a million (20x20 at 100000 would need some 35 GB and 40 minutes)
MAX_OBS_PER_BLOCK = 12_000_000


@cli.command("simulate")
@click.argument("out", type=GivenPath(), required=False)
@click.option(
    "--seed", default=20231, show_default=True, type=click.IntRange(min=0), help="Random seed."
)
@click.option(
    "--fields",
    default="1,2,3,4",
    show_default=True,
    help="Published test fields to mirror (comma separated).",
)
@click.option(
    "--blocks-per-field",
    default=2,
    show_default=True,
    type=click.IntRange(1, 50),
    help="Blocks written per field.",
)
@click.option(
    "--grid",
    default="4x4",
    show_default=True,
    help="Footprints per block, ROWSxCOLS (3 scenes each: F and B PAN, B MS).",
)
@click.option(
    "--obs-per-scene",
    default=300,
    show_default=True,
    type=click.IntRange(10, MAX_OBS_PER_SCENE),
    help=f"Tie-point observations per PAN scene (about; at most {MAX_OBS_PER_SCENE}).",
)
@click.option(
    "--fault",
    "faults",
    multiple=True,
    help="Switch a fault on (repeatable); --list-faults shows them.",
)
@click.option("--list-faults", is_flag=True, help="List the faults and exit.")
@click.option(
    "--dem-dir",
    type=GivenPath("the folder of the DEM tiles", file_okay=False),
    help="Folder of the DEM tiles (default: samples/dem of the checkout).",
)
def simulate_cmd(
    out: Path | None,
    seed: int,
    fields: str,
    blocks_per_field: int,
    grid: str,
    obs_per_scene: int,
    faults: tuple[str, ...],
    list_faults: bool,
    dem_dir: Path | None,
) -> None:
    """Write sample deliveries that mirror the four published test fields."""
    from blockqc.simulate import FAULTS, Layout, Options, simulate

    if list_faults:
        for name, what in FAULTS.items():
            click.echo(f"{name:18} {what}")
        return
    if out is None:
        raise UsageError("Missing argument 'OUT': the folder to write the deliveries into")
    try:
        rows, cols = (int(v) for v in grid.lower().split("x"))
    except ValueError:
        raise UsageError(f"--grid is ROWSxCOLS (e.g. 4x4), got {grid!r}") from None
    try:
        chosen = tuple(int(f) for f in fields.split(","))
    except ValueError:
        raise UsageError(f"--fields is a list like 1,2,3,4, got {fields!r}") from None
    if not (1 <= rows <= MAX_GRID and 1 <= cols <= MAX_GRID):
        raise UsageError(f"--grid {grid}: ROWS and COLS are 1 to {MAX_GRID} (e.g. 4x4)")
    per_block = 2 * rows * cols * obs_per_scene
    if per_block > MAX_OBS_PER_BLOCK:
        raise UsageError(
            f"--grid {grid} with --obs-per-scene {obs_per_scene}: {per_block:,} tie-point "
            f"observations per block (2 PAN scenes a footprint), more than the "
            f"{MAX_OBS_PER_BLOCK:,} a block may hold (memory and time); make the grid or "
            "--obs-per-scene smaller"
        )
    if len(set(chosen)) != len(chosen):
        raise UsageError(f"--fields {fields}: a field is named twice")
    opts = Options(
        seed=seed,
        fields=chosen,
        blocks_per_field=blocks_per_field,
        layout=Layout(rows=rows, cols=cols, obs_per_scene=obs_per_scene),
        faults=frozenset(faults),
    )
    ids = simulate(out, opts, dem_dir)
    click.echo(f"wrote {len(ids)} deliveries to {out}: {', '.join(ids)}")


def _template_error(exc: Exception) -> bool:
    """Whether a page could not be rendered from its templates (a user's that fails at run time:
    an undefined name); jinja2 is imported only then."""
    import jinja2

    return isinstance(exc, jinja2.TemplateError)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the process is, so that a run stops as on Ctrl-C: its workers
    finish the blocks they write, its staged outputs and lock are cleared, and it says so."""


def _terminated(signum, frame) -> None:
    raise Terminated


def _stopped(exc: KeyboardInterrupt) -> None:
    """Say that the run was interrupted (Ctrl-C: exit 130) or terminated (SIGTERM: 143), and
    for an inspection how many of its blocks were finished, their outputs kept."""
    terminated = isinstance(exc, Terminated)
    line = "terminated" if terminated else "interrupted"
    if (kept := getattr(exc, "kept", None)) is not None:
        n, total, out = kept
        blocks = f"{total} block{'' if total == 1 else 's'}"
        line += (
            f": {n} of {blocks} finished, their outputs kept in {out} (each whole; an "
            "--incremental run reuses them)"
            if n
            else f": none of {blocks} finished"
        )
    echo(line, err=True)
    sys.exit(143 if terminated else 130)


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the command group, turning blockqc's errors into messages and exit 2."""
    memory.tune()  # before any command imports numpy
    if threading.current_thread() is threading.main_thread():  # signals go to the main one
        signal.signal(signal.SIGTERM, _terminated)
    try:
        rc = cli.main(args=argv, prog_name="blockqc", standalone_mode=False)
    except BlockqcError as exc:
        for problem in exc.problems:
            echo(f"error: {problem}", err=True)
        sys.exit(exc.exit_code)
    except click.exceptions.Abort as exc:
        if isinstance(exc.__cause__, KeyboardInterrupt):  # Ctrl-C or SIGTERM during a command
            _stopped(exc.__cause__)
        echo("aborted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        exc.show()
        sys.exit(2)
    except KeyboardInterrupt as exc:
        _stopped(exc)
    except OSError as exc:  # the system refused a path: too long, a link loop, no space …
        where = f"{exc.filename}: " if exc.filename else ""  # a raster library's names the file
        echo(f"error: {where}{exc.strerror or exc}", err=True)
        sys.exit(2)
    except Exception as exc:  # a defect of blockqc, not of the input: say so, briefly
        if os.environ.get("BLOCKQC_DEBUG"):
            raise
        if isinstance(exc, RuntimeError) and str(exc).startswith("Symlink loop"):
            echo(f"error: {exc}: a symbolic link leads back to itself", err=True)
            sys.exit(2)
        from blockqc.outputs import template_problem

        if (found := template_problem(exc)) is not None:
            echo(f"error: {found}", err=True)
            sys.exit(2)
        if _template_error(exc):
            why = f"{type(exc).__name__}: {exc}"
            echo(f"error: a template of --templates failed: {why}", err=True)
            sys.exit(2)
        echo(
            f"internal error: {type(exc).__name__}: {exc} (set BLOCKQC_DEBUG=1 for the "
            "traceback; please report it)",
            err=True,
        )
        sys.exit(2)
    sys.exit(rc if isinstance(rc, int) else 0)


def run() -> None:
    """The command line as a process (`blockqc`, `python -m blockqc`): main(), then the process
    ends once its streams are flushed and its exit handlers have run, without tearing down every
    module it imported one object at a time (0.14 s at the end of every command; the system takes
    the memory back at once). Under a tracer or profiler (coverage, cProfile) it ends as
    Python does, so that they write their results."""
    try:
        main()
    except SystemExit as exc:
        status = exc.code
    else:
        status = 0
    ends_here = isinstance(status, int) and hasattr(atexit, "_run_exitfuncs")
    if not ends_here or sys.gettrace() is not None or sys.getprofile() is not None:
        sys.exit(status)
    for stream in (sys.stdout, sys.stderr):
        if stream is None:  # the process was started with it closed (`>&-`): nothing to flush
            continue
        with contextlib.suppress(OSError, ValueError):  # a pipe its reader closed: nothing to do
            stream.flush()
    atexit._run_exitfuncs()
    os._exit(status)
