"""What the templates show, worked out from results.json alone (and nothing else)."""

from __future__ import annotations

import math
from typing import Any

from blockqc.report import plots
from blockqc.report.contents import SEVERITY_ORDER, content_rows, worst
from blockqc.report.messages import MESSAGES, translator

SCENE_KEYS = ("scene_id", "scene_a", "scene_b", "pan_scene_id", "ms_scene_id")
MAX_SCENE_MAPS = 24
DEFAULT_MARKS = (0.5, 1.0, 1.5)


class Formatter:
    """Numbers, thresholds, groups and statuses for people, in one language."""

    def __init__(self, lang: str):
        self.lang = lang
        self.t = translator(lang)

    def num(self, v: Any, digits: int | None = None) -> str:
        if v is None:
            return "–"
        if isinstance(v, bool):
            return self.t("yes") if v else self.t("no")
        if isinstance(v, int):
            return str(v)
        if isinstance(v, float):
            if not math.isfinite(v):
                return str(v)
            if v.is_integer() and abs(v) < 1e9 and digits is None:
                return str(int(v))
            d = digits if digits is not None else (3 if abs(v) < 1 else 2)
            return f"{v:.{d}f}"
        if isinstance(v, list | tuple):
            return ", ".join(self.num(x, digits) for x in v)
        if isinstance(v, dict):
            return ", ".join(f"{k}: {self.num(x, digits)}" for k, x in v.items())
        return str(v)

    def unit(self, unit: str | None) -> str:
        key = f"unit_{unit}"
        return self.t(key) if unit and key in MESSAGES else (unit or "")

    def bound(self, v: Any) -> str:
        """A threshold as the specification writes it: 0.5, 2.6, 28.28 (two decimals at most)."""
        if isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v):
            return f"{v:.2f}".rstrip("0").rstrip(".")
        return self.num(v)

    def value(self, res: dict[str, Any]) -> str:
        if res.get("status") == "manual" and res.get("value") is None:
            return "–"
        text = self.num(res.get("value"))
        unit = self.unit(res.get("unit"))
        return f"{text} {unit}".strip() if res.get("value") is not None and unit else text

    def threshold(self, res: dict[str, Any]) -> str:
        comp, th = res.get("comparison"), res.get("threshold")
        unit = self.unit(res.get("unit"))
        if comp is None or th is None:
            return res.get("threshold_text") or "–"
        symbols = {"<=": "≤", "<": "<", ">=": "≥", ">": ">", "equals": "="}
        if comp in symbols:
            text = f"{symbols[comp]} {self.bound(th)}"
        elif comp == "between" and isinstance(th, list) and len(th) == 2:
            text = f"{self.bound(th[0])} … {self.bound(th[1])}"
        elif comp == "in":
            text = "∈ {" + self.num(th) + "}"
        else:
            return res.get("threshold_text") or "–"
        return (
            f"{text} {unit}".strip()
            if isinstance(th, int | float | list) and not isinstance(th, bool) and unit
            else text
        )

    def group(self, group: dict[str, Any] | None) -> str:
        parts = []
        for k, v in (group or {}).items():
            key = f"{k}_{v}"
            parts.append(self.t(key) if key in MESSAGES else str(v))
        return " · ".join(parts)

    def status(self, s: str | None) -> str:
        if s is None:
            return self.t("not_checked")
        key = f"status_{s}"
        return self.t(key) if key in MESSAGES else s

    def verdict(self, v: str) -> str:
        key = f"verdict_{v}"
        return self.t(key) if key in MESSAGES else v.upper()

    def title(self, res: dict[str, Any]) -> str:
        key = f"rt_{res['rule']}"
        if self.lang != "en" and key in MESSAGES and MESSAGES[key][0] == res.get("title"):
            return self.t(key)
        return str(res.get("title") or res["rule"])

    def column(self, key: str) -> str:
        for k in (f"col_{key}", key):
            if k in MESSAGES and not k.startswith(("rt_", "qe_", "it_", "ct_")):
                return self.t(k)
        return key

    def method(self, m: str) -> str:
        return self.t(f"method_{m}") if f"method_{m}" in MESSAGES else m

    def component(self, c: str) -> str:
        return self.t(f"component_{c}") if f"component_{c}" in MESSAGES else c


def _measure(results: dict[str, Any], *path: str) -> Any:
    node: Any = results.get("measurements") or {}
    for p in path:
        if not isinstance(node, dict) or p not in node:
            return None
        node = node[p]
    return node


