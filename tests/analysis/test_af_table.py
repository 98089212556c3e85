"""The experiments table: the appendix reads, bad cells are named by row and column."""

from __future__ import annotations

import pytest

from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS, read_table
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
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_table(bad)
    found = {(p.row, p.column) for p in err.value.problems}
    assert found == {(3, "mean_slope_deg"), (3, "s_rmse_px")}
    assert all(p.file == str(bad) for p in err.value.problems)


def test_missing_column_is_named(tmp_path, appendix_path):
    text = appendix_path.read_text(encoding="utf-8").replace("tp_nn_coefficient", "tp_nn")
    bad = tmp_path / "renamed.csv"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_table(bad)
    assert [p.column for p in err.value.problems] == ["tp_nn_coefficient"]


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_table(tmp_path / "nothing.csv")
