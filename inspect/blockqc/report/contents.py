"""The inspection contents of DOMAIN §2 and the stock rules that decide each of them.

Three quality elements split into items and inspection contents; a content's status is the worst
status of the rule results mapped to it. Rules the mapping does not know (a project's own rules)
are placed by the `inspection_content`, `content` and `quality_element` fields of their result
when the engine provides them, and otherwise listed under "other rules".

Reading: the tie-point error rules TP-1..3 verify the relative orientation accuracy that the
producer's relative orientation accuracy report states, so they decide that content; DOC-2
(reported figures agree with the process data) decides both report contents.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

# Rule results: worst first. A content's status is the first of these among its results.
SEVERITY_ORDER = ("error", "fail", "manual", "warn", "waived", "pass", "not_applicable")


@dataclass(frozen=True)
class Content:
    key: str  # message key ct_…
    selectors: tuple[tuple[str, dict[str, str]], ...]  # (rule id, group filter)


@dataclass(frozen=True)
class Item:
    key: str  # message key it_…
    how: str  # message key how_…
    contents: tuple[Content, ...]


@dataclass(frozen=True)
class Element:
    key: str  # message key qe_…
    items: tuple[Item, ...]


def _c(key: str, *selectors: str | tuple[str, dict[str, str]]) -> Content:
    return Content(key, tuple((s, {}) if isinstance(s, str) else s for s in selectors))


PLANE = {"component": "plane"}
HEIGHT = {"component": "height"}

ELEMENTS: tuple[Element, ...] = (
    Element(
        "qe_data",
        (
            Item(
                "it_math",
                "how_process",
                (
                    _c("ct_coordinate_system", "MB-1"),
                    _c("ct_geodetic_datum", "MB-1"),
                    _c("ct_height_datum", "MB-2"),
                    _c("ct_projection", "MB-3"),
                ),
            ),
            Item(
                "it_plane",
                "how_checkpoints",
                (
                    _c("ct_cp_plane", "CP-1", ("CP-2", PLANE), ("CP-4", PLANE), "CP-5"),
                    _c("ct_pan_ms", "RO-1"),
                ),
            ),
            Item(
                "it_height",
                "how_checkpoints",
                (_c("ct_cp_height", "CP-1", ("CP-3", HEIGHT), ("CP-4", HEIGHT), "CP-5"),),
            ),
            Item(
                "it_edge",
                "how_automatic",
                (
                    _c("ct_between_blocks", "RO-2"),
                    _c("ct_within_block", "RO-3", "RO-4"),
                ),
            ),
        ),
    ),
    Element(
        "qe_layout",
        (
            Item(
                "it_points",
                "how_process",
                (
                    _c("ct_tp_number", "TP-4"),
                    _c("ct_tp_distribution", "TP-5"),
                ),
            ),
        ),
    ),
    Element(
        "qe_attachment",
        (
            Item(
                "it_report",
                "how_process",
                (
                    _c("ct_ro_report", "TP-1", "TP-2", "TP-3", "DOC-2"),
                    _c("ct_ao_report", "DOC-2"),
                ),
            ),
            Item("it_documents", "how_process_person", (_c("ct_documents", "DOC-1", "DOC-3"),)),
        ),
    ),
)

# Names a result (or a pack) may give for its content or element → message keys.
CONTENT_NAMES = {
    "coordinate system": "ct_coordinate_system",
    "geodetic datum": "ct_geodetic_datum",
    "height datum": "ct_height_datum",
    "projection": "ct_projection",
    "map projection": "ct_projection",
    "checkpoint plane accuracy": "ct_cp_plane",
    "pan-ms relative orientation accuracy": "ct_pan_ms",
    "pan–ms relative orientation accuracy": "ct_pan_ms",
    "checkpoint height accuracy": "ct_cp_height",
    "relative orientation between blocks": "ct_between_blocks",
    "relative orientation within blocks": "ct_within_block",
    "relative orientation accuracy report": "ct_ro_report",
    "absolute orientation accuracy report": "ct_ao_report",
    "number of connection points": "ct_tp_number",
    "distribution of connection points": "ct_tp_distribution",
    "documents": "ct_documents",
}


def worst(statuses: list[str]) -> str | None:
    """The worst status of a content's results (None when no rule decides it)."""
    for s in SEVERITY_ORDER:
        if s in statuses:
            return s
    return None


def _matches(result: dict[str, Any], rule: str, where: dict[str, str]) -> bool:
    if result["rule"] != rule:
        return False
    group = result.get("group") or {}
    return all(group.get(k, v) == v for k, v in where.items())


def mapped_rules() -> set[str]:
    return {rule for e in ELEMENTS for i in e.items for c in i.contents for rule, _ in c.selectors}


@dataclass
class ContentRow:
    element: str
    item: str
    how: str
    content: str
    status: str | None
    results: list[dict[str, Any]] = field(default_factory=list)


def content_rows(results: list[dict[str, Any]]) -> tuple[list[ContentRow], list[dict[str, Any]]]:
    """Every inspection content with its results, and the results no content claims."""
    named: dict[str, list[int]] = {}
    for idx, res in enumerate(results):  # results that name their content themselves
        name = str(res.get("inspection_content") or "").strip().lower()
        if name in CONTENT_NAMES:
            named.setdefault(CONTENT_NAMES[name], []).append(idx)
    self_named = {i for idxs in named.values() for i in idxs}
    claimed: set[int] = set(self_named)
    rows: list[ContentRow] = []
    for element in ELEMENTS:
        for item in element.items:
            for content in item.contents:
                mine = [
                    i
                    for i, r in enumerate(results)
                    if i not in self_named
                    and any(_matches(r, rule, where) for rule, where in content.selectors)
                ]
                mine += named.get(content.key, [])
                claimed.update(mine)
                chosen = [results[i] for i in sorted(set(mine))]
                rows.append(
                    ContentRow(
                        element.key,
                        item.key,
                        item.how,
                        content.key,
                        worst([r["status"] for r in chosen]),
                        chosen,
                    )
                )
    others = [r for i, r in enumerate(results) if i not in claimed]
    return rows, others
