"""A value that is none of the kinds a key takes was reported once per kind, at a key path
ending in pydantic's type names (`rule CP-2: where.method.str: Input should be a valid string`,
then `.float`, `.bool`): three messages naming keys the file does not have. It is one message
at the value's own key, saying what the key takes and what the file gives."""

from __future__ import annotations

from pathlib import Path

from casekit import extension_pack
from casekit import lint_messages as _messages


def test_a_value_of_no_allowed_kind_is_one_message_at_its_key(tmp_path: Path) -> None:
    path = extension_pack(
        tmp_path,
        "overrides:\n"
        "  CP-2: {where: {component: plane, method: [high_precision, same_accuracy]}}\n"
        "  CP-3: {evidence_where: {gross: {eq: false}}}\n"
        "  TP-4: {threshold: {min: [100]}}\n",
    )
    assert _messages(path) == [
        f"{path}, line 6: rule TP-4: threshold.min: expected a number or text, got a list",
        f"{path}, line 4: rule CP-2: where.method: expected text, a number or true/false, "
        "got a list",
        f"{path}, line 5: rule CP-3: evidence_where.gross: expected text, a number or "
        "true/false, got a mapping",
    ]


def test_a_content_selector_of_no_allowed_kind_names_the_list_too(tmp_path: Path) -> None:
    path = extension_pack(
        tmp_path, "overrides:\n  CP-4: {content: {cp_plane: {component: {in: [plane]}}}}\n"
    )
    assert _messages(path) == [
        f"{path}, line 4: rule CP-4: content.cp_plane.component: expected text, a number, "
        "true/false or a list, got a mapping"
    ]
