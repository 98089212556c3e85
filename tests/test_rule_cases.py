"""Every rule's passing and failing cases, run by the package's case runner, one test each.

The cases live beside their pack (`rules/<pack>.cases/<RULE>.yaml`); `blockqc rules test PACK`
runs the same cases from the command line.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.resources import rules_dir
from blockqc.rules import load_pack
from blockqc.rules.cases import iter_cases, run_case


def _cases():
    for pack_file in sorted(rules_dir().glob("*.yaml")):
        for f, doc, _, case in iter_cases(pack_file):
            yield pytest.param(
                pack_file, doc.rule, case, id=f"{pack_file.stem}:{f.stem}:{case.name}"
            )


@pytest.mark.parametrize(("pack_file", "rule_id", "case"), list(_cases()))
def test_rule_case(tmp_path: Path, pack_file: Path, rule_id: str, case) -> None:
    message = run_case(load_pack(pack_file), pack_file, rule_id, case, tmp_path)
    assert message == ""
