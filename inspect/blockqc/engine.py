"""Runs a rule pack over a delivery: measure each metric once, judge every rule, keep evidence."""

from __future__ import annotations

import datetime as dt
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from blockqc import __version__
from blockqc.delivery import Delivery, summary
from blockqc.inspector import BlockInput, Waiver
from blockqc.metrics import REGISTRY, Measurement, Table
from blockqc.rules.expr import ExpressionError, evaluate, resolve_params
from blockqc.rules.model import Pack, Rule, Threshold
from blockqc.verification import annotate, prepare

STATUSES = ("pass", "fail", "warn", "waived", "manual", "not_applicable", "error")
#: tables up to this many rows are kept in results.json for the report
MEASUREMENT_ROWS_KEPT = 5000


def jsonable(value: Any) -> Any:
    """Plain JSON values: numpy scalars unwrapped, NaN/NaT as null, timestamps as ISO dates."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    if isinstance(value, (pd.Timestamp, dt.date)):
        return value.isoformat()[:10] if not pd.isna(value) else None
    if value is None or value is pd.NA or value is pd.NaT:
        return None
    return value


def records(df: pd.DataFrame) -> list[dict[str, Any]]:
    return jsonable(df.to_dict("records"))


@dataclass
class Context:
    """One delivery under inspection: its names for expressions and the measurement cache."""

    delivery: Delivery
    constants: dict[str, Any]
    cache: dict[tuple[str, str], Measurement] = field(default_factory=dict)

    def measure(self, name: str, raw_params: Mapping[str, Any]) -> Measurement:
        spec = REGISTRY[name]
        params = resolve_params(spec.params, raw_params, self.constants)
        key = (name, json.dumps(params.model_dump(mode="json"), sort_keys=True))
        if key not in self.cache:
            self.cache[key] = spec.func(self.delivery, params, self.measure)
        return self.cache[key]


def names_for(delivery: Delivery, pack: Pack) -> dict[str, Any]:
    """What threshold expressions may name: the pack's constants and the delivery's GSDs."""
    gsd = delivery.manifest.gsd_m
    return {
        **pack.constants,
        "gsd": {k: v for k, v in (("pan", gsd.pan), ("ms", gsd.ms)) if v is not None},
    }


def bounds(th: Threshold, names: Mapping[str, Any]) -> tuple[float | None, float | None]:
    lo = evaluate(th.min, names) if th.min is not None else None
    hi = evaluate(th.max, names) if th.max is not None else None
    return lo, hi


def passes(values: pd.Series, th: Threshold, lo: float | None, hi: float | None) -> np.ndarray:
    """Vectorized judgement of values against a threshold; missing values never pass."""
    if th.equals is not None:
        return (values == th.equals).fillna(False).to_numpy(dtype=bool)
    if th.in_ is not None:
        return values.isin(th.in_).to_numpy(dtype=bool)
    v = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    ok = np.isfinite(v)
    with np.errstate(invalid="ignore"):
        if hi is not None:
            ok &= (v <= hi) if th.inclusive else (v < hi)
        if lo is not None:
            ok &= (v >= lo) if th.inclusive else (v > lo)
    return ok


def worst(values: pd.Series, ok: np.ndarray, th: Threshold, hi: float | None) -> Any:
    """The worst case of the values: the largest against an upper bound, else the smallest."""
    if values.empty:
        return None
    if th.equals is not None or th.in_ is not None:
        return values[~ok].iloc[0] if (~ok).any() else values.iloc[0]
    v = pd.to_numeric(values, errors="coerce")
    if v.isna().any():
        return None
    return v.max() if hi is not None else v.min()


def _severity_status(rule: Rule) -> str:
    return "fail" if rule.severity == "fail" else "warn"


def _threshold_fields(th: Threshold | None, lo: float | None, hi: float | None) -> dict[str, Any]:
    if th is None:
        return {"threshold": None, "comparison": None, "threshold_text": ""}
    if th.equals is not None:
        return {"threshold": th.equals, "comparison": "equals", "threshold_text": th.describe()}
    if th.in_ is not None:
        return {"threshold": th.in_, "comparison": "in", "threshold_text": th.describe()}
    if lo is not None and hi is not None:
        value: Any = [lo, hi]
        comp = "between" if th.inclusive else "strictly_between"
    elif hi is not None:
        value, comp = hi, "<=" if th.inclusive else "<"
    else:
        value, comp = lo, ">=" if th.inclusive else ">"
    return {"threshold": value, "comparison": comp, "threshold_text": th.describe(lo, hi)}


def _filter(df: pd.DataFrame, where: Mapping[str, Any]) -> pd.DataFrame:
    for col, val in where.items():
        if col not in df.columns:
            raise KeyError(
                f"'where' names column '{col}' which the metric does not give "
                f"(it gives: {', '.join(map(str, df.columns))})"
            )
        df = df[df[col] == val]
    return df


def _order(df: pd.DataFrame, stat: str | None, sort: str | None, hi: float | None) -> pd.DataFrame:
    col = stat if stat in df.columns and pd.api.types.is_numeric_dtype(df[stat]) else sort
    if col is None or col not in df.columns or not pd.api.types.is_numeric_dtype(df[col]):
        return df
    key = df[col].abs() if stat is None or col != stat else df[col]
    asc = stat == col and hi is None
    return (
        df.assign(_k=key.to_numpy())
        .sort_values("_k", ascending=asc, kind="stable")
        .drop(columns="_k")
    )


class Judge:
    """Judges one rule against its measurement, producing results in the contract's shape."""

    def __init__(self, rule: Rule, ctx: Context, block_input: BlockInput):
        self.rule, self.ctx = rule, ctx
        self.waiver: Waiver | None = block_input.waivers.get(rule.id)
        self.verdict = block_input.verdicts.get(rule.id)
        self.bind({})

    def bind(self, group: dict[str, Any]) -> None:
        """Select the threshold for a group (rules with `thresholds:` per group value)."""
        r = self.rule
        self.th = r.threshold
        if r.thresholds and group:
            key = next((str(v) for v in group.values() if str(v) in r.thresholds), None)
            if key is None:
                raise ValueError(
                    f"rule {r.id} gives no threshold for {group} "
                    f"(thresholds for: {', '.join(r.thresholds)})"
                )
            self.th = r.thresholds[key]
        self.lo, self.hi = bounds(self.th, self.ctx.constants) if self.th else (None, None)

    def result(
        self,
        group: dict[str, Any],
        status: str,
        value: Any,
        detail: dict[str, Any],
        evidence: list[dict[str, Any]] | None = None,
    ) -> dict[str, Any]:
        r = self.rule
        return {
            "rule": r.id,
            "title": r.title,
            "clause": r.clause,
            "quality_element": r.quality_element,
            "content": r.content,
            "inspection_content": r.inspection_content,
            "group": group,
            "status": status,
            "statistic": r.statistic,
            "value": jsonable(value),
            **jsonable(_threshold_fields(self.th, self.lo, self.hi)),
            "unit": r.unit,
            "severity": r.severity,
            "detail": jsonable(detail),
            "evidence": jsonable(evidence or []),
        }

    def run(self) -> list[dict[str, Any]]:
        r = self.rule
        if r.manual:
            return [self._manual()]
        m = self.ctx.measure(r.metric, r.params)
        if m.not_applicable:
            return [self.result({}, "not_applicable", None, {"reason": m.not_applicable})]
        table = m.tables[r.scope]
        df = _filter(table.df, r.where)
        group_cols = [c for c in table.group if c not in r.where]
        out = []
        fixed = {k: v for k, v in r.where.items() if k in table.group}
        for group, sub in self._groups(df, table, group_cols):
            group = {**fixed, **group}
            self.bind(group)
            if sub.empty:
                out.append(
                    self.result(
                        group, "not_applicable", None, {"reason": "nothing measured for this group"}
                    )
                )
            elif table.keys:
                out.append(self._units(group, sub, table))
            else:
                out.extend(self._rows(group, sub, m))
        return out

    def _groups(self, df: pd.DataFrame, table: Table, cols: list[str]):
        if not cols:
            yield {}, df
            return
        seen = []
        for vals, sub in df.groupby(cols, sort=False):
            vals = vals if isinstance(vals, tuple) else (vals,)
            seen.append(dict(zip(cols, vals, strict=True)))
            yield seen[-1], sub
        for g in table.groups or []:
            g = {k: v for k, v in g.items() if k in cols}
            if g not in seen and all(self.rule.where.get(k, v) == v for k, v in g.items()):
                seen.append(g)
                yield g, df.iloc[0:0]

    def _waived(self, units: pd.DataFrame, keys: list[str]) -> tuple[np.ndarray, pd.Series]:
        """Units the inspector waived, and their labels ("A", "A/B", ...)."""
        if self.waiver is None or not self.rule.waivable or self.waiver.whole_rule:
            return np.zeros(len(units), dtype=bool), pd.Series([], dtype=object)
        labels = units[keys[0]].astype(str)
        for k in keys[1:]:
            labels = labels + "/" + units[k].astype(str)
        return labels.isin(self.waiver.labels()).to_numpy(dtype=bool), labels

    def _units(self, group: dict[str, Any], sub: pd.DataFrame, table: Table) -> dict[str, Any]:
        """Per scene/pair/point: value = worst case, evidence = the offending units."""
        r = self.rule
        exempt = sub["exempt"].to_numpy(dtype=bool) if "exempt" in sub else np.zeros(len(sub), bool)
        judged = sub[~exempt]
        ok = passes(judged[r.statistic], self.th, self.lo, self.hi)
        waivable, labels = self._waived(judged, table.keys)
        waived = ~ok & waivable
        failing = ~ok & ~waived
        detail: dict[str, Any] = {"n_units": int(len(sub)), "n_offending": int((~ok).sum())}
        if exempt.any():
            ex = sub[exempt]
            detail["exempt"] = records(
                ex[table.keys + (["exempt_reason"] if "exempt_reason" in ex else [])]
            )
        if waived.any():
            detail["waived"] = labels[waived].tolist()
            detail["waiver_reason"] = self.waiver.reason
        detail.update(self._waiver_note())
        if judged.empty:
            detail["reason"] = "every unit is exempt"
            return self.result(group, "not_applicable", None, detail)
        status = _severity_status(r) if failing.any() else "waived" if waived.any() else "pass"
        value = worst(judged[r.statistic], ok, self.th, self.hi)
        evidence = []
        if status != "pass":
            bad = _order(judged[~ok], r.statistic, table.sort, self.hi)
            bad = _filter(bad, r.evidence_where)
            evidence = records(
                bad.head(r.evidence_limit).drop(
                    columns=[c for c in ("exempt", "exempt_reason") if c in bad], errors="ignore"
                )
            )
            if len(bad) > r.evidence_limit:
                detail["evidence_truncated"] = int(len(bad) - r.evidence_limit)
        return self.result(group, status, value, detail, evidence)

    def _rows(self, group: dict[str, Any], sub: pd.DataFrame, m: Measurement) -> list[dict]:
        """Block- or group-level rows: one result per row, evidence from `evidence_from`."""
        r = self.rule
        out = []
        ok_all = passes(sub[r.statistic], self.th, self.lo, self.hi)
        for (_, row), ok in zip(sub.iterrows(), ok_all, strict=True):  # one row per group
            detail = {k: v for k, v in row.items() if k not in group and k != r.statistic}
            detail.update(self._waiver_note())
            status = "pass" if ok else _severity_status(r)
            if not ok and self.waiver is not None and self.rule.waivable and self.waiver.whole_rule:
                status = "waived"
                detail["waiver_reason"] = self.waiver.reason
            evidence: list[dict[str, Any]] = []
            if status != "pass" and r.evidence_from:
                evidence, more = self._evidence(m.tables[r.evidence_from], group)
                if more:
                    detail["evidence_truncated"] = more
            out.append(self.result(group, status, row[r.statistic], detail, evidence))
        return out

    def _evidence(self, table: Table, group: dict[str, Any]) -> tuple[list[dict], int]:
        r = self.rule
        df = table.df
        for col, val in group.items():
            if col in df.columns:
                df = df[df[col] == val]
        df = _filter(
            df, {**{k: v for k, v in r.where.items() if k in df.columns}, **r.evidence_where}
        )
        if "exempt" in df.columns:
            df = df[~df["exempt"].to_numpy(dtype=bool)]
        if r.statistic in df.columns:
            df = df[~passes(df[r.statistic], self.th, self.lo, self.hi)]
        df = _order(df, r.statistic, table.sort, self.hi)
        more = max(0, len(df) - r.evidence_limit)
        return records(df.head(r.evidence_limit)), more

    def _waiver_note(self) -> dict[str, Any]:
        if self.waiver is not None and not self.rule.waivable:
            return {"waiver_ignored": f"rule {self.rule.id} is not waivable"}
        return {}

    def _manual(self) -> dict[str, Any]:
        if self.verdict is None:
            return self.result({}, "manual", None, {"reason": "awaiting the inspector's verdict"})
        status = "pass" if self.verdict.status == "pass" else _severity_status(self.rule)
        return self.result(
            {}, status, self.verdict.status, {"note": self.verdict.note, "decided_by": "inspector"}
        )


