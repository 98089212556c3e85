"""Inspecting many deliveries: per-block outputs and the batch summary (contract v1).

Each delivery is inspected and written by a `Job` — in this process, in a pool of processes
(`--jobs`) or on a dask.distributed cluster (`--scheduler`) — which hands back only the block's
line of the summary: a batch never holds the results of all its blocks.
"""

from __future__ import annotations

import ctypes
import datetime as dt
import json
import os
import shutil
import signal
import sys
from collections.abc import Callable, Iterable
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from blockqc import __version__, pieces
from blockqc.acceptance.decision import decide
from blockqc.acceptance.evaluate import evaluate_results
from blockqc.acceptance.model import BatchDecision, BlockGrade, PlanNote, ReportMeta
from blockqc.acceptance.plan import Plan, apply_plan
from blockqc.acceptance.scoring import a_class_errors
from blockqc.cache import (
    CACHE_FILE,
    Cached,
    Untrusted,
    delivery_fingerprint,
    forget_block,
    forget_summary,
    read_cached,
    write_cached,
)
from blockqc.checkpoint_inputs import InspectorCheckpoints, merge_checkpoints
from blockqc.delivery import (
    MANIFEST,
    Manifest,
    batch_files,
    find_deliveries,
    is_delivery,
    load_delivery,
    load_manifest,
    not_a_manifest,
)
from blockqc.engine import inspect_delivery, names_for, tie_point_columns
from blockqc.errors import InputError, OutputError, Problem
from blockqc.inspector import InspectorInput
from blockqc.outputs import (
    BATCH_OUTPUTS,
    BLOCK_OUTPUTS,
    PREVIOUS_SUMMARY_DIR,
    clear_staging,
    drop_set_aside,
    publish,
    refusal,
    restore_summary,
    safe_child,
    set_aside_summary,
    staged_folder,
    template_problem,
    write_json_atomic,
)
from blockqc.report import checkpoint_rows, write_block_report, write_summary_report
from blockqc.results import (
    STATUSES,
    BatchCounts,
    BlockEntry,
    BlockResults,
    Rejected,
    Summary,
    block_fails,
)
from blockqc.rules.model import Pack
from blockqc.textio import dangling_link, real_path, unreadable_path

PDF_POLICIES = ("all", "failing", "sampled", "none")
_PR_SET_PDEATHSIG = 1  # Linux prctl: the signal a process gets when its parent dies


@dataclass
class Outcome:
    """One delivery's fate: its line of the summary, or the problems that kept it from being
    inspected. `rules` counts its results per rule and status; `cached` when reused unchanged."""

    path: Path
    entry: BlockEntry | None = None
    rules: dict[str, dict[str, int]] = field(default_factory=dict)
    problems: list[Problem] = field(default_factory=list)
    cached: bool = False
    grade: BlockGrade | None = None  # §QE, for the batch decision
    key: str | None = None  # incremental mode: the key its outputs were reused or written under
    errors: list[str] = field(default_factory=list)  # rules in error: "RULE: why"
    warnings: list[str] = field(default_factory=list)  # e.g. a cache not trusted
    block_id: str | None = None  # not inspected: its block id, when its block.yaml was read


@dataclass
class Collected:
    """The deliveries named on the command line, each manifest read once."""

    deliveries: list[Path]
    is_batch: bool
    manifests: dict[Path, Manifest] = field(default_factory=dict)
    refused: dict[Path, Problem] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)  # lying beside a batch's deliveries, unread
    repeated: list[Path] = field(default_factory=list)  # named again: inspected once


def _nested(path: Path) -> str:
    """What to say of a batch's sub-folder without block.yaml whose own sub-folders hold one:
    a batch inside the batch, whose deliveries are not inspected."""
    with suppress(OSError):
        inner = sorted(p.name for p in path.iterdir() if is_delivery(p))
        if inner:
            more = f" and {len(inner) - 3} more" if len(inner) > 3 else ""
            return (
                f"; it holds deliveries ({', '.join(inner[:3])}{more}): a batch inside the "
                "batch, whose deliveries are not inspected; give it as a batch of its own"
            )
    return ""


