"""What the templates show, worked out from the results document alone (and nothing else).

Nothing here knows a rule of a pack: sections come from the pack's `elements:` tree and each
result's `content` and `inspection`; figures from the results' `figures` hints and the
measurements the results name.
"""

from __future__ import annotations

import os
from typing import Any

from blockqc.report.acceptance import (
    decision_context,
    evaluation_context,
    failed_items,
    grade_text,
    local_time,
    name_only,
)
from blockqc.report.checkpoints import (
    axis_statistics,
    checkpoint_measurement,
    checkpoint_points,
    checkpoint_rows,
    failed_criteria,
)
from blockqc.report.contents import content_rows
from blockqc.report.figures import block_figures, scene_statuses
from blockqc.report.format import SENTENCES, Formatter, metric_units
from blockqc.report.messages import MESSAGES
from blockqc.report.overview import overview_map
from blockqc.report.process import process_rows
from blockqc.results import (
    STATUSES,
    BlockResults,
    RuleResult,
    Summary,
    status_rank,
)

NO_FIGURES: dict[str, list] = {
    "general": [],
    "detailed": [],
    "scene_maps": [],
    "general_notes": [],
    "notes": [],
}


#: the statistics a checkpoint rule judges that the mean error replaces below 20 points (§CP-7)
MEDIUM_ERROR_STATISTICS = ("medium_error",)


def _conditional(res: RuleResult) -> bool:
    """An inspector's pass on a condition (stated in the verdict's note)."""
    return res.value == "conditional_pass"


#: the notes of blockqc's own a result may carry that read in the page's language (MB-3's)
PROJECTION_NOTES = tuple(k for k in SENTENCES if k.startswith("mb_"))
#: blockqc's hints: the convention RC-1's delivered residuals reproduce in, a geometry RC-1 fails
#: under the discrepancies derived from it
HINTS = ("rc_convention", "rc_on_failed_geometry")


def _notes(res: RuleResult, f: Formatter) -> list[str]:
    """The result's reason, note (the condition of a conditional pass), waiver and §CP-7 notes."""
    detail, colon = res.detail, f.colon
    measured = detail.get("decided_by") != "inspector"  # a note of blockqc's, not a person's

    def said(k: str) -> str:
        text = f.text(str(detail[k]))
        if measured and k in ("note", "hint"):
            return f.sentence(text, PROJECTION_NOTES if k == "note" else HINTS)
        return text

    keys = ("reason", "note", "hint", "computed_by_blockqc", "waiver_reason", "waiver_ignored")
    notes = [said(k) for k in keys if detail.get(k)]
    if _conditional(res) and detail.get("note"):
        notes[notes.index(f.text(str(detail["note"])))] = f.t("condition") + colon + detail["note"]
    used_mean = detail.get("used_mean") or detail.get("statistic") == "mean"
    if used_mean and res.statistic in MEDIUM_ERROR_STATISTICS:
        notes.append(_mean_note(f, [detail.get("min_points_for_medium_error")]))
    return notes + _beside(res, f)


#: of the tie-point errors over the block, the statistic shown beside the one a rule judges
#: (§TP-1: the median judged, the RMS — 中误差 — always reported beside it; or the reverse)
TIE_POINT_BESIDE = {"median": ("rms", "tp_rms_beside"), "rms": ("median", "tp_median_beside")}


def _beside(res: RuleResult, f: Formatter) -> list[str]:
    """The other tie-point error statistic of the block, under a rule judging one of them."""
    other, key = TIE_POINT_BESIDE.get(res.statistic or "", ("", ""))
    value = res.detail.get(other)
    number = isinstance(value, int | float) and not isinstance(value, bool)
    if (res.measurement or "").split("#")[0] != "tie_point_errors" or not number:
        return []
    return [f.t(key, value=f.num(value), unit=f.unit(res.unit))]


def _mean_note(f: Formatter, counts: list[Any]) -> str:
    """The §CP-7 note, naming the number of checkpoints below which the mean error replaced
    the medium error (the pack's cp.min_points) when the results give that one number."""
    if counts and len(set(counts)) == 1 and counts[0] is not None:
        return f.t("used_mean_note_n", n=f.num(counts[0]))
    return f.t("used_mean_note")


def _status_text(res: RuleResult, f: Formatter) -> str:
    return f.t("val_conditional_pass") if _conditional(res) else f.status(res.status)


