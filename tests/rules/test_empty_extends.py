"""`extends:` left empty (or `extends: ''`) was passed over as if the pack extended nothing:
the pack was refused with "the pack has no rule to judge: no rule is defined", or, with rules
of its own, loaded without the stock rules the user meant to extend, unsaid. It is refused at
its line."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack

_OWN = "rules:\n  - {id: PR-1, title: Standardization, clause: §DOC-3, manual: true}\n"


@pytest.mark.parametrize("written", ["", "''", "'  '", "null"])
def test_an_empty_extends_is_refused_at_its_line(tmp_path: Path, written: str) -> None:
    path = tmp_path / "project.yaml"
    path.write_text(f"pack: project\nextends: {written}\n{_OWN}", "utf-8")
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    assert [str(p) for p in exc.value.problems] == [
        f"{path}, line 2: extends: an empty rule pack name: give a stock pack name "
        "(asprs-2023, global-project) or a file path, or leave extends out"
    ]


def test_a_pack_without_extends_stands_alone(tmp_path: Path) -> None:
    path = tmp_path / "project.yaml"
    path.write_text(
        "pack: project\nelements:\n  - id: attachment\n    title: Attachment quality\n"
        "    items:\n      - id: documents\n        title: Documents\n        contents:\n"
        "          - {id: documents, title: Documents}\n"
        "rules:\n  - {id: PR-1, title: Standardization, clause: §DOC-3, content: documents, "
        "manual: true}\n",
        "utf-8",
    )
    pack = load_pack(path)
    assert [r.id for r in pack.rules] == ["PR-1"] and pack.chain == [str(path)]
