"""Placeholders in a rule's titles and descriptions, resolved from the pack's constants.

`At least {tp.min_points_per_scene} tie points in every scene` reads "At least 100 …" with the
stock constants and "At least 150 …" in a pack that sets `tp.min_points_per_scene: 150`. A
placeholder is an expression of the threshold language (`{2 * sqrt(2) * norm.plane_m}`), with an
optional format after a colon (`{2 * sqrt(2) * norm.plane_m:.1f}`, default `g`); a list constant
gives its numbers joined by ", ". `{{` and `}}` are literal braces. The texts are resolved when
the pack is loaded, after its overrides, so they may name the pack's constants only.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from decimal import Decimal
from typing import Any

from blockqc.errors import Problem
from blockqc.rules.expr import ExpressionError, evaluate
from blockqc.rules.model import Rule

#: the rule fields whose placeholders are resolved
TEXT_FIELDS = ("title", "title_zh", "description", "description_zh")
#: a literal brace, a placeholder, or a brace left alone
_TOKEN = re.compile(r"\{\{|\}\}|\{([^{}]*)\}|[{}]")
#: the formats a placeholder may ask for: `g`, `.3g`, `.1f`, `d`
_FORMAT = re.compile(r"\.\d{1,2}[fg]|\d{0,2}[dg]")
#: values the delivery supplies, unknown when a pack is loaded
_DELIVERY = ("gsd",)


def placeholders(text: str) -> list[str]:
    """The placeholders of a text, as written between the braces."""
    return [m.group(1) for m in _TOKEN.finditer(text) if m.group(1) is not None]


def render(text: str, constants: Mapping[str, Any]) -> str:
    """The text with each placeholder replaced by its value; ExpressionError when one cannot be."""
    return _TOKEN.sub(lambda m: _token(m, constants), text)


def _token(m: re.Match[str], constants: Mapping[str, Any]) -> str:
    whole, inner = m.group(0), m.group(1)
    if whole in ("{{", "}}"):
        return whole[0]
    if inner is None:
        raise ExpressionError(f"a lone '{whole}': write {whole * 2} for a literal brace")
    expr, _, spec = inner.partition(":")
    return _formatted(_value(expr, inner, constants), spec.strip() or "g", inner)


def _value(expr: str, inner: str, constants: Mapping[str, Any]) -> Any:
    if not expr.strip():
        raise ExpressionError("an empty placeholder {}: name a constant, e.g. {norm.plane_m}")
    if expr.strip().split(".")[0] in _DELIVERY:
        raise ExpressionError(
            f"placeholder {{{inner}}} names a value of the delivery, unknown when the pack is "
            "loaded: name the pack's constants only"
        )
    try:
        return evaluate(expr, constants)
    except ExpressionError as exc:
        raise ExpressionError(f"placeholder {{{inner}}}: {exc}") from None


def _formatted(value: Any, spec: str, inner: str) -> str:
    if not _FORMAT.fullmatch(spec):
        raise ExpressionError(
            f"placeholder {{{inner}}}: unknown format '{spec}' (give .1f, .3g, g or d)"
        )
    values = value if isinstance(value, list) else [value]
    if spec.endswith("d"):
        values = [_whole(v, inner) for v in values]
    return ", ".join(format(v, _precise(v, spec)) for v in values)


def _precise(value: float, spec: str) -> str:
    """The format for one number: as asked, with more digits where the number is a decimal of
    up to six significant digits that the asked precision would round (a constant 0.75 with
    `.1f` reads 0.75, not 0.8: the text must state the number the rule judges by); a number
    with more digits (2·√2·10) is rounded as asked."""
    m = re.fullmatch(r"\.(\d{1,2})([fg])", spec)
    short = format(value, ".6g")
    if not m or abs(float(short) - value) > 1e-9 * max(1.0, abs(value)):
        return spec
    digits = Decimal(short).normalize().as_tuple()
    need = -int(digits.exponent) if m[2] == "f" else len(digits.digits)
    return f".{max(int(m[1]), need)}{m[2]}"


def _whole(value: float, inner: str) -> int:
    """A number `d` writes: a whole one (within a billionth of its magnitude, the rounding of
    a computed value), never a fraction rounded away (1.5 px read as 2 px)."""
    near = round(value)
    if abs(value - near) > 1e-9 * max(1.0, abs(value)):
        raise ExpressionError(
            f"placeholder {{{inner}}}: {value:g} is not a whole number, which format 'd' "
            "writes: give g or .1f"
        )
    return near


def render_rule(
    rule: Rule, constants: Mapping[str, Any], file: str, line: Callable[..., int | None]
) -> tuple[Rule, list[Problem]]:
    """The rule with its texts resolved, and a problem (file, line) for each text that cannot."""
    texts, problems = {}, []
    for key in TEXT_FIELDS:
        try:
            texts[key] = render(getattr(rule, key), constants)
        except ExpressionError as exc:
            problems.append(Problem(file, f"rule {rule.id}: {key}: {exc}", line=line(key)))
    return rule.model_copy(update=texts), problems
