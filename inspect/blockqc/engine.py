"""Runs a rule pack over a delivery: measure each metric once, judge every rule, keep evidence."""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from blockqc import __version__
from blockqc.delivery import Delivery, summary
from blockqc.errors import Problem
from blockqc.geometry_inputs import ONE_GROUND_POINT, ground_disagreements
from blockqc.inspector import BlockInput, Waiver
from blockqc.layout import apart_scenes
from blockqc.metrics import REGISTRY, Measurement, Table
from blockqc.metrics.documents import REQUIRED as REQUIRED_DOCUMENTS
from blockqc.outputs import jsonable, records
from blockqc.results import BlockResults, MeasurementRecord, RuleResult, tally
from blockqc.rules.expr import ExpressionError, evaluate, resolve_params
from blockqc.rules.model import Pack, Rule, Threshold, selected, within
from blockqc.schema import did_you_mean, key_labels
from blockqc.textio import located
from blockqc.verification import annotate, annotated_keys, prepare

#: tables up to this many rows are kept in results.json for the report
MEASUREMENT_ROWS_KEPT = 5000


@dataclass
class Context:
    """One delivery under inspection: its names for expressions and the measurement cache."""

    delivery: Delivery
    constants: dict[str, Any]
    cache: dict[tuple[str, str], Measurement] = field(default_factory=dict)

    def cache_key(self, name: str, raw_params: Mapping[str, Any]) -> tuple[str, str]:
        params = resolve_params(REGISTRY[name].params, raw_params, self.constants)
        return name, json.dumps(params.model_dump(mode="json"), sort_keys=True)

    def measure(self, name: str, raw_params: Mapping[str, Any]) -> Measurement:
        key = self.cache_key(name, raw_params)
        if key not in self.cache:
            spec = REGISTRY[name]
            params = spec.params.model_validate(json.loads(key[1]))
            self.cache[key] = spec.func(self.delivery, params, self.measure)
        return self.cache[key]

    def measurement_keys(self) -> dict[tuple[str, str], str]:
        """A readable key per measurement: the metric's name, numbered when measured twice."""
        names = [name for name, _ in self.cache]
        seen: dict[str, int] = {}
        out = {}
        for key in self.cache:
            n = seen[key[0]] = seen.get(key[0], 0) + 1
            out[key] = key[0] if names.count(key[0]) == 1 else f"{key[0]}#{n}"
        return out


class MissingGSD(ExpressionError):
    """A band's GSD an expression names (gsd.ms) that block.yaml does not give."""

    def __init__(self, band: str) -> None:
        self.band = band
        super().__init__(
            f"block.yaml gives no gsd_m.{band}, which this rule's threshold (gsd.{band}) needs: "
            f"add the {band.upper()} GSD in metres to gsd_m"
        )


class _GSDs(dict):
    """The delivery's GSD per band; a band block.yaml does not give is named as such when a
    threshold needs it (not as an unknown constant)."""

    BANDS = ("pan", "ms")

    def __contains__(self, band: object) -> bool:
        return band in self.BANDS or super().__contains__(band)

    def __missing__(self, band: str) -> float:
        raise MissingGSD(band)


def names_for(delivery: Delivery, pack: Pack) -> dict[str, Any]:
    """What threshold expressions may name: the pack's constants and the delivery's GSDs."""
    gsd = delivery.manifest.gsd_m
    given = {k: getattr(gsd, k) for k in _GSDs.BANDS if getattr(gsd, k) is not None}
    return {**pack.constants, "gsd": _GSDs(given)}


def bounds(th: Threshold, names: Mapping[str, Any]) -> tuple[float | None, float | None]:
    lo = evaluate(th.min, names) if th.min is not None else None
    hi = evaluate(th.max, names) if th.max is not None else None
    return lo, hi


