"""The inspector's own checkpoints (`inspect --checkpoints FILE…`), merged with a delivery's.

Contract v1.1: checkpoints may come from outside the delivery, like verdicts — e.g. the
`checkpoints.csv` of a recalculation (method `recalculation`, §RC-3). Each file has the columns of
checkpoints.csv and, when several blocks are inspected, a `block_id` column saying whose rows they
are. A (point_id, method) given twice, in two files or in a file and the delivery, is refused.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from blockqc.delivery import (
    MANIFEST,
    Delivery,
    _check_consistency,
    header_names,
    load_manifest,
    read_table,
)
from blockqc.errors import InputError, Problem
from blockqc.precision import stored_resolution
from blockqc.schema import CHECKPOINTS, Column, TableSchema, near_column
from blockqc.textio import located, not_there

BLOCK = "block_id"

#: a file of several blocks' checkpoints: its block ids are text as block.yaml's ('0012' stays
#: '0012'), and a point id may come again in another block (each block numbers its own points)
BY_BLOCK = TableSchema(
    CHECKPOINTS.name,
    (*CHECKPOINTS.columns, Column(BLOCK, "str", nullable=True)),
    unique=(BLOCK, *CHECKPOINTS.unique),
)


@dataclass
class InspectorCheckpoints:
    """Rows of the inspector's checkpoint files, each with its file and row for messages."""

    rows: pd.DataFrame
    by_block: bool
    files: list[str] = field(default_factory=list)

    def block_ids(self) -> set[str]:
        return set(self.rows[BLOCK]) if self.by_block else set()

    def for_block(self, block_id: str, single: bool) -> pd.DataFrame:
        """This block's rows; without a block_id column only a single delivery may be inspected."""
        if self.by_block:
            return self.rows[self.rows[BLOCK] == block_id]
        if not single:
            raise self.no_block_column()
        return self.rows

    def no_block_column(self) -> InputError:
        """The refusal of files without a block_id column when several blocks are inspected."""
        return InputError(
            [
                Problem(
                    f,
                    f"several blocks are inspected: give a '{BLOCK}' column saying which block "
                    "each checkpoint belongs to",
                )
                for f in self.files
            ]
        )


def load_checkpoint_files(paths: list[Path]) -> InspectorCheckpoints:
    """Read and validate every file (checkpoints.csv columns); list every problem at once."""
    problems: list[Problem] = _given_twice(list(map(Path, paths)))
    if problems:
        raise InputError(problems)
    parts: list[pd.DataFrame] = []
    with_block = []
    for path in map(Path, paths):
        if not path.is_file():
            what = (
                "a folder"
                if path.is_dir()
                else "not a file"
                if path.exists()
                else not_there(path, "no such file")
            )
            problems.append(Problem(str(path), f"{what} (expected a checkpoints table)"))
            continue
        if path.suffix.lower() not in (".csv", ".parquet"):
            what = "a checkpoints table: a .csv file (with a header row) or a .parquet file"
            problems.append(
                Problem(str(path), f"named {path.suffix or 'without a suffix'}; expected {what}")
            )
            continue
        try:
            df, found = read_table(path, _schema(path))
        except InputError as exc:
            problems.extend(exc.problems)
            continue
        problems.extend(found + _misspelt_block(path, df))
        # the same row checks as a delivered checkpoints.csv (a row comparing nothing, ...)
        problems.extend(_check_consistency({"checkpoints": df}, {"checkpoints": path}))
        with_block.append(BLOCK in df.columns)
        if BLOCK in df.columns:
            df[BLOCK] = df[BLOCK].astype("string").str.strip().astype(object)
            problems.extend(_blank_blocks(path, df[BLOCK]))
        parts.append(df.assign(_file=str(path), _row=range(1, len(df) + 1)))
    if problems:
        raise InputError(located(problems))
    if len(set(with_block)) > 1:
        raise InputError(
            Problem(str(paths[0]), f"give a '{BLOCK}' column in every checkpoint file or in none")
        )
    rows = pd.concat(parts, ignore_index=True)
    problems.extend(_duplicates(rows, [BLOCK] if with_block[0] else []))
    if problems:
        raise InputError(located(problems))
    return InspectorCheckpoints(rows, with_block[0], [str(p) for p in paths])


def _schema(path: Path) -> TableSchema:
    """The checkpoints table, keyed and typed per block when the file has a block_id column."""
    return BY_BLOCK if BLOCK in header_names(path) else CHECKPOINTS


def _blank_blocks(path: Path, block: pd.Series) -> list[Problem]:
    """Rows with an empty block_id: they name no block (the first ten)."""
    blank = np.flatnonzero((block.isna() | (block == "")).to_numpy())
    message = "empty: every row names the block of its checkpoint"
    return [
        Problem(str(path), message, row=int(i) + 1, line=_line(path, int(i) + 1), column=BLOCK)
        for i in blank[:10]
    ]


def _line(path: Path | str, row: int) -> int | None:
    """The line of a CSV file's row as counted before `located` (row + 1; None in Parquet)."""
    return row + 1 if str(path).lower().endswith(".csv") else None


