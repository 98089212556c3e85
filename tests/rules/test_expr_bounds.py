"""Threshold expressions: any text gives a bounded finite number or an ExpressionError."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.rules.expr import MAX_MAGNITUDE, ExpressionError, evaluate

NAMES = {"norm": {"plane_m": 10.0, "height_m": 6.0}, "tp": {"interval": [1.0, 1.5]}}
ALPHABET = "0123456789.e+-*/() ,abdgilmnoqrstux_"
TOKENS = ["sqrt(", "abs(", "min(", "max(", "round(", "norm.plane_m", "tp.interval", "**", "1e308"]


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(st.sampled_from(TOKENS), st.text(ALPHABET, max_size=4)), max_size=80))
def test_any_text_is_a_bounded_number_or_a_message(parts: list[str]) -> None:
    text = "".join(parts)
    try:
        value = evaluate(text, NAMES)
    except ExpressionError:
        return
    values = value if isinstance(value, list) else [value]
    assert all(math.isfinite(v) and abs(v) <= MAX_MAGNITUDE for v in values), (text, value)


@settings(max_examples=100, deadline=None)
@given(st.integers(min_value=1, max_value=5000))
def test_nesting_of_any_depth_is_refused_not_crashing(depth: int) -> None:
    for text in (
        "(" * depth + "1" + ")" * depth,
        "-" * depth + "1",
        "sqrt(" * depth + "4" + ")" * depth,
    ):
        try:
            evaluate(text, NAMES)
        except ExpressionError:
            continue


def test_what_python_only_warns_about_is_a_message_not_a_printed_warning(recwarn) -> None:
    """`1if 1 else 2` parses in Python with a SyntaxWarning on stderr; an expression of a pack
    is refused with the message instead, and nothing is printed."""
    import pytest

    with pytest.raises(
        ExpressionError, match=r"malformed expression '1if 1 else 2': invalid decimal"
    ):
        evaluate("1if 1 else 2", {})
    assert not [w for w in recwarn if issubclass(w.category, SyntaxWarning)]


def test_a_number_with_its_unit_is_told_to_drop_the_unit() -> None:
    import pytest

    for text in ("0.5 px", "10m", "5 %", "-1.5e-1 pixels"):
        with pytest.raises(ExpressionError) as exc:
            evaluate(text, NAMES)
        assert str(exc.value).endswith(
            "; write the number alone: the rule's `unit` gives its unit"
        ), exc.value
    with pytest.raises(ExpressionError) as exc:
        evaluate("norm.plane_m m", NAMES)  # not a number with a unit: no such hint
    assert "unit" not in str(exc.value)


def test_round_to_decimal_places() -> None:
    # round(x, 1) was refused whatever x: "'float' object cannot be interpreted as an integer"
    assert evaluate("round(2 * sqrt(2) * norm.plane_m, 1)", NAMES) == 28.3
    assert evaluate("round(1234.5, -2)", NAMES) == 1200.0
    assert evaluate("round(norm.plane_m / 3)", NAMES) == 3.0


def test_a_function_given_the_wrong_arguments_is_refused_in_words() -> None:
    import pytest

    cases = {
        "max(norm.plane_m)": "max() takes two or more numbers, got 1",
        "min()": "min() takes two or more numbers, got 0",
        "sqrt(norm.plane_m, 2)": "sqrt() takes one number, got 2",
        "abs()": "abs() takes one number, got 0",
        "round(1, 2, 3)": "round() takes a number and optionally its decimal places, got 3",
        "round(norm.plane_m, 1.5)": "round()'s decimal places must be a whole number, got 1.5",
    }
    for text, why in cases.items():
        with pytest.raises(ExpressionError) as exc:
            evaluate(text, NAMES)
        assert str(exc.value) == f"cannot evaluate '{text}': {why}"


def test_a_negative_number_to_a_fractional_power_is_refused_in_words() -> None:
    import pytest

    from blockqc.rules.expr import EvaluationError

    with pytest.raises(EvaluationError) as exc:
        evaluate("(norm.plane_m - 20) ** 0.5", NAMES)
    assert str(exc.value) == (
        "cannot evaluate '(norm.plane_m - 20) ** 0.5': (-10) ** 0.5, a negative number to a "
        "fractional power, is not a real number"
    )
    assert evaluate("(norm.plane_m - 20) ** 2", NAMES) == 100.0
