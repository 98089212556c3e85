"""A small whitelisted evaluator for threshold expressions such as `2*sqrt(2)*norm.plane_m`.

Only numbers, names of the pack's constants (dotted), + - * / ** and the functions listed in
FUNCTIONS are allowed; anything else is refused with a message. Python's `eval` is never used.
"""

from __future__ import annotations

import ast
import difflib
import math
import operator
import re
import warnings
from collections.abc import Callable, Mapping
from typing import Any

FUNCTIONS: dict[str, Callable[..., float]] = {
    "sqrt": math.sqrt,
    "abs": abs,
    "min": min,
    "max": max,
    "round": round,
}
_BINARY: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[Any], Any]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}

#: bounds checked before anything is evaluated: a threshold is a short formula, not a program
MAX_LENGTH = 200  # characters
MAX_NODES = 100  # syntax-tree nodes
MAX_DEPTH = 24  # nesting of operations and calls
MAX_MAGNITUDE = 1e12  # |literal| and |result|
MAX_EXPONENT = 64.0  # |b| in a ** b


class ExpressionError(ValueError):
    """An expression that is malformed, refers to an unknown name or uses what is not allowed."""


class EvaluationError(ExpressionError):
    """A well-formed expression whose value cannot be computed from the values it was given
    (a division by zero, a result not finite, the square root of a negative number)."""


def _dotted(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value)
        return f"{base}.{node.attr}" if base else None
    return None


def lookup(name: str, constants: Mapping[str, Any]) -> Any:
    """Resolve a dotted name (`norm.plane_m`) in nested constants."""
    node: Any = constants
    for part in name.split("."):
        if not isinstance(node, Mapping) or part not in node:
            names = sorted(flatten(constants))
            close = difflib.get_close_matches(name, names, n=1, cutoff=0.6)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise ExpressionError(
                f"unknown constant '{name}'{hint} (known: {', '.join(names) or 'none'})"
            )
        node = node[part]
    return node


