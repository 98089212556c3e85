"""Reading a delivery (contract v1) into typed tables; a delivery is never written to."""

from __future__ import annotations

import difflib
import io
import os
import re
from collections.abc import Collection
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PositiveFloat,
    ValidationError,
    field_validator,
    model_validator,
)

from blockqc import grouped, memory, prefetch
from blockqc.errors import InputError, Problem
from blockqc.geometry_inputs import (
    GEOMETRY_DIRS,
    BlockGeometry,
    gives_adjustment,
    ground_column_problems,
    has_geometry,
    load_geometry,
    residual_column_problems,
)
from blockqc.outputs import block_id_problem
from blockqc.precision import stored_resolution
from blockqc.schema import (
    MAX_INT,
    TABLES,
    TIE_POINTS,
    TableSchema,
    did_you_mean,
    report_rows,
    validate_table,
    visible_name,
)
from blockqc.textio import (
    BOM,
    check_no_nul,
    check_utf8,
    dangling_link,
    header_problem,
    listed,
    located,
    not_a_file,
    not_there,
    read_bytes,
    unreadable_folder,
    wide_separated,
)
from blockqc.yamlio import line_of, load_yaml, pydantic_problems

MANIFEST = "block.yaml"


#: a ground sample distance larger than this (metres) is no GSD: the rules' thresholds built on
#: it would be beyond the range the rule expressions accept (1e12), or meaninglessly lax
MAX_GSD_M = 1000.0