def collect(paths: Iterable[Path]) -> Collected:
    """The delivery folders named by the arguments; duplicate block ids refused up front."""
    found: list[Path] = []
    batch = False
    for p in paths:
        ds = find_deliveries(Path(p))
        batch |= len(ds) > 1 or ds[0] != Path(p)
        found.extend(ds)
    once: dict[Path, Path] = {}  # each folder once, where it is first named
    repeated = [d for d in found if once.setdefault(real_path(d), d) is not d]
    found = list(once.values())
    got = Collected(
        found,
        batch or len(found) > 1,
        files=[f for p in paths for f in batch_files(p)],
        repeated=list(dict.fromkeys(repeated)),
    )
    seen: dict[str, tuple[Path, str]] = {}  # block ids (case folded) met so far
    for path in found:
        if problem := _not_a_delivery(path):
            got.refused[path] = problem
            continue
        try:
            manifest = got.manifests[path] = load_manifest(path / MANIFEST)
        except InputError:
            continue  # reported in full when the delivery is read
        if problem := _block_id_taken(path, manifest.block_id, seen):
            got.refused[path] = problem
    return got


def _not_a_delivery(path: Path) -> Problem | None:
    """Why a folder of the batch is no delivery: a link to nothing, no block.yaml (or one that
    is no file); None when it is one."""
    if link := dangling_link(path):
        return Problem(
            str(path),
            f"{link}: a delivery of the batch moved or removed? (give it again, or remove the "
            "link)",
        )
    if is_delivery(path):
        return None
    return Problem(
        str(path / MANIFEST),
        not_a_manifest(path)
        or "missing: every sub-folder of a batch is a delivery and needs its block.yaml "
        f"(folders named '.…' are left out){_nested(path)}",
    )


def _block_id_taken(path: Path, block_id: str, seen: dict[str, tuple[Path, str]]) -> Problem | None:
    """A block id that a delivery met before has, whatever the case (their outputs would share
    a folder on Windows and macOS); else None, the id now met."""
    key = block_id.casefold()
    if key not in seen:
        seen[key] = (path, block_id)
        return None
    other, first = seen[key]
    same = f"differs only in case from {first}," if first != block_id else "is also"
    return Problem(
        str(path / MANIFEST),
        f"block_id {block_id} {same} the id of {other}: block ids must be unique in a batch, "
        "whatever their case (their outputs share a folder on Windows and macOS)",
    )


@dataclass(frozen=True)
class Extra:
    """The inspector's checkpoints (contract v1.1, `--checkpoints FILE…`), merged per block;
    `single` when one delivery is inspected (its file then needs no block_id column)."""

    checkpoints: InspectorCheckpoints | None = None
    single: bool = True
    plan: Plan | None = None  # §QE-1: the sampled blocks get the detailed inspection
    meta: ReportMeta | None = None  # the filed report's particulars
    plan_notes: tuple[PlanNote, ...] = ()  # where the plan differs from the batch inspected


SAMPLED_WITHOUT_CHECKPOINTS = (
    "sampled: true, but the delivery gives no checkpoints (checkpoints.csv or .parquet, or the "
    "inspector's --checkpoints): a sampled block is judged on its checkpoints; give them, or "
    "sampled: false"
)


def inspect_one(
    path: Path,
    pack: Pack,
    inspector: InspectorInput | None,
    manifest: Manifest | None = None,
    extra: Extra | None = None,
) -> BlockResults:
    """Read one delivery (InputError when it cannot be) and judge every rule of the pack."""
    delivery = load_delivery(path, manifest=manifest, tie_point_columns=tie_point_columns(pack))
    if extra is not None and extra.checkpoints is not None:
        merge_checkpoints(delivery, extra.checkpoints.for_block(delivery.block_id, extra.single))
    if delivery.manifest.sampled and (delivery.checkpoints is None or delivery.checkpoints.empty):
        raise InputError(Problem(str(path / MANIFEST), SAMPLED_WITHOUT_CHECKPOINTS))
    block_input = inspector.for_block(delivery.block_id) if inspector else None
    results = inspect_delivery(
        delivery, pack, block_input, inspector.inspector if inspector else None
    )
    if extra is not None and extra.plan is not None:
        apply_plan(results, results.block_id in extra.plan.sampled)
    results.evaluation = evaluate_results(results, pack, names_for(delivery, pack))
    if extra is not None and extra.meta is not None:
        results.meta = _meta(extra.meta, pack)
    return results


