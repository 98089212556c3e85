"""A case whose edits make a delivery that inspect refuses (a misspelt block.yaml key under
`manifest:`) was reported at a file of a temporary folder, gone once the case had run, and a
line of a file the user did not write: "/tmp/blockqc-case-…/delivery/block.yaml, line 18:
blok_id: unknown key". It names the case, its line, and the file by its name in the delivery."""

from __future__ import annotations

from pathlib import Path

from casekit import PR1_RULES, project_with_cases

_CASES = (
    "rule: PR-1\ncases:\n  - name: every error 0.3 px\n    expect: pass\n"
    "  - name: S1 at 1.5 px\n"
    "    set: {tie_points: [{where: {scene_id: S1}, values: {v_line: 1.5, v_sample: 0}}]}\n"
    "    expect: fail\n"
    "  - name: another sensor\n    manifest: MANIFEST\n    expect: pass\n"
)


def test_a_manifest_key_inspect_refuses_is_named_in_the_cases_words(
    tmp_path: Path, blockqc
) -> None:
    text = _CASES.replace("MANIFEST", "{sensr: GF-7}")
    pack = project_with_cases(tmp_path, PR1_RULES, {"PR-1": text})
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr == (
        f"error: {tmp_path / 'project.cases' / 'PR-1.yaml'}, line 8: case 'another sensor': "
        "the case's block.yaml: sensr: unknown key; did you mean 'sensor'?\n"
    )


def test_the_same_case_with_the_key_spelt_right_runs(tmp_path: Path, blockqc) -> None:
    text = _CASES.replace("MANIFEST", "{sensor: GF-7}")
    pack = project_with_cases(tmp_path, PR1_RULES, {"PR-1": text})
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.splitlines()[-1] == "3 cases, 0 failed"


def test_a_row_appended_without_its_values_is_named_by_its_row(tmp_path: Path, blockqc) -> None:
    # the base tie_points.csv holds 484 rows (4 scenes × 121): the appended row is row 485
    text = _CASES.replace(
        "    manifest: MANIFEST\n", "    append: {tie_points: [{point_id: Z1, scene_id: S1}]}\n"
    )
    pack = project_with_cases(tmp_path, PR1_RULES, {"PR-1": text})
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    missing = [
        f"the case's tie_points.csv, row 485, column '{c}': empty or NaN value where one is "
        "required"
        for c in ("line", "sample", "v_line", "v_sample")
    ]
    assert p.stderr == (
        f"error: {tmp_path / 'project.cases' / 'PR-1.yaml'}, line 8: case 'another sensor': "
        + "; ".join(missing)
        + "\n"
    )


_TP4 = (
    "rule: TP-4\ncases:\n  - name: 121 points on every scene\n    expect: pass\n"
    "  - name: 40 points on S1, waived\n"
    "    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 40}]}\n"
    "    verdicts: {waivers: {TP-4: {scenes: [SCENE], reason: open sea}}}\n"
    "    expect: waived\n"
    "  - name: 40 points on S1\n"
    "    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 40}]}\n"
    "    expect: fail\n"
)


def test_a_waiver_of_a_scene_the_case_lacks_is_refused(tmp_path: Path, blockqc) -> None:
    # it was passed over: the case failed (exit 1, "expected waived, got fail"), where
    # inspect refuses such a waiver (exit 2)
    pack = project_with_cases(tmp_path, "", {"TP-4": _TP4.replace("SCENE", "S9")})
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr == (
        f"error: {tmp_path / 'project.cases' / 'TP-4.yaml'}, line 5: case '40 points on S1, "
        "waived': a waiver for scene 'S9', which is not a scene of any block inspected\n"
    )


def test_a_waiver_of_a_scene_the_case_has_is_judged(tmp_path: Path, blockqc) -> None:
    pack = project_with_cases(tmp_path, "", {"TP-4": _TP4.replace("SCENE", "S1")})
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.splitlines()[-1] == "3 cases, 0 failed"