class GSD(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    pan: PositiveFloat | None = Field(default=None, le=MAX_GSD_M)
    ms: PositiveFloat | None = Field(default=None, le=MAX_GSD_M)

    @field_validator("pan", "ms", mode="before")
    @classmethod
    def _not_bool(cls, value: Any) -> Any:
        if isinstance(value, bool):  # YAML `true` would otherwise read as 1.0 m
            raise ValueError(f"expected a number of metres, got {str(value).lower()}")
        return value

    @model_validator(mode="after")
    def _one(self) -> GSD:
        if self.pan is None and self.ms is None:
            raise ValueError("give the GSD of at least one band (pan, ms)")
        return self


#: a UTM zone as block.yaml may state it beside `projection: UTM`: 1..60 and a hemisphere
UTM_ZONE = re.compile(r"\s*(\d{1,2})\s*([NSns])\s*")


#: EPSG codes of one projection under another code: UPS North and South with the axes east,
#: north (5041, 5042, as GIS tools give UPS now) are the projections of 32661 and 32761
SAME_PROJECTION = {5041: 32661, 5042: 32761}


def canonical_epsg(code: int | None) -> int | None:
    """The code of `SAME_PROJECTION` an EPSG code is judged as (any other code itself)."""
    return SAME_PROJECTION.get(code, code) if code is not None else None


class SpatialReference(BaseModel):
    # bytes of an unread key (YAML's !!binary), dumped as JSON for a plan's strata, as base64:
    # as UTF-8 they may be no text at all
    model_config = ConfigDict(extra="allow", allow_inf_nan=False, ser_json_bytes="base64")
    geodetic_datum: str | None = None
    height_datum: str | None = None
    projection: str | None = None
    epsg: int | None = Field(default=None, ge=1, le=2**31 - 1)

    @field_validator("epsg", mode="before")
    @classmethod
    def _code(cls, value: Any) -> Any:
        """An EPSG code as a number, or as text: '32650' or 'EPSG:32650' (as GIS tools write
        it); anything else is refused."""
        if isinstance(value, bool):
            raise ValueError(f"expected an EPSG code, got {str(value).lower()}")
        if not isinstance(value, str):
            return value
        m = re.fullmatch(r"\s*(?:EPSG\s*:\s*)?(\d{1,10})\s*", value, flags=re.IGNORECASE)
        if m is None:
            raise ValueError(f"expected an EPSG code such as 32650 or 'EPSG:32650', got {value!r}")
        return int(m.group(1))

    def zone_epsg(self) -> int | None:
        """The EPSG code of `projection: UTM` with `zone: 50N` (or UPS with N/S); None when the
        projection is another or no zone is stated."""
        zone = str((self.model_extra or {}).get("zone") or "").strip()
        projection = re.sub(r"[\s_\-:.]", "", (self.projection or "").upper())
        m = UTM_ZONE.fullmatch(zone)
        if projection == "UTM" and m and 1 <= int(m.group(1)) <= 60:
            return (32600 if m.group(2).upper() == "N" else 32700) + int(m.group(1))
        if projection == "UPS" and zone.upper() in {"N", "S", "NORTH", "SOUTH"}:
            return 32661 if zone.upper().startswith("N") else 32761
        return None

    @model_validator(mode="after")
    def _zone(self) -> SpatialReference:
        """A UTM zone is read (1..60 and N or S) and agrees with the EPSG code when both are
        given: neither silently overrides the other."""
        zone = (self.model_extra or {}).get("zone")
        utm = re.sub(r"[\s_\-:.]", "", (self.projection or "").upper()) == "UTM"
        code = self.zone_epsg()
        if utm and zone is not None and code is None:
            raise ValueError(f"zone {zone!r}: expected a UTM zone 1-60 and N or S, e.g. 50N")
        if code is not None and self.epsg is not None and code != canonical_epsg(self.epsg):
            raise ValueError(
                f"zone {zone} is EPSG:{code} but epsg is {self.epsg}: give one, or make them agree"
            )
        return self


def _figure(value: Any) -> Any:
    """A reported figure of true/false (YAML reads `yes` so) is no number: not taken for 1."""
    if isinstance(value, bool):
        raise ValueError(f"expected a number, got {str(value).lower()}")
    return value


class Manifest(BaseModel):
    """block.yaml: the block's identity, GSDs, spatial reference, documents, reported figures."""

    # bytes of an unread key, as base64 (SpatialReference)
    model_config = ConfigDict(extra="allow", allow_inf_nan=False, ser_json_bytes="base64")
    block_id: str = Field(min_length=1)
    sensor: str | None = None
    gsd_m: GSD
    spatial_reference: SpatialReference | None = None
    documents: dict[str, str] = Field(default_factory=dict)
    reported: dict[str, Annotated[float, BeforeValidator(_figure)]] = Field(default_factory=dict)
    # keys the sample deliveries carry: typed, so that a wrong value is refused
    test_field: int | None = Field(default=None, ge=1, le=2**31 - 1)
    sampled: bool | None = None

    #: keys block.yaml gives that no part of blockqc reads (stated as warnings)
    unknown_keys: list[Problem] = Field(default_factory=list, exclude=True)
    #: each reported figure's place in block.yaml (file, line), for what the pack does not read
    reported_at: dict[str, Problem] = Field(default_factory=dict, exclude=True)
    #: each document kind's place in block.yaml (file, line), for a kind said in warnings
    documents_at: dict[str, Problem] = Field(default_factory=dict, exclude=True)

    @field_validator("block_id", mode="before")
    @classmethod
    def _text(cls, value: Any) -> Any:
        if not isinstance(value, str):  # YAML reads 0101 as the number 65: not guessed back
            raise ValueError(
                "expected text: write the id in quotes (block_id: '…'), so that YAML keeps it "
                "as written"
            )
        return value

    @field_validator("gsd_m", mode="before")
    @classmethod
    def _per_band(cls, value: Any) -> Any:
        if isinstance(value, int | float) and not isinstance(value, bool):
            raise ValueError(
                "expected the ground sample distance of each band in metres, e.g. "
                f"gsd_m: {{pan: {value}, ms: …}} (got one number)"
            )
        return value

    @field_validator("block_id")
    @classmethod
    def _safe_block_id(cls, value: str) -> str:
        problem = block_id_problem(value)
        if problem:
            raise ValueError(problem)
        return value

    @field_validator("documents")
    @classmethod
    def _document_paths(cls, value: dict[str, str]) -> dict[str, str]:
        for kind, rel in value.items():
            if not rel.strip() or "\0" in rel or len(rel) > 1000:
                raise ValueError(f"{kind}: expected a file path inside the delivery")
        return value


@dataclass
class Delivery:
    """One block's delivery, read and validated: the manifest and its tables as DataFrames."""

    path: Path
    manifest: Manifest
    scenes: pd.DataFrame
    tie_points: pd.DataFrame
    pan_ms: pd.DataFrame | None = None
    overlaps: pd.DataFrame | None = None
    edges: pd.DataFrame | None = None
    checkpoints: pd.DataFrame | None = None
    files: dict[str, Path] = field(default_factory=dict)
    # contract v1.1: the producer's adjustment table, the geometry read from rpc/ (and
    # rpc_adjusted/), and what blockqc computed from it (blockqc.verification)
    adjustment: pd.DataFrame | None = None
    geometry: BlockGeometry | None = None
    process_data: dict[str, Any] = field(default_factory=dict)
    # subsets of the tie points that several measurements share (e.g. those on PAN scenes),
    # made once: key -> ((the tie_points and scenes frames it was taken from), the subset)
    selections: dict[Any, tuple[tuple[pd.DataFrame, pd.DataFrame], Any]] = field(
        default_factory=dict, repr=False, compare=False
    )
    # columns the files give that were not read (a pack with `columns: used`), by table
    not_read: dict[str, list[str]] = field(default_factory=dict)
    # what the tables give that is read as given but said: ground columns stored coarser than
    # float64 (`precision.stored_resolution`)
    read_warnings: list[Problem] = field(default_factory=list)

    @property
    def block_id(self) -> str:
        return self.manifest.block_id

    def tie_point_values(self, column: str, rows: np.ndarray) -> pd.Series:
        """One tie_points column at some rows (positions in the table), read from the file when
        the column was not read with the delivery (text stripped, blank cells missing)."""
        rows = np.asarray(rows, dtype=np.int64)
        if column in self.tie_points.columns:
            return self.tie_points[column].iloc[rows].reset_index(drop=True)
        values = read_rows(self.files["tie_points"], column, rows)
        if TIE_POINTS.column(column).kind == "str":  # stripped, blank missing, as when read
            return pd.Series(_categorical(pa.chunked_array([values.cast(pa.string())])))
        return pd.Series(values.to_numpy(zero_copy_only=False), dtype=float)


def is_delivery(path: Path) -> bool:
    return (path / MANIFEST).is_file()


def not_a_manifest(path: Path) -> str | None:
    """Why a folder's block.yaml, there but no file, is not read: a folder, a link to nothing,
    a pipe; or, not there, the file beside it named otherwise (block.yml, Block.yaml); None
    when it is a file, or neither it nor such a file is there."""
    f = path / MANIFEST
    if what := not_a_file(f):
        return f"{what}: expected the delivery's manifest"
    if not f.exists() and (other := _manifest_named_otherwise(path)):
        return f"missing; {other} is there: the manifest is read from {MANIFEST} (lower case)"
    return None


def _manifest_named_otherwise(path: Path) -> str | None:
    """The name of a file in the folder that is block.yaml named otherwise (block.yml,
    Block.yaml, BLOCK.YML), or None."""
    names = {MANIFEST, "block.yml"}
    try:
        found = sorted(p.name for p in path.iterdir() if p.name.casefold() in names)
    except OSError:
        return None
    return next((n for n in found if n != MANIFEST), None)


def find_deliveries(path: Path) -> list[Path]:
    """A delivery folder gives itself; a batch folder gives its sub-folders, sorted.

    Every sub-folder of a batch is a delivery: one without block.yaml is given too, so that it
    is refused by name when read rather than left out unseen; so is a link to nothing. Hidden
    folders (a name starting with '.') are not part of a batch."""
    path = Path(path)
    if not path.exists():
        raise InputError(Problem(str(path), not_there(path, "no such file or folder")))
    if not path.is_dir():
        raise InputError(
            Problem(
                str(path),
                "expected a delivery folder (with block.yaml) or a batch folder of deliveries",
            )
        )
    if is_delivery(path):
        return refuse_undecodable([path])
    if why := not_a_manifest(path):
        raise InputError(Problem(str(path / MANIFEST), why))
    found = [p for p in _members(path) if p.is_dir() or dangling_link(p)]
    if not any(is_delivery(p) for p in found):
        raise InputError(
            Problem(
                str(path),
                f"neither a delivery (no {MANIFEST}) nor a batch "
                f"(no sub-folder holds a {MANIFEST})",
            )
        )
    return refuse_undecodable(found)


def refuse_undecodable(deliveries: list[Path]) -> list[Path]:
    """The deliveries, refused where a path is no UTF-8 text: the outputs (results.json, the
    summary) name each delivery by its path, in UTF-8."""
    problems = []
    for path in deliveries:
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:
            shown = os.fsencode(path).decode("utf-8", "backslashreplace")
            message = "a path that is not UTF-8 text: the outputs name each delivery by its path"
            problems.append(Problem(shown, f"{message}, in UTF-8; rename the folder"))
    if problems:
        raise InputError(problems)
    return deliveries


def batch_files(path: Path) -> list[Path]:
    """The files lying in a batch folder beside its deliveries (none of them is read)."""
    path = Path(path)
    if not path.is_dir() or is_delivery(path):
        return []
    return [p for p in _members(path) if not p.is_dir() and not dangling_link(p)]


def _members(batch: Path) -> list[Path]:
    """What a batch folder holds, sorted; names starting with '.' are not part of it."""
    return sorted(p for p in batch.iterdir() if not p.name.startswith("."))


def _table_file(folder: Path, name: str) -> Path | None:
    """The table's file, or None when the delivery has none; anything else there is an error."""
    given = [
        f
        for f in (folder / f"{name}.csv", folder / f"{name}.parquet")
        if f.exists() or f.is_symlink()
    ]
    if len(given) > 1:
        raise InputError(
            Problem(
                str(folder),
                f"both {given[0].name} and {given[1].name} are present; give the table once",
            )
        )
    if not given:
        return None
    f = given[0]
    if what := not_a_file(f):
        raise InputError(Problem(str(f), f"{what}: expected the {name} table"))
    return f


def _read_csv(
    path: Path, schema: TableSchema, columns: Collection[str] | None = None
) -> tuple[pd.DataFrame, list[str]]:
    """Read a CSV fast with pyarrow; text-like columns stay text (ids keep leading zeros).
    Only the `columns` given are read (None: all); the header's names come back beside."""
    data = _csv_bytes(path)
    if not data or data.isspace():  # no stripped copy of the whole file
        raise InputError(Problem(str(path), "the file is empty: expected a header row"))
    first = _csv_header(data)
    wrong = header_problem(path, first, len(schema.columns))
    if wrong:
        raise InputError(wrong)
    header = None if columns is None else first
    include = None if header is None else [h for h in header if h.strip() in columns]
    convert = _convert_options(schema, first, include)
    parse = _parse_options(data)
    if len(data) >= RELEASE_BYTES and path.is_file():  # parsed from the file again: its
        data = None  # bytes are not held beside the table, and go back to the system first
        memory.release()
    try:
        table = _arrow_csv(path, data, convert, parse)
    except (pa.ArrowInvalid, pa.ArrowKeyError) as exc:
        raw = _read_csv_slow(path, data or _csv_bytes(path), str(exc))
        keep = [i for i, h in enumerate(raw.columns) if columns is None or h.strip() in columns]
        return raw.iloc[:, keep], header or [str(c) for c in raw.columns]
    del data  # the file's bytes, parsed: not held while the frame is built
    handed, table = [table], None
    frame = _to_pandas(handed, schema)
    return frame, header or [str(c) for c in frame.columns]


def _csv_bytes(path: Path) -> bytes:
    """A CSV file's bytes, checked to be UTF-8 without NUL (else the line is named), its byte
    order mark left out."""
    data = read_bytes(path, None)
    check_utf8(path, data)
    check_no_nul(path, data)
    return data.removeprefix(BOM)


def _convert_options(
    schema: TableSchema, header: list[str], include: list[str] | None
) -> pacsv.ConvertOptions:
    """How Arrow converts a table's cells: the text-like columns of the schema as text."""
    text_cols = {
        c.name: pa.string() for c in schema.columns if c.kind in ("str", "enum", "date", "wkt")
    }
    # a name padded with spaces (' scene_id') is read as text too: ids keep '0001' and 'NA'
    text_cols |= {h: pa.string() for h in header if h.strip() in text_cols}
    return pacsv.ConvertOptions(
        column_types=text_cols,
        strings_can_be_null=False,
        null_values=["", "NA", "NaN", "nan", "null"],
        include_columns=include,
    )


def _parse_options(data: bytes) -> pacsv.ParseOptions:
    """How Arrow finds a CSV's rows: a file holding a quote is cut into the blocks parsed in
    parallel where no quoted field is open, not at any line end. Cut at any, a quote left open
    lost the rest of its block unsaid (a 3 MB tie_points.csv: a third of its rows); now it is
    refused, naming its line (`_read_csv_slow`). A file without quotes is cut the fast way."""
    return pacsv.ParseOptions(newlines_in_values=data.find(b'"') >= 0)


def _arrow_csv(
    path: Path, data: bytes | None, convert: pacsv.ConvertOptions, parse: pacsv.ParseOptions
) -> pa.Table:
    """The CSV parsed from its `data` by the reader of whole tables, or, when None (a large
    file), from the file by Arrow's streaming reader, `STREAM_BYTES` at a time, each column's
    type taken from the first block; a file a later block does not fit (whole numbers turning
    to decimals further down, a line longer than a block, a malformed row) is then parsed
    whole. Arrow leaves a byte order mark out, as `_csv_bytes` does."""
    if data is not None:  # a small file, or not a regular one: its bytes, whole
        return _whole_csv(data, convert, parse)
    options = pacsv.ReadOptions(use_threads=True, block_size=STREAM_BYTES)
    try:
        with pa.OSFile(str(path)) as source:
            return pacsv.open_csv(source, options, parse, convert).read_all()
    except pa.ArrowInvalid:
        return _whole_csv(_csv_bytes(path), convert, parse)


#: a CSV file of this size or more is streamed from the file, its bytes (read for their checks)
#: freed and given back to the system first (`memory.release`: the heap would keep them, unused
#: by Arrow's parse); a smaller one is parsed from its bytes, read once
RELEASE_BYTES = 1 << 26
#: CSV bytes the streaming reader parses at once. The reader of whole tables held about as much
#: again as the table while it parsed (a 400 MB file of 10 M rows: 1.5 GB at its peak, 2.4 s;
#: streamed, 0.9 GB and 1.5 s, the file's bytes included)
STREAM_BYTES = 1 << 24


def _whole_csv(data: bytes, convert: pacsv.ConvertOptions, parse: pacsv.ParseOptions) -> pa.Table:
    """The CSV parsed by Arrow in blocks of its default size, or, when a line is longer than
    that (Arrow refuses a row straddling two blocks), in blocks that hold the longest line: such
    a file went to the slow reader whole (a 500 MB line in 2.2 M rows: 23 s and 5.4 GB)."""
    try:
        options = pacsv.ReadOptions(use_threads=True)
        return pacsv.read_csv(pa.BufferReader(data), options, parse, convert)
    except pa.ArrowInvalid as exc:
        if "straddling" not in str(exc):
            raise
        longest = _longest_line(data)
        if not BLOCK_BYTES < longest < 2**31 - 2:
            raise
    options = pacsv.ReadOptions(use_threads=True, block_size=longest + 2)
    return pacsv.read_csv(pa.BufferReader(data), options, parse, convert)


#: Arrow's default block of CSV bytes parsed at once
BLOCK_BYTES = 1 << 20
#: bytes searched for line ends at once (no mask of the whole file)
PIECE_BYTES = 1 << 26


def _longest_line(data: bytes) -> int:
    """The length in bytes of the longest line, its end included."""
    view = np.frombuffer(data, dtype=np.uint8)
    longest, start = 0, 0  # start: where the line being measured begins
    for at in range(0, view.size, PIECE_BYTES):
        ends = np.flatnonzero(view[at : at + PIECE_BYTES] == 10) + at
        if ends.size:
            longest = max(longest, int(ends[0]) + 1 - start, int(np.diff(ends).max(initial=0)))
            start = int(ends[-1]) + 1
    return max(longest, view.size - start)


def _csv_header(data: bytes) -> list[str]:
    """The names of a CSV's header row (its first record, quotes read as CSV reads them)."""
    import csv

    first = data[: data.find(b"\n") + 1 or len(data)]
    while first.count(b'"') % 2 and len(first) < len(data):  # a quoted name over lines
        end = data.find(b"\n", len(first))
        first = data[: end + 1 if end >= 0 else len(data)]
    text = first.decode("utf-8", errors="replace").replace("\r\n", "\n")
    try:
        return next(csv.reader(io.StringIO(text, newline="")), [])
    except csv.Error:  # e.g. a name beyond the csv module's limit: the reader reports it
        return text.rstrip("\n").split(",")


def _to_pandas(
    handed: list[pa.Table], schema: TableSchema, early: dict[str, Future] | None = None
) -> pd.DataFrame:
    """Arrow to pandas column by column, each Arrow column let go once converted (the table is
    handed over in a list, so that no caller keeps it alive). The schema's key columns (ids
    repeated over millions of rows) become Categoricals made in Arrow, so no Python string is
    made per row; floats become numpy arrays (a column in one piece is not copied). The pandas
    metadata a Parquet file may carry is not applied: an index written by pandas is one more
    column. `early`: key columns already being encoded (`_parquet_table`)."""
    table, early = handed.pop(), early or {}
    keys = _text_keys(schema, table.schema)
    names = table.column_names
    converted: dict[str, Any] = {}
    for f in table.schema:
        text = f.name in keys
        if text or (names.count(f.name) == 1 and pa.types.is_floating(f.type)):
            col = table.column(f.name)
            table = table.drop_columns([f.name])
            if f.name in early:
                converted[f.name] = early[f.name].result()
            else:
                converted[f.name] = _categorical(col) if text else col.to_numpy()
            del col
    rest = table.to_pandas(ignore_metadata=True)
    del table
    others = iter(range(rest.shape[1]))
    frame = pd.DataFrame(
        {
            i: converted[n] if n in converted else rest.iloc[:, next(others)]
            for i, n in enumerate(names)
        },
        index=rest.index,
        copy=False,
    )
    frame.columns = pd.Index(names, dtype=object)
    return frame


def _text_keys(schema: TableSchema, found: pa.Schema) -> list[str]:
    """The schema's key columns (`category`) that the table gives once, as text: they become
    Categoricals."""
    keys = {c.name for c in schema.columns if c.category}
    names = found.names
    return [
        f.name for f in found if f.name in keys and names.count(f.name) == 1 and _is_text(f.type)
    ]


def _is_text(t: pa.DataType) -> bool:
    """Arrow text, plain or dictionary-encoded."""
    if pa.types.is_dictionary(t):
        t = t.value_type
    return pa.types.is_string(t) or pa.types.is_large_string(t)


def _categorical(col: pa.ChunkedArray) -> pd.Categorical:
    """Text as a Categorical of values stripped of surrounding white space; blank → missing.

    One dictionary encoding in Arrow over every chunk (the chunks' indices all refer to the
    last chunk's dictionary), or the column's own dictionaries unified (Parquet's, a pandas
    Categorical's); the values are stripped once per distinct value.
    """
    if len(col) == 0:
        return pd.Categorical([], categories=pd.Index([], dtype=object))
    dictionary = pa.types.is_dictionary(col.type)
    enc = _unified(col) if dictionary else None
    if enc is None:
        col = col.cast(col.type.value_type) if dictionary else col
        if col.nbytes < 2**31:  # one chunk encodes faster (its text must fit 32-bit offsets)
            col = pa.chunked_array([col.combine_chunks()])
        enc = pc.dictionary_encode(col)
    words = enc.chunk(enc.num_chunks - 1).dictionary
    indices = pa.chunked_array([c.indices for c in enc.chunks], enc.type.index_type)
    stripped = pc.utf8_trim_whitespace(words)
    if not stripped.equals(words):  # some ids carried spaces: encode the stripped ones
        enc = pc.dictionary_encode(pc.take(stripped, indices)).combine_chunks()
        stripped, indices = enc.dictionary, enc.indices
    codes = _codes(indices, len(stripped))
    empty = pc.equal(stripped, "").to_numpy(zero_copy_only=False)
    if empty.any():
        remap = np.where(empty, -1, np.cumsum(~empty) - 1)
        codes = np.where(codes >= 0, remap[np.maximum(codes, 0)], -1)
        stripped = stripped.filter(pa.array(~empty))
    return pd.Categorical.from_codes(codes, dtype=_distinct_categories(stripped), validate=False)


def _codes(indices: pa.ChunkedArray | pa.Array, n: int) -> np.ndarray:
    """Dictionary indices as the codes of a Categorical of n categories, in the smallest
    integer type pandas keeps them in (so that pandas does not convert them again), chunk by
    chunk into one array; a missing value is −1."""
    dtype = next(t for t in (np.int8, np.int16, np.int32, np.int64) if n < np.iinfo(t).max)
    codes = np.empty(len(indices), dtype=dtype)
    at = 0
    chunks = indices.chunks if isinstance(indices, pa.ChunkedArray) else [indices]
    for chunk in chunks:  # one per row group
        codes[at : at + len(chunk)] = chunk.fill_null(-1).to_numpy()
        at += len(chunk)
    return codes


def _unified(col: pa.ChunkedArray) -> pa.ChunkedArray | None:
    """A dictionary column's chunks over one dictionary of distinct values; None when it is
    cheaper to decode and encode again (large dictionaries repeated per chunk) or when the
    dictionary repeats a value."""
    if sum(len(c.dictionary) for c in col.chunks) > max(1024, len(col) // 8):
        return None
    enc = col.unify_dictionaries()
    words = enc.chunk(enc.num_chunks - 1).dictionary
    return enc if pc.count_distinct(words).as_py() == len(words) else None


def _distinct_categories(values: pa.Array) -> pd.CategoricalDtype:
    """The dtype of categories known to be distinct (a dictionary's values), as pandas holds
    text (kept in Arrow where pandas does, no Python string per value): pandas' own check
    hashes every value again, seconds for millions of point ids, so it is skipped when the
    installed pandas offers its fast path."""
    index = pd.Index(values.to_pandas())
    fast = getattr(pd.CategoricalDtype, "_from_fastpath", None)
    return fast(index, ordered=False) if fast else pd.CategoricalDtype(index)


def _read_csv_slow(path: Path, data: bytes, reason: str) -> pd.DataFrame:
    """Fallback reader whose errors carry the line number of a malformed row."""
    try:
        raw = pd.read_csv(
            io.BytesIO(data), dtype=str, keep_default_na=False, skipinitialspace=True, header=None
        )  # header=None: every row must have the header's fields, and repeated names stay
    except pd.errors.EmptyDataError:
        raise InputError(Problem(str(path), "the file is empty: expected a header row")) from None
    except (pd.errors.ParserError, ValueError) as exc:
        raise InputError(_parser_problem(path, str(exc), data)) from None
    except Exception:  # pragma: no cover - report the original reader's reason
        raise InputError(Problem(str(path), f"not a readable CSV table: {reason}")) from None
    short = _short_rows(data)  # checked once the file parses: a quote never closed is said so
    if short:
        raise InputError(
            [
                Problem(str(path), f"not a readable CSV table: {why}", line=line)
                for line, why in short
            ]
        )
    return raw.iloc[1:].set_axis(list(raw.iloc[0]), axis=1).reset_index(drop=True)


def _short_rows(data: bytes, limit: int = 5) -> list[tuple[int, str]]:
    """Rows with fewer fields than the header, as (the line they start on, what is wrong):
    pandas pads them with empty cells, which would pass for cells left empty on purpose."""
    import csv

    text = data.decode("utf-8", errors="replace").replace("\r\n", "\n")
    reader = csv.reader(io.StringIO(text, newline=""), skipinitialspace=True)
    header = next(reader, None)
    out: list[tuple[int, str]] = []
    if not header:
        return out
    end = reader.line_num  # the last line read
    try:
        for row in reader:
            start, end = end + 1, reader.line_num
            if row and len(row) < len(header):
                spaces = len(row) == 1 and not row[0].strip()
                why = (
                    "a line of spaces only, where a row is expected (remove it; an empty line "
                    "is skipped)"
                    if spaces
                    else f"{len(row)} fields where the header has {len(header)}"
                    + wide_separated(",".join(row))
                )
                out.append((start, why))
                if len(out) >= limit:
                    break
    except csv.Error:  # e.g. a field beyond the csv module's limit: pandas reports it
        pass
    return out


def _parser_problem(path: Path, message: str, data: bytes) -> Problem:
    """A CSV parser's complaint, with its line taken out into the problem's place (the parser
    counts records: its number is turned into the line the record starts on)."""
    ragged = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", message)
    if ragged:
        want, record, got = map(int, ragged.groups())
        line = _record_line(data, record)
        wide = wide_separated(_line_text(data, line)) if got < want else ""
        return Problem(
            str(path),
            f"not a readable CSV table: {got} fields where the header has {want}{wide}",
            line=line,
        )
    unclosed = re.search(r"EOF inside string starting at row (\d+)", message)
    if unclosed:  # the parser counts its rows from 0, the header being row 0
        return Problem(
            str(path),
            "not a readable CSV table: a quoted field opened on this line is never closed "
            '(expected a closing ", and "" for a quote inside a field)',
            line=_record_line(data, int(unclosed.group(1)) + 1),
        )
    line = re.search(r"(?:line|row) (\d+)", message)
    return Problem(
        str(path),
        f"not a readable CSV table: {message.strip()}",
        line=int(line.group(1)) if line else None,
    )


def _line_text(data: bytes, line: int) -> str:
    """The text of one line (1-based) of a file's bytes."""
    ends = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 0x0A)
    if not 1 <= line <= len(ends) + 1:
        return ""
    start = int(ends[line - 2]) + 1 if line > 1 else 0
    end = int(ends[line - 1]) if line <= len(ends) else len(data)
    return data[start:end].decode("utf-8", errors="replace")


def _record_line(data: bytes, record: int) -> int:
    """The line on which a CSV's `record`-th record (1-based, the header first, an empty line
    one record) starts: later than `record` by the line ends inside the quoted fields above."""
    import csv

    if b'"' not in data:
        return record
    reader = csv.reader(io.StringIO(data.decode("utf-8", errors="replace"), newline=""))
    end = 0  # the last line read
    try:
        for _ in range(record - 1):
            next(reader)
            end = reader.line_num
    except (StopIteration, csv.Error):
        return record
    return end + 1


def _read_parquet(
    path: Path, schema: TableSchema, columns: Collection[str] | None = None
) -> tuple[pd.DataFrame, list[str]]:
    """Read a Parquet table (only the `columns` given; None: all), and its column names;
    columns of the contract must hold plain values, not lists."""
    found = None
    try:
        found = pq.read_schema(path)
        given = found.names
        repeated = [n for n in dict.fromkeys(given) if given.count(n) > 1]
        if repeated:
            raise InputError(
                [
                    Problem(str(path), f"column '{n}' appears more than once; give each once")
                    for n in repeated
                ]
            )
        if columns is not None:
            found = pa.schema([f for f in found if f.name.strip() in columns])
        table, early = _parquet_table(path, schema, found)
    except (pa.ArrowException, OSError) as exc:
        where = _unreadable_row_group(path, found.names if found is not None else None)
        message = f"not a readable Parquet table{where}: {_plain(exc)}"
        raise InputError(Problem(str(path), message)) from None
    names = {c.name for c in schema.columns}
    problems = []
    problems += [
        Problem(
            str(path),
            f"a column of type {f.type} (lists or records): expected one "
            f"{schema.column(f.name).kind} value per row",
            column=f.name,
        )
        for f in table.schema
        if f.name in names and pa.types.is_nested(f.type)
    ]
    problems += _not_utf8(path, table, schema)
    if problems:
        raise InputError(problems)
    try:
        for i, f in enumerate(table.schema):  # text stored as bytes or numbers: read as text
            text = _text_stored_otherwise(schema, names, f, table.column(i))
            if text is not None:
                table = table.set_column(i, f.name, text)
        handed, table = [table], None
        return _to_pandas(handed, schema, early), given
    except (pa.ArrowException, ValueError, OverflowError) as exc:
        message = f"not a readable Parquet table: {_plain(exc)}"
        raise InputError(Problem(str(path), message)) from None


def _text_stored_otherwise(
    schema: TableSchema, names: set[str], f: pa.Field, col: pa.ChunkedArray
) -> pa.ChunkedArray | None:
    """A column of the contract stored as bytes, as UTF-8 text; an id column stored as decimal
    numbers that are all whole (a table written from a numeric array: 1001.0), as the text of
    those whole numbers, as an integer id reads, so that it meets the same id in the other
    tables and in a column read again (`read_rows`). None: the column is read as it is."""
    if f.name not in names:  # the schema's columns
        return None
    if pa.types.is_binary(f.type) or pa.types.is_large_binary(f.type):
        return col.cast(pa.string())
    if schema.column(f.name).kind != "str" or not pa.types.is_floating(f.type):
        return None
    values = pc.if_else(pc.is_nan(col), None, col)  # NaN: no id, as an empty cell
    size = pc.max(pc.abs(values)).as_py() or 0
    if size > MAX_INT or not pc.all(pc.equal(pc.round(values), values)).as_py():
        return None
    return values.cast(pa.int64()).cast(pa.string())


def _plain(exc: Exception) -> str:
    """A reader's message on one line (its control characters, the damaged bytes Arrow quotes
    as they are, are escaped where every Problem is shown: `errors.shown`)."""
    return " ".join(str(exc).split())


def _unreadable_row_group(path: Path, columns: list[str] | None) -> str:
    """Where a Parquet file that fails to read fails: ' (row group i, rows a–b)' of the first
    row group that cannot be read, '' when none alone fails (the footer, the file as a whole)."""
    try:
        parquet = pq.ParquetFile(path)
        meta = parquet.metadata
    except (pa.ArrowException, OSError):
        return ""
    first = 0
    for i in range(meta.num_row_groups):  # row groups, not rows: a few dozen reads at most
        rows = meta.row_group(i).num_rows
        try:
            parquet.read_row_group(i, columns=columns)
        except (pa.ArrowException, OSError):
            return f" (row group {i}, rows {first + 1}–{first + rows})"
        first += rows
    return ""


def _not_utf8(path: Path, table: pa.Table, schema: TableSchema) -> list[Problem]:
    """The first row of each text column of the contract (text or bytes) whose bytes are not
    UTF-8: Arrow keeps such text as it is read, and it would reach the outputs."""
    names = {c.name for c in schema.columns}
    problems = []
    for f in table.schema:
        t = f.type.value_type if pa.types.is_dictionary(f.type) else f.type
        if f.name in names and (
            _is_text(t) or pa.types.is_binary(t) or pa.types.is_large_binary(t)
        ):
            found = _first_not_utf8(table.column(f.name))
            if found is not None:
                row, value = found
                message = _undecodable(value, schema.column(f.name).kind == "wkt")
                problems.append(Problem(str(path), message, row=row + 1, column=f.name))
    return problems


def _undecodable(value: bytes, wkt: bool) -> str:
    """Why a text cell's bytes are refused: no UTF-8, or (a footprint) a geometry in WKB."""
    import shapely

    if wkt and shapely.from_wkb(value, on_invalid="ignore") is not None:
        return (
            "a geometry in WKB (binary, as GeoParquet stores geometries): expected the "
            "footprint as WKT text, e.g. POLYGON((lon lat, …))"
        )
    return f"text that is not UTF-8 (got the bytes {value[:40]!r}): expected UTF-8"


def _first_not_utf8(col: pa.ChunkedArray) -> tuple[int, bytes] | None:
    """The first position in a text or bytes column whose value is not UTF-8, and its bytes
    (None: every value is UTF-8): each piece is checked at once, a piece that fails is halved
    until one value is left."""
    at = 0
    for chunk in col.chunks:
        if pa.types.is_dictionary(chunk.type):
            if _utf8(_view(chunk.dictionary)):
                at += len(chunk)
                continue
            chunk = chunk.dictionary_decode()
        text = _view(chunk)
        if not _utf8(text):
            lo, hi = 0, len(text)  # text[lo:hi] holds a value that is not UTF-8
            while hi - lo > 1:
                mid = (lo + hi) // 2
                lo, hi = (lo, mid) if not _utf8(text.slice(lo, mid - lo)) else (mid, hi)
            return at + lo, _view(text, text=False)[lo].as_py()
        at += len(chunk)
    return None


def _view(a: pa.Array, text: bool = True) -> pa.Array:
    """Bytes seen as text, or text as bytes (no copy, not checked)."""
    large = pa.types.is_large_binary(a.type) or pa.types.is_large_string(a.type)
    if text:
        return a.view(pa.large_string() if large else pa.string())
    return a.view(pa.large_binary() if large else pa.binary())


def _utf8(text: pa.Array) -> bool:
    try:
        text.validate(full=True)
    except pa.ArrowInvalid:
        return False
    return True


#: from this many rows, a Parquet table's text keys (point ids) are encoded by a second thread
#: while its other columns are read
EARLY_ROWS = 1_000_000


def _parquet_table(
    path: Path, schema: TableSchema, found: pa.Schema
) -> tuple[pa.Table, dict[str, Future]]:
    """The columns of `found` of a Parquet file, each column in one piece (so that a float
    column becomes a numpy array without a copy), not read ahead into memory (pre_buffer), but
    those read while the modules imported (`blockqc.prefetch`) taken as they are. In a large
    file, the key columns that are not decoded into a dictionary (point ids: millions of
    distinct values) are read first and encoded by a second thread while the other columns are
    read (`_to_pandas` takes the encodings)."""
    dictionary = _bounded_keys(schema, found)
    parquet = pq.ParquetFile(path, read_dictionary=dictionary, pre_buffer=False)
    if not found.names:  # no column at all: the file's rows, without columns
        return parquet.read(columns=[]), {}
    ahead = prefetch.take(path, found.names, dictionary)
    parts = [] if ahead is None else [ahead]
    names = [n for n in found.names if ahead is None or n not in ahead.column_names]
    first = [n for n in _text_keys(schema, found) if n in names and n not in dictionary]
    early: dict[str, Future] = {}
    if first and parquet.metadata.num_rows >= EARLY_ROWS:
        parts.append(parquet.read(columns=first))
        with ThreadPoolExecutor(1) as encoder:
            early = {n: encoder.submit(_categorical, parts[-1].column(n)) for n in first}
            parts.append(parquet.read(columns=[n for n in names if n not in first]))
    elif names:
        parts.append(parquet.read(columns=names))
    where = {n: part for part in parts for n in part.column_names}
    return pa.table([where[n].column(n) for n in found.names], names=found.names), early


def read_rows(path: Path, column: str, rows: np.ndarray) -> pa.Array:
    """One column of a table file at the rows given (positions): from a Parquet file only
    the row groups that hold them are read; a CSV file is parsed for that column alone."""
    if path.suffix.lower() == ".csv":
        data = read_bytes(path, None).removeprefix(BOM)
        header = _csv_header(data)
        name = next(h for h in header if h.strip() == column)
        table = pacsv.read_csv(
            pa.BufferReader(data),
            convert_options=pacsv.ConvertOptions(
                include_columns=[name], column_types={name: pa.string()}
            ),
        )
        return table.column(0).take(pa.array(rows)).combine_chunks()
    parquet = pq.ParquetFile(path)
    meta = parquet.metadata
    sizes = np.array([meta.row_group(i).num_rows for i in range(meta.num_row_groups)])
    ends = np.cumsum(sizes)
    group = np.searchsorted(ends, rows, side="right")  # the row group of each row
    groups = np.unique(group)
    table = parquet.read_row_groups(groups.tolist(), columns=[column])
    first = np.cumsum(sizes[groups]) - sizes[groups]  # where each group read begins in table
    k = np.searchsorted(groups, group)
    at = first[k] + rows - (ends - sizes)[group]
    return table.column(0).take(pa.array(at)).combine_chunks()


def _bounded_keys(schema: TableSchema, found: pa.Schema) -> list[str]:
    """Text columns referring to another table's key (a tie point's scene_id): their values are
    as few as that table's rows, so Parquet decodes them straight into a dictionary."""
    refs = {r.column for r in schema.references}
    return [f.name for f in found if f.name in refs and _is_text(f.type)]


def header_names(path: Path) -> list[str]:
    """A table file's column names, stripped ([] when the file cannot be read: reading the
    table says why)."""
    try:
        if path.suffix.lower() == ".csv":
            return [h.strip() for h in _csv_header(read_bytes(path, None).removeprefix(BOM))]
        return [name.strip() for name in pq.read_schema(path).names]
    except (InputError, pa.ArrowException, OSError):
        return []


def read_table(path: Path, schema: TableSchema) -> tuple[pd.DataFrame, list[Problem]]:
    """Read and validate one table file (CSV or Parquet) against its schema."""
    df, problems, _ = read_columns(path, schema)
    return df, problems


def read_columns(
    path: Path, schema: TableSchema, columns: Collection[str] | None = None
) -> tuple[pd.DataFrame, list[Problem], list[str]]:
    """Read and validate some columns of a table file (None: all), and the file's column
    names: the checks of columns not read, and of keys over them, are not made."""
    csv = path.suffix.lower() == ".csv"
    raw, header = _read_csv(path, schema, columns) if csv else _read_parquet(path, schema, columns)
    df, problems = validate_table(
        raw, schema, str(path), csv=csv, header=None if columns is None else header
    )
    return df, problems, [h.strip() for h in header]


def load_manifest(path: Path) -> Manifest:
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping of keys (block_id, gsd_m, ...)", line=1)
        )
    problems = _misspelt_keys(path, data)
    try:
        manifest = Manifest.model_validate(data)
    except ValidationError as exc:
        problems = pydantic_problems(exc, path, data, model=Manifest) + problems
    if problems:
        raise InputError(problems)
    manifest.unknown_keys = _unknown_keys(path, data, manifest)
    manifest.reported_at = _places(path, data, "reported", manifest.reported)
    manifest.documents_at = _places(path, data, "documents", manifest.documents)
    return manifest


