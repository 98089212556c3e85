"""Checking rule packs: every problem of a pack at once, each with its file and line.

The loader calls the checks of one rule and of the constants while it reads a pack (a pack with
a problem is refused whole); `lint` adds what only matters when a pack is written: that every
rule ships a passing and a failing case beside its pack (`blockqc rules lint`, the tests).
"""

from __future__ import annotations

import ast
import difflib
import math
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from blockqc.errors import Problem, RuleError
from blockqc.metrics import REGISTRY, MetricSpec, Scope
from blockqc.rules.expr import (
    MAX_MAGNITUDE,
    EvaluationError,
    ExpressionError,
    evaluate,
    flatten,
    resolve_params,
    syntax_tree,
)
from blockqc.rules.model import ElementDef, Pack, Rule, selected
from blockqc.rules.text import TEXT_FIELDS, placeholders
from blockqc.yamlio import line_of, worded

LineFn = Callable[..., int | None]
_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """' (did you mean X?)' when a known name is close to `name` (case-insensitive), else ''."""
    known = list(known)
    by_upper = {k.upper(): k for k in known}
    if name.upper() in by_upper and by_upper[name.upper()] != name:
        return f" (did you mean {by_upper[name.upper()]}?)"
    close = difflib.get_close_matches(name.upper(), list(by_upper), n=1, cutoff=0.6)
    return f" (did you mean {by_upper[close[0]]}?)" if close else ""


# ------------------------------------------------------------------------------ constants
@dataclass(frozen=True)
class ConstantSite:
    """A constant a pack file introduces (not inherited): its dotted name and where it stands."""

    name: str
    file: str
    line: int | None
    parent_names: tuple[str, ...]  # the constants inherited, for "did you mean"


def _is_number(v: Any) -> bool:
    """A finite number of the magnitude expressions compute with (MAX_MAGNITUDE)."""
    return (
        isinstance(v, (int, float))
        and not isinstance(v, bool)
        and math.isfinite(v)
        and abs(v) <= MAX_MAGNITUDE
    )


def _not_a_constant(value: Any) -> str:
    """What a constant's value is that no constant may be."""
    if isinstance(value, list):
        bad = next((v for v in value if not _is_number(v)), None)
        return "an empty list" if not value else f"a list holding {_not_a_constant(bad)}"
    if isinstance(value, bool):
        return f"true/false ({str(value).lower()})"
    if isinstance(value, float) and not math.isfinite(value):
        return "a non-finite number"
    if isinstance(value, (int, float)):
        return f"{value:g}, beyond ±{MAX_MAGNITUDE:g} (the most an expression computes with)"
    return repr(value)


def check_constants(
    consts: Mapping[str, Any], data: Any, path: Path, reserved: Mapping[str, Any] | None = None
) -> list[Problem]:
    """Each constant is a finite number or a list of them, under a plain name (at its own line)
    that is not one of the `reserved` names, the values the delivery provides (gsd)."""
    out: list[Problem] = []
    reserved = reserved or {}

    def walk(node: Mapping[str, Any], loc: tuple[str, ...]) -> None:
        for key, value in node.items():
            here = (*loc, key)
            where = ".".join(here)
            line = line_of(data, ("constants", *here))
            if not isinstance(key, str) or not _valid_name(key):
                out.append(Problem(str(path), f"constants.{where}: not a plain name", line=line))
            elif not loc and key in reserved:
                out.append(Problem(str(path), _reserved(key, reserved[key]), line=line))
            elif isinstance(value, Mapping):
                walk(value, here)
            elif isinstance(value, list) and value and all(_is_number(v) for v in value):
                continue
            elif not _is_number(value):
                got = _not_a_constant(value)
                out.append(
                    Problem(
                        str(path),
                        f"constants.{where}: expected a finite number or a list of finite "
                        f"numbers, got {got}",
                        line=line,
                    )
                )

    walk(consts, ())
    return out


def _reserved(key: str, provided: Any) -> str:
    names = list(flatten({key: provided})) if isinstance(provided, Mapping) else [key]
    return (
        f"constants.{key}: the name {key} is reserved for the values the delivery provides "
        f"({', '.join(names)}, read from block.yaml), which expressions read in place of any "
        "constant: give the constant another name"
    )


def without_reserved(consts: Mapping[str, Any], reserved: Mapping[str, Any]) -> dict[str, Any]:
    """The constants less those under a reserved name (reported by check_constants)."""
    return {k: v for k, v in consts.items() if k not in reserved}


def stand_in_invalid(consts: Mapping[str, Any], inherited: Mapping[str, Any]) -> dict[str, Any]:
    """The constants with each invalid value replaced by the inherited one (or 1.0), and each
    one given another shape than it inherits replaced by the inherited one, so that such a
    constant is reported once, where it is written, and not again at every use."""
    out: dict[str, Any] = {}
    for key, value in consts.items():
        before = inherited.get(key) if isinstance(inherited, Mapping) else None
        if before is not None and _valid(value) and _shape(value) != _shape(before):
            out[key] = before
        elif isinstance(value, Mapping):
            out[key] = stand_in_invalid(value, before if isinstance(before, Mapping) else {})
        elif _valid(value):
            out[key] = value
        else:
            out[key] = before if before is not None and not isinstance(before, Mapping) else 1.0
    return out