def _meta(meta: ReportMeta | None, pack: Pack) -> ReportMeta | None:
    """The report's particulars with the pack's inspection basis where the file gives none;
    a file giving its own basis in English alone has it on the pages in Chinese too, not the
    pack's documents."""
    if pack.acceptance is None and meta is None:
        return None
    meta = (meta or ReportMeta()).model_copy()
    if pack.acceptance is not None and not meta.basis:
        meta.basis = list(pack.acceptance.basis)
        meta.basis_zh = meta.basis_zh or list(pack.acceptance.basis_zh)
    return meta


@dataclass(frozen=True)
class Writer:
    """Where and how the outputs are written; `pdf` is one of PDF_POLICIES, `pdf_engine` what
    lays the PDFs out."""

    out: Path
    templates: Path | None = None
    lang: str = "en"
    pdf: str = "all"
    pdf_engine: str = "weasyprint"

    def wants_pdf(self, results: BlockResults) -> bool:
        """all; failing blocks; sampled ones (the plan's, or without a plan those with
        checkpoints); none."""
        if self.pdf == "failing":
            return block_fails(results.verdict)
        if self.pdf == "sampled":
            return _sampled(results)
        return self.pdf == "all"

    def block(self, results: BlockResults) -> bool:
        """results.json first, the report rendered from it, written apart and put in place
        (`publish`: never an earlier PDF beside new results; a failure leaves the earlier
        outputs); whether a PDF was written."""
        folder = safe_child(self.out, results.block_id, source=results.delivery)
        staged = staged_folder(self.out, results.block_id)
        try:
            write_json_atomic(staged / "results.json", results)
            pdf = self.wants_pdf(results)
            write_block_report(
                staged, results, lang=self.lang, templates=self.templates, pdf=pdf,
                pdf_engine=self.pdf_engine,
            )  # fmt: skip
            publish(staged, folder, (*BLOCK_OUTPUTS, CACHE_FILE), last="results.json")
        finally:
            shutil.rmtree(staged, ignore_errors=True)
        return pdf

    def discard(self, block_id: str) -> None:
        """Remove the block's outputs (and its folder, when nothing else is left in it)."""
        try:
            folder = safe_child(self.out, block_id)
        except (InputError, OutputError):
            return  # an id that cannot name a folder of the outputs has none, nor a link out
        for name in (*BLOCK_OUTPUTS, CACHE_FILE):
            with suppress(OSError):  # a file in the folder's place: nothing of ours to remove
                (folder / name).unlink(missing_ok=True)
        with suppress(OSError):
            folder.rmdir()

    def drop_summary(self) -> None:
        """Remove the batch outputs (summary, acceptance pages) and the key that vouched for
        them: no summary of an earlier run is taken for this one's."""
        forget_summary(self.out)
        for name in BATCH_OUTPUTS:
            with suppress(OSError):
                (self.out / name).unlink(missing_ok=True)

    def summary(self, summary: Summary, jobs: int = 1) -> list[Path]:
        """summary.json and the summary reports, written apart and put in place together
        (`publish`: summary.json last; an earlier run's summary PDF or acceptance page not
        made again removed): a page that cannot be made, or a run stopped meanwhile, leaves
        none of them; the files written."""
        staged = staged_folder(self.out, "summary")
        try:
            write_json_atomic(staged / "summary.json", summary)
            pdf = self.pdf != "none"
            made = write_summary_report(
                staged, summary, lang=self.lang, templates=self.templates, pdf=pdf, jobs=jobs,
                pdf_engine=self.pdf_engine,
            )  # fmt: skip
            publish(staged, self.out, BATCH_OUTPUTS, last="summary.json")
        finally:
            clear_staging(self.out)
        return [self.out / "summary.json"] + [self.out / p.name for p in made]


