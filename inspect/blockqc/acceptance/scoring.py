"""A block's score and grade from its rule results (§QE-2..5), as the pack's acceptance says.

Readings (docs/acceptance.md): one error per failing result (rule × group), counted in every
item whose content it decides; only `fail` results are errors (warnings, waivers and pending
manual items are not); an item with an A-class error scores 0; an item's score is the lowest
accuracy score of its accuracy results less the deduction of its other errors; items and
elements with nothing judged are left out and the weights re-normalised over the rest.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from blockqc.acceptance.model import (
    Acceptance,
    AccuracyRecord,
    AccuracyScore,
    ElementScore,
    ErrorClass,
    ErrorRecord,
    Evaluation,
    ItemScore,
)

JUDGED = ("pass", "fail", "warn", "waived")
#: scores are kept to this many decimals, at every step: the binary fractions of weights and
#: shares must not take a score a hair below a grade's bound (0.6·87 + 0.2·90 + 0.2·99 is 90)
SCORE_DECIMALS = 9
CLASSES: tuple[ErrorClass, ...] = ("A", "B", "C", "D")


@dataclass(frozen=True)
class Finding:
    """One judged rule result as scoring sees it."""

    rule: str
    status: str
    places: tuple[tuple[str, str], ...]  # (element id, item id) it decides
    error_class: ErrorClass
    value: Any = None
    threshold: Any = None
    norm: float | None = None  # set for results scored as mathematical accuracy
    group: dict[str, Any] = field(default_factory=dict)
    comparison: str | None = None
    unit: str = ""


def settled(score: float) -> float:
    """A score to SCORE_DECIMALS decimals (89.99999999999999 is 90)."""
    return round(score, SCORE_DECIMALS)


def accuracy_score(m: float, m0: float, acc: AccuracyScore | None = None) -> float | None:
    """§QE-3: 100 for m ≤ 0.3·m0; 60 + 40·(m0 − m)/(0.7·m0) up to m0; None beyond (A-class)."""
    acc = acc or AccuracyScore()
    m = abs(m)
    if m <= acc.full * m0:
        return 100.0
    if m <= m0:
        return settled(acc.floor + acc.span * (m0 - m) / ((1 - acc.full) * m0))
    return None


def deduction_score(counts: dict[str, int], acc: Acceptance) -> float:
    """§QE-4: 100 − (12·nB + 4·nC + nD)/t, at least 0."""
    return max(0.0, settled(100.0 - _deduction(counts, acc)))


def _deduction(counts: dict[str, int], acc: Acceptance) -> float:
    d = acc.deduction
    return (d.B * counts.get("B", 0) + d.C * counts.get("C", 0) + d.D * counts.get("D", 0)) / d.t


def _error(f: Finding, cls: ErrorClass, reason: str, norm: float | None = None) -> ErrorRecord:
    return ErrorRecord(
        rule=f.rule,
        error_class=cls,
        group=f.group,
        value=f.value,
        threshold=f.threshold,
        reason=reason,
        comparison=f.comparison,
        unit=f.unit,
        norm=norm,
    )


def _judge_finding(f: Finding, acc: Acceptance) -> tuple[AccuracyRecord | None, ErrorRecord | None]:
    """A finding's accuracy score and its error, if any."""
    if f.norm is not None and isinstance(f.value, (int, float)) and f.status in JUDGED:
        s = accuracy_score(float(f.value), f.norm, acc.accuracy)
        if s is None and f.status == "waived":
            return None, None  # waived by the inspector: no error, nothing to score beyond
        rec = AccuracyRecord(rule=f.rule, group=f.group, value=f.value, norm=f.norm, score=s)
        if s is None:
            return rec, _error(f, "A", "beyond the norm", f.norm)
        if f.status == "fail":
            return rec, _error(f, f.error_class, "fails its threshold")
        return rec, None
    if f.status == "fail":
        return None, _error(f, f.error_class, "fails its threshold")
    return None, None