def reshaped_constants(
    consts: Mapping[str, Any], inherited: Mapping[str, Any], data: Any, path: Path
) -> list[Problem]:
    """Constants given another shape than the one they inherit (a group of constants, a list of
    numbers, one number), each at its own line: the inherited rules read them in that shape."""
    out: list[Problem] = []

    def walk(node: Mapping[str, Any], before: Mapping[str, Any], loc: tuple[str, ...]) -> None:
        for key, value in node.items():
            if key not in before or not _valid(value):
                continue
            here, old = (*loc, key), before[key]
            if isinstance(value, Mapping) and isinstance(old, Mapping):
                walk(value, old, here)
            elif _shape(value) != _shape(old):
                where = ".".join(here)
                message = (
                    f"constants.{where}: {_described(value, where)}, where the pack it extends "
                    f"gives {_described(old, where)}: give the same shape"
                )
                out.append(Problem(str(path), message, line=line_of(data, ("constants", *here))))

    walk(consts, inherited, ())
    return out


def _valid(value: Any) -> bool:
    """A group of constants, a number or a non-empty list of numbers (each checked apart)."""
    if isinstance(value, Mapping):
        return True
    return _is_number(value) or (
        isinstance(value, list) and bool(value) and all(_is_number(v) for v in value)
    )


def _shape(value: Any) -> str:
    return "group" if isinstance(value, Mapping) else "list" if isinstance(value, list) else "one"


def _described(value: Any, where: str) -> str:
    if isinstance(value, Mapping):
        return f"a group of constants ({', '.join(flatten(value, where + '.'))})"
    if isinstance(value, list):
        return f"a list of numbers {value}"
    return f"one number ({value})"


def _valid_name(key: str) -> bool:
    return re.fullmatch(_NAME, key) is not None


def new_constant_sites(
    consts: Mapping[str, Any], inherited: Mapping[str, Any], data: Any, path: Path
) -> list[ConstantSite]:
    """The constants a file adds to those it inherits, with their lines (not those under an
    inherited number or list made a group: `reshaped_constants` reports them)."""
    known = flatten(inherited)
    sites = []
    for name in flatten(consts):
        parts = name.split(".")
        if not any(".".join(parts[:i]) in known for i in range(1, len(parts) + 1)):
            line = line_of(data, ("constants", *name.split(".")))
            sites.append(ConstantSite(name, str(path), line, tuple(known)))
    return sites


def referenced_names(value: Any) -> set[str]:
    """Dotted names the expressions inside a rule's fields refer to."""
    if isinstance(value, Mapping):
        return set().union(set(), *(referenced_names(v) for v in value.values()))
    if isinstance(value, list):
        return set().union(set(), *(referenced_names(v) for v in value))
    if not isinstance(value, str) or len(value) > 500:
        return set()
    try:
        tree = syntax_tree(value.strip())
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return set()
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Attribute, ast.Name)):
            name = ast.unparse(node)
            if all(_valid_name(p) for p in name.split(".")):
                out.add(name)
    return out


def _text_names(raw: Mapping[str, Any]) -> set[str]:
    """Dotted names the placeholders of a rule's titles and descriptions refer to."""
    texts = [raw.get(k) for k in TEXT_FIELDS]
    exprs = [p.partition(":")[0] for t in texts if isinstance(t, str) for p in placeholders(t)]
    return referenced_names(exprs)


#: the fields of a rule that say what it judges by, the bound given either way
_JUDGING = (("threshold", "thresholds"), ("params",), ("score",))


def stale_texts(before: Mapping[str, Any], after: Mapping[str, Any]) -> tuple[set[str], list[str]]:
    """An override replacing a threshold (or params, score) that read a constant its texts
    state: the constants the texts still state that the replaced field no longer reads
    (TP-4 overridden to `min: 150` while its title says "At least {tp.min_points_per_scene}"
    tie points, i.e. 100), and the texts stating them."""
    stale: set[str] = set()
    for fields in _JUDGING:
        if not any(f in after and after.get(f) is not before.get(f) for f in fields):
            continue
        was = referenced_names([before.get(f) for f in fields])
        now = referenced_names([after.get(f) for f in fields])
        if fields == ("params",):
            was, now = was | _taken_by_default(before), now | _taken_by_default(after)
        stale |= was - now
    stale &= _text_names(after)
    texts = [k for k in TEXT_FIELDS if _text_names({k: after.get(k)}) & stale]
    return stale, texts


def _taken_by_default(raw: Mapping[str, Any]) -> set[str]:
    """The constants a rule's metric takes for the parameters the rule leaves out (e.g.
    checkpoint_accuracy's plane_norm_m: norm.plane_m)."""
    spec = REGISTRY.get(raw.get("metric") or "") if isinstance(raw.get("metric"), str) else None
    params = raw.get("params")
    given = params if isinstance(params, Mapping) else {}
    standing = getattr(spec.params, "CONSTANTS", {}) if spec is not None else {}
    return {name for key, name in standing.items() if key not in given}


