"""A case's `derive` reading a column of texts (`from: scene_id`) stopped `rules test` with
"internal error: ValueError: could not convert string to float: 'S1'". It is refused as a
broken case at its line (exit 2), as other edits that cannot be made are; a derive from a
number column is made."""

from __future__ import annotations

import math
from pathlib import Path

from blockqc.rules import load_pack
from blockqc.rules.cases import run_pack_cases
from casekit import PR1_RULES, lint_messages, project_with_cases

_CASES = (
    "rule: PR-1\ncases:\n  - name: every error 0.3 px\n    expect: pass\n"
    "  - name: S1 at 1.5 px\n"
    "    set: {{tie_points: [{{where: {{scene_id: S1}}, values: {{v_line: 1.5, v_sample: 0}}}}]}}\n"
    "    expect: fail\n"
    "  - name: S1's residuals tripled\n"
    "    derive: {{tie_points: [{{where: {{scene_id: S1}}, column: v_line, from: {src},"
    " times: 3}}]}}\n"
    "    expect: {expect}\n"
)


def test_a_derive_from_a_text_column_is_refused_at_its_case(tmp_path: Path, blockqc) -> None:
    pack = project_with_cases(
        tmp_path, PR1_RULES, {"PR-1": _CASES.format(src="scene_id", expect="fail")}
    )
    cases = tmp_path / "project.cases" / "PR-1.yaml"
    message = (
        f"{cases}, line 8: cases.2: cannot be made on the base delivery: derive "
        "tie_points.v_line: from: scene_id holds texts ('S1' …), not numbers: derive from a "
        "number column"
    )
    assert lint_messages(pack) == [message]
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2 and p.stderr == f"error: {message}\n", p.stderr


def test_a_derive_from_a_number_column_is_made(tmp_path: Path) -> None:
    # S1's v_line = 3·0.3·cos θ, v_sample unchanged, over the 121 θ = 0.7·k of casebase.py:
    # its squared errors 0.09·(9cos²θ + sin²θ) = 0.09·(1 + 8cos²θ); the other 363 are 0.09
    s1 = sum(0.09 * (1 + 8 * math.cos(0.7 * k) ** 2) for k in range(121))
    rms = math.sqrt((s1 + 363 * 0.09) / 484)  # ≈ 0.424: passes the 0.5 px bound
    pack = project_with_cases(
        tmp_path, PR1_RULES, {"PR-1": _CASES.format(src="v_line", expect="pass")}
    )
    cases = tmp_path / "project.cases" / "PR-1.yaml"
    cases.write_text(cases.read_text("utf-8") + f"    value: {rms!r}\n", "utf-8")
    assert lint_messages(pack) == []
    outcomes = run_pack_cases(load_pack(pack), own_only=True)
    assert [(o.name, o.ok, o.message) for o in outcomes] == [
        ("every error 0.3 px", True, ""),
        ("S1 at 1.5 px", True, ""),
        ("S1's residuals tripled", True, ""),
    ]


def test_numbers_derived_into_a_column_of_texts_are_refused(tmp_path: Path, blockqc) -> None:
    # it stopped with "internal error: TypeError: Invalid value for dtype 'str'. ..."
    text = _CASES.format(src="line", expect="fail").replace("column: v_line", "column: scene_id")
    pack = project_with_cases(tmp_path, PR1_RULES, {"PR-1": text})
    cases = tmp_path / "project.cases" / "PR-1.yaml"
    message = (
        f"{cases}, line 8: cases.2: cannot be made on the base delivery: derive "
        "tie_points.scene_id: cannot write numbers: column scene_id holds texts (to give a "
        "table a value of another kind, write its file under files:)"
    )
    assert lint_messages(pack) == [message]
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2 and p.stderr == f"error: {message}\n", p.stderr


def test_a_text_set_into_a_column_of_numbers_is_refused_in_words(tmp_path: Path) -> None:
    text = _CASES.format(src="v_line", expect="pass").replace("v_line: 1.5", "v_line: abc")
    pack = project_with_cases(tmp_path, PR1_RULES, {"PR-1": text})
    assert lint_messages(pack) == [
        f"{tmp_path / 'project.cases' / 'PR-1.yaml'}, line 5: cases.1: cannot be made on the "
        "base delivery: set tie_points.v_line: cannot write 'abc': column v_line holds numbers "
        "(to give a table a value of another kind, write its file under files:)"
    ]
