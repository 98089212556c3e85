"""`blockqc rules …`: list, explain, lint and test rule packs; the metrics they may use."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from blockqc.cli import OnceGroup
from blockqc.errors import RuleError
from blockqc.rules.model import Pack, Rule


@click.group("rules", cls=OnceGroup)
def command() -> None:
    """List, explain, lint and test rule packs; list the metrics rules may use."""


def _pack_option(f):
    return click.option(
        "--rules",
        "rules_ref",
        default="global-project",
        show_default=True,
        help="Stock rule pack name or a rule pack file.",
    )(f)


def _delivery_named(expr: Any) -> bool:
    """Whether an expression names a value the delivery supplies (e.g. gsd.ms)."""
    from blockqc.rules.lint import delivery_named

    return delivery_named(expr)


def threshold_text(rule: Rule, constants: dict[str, Any]) -> str:
    """Thresholds evaluated over the pack's constants; those naming delivery values as written."""
    from blockqc.engine import bounds

    parts = []
    for group, th in rule.all_thresholds().items():
        if any(_delivery_named(e) for e in (th.min, th.max)):
            text = th.describe(th.min, th.max)
        else:
            text = th.describe(*bounds(th, constants))
        if rule.unit and th.equals is None and th.in_ is None:
            text = f"{text} {rule.unit}"
        parts.append(f"{group}: {text}" if group else text)
    return "; ".join(parts) or "inspector's verdict"


def _written(rule: Rule) -> str:
    """Thresholds as written in the pack (expressions not evaluated)."""
    parts = []
    for group, th in rule.all_thresholds().items():
        exprs = [f"{k}: {getattr(th, k)}" for k in ("min", "max") if getattr(th, k) is not None]
        if exprs:
            parts.append(f"{group + ' ' if group else ''}{', '.join(exprs)}")
    return "; ".join(parts)


@command.command("list")
@_pack_option
@click.option("--markdown", is_flag=True, help="Print a Markdown table (for the docs).")
def rules_list(rules_ref: str, markdown: bool) -> None:
    """List the rules of a pack with their thresholds, units and whether they are waivable."""
    from blockqc.rules import load_pack

    pack = load_pack(rules_ref)
    if markdown:
        click.echo(f"# Rule pack `{pack.name}` {pack.version}\n\n{pack.description.strip()}\n")
        click.echo("| id | clause | title | measured | threshold | unit | severity | waivable |")
        click.echo("| --- | --- | --- | --- | --- | --- | --- | --- |")
    else:
        click.echo(f"{'id':7} {'clause':8} {'sev.':5} {'waiv.':5} {'threshold':34} title")
    for r in pack.rules:
        what = f"{r.metric}.{r.scope}.{r.statistic}" if not r.manual else "manual"
        th = threshold_text(r, pack.constants)
        waiv = "yes" if r.waivable else "no"
        if markdown:
            cells = [r.id, r.clause, r.title, f"`{what}`", th, r.unit or "-", r.severity, waiv]
            click.echo("| " + " | ".join(map(_cell, cells)) + " |")
        else:
            click.echo(f"{r.id:7} {r.clause:8} {r.severity:5} {waiv:5} {th:34} {r.title}")
    if pack.disabled and not markdown:
        click.echo(f"disabled: {', '.join(pack.disabled)}")
    if pack.columns == "used" and not markdown:
        from blockqc.engine import tie_point_columns

        read = ", ".join(sorted(tie_point_columns(pack) or ["every column"]))
        click.echo(f"tie-point columns read (columns: used): {read}")


def _cell(text: str) -> str:
    """A Markdown table cell: a `|` of the text (a title's |Δ|) escaped, not a column's end."""
    return text.replace("|", "\\|")


def _find(pack: Pack, rule_id: str, rules_ref: str) -> Rule:
    from blockqc.rules.lint import did_you_mean

    rule_id = rule_id.strip()  # ' TP-1' as pasted from a table is TP-1, as tp-1 is
    try:
        return pack.rule(rule_id)
    except KeyError:
        ids = [x.id for x in pack.rules]
        if not rule_id:
            raise RuleError(f"no rule id given (rules: {', '.join(ids)})", file=rules_ref) from None
        off = [d for d in pack.disabled if d.upper() == rule_id.upper()]
        why = f": {off[0]} is disabled by the pack" if off else did_you_mean(rule_id, ids)
        raise RuleError(
            f"no rule {rule_id} in pack {pack.name}{why} (rules: {', '.join(ids)})",
            file=rules_ref,
        ) from None


def _history_lines(pack: Pack, rule: Rule) -> list[str]:
    """Where the rule is defined, and what each overriding pack changed."""
    hist = pack.history.get(rule.id) or [(*pack.origin.get(rule.id, ("", None)), {})]
    file, line, _ = hist[0]
    out = [f"  defined:   {file}, line {line}"]
    for f, ln, fields in hist[1:]:
        changed = ", ".join(f"{k} {v}" if not isinstance(v, dict) else k for k, v in fields.items())
        out.append(f"  overridden in {f}, line {ln}: {changed}")
    return out