def unused_constants(
    sites: list[ConstantSite], rules: Iterable[Mapping[str, Any]]
) -> list[Problem]:
    """A constant a pack adds that no rule uses is a typo until shown otherwise (`plane` for
    `plane_m`): refused, with the inherited name it most resembles."""
    used: set[str] = set()
    for raw in rules:
        for key in ("threshold", "thresholds", "params", "score"):  # score: its norm
            used |= referenced_names(raw.get(key))
        used |= _text_names(raw) | _taken_by_default(raw)
    out = []
    for s in sites:
        if s.name in used:
            continue
        hint = did_you_mean(s.name, s.parent_names)
        inherited = " is not a constant of the pack it extends and" if s.parent_names else ""
        out.append(
            Problem(s.file, f"constants.{s.name}{inherited} is used by no rule{hint}", line=s.line)
        )
    return out


# ---------------------------------------------------------------------------------- rules
def check_rule(
    rule: Rule,
    names: Mapping[str, Any],
    file: str,
    line: LineFn,
    notes: list[Problem] | None = None,
) -> list[Problem]:
    """Everything a rule can get wrong beyond its shape: expressions, metric, scope, statistic,
    columns in `where`, threshold groups, parameters. What could not be checked without a
    delivery, and does not refuse the pack, is added to `notes` (lint prints it as a warning)."""
    out: list[Problem] = []

    def bad(msg: str, *loc: Any, warning: bool = False) -> None:
        problem = Problem(file, f"rule {rule.id}: {msg}", line=line(*loc))
        if not warning:
            out.append(problem)
        elif notes is not None:
            notes.append(problem)

    if not rule.title.strip():
        bad("a rule needs a title", "title")
    _check_thresholds(rule, names, bad)
    _check_score(rule, names, bad)
    if rule.manual:
        if rule.figures:
            bad("figures: a manual rule has no values to draw: leave figures out", "figures")
        return out
    found = _metric_and_scope(rule, bad)
    if found is None:
        return out
    spec, scope = found
    what = f"{spec.name} at scope {rule.scope}"
    _check_statistic(rule, scope, what, bad)
    _check_figures(rule, scope, what, bad)
    _check_threshold_kinds(rule, scope, bad)
    _check_never_negative(rule, scope, names, what, bad)
    _check_unit(rule, scope, bad)
    _check_where(rule.where, scope, what, "where", bad)
    _check_content_groups(rule, scope, what, bad)
    _check_apart(rule, scope, what, bad)
    _check_groups(rule, spec, scope, bad)
    _check_evidence(rule, spec, scope, bad)
    _check_params(rule, spec, names, bad)
    return out


def _metric_and_scope(rule: Rule, bad: Callable[..., None]) -> tuple[MetricSpec, Scope] | None:
    """The metric the rule names and its scope; None, said, when the registry has no such
    metric or the metric no such scope."""
    spec = REGISTRY.get(rule.metric or "")
    if spec is None:
        known = sorted(REGISTRY)
        hint = did_you_mean(rule.metric or "", known)
        bad(f"unknown metric '{rule.metric}'{hint} (known: {', '.join(known)})", "metric")
        return None
    scope = spec.scopes.get(rule.scope)
    if scope is None:
        hint = did_you_mean(rule.scope, spec.scopes)
        offers = ", ".join(spec.scopes)
        bad(f"metric {spec.name} offers no scope '{rule.scope}'{hint} (offers: {offers})", "scope")
        return None
    return spec, scope


def _check_statistic(rule: Rule, scope: Scope, what: str, bad: Callable[..., None]) -> None:
    if rule.statistic not in scope.statistics:
        hint = did_you_mean(rule.statistic or "", scope.statistics)
        offers = ", ".join(scope.statistics)
        bad(
            f"metric {what} offers no statistic '{rule.statistic}'{hint} (offers: {offers})",
            "statistic",
        )


def _check_thresholds(rule: Rule, names: Mapping[str, Any], bad: Callable[..., None]) -> None:
    for group, th in rule.all_thresholds().items():
        loc = ("thresholds", group) if group else ("threshold",)
        where = ".".join(loc)
        lo, hi = (
            _number(getattr(th, key), names, bad, f"{where}.{key}", *loc, key)
            for key in ("min", "max")
        )
        # bounds naming the delivery are compared at inspect, not with the stand-in values
        compared = lo is not None and hi is not None and not delivery_named([th.min, th.max])
        if compared and lo > hi:
            bad(f"{where}: min {lo:g} is above max {hi:g}: nothing can pass", *loc)
        elif compared and lo == hi and not th.inclusive:
            bad(
                f"{where}: min and max are both {lo:g} and inclusive is false: nothing can "
                f"pass (to pass {lo:g} alone, write equals: {lo:g})",
                *loc,
            )
        if th.in_ is not None and not th.in_:
            bad(f"{where}.in: an empty list: nothing can pass", *loc, "in")
        if isinstance(th.equals, float) and not math.isfinite(th.equals):
            bad(f"{where}.equals: expected a finite number, true/false or a text", *loc)


def _number(
    expr: Any, names: Mapping[str, Any], bad: Callable[..., None], label: str, *loc: Any
) -> float | None:
    """A bound or norm evaluated to one number; None when not given or not one (reported). A
    constant that is a list of numbers (for a list parameter) is no bound."""
    if expr is None:
        return None
    try:
        value = evaluate(expr, names)
    except EvaluationError as exc:
        if delivery_named(expr):  # the stand-ins, not the expression, may be at fault
            bad(f"{label}: {_stand_ins_fail(exc)}", *loc, warning=True)
        else:
            bad(f"{label}: {exc}", *loc)
        return None
    except ExpressionError as exc:
        bad(f"{label}: {exc}", *loc)
        return None
    if isinstance(value, list):
        listed = ", ".join(f"{v:g}" for v in value)
        bad(f"{label}: {expr} is a list of numbers ({listed}): expected one number", *loc)
        return None
    return value


