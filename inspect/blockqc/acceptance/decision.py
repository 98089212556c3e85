"""The batch decision (§QE-5): the sample judged, its mean score and grade, the batch grade.

Readings (docs/acceptance.md): the sample is the plan's sampled blocks (without a plan, the
blocks that carry checkpoints); the batch grade's shares are taken over the sampled units;
unsampled blocks that fail their general inspection (a rule failed: the verdict is not pass)
or their evaluation are listed to be returned for correction and do not change the decision;
a sampled block whose evaluation is incomplete, or that could not be read, leaves the decision
incomplete unless some sampled block already fails. Without a plan a delivery that could not be
read may carry checkpoints, so be one of the sample: any such delivery leaves the decision
incomplete.
"""

from __future__ import annotations

from blockqc.acceptance.model import Acceptance, BatchDecision, BlockGrade
from blockqc.acceptance.scoring import mean


def rank(acc: Acceptance, grade: str | None) -> int:
    """Position of a grade, best first (the fail grade and unknown last)."""
    ids = [g.id for g in acc.grades]
    return ids.index(grade) if grade in ids else len(ids)


def batch_grade(acc: Acceptance, grades: list[str]) -> tuple[str, float, float]:
    """§QE-5: the first batch grade whose shares hold (good or better %, top %), else default."""
    n = len(grades)
    better = 100.0 * sum(rank(acc, g) <= rank(acc, acc.better_than) for g in grades) / n
    top = 100.0 * sum(rank(acc, g) == 0 for g in grades) / n
    for bg in acc.batch_grades:
        if better >= bg.better_pct and top >= bg.top_pct:
            return bg.grade, better, top
    return acc.batch_default, better, top


def decide(
    blocks: list[BlockGrade],
    acc: Acceptance,
    source: str,
    unreadable: list[str] | None = None,
    planned: list[str] | None = None,
) -> BatchDecision:
    """A sample fails with any failing sampled block; else its mean score, grade, batch grade.

    `unreadable`: the deliveries not read (block ids); `planned`: the plan's sampled blocks
    (None without a plan: the sample is the blocks read that carry checkpoints)."""
    sample = [b for b in blocks if b.sampled]
    unreadable = unreadable or []
    out = BatchDecision(
        standard=acc.standard,
        grades=[*acc.grades, acc.fail_grade],
        sample_source=source,
        sample=[b.block_id for b in sample] if planned is None else list(planned),
        failing=[b for b in sample if b.fails],
        incomplete=[b.block_id for b in sample if not b.complete or b.score is None],
        returned=[b for b in blocks if not b.sampled and (b.fails or b.failed_rules)],
        unreadable=unreadable,
        blocks=blocks,
    )
    if out.failing:
        out.decision = "fail"
        out.sample_grade = out.batch_grade = acc.fail_grade.id
        return out
    if not sample or out.incomplete or unread_in_sample(out):
        return out
    out.mean_score = mean(b.score for b in sample)
    out.sample_grade = acc.grade(out.mean_score).id
    out.batch_grade, out.better_pct, out.top_pct = batch_grade(acc, [b.grade for b in sample])
    out.decision = "pass"
    return out


def unread_in_sample(d: BatchDecision) -> list[str]:
    """The deliveries not read that belong, or may belong, to the sample: without a plan any;
    with one, those named as sampled blocks, and any when a sampled block is among neither the
    blocks read nor the deliveries not read (one named by its folder may be it)."""
    if d.sample_source != "plan" or unaccounted(d):
        return list(d.unreadable)
    return [u for u in d.unreadable if u in d.sample]


def unaccounted(d: BatchDecision) -> list[str]:
    """A plan's sampled blocks that no block read is, nor a delivery not read by its block id:
    one of the deliveries whose block.yaml could not be read (named by folder) may be each."""
    if d.sample_source != "plan":
        return []
    known = {b.block_id for b in d.blocks} | set(d.unreadable)
    return [u for u in d.sample if u not in known]
