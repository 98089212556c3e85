"""From a block's results to its §QE findings and evaluation, with the pack that judged them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from blockqc.acceptance.model import Evaluation
from blockqc.acceptance.scoring import JUDGED, Finding, evaluate_block
from blockqc.engine import MissingGSD
from blockqc.report.messages import translator
from blockqc.results import BlockResults, RuleResult
from blockqc.rules.expr import ExpressionError, evaluate
from blockqc.rules.model import Pack, Rule

EN = translator("en")


def _places(res: RuleResult, tree: dict[str, tuple[str, str]]) -> tuple[tuple[str, str], ...]:
    """(element, item) of every content the result decides; else every item of its element (a
    rule placed by `quality_element` alone decides the element: its errors count in each of its
    items, as a content's count in its item)."""
    got = {tree[c] for c in res.content if c in tree}
    if not got and res.quality_element:
        got = {place for place in tree.values() if place[0] == res.quality_element}
    return tuple(sorted(got))


def _norm(rule: Rule, res: RuleResult, names: Mapping[str, Any]) -> float | None:
    """The norm m0 of a mathematical-accuracy result: the rule's `score.norm`, else its bound
    (of a range [min, max], the upper: an error is never accurate for being small).
    ExpressionError when the norm cannot be computed (it names a GSD the delivery lacks)."""
    if rule.score is None or rule.score.kind != "accuracy":
        return None
    if rule.score.norm is not None:  # it may name the delivery's GSD, as thresholds do
        return float(evaluate(rule.score.norm, names))
    th = res.threshold
    if isinstance(th, list | tuple) and len(th) == 2:
        th = th[1]
    return float(th) if isinstance(th, (int, float)) and not isinstance(th, bool) else None


def _norm_problem(exc: ExpressionError, rule: Rule) -> str:
    """Why a result's norm cannot be computed (the catalogue's sentence: pages translate it)."""
    norm = rule.score.norm
    if not isinstance(exc, MissingGSD):
        return EN("qe_norm_problem", norm=norm, problem=exc)
    return EN("qe_norm_no_gsd", band=exc.band, norm=norm, upper=exc.band.upper())


def findings(
    results: BlockResults,
    pack: Pack,
    names: Mapping[str, Any] | None = None,
    unscored: dict[str, str] | None = None,
) -> list[Finding]:
    """Every result of the block as scoring sees it: places, class, norm (`names`: what a norm
    may name, the pack's constants and the delivery's GSDs; the constants alone by default).
    A judged result whose norm cannot be computed (its `score.norm` names a band the delivery
    gives no GSD for: known only with the delivery, lint takes every band) is left unscored,
    and why is put in `unscored`, once per rule."""
    assert pack.acceptance is not None
    tree = {c.id: (e.id, i.id) for e in results.elements for i in e.items for c in i.contents}
    rules = {r.id: r for r in pack.rules}
    names = pack.constants if names is None else names
    out = []
    for res in results.results:
        rule = rules.get(res.rule)
        if rule is None:
            continue  # a result of a rule the pack no longer has cannot be classed
        try:
            norm = _norm(rule, res, names)
        except ExpressionError as exc:
            norm = None
            if unscored is not None and res.status in JUDGED:
                why = EN("qe_not_scored", rule=res.rule, why=_norm_problem(exc, rule))
                unscored.setdefault(res.rule, why)
        out.append(
            Finding(
                rule=res.rule,
                status=res.status,
                places=_places(res, tree),
                error_class=rule.error_class or pack.acceptance.default_error_class,
                value=res.value,
                threshold=res.threshold,
                norm=norm,
                group=res.group,
                comparison=res.comparison,
                unit=res.unit,
            )
        )
    return out


def incomplete_reasons(results: BlockResults) -> list[str]:
    """Why an evaluation cannot be final: rules not judged, verdicts awaited, plan notes."""
    out = [EN("qe_not_judged", rule=r.rule) for r in results.results if r.status == "error"]
    out += [f"awaiting the inspector's verdict on {rid}" for rid in results.pending_manual]
    out += [
        f"{r.rule}: {r.detail['plan']}"
        for r in results.results
        if r.detail.get("plan_incomplete") and "plan" in r.detail
    ][:1]
    return out


def evaluate_results(
    results: BlockResults, pack: Pack, names: Mapping[str, Any] | None = None
) -> Evaluation | None:
    """§QE-2..5 for one block (None when the pack has no acceptance section)."""
    if pack.acceptance is None:
        return None
    unscored: dict[str, str] = {}
    got = findings(results, pack, names, unscored)
    why = incomplete_reasons(results) + list(unscored.values())
    return evaluate_block(results.elements, got, pack.acceptance, why)
