"""The sampling plan file (§QE-1): written by `blockqc sample`, read by `inspect --plan`.

Applying a plan to a block's results: the detailed-inspection rules (`inspection: detailed`)
stand for sampled blocks only; elsewhere they are not applicable, with the reason. A sampled
block without checkpoints is incomplete, and its results say so.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError

from blockqc import metrics
from blockqc.acceptance.model import EMPTY_BASIS, ReportMeta, empty_basis
from blockqc.acceptance.sampling import Lot, natural_key
from blockqc.errors import InputError, Problem
from blockqc.results import BlockResults, tally
from blockqc.yamlio import line_of, load_yaml, pydantic_problems, yaml_kind

NOT_SAMPLED = "not sampled for detailed inspection (sampling plan)"
NO_CHECKPOINTS = (
    "sampled for detailed inspection, but the delivery has no checkpoints: "
    "the detailed inspection is incomplete"
)


class _M(BaseModel):
    """Types as `blockqc sample` writes them: a number written as text ("7"), true/false for a
    number or 0/"no" for true/false is refused, never converted."""

    model_config = ConfigDict(extra="forbid", strict=True)


class StratumPlan(_M):
    value: str
    size: int
    sample: int
    units: list[str]
    sampled: list[str]


class LotPlan(_M):
    size: int
    sample_size: int
    census: bool
    strata: list[StratumPlan]
    sampled: list[str]


SIMPLE, STRATIFIED = "simple random", "stratified proportional random"


class Plan(_M):
    """What was sampled, how, and from what: enough to draw the same sample again.

    Every field is required (`blockqc sample` writes them all); `load_plan` also refuses a plan
    whose parts disagree (see `plan_problems`)."""

    plan: str
    standard: str
    rule_pack: str
    batch: str  # the batch folder's name (never an absolute path)
    seed: int = Field(ge=0)  # as `blockqc sample --seed` takes it
    strata_key: Annotated[str, Field(min_length=1)] | None
    method: Literal["simple random", "stratified proportional random"]
    units: int
    sample_size: int
    lots: list[LotPlan]
    sampled: list[str]
    _data: Any = PrivateAttr(default=None)  # the file as read, for the lines of its keys

    @property
    def population(self) -> set[str]:
        return {u for lot in self.lots for s in lot.strata for u in s.units}

    def line(self, *loc: str | int) -> int | None:
        """The line of a key of the plan file it was read from (None for a plan made here)."""
        return line_of(self._data, loc) if self._data is not None else None


def make_plan(lots: list[Lot], seed: int, key: str | None, **about: Any) -> Plan:
    """The plan file's content from the lots drawn."""
    out = [
        LotPlan(
            size=len(lot.units),
            sample_size=lot.sample_size,
            census=lot.census,
            strata=[
                StratumPlan(
                    value=s.value,
                    size=len(s.units),
                    sample=len(s.sampled),
                    units=s.units,
                    sampled=s.sampled,
                )
                for s in lot.strata
            ],
            sampled=lot.sampled,
        )
        for lot in lots
    ]
    return Plan(
        plan="sampling plan",
        seed=seed,
        strata_key=key,
        method=STRATIFIED if key else SIMPLE,
        units=sum(x.size for x in out),
        sample_size=sum(x.sample_size for x in out),
        lots=out,
        sampled=sorted((u for x in out for u in x.sampled), key=natural_key),
        **about,
    )


def load_plan(path: Path) -> Plan:
    """Read a plan file; InputError names the file, line and key of any problem."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(Problem(str(path), "expected a sampling plan (blockqc sample)", line=1))
    try:
        plan = Plan.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data, say=_expected, model=Plan)) from None
    found = plan_problems(plan)
    if found:
        raise InputError(
            [
                Problem(str(path), f"{key_path(loc)}: {msg}", line=line_of(data, loc))
                for loc, msg in found
            ]
        )
    plan._data = data
    return plan


#: what a field of a plan holds, by pydantic's error type
EXPECTED = {
    "int_type": "a whole number",
    "bool_type": "true or false",
    "string_type": "text",
    "list_type": "a list",
    "greater_than_equal": "a whole number ≥ {ge}",
    "string_too_short": "a block.yaml key (not empty)",
}


def _expected(err: dict[str, Any]) -> str | None:
    """A type error in the project's words: what was expected, what the file gives."""
    what = EXPECTED.get(err["type"])
    if what is None:
        return None
    return f"expected {what.format(**err.get('ctx', {}))}, got {yaml_kind(err['input'])}"