def delivery_named(expr: Any) -> bool:
    """Whether an expression (or any inside a mapping or list) names a value the delivery
    provides (e.g. gsd.ms)."""
    from blockqc.rules.loader import DELIVERY_NAMES

    return any(n.split(".")[0] in DELIVERY_NAMES for n in referenced_names(expr))


def _stand_ins_fail(exc: ExpressionError) -> str:
    """Why an expression naming the delivery is not refused although it could not be computed:
    lint knows no delivery and computes it with stand-ins, which any delivery may differ from."""
    from blockqc.rules.loader import DELIVERY_NAMES

    given = ", ".join(f"{k} = {v:g}" for k, v in flatten(DELIVERY_NAMES).items())
    return (
        f"could not be evaluated with the stand-in values lint gives the delivery's names "
        f"({given}) ({exc}); inspect evaluates it with each delivery's own values"
    )


def _check_score(rule: Rule, names: Mapping[str, Any], bad: Callable[..., None]) -> None:
    """An accuracy score divides by its norm m0 (§QE-3): the norm, or else every upper bound
    that stands for it, is a number above 0."""
    score = rule.score
    if score is None or score.kind != "accuracy":
        return
    if score.norm is None:
        _check_bound_norms(rule, names, bad)
        return
    m0 = _number(score.norm, names, bad, "score.norm", "score", "norm")
    if isinstance(m0, float) and not m0 > 0:
        bad(f"score.norm is {m0:g}: {_DIVIDES}", "score", "norm")


def _check_bound_norms(rule: Rule, names: Mapping[str, Any], bad: Callable[..., None]) -> None:
    """Without `score.norm`, each threshold's max is the norm of its results."""
    for group, th in rule.all_thresholds().items():
        loc = ("thresholds", group) if group else ("threshold",)
        where = ".".join(loc)
        if th.max is None:
            bad(
                f"score: without score.norm the norm m0 is the upper bound, and {where} has no "
                "max: give score.norm",
                "score",
            )
            continue
        try:
            m0 = evaluate(th.max, names)
        except ExpressionError:
            continue  # reported by the threshold checks
        if isinstance(m0, float) and not m0 > 0:
            bad(f"score: the norm m0 is {where}.max, {m0:g}: {_DIVIDES}, or give score.norm", *loc)


_DIVIDES = "m0 divides the accuracy score (§QE-3): give a norm above 0"


#: units of statistics that are texts (a datum's name)
TEXT_UNITS = {"name"}
#: units of statistics that are not numbers (true/false, texts; "" declares none)
NOT_NUMBER_UNITS = {"", "true/false", *TEXT_UNITS}
#: units that are no unit of measure a rule's `unit` repeats: those of statistics that are not
#: numbers, and of numbers that are codes or take each figure's own unit
NON_NUMERIC_UNITS = {*NOT_NUMBER_UNITS, "EPSG code", "the figure's unit"}


def _check_threshold_kinds(rule: Rule, scope: Scope, bad: Callable[..., None]) -> None:
    """A true/false statistic is compared with `equals: true/false`; a text statistic with
    `equals` or `in` of texts (no min/max); a statistic with a unit is a number: `equals: true`,
    a text, or `in` of texts never pass."""
    unit = scope.statistics.get(rule.statistic or "", "")
    for group, th in rule.all_thresholds().items():
        loc = ("thresholds", group) if group else ("threshold",)
        if unit == "true/false":
            given = [th.equals] if th.in_ is None else th.in_
            wrong = not all(isinstance(v, bool) for v in given)
            kind = "is true/false: compare it with equals: true or equals: false"
        elif unit in TEXT_UNITS:
            bounds = th.min is not None or th.max is not None
            given = [th.equals] if th.in_ is None else th.in_
            wrong = bounds or not all(isinstance(v, str) for v in given)
            why = (
                "min/max do not apply"
                if bounds
                else "quote a text that YAML reads as a number or true/false"
            )
            kind = (
                f"is a text ({unit}): compare it with equals: a text or in: a list of texts ({why})"
            )
        else:
            texts = isinstance(th.equals, (bool, str)) or any(
                isinstance(v, str) for v in th.in_ or []
            )
            wrong = unit not in NOT_NUMBER_UNITS and texts
            kind = f"is a number ({unit}): compare it with min/max or numbers"
        if wrong:
            bad(f"{'.'.join(loc)}: statistic {rule.statistic} {kind}", *loc)