def passes(values: pd.Series, th: Threshold, lo: float | None, hi: float | None) -> np.ndarray:
    """Vectorized judgement of values against a threshold (bounds by `rules.model.within`);
    missing values never pass."""
    if th.equals is not None:
        return (values == th.equals).fillna(False).to_numpy(dtype=bool)
    if th.in_ is not None:
        return values.isin(th.in_).to_numpy(dtype=bool)
    v = _numbers(values)
    with np.errstate(invalid="ignore"):
        return np.isfinite(v) & within(v, lo, hi, th.inclusive)


def worst(values: pd.Series, ok: np.ndarray, th: Threshold, lo: Any, hi: Any) -> Any:
    """The worst case of the values: the one farthest beyond its bounds (nearest to them when
    all pass): the largest against an upper bound, the smallest against a lower one. Units
    without a value (a scene holding no tie point has no median) are left to the evidence:
    the worst of the others is the value, None when none has one."""
    if values.empty:
        return None
    if th.equals is not None or th.in_ is not None:
        return values[~ok].iloc[0] if (~ok).any() else values.iloc[0]
    v = values.to_numpy() if _floats(values) else pd.to_numeric(values, errors="coerce")
    missing = pd.isna(v)
    if missing.all():
        return None
    if missing.any():  # (a float column without missing values is not copied)
        v = np.asarray(v)[~missing]
    if hi is not None and lo is not None:
        at = int(np.argmax(_beyond(np.asarray(v, dtype=float), lo, hi)))
        return np.asarray(v)[at]
    return v.max() if hi is not None else v.min()


def _beyond(v: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """How far each value lies beyond [lo, hi] (negative inside: its margin to the nearer)."""
    return np.maximum(lo - v, v - hi)


def _floats(values: pd.Series) -> bool:
    return pd.api.types.is_float_dtype(values.dtype) and isinstance(values.dtype, np.dtype)


def _numbers(values: pd.Series) -> np.ndarray:
    """The values as floats (not a number: NaN); a float column is not copied."""
    if _floats(values):
        return values.to_numpy()
    return pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)


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
        _same_kind(df[col], col, val)
        df = df[df[col] == val]
    return df


def _same_kind(column: pd.Series, name: str, value: Any) -> None:
    """A filter's value of the column's kind: text against a true/false or number column
    (gross: "no") would select nothing, silently; refused (ValueError: the rule in error)."""
    if not isinstance(value, str) or not pd.api.types.is_numeric_dtype(column.dtype):
        return  # (numeric covers true/false; 0 and 1 select them as pandas compares)
    if pd.api.types.is_bool_dtype(column.dtype):
        kind = "true/false: write true or false, unquoted"
    else:
        kind = "numbers: write a number, unquoted"
    raise ValueError(f"where.{name}: {value!r} selects nothing: the column {name} holds {kind}")


def _order(df: pd.DataFrame, stat: str | None, sort: str | None, lo: Any, hi: Any) -> pd.DataFrame:
    """Worst first: by the statistic against its bounds (by `sort`, in magnitude, else)."""
    col = stat if stat in df.columns and pd.api.types.is_numeric_dtype(df[stat]) else sort
    if col is None or col not in df.columns or not pd.api.types.is_numeric_dtype(df[col]):
        return df
    key = df[col].abs() if stat is None or col != stat else df[col]
    if stat == col and lo is not None and hi is not None:
        key = pd.Series(_beyond(_numbers(df[col]), lo, hi), index=df.index)
    asc = stat == col and hi is None
    return (
        df.assign(_k=key.to_numpy())
        .sort_values("_k", ascending=asc, kind="stable")
        .drop(columns="_k")
    )


#: the reason of a rule, or a group of it, that its metric measured nothing for
NOTHING = "nothing measured for this group"


#: the detail keys of a per-unit result (scenes, pairs, points) besides those of any result
UNIT_DETAIL = ("n_units", "n_offending", "exempt", "waived")
#: the detail keys any automatic result may have
ANY_DETAIL = ("reason", "waiver_reason", "waiver_ignored", "evidence_truncated")
#: the detail keys of a manual rule's result (the inspector's verdict)
MANUAL_DETAIL = ("reason", "note", "decided_by", "condition")


