"""Inspecting many deliveries: per-block outputs and the batch summary (contract v1)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from blockqc import __version__
from blockqc.acceptance.decision import decide
from blockqc.acceptance.evaluate import evaluate_results
from blockqc.acceptance.model import BatchDecision, BlockGrade, ReportMeta
from blockqc.acceptance.plan import Plan, apply_plan
from blockqc.acceptance.scoring import a_class_errors
from blockqc.delivery import MANIFEST, Manifest, find_deliveries, load_delivery, load_manifest
from blockqc.engine import inspect_delivery
from blockqc.errors import InputError, Problem
from blockqc.inspector import InspectorInput
from blockqc.outputs import write_json_atomic
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


@dataclass
class Outcome:
    """One delivery's fate: its results, or the problems that kept it from being inspected."""

    path: Path
    results: BlockResults | None = None
    problems: list[Problem] = field(default_factory=list)


@dataclass
class Collected:
    """The deliveries named on the command line, each manifest read once."""

    deliveries: list[Path]
    is_batch: bool
    manifests: dict[Path, Manifest] = field(default_factory=dict)
    refused: dict[Path, Problem] = field(default_factory=dict)


def collect(paths: Iterable[Path]) -> Collected:
    """The delivery folders named by the arguments; duplicate block ids refused up front."""
    found: list[Path] = []
    batch = False
    for p in paths:
        ds = find_deliveries(Path(p))
        batch |= len(ds) > 1 or ds[0] != Path(p)
        found.extend(ds)
    got = Collected(found, batch or len(found) > 1)
    seen: dict[str, Path] = {}
    for path in found:
        try:
            manifest = got.manifests[path] = load_manifest(path / MANIFEST)
        except InputError:
            continue  # reported in full when the delivery is read
        if manifest.block_id in seen:
            got.refused[path] = Problem(
                str(path / MANIFEST),
                f"block_id {manifest.block_id} is also the id of {seen[manifest.block_id]}: "
                "block ids must be unique in a batch",
            )
        else:
            seen[manifest.block_id] = path
    return got


def inspect_one(
    path: Path,
    pack: Pack,
    inspector: InspectorInput | None,
    manifest: Manifest | None = None,
    plan: Plan | None = None,
    meta: ReportMeta | None = None,
) -> Outcome:
    try:
        delivery = load_delivery(path, manifest=manifest)
    except InputError as exc:
        return Outcome(path, problems=exc.problems)
    block_input = inspector.for_block(delivery.block_id) if inspector else None
    results = inspect_delivery(
        delivery, pack, block_input, inspector.inspector if inspector else None
    )
    if plan is not None:
        apply_plan(results, results.block_id in plan.sampled)
    results.evaluation = evaluate_results(results, pack)
    results.meta = _meta(meta, pack) if meta is not None else None
    return Outcome(path, results)


@dataclass(frozen=True)
class Writer:
    """Where and how the outputs are written."""

    out: Path
    templates: Path | None = None
    lang: str = "en"
    pdf: bool = True

    def block(self, results: BlockResults) -> Path:
        """results.json first; the report is rendered from it (never beside it)."""
        folder = self.out / results.block_id
        write_json_atomic(folder / "results.json", results)
        write_block_report(folder, results, lang=self.lang, templates=self.templates, pdf=self.pdf)
        return folder

    def summary(self, summary: Summary) -> None:
        write_json_atomic(self.out / "summary.json", summary)
        write_summary_report(
            self.out, summary, lang=self.lang, templates=self.templates, pdf=self.pdf
        )


@dataclass(frozen=True)
class Job:
    """Inspect one delivery and write its outputs (runs in a worker process with --jobs)."""

    pack: Pack
    inspector: InspectorInput | None
    writer: Writer
    plan: Plan | None = None
    meta: ReportMeta | None = None

    def __call__(self, path: Path, manifest: Manifest | None = None) -> Outcome:
        try:
            o = inspect_one(path, self.pack, self.inspector, manifest, self.plan, self.meta)
            if o.results is not None:
                self.writer.block(o.results)
            return o
        except Exception as exc:  # one block's failure must not stop the batch
            reason = f"could not be inspected: {type(exc).__name__}: {exc}"
            return Outcome(path, problems=[Problem(str(path), reason)])


