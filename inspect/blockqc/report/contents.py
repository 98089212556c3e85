"""The inspection contents of DOMAIN §2 as the rule pack declares them, with their results.

The pack's `elements:` tree (quality elements → items → contents) travels in results.json; each
result names the contents it decides (`content`). A content's status is the worst status of its
results. Results that decide no content of the tree are returned apart ("other rules").
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockqc.results import BlockResults, RuleResult, worst_status
from blockqc.rules.model import ElementDef, ItemDef


@dataclass
class ContentRow:
    element: ElementDef
    item: ItemDef
    content: str  # content id
    title: str
    title_zh: str
    status: str | None
    results: list[RuleResult] = field(default_factory=list)


def content_rows(results: BlockResults) -> tuple[list[ContentRow], list[RuleResult]]:
    """Every inspection content of the tree with its results, and the results none claims."""
    rows: list[ContentRow] = []
    claimed: set[int] = set()
    for element in results.elements:
        for item in element.items:
            for c in item.contents:
                mine = [(i, r) for i, r in enumerate(results.results) if c.id in r.content]
                claimed.update(i for i, _ in mine)
                chosen = [r for _, r in mine]
                status = worst_status(r.status for r in chosen)
                rows.append(ContentRow(element, item, c.id, c.title, c.title_zh, status, chosen))
    others = [r for i, r in enumerate(results.results) if i not in claimed]
    return rows, others
