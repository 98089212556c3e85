"""A sampling plan against the batch it is applied to (`inspect --plan`, §QE-1).

Refused, naming the plan file and its line: a block inspected that is not one of the plan's
units, a sampled block that no delivery is, a unit placed in a stratum its block.yaml does not
give by the plan's `strata_key`. Stated, as a warning and a note of the acceptance report: units
of the plan that no delivery is (none sampled: deliveries withdrawn after sampling), a plan
drawn from another batch, with another rule pack or under another standard, a lot sampled below
the pack's table.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

from blockqc.acceptance.command import lookup, stratum_of
from blockqc.acceptance.model import PlanNote, Sampling
from blockqc.acceptance.plan import Plan, key_path, listed
from blockqc.acceptance.sampling import NUMBER, draw, natural_key, sample_size, split_sizes
from blockqc.errors import InputError, Problem

Loc = tuple[str | int, ...]


def check_blocks(
    plan: Plan, path: Path, block_ids: list[str], whole_batch: bool, unread: bool = False
) -> None:
    """Every block inspected is in the plan's batch; with a whole batch, every sampled block too,
    unless a delivery's block.yaml cannot be read (`unread`: it may be the sampled block; it is
    refused when read, and leaves the decision incomplete). Each problem names the plan's line:
    its `units`, or the sampled block's."""
    units = f"its {plan.units} units: {listed(sorted(plan.population))}"
    problems = [
        Problem(
            str(path),
            f"units: block {b} is not in the plan's batch ({units})",
            line=plan.line("units"),
        )
        for b in block_ids
        if b not in plan.population
    ]
    if whole_batch and not unread:
        problems += [
            Problem(
                str(path),
                f"sampled: block {b} is sampled by the plan but not among the deliveries "
                f"inspected ({listed(sorted(block_ids))})",
                line=plan.line("sampled", i),
            )
            for i, b in enumerate(plan.sampled)
            if b not in block_ids
        ]
    if problems:
        raise InputError(problems)


def _placed(plan: Plan) -> Iterator[tuple[Loc, str, str]]:
    """Every unit of the plan: where it is listed, its id and its stratum's value."""
    for i, lot in enumerate(plan.lots):
        for j, s in enumerate(lot.strata):
            for k, u in enumerate(s.units):
                yield ("lots", i, "strata", j, "units", k), u, s.value


def _gives(block: dict[str, Any], key: str) -> str:
    """What a block's block.yaml gives by the strata key, as the message says it."""
    try:
        return f"its block.yaml gives {key}: '{stratum_of(block, key)}'"
    except KeyError:
        return f"its block.yaml has no key '{key}'"
    except ValueError as exc:
        return f"in its block.yaml {exc}"


def _in_stratum(block: dict[str, Any], key: str, value: str) -> bool:
    """The block's stratum is the plan's; a number also by value (a plan may write the 1.0 of a
    block.yaml as '1.0', as `blockqc sample` did before it read numbers by value)."""
    try:
        given = stratum_of(block, key)
    except (KeyError, ValueError):
        return False
    raw = lookup(block, key)
    if given == value or isinstance(raw, str) or not NUMBER.fullmatch(value):
        return given == value
    return float(value) == raw


def check_strata(plan: Plan, path: Path, blocks: dict[str, dict[str, Any]]) -> None:
    """Each unit of a stratified plan that is in the batch lies in the stratum its block.yaml
    gives by `strata_key` (`blocks`: block.yaml of each block read, by block id). When none
    does, the key itself is named: the plan was drawn by another."""
    key = plan.strata_key
    if not key:
        return
    placed = [(loc, u, value) for loc, u, value in _placed(plan) if u in blocks]
    wrong = [(loc, u, v) for loc, u, v in placed if not _in_stratum(blocks[u], key, v)]
    if not wrong:
        return
    if len(wrong) == len(placed) > 1:
        _, u, value = wrong[0]
        why = (
            f"strata_key: {key}, but no block inspected lies in the stratum its block.yaml gives "
            f"by this key (e.g. {u}, in stratum '{value}': {_gives(blocks[u], key)}): the plan "
            "was not drawn by this key"
        )
        raise InputError(Problem(str(path), why, line=plan.line("strata_key")))
    raise InputError(
        [
            Problem(
                str(path),
                f"{key_path(loc)}: block {u} is in the stratum {key} = '{value}', but "
                f"{_gives(blocks[u], key)}",
                line=plan.line(*loc),
            )
            for loc, u, value in wrong
        ]
    )