def _status_rank(s: str) -> int:
    order = {"error": 0, "fail": 0, "warn": 1, "waived": 2, "exempt": 3, "pass": 4}
    return order.get(s, 5)


def scene_statuses(results: dict[str, Any], rules: tuple[str, ...] | None = None) -> dict[str, str]:
    """The worst status met by each scene in the evidence, exemptions or waivers of `rules`."""
    out: dict[str, str] = {}

    def mark(scene: Any, status: str) -> None:
        if scene is None:
            return
        key = str(scene)
        if key not in out or _status_rank(status) < _status_rank(out[key]):
            out[key] = status

    for res in results.get("results", []):
        if rules is not None and res["rule"] not in rules:
            continue
        status = res.get("status", "pass")
        detail = res.get("detail") or {}
        for row in detail.get("exempt") or []:
            if isinstance(row, dict):
                mark(row.get("scene_id"), "exempt")
        for label in detail.get("waived") or []:
            for part in str(label).split("/"):
                mark(part, "waived")
        if status in ("fail", "error", "warn"):
            for row in res.get("evidence") or []:
                for k in SCENE_KEYS:
                    if k in row:
                        mark(row[k], status)
    return out


def _evidence_table(res: dict[str, Any], f: Formatter) -> dict[str, Any]:
    rows = res.get("evidence") or []
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    group = res.get("group") or {}
    keys = [
        k
        for k in keys
        if any(r.get(k) is not None for r in rows)
        and not (k in group and all(r.get(k) == group[k] for r in rows))
    ]
    truncated = (res.get("detail") or {}).get("evidence_truncated") or 0
    return {
        "headers": [f.column(k) for k in keys],
        "numeric": [
            all(
                isinstance(r.get(k), int | float) and not isinstance(r.get(k), bool)
                for r in rows
                if r.get(k) is not None
            )
            for k in keys
        ],
        "rows": [[f.num(r.get(k)) for k in keys] for r in rows],
        "shown": len(rows),
        "total": len(rows) + int(truncated),
    }


def _row(res: dict[str, Any], f: Formatter) -> dict[str, Any]:
    detail = res.get("detail") or {}
    notes = []
    for k in ("reason", "note", "waiver_reason", "waiver_ignored"):
        if detail.get(k):
            notes.append(str(detail[k]))
    if detail.get("used_mean") or detail.get("statistic") == "mean":
        notes.append(f.t("used_mean_note"))
    return {
        "rule": res["rule"],
        "title": f.title(res),
        "group": f.group(res.get("group")),
        "status": res.get("status"),
        "status_text": f.status(res.get("status")),
        "value": f.value(res),
        "threshold": f.threshold(res),
        "clause": res.get("clause") or "",
        "notes": notes,
    }


def _checkpoint_tables(results: dict[str, Any], f: Formatter) -> list[dict[str, Any]]:
    stats = _measure(results, "checkpoint_accuracy", "component_method") or []
    agreement = _measure(results, "checkpoint_accuracy", "detail", "agreement") or []
    res_by_group: dict[tuple[str, str], list[str]] = {}
    for res in results.get("results", []):
        g = res.get("group") or {}
        if res["rule"].startswith("CP-") and "component" in g and "method" in g:
            res_by_group.setdefault((g["component"], g["method"]), []).append(res["status"])
    tables = []
    for component in dict.fromkeys(s["component"] for s in stats):
        cols = [s for s in stats if s["component"] == component]
        mean_used = [bool(s.get("used_mean")) for s in cols]
        rows = [
            (f.t("n_total"), [f.num(s.get("n_total")) for s in cols]),
            (f.t("n_used"), [f.num(s.get("n")) for s in cols]),
            (
                f.t("statistic"),
                [
                    f.t(f"stat_{s['statistic']}")
                    if f"stat_{s.get('statistic')}" in MESSAGES
                    else f.num(s.get("statistic"))
                    for s in cols
                ],
            ),
            (
                f.t("medium_error"),
                [
                    ("* " if u else "") + f.num(s.get("medium_error"), 2)
                    for s, u in zip(cols, mean_used, strict=True)
                ],
            ),
            (f.t("used_mean"), [f.num(u) for u in mean_used]),
            (f.t("max_error"), [f.num(s.get("max_error"), 2) for s in cols]),
            (f.t("n_gross"), [f.num(s.get("n_gross")) for s in cols]),
            (
                f.t("gross_rate"),
                [
                    f.num(s.get("gross_rate"), 1) + " %" if s.get("gross_rate") is not None else "–"
                    for s in cols
                ],
            ),
            (f.t("norm"), [f.num(s.get("norm_m"), 2) for s in cols]),
            (f.t("bound"), [f.num(s.get("bound_m"), 2) for s in cols]),
        ]
        statuses = [worst(res_by_group.get((component, s["method"]), [])) for s in cols]
        agree = [a for a in agreement if a.get("component") == component]
        tables.append(
            {
                "component": f.component(component),
                "key": component,
                "methods": [f.method(s["method"]) for s in cols],
                "rows": rows,
                "statuses": [(s, f.status(s)) for s in statuses],
                "any_mean": any(mean_used),
                "agreement": [
                    {
                        "methods": " / ".join(f.method(m) for m in a.get("methods", [])),
                        "errors": f.num(a.get("medium_error"), 2),
                        "spread": f.num(a.get("spread_m"), 2),
                        "agree": a.get("agree"),
                        "text": f.t("agree") if a.get("agree") else f.t("disagree"),
                    }
                    for a in agree
                ],
            }
        )
    return tables