def _places(path: Path, data: dict, key: str, given: dict[str, Any]) -> dict[str, Problem]:
    """The place in block.yaml (file, line) of each key of one of its mappings."""
    return {k: Problem(str(path), f"{key}.{k}", line=line_of(data, (key, k))) for k in given}


def _unknown_keys(path: Path, data: dict, manifest: Manifest) -> list[Problem]:
    """Keys of block.yaml, and of its spatial_reference, that nothing reads (warnings)."""
    sr = manifest.spatial_reference
    keys = [(key,) for key in manifest.model_extra or {}]
    extra = (sr.model_extra or {}) if sr is not None else {}
    keys += [("spatial_reference", k) for k in extra if k != "zone"]
    strata = " (a key `blockqc sample --strata` may draw strata by)"
    return [
        Problem(
            str(path),
            f"unknown key '{'.'.join(visible_name(str(k)) for k in loc)}': not read by the rules"
            + (strata if len(loc) == 1 else ""),
            line=line_of(data, loc),
        )
        for loc in keys
    ]


def _misspelt_keys(path: Path, data: dict) -> list[Problem]:
    """Extra keys are allowed in block.yaml, but not one that looks like a misspelt known key,
    in other case or close (it would be ignored while the key meant is missed)."""
    sections: list[tuple[tuple[str, ...], Any, set[str]]] = [((), data, set(Manifest.model_fields))]
    sr = data.get("spatial_reference")
    if isinstance(sr, dict):
        sections.append((("spatial_reference",), sr, {*SpatialReference.model_fields, "zone"}))
    problems = []
    for loc, section, known in sections:
        folded = {k.casefold(): k for k in known}  # EPSG, Block_ID: a known key in other case
        for key in section:
            same = folded.get(str(key).casefold())
            close = [same] if same else difflib.get_close_matches(str(key), known, n=1, cutoff=0.75)
            if key not in known and close:
                where = ".".join((*loc, visible_name(str(key))))
                problems.append(
                    Problem(
                        str(path),
                        f"{where}: unknown key; did you mean '{close[0]}'?",
                        line=line_of(data, (*loc, key)),
                    )
                )
    return problems