@command.command("explain")
@click.argument("rule_id")
@_pack_option
def rules_explain(rule_id: str, rules_ref: str) -> None:
    """Explain one rule as the pack sets it (overrides applied); the id is case-insensitive."""
    from blockqc.metrics import REGISTRY
    from blockqc.rules import load_pack

    pack = load_pack(rules_ref)
    r = _find(pack, rule_id, rules_ref)
    click.echo(f"{r.id} — {r.title}")
    click.echo(f"  implements {r.clause} (DOMAIN.md)")
    click.echo(f"  pack:      {pack.name} {pack.version}")
    for text in _history_lines(pack, r):
        click.echo(text)
    effect = "a failure fails the block" if r.severity == "fail" else "a failure only warns"
    waiv = "the inspector may waive it" if r.waivable else "not waivable"
    click.echo(f"  severity:  {r.severity} ({effect}); {waiv}")
    if pack.acceptance is not None:
        cls = r.error_class or pack.acceptance.default_error_class
        scored = "by deduction"
        if r.score is not None and r.score.kind == "accuracy":
            scored = f"as accuracy against {r.score.norm or 'its upper bound'} (§QE-3)"
        click.echo(f"  class:     {cls} (§QE-2), scored {scored}")
    if r.manual:
        click.echo("  judged by: the inspector's verdict (--verdicts file)")
    else:
        spec = REGISTRY[r.metric]
        unit = spec.scopes[r.scope].statistics.get(r.statistic or "", "")
        click.echo(f"  measures:  {r.metric} — {spec.description}")
        click.echo(
            f"  judges:    the {r.statistic} at scope {r.scope}"
            + (f" ({unit})" if unit else "")
            + (f"; where {dict(r.where)}" if r.where else "")
        )
        if r.params:
            click.echo(f"  params:    {dict(r.params)}")
        click.echo(f"  threshold: {threshold_text(r, pack.constants)}")
        if _written(r):
            click.echo(f"             as written: {_written(r)}")
    if r.description:
        hist = pack.history.get(r.id, [])
        note = ""
        if len(hist) > 1:
            note = f" (as written in {Path(hist[0][0]).name}, before the overrides above)"
        click.echo(f"\n  description{note}:")
        click.echo(click.wrap_text(r.description.strip(), 96, "  ", "  "))


@command.command("lint")
@click.argument("packs", nargs=-1)
def rules_lint(packs: tuple[str, ...]) -> int:
    """Check rule packs and their cases (default: every stock pack); exit 2 listing every
    problem with its file and line."""
    from blockqc.rules import available_packs
    from blockqc.rules.lint import lint, untranslated_titles

    problems = []
    for ref in packs or available_packs():
        pack, found = lint(ref)
        problems.extend(found)
        for note in [*pack.notes, *untranslated_titles(pack)] if pack is not None else []:
            click.echo(f"warning: {note}", err=True)
        if pack is not None and not found:
            click.echo(f"{ref}: {len(pack.rules)} rules, ok")
    if problems:
        raise RuleError(problems)
    return 0


@command.command("test")
@click.argument("pack_ref", metavar="[PACK]", default="global-project")
@click.option("--own", is_flag=True, help="Only the pack's own cases, not its parents'.")
def rules_test(pack_ref: str, own: bool) -> int:
    """Run the pass/fail cases beside a pack (PACK.cases/RULE.yaml; default: global-project)
    and the packs it extends; exit 1 when a case fails, 2 when a case file is broken."""
    from blockqc.rules import load_pack
    from blockqc.rules.cases import run_pack_cases

    pack = load_pack(pack_ref)
    outcomes = run_pack_cases(pack, own_only=own)
    for o in outcomes:
        mark = click.style("pass", fg="green") if o.ok else click.style("FAIL", fg="red")
        mark = click.style("skip", fg="yellow") if o.skipped else mark
        click.echo(f"{mark}  {o.rule:8} {o.name}")
        if not o.ok or o.skipped:
            click.echo(f"      {o.file}, line {o.line}: {o.message}")
    failed = sum(not o.ok for o in outcomes)
    skipped = sum(o.skipped for o in outcomes)
    run = len(outcomes) - skipped
    more = f", {skipped} not run (their rule disabled)" if skipped else ""
    click.echo(f"{run} cases, {failed} failed{more}")
    return 1 if failed else 0


@command.command("metrics")
@click.option("--markdown", is_flag=True, help="Print the Markdown reference (docs/metrics.md).")
def rules_metrics(markdown: bool) -> None:
    """The metrics rules may use: scopes, statistics with units, parameters, groups, columns."""
    from blockqc.metrics.reference import markdown_reference, text_reference

    click.echo(markdown_reference() if markdown else text_reference(), nl=False)
