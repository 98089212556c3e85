"""Safe YAML reading that remembers line numbers, so every error can name its line."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from blockqc.errors import BlockqcError, InputError, Problem


class LineDict(dict):
    """A mapping read from YAML: `line` is where it starts, `key_lines` where each key stands."""

    line: int = 0
    key_lines: dict[Any, int]


class LineList(list):
    """A sequence read from YAML: `line` is where it starts, `item_lines` where each item starts."""

    line: int = 0
    item_lines: list[int]


class _Loader(yaml.SafeLoader):
    """SafeLoader (no Python tags) that builds LineDict/LineList and refuses duplicate keys."""


def _mapping(loader: _Loader, node: yaml.MappingNode) -> LineDict:
    loader.flatten_mapping(node)
    out = LineDict()
    out.line = node.start_mark.line + 1
    out.key_lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if not isinstance(key, (str, int, float, bool)) and key is not None:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"a mapping key must be a plain value, got {type(key).__name__}",
                key_node.start_mark,
            )
        if key in out:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"duplicate key '{key}' (first on line {out.key_lines[key]})",
                key_node.start_mark,
            )
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[key] = key_node.start_mark.line + 1
    return out


def _sequence(loader: _Loader, node: yaml.SequenceNode) -> LineList:
    out = LineList(loader.construct_object(child, deep=True) for child in node.value)
    out.line = node.start_mark.line + 1
    out.item_lines = [child.start_mark.line + 1 for child in node.value]
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _sequence)


def load_yaml(path: Path, error: type[BlockqcError] = InputError) -> Any:
    """Read one YAML document safely; syntax errors and unsafe tags name the file and line."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(Problem(str(path), "file not found")) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(Problem(str(path), f"cannot be read as UTF-8 text: {exc}")) from None
    try:
        loader = _Loader(text)  # a SafeLoader: no tag can build a Python object
        try:
            return loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        what = exc.problem or str(exc)
        if "could not determine a constructor" in what:
            what = f"{what}: tags that build objects are not allowed in blockqc files"
        raise error(Problem(str(path), f"not valid YAML: {what}", line=line)) from None
    except yaml.YAMLError as exc:
        raise error(Problem(str(path), f"not valid YAML: {exc}")) from None


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


def pydantic_problems(exc: Any, file: Path, data: Any, prefix: Sequence[Any] = ()) -> list[Problem]:
    """Turn a pydantic ValidationError into problems naming the file, the line and the key path."""
    problems = []
    for err in exc.errors():
        loc = tuple(prefix) + tuple(err["loc"])
        path = ".".join(str(p) for p in loc) or "(top level)"
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        problems.append(Problem(str(file), f"{path}: {msg}", line=line_of(data, loc)))
    return problems