def _checkpoint_points(results: dict[str, Any], f: Formatter) -> list[dict[str, Any]]:
    points = _measure(results, "checkpoint_accuracy", "point") or []
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
        for p in points
    ]


def _marks(results: dict[str, Any]) -> list[float]:
    marks: set[float] = set()
    for res in results.get("results", []):
        if res["rule"] in ("TP-1", "TP-2") and isinstance(res.get("threshold"), int | float):
            marks.add(float(res["threshold"]))
    interval = _measure(results, "tie_point_errors", "detail", "interval_px")
    if isinstance(interval, list):
        marks.update(float(v) for v in interval if isinstance(v, int | float))
    return sorted(marks) or list(DEFAULT_MARKS)


def _figures(results: dict[str, Any], f: Formatter, statuses: dict[str, str]) -> dict[str, Any]:
    t = f.t
    figs: dict[str, Any] = {"general": [], "detailed": [], "scene_maps": [], "notes": []}
    points = _measure(results, "checkpoint_accuracy", "point") or []
    stats = _measure(results, "checkpoint_accuracy", "component_method") or []
    for component in ("plane", "height"):
        if any(p.get("component") == component for p in points):
            figs["detailed"].append(
                plots.checkpoint_errors(points, stats, component, t, f"cp-{component}")
            )
    if any(p.get("component") == "plane" for p in points):
        if not any(p.get("x_m") is not None for p in points):
            figs["notes"].append(t("vector_no_positions"))
        figs["detailed"].append(plots.checkpoint_vectors(points, stats, t, "cp-vectors"))
    hist = _measure(results, "tie_point_errors", "detail", "histogram")
    if isinstance(hist, dict) and hist.get("counts"):
        figs["general"].append(plots.residual_histogram(hist, _marks(results), t, "tp-hist"))
    per_scene = _measure(results, "tie_point_distribution", "scene") or []
    tp4 = next((r for r in results.get("results", []) if r["rule"] == "TP-4"), None)
    minimum = (
        tp4.get("threshold") if tp4 and isinstance(tp4.get("threshold"), int | float) else None
    )
    if per_scene:
        figs["general"].append(
            plots.scene_counts(
                per_scene, minimum, scene_statuses(results, ("TP-4",)), t, "tp-counts"
            )
        )
    scenes = _measure(results, "scenes") or []
    if any(s.get("footprint_wkt") for s in scenes):
        figs["general"].append(plots.footprints(scenes, statuses, t, "footprints"))
    failing: list[str] = []
    for res in results.get("results", []):
        if res["rule"] in ("TP-4", "TP-5") and res.get("status") in ("fail", "error"):
            failing += [
                str(r["scene_id"])
                for r in res.get("evidence") or []
                if "scene_id" in r and str(r["scene_id"]) not in failing
            ]
    kept = _measure(results, "tie_point_distribution", "failing_scene_points") or {}
    grid = _measure(results, "tie_point_distribution", "detail", "grid") or 3
    size = {str(s["scene_id"]): s for s in scenes}
    for i, sid in enumerate(failing[:MAX_SCENE_MAPS]):
        pts = kept.get(sid)
        scene = size.get(sid, {})
        if not pts or not scene.get("lines") or not scene.get("samples"):
            figs["scene_maps"].append({"scene": sid, "svg": None, "caption": t("no_points_kept")})
            continue
        svg = plots.scene_points(
            sid,
            pts.get("line", []),
            pts.get("sample", []),
            scene["lines"],
            scene["samples"],
            int(grid),
            t,
            f"scene-{i}",
        )
        figs["scene_maps"].append(
            {
                "scene": sid,
                "svg": svg,
                "caption": t("scene_points_caption", n=len(pts.get("line", []))),
            }
        )
    if len(failing) > MAX_SCENE_MAPS:
        figs["notes"].append(t("maps_capped", n=MAX_SCENE_MAPS, total=len(failing)))
    return figs


