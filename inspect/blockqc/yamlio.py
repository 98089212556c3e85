"""Safe YAML reading that remembers line numbers, so every error can name its line."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path
from types import UnionType
from typing import Annotated, Any, Union, get_args, get_origin

import yaml
from pydantic import AfterValidator, BaseModel

from blockqc.errors import BlockqcError, InputError, Problem
from blockqc.textio import read_text


class LineDict(dict):
    """A mapping read from YAML: `line` is where it starts, `key_lines` where each key stands."""

    line: int = 0
    key_lines: dict[Any, int]


class LineList(list):
    """A sequence read from YAML: `line` is where it starts, `item_lines` where each item starts."""

    line: int = 0
    item_lines: list[int]


def _not_blank(value: str) -> str:
    if not value.strip():
        raise ValueError("expected a text, got a blank one")
    return value


#: a text a YAML file must give (a title, a name): blank (empty or spaces only) is refused
Text = Annotated[str, AfterValidator(_not_blank)]


_BaseLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's parser when built in

#: YAML inputs (block.yaml, verdicts, rule packs) larger than this are refused unread
MAX_YAML_BYTES = 2 * 2**20
#: deepest nesting of mappings and sequences accepted (the contract needs fewer than ten)
MAX_YAML_DEPTH = 64
#: most values a document may expand to once its aliases are followed
MAX_YAML_VALUES = 1_000_000


class _Loader(_BaseLoader):  # type: ignore[misc, valid-type]
    """A safe loader (no Python tags) that builds LineDict/LineList and refuses duplicate keys;
    `unlike_written` gathers the numbers it reads otherwise than their digits say."""

    unlike_written: list[tuple[int, str]]


#: a number YAML 1.1 reads otherwise than its digits say in decimal: octal (010 is 8),
#: hexadecimal, binary, with underscores (1_0 is 10) or sexagesimal (1:30 is 90)
OTHER_NUMBER = re.compile(r"[-+]?(0[0-9]+|0[xob].*|.*_.*|.*:.*)")
_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")


def _unlike_written(loader: _Loader, node: yaml.Node, value: Any, where: str) -> None:
    """Note a scalar YAML reads as a number other than its digits say (`epsg: 032637` is the
    octal 13727), with its line: refused once the file is read, every one named."""
    if node.tag not in _NUMBER_TAGS or not OTHER_NUMBER.fullmatch(node.value):
        return
    loader.unlike_written.append(
        (
            node.start_mark.line + 1,
            f"{where} is written {node.value}, which YAML reads as the number {value}: write the "
            f"number in decimal digits, or in quotes ('{node.value}') to keep it as text",
        )
    )


def _mapping(loader: _Loader, node: yaml.MappingNode) -> LineDict:
    """A mapping; a key written twice is refused, but a key of its own overrides one merged
    in (`<<: *base` then `id: PR-2`), as YAML's merge keys have it."""
    explicit = sum(k.tag != "tag:yaml.org,2002:merge" for k, _ in node.value)
    loader.flatten_mapping(node)  # the merged pairs first, then the mapping's own
    merged = len(node.value) - explicit
    out = LineDict()
    out.line = node.start_mark.line + 1
    out.key_lines = {}
    own: set[Any] = set()
    for i, (key_node, value_node) in enumerate(node.value):
        key = loader.construct_object(key_node, deep=True)
        if not isinstance(key, (str, int, float, bool)) and key is not None:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"a mapping key must be a plain value (text or a number), got {yaml_kind(key)}",
                key_node.start_mark,
            )
        if i >= merged and key in own:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"duplicate key '{key}' (first on line {out.key_lines[key]})",
                key_node.start_mark,
            )
        own |= {key} if i >= merged else set()
        out[key] = loader.construct_object(value_node, deep=True)
        _unlike_written(loader, value_node, out[key], f"key '{key}'")
        out.key_lines[key] = key_node.start_mark.line + 1
    return out


