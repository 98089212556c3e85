"""The §AF experiments table: one row per block or adjustment run, columns as the appendix CSV."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pandas as pd

from blockqc.errors import InputError, Problem
from blockqc.report.exports import neutralise
from blockqc.schema import near_column
from blockqc.textio import check_no_nul, decode_utf8, header_problem, read_bytes

#: Columns that identify an experiment (text, kept but not analysed).
ID_COLUMNS: tuple[str, ...] = ("experiment", "region", "periods", "image_pairs")

#: The ten adjustment factors, §AF-1..10, in the appendix order.
FACTOR_COLUMNS: tuple[str, ...] = (
    "mean_elevation_m",
    "mean_slope_deg",
    "mean_roughness_m",
    "images_area_km2",
    "images_number",
    "images_periods",
    "overlap_degree",
    "tp_number",
    "tp_density_per_km2",
    "tp_nn_coefficient",
)

#: The five accuracy indicators of §AF, in the appendix order.
INDICATOR_COLUMNS: tuple[str, ...] = (
    "l_rmse_px",
    "s_rmse_px",
    "x_rmse_m",
    "y_rmse_m",
    "h_rmse_m",
)

TABLE_COLUMNS: tuple[str, ...] = ID_COLUMNS + FACTOR_COLUMNS + INDICATOR_COLUMNS

#: the values a column can hold (the others are any finite number: a mean elevation may be
#: below sea level): RMS errors, counts, areas, densities and a Clark–Evans R are not negative
RANGES: dict[str, tuple[float, float]] = {
    "mean_slope_deg": (0.0, 90.0),
    **{c: (0.0, np.inf) for c in FACTOR_COLUMNS[2:] + INDICATOR_COLUMNS},
}

#: Short labels with units, for plots and pages.
LABELS: dict[str, str] = {
    "mean_elevation_m": "mean elevation (m)",
    "mean_slope_deg": "mean slope (°)",
    "mean_roughness_m": "mean roughness (m)",
    "images_area_km2": "covered area (km²)",
    "images_number": "number of images",
    "images_periods": "acquisition periods",
    "overlap_degree": "overlap degree",
    "tp_number": "tie-point number",
    "tp_density_per_km2": "tie-point density (/km²)",
    "tp_nn_coefficient": "Clark–Evans R",
    "l_rmse_px": "δ_l (px)",
    "s_rmse_px": "δ_s (px)",
    "x_rmse_m": "δ_X (m)",
    "y_rmse_m": "δ_Y (m)",
    "h_rmse_m": "δ_H (m)",
}


def read_table(path: Path) -> pd.DataFrame:
    """Read and validate an experiments table (CSV, UTF-8); every problem named with its row,
    line and column."""
    path = Path(path)
    name = str(path)
    data = read_bytes(path, None)  # not found, a folder: named
    text = decode_utf8(path, data)  # not UTF-8: named with the line
    check_no_nul(path, data)  # a cell would keep it as text: named with the line
    if not text.strip():
        raise InputError(Problem(name, "the file is empty: expected a header row"))
    lines = _check_shape(path, text)
    try:
        raw = pd.read_csv(
            io.StringIO(text),
            dtype=str,
            keep_default_na=False,
            skipinitialspace=True,
            index_col=False,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputError(Problem(file=name, message=f"not a readable CSV table: {exc}")) from None
    raw.columns = [str(c).strip() for c in raw.columns]
    return validate_table(raw, name, lines if len(lines) == len(raw) else None)


def _is_blank(row: list[str]) -> bool:
    """A record pandas skips: an empty or blank line."""
    return len(row) <= 1 and not "".join(row).strip()


def _check_shape(path: Path, text: str) -> list[int]:
    """What pandas would silently repair: a column named twice (renamed `x.1`), a row with
    more fields than the header (which shifts every column of the table by one) and one with
    fewer (its last cells read as empty, an extra column's unsaid). Returns the line each data
    row starts on (blank lines skipped, as pandas skips them)."""
    rows = csv.reader(io.StringIO(text, newline=""))
    try:
        header = [h.strip() for h in next(rows, [])]
        wrong = header_problem(path, header)
        if wrong:
            raise InputError(wrong)
        problems = [
            Problem(file=str(path), column=c, message="column named more than once")
            for c in sorted({h for h in header if header.count(h) > 1})
        ]
        starts: list[int] = []
        end = rows.line_num
        for row in rows:
            start, end = end + 1, rows.line_num
            if _is_blank(row):
                continue
            starts.append(start)
            if len(row) != len(header):
                problems.append(
                    Problem(
                        file=str(path),
                        row=len(starts),
                        line=start,
                        message=f"{len(row)} fields where the header names {len(header)}",
                    )
                )
    except csv.Error as exc:
        raise InputError(
            Problem(str(path), f"not a readable CSV table: {exc}", line=rows.line_num)
        ) from None
    if problems:
        raise InputError(problems[:20])
    return starts


#: |value| beyond which a factor or indicator is refused (sums of squares must stay finite)
MAX_MAGNITUDE = 1e12


def validate_table(raw: pd.DataFrame, file: str, lines: list[int] | None = None) -> pd.DataFrame:
    """Check the columns and ids and parse the factors and indicators as finite numbers;
    `lines`: the line each row starts on, named beside the row in the problems."""
    extra = [str(c) for c in raw.columns if c not in TABLE_COLUMNS]
    problems = _missing_columns(raw, file, extra)
    problems += _misnamed_ids(raw, file, extra)
    if problems:
        raise InputError(problems)
    if len(raw) == 0:
        raise InputError(Problem(file=file, message="the table has a header but no data rows"))
    dup = raw.columns[raw.columns.duplicated()].tolist()
    if dup:
        raise InputError(
            [Problem(file=file, column=c, message="column named more than once") for c in dup]
        )
    problems = _duplicate_ids(raw, file, lines)
    table = raw.copy()
    if "experiment" not in table.columns:
        table.insert(0, "experiment", [str(i + 1) for i in range(len(table))])
    for col in FACTOR_COLUMNS + INDICATOR_COLUMNS:
        table[col], found = _parsed_column(raw, col, file, lines)
        problems += found
    if problems:
        raise InputError(problems)
    problems = _repeated_rows(table, file, lines)
    if problems:
        raise InputError(problems)
    return table


def _missing_columns(raw: pd.DataFrame, file: str, extra: list[str]) -> list[Problem]:
    """The factors and indicators the header does not name, each with the `extra` column that
    may be meant for it."""
    problems: list[Problem] = []
    missing = [c for c in FACTOR_COLUMNS + INDICATOR_COLUMNS if c not in raw.columns]
    for col in missing:
        near = near_column(col, extra)
        problems.append(
            Problem(
                file=file,
                column=col,
                message="required column missing (the header must name the ten factors and "
                "five indicators as in samples/factors/gf7_adjustment_experiments.csv)"
                + (f"; is '{near}' meant to be it?" if near else ""),
            )
        )
    return problems


def _parsed_column(
    raw: pd.DataFrame, col: str, file: str, lines: list[int] | None
) -> tuple[np.ndarray, list[Problem]]:
    """A factor or indicator column as numbers, and a problem for each cell that is empty, not
    a finite number or outside the column's range."""
    problems: list[Problem] = []
    text = raw[col].astype(str).str.strip()
    values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values) | (np.abs(values) > MAX_MAGNITUDE)
    for i in np.flatnonzero(bad):
        shown = text.iloc[i]
        what = (
            "empty"
            if shown == ""
            else f"'{shown}' is not a finite number of magnitude at most {MAX_MAGNITUDE:g}"
        )
        problems.append(_cell_problem(file, int(i), lines, col, what))
    low, high = RANGES.get(col, (-np.inf, np.inf))
    for i in np.flatnonzero(~bad & ((values < low) | (values > high))):
        most = f" and at most {high:g}" if np.isfinite(high) else ""
        what = f"'{text.iloc[i]}': a {LABELS[col]} is at least {low:g}{most}"
        problems.append(_cell_problem(file, int(i), lines, col, what))
    return values, problems