def detail_keys(rule: Rule) -> tuple[str, ...]:
    """Every key the detail of a result of the rule may hold (what Judge writes): per unit its
    counts, per row of a block or group the row's other columns; the statistic is the value."""
    if rule.manual:
        return MANUAL_DETAIL
    scope = REGISTRY[rule.metric or ""].scopes[rule.scope]
    own = scope.all_columns() if not scope.keys else UNIT_DETAIL
    own = tuple(
        c
        for c in own
        if c not in scope.groups and c != rule.statistic and c not in scope.notes.values()
    )
    note = ("note",) if rule.statistic in scope.notes else ()
    return tuple(dict.fromkeys((*own, *note, *ANY_DETAIL, *annotated_keys(rule.metric or ""))))


class Judge:
    """Judges one rule against its measurement, producing results in the contract's shape."""

    def __init__(self, rule: Rule, ctx: Context, block_input: BlockInput, elements: dict[str, str]):
        self.rule, self.ctx, self.elements = rule, ctx, elements
        self.waiver: Waiver | None = block_input.waivers.get(rule.id)
        self.verdict = block_input.verdicts.get(rule.id)
        self.cache_key: tuple[str, str] | None = None
        self.th, self.lo, self.hi = None, None, None

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
    ) -> RuleResult:
        r = self.rule
        contents = [c for c, where in r.content.items() if _in_group(group, where)]
        element = self.elements.get(contents[0], "") if contents else r.quality_element
        return RuleResult(
            rule=r.id,
            title=r.title,
            title_zh=r.title_zh,
            clause=r.clause,
            description=r.description.strip(),
            description_zh=r.description_zh.strip(),
            quality_element=element,
            content=contents,
            inspection=r.inspection,
            figures=list(r.figures),
            group=jsonable(group),
            status=status,
            statistic=r.statistic,
            value=jsonable(value),
            **jsonable(_threshold_fields(self.th, self.lo, self.hi)),
            unit=r.unit,
            severity=r.severity,
            measurement="|".join(self.cache_key) if self.cache_key else None,
            detail=jsonable(detail),
            evidence=jsonable(evidence or []),
        )

    def error(self, reason: str) -> RuleResult:
        """The rule could not be judged on this delivery (e.g. a threshold for a missing group)."""
        self.th, self.lo, self.hi = None, None, None
        return self.result({}, "error", None, {"reason": reason})

    def run(self) -> list[RuleResult]:
        r = self.rule
        if r.manual:
            return [self._manual()]
        self.cache_key = self.ctx.cache_key(r.metric, r.params)
        m = self.ctx.measure(r.metric, r.params)
        if m.not_applicable:  # judged on nothing: its threshold (which may name an absent
            # delivery value, e.g. gsd.ms) is not evaluated
            return [self.result({}, "not_applicable", None, {"reason": m.not_applicable})]
        self.bind({})
        table = m.tables[r.scope]
        df = _filter(table.complete(table.df, r.where), r.where)
        group_cols = [c for c in table.group if c not in r.where]
        out = []
        fixed = {k: v for k, v in r.where.items() if k in table.group}
        for group, sub in self._groups(df, table, group_cols):
            group = {**fixed, **group}
            self.bind(group)
            if sub.empty:
                why = table.empty_reason(group) or NOTHING
                out.append(self.result(group, "not_applicable", None, {"reason": why}))
            elif table.keys:
                out.append(self._units(group, sub, table))
            else:
                out.extend(self._rows(group, sub, m))
        if not out:  # nothing selected, no group expected: said, never a rule gone unsaid
            self.bind(fixed)
            out.append(self.result(fixed, "not_applicable", None, {"reason": NOTHING}))
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

    def _waived(self, units: pd.DataFrame, table: Table) -> tuple[np.ndarray, pd.Series]:
        """Units the inspector waived, and their labels ("A", "A/B", ...)."""
        if self.waiver is None or not self.rule.waivable:
            return np.zeros(len(units), dtype=bool), pd.Series([], dtype=object)
        units = table.complete(units, table.keys)
        labels = key_labels(units, table.keys)
        if self.waiver.whole_rule:  # no units named: the waiver covers every unit
            return np.ones(len(units), dtype=bool), labels
        return self.waiver.covers(units, table.keys), labels

    def _units(self, group: dict[str, Any], sub: pd.DataFrame, table: Table) -> RuleResult:
        """Per scene/pair/point: value = worst case, evidence = the offending units."""
        r = self.rule
        exempt = sub["exempt"].to_numpy(dtype=bool) if "exempt" in sub else np.zeros(len(sub), bool)
        judged = sub[~exempt] if exempt.any() else sub  # (millions of observations: no copy)
        ok = passes(judged[r.statistic], self.th, self.lo, self.hi)
        waivable, labels = self._waived(judged, table)
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
        sel = _deciding(failing, waived)
        units = judged if sel is None else judged[sel]
        value = worst(units[r.statistic], ok if sel is None else ok[sel], self.th, self.lo, self.hi)
        evidence = []
        if status != "pass":
            bad = _order(units, r.statistic, table.sort, self.lo, self.hi)
            bad = _filter(table.complete(bad, r.evidence_where), r.evidence_where)
            shown = table.complete(bad.head(r.evidence_limit))
            evidence = records(
                shown.drop(
                    columns=[c for c in ("exempt", "exempt_reason") if c in bad], errors="ignore"
                )
            )
            if len(bad) > r.evidence_limit:
                detail["evidence_truncated"] = int(len(bad) - r.evidence_limit)
        return self.result(group, status, value, detail, evidence)

    def _rows(self, group: dict[str, Any], sub: pd.DataFrame, m: Measurement) -> list[RuleResult]:
        """Block- or group-level rows: one result per row, evidence from `evidence_from`."""
        r = self.rule
        out = []
        notes = REGISTRY[r.metric or ""].scopes[r.scope].notes
        ok_all = passes(sub[r.statistic], self.th, self.lo, self.hi)
        # one row per group, each value of its column's type (iterrows made a block table's
        # counts floats: TP-1's n 1378.0 beside its median)
        for row, ok in zip(records(sub), ok_all, strict=True):
            detail = {
                k: v
                for k, v in row.items()
                if k not in group and k != r.statistic and k not in notes.values()
            }
            if row.get(notes.get(r.statistic, "")):
                detail["note"] = row[notes[r.statistic]]
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
        given = {*df.columns, *table.lazy}
        where = {**{k: v for k, v in r.where.items() if k in given}, **r.evidence_where}
        df = _filter(table.complete(df, where), where)
        if "exempt" in df.columns:
            df = df[~df["exempt"].to_numpy(dtype=bool)]
        if r.statistic in df.columns:  # the units beyond the threshold; not those without a
            # value (a scene holding no tie point has no median: no part in the block's figure)
            values = df[r.statistic]
            df = df[~passes(values, self.th, self.lo, self.hi) & values.notna().to_numpy()]
        df = _order(df, r.statistic, table.sort, self.lo, self.hi)
        more = max(0, len(df) - r.evidence_limit)
        return records(table.complete(df.head(r.evidence_limit))), more

    def _waiver_note(self) -> dict[str, Any]:
        if self.waiver is not None and not self.rule.waivable:
            return {"waiver_ignored": f"rule {self.rule.id} is not waivable"}
        return {}

    def _manual(self) -> RuleResult:
        if self.verdict is None:
            return self.result({}, "manual", None, {"reason": "awaiting the inspector's verdict"})
        v = self.verdict.status  # readings of the statuses: blockqc.inspector
        status = {"pass": "pass", "conditional_pass": "pass", "rework": "fail"}.get(
            v, _severity_status(self.rule)
        )
        detail = {"note": self.verdict.note, "decided_by": "inspector"}
        if v == "conditional_pass":
            detail["condition"] = self.verdict.note
        return self.result({}, status, v, detail)


