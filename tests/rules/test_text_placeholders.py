"""Numbers in rules' titles and descriptions follow the pack's constants (`{tp.min_points}`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from blockqc.rules.expr import ExpressionError
from blockqc.rules.text import render
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages

DESERT = "constants:\n  norm: {plane_m: 8}\n  tp: {min_points_per_scene: 150}\n"


def test_stock_texts_follow_the_constants_a_project_changes(tmp_path: Path) -> None:
    pack = load_pack(_pack(tmp_path, DESERT))
    tp4, cp2 = pack.rule("TP-4"), pack.rule("CP-2")
    assert tp4.title == "At least 150 tie points in every scene"
    assert tp4.title_zh == "每景影像至少 150 个连接点"
    assert tp4.description.startswith("Every PAN scene holds at least 150 tie points.")
    assert cp2.description.rstrip().endswith("is at most 8 m.")
    assert cp2.description_zh.endswith("不超过 8 m。")
    assert "plane below 22.6 m, height below 17.0 m" in " ".join(
        pack.rule("RO-3").description.split()
    )


def test_a_projects_decimal_is_written_whole_not_rounded_to_the_texts_format(
    tmp_path: Path,
) -> None:
    # TP-3 writes its interval `.1f`: a project's (0.75, 1.25] read (0.8, 1.2] px, a bound
    # the rule does not judge by; irrational figures (2·√2·7.25 = 20.506…) are still rounded
    pack = load_pack(
        _pack(
            tmp_path,
            "constants:\n  norm: {plane_m: 7.25}\n  tp: {share_interval_px: [0.75, 1.25]}\n",
        )
    )
    tp3 = pack.rule("TP-3")
    assert tp3.title == "Share of tie points with errors in (0.75, 1.25] px"
    assert tp3.title_zh == "误差在 (0.75, 1.25] 像素之间的连接点比例"
    assert "errors in (0.75, 1.25] px" in " ".join(tp3.description.split())
    ro3 = " ".join(pack.rule("RO-3").description.split())
    assert "plane below 20.5 m, height below 17.0 m" in ro3


def test_stock_texts_with_the_default_constants() -> None:
    pack = load_pack("global-project")
    assert pack.rule("TP-4").title == "At least 100 tie points in every scene"
    assert pack.rule("TP-3").title == "Share of tie points with errors in (1.0, 1.5] px"
    assert pack.rule("CP-1").title_zh == "抽样区域网布设 20 至 50 个检查点"
    assert pack.rule("CP-4").title == "Gross-error rate below 5 %"
    assert "plane 14.1 m, height 8.5 m" in " ".join(pack.rule("RO-4").description.split())
    asprs = load_pack("asprs-2023")
    assert asprs.rule("AS-3").title == "Mean error (bias) below 25 % of the target RMSE"
    assert "Accuracy_r = 1.7308·RMSE_r and CE90 = 2.1460·RMSE_x" in asprs.rule("AS-4").description


def test_explain_shows_the_projects_number(blockqc, tmp_path: Path) -> None:
    p = blockqc("rules", "explain", "TP-4", "--rules", _pack(tmp_path, DESERT))
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[0] == "TP-4 — At least 150 tie points in every scene"


def test_unknown_placeholder_is_refused_at_its_line(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "overrides:\n  TP-4:\n    title: At least {tp.min_point} points\n")
    assert _messages(pack) == [
        f"{pack}, line 5: rule TP-4: title: placeholder {{tp.min_point}}: unknown constant "
        "'tp.min_point' (did you mean cp.min_points?) (known: cp.max_gross_rate_pct, "
        "cp.max_points, cp.min_points, norm.height_m, norm.plane_m, rc.residual_tolerance_px, "
        "tp.error_px, tp.max_error_px, tp.max_share_pct, tp.min_points_per_scene, "
        "tp.share_interval_px)"
    ]
    with pytest.raises(RuleError):
        load_pack(pack)


@pytest.mark.parametrize(
    ("text", "why"),
    [
        (
            "below {gsd.ms} m",
            "placeholder {gsd.ms} names a value of the delivery, unknown when the pack is "
            "loaded: name the pack's constants only",
        ),
        (
            "below {norm.plane_m:x} m",
            "placeholder {norm.plane_m:x}: unknown format 'x' (give .1f, .3g, g or d)",
        ),
        (
            "at most {tp.max_error_px:d} px",
            "placeholder {tp.max_error_px:d}: 1.5 is not a whole number, which format 'd' "
            "writes: give g or .1f",
        ),
        (
            "in ({tp.share_interval_px:d}] px",
            "placeholder {tp.share_interval_px:d}: 1.5 is not a whole number, which format "
            "'d' writes: give g or .1f",
        ),
        ("a set {a, b", "a lone '{': write {{ for a literal brace"),
        ("empty {}", "an empty placeholder {}: name a constant, e.g. {norm.plane_m}"),
    ],
)
def test_bad_placeholders_are_refused(tmp_path: Path, text: str, why: str) -> None:
    pack = _pack(tmp_path, f'overrides:\n  CP-2:\n    description_zh: "{text}"\n')
    assert _messages(pack) == [f"{pack}, line 5: rule CP-2: description_zh: {why}"]


def test_render_formats_lists_and_literal_braces() -> None:
    consts = {"tp": {"share": [1.0, 1.5], "n": 100}, "norm": {"plane_m": 10}}
    assert render("({tp.share:.1f}] px, {{x}}", consts) == "(1.0, 1.5] px, {x}"
    assert render("{2 * sqrt(2) * norm.plane_m:.1f} m; {tp.n} points", consts) == (
        "28.3 m; 100 points"
    )
    assert render("{tp.share:.1f}; {norm.plane_m:.3g}; {0.125:.2g}", consts) == (
        "1.0, 1.5; 10; 0.125"
    )
    # `d` writes whole numbers as such, also one computed a hair off (3 · 0.1 · 20 = 6)
    assert render("{tp.n:d}; {3 * 0.1 * 20:d}; {tp.n / 4:3d}", consts) == "100; 6;  25"
    with pytest.raises(ExpressionError, match="0.5 is not a whole number"):
        render("{tp.share:d}", {"tp": {"share": [1.0, 0.5]}})
    with pytest.raises(ExpressionError, match="a lone '}'"):
        render("x}", consts)


def test_a_constant_used_only_in_a_text_is_used(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "constants:\n  mine: {cells: 4}\noverrides:\n"
        "  TP-5:\n    title: Tie points in each of {mine.cells} cells\n",
    )
    assert _messages(pack) == []
    assert load_pack(pack).rule("TP-5").title == "Tie points in each of 4 cells"


def test_an_override_judging_by_another_figure_than_its_texts_state_is_warned_of(
    blockqc, tmp_path: Path
) -> None:
    """TP-4 overridden to `min: 150` judged 150 tie points while its title read "At least 100
    tie points in every scene", in every report, and lint said nothing."""
    path = _pack(
        tmp_path,
        "overrides:\n  TP-4: {threshold: {min: 150}}\n"
        "  TP-3: {params: {interval_px: [0.75, 1.25]}}\n"
        "  CP-2: {threshold: {max: 8}}\n"
        "  TP-2: {threshold: {max: tp.max_error_px, inclusive: false}}\n",
    )
    pack = load_pack(path)
    assert [str(n) for n in pack.notes] == [
        f"{path}, line 4: overrides.TP-4: its title and description still state "
        "tp.min_points_per_scene = 100, which the rule no longer judges by: set the constant "
        "instead, or override the texts too",
        f"{path}, line 5: overrides.TP-3: its title and description still state "
        "tp.share_interval_px = [1.0, 1.5], which the rule no longer judges by: set the "
        "constant instead, or override the texts too",
        f"{path}, line 6: overrides.CP-2: its description still states norm.plane_m = 10, "
        "which the rule no longer judges by: set the constant instead, or override the texts "
        "too",
    ]
    assert pack.rule("TP-4").title == "At least 100 tie points in every scene"
    p = blockqc("rules", "lint", path)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"warning: {path}, line 4: overrides.TP-4: its title" in p.stderr


def test_an_override_with_its_own_texts_or_the_same_constant_is_not_warned_of(
    tmp_path: Path,
) -> None:
    path = _pack(
        tmp_path,
        "overrides:\n  TP-4:\n    threshold: {min: 150}\n    title: At least 150 tie points\n"
        "    title_zh: 至少 150 个连接点\n    description: Every scene holds 150.\n"
        "    description_zh: 每景 150 个。\n"
        "  TP-1: {threshold: {max: 0.4}}\n",
    )
    assert load_pack(path).notes == []
