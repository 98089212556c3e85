"""A case edit that changes nothing — rows selected by a misspelt scene id, a column written
under a misspelt name, every selected row kept — is refused with the case's file and line: the
case would judge the base delivery unedited, and a passing case would pass having tested
nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from casekit import PA1_RULE, extension_pack, lint_messages

RULE = "rules:\n" + PA1_RULE

# the base delivery: 121 tie points on each of S1..S4 (casebase.py)
GOOD = """\
  - name: 121 points on every scene
    expect: pass
  - name: 99 points on S1
    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 99}]}
    expect: fail
    value: 99
"""

WRONG = {
    "drop selects no row": (
        "  - name: exactly 100 points on S1\n"
        "    drop: {tie_points: [{where: {scene_id: s1}, keep_first: 100}]}\n"
        "    expect: pass\n",
        "drop tie_points: where/any matches no row",
    ),
    "drop keeps every row": (
        "  - name: exactly 100 points on S1\n"
        "    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 121}]}\n"
        "    expect: pass\n",
        "keep_first 121 keeps every one of the 121 rows selected",
    ),
    "derive selects no row": (
        "  - name: S9's residuals doubled\n"
        "    derive: {tie_points: [{where: {scene_id: S9}, column: v_line, from: v_line,"
        " times: 2}]}\n"
        "    expect: pass\n",
        "derive tie_points: where/any matches no row",
    ),
    "derive writes a misspelt column": (
        "  - name: S1's residuals doubled\n"
        "    derive: {tie_points: [{where: {scene_id: S1}, column: v_lin, from: v_line,"
        " times: 2}]}\n"
        "    expect: pass\n",
        "tie_points has no column 'v_lin' (did you mean v_line?)",
    ),
    "append names a misspelt column": (
        "  - name: S1 is mostly sea\n"
        "    append: {scenes: [{scene_id: S5, band: pan, acquired: '2022-05-01', lines: 1000,"
        " samples: 1000, footprint_wkt: 'POLYGON((116.3 39.9, 116.32 39.9, 116.32 39.88,"
        " 116.3 39.88, 116.3 39.9))', water_fractio: 0.9}]}\n"
        "    expect: pass\n",
        "scenes has no column 'water_fractio' (did you mean water_fraction?)",
    ),
}


def _project(tmp_path: Path, extra: str) -> Path:
    pack = extension_pack(tmp_path, RULE)
    cases = tmp_path / "project.cases"
    cases.mkdir()
    (cases / "PA-1.yaml").write_text(f"rule: PA-1\ncases:\n{GOOD}{extra}", "utf-8")
    return pack


def test_cases_that_change_the_delivery_lint_clean(tmp_path: Path) -> None:
    assert lint_messages(_project(tmp_path, "")) == []


@pytest.mark.parametrize("kind", list(WRONG))
def test_an_edit_that_changes_nothing_is_refused_at_its_case(
    blockqc, tmp_path: Path, kind: str
) -> None:
    extra, message = WRONG[kind]
    pack = _project(tmp_path, extra)
    (found,) = lint_messages(pack)
    assert f"{tmp_path / 'project.cases' / 'PA-1.yaml'}, line 9: cases.2: " in found
    assert message in found
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert message in p.stderr
