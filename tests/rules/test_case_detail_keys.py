"""A case's expected detail names keys the rule's results give: a misspelt key (`n_offendng`
for `n_offending`) is in no result's detail, so the case would fail whatever the rule gives; it
is refused by lint with the case's file and line and the keys the rule's metric gives, as a
misspelt evidence column is."""

from __future__ import annotations

from pathlib import Path

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import PA1_RULE, PA2_RULE, lint_messages, project_with_cases

RULES = "rules:\n" + PA1_RULE + PA2_RULE

# the base delivery: 121 tie points on each of the 4 PAN scenes S1..S4, every error 0.3 px
# (casebase.py); 99 points on S1 leave 1 of the 4 scenes offending
PA1 = """\
rule: PA-1
cases:
  - name: 121 points on every scene
    expect: pass
  - name: 99 points on S1
    drop: {tie_points: [{where: {scene_id: S1}, keep_first: 99}]}
    expect: fail
    value: 99
    detail: {n_units: 4, n_offending: 1}
"""

# every error doubled: 0.6 px, the median as the RMS
PA2 = """\
rule: PA-2
cases:
  - name: every error 0.3 px
    expect: pass
    value: 0.3
    detail: {median: 0.3}
  - name: every error 0.6 px
    derive: {tie_points: [{column: v_line, from: v_line, times: 2},
                          {column: v_sample, from: v_sample, times: 2}]}
    expect: fail
    value: 0.6
    detail: {median: 0.6, max: 0.6}
"""


def _project(tmp_path: Path, pa1: str = PA1, pa2: str = PA2) -> Path:
    return project_with_cases(tmp_path, RULES, {"PA-1": pa1, "PA-2": pa2})


def test_cases_whose_detail_the_rule_gives_lint_clean(blockqc, tmp_path: Path) -> None:
    pack = _project(tmp_path)
    assert lint_messages(pack) == []
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "4 cases, 0 failed" in p.stdout


def test_a_misspelt_detail_key_is_refused_at_its_line(blockqc, tmp_path: Path) -> None:
    pack = _project(tmp_path, PA1.replace("n_offending: 1", "n_offendng: 1"))
    (found,) = lint_messages(pack)
    file = tmp_path / "project.cases" / "PA-1.yaml"
    assert found.startswith(f"{file}, line 9: cases.1.detail.n_offendng: ")
    assert "has no key 'n_offendng' (did you mean n_offending?)" in found
    assert "n_units, n_offending" in found  # the keys a per-scene rule gives
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert "has no key 'n_offendng'" in p.stderr


def test_a_key_of_another_metric_is_refused_with_the_metrics_keys(tmp_path: Path) -> None:
    """n_offending is a per-unit rule's; PA-2 judges one row of the block, whose columns the
    detail holds (its own statistic, rms, is the value)."""
    pa2 = PA2.replace("{median: 0.6, max: 0.6}", "{median: 0.6, n_offending: 1}")
    (found,) = lint_messages(_project(tmp_path, pa2=pa2))
    file = tmp_path / "project.cases" / "PA-2.yaml"
    assert found.startswith(f"{file}, line 12: cases.1.detail.n_offending: ")
    assert "tie_point_errors at scope block" in found
    assert "median" in found and "n_in_interval" in found


def test_the_rules_statistic_is_its_value_not_a_detail(tmp_path: Path) -> None:
    pa2 = PA2.replace("{median: 0.3}", "{rms: 0.3}")
    (found,) = lint_messages(_project(tmp_path, pa2=pa2))
    assert ", line 6: cases.0.detail.rms: " in found
    assert "rms is the statistic rule PA-2 judges: give it as the case's value" in found


def test_every_detail_key_a_result_gives_is_one_of_its_rules(tmp_path: Path) -> None:
    """The keys lint accepts are those the results give: the stock rules on the base delivery
    (every result, its detail's keys among those of its rule)."""
    from blockqc.engine import detail_keys

    pack = load_pack("global-project")
    delivery = load_delivery(write_delivery(tmp_path / "delivery"))
    rules = {r.id: r for r in pack.rules}
    for result in inspect_delivery(delivery, pack).results:
        assert set(result.detail) <= set(detail_keys(rules[result.rule])), result.rule