#: a disagreement between parts of a plan: where (a key path) and what
Mismatch = tuple[tuple[str | int, ...], str]


def key_path(loc: tuple[str | int, ...]) -> str:
    return ".".join(str(p) for p in loc)


def listed(units: list[str], most: int = 10) -> str:
    more = f", … ({len(units)} in all)" if len(units) > most else ""
    return ", ".join(units[:most]) + more if units else "none"


def _count(loc: tuple[str | int, ...], given: int, units: list[str], what: str) -> list[Mismatch]:
    """`given` must be the number of `units` (what they are, for the message)."""
    if given == len(units):
        return []
    return [(loc, f"{given}, but {what} {len(units)} unit(s): {listed(units)}")]


def _same(
    loc: tuple[str | int, ...], given: list[str], units: list[str], what: str
) -> list[Mismatch]:
    """`given` must list the same blocks as `units` (any order, each once)."""
    if sorted(given) == sorted(units):
        return []
    return [(loc, f"{listed(given)} disagrees with {what}: {listed(sorted(units))}")]


def _once(loc: tuple[str | int, ...], units: list[str]) -> list[Mismatch]:
    """Each block once in a list of units: a repeat, at its line, would count one block twice."""
    seen: set[str] = set()
    out = []
    for i, u in enumerate(units):
        if u in seen:
            out.append(((*loc, i), f"{u} is listed more than once"))
        seen.add(u)
    return out


def _stratum_problems(s: StratumPlan, at: tuple[str | int, ...]) -> list[Mismatch]:
    out = _once((*at, "units"), s.units) + _once((*at, "sampled"), s.sampled)
    if not s.units:  # `blockqc sample` makes a stratum of the units that give its value
        out.append(((*at, "units"), "a stratum lists its units, at least one"))
    out += _count((*at, "size"), s.size, s.units, "the stratum lists")
    out += _count((*at, "sample"), s.sample, s.sampled, "the stratum samples")
    out += [
        ((*at, "sampled"), f"{u} is not among the stratum's units")
        for u in s.sampled
        if u not in s.units
    ]
    return out


def _values_once(lot: LotPlan, at: tuple[str | int, ...]) -> list[Mismatch]:
    """A lot is at least one stratum, each value once: two strata of one value would be
    allocated and drawn apart, where `blockqc sample` draws one stratum per value."""
    if not lot.strata:
        return [((*at, "strata"), "a lot is at least one stratum of units; it lists none")]
    seen: set[str] = set()
    out = []
    for j, s in enumerate(lot.strata):
        if s.value in seen:
            why = (
                f"'{s.value}' is the value of an earlier stratum of the lot: one value, one stratum"
            )
            out.append(((*at, "strata", j, "value"), why))
        seen.add(s.value)
    return out


def _lot_problems(lot: LotPlan, at: tuple[str | int, ...]) -> list[Mismatch]:
    out = [p for j, s in enumerate(lot.strata) for p in _stratum_problems(s, (*at, "strata", j))]
    units = [u for s in lot.strata for u in s.units]
    drawn = [u for s in lot.strata for u in s.sampled]
    out += _count((*at, "size"), lot.size, units, "its strata list")
    out += _values_once(lot, at)
    out += _once((*at, "sampled"), lot.sampled)
    out += _same((*at, "sampled"), lot.sampled, drawn, "the sampled blocks of its strata")
    out += _count((*at, "sample_size"), lot.sample_size, lot.sampled, "the lot samples")
    if lot.census != (lot.sample_size == lot.size):
        census = "every unit" if lot.sample_size == lot.size else "not every unit"
        out.append(((*at, "census"), f"{lot.census}, but the lot samples {census}"))
    return out