def load_delivery(
    path: Path,
    manifest: Manifest | None = None,
    *,
    residuals: bool = True,
    tie_point_columns: Collection[str] | None = None,
) -> Delivery:
    """Read a delivery folder; raise InputError listing every problem found (file, row, column).

    `manifest`: block.yaml when already read (a batch reads each manifest once). `residuals`:
    the tie points' v_line/v_sample are needed (inspection) unless the producer's adjusted
    geometry gives them; a recalculation reads the observations alone (False).
    `tie_point_columns`: read only these columns of the tie points (None: every column); the
    others are listed in `Delivery.not_read`, and their checks are not made. A delivery that
    gives its geometry (contract v1.1) is read whole: the verification needs every column.
    """
    path = refuse_undecodable([Path(path)])[0]
    problems: list[Problem] = []
    try:
        manifest = manifest or load_manifest(path / MANIFEST)
    except InputError as exc:
        problems.extend(exc.problems)
    if tie_point_columns is not None and has_geometry(path):
        tie_point_columns = None
    read = _read_tables(path, tie_point_columns)
    problems.extend(read.problems)
    problems.extend(_across_tables(path, read, manifest))
    geometry, found = load_geometry(path, read.tables, read.files)  # contract v1.1
    problems.extend(found)
    problems.extend(_tie_point_column_problems(path, read, residuals))
    if problems and manifest is not None:  # reported now too, not only once the tables are fixed
        problems.extend(_missing_documents(path, manifest))
    if problems:
        raise InputError(located(problems))
    assert manifest is not None
    return Delivery(
        path=path,
        manifest=manifest,
        files=read.files,
        geometry=geometry,
        not_read=_not_read(read),
        read_warnings=read.warnings,
        **read.tables,
    )


