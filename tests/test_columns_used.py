"""A pack with `columns: used` reads only the tie-point columns its rules use: the results are
those of a full read, the columns not read (and the checks over them) are stated, and the
observations shown as evidence get their point ids from the file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.delivery import load_delivery, read_rows
from blockqc.engine import inspect_delivery, tie_point_columns
from blockqc.errors import InputError, RuleError
from blockqc.rules import load_pack
from casekit import run_blockqc, write_delivery

ERRORS = {"scene_id", "line", "sample", "v_line", "v_sample"}  # what TP-1..TP-5 read

#: TP-2 fails on one observation of S3 (2 px); its evidence names the point
FAILING = {
    "set": {
        "tie_points": [
            {"where": {"point_id": "PS3-050", "scene_id": "S3"}, "values": {"v_line": 2.0}}
        ]
    }
}


def _pack(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"pack: {name}\n{body}", "utf-8")
    return path


def _to_parquet(folder: Path, rows_per_group: int) -> None:
    """tie_points.csv as tie_points.parquet in row groups of `rows_per_group` rows."""
    csv = folder / "tie_points.csv"
    frame = pd.read_csv(csv, dtype={"point_id": str, "scene_id": str})
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), folder / "tie_points.parquet",
                   row_group_size=rows_per_group)  # fmt: skip
    csv.unlink()


def test_the_setting_is_inherited_overridden_and_checked(tmp_path: Path) -> None:
    used = _pack(tmp_path, "used", "extends: global-project\ncolumns: used\n")
    child = _pack(tmp_path, "child", f"extends: {used}\n")
    back = _pack(tmp_path, "back", f"extends: {used}\ncolumns: all\n")
    assert load_pack("global-project").columns == "all"
    assert load_pack(used).columns == load_pack(child).columns == "used"
    assert load_pack(back).columns == "all"
    wrong = _pack(tmp_path, "wrong", "extends: global-project\n\ncolumns: some\n")
    with pytest.raises(RuleError) as err:
        load_pack(wrong)
    assert err.value.problems[0].line == 4 and "columns" in str(err.value.problems[0])


def test_the_columns_a_pack_reads(tmp_path: Path) -> None:
    """Every column for a pack without the setting; with it, those of its metrics (the scene
    id always, to check it against the scenes)."""
    assert tie_point_columns(load_pack("global-project")) is None
    used = _pack(tmp_path, "used", "extends: global-project\ncolumns: used\n")
    assert tie_point_columns(load_pack(used)) == ERRORS
    basis = _pack(
        tmp_path,
        "basis",
        f"extends: {used}\ndisable: [TP-1, TP-2, TP-3, TP-4, TP-5, DOC-2]\n",
    )
    assert tie_point_columns(load_pack(basis)) == {"scene_id"}
    listed = run_blockqc("rules", "list", "--rules", used).stdout.splitlines()[-1]
    assert (
        listed == "tie-point columns read (columns: used): line, sample, scene_id, v_line, v_sample"
    )


@pytest.mark.parametrize("form", ["csv", "parquet"])
def test_columns_not_read_are_listed_and_the_rest_checked(tmp_path: Path, form: str) -> None:
    folder = write_delivery(tmp_path / "block")
    if form == "parquet":
        _to_parquet(folder, 100)
    d = load_delivery(folder, tie_point_columns={"scene_id", "v_line", "v_sample"})
    assert list(d.tie_points.columns) == ["scene_id", "v_line", "v_sample"]
    assert d.not_read == {"tie_points": ["point_id", "line", "sample"]}
    assert len(d.tie_points) == 4 * 121
    assert load_delivery(folder).not_read == {}


def test_problems_of_the_columns_read_and_of_the_header_are_still_found(tmp_path: Path) -> None:
    """A required column missing or named twice is found from the header, a scene id not in
    the scenes and an empty residual in the columns read; a bad point id, not read, is not."""
    case = {
        "set": {
            "tie_points": [
                {"where": {"point_id": "PS1-000"}, "values": {"scene_id": "S9"}},
                {"where": {"point_id": "PS2-000"}, "values": {"v_line": None}},
                {"where": {"point_id": "PS3-000"}, "values": {"point_id": " "}},
            ]
        }
    }
    folder = write_delivery(tmp_path / "block", case)
    with pytest.raises(InputError) as err:
        load_delivery(folder, tie_point_columns={"scene_id", "v_line", "v_sample"})
    text = "\n".join(map(str, err.value.problems))
    assert "unknown scene_id" in text and "'S9'" in text
    assert "v_line" in text and "required" in text
    assert "point_id" not in text  # not read: its check is not made (and stated when read)
    frame = pd.read_csv(folder / "tie_points.csv", dtype=str)  # no point_id, line twice:
    frame = frame[["scene_id", "line", "line", "sample", "v_line", "v_sample"]]
    frame.to_csv(folder / "tie_points.csv", index=False)
    with pytest.raises(InputError) as err:
        load_delivery(folder, tie_point_columns={"scene_id", "v_line", "v_sample"})
    text = "\n".join(map(str, err.value.problems))
    assert "missing column 'point_id'" in text
    assert "column 'line' appears more than once" in text


@pytest.mark.parametrize("form", ["csv", "parquet"])
def test_results_as_a_full_read_and_evidence_with_point_ids(tmp_path: Path, form: str) -> None:
    """TP-1..TP-5 give the same results as with every column read; the failing observation of
    TP-2 is named by its point id, read from the file (Parquet: from its row group only)."""
    folder = write_delivery(tmp_path / "block", FAILING)
    if form == "parquet":
        _to_parquet(folder, 37)  # the observation lies in the 8th of 14 row groups
    used = load_pack(_pack(tmp_path, "used", "extends: global-project\ncolumns: used\n"))
    full = inspect_delivery(load_delivery(folder), used)
    part = inspect_delivery(load_delivery(folder, tie_point_columns=tie_point_columns(used)), used)
    assert part.not_read == {"tie_points": ["point_id"]}
    assert part.summary["tie_points"] is None and full.summary["tie_points"] == 4 * 121

    def tp(results) -> list[dict]:
        return [r.model_dump() for r in results.results if r.rule.startswith("TP")]

    for a, b in zip(tp(full), tp(part), strict=True):
        a["detail"].pop("n_points", None)
        assert a == b
    (tp2,) = [r for r in part.results if r.rule == "TP-2"]
    assert tp2.status == "fail"
    assert tp2.evidence == [
        {"point_id": "PS3-050", "scene_id": "S3", "line": 409.0, "sample": 591.0,
         "v_line": 2.0, "v_sample": pytest.approx(0.3 * np.sin(50 * 0.7)),
         "error_px": pytest.approx(np.hypot(2.0, 0.3 * np.sin(50 * 0.7)))}
    ]  # fmt: skip


@given(
    st.lists(st.integers(1, 40), min_size=1, max_size=6),
    st.lists(st.integers(0, 10**6), min_size=1, max_size=30),
)
@settings(max_examples=60, deadline=None)
def test_rows_read_back_by_position(tmp_path_factory, groups: list[int], picks: list[int]) -> None:
    """Rows read by position from a Parquet file of row groups of any sizes, and from a CSV,
    are the rows at those positions."""
    folder = tmp_path_factory.mktemp("rows")
    n = sum(groups)
    ids = pa.array([f"P{i:05d}" for i in range(n)])
    writer = pq.ParquetWriter(folder / "t.parquet", pa.schema([("point_id", pa.string())]))
    start = 0
    for size in groups:
        writer.write_table(pa.table({"point_id": ids[start : start + size]}))
        start += size
    writer.close()
    (folder / "t.csv").write_text("point_id\n" + "\n".join(ids.to_pylist()) + "\n", "utf-8")
    rows = np.array([p % n for p in picks])
    want = [f"P{i:05d}" for i in rows]
    assert read_rows(folder / "t.parquet", "point_id", rows).to_pylist() == want
    assert read_rows(folder / "t.csv", "point_id", rows).to_pylist() == want


@pytest.mark.parametrize("lang, label", [("en", "Not read"), ("zh", "未读取")])
def test_results_and_report_state_what_was_not_read(tmp_path: Path, lang: str, label: str):
    folder = write_delivery(tmp_path / "CASE")
    pack = _pack(tmp_path, "used", "extends: global-project\ncolumns: used\n")
    out = tmp_path / "out"
    p = run_blockqc("inspect", folder, "--rules", pack, "--out", out, "--pdf", "none",
                    "--lang", lang)  # fmt: skip
    assert p.returncode in (0, 1), p.stderr
    results = json.loads((out / "CASE" / "results.json").read_text("utf-8"))
    assert results["not_read"] == {"tie_points": ["point_id"]}
    html = (out / "CASE" / "report.html").read_text("utf-8")
    assert label in html and "tie_points.point_id" in html


@pytest.mark.parametrize("form", ["csv", "parquet"])
def test_every_stock_metric_reads_no_more_than_it_declares(tmp_path: Path, form: str) -> None:
    """Each metric of the stock pack, measured on a delivery read with only the tie-point
    columns it declares, gives the tables of a full read (its lazy columns filled in)."""
    from blockqc.engine import Context, names_for
    from blockqc.metrics import REGISTRY
    from blockqc.rules.expr import resolve_params

    folder = write_delivery(tmp_path / "block", FAILING)
    if form == "parquet":
        _to_parquet(folder, 50)
    pack = load_pack("global-project")
    full_delivery = load_delivery(folder)
    names = names_for(full_delivery, pack)
    for rule in (r for r in pack.rules if not r.manual):
        spec = REGISTRY[rule.metric]
        cols = spec.tie_point_columns(resolve_params(spec.params, rule.params, names))
        part = load_delivery(
            folder, tie_point_columns=None if cols is None else {"scene_id", *cols}
        )
        a = Context(full_delivery, names).measure(rule.metric, rule.params)
        b = Context(part, names).measure(rule.metric, rule.params)
        assert a.not_applicable == b.not_applicable
        counted = ["n_points"] if rule.metric == "tie_point_errors" else []  # needs point ids
        for scope, table in a.tables.items():
            want = table.complete(table.df).drop(columns=counted, errors="ignore")
            other = b.tables[scope]
            pd.testing.assert_frame_equal(want, other.complete(other.df), obj=f"{rule.id} {scope}")
