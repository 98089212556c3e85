"""Checking a pack's `acceptance:` section (§QE) as merged down its `extends` chain.

Each problem names the file of the chain that wrote the offending value and its line: the pack
itself or a pack it extends, whichever wrote it last.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from blockqc.acceptance import model
from blockqc.acceptance.model import Acceptance
from blockqc.errors import Problem
from blockqc.rules.lint import did_you_mean
from blockqc.rules.model import ElementDef
from blockqc.yamlio import LineDict, LineList, line_of, pydantic_problems, yaml_kind

#: every file of a pack's chain as read, the pack it extends first: (file, its YAML, its model)
Sources = Sequence[tuple[str, Any, Any]]


def _holds(data: Any, loc: Sequence[Any]) -> bool:
    node = data
    for part in loc:
        if isinstance(node, LineDict) and part in node:
            node = node[part]
        elif isinstance(node, LineList) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            return False
    return True


def site(sources: Sources, loc: Sequence[Any]) -> tuple[str, int | None]:
    """The file that last writes `acceptance.<loc>` (or the deepest part of it) and the line."""
    full = ("acceptance", *loc)
    for n in range(len(full), 0, -1):
        for file, data, _ in reversed(sources):
            if _holds(data, full[:n]):
                return file, line_of(data, full)
    return (sources[-1][0], None) if sources else ("", None)


#: what a number of the section is, by pydantic's error type
EXPECTED = {"int_type": "a whole number", "float_type": "a number"}


def _expected(err: dict[str, Any]) -> str | None:
    """A number given as anything else (true/false, text), in the project's words."""
    what = EXPECTED.get(err["type"])
    value = err["input"]
    if what and isinstance(value, float) and not isinstance(value, bool) and value.is_integer():
        return f"expected {what}, got {value!r} (write {int(value)})"
    return f"expected {what}, got {yaml_kind(value)}" if what else None


def validate(merged: dict[str, Any], sources: Sources) -> tuple[Acceptance | None, list[Problem]]:
    """The merged section validated; each problem at the file and line that wrote the value."""
    try:
        return Acceptance.model_validate(merged), []
    except ValidationError as exc:
        found = pydantic_problems(exc, Path(""), None, ("acceptance",), say=_expected)
        out = []
        for err, p in zip(exc.errors(), found, strict=True):
            file, line = site(sources, err["loc"])
            out.append(Problem(file, p.message, line=line))
        return None, out


#: where a pack's basis comes from with the key left out: the pack it extends, or else the
#: --meta file (its basis, shown in Chinese too where it gives no basis_zh)
BASIS_LEFT_OUT = {
    (True, "basis"): "to use the basis of the pack it extends",
    (True, "basis_zh"): "to use the basis_zh of the pack it extends",
    (False, "basis"): "and give the basis in the --meta file",
    (False, "basis_zh"): "to show basis on the pages in Chinese",
}


def empty_basis(sources: Sources) -> list[Problem]:
    """Each file's `acceptance: basis: []` (or basis_zh), refused at its line as a --meta
    file's is (acceptance.model.empty_basis): an empty list merged over the basis of the pack
    it extends, or left as the pack's own, had the acceptance page show no basis."""
    out = []
    for file, data, pf in sources:
        own = data.get("acceptance") if isinstance(data, dict) else None
        for key in model.empty_basis(own):
            how = BASIS_LEFT_OUT[(pf.extends is not None, key)]
            line = line_of(data, ("acceptance", key))
            out.append(Problem(file, f"acceptance.{key}: {model.EMPTY_BASIS} {how}", line=line))
    return out


def check_weights(acc: Acceptance, elements: list[ElementDef], sources: Sources) -> list[Problem]:
    """Weights name elements under `elements` and items under `items`; no group re-normalised
    is weighted all 0. An element's id under items (or an item's under elements) would be read
    by nothing: refused, saying where it belongs."""
    ids = {"elements": [e.id for e in elements], "items": [i.id for e in elements for i in e.items]}
    other = {"elements": "items", "items": "elements"}
    out = []
    for group, known in ids.items():
        for k in getattr(acc.weights, group):
            if k in known:
                continue
            if k in ids[other[group]]:
                where = f" (it is one of the {other[group]})"
            else:
                where = did_you_mean(k, known)
            message = f"'{k}' is no {group[:-1]}{where}; the {group}: {', '.join(known)}"
            out.append(_at(sources, ("weights", group, k), message))
    groups = [("elements", "the quality elements", [e.id for e in elements])]
    groups += [("items", f"the items of element {e.id}", [i.id for i in e.items]) for e in elements]
    for group, what, ids in groups:
        weights = getattr(acc.weights, group)
        out += _unweighted(sources, group, what, ids, weights)
        if ids and all(weights.get(i, 1.0) == 0 for i in ids):
            msg = (
                f"every weight of {what} ({', '.join(ids)}) is 0: their score Σwᵢsᵢ/Σwᵢ is "
                "undefined; give at least one a weight above 0"
            )
            out.append(_at(sources, ("weights", group, ids[0]), msg))
    return out


def _unweighted(
    sources: Sources, group: str, what: str, ids: list[str], weights: dict[str, float]
) -> list[Problem]:
    """Of a group some of whose members are weighted, one without a weight would be weighted 1
    unsaid (an element added by a project pack outweighing the stock ones): refused. A group
    none of whose members is weighted counts them alike."""
    given = [i for i in ids if i in weights]
    missing = [i for i in ids if i not in weights]
    if not given or not missing:
        return []
    stated = ", ".join(f"{i} {weights[i]:g}" for i in given)
    out = []
    for i in missing:
        file, line = _defined(sources, i)
        message = (
            f"{group[:-1]} {i}: no weight under acceptance.weights.{group}, beside {stated} "
            f"({what}): it would be weighted 1; give it one (0: not counted)"
        )
        out.append(Problem(file, message, line=line))
    return out


def _defined(sources: Sources, gid: str) -> tuple[str, int | None]:
    """The file of the chain that defines an element or item (the last one) and its line."""
    for file, data, _ in reversed(sources):
        elements = data.get("elements") if isinstance(data, dict) else None
        for j, el in enumerate(elements if isinstance(elements, list) else []):
            if not isinstance(el, dict):
                continue
            if el.get("id") == gid:
                return file, line_of(data, ("elements", j))
            items = el.get("items")
            for k, it in enumerate(items if isinstance(items, list) else []):
                if isinstance(it, dict) and it.get("id") == gid:
                    return file, line_of(data, ("elements", j, "items", k))
    return (sources[-1][0], None) if sources else ("", None)


def _at(sources: Sources, loc: tuple[str, ...], message: str) -> Problem:
    file, line = site(sources, loc)
    return Problem(file, f"acceptance.{'.'.join(loc[:2])}: {message}", line=line)
