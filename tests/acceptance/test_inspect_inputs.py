"""The inspector's inputs to `inspect` that would match nothing are refused up front: checkpoint
files without a block_id column for a batch, waivers naming a document kind the rule does not
check (or units under the wrong key)."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.checkpoint_inputs import check_blocks, load_checkpoint_files
from blockqc.delivery import DeliveryIds
from blockqc.errors import InputError
from blockqc.inspector import check_inspector_input, load_inspector_input
from blockqc.rules import load_pack
from casekit import base_tables, run_blockqc, write_delivery

NO_BLOCK_COLUMN = (
    "several blocks are inspected: give a 'block_id' column saying which block each checkpoint "
    "belongs to"
)


def _checkpoints(tmp_path: Path) -> Path:
    path = tmp_path / "mine.csv"
    cps = base_tables()["checkpoints"].head(3).assign(method="recalculation")
    cps.to_csv(path, index=False)
    return path


def test_no_block_id_column_for_several_deliveries_is_refused_once(tmp_path: Path) -> None:
    paths = [write_delivery(tmp_path / b, {"manifest": {"block_id": b}}) for b in ("B00", "B01")]
    cps = load_checkpoint_files([_checkpoints(tmp_path)])
    check_blocks(cps, paths[:1])  # one delivery: the rows are its own
    with pytest.raises(InputError) as exc:
        check_blocks(cps, paths)
    assert [str(p) for p in exc.value.problems] == [f"{tmp_path / 'mine.csv'}: {NO_BLOCK_COLUMN}"]


def test_inspect_refuses_it_before_any_block_is_read(tmp_path: Path) -> None:
    for b in ("B00", "B01"):
        write_delivery(tmp_path / "batch" / b, {"manifest": {"block_id": b}})
    cps, out = _checkpoints(tmp_path), tmp_path / "out"
    r = run_blockqc("inspect", tmp_path / "batch", "--checkpoints", cps, "--out", out, "--no-pdf")
    assert r.returncode == 2
    assert r.stderr.count(NO_BLOCK_COLUMN) == 1 and "UNREADABLE" not in r.stdout + r.stderr
    assert not list(out.glob("**/*.json"))


def test_an_empty_block_id_is_named_by_row(tmp_path: Path) -> None:
    path = tmp_path / "mine.csv"
    cps = base_tables()["checkpoints"].head(3).assign(method="recalculation", block_id="B00")
    cps.loc[1, "block_id"] = " "
    cps.to_csv(path, index=False)
    with pytest.raises(InputError) as exc:
        load_checkpoint_files([path])
    assert [str(p) for p in exc.value.problems] == [
        f"{path}, row 2 (line 3), column 'block_id': empty: every row names the block of its "
        "checkpoint"
    ]


def test_a_checkpoints_file_neither_csv_nor_parquet_is_named_so(tmp_path: Path) -> None:
    path = _checkpoints(tmp_path).rename(tmp_path / "mine.txt")
    with pytest.raises(InputError) as exc:
        load_checkpoint_files([path])
    assert [str(p) for p in exc.value.problems] == [
        f"{path}: named .txt; expected a checkpoints table: a .csv file (with a header row) or "
        "a .parquet file"
    ]


@pytest.fixture(scope="module")
def rules():
    return {r.id: r for r in load_pack("global-project").rules}


def _check(tmp_path: Path, rules, text: str) -> list[str]:
    path = tmp_path / "verdicts.yaml"
    path.write_text(text, "utf-8")
    with pytest.raises(InputError) as exc:
        check_inspector_input(
            load_inspector_input(path), rules, {"B00": DeliveryIds("B00", tmp_path, {"S1"})}
        )
    return [str(p).removeprefix(f"{path}, ") for p in exc.value.problems]


def test_a_waiver_for_a_document_kind_the_rule_does_not_check(tmp_path: Path, rules) -> None:
    text = "waivers:\n  DOC-1:\n    reason: on paper\n    units: [tecnical_design]\n"
    assert _check(tmp_path, rules, text) == [
        "line 4: a waiver for document 'tecnical_design', which rule DOC-1 does not check "
        "(technical_design, inspection_report, technical_summary, relative_orientation_report, "
        "absolute_orientation_report); did you mean 'technical_design'?"
    ]


def test_documents_are_waived_under_units(tmp_path: Path, rules) -> None:
    text = "waivers:\n  DOC-1:\n    reason: on paper\n    scenes: [S1]\n"
    assert _check(tmp_path, rules, text) == [
        "line 4: rule DOC-1 is judged per document: list the document kinds to waive under "
        "'units' ('scenes' would match none)"
    ]


def test_a_waiver_for_a_document_kind_the_rule_checks(tmp_path: Path, rules) -> None:
    path = tmp_path / "verdicts.yaml"
    path.write_text("waivers:\n  DOC-1:\n    reason: r\n    units: [technical_design]\n", "utf-8")
    check_inspector_input(
        load_inspector_input(path), rules, {"B00": DeliveryIds("B00", tmp_path, {"S1"})}
    )


@pytest.mark.parametrize("text", ["", "# verdicts to come\n"])
def test_a_verdicts_file_that_says_nothing_is_refused(tmp_path: Path, text: str) -> None:
    """--verdicts given with a file saved empty (or a template of comments): refused, not
    taken for an inspector who gave no verdict."""
    path = tmp_path / "verdicts.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_inspector_input(path)
    assert [str(p) for p in exc.value.problems] == [
        f"{path}: holds no verdicts (empty, or comments only): expected a mapping (inspector, "
        "verdicts, waivers); leave --verdicts out to give none"
    ]
