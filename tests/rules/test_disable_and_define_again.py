"""A rule that a parent pack disables and a pack further down the chain defines again is judged
again: it is no longer listed as disabled (`rules list` said "disabled: CP-5" under a CP-5 it
listed, and results named it disabled while judging it)."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack
from casekit import extension_pack

CP5_AGAIN = """\
rules:
  - id: CP-5
    title: High-precision reference coverage
    clause: §CP-2
    content: [cp_plane, cp_height]
    metric: reference_coverage
    params: {method: high_precision, min_reference_images: 8, points_per_reference: 3}
    statistic: conforms
    threshold: {equals: true}
"""


def _chain(tmp_path: Path, child_body: str) -> Path:
    extension_pack(tmp_path, "disable: [CP-5, DOC-2]\n", name="parent")
    return extension_pack(tmp_path, child_body, name="child", extends="parent.yaml")


def test_a_disabled_rule_defined_again_is_not_listed_as_disabled(tmp_path: Path, blockqc) -> None:
    pack = load_pack(_chain(tmp_path, CP5_AGAIN))
    assert pack.disabled == ["DOC-2"]
    assert pack.rule("CP-5").severity == "fail"
    p = blockqc("rules", "list", "--rules", tmp_path / "child.yaml")
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1] == "disabled: DOC-2"


def test_a_disabled_rule_not_defined_again_stays_disabled(tmp_path: Path, blockqc) -> None:
    pack = load_pack(_chain(tmp_path, "constants: {norm: {plane_m: 8}}\n"))
    assert pack.disabled == ["CP-5", "DOC-2"]
    assert [r.id for r in pack.rules if r.id in ("CP-5", "DOC-2")] == []
    p = blockqc("rules", "list", "--rules", tmp_path / "child.yaml")
    assert p.stdout.splitlines()[-1] == "disabled: CP-5, DOC-2"


def test_a_rule_defined_again_can_be_disabled_again(tmp_path: Path) -> None:
    middle = _chain(tmp_path, CP5_AGAIN)
    child = extension_pack(tmp_path, "disable: [CP-5]\n", name="grandchild", extends=middle.name)
    assert load_pack(child).disabled == ["DOC-2", "CP-5"]