def flatten(constants: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested constants as dotted names."""
    out: dict[str, Any] = {}
    for k, v in constants.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def evaluate(expression: Any, constants: Mapping[str, Any]) -> Any:
    """Evaluate a number, a boolean, a string, a list, or an arithmetic expression in a string."""
    if isinstance(expression, bool) or expression is None:
        return expression
    if isinstance(expression, (int, float)):
        return _bounded(float(expression), repr(expression))
    if isinstance(expression, list):
        return [evaluate(e, constants) for e in expression]
    if not isinstance(expression, str):
        raise ExpressionError(f"cannot evaluate a {type(expression).__name__}")
    tree = parse(expression)
    name = _dotted(tree.body)
    if name is not None:  # a bare constant may also stand for a list of numbers
        value = lookup(name, constants)
        if isinstance(value, list) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        ):
            return [float(v) for v in value]
    return _eval(tree.body, constants, expression)


def _short(text: str) -> str:
    return repr(text if len(text) <= 60 else text[:57] + "...")


def _bounded(value: float, text: str) -> float:
    """A finite number of sane magnitude, or an ExpressionError."""
    if not math.isfinite(value) or abs(value) > MAX_MAGNITUDE:
        raise EvaluationError(
            f"cannot evaluate {_short(text)}: {value:g} is not a finite number of magnitude "
            f"at most {MAX_MAGNITUDE:g}"
        )
    return value


def _depth(node: ast.AST) -> int:
    """Nesting depth of a tree (iterative: a deep tree must not exhaust the stack)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        n, d = stack.pop()
        deepest = max(deepest, d)
        if deepest > MAX_DEPTH:
            return deepest
        stack.extend((c, d + 1) for c in ast.iter_child_nodes(n))
    return deepest


#: a number followed by a unit (`0.5 px`, `10m`, `5 %`), as thresholds are written in prose
WITH_UNIT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*(px|pixels?|m|cm|mm|km|%|deg|°)")


def syntax_tree(text: str) -> ast.Expression:
    """`ast.parse` of an expression; what Python only warns about (`1if x else 2`, an invalid
    escape) is refused as the SyntaxError it announces, never printed to the user."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", SyntaxWarning)
        return ast.parse(text, mode="eval")


def parse(expression: str) -> ast.Expression:
    """Parse an expression after bounding its length, then its size and depth."""
    text = expression.strip()
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"expression {_short(text)} is {len(text)} characters long (at most {MAX_LENGTH})"
        )
    try:
        tree = syntax_tree(text)
    except (SyntaxError, ValueError) as exc:
        msg = getattr(exc, "msg", str(exc))
        if WITH_UNIT.fullmatch(text):
            msg += "; write the number alone: the rule's `unit` gives its unit"
        raise ExpressionError(f"malformed expression {_short(text)}: {msg}") from None
    except (RecursionError, MemoryError):
        raise ExpressionError(f"expression {_short(text)} is nested too deeply") from None
    nodes = sum(1 for _ in ast.walk(tree))
    if nodes > MAX_NODES:
        raise ExpressionError(
            f"expression {_short(text)} has {nodes} terms and operators (at most {MAX_NODES})"
        )
    if _depth(tree) > MAX_DEPTH:
        raise ExpressionError(
            f"expression {_short(text)} is nested more than {MAX_DEPTH} levels deep"
        )
    return tree


def _eval(node: ast.AST, constants: Mapping[str, Any], text: str) -> Any:
    if (
        isinstance(node, ast.Constant)
        and isinstance(node.value, (int, float))
        and not isinstance(node.value, bool)
    ):
        if isinstance(node.value, int) and abs(node.value) > MAX_MAGNITUDE:
            raise ExpressionError(
                f"cannot evaluate {_short(text)}: a literal beyond ±{MAX_MAGNITUDE:g}"
            )
        return _bounded(float(node.value), text)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _binary(node, constants, text)
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_eval(node.operand, constants, text))
    if isinstance(node, ast.Call):
        return _call(node, constants, text)
    name = _dotted(node)
    if name is not None:
        value = lookup(name, constants)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ExpressionError(f"constant '{name}' in {_short(text)} is not a number")
        return _bounded(float(value), text)
    raise ExpressionError(
        f"'{ast.unparse(node)}' is not allowed in {text!r}: use numbers, constants, + - * / ** "
        f"and {', '.join(sorted(FUNCTIONS))}()"
    )


def _binary(node: ast.BinOp, constants: Mapping[str, Any], text: str) -> float:
    """An arithmetic operation of two values: a power beyond MAX_EXPONENT, or one that is no
    real number, refused."""
    left, right = _eval(node.left, constants, text), _eval(node.right, constants, text)
    if isinstance(node.op, ast.Pow) and abs(right) > MAX_EXPONENT:
        raise EvaluationError(
            f"cannot evaluate {_short(text)}: exponent {right:g} beyond ±{MAX_EXPONENT:g}"
        )
    if isinstance(node.op, ast.Pow) and left < 0 and not float(right).is_integer():
        raise EvaluationError(
            f"cannot evaluate {_short(text)}: ({left:g}) ** {right:g}, a negative number to a "
            "fractional power, is not a real number"
        )
    try:
        return _bounded(float(_BINARY[type(node.op)](left, right)), text)
    except (ZeroDivisionError, OverflowError, TypeError) as exc:
        raise EvaluationError(f"cannot evaluate {_short(text)}: {exc}") from None


def _call(node: ast.Call, constants: Mapping[str, Any], text: str) -> float:
    """A call of one of FUNCTIONS, its arguments counted (no other function, no keywords)."""
    name = _dotted(node.func)
    if name not in FUNCTIONS or node.keywords:
        allowed = ", ".join(sorted(FUNCTIONS))
        raise ExpressionError(
            f"function '{name or ast.unparse(node.func)}' is not allowed in {text!r} "
            f"(allowed: {allowed})"
        )
    args = [_eval(a, constants, text) for a in node.args]
    _check_arguments(name, args, text)
    if name == "round" and len(args) == 2:  # decimal places: a whole number to Python
        args[1] = int(args[1])
    try:
        return _bounded(float(FUNCTIONS[name](*args)), text)
    except EvaluationError:
        raise
    except (ValueError, OverflowError) as exc:  # sqrt(-1): the values, not the writing
        raise EvaluationError(f"cannot evaluate {text!r}: {exc}") from None


#: how many arguments each function takes (least, most; None: no limit)
ARITY: dict[str, tuple[int, int | None]] = {
    "sqrt": (1, 1),
    "abs": (1, 1),
    "min": (2, None),
    "max": (2, None),
    "round": (1, 2),
}


def _check_arguments(name: str, args: list[Any], text: str) -> None:
    """The number of a function's arguments, and round's digits a whole number: the writing,
    refused in words rather than Python's ('float' object is not iterable)."""
    least, most = ARITY[name]
    if len(args) < least or (most is not None and len(args) > most):
        want = {
            (1, 1): "one number",
            (2, None): "two or more numbers",
            (1, 2): "a number and optionally its decimal places",
        }[(least, most)]
        raise ExpressionError(
            f"cannot evaluate {_short(text)}: {name}() takes {want}, got {len(args)}"
        )
    if name == "round" and len(args) == 2 and not float(args[1]).is_integer():
        raise ExpressionError(
            f"cannot evaluate {_short(text)}: round()'s decimal places must be a whole number, "
            f"got {args[1]:g}"
        )


def _wants_number(annotation: Any) -> bool:
    """Whether a pydantic field annotation takes numbers (so strings in it are expressions)."""
    import types
    import typing

    if annotation in (float, int):
        return True
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        return str not in args and any(_wants_number(a) for a in args if a is not type(None))
    if origin in (dict, Mapping) or (origin is not None and str(origin).endswith("Mapping'>")):
        return len(args) == 2 and _wants_number(args[1])
    if origin in (list, tuple):
        return any(_wants_number(a) for a in args if a is not Ellipsis)
    return False


def _numbers(value: Any, constants: Mapping[str, Any]) -> Any:
    if isinstance(value, str):
        return evaluate(value, constants)
    if isinstance(value, Mapping):
        return {k: _numbers(v, constants) for k, v in value.items()}
    if isinstance(value, list):
        return [_numbers(v, constants) for v in value]
    return value


def constant_defaults(
    model: Any, raw: Mapping[str, Any], constants: Mapping[str, Any]
) -> dict[str, str]:
    """The parameters a rule leaves out that take a constant of the pack (the model's
    `CONSTANTS`, e.g. plane_norm_m: norm.plane_m), by name, for those the pack sets in the
    parameter's shape (a list for a list; a number else)."""
    import typing

    known = flatten(constants)
    out = {}
    for key, name in getattr(model, "CONSTANTS", {}).items():
        listed = typing.get_origin(model.model_fields[key].annotation) in (list, tuple)
        if key not in raw and name in known and isinstance(known[name], list) == listed:
            out[key] = name
    return out


def resolve_params(model: Any, raw: Mapping[str, Any], constants: Mapping[str, Any]) -> Any:
    """Validate a metric's parameters, evaluating expressions in the fields that take numbers;
    a parameter left out that stands for a constant the pack sets takes it (`CONSTANTS`)."""
    raw = {**constant_defaults(model, raw, constants), **raw}
    data = {}
    for key, value in raw.items():
        field = model.model_fields.get(key)
        data[key] = (
            _numbers(value, constants) if field and _wants_number(field.annotation) else value
        )
    return model.model_validate(data)
