"""Block-id lists in the summary and acceptance reports: runs of consecutive numbers shortened."""

from __future__ import annotations

from blockqc.report.acceptance import id_list


def test_runs_of_three_or_more_are_written_first_to_last():
    ids = [f"B{i:05d}" for i in range(1000)]
    assert id_list(ids) == "B00000–B00999"
    assert id_list(["B01", "B02", "B04", "B05", "B06", "X", "B07"]) == "B01, B02, B04–B06, X, B07"


def test_prefix_width_and_order_must_match():
    assert id_list(["F1-B01", "F1-B02", "F2-B03"]) == "F1-B01, F1-B02, F2-B03"
    assert id_list(["B9", "B10", "B11"]) == "B9, B10, B11"  # B9 is narrower: not one run
    assert id_list(["B3", "B2", "B1"]) == "B3, B2, B1"
    assert id_list(["T-B01", "T-B02", "T-B03", "T-B03"]) == "T-B01–T-B03, T-B03"


def test_empty_lists():
    assert id_list([]) == "–"
    assert id_list([], empty="") == ""