def _deciding(failing: np.ndarray, waived: np.ndarray) -> np.ndarray | None:
    """The units a per-unit result's value and evidence come from: the failing ones when any
    fail (a waived unit, listed in the detail as waived, never supplies the figure of a failure);
    when every offending unit is waived (status waived), the waived ones, the worst of them the
    value; when none offends, every unit (None: the value is the worst that passes)."""
    if failing.any():
        return failing
    return waived if waived.any() else None


def _in_group(group: Mapping[str, Any], where: Mapping[str, Any]) -> bool:
    """Whether a result's group is one a content selects (a value or a list of values); a
    result of no group (not applicable, an error) belongs to every content of its rule."""
    return all(k not in group or str(group[k]) in selected(v) for k, v in where.items())


def judge_all(ctx: Context, pack: Pack, block_input: BlockInput) -> list[RuleResult]:
    """Every rule of the pack judged; a rule that cannot be judged is an error result."""
    elements = pack.content_ids()
    results: list[RuleResult] = []
    for rule in pack.rules:
        judge = Judge(rule, ctx, block_input, elements)
        try:
            results.extend(judge.run())
        except (ExpressionError, KeyError, ValueError) as exc:
            results.append(judge.error(str(exc).strip("'\"")))
    keys = ctx.measurement_keys()
    by_cache = {"|".join(k): v for k, v in keys.items()}
    for res in results:
        res.measurement = by_cache.get(res.measurement or "")
    return results


