"""Loading rule packs: stock packs by name or files by path, `extends`, overrides, disabling.

A pack is refused whole when anything in it is wrong, with every problem listed with its file
and line: unknown keys, unknown metrics or statistics, bad parameters, bad expressions.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from blockqc.acceptance.model import Acceptance
from blockqc.errors import Problem, RuleError
from blockqc.metrics import REGISTRY
from blockqc.resources import rules_dir
from blockqc.rules.expr import ExpressionError, evaluate, resolve_params
from blockqc.rules.model import ElementDef, Pack, PackFile, Rule, merge_elements
from blockqc.yamlio import LineDict, line_of, load_yaml, pydantic_problems

#: values the delivery supplies to expressions; pack checks evaluate them with these stand-ins
DELIVERY_NAMES = {"gsd": {"pan": 1.0, "ms": 1.0}}


def available_packs() -> list[str]:
    return sorted(p.stem for p in rules_dir().glob("*.yaml"))


def resolve_pack_path(ref: str | Path, base: Path | None = None) -> Path:
    """A pack reference is a file path (relative to `base` in `extends`) or a stock pack name."""
    ref_s = str(ref)
    candidates = []
    if base is not None:
        candidates.append(base / ref_s)
    candidates.append(Path(ref_s))
    if not ref_s.endswith((".yaml", ".yml")):
        candidates.append(rules_dir() / f"{ref_s}.yaml")
    for c in candidates:
        if c.is_file():
            return c
    raise RuleError(
        Problem(
            ref_s,
            "no such rule pack: give a file path or one of the stock "
            f"packs ({', '.join(available_packs()) or 'none'})",
        )
    )


def _deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _merge_rule(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """Params merge key by key; every other field (threshold included) is replaced whole."""
    out = copy.deepcopy(base)
    for k, v in override.items():
        if k == "params" and isinstance(v, dict):
            out[k] = _deep_merge(out.get(k, {}), v)
        else:
            out[k] = copy.deepcopy(v)
    return out


class _Raw:
    """A rule's raw mapping and where it was last written (file, line)."""

    def __init__(self, data: dict[str, Any], file: str, line: int | None, src: Any):
        self.data, self.file, self.line, self.src = data, file, line, src


def _load_raw(
    path: Path, seen: tuple[Path, ...]
) -> tuple[PackFile, dict[str, Any], dict[str, _Raw], list[str], list[str]]:
    """Read one pack file and what it extends: file model, constants, raw rules, chain, disabled."""
    resolved = path.resolve()
    if resolved in seen:
        chain = " -> ".join(str(p) for p in seen + (resolved,))
        raise RuleError(Problem(str(path), f"circular extends: {chain}"))
    data = load_yaml(path, RuleError)
    if not isinstance(data, dict):
        raise RuleError(
            Problem(str(path), "a rule pack is a mapping with pack, rules, ...", line=1)
        )
    try:
        pf = PackFile.model_validate(data)
    except ValidationError as exc:
        raise RuleError(pydantic_problems(exc, path, data)) from None

    problems: list[Problem] = []
    constants: dict[str, Any] = {}
    rules: dict[str, _Raw] = {}
    chain = [str(path)]
    disabled: list[str] = []
    if pf.extends:
        parent = resolve_pack_path(pf.extends, path.parent)
        _, constants, rules, parent_chain, disabled = _load_raw(parent, seen + (resolved,))
        chain += parent_chain
    constants = _deep_merge(constants, pf.constants)

    for i, raw in enumerate(pf.rules):
        line = line_of(data, ("rules", i))
        rid = raw.get("id") if isinstance(raw, dict) else None
        if not isinstance(rid, str):
            problems.append(Problem(str(path), f"rules.{i}: a rule needs an id", line=line))
            continue
        if rid in rules:
            where = "earlier in this file" if rules[rid].file == str(path) else rules[rid].file
            problems.append(
                Problem(
                    str(path),
                    f"rules.{i}: rule {rid} is already defined "
                    f"({where}); change it under overrides:",
                    line=line,
                )
            )
            continue
        rules[rid] = _Raw(dict(raw), str(path), line, data["rules"][i])
    for rid, override in pf.overrides.items():
        line = line_of(data, ("overrides", rid))
        if rid not in rules:
            problems.append(
                Problem(
                    str(path),
                    f"overrides.{rid}: no rule {rid} to override (known: {', '.join(rules)})",
                    line=line,
                )
            )
            continue
        if "id" in override and override["id"] != rid:
            problems.append(Problem(str(path), f"overrides.{rid}: the id cannot change", line=line))
            continue
        prev = rules[rid]
        rules[rid] = _Raw(_merge_rule(prev.data, override), str(path), line, data["overrides"][rid])
    for i, rid in enumerate(pf.disable):
        if rid not in rules:
            problems.append(
                Problem(
                    str(path),
                    f"disable: no rule {rid} to disable",
                    line=line_of(data, ("disable", i)),
                )
            )
            continue
        del rules[rid]
        disabled.append(rid)
    if problems:
        raise RuleError(problems)
    return pf, constants, rules, chain, disabled