def inspect_delivery(
    delivery: Delivery,
    pack: Pack,
    block_input: BlockInput | None = None,
    inspector: str | None = None,
) -> dict[str, Any]:
    """Judge every rule of the pack on one delivery; the results document of contract v1."""
    block_input = block_input or BlockInput()
    process_data = prepare(delivery)  # contract v1.1: residuals/overlaps from the geometry
    ctx = Context(delivery, names_for(delivery, pack))
    results: list[dict[str, Any]] = []
    for rule in pack.rules:
        try:
            results.extend(Judge(rule, ctx, block_input).run())
        except (ExpressionError, KeyError, ValueError) as exc:
            judge = Judge.__new__(Judge)
            judge.rule, judge.th, judge.lo, judge.hi = rule, None, None, None
            results.append(judge.result({}, "error", None, {"reason": str(exc).strip("'\"")}))
    annotate(results, {r.id: r.metric for r in pack.rules if not r.manual}, process_data)
    counts = {s: 0 for s in STATUSES}
    for res in results:
        counts[res["status"]] += 1
    verdict = "error" if counts["error"] else "fail" if counts["fail"] else "pass"
    pending = sorted({r["rule"] for r in results if r["status"] == "manual"})
    return {
        "block_id": delivery.block_id,
        "sensor": delivery.manifest.sensor,
        "rule_pack": pack.name,
        "rule_pack_version": pack.version,
        "rule_pack_files": pack.chain,
        "blockqc_version": __version__,
        "generated_at": dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "inspector": inspector,
        "delivery": str(delivery.path),
        "verdict": verdict,
        "complete": not pending,
        "pending_manual": pending,
        "counts": counts,
        "summary": summary(delivery),
        "process_data": jsonable(process_data),
        "results": results,
        "measurements": _measurements(ctx, pack, results),
    }