def plan_problems(plan: Plan) -> list[Mismatch]:
    """Every disagreement between the parts of a plan: counts against the lists they count,
    the sampled blocks against those of the lots and strata, each block once in every list, the
    method against the key (without a key, one stratum per lot)."""
    out = [p for i, lot in enumerate(plan.lots) for p in _lot_problems(lot, ("lots", i))]
    units = [u for lot in plan.lots for s in lot.strata for u in s.units]
    places = Counter(u for lot in plan.lots for s in lot.strata for u in set(s.units))
    twice = sorted(u for u, n in places.items() if n > 1)
    if twice:
        out.append((("lots",), f"{listed(twice)} listed in more than one stratum or lot"))
    out += _count(("units",), plan.units, units, "its lots list")
    lots_sampled = [u for lot in plan.lots for u in lot.sampled]
    out += _count(("sample_size",), plan.sample_size, lots_sampled, "its lots sample")
    out += _once(("sampled",), plan.sampled)
    out += _same(("sampled",), plan.sampled, lots_sampled, "the sampled blocks of its lots")
    method = STRATIFIED if plan.strata_key else SIMPLE
    if plan.method != method:
        key = f"strata_key {plan.strata_key}" if plan.strata_key else "no strata_key"
        out.append((("method",), f"{plan.method}, but with {key} the method is {method}"))
    elif not plan.strata_key:
        out += [
            (("lots", i, "strata"), "without strata_key a lot is one stratum, of value ''")
            for i, lot in enumerate(plan.lots)
            if [s.value for s in lot.strata] != [""]
        ]
    return out


def apply_plan(results: BlockResults, sampled: bool) -> BlockResults:
    """Detailed-inspection results kept for a sampled block, not applicable elsewhere (§QE-1)."""
    results.sampled = sampled
    has_cps = results.summary.get("checkpoints", 0) > 0
    for r in results.results:
        if r.inspection != "detailed":
            continue
        if not sampled:
            r.status, r.value, r.evidence = "not_applicable", None, []
            r.detail = {"reason": NOT_SAMPLED, "plan": NOT_SAMPLED}
        elif not has_cps:
            r.detail = {**r.detail, "plan": NO_CHECKPOINTS, "plan_incomplete": True}
            if r.detail.get("reason") == metrics.NO_CHECKPOINTS:  # "… was not sampled …"
                r.detail["reason"] = NO_CHECKPOINTS
    if sampled and not has_cps:
        results.complete = False
    _recount(results)
    return results


def _recount(results: BlockResults) -> None:
    results.counts, results.verdict = tally(r.status for r in results.results)


def load_meta(path: Path) -> ReportMeta:
    """Read the filed report's particulars; InputError names the file, line and key."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping (report_number, project, …)", line=1)
        )
    problems = _empty_basis(path, data)
    try:
        meta = ReportMeta.model_validate(data)
    except ValidationError as exc:
        problems += pydantic_problems(exc, path, data, say=_expected_text, model=ReportMeta)
    if problems:
        raise InputError(problems)
    return meta


#: where a --meta file's basis comes from with the key left out: the pack's, which an empty
#: list would have let pass as the file's own
BASIS_LEFT_OUT = {
    "basis": "to use the rule pack's basis",
    "basis_zh": "to show basis (without it, the rule pack's basis_zh) on the pages in Chinese",
}


def _empty_basis(path: Path, data: dict[str, Any]) -> list[Problem]:
    """`basis: []` (or basis_zh), refused at its line (acceptance.model.empty_basis)."""
    return [
        Problem(str(path), f"{key}: {EMPTY_BASIS} {BASIS_LEFT_OUT[key]}", line=line_of(data, [key]))
        for key in empty_basis(data)
    ]


def _expected_text(err: dict[str, Any]) -> str | None:
    """As `_expected`; a particular YAML reads as a number or true/false (report_number: 0012,
    prepared: yes) is to be quoted to be kept as written."""
    said = _expected(err)
    if err["type"] == "string_type" and isinstance(err["input"], (bool, int, float)):
        return f"{said}: put it in quotes to keep it as written"
    return said