@dataclass
class _Tables:
    """The tables of a delivery as read: frames, files, header names, problems; `clean`: the
    tables read without a problem (checked row by row further)."""

    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)
    headers: dict[str, list[str]] = field(default_factory=dict)
    clean: set[str] = field(default_factory=set)
    problems: list[Problem] = field(default_factory=list)
    warnings: list[Problem] = field(default_factory=list)


def _read_tables(path: Path, tie_point_columns: Collection[str] | None) -> _Tables:
    """Read and validate every table of the contract the delivery gives (a required one
    missing is a problem); of the tie points only `tie_point_columns` (None: all)."""
    out = _Tables()
    for name, schema in TABLES.items():
        columns = tie_point_columns if name == "tie_points" else None
        try:
            f = _table_file(path, name)
            if f is None:
                if schema.required:
                    out.problems.append(
                        Problem(
                            str(path / f"{name}.csv"),
                            f"required table {name} is missing (expected "
                            f"{name}.csv or {name}.parquet)",
                        )
                    )
                continue
            out.files[name] = f
            df, found, out.headers[name] = read_columns(f, schema, columns)
        except InputError as exc:
            out.problems.extend(exc.problems)
            continue
        out.problems.extend(found)
        out.warnings.extend(stored_resolution(f, schema, df))
        out.tables[name] = df
        if not found:
            out.clean.add(name)
    return out