def _check_never_negative(
    rule: Rule, scope: Scope, names: Mapping[str, Any], what: str, bad: Callable[..., None]
) -> None:
    """A statistic that is never negative passes no max below 0, nor max 0 exclusive: the rule
    would fail every delivery (refused). A min at or below 0 with no max passes every delivery
    (a warning: a rule that cannot fail). Bounds naming the delivery are left to inspect."""
    unit = scope.statistics.get(rule.statistic or "", "")
    if unit in NOT_NUMBER_UNITS or rule.statistic in scope.signed:
        return
    never = f"statistic {rule.statistic} ({unit}) of {what} is never negative"
    for group, th in rule.all_thresholds().items():
        loc = ("thresholds", group) if group else ("threshold",)
        hi = _constant_bound(th.max, names)
        if hi is not None and (hi < 0 or (hi == 0 and not th.inclusive)):
            how = "is below 0" if hi < 0 else "with inclusive: false"
            bad(f"{'.'.join(loc)}.max: {hi:g} {how}, and {never}: nothing can pass", *loc)
        lo = _constant_bound(th.min, names)
        if th.max is None and lo is not None and (lo < 0 or (lo == 0 and th.inclusive)):
            how = "is below 0" if lo < 0 else "takes 0 in"
            bad(
                f"{'.'.join(loc)}.min: {lo:g} {how}, and {never}: every delivery passes "
                "(the rule cannot fail)",
                *loc,
                warning=True,
            )


def _constant_bound(bound: Any, names: Mapping[str, Any]) -> float | None:
    """A bound's number when the pack fixes it (None: absent, naming the delivery, not a
    number, or not evaluable: the threshold checks report that)."""
    if bound is None or delivery_named(bound):
        return None
    try:
        value = evaluate(bound, names)
    except ExpressionError:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
        return None
    return float(value)


#: what each figure hint draws from its rule (DOMAIN §2 report figures): the metric whose
#: measurement it plots, and what of the rule it marks on it
FIGURE_NEEDS: dict[str, tuple[str, str]] = {
    "residual_histogram": ("tie_point_errors", "its bound (px) on the tie-point residuals"),
    "scene_counts": ("tie_point_distribution", "its bound of n_points on the per-scene counts"),
    "scene_points": ("tie_point_distribution", "the tie-point layout of each scene it fails"),
}


def _check_figures(rule: Rule, scope: Scope, what: str, bad: Callable[..., None]) -> None:
    """A figure hint draws the rule's bound on a figure of the tie points: a rule of another
    metric or statistic would mark its bound there in the wrong unit (a checkpoint's 30 m drawn
    as 30 px on the residual histogram, a share of cells as a count of tie points)."""
    if rule.statistic not in scope.statistics:  # said by _check_statistic
        return
    unit = scope.statistics[rule.statistic]
    for i, hint in enumerate(rule.figures):
        metric, draws = FIGURE_NEEDS[hint]
        fits = rule.metric == metric
        if hint == "residual_histogram":
            fits = fits and unit == "px"
        elif hint == "scene_counts":
            fits = fits and rule.statistic == "n_points"
        if not fits:
            need = {
                "residual_histogram": f"{metric} with a statistic in px",
                "scene_counts": f"{metric}, statistic n_points",
                "scene_points": f"{metric}",
            }[hint]
            bad(
                f"figures: {hint} draws {draws}: it needs a rule of {need}, not {what}, "
                f"statistic {rule.statistic}: leave it out",
                "figures",
                i,
            )


def _check_unit(rule: Rule, scope: Scope, bad: Callable[..., None]) -> None:
    """A rule's `unit`, shown beside its value and threshold, is the unit its statistic is
    measured in: `unit: m` on a share in % would print a share as metres."""
    unit = scope.statistics.get(rule.statistic or "", "")
    if rule.unit and unit not in NON_NUMERIC_UNITS and rule.unit != unit:
        bad(
            f"unit: '{rule.unit}', but statistic {rule.statistic} is measured in {unit}: "
            f"write unit: '{unit}' or leave it out (units are not converted)",
            "unit",
        )


def _check_where(
    where: Mapping[str, Any], scope: Scope, what: str, key: str, bad: Callable[..., None]
) -> None:
    columns = scope.all_columns()
    for col, val in where.items():
        if col not in columns:
            hint = did_you_mean(col, columns)
            bad(
                f"{key}: {what} gives no column '{col}'{hint} (columns: {', '.join(columns)})",
                key,
                col,
            )
        elif (values := scope.values_of(col)) and str(val) not in values:
            hint = did_you_mean(str(val), values)
            bad(f"{key}.{col}: no {col} '{val}'{hint} (values: {', '.join(values)})", key, col)


def _check_content_groups(rule: Rule, scope: Scope, what: str, bad: Callable[..., None]) -> None:
    """`content: {id: {column: value or [values]}}` selects the results of some groups: the
    column must be a group column of the scope, each value one of its values, and together the
    contents must take every group the rule judges (a result no content takes is reported
    apart from the contents it belongs to)."""
    taken: dict[str, set[str]] = {}
    for content, where in rule.content.items():
        for col, val in where.items():
            if col not in scope.groups:
                groups = ", ".join(scope.groups) or "none"
                hint = did_you_mean(col, scope.groups)
                bad(
                    f"content.{content}: {what} has no group column '{col}'{hint} "
                    f"(group columns: {groups})",
                    "content",
                    content,
                    col,
                )
                continue
            vals = selected(val)
            for v in vals:
                _check_where({col: v}, scope, what, f"content.{content}", _at(bad, content))
            taken.setdefault(col, set()).update(vals)
    if any(not where for where in rule.content.values()):
        return  # a content that takes every result
    for col, vals in taken.items():
        judged = list(_judged(rule, scope, col))
        missing = [v for v in judged if v not in vals]
        if missing:
            bad(
                f"content: no content takes the results of {col} {', '.join(missing)} "
                f"(give each value of {col} to a content: {', '.join(judged)})",
                "content",
            )