def _sequence(loader: _Loader, node: yaml.SequenceNode) -> LineList:
    out = LineList(loader.construct_object(child, deep=True) for child in node.value)
    for i, (child, value) in enumerate(zip(node.value, out, strict=True)):
        _unlike_written(loader, child, value, f"item {i + 1} of a list")
    out.line = node.start_mark.line + 1
    out.item_lines = [child.start_mark.line + 1 for child in node.value]
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _sequence)
# numbers in exponent form without a decimal point or an exponent sign (5e-1, 1.5e3, 2E+2),
# which YAML 1.1 reads as text and YAML 1.2 (and JSON) as numbers: read as numbers
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def _scan(text: str) -> tuple[int, str] | None:
    """Walk the parser's events (no recursion, nothing built): too deep, or aliases expanding
    to too many values (an alias bomb), gives the line and the problem; else None."""
    sizes: dict[str, int] = {}
    stack: list[list] = [[None, 0]]  # per open collection: [anchor, values so far]
    for ev in yaml.parse(text, Loader=_BaseLoader):
        if isinstance(ev, yaml.CollectionStartEvent):
            stack.append([ev.anchor, 1])
            if len(stack) - 1 > MAX_YAML_DEPTH:
                return ev.start_mark.line + 1, f"nested deeper than {MAX_YAML_DEPTH} levels"
            continue
        if isinstance(ev, yaml.CollectionEndEvent):
            anchor, n = stack.pop()
        elif isinstance(ev, yaml.ScalarEvent):
            anchor, n = ev.anchor, 1
        elif isinstance(ev, yaml.AliasEvent):
            anchor, n = None, sizes.get(ev.anchor, 1)
        else:
            continue
        if anchor is not None:
            sizes[anchor] = n
        stack[-1][1] += n
        if stack[-1][1] > MAX_YAML_VALUES:
            return ev.start_mark.line + 1, (
                f"aliases expand to more than {MAX_YAML_VALUES:,} values: refused unexpanded"
            )
    return None


def load_yaml(path: Path, error: type[BlockqcError] = InputError) -> Any:
    """Read one YAML document safely; syntax errors and unsafe tags name the file and line."""
    text = read_text(path, MAX_YAML_BYTES, error)
    try:
        bad = _scan(text)
        if bad is not None:
            raise error(Problem(str(path), f"not accepted: {bad[1]}", line=bad[0]))
        loader = _Loader(text)  # a safe loader: no tag can build a Python object
        loader.unlike_written = []
        try:
            data = loader.get_single_data()
        finally:
            loader.dispose()
        if loader.unlike_written:
            raise error([Problem(str(path), why, line=at) for at, why in loader.unlike_written])
        return data
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        what = exc.problem or str(exc)
        if "nesting depth" in what:  # PyYAML's own limit (6.0.4 on), met before blockqc's
            raise error(
                Problem(
                    str(path),
                    f"not accepted: nested deeper than {MAX_YAML_DEPTH} levels",
                    line=line,
                )
            ) from None
        what = _hinted(what, text, mark)
        raise error(Problem(str(path), f"not valid YAML: {what}", line=line)) from None
    except yaml.YAMLError as exc:
        raise error(Problem(str(path), f"not valid YAML: {exc}")) from None


def _hinted(what: str, text: str, mark: Any) -> str:
    """PyYAML's problem, with what it most likely comes from when that is plain."""
    if "could not determine a constructor" in what:
        return f"{what}: tags that build objects are not allowed in blockqc files"
    lines = text.splitlines()
    at = lines[mark.line][mark.column : mark.column + 1] if mark and mark.line < len(lines) else ""
    if at == "\t" and "tab" not in what:
        return f"{what}: a tab; YAML indents with spaces"
    return what