def block_context(
    results: dict[str, Any], lang: str = "en", figures: bool = True
) -> dict[str, Any]:
    """Everything block.html.j2 shows, formatted in `lang`."""
    f = Formatter(lang)
    t = f.t
    rs = results.get("results", [])
    rows, others = content_rows(rs)
    elements: list[dict[str, Any]] = []
    for row in rows:
        if not elements or elements[-1]["key"] != row.element:
            elements.append({"key": row.element, "name": t(row.element), "items": []})
        items = elements[-1]["items"]
        if not items or items[-1]["key"] != row.item:
            items.append({"key": row.item, "name": t(row.item), "how": t(row.how), "contents": []})
        items[-1]["contents"].append(
            {
                "name": t(row.content),
                "status": row.status,
                "status_text": f.status(row.status),
                "results": [_row(r, f) for r in row.results],
            }
        )
    general = [_row(r, f) for r in rs if not r["rule"].startswith("CP-")]
    detailed = [_row(r, f) for r in rs if r["rule"].startswith("CP-")]
    manual = [
        {
            **_row(r, f),
            "verdict": f.status(r.get("value")) if r.get("value") else "–",
            "note": (r.get("detail") or {}).get("note")
            or (r.get("detail") or {}).get("reason")
            or "",
        }
        for r in rs
        if r.get("status") == "manual" or (r.get("detail") or {}).get("decided_by") == "inspector"
    ]
    waivers, exemptions = [], []
    for r in rs:
        d = r.get("detail") or {}
        if d.get("waived") or d.get("waiver_reason") or r.get("status") == "waived":
            waivers.append(
                {
                    "rule": r["rule"],
                    "group": f.group(r.get("group")),
                    "units": ", ".join(map(str, d.get("waived") or [])) or t("whole_rule"),
                    "reason": d.get("waiver_reason") or "",
                    "status_text": f.status(r.get("status")),
                    "status": r.get("status"),
                }
            )
        if d.get("waiver_ignored"):
            waivers.append(
                {
                    "rule": r["rule"],
                    "group": f.group(r.get("group")),
                    "units": "–",
                    "reason": f"{t('waiver_ignored')}: {d['waiver_ignored']}",
                    "status_text": f.status(r.get("status")),
                    "status": r.get("status"),
                }
            )
        for e in d.get("exempt") or []:
            if isinstance(e, dict):
                unit = ", ".join(str(v) for k, v in e.items() if k != "exempt_reason")
                exemptions.append(
                    {"rule": r["rule"], "units": unit, "reason": e.get("exempt_reason", "")}
                )
    rank = {s: i for i, s in enumerate(SEVERITY_ORDER)}
    failures = sorted(
        (
            {**_row(r, f), "evidence": _evidence_table(r, f)}
            for r in rs
            if r.get("status") in ("fail", "error", "warn")
        ),
        key=lambda x: rank.get(x["status"], 9),
    )
    statuses = scene_statuses(results)
    counts = results.get("counts") or {}
    summary = results.get("summary") or {}
    return {
        "t": t,
        "f": f,
        "lang": lang,
        "r": results,
        "verdict": results.get("verdict", "error"),
        "verdict_text": f.verdict(results.get("verdict", "error")),
        "inspector": results.get("inspector") or t("not_given"),
        "date": (results.get("generated_at") or "").replace("T", " ").replace("Z", " UTC"),
        "counts_text": t(
            "counts_line",
            pass_=counts.get("pass", 0),
            fail=counts.get("fail", 0),
            warn=counts.get("warn", 0),
            waived=counts.get("waived", 0),
            manual=counts.get("manual", 0),
            na=counts.get("not_applicable", 0),
            error=counts.get("error", 0),
        ),
        "contents_text": t(
            "contents_text",
            scenes=summary.get("scenes", "–"),
            tie_points=summary.get("tie_points", "–"),
            observations=summary.get("tie_point_observations", "–"),
            checkpoints=summary.get("checkpoints", "–"),
        ),
        "elements": elements,
        "others": [_row(r, f) for r in others],
        "general": general,
        "detailed": detailed,
        "cp_tables": _checkpoint_tables(results, f),
        "cp_points": _checkpoint_points(results, f),
        "manual": manual,
        "waivers": waivers,
        "exemptions": exemptions,
        "failures": failures,
        "figures": _figures(results, f, statuses)
        if figures
        else {"general": [], "detailed": [], "scene_maps": [], "notes": []},
        "pending": results.get("pending_manual") or [],
    }


