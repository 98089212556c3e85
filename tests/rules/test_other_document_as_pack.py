"""Another file of blockqc given where a rule pack is expected (`--rules verdicts.yaml`, the
options swapped; a case file; a block.yaml) was refused key by key as a pack: 'pack: Field
required', 'rule: unknown key; did you mean rules?', 'verdicts: unknown key' … It is said
once what the file is, and what to give."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from casekit import SAMPLES


def _refused(path: Path) -> list[str]:
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    return [str(p) for p in exc.value.problems]


def test_a_verdicts_file_given_as_the_pack(blockqc, tmp_path: Path) -> None:
    verdicts = SAMPLES / "verdicts.yaml"
    p = blockqc(
        "inspect", SAMPLES / "batch" / "F1-B01", "--rules", verdicts, "--out", tmp_path / "o"
    )
    assert p.returncode == 2
    assert p.stderr == (
        f"error: {verdicts}, line 1: is an inspector's verdicts file (verdicts, waivers), not a "
        "rule pack (pack, rules, ...): give it with --verdicts\n"
    )


def test_a_case_file_or_a_block_yaml_given_as_the_pack(tmp_path: Path) -> None:
    case = tmp_path / "TP-1.yaml"
    case.write_text("rule: TP-1\ncases:\n  - {name: ok, expect: pass}\n", "utf-8")
    assert _refused(case) == [
        f"{case}, line 1: is a case file of a rule (rule, cases), not a rule pack (pack, rules, "
        "...): give the pack file beside its cases folder (project.yaml beside project.cases/)"
    ]
    block = SAMPLES / "batch" / "F1-B01" / "block.yaml"
    assert _refused(block) == [
        f"{block}, line 1: is a delivery's block.yaml (block_id, ...), not a rule pack (pack, "
        "rules, ...): give a rule pack file"
    ]


def test_a_pack_with_keys_of_its_own_is_read_as_a_pack(tmp_path: Path) -> None:
    pack = tmp_path / "project.yaml"
    pack.write_text("pack: project\nextends: global-project\n", "utf-8")
    assert load_pack(pack).name == "project"
    other = tmp_path / "other.yaml"
    other.write_text("title: no pack key\n", "utf-8")
    assert _refused(other) == [f"{other}, line 1: pack: Field required"]
