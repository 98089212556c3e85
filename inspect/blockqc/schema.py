"""Contract v1: the typed schemas of a delivery's tables and their vectorized validation."""

from __future__ import annotations

import difflib
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd
import shapely

from blockqc.errors import Problem

Kind = Literal["str", "float", "int", "date", "enum", "wkt"]

#: the largest whole number accepted in an int column (exactly representable as a float)
MAX_INT = 2**53

#: how many offending rows of one column and one kind of problem are listed one by one
MAX_ROWS_LISTED = 5


@dataclass(frozen=True)
class Column:
    """One column of a table: its type, whether it must be there and filled, and its range."""

    name: str
    kind: Kind
    required: bool = True
    nullable: bool = False
    min: float | None = None
    max: float | None = None
    choices: tuple[str, ...] = ()
    category: bool = False
    """Text held as a pandas Categorical: the keys of tables of millions of rows (tie points),
    so that grouping, counting and joining work on integer codes."""
    ground: Literal["", "deg", "m"] = ""
    """A ground coordinate or discrepancy, in degrees or metres: the resolution its stored type
    gives it is said when coarser than float64 (`blockqc.precision`)."""
    figures: str = ""
    """The stock rules whose figures the column's values enter (said with its resolution)."""


@dataclass(frozen=True)
class Reference:
    """A column whose values must be keys of another table (e.g. a tie point's `scene_id`)."""

    column: str
    table: str
    key: str


@dataclass(frozen=True)
class TableSchema:
    name: str
    columns: tuple[Column, ...]
    unique: tuple[str, ...] = ()
    references: tuple[Reference, ...] = field(default_factory=tuple)
    required: bool = False

    def column(self, name: str) -> Column:
        return next(c for c in self.columns if c.name == name)


METHODS = ("high_precision", "same_accuracy", "recalculation")
#: the ground columns of the tie points (the producer's point: RC-1 with `ground: delivered`, the
#: checkpoints of `blockqc adjust`) and of the checkpoints, with the rules they enter
TIE_XY: dict = {"ground": "deg", "figures": "RC-1, CP-2"}
CP_PLANE: dict = {"ground": "m", "figures": "CP-2, CP-4"}
CP_HEIGHT: dict = {"ground": "m", "figures": "CP-3, CP-4"}

SCENES = TableSchema(
    "scenes",
    (
        Column("scene_id", "str"),
        Column("band", "enum", choices=("pan", "ms")),
        Column("acquired", "date"),
        Column("lines", "int", min=1),
        Column("samples", "int", min=1),
        Column("footprint_wkt", "wkt"),
        Column("water_fraction", "float", required=False, nullable=True, min=0.0, max=1.0),
    ),
    unique=("scene_id",),
    required=True,
)

TIE_POINTS = TableSchema(
    "tie_points",
    (
        Column("point_id", "str", category=True),
        Column("scene_id", "str", category=True),
        Column("line", "float"),
        Column("sample", "float"),
        # contract v1.1: the residuals may be absent when the delivery gives its geometry
        # (blockqc.geometry_inputs checks that); lon/lat/h is the producer's ground point
        Column("v_line", "float", required=False),
        Column("v_sample", "float", required=False),
        Column("lon", "float", required=False, nullable=True, min=-180.0, max=180.0, **TIE_XY),
        Column("lat", "float", required=False, nullable=True, min=-90.0, max=90.0, **TIE_XY),
        Column("h", "float", required=False, nullable=True, ground="m", figures="RC-1, CP-3"),
    ),
    unique=("point_id", "scene_id"),
    references=(Reference("scene_id", "scenes", "scene_id"),),
    required=True,
)