def block_entry(path: Path, r: BlockResults, pdf: bool) -> BlockEntry:
    """A block's line in the summary, with the checkpoint statistics of sampled blocks."""
    from blockqc.report.overview import block_extent

    return BlockEntry(
        block_id=r.block_id,
        verdict=r.verdict,
        path=str(path),
        results=f"{r.block_id}/results.json",
        report=f"{r.block_id}/report.html",
        sampled=_sampled(r),
        failed_rules=sorted({x.rule for x in r.results if x.status in ("fail", "error")}),
        warned_rules=sorted({x.rule for x in r.results if x.status == "warn"}),
        pending_manual=r.pending_manual,
        counts=r.counts,
        complete=r.complete,
        checkpoints=checkpoint_rows(r),
        extent_wkt=block_extent(r.scenes),
        pdf=pdf,
        **_evaluation_fields(r),
    )


def _evaluation_fields(r: BlockResults) -> dict[str, Any]:
    ev = r.evaluation
    if ev is None:
        return {}
    return {
        "score": ev.score,
        "grade": ev.grade,
        "evaluation_fails": ev.fails,
        "evaluation_reasons": ev.reasons,
    }


def _sampled(r: BlockResults) -> bool:
    """Sampled by the plan; without a plan, a block that carries checkpoints."""
    return r.sampled if r.sampled is not None else r.summary.get("checkpoints", 0) > 0


def block_grade(r: BlockResults, pack: Pack) -> BlockGrade | None:
    """§QE: what the batch decision needs of one block."""
    return None if pack.acceptance is None else graded(r)


def graded(r: BlockResults) -> BlockGrade | None:
    """What the batch decision needs of one block, from its results file alone (its evaluation
    records the pack's element_fail_below); None when the block was not evaluated."""
    ev = r.evaluation
    if ev is None:
        return None
    below = ev.element_fail_below
    low = [
        e.model_dump(include={"id", "title", "title_zh", "score"}) | {"below": below}
        for e in ev.elements
        if e.score is not None and e.score < below
    ]
    failed = sorted({x.rule for x in r.results if x.status in ("fail", "error")})  # cf. tally
    return BlockGrade(
        block_id=r.block_id, sampled=_sampled(r), score=ev.score, grade=ev.grade, fails=ev.fails,
        complete=ev.complete, reasons=ev.reasons, failed_rules=failed,
        a_errors=a_class_errors(ev), low_elements=low,
    )  # fmt: skip


def delivery_warnings(path: Path, r: BlockResults) -> list[str]:
    """What the delivery gives that its rules judge as given, but an inspector should know."""
    n = r.summary.get("tie_points_on_one_scene")
    one_scene = [
        f"{path}: {n} of {r.summary['tie_points']} tie points are observed on one scene only: "
        "they tie no scenes, and are counted as delivered (TP-1..TP-4)"
    ]
    return (one_scene if n else []) + r.input_warnings


def rule_counts(r: BlockResults) -> dict[str, dict[str, int]]:
    out: dict[str, dict[str, int]] = {}
    for res in r.results:
        out.setdefault(res.rule, dict.fromkeys(STATUSES, 0))[res.status] += 1
    return out


