"""What the pages show of §QE: a block's score and grade, the batch decision, the filed report.

Built from results.json / summary.json alone, in the report's language.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Sequence
from pathlib import PurePath
from typing import Any

from pydantic import ValidationError

from blockqc.acceptance.decision import unaccounted, unread_in_sample
from blockqc.acceptance.model import BatchDecision, ErrorRecord, Evaluation, PlanNote, Sampling
from blockqc.acceptance.sampling import sample_size, split_sizes
from blockqc.report.format import Formatter, apart
from blockqc.results import BlockResults, RuleResult, Summary

CLASSES = ("A", "B", "C", "D")
#: the reason of a score that reaches no grade (acceptance.scoring), the lowest grade by its id
_BELOW_GRADES = re.compile(r"score below the lowest grade: (\S+) < (\S+) \((.+)\)")
#: a reason a rule gives (acceptance.evaluate: a rule's word on the sampling plan)
_RULE_SAYS = re.compile(r"([A-Z][A-Za-z0-9]*-\d+\w*): (.+)", re.S)


def grade_text(f: Formatter, grade: str | None, en: str = "", zh: str = "") -> str:
    """A grade in the page's language: the pack's titles, else the catalogue's, else its id."""
    if grade is None:
        return "–"
    return f.pick(en, zh) or f.pick(*f.grades.get(grade, ("", ""))) or f._key("grade", grade, grade)


def _why(x: ErrorRecord, f: Formatter) -> str:
    return f.t("err_beyond_norm") if x.reason == "beyond the norm" else f.t("err_fails")


def _shown(x: ErrorRecord, f: Formatter, results: Sequence[RuleResult] = ()) -> tuple[str, str]:
    """An error's value and threshold as the rule that found it shows them, with its unit and
    comparison ("37.50 %", "< 5 %"): from its result, else as the error records them (a record
    written before it kept them: the bare figures)."""
    res = next((r for r in results if r.rule == x.rule and r.group == x.group), None)
    if res is None and x.comparison is None and not x.unit:
        return f.cell(x.value), f.cell(x.threshold)
    if res is None:
        res = RuleResult.model_construct(comparison=x.comparison, unit=x.unit, threshold_text="")
    shown = res.model_copy(update={"value": x.value, "threshold": x.threshold})
    return f.value(shown), f.threshold(shown)


def _evidence(x: ErrorRecord, f: Formatter, colon: str, lp: str, rp: str) -> str:
    """An A-class error's value and what it misses: the norm it exceeds (§QE-3), else the
    threshold it fails ("15.70 m (beyond the norm: 10 m)", "37.50 % (fails its threshold:
    < 5 %)"); a record without them (written before they were kept) with its value alone."""
    value, threshold = _shown(x, f)
    if x.reason == "beyond the norm" and x.norm is not None:
        norm = RuleResult.model_construct(value=x.norm, threshold=None, unit=x.unit)
        threshold = f.value(norm)
    elif x.comparison is None and not x.unit:
        return f"{value}{lp}{_why(x, f)}{rp}"
    return f"{value}{lp}{_why(x, f)}{colon}{threshold}{rp}"


def _error_row(x: ErrorRecord, f: Formatter, results: Sequence[RuleResult] = ()) -> dict[str, Any]:
    """An error with its value and threshold as the rule that found it shows them."""
    value, threshold = _shown(x, f, results)
    return {
        "rule": x.rule,
        "group": f.group(x.group),
        "cls": x.error_class,
        "value": value,
        "threshold": threshold,
        "why": _why(x, f),
    }


def _items(ev: Evaluation, f: Formatter) -> list[dict[str, Any]]:
    rows = []
    for e in ev.elements:
        rows.append(_part(e, f, level="element"))
        rows += [_part(i, f, level="item") for i in e.items]
    return rows


def _part(p: Any, f: Formatter, level: str) -> dict[str, Any]:
    counts = getattr(p, "counts", {}) or {}
    acc = getattr(p, "accuracy", [])
    return {
        "level": level,
        "name": f.pick(p.title, p.title_zh) or p.id,
        "weight": f.num(p.weight, 2),
        "score": f.score(p.score, f.t("only_weight_0" if p.inspected else "not_inspected")),
        "errors": " ".join(f"{c}{counts[c]}" for c in CLASSES if counts.get(c)) or "–",
        "deduction": f.num(getattr(p, "deduction", 0.0), 1) if level == "item" else "",
        "accuracy": f.clause_sep.join(
            f"{a.rule}{(' ' + f.group(a.group)) if a.group else ''}{f.colon}"
            f"{'/'.join(apart(a.value, a.norm))} → "
            f"{f.score(a.score, 'A')}"
            for a in acc
        ),
    }


