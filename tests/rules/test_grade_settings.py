"""The grade settings of a pack's `acceptance:` (§QE-5): what would grade blocks or batches
wrongly is refused at its line, by lint and by inspect."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.resources import rules_dir
from blockqc.rules import load_pack
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages


def test_batch_grades_listed_worst_first_are_refused(blockqc, tmp_path: Path) -> None:
    """The first batch grade whose shares hold is given: with `good` first, a batch of
    excellent blocks was graded good."""
    pack = _pack(
        tmp_path,
        "acceptance:\n  batch_grades:\n"
        "    - {grade: good, better_pct: 80, top_pct: 30}\n"
        "    - {grade: excellent, better_pct: 90, top_pct: 50}\n",
    )
    message = (
        f"{pack}, line 4: acceptance.batch_grades: list them best first, in the order of grades "
        "(excellent, good, pass), each once: got good, excellent"
    )
    assert _messages(pack) == [message]
    p = blockqc("rules", "lint", pack)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr == f"error: {message}\n"


def test_a_batch_grade_listed_twice_is_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  batch_grades:\n"
        "    - {grade: good, better_pct: 90, top_pct: 50}\n"
        "    - {grade: good, better_pct: 80, top_pct: 30}\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.batch_grades: list them best first, in the order of grades "
        "(excellent, good, pass), each once: got good, good"
    ]


def test_a_fail_grade_with_the_id_of_a_grade_is_refused(tmp_path: Path) -> None:
    """Failing blocks were graded `pass`, like the blocks of the pass grade."""
    pack = _pack(tmp_path, "acceptance:\n  fail_grade: {id: pass, min: 0, title: Fail}\n")
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.fail_grade: id 'pass' is also the id of a grade "
        "(excellent, good, pass): failing blocks would be graded like blocks of that grade; "
        "give the fail grade an id of its own, e.g. fail"
    ]
    with pytest.raises(RuleError):
        load_pack(pack)


@pytest.mark.parametrize("gid", ["Passed", "waived", "conditional_pass"])
def test_a_fail_grade_reading_as_a_passing_verdict_is_refused(tmp_path: Path, gid: str) -> None:
    pack = _pack(tmp_path, f"acceptance:\n  fail_grade: {{id: {gid}, min: 0, title: Fail}}\n")
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.fail_grade: id '{gid}' reads as a passing verdict: "
        f"failing blocks would be graded '{gid}'; give the fail grade an id such as fail"
    ]


def test_grades_with_the_same_id_are_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  grades:\n    - {id: excellent, min: 90, title: Excellent}\n"
        "    - {id: good, min: 75, title: Good}\n    - {id: good, min: 60, title: Pass}\n"
        "  batch_default: good\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.grades: each grade has an id of its own: good twice"
    ]


def test_scores_outside_0_to_100_are_refused(tmp_path: Path) -> None:
    """No score reaches 190 (nothing is excellent), every score is above -60 (nothing fails
    below pass), and every element is below 150 (every block fails)."""
    pack = _pack(
        tmp_path,
        "acceptance:\n  element_fail_below: 150\n  grades:\n"
        "    - {id: excellent, min: 190, title: Excellent}\n"
        "    - {id: good, min: 75, title: Good}\n"
        "    - {id: pass, min: -60, title: Pass}\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.element_fail_below: expected a score from 0 to 100, got 150",
        f"{pack}, line 6: acceptance.grades.0.min: expected a score from 0 to 100, got 190",
        f"{pack}, line 8: acceptance.grades.2.min: expected a score from 0 to 100, got -60",
    ]


def test_grade_settings_in_range_and_in_order_are_kept(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  element_fail_below: 100\n  grades:\n"
        "    - {id: excellent, min: 100, title: Excellent}\n"
        "    - {id: good, min: 75, title: Good}\n"
        "    - {id: pass, min: 0, title: Pass}\n"
        "  fail_grade: {id: rejected, min: 0, title: Rejected}\n"
        "  batch_grades:\n    - {grade: excellent, better_pct: 90, top_pct: 50}\n"
        "    - {grade: pass, better_pct: 0, top_pct: 0}\n",
    )
    assert _messages(pack) == []
    acc = load_pack(pack).acceptance
    assert acc is not None and acc.fail_grade.id == "rejected"


def test_an_unknown_grade_is_refused_at_the_line_naming_it(tmp_path: Path) -> None:
    """A misspelt grade was refused at the `acceptance:` line, the grades listed in no set
    order; each is named at its own line, the grades best first, with a "did you mean"."""
    pack = _pack(
        tmp_path,
        "acceptance:\n  better_than: god\n  batch_default: passs\n  batch_grades:\n"
        "    - {grade: excellent, better_pct: 90, top_pct: 50}\n"
        "    - {grade: goo, better_pct: 80, top_pct: 30}\n",
    )
    grades = "is not one of the grades (excellent, good, pass)"
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.better_than: grade 'god' {grades}; did you mean 'good'?",
        f"{pack}, line 8: acceptance.batch_grades.1: grade 'goo' {grades}; did you mean 'good'?",
        f"{pack}, line 5: acceptance.batch_default: grade 'passs' {grades}; did you mean 'pass'?",
    ]


def test_grades_replaced_name_the_inherited_settings_left_naming_old_ones(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  grades:\n    - {id: top, min: 90, title: Top}\n"
        "    - {id: ok, min: 60, title: OK}\n",
    )
    stock = rules_dir() / "global-project.yaml"  # the installed stock pack's file
    lines = stock.read_text("utf-8").splitlines()
    line = next(n for n, text in enumerate(lines, 1) if text.startswith("  better_than:"))
    assert _messages(pack)[0] == (
        f"{stock}, line {line}: acceptance.better_than: grade 'good' is not one of the grades "
        "(top, ok)"
    )


def test_a_default_grade_setting_naming_no_grade_is_refused() -> None:
    """A setting left at its default names a grade too (`good` for better_than)."""
    from pydantic import ValidationError

    from blockqc.acceptance.model import Acceptance

    grades = [{"id": "top", "min": 90, "title": "Top"}, {"id": "ok", "min": 60, "title": "OK"}]
    with pytest.raises(ValidationError) as err:
        Acceptance.model_validate(
            {
                "sampling": {"table": [{"batch": 20, "sample": 3}]},
                "grades": grades,
                "fail_grade": {"id": "fail", "min": 0, "title": "Fail"},
                "batch_default": "ok",
            }
        )
    assert [e["loc"] for e in err.value.errors()] == [("better_than",)]
