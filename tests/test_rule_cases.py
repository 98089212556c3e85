"""Every rule's passing and failing cases (tests/rules/cases/<pack>/<RULE>.yaml), one test each."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.inspector import InspectorInput
from blockqc.results import dump
from blockqc.rules import load_pack
from casekit import aggregate_status, write_delivery, write_pack

CASES = Path(__file__).parent / "rules" / "cases"


def _cases():
    for f in sorted(CASES.glob("*/*.yaml")):
        doc = yaml.safe_load(f.read_text())
        for case in doc["cases"]:
            yield pytest.param(
                f.parent.name, doc["rule"], case, id=f"{f.parent.name}:{doc['rule']}:{case['name']}"
            )


def _matches(expected, actual) -> bool:
    if isinstance(expected, dict):
        return isinstance(actual, dict) and all(
            k in actual and _matches(v, actual[k]) for k, v in expected.items()
        )
    if isinstance(expected, list):
        return isinstance(actual, list) and all(
            any(_matches(e, a) for a in actual) for e in expected
        )
    if isinstance(expected, float) and isinstance(actual, (int, float)):
        return math.isclose(expected, actual, rel_tol=1e-8, abs_tol=1e-9)
    return expected == actual


@pytest.mark.parametrize(("pack_name", "rule_id", "case"), list(_cases()))
def test_rule_case(tmp_path: Path, pack_name: str, rule_id: str, case: dict) -> None:
    folder = write_delivery(tmp_path / "delivery", case)
    pack_ref = pack_name
    if "pack" in case:
        pack_ref = str(write_pack(tmp_path / "pack.yaml", case["pack"]))
    pack = load_pack(pack_ref)
    inspector = InspectorInput.model_validate(case.get("verdicts") or {})
    doc = dump(inspect_delivery(load_delivery(folder), pack, inspector.for_block("CASE")))
    results = [r for r in doc["results"] if r["rule"] == rule_id]
    assert results, f"rule {rule_id} gave no result"
    group = case.get("group")
    chosen = [r for r in results if not group or _matches(group, r["group"])]
    status = aggregate_status(chosen)
    assert status == case["expect"], [
        (r["group"], r["status"], r["value"], r["detail"]) for r in results
    ]
    if "value" in case:
        values = [r["value"] for r in chosen if r["status"] == status]
        assert any(_matches(case["value"], v) for v in values), values
    if "evidence" in case:
        evidence = [e for r in chosen for e in r["evidence"]]
        assert _matches(case["evidence"], evidence), evidence
    if "detail" in case:
        assert any(_matches(case["detail"], r["detail"]) for r in chosen), [
            r["detail"] for r in chosen
        ]