def _across_tables(path: Path, read: _Tables, manifest: Manifest | None) -> list[Problem]:
    """The problems of the delivery's tables taken together: files misnamed or misplaced, keys
    no table gives, rows inconsistent with each other (of the tables read without a problem),
    edges from the block to itself."""
    tables, files = read.tables, read.files
    problems: list[Problem] = []
    problems.extend(_misnamed_tables(path))
    problems.extend(_misplaced_inputs(path))
    problems.extend(_check_references(tables, files))
    problems.extend(_check_consistency({k: tables[k] for k in read.clean}, files))
    if manifest is not None and "edges" in read.clean:
        problems.extend(_edges_to_itself(tables["edges"], files["edges"], manifest.block_id))
    return problems


def _tie_point_column_problems(path: Path, read: _Tables, residuals: bool) -> list[Problem]:
    """The problems of the tie points' ground columns and, when `residuals` are needed, of their
    residual columns (which the producer's adjustment, when the delivery gives one, may stand
    in for)."""
    if "tie_points" not in read.tables:
        return []
    tp_columns, tp_file = read.headers["tie_points"], read.files["tie_points"]
    problems = ground_column_problems(tp_columns, tp_file)
    if residuals:
        problems.extend(residual_column_problems(tp_columns, tp_file, gives_adjustment(path)))
    return problems


def _not_read(read: _Tables) -> dict[str, list[str]]:
    """The columns each table's header names that were not read, by table (a table read whole
    is left out)."""
    not_read = {
        name: [c for c in dict.fromkeys(read.headers[name]) if c and c not in df.columns]
        for name, df in read.tables.items()
    }
    return {k: v for k, v in not_read.items() if v}


def _misnamed_tables(path: Path) -> list[Problem]:
    """Files that look like a table of the contract but are not named <table>.csv|.parquet
    (checkpoints.CSV, checkpoints.csv.gz, checkpoint.csv; and, where the table is not given,
    checkpoints (1).csv or F1-B01_checkpoints.csv): not read, so an optional table would be
    left out unsaid (a sampled block judged without its checkpoints). Likewise a folder named
    like rpc/ or rpc_adjusted/ (RPC/, rpcs/): its geometry would pass for absent. Only the
    delivery's own folder is looked at here; what lies below it, by `_misplaced_inputs`."""
    exact = {f"{n}.{ext}" for n in TABLES for ext in ("csv", "parquet")} | set(GEOMETRY_DIRS)
    absent = _absent_tables(path)
    problems = []
    for f in sorted(path.iterdir()):
        if f.name in exact or f.name.startswith("."):
            continue
        stem = _stem(f.name)
        if f.is_dir():
            close = _geometry_meant(stem, GEOMETRY_DIRS)
            why = "not read: the geometry of contract v1.1 is read from {0}/ (lower case)"
        else:
            close = difflib.get_close_matches(stem, list(TABLES), n=1, cutoff=0.9)
            close = close or difflib.get_close_matches(stem, absent, n=1, cutoff=0.8)  # edge.csv
            close = close or [
                n for n in absent if re.search(rf"(?<![a-z0-9]){n}(?![a-z0-9])", stem)
            ]
            why = "not read: a table is named {0}.csv or {0}.parquet (lower case, not compressed)"
        if close:
            problems.append(Problem(str(f), why.format(close[0])))
    return problems


def _absent_tables(path: Path) -> list[str]:
    """The tables of the contract the delivery's own folder does not give (in either form)."""
    given = {f.name for f in path.iterdir()}
    return [n for n in TABLES if not {f"{n}.csv", f"{n}.parquet"} & given]


def _stem(name: str) -> str:
    """A file or folder name as compared with the contract's: lower case, without its
    extensions, '-' and ' ' read as '_' (Checkpoints-Final.CSV: checkpoints_final)."""
    return name.lower().split(".", 1)[0].replace("-", "_").replace(" ", "_")


def _geometry_meant(stem: str, dirs: Collection[str]) -> list[str]:
    """The geometry folder of `dirs` a folder's name (`_stem`) is close to: rpc for RPC or
    rpcs, rpc_adjusted for RPC_Adjusted; [] for none."""
    return difflib.get_close_matches(stem, list(dirs), n=1, cutoff=0.8)


#: entries below a delivery's own folder looked through for its inputs placed there: a
#: documents tree of many files stays cheap to look through (10,000 files: some 10 ms; 20,000,
#: some 20 ms), and one beyond this is said not to be looked through all (`unread_tables`)
MAX_ENTRIES_BELOW = 20_000


@dataclass
class _Below:
    """The entries of a delivery's sub-folders at any depth (`_below`), the folders among them
    that cannot be read, and whether the look stopped at MAX_ENTRIES_BELOW entries."""

    entries: list[os.DirEntry] = field(default_factory=list)
    unreadable: list[Problem] = field(default_factory=list)
    cut: bool = False


def _below(path: Path) -> _Below:
    """What lies in the sub-folders of a delivery, at any depth, breadth first (each folder's
    entries sorted): names starting with '.' are left out; rpc/ and rpc_adjusted/ are not
    looked into (their files are read as the geometry, and anything else in them refused);
    a folder linked to is followed from the delivery's own folder only, so that links cannot
    lead the look round in a loop. A folder that cannot be listed, or whose entries cannot be
    reached (`listed`), is a problem named by the folder."""
    below = _Below()
    queue = [str(f) for f in _members(path) if f.name not in GEOMETRY_DIRS and f.is_dir()]
    for folder in queue:  # grows as folders are found: breadth first
        try:
            entries = listed(folder)
        except OSError as exc:
            below.unreadable.append(unreadable_folder(Path(folder), exc))
            continue
        room = MAX_ENTRIES_BELOW - len(below.entries)
        below.cut = len(entries) > room
        below.entries.extend(entries[:room])
        if below.cut:
            break
        queue.extend(e.path for e in entries[:room] if _is_dir(e, follow=False))
    return below


def _misplaced_inputs(path: Path) -> list[Problem]:
    """Inputs of the contract placed below the delivery's own folder, at any depth, where
    nothing is read: a table the delivery does not give (tables/checkpoints.csv,
    documents/annex/pan_ms.csv) and a geometry folder it does not give (geometry/rpc/): left
    out, a sampled block would be judged without its checkpoints, a delivery of contract v1.1
    as one of v1 without geometry. A folder there that cannot be read is said, by name (it
    cannot be looked through)."""
    absent = {f"{n}.{ext}": n for n in _absent_tables(path) for ext in ("csv", "parquet")}
    dirs = [d for d in GEOMETRY_DIRS if not (path / d).exists()]
    below = _below(path)
    problems = list(below.unreadable)
    for e in below.entries:
        if e.name in absent and _is_file(e):
            held = _HELD.format(_with_article(absent[e.name]), absent[e.name])
            problems.append(Problem(os.path.dirname(e.path), held))
        elif meant := _geometry_below(e, dirs):
            problems.append(Problem(e.path, _GEOMETRY_BELOW.format(meant)))
    return list(dict.fromkeys(problems))  # a table given twice in one folder, said once


_HELD = (
    "holds {0} table, not read there: tables are read from the delivery's own folder "
    "({1}.csv or {1}.parquet beside block.yaml)"
)
_GEOMETRY_BELOW = (
    "not read there: the geometry of contract v1.1 is read from the delivery's own folder "
    "({0}/ beside block.yaml)"
)


def _with_article(word: str) -> str:
    """A table's name after its article: a pan_ms, an overlaps, an adjustment."""
    return f"{'an' if word[:1].lower() in {'a', 'e', 'i', 'o', 'u'} else 'a'} {word}"


