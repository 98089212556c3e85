"""`blockqc sample`: draw the sample of a batch for detailed inspection (§QE-1)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import yaml

from blockqc.acceptance.plan import Plan, make_plan
from blockqc.acceptance.sampling import NUMBER, draw
from blockqc.cli import GivenPath
from blockqc.errors import InputError, Problem, RuleError, UsageError


def lookup(data: dict[str, Any], key: str) -> Any:
    """A dotted key of block.yaml (e.g. `producer` or `terrain.class`); KeyError when absent."""
    value: Any = data
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            raise KeyError(key)
        value = value[part]
    return value


def stratum_of(data: dict[str, Any], key: str) -> str:
    """A block's stratum: the key's value, text or a number; ValueError for anything else."""
    value = lookup(data, key)
    if isinstance(value, str) and not value.strip():
        raise ValueError(f"key '{key}' is blank text: a stratum is text or a number")
    if isinstance(value, (str, int, float)) and not isinstance(value, bool):
        return number_text(value) if isinstance(value, float) else str(value)
    if isinstance(value, dict):
        why = f"a mapping (stratify by one of its keys, e.g. '{key}.{next(iter(value), 'name')}')"
    else:
        why = {bool: "true/false", list: "a list", type(None): "empty"}.get(type(value), "not text")
    raise ValueError(f"key '{key}' is {why}: a stratum is text or a number")


def number_text(value: float) -> str:
    """A number YAML reads with a decimal point, as a stratum: by its value, so that 1.0 is the
    stratum of 1 (a whole number written without its point), 0.80 and 0.8 one stratum."""
    return str(int(value)) if value.is_integer() else str(value)


def read_units(batch: Path, key: str | None) -> tuple[list[str], dict[str, str] | None]:
    """The batch's block ids and, with a key, each block's stratum; every problem at once."""
    from blockqc.batch import collect
    from blockqc.delivery import MANIFEST, load_manifest

    got = collect([batch])
    for d in got.repeated:  # a link to another delivery of the batch: one unit, as inspect says
        click.echo(f"warning: {d}: named more than once, drawn from once", err=True)
    problems = list(got.refused.values())
    strata: dict[str, str] = {}
    values: dict[Path, Any] = {}  # each block.yaml's value of the key, as YAML reads it
    for path in got.deliveries:
        if path in got.refused:
            continue
        if path not in got.manifests:
            try:
                load_manifest(path / MANIFEST)
            except InputError as exc:
                problems += exc.problems
            continue
        m = got.manifests[path]
        if key:
            try:
                given = m.model_dump(mode="json", exclude_unset=True)  # a key left out: absent
                strata[m.block_id] = stratum_of(given, key)
                values[path / MANIFEST] = lookup(given, key)
            except KeyError:
                why = f"no key '{key}' in block.yaml to stratify by{_key_hint(given, key)}"
                problems.append(_key_problem(path / MANIFEST, key.split(".")[:-1], why))
            except ValueError as exc:
                problems.append(_key_problem(path / MANIFEST, key.split("."), str(exc)))
    problems += _number_as_text(key, values)
    if problems:
        raise InputError(problems)
    ids = [got.manifests[p].block_id for p in got.deliveries]
    return ids, strata if key else None


def _key_hint(data: dict[str, Any], key: str) -> str:
    """ "; did you mean 'x'?" for a strata key misspelt (test_feild, gsd_m.PAN): the key of
    block.yaml, at the level where the key is not found, that is close to the part given."""
    from blockqc.schema import closest

    parts = key.split(".")
    value: Any = data
    for i, part in enumerate(parts):
        if not isinstance(value, dict):
            return ""
        if part not in value:
            close = closest([k for k in value if isinstance(k, str)], part)
            if close is None:
                return ""
            return f"; did you mean '{'.'.join([*parts[:i], close, *parts[i + 1 :]])}'?"
        value = value[part]
    return ""


def _number_as_text(key: str, values: dict[Path, Any]) -> list[Problem]:
    """A number written as a number in one block.yaml and as other text in another ('1.0' in
    quotes beside 1 or 1.0): one stratum or two cannot be told, refused at the text's line."""
    numbers: dict[float, tuple[Path, str]] = {}
    for path, v in values.items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            numbers.setdefault(float(v), (path, number_text(v) if isinstance(v, float) else str(v)))
    out = []
    for path, v in values.items():
        if not isinstance(v, str) or not NUMBER.fullmatch(v):
            continue
        other, spelled = numbers.get(float(v), (None, v))
        if other is not None and spelled != v:
            why = (
                f"key '{key}' is the text '{v}', and {other} gives the number {spelled}: one "
                "stratum or two? write them alike (both numbers, or the same text in quotes)"
            )
            out.append(_key_problem(path, key.split("."), why))
    return out