def plan_notes(
    plan: Plan,
    path: Path,
    block_ids: list[str],
    batch: str | None,
    rule_pack: str,
    sampling: Sampling | None = None,
    standard: str | None = None,
) -> tuple[list[PlanNote], list[Problem]]:
    """Where the plan differs from the batch inspected (`batch`: its folder's name, None when
    the deliveries were named one by one), from the pack inspecting (`rule_pack`, its
    `standard`: None when it has no acceptance section) or from its sampling table (`sampling`)
    without changing the sample; each also as a warning naming the plan's line. Sampled blocks
    missing are refused before (`check_blocks`)."""
    notes, warnings = _absent(plan, path, block_ids)
    if sampling is not None:
        for note, warning in [
            *_undersized(plan, path, sampling),
            *_not_drawn(plan, path, sampling),
        ]:
            notes.append(note)
            warnings.append(warning)
    named = (
        ("batch", plan.batch, batch),
        ("rule_pack", plan.rule_pack, rule_pack),
        ("standard", plan.standard, standard),
    )
    for about, given, found in named:
        if found is not None and given != found:
            notes.append(PlanNote(about=about, plan=given, inspected=found))
            warnings.append(Problem(str(path), _other(about, given, found), line=plan.line(about)))
    return notes, warnings


def _absent(plan: Plan, path: Path, block_ids: list[str]) -> tuple[list[PlanNote], list[Problem]]:
    """The plan's units that no delivery is (none sampled: a sampled one missing is refused, or
    is a delivery whose block.yaml cannot be read): a note, and a warning for each."""
    ids, sampled = set(block_ids), set(plan.sampled)
    absent = [(loc, u) for loc, u, _ in _placed(plan) if u not in ids and u not in sampled]
    if not absent:
        return [], []
    note = PlanNote(
        about="units",
        plan=str(plan.units),
        inspected=str(len(ids)),
        blocks=[u for _, u in absent],
    )
    warnings = [
        Problem(
            str(path),
            f"{key_path(loc)}: no delivery of the batch is block {u}, a unit of the plan "
            "(a delivery withdrawn after sampling?); it is not sampled: the sample stands",
            line=plan.line(*loc),
        )
        for loc, u in absent
    ]
    return [note], warnings


def _undersized(plan: Plan, path: Path, sampling: Sampling) -> Iterator[tuple[PlanNote, Problem]]:
    """Lots whose sample is smaller than the pack's table asks for their size (§QE-1): a plan
    edited by hand, or drawn with another table. The sample is judged as drawn, and this said."""
    for i, lot in enumerate(plan.lots):
        if lot.size < 1:
            continue
        wanted, split = _wanted(lot.size, sampling)
        drawn = len(lot.sampled)
        if drawn < wanted:
            yield (
                PlanNote(about="sample_size", plan=str(drawn), inspected=str(wanted)),
                Problem(
                    str(path),
                    f"lots[{i}]: {drawn} of the lot's {lot.size} units sampled; the pack's "
                    f"table (§QE-1) asks {wanted}{split}: the batch is judged on the smaller "
                    "sample",
                    line=plan.line("lots", i, "sampled"),
                ),
            )


def _not_drawn(plan: Plan, path: Path, sampling: Sampling) -> list[tuple[PlanNote, Problem]]:
    """Blocks sampled that the plan's seed does not draw from its units (and strata) by the
    pack's table: a plan edited by hand (a block sampled swapped for another), or drawn with
    another table. The sample is judged as the plan gives it, and this said."""
    units = [u for lot in plan.lots for s in lot.strata for u in s.units]
    if not units:
        return []
    strata = {u: s.value for lot in plan.lots for s in lot.strata for u in s.units}
    lots = draw(units, sampling, plan.seed, strata if plan.strata_key else None)
    drawn = sorted((u for lot in lots for u in lot.sampled), key=natural_key)
    other = [u for u in plan.sampled if u not in drawn]
    if not other:  # the seed's sample, or part of it (a lot below the table: said apart)
        return []
    note = PlanNote(about="seed", plan=str(plan.seed), inspected=listed(drawn), blocks=other)
    why = (
        f"sampled: the plan's seed {plan.seed} draws {listed(drawn)} from its {len(units)} "
        f"units by the pack's table (§QE-1); the plan samples {listed(plan.sampled)} (edited "
        "by hand, or drawn with another table): the batch is judged on the plan's sample"
    )
    return [(note, Problem(str(path), why, line=plan.line("sampled")))]


def _wanted(size: int, sampling: Sampling) -> tuple[int, str]:
    """The sample the pack's table asks of a lot; one above its largest batch, split as
    `blockqc sample` splits a batch, asks each part's (said)."""
    parts = split_sizes(size, sampling.max_batch)
    wanted = sum(sample_size(n, sampling) for n in parts)
    if len(parts) == 1:
        return wanted, ""
    sizes = ", ".join(str(n) for n in parts)
    return wanted, (
        f" (the lot is above its largest batch, {sampling.max_batch}: it splits it into "
        f"{len(parts)} lots of {sizes})"
    )


def _other(about: str, given: str, found: str) -> str:
    if about == "batch":
        return f"batch: the plan was drawn from batch '{given}'; the batch inspected is '{found}'"
    if about == "standard":
        return f"standard: the plan was drawn under {given}; the batch is judged under {found}"
    return f"rule_pack: the plan was drawn with {given}; the batch is inspected with {found}"