def _row(res: RuleResult, f: Formatter) -> dict[str, Any]:
    return {
        "rule": res.rule,
        "title": f.title(res),
        "description": f.pick(res.description, res.description_zh),
        "group": f.group(res.group),
        "status": res.status,
        "status_text": _status_text(res, f),
        "value": f.value(res),
        "threshold": f.threshold(res),
        "clause": res.clause,
        "notes": _notes(res, f),
    }


def _elements(results: BlockResults, f: Formatter) -> tuple[list[dict], list[RuleResult]]:
    rows, others = content_rows(results)
    elements: list[dict[str, Any]] = []
    for row in rows:
        if not elements or elements[-1]["key"] != row.element.id:
            name = f.pick(row.element.title, row.element.title_zh)
            elements.append({"key": row.element.id, "name": name, "items": []})
        items = elements[-1]["items"]
        if not items or items[-1]["key"] != row.item.id:
            items.append(
                {
                    "key": row.item.id,
                    "name": f.pick(row.item.title, row.item.title_zh),
                    "how": f.pick(row.item.method, row.item.method_zh),
                    "contents": [],
                }
            )
        items[-1]["contents"].append(
            {
                "name": f.pick(row.title, row.title_zh),
                "status": row.status,
                "status_text": f.status(row.status),
                "results": [_row(r, f) for r in row.results],
            }
        )
    return elements, others


# ------------------------------------------------------------------------- checkpoints
def _gross_rate(f: Formatter, s: dict[str, Any]) -> str:
    """The gross-error rate as the CP-4 result beside it shows its value (37.50 %, 0 %)."""
    return f.num(s.get("gross_rate")) + " %" if s.get("gross_rate") is not None else "–"


def _cp_stat_rows(
    f: Formatter, cols: list[dict[str, Any]], divisor: dict[str, Any]
) -> list[tuple[str, list[str]]]:
    def stat(s: dict[str, Any]) -> str:
        key = f"stat_{s.get('statistic')}"
        if s.get("statistic") == "mean":  # §CP-7: Σ|Δ|/n, or /(√2·n) where M2 is the statistic
            key += {1: "_M1", 2: "_M2"}.get(divisor.get(s.get("method")), "")
        return f.t(key) if key in MESSAGES else f.num(s.get("statistic"))

    mean = [bool(s.get("used_mean")) for s in cols]
    return [
        (f.t("n_total"), [f.num(s.get("n_total")) for s in cols]),
        (f.t("n_used"), [f.num(s.get("n")) for s in cols]),
        (f.t("statistic"), [stat(s) for s in cols]),
        (
            f.t("medium_error"),
            [
                ("* " if u else "") + f.num(s.get("medium_error"), 2)
                for s, u in zip(cols, mean, strict=True)
            ],
        ),
        (f.t("used_mean"), [f.num(u) for u in mean]),
        (f.t("max_error"), [f.num(s.get("max_error"), 2) for s in cols]),
        (f.t("n_gross"), [f.num(s.get("n_gross")) for s in cols]),
        (f.t("gross_rate"), [_gross_rate(f, s) for s in cols]),
        (f.t("norm"), [f.num(s.get("norm_m"), 2) for s in cols]),
        (f.t("bound"), [f.num(s.get("bound_m"), 2) for s in cols]),
    ]


def _axis_rows(
    f: Formatter, cols: list[dict[str, Any]], axes: dict, failed: dict
) -> list[tuple[str, list[str]]]:
    """Mean (bias), standard deviation and RMS per axis, and the criterion that failed."""
    names = {"dx_m": "dx", "dy_m": "dy", "dz_m": "dz"}
    out = []
    for axis in ("dx_m", "dy_m", "dz_m"):
        got = [axes.get((s["component"], s["method"]), {}).get(axis) for s in cols]
        if not any(got):
            continue
        for stat in ("mean", "std", "rms"):
            label = f"{f.t('axis_' + stat)} {names[axis]}{f.paren('m')}"
            out.append((label, [f.num(g[stat], 2) if g else "–" for g in got]))
    crit = [failed.get((s["component"], s["method"]), []) for s in cols]
    out.append((f.t("failed_criterion"), [f.join(f.column(c) for c in x) or "–" for x in crit]))
    return out


