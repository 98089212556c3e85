"""A project pack named as the pack it extends (`pack: global-project`, `extends:
global-project`) was loaded and its results and reports named 'global-project 1.0', the stock
pack, for rules it changed (a plane norm of 20 m passing blocks the stock pack fails). Such a
pack is refused at its `pack:` line."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.resources import rules_dir
from blockqc.rules import load_pack
from casekit import extension_pack

_BODY = 'version: "1.0"\nconstants:\n  norm: {plane_m: 20}\n'


def test_a_pack_named_as_the_stock_pack_it_extends_is_refused(tmp_path: Path) -> None:
    path = extension_pack(tmp_path, _BODY, name="global-project")
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    assert [str(p) for p in exc.value.problems] == [
        f"{path}, line 1: pack: global-project is the name of the pack it extends "
        f"({rules_dir() / 'global-project.yaml'}): results and reports would name that pack "
        "for the rules this one changes; give this pack a name of its own"
    ]


def test_a_name_taken_further_up_the_chain_is_refused(tmp_path: Path) -> None:
    parent = extension_pack(tmp_path, _BODY, name="project")
    child = tmp_path / "child.yaml"
    child.write_text("pack: global-project\nextends: project.yaml\n", "utf-8")
    with pytest.raises(RuleError) as exc:
        load_pack(child)
    assert [p.line for p in exc.value.problems] == [1]
    assert "pack: global-project is the name of the pack it extends" in str(exc.value.problems[0])
    assert load_pack(parent).name == "project"


def test_a_pack_of_its_own_name_is_read(tmp_path: Path) -> None:
    pack = load_pack(extension_pack(tmp_path, _BODY, name="relaxed-project"))
    assert (pack.name, pack.version, pack.constants["norm"]["plane_m"]) == (
        "relaxed-project",
        "1.0",
        20,
    )
