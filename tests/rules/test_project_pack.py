"""A project adds a rule in one place: its pack file and the cases beside it, no Python."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from markupsafe import escape

from blockqc.report.build import block_context
from blockqc.rules import load_pack

# "≤ 10 % of each PAN scene's tie-point observations above 1 px": the share in (1 px, 1000 px]
RULE = """\
pack: scene-share
version: "1.0"
extends: global-project
constants:
  scene: {max_share_above_1px_pct: 10}
rules:
  - id: PR-1
    title: At most 10 % of each scene's tie points above 1 px
    title_zh: 每景影像连接点误差大于1像素的比例不超过10%
    clause: §TP-3
    content: ro_report
    description: The share of a PAN scene's tie-point observations with errors above 1 px.
    metric: tie_point_errors
    params: {bands: [pan], interval_px: [1.0, 1000.0]}
    scope: scene
    statistic: share_in_interval
    threshold: {max: scene.max_share_above_1px_pct}
    unit: "%"
"""

# the base delivery has 121 observations per PAN scene, all at 0.3 px (casebase.py)
CASES = """\
rule: PR-1
cases:
  - name: no observation above 1 px
    expect: pass
    value: 0.0
  - name: 12 of S1's 121 observations at 1.2 px (9.92 %)
    set: {tie_points: [{where: {scene_id: S1, point_id: {lt: PS1-012}},
                        values: {v_line: 1.2, v_sample: 0.0}}]}
    expect: pass
  - name: 13 of S1's 121 observations at 1.2 px (10.74 %)
    set: {tie_points: [{where: {scene_id: S1, point_id: {lt: PS1-013}},
                        values: {v_line: 1.2, v_sample: 0.0}}]}
    expect: fail
    value: 10.743801653
    evidence: [{scene_id: S1}]
"""


def write_project(folder: Path, cases: str = CASES) -> Path:
    """The project pack and its cases file beside it (project.cases/PR-1.yaml)."""
    pack = folder / "project.yaml"
    pack.write_text(RULE, "utf-8")
    (folder / "project.cases").mkdir(exist_ok=True)
    (folder / "project.cases" / "PR-1.yaml").write_text(cases, "utf-8")
    return pack


def test_project_rule_with_its_cases_lints_and_tests(blockqc, tmp_path: Path) -> None:
    pack = write_project(tmp_path)
    stock = len(load_pack("global-project").rules)
    p = blockqc("rules", "lint", pack)
    assert p.returncode == 0, p.stderr
    assert f"{pack}: {stock + 1} rules, ok" in p.stdout
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.count("pass  PR-1") == 3
    assert "3 cases, 0 failed" in p.stdout
    rule = load_pack(pack).rule("PR-1")
    assert rule.content == {"ro_report": {}}


def test_rules_test_exits_1_on_a_failing_case(blockqc, tmp_path: Path) -> None:
    wrong = CASES.replace("value: 10.743801653", "value: 10.0")
    pack = write_project(tmp_path, wrong)
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 1
    assert "FAIL  PR-1" in p.stdout and "3 cases, 1 failed" in p.stdout
    assert f"{tmp_path / 'project.cases' / 'PR-1.yaml'}, line 10: expected value 10.0" in p.stdout


@pytest.mark.parametrize(
    ("broken", "where", "what"),
    [
        ("    expect: passs\n", "line 4", "cases.0.expect"),
        (
            "    set: {tie_points: [{where: {scene: S1}, values: {v_line: 2}}]}\n",
            "line 3",
            "tie_points has no column 'scene'",
        ),  # fmt: skip
        ("    files: {../outside.txt: x}\n", "line 3", "outside the delivery"),
    ],
)
def test_rules_test_exits_2_on_a_broken_case_file(blockqc, tmp_path, broken, where, what) -> None:
    text = "rule: PR-1\ncases:\n  - name: broken\n" + broken
    if "expect" not in broken:
        text += "    expect: pass\n"
    pack = write_project(tmp_path, text)
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert f"{tmp_path / 'project.cases' / 'PR-1.yaml'}, {where}" in p.stderr, p.stderr
    assert what in p.stderr
    assert not (tmp_path / "outside.txt").exists()


def test_a_project_rule_is_reported_under_its_content_in_both_languages(blockqc, tmp_path):
    """The same pack on a sample block: the report places the rule under its content."""
    pack = write_project(tmp_path)
    stock = Path(__file__).resolve().parents[2] / "samples" / "batch" / "F1-B01"
    for lang in ("en", "zh"):
        out = tmp_path / f"out-{lang}"
        proc = blockqc(
            "inspect", stock, "--rules", pack, "--out", out,
            "--lang", lang, "--no-pdf",
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        results = json.loads((out / "F1-B01" / "results.json").read_text(encoding="utf-8"))
        mine = [r for r in results["results"] if r["rule"] == "PR-1"]
        assert [r["status"] for r in mine] == ["pass"] and mine[0]["content"] == ["ro_report"]
        ctx = block_context(results, lang)
        placed = {
            c["name"]: [x["rule"] for x in c["results"]]
            for e in ctx["elements"]
            for i in e["items"]
            for c in i["contents"]
        }
        name = "相对定向精度报告" if lang == "zh" else "Relative orientation accuracy report"
        ro = [r.id for r in load_pack("global-project").rules if "ro_report" in r.content]
        assert placed[name] == [*ro, "PR-1"] and not ctx["others"]
        html = (out / "F1-B01" / "report.html").read_text(encoding="utf-8")
        title = "每景影像连接点误差大于1像素的比例不超过10%" if lang == "zh" else "At most 10 %"
        assert escape(title) in html


def test_the_readme_example_lints_and_its_cases_pass(tmp_path: Path) -> None:
    """The rule and cases README's "Adding a rule" shows, as a user would copy them into a
    pack extending the stock one: `rules lint` finds nothing, `rules test` passes both cases."""
    from casekit import ROOT, run_blockqc

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Adding a rule") :]
    rule, cases = (b.split("\n", 1)[1] for b in section.split("```yaml")[1:3])
    rule, cases = (textwrap.dedent(b.split("```")[0]) for b in (rule, cases))
    header = 'pack: project\nversion: "1.0"\nextends: global-project\nrules:\n'
    (tmp_path / "project.yaml").write_text(header + textwrap.indent(rule, "  "), "utf-8")
    (tmp_path / "project.cases").mkdir()
    (tmp_path / "project.cases" / "PR-1.yaml").write_text(cases, "utf-8")
    lint = run_blockqc("rules", "lint", tmp_path / "project.yaml")
    assert lint.returncode == 0, lint.stdout + lint.stderr
    test = run_blockqc("rules", "test", tmp_path / "project.yaml", "--own")
    assert test.returncode == 0, test.stdout + test.stderr
    assert "pass  PR-1     13 of S1's 121 observations at 1.2 px (10.74 %)" in test.stdout


def test_rules_test_help_shows_the_pack_optional_and_its_default(blockqc) -> None:
    """`rules test` without a pack runs the stock pack's cases: its usage line shows PACK as
    optional, and its help names the default."""
    p = blockqc("rules", "test", "--help")
    assert p.returncode == 0, p.stderr
    assert "Usage: blockqc rules test [OPTIONS] [PACK]" in p.stdout
    assert "default: global-project" in " ".join(p.stdout.split())
