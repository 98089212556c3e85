"""A bound written true/false (or yes/no) is refused, not read as 1; `.yml` case files are read."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import cases, load_pack
from blockqc.rules.cases import find_case_file, iter_cases
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages


@pytest.mark.parametrize("written", ["true", "yes", "True"])
def test_a_true_bound_is_refused_at_the_rule_and_line(tmp_path: Path, written: str) -> None:
    pack = _pack(tmp_path, f"overrides:\n  TP-2:\n    threshold: {{max: {written}}}\n")
    assert _messages(pack) == [
        f"{pack}, line 5: rule TP-2: threshold.max: expected a number or an expression, "
        "got true (YAML reads yes/no as true/false)"
    ]
    with pytest.raises(RuleError):  # inspect refuses it too: it would be read as 1 px
        load_pack(pack)


def test_a_false_bound_of_one_group_is_refused(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "overrides:\n  CP-2:\n    thresholds:\n      plane: {min: no}\n")
    assert _messages(pack) == [
        f"{pack}, line 6: rule CP-2: thresholds.plane.min: expected a number or an expression, "
        "got false (YAML reads yes/no as true/false)"
    ]


def test_numbers_and_expressions_stay_bounds(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "overrides:\n  TP-2:\n    threshold: {max: 1}\n")
    assert load_pack(pack).rule("TP-2").threshold.max == 1


def _manual_pack(tmp_path: Path) -> Path:
    return _pack(
        tmp_path, "rules:\n  - id: PR-1\n    title: t\n    clause: §TP-1\n    manual: true\n"
    )


def _write_cases(folder: Path, name: str) -> Path:
    folder.mkdir(exist_ok=True)
    path = folder / name
    path.write_text(
        "rule: PR-1\ncases:\n  - name: awaiting\n    expect: manual\n"
        "  - name: rejected\n    verdicts: {verdicts: {PR-1: {status: fail}}}\n    expect: fail\n",
        "utf-8",
    )
    return path


def test_a_yml_case_file_is_read_by_lint_and_test(tmp_path: Path) -> None:
    pack = _manual_pack(tmp_path)
    yml = _write_cases(tmp_path / "project.cases", "PR-1.yml")
    assert find_case_file([str(pack)], "PR-1") == yml
    # before, the .yml file was skipped: "rule PR-1 has no cases"; now its own gap is found
    assert _messages(pack) == [f"{yml}: rule PR-1: no passing case (expect: pass)"]
    assert [(f, c.name) for f, _, _, c in iter_cases(pack)] == [
        (yml, "awaiting"),
        (yml, "rejected"),
    ]


def test_a_rule_with_both_a_yaml_and_a_yml_case_file_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "project.cases"
    _write_cases(folder, "PR-1.yaml")
    yml = _write_cases(folder, "PR-1.yml")
    with pytest.raises(RuleError) as exc:
        cases.case_files(folder)
    assert str(exc.value) == f"{yml}: cases for PR-1 also in PR-1.yaml: keep one"


def test_a_stray_yml_case_file_is_named_by_lint(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "")
    folder = tmp_path / "project.cases"
    folder.mkdir()
    (folder / "TP-9.yml").write_text("rule: TP-9\ncases: []\n", "utf-8")
    assert any(
        "TP-9.yml: cases for TP-9, which the pack has no rule for" in m for m in _messages(pack)
    )
