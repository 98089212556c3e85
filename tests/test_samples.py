"""The bundled sample batch reproduces the published verdicts and checkpoint statistics."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from casekit import SAMPLES

# DOMAIN.md §CP, published results of the four test fields:
# (component, method) -> (medium or mean error, max error, gross errors, gross rate %)
PUBLISHED = {
    "F1-B01": {
        ("plane", "high_precision"): (3.33, 8.94, 0, 0.0),
        ("height", "high_precision"): (2.69, 7.39, 0, 0.0),
    },
    "F2-B01": {
        ("plane", "high_precision"): (6.22, 17.67, 1, 3.3),
        ("plane", "recalculation"): (5.28, 14.44, 1, 3.3),
        ("height", "same_accuracy"): (1.92, 6.78, 0, 0.0),
        ("height", "recalculation"): (2.84, 9.36, 0, 0.0),
    },
    "F3-B01": {
        ("plane", "high_precision"): (15.7, 18.25, 3, 37.5),
        ("plane", "same_accuracy"): (7.14, 16.85, 2, 8.7),
        ("height", "same_accuracy"): (2.94, 11.21, 2, 8.3),
    },
    "F4-B01": {
        ("plane", "same_accuracy"): (2.26, 5.57, 0, 0.0),
        ("height", "same_accuracy"): (3.09, 11.96, 0, 0.0),
    },
}


def _digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(folder)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def inspected(tmp_path_factory):
    from casekit import run_blockqc

    out = tmp_path_factory.mktemp("out")
    before = _digest(SAMPLES / "batch")
    proc = run_blockqc(
        "inspect", SAMPLES / "batch", "--verdicts", SAMPLES / "verdicts.yaml", "--out", out
    )
    assert _digest(SAMPLES / "batch") == before, "the delivery was written to"
    return proc, out


def test_published_verdicts(inspected) -> None:
    proc, out = inspected
    assert proc.returncode == 1, proc.stderr  # field 3 fails
    summary = json.loads((out / "summary.json").read_text())
    verdicts = {b["block_id"]: b["verdict"] for b in summary["blocks"]}
    assert {k for k, v in verdicts.items() if v == "fail"} == {"F3-B01", "F3-B02"}
    f3 = next(b for b in summary["blocks"] if b["block_id"] == "F3-B01")
    assert {"CP-2", "CP-4", "RO-3"} <= set(f3["failed_rules"])
    for line in ("F1-B01       PASS", "F3-B01       FAIL", "8 blocks: 6 pass, 2 fail"):
        assert line in proc.stdout
    assert summary["complete"] is True  # DOC-3 decided in samples/verdicts.yaml


@pytest.mark.parametrize("block", sorted(PUBLISHED))
def test_checkpoint_statistics_close_to_published(inspected, block: str) -> None:
    _, out = inspected
    r = json.loads((out / block / "results.json").read_text())
    table = {
        (g["component"], g["method"]): g
        for m in r["measurements"]
        if m["metric"] == "checkpoint_accuracy"
        for g in m["tables"]["component_method"]
    }
    assert set(table) == set(PUBLISHED[block])
    for key, (m, mx, n_gross, rate) in PUBLISHED[block].items():
        g = table[key]
        assert g["medium_error"] == pytest.approx(m, abs=0.01), key
        assert g["max_error"] == pytest.approx(mx, abs=0.01), key
        assert g["n_gross"] == n_gross, key
        assert g["gross_rate"] == pytest.approx(rate, abs=0.05), key
    if block == "F3-B01":
        hp = table[("plane", "high_precision")]
        assert hp["used_mean"] and hp["statistic"] == "mean" and hp["n_total"] == 8


def test_outputs_are_complete_and_atomic(inspected) -> None:
    _, out = inspected
    names = {p.name for p in out.rglob("*")}
    assert not any(n.endswith(".tmp") for n in names)
    for block in ("F1-B01", "F4-B02"):
        assert (out / block / "results.json").is_file()
        assert (out / block / "report.html").is_file()
    assert (out / "summary.html").is_file()
    r = json.loads((out / "F3-B01" / "results.json").read_text())
    ro3 = next(x for x in r["results"] if x["rule"] == "RO-3" and x["status"] == "fail")
    assert ro3["evidence"] and ro3["evidence"][0]["value_m"] >= 28.28
    assert ro3["evidence"] == sorted(ro3["evidence"], key=lambda e: -e["value_m"])


def test_results_and_summary_follow_the_published_json_schema(inspected) -> None:
    """`blockqc schema` validates every document the sample batch produces, rejects a broken one."""
    import jsonschema

    from casekit import run_blockqc

    _, out = inspected
    schemas = {}
    for kind in ("results", "summary"):
        proc = run_blockqc("schema", kind)
        assert proc.returncode == 0, proc.stderr
        schemas[kind] = json.loads(proc.stdout)
        jsonschema.Draft202012Validator.check_schema(schemas[kind])
    docs = sorted(out.glob("*/results.json"))
    assert len(docs) == 8
    for path in docs:
        jsonschema.validate(json.loads(path.read_text()), schemas["results"])
    jsonschema.validate(json.loads((out / "summary.json").read_text()), schemas["summary"])
    broken = json.loads(docs[0].read_text())
    broken["results"][0]["status"] = "passed"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, schemas["results"])
    del broken["verdict"]
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, schemas["summary"])