def summary_context(
    summary: dict[str, Any], block_results: list[dict[str, Any]], lang: str = "en", pdf: bool = True
) -> dict[str, Any]:
    """Everything summary.html.j2 shows: verdicts, counts per rule, the sampled blocks."""
    f = Formatter(lang)
    t = f.t
    by_id = {r["block_id"]: r for r in block_results}
    blocks = []
    for b in summary.get("blocks", []):
        report = b.get("report") or f"{b['block_id']}/report.html"
        blocks.append(
            {
                **b,
                "verdict_text": f.verdict(b.get("verdict", "error")),
                "report": report,
                "pdf": report[: -len(".html")] + ".pdf"
                if pdf and report.endswith(".html")
                else None,
                "sampled_text": f.num(bool(b.get("sampled"))),
                "failed": ", ".join(b.get("failed_rules") or []),
                "warned": ", ".join(b.get("warned_rules") or []),
                "pending": ", ".join(b.get("pending_manual") or []),
            }
        )
    sampled = []
    for b in summary.get("blocks", []):
        r = by_id.get(b["block_id"])
        if r is None or not b.get("sampled"):
            continue
        stats = _measure(r, "checkpoint_accuracy", "component_method") or []
        status_of: dict[tuple[str, str], list[str]] = {}
        for res in r.get("results", []):
            g = res.get("group") or {}
            if "component" in g and "method" in g and res["rule"].startswith("CP-"):
                status_of.setdefault((g["component"], g["method"]), []).append(res["status"])
        for s in stats:
            st = worst(status_of.get((s["component"], s["method"]), []))
            sampled.append(
                {
                    "block_id": b["block_id"],
                    "report": b.get("report"),
                    "component": f.component(s["component"]),
                    "method": f.method(s["method"]),
                    "n_total": f.num(s.get("n_total")),
                    "n": f.num(s.get("n")),
                    "medium_error": ("* " if s.get("used_mean") else "")
                    + f.num(s.get("medium_error"), 2),
                    "max_error": f.num(s.get("max_error"), 2),
                    "n_gross": f.num(s.get("n_gross")),
                    "gross_rate": f.num(s.get("gross_rate"), 1) + " %"
                    if s.get("gross_rate") is not None
                    else "–",
                    "used_mean": bool(s.get("used_mean")),
                    "status": st,
                    "status_text": f.status(st),
                }
            )
    statuses = ("pass", "fail", "warn", "waived", "manual", "not_applicable", "error")
    rules = [
        {"rule": rid, "counts": [c.get(s, 0) for s in statuses]}
        for rid, c in (summary.get("rules") or {}).items()
    ]
    c = summary.get("counts") or {}
    return {
        "t": t,
        "f": f,
        "lang": lang,
        "s": summary,
        "verdict": summary.get("verdict", "error"),
        "verdict_text": f.verdict(summary.get("verdict", "error")),
        "inspector": summary.get("inspector") or t("not_given"),
        "date": (summary.get("generated_at") or "").replace("T", " ").replace("Z", " UTC"),
        "counts_text": t(
            "batch_counts",
            blocks=c.get("blocks", 0),
            pass_=c.get("pass", 0),
            fail=c.get("fail", 0),
            unreadable=c.get("unreadable", 0),
        ),
        "blocks": blocks,
        "sampled": sampled,
        "any_mean": any(x["used_mean"] for x in sampled),
        "rule_statuses": [f.status(s) for s in statuses],
        "rules": rules,
        "unreadable": summary.get("unreadable") or [],
    }


__all__ = ["Formatter", "block_context", "scene_statuses", "summary_context"]