def reported_figure_names(pack: Pack) -> set[str] | None:
    """The figures of block.yaml's `reported` that the pack's rules recompute (§DOC-2); None
    when no rule reads them."""
    from blockqc.rules.loader import DELIVERY_NAMES

    names = {**pack.constants, **DELIVERY_NAMES}
    rules = [r for r in pack.rules if not r.manual and r.metric == "reported_figures"]
    if not rules:
        return None
    spec = REGISTRY["reported_figures"]
    return {f for r in rules for f in resolve_params(spec.params, r.params, names).figures}


def tie_point_columns(pack: Pack) -> set[str] | None:
    """The tie_points columns to read for this pack: every column (None) unless the pack says
    `columns: used`; then those its automatic rules' metrics read, and the scene id (checked
    against the scenes)."""
    if pack.columns != "used":
        return None
    from blockqc.rules.loader import DELIVERY_NAMES

    names = {**pack.constants, **DELIVERY_NAMES}
    out = {"scene_id"}
    for rule in pack.rules:
        if rule.manual or rule.metric not in REGISTRY:
            continue
        spec = REGISTRY[rule.metric]
        by_params = callable(spec.tie_points)  # the parameters are read only when they matter
        params = resolve_params(spec.params, rule.params, names) if by_params else None
        cols = spec.tie_point_columns(params)
        if cols is None:
            return None
        out |= cols
    return out


def inspect_delivery(
    delivery: Delivery,
    pack: Pack,
    block_input: BlockInput | None = None,
    inspector: str | None = None,
) -> BlockResults:
    """Judge every rule of the pack on one delivery; the results document of contract v1."""
    process_data = prepare(delivery)  # contract v1.1: residuals/overlaps from the geometry
    ctx = Context(delivery, names_for(delivery, pack))
    results = judge_all(ctx, pack, block_input or BlockInput())
    annotate(results, {r.id: r.metric for r in pack.rules if not r.manual}, process_data)
    counts, verdict = tally(r.status for r in results)
    pending = sorted({r.rule for r in results if r.status == "manual"})
    return BlockResults(
        block_id=delivery.block_id,
        sensor=delivery.manifest.sensor,
        rule_pack=pack.name,
        rule_pack_version=pack.version,
        rule_pack_files=pack.chain,
        blockqc_version=__version__,
        generated_at=dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        inspector=inspector,
        delivery=str(delivery.path),
        verdict=verdict,
        complete=not pending,
        pending_manual=pending,
        counts=counts,
        summary=summary(delivery),
        not_read=delivery.not_read,
        input_warnings=input_warnings(delivery),
        process_data=jsonable(process_data),
        elements=pack.elements,
        scenes=_scenes(delivery),
        results=results,
        measurements=_measurements(ctx, pack, results),
    )