def _geometry_below(entry: os.DirEntry, dirs: list[str]) -> str | None:
    """The geometry folder of `dirs` a folder below the delivery's own is named like (rpc/,
    RPC/, rpcs/, rpc_adjusted/), or None. Its name must hold 'rpc': a short one close to rpc
    by its letters alone (pc/, rc/) is another folder of a documents tree."""
    if "rpc" not in entry.name.lower() or not _is_dir(entry):
        return None
    meant = _geometry_meant(_stem(entry.name), dirs)
    return meant[0] if meant else None


def _is_file(entry: os.DirEntry) -> bool:
    """Whether an entry is a file or a link to one (False when that cannot be looked at)."""
    try:
        return entry.is_file()
    except OSError:
        return False


def _is_dir(entry: os.DirEntry, follow: bool = True) -> bool:
    """Whether an entry is a folder, or (`follow`) a link to one; False when that cannot be
    looked at."""
    try:
        return entry.is_dir(follow_symlinks=follow)
    except OSError:
        return False


#: the endings of files read as tables elsewhere: such a file in a delivery's folder that is no
#: table of the contract is said not to be read (`unread_tables`)
TABLE_SUFFIXES = (".csv", ".tsv", ".parquet", ".xlsx", ".xls")


def unread_tables(path: Path) -> list[str]:
    """Warnings for the table files of a delivery's folder from which no table of the contract
    is read (checkpoints_extra.csv beside checkpoints.csv): their rows are judged by no rule,
    and said so. Those taken for a misnamed table are refused (`_misnamed_tables`) instead.
    A tree of sub-folders too large to be looked through all for misplaced inputs is said."""
    try:
        files = sorted(f for f in path.iterdir() if f.name.lower().endswith(TABLE_SUFFIXES))
        refused = {p.file for p in _misnamed_tables(path)}
        cut = _below(path).cut
    except OSError:  # the delivery's reader says what is wrong with the folder
        return []
    tables = {f"{n}.{ext}" for n in TABLES for ext in ("csv", "parquet")}
    why = (
        "not read: no table of the contract is read from it (a delivery's tables are "
        f"{', '.join(TABLES)}, each .csv or .parquet)"
    )
    warnings = [f"{f}: {why}" for f in files if f.name not in tables and str(f) not in refused]
    if cut:
        warnings.append(
            f"{path}: its sub-folders hold more than {MAX_ENTRIES_BELOW:,} files and folders: "
            f"the first {MAX_ENTRIES_BELOW:,} (breadth first) were looked through for tables or "
            "geometry placed there, the others not"
        )
    return warnings


def _check_references(tables: dict[str, pd.DataFrame], files: dict[str, Path]) -> list[Problem]:
    """Every reference between tables must resolve (e.g. a tie point's scene_id is a scene)."""
    problems: list[Problem] = []
    for name, df in tables.items():
        for ref in TABLES[name].references:
            target = tables.get(ref.table)
            if target is None or ref.column not in df.columns or ref.key not in target.columns:
                continue
            missing = _unknown(df[ref.column], target[ref.key])  # blank cells: reported apart
            f = files[name]
            report_rows(
                problems,
                str(f),
                ref.column,
                missing,
                f"unknown {ref.key} (not in {files[ref.table].name})",
                df[ref.column],
                f.suffix == ".csv",
                did_you_mean(target[ref.key].dropna().unique()[:100_000]),
            )
    return problems


def _unknown(values: pd.Series, keys: pd.Series) -> np.ndarray:
    """Cells holding a value that is not one of `keys` (missing cells aside); a Categorical's
    categories are looked up once each, its rows only when one is unknown."""
    if isinstance(values.dtype, pd.CategoricalDtype):
        codes = values.array.codes  # -1: a missing cell
        bad = ~values.cat.categories.isin(keys)
        if not (bad & (grouped.counts(codes, len(bad)) > 0)).any():
            return np.zeros(len(values), dtype=bool)
        return bad[codes] & (codes >= 0)
    given = values.notna().to_numpy(dtype=bool)
    return given & ~values.isin(keys).to_numpy(dtype=bool)


#: image positions may use either pixel convention (corner or centre of the first pixel)
PIXEL_SLACK = 0.5


Masks = list[tuple[str, str | None, np.ndarray, str]]


def _consistency_masks(tables: dict[str, pd.DataFrame], scenes_file: str = "scenes.csv") -> Masks:
    """Rows whose cells contradict each other, per table: (table, column, mask, message)."""
    tp, sc = tables.get("tie_points"), tables.get("scenes")
    return [
        *_checkpoint_masks(tables.get("checkpoints")),
        *_partial_ground_points(tp),
        *_outside_scene_masks(tp, sc, scenes_file),
        *_pan_ms_band_masks(tables.get("pan_ms"), sc, scenes_file),
        *_overlap_masks(tables.get("overlaps")),
    ]


def _checkpoint_masks(cp: pd.DataFrame | None) -> Masks:
    """Checkpoint rows giving half a reference position, a height without its reference, or
    nothing to compare."""
    if cp is None or not {"x_m", "ref_x_m", "ref_y_m", "z_m", "ref_z_m"} <= set(cp.columns):
        return []
    rx, ry = cp["ref_x_m"].isna().to_numpy(), cp["ref_y_m"].isna().to_numpy()
    z, rz = cp["z_m"].isna().to_numpy(), cp["ref_z_m"].isna().to_numpy()
    return [
        ("checkpoints", "ref_x_m", rx & ~ry,
         "ref_x_m is empty where ref_y_m is given: give both, or neither"),
        ("checkpoints", "ref_y_m", ry & ~rx,
         "ref_y_m is empty where ref_x_m is given: give both, or neither"),
        ("checkpoints", "z_m", z & ~rz,
         "z_m is empty where ref_z_m is given: the height cannot be compared"),
        ("checkpoints", None, rx & ry & rz,
         "the row compares nothing: give ref_x_m and ref_y_m, or ref_z_m"),
    ]  # fmt: skip


def _outside_scene_masks(tp: pd.DataFrame | None, sc: pd.DataFrame | None, file: str) -> Masks:
    """Tie-point observations whose line or sample lies outside their scene's extent."""
    if tp is None or sc is None:
        return []
    out = []
    size = sc.drop_duplicates("scene_id").set_index("scene_id")
    codes, lookup = scene_lookup(tp["scene_id"], size.index)  # grouped by the codes
    for col, extent in (("line", "lines"), ("sample", "samples")):
        if col not in tp.columns:  # not read
            continue
        v = tp[col].to_numpy(dtype=float)
        limit = size[extent].to_numpy(dtype=float, na_value=np.nan)
        top = np.append(limit, np.nan)[lookup]  # position −1, no scene: reported apart
        outside = _outside(v, codes, -PIXEL_SLACK, top + PIXEL_SLACK)
        msg = f"{col} lies outside its scene (0 to the scene's {extent} in {file})"
        out.append(("tie_points", col, outside, msg))
    return out


def _pan_ms_band_masks(pm: pd.DataFrame | None, sc: pd.DataFrame | None, file: str) -> Masks:
    """PAN/MS registration rows naming a scene of the other band."""
    if pm is None or sc is None:
        return []
    out = []
    band = sc.drop_duplicates("scene_id").set_index("scene_id")["band"]
    for col, want in (("pan_scene_id", "pan"), ("ms_scene_id", "ms")):
        got = pm[col].astype(object).map(band)
        wrong = (got.notna() & (got != want)).to_numpy(dtype=bool)
        msg = f"{col} names a scene whose band in {file} is not {want}"
        out.append(("pan_ms", col, wrong, msg))
    return out


def _overlap_masks(ov: pd.DataFrame | None) -> Masks:
    """Overlap rows pairing a scene with itself, or giving a point of a pair twice (swapped)."""
    if ov is None or not {"scene_a", "scene_b"} <= set(ov.columns):
        return []
    same = (ov["scene_a"] == ov["scene_b"]).to_numpy(dtype=bool)
    out = [("overlaps", "scene_b", same, "scene_b is scene_a: expected two scenes")]
    if "point_id" in ov.columns:
        msg = (
            "the same point of this pair is also given with scene_a and scene_b swapped: "
            "give each point of a pair once"
        )
        out.append(("overlaps", None, _given_swapped(ov) & ~same, msg))
    return out


#: why a row's lon, lat and h go together (contract v1.1; `ground_column_problems` for columns)
WHOLE_GROUND_POINT = (
    "a ground point is lon and lat together, and h its height: give lon and lat, with or "
    "without h, or none of the three"
)


def _partial_ground_points(tp: pd.DataFrame | None) -> Masks:
    """Tie-point rows giving part of the producer's ground point: lon without lat, lat without
    lon, or h without both (a row giving none has no ground point). Rows are only checked
    when the table has lon and lat columns (else the columns are refused)."""
    if tp is None or not {"lon", "lat"} <= set(tp.columns):
        return []
    lon, lat = tp["lon"].isna().to_numpy(), tp["lat"].isna().to_numpy()
    out = [
        (
            "tie_points",
            "lon",
            lon & ~lat,
            f"lon is empty where lat is given ({WHOLE_GROUND_POINT})",
        ),
        (
            "tie_points",
            "lat",
            lat & ~lon,
            f"lat is empty where lon is given ({WHOLE_GROUND_POINT})",
        ),
    ]
    if "h" in tp.columns:
        h = tp["h"].notna().to_numpy()
        message = f"h is given where lon and lat are empty ({WHOLE_GROUND_POINT})"
        out.append(("tie_points", "h", h & lon & lat, message))
    return out