@dataclass(frozen=True)
class Job:
    """Inspect one delivery and write its outputs; runs here, in a worker process or on a dask
    worker. With `digest` (incremental mode) an unchanged delivery's outputs are reused."""

    pack: Pack
    inspector: InspectorInput | None
    writer: Writer
    digest: str | None = None
    extra: Extra | None = None

    def __call__(self, path: Path, manifest: Manifest | None = None) -> Outcome:
        try:
            key, untrusted = self._key(path, manifest), []
            if key:
                hit, untrusted = self._reused(manifest.block_id, key)
                if hit is not None:
                    o = Outcome(path, hit.entry, hit.rules, cached=True, grade=hit.grade, key=key)
                    o.errors = hit.errors or []  # why its rules in error are, said again
                    o.warnings = hit.warnings or []  # and what its delivery gives, said again
                    return o
            results = inspect_one(path, self.pack, self.inspector, manifest, self.extra)
            o = self._written(path, results, key)
            o.warnings = [*untrusted, *o.warnings]
            return o
        except OutputError:
            raise  # no fault of the delivery: the run stops
        except InputError as exc:
            return self._not_inspected(path, manifest, exc.problems)
        except OSError as exc:  # a file or folder gone (or refused) since the batch was read
            return self._not_inspected(path, manifest, [unreadable_path(path, exc)])
        except Exception as exc:  # one block's failure must not stop the batch
            reason = f"could not be inspected: {type(exc).__name__}: {exc}"
            return self._not_inspected(path, manifest, [Problem(str(path), reason)])

    def _reused(self, block_id: str, key: str) -> tuple[Cached | None, list[str]]:
        """The block's cached line under `key`, if its outputs can be reused; else None, and
        why a cache that was there was not trusted (said as a warning)."""
        try:
            hit = read_cached(safe_child(self.writer.out, block_id), key)
        except Untrusted as exc:
            return None, [f"{exc}: not trusted, the block was inspected again"]
        if hit is not None and hit.entry.block_id != block_id:
            why = f"{CACHE_FILE} of block {block_id} names block {hit.entry.block_id}"
            return None, [f"{why}: not trusted, the block was inspected again"]
        return hit, []

    def _written(self, path: Path, results: BlockResults, key: str | None) -> Outcome:
        """The block's outputs written, and its outcome; a failure to write them stops the run
        (OutputError): it is no fault of the delivery, which was inspected."""
        try:
            folder = safe_child(self.writer.out, results.block_id, source=results.delivery)
            forget_block(folder)
            forget_summary(self.writer.out)  # both rewritten: no key may vouch for them meanwhile
            pdf = self.writer.block(results)
            grade = block_grade(results, self.pack)
            o = Outcome(path, block_entry(path, results, pdf), rule_counts(results), grade=grade)
            o.errors = [
                f"{r.rule}: {r.detail.get('reason', 'see results.json')}"
                for r in results.results
                if r.status == "error"
            ]
            o.key = key
            o.warnings = delivery_warnings(path, results)
            if key:
                cached = Cached(key, o.entry, o.rules, grade, errors=o.errors, warnings=o.warnings)
                write_cached(folder, cached)
            return o
        except (InputError, OutputError):
            raise  # an output name the block id cannot give (safe_child): the delivery's own;
            # or a folder refused there (a link out of `--out`): the output folder's
        except Exception as exc:  # its earlier outputs are left whole (`Writer.block`)
            raise output_error(results.block_id, self.writer.out, exc) from None

    def _not_inspected(
        self, path: Path, manifest: Manifest | None, problems: list[Problem]
    ) -> Outcome:
        """A delivery that could not be inspected: the outputs of its block id (from an earlier
        run, or written by this one before it failed) are removed, so that none is taken for
        its results."""
        if manifest is None:
            return Outcome(path, problems=problems)
        self.writer.discard(manifest.block_id)
        return Outcome(path, problems=problems, block_id=manifest.block_id)

    def _key(self, path: Path, manifest: Manifest | None) -> str | None:
        if self.digest is None or manifest is None:
            return None
        block_id, extra = manifest.block_id, self.extra or Extra()
        block_input = self.inspector.for_block(block_id) if self.inspector else None
        cps = extra.checkpoints
        rows = None if cps is None else cps.for_block(block_id, extra.single)
        sampled = None if extra.plan is None else block_id in extra.plan.sampled
        return delivery_fingerprint(path, self.digest, block_input, rows, sampled, manifest)


def output_error(block_id: str, out: Path, exc: Exception) -> OutputError:
    """Why the outputs of a block could not be written: at the template's file and line when
    a template failed, else at the block's output folder."""
    found = template_problem(exc, f" on block {block_id}")
    if found is not None:
        return OutputError(found)
    message = f"the outputs of block {block_id} could not be written"
    if isinstance(exc, OSError) and exc.filename:
        where, why = refusal(exc)
        return OutputError(Problem(where, f"{message}: {why}"))
    return OutputError(Problem(str(out / block_id), f"{message}: {type(exc).__name__}: {exc}"))