def _offending_points(ctx: Context, pack: Pack, results: list[dict]) -> dict[str, dict]:
    """For failing per-scene rules, the positions behind the offending scenes (for maps)."""
    out: dict[str, dict] = {}
    for res in results:
        if res["status"] not in ("fail", "warn", "waived") or not res["evidence"]:
            continue
        rule = pack.rule(res["rule"])
        if rule.manual:
            continue
        m = ctx.measure(rule.metric, rule.params)
        ids = [e["scene_id"] for e in res["evidence"] if "scene_id" in e]
        if m.unit_points is not None and ids:
            out.setdefault(rule.metric, {}).update(m.unit_points(ids))
    return out


def _measurements(ctx: Context, pack: Pack, results: list[dict]) -> dict[str, Any]:
    """Small tables and details of every metric measured, for reports and plots."""
    d = ctx.delivery
    out: dict[str, Any] = {
        "scenes": records(
            d.scenes[
                [
                    c
                    for c in (
                        "scene_id",
                        "band",
                        "acquired",
                        "lines",
                        "samples",
                        "footprint_wkt",
                        "water_fraction",
                    )
                    if c in d.scenes
                ]
            ]
        ),
    }
    for (name, _), m in ctx.cache.items():
        if m.not_applicable or name in out:
            continue
        entry: dict[str, Any] = {"detail": jsonable(m.detail)} if m.detail else {}
        for scope, table in m.tables.items():
            if len(table.df) <= MEASUREMENT_ROWS_KEPT:
                entry[scope] = records(table.df)
        out[name] = entry
    for name, points in _offending_points(ctx, pack, results).items():
        out.setdefault(name, {})["failing_scene_points"] = jsonable(points)
    return out
