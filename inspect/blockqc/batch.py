"""Inspecting many deliveries: per-block outputs and the batch summary (contract v1)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from blockqc import __version__
from blockqc.checkpoint_inputs import InspectorCheckpoints, merge_checkpoints
from blockqc.delivery import MANIFEST, find_deliveries, load_delivery, load_manifest
from blockqc.engine import STATUSES, inspect_delivery
from blockqc.errors import InputError, Problem
from blockqc.inspector import InspectorInput
from blockqc.outputs import write_json_atomic
from blockqc.report import write_block_report, write_summary_report
from blockqc.rules.model import Pack


@dataclass
class Outcome:
    """One delivery's fate: its results, or the problems that kept it from being read."""

    path: Path
    results: dict[str, Any] | None = None
    problems: list[Problem] = field(default_factory=list)


def collect(paths: Iterable[Path]) -> tuple[list[Path], bool]:
    """The delivery folders named by the arguments, and whether this is a batch."""
    found: list[Path] = []
    batch = False
    for p in paths:
        ds = find_deliveries(Path(p))
        batch |= len(ds) > 1 or ds[0] != Path(p)
        found.extend(ds)
    return found, batch or len(found) > 1


def inspect_one(
    path: Path,
    pack: Pack,
    inspector: InspectorInput | None,
    checkpoints: InspectorCheckpoints | None = None,
    single: bool = True,
) -> Outcome:
    try:
        delivery = load_delivery(path)
        if checkpoints is not None:  # contract v1.1: inspect --checkpoints FILE…
            merge_checkpoints(delivery, checkpoints.for_block(delivery.block_id, single))
    except InputError as exc:
        return Outcome(path, problems=exc.problems)
    block_input = inspector.for_block(delivery.block_id) if inspector else None
    return Outcome(
        path,
        inspect_delivery(delivery, pack, block_input, inspector.inspector if inspector else None),
    )


def write_block(
    out: Path,
    results: dict[str, Any],
    *,
    templates: Path | None = None,
    lang: str = "en",
    pdf: bool = True,
) -> Path:
    """results.json first; the report is rendered from it (never beside it)."""
    folder = out / results["block_id"]
    write_json_atomic(folder / "results.json", results)
    write_block_report(folder, results, lang=lang, templates=templates, pdf=pdf)
    return folder


def refuse_duplicates(deliveries: list[Path]) -> dict[Path, Problem]:
    """Deliveries repeating a block id seen before: refused before anything is inspected."""
    seen: dict[str, Path] = {}
    refused: dict[Path, Problem] = {}
    for path in deliveries:
        try:
            bid = load_manifest(path / MANIFEST).block_id
        except InputError:
            continue  # reported in full when the delivery is read
        if bid in seen:
            refused[path] = Problem(
                str(path / MANIFEST),
                f"block_id {bid} is also the id of {seen[bid]}: block ids must be unique "
                "in a batch",
            )
        else:
            seen[bid] = path
    return refused


@dataclass(frozen=True)
class Job:
    """Inspect one delivery and write its outputs (runs in a worker process with --jobs)."""

    pack: Pack
    inspector: InspectorInput | None
    out: Path
    templates: Path | None
    lang: str
    pdf: bool
    checkpoints: InspectorCheckpoints | None = None
    single: bool = True

    def __call__(self, path: Path) -> Outcome:
        o = inspect_one(path, self.pack, self.inspector, self.checkpoints, self.single)
        if o.results is not None:
            write_block(self.out, o.results, templates=self.templates, lang=self.lang, pdf=self.pdf)
        return o


