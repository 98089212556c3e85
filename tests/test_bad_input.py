"""Malformed deliveries, packs and inspector files: exit 2, a message naming file and row/line."""

from __future__ import annotations

from pathlib import Path

import pytest

from casekit import write_delivery


def _no_traceback(proc) -> None:
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout


def _replace(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


@pytest.fixture
def delivery(tmp_path: Path) -> Path:
    return write_delivery(tmp_path / "block")


def test_missing_column(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "tie_points.csv", "v_sample", "vs")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert "tie_points.csv" in p.stderr and "missing column 'v_sample'" in p.stderr
    assert not (tmp_path / "out").exists()  # the folder the run made, left empty: removed


def test_an_output_folder_that_was_there_stays_when_nothing_is_written(blockqc, delivery, tmp_path):
    """Only a folder the run made is removed when the delivery cannot be read."""
    _replace(delivery / "tie_points.csv", "v_sample", "vs")
    (tmp_path / "out").mkdir()
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2 and (tmp_path / "out").is_dir()


def test_text_in_numeric_column(blockqc, delivery: Path, tmp_path: Path) -> None:
    lines = (delivery / "tie_points.csv").read_text().splitlines()
    cells = lines[17].split(",")
    cells[4] = "abc"  # v_line of data row 17, line 18
    lines[17] = ",".join(cells)
    (delivery / "tie_points.csv").write_text("\n".join(lines) + "\n")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert (
        "tie_points.csv, row 17 (line 18), column 'v_line': expected a number, got 'abc'"
        in p.stderr
    )


def test_duplicated_scene_id(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "scenes.csv", "\nS2,", "\nS1,")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert "scenes.csv, row 1 (line 2), column 'scene_id': duplicated key" in p.stderr
    assert "scenes.csv, row 2 (line 3), column 'scene_id': duplicated key" in p.stderr
    assert not (tmp_path / "out" / "CASE" / "results.json").exists()


def test_unknown_scene_reference_and_several_problems_at_once(blockqc, delivery, tmp_path):
    _replace(delivery / "tie_points.csv", ",S4,", ",S9,")
    _replace(delivery / "checkpoints.csv", "high_precision", "best_guess")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert "unknown scene_id (not in scenes.csv), got 'S9'" in p.stderr
    assert "checkpoints.csv, row 1 (line 2), column 'method': expected one of" in p.stderr


def test_bad_manifest_names_its_line(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "block.yaml", "  pan: 1.0", "  pan: -1.0")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert "block.yaml, line 4: gsd_m.pan: expected a number above 0, got a number (-1.0)" in (
        p.stderr
    )


def _pack(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "pack.yaml"
    path.write_text("pack: broken\nextends: global-project\n" + body)
    return path


def test_unknown_rule_key(blockqc, delivery: Path, tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "rules:\n  - id: X-1\n    title: t\n    clause: §TP-1\n"
        "    metric: tie_point_errors\n    statistic: median\n"
        "    threshold: {max: 1}\n    treshold_note: typo\n",
    )
    p = blockqc("inspect", delivery, "--rules", pack, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert f"{pack}, line 10: rule X-1: treshold_note: unknown key" in p.stderr


def test_python_object_tag_is_refused(blockqc, delivery: Path, tmp_path: Path) -> None:
    pack = _pack(tmp_path, "constants:\n  x: !!python/object/apply:os.system ['echo hi']\n")
    p = blockqc("inspect", delivery, "--rules", pack, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert f"{pack}, line 4: not valid YAML" in p.stderr and "python/object" in p.stderr
    assert "hi" not in p.stdout


def test_expression_with_a_function_not_whitelisted(blockqc, delivery, tmp_path) -> None:
    pack = _pack(tmp_path, 'overrides:\n  TP-1:\n    threshold: {max: "exp(norm.plane_m)"}\n')
    p = blockqc("inspect", delivery, "--rules", pack, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert f"{pack}, line 5: rule TP-1: threshold.max: function 'exp' is not allowed" in p.stderr


def test_unknown_metric_and_statistic_listed_together(blockqc, tmp_path: Path) -> None:
    pack = _pack(
        tmp_path, "overrides:\n  TP-1: {metric: tie_point_magic}\n  TP-2: {statistic: biggest}\n"
    )
    p = blockqc("rules", "lint", pack)
    assert p.returncode == 2
    assert "line 4: rule TP-1: unknown metric 'tie_point_magic'" in p.stderr
    assert (
        "line 5: rule TP-2: metric tie_point_errors at scope observation offers no "
        "statistic 'biggest'" in p.stderr
    )


def test_bad_verdicts_file(blockqc, delivery: Path, tmp_path: Path) -> None:
    v = tmp_path / "verdicts.yaml"
    v.write_text("inspector: A\nverdicts:\n  DOC-3: {status: maybe}\n")
    p = blockqc("inspect", delivery, "--verdicts", v, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert f"{v}, line 3: verdicts.DOC-3.status: Input should be 'pass', 'conditional_pass'" in (
        p.stderr
    )


def test_output_inside_the_delivery_is_refused(blockqc, delivery: Path) -> None:
    before = sorted(p.name for p in delivery.rglob("*"))
    p = blockqc("inspect", delivery, "--out", delivery / "out")
    assert p.returncode == 2
    assert "never writes into a delivery" in p.stderr
    assert sorted(p.name for p in delivery.rglob("*")) == before


def test_not_a_delivery(blockqc, tmp_path: Path) -> None:
    p = blockqc("inspect", tmp_path, "--out", tmp_path.parent / "o")
    assert p.returncode == 2
    assert "neither a delivery" in p.stderr


@pytest.mark.parametrize(
    ("sep", "name", "count"),
    [
        (";", "semicolons", -1),
        ("\t", "tabs", -1),
        # as Chinese input methods type them: each column was said to be missing
        ("，", "full-width commas ('，')", -1),
        ("；", "full-width semicolons ('；')", -1),
        ("，", "full-width commas ('，')", 3),  # some of the header's commas only
    ],
)
def test_csv_of_another_separator(
    blockqc, delivery: Path, tmp_path: Path, sep: str, name: str, count: int
) -> None:
    tp = delivery / "tie_points.csv"
    tp.write_text(tp.read_text().replace(",", sep, count))
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert (
        f"tie_points.csv, line 1: columns separated by {name}, not by commas: blockqc reads "
        "CSV tables comma-separated (RFC 4180); export the table with ',' as the separator"
    ) in p.stderr
    assert "missing column" not in p.stderr  # said once, not once per column


@pytest.mark.parametrize(
    ("row", "fields", "name"),
    [
        (3, "1", "full-width commas ('，')"),  # every comma of the row typed full-width
        (2, "2", "full-width semicolons ('；')"),  # all but its first
    ],
)
def test_a_row_of_full_width_separators_is_said_so(
    blockqc, delivery: Path, tmp_path: Path, row: int, fields: str, name: str
) -> None:
    """A row typed with full-width separators under a header of commas was '1 fields where
    the header has 6', without saying why."""
    ov = delivery / "overlaps.csv"
    lines = ov.read_text().splitlines(keepends=True)
    head, _, rest = lines[row].partition(",")
    sep = name[-3]  # the separator named between the quotes: ，or ；
    lines[row] = head + ("," if fields == "2" else sep) + rest.replace(",", sep)
    ov.write_text("".join(lines))
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert (
        f"overlaps.csv, line {row + 1}: not a readable CSV table: {fields} fields where the "
        f"header has 6 (its values are separated by {name}: expected ',')"
    ) in p.stderr, p.stderr


def test_empty_and_ragged_csv(blockqc, delivery: Path, tmp_path: Path) -> None:
    (delivery / "edges.csv").write_text("")
    (delivery / "pan_ms.csv").write_bytes(b" \r\n\t\n")  # white space only: empty too
    with (delivery / "overlaps.csv").open("a") as fh:
        fh.write("S1,S2,O9,1,2,3,4,5\n")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2
    _no_traceback(p)
    assert "edges.csv: the file is empty" in p.stderr
    assert "pan_ms.csv: the file is empty" in p.stderr
    assert "overlaps.csv, line 7: not a readable CSV table: 8 fields where the header has 6" in (
        p.stderr
    )


def test_parquet_tables_read_and_validated(blockqc, delivery: Path, tmp_path: Path) -> None:
    import pandas as pd

    tp = pd.read_csv(delivery / "tie_points.csv", dtype={"point_id": str, "scene_id": str})
    (delivery / "tie_points.csv").unlink()
    tp.to_parquet(delivery / "tie_points.parquet")
    p = blockqc("inspect", delivery, "--out", tmp_path / "ok", "--no-pdf")
    assert p.returncode == 0, p.stderr  # the base delivery passes (DOC-3 awaits the inspector)
    tp["v_line"] = tp["v_line"].astype(object)
    tp.loc[41, "v_line"] = "n/a"
    tp["v_line"] = tp["v_line"].astype(str)
    tp.to_parquet(delivery / "tie_points.parquet")
    p = blockqc("inspect", delivery, "--out", tmp_path / "bad")
    assert p.returncode == 2
    _no_traceback(p)
    assert "tie_points.parquet, row 42, column 'v_line': expected a number, got 'n/a'" in p.stderr
    tp.to_csv(delivery / "tie_points.csv", index=False)
    p = blockqc("inspect", delivery, "--out", tmp_path / "both")
    assert p.returncode == 2 and "both tie_points.csv and tie_points.parquet" in p.stderr


def test_duplicate_block_ids_refused_in_parallel_batch(blockqc, tmp_path: Path) -> None:
    import json

    batch = tmp_path / "batch"
    write_delivery(batch / "a")
    write_delivery(batch / "b")  # the same block_id CASE again
    write_delivery(batch / "c", {"manifest": {"block_id": "OTHER"}})
    p = blockqc("inspect", batch, "--out", tmp_path / "out", "--no-pdf", "--jobs", "2")
    assert p.returncode == 2
    _no_traceback(p)
    assert (
        f"{batch / 'b' / 'block.yaml'}: block_id CASE is also the id of {batch / 'a'}" in p.stderr
    )
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [b["block_id"] for b in summary["blocks"]] == ["CASE", "OTHER"]
    assert summary["unreadable"][0]["path"] == str(batch / "b")
    assert summary["complete"] is False and summary["verdict"] == "error"


def test_block_ids_differing_only_in_case_are_refused(blockqc, tmp_path: Path) -> None:
    """F1-B01 and f1-b01 would write one output folder on a case-insensitive file system."""
    batch = tmp_path / "batch"
    write_delivery(batch / "a", {"manifest": {"block_id": "F1-B01"}})
    write_delivery(batch / "b", {"manifest": {"block_id": "f1-b01"}})
    p = blockqc("inspect", batch, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 2
    _no_traceback(p)
    assert (
        f"{batch / 'b' / 'block.yaml'}: block_id f1-b01 differs only in case from F1-B01, the id "
        f"of {batch / 'a'}: block ids must be unique in a batch, whatever their case" in p.stderr
    )
    assert sorted(q.name for q in (tmp_path / "out").iterdir() if q.is_dir()) == ["F1-B01"]


def test_a_delivery_named_twice_is_inspected_once(blockqc, tmp_path: Path) -> None:
    import json

    batch = tmp_path / "batch"
    write_delivery(batch / "a")
    write_delivery(batch / "c", {"manifest": {"block_id": "OTHER"}})
    again = batch / "a" / ".." / "a"  # the same folder, written otherwise
    p = blockqc("inspect", batch / "a", batch, again, "--out", tmp_path / "out", "--no-pdf")
    _no_traceback(p)
    assert p.returncode in (0, 1), p.stderr
    assert p.stderr.count("named more than once, inspected once") == 2  # in the batch, again
    assert f"warning: {batch / 'a'}: named more than once, inspected once" in p.stderr
    assert f"warning: {again}: named more than once, inspected once" in p.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [b["block_id"] for b in summary["blocks"]] == ["CASE", "OTHER"]
    assert summary["unreadable"] == []