def _check_apart(rule: Rule, scope: Scope, what: str, bad: Callable[..., None]) -> None:
    """The values of a column decided apart (checkpoint plane and height) go to contents of
    their own: a content that takes two (no `where` on the column, no selector in `content`)
    would file the plane's results with the height's and judge them by its threshold."""
    for col in scope.apart:
        judged = _judged(rule, scope, col)
        if col in rule.where or len(judged) < 2:
            continue
        for content, where in rule.content.items():
            if not set(where) <= set(scope.groups):
                continue  # a column that is no group column: reported as such
            took = [v for v in judged if col not in where or v in selected(where[col])]
            if len(took) > 1:
                bad(_apart_message(content, col, took, what), "content")
                return


def apart_contents(rules: Iterable[tuple[Rule, int]]) -> dict[str, str]:
    """Across rules: a content that takes the results of one value of a column decided apart
    (checkpoint plane) from one rule and of another (height) from another would file them
    together, each judged by its own rule's threshold (a project rule `content: cp_height`
    with `where: {component: plane}`, CP-2 overridden to `where: {component: height}`).
    Rules come with their rank (0: written or overridden in the pack named, higher: in the packs
    it extends); each mix is reported once, at the rule of lowest rank (the last written of
    them): {rule id: message}."""
    taken: dict[tuple[str, str, str], dict[str, list[tuple[str, int, int]]]] = {}
    for pos, (rule, rank) in enumerate(rules):
        spec = None if rule.manual else REGISTRY.get(rule.metric or "")
        scope = spec.scopes.get(rule.scope) if spec else None
        if spec is None or scope is None:
            continue
        for col in scope.apart:
            judged = _judged(rule, scope, col)
            for content, where in rule.content.items():
                if not set(where) <= set(scope.groups):
                    continue
                took = [v for v in judged if col not in where or v in selected(where[col])]
                if len(took) == 1:  # two in one content: reported at the rule (_check_apart)
                    by_value = taken.setdefault((spec.name, col, content), {})
                    by_value.setdefault(took[0], []).append((rule.id, rank, pos))
    out: dict[str, str] = {}
    for (metric, col, content), by_value in taken.items():
        if len(by_value) < 2:
            continue
        rid, mine = min(
            ((r, v) for v, rs in by_value.items() for r in rs), key=lambda rv: (rv[0][1], -rv[0][2])
        )
        took = " and ".join(f"{v} ({', '.join(r[0] for r in rs)})" for v, rs in by_value.items())
        others = sorted({k[2] for k, vs in taken.items() if k[:2] == (metric, col) and mine in vs})
        elsewhere = [c for c in others if c != content]
        to = f"content: {' or '.join(elsewhere)}" if elsewhere else "a content of their own"
        other = " or ".join(f"where: {{{col}: {v}}}" for v in by_value if v != mine)
        out[rid[0]] = (
            f"content: {content} would take the results of {col} {took} of {metric}, each "
            f"{col} a content of its own: write {to} for this rule's {col} {mine}, or "
            f"{other} to judge the other"
        )
    return out


def _apart_message(content: str, col: str, took: list[str], what: str) -> str:
    wheres = " or ".join(f"where: {{{col}: {v}}}" for v in took)
    each = ", ".join(f"<{v} content>: {{{col}: {v}}}" for v in took)
    return (
        f"content: {content} would take the results of {col} {' and '.join(took)} of {what}, "
        f"each a content of its own: add {wheres} to judge one, or give each its content "
        f"(content: {{{each}}})"
    )


def _judged(rule: Rule, scope: Scope, col: str) -> tuple[str, ...]:
    """The values of a group column the rule judges: the one its `where` keeps, else every one
    (also when `where` names no value of the column: that is reported at the `where`)."""
    vals = tuple(scope.groups[col])
    kept = str(rule.where[col]) if col in rule.where else None
    return (kept,) if kept in vals else vals


def _at(bad: Callable[..., None], content: str) -> Callable[..., None]:
    return lambda message, *_: bad(message, "content", content)


def _check_groups(rule: Rule, spec: MetricSpec, scope: Scope, bad: Callable[..., None]) -> None:
    """`thresholds:` give one threshold per value of one group column (after `where`)."""
    if not rule.thresholds:
        return
    what = f"metric {spec.name} at scope {rule.scope}"
    if not scope.groups:
        bad(f"thresholds: {what} has no groups: give a single threshold:", "thresholds")
        return
    values = {col: _judged(rule, scope, col) for col in scope.groups}
    every = {v for vals in values.values() for v in vals}
    for key in rule.thresholds:
        if key not in every:
            groups = "; ".join(f"{c}: {', '.join(v)}" for c, v in values.items())
            hint = did_you_mean(key, every)
            bad(f"thresholds.{key}: no group '{key}'{hint} ({groups})", "thresholds", key)
    known = [k for k in rule.thresholds if k in every]
    if known and not any(set(known) <= set(vals) for vals in values.values()):
        by = "; ".join(f"{c}: {', '.join(k for k in known if k in v)}" for c, v in values.items())
        bad(
            f"thresholds: keys of more than one group column ({by}): a group takes the first "
            "that matches, so the others would never apply; give them per value of one column "
            "(filter the other with where:, or write a rule per value)",
            "thresholds",
        )
        return
    if any(set(vals) <= set(rule.thresholds) for vals in values.values()):
        return
    col, vals = max(values.items(), key=lambda cv: len(set(cv[1]) & set(rule.thresholds)))
    missing = [v for v in vals if v not in rule.thresholds]
    bad(
        f"thresholds: no threshold for {col} {', '.join(missing)} "
        f"(give one per value of {col}: {', '.join(vals)}, or filter with where:)",
        "thresholds",
    )


