"""A rule's `figures:` hints mark its bound on figures of the tie points. A checkpoint rule
hinting `residual_histogram` had its 30 m bound drawn as a "30 px" mark on the tie-point
residual histogram (the axis stretched to 30 px); such hints are refused at their line. An
override of TP-4's threshold keeps its inherited hints."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack
from casekit import extension_pack
from casekit import lint_messages as _messages

_RULE = """\
rules:
  - id: PR-1
    title: A project rule
    clause: §TP-1
    content: {content}
    figures: [{figure}]
    metric: {metric}
    params: {{bands: [pan]}}
    scope: {scope}
    statistic: {statistic}
    threshold: {threshold}
    unit: {unit}
"""


def _pack(tmp_path: Path, **kw: str) -> Path:
    return extension_pack(tmp_path, _RULE.format(**kw))


def _lint(pack: Path) -> list[str]:
    return [m for m in _messages(pack) if "has no cases" not in m]


def test_a_checkpoint_rule_cannot_mark_the_residual_histogram(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        content="cp_plane",
        figure="residual_histogram",
        metric="checkpoint_accuracy",
        scope="component_method\n    where: {component: plane}",
        statistic="max_error",
        threshold="{max: 30}",
        unit="m",
    ).read_text("utf-8")
    path = tmp_path / "project.yaml"
    path.write_text(pack.replace("    params: {bands: [pan]}\n", ""), "utf-8")
    assert _lint(path) == [
        f"{path}, line 8: rule PR-1: figures: residual_histogram draws its bound (px) on the "
        "tie-point residuals: it needs a rule of tie_point_errors with a statistic in px, not "
        "checkpoint_accuracy at scope component_method, statistic max_error: leave it out"
    ]


def test_a_share_in_percent_cannot_mark_the_residual_histogram(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        content="ro_report",
        figure="residual_histogram",
        metric="tie_point_errors",
        scope="scene",
        statistic="share_in_interval",
        threshold="{max: 10}",
        unit='"%"',
    )
    assert _lint(pack) == [
        f"{pack}, line 8: rule PR-1: figures: residual_histogram draws its bound (px) on the "
        "tie-point residuals: it needs a rule of tie_point_errors with a statistic in px, not "
        "tie_point_errors at scope scene, statistic share_in_interval: leave it out"
    ]


def test_a_share_of_cells_cannot_be_drawn_on_the_counts(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        content="tp_distribution",
        figure="scene_counts",
        metric="tie_point_distribution",
        scope="scene",
        statistic="coverage",
        threshold="{min: 0.8}",
        unit="share of cells",
    )
    assert _lint(pack) == [
        f"{pack}, line 8: rule PR-1: figures: scene_counts draws its bound of n_points on the "
        "per-scene counts: it needs a rule of tie_point_distribution, statistic n_points, not "
        "tie_point_distribution at scope scene, statistic coverage: leave it out"
    ]


def test_a_manual_rule_has_no_figures(tmp_path: Path) -> None:
    pack = extension_pack(
        tmp_path,
        "overrides:\n  DOC-3: {figures: [scene_points]}\n",
    )
    assert _lint(pack) == [
        f"{pack}, line 4: rule DOC-3: figures: a manual rule has no values to draw: leave "
        "figures out"
    ]


def test_hints_that_fit_their_rules_are_kept(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        content="tp_number",
        figure="scene_counts, scene_points",
        metric="tie_point_distribution",
        scope="scene",
        statistic="n_points",
        threshold="{min: 150}",
        unit="points",
    )
    assert _lint(pack) == []
    assert load_pack(pack).rule("PR-1").figures == ["scene_counts", "scene_points"]
    mine = _pack(
        tmp_path,
        content="ro_report",
        figure="residual_histogram",
        metric="tie_point_errors",
        scope="observation",
        statistic="error_px",
        threshold="{max: 1.2}",
        unit="px",
    )
    assert _lint(mine) == []


def test_an_override_of_tp4s_threshold_keeps_its_hints(tmp_path: Path) -> None:
    pack = extension_pack(tmp_path, "overrides:\n  TP-4: {threshold: {min: 50, max: 5000}}\n")
    assert _lint(pack) == []
    assert load_pack(pack).rule("TP-4").figures == ["scene_counts", "scene_points"]