def _key_problem(path: Path, loc: list[str], why: str) -> Problem:
    """A problem of the strata key at the line of `loc` in block.yaml, or of as much of it as is
    there (no line when none of it is)."""
    from blockqc.yamlio import line_of, load_yaml

    data = load_yaml(path)
    while loc and not _has(data, loc):
        loc = loc[:-1]
    return Problem(str(path), why, line=line_of(data, loc) if loc else None)


def _has(data: dict[str, Any], loc: list[str]) -> bool:
    try:
        lookup(data, ".".join(loc))
    except KeyError:
        return False
    return True


def _echo_plan(plan: Plan, out: Path) -> None:
    click.echo(
        f"{plan.units} block{'' if plan.units == 1 else 's'}, {len(plan.lots)} "
        f"lot{'' if len(plan.lots) == 1 else 's'}, {plan.method}: "
        f"sample of {plan.sample_size} — {out}"
    )
    for i, lot in enumerate(plan.lots, 1):
        census = " (every unit)" if lot.census else ""
        units = "unit" if lot.size == 1 else "units"
        click.echo(f"  lot {i}: {lot.size} {units} → {lot.sample_size}{census}")
        for s in lot.strata:
            label = f"{plan.strata_key}={s.value}: " if plan.strata_key else ""
            click.echo(f"    {label}{s.size} → {s.sample}: {', '.join(s.sampled) or '-'}")


def _refuse_under_a_file(out: Path) -> None:
    """A file where the plan's folder would be: named as the plan's file lying under it (the
    folder's own check would name the folder as --out)."""
    real = out.resolve()
    blocker = next((p for p in real.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        raise UsageError(f"--out {out} lies under the file {blocker}: give a folder for the plan")


@click.command("sample")
@click.argument("batch", type=GivenPath("a batch folder"))
@click.option(
    "--seed", required=True, type=click.IntRange(min=0), help="Seed of the random generator."
)
@click.option("--strata", "key", help="block.yaml key to stratify by (e.g. test_field).")
@click.option(
    "--rules", "rules_ref", default="global-project", show_default=True, help="Rule pack."
)
@click.option(
    "--out",
    required=True,
    type=GivenPath(what="the plan's file (plan.yaml)"),
    help="Plan file (YAML).",
)
def command(batch: Path, seed: int, key: str | None, rules_ref: str, out: Path) -> None:
    """Draw the blocks of a batch to inspect in detail (§QE-1) and write the plan."""
    from blockqc.delivery import batch_files
    from blockqc.outputs import check_out_dir, refuse_inside, write_text_atomic
    from blockqc.rules import load_pack

    pack = load_pack(rules_ref)
    if pack.acceptance is None:
        raise RuleError(f"pack {pack.name} has no acceptance section (sampling table)", rules_ref)
    if key is not None and not key.strip():
        raise UsageError(
            f"--strata '{key}': expected a block.yaml key to stratify by (e.g. test_field); "
            "leave --strata out for simple random sampling"
        )
    if out.suffix not in (".yaml", ".yml"):
        raise UsageError(f"--out {out}: the plan is a YAML file (.yaml)")
    refuse_inside(out, [batch])  # before reading; its folder is made once the batch is read
    ids, strata = read_units(batch, key)
    for f in batch_files(batch):  # as inspect says of them: the plan draws from the deliveries
        click.echo(f"warning: {f}: a file beside the deliveries of a batch, not read", err=True)
    _refuse_under_a_file(out)
    check_out_dir(out.parent, [batch])
    lots = draw(ids, pack.acceptance.sampling, seed, strata)
    plan = make_plan(
        lots,
        seed,
        key,
        standard=pack.acceptance.standard,
        rule_pack=f"{pack.name} {pack.version}",
        batch=batch.resolve().name,
    )
    text = "# blockqc sampling plan (§QE-1): inspect with `blockqc inspect BATCH --plan FILE`\n"
    text += yaml.safe_dump(plan.model_dump(mode="json"), sort_keys=False, allow_unicode=True)
    write_text_atomic(out, text)
    _echo_plan(plan, out)