def _given_swapped(ov: pd.DataFrame) -> np.ndarray:
    """Overlap rows whose point is given again for the same pair in the other order (B, A):
    the unique key (scene_a, scene_b, point_id) lets it through, and it would count twice.
    Scenes and points get integer codes (a blank its own), each pair in both orders one code
    below 2·rows, and each row one integer key; one isin finds the swapped keys among the given."""
    n = len(ov)
    scene = pd.factorize(pd.concat([ov["scene_a"], ov["scene_b"]], ignore_index=True))[0] + 1
    point = pd.factorize(ov["point_id"])[0].astype(np.int64) + 1
    a, b, k = scene[:n].astype(np.int64), scene[n:].astype(np.int64), int(scene.max(initial=0)) + 1
    pair = pd.factorize(np.concatenate([a * k + b, b * k + a]))[0].astype(np.int64)
    m = int(point.max(initial=0)) + 1
    return np.isin(pair[n:] * m + point, pair[:n] * m + point)


def _outside(v: np.ndarray, at: np.ndarray, low: float, high: np.ndarray) -> np.ndarray:
    """Rows whose value lies below `low` or above its group's `high[at]` (NaN compares as
    inside; group −1 is high's last). The extremes of each group are found first, so that a
    table within its bounds costs one grouped pass and no row-sized temporary."""
    lo, hi = grouped.extremes(v, at, len(high))
    with np.errstate(invalid="ignore"):
        if at.min(initial=0) >= 0 and not ((lo < low) | (hi > high)).any():
            return np.zeros(len(v), dtype=bool)
        return (v < low) | (v > high[at])


def _check_consistency(tables: dict[str, pd.DataFrame], files: dict[str, Path]) -> list[Problem]:
    """Cells of one row that contradict each other (else their rows would be dropped unsaid)."""
    problems: list[Problem] = []
    scenes_file = files["scenes"].name if "scenes" in files else "scenes.csv"
    for name, column, mask, message in _consistency_masks(tables, scenes_file):
        f = files[name]
        shown = ("line", "sample", "pan_scene_id", "ms_scene_id")
        values = tables[name][column] if column in shown else None
        report_rows(problems, str(f), column, mask, message, values, f.suffix == ".csv")
    return problems


def _edges_to_itself(edges: pd.DataFrame, f: Path, block_id: str) -> list[Problem]:
    """Edge discrepancies whose neighbour_block is the block itself (whatever its case, as
    block ids are unique): no adjacent block's, they would be judged by RO-2 as if they were."""
    neighbour = edges["neighbour_block"].astype("string").str.casefold()
    own = (neighbour == block_id.casefold()).to_numpy(dtype=bool, na_value=False)
    problems: list[Problem] = []
    msg = (
        f"neighbour_block names this block (block_id {block_id} in block.yaml): "
        "expected an adjacent block"
    )
    values = edges["neighbour_block"]
    report_rows(problems, str(f), "neighbour_block", own, msg, values, f.suffix == ".csv")
    return problems


def _missing_documents(path: Path, manifest: Manifest) -> list[Problem]:
    """Documents block.yaml names that are not files of the delivery (judged by DOC-1 when the
    delivery is otherwise readable; listed with its other problems when it is not)."""
    return [
        Problem(
            str(path / MANIFEST),
            f"documents.{kind}: {rel} is missing from the delivery{other_case(path, rel)}",
        )
        for kind, rel in manifest.documents.items()
        if _document_missing(document_path(path, rel))
    ]


def _document_missing(path: Path) -> bool:
    """Whether a document is missing; one that cannot be looked at (in a folder that cannot
    be read, said of the folder by `_misplaced_inputs`) is not said missing as well."""
    try:
        return not path.is_file()
    except OSError:
        return False


def other_case(root: Path, rel: str) -> str:
    """Where the delivery holds a missing document under a name differing only in case
    (`report.PDF`), said in parentheses; a link of its own name to nothing, said so; else
    nothing."""
    path = document_path(root, rel)
    if path.is_symlink() and not path.exists():
        return " (a symbolic link to a file that does not exist)"
    try:
        near = [
            p
            for p in path.parent.iterdir()
            if p.name != path.name and p.name.casefold() == path.name.casefold()
        ]
    except OSError:  # no such folder either
        return ""
    if not near:
        return ""
    found = near[0].relative_to(root).as_posix()
    return f" ({found} is there: file names are matched exactly, in their case)"


def document_path(root: Path, rel: str) -> Path:
    """A document block.yaml names, in the delivery `root`: a path written with Windows
    separators (documents\\design.pdf, as Windows tools write it) is read with '/'."""
    return root / rel.replace("\\", "/")


def summary(d: Delivery) -> dict[str, Any]:
    """Counts for messages and reports; with the point ids read, also the tie points observed
    on one scene only (an observation a row, a point on a scene once: they tie no scenes)."""
    out: dict[str, Any] = {
        "scenes": len(d.scenes),
        "tie_point_observations": len(d.tie_points),
        "tie_points": None,
        "checkpoints": 0 if d.checkpoints is None else distinct_count(d.checkpoints["point_id"]),
    }
    if "point_id" in d.tie_points:
        counts = value_counts(d.tie_points["point_id"])
        out["tie_points"] = int(np.count_nonzero(counts))
        out["tie_points_on_one_scene"] = int(np.count_nonzero(counts == 1))
    return out


def distinct_count(values: pd.Series) -> int:
    """How many distinct values, missing ones aside."""
    return int(np.count_nonzero(value_counts(values)))


def value_counts(values: pd.Series) -> np.ndarray:
    """How many times each value is given (some counts may be 0), missing ones aside; a
    Categorical's by one bincount of its codes (millions of point ids are not hashed again)."""
    if not isinstance(values.dtype, pd.CategoricalDtype):
        return values.value_counts(dropna=True).to_numpy()
    codes = values.array.codes
    return np.bincount(codes + 1, minlength=len(values.cat.categories) + 1)[1:]


def scene_positions(scene_id: pd.Series, scene_ids: Any) -> np.ndarray:
    """Each row's position in `scene_ids` (-1 when absent), as int32."""
    codes, lookup = scene_lookup(scene_id, scene_ids)
    return lookup[codes]


def scene_lookup(scene_id: pd.Series, scene_ids: Any) -> tuple[np.ndarray, np.ndarray]:
    """Each row's code and, per code, its position in `scene_ids` (-1 when absent): a row's
    position is lookup[code], code −1 (a missing cell) taking lookup's last entry, −1. A
    Categorical's own codes are given and its categories looked up once each, so that a pass
    over millions of rows can take positions a piece at a time, or group by the codes."""
    index = pd.Index(scene_ids)
    if not isinstance(scene_id.dtype, pd.CategoricalDtype):
        codes = index.get_indexer(scene_id).astype(np.int32)
        return codes, np.append(np.arange(len(index), dtype=np.int32), np.int32(-1))
    found = np.append(index.get_indexer(scene_id.cat.categories), -1)
    return scene_id.array.codes, found.astype(np.int32)


@dataclass
class DeliveryIds:
    """What of one delivery a verdicts file may name, read lightly for checking it: the scene
    ids (None where scenes.csv cannot be read) and, only when a waiver names units of a table,
    that table's key columns. What cannot be read is reported when the delivery is inspected."""

    block_id: str
    path: Path
    scenes: set[str] | None
    _units: dict[tuple[str, tuple[str, ...]], pd.DataFrame | None] = field(
        default_factory=dict, repr=False
    )

    def units(self, table: str, columns: tuple[str, ...]) -> pd.DataFrame | None:
        """The distinct rows of these columns of a table (none when the delivery has no such
        table), or None when the table cannot be read."""
        key = (table, columns)
        if key not in self._units:
            self._units[key] = _key_rows(self.path, table, columns)
        return self._units[key]


def _key_rows(path: Path, table: str, columns: tuple[str, ...]) -> pd.DataFrame | None:
    try:
        f = _table_file(path, table)
        if f is None:
            return pd.DataFrame(columns=list(columns))
        df, problems, _ = read_columns(f, TABLES[table], set(columns))
    except InputError:
        return None
    return None if problems else df[list(columns)].drop_duplicates()


def block_ids(
    paths: list[Path], manifests: dict[Path, Manifest] | None = None
) -> tuple[dict[str, DeliveryIds], list[Path]]:
    """Block id -> the ids of its delivery, for checking the inspector's file, and the deliveries
    whose block.yaml cannot be read (their block ids unknown; their problems are reported when
    they are read). `manifests`: the manifests already read."""
    out: dict[str, DeliveryIds] = {}
    unread: list[Path] = []
    manifests = manifests or {}
    for path in paths:  # a handful of small files per delivery
        try:
            bid = (manifests.get(path) or load_manifest(path / MANIFEST)).block_id
        except InputError:
            unread.append(path)
            continue
        try:
            f = _table_file(path, "scenes")
            df, problems = read_table(f, TABLES["scenes"]) if f else (None, [])
        except InputError:
            df, problems = None, []
        ok = df is not None and not problems
        scenes = set(df["scene_id"].dropna().astype(str)) if ok else None
        out[bid] = DeliveryIds(bid, path, scenes)
    return out, unread
