"""The results model: one status order, one failing block, published schemas kept in sync."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.results import (
    STATUS_ORDER,
    STATUSES,
    BlockResults,
    block_fails,
    json_schema,
    worst_status,
)
from blockqc.rules import load_pack
from casekit import SAMPLES

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.mark.parametrize("kind", ["results", "summary"])
def test_published_schema_is_generated_from_the_model(kind: str) -> None:
    written = json.loads((DOCS / f"{kind}.schema.json").read_text(encoding="utf-8"))
    assert written == json_schema(kind), f"regenerate: blockqc schema {kind} > docs/..."


def test_one_status_order_and_one_failing_block() -> None:
    assert set(STATUS_ORDER) == set(STATUSES) and len(STATUSES) == 7
    assert worst_status(["pass", "waived", "warn"]) == "warn"
    assert worst_status(["pass", "manual", "fail"]) == "fail"
    assert worst_status(["not_applicable", "pass"]) == "pass"
    assert worst_status([]) is None
    assert [block_fails(v) for v in ("pass", "fail", "error")] == [False, True, True]


def test_two_rules_on_one_metric_with_different_parameters_keep_both_tables(tmp_path) -> None:
    """A project rule with its own error interval beside the stock TP rules: both tables kept."""
    pack = tmp_path / "pack.yaml"
    pack.write_text(
        yaml.safe_dump(
            {
                "pack": "ms-project",
                "extends": "global-project",
                "rules": [
                    {
                        "id": "TPX-1",
                        "title": "Share of tie points with errors in (0.5, 1.0] px",
                        "clause": "§TP-1",
                        "content": "ro_report",
                        "metric": "tie_point_errors",
                        "params": {"bands": ["pan"], "interval_px": [0.5, 1.0]},
                        "scope": "block",
                        "statistic": "share_in_interval",
                        "threshold": {"max": 50},
                        "unit": "%",
                    }
                ],
            }
        ),
        encoding="utf-8",
    )
    doc = inspect_delivery(load_delivery(SAMPLES / "batch" / "F1-B01"), load_pack(pack))
    tp = doc.measurements_of("tie_point_errors")
    assert sorted(m.params["interval_px"][0] for m in tp) == [0.5, 1.0]
    assert all(m.tables.get("block") and m.tables.get("scene") for m in tp)
    keys = {r.rule: r.measurement for r in doc.results if r.rule in ("TP-1", "TPX-1")}
    assert keys["TP-1"] != keys["TPX-1"] and {m.key for m in tp} == set(keys.values())
    shares = {m.params["interval_px"][0]: m.tables["block"][0]["share_in_interval"] for m in tp}
    assert shares[0.5] != shares[1.0]  # two different measurements, not one copied
    BlockResults.model_validate(json.loads(doc.model_dump_json()))  # round trip