SCENES_FILE = "scenes.csv"  # named in a warning when the delivery's scenes came from no file
#: why a tie point given two ground points is said, not refused, by the inspection
GROUND_POINTS_DIFFER = (
    f"{ONE_GROUND_POINT}; judged as given (RC-1 with ground: delivered back-projects each row's "
    "own ground point)"
)


def input_warnings(d: Delivery) -> list[str]:
    """What the delivery gives that is judged as given but said: ground columns a table stores
    coarser than float64 (`precision.stored_resolution`), scenes whose footprints lie
    apart from the block's (`layout.apart_scenes`), the tie points whose rows give their point
    different ground points (`blockqc adjust` refuses them, by the same check), the scenes
    without an RPC file nor observations (`geometry_inputs.scenes_without_rpc`), the document
    kinds that look like a kind of the contract misspelt (`misspelt_document_kinds`)."""
    found = d.read_warnings + apart_scenes(d.scenes, d.files.get("scenes", SCENES_FILE))
    if d.geometry is not None:
        found += d.geometry.warnings
    file = d.files.get("tie_points")
    if file is not None:
        found += ground_disagreements(file, d.tie_points, GROUND_POINTS_DIFFER)
    found += misspelt_document_kinds(d)  # located by their line already
    return [str(p) for p in located(found)]


def misspelt_document_kinds(d: Delivery) -> list[Problem]:
    """Document kinds of block.yaml that are none of the contract's, but one it does not
    give in other case or misspelt (Technical_Design for technical_design). Other kinds are
    allowed, each checked as given: DOC-1 then fails on the kind meant, as not declared."""
    declared = d.manifest.documents
    hint = did_you_mean(k for k in REQUIRED_DOCUMENTS if k not in declared)
    return [
        Problem(
            at.file, f"{at.message}: not a document kind of the contract{hint(k)}", line=at.line
        )
        for k, at in d.manifest.documents_at.items()
        if k not in REQUIRED_DOCUMENTS and hint(k)
    ]


SCENE_COLUMNS = ("scene_id", "band", "acquired", "lines", "samples", "footprint_wkt")


def _scenes(d: Delivery) -> list[dict[str, Any]]:
    cols = [c for c in (*SCENE_COLUMNS, "water_fraction") if c in d.scenes]
    return records(d.scenes[cols])


def _offending_points(ctx: Context, pack: Pack, res: RuleResult) -> dict[str, Any]:
    """For a failing per-scene rule, the positions behind the offending scenes (for maps)."""
    if res.status not in ("fail", "warn", "waived") or not res.evidence:
        return {}
    rule = pack.rule(res.rule)
    if rule.manual:
        return {}
    m = ctx.measure(rule.metric, rule.params)
    ids = [e["scene_id"] for e in res.evidence if "scene_id" in e]
    return m.unit_points(ids) if m.unit_points is not None and ids else {}


def _measurements(ctx: Context, pack: Pack, results: list[RuleResult]) -> list[MeasurementRecord]:
    """Every measurement taken, keyed by metric and parameters: details and small tables."""
    out = []
    for cache_key, key in ctx.measurement_keys().items():
        m = ctx.cache[cache_key]
        if m.not_applicable:
            continue
        points: dict[str, Any] = {}
        for res in results:
            if res.measurement == key:
                points.update(_offending_points(ctx, pack, res))
        out.append(
            MeasurementRecord(
                key=key,
                metric=cache_key[0],
                params=json.loads(cache_key[1]),
                detail=jsonable(m.detail),
                tables={
                    scope: records(t.complete(t.df))
                    for scope, t in m.tables.items()
                    if len(t.df) <= MEASUREMENT_ROWS_KEPT
                },
                rows={scope: len(t.df) for scope, t in m.tables.items()},
                failing_scene_points=jsonable(points) or None,
            )
        )
    return out