def load_pack(ref: str | Path) -> Pack:
    """Load, merge and validate a rule pack; raise RuleError listing every problem."""
    path = resolve_pack_path(ref)
    pf, constants, raw_rules, chain, disabled = _load_raw(path, ())
    elements = _elements(chain)
    acceptance, problems = _acceptance(chain, elements, constants)
    rules: list[Rule] = []
    names = {**constants, **DELIVERY_NAMES}
    for rid, raw in raw_rules.items():
        try:
            rule = Rule.model_validate(raw.data)
        except ValidationError as exc:
            for p in pydantic_problems(exc, Path(raw.file), raw.src):
                problems.append(
                    Problem(p.file, f"rule {rid}: {p.message}", line=p.line or raw.line)
                )
            continue
        problems.extend(_check_rule(rule, names, raw))
        problems.extend(_check_contents(rule, elements, raw))
        rules.append(rule)
    if problems:
        raise RuleError(problems)
    return Pack(
        name=pf.pack,
        version=pf.version,
        title=pf.title,
        description=pf.description,
        constants=constants,
        rules=rules,
        elements=elements,
        chain=chain,
        disabled=disabled,
        origin={rid: (r.file, r.line) for rid, r in raw_rules.items()},
        acceptance=acceptance,
    )


def _check_contents(rule: Rule, elements: list[ElementDef], raw: _Raw) -> list[Problem]:
    """A rule's contents and quality element must be in the pack's `elements:` tree."""
    contents = {c.id for e in elements for i in e.items for c in i.contents}
    out = [
        Problem(
            raw.file,
            f"rule {rule.id}: content '{c}' is not in the pack's elements "
            f"(known: {', '.join(sorted(contents))}); add it under elements:",
            line=_line(raw, "content"),
        )
        for c in rule.content
        if c not in contents
    ]
    if rule.quality_element and rule.quality_element not in {e.id for e in elements}:
        out.append(
            Problem(
                raw.file,
                f"rule {rule.id}: quality_element '{rule.quality_element}' is not an element id "
                f"(known: {', '.join(e.id for e in elements)})",
                line=_line(raw, "quality_element"),
            )
        )
    return out


def _elements(chain: list[str]) -> list[ElementDef]:
    """The pack's inspection contents: each file's `elements:` merged from the root pack down."""
    out: list[ElementDef] = []
    for file in reversed(chain):
        data = load_yaml(Path(file), RuleError)
        out = merge_elements(out, PackFile.model_validate(data).elements)
    return out


def _acceptance(
    chain: list[str], elements: list[ElementDef], constants: dict[str, Any]
) -> tuple[Acceptance | None, list[Problem]]:
    """§QE: each file's `acceptance:` merged from the root pack down, validated, weights checked."""
    merged: dict[str, Any] | None = None
    where, src = "", None
    for file in reversed(chain):
        data = load_yaml(Path(file), RuleError)
        own = data.get("acceptance") if isinstance(data, dict) else None
        if own is not None:
            merged = _deep_merge(merged or {}, own)
            where, src = file, data
    if merged is None:
        return None, []
    try:
        acc = Acceptance.model_validate(merged)
    except ValidationError as exc:
        return None, pydantic_problems(exc, Path(where), src, ("acceptance",))
    known = {e.id for e in elements} | {i.id for e in elements for i in e.items}
    problems = [
        Problem(where, f"acceptance.weights: '{k}' is no element or item (known: {sorted(known)})")
        for k in [*acc.weights.elements, *acc.weights.items]
        if k not in known
    ]
    return acc, problems


def _line(raw: _Raw, *loc: Any) -> int | None:
    if isinstance(raw.src, LineDict):
        return line_of(raw.src, loc) or raw.line
    return raw.line


def _check_rule(rule: Rule, names: dict[str, Any], raw: _Raw) -> list[Problem]:
    """Everything a pack can get wrong beyond its shape: metric, scope, statistic, parameters."""
    out: list[Problem] = []

    def bad(msg: str, *loc: Any) -> None:
        out.append(Problem(raw.file, f"rule {rule.id}: {msg}", line=_line(raw, *loc)))

    for group, th in rule.all_thresholds().items():
        loc = ("thresholds", group) if group else ("threshold",)
        for key in ("min", "max"):
            expr = getattr(th, key)
            if expr is not None:
                try:
                    evaluate(expr, names)
                except ExpressionError as exc:
                    bad(f"{'.'.join(loc)}.{key}: {exc}", *loc, key)
    if rule.score is not None and isinstance(rule.score.norm, str):
        try:
            evaluate(rule.score.norm, names)
        except ExpressionError as exc:
            bad(f"score.norm: {exc}", "score", "norm")
    if rule.manual:
        return out
    spec = REGISTRY.get(rule.metric or "")
    if spec is None:
        bad(f"unknown metric '{rule.metric}' (known: {', '.join(sorted(REGISTRY))})", "metric")
        return out
    if rule.scope not in spec.scopes:
        bad(
            f"metric {spec.name} offers no scope '{rule.scope}' "
            f"(it offers: {', '.join(spec.scopes)})",
            "scope",
        )
    elif rule.statistic not in spec.scopes[rule.scope]:
        bad(
            f"metric {spec.name} at scope {rule.scope} offers no statistic '{rule.statistic}' "
            f"(it offers: {', '.join(spec.scopes[rule.scope])})",
            "statistic",
        )
    if rule.evidence_from is not None and rule.evidence_from not in spec.scopes:
        bad(
            f"evidence_from: metric {spec.name} offers no scope '{rule.evidence_from}'",
            "evidence_from",
        )
    try:
        resolve_params(spec.params, rule.params, names)
    except ExpressionError as exc:
        bad(f"params: {exc}", "params")
    except ValidationError as exc:
        for err in exc.errors():
            loc = ".".join(str(x) for x in err["loc"])
            msg = "unknown parameter" if err["type"] == "extra_forbidden" else err["msg"]
            bad(f"params.{loc}: {msg}", "params", *err["loc"])
    return out
