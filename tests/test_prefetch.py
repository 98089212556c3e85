"""A delivery's tie points read while the command's modules import (blockqc.prefetch): what is
taken is what the reader would have read, a changed or broken file is read again by the reader,
and `inspect` gives the same results read ahead or not."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from blockqc import prefetch
from casekit import extension_pack, run_blockqc, write_delivery

COLUMNS = ["scene_id", "line", "sample", "v_line", "v_sample"]


@pytest.fixture
def delivery(tmp_path: Path) -> Path:
    """The rule-case delivery with its tie points in Parquet, in row groups of 50 rows."""
    block = write_delivery(tmp_path / "batch" / "block")
    frame = pd.read_csv(block / "tie_points.csv", dtype={"point_id": str, "scene_id": str})
    table = pa.Table.from_pandas(frame, preserve_index=False)
    pq.write_table(table, block / "tie_points.parquet", row_group_size=50)
    (block / "tie_points.csv").unlink()
    return block


def _as_the_reader_reads(path: Path, columns: list[str]) -> pa.Table:
    parquet = pq.ParquetFile(path, read_dictionary=["scene_id"], pre_buffer=False)
    return parquet.read(columns=columns)


def test_the_columns_read_ahead_are_those_the_reader_reads(delivery: Path) -> None:
    path = delivery / "tie_points.parquet"
    prefetch.start(delivery)
    got = prefetch.take(path, ["point_id", *COLUMNS], dictionary=["scene_id"])
    assert got is not None and got.column_names == COLUMNS
    assert got.equals(_as_the_reader_reads(path, COLUMNS))
    assert got.column("scene_id").num_chunks == pq.ParquetFile(path).num_row_groups
    assert prefetch.take(path, COLUMNS, ["scene_id"]) is None  # taken once


def test_only_the_columns_asked_for_and_read_the_same_way_are_taken(delivery: Path) -> None:
    path = delivery / "tie_points.parquet"
    prefetch.start(delivery)
    got = prefetch.take(path, ["scene_id", "line"], dictionary=[])  # scene_id as plain text
    assert got is not None and got.column_names == ["line"]


def test_a_file_changed_since_is_left_to_the_reader(delivery: Path) -> None:
    path = delivery / "tie_points.parquet"
    prefetch.start(delivery)
    table = pq.read_table(path)
    pq.write_table(table.slice(0, 10), path)
    os.utime(path, ns=(1, 1))  # whatever the clock's resolution
    assert prefetch.take(path, COLUMNS, ["scene_id"]) is None


def test_a_broken_file_is_left_to_the_reader(delivery: Path, tmp_path: Path) -> None:
    """Nothing is taken from a file that is no Parquet table, and `inspect` of the delivery
    alone (read ahead) says what `inspect --incremental` (not read ahead) says of it."""
    path = delivery / "tie_points.parquet"
    path.write_bytes(b"PAR1 not a table")
    prefetch.start(delivery)
    assert prefetch.take(path, COLUMNS, ["scene_id"]) is None
    ahead = run_blockqc("inspect", delivery, "--out", tmp_path / "a", "--pdf", "none")
    not_ahead = run_blockqc(
        "inspect", delivery, "--out", tmp_path / "b", "--pdf", "none", "--incremental"
    )
    assert ahead.returncode == not_ahead.returncode == 2
    assert "tie_points.parquet: not a readable Parquet table" in ahead.stderr
    assert ahead.stderr == not_ahead.stderr


def _results(out: Path) -> dict:
    (path,) = out.glob("*/results.json")
    results = json.loads(path.read_text(encoding="utf-8"))
    results.pop("generated_at")
    return results


@pytest.mark.parametrize("columns", ["all", "used"])
def test_inspect_gives_the_same_results_read_ahead_or_not(
    delivery: Path, tmp_path: Path, columns: str
) -> None:
    """One delivery (read ahead) and the same with --incremental into a fresh folder (not read
    ahead): the stock pack, which reads every column, and one reading the columns it uses."""
    pack = extension_pack(tmp_path, f"columns: {columns}\n")
    args = ["inspect", delivery, "--rules", pack, "--pdf", "none"]
    ahead = run_blockqc(*args, "--out", tmp_path / "a")
    not_ahead = run_blockqc(*args, "--out", tmp_path / "b", "--incremental")
    assert ahead.returncode == not_ahead.returncode, ahead.stderr + not_ahead.stderr
    assert _results(tmp_path / "a") == _results(tmp_path / "b")


def _taken(monkeypatch, *args: object) -> list[list[str]]:
    """The columns `blockqc inspect ARGS` (run in this process) took as read ahead."""
    from blockqc.cli import main

    taken: list[list[str]] = []
    take = prefetch.take

    def recorded(*a, **k):
        got = take(*a, **k)
        taken.append([] if got is None else got.column_names)
        return got

    monkeypatch.setattr(prefetch, "take", recorded)
    with pytest.raises(SystemExit):
        main([str(a) for a in args])
    return taken


def test_one_delivery_is_read_ahead_a_batch_or_a_reuse_not(
    delivery: Path, tmp_path: Path, monkeypatch
) -> None:
    out = ["--pdf", "none", "--out"]
    assert _taken(monkeypatch, "inspect", delivery, *out, tmp_path / "a") == [COLUMNS]
    assert _taken(monkeypatch, "inspect", delivery.parent, *out, tmp_path / "b") == [[]]
    again = ["inspect", delivery, *out, tmp_path / "c", "--incremental"]
    assert _taken(monkeypatch, *again) == [[]]


def test_the_names_read_ahead_are_the_contracts_and_the_metrics(delivery: Path) -> None:
    """prefetch names again, without importing pandas, what delivery.py and the tie-point
    metrics own: the columns every tie-point metric reads, the text columns read as Arrow
    dictionaries, the Parquet file of the tie points and the file that makes a delivery."""
    import inspect as source

    from blockqc import cli
    from blockqc.delivery import MANIFEST, _bounded_keys, _table_file
    from blockqc.metrics.tiepoints import DISTRIBUTION_COLUMNS, ERROR_COLUMNS
    from blockqc.schema import TABLES

    assert prefetch.COLUMNS == ERROR_COLUMNS and set(DISTRIBUTION_COLUMNS) <= set(COLUMNS)
    read = pa.schema([(n, pa.string() if n == "scene_id" else pa.float64()) for n in COLUMNS])
    assert list(prefetch.DICTIONARY) == _bounded_keys(TABLES["tie_points"], read)
    assert _table_file(delivery, "tie_points") == delivery / prefetch.FILE
    assert f'"{MANIFEST}"' in source.getsource(cli._read_ahead)