def _agreement(f: Formatter, a: dict[str, Any]) -> dict[str, Any]:
    return {
        "methods": " / ".join(f.method(m) for m in a.get("methods", [])),
        "errors": f.join(f.num(e, 2) for e in a.get("medium_error") or []),
        "spread": f.num(a.get("spread_m"), 2),
        "agree": a.get("agree"),
        "text": f.t("agree") if a.get("agree") else f.t("disagree"),
    }


def _checkpoint_tables(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    """The published layout: one column per method, statistics in rows, per component."""
    stats = checkpoint_rows(results)
    m = checkpoint_measurement(results)
    axes, failed = axis_statistics(results), failed_criteria(results)
    agreement = (m.detail.get("agreement") if m else None) or []
    divisor = (m.params.get("divisor") if m else None) or {}
    tables = []
    for component in dict.fromkeys(s["component"] for s in stats):
        cols = [s for s in stats if s["component"] == component]
        tables.append(
            {
                "component": f.component(component),
                "key": component,
                "methods": [f.method(s["method"]) for s in cols],
                "rows": _cp_stat_rows(f, cols, divisor) + _axis_rows(f, cols, axes, failed),
                "statuses": [(s["status"], f.status(s["status"])) for s in cols],
                "any_mean": any(bool(s.get("used_mean")) for s in cols),
                "mean_note": _mean_note(
                    f, [s.get("min_points_for_medium_error") for s in cols if s.get("used_mean")]
                ),
                "agreement": [
                    _agreement(f, a) for a in agreement if a.get("component") == component
                ],
            }
        )
    return tables


def _checkpoint_points(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    return [
        {
            "component": f.component(p.get("component", "")),
            "method": f.method(p.get("method", "")),
            "point_id": f.num(p.get("point_id")),
            "reference_id": f.num(p.get("reference_id")),
            "dx": f.num(p.get("dx_m"), 2),
            "dy": f.num(p.get("dy_m"), 2),
            "dz": f.num(p.get("dz_m"), 2),
            "error": f.num(p.get("error_m"), 2),
            "bound": f.num(p.get("bound_m"), 2),
            "gross": bool(p.get("gross")),
            "gross_text": f.num(bool(p.get("gross"))),
        }
        for p in checkpoint_points(results)
    ]


# --------------------------------------------------------------- inspector and failures
def _manual(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    return [
        {
            **_row(r, f),
            "verdict": f.value(r) if r.value else "–",
            "note": f.text(r.detail.get("note") or r.detail.get("reason") or ""),
        }
        for r in results.results
        if r.status == "manual" or r.detail.get("decided_by") == "inspector"
    ]


def _waivers(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    out = []
    for r in results.results:
        d = r.detail
        base = {
            "rule": r.rule,
            "group": f.group(r.group),
            "status_text": f.status(r.status),
            "status": r.status,
        }
        if d.get("waived") or d.get("waiver_reason") or r.status == "waived":
            units = ", ".join(map(str, d.get("waived") or [])) or f.t("whole_rule")
            out.append({**base, "units": units, "reason": d.get("waiver_reason") or ""})
        if d.get("waiver_ignored"):
            reason = f"{f.t('waiver_ignored')}: {d['waiver_ignored']}"
            out.append({**base, "units": "–", "reason": reason})
    return out


def _exemptions(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    return [
        {
            "rule": r.rule,
            "units": ", ".join(str(v) for k, v in e.items() if k != "exempt_reason"),
            "reason": f.text(str(e.get("exempt_reason", ""))),
        }
        for r in results.results
        for e in r.detail.get("exempt") or []
        if isinstance(e, dict)
    ]


def _evidence_rows(res: RuleResult) -> list[dict[str, Any]]:
    """The offending units; for a block-level failure without any, the measured row itself
    (the scalars of its detail: stated and expected datum, EPSG code, zone …)."""
    if res.evidence or res.status not in ("fail", "error", "warn"):
        return res.evidence
    skip = {"reason", "note", "waiver_reason", "waiver_ignored", "evidence_truncated"}
    row = {
        k: v
        for k, v in res.detail.items()
        if k not in skip and (v is None or isinstance(v, str | int | float | bool))
    }
    return [row] if row else []


def _evidence_table(res: RuleResult, f: Formatter, units: dict[str, str]) -> dict[str, Any]:
    rows = _evidence_rows(res)
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    keys = [
        k
        for k in keys
        if any(r.get(k) is not None for r in rows)
        and not (k in res.group and all(r.get(k) == res.group[k] for r in rows))
    ]

    def numeric(k: str) -> bool:
        vals = [r.get(k) for r in rows if r.get(k) is not None]
        return all(isinstance(v, int | float) and not isinstance(v, bool) for v in vals)

    cells = [[f.cell(r.get(k)) for k in keys] for r in rows]
    return {
        "headers": [f.evidence_column(k, units) for k in keys],
        "numeric": [numeric(k) for k in keys],
        "long": [bool(f.ident([c[i] for c in cells])) for i in range(len(keys))],
        "rows": cells,
        "shown": len(rows),
        "total": len(rows) + int(res.detail.get("evidence_truncated") or 0),
    }


def _failures(results: BlockResults, f: Formatter) -> list[dict[str, Any]]:
    """The results not passed, each with its evidence, the worst first: waived ones too, so
    that what a waiver covers is seen with its values."""
    bad = [r for r in results.results if r.status in ("fail", "error", "warn", "waived")]
    bad.sort(key=lambda r: status_rank(r.status))
    return [{**_row(r, f), "evidence": _evidence_table(r, f, _units(results, r))} for r in bad]


def _units(results: BlockResults, res: RuleResult) -> dict[str, str]:
    m = results.measurement(res.measurement)
    return metric_units(m.metric if m else None)


# ----------------------------------------------------------------------------- pages
def _header(results: BlockResults, f: Formatter) -> dict[str, Any]:
    t, c, s = f.t, results.counts, results.summary
    return {
        "verdict": results.verdict,
        "verdict_text": f.verdict(results.verdict),
        "inspector": results.inspector or t("not_given"),
        "date": local_time(results.generated_at),
        "counts_text": t(
            "counts_line",
            pass_=c.get("pass", 0),
            fail=c.get("fail", 0),
            warn=c.get("warn", 0),
            waived=c.get("waived", 0),
            manual=c.get("manual", 0),
            na=c.get("not_applicable", 0),
            error=c.get("error", 0),
        ),
        "contents_text": t(
            "contents_text",
            scenes=s.get("scenes", "–"),
            tie_points=s.get("tie_points") if s.get("tie_points") is not None else "–",
            observations=s.get("tie_point_observations", "–"),
            checkpoints=s.get("checkpoints", "–"),
        )
        + (t("contents_one_scene", n=s["tie_points_on_one_scene"]) if _one_scene(s) else ""),
        "not_read_text": _not_read(results, f),
        "input_warnings": _input_warnings(results, f),
    }


def _one_scene(s: dict) -> bool:
    """Whether the delivery gives tie points observed on one scene only (counted as given)."""
    return bool(s.get("tie_points_on_one_scene"))


def _not_read(results: BlockResults, f: Formatter) -> str:
    """The columns the pack did not read, by table ("" when every column was read)."""
    if not results.not_read:
        return ""
    columns = ", ".join(f"{table}.{c}" for table, cols in results.not_read.items() for c in cols)
    return f.t("not_read_text", columns=columns)


#: the sentences of results.json's input_warnings, in the page's language
INPUT_WARNINGS = (
    "iw_scene_apart",
    "iw_scenes_apart",
    "iw_ground_differs",
    "iw_ground_more",
    "iw_scenes_without_rpc",
    "iw_stored_type_coarse",
    "iw_stored_type",
    "iw_document_kind",
)


def _input_warnings(results: BlockResults, f: Formatter) -> list[str]:
    """What the delivery gives that its rules judged as given, each in the page's language,
    its file named within the delivery (the delivery is named on the page)."""
    folder = os.path.join(results.delivery, "") if results.delivery else ""
    return [
        f.sentence(w.removeprefix(folder) if folder else w, INPUT_WARNINGS)
        for w in results.input_warnings
    ]


def block_context(
    results: BlockResults | dict[str, Any], lang: str = "en", figures: bool = True
) -> dict[str, Any]:
    """Everything block.html.j2 shows, formatted in `lang`."""
    results = BlockResults.model_validate(results)
    f = Formatter(lang)
    elements, others = _elements(results, f)
    rows = results.results
    return {
        "t": f.t,
        "f": f,
        "lang": lang,
        "r": results,
        **_header(results, f),
        "elements": elements,
        "others": [_row(r, f) for r in others],
        "general": [_row(r, f) for r in rows if r.inspection == "general"],
        "detailed": [_row(r, f) for r in rows if r.inspection == "detailed"],
        "process": process_rows(results.process_data, f),
        "cp_tables": _checkpoint_tables(results, f),
        "cp_points": _checkpoint_points(results, f),
        "manual": _manual(results, f),
        "waivers": _waivers(results, f),
        "exemptions": _exemptions(results, f),
        "failures": _failures(results, f),
        "figures": block_figures(results, f, scene_statuses(results)) if figures else NO_FIGURES,
        "pending": f.join(results.pending_manual),
        "evaluation": evaluation_context(results.evaluation, f, results.results),
        "colon": f.colon,
        "sep": f.clause_sep,
        "failed_items": failed_items(results, f),
        "delivery_name": name_only(results.delivery),
        "pack_files": ", ".join(name_only(p) for p in results.rule_pack_files) or "–",
    }


def _summary_block(b: Any, f: Formatter, pdf: bool) -> dict[str, Any]:
    return {
        **b.model_dump(by_alias=True),
        "verdict_text": f.verdict(b.verdict),
        "pdf": b.report[: -len(".html")] + ".pdf" if b.pdf and b.report.endswith(".html") else None,
        "sampled_text": f.num(b.sampled),
        "score_text": f.score(b.score),
        "grade_text": grade_text(f, b.grade),
        "failed": f.join(b.failed_rules),
        "warned": f.join(b.warned_rules),
        "pending": f.join(b.pending_manual),
    }


def _sampled_row(b: Any, s: dict[str, Any], f: Formatter) -> dict[str, Any]:
    return {
        "block_id": b.block_id,
        "report": b.report,
        "component": f.component(s["component"]),
        "method": f.method(s["method"]),
        "n_total": f.num(s.get("n_total")),
        "n": f.num(s.get("n")),
        "medium_error": ("* " if s.get("used_mean") else "") + f.num(s.get("medium_error"), 2),
        "max_error": f.num(s.get("max_error"), 2),
        "n_gross": f.num(s.get("n_gross")),
        "gross_rate": _gross_rate(f, s),
        "used_mean": bool(s.get("used_mean")),
        "status": s.get("status"),
        "status_text": f.status(s.get("status")),
    }


def summary_context(
    summary: Summary | dict[str, Any], lang: str = "en", pdf: bool = True, figures: bool = True
) -> dict[str, Any]:
    """Everything summary.html.j2 shows: verdicts, counts per rule, the sampled blocks."""
    summary = Summary.model_validate(summary)
    f = Formatter(lang, summary.acceptance.grades if summary.acceptance else ())
    t = f.t
    stats = [(b, s) for b in summary.blocks if b.sampled for s in b.checkpoints]
    sampled = [_sampled_row(b, s, f) for b, s in stats]
    c = summary.counts
    return {
        "t": t,
        "f": f,
        "lang": lang,
        "s": summary,
        "verdict": summary.verdict,
        "verdict_text": f.verdict(summary.verdict),
        "inspector": summary.inspector or t("not_given"),
        "date": local_time(summary.generated_at),
        "counts_text": t(  # the blocks in error are among those that fail: said apart
            "batch_counts_error" if c.error else "batch_counts",
            blocks=c.blocks,
            pass_=c.pass_,
            fail=c.fail,
            error=c.error,
            unreadable=c.unreadable,
        ),
        "blocks": [_summary_block(b, f, pdf) for b in summary.blocks],
        "overview": overview_map(summary.blocks, t, "overview") if figures else None,
        "sampled": sampled,
        "any_mean": any(x["used_mean"] for x in sampled),
        "mean_note": _mean_note(
            f, [s.get("min_points_for_medium_error") for _, s in stats if s.get("used_mean")]
        ),
        "rule_statuses": [f.status(s) for s in STATUSES],
        "rules": [
            {"rule": rid, "counts": [cnt.get(s, 0) for s in STATUSES]}
            for rid, cnt in summary.rules.items()
        ],
        "unreadable": [
            {**u.model_dump(), "problems": [f.text(str(p)) for p in u.problems]}
            for u in summary.unreadable
        ],
        "acceptance": decision_context(summary, f),
    }


__all__ = [
    "Formatter",
    "block_context",
    "checkpoint_points",
    "checkpoint_rows",
    "scene_statuses",
    "summary_context",
]
