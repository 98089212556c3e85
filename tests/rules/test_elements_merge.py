"""A project's `elements:` merged into the stock tree. An item or content given again with
a new title kept the old one, the new title read by nothing; a content id given in a second
item (or twice in one) was accepted, a rule naming it then filed under one of them. Titles
given again now replace the old ones; a content id in two places is refused at its line."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.resources import rules_dir
from blockqc.rules import load_pack
from casekit import extension_pack

_LAYOUT = """\
elements:
  - id: layout
    title: Layout quality
    items:
      - id: points_distribution
        title: Distribution of tie points
        title_zh: 连接点分布情况
        contents:
          - {id: tp_number, title: Tie points per scene, title_zh: 每景连接点数}
          - {id: CONTENT, title: Another content}
"""


def test_titles_given_again_replace_the_old_ones(tmp_path: Path) -> None:
    pack = load_pack(extension_pack(tmp_path, _LAYOUT.replace("CONTENT", "tp_extra")))
    (layout,) = [e for e in pack.elements if e.id == "layout"]
    (item,) = layout.items
    assert (item.title, item.title_zh, item.method) == (
        "Distribution of tie points",
        "连接点分布情况",
        "verification of process data",  # not given again: kept
    )
    assert [(c.id, c.title, c.title_zh) for c in item.contents] == [
        ("tp_number", "Tie points per scene", "每景连接点数"),
        ("tp_distribution", "Distribution of connection points", "连接点分布"),
        ("tp_extra", "Another content", ""),
    ]


def test_a_content_id_of_another_item_is_refused(tmp_path: Path) -> None:
    path = extension_pack(tmp_path, _LAYOUT.replace("CONTENT", "documents"))
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    stock = rules_dir() / "global-project.yaml"
    assert [str(p) for p in exc.value.problems] == [
        f"{path}, line 12: elements: content documents is also a content of item documents "
        f"({stock}, line 102): a content id names one content of the tree; give this one "
        "another id"
    ]


def test_a_content_id_twice_in_one_item_is_refused(tmp_path: Path) -> None:
    body = _LAYOUT.replace("CONTENT", "tp_extra") + "          - {id: tp_extra, title: Again}\n"
    path = extension_pack(tmp_path, body)
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    assert [str(p) for p in exc.value.problems] == [
        f"{path}, line 13: elements: content tp_extra is also a content of item "
        f"points_distribution ({path}, line 12): a content id names one content of the tree; "
        "give this one another id"
    ]