def summarize(outcomes: list[Outcome], pack: Pack, inspector: InspectorInput | None) -> dict:
    blocks, unreadable = [], []
    rules: dict[str, dict[str, int]] = {r.id: dict.fromkeys(STATUSES, 0) for r in pack.rules}
    for o in outcomes:
        if o.results is None:
            unreadable.append({"path": str(o.path), "problems": [str(p) for p in o.problems]})
            continue
        r = o.results
        for res in r["results"]:
            rules.setdefault(res["rule"], dict.fromkeys(STATUSES, 0))[res["status"]] += 1
        blocks.append(
            {
                "block_id": r["block_id"],
                "verdict": r["verdict"],
                "path": str(o.path),
                "results": f"{r['block_id']}/results.json",
                "report": f"{r['block_id']}/report.html",
                "sampled": r["summary"]["checkpoints"] > 0,
                "failed_rules": sorted({x["rule"] for x in r["results"] if x["status"] == "fail"}),
                "warned_rules": sorted({x["rule"] for x in r["results"] if x["status"] == "warn"}),
                "pending_manual": r["pending_manual"],
                "counts": r["counts"],
            }
        )
    n_fail = sum(b["verdict"] != "pass" for b in blocks)
    verdict = "error" if unreadable else "fail" if n_fail else "pass"
    return {
        "rule_pack": pack.name,
        "rule_pack_version": pack.version,
        "blockqc_version": __version__,
        "generated_at": dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "inspector": inspector.inspector if inspector else None,
        "verdict": verdict,
        "complete": not unreadable and not any(b["pending_manual"] for b in blocks),
        "counts": {
            "blocks": len(outcomes),
            "pass": len(blocks) - n_fail,
            "fail": n_fail,
            "unreadable": len(unreadable),
        },
        "blocks": blocks,
        "rules": rules,
        "unreadable": unreadable,
    }


def write_summary(
    out: Path,
    summary: dict[str, Any],
    block_results: list[dict[str, Any]],
    *,
    templates: Path | None = None,
    lang: str = "en",
    pdf: bool = True,
) -> None:
    write_json_atomic(out / "summary.json", summary)
    write_summary_report(out, summary, block_results, lang=lang, templates=templates, pdf=pdf)


def run(
    paths: list[Path],
    pack: Pack,
    out: Path,
    inspector: InspectorInput | None = None,
    *,
    templates: Path | None = None,
    lang: str = "en",
    pdf: bool = True,
    jobs: int = 1,
    progress: Callable[[Outcome], None] | None = None,
    checkpoints: InspectorCheckpoints | None = None,
) -> tuple[list[Outcome], dict | None]:
    """Inspect every delivery named, writing its outputs as it goes; for a batch, the summary.

    With jobs > 1 the deliveries are inspected in that many processes; outcomes keep the order
    of the deliveries.
    """
    deliveries, batch = collect(paths)
    refused = refuse_duplicates(deliveries)
    done = {p: Outcome(p, problems=[problem]) for p, problem in refused.items()}
    todo = [p for p in deliveries if p not in refused]
    job = Job(pack, inspector, out, templates, lang, pdf, checkpoints, len(deliveries) == 1)

    def finished(o: Outcome) -> None:
        done[o.path] = o
        if progress:
            progress(o)

    for o in list(done.values()):
        finished(o)
    if jobs > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=min(jobs, len(todo))) as pool:
            for future in as_completed([pool.submit(job, p) for p in todo]):
                finished(future.result())
    else:
        for p in todo:
            finished(job(p))
    outcomes = [done[p] for p in deliveries]
    summary = None
    if batch:
        summary = summarize(outcomes, pack, inspector)
        write_summary(
            out,
            summary,
            [o.results for o in outcomes if o.results],
            templates=templates,
            lang=lang,
            pdf=pdf,
        )
    return outcomes, summary


def exit_status(outcomes: list[Outcome]) -> int:
    """0 every block passes, 1 some block fails, 2 something could not be read or judged."""
    if any(o.results is None or o.results["verdict"] == "error" for o in outcomes):
        return 2
    return 1 if any(o.results["verdict"] == "fail" for o in outcomes) else 0


__all__ = ["Outcome", "exit_status", "run", "summarize"]
