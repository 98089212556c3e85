"""Numbers in exponent form without a decimal point or without an exponent sign (`5e-1`,
`1.5e0`), numbers in YAML 1.2 and JSON, were read as texts by the YAML 1.1 rules: a pack
setting `error_px: 5e-1` was refused with "expected a finite number ..., got '5e-1'". They are
read as the numbers they are, in packs, their cases and every other YAML input."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from blockqc.rules.cases import run_pack_cases
from blockqc.yamlio import load_yaml
from casekit import extension_pack, project_with_cases


@pytest.mark.parametrize(
    ("written", "value"),
    [("5e-1", 0.5), ("1.5e3", 1500.0), ("2E+2", 200.0), ("-3e2", -300.0), (".5e1", 5.0)],
)
def test_exponent_forms_are_numbers(tmp_path: Path, written: str, value: float) -> None:
    path = tmp_path / "x.yaml"
    path.write_text(f"a: {written}\nb: [{written}]\nc: '{written}'\nd: 1e5x\n", "utf-8")
    assert load_yaml(path) == {"a": value, "b": [value], "c": written, "d": "1e5x"}


def test_a_pack_and_its_cases_written_with_exponents(tmp_path: Path) -> None:
    rules = (
        "constants:\n  tp: {error_px: 5e-1}\n"
        "rules:\n  - id: PR-1\n    title: Tie-point RMS\n    clause: §TP-1\n"
        "    content: ro_report\n    metric: tie_point_errors\n    statistic: rms\n"
        "    threshold: {max: 4e-1}\n    unit: px\n"
    )
    cases = (
        "rule: PR-1\ncases:\n  - name: all at 0.3 px\n    expect: pass\n    value: 3e-1\n"
        "  - name: S1 at 0.9 px\n"
        "    set: {tie_points: [{where: {scene_id: S1}, values: {v_line: 9e-1, v_sample: 0}}]}\n"
        "    expect: fail\n"
        "    value: 5.19615242e-1\n"
    )
    # S1's 121 observations at 0.9 px, the other 363 at 0.3 px (casebase.py): the RMS is
    # √((0.81 + 3·0.09) / 4) = √0.27 = 0.519615242
    pack = project_with_cases(tmp_path, rules, {"PR-1": cases})
    loaded = load_pack(pack)
    assert loaded.constants["tp"]["error_px"] == 0.5
    assert [(o.name, o.ok) for o in run_pack_cases(loaded, own_only=True)] == [
        ("all at 0.3 px", True),
        ("S1 at 0.9 px", True),
    ]


def test_an_exponent_beyond_a_float_is_refused_as_not_finite(tmp_path: Path) -> None:
    pack = extension_pack(tmp_path, "constants:\n  norm: {plane_m: 1e400}\n")
    with pytest.raises(RuleError) as exc:
        load_pack(pack)
    assert [str(p) for p in exc.value.problems] == [
        f"{pack}, line 4: constants.norm.plane_m: expected a finite number or a list of finite "
        "numbers, got a non-finite number"
    ]
    assert math.isinf(load_yaml(pack)["constants"]["norm"]["plane_m"])
