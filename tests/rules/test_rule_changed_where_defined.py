"""A rule defined under `rules:` and named under `overrides:` or `disable:` of the same file:
the override silently replaced what the rule says a few lines above (its threshold 0.5 judged
as 0.4), and the disable dropped the rule the file defines ("21 rules, ok"). Both are refused
at their lines; a rule defined here and changed by a pack extending this one is not."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack
from casekit import PR1_RULES, extension_pack
from casekit import lint_messages as _messages


def _lint(pack: Path) -> list[str]:
    return [m for m in _messages(pack) if "has no cases" not in m]


def test_an_override_of_a_rule_of_the_same_file_is_refused(tmp_path: Path) -> None:
    pack = extension_pack(tmp_path, PR1_RULES + "overrides:\n  PR-1: {threshold: {max: 0.4}}\n")
    assert _lint(pack) == [
        f"{pack}, line 13: overrides.PR-1: PR-1 is defined in this file (rules, line 4): "
        "change it there"
    ]


def test_a_disable_of_a_rule_of_the_same_file_is_refused(tmp_path: Path) -> None:
    pack = extension_pack(tmp_path, PR1_RULES + "disable: [PR-1]\n")
    assert _lint(pack) == [
        f"{pack}, line 12: disable: PR-1 is defined in this file (rules, line 4): remove it there"
    ]


def test_a_rule_defined_in_a_parent_is_overridden_and_disabled_below(tmp_path: Path) -> None:
    extension_pack(tmp_path, PR1_RULES, name="parent")
    child = extension_pack(
        tmp_path, "overrides:\n  PR-1: {threshold: {max: 0.4}}\n", name="child",
        extends="parent.yaml",
    )  # fmt: skip
    assert _lint(child) == []
    assert load_pack(child).rule("PR-1").threshold.max == 0.4
    grandchild = extension_pack(
        tmp_path, "disable: [PR-1]\n", name="grandchild", extends="child.yaml"
    )
    assert _lint(grandchild) == [] and load_pack(grandchild).disabled == ["PR-1"]