def evaluation_context(
    ev: Evaluation | None, f: Formatter, results: Sequence[RuleResult] = ()
) -> dict[str, Any] | None:
    """A block's §QE evaluation for its report (None when the pack has no acceptance); its
    errors are shown with the units and comparisons of the rule `results` that found them."""
    if ev is None:
        return None
    errors = [x for e in ev.elements for i in e.items for x in i.errors] + ev.other_errors
    seen, unique = set(), []
    for x in errors:
        if (x.rule, str(x.group)) not in seen:
            seen.add((x.rule, str(x.group)))
            unique.append(x)
    unique.sort(key=lambda x: x.error_class)
    return {
        "score": f.score(ev.score),
        "grade": ev.grade or "none",
        "grade_text": grade_text(f, ev.grade, ev.grade_title, ev.grade_title_zh),
        "fails": ev.fails,
        "complete": ev.complete,
        "counts": " · ".join(f"{c}{f.colon}{ev.counts.get(c, 0)}" for c in CLASSES),
        "errors": [_error_row(x, f, results) for x in unique],
        "rows": _items(ev, f),
        "low_elements": [
            f.t(
                "element_below",
                name=f.pick(e.title, e.title_zh),
                score=f.score(e.score),
                below=f.num(ev.element_fail_below),
            )
            for e in ev.elements
            if e.score is not None
            and ev.fails
            and not any(x.error_class == "A" for x in unique)
            and e.score < ev.element_fail_below
        ],
        "notes": [
            reason_text(r, f) for r in ev.reasons if not r.startswith(("A-class", "element "))
        ],
        "standard": f.pick(ev.standard, ev.standard_zh),
    }


