"""A delivery's tie points read while the command's modules import.

`blockqc inspect` of one delivery spends its first 0.4 s importing pandas, pydantic and its own
modules, on one core, while the other is idle. When the delivery gives its tie points as Parquet,
the columns that every tie-point metric reads (COLUMNS) are read meanwhile by a thread of their
own (`start`); the delivery's reader takes those it would have read the same way (`take`) and
reads any others itself. A read that fails, or a file changed since, is left to the reader: it
reads the file again and reports what it finds. Nothing is kept once taken; a read not taken
(the pack reads no tie points) is let go with the process.
"""

from __future__ import annotations

import threading
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

#: the tie-point columns read ahead: those the error and distribution metrics read
#: (metrics.tiepoints.ERROR_COLUMNS, which imports pandas: named again here, a test keeps them
#: equal)
COLUMNS = ("scene_id", "line", "sample", "v_line", "v_sample")
#: read ahead as Arrow dictionaries (text referring to scenes.csv, as the reader reads them)
DICTIONARY = ("scene_id",)
FILE = "tie_points.parquet"  # the Parquet form of the contract's tie_points table


@dataclass
class _Ahead:
    stamp: tuple[int, int]  # the file's size and modification time when the read began
    thread: threading.Thread | None = None
    table: pa.Table | None = None  # set by the thread once read


_ahead: dict[Path, _Ahead] = {}


def _stamp(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_size, st.st_mtime_ns


def start(delivery: Path) -> None:
    """Begin reading the tie points of `delivery` ahead, if it gives them as Parquet."""
    path = delivery / FILE
    try:
        if not path.is_file():
            return
        key, ahead = path.resolve(), _Ahead(_stamp(path))
    except (OSError, RuntimeError):  # the reader says what is wrong with the path
        return
    ahead.thread = threading.Thread(target=_read, args=(path, ahead), daemon=True)
    _ahead[key] = ahead
    ahead.thread.start()


def _read(path: Path, ahead: _Ahead) -> None:
    try:
        parquet = pq.ParquetFile(path, read_dictionary=DICTIONARY, pre_buffer=False)
        names = parquet.schema_arrow.names
        wanted = [n for n in COLUMNS if names.count(n) == 1]
        ahead.table = parquet.read(columns=wanted, use_threads=False)
    except Exception:  # whatever it is, the reader meets it again and says so
        return


def take(path: Path, names: Collection[str], dictionary: Collection[str]) -> pa.Table | None:
    """The columns `names` of the table file `path` read ahead, each as the reader reads it (a
    dictionary for the columns named in `dictionary`, plain otherwise), None where none was; the
    read ahead is let go whatever is taken."""
    try:
        ahead = _ahead.pop(path.resolve(), None)
    except (OSError, RuntimeError):
        return None
    if ahead is None:
        return None
    assert ahead.thread is not None
    ahead.thread.join()
    table, ahead.table = ahead.table, None
    try:
        if table is None or _stamp(path) != ahead.stamp:
            return None
    except OSError:
        return None
    same = [
        f.name
        for f in table.schema
        if f.name in names and pa.types.is_dictionary(f.type) == (f.name in dictionary)
    ]
    return table.select(same) if same else None
