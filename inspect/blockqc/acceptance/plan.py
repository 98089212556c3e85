"""The sampling plan file (§QE-1): written by `blockqc sample`, read by `inspect --plan`.

Applying a plan to a block's results: the detailed-inspection rules (`inspection: detailed`)
stand for sampled blocks only; elsewhere they are not applicable, with the reason. A sampled
block without checkpoints is incomplete, and its results say so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from blockqc.acceptance.model import ReportMeta
from blockqc.acceptance.sampling import Lot
from blockqc.errors import InputError, Problem
from blockqc.results import STATUSES, BlockResults
from blockqc.yamlio import load_yaml, pydantic_problems

NOT_SAMPLED = "not sampled for detailed inspection (sampling plan)"
NO_CHECKPOINTS = (
    "sampled for detailed inspection, but the delivery has no checkpoints: "
    "the detailed inspection is incomplete"
)


class _M(BaseModel):
    model_config = ConfigDict(extra="forbid")


class StratumPlan(_M):
    value: str
    size: int
    sample: int
    units: list[str]
    sampled: list[str]


class LotPlan(_M):
    size: int
    sample_size: int
    census: bool
    strata: list[StratumPlan]
    sampled: list[str]


class Plan(_M):
    """What was sampled, how, and from what: enough to draw the same sample again."""

    plan: str = "sampling plan"
    standard: str = ""
    rule_pack: str = ""
    batch: str = ""  # the batch folder's name (never an absolute path)
    seed: int
    strata_key: str | None = None
    method: str = "simple random"
    units: int
    sample_size: int
    lots: list[LotPlan]
    sampled: list[str] = Field(default_factory=list)

    @property
    def population(self) -> set[str]:
        return {u for lot in self.lots for s in lot.strata for u in s.units}


def make_plan(lots: list[Lot], seed: int, key: str | None, **about: Any) -> Plan:
    """The plan file's content from the lots drawn."""
    out = [
        LotPlan(
            size=len(lot.units),
            sample_size=lot.sample_size,
            census=lot.census,
            strata=[
                StratumPlan(
                    value=s.value,
                    size=len(s.units),
                    sample=len(s.sampled),
                    units=s.units,
                    sampled=s.sampled,
                )
                for s in lot.strata
            ],
            sampled=lot.sampled,
        )
        for lot in lots
    ]
    return Plan(
        seed=seed,
        strata_key=key,
        method="stratified proportional random" if key else "simple random",
        units=sum(x.size for x in out),
        sample_size=sum(x.sample_size for x in out),
        lots=out,
        sampled=sorted(u for x in out for u in x.sampled),
        **about,
    )


def load_plan(path: Path) -> Plan:
    """Read a plan file; InputError names the file, line and key of any problem."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(Problem(str(path), "expected a sampling plan (blockqc sample)", line=1))
    try:
        return Plan.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data)) from None


def check_blocks(plan: Plan, path: Path, block_ids: list[str], whole_batch: bool) -> None:
    """Every block inspected is in the plan's batch; with a whole batch, every sampled block too."""
    problems = [
        Problem(str(path), f"block {b} is not in the plan's batch ({plan.units} units)")
        for b in block_ids
        if b not in plan.population
    ]
    if whole_batch:
        problems += [
            Problem(str(path), f"sampled block {b} is not among the deliveries inspected")
            for b in plan.sampled
            if b not in block_ids
        ]
    if problems:
        raise InputError(problems)


def apply_plan(results: BlockResults, sampled: bool) -> BlockResults:
    """Detailed-inspection results kept for a sampled block, not applicable elsewhere (§QE-1)."""
    results.sampled = sampled
    has_cps = results.summary.get("checkpoints", 0) > 0
    for r in results.results:
        if r.inspection != "detailed":
            continue
        if not sampled:
            r.status, r.value, r.evidence = "not_applicable", None, []
            r.detail = {"reason": NOT_SAMPLED, "plan": NOT_SAMPLED}
        elif not has_cps:
            r.detail = {**r.detail, "plan": NO_CHECKPOINTS, "plan_incomplete": True}
    if sampled and not has_cps:
        results.complete = False
    _recount(results)
    return results


def _recount(results: BlockResults) -> None:
    counts = dict.fromkeys(STATUSES, 0)
    for r in results.results:
        counts[r.status] += 1
    results.counts = counts
    results.verdict = "error" if counts["error"] else "fail" if counts["fail"] else "pass"


def load_meta(path: Path) -> ReportMeta:
    """Read the filed report's particulars; InputError names the file, line and key."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping (report_number, project, …)", line=1)
        )
    try:
        return ReportMeta.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data)) from None