def _check_evidence(rule: Rule, spec: MetricSpec, scope: Scope, bad: Callable[..., None]) -> None:
    ev_scope = scope
    if rule.evidence_from is not None:
        ev_scope = spec.scopes.get(rule.evidence_from)
        if ev_scope is None:
            hint = did_you_mean(rule.evidence_from, spec.scopes)
            bad(
                f"evidence_from: metric {spec.name} offers no scope '{rule.evidence_from}'{hint}",
                "evidence_from",
            )
            return
    what = f"{spec.name} at scope {rule.evidence_from or rule.scope}"
    _check_where(rule.evidence_where, ev_scope, what, "evidence_where", bad)


def _check_params(
    rule: Rule, spec: MetricSpec, names: Mapping[str, Any], bad: Callable[..., None]
) -> None:
    resolved = _resolve(spec, rule.params, names, bad, ("params",))
    for loc, ref in _references(resolved):
        _check_reference(ref, names, bad, ("params", *loc))


def _resolve(
    spec: MetricSpec,
    raw: Mapping[str, Any],
    names: Mapping[str, Any],
    bad: Callable[..., None],
    at: tuple[Any, ...],
) -> BaseModel | None:
    """A metric's parameters validated, expressions evaluated; None (reported) when invalid."""
    label = ".".join(map(str, at))
    try:
        return resolve_params(spec.params, raw, names)
    except EvaluationError as exc:
        if delivery_named(raw):
            bad(f"{label}: {_stand_ins_fail(exc)}", *at, warning=True)
        else:
            bad(f"{label}: {exc}", *at)
    except ExpressionError as exc:
        bad(f"{label}: {exc}", *at)
    except ValidationError as exc:
        for err in exc.errors():
            loc = ".".join(str(x) for x in err["loc"])
            if err["type"] == "extra_forbidden":
                hint = did_you_mean(str(err["loc"][-1]), spec.params.model_fields)
                msg = f"unknown parameter{hint} (known: {', '.join(spec.params.model_fields)})"
            else:
                msg = worded(err) or err["msg"].removeprefix("Value error, ")
            bad(f"{'.'.join(filter(None, (label, loc)))}: {msg}", *at, *err["loc"])
    return None


def _references(params: BaseModel | None) -> list[tuple[tuple[str, ...], Any]]:
    """Parameters that name another metric's statistic (e.g. DOC-2's figures), by location."""
    out = []
    for key, value in params if params is not None else ():
        for k, v in value.items() if isinstance(value, dict) else ():
            if isinstance(v, BaseModel) and all(
                hasattr(v, a) for a in ("metric", "scope", "statistic", "params")
            ):
                out.append(((key, k), v))
    return out


def _check_reference(
    ref: Any, names: Mapping[str, Any], bad: Callable[..., None], at: tuple[Any, ...]
) -> None:
    """A parameter naming a metric, scope, statistic and filter: checked like a rule's."""
    label = ".".join(map(str, at))
    spec = REGISTRY.get(ref.metric)
    if spec is None:
        hint = did_you_mean(ref.metric, REGISTRY)
        bad(f"{label}.metric: unknown metric '{ref.metric}'{hint}", *at, "metric")
        return
    scope = spec.scopes.get(ref.scope)
    if scope is None:
        hint = did_you_mean(ref.scope, spec.scopes)
        bad(f"{label}.scope: metric {spec.name} offers no scope '{ref.scope}'{hint}", *at, "scope")
        return
    if ref.statistic not in scope.all_columns():
        hint = did_you_mean(ref.statistic, scope.all_columns())
        bad(
            f"{label}.statistic: {spec.name} at scope {ref.scope} gives no '{ref.statistic}'{hint}",
            *at,
            "statistic",
        )
    what = f"{spec.name} at scope {ref.scope}"
    _check_where(ref.where, scope, what, f"{label}.where", lambda m, *_: bad(m, *at, "where"))
    for col in getattr(ref, "prefer", {}) or {}:
        if col not in scope.all_columns():
            bad(f"{label}.prefer: {what} gives no column '{col}'", *at, "prefer")
    _resolve(spec, ref.params, names, bad, (*at, "params"))


#: a part of a pack a Chinese page shows by its title_zh (its English title where it has
#: none): what it is ('rule', 'element', 'item', 'content'), its id and its line (None: unknown)
Untitled = tuple[str, str, int | None]


def untitled_parts(elements: Iterable[ElementDef]) -> list[tuple[str, str]]:
    """The elements, items and contents of an `elements:` tree without a Chinese title, in the
    tree's order: a Chinese page shows their English titles."""
    out = []
    for e in elements:
        out += [("element", e.id)] if not e.title_zh.strip() else []
        for i in e.items:
            out += [("item", i.id)] if not i.title_zh.strip() else []
            out += [("content", c.id) for c in i.contents if not c.title_zh.strip()]
    return out