PAN_MS = TableSchema(
    "pan_ms",
    (
        Column("pan_scene_id", "str"),
        Column("ms_scene_id", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float", ground="m", figures="RO-1"),
        Column("dy_m", "float", ground="m", figures="RO-1"),
    ),
    unique=("pan_scene_id", "ms_scene_id", "point_id"),
    references=(
        Reference("pan_scene_id", "scenes", "scene_id"),
        Reference("ms_scene_id", "scenes", "scene_id"),
    ),
)

OVERLAPS = TableSchema(
    "overlaps",
    (
        Column("scene_a", "str"),
        Column("scene_b", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float", ground="m", figures="RO-3, RO-4"),
        Column("dy_m", "float", ground="m", figures="RO-3, RO-4"),
        Column("dz_m", "float", required=False, nullable=True, ground="m", figures="RO-3, RO-4"),
    ),
    unique=("scene_a", "scene_b", "point_id"),
    references=(
        Reference("scene_a", "scenes", "scene_id"),
        Reference("scene_b", "scenes", "scene_id"),
    ),
)

EDGES = TableSchema(
    "edges",
    (
        Column("neighbour_block", "str"),
        Column("point_id", "str"),
        Column("dx_m", "float", ground="m", figures="RO-2"),
        Column("dy_m", "float", ground="m", figures="RO-2"),
        Column("dz_m", "float", required=False, nullable=True, ground="m", figures="RO-2"),
    ),
    unique=("neighbour_block", "point_id"),
)

CHECKPOINTS = TableSchema(
    "checkpoints",
    (
        Column("point_id", "str"),
        Column("method", "enum", choices=METHODS),
        Column("reference_id", "str"),
        Column("x_m", "float", **CP_PLANE),
        Column("y_m", "float", **CP_PLANE),
        Column("z_m", "float", nullable=True, **CP_HEIGHT),
        # Extension of contract v1: ref_x_m/ref_y_m may be empty for height-only references
        # (e.g. laser altimetry); such a row checks the height component only.
        Column("ref_x_m", "float", nullable=True, **CP_PLANE),
        Column("ref_y_m", "float", nullable=True, **CP_PLANE),
        Column("ref_z_m", "float", nullable=True, **CP_HEIGHT),
    ),
    unique=("point_id", "method"),
)

# contract v1.1: the producer's adjustment per scene (blockqc.geometry_inputs gives its form)
ADJUSTMENT = TableSchema(
    "adjustment",
    (
        Column("scene_id", "str"),
        *(Column(k, "float") for k in ("a0", "a1", "a2", "b0", "b1", "b2")),
    ),
    unique=("scene_id",),
    references=(Reference("scene_id", "scenes", "scene_id"),),
)

TABLES: dict[str, TableSchema] = {
    t.name: t for t in (SCENES, TIE_POINTS, PAN_MS, OVERLAPS, EDGES, CHECKPOINTS, ADJUSTMENT)
}


def _rows(mask: np.ndarray) -> np.ndarray:
    return np.flatnonzero(mask)


def report_rows(
    problems: list[Problem],
    file: str,
    column: str | None,
    mask: np.ndarray,
    message: str,
    values: pd.Series | None,
    csv: bool,
    hint: Callable[[object], str] | None = None,
) -> None:
    """Add one problem per offending row (the first few) and a count of the rest."""
    rows = _rows(mask)
    for i in rows[:MAX_ROWS_LISTED]:
        got = f", got {_show(values.iloc[i])}" if values is not None else ""
        if hint is not None and values is not None:
            got += hint(values.iloc[i])
        problems.append(
            Problem(
                file,
                f"{message}{got}",
                row=int(i) + 1,
                line=int(i) + 2 if csv else None,
                column=column,
            )
        )
    if len(rows) > MAX_ROWS_LISTED:
        problems.append(
            Problem(
                file, f"{message}: {len(rows) - MAX_ROWS_LISTED} more rows like this", column=column
            )
        )


def did_you_mean(choices: Iterable[object]) -> Callable[[object], str]:
    """A hint for a misspelt value: "; did you mean 'x'?" when one choice is the same but for
    case (gf7-1010000-f for GF7-1010000-F), else when one is close."""
    pool = [str(c) for c in choices]
    folded = {c.casefold(): c for c in reversed(pool)}  # the first of those alike
    zeros = {c.lstrip("0"): c for c in reversed(pool) if c.isdigit() and c.startswith("0")}

    def hint(value: object) -> str:
        text = str(value).strip()
        padded = zeros.get(text.lstrip("0")) if text.isdigit() else None
        if padded is not None and padded != text:  # ids stored as numbers: 0012 read as 12
            return f"; did you mean '{padded}'? (its leading zeros lost: give the ids as text)"
        close = _closest(text, pool, folded)
        return f"; did you mean '{close}'?" if close else ""

    return hint


def closest(choices: Iterable[object], value: object) -> str | None:
    """The choice a misspelt value stands for, as `did_you_mean` finds it; None when none is."""
    pool = [str(c) for c in choices]
    return _closest(str(value).strip(), pool, {c.casefold(): c for c in reversed(pool)})


def _closest(text: str, pool: list[str], folded: dict[str, str]) -> str | None:
    """The same but for case, else the closest (difflib, ratio ≥ 0.6), else None."""
    same = folded.get(text.casefold())
    close = [same] if same else difflib.get_close_matches(text, pool, n=1, cutoff=0.6)
    return close[0] if close else None


def _show(value: object) -> str:
    if isinstance(value, str):
        return repr(value if len(value) <= 80 else value[:77] + "...")
    return str(value.item() if hasattr(value, "item") else value)


def _blank(s: pd.Series) -> np.ndarray:
    """Cells that are missing or hold only white space."""
    if isinstance(s.dtype, pd.CategoricalDtype):  # made by the readers: stripped, blank missing
        return s.array.codes < 0
    if pd.api.types.is_numeric_dtype(s.dtype) or pd.api.types.is_datetime64_any_dtype(s.dtype):
        return s.isna().to_numpy()
    return (s.isna() | (s.astype("string").str.strip() == "")).to_numpy(dtype=bool)


def _duplicate_headers(
    df: pd.DataFrame, file: str, header: list[str] | None = None
) -> tuple[pd.DataFrame, list[Problem]]:
    """Columns named twice in the header (the file's, when only some columns were read): each
    repeat is a problem (the first one is kept)."""
    names = pd.Index(df.columns if header is None else [h.strip() for h in header])
    problems = [
        Problem(
            file,
            f"column '{name}' appears more than once in the header (columns "
            f"{', '.join(str(i + 1) for i in np.flatnonzero(names == name))}); "
            "give each column once",
            line=1 if file.lower().endswith(".csv") else None,
        )
        for name in dict.fromkeys(names[names.duplicated()])
    ]
    return df.loc[:, ~df.columns.duplicated()], problems


def _check_column(
    raw: pd.Series, col: Column, file: str, csv: bool, problems: list[Problem]
) -> pd.Series:
    """Convert one column to its kind, adding every problem of its cells; return it converted."""
    if _clean_floats(raw, col):
        return raw
    blank = _blank(raw)
    if not col.nullable:
        what = "empty or NaN value" if col.kind in ("float", "int") else "empty value"
        report_rows(problems, file, col.name, blank, f"{what} where one is required", None, csv)
    conv, bad = _convert(raw, col, blank)
    if bad is not None:
        hint = did_you_mean(col.choices) if col.kind == "enum" else None
        report_rows(problems, file, col.name, bad, _expected(col), raw, csv, hint)
    ok = ~blank & (~bad if bad is not None else True)
    if col.kind == "str" and csv:
        report_rows(problems, file, col.name, _over_lines(conv), OVER_LINES, raw, csv)
    if col.kind == "wkt":
        _check_polygons(conv, ok, file, col.name, csv, problems)
    if col.kind == "date":
        _check_dates(conv, ok, file, col.name, raw, csv, problems)
    if col.kind not in ("float", "int"):
        return conv
    vals = conv.to_numpy(dtype=float, na_value=np.nan)
    finite = np.isfinite(vals)
    checks = [(~finite, "value is not finite (inf or NaN): expected a finite number")]
    with np.errstate(invalid="ignore"):
        checks.append((finite & (np.abs(vals) > MAGNITUDE_LIMIT), NOT_A_MEASUREMENT))
        if col.min is not None:
            low = finite & (vals < col.min)
            checks.append((low, f"value below the allowed minimum {col.min:g}"))
        if col.max is not None:
            high = finite & (vals > col.max)
            checks.append((high, f"value above the allowed maximum {col.max:g}"))
    for mask, message in checks:
        report_rows(problems, file, col.name, ok & mask, message, raw, csv)
    return conv


OVER_LINES = (
    "a line break inside the value: expected one line (a quote opening the field and another "
    "on a later line join the rows between into it)"
)


def _over_lines(text: pd.Series) -> np.ndarray:
    """Text cells holding a line break: no id or name of the contract has one, but a CSV field
    opened by a stray quote runs to the next quote, rows and all (a WKT may run over lines:
    a line break is white space to it). A Categorical's categories are looked at once each."""

    def broken(values: pd.Series | pd.Index) -> np.ndarray:
        found = values.astype("string").str.contains("[\r\n]", regex=True)
        return np.asarray(found.fillna(False), dtype=bool)

    if isinstance(text.dtype, pd.CategoricalDtype):
        per_category = np.append(broken(text.cat.categories), False)
        return per_category[text.array.codes]  # code -1 (a missing cell): the False appended
    return broken(text)


#: the launch of the first artificial satellite: no scene was acquired before it
FIRST_LAUNCH = pd.Timestamp("1957-10-04")


def _check_dates(
    d: pd.Series, ok, file: str, name: str, raw: pd.Series, csv: bool, problems: list[Problem]
) -> None:
    """Dates no scene can have: before the first satellite's launch (a year 0000 or 1900 left
    by an export), or after today (UTC, a day allowed for time zones)."""
    values = pd.to_datetime(d, errors="coerce")
    if getattr(values.dt, "tz", None) is not None:
        values = values.dt.tz_convert(None)
    tomorrow = pd.Timestamp.now(tz="UTC").tz_localize(None).normalize() + pd.Timedelta(days=1)
    early = ok & (values < FIRST_LAUNCH).to_numpy(dtype=bool)
    late = ok & (values >= tomorrow + pd.Timedelta(days=1)).to_numpy(dtype=bool)
    why = f"date before {FIRST_LAUNCH.date()}, the first satellite's launch: not a scene's date"
    report_rows(problems, file, name, early, why, raw, csv)
    why = f"date after {tomorrow.date()}: a scene cannot be acquired after the inspection"
    report_rows(problems, file, name, late, why, raw, csv)


#: no value of the contract's units (metres, pixels, degrees, shares) comes near this size: a
#: larger one is a no-data marker (-1e30, 3.4e38) or a broken export, and would overflow the
#: errors and sums computed from it
MAGNITUDE_LIMIT = 1e15
NOT_A_MEASUREMENT = (
    f"value of magnitude above {MAGNITUDE_LIMIT:g}: not a measurement in metres, pixels or "
    "degrees (a no-data marker?)"
)


def _clean_floats(raw: pd.Series, col: Column) -> bool:
    """A float column read as floats whose smallest and largest values are finite and within
    the column's bounds: nothing to report, found by two reductions (NaN carries through
    min and max) instead of a mask per check over millions of rows."""
    if col.kind != "float" or raw.dtype != np.float64 or raw.empty:
        return False
    values = raw.to_numpy()
    lo, hi = values.min(), values.max()
    return bool(
        np.isfinite(lo)
        and np.isfinite(hi)
        and max(-lo, hi) <= MAGNITUDE_LIMIT
        and (col.min is None or lo >= col.min)
        and (col.max is None or hi <= col.max)
    )


def _from_wkt(text: np.ndarray) -> np.ndarray:
    """Geometries of WKT texts, None where a text is none; a NaN coordinate is read as given
    (and refused by the checks), without shapely's RuntimeWarning on the console."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return shapely.from_wkt(text, on_invalid="ignore")


def _check_polygons(
    wkt: pd.Series, ok: np.ndarray, file: str, column: str, csv: bool, problems: list[Problem]
) -> None:
    """Footprints must be valid polygons: not self-intersecting, no repeated rings, no holes
    (an image's outline has none; its corners and area would be read from different rings)."""
    text = wkt.where(ok, "").fillna("").to_numpy(dtype=object)
    geoms = _from_wkt(text)
    bounds = shapely.bounds(geoms)
    with np.errstate(invalid="ignore"):  # NaN: no polygon (not ok)
        lon = ok & ((bounds[:, 0] < -180) | (bounds[:, 2] > 180))
        lat = ok & ((bounds[:, 1] < -90) | (bounds[:, 3] > 90))
    msg = "a longitude beyond ±180°: expected lon/lat degrees, longitudes within -180…180"
    report_rows(problems, file, column, lon, msg, wkt, csv)
    msg = "a latitude beyond ±90°: expected lon/lat degrees (longitude and latitude swapped?)"
    report_rows(problems, file, column, lat & ~lon, msg, wkt, csv)
    ok = ok & ~lon & ~lat
    invalid = ok & ~shapely.is_valid(geoms)
    rings = shapely.get_exterior_ring(geoms)
    few = ok & ~invalid & (shapely.get_num_coordinates(rings) < 5)
    msg = "a footprint has at least four corners (they are read as the image corners)"
    report_rows(problems, file, column, few, msg, wkt, csv)
    holes = ok & ~invalid & (shapely.get_num_interior_rings(geoms) > 0)
    msg = "a footprint is the outline of an image: expected a polygon without holes"
    report_rows(problems, file, column, holes, msg, wkt, csv)
    if invalid.any():
        reasons = pd.Series(shapely.is_valid_reason(geoms), index=wkt.index)
        msg = "not a valid polygon (its boundary must not cross itself)"
        report_rows(problems, file, column, invalid, msg, reasons, csv)


def validate_table(
    df: pd.DataFrame,
    schema: TableSchema,
    file: str,
    csv: bool = True,
    header: list[str] | None = None,
) -> tuple[pd.DataFrame, list[Problem]]:
    """Check and convert a raw table (strings or typed) column by column; list every problem.

    `header`: the file's column names when only some of them were read into `df`: a column
    it names is not missing, and the checks of the columns not read are not made."""
    df = df.rename(columns=lambda c: str(c).strip())
    unnamed = [i for i, c in enumerate(df.columns) if c == "" and _blank(df.iloc[:, i]).all()]
    df = df.iloc[:, [i for i in range(df.shape[1]) if i not in unnamed]]  # trailing commas
    df, problems = _duplicate_headers(df, file, header)
    given = set(df.columns) | {h.strip() for h in header or ()}
    if len(df) == 0 and len(df.columns):
        problems.append(
            Problem(
                file,
                "the table has a header but no rows: give its rows "
                "(or leave an optional table out of the delivery)",
            )
        )
    out: dict[str, pd.Series] = {}
    known = {col.name for col in schema.columns}
    in_order = dict.fromkeys([*df.columns, *(h.strip() for h in header or ())])
    extra = [c for c in in_order if c not in known]  # as the header has them
    problems += _other_case(extra, given, schema, file)
    for col in schema.columns:
        if col.name in df.columns:
            out[col.name] = _check_column(df[col.name], col, file, csv, problems)
        elif col.name not in given:
            problems += _missing(
                col, near_column(col.name, extra), file, header or list(df.columns)
            )
    for c in df.columns:  # extra columns are kept, untouched
        if c not in out:
            out[c] = df[c]
    table = pd.DataFrame(out, index=pd.RangeIndex(len(df)), copy=False)  # copy on write
    _check_unique(table, schema, file, csv, problems)
    return table, problems


def _other_case(extra: list[str], given: set[str], schema: TableSchema, file: str) -> list[Problem]:
    """Extra columns that repeat a column of the contract in another case (`Dz_m` beside
    `dz_m`): which one is meant cannot be told, and the other would go unread."""
    names = {col.name.casefold(): col.name for col in schema.columns if col.name in given}
    return [
        Problem(
            file,
            f"column '{c}' repeats column '{names[c.casefold()]}' in another case: give it once",
            line=1 if file.lower().endswith(".csv") else None,
        )
        for c in sorted(extra)
        if c.casefold() in names
    ]


def _missing(col: Column, near: str | None, file: str, found: list) -> list[Problem]:
    """A column of the schema that the file lacks: refused when required; when optional, only
    beside a column that looks like it misspelt, whose checks would else go unmade."""
    if col.required:
        hint = f"; is '{visible_name(near)}' meant to be it?" if near else ""
        names = ", ".join(visible_name(str(c)) for c in found)
        why = f"expected {column_of(col)}; columns found: {names}{hint}"
        return [Problem(file, f"missing column '{col.name}' ({why})")]
    if near:
        why = "rename it: misspelt, the checks of that optional column would not be made"
        return [Problem(file, f"column '{visible_name(near)}': did you mean '{col.name}'? ({why})")]
    return []


def column_of(col: Column) -> str:
    """What a column of the contract holds, in words: a column of numbers, of whole numbers,
    of text, of dates, of pan or ms, of WKT polygons."""
    if col.kind == "enum":
        *first, last = col.choices
        return f"a column of {', '.join(first)} or {last}" if first else f"a column of {last}"
    cells = {
        "str": "text",
        "float": "numbers",
        "int": "whole numbers",
        "date": "dates",
        "wkt": "WKT polygons",
    }[col.kind]
    return f"a column of {cells}"


def visible_name(name: str) -> str:
    """A name (a column's, a key's) as shown in a message: a character that shows nothing (a
    zero-width space, a byte order mark, a soft hyphen pasted with the name) escaped, as Python
    writes it."""
    return name if name.isprintable() else repr(name)[1:-1]


#: the last words of column names that are units (`dz_m`, `lat_deg`)
UNIT_WORDS = {"m", "mm", "cm", "km", "px", "pix", "pixel", "pixels", "deg", "degree", "degrees"}


def near_column(name: str, columns: list[str]) -> str | None:
    """The one of `columns` that looks most like `name` misspelt: in other case (REF_X_M for
    ref_x_m, before REF_Y_M), else with its unit dropped, added or changed (`dz`, `dz_mm` for
    `dz_m`; `h_m` for `h`), else differing in a letter or two, the closest first. (`water` is
    not `water_fraction`: 'fraction' is no unit.)"""
    want = name.casefold()
    folded = [(str(column).casefold(), column) for column in columns]
    for same in (lambda c: c == want, lambda c: _stem(c) == _stem(want)):
        found = [column for c, column in folded if same(c)]
        if found:
            return found[0]
    ratios = [(difflib.SequenceMatcher(None, c, want).ratio(), column) for c, column in folded]
    close = [(r, column) for r, column in ratios if r >= 0.8]
    return max(close, key=lambda rc: rc[0])[1] if close else None


def _stem(name: str) -> str:
    """A column name without its unit word: `dz_m` → `dz`, `water_fraction` as it is."""
    base, _, last = name.rpartition("_")
    return base if base and last in UNIT_WORDS else name


def key_labels(table: pd.DataFrame, cols: Sequence[str]) -> pd.Series:
    """Each row's key as text, "a/b" for a key of several columns (vectorized; a missing cell
    as empty text): a unit's label, as messages and waivers name it."""
    parts = [table[c].astype("string").fillna("") for c in cols]
    out = parts[0]
    for s in parts[1:]:
        out = out + "/" + s
    return out


def _check_unique(
    table: pd.DataFrame, schema: TableSchema, file: str, csv: bool, problems: list[Problem]
) -> None:
    """Rows repeating a key (e.g. two rows of one scene_id) are listed."""
    bad_keys = any(p.column in schema.unique for p in problems)
    if not schema.unique or bad_keys or not all(k in table.columns for k in schema.unique):
        return
    cols = list(schema.unique)
    if any(isinstance(table[c].dtype, pd.CategoricalDtype) for c in cols):
        dup = _repeated(_key_codes(table, cols))
    else:
        dup = table.duplicated(cols, keep=False).to_numpy()
    if dup.any():
        key = ", ".join(schema.unique)
        report_rows(
            problems,
            file,
            schema.unique[0] if len(schema.unique) == 1 else None,
            dup,
            f"duplicated key ({key})",
            key_labels(table, list(schema.unique)),
            csv,
        )


def _stripped_category(raw: pd.Series, blank: np.ndarray) -> pd.Series:
    """Text as a Categorical of stripped values, blank cells missing. A Categorical comes from
    the readers (`blockqc.delivery`), already stripped; other text is stripped here."""
    if isinstance(raw.dtype, pd.CategoricalDtype):
        return raw
    text = raw.astype("string").str.strip().where(~blank)
    return text.astype(object).astype("category")


def _repeated(key: np.ndarray) -> np.ndarray:
    """Rows whose int64 key occurs more than once: one sort; the rows are found only when
    some key repeats (the usual clean table costs the sort alone). The stable sort runs in
    linear time over rows already in key order, as a table grouped by point is."""
    ordered = np.sort(key, kind="stable")
    if not (ordered[1:] == ordered[:-1]).any():
        return np.zeros(key.size, dtype=bool)
    return pd.Series(key).duplicated(keep=False).to_numpy()


def _key_codes(table: pd.DataFrame, cols: list[str]) -> np.ndarray:
    """One int64 per row for a key of several columns (codes of each column, combined)."""
    key, span = np.zeros(len(table), dtype=np.int64), 1
    for c in cols:
        s = table[c]
        codes = s.array.codes if isinstance(s.dtype, pd.CategoricalDtype) else None
        if codes is None:
            codes = pd.factorize(s)[0]
        size = int(codes.max(initial=-1)) + 2
        span *= size
        if span >= 2**62:  # too many combinations for one int64: combine again by factorizing
            key, span = pd.factorize(key)[0].astype(np.int64), int(key.size) + 1
            span *= size
        key *= size  # in place: no temporary of millions of rows
        key += codes
        key += 1
    return key


def _expected(col: Column) -> str:
    return {
        "str": "expected text",
        "float": "expected a number",
        "int": f"expected a whole number (at most {MAX_INT:,} in size)",
        "date": "expected an ISO date (YYYY-MM-DD)",
        "enum": f"expected one of {', '.join(col.choices)}",
        "wkt": "expected a WKT polygon in lon/lat degrees (a MULTIPOLYGON of one part is read "
        "as that polygon)",
    }[col.kind]


#: a date that names its day (2021-04-11, 2021/04/11, 20210411, with a time or not): a year or a
#: month alone (2021, 2021-04), reduced precision to ISO 8601, would be read as its first day
WITH_DAY = r"\d{4}(?:[-/.]\d{1,2}[-/.]\d{1,2}|\d{4})(?:[T ].*)?"


def _convert(raw: pd.Series, col: Column, blank: np.ndarray) -> tuple[pd.Series, np.ndarray | None]:
    """Convert one column to its kind; return the converted series and the unconvertible cells."""
    if col.kind == "str" and col.category:
        return _stripped_category(raw, blank), None
    if col.kind == "str":
        s = raw.astype("string").str.strip()
        return s.astype(object).where(~blank, None), None
    if col.kind == "enum":
        s = raw.astype("string").str.strip().str.lower()
        bad = ~blank & ~s.isin(col.choices).to_numpy(dtype=bool)
        return s.astype(object).where(~blank, None), bad
    if col.kind in ("float", "int"):
        if pd.api.types.is_numeric_dtype(raw.dtype) and not pd.api.types.is_bool_dtype(raw.dtype):
            num = raw.astype(float)
        else:
            num = pd.to_numeric(raw.astype("string").str.strip(), errors="coerce").astype(float)
        bad = ~blank & num.isna().to_numpy()
        if col.kind == "int":
            v = num.to_numpy()
            with np.errstate(invalid="ignore"):
                whole = np.isfinite(v) & (np.abs(v) <= MAX_INT) & (v == np.round(v))
            bad = bad | (~blank & ~bad & ~whole)
            return num.where(whole).round().astype("Int64"), bad
        return num, bad
    if col.kind == "date":
        if pd.api.types.is_datetime64_any_dtype(raw.dtype):
            return raw, None
        text = raw.astype("string").str.strip()
        try:
            d = pd.to_datetime(text, errors="coerce", format="ISO8601")
        except (ValueError, TypeError):  # time zones mixed with naive dates: compared in UTC
            d = pd.to_datetime(text, errors="coerce", format="ISO8601", utc=True)
            d = d.dt.tz_localize(None)
        partial = ~text.str.fullmatch(WITH_DAY).fillna(False).to_numpy(dtype=bool)
        return d, ~blank & (d.isna().to_numpy() | partial)
    if col.kind == "wkt":
        stripped = raw.astype("string").str.strip().astype(object)
        text = stripped.fillna("").to_numpy(dtype=object)
        geoms = _from_wkt(text)
        one = (shapely.get_type_id(geoms) == 6) & (shapely.get_num_geometries(geoms) == 1)
        if one.any():  # a MULTIPOLYGON of one part (as GIS exports write any polygon): its part
            geoms[one] = shapely.get_geometry(geoms[one], 0)
            stripped[one] = shapely.to_wkt(geoms[one], rounding_precision=-1)
        poly = shapely.get_type_id(geoms) == 3  # Polygon
        finite = np.isfinite(shapely.bounds(geoms)).all(axis=1)  # beyond the globe: said apart
        return stripped, ~blank & ~(poly & finite)
    raise AssertionError(col.kind)