def decision(outcomes: list[Outcome], pack: Pack, extra: Extra) -> BatchDecision | None:
    """§QE-5: the batch decision over the blocks inspected (None without acceptance), with where
    the plan differs from the batch."""
    if pack.acceptance is None:
        return None
    grades = [o.grade for o in outcomes if o.grade is not None]
    unread = [o.block_id or o.path.name for o in outcomes if o.entry is None]
    plan = extra.plan
    source, planned = ("plan", plan.sampled) if plan else ("checkpoints", None)
    out = decide(grades, pack.acceptance, source, unread, planned)
    out.plan_notes = list(extra.plan_notes)
    return out


def summarize(
    outcomes: list[Outcome],
    pack: Pack,
    inspector: InspectorInput | None,
    extra: Extra | None = None,
) -> Summary:
    """summary.json of a batch: one entry per block, counts per rule, rejected deliveries."""
    blocks: list[BlockEntry] = []
    rejected: list[Rejected] = []
    rules: dict[str, dict[str, int]] = {r.id: dict.fromkeys(STATUSES, 0) for r in pack.rules}
    for o in outcomes:
        if o.entry is None:
            rejected.append(Rejected(path=str(o.path), problems=[str(p) for p in o.problems]))
            continue
        for rid, counts in o.rules.items():
            mine = rules.setdefault(rid, dict.fromkeys(STATUSES, 0))
            for status, n in counts.items():
                mine[status] += n
        blocks.append(o.entry)
    failing = [b for b in blocks if block_fails(b.verdict)]
    verdict = "error" if rejected else "fail" if failing else "pass"
    return Summary(
        rule_pack=pack.name,
        rule_pack_version=pack.version,
        blockqc_version=__version__,
        generated_at=dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        inspector=inspector.inspector if inspector else None,
        verdict=verdict,
        complete=not rejected and all(b.complete and not b.pending_manual for b in blocks),
        counts=BatchCounts(
            blocks=len(outcomes),
            **{"pass": len(blocks) - len(failing)},
            fail=len(failing),
            error=sum(b.verdict == "error" for b in blocks),
            unreadable=len(rejected),
        ),
        blocks=blocks,
        rules=rules,
        unreadable=rejected,
        **_acceptance_fields(outcomes, pack, extra or Extra()),
    )


def _acceptance_fields(outcomes: list[Outcome], pack: Pack, extra: Extra) -> dict[str, Any]:
    """§QE: the batch decision, the sampling plan, the report's particulars."""
    table = pack.acceptance.sampling.table if pack.acceptance else []
    return {
        "acceptance": decision(outcomes, pack, extra),
        "sampling": extra.plan.model_dump(mode="json") if extra.plan else None,
        "meta": _meta(extra.meta, pack),
        "elements": pack.elements,
        "sampling_table": [r.model_dump() for r in table],
    }


@dataclass(frozen=True)
class Runner:
    """Where the jobs run: here, `jobs` local processes, or a dask scheduler ('local' or an
    address such as tcp://host:8786)."""

    jobs: int = 1
    scheduler: str | None = None

    def __post_init__(self) -> None:
        if self.scheduler is not None:  # a wrong or empty address, or one where no scheduler
            from blockqc.distributed import check_reachable, check_scheduler  # answers: refused

            check_scheduler(self.scheduler)  # before anything runs
            check_reachable(self.scheduler)

    def run(self, job: Job, todo: list[tuple[Path, Manifest | None]], done: Callable) -> None:
        if self.scheduler:
            from blockqc.distributed import run_on_dask

            run_on_dask(
                self.scheduler, job, todo, done, lambda p, m, why: _died(job, p, m, done, why)
            )
        elif self.jobs > 1 and len(todo) > 1:
            self._in_processes(job, todo, done)
        else:
            for p, m in todo:
                done(job(p, m))

    def _in_processes(
        self, job: Job, todo: list[tuple[Path, Manifest | None]], done: Callable
    ) -> None:
        """The jobs in a pool of processes, one thread each (they share the cores). The blocks a
        pool lost when one of its workers died (killed, out of memory) run again in a new pool;
        those lost again, each in a process of its own: a block whose process dies then is not
        inspected, and is said to be so."""
        lost = _pooled(job, todo, done, min(self.jobs, len(todo)))
        if lost:
            lost = _pooled(job, lost, done, min(self.jobs, len(lost)))
        for p, m in lost:
            if _pooled(job, [(p, m)], done, 1):
                _died(job, p, m, done, "its worker process died, again when it ran alone")


