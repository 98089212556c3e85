"""A pack key or parameter refused for its value is named at its own line, with what was
expected."""

from __future__ import annotations

from pathlib import Path

from casekit import extension_pack, lint_messages


def test_an_interval_given_upper_first_is_named_at_its_line(tmp_path: Path) -> None:
    """Before: 'line 5: rule TP-3: params.: Value error, interval_px must be …' (the line of
    `params:`, no parameter named)."""
    body = "overrides:\n  TP-3:\n    params:\n      interval_px: [1.5, 1.0]\n"
    path = extension_pack(tmp_path, body)
    (found,) = lint_messages(path)
    assert found == (
        f"{path}, line 6: rule TP-3: params.interval_px: expected [lower, upper] with "
        "lower < upper, got [1.5, 1]"
    )


def test_an_unquoted_version_is_refused_with_the_quoted_form(tmp_path: Path) -> None:
    """YAML reads `version: 1.0` as a number. Before: 'version: Input should be a valid
    string', nothing said of the quotes."""
    path = tmp_path / "project.yaml"
    path.write_text("pack: project\nversion: 1.0\nextends: global-project\n", "utf-8")
    (found,) = lint_messages(path)
    assert found.startswith(f"{path}, line 2: version: a version is a text: write it in quotes")
    assert '(version: "1.0")' in found
    path.write_text('pack: project\nversion: "1.10"\nextends: global-project\n', "utf-8")
    assert lint_messages(path) == []