def untranslated_titles(pack: Pack) -> list[Problem]:
    """The rules, elements, items and contents of the pack without a Chinese title, one warning
    per pack file naming them and their lines: a Chinese page shows their English titles (none
    is made up for them)."""
    files: dict[str, list[Untitled]] = {}
    for rule in pack.rules:
        if not rule.title_zh.strip():
            file, line = pack.origin.get(rule.id, (pack.name, None))
            files.setdefault(str(file), []).append(("rule", rule.id, line))
    for kind, pid in untitled_parts(pack.elements):
        file, line = pack.title_sites.get((kind, pid), (pack.name, None))
        files.setdefault(str(file), []).append((kind, pid, line))
    out = []
    for file, named in files.items():
        one = len(named) == 1
        out.append(Problem(file, untranslated(named), line=named[0][2] if one else None))
    return out


def untranslated(named: list[Untitled], pack: str = "") -> str:
    """The warning of parts without a Chinese title ('rules PR-1 (line 4), PR-3 (line 23),
    item survey (line 30) have no title_zh: …'; one part by itself, its line said where the
    warning is); `pack` names the pack where the lines are not known (from results.json)."""
    one = len(named) == 1
    kinds: dict[str, list[str]] = {}
    for kind, pid, line in named:
        kinds.setdefault(kind, []).append(pid if one or line is None else f"{pid} (line {line})")
    names = ", ".join(
        f"{k}{'s' if len(ids) > 1 else ''} {', '.join(ids)}" for k, ids in kinds.items()
    )
    return (
        f"{names} {'has' if one else 'have'} no title_zh{f' (pack {pack})' if pack else ''}: a "
        f"Chinese page (--lang zh) shows {'its English title' if one else 'their English titles'}; "
        f"give {'it' if one else 'each'} a title_zh{' in the pack' if pack else ''}"
    )


# ---------------------------------------------------------------------------------- lint
def check_cases(pack: Pack) -> list[Problem]:
    """Every rule has a case file (nearest along the pack's chain) with a pass and a fail case,
    whose values and groups its rule can give."""
    from blockqc.rules.cases import case_folder, case_problems, find_case_file, read_case_file

    out: list[Problem] = []
    owners = _case_owners(pack)
    for rule in pack.rules:
        file, line = pack.origin.get(rule.id, (pack.chain[0], None))
        found = find_case_file(pack.chain, rule.id)
        if found is None:
            folder = case_folder(Path(file))
            out.append(
                Problem(
                    file,
                    f"rule {rule.id} has no cases: write {folder / (rule.id + '.yaml')} with a "
                    "passing and a failing case",
                    line=line,
                )
            )
            continue
        try:
            doc = read_case_file(found)
        except RuleError as exc:
            out.extend(exc.problems)
            continue
        owner = owners(found)
        if owner is not None:
            out.extend(case_problems(found, doc, *owner))
        expects = {c.expect for c in doc.cases}
        if "pass" not in expects:
            out.append(Problem(str(found), f"rule {rule.id}: no passing case (expect: pass)"))
        if not expects & {"fail", "warn"}:
            out.append(Problem(str(found), f"rule {rule.id}: no failing case (expect: fail)"))
    out.extend(_stray_case_files(pack))
    return out


def _case_owners(pack: Pack) -> Callable[[Path], tuple[Pack, Path] | None]:
    """The pack a case file runs against (the pack of its folder, along the chain) and its file;
    None when that pack cannot be loaded (its own problems are reported when it is linted)."""
    from blockqc.rules.cases import case_folder
    from blockqc.rules.loader import load_pack

    loaded: dict[Path, Pack | None] = {Path(pack.chain[0]): pack}

    def owner(case_file: Path) -> tuple[Pack, Path] | None:
        file = next(Path(f) for f in pack.chain if case_folder(Path(f)) == case_file.parent)
        if file not in loaded:
            try:
                loaded[file] = load_pack(file)
            except RuleError:
                loaded[file] = None
        found = loaded[file]
        return None if found is None else (found, file)

    return owner


def _stray_case_files(pack: Pack) -> list[Problem]:
    """A case file in the pack's own folder for a rule the pack does not have."""
    from blockqc.rules.cases import case_files, case_folder

    ids = [r.id for r in pack.rules]
    out = []
    for f in case_files(case_folder(Path(pack.chain[0]))):
        if f.stem not in ids and f.stem not in pack.disabled:
            hint = did_you_mean(f.stem, ids)
            out.append(Problem(str(f), f"cases for {f.stem}, which the pack has no rule for{hint}"))
    return out


def lint(ref: str | Path) -> tuple[Pack | None, list[Problem]]:
    """Every problem of a pack: its files, its rules, its constants and its cases."""
    from blockqc.rules.loader import read_pack

    try:
        pack, problems = read_pack(ref)
    except RuleError as exc:
        return None, list(exc.problems)
    if pack is not None:
        try:
            problems += check_cases(pack)
        except RuleError as exc:  # a cases folder that cannot be read as one (cases.case_files)
            problems += exc.problems
    return pack, problems
