"""`blockqc report` refuses results that contradict themselves, text for numbers, and a summary
whose blocks' results are missing: exit 2, the file and the field named, nothing written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from report_helpers import make_summary, results_entry, summary_entry

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
    lines = [results_entry(results_doc), summary_entry("T-B02", "pass")]
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


@pytest.mark.parametrize(
    ("index", "value", "message"),
    [
        # TP-1 (results[3]) passes at 0.31 px <= 0.5 px; its value edited to 0.93 px fails it
        (3, 0.93, "(TP-1): status pass, but its value 0.93 against <= 0.5 does not meet the "
         "threshold"),
        # CP-2 plane high_precision (results[7]) fails at 10.4 m > 10 m; 9.6 m would pass
        (7, 9.6, "(CP-2, component plane, method high_precision): status fail, but its value "
         "9.6 against <= 10.0 meets the threshold"),
    ],
    ids=["pass-beyond", "fail-within"],
)  # fmt: skip
def test_a_status_its_value_does_not_make_is_refused(
    tmp_path, capsys, results_doc, index, value, message
):
    err = _refused(tmp_path, capsys, _edited(results_doc, index, value=value))
    path = tmp_path / "in" / "results.json"
    assert err == [f"error: {path}: $.results[{index}] {message}"]


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


def _summary_refused(tmp_path: Path, capsys, results_doc, summary: dict[str, Any]) -> list[str]:
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    (batch / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    assert run("report", str(batch), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert not (tmp_path / "o").exists()
    prefix = f"error: {batch / 'summary.json'}: "
    return [line.removeprefix(prefix) for line in capsys.readouterr().err.splitlines()]


AGAIN = "the summary is not that of these results (inspect again, or name the results files "


def test_a_summary_naming_other_failed_rules_than_its_results_is_refused(
    tmp_path, capsys, results_doc
):
    # the block fails TP-4, TP-5, RO-3, CP-2 and CP-4 (results[4..7], [10]): its summary
    # line names only TP-4
    entry = results_entry(results_doc, failed_rules=["TP-4"])
    err = _summary_refused(tmp_path, capsys, results_doc, make_summary([entry]))
    assert err == [
        'lists block T-B01 with failed_rules ["TP-4"], but its results file makes it '
        f'["CP-2", "CP-4", "RO-3", "TP-4", "TP-5"]: {AGAIN}without the summary)'
    ]


def test_a_summary_whose_checkpoint_figures_are_not_its_results_is_refused(
    tmp_path, capsys, results_doc
):
    entry = results_entry(results_doc)
    rows = [dict(r) for r in entry["checkpoints"]]
    at = next(i for i, r in enumerate(rows) if r["method"] == "same_accuracy")
    assert rows[at]["medium_error"] == 2.1  # the hand-made same-accuracy plane figure
    rows[at]["medium_error"] = 1.2
    err = _summary_refused(
        tmp_path, capsys, results_doc, make_summary([{**entry, "checkpoints": rows}])
    )
    assert err == [
        f"lists block T-B01 with checkpoints [{at}] (plane, same_accuracy) medium_error 1.2, "
        f"but its results file makes it 2.1: {AGAIN}without the summary)"
    ]


def test_a_summary_whose_counts_per_rule_are_not_its_blocks_is_refused(
    tmp_path, capsys, results_doc
):
    # results_doc holds two CP-2 results, one passing and one failing (results[7], [8])
    zero = dict.fromkeys(("pass", "fail", "warn", "waived", "manual", "not_applicable"), 0)
    rules = {"CP-2": {**zero, "pass": 2, "error": 0}, "TP-1": {**zero, "pass": 1, "error": 0}}
    summary = make_summary([results_entry(results_doc)], rules)
    err = _summary_refused(tmp_path, capsys, results_doc, summary)
    assert err[0] == (
        "$.rules.CP-2 counts pass 2, fail 0, but its blocks' results files hold pass 1, fail 1: "
        "the summary is not that of these results"
    )
    # every rule of the results the summary does not count is named too (MB-1 … DOC-3)
    assert len(err) == 1 + len({r["rule"] for r in results_doc["results"]} - {"CP-2", "TP-1"})


def test_a_summary_complete_over_a_pending_item_is_refused(tmp_path, capsys, results_doc):
    doc = {**results_doc, "pending_manual": ["DOC-3"]}
    doc["results"] = [
        {**r, "status": "manual", "value": None} if r["rule"] == "DOC-3" else r
        for r in results_doc["results"]
    ]
    doc["counts"] = {**doc["counts"], "pass": doc["counts"]["pass"] - 1, "manual": 1}
    err = _summary_refused(tmp_path, capsys, doc, make_summary([results_entry(doc)]))
    assert err == [
        "$.complete is true, but its blocks make it false (complete unless a delivery is "
        "unreadable, a block incomplete or awaiting the inspector)"
    ]


def test_a_summary_over_results_of_another_pack_is_refused(tmp_path, capsys, results_doc):
    # the block judged by a project's pack, the summary by the stock one (make_summary)
    doc = {**results_doc, "rule_pack": "strict-project", "rule_pack_version": "2.0"}
    err = _summary_refused(tmp_path, capsys, doc, make_summary([results_entry(doc)]))
    assert err == [
        "is of rule pack global-project 1.0, but block T-B01's results file "
        "T-B01/results.json was judged by strict-project 2.0: the summary is not that of these "
        "results"
    ]
