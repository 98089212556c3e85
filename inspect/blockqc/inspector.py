"""The inspector's input, never inside a delivery: verdicts for manual items and waivers.

Verdict statuses (README "Readings"):
  pass              the item is accepted;
  conditional_pass  accepted on a condition the inspector states in `note` (required); the
                    rule passes and the condition is shown beside it in the results and reports;
  rework            the producer must redo the item: the rule fails (whatever its severity),
                    so the block fails;
  fail              the item is rejected: the rule fails at its severity (fail, or warn).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from blockqc.errors import InputError, Problem
from blockqc.schema import TABLES, did_you_mean, key_labels
from blockqc.yamlio import line_of, load_yaml, pydantic_problems

if TYPE_CHECKING:
    from blockqc.delivery import DeliveryIds
    from blockqc.metrics import Scope

VERDICT_STATUSES = ("pass", "conditional_pass", "rework", "fail")


class Verdict(BaseModel):
    model_config = ConfigDict(extra="forbid")
    status: Literal["pass", "conditional_pass", "rework", "fail"]
    note: str = ""

    @model_validator(mode="after")
    def _condition_stated(self) -> Verdict:
        if self.status == "conditional_pass" and not self.note.strip():
            raise ValueError("a conditional_pass states its condition in 'note'")
        return self


class Waiver(BaseModel):
    """Waives a waivable rule: for the units listed, or for the whole rule when none are."""

    model_config = ConfigDict(extra="forbid")
    reason: str = Field(min_length=1)
    scenes: list[str] = Field(default_factory=list)
    pairs: list[tuple[str, str]] = Field(default_factory=list)
    points: list[str] = Field(default_factory=list)
    units: list[str] = Field(default_factory=list)  # other units by key, e.g. a document kind

    @field_validator("scenes", "pairs", "points", "units")
    @classmethod
    def _names_units(cls, value: list) -> list:
        """A list given names units: an empty one would waive the whole rule unsaid."""
        if not value:
            raise ValueError(
                "an empty list waives nothing: list the units to waive, or leave the key out "
                "to waive the whole rule"
            )
        return value

    def named(self, kind: str) -> list[str]:
        """What the waiver names under a key (scenes, pairs, points, units) as unit labels:
        a pair in both orders ("A/B", "B/A")."""
        if kind == "pairs":
            return [f"{a}/{b}" for a, b in self.pairs] + [f"{b}/{a}" for a, b in self.pairs]
        return list(getattr(self, kind))

    def covers(self, units: pd.DataFrame, keys: Sequence[str]) -> np.ndarray:
        """Which units (rows holding the key columns `keys`) the waiver names, under any key
        that names units of such a scope (unit_columns)."""
        out = np.zeros(len(units), dtype=bool)
        for kind, columns in unit_columns(keys).items():
            names = self.named(kind)
            if names:
                out |= key_labels(units, columns).isin(names).to_numpy(dtype=bool)
        return out

    def scene_ids(self) -> list[tuple[tuple[Any, ...], str]]:
        """The scene ids named (in `scenes` and `pairs`) with their place in the waiver."""
        named = [(("scenes", i), s) for i, s in enumerate(self.scenes)]
        for i, pair in enumerate(self.pairs):
            named += [(("pairs", i, j), s) for j, s in enumerate(pair)]
        return named

    @property
    def whole_rule(self) -> bool:
        return not (self.scenes or self.pairs or self.points or self.units)


#: the key columns naming a scene (those referring to scenes.csv)
SCENE_COLUMNS = frozenset(
    r.column for t in TABLES.values() for r in t.references if r.table == "scenes"
)
WAIVER_KEYS = ("scenes", "pairs", "points", "units")


def unit_columns(keys: Sequence[str]) -> dict[str, list[str]]:
    """The waiver keys naming units of a scope keyed by `keys`, each with the key columns
    its names are matched with: a unit that is a scene is named under 'scenes'; one keyed by
    two scenes (a pair, a point of a pair) under 'pairs' too, in either order; one keyed by a
    point id under 'points' too (every unit of that point id: each pair holding it); any unit
    under 'units', its key columns joined by '/' ("A/B/P7"). A scope without keys names none."""
    keys = list(keys)
    scenes = [k for k in keys if k in SCENE_COLUMNS]
    if len(keys) == 1 and scenes:
        return {"scenes": keys}
    out: dict[str, list[str]] = {}
    if len(scenes) == 2:
        out["pairs"] = scenes
    if "point_id" in keys:
        out["points"] = ["point_id"]
    return {**out, "units": keys} if keys else out


class BlockInput(BaseModel):
    model_config = ConfigDict(extra="forbid")
    verdicts: dict[str, Verdict] = Field(default_factory=dict)
    waivers: dict[str, Waiver] = Field(default_factory=dict)


class InspectorInput(BaseModel):
    """verdicts.yaml: the inspector, and verdicts/waivers for every block or per block id."""

    model_config = ConfigDict(extra="forbid")
    inspector: str | None = None
    verdicts: dict[str, Verdict] = Field(default_factory=dict)
    waivers: dict[str, Waiver] = Field(default_factory=dict)
    blocks: dict[str, BlockInput] = Field(default_factory=dict)
    _file: str = PrivateAttr(default="")
    _data: Any = PrivateAttr(default=None)

    def for_block(self, block_id: str) -> BlockInput:
        own = self.blocks.get(block_id, BlockInput())
        return BlockInput(
            verdicts={**self.verdicts, **own.verdicts}, waivers={**self.waivers, **own.waivers}
        )

    def problem(self, loc: tuple[Any, ...], message: str) -> Problem:
        """A problem of this file at the line of `loc` (a key path)."""
        return Problem(self._file, message, line=line_of(self._data, loc))


def _hint(value: str, choices: Iterable[str]) -> str:
    return did_you_mean(choices)(value)


def _rule_problems(
    inp: InspectorInput, loc: tuple[Any, ...], rule_id: str, rules: Mapping[str, Any], waiver: bool
) -> list[Problem]:
    """A verdict must be for a manual rule of the pack, a waiver for a waivable one."""
    rule = rules.get(rule_id)
    what = "waiver" if waiver else "verdict"
    if rule is None:
        msg = f"a {what} for rule '{rule_id}', which the rule pack does not hold"
        return [inp.problem(loc, msg + _hint(rule_id, rules))]
    if waiver and not rule.waivable:
        ok = ", ".join(r for r, x in rules.items() if x.waivable) or "none"
        msg = f"rule {rule_id} is not waivable: the waiver is refused (waivable rules: {ok})"
        return [inp.problem(loc, msg)]
    if not waiver and not rule.manual:
        ok = ", ".join(r for r, x in rules.items() if x.manual) or "none"
        msg = (
            f"rule {rule_id} is judged from the delivery, not by the inspector: a verdict is "
            f"given only for a manual rule ({ok}); to set a result aside, waive a waivable rule"
        )
        return [inp.problem(loc, msg)]
    return []


def rule_scope(rule: Any) -> Scope | None:
    """The scope of the metric an automatic rule is judged at (None for a manual rule, or one
    whose metric or scope is unknown: the pack's own problem, reported when it is loaded)."""
    from blockqc.metrics import REGISTRY

    spec = REGISTRY.get(getattr(rule, "metric", None) or "")
    return spec.scopes.get(rule.scope) if spec is not None else None


def _instead(rule: Any, keys: Sequence[str], allowed: Iterable[str]) -> str:
    """What to write instead of a waiver key that names no unit of the rule's scope."""
    what = {"scenes": "scenes", "pairs": "pairs of scenes", "points": "point ids"}
    what["units"] = "document kinds" if rule.scope == "document" else f"units ({'/'.join(keys)})"
    parts = [f"the {what[k]}" + (" to waive" if i == 0 else "") + f" under '{k}'"
             for i, k in enumerate(allowed)]  # fmt: skip
    if not parts:
        return ", which names no units: leave them out to waive the whole rule"
    listed = ", ".join(parts[:-1]) + " or " + parts[-1] if len(parts) > 1 else parts[0]
    return ": list " + listed


def _unit_kind_problems(
    inp: InspectorInput, loc: tuple[Any, ...], waiver: Waiver, rule: Any
) -> list[Problem]:
    """Units are waived under the keys that name units of the rule's scope (unit_columns): a
    rule judged per scene is waived for scenes, one judged per document for document kinds
    (under 'units'); units under another key would match none."""
    scope = rule_scope(rule)
    if scope is None:
        return []
    allowed = unit_columns(scope.keys)
    return [
        inp.problem(
            (*loc, kind),
            f"rule {rule.id} is judged per {rule.scope}{_instead(rule, scope.keys, allowed)} "
            f"('{kind}' would match none)",
        )
        for kind in WAIVER_KEYS
        if kind not in allowed and getattr(waiver, kind)
    ]


def document_kinds(rule: Any) -> list[str] | None:
    """The document kinds a rule judged per document checks (its `required`), else None."""
    if getattr(rule, "scope", None) != "document" or getattr(rule, "metric", None) != "documents":
        return None
    from blockqc.metrics.documents import DocumentParams

    try:
        return DocumentParams.model_validate(rule.params).required
    except ValueError:
        return None  # the pack's own problem, reported when it is loaded


def _document_problems(
    inp: InspectorInput, loc: tuple[Any, ...], waiver: Waiver, rule: Any
) -> list[Problem]:
    """Every document kind a waiver names must be one the rule checks: another would match none
    (a kind the rule does not require never fails, so there is nothing to waive)."""
    kinds = document_kinds(rule)
    if kinds is None:
        return []
    return [
        inp.problem(
            (*loc, "units", i),
            f"a waiver for document '{u}', which rule {rule.id} does not check "
            f"({', '.join(kinds)})" + _hint(u, kinds),
        )
        for i, u in enumerate(waiver.units)
        if u not in kinds
    ]


def _not_read(names: list[str], what: str) -> str:
    """A note naming the blocks some of whose ids could not be read (so not checked)."""
    return f" ({what} of {', '.join(names)} could not be read)" if names else ""


def _scene_problems(
    inp: InspectorInput, loc: tuple[Any, ...], waiver: Waiver, ids: list[DeliveryIds], where: str
) -> list[Problem]:
    """Every scene a waiver names must be a scene of the block(s) it applies to, among those
    whose scenes could be read (none read: not checked)."""
    read = [d for d in ids if d.scenes is not None]
    if not read:
        return []
    scenes = set().union(*(d.scenes or set() for d in read))
    note = _not_read([d.block_id for d in ids if d.scenes is None], "the scenes")
    return [
        inp.problem(
            (*loc, *at),
            f"a waiver for scene '{s}', which is not a scene of {where}{note}" + _hint(s, scenes),
        )
        for at, s in waiver.scene_ids()
        if s not in scenes
    ]


#: beyond this many units of a table, no "did you mean" is looked for among them
HINT_LIMIT = 10_000


def _labels_of(
    ids: list[DeliveryIds], table: str, columns: list[str]
) -> tuple[set[str] | None, list[str]]:
    """The labels of the units of a table in these deliveries (None: none could be read), and
    the blocks whose table could not be read."""
    frames = {d.block_id: d.units(table, tuple(columns)) for d in ids}
    unread = [b for b, f in frames.items() if f is None]
    read = [f for f in frames.values() if f is not None]
    if not read:
        return None, unread
    return set().union(*(set(key_labels(f, columns)) for f in read)), unread


def _unit_hint(name: str, have: set[str], pair_first: bool) -> str:
    """A "did you mean" for a unit: the same unit with its pair in the other order (a unit's
    label keeps the order of the table), else a close one among not too many."""
    a, _, rest = name.partition("/")
    b, _, rest = rest.partition("/")
    swapped = "/".join([b, a, rest] if rest else [b, a])
    if pair_first and swapped in have:
        return f"; did you mean '{swapped}'?"
    return _hint(name, have) if len(have) <= HINT_LIMIT else ""


def _unmatched(
    waiver: Waiver, kind: str, have: set[str], scenes: set[str] | None
) -> list[tuple[tuple[Any, ...], str]]:
    """(place, name) of what the waiver names under `kind` that no unit has; a pair naming a
    scene that is not one of the block's is left to _scene_problems."""
    if kind != "pairs":
        return [((kind, i), u) for i, u in enumerate(waiver.named(kind)) if u not in have]
    return [
        (("pairs", i), f"{a}/{b}")
        for i, (a, b) in enumerate(waiver.pairs)
        if f"{a}/{b}" not in have and f"{b}/{a}" not in have
        and (scenes is None or {a, b} <= scenes)
    ]  # fmt: skip


def _named_unit_problems(
    inp: InspectorInput,
    loc: tuple[Any, ...],
    waiver: Waiver,
    rule: Any,
    ids: list[DeliveryIds],
    where: str,
) -> list[Problem]:
    """Every pair, point or unit a waiver names must be one the table of the rule's units holds
    in the block(s) it applies to (its key columns, read lightly): another would match none."""
    scope = rule_scope(rule)
    if scope is None or not scope.table:
        return []
    read = [d.scenes for d in ids if d.scenes is not None]
    scenes = set().union(*read) if read else None
    out = []
    allowed = unit_columns(scope.keys)
    for kind, columns in allowed.items():
        if kind == "scenes" or not getattr(waiver, kind):
            continue
        have, unread = _labels_of(ids, scope.table, columns)
        if have is None:
            continue
        note = _not_read(unread, f"the {scope.table} table")
        noun = {"pairs": "pair", "points": "point", "units": "unit"}[kind]
        for at, name in _unmatched(waiver, kind, have, scenes):
            hint = _unit_hint(name, have, kind == "units" and "pairs" in allowed)
            msg = f"a waiver for {noun} '{name}', which is not a {noun} in the {scope.table} table"
            if kind == "units":
                msg += f" ({'/'.join(columns)})"
            out.append(inp.problem((*loc, *at), f"{msg} of {where}{note}{hint}"))
    return out


def check_inspector_input(
    inp: InspectorInput,
    rules: Mapping[str, Any],
    blocks: Mapping[str, DeliveryIds | None],
    unread: Sequence[Path] = (),
) -> None:
    """Refuse what would otherwise be dropped: verdicts on automatic or unknown rules, waivers
    of rules that are not waivable, unknown block ids, scenes and units. `rules` maps rule ids
    to rules; `blocks` maps the block ids inspected to their deliveries' ids (None where not
    known); `unread`: deliveries whose block.yaml cannot be read. Block ids are checked when
    every block id is known; scenes and units against the deliveries where they could be read
    (a unit is refused only where some delivery could be read, naming those that could not)."""
    problems: list[Problem] = []
    every = [d for d in blocks.values() if d is not None]
    anywhere = "any block inspected" + _not_read([str(p) for p in unread], "the block.yaml")
    parts = [((), inp.verdicts, inp.waivers, every, anywhere)]
    for bid, own in inp.blocks.items():
        if bid not in blocks and not unread:
            msg = f"block '{bid}' is not one of the blocks inspected ({', '.join(blocks)})"
            problems.append(inp.problem(("blocks", bid), msg + _hint(bid, blocks)))
        d = blocks.get(bid)
        ids = [d] if d is not None else []
        parts.append((("blocks", bid), own.verdicts, own.waivers, ids, f"block {bid}"))
    for loc, verdicts, waivers, ids, where in parts:
        for rid in verdicts:
            problems += _rule_problems(inp, (*loc, "verdicts", rid), rid, rules, False)
        for rid, waiver in waivers.items():
            at = (*loc, "waivers", rid)
            problems += _waiver_problems(inp, at, waiver, rules, rid, ids, where)
    if problems:
        raise InputError(sorted(problems, key=lambda p: p.line or 0))


def _waiver_problems(
    inp: InspectorInput,
    at: tuple[Any, ...],
    waiver: Waiver,
    rules: Mapping[str, Any],
    rid: str,
    ids: list[DeliveryIds],
    where: str,
) -> list[Problem]:
    """A waiver's problems: its rule, the keys it names units under, the units themselves
    (checked against the deliveries' ids, where they could be read)."""
    rule = rules.get(rid)
    out = _rule_problems(inp, at, rid, rules, True)
    kinds = _unit_kind_problems(inp, at, waiver, rule)
    out += kinds + _document_problems(inp, at, waiver, rule)
    out += _scene_problems(inp, at, waiver, ids, where)
    return out if kinds else out + _named_unit_problems(inp, at, waiver, rule, ids, where)


def load_inspector_input(path: Path) -> InspectorInput:
    data = load_yaml(path)
    if data is None:  # given on purpose, it says nothing: a file saved empty, or a template
        raise InputError(
            Problem(
                str(path),
                "holds no verdicts (empty, or comments only): expected a mapping (inspector, "
                "verdicts, waivers); leave --verdicts out to give none",
            )
        )
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping (inspector, verdicts, waivers)", line=1)
        )
    try:
        out = InspectorInput.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data, model=InspectorInput)) from None
    out._file, out._data = str(path), data
    return out


__all__ = [
    "VERDICT_STATUSES",
    "BlockInput",
    "InspectorInput",
    "Verdict",
    "Waiver",
    "check_inspector_input",
    "load_inspector_input",
]