def line_of(data: Any, loc: Sequence[Any]) -> int | None:
    """The line of the deepest element of `loc` (a pydantic error location) found in `data`."""
    line = getattr(data, "line", None)
    node = data
    for part in loc:
        if isinstance(node, LineDict) and part in node:
            line = node.key_lines.get(part, line)
            node = node[part]
        elif isinstance(node, LineList) and isinstance(part, int) and 0 <= part < len(node):
            line = node.item_lines[part]
            node = node[part]
        else:
            break
    return line


def yaml_kind(value: Any) -> str:
    """What a YAML value is, in the words of a YAML file (not of Python's classes)."""
    if value is None:
        return "an empty value"
    if isinstance(value, bool):
        return f"true/false ({str(value).lower()})"
    if isinstance(value, int | float):
        return f"a number ({value})"
    if isinstance(value, str):
        return f"text {value[:40]!r}"
    if isinstance(value, list | tuple):
        return "a list"
    return "a mapping" if isinstance(value, dict) else type(value).__name__


def pydantic_problems(
    exc: Any,
    file: Path,
    data: Any,
    prefix: Sequence[Any] = (),
    say: Callable[[dict[str, Any]], str | None] | None = None,
    model: Any = None,
) -> list[Problem]:
    """Turn a pydantic ValidationError into problems naming the file, the line and the key path;
    `say` words an error its own way (None: pydantic's message); with the `model` validated, an
    unknown key close to one it takes there gets a "did you mean"."""
    problems = []
    for err in _union_errors_joined(exc.errors()):
        loc = tuple(prefix) + tuple(err["loc"])
        path = ".".join(str(p) for p in loc) or "(top level)"
        msg = err["msg"].removeprefix("Value error, ")
        if _key_not_text(err):  # pydantic names the key as text ('None', 1 for true)
            key = err.get("input")
            loc = loc[:-2] if loc[-1] == "[key]" else loc[:-1]
            path = ".".join(str(p) for p in loc) or "(top level)"
            msg = f"a key YAML reads as {yaml_kind(key)}, not text: write it in quotes"
            loc = (*loc, key)
        elif err["type"] == "extra_forbidden":
            msg = "unknown key" + (_cut_at_comma(err) or known_key_hint(model, err["loc"]))
        else:
            msg = worded(err) or msg
        msg = (say(err) if say else None) or msg
        problems.append(Problem(str(file), f"{path}: {msg}", line=line_of(data, loc)))
    return problems


#: what a text of a pattern is, in words, by the pattern (`worded_pattern`)
PATTERN_WORDS: dict[str, str] = {}


def worded_pattern(pattern: str, words: str) -> str:
    """A pattern of a model's field, with what it asks in words for the messages (a user is
    not shown the regular expression)."""
    PATTERN_WORDS[pattern] = words
    return pattern


#: a number's bound in words, by pydantic's error type
_BOUND_WORDS = {
    "greater_than_equal": "at least",
    "greater_than": "above",
    "less_than_equal": "at most",
    "less_than": "below",
}
#: what a value should have been, by pydantic's error type
_KIND_WORDS = {
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "int_from_float": "a whole number",
    "float_type": "a number",
    "float_parsing": "a number",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
}


def worded(err: Any) -> str | None:
    """A value of the wrong kind, in the words of a YAML file rather than pydantic's ('Input
    should be a valid dictionary', 'String should match pattern ...'); None to keep its own."""
    kind, got = err["type"], yaml_kind(err.get("input"))
    if kind in ("model_type", "model_attributes_type", "dataclass_type", "dict_type"):
        return f"expected a mapping of keys, got {got}"
    if kind == "list_type":
        one = err.get("input")
        hint = f" (a list of one is written [{one}])" if isinstance(one, str | int | float) else ""
        return f"expected a list, got {got}{hint}"
    if kind == "string_type":
        return f"expected a text, got {got}"
    if kind == "string_too_short":
        return "expected a text, got an empty one"
    bound = _BOUND_WORDS.get(kind)
    if bound is not None:
        limit = next(iter((err.get("ctx") or {}).values()), None)
        if not isinstance(limit, int | float):
            return None
        return f"expected a number {bound} {limit:g}, got {got}"
    if kind in _KIND_WORDS:
        return f"expected {_KIND_WORDS[kind]}, got {got}"
    if kind == "string_pattern_mismatch":
        words = PATTERN_WORDS.get((err.get("ctx") or {}).get("pattern", ""))
        return f"expected {words}, got {got}" if words else None
    return None


