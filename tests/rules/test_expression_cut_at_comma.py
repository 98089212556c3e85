"""A function call with two arguments inside a YAML flow mapping (`{max: round(x, 1)}`) is cut
by YAML at its comma: the pack was refused with "thresholds.plane.1): unknown key", which said
nothing of the cause. The message now says to quote the expression; quoted, it is read."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack
from blockqc.rules.expr import evaluate
from casekit import extension_pack
from casekit import lint_messages as _messages

_HINT = (
    "unknown key; '{key}' looks like the end of an expression cut at its comma: inside {{ }} a "
    'comma ends a value, so write the expression in quotes (max: "round(x, 1)")'
)


def test_an_unquoted_call_in_a_flow_mapping_is_refused_with_the_cause(tmp_path: Path) -> None:
    pack = extension_pack(
        tmp_path,
        "overrides:\n"
        "  RO-3:\n"
        "    thresholds:\n"
        "      plane: {max: round(2 * sqrt(2) * norm.plane_m, 1), inclusive: false}\n"
        "      height: {max: 17, inclusive: false}\n"
        "  TP-1: {threshold: {max: max(0.4, tp.error_px)}}\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 8: rule TP-1: threshold.tp.error_px): " + _HINT.format(key="tp.error_px)"),
        f"{pack}, line 6: rule RO-3: thresholds.plane.1): " + _HINT.format(key="1)"),
    ]


def test_the_same_call_quoted_is_read(tmp_path: Path) -> None:
    pack = extension_pack(
        tmp_path,
        "overrides:\n"
        "  RO-3:\n"
        "    thresholds:\n"
        '      plane: {max: "round(2 * sqrt(2) * norm.plane_m, 1)", inclusive: false}\n'
        "      height: {max: 17, inclusive: false}\n",
    )
    assert _messages(pack) == []
    loaded = load_pack(pack)
    bound = loaded.rule("RO-3").all_thresholds()["plane"].max
    assert evaluate(bound, loaded.constants) == 28.3  # 2·√2·10 = 28.28…, to one decimal


def test_an_unknown_key_without_a_parenthesis_keeps_its_did_you_mean(tmp_path: Path) -> None:
    pack = extension_pack(tmp_path, "overrides:\n  TP-1: {threshold: {max: 1, inclusiv: true}}\n")
    assert _messages(pack) == [
        f"{pack}, line 4: rule TP-1: threshold.inclusiv: unknown key; did you mean 'inclusive'?"
    ]