def _died(job: Job, p: Path, m: Manifest | None, done: Callable, why: str) -> None:
    """A block whose process died each time it ran: what it wrote before removed, and recorded
    as not inspected (`why`), the others going on."""
    if m is not None:
        job.writer.discard(m.block_id)  # what it wrote before it died
    problem = Problem(str(p), f"could not be inspected: {why} (killed, or out of memory)")
    done(Outcome(p, problems=[problem], block_id=m.block_id if m else None))


def _worker_start(parent: int) -> None:
    """A worker process: one thread (the processes share the cores), and SIGTERM left to end
    it, not raised as the main process raises it (`blockqc.cli`); on Linux, also sent to it
    when the main process dies without stopping its workers (SIGKILL, out of memory), so that
    no orphan goes on writing into the output folder (they used to, then wait for ever).
    Ctrl-C, which a terminal sends to every process of the run, is left to the main process,
    which stops the run (the blocks being written finished): a worker it interrupted printed
    Python's traceback of where it was."""
    pieces.single_thread()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform == "linux":
        with suppress(OSError, AttributeError):
            ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
        if os.getppid() != parent:  # it died before the worker asked
            os.kill(os.getpid(), signal.SIGTERM)


def _pooled(
    job: Job, todo: list[tuple[Path, Manifest | None]], done: Callable, workers: int
) -> list[tuple[Path, Manifest | None]]:
    """done(outcome) of each job run in a pool of `workers` processes; the jobs lost to a
    process that died."""
    lost, said = [], set()
    start = {"initializer": _worker_start, "initargs": (os.getpid(),)}
    with ProcessPoolExecutor(workers, **start) as pool:
        futures = {pool.submit(job, p, m): (p, m) for p, m in todo}
        try:
            for future in as_completed(futures):
                said.add(future)  # before its line: a signal may stop the run as it is out
                try:
                    done(future.result())
                except BrokenProcessPool:
                    lost.append(futures[future])
        except BaseException:  # the run stops (outputs that cannot be written, interrupted,
            pool.shutdown(wait=True, cancel_futures=True)  # terminated): the jobs not begun
            _finished_meanwhile([f for f in futures if f not in said], done)  # are dropped,
            raise  # those running end, and are said
    return lost


def _finished_meanwhile(futures: list[Future], done: Callable) -> None:
    """done(outcome) of the jobs that ended while a stopped run waited for its workers: their
    outputs are written whole, and are said as those of the blocks before them were."""
    for future in futures:
        if future.done() and not future.cancelled() and future.exception() is None:
            done(future.result())


def run(
    got: Collected,
    pack: Pack,
    writer: Writer,
    inspector: InspectorInput | None = None,
    *,
    runner: Runner | None = None,
    incremental: bool = False,
    progress: Callable[[Outcome], None] | None = None,
    checkpoints: InspectorCheckpoints | None = None,
    plan: Plan | None = None,
    meta: ReportMeta | None = None,
    plan_notes: list[PlanNote] | None = None,
) -> tuple[list[Outcome], Summary | None]:
    """Inspect every delivery collected, writing its outputs as it goes; for a batch, the summary.

    Outcomes keep the order of the deliveries, whatever order the jobs finish in.
    """
    from blockqc.cache import run_digest

    done: dict[Path, Outcome] = {}

    def finished(o: Outcome) -> None:
        done[o.path] = o
        if progress:
            progress(o)

    for p, problem in got.refused.items():
        manifest = got.manifests.get(p)
        finished(Outcome(p, problems=[problem], block_id=manifest.block_id if manifest else None))
    _discard_refused(writer, list(got.refused))
    extra = Extra(checkpoints, len(got.deliveries) == 1, plan, meta, tuple(plan_notes or ()))
    name = inspector.inspector if inspector else None
    digest = run_digest(pack, writer, extra, name) if incremental else None
    todo = [(p, got.manifests.get(p)) for p in got.deliveries if p not in got.refused]
    runner = runner or Runner()
    clear_staging(writer.out)  # what a run killed half-way left
    if got.is_batch:
        set_aside_summary(writer.out)  # put back once the blocks are written
    try:
        runner.run(Job(pack, inspector, writer, digest, extra), todo, finished)
    finally:
        clear_staging(writer.out)
    outcomes = [done[p] for p in got.deliveries]
    summary = None
    if got.is_batch:
        summary = summarize(outcomes, pack, inspector, extra)
        _write_summary(writer, summary, outcomes, digest, runner.jobs)
    return outcomes, summary