def _misspelt_block(path: Path, df: pd.DataFrame) -> list[Problem]:
    """A column that looks like `block_id` misspelt (`Block_ID`, `blockid`) where there is no
    `block_id`: its blocks would go unread, and every row be taken as the one block's."""
    known = {c.name for c in CHECKPOINTS.columns}
    near = near_column(BLOCK, [c for c in df.columns if c not in known])
    if BLOCK in df.columns or near is None:
        return []
    message = f"column '{near}': did you mean '{BLOCK}'? (the block of each row is read from it)"
    return [Problem(str(path), message, line=1 if path.suffix.lower() == ".csv" else None)]


def _given_twice(paths: list[Path]) -> list[Problem]:
    """A file named again (by the same or another path to it): its rows would be taken twice."""
    seen: dict[Path, Path] = {}
    problems = []
    for path in paths:
        real = path.resolve()
        if real in seen:
            problems.append(
                Problem(
                    str(path), f"given twice to --checkpoints (also as {seen[real]}): give it once"
                )
            )
        seen.setdefault(real, path)
    return problems


def _duplicates(rows: pd.DataFrame, extra: list[str]) -> list[Problem]:
    """A (point_id, method) given twice across the inspector's files."""
    keys = [*extra, "point_id", "method"]
    dup = rows.duplicated(keys, keep="first").to_numpy()
    first = rows.drop_duplicates(keys).set_index(keys)
    return [
        Problem(
            r["_file"],
            f"checkpoint {r['point_id']} ({r['method']}) is also in "
            f"{first.loc[tuple(r[k] for k in keys), '_file']}",
            row=int(r["_row"]),
            line=_line(r["_file"], int(r["_row"])),
        )
        for _, r in rows[dup].head(10).iterrows()
    ]


def merge_checkpoints(d: Delivery, extra: pd.DataFrame) -> Delivery:
    """The delivery with the inspector's rows added to its checkpoints (§CP-2, contract v1.1),
    and the ground columns their files store coarser than float64 said as the delivery's are."""
    if extra.empty:
        return d
    cols = [c.name for c in CHECKPOINTS.columns]
    if d.checkpoints is not None:
        both = extra.merge(d.checkpoints[["point_id", "method"]], on=["point_id", "method"])
        if not both.empty:
            where = d.files.get("checkpoints", d.path / "checkpoints.csv")
            raise InputError(
                _listed(
                    both,
                    lambda r: f"checkpoint {r['point_id']} ({r['method']}) is also in {where}",
                    "a checkpoint the delivery also has",
                )
            )
    mine = extra[cols].reset_index(drop=True)
    d.checkpoints = mine if d.checkpoints is None else pd.concat([d.checkpoints, mine])
    d.checkpoints = d.checkpoints.reset_index(drop=True)
    counts = extra.groupby("_file").size()
    d.read_warnings = d.read_warnings + [
        w
        for f in counts.index  # a few files
        for w in stored_resolution(Path(f), CHECKPOINTS, extra[extra["_file"] == f])
    ]
    d.process_data.setdefault("notes", {})["inspector_checkpoints"] = {
        str(f): int(n) for f, n in counts.items()
    }
    return d


def check_blocks(cp: InspectorCheckpoints, deliveries: list[Path]) -> None:
    """Rows naming a block that is not inspected would be ignored: refuse them, when every
    block id is known (a delivery whose block.yaml cannot be read may be the block they name:
    it is refused when read, its problems listed); and files without a block_id column when
    several deliveries are inspected, once, before any is read."""
    if not cp.by_block:
        if len(deliveries) > 1:
            raise cp.no_block_column()
        return
    known, unread = set(), False
    for path in deliveries:
        try:
            known.add(load_manifest(path / MANIFEST).block_id)
        except InputError:
            unread = True  # reported in full when the delivery is read
    bad = cp.rows[~cp.rows[BLOCK].isin(known)]
    if not bad.empty and not unread:
        raise InputError(
            _listed(
                bad,
                lambda r: f"no block '{r[BLOCK]}' among the deliveries inspected",
                "no block among the deliveries inspected",
                column=BLOCK,
            )
        )


#: the rows of the inspector's files listed in a refusal (the others are counted)
ROWS_LISTED = 10


def _listed(
    rows: pd.DataFrame, message: Callable[[pd.Series], str], kind: str, column: str | None = None
) -> list[Problem]:
    """One problem per refused row (the first ROWS_LISTED), with its line in a CSV file, and
    the count of the others per file."""
    problems = [
        Problem(
            r["_file"],
            message(r),
            row=int(r["_row"]),
            line=_line(r["_file"], int(r["_row"])),
            column=column,
        )
        for _, r in rows.head(ROWS_LISTED).iterrows()
    ]
    rest = rows.iloc[ROWS_LISTED:].groupby("_file", sort=False).size()
    problems += [
        Problem(str(f), f"{kind}: {n} more rows like this", column=column) for f, n in rest.items()
    ]
    return located(problems)