def score_item(findings: list[Finding], acc: Acceptance) -> ItemScore:
    """One item: accuracy scores, errors by class, and the item's score (None: not inspected)."""
    judged = [f for f in findings if f.status in JUDGED]
    item = ItemScore(id="", weight=0.0, inspected=bool(judged))
    for f in judged:
        rec, err = _judge_finding(f, acc)
        item.accuracy += [rec] if rec else []
        item.errors += [err] if err else []
    item.counts = {c: sum(e.error_class == c for e in item.errors) for c in CLASSES}
    if not judged:
        return item
    scored = [r.score for r in item.accuracy if r.score is not None]
    item.deduction = _deduction(item.counts, acc)
    if item.counts["A"]:
        item.score = 0.0
    else:
        item.score = max(0.0, settled((min(scored) if scored else 100.0) - item.deduction))
    return item


def weighted(parts: Iterable[tuple[float, float | None]]) -> float | None:
    """Σ wᵢ·sᵢ / Σ wᵢ over the parts that were scored (§QE-4, re-weighted); None when none. A
    part weighted 0 is not counted: parts scored that all weigh 0 give no score (Σ wᵢ = 0)."""
    got = [(w, s) for w, s in parts if s is not None and w > 0]
    if not got:
        return None
    return settled(math.fsum(w * s for w, s in got) / math.fsum(w for w, _ in got))


def mean(scores: Iterable[float]) -> float:
    """The mean of scores (a sample's, §QE-5), kept to SCORE_DECIMALS decimals."""
    got = list(scores)
    return settled(math.fsum(got) / len(got))


def _items_of(findings: list[Finding], element: str, item: str) -> list[Finding]:
    return [f for f in findings if (element, item) in f.places]


def score_element(el: Any, findings: list[Finding], acc: Acceptance) -> ElementScore:
    """An element of the pack's tree (ElementDef): its items scored and rolled up by weight."""
    items = []
    for it in el.items:
        s = score_item(_items_of(findings, el.id, it.id), acc)
        s.id, s.title, s.title_zh = it.id, it.title, it.title_zh
        s.weight = acc.weights.items.get(it.id, 1.0)
        items.append(s)
    score = weighted((i.weight, i.score) for i in items)
    return ElementScore(
        id=el.id,
        title=el.title,
        title_zh=el.title_zh,
        weight=acc.weights.elements.get(el.id, 1.0),
        inspected=any(i.inspected for i in items),  # scored only when a weighted one is
        score=score,
        items=items,
    )


def evaluate_block(
    elements: list[Any], findings: list[Finding], acc: Acceptance, incomplete: list[str] = ()
) -> Evaluation:
    """§QE-2..5: the block's score (weighted over its elements), whether it fails, its grade."""
    els = [score_element(e, findings, acc) for e in elements]
    score = weighted((e.weight, e.score) for e in els)
    other = other_errors(findings, acc)
    errors = [x for e in els for i in e.items for x in i.errors] + other
    counts = {c: sum(x.error_class == c for x in _unique(errors)) for c in CLASSES}
    reasons = [
        f"A-class error: {x.rule}{_group_text(x.group)} {_num(x.value)} ({x.reason})"
        for x in _unique(errors)
        if x.error_class == "A"
    ]
    reasons += [
        f"element {e.id} scores {math.floor(e.score * 10 + 1e-9) / 10:.1f} < "
        f"{acc.element_fail_below:g}"
        for e in els
        if e.score is not None and e.score < acc.element_fail_below
    ]
    reasons += _below_grades(score, acc)
    fails = bool(reasons)
    grade = acc.fail_grade if fails else acc.grade(score) if score is not None else None
    ev = Evaluation(
        standard=acc.standard,
        standard_zh=acc.standard_zh,
        score=score,
        grade=grade.id if grade else None,
        grade_title=grade.title if grade else "",
        grade_title_zh=grade.title_zh if grade else "",
        fails=fails,
        complete=not incomplete and score is not None,
        reasons=reasons + list(incomplete),
        element_fail_below=acc.element_fail_below,
        counts=counts,
        elements=els,
        other_errors=other,
    )
    return ev


def other_errors(findings: list[Finding], acc: Acceptance) -> list[ErrorRecord]:
    """The errors of results that decide no content of the pack's tree (a rule naming neither
    `content` nor `quality_element`): no item to count them in, they count for the block (an
    A-class one fails it, §QE-2), not deducted from any item's score."""
    judged = [f for f in findings if not f.places and f.status in JUDGED]
    return [err for f in judged if (err := _judge_finding(f, acc)[1]) is not None]