def _discard_refused(writer: Writer, refused: list[Path]) -> None:
    """Outputs of deliveries refused unread (their block.yaml, so their block id, unreadable):
    found by the block id the last summary in `--out` gave their path (in `--out`, or set
    aside by a run that stopped half-way), and removed."""
    if not refused:
        return
    ids: dict[Path, str] = {}
    for folder in (writer.out / PREVIOUS_SUMMARY_DIR, writer.out):  # the later one wins
        try:
            doc = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
            ids.update({real_path(Path(b["path"])): str(b["block_id"]) for b in doc["blocks"]})
        except (OSError, ValueError, KeyError, TypeError):
            continue  # no summary (or not one of ours): nothing to find them by
    for p in refused:
        if (block_id := ids.get(real_path(p))) is not None:
            writer.discard(block_id)


def drop_outdated_summary(writer: Writer, got: Collected) -> str | None:
    """A delivery inspected on its own into an `--out` whose summary lists it (by block id or
    path): that summary, and the pages made from it, would go on giving the block's earlier
    verdict beside its new results, so they are removed. What was removed and why, or None."""
    if got.is_batch:
        return None
    try:
        doc = json.loads((writer.out / "summary.json").read_text(encoding="utf-8"))
        listed = [(str(b["block_id"]), b["path"]) for b in doc["blocks"]]
        listed += [(str(u["path"]), u["path"]) for u in doc["unreadable"]]
        ids = {m.block_id for m in got.manifests.values()}
        paths = {real_path(p) for p in got.deliveries}
        hit = [name for name, path in listed if name in ids or real_path(Path(path)) in paths]
    except (OSError, ValueError, KeyError, TypeError):
        return None  # no summary (or not one of ours)
    if not hit:
        return None
    writer.drop_summary()
    return (
        f"{writer.out / 'summary.json'}: it listed {', '.join(hit)}, inspected again on its own: "
        "the batch's summary and acceptance pages are removed (inspect the batch to remake them)"
    )


def _write_summary(
    writer: Writer, summary: Summary, outcomes: list[Outcome], digest: str | None, jobs: int
) -> None:
    """The summary outputs; in incremental mode kept as they are when every block's line is the
    one they were written from (an unchanged batch of a thousand blocks rewrites nothing)."""
    from blockqc.cache import forget_summary, remember_summary, summary_key, summary_unchanged

    key, aside = None, writer.out / PREVIOUS_SUMMARY_DIR
    if digest is not None:
        key = summary_key(digest, [o.key for o in outcomes], summary)
        if aside.is_dir() and summary_unchanged(writer.out, key, held=aside):
            restore_summary(writer.out)
            return
    forget_summary(writer.out)
    remember_summary(writer.out, key, writer.summary(summary, jobs))
    drop_set_aside(writer.out)  # this run's written whole: the earlier one's no longer kept


def exit_status(outcomes: list[Outcome]) -> int:
    """0 every block passes, 1 some block fails, 2 something could not be read or judged."""
    if any(o.entry is None or o.entry.verdict == "error" for o in outcomes):
        return 2
    return 1 if any(block_fails(o.entry.verdict) for o in outcomes) else 0


__all__ = [
    "Collected",
    "Job",
    "Outcome",
    "Runner",
    "Writer",
    "collect",
    "drop_outdated_summary",
    "exit_status",
    "run",
    "summarize",
]
