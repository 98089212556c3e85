"""The experiments table: the appendix reads, bad cells are named by row and column."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS, read_table, write_table_csv
from blockqc.errors import InputError


def test_appendix_reads_as_published(appendix_path):
    t = read_table(appendix_path)
    assert len(t) == 20
    assert list(t.columns[4:19]) == list(FACTOR_COLUMNS + INDICATOR_COLUMNS)
    # row 1 as printed in the appendix (Tang et al. 2023, table A1/A2)
    assert t.loc[0, "images_area_km2"] == 59601.0
    assert t.loc[0, "tp_nn_coefficient"] == 0.60
    assert t.loc[19, "h_rmse_m"] == 5.879


def test_bad_cells_name_row_and_column(tmp_path, appendix_path):
    lines = appendix_path.read_text(encoding="utf-8").splitlines()
    cells = lines[3].split(",")
    cells[5] = "n/a"  # mean_slope_deg of data row 3
    cells[15] = ""  # s_rmse_px of data row 3
    lines[3] = ",".join(cells)
    bad, err = _refused(tmp_path / "bad.csv", lines)
    found = {(p.row, p.column) for p in err.problems}
    assert found == {(3, "mean_slope_deg"), (3, "s_rmse_px")}
    assert all(p.file == str(bad) for p in err.problems)


def test_values_no_factor_or_indicator_takes_are_named(tmp_path, appendix_path):
    """A negative RMS error or count, a slope above 90°: refused by row and column; a mean
    elevation below sea level is a value it takes."""
    lines = appendix_path.read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    cells = lines[2].split(",")
    for col, value in (
        ("h_rmse_m", "-3"), ("tp_number", "-1"), ("mean_slope_deg", "95"),
        ("mean_elevation_m", "-400"),
    ):  # fmt: skip
        cells[header.index(col)] = value
    lines[2] = ",".join(cells)
    bad, err = _refused(tmp_path / "bad.csv", lines)
    found = {(p.row, p.column): p.message for p in err.problems}
    assert set(found) == {(2, "h_rmse_m"), (2, "tp_number"), (2, "mean_slope_deg")}
    assert found[(2, "mean_slope_deg")] == "'95': a mean slope (°) is at least 0 and at most 90"
    assert found[(2, "h_rmse_m")] == "'-3': a δ_H (m) is at least 0"


def test_missing_column_is_named(tmp_path, appendix_path):
    text = appendix_path.read_text(encoding="utf-8").replace("tp_nn_coefficient", "tp_nn")
    bad = tmp_path / "renamed.csv"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_table(bad)
    assert [p.column for p in err.value.problems] == ["tp_nn_coefficient"]


def test_a_column_with_its_unit_in_the_header_is_pointed_at(tmp_path, appendix_path):
    """A spreadsheet's header `mean_elevation_m (m)`, or in capitals: the column the user gave
    is named beside the one expected."""
    text = appendix_path.read_text(encoding="utf-8")
    text = text.replace("mean_elevation_m", "mean_elevation_m (m)", 1)
    text = text.replace("h_rmse_m", "H_RMSE_M", 1)
    bad = tmp_path / "units.csv"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_table(bad)
    expected = "the header must name the ten factors and five indicators as in "
    expected += "samples/factors/gf7_adjustment_experiments.csv"
    assert [p.message for p in err.value.problems] == [
        f"required column missing ({expected}); is 'mean_elevation_m (m)' meant to be it?",
        f"required column missing ({expected}); is 'H_RMSE_M' meant to be it?",
    ]


def test_the_experiment_column_in_other_case_is_refused(tmp_path, appendix_path):
    """`Experiment` was kept as an extra column and the experiments numbered 1, 2, … by row:
    the ids given, and an id given twice, went unread."""
    lines = _rows(appendix_path, 4)
    lines[0] = "Experiment" + lines[0].removeprefix("experiment")
    bad, err = _refused(tmp_path / "ids.csv", lines)
    assert str(err) == (
        f"{bad}, column 'Experiment': did you mean 'experiment'? (the experiments would be "
        "numbered by row instead of by the ids it holds)"
    )


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_table(tmp_path / "nothing.csv")


def _refused(bad: Path, lines: list[str]) -> tuple[Path, InputError]:
    """The table of `lines` written to `bad`, and read_table's refusal of it."""
    bad.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_table(bad)
    return bad, err.value


def _rows(appendix_path, n: int) -> list[str]:
    """The appendix header and its first `n` data rows, as lines."""
    return appendix_path.read_text(encoding="utf-8").splitlines()[: n + 1]


def test_duplicate_experiment_ids_are_named(tmp_path, appendix_path):
    lines = _rows(appendix_path, 4)
    lines[4] = "2" + lines[4][1:]  # data row 4 takes the id of data row 2
    bad, err = _refused(tmp_path / "dup.csv", lines)
    assert str(err) == (
        f"{bad}, row 4 (line 5), column 'experiment': experiment id '2' is also the id of "
        "row 2 (line 3): each experiment needs its own id"
    )


