"""Inspecting many deliveries: per-block outputs and the batch summary (contract v1)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from blockqc import __version__
from blockqc.delivery import find_deliveries, load_delivery
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


def inspect_one(path: Path, pack: Pack, inspector: InspectorInput | None) -> Outcome:
    try:
        delivery = load_delivery(path)
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


def _duplicate(o: Outcome, seen: dict[str, Path]) -> Outcome:
    """A second delivery with a block id already seen is refused (block ids are unique)."""
    bid = o.results["block_id"] if o.results else None
    if bid is None:
        return o
    if bid in seen:
        return Outcome(
            o.path,
            problems=[
                Problem(
                    str(o.path / "block.yaml"),
                    f"block_id {bid} is also the id of {seen[bid]}: "
                    "block ids must be unique in a batch",
                )
            ],
        )
    seen[bid] = o.path
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
    progress: Callable[[Outcome], None] | None = None,
) -> tuple[list[Outcome], dict | None]:
    """Inspect every delivery named, writing its outputs as it goes; for a batch, the summary."""
    deliveries, batch = collect(paths)
    outcomes: list[Outcome] = []
    seen: dict[str, Path] = {}
    for path in deliveries:
        o = _duplicate(inspect_one(path, pack, inspector), seen)
        if o.results is not None:
            write_block(out, o.results, templates=templates, lang=lang, pdf=pdf)
        outcomes.append(o)
        if progress:
            progress(o)
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
