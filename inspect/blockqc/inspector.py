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

import difflib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

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
from blockqc.yamlio import line_of, load_yaml, pydantic_problems

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

    def labels(self) -> set[str]:
        """Unit labels this waiver covers: ids, and pairs in both orders ("A/B", "B/A")."""
        out = set(self.scenes) | set(self.points) | set(self.units)
        for a, b in self.pairs:
            out |= {f"{a}/{b}", f"{b}/{a}"}
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
    close = difflib.get_close_matches(value, list(choices), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


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


#: the scopes whose units a waiver lists under one key: (that key, what the units are)
_UNIT_KEYS = {"scene": ("scenes", "scenes"), "document": ("units", "document kinds")}


def _unit_kind_problems(
    inp: InspectorInput, loc: tuple[Any, ...], waiver: Waiver, rule: Any
) -> list[Problem]:
    """A rule judged per scene is waived for scenes, one judged per document for document kinds
    (under 'units'): units under another key would match none."""
    scope = getattr(rule, "scope", None)
    if rule is None or scope not in _UNIT_KEYS:
        return []
    key, what = _UNIT_KEYS[scope]
    return [
        inp.problem(
            (*loc, kind),
            f"rule {rule.id} is judged per {scope}: list the {what} to waive under '{key}' "
            f"('{kind}' would match none)",
        )
        for kind in ("scenes", "pairs", "points", "units")
        if kind != key and getattr(waiver, kind)
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


def _scene_problems(
    inp: InspectorInput, loc: tuple[Any, ...], waiver: Waiver, scenes: set[str], where: str
) -> list[Problem]:
    """Every scene a waiver names must be a scene of the block(s) it applies to."""
    return [
        inp.problem(
            (*loc, *at),
            f"a waiver for scene '{s}', which is not a scene of {where}" + _hint(s, scenes),
        )
        for at, s in waiver.scene_ids()
        if s not in scenes
    ]


def check_inspector_input(
    inp: InspectorInput, rules: Mapping[str, Any], blocks: Mapping[str, set[str] | None]
) -> None:
    """Refuse what would otherwise be dropped: verdicts on automatic or unknown rules, waivers
    of rules that are not waivable, unknown block ids and scenes. `rules` maps rule ids to rules;
    `blocks` maps the block ids inspected to their scene ids (None where not readable)."""
    problems: list[Problem] = []
    known = all(s is not None for s in blocks.values())
    every = set().union(*(s for s in blocks.values() if s is not None))
    parts = [((), inp.verdicts, inp.waivers, every if known else None, "any block inspected")]
    for bid, own in inp.blocks.items():
        if bid not in blocks and known:
            msg = f"block '{bid}' is not one of the blocks inspected ({', '.join(blocks)})"
            problems.append(inp.problem(("blocks", bid), msg + _hint(bid, blocks)))
        where = f"block {bid}"
        parts.append((("blocks", bid), own.verdicts, own.waivers, blocks.get(bid), where))
    for loc, verdicts, waivers, scenes, where in parts:
        for rid in verdicts:
            problems += _rule_problems(inp, (*loc, "verdicts", rid), rid, rules, False)
        for rid, waiver in waivers.items():
            at = (*loc, "waivers", rid)
            problems += _rule_problems(inp, at, rid, rules, True)
            problems += _unit_kind_problems(inp, at, waiver, rules.get(rid))
            problems += _document_problems(inp, at, waiver, rules.get(rid))
            if scenes is not None:
                problems += _scene_problems(inp, at, waiver, scenes, where)
    if problems:
        raise InputError(sorted(problems, key=lambda p: p.line or 0))


def load_inspector_input(path: Path) -> InspectorInput:
    data = load_yaml(path)
    if data is None:
        out = InspectorInput()
    elif not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping (inspector, verdicts, waivers)", line=1)
        )
    else:
        try:
            out = InspectorInput.model_validate(data)
        except ValidationError as exc:
            raise InputError(pydantic_problems(exc, path, data)) from None
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
