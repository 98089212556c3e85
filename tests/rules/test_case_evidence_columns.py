"""A case's expected evidence names columns the rule's evidence has: a misspelt column
(`scene` for `scene_id`) can match no evidence row, so the case would fail whatever the rule
gives; it is refused by lint with the case's file and line, as a misspelt `group` is."""

from __future__ import annotations

from pathlib import Path

from casekit import PA1_RULE, PA2_RULE, lint_messages, project_with_cases

RULES = "rules:\n" + PA1_RULE + PA2_RULE

# the base delivery: 121 tie points on each of S1..S4, every error 0.3 px (casebase.py)
PA1 = """\
rule: PA-1
cases:
  - name: 121 points on every scene
    expect: pass
  - name: 99 points on S1
    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 99}]}
    expect: fail
    value: 99
    evidence: [{scene_id: S1, n_points: 99}]
"""

PA2 = """\
rule: PA-2
cases:
  - name: every error 0.3 px
    expect: pass
    value: 0.3
  - name: every error 0.6 px
    derive: {tie_points: [{column: v_line, from: v_line, times: 2},
                          {column: v_sample, from: v_sample, times: 2}]}
    expect: fail
    value: 0.6
"""


def _project(tmp_path: Path, pa1: str = PA1, pa2: str = PA2) -> Path:
    return project_with_cases(tmp_path, RULES, {"PA-1": pa1, "PA-2": pa2})


def test_cases_whose_evidence_the_rule_gives_lint_clean(blockqc, tmp_path: Path) -> None:
    pack = _project(tmp_path)
    assert lint_messages(pack) == []
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "4 cases, 0 failed" in p.stdout


def test_a_misspelt_evidence_column_is_refused_at_its_line(blockqc, tmp_path: Path) -> None:
    pack = _project(
        tmp_path, PA1.replace("{scene_id: S1, n_points: 99}", "{scene: S1, n_points: 99}")
    )
    (found,) = lint_messages(pack)
    file = tmp_path / "project.cases" / "PA-1.yaml"
    assert found.startswith(f"{file}, line 9: cases.1.evidence.0.scene: ")
    assert "has no column 'scene' (did you mean scene_id?)" in found
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert "has no column 'scene'" in p.stderr


def test_evidence_of_a_rule_that_lists_none_is_refused(tmp_path: Path) -> None:
    """PA-2 judges the block and names no evidence_from: its results list no evidence."""
    pa2 = PA2 + "    evidence: [{scene_id: S1}]\n"
    (found,) = lint_messages(_project(tmp_path, pa2=pa2))
    file = tmp_path / "project.cases" / "PA-2.yaml"
    assert found.startswith(f"{file}, line 11: cases.1.evidence: ")
    assert "rule PA-2 lists no evidence (judged at scope block, no evidence_from)" in found