def _misnamed_ids(raw: pd.DataFrame, file: str, extra: list[str]) -> list[Problem]:
    """An `experiment` column named otherwise (`Experiment`, `experiment_id`): its ids would be
    replaced by row numbers, and a repeated one go unnoticed."""
    near = near_column("experiment", extra) if "experiment" not in raw.columns else None
    if near is None:
        return []
    why = "the experiments would be numbered by row instead of by the ids it holds"
    return [Problem(file=file, column=near, message=f"did you mean 'experiment'? ({why})")]


def _cell_problem(
    file: str, index: int, lines: list[int] | None, column: str, message: str
) -> Problem:
    """A problem in the row at `index` (0-based), named by row number and line."""
    line = lines[index] if lines else None
    return Problem(file=file, row=index + 1, line=line, column=column, message=message)


def _where(index: int, lines: list[int] | None) -> str:
    return f"row {index + 1}" + (f" (line {lines[index]})" if lines else "")


def _duplicate_ids(raw: pd.DataFrame, file: str, lines: list[int] | None) -> list[Problem]:
    """Rows whose experiment id an earlier row already has (ids left empty are not compared)."""
    if "experiment" not in raw.columns:
        return []
    ids = raw["experiment"].astype(str).str.strip()
    first: dict[str, int] = {}
    problems = []
    for i, value in enumerate(ids):
        if value and value in first:
            message = (
                f"experiment id '{value}' is also the id of {_where(first[value], lines)}: "
                "each experiment needs its own id"
            )
            problems.append(_cell_problem(file, i, lines, "experiment", message))
        first.setdefault(value, i)
    return problems


def _repeated_rows(table: pd.DataFrame, file: str, lines: list[int] | None) -> list[Problem]:
    """Rows equal to an earlier row in every column but the experiment id (the factors and
    indicators as numbers, other cells as text): one experiment given twice, which would count
    twice in the correlations and the CCA."""
    others = [c for c in table.columns if c != "experiment"]
    keys = table[others].astype(str).apply(lambda col: col.str.strip())
    numbers = [c for c in FACTOR_COLUMNS + INDICATOR_COLUMNS if c in others]
    keys[numbers] = table[numbers].map(repr)
    first: dict[tuple[str, ...], int] = {}
    problems = []
    for i, key in enumerate(keys.itertuples(index=False, name=None)):
        if key in first:
            message = (
                f"the same values as {_where(first[key], lines)} in every column but the "
                "experiment id: one experiment given twice would count twice in the "
                "correlations and the CCA; remove the copy"
            )
            problems.append(
                Problem(file=file, row=i + 1, line=lines[i] if lines else None, message=message)
            )
        first.setdefault(key, i)
    return problems


def write_table_csv(table: pd.DataFrame) -> str:
    """The table as CSV text: the appendix columns first, then any extra columns; text a
    spreadsheet would run as a formula (`=1+1`, `@SUM(A1)`) is prefixed with `'`."""
    cols = [c for c in TABLE_COLUMNS if c in table.columns]
    cols += [c for c in table.columns if c not in cols]
    out = table[cols].copy()
    for col in cols:
        if out[col].dtype == object or isinstance(out[col].dtype, pd.StringDtype):
            out[col] = out[col].map(lambda v: neutralise(v) if isinstance(v, str) else v)
    out.columns = [neutralise(str(c)) for c in cols]
    return out.to_csv(index=False, lineterminator="\n")