def _cut_at_comma(err: Any) -> str:
    """The hint for a key without a value that closes a parenthesis it does not open (`1)` of
    `{max: round(x, 1)}`): YAML ended the value before it at the comma of a function call."""
    key = err["loc"][-1] if err["loc"] else None
    if err.get("input") is not None or not isinstance(key, str):
        return ""
    if key.count(")") <= key.count("("):
        return ""
    return (
        f"; '{key}' looks like the end of an expression cut at its comma: inside {{ }} a comma "
        'ends a value, so write the expression in quotes (max: "round(x, 1)")'
    )


def known_key_hint(model: Any, loc: tuple[Any, ...]) -> str:
    """The hint "; did you mean 'x'?" for the unknown key at the end of `loc` when the model
    takes a key close to it there (through its mappings, lists and optional members); else ''."""
    from blockqc.schema import did_you_mean

    kind = model
    for part in loc[:-1]:
        kind = _model_in(kind)
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            field = kind.model_fields.get(part)
            kind = field.annotation if field is not None else None
        else:  # a mapping's value or a list's item
            args = get_args(kind)
            kind = args[-1] if get_origin(kind) is dict else args[0] if args else None
    kind = _model_in(kind)
    if not (isinstance(kind, type) and issubclass(kind, BaseModel)):
        return ""
    return did_you_mean(kind.model_fields)(loc[-1])


def _model_in(kind: Any) -> Any:
    """The model of an optional or annotated type (`Verdict | None`), else the type itself."""
    if get_origin(kind) not in (Union, UnionType, Annotated):
        return kind
    models = [a for a in get_args(kind) if isinstance(a, type) and issubclass(a, BaseModel)]
    return models[0] if models else kind


#: the member of a union pydantic names as the last part of an error's location, in the
#: words of a YAML file
_MEMBERS = {"str": "text", "float": "a number", "int": "a whole number", "bool": "true/false"}


def _member(tag: Any) -> str | None:
    if not isinstance(tag, str):
        return None
    if tag.startswith("list["):
        return "a list"
    return "a mapping" if tag.startswith("dict[") else _MEMBERS.get(tag)


def _union_errors_joined(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """A value that is none of a union's members gives pydantic one error per member, each
    at a location ending in the member's type (`where.method.str`, `where.method.float`, …):
    joined into one at the value's own location, saying what it may be and what it is."""
    members: dict[tuple[Any, ...], list[str]] = {}
    for err in errors:
        kind = _member(err["loc"][-1]) if err["loc"] else None
        if kind is not None:
            members.setdefault(tuple(err["loc"][:-1]), []).append(kind)
    out, done = [], set()
    for err in errors:
        at = tuple(err["loc"][:-1])
        kinds = list(dict.fromkeys(members.get(at, [])))
        if "a number" in kinds and "a whole number" in kinds:
            kinds.remove("a whole number")
        if len(members.get(at, [])) < 2 or _member(err["loc"][-1]) is None:
            out.append(err)
        elif at not in done:
            done.add(at)
            given = yaml_kind(err.get("input"))
            either = ", ".join(kinds[:-1]) + f" or {kinds[-1]}" if len(kinds) > 1 else kinds[0]
            out.append(
                {**err, "loc": at, "type": "union", "msg": f"expected {either}, got {given}"}
            )
    return out


def _key_not_text(err: dict[str, Any]) -> bool:
    """A pydantic error about a mapping key that YAML read as no text (null, true, 12)."""
    key = err.get("input")
    return not isinstance(key, str) and (
        err["type"] == "invalid_key" or err["loc"][-1:] == ("[key]",)
    )