def block_entry(o: Outcome) -> BlockEntry:
    """A block's line in the summary, with the checkpoint statistics of sampled blocks."""
    r = o.results
    assert r is not None
    cps = checkpoint_rows(r)
    return BlockEntry(
        block_id=r.block_id,
        verdict=r.verdict,
        path=str(o.path),
        results=f"{r.block_id}/results.json",
        report=f"{r.block_id}/report.html",
        sampled=_sampled(r),
        failed_rules=sorted({x.rule for x in r.results if x.status in ("fail", "error")}),
        warned_rules=sorted({x.rule for x in r.results if x.status == "warn"}),
        pending_manual=r.pending_manual,
        counts=r.counts,
        checkpoints=cps,
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


def decision(outcomes: list[Outcome], pack: Pack, plan: Plan | None) -> BatchDecision | None:
    """§QE-5: the batch decision over the blocks inspected (None without acceptance)."""
    if pack.acceptance is None:
        return None
    grades = [
        BlockGrade(
            block_id=r.block_id,
            sampled=_sampled(r),
            score=r.evaluation.score,
            grade=r.evaluation.grade,
            fails=r.evaluation.fails,
            complete=r.evaluation.complete,
            reasons=r.evaluation.reasons,
            a_errors=a_class_errors(r.evaluation),
            low_elements=[
                e.model_dump(include={"id", "title", "title_zh", "score"})
                for e in r.evaluation.elements
                if e.score is not None and e.score < pack.acceptance.element_fail_below
            ],
        )
        for o in outcomes
        if (r := o.results) is not None and r.evaluation is not None
    ]
    return decide(grades, pack.acceptance, "plan" if plan else "checkpoints")


def summarize(
    outcomes: list[Outcome],
    pack: Pack,
    inspector: InspectorInput | None,
    plan: Plan | None = None,
    meta: ReportMeta | None = None,
) -> Summary:
    """summary.json of a batch: one entry per block, counts per rule, rejected deliveries."""
    blocks: list[BlockEntry] = []
    rejected: list[Rejected] = []
    rules: dict[str, dict[str, int]] = {r.id: dict.fromkeys(STATUSES, 0) for r in pack.rules}
    for o in outcomes:
        if o.results is None:
            rejected.append(Rejected(path=str(o.path), problems=[str(p) for p in o.problems]))
            continue
        for res in o.results.results:
            rules.setdefault(res.rule, dict.fromkeys(STATUSES, 0))[res.status] += 1
        blocks.append(block_entry(o))
    failing = [b for b in blocks if block_fails(b.verdict)]
    verdict = "error" if rejected else "fail" if failing else "pass"
    return Summary(
        rule_pack=pack.name,
        rule_pack_version=pack.version,
        blockqc_version=__version__,
        generated_at=dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        inspector=inspector.inspector if inspector else None,
        verdict=verdict,
        complete=not rejected and not any(b.pending_manual for b in blocks),
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
        acceptance=decision(outcomes, pack, plan),
        sampling=plan.model_dump(mode="json") if plan else None,
        meta=_meta(meta, pack),
        elements=pack.elements,
        sampling_table=[r.model_dump() for r in pack.acceptance.sampling.table]
        if pack.acceptance
        else [],
    )


def _meta(meta: ReportMeta | None, pack: Pack) -> ReportMeta | None:
    """The report's particulars with the pack's inspection basis where the file gives none."""
    if pack.acceptance is None and meta is None:
        return None
    meta = (meta or ReportMeta()).model_copy()
    if pack.acceptance is not None:
        meta.basis = meta.basis or list(pack.acceptance.basis)
        meta.basis_zh = meta.basis_zh or list(pack.acceptance.basis_zh)
    return meta


def _inspect_all(got: Collected, job: Job, jobs: int, finished: Callable[[Outcome], None]) -> None:
    todo = [p for p in got.deliveries if p not in got.refused]
    if jobs > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=min(jobs, len(todo))) as pool:
            futures = [pool.submit(job, p, got.manifests.get(p)) for p in todo]
            for future in as_completed(futures):
                finished(future.result())
    else:
        for p in todo:
            finished(job(p, got.manifests.get(p)))


def run(
    got: Collected,
    pack: Pack,
    writer: Writer,
    inspector: InspectorInput | None = None,
    *,
    jobs: int = 1,
    progress: Callable[[Outcome], None] | None = None,
    plan: Plan | None = None,
    meta: ReportMeta | None = None,
) -> tuple[list[Outcome], Summary | None]:
    """Inspect every delivery collected, writing its outputs as it goes; for a batch, the summary.

    With jobs > 1 the deliveries are inspected in that many processes; outcomes keep the order
    of the deliveries.
    """
    done: dict[Path, Outcome] = {}

    def finished(o: Outcome) -> None:
        done[o.path] = o
        if progress:
            progress(o)

    for p, problem in got.refused.items():
        finished(Outcome(p, problems=[problem]))
    _inspect_all(got, Job(pack, inspector, writer, plan, meta), jobs, finished)
    outcomes = [done[p] for p in got.deliveries]
    summary = None
    if got.is_batch:
        summary = summarize(outcomes, pack, inspector, plan, meta)
        writer.summary(summary)
    return outcomes, summary


def exit_status(outcomes: list[Outcome]) -> int:
    """0 every block passes, 1 some block fails, 2 something could not be read or judged."""
    if any(o.results is None or o.results.verdict == "error" for o in outcomes):
        return 2
    return 1 if any(block_fails(o.results.verdict) for o in outcomes) else 0


def outcome_line(o: Outcome) -> dict[str, Any]:
    """What the command line prints of one outcome."""
    if o.results is None:
        return {"path": str(o.path), "problems": len(o.problems)}
    r = o.results
    return {
        "block_id": r.block_id,
        "verdict": r.verdict,
        "failed": sorted({x.rule for x in r.results if x.status in ("fail", "error")}),
        "warned": sorted({x.rule for x in r.results if x.status == "warn"}),
        "pending": r.pending_manual,
    }


__all__ = ["Collected", "Outcome", "Writer", "collect", "exit_status", "run", "summarize"]