def _below_grades(score: float | None, acc: Acceptance) -> list[str]:
    """A score that reaches no grade (a pack whose lowest grade starts above
    element_fail_below) fails the block: its grade is the fail grade."""
    lowest = acc.grades[-1]
    if score is None or score >= lowest.min:
        return []
    shown = math.floor(score * 10 + 1e-9) / 10
    return [f"score below the lowest grade: {shown:.1f} < {lowest.min:g} ({lowest.id})"]


def a_class_errors(ev: Evaluation) -> list[ErrorRecord]:
    """The block's A-class errors, each (rule, group) once."""
    errors = [x for e in ev.elements for i in e.items for x in i.errors] + ev.other_errors
    return [x for x in _unique(errors) if x.error_class == "A"]


def _unique(errors: list[ErrorRecord]) -> list[ErrorRecord]:
    seen, out = set(), []
    for x in errors:
        key = (x.rule, str(x.group))
        if key not in seen:
            seen.add(key)
            out.append(x)
    return out


def _group_text(group: dict[str, Any]) -> str:
    return f" ({', '.join(str(v) for v in group.values())})" if group else ""


def _num(v: Any) -> str:
    return f"{v:.2f}" if isinstance(v, float) else str(v)


#: where an evaluation's figure disagrees with those it is made of, and how
Disagreement = tuple[str, str]


def _differs(given: float | None, made: float | None) -> bool:
    if given is None or made is None:
        return given is not made
    return not math.isclose(given, made, rel_tol=1e-9, abs_tol=1e-9)


def _item_score(item: ItemScore) -> float | None:
    """An item's score from its own record: 0 with an A-class error, else its lowest accuracy
    score (100 without one) less its deduction, at least 0; None when it was not inspected."""
    if not item.inspected:
        return None
    if item.counts.get("A", 0):
        return 0.0
    scored = [r.score for r in item.accuracy if r.score is not None]
    return max(0.0, settled((min(scored) if scored else 100.0) - item.deduction))


def _counted(errors: list[ErrorRecord]) -> dict[str, int]:
    return {c: sum(x.error_class == c for x in errors) for c in CLASSES}


def recheck(ev: Evaluation) -> list[Disagreement]:
    """The figures of a stored evaluation that its parts do not make (a results.json edited):
    each item's errors by class and score, each element's score over its items, the block's
    over its elements (the weights as stored), its errors by class, and `fails` with an A-class
    error or an element below `element_fail_below`. Each as (JSON path, why)."""
    out: list[Disagreement] = []
    for i, el in enumerate(ev.elements):
        for j, it in enumerate(el.items):
            at = f"elements[{i}].items[{j}] ({it.id})"
            if {c: it.counts.get(c, 0) for c in CLASSES} != _counted(it.errors):
                out.append(
                    (f"{at}.counts", f"{it.counts}, but its errors make {_counted(it.errors)}")
                )
            if _differs(it.score, made := _item_score(it)):
                out.append((f"{at}.score", f"{it.score}, but its record makes it {made}"))
        made = weighted((it.weight, it.score) for it in el.items)
        if _differs(el.score, made):
            out.append((f"elements[{i}] ({el.id}).score", f"{el.score}, but its items make {made}"))
    made = weighted((el.weight, el.score) for el in ev.elements)
    if _differs(ev.score, made):
        out.append(("score", f"{ev.score}, but its elements make it {made}"))
    errors = _unique([x for e in ev.elements for i in e.items for x in i.errors] + ev.other_errors)
    if {c: ev.counts.get(c, 0) for c in CLASSES} != _counted(errors):
        out.append(("counts", f"{ev.counts}, but its errors make {_counted(errors)}"))
    low = [e.id for e in ev.elements if e.score is not None and e.score < ev.element_fail_below]
    if not ev.fails and (low or _counted(errors)["A"]):
        why = f"element {low[0]} below {ev.element_fail_below:g}" if low else "an A-class error"
        out.append(("fails", f"false, but the block has {why}: it fails (§QE-2)"))
    return out
