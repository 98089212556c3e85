"""Loading rule packs: stock packs by name or files by path, `extends`, overrides, disabling.

A pack is refused whole when anything in it is wrong, with every problem listed with its file
and line: unknown keys, unknown metrics or statistics, bad parameters, bad expressions.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from blockqc.acceptance.model import Acceptance
from blockqc.errors import Problem, RuleError
from blockqc.metrics import REGISTRY
from blockqc.resources import rules_dir
from blockqc.rules import accept
from blockqc.rules.expr import flatten
from blockqc.rules.lint import (
    apart_contents,
    check_constants,
    check_rule,
    did_you_mean,
    new_constant_sites,
    referenced_names,
    reshaped_constants,
    stale_texts,
    stand_in_invalid,
    unused_constants,
    without_reserved,
)
from blockqc.rules.model import ElementDef, Pack, PackFile, Rule, merge_elements
from blockqc.rules.text import render_rule
from blockqc.textio import dangling_link
from blockqc.yamlio import LineDict, line_of, load_yaml, pydantic_problems

#: values the delivery supplies to expressions; pack checks evaluate them with these stand-ins
#: (an expression they cannot compute is not refused for it: lint warns, README "Rule packs")
DELIVERY_NAMES = {"gsd": {"pan": 1.0, "ms": 1.0}}


def available_packs() -> list[str]:
    return sorted(p.stem for p in rules_dir().glob("*.yaml"))


def resolve_pack_path(
    ref: str | Path | None, base: Path | None = None, site: tuple[str, int | None] | None = None
) -> Path:
    """A pack reference is a file path (relative to `base` in `extends`) or a stock pack name.

    `site` is the file and line that names the reference (an `extends:`), for the message.
    """
    ref_s = "" if ref is None else str(ref)
    if not ref_s.strip():
        file, line = site or ("<rules>", None)
        raise RuleError(
            Problem(
                file,
                f"{'extends: ' if site else ''}an empty rule pack name: give a stock pack name "
                f"({', '.join(available_packs())}) or a file path"
                + (", or leave extends out" if site else ""),
                line=line,
            )
        )
    candidates = []
    if base is not None:
        candidates.append(base / ref_s)
    candidates.append(Path(ref_s))
    if not ref_s.endswith((".yaml", ".yml")):
        candidates.append(rules_dir() / f"{ref_s}.yaml")
    for c in candidates:
        if c.is_file() or (c.exists() and not c.is_dir()):  # a pipe too: --rules <(...)
            return c
    message = (
        f"give a file path or one of the stock packs ({', '.join(available_packs()) or 'none'})"
    )
    if site is not None:
        tried = (base / ref_s if base is not None else Path(ref_s)).resolve()
        raise RuleError(
            Problem(
                site[0],
                f"extends: no rule pack '{ref_s}' (no file {tried}): {message}",
                line=site[1],
            )
        )
    if Path(ref_s).is_dir():
        raise RuleError(Problem(ref_s, f"is a folder, not a rule pack file: {message}"))
    if link := dangling_link(Path(ref_s)):
        raise RuleError(Problem(ref_s, f"{link}: expected a rule pack file; {message}"))
    raise RuleError(Problem(ref_s, f"no such rule pack: {message}"))


def _deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _merge_rule(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """Params merge key by key; every other field (threshold included) is replaced whole. The
    bound is one field given two ways: `threshold:` replaces inherited `thresholds:` (one per
    group) and the other way round."""
    out = copy.deepcopy(base)
    for one, other in (("threshold", "thresholds"), ("thresholds", "threshold")):
        if one in override and other not in override:
            out.pop(other, None)
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
        self.history: list[tuple[str, int | None, dict[str, Any]]] = [(file, line, {})]


@dataclass
class _Loaded:
    """What reading a pack file and its parents gave, with every problem found on the way."""

    pf: PackFile
    constants: dict[str, Any] = field(default_factory=dict)
    rules: dict[str, _Raw] = field(default_factory=dict)
    chain: list[str] = field(default_factory=list)
    disabled: list[str] = field(default_factory=list)
    disabled_at: dict[str, tuple[str, int | None]] = field(default_factory=dict)  # file, line
    problems: list[Problem] = field(default_factory=list)
    notes: list[Problem] = field(default_factory=list)  # warnings: the pack is usable
    # where each constant was last set: dotted name → (file, line, value)
    constant_set_at: dict[str, tuple[str, int | None, Any]] = field(default_factory=dict)
    # every file of the chain as read, the root pack first: (file, its YAML, its model)
    sources: list[tuple[str, Any, PackFile]] = field(default_factory=list)


def _read_file(path: Path) -> tuple[PackFile, Any]:
    """One pack file read and validated for its shape (unknown keys refused)."""
    data = load_yaml(path, RuleError)
    if not isinstance(data, dict):
        raise RuleError(
            Problem(str(path), "a rule pack is a mapping with pack, rules, ...", line=1)
        )
    other = _other_document(data)
    if other is not None:
        raise RuleError(Problem(str(path), other, line=1))
    try:
        return PackFile.model_validate(data), data
    except ValidationError as exc:
        raise RuleError(pydantic_problems(exc, path, data, model=PackFile)) from None


def _other_document(data: dict[str, Any]) -> str | None:
    """What another YAML file of blockqc given where a rule pack is expected is (a pack's case
    file, a delivery's block.yaml, an inspector's verdicts), rather than each of its keys
    refused as unknown ('rule: unknown key; did you mean rules?')."""
    if "pack" in data:
        return None
    if {"rule", "cases"} <= data.keys():
        what, hint = (
            "a case file of a rule (rule, cases)",
            "the pack file beside its cases folder (project.yaml beside project.cases/)",
        )
    elif "block_id" in data:
        what, hint = "a delivery's block.yaml (block_id, ...)", "a rule pack file"
    elif data.keys() & {"verdicts", "waivers", "inspector"}:
        what, hint = "an inspector's verdicts file (verdicts, waivers)", "it with --verdicts"
    else:
        return None
    return f"is {what}, not a rule pack (pack, rules, ...): give {hint}"


def _load_raw(path: Path, seen: tuple[Path, ...]) -> _Loaded:
    """Read one pack file and what it extends, collecting (not raising) the problems found."""
    pf, data = _read_file(path)
    out = _Loaded(pf)
    if "extends" in data:  # `extends:` or `extends: ''` names no pack: said, not passed over
        site = (str(path), line_of(data, ("extends",)))
        parent = resolve_pack_path(pf.extends, path.parent, site)
        seen = seen + (path.resolve(),)
        if parent.resolve() in seen:
            _circle(pf.extends, (*seen, parent.resolve()), site)
        out = _load_raw(parent, seen)
        out.problems += _name_taken(pf, data, path, out.sources)
        out.pf = pf
    out.problems += check_constants(pf.constants, data, path, DELIVERY_NAMES)
    # a constant under a name the delivery provides is reported once, at its own line, and set
    # aside: the delivery's value is the one expressions read
    consts = without_reserved(pf.constants, DELIVERY_NAMES)
    sites = new_constant_sites(consts, out.constants, data, path)
    out.problems += reshaped_constants(consts, out.constants, data, path)
    # an invalid constant is reported once, at its own line; its uses evaluate a stand-in
    out.constants = _deep_merge(out.constants, stand_in_invalid(consts, out.constants))
    for name, value in flatten(consts).items():
        out.constant_set_at[name] = (
            str(path),
            line_of(data, ("constants", *name.split("."))),
            value,
        )
    out.chain.insert(0, str(path))
    out.sources.append((str(path), data, pf))
    _add_rules(out, pf, data, path)
    _apply_overrides(out, pf, data, path)
    _apply_disable(out, pf, data, path)
    out.problems += unused_constants(sites, [r.data for r in out.rules.values()])
    return out


def _name_taken(
    pf: PackFile, data: Any, path: Path, parents: list[tuple[str, Any, PackFile]]
) -> list[Problem]:
    """A pack named as a pack it extends: its results and reports would name that pack (the
    stock global-project 1.0) for rules it changes."""
    taken = next((f for f, _, p in parents if p.pack == pf.pack), None)
    if taken is None:
        return []
    return [
        Problem(
            str(path),
            f"pack: {pf.pack} is the name of the pack it extends ({taken}): results and reports "
            "would name that pack for the rules this one changes; give this pack a name of "
            "its own",
            line=line_of(data, ("pack",)),
        )
    ]


def _circle(ref: str, chain: tuple[Path, ...], site: tuple[str, int | None]) -> None:
    """An `extends` naming a pack already in the chain: refused at the file and line naming it."""
    circle = " -> ".join(map(str, chain))
    raise RuleError(
        Problem(
            site[0],
            f"extends: {ref} closes a circle ({circle}): a pack cannot extend itself or a pack "
            "that extends it",
            line=site[1],
        )
    )


def _add_rules(out: _Loaded, pf: PackFile, data: Any, path: Path) -> None:
    for i, raw in enumerate(pf.rules):
        line = line_of(data, ("rules", i))
        rid = raw.get("id") if isinstance(raw, dict) else None
        if not isinstance(rid, str):
            out.problems.append(Problem(str(path), f"rules.{i}: a rule needs an id", line=line))
            continue
        same = next((k for k in out.rules if k.upper() == rid.upper()), None)
        if same is not None:
            where = (
                "earlier in this file"
                if out.rules[same].file == str(path)
                else out.rules[same].file
            )
            out.problems.append(
                Problem(
                    str(path),
                    f"rules.{i}: rule {rid} is already defined as {same} "
                    f"({where}); change it under overrides:",
                    line=line,
                )
            )
            continue
        out.rules[rid] = _Raw(dict(raw), str(path), line, data["rules"][i])
        if rid in out.disabled_at:  # a parent disabled it: defined again, it is judged again
            out.disabled.remove(rid)
            del out.disabled_at[rid]


def _apply_overrides(out: _Loaded, pf: PackFile, data: Any, path: Path) -> None:
    for rid, override in pf.overrides.items():
        line = line_of(data, ("overrides", rid))
        if rid not in out.rules:
            hint = did_you_mean(rid, out.rules)
            why = f"no rule {rid} to override{hint} (known: {', '.join(out.rules)})"
            if rid in out.disabled_at:
                why = f"{rid} is disabled by {', line '.join(map(str, out.disabled_at[rid]))}"
            out.problems.append(Problem(str(path), f"overrides.{rid}: {why}", line=line))
            continue
        if _defined_here(out, rid, path):
            why = _here(out, rid, f"overrides.{rid}", "change it there")
            out.problems.append(Problem(str(path), why, line=line))
            continue
        if "id" in override and override["id"] != rid:
            out.problems.append(
                Problem(str(path), f"overrides.{rid}: the id cannot change", line=line)
            )
            continue
        prev = out.rules[rid]
        merged = _merge_rule(prev.data, override)
        out.notes += _stale_texts(rid, prev.data, merged, out.constants, (str(path), line))
        out.rules[rid] = _Raw(merged, str(path), line, data["overrides"][rid])
        out.rules[rid].history = [*prev.history, (str(path), line, dict(override))]


def _stale_texts(
    rid: str,
    before: dict[str, Any],
    after: dict[str, Any],
    constants: dict[str, Any],
    site: tuple[str, int | None],
) -> list[Problem]:
    """A warning at an override whose threshold (params, score) no longer reads a constant
    the rule's title or description states: the report would state the constant's figure
    beside a rule judging by another."""
    stale, texts = stale_texts(before, after)
    flat = flatten(constants)
    stale = {n for n in stale if n in flat}  # a group's name (tp of tp.error_px) is no value
    if not stale:
        return []
    said = ", ".join(f"{n} = {flat[n]}" for n in sorted(stale))
    which = " and ".join(dict.fromkeys(t.removesuffix("_zh") for t in texts))
    return [
        Problem(
            site[0],
            f"overrides.{rid}: its {which} still {'state' if ' and ' in which else 'states'} "
            f"{said}, which the rule no longer "
            "judges by: set the constant instead, or override the texts too",
            line=site[1],
        )
    ]


def _apply_disable(out: _Loaded, pf: PackFile, data: Any, path: Path) -> None:
    for i, rid in enumerate(pf.disable):
        line = line_of(data, ("disable", i))
        if rid not in out.rules:
            out.problems.append(Problem(str(path), _not_disabled(out, rid), line=line))
            continue
        if _defined_here(out, rid, path):
            out.problems.append(
                Problem(str(path), _here(out, rid, "disable", "remove it there"), line=line)
            )
            continue
        if rid in pf.overrides:  # the override would be read by nothing
            out.problems.append(
                Problem(
                    str(path),
                    f"disable: {rid} is also overridden in this file (overrides.{rid}, line "
                    f"{line_of(data, ('overrides', rid))}): disable it or override it",
                    line=line,
                )
            )
        del out.rules[rid]
        out.disabled.append(rid)
        out.disabled_at[rid] = (str(path), line)


def _defined_here(out: _Loaded, rid: str, path: Path) -> bool:
    """Whether the rule is defined under `rules:` of this very file (not inherited)."""
    return out.rules[rid].history[0][0] == str(path) if rid in out.rules else False


def _here(out: _Loaded, rid: str, key: str, what: str) -> str:
    """A rule of this file named under its `overrides:` or `disable:`: its definition would be
    changed, or dropped, by a key read after it, unsaid."""
    return (
        f"{key}: {rid} is defined in this file (rules, line {out.rules[rid].history[0][1]}): {what}"
    )


def _not_disabled(out: _Loaded, rid: str) -> str:
    """Why a rule named under `disable:` cannot be disabled: it already is, or there is none."""
    if rid in out.disabled_at:
        file, line = out.disabled_at[rid]
        if file == out.chain[0]:
            return f"disable: {rid} is listed twice (first on line {line})"
        return f"disable: {rid} is already disabled by {file}, line {line}"
    return f"disable: no rule {rid} to disable{did_you_mean(rid, out.rules)}"


def read_pack(ref: str | Path) -> tuple[Pack | None, list[Problem]]:
    """Load, merge and check a rule pack: the pack (None when unusable) and every problem."""
    path = resolve_pack_path(ref)
    loaded = _load_raw(path, ())
    problems = list(loaded.problems)
    elements = _elements(loaded.sources)
    problems += _contents_twice(loaded.sources)
    acceptance, found = _acceptance(loaded.sources, elements)
    problems.extend(found)
    rules: list[Rule] = []
    notes: list[Problem] = list(loaded.notes)
    names = {**loaded.constants, **DELIVERY_NAMES}
    for rid, raw in loaded.rules.items():
        try:
            rule = Rule.model_validate(_with_inspection(raw.data))
        except ValidationError as exc:
            for p in pydantic_problems(exc, Path(raw.file), raw.src, model=Rule):
                problems.append(
                    Problem(p.file, f"rule {rid}: {p.message}", line=p.line or raw.line)
                )
            continue
        rule, found = render_rule(rule, loaded.constants, raw.file, partial(_line, raw))
        found += check_rule(rule, names, raw.file, partial(_line, raw), notes)
        problems.extend(_with_constants_set(found, raw, loaded))
        problems.extend(_check_contents(rule, elements, raw))
        rules.append(rule)
    problems.extend(_mixed_contents(rules, loaded))
    if not loaded.rules:
        problems.append(_no_rules(path, loaded))
    pf = loaded.pf
    pack = Pack(
        name=pf.pack,
        version=pf.version,
        title=pf.title,
        description=pf.description,
        constants=loaded.constants,
        rules=rules,
        elements=elements,
        chain=loaded.chain,
        disabled=loaded.disabled,
        origin={rid: (r.file, r.line) for rid, r in loaded.rules.items()},
        history={rid: r.history for rid, r in loaded.rules.items()},
        acceptance=acceptance,
        columns=next((f.columns for _, _, f in reversed(loaded.sources) if f.columns), "all"),
        notes=notes,
        title_sites=_title_sites(loaded.sources),
    )
    return pack, problems


def _with_constants_set(found: list[Problem], raw: _Raw, loaded: _Loaded) -> list[Problem]:
    """A rule's problems at its own file, with the constants it reads that a pack extending
    that file set (a project pack's `norm: {plane_m: -5}` makes stock rules fail at their
    lines): named with their value, file and line, so that the user finds what to change."""
    names = referenced_names(raw.data)
    chain = loaded.chain  # the pack named first, the stock pack last
    later = set(chain[: chain.index(raw.file)]) if raw.file in chain else set()
    set_elsewhere = [
        f"{n} = {v}, set in {f}, line {line}"
        for n, (f, line, v) in sorted(loaded.constant_set_at.items())
        if n in names and f in later
    ]
    if not set_elsewhere:
        return found
    hint = f" (constants set elsewhere: {'; '.join(set_elsewhere)})"
    return [
        Problem(p.file, p.message + hint, line=p.line) if p.file == raw.file else p for p in found
    ]


def _with_inspection(data: dict[str, Any]) -> dict[str, Any]:
    """A rule that does not say `inspection:` is of the detailed inspection when its metric
    measures the sampled blocks' checkpoints (DOMAIN §2): under a sampling plan it judges the
    sampled blocks only, as CP-1..CP-5 do; of the general inspection otherwise."""
    spec = REGISTRY.get(data.get("metric") or "") if isinstance(data.get("metric"), str) else None
    if "inspection" in data or spec is None or not spec.detailed:
        return data
    return {**data, "inspection": "detailed"}


def _mixed_contents(rules: list[Rule], loaded: _Loaded) -> list[Problem]:
    """A content given checkpoint plane results by one rule and height by another (lint's
    apart_contents), at the content line of the rule the pack wrote last."""
    chain = loaded.chain
    ranked = [
        (r, chain.index(loaded.rules[r.id].file) if loaded.rules[r.id].file in chain else 0)
        for r in rules
    ]
    return [
        Problem(raw.file, f"rule {rid}: {msg}", line=_line(raw, "content"))
        for rid, msg in apart_contents(ranked).items()
        for raw in (loaded.rules[rid],)
    ]


def _no_rules(path: Path, loaded: _Loaded) -> Problem:
    """A pack left without rules would pass every delivery having checked nothing."""
    why = f"every rule is disabled ({', '.join(loaded.disabled)})" if loaded.disabled else ""
    why = why or "no rule is defined"
    return Problem(str(path), f"the pack has no rule to judge: {why}; give it at least one rule")


def load_pack(ref: str | Path) -> Pack:
    """Load, merge and validate a rule pack; raise RuleError listing every problem."""
    pack, problems = read_pack(ref)
    if problems or pack is None:
        raise RuleError(problems)
    return pack


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


def _elements(sources: list[tuple[str, Any, PackFile]]) -> list[ElementDef]:
    """The pack's inspection contents: each file's `elements:` merged from the root pack down."""
    out: list[ElementDef] = []
    for _, _, pf in sources:
        out = merge_elements(out, pf.elements)
    return out


def _title_sites(sources: list[tuple[str, Any, PackFile]]) -> dict[tuple[str, str], Any]:
    """Each element, item and content of the `elements:` tree: the file (and line) that last
    writes it, where a warning of its missing title_zh names it."""
    out: dict[tuple[str, str], tuple[str, int | None]] = {}
    for file, data, pf in sources:
        for i, e in enumerate(pf.elements):
            out[("element", e.id)] = (file, line_of(data, ("elements", i)))
            for j, item in enumerate(e.items):
                at = ("elements", i, "items", j)
                out[("item", item.id)] = (file, line_of(data, at))
                for k, c in enumerate(item.contents):
                    out[("content", c.id)] = (file, line_of(data, (*at, "contents", k)))
    return out


def _contents_twice(sources: list[tuple[str, Any, PackFile]]) -> list[Problem]:
    """A content id given in two places of the `elements:` tree (two items, or twice in one
    item of a file): a rule naming it would be filed under one of them, unsaid. A content
    given again under its item by a pack further down retitles it."""
    first: dict[str, tuple[str, str, str, int | None]] = {}  # id -> element, item, file, line
    out = []
    for file, data, pf in sources:
        for i, e in enumerate(pf.elements):
            for j, item in enumerate(e.items):
                for k, c in enumerate(item.contents):
                    line = line_of(data, ("elements", i, "items", j, "contents", k))
                    seen = first.setdefault(c.id, (e.id, item.id, file, line))
                    if seen[2:] == (file, line) or (
                        seen[:2] == (e.id, item.id) and seen[2] != file
                    ):
                        continue
                    out.append(
                        Problem(
                            file,
                            f"elements: content {c.id} is also a content of item {seen[1]} "
                            f"({seen[2]}, line {seen[3]}): a content id names one content of "
                            "the tree; give this one another id",
                            line=line,
                        )
                    )
    return out


def _acceptance(
    sources: list[tuple[str, Any, PackFile]], elements: list[ElementDef]
) -> tuple[Acceptance | None, list[Problem]]:
    """§QE: each file's `acceptance:` merged from the root pack down, validated, weights checked."""
    merged: dict[str, Any] | None = None
    for _, data, _ in sources:
        own = data.get("acceptance") if isinstance(data, dict) else None
        if own is not None:
            merged = _deep_merge(merged or {}, own)
    if merged is None:
        return None, []
    acc, problems = accept.validate(merged, sources)
    problems += accept.empty_basis(sources)
    if acc is None:
        return None, problems
    return acc, problems + accept.check_weights(acc, elements, sources)


def _line(raw: _Raw, *loc: Any) -> int | None:
    if isinstance(raw.src, LineDict):
        return line_of(raw.src, loc) or raw.line
    return raw.line