def test_rows_are_named_with_their_line(tmp_path, appendix_path):
    """Blank lines and a quoted cell over two lines: the line is where the row starts."""
    lines = _rows(appendix_path, 5)
    lines[2] = lines[2].replace("08HZ", '"08\nHZ"')  # data row 2 spans lines 3 and 4
    cells = lines[4].split(",")
    cells[5] = "abc"  # mean_slope_deg of data row 4
    lines[4] = ",".join(cells)
    lines.insert(4, "")  # a blank line before data row 4, skipped
    bad, err = _refused(tmp_path / "lines.csv", lines)
    assert [(p.row, p.line, p.column) for p in err.problems] == [(4, 7, "mean_slope_deg")]


def test_a_row_with_fewer_fields_than_the_header_is_named(tmp_path, appendix_path):
    """A row short of its last field: with an extra column last, it was read with that cell
    empty and nothing said; short of an indicator, its cell was said to be "empty"."""
    lines = _rows(appendix_path, 3)
    lines = [lines[0] + ",note"] + [line + ",checked" for line in lines[1:]]
    lines[2] = lines[2].removesuffix(",checked")  # data row 2: 19 fields, the header 20
    bad, err = _refused(tmp_path / "short.csv", lines)
    assert str(err) == f"{bad}, row 2 (line 3): 19 fields where the header names 20"
    lines = _rows(appendix_path, 3)
    lines[3] = lines[3].rsplit(",", 1)[0]  # data row 3 without its h_rmse_m
    bad, err = _refused(tmp_path / "short2.csv", lines)
    assert str(err) == f"{bad}, row 3 (line 4): 18 fields where the header names 19"


def test_a_table_not_in_utf8_names_the_line(tmp_path, appendix_path):
    lines = _rows(appendix_path, 3)
    lines[3] = lines[3].replace("08HZ", "Zürich")
    bad = tmp_path / "latin1.csv"
    bad.write_bytes(("\n".join(lines) + "\n").encode("latin-1"))
    with pytest.raises(InputError) as err:
        read_table(bad)
    (problem,) = err.value.problems
    assert (problem.file, problem.line) == (str(bad), 4)
    assert "byte 0xfc at character 4 is not UTF-8" in problem.message
    assert "must be UTF-8" in problem.message


def test_a_nul_byte_in_a_cell_is_named_not_kept_as_text(tmp_path, appendix_path):
    """A NUL in the region of data row 2 was read into the region's text and written on to
    experiments.csv; the delivery's tables refuse it, naming the line."""
    lines = _rows(appendix_path, 3)
    lines[2] = lines[2].replace("08HZ", "08\0HZ")  # '2,08\0HZ,…': the NUL is character 5
    bad, err = _refused(tmp_path / "nul.csv", lines)
    (problem,) = err.problems
    assert (problem.file, problem.line) == (str(bad), 3)
    assert problem.message.startswith("a NUL byte (0x00) at character 5: expected text")


@pytest.mark.parametrize("content", [b"", b"\xef\xbb\xbf", b"\n \n\t\n"])
def test_an_empty_table_says_so(tmp_path, content):
    """An empty file (or one of a byte-order mark or blank lines only) was 'not a readable CSV
    table: No columns to parse from file', pandas' words."""
    bad = tmp_path / "empty.csv"
    bad.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_table(bad)
    assert str(err.value) == f"{bad}: the file is empty: expected a header row"


@pytest.mark.parametrize("new_id", ["21", ""])
def test_a_row_given_twice_under_another_id_or_none_is_named(tmp_path, appendix_path, new_id):
    """Data row 3 copied to the end with another id, or none: it was analysed as a 5th
    experiment (on the whole appendix the CCA's p fell from 0.00016 to 5.6e-06)."""
    lines = _rows(appendix_path, 4)
    copy = lines[3].split(",", 1)[1]
    lines.append(f"{new_id},{copy}")
    bad, err = _refused(tmp_path / "twice.csv", lines)
    assert str(err) == (
        f"{bad}, row 5 (line 6): the same values as row 3 (line 4) in every column but the "
        "experiment id: one experiment given twice would count twice in the correlations and "
        "the CCA; remove the copy"
    )
    # the same numbers written otherwise ('99.080' for 99.08) are the same values
    lines[-1] = lines[-1].replace(",99.08,", ",99.080,")
    assert ",99.080," in lines[-1]
    _refused(tmp_path / "twice2.csv", lines)


def test_rows_alike_in_the_factors_but_not_the_indicators_are_kept(tmp_path, appendix_path):
    """Rows 17 and 18 of the appendix share their terrain and tie-point factors; a row that
    differs from another in one value is its own experiment."""
    lines = _rows(appendix_path, 3)
    cells = lines[3].split(",")
    cells[0], cells[-1] = "4", "9.999"  # h_rmse_m differs
    lines.append(",".join(cells))
    src = tmp_path / "alike.csv"
    src.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert len(read_table(src)) == 4


def test_written_table_keeps_formulas_as_text(tmp_path, appendix_path):
    lines = _rows(appendix_path, 2)
    lines[0] += ",=note"
    lines[1] = "=1+1,@SUM(A1)," + lines[1].split(",", 2)[2] + ",-2.5"
    lines[2] += ",+cmd"
    src = tmp_path / "t.csv"
    src.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = write_table_csv(read_table(src)).splitlines()
    assert out[0].endswith(",'=note")
    assert out[1].startswith("'=1+1,'@SUM(A1),H1-H5,14,")
    assert out[1].endswith(",-2.5") and out[2].endswith(",'+cmd")
