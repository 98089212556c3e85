"""`blockqc report` refuses results that contradict themselves, text for numbers, and a summary
whose blocks' results are missing: exit 2, the file and the field named, nothing written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from report_helpers import make_summary, summary_entry

from blockqc.cli import main


def run(*args: str) -> int:
    with pytest.raises(SystemExit) as exc:
        main(list(args))
    return exc.value.code


def _refused(tmp_path: Path, capsys, doc: dict[str, Any]) -> list[str]:
    path = tmp_path / "in" / "results.json"
    path.parent.mkdir()
    path.write_text(json.dumps(doc), encoding="utf-8")
    assert run("report", str(path), "--out", str(tmp_path / "out"), "--no-pdf") == 2
    assert not (tmp_path / "out").exists()
    return capsys.readouterr().err.splitlines()


def test_a_pass_verdict_over_a_failing_result_is_refused(tmp_path, capsys, results_doc):
    # the hand-made document has 5 failing results (TP-4, CP-2, ...), and says fail
    err = _refused(tmp_path, capsys, {**results_doc, "verdict": "pass"})
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: $.verdict is pass, but its rule results "
        "make it fail (0 error, 5 fail)"
    ]


def test_counts_that_are_not_those_of_the_results_are_refused(tmp_path, capsys, results_doc):
    counts = {**results_doc["counts"], "fail": 0}
    err = _refused(tmp_path, capsys, {**results_doc, "counts": counts})
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: $.counts.fail is 0, but 5 rule result(s) "
        "have status fail"
    ]


def test_a_count_written_as_text_is_refused(tmp_path, capsys, results_doc):
    counts = {**results_doc["counts"], "pass": "7"}
    err = _refused(tmp_path, capsys, {**results_doc, "counts": counts})
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: not a valid results.json: at "
        "$.counts.pass: Input should be a valid integer"
    ]


def test_a_summary_block_without_its_results_is_refused(tmp_path, capsys, results_doc):
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    lines = [summary_entry("T-B01", "fail"), summary_entry("T-B02", "pass")]
    (batch / "summary.json").write_text(json.dumps(make_summary(lines)), encoding="utf-8")
    assert run("report", str(batch), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: {batch / 'summary.json'}: lists block T-B02, but its results file "
        f"{batch / 'T-B02' / 'results.json'} is missing (name the results files to re-render "
        "without the summary)"
    ]
    assert not (tmp_path / "o").exists()
    # the blocks that are there can still be re-rendered, without the summary
    assert run("report", str(batch / "T-B01"), "--out", str(tmp_path / "o"), "--no-pdf") == 0


def test_a_results_json_saved_with_a_byte_order_mark_is_read(tmp_path, results_doc):
    path = tmp_path / "in" / "results.json"
    path.parent.mkdir()
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(results_doc).encode("utf-8"))
    assert run("report", str(path), "--out", str(tmp_path / "out"), "--no-pdf") == 0
    assert (tmp_path / "out" / results_doc["block_id"] / "report.html").is_file()


def _edited(doc: dict[str, Any], index: int, **fields: Any) -> dict[str, Any]:
    results = [dict(r) for r in doc["results"]]
    results[index].update(fields)
    return {**doc, "results": results}


def test_a_passing_status_over_a_value_beyond_its_threshold_is_refused(
    tmp_path, capsys, results_doc
):
    # TP-1 (results[3]) passes at 0.31 px <= 0.5 px; its value edited to 0.93 px fails it
    err = _refused(tmp_path, capsys, _edited(results_doc, 3, value=0.93))
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: $.results[3] (TP-1): status pass, but its "
        "value 0.93 against <= 0.5 does not meet the threshold"
    ]


def test_a_failing_status_over_a_value_within_its_threshold_is_refused(
    tmp_path, capsys, results_doc
):
    # CP-2 plane high_precision (results[7]) fails at 10.4 m > 10 m; 9.6 m would pass
    err = _refused(tmp_path, capsys, _edited(results_doc, 7, value=9.6))
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: $.results[7] (CP-2, component plane, "
        "method high_precision): status fail, but its value 9.6 against <= 10.0 meets the "
        "threshold"
    ]


def test_a_value_on_an_inclusive_bound_within_its_rounding_passes(tmp_path, results_doc):
    # 10.000000000000005 m is 10 m as the engine judges it (within 1e-9 of the bound)
    doc = _edited(results_doc, 8, value=10.000000000000005)
    path = tmp_path / "in" / "results.json"
    path.parent.mkdir()
    path.write_text(json.dumps(doc), encoding="utf-8")
    assert run("report", str(path), "--out", str(tmp_path / "out"), "--no-pdf") == 0


def test_a_warning_status_of_a_rule_of_severity_fail_is_refused(tmp_path, capsys, results_doc):
    # RO-3 (results[6]) fails; written as a warning, with the counts and verdict to match
    doc = _edited(results_doc, 6, status="warn")
    counts = {**doc["counts"], "fail": doc["counts"]["fail"] - 1, "warn": 1}
    err = _refused(tmp_path, capsys, {**doc, "counts": counts})
    assert err == [
        f"error: {tmp_path / 'in' / 'results.json'}: $.results[6] (RO-3, component plane): "
        "status warn, but the rule's severity is fail (a failure fails the block)"
    ]
