"""A case's `value` and `group` are checked against its rule: a case that can never match is a
broken case file (exit 2, its file and line), not a failing case."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from blockqc.rules.cases import run_pack_cases
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages

_TP1 = (
    "rule: TP-1\ncases:\n  - name: every error 0.3 px\n    expect: pass\n    value: {value}\n"
    "  - name: errors of 0.707 px\n    set: {{tie_points: [{{values: {{v_line: 0.5, "
    "v_sample: 0.5}}}}]}}\n    expect: fail\n"
)
_RO3 = (
    "rule: RO-3\ncases:\n  - name: passes\n    expect: pass\n"
    "  - name: 20 m and 20 m fail\n"
    "    set: {{overlaps: [{{where: {{point_id: O1}}, values: {{dx_m: 20.0, dy_m: 20.0}}}}]}}\n"
    "    expect: fail\n    group: {group}\n"
)


def _with_cases(tmp_path: Path, rule: str, text: str) -> tuple[Path, Path]:
    pack = _pack(tmp_path, "")
    folder = tmp_path / "project.cases"
    folder.mkdir()
    case_file = folder / f"{rule}.yaml"
    case_file.write_text(text, "utf-8")
    return pack, case_file


def _refused(pack: Path) -> list[str]:
    with pytest.raises(RuleError) as exc:
        run_pack_cases(load_pack(pack), own_only=True)
    return [str(p) for p in exc.value.problems]


def test_a_value_written_as_text_for_a_number_is_refused(tmp_path: Path) -> None:
    pack, cases = _with_cases(tmp_path, "TP-1", _TP1.format(value='"0.3"'))
    expected = [
        f"{cases}, line 5: cases.0.value: rule TP-1 judges median (px): expected a number, "
        "got the text '0.3'"
    ]
    assert _refused(pack) == expected
    assert _messages(pack) == expected


def test_a_number_for_a_true_false_statistic_is_refused(tmp_path: Path) -> None:
    text = (
        "rule: MB-3\ncases:\n  - name: ok\n    expect: pass\n    value: 1\n"
        "  - name: wrong\n    manifest: {spatial_reference: {epsg: 32651}}\n    expect: fail\n"
    )
    pack, cases = _with_cases(tmp_path, "MB-3", text)
    assert _messages(pack) == [
        f"{cases}, line 5: cases.0.value: rule MB-3 judges projection_ok (true/false): "
        "expected true or false, got 1"
    ]


def test_a_group_value_the_rule_does_not_judge_is_refused(tmp_path: Path) -> None:
    pack, cases = _with_cases(tmp_path, "RO-3", _RO3.format(group="{component: planar}"))
    expected = [
        f"{cases}, line 8: cases.1.group.component: rule RO-3 has no component 'planar' "
        "(did you mean plane?) (values: plane, height)"
    ]
    assert _refused(pack) == expected
    assert _messages(pack) == expected


def test_a_group_column_the_rule_does_not_have_is_refused(tmp_path: Path) -> None:
    pack, cases = _with_cases(tmp_path, "RO-3", _RO3.format(group="{componnet: plane}"))
    assert _messages(pack) == [
        f"{cases}, line 8: cases.1.group.componnet: rule RO-3 has no group column 'componnet' "
        "(did you mean component?) (group columns: component)"
    ]


def test_a_group_on_a_rule_without_groups_is_refused(tmp_path: Path) -> None:
    text = _TP1.format(value="0.3") + "    group: {component: plane}\n"
    pack, cases = _with_cases(tmp_path, "TP-1", text)
    assert _messages(pack) == [
        f"{cases}, line 9: cases.1.group: rule TP-1 judges no groups "
        "(tie_point_errors at scope block): leave group out"
    ]


def test_a_group_left_out_by_the_rules_where_is_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "overrides:\n  RO-3:\n    where: {component: plane}\n"
        "    thresholds: {plane: {max: 2 * sqrt(2) * norm.plane_m, inclusive: false}}\n",
    )
    cases = tmp_path / "project.cases"
    cases.mkdir()
    (cases / "RO-3.yaml").write_text(_RO3.format(group="{component: height}"), "utf-8")
    assert _messages(pack) == [
        f"{cases / 'RO-3.yaml'}, line 8: cases.1.group.component: rule RO-3 judges component "
        "plane only (where:)"
    ]


def test_the_command_exits_2_on_a_broken_case(blockqc, tmp_path: Path) -> None:
    pack, cases = _with_cases(tmp_path, "TP-1", _TP1.format(value='"0.3"'))
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert f"{cases}, line 5: cases.0.value" in p.stderr


def test_a_case_pack_changing_the_statistic_is_checked_against_it(tmp_path: Path) -> None:
    text = _TP1.format(value="0.3") + "    pack: {overrides: {TP-1: {statistic: rms}}}\n"
    pack, _ = _with_cases(tmp_path, "TP-1", text)
    assert _messages(pack) == []
    assert all(o.ok for o in run_pack_cases(load_pack(pack), own_only=True))


def test_a_case_pack_that_cannot_be_read_is_named_at_the_cases_line(tmp_path: Path) -> None:
    """Lint passed it; rules test named a temporary file of its own."""
    text = _TP1.format(value="0.3") + "    pack: {overrides: {TP-1: {statistic: rmss}}}\n"
    pack, cases = _with_cases(tmp_path, "TP-1", text)
    expected = [
        f"{cases}, line 9: cases.1.pack: rule TP-1: metric tie_point_errors at scope block "
        "offers no statistic 'rmss' (did you mean rms?) (offers: n, median, rms, mean, max, "
        "share_in_interval, n_in_interval)"
    ]
    assert _messages(pack) == expected
    assert _refused(pack) == expected


def test_a_case_pack_disabling_the_rule_is_refused(tmp_path: Path) -> None:
    text = _TP1.format(value="0.3") + "    pack: {disable: [TP-1]}\n"
    pack, cases = _with_cases(tmp_path, "TP-1", text)
    assert _messages(pack) == [
        f"{cases}, line 9: cases.1.pack: disables TP-1, the rule the cases are for"
    ]


def test_a_case_verdict_for_an_automatic_rule_is_refused(tmp_path: Path) -> None:
    """inspect refuses it; the case runner dropped it and the case failed for another reason."""
    text = (
        "rule: TP-1\ncases:\n  - name: ok\n    expect: pass\n  - name: set aside\n"
        "    verdicts: {verdicts: {TP-1: {status: fail}}}\n    expect: fail\n"
    )
    pack, cases = _with_cases(tmp_path, "TP-1", text)
    expected = [
        f"{cases}, line 6: cases.1.verdicts: rule TP-1 is judged from the delivery, not by the "
        "inspector: a verdict is given only for a manual rule (DOC-3); to set a result aside, "
        "waive a waivable rule"
    ]
    assert _messages(pack) == expected
    assert _refused(pack) == expected


def test_the_cases_of_a_rule_the_pack_disables_are_listed_not_run(blockqc, tmp_path: Path) -> None:
    """lint accepts a case file of a rule the pack disables; `rules test` refused it as a
    broken case file (exit 2, "no such rule in the pack"). Its cases are listed as not run."""
    pack = _pack(tmp_path, "disable: [CP-5]\n")
    (tmp_path / "project.cases").mkdir()
    case_file = tmp_path / "project.cases" / "CP-5.yaml"
    case_file.write_text("rule: CP-5\ncases:\n  - name: covered\n    expect: pass\n", "utf-8")
    assert _messages(pack) == []
    (outcome,) = run_pack_cases(load_pack(pack), own_only=True)
    assert (outcome.rule, outcome.ok, outcome.skipped, outcome.line) == ("CP-5", True, True, 3)
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert (
        f"skip  CP-5     covered\n      {case_file}, line 3: not run: the pack disables CP-5"
        in (p.stdout)
    )
    assert p.stdout.rstrip().endswith("0 cases, 0 failed, 1 not run (their rule disabled)")


@pytest.mark.parametrize(("written", "read"), [(".nan", "nan"), (".inf", "inf"), ("-.inf", "-inf")])
def test_a_value_that_is_not_finite_is_refused(tmp_path: Path, written: str, read: str) -> None:
    # no result's value is NaN or infinite: the case could never pass, so it is a broken case
    # file (exit 2), not a failing case (exit 1)
    pack, cases = _with_cases(tmp_path, "TP-1", _TP1.format(value=written))
    expected = [
        f"{cases}, line 5: cases.0.value: rule TP-1 judges median (px): expected a finite "
        f"number, got {read} (which no result gives)"
    ]
    assert _refused(pack) == expected
    assert _messages(pack) == expected


def test_a_finite_value_that_holds_passes(tmp_path: Path) -> None:
    pack, _ = _with_cases(tmp_path, "TP-1", _TP1.format(value="0.3"))
    outcomes = run_pack_cases(load_pack(pack), own_only=True)
    assert [(o.name, o.ok) for o in outcomes] == [
        ("every error 0.3 px", True),
        ("errors of 0.707 px", True),
    ]


def test_a_case_name_given_twice_is_refused_at_the_second_one(tmp_path: Path) -> None:
    # it was refused at line 1, "(top level): case names repeat: ...", naming neither case
    text = (
        "rule: TP-1\ncases:\n  - name: every error 0.3 px\n    expect: pass\n"
        "  - name: errors of 0.707 px\n    set: {tie_points: [{values: {v_line: 0.5, "
        "v_sample: 0.5}}]}\n    expect: fail\n"
        "  - name: every error 0.3 px\n    expect: pass\n    value: 0.3\n"
    )
    pack, cases = _with_cases(tmp_path, "TP-1", text)
    expected = [
        f"{cases}, line 8: cases.2.name: 'every error 0.3 px' is also the name of cases.0 "
        "(line 3): give each case a name of its own"
    ]
    assert _refused(pack) == expected
    assert _messages(pack) == expected