def failed_items(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    """Page 1: every failing (or unjudged) result with its value, threshold and badge."""
    return [
        {
            "rule": r.rule,
            "title": f.title(r),
            "group": f.group(r.group),
            "status": r.status,
            "status_text": f.status(r.status),
            "value": f.value(r),
            "threshold": f.threshold(r),
        }
        for r in results.results
        if r.status in ("fail", "error")
    ]


def local_time(stamp: str) -> str:
    """An ISO UTC stamp (…Z) in local time with its zone, e.g. 2026-11-22 20:05 CST."""
    try:
        t = dt.datetime.strptime(stamp, "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=dt.UTC)
    except ValueError:
        return stamp
    local = t.astimezone()
    return local.strftime("%Y-%m-%d %H:%M ") + (local.tzname() or local.strftime("%z"))


def name_only(path: str) -> str:
    """A path shown by its last part: reports never show where this machine keeps files."""
    return PurePath(path).name if path else "–"


_NUMBERED = re.compile(r"^(.*?)(\d+)$")


def id_list(ids: Sequence[str], empty: str = "–", sep: str = ", ") -> str:
    """Ids joined by `sep` (commas; "、" on a Chinese page), each run of three or more
    consecutive numbers with the same prefix and width written first–last (B00001–B00250):
    a sample of a thousand blocks stays a line."""
    out: list[str] = []
    run: list[str] = []
    last: tuple[str, int, int] | None = None
    for block_id in ids:
        m = _NUMBERED.match(block_id)
        key = (m.group(1), len(m.group(2)), int(m.group(2))) if m else None
        if not (run and key and last and key[:2] == last[:2] and key[2] == last[2] + 1):
            out += [f"{run[0]}–{run[-1]}"] if len(run) >= 3 else run
            run = []
        run.append(block_id)
        last = key
    out += [f"{run[0]}–{run[-1]}"] if len(run) >= 3 else run
    return sep.join(out) or empty


def decision_context(s: Summary, f: Formatter) -> dict[str, Any] | None:
    """The batch decision (§QE-5) for summary.html and the batch acceptance report."""
    d: BatchDecision | None = s.acceptance
    if d is None:
        return None
    grade = {b.block_id: b for b in s.blocks}
    source = f.t("sample_by_plan") if d.sample_source == "plan" else f.t("sample_by_cps")
    return {
        "decision": d.decision,
        "decision_text": f._key("decision", d.decision, d.decision),
        "source": source,
        # beside the sample, in the page's brackets: a full-width one takes no space before it
        "source_note": f.paren(source),
        "sample": id_list(d.sample, sep=f.list_sep),
        "mean": f.score(d.mean_score),
        "sample_grade": grade_text(f, d.sample_grade),
        "batch_grade": grade_text(f, d.batch_grade),
        "shares": ""
        if d.better_pct is None
        else f.t("shares", better=f.score(d.better_pct), top=f.score(d.top_pct)),
        "failing": [_block_line(b, f) for b in d.failing],
        # sampled blocks with rules failed that do not fail the sample (errors of class B–D)
        "corrected": [
            _block_line(b, f) for b in d.blocks if b.sampled and not b.fails and b.failed_rules
        ],
        "returned": [_block_line(b, f) for b in d.returned],
        "incomplete": id_list(d.incomplete, empty="", sep=f.list_sep),
        "unread": _unread(d, f),
        "plan_notes": [_plan_note(n, f) for n in d.plan_notes],
        "short_sample": _short_sample(s, d, f),
        "blocks": [
            {
                **_block_line(b, f),
                "report": grade[b.block_id].report if b.block_id in grade else "",
                "verdict": grade[b.block_id].verdict if b.block_id in grade else "",
            }
            for b in d.blocks
        ],
        "standard": d.standard,
    }


def _unread(d: BatchDecision, f: Formatter) -> list[dict[str, str]]:
    """The deliveries not read, as the decision sees them: sampled or not (by the plan), or,
    without a plan, perhaps of the sample; one line each kind, with the block ids."""
    bearing = unread_in_sample(d)
    other = [u for u in d.unreadable if u not in bearing]
    plan = d.sample_source == "plan"
    missing = unaccounted(d)
    key = "unread_maybe_sampled" if missing else "unread_sampled" if plan else "unread_no_plan"
    lines = [
        (key, bearing, f.num(True) if plan and not missing else "–"),
        ("unread_not_sampled", other, f.num(False)),
    ]
    return [
        {
            "label": f.t(k, blocks=id_list(missing, sep=f.list_sep)),
            "blocks": id_list(ids, sep=f.list_sep),
            "ids": ids,
            "sampled": sampled,
        }
        for k, ids, sampled in lines
        if ids
    ]  # fmt: skip


def _short_sample(s: Summary, d: BatchDecision, f: Formatter) -> str:
    """Without a plan the sample is the blocks that carry checkpoints: said when they are fewer
    than the pack's table (§QE-1) asks of a batch of the deliveries inspected ("" otherwise)."""
    if d.sample_source == "plan" or not s.sampling_table or not s.counts.blocks:
        return ""
    try:
        sampling = Sampling.model_validate({"table": s.sampling_table})
    except ValidationError:
        return ""
    units = s.counts.blocks
    wanted = sum(sample_size(n, sampling) for n in split_sizes(units, sampling.max_batch))
    if len(d.sample) >= wanted:
        return ""
    return f.t("sample_below_table", n=len(d.sample), wanted=wanted, units=units)


def _plan_note(n: PlanNote, f: Formatter) -> str:
    """Where the plan differs from the batch inspected, in the page's language."""
    extra = (
        {"n": len(n.blocks), "blocks": id_list(n.blocks, sep=f.list_sep)}
        if n.about in ("units", "seed")
        else {}
    )
    return f.t(f"plan_note_{n.about}", plan=n.plan, inspected=n.inspected, **extra)


def _block_line(b: Any, f: Formatter) -> dict[str, Any]:
    return {
        "block_id": b.block_id,
        "sampled": f.num(b.sampled),
        "score": f.score(b.score),
        "grade": b.grade or "none",
        "grade_text": grade_text(f, b.grade),
        "fails": b.fails,
        "complete": b.complete,
        "reasons": f.clause_sep.join(_reasons(b, f)),
    }


def _reasons(b: Any, f: Formatter) -> list[str]:
    """Why a block fails or is incomplete, in the page's language, from the structured record."""
    # a full-width bracket takes no space before it
    colon, lp, rp = ("：", "（", "）") if f.lang == "zh" else (": ", " (", ")")
    out = [
        f"{f.t('a_class_error')}{colon}{x.rule}{(' ' + f.group(x.group)) if x.group else ''} "
        f"{_evidence(x, f, colon, lp, rp)}"
        for x in b.a_errors
    ]
    out += [
        f.t(
            "element_below",
            name=f.pick(e["title"], e["title_zh"]),
            score=f.score(e["score"]),
            below=f.num(e.get("below", 60)),  # (a summary written before it was recorded)
        )
        for e in b.low_elements
    ]
    out += [reason_text(r, f) for r in b.reasons if not r.startswith(("A-class error", "element "))]
    if b.failed_rules:
        out.append(f.t("rules_failed", rules=f.join(b.failed_rules)))
    return out


def reason_text(reason: str, f: Formatter) -> str:
    """An evaluation's reason (recorded in English) in the page's language."""
    if f.lang == "en":
        return reason
    if below := _BELOW_GRADES.fullmatch(reason):  # the lowest grade by its name, not its id
        score, least, grade = below.groups()
        return f.t("qe_below_grades", score=score, min=least, grade=grade_text(f, grade))
    if (sentence := f.sentence(reason)) != reason:  # why a rule is not judged or not scored
        return sentence
    if ruled := _RULE_SAYS.fullmatch(reason):  # "CP-1: sampled …, but …": the plan's word
        return f"{ruled[1]}：{f.text(ruled[2])}"
    for en, key in (
        ("A-class error", "a_class_error"),
        ("(fails its threshold)", "err_fails_p"),
        ("(beyond the norm)", "err_beyond_norm_p"),
    ):
        reason = reason.replace(en, f.t(key))
    return f.text(reason)  # the fixed phrases of results.json (a sampled block's, …)


def _sampling_rows(s: Summary, f: Formatter) -> list[dict[str, Any]]:
    """The plan's lots and strata (§QE-1), one row per stratum."""
    plan = s.sampling or {}
    rows = []
    for i, lot in enumerate(plan.get("lots", []), 1):
        for st in lot["strata"]:
            rows.append(
                {
                    "lot": i,
                    "lot_size": lot["size"],
                    "lot_sample": lot["sample_size"],
                    "census": f.num(bool(lot["census"])),
                    "stratum": st["value"] or "–",
                    "size": st["size"],
                    "sample": st["sample"],
                    "sampled": id_list(st["sampled"], sep=f.list_sep),
                }
            )
    return rows


def _contents(s: Summary, f: Formatter) -> list[dict[str, Any]]:
    """Inspection contents and methods: the pack's elements, items and how each is checked."""
    return [
        {
            "element": f.pick(e.title, e.title_zh),
            "item": f.pick(i.title, i.title_zh),
            "contents": "、".join(f.pick(c.title, c.title_zh) for c in i.contents)
            if f.lang == "zh"
            else "; ".join(c.title for c in i.contents),
            "method": f.pick(i.method, i.method_zh),
        }
        for e in s.elements
        for i in e.items
    ]


def _grade_counts(s: Summary, f: Formatter) -> str:
    counts: dict[str, int] = {}
    for b in s.blocks:
        if b.grade:
            counts[b.grade] = counts.get(b.grade, 0) + 1
    sep = "，" if f.lang == "zh" else ", "
    return sep.join(f"{grade_text(f, g)} {n}" for g, n in counts.items()) or "–"


def filed_context(s: Summary, lang: str) -> dict[str, Any]:
    """Everything acceptance.html.j2 shows: the batch acceptance report as a filed document."""
    f = Formatter(lang, s.acceptance.grades if s.acceptance else ())
    meta = s.meta
    d = decision_context(s, f)
    return {
        "t": f.t,
        "f": f,
        "lang": lang,
        "s": s,
        "m": meta,
        "project": f.pick(meta.project, meta.project_zh) if meta else "",
        "producer": f.pick(meta.producer, meta.producer_zh) if meta else "",
        "unit": f.pick(meta.inspection_unit, meta.inspection_unit_zh) if meta else "",
        "basis": (meta.basis_zh or meta.basis)
        if meta and lang == "zh"
        else (meta.basis if meta else []),
        "handling": (f.pick(meta.handling, meta.handling_zh) if meta else "")
        or f.t("handling_default"),
        "date": local_time(s.generated_at),
        "inspector": s.inspector or f.t("not_given"),
        "colon": f.colon,
        "method": f._key("sampling_method", (s.sampling or {}).get("method", "").replace(" ", "_")),
        "d": d,
        "sampling_rows": _sampling_rows(s, f),
        "plan": s.sampling,
        "table": s.sampling_table,
        "contents": _contents(s, f),
        "grade_counts": _grade_counts(s, f),
        "annexes": [f"{b.block_id}/report.html" for b in s.blocks] + (meta.annexes if meta else []),
    }
