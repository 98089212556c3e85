"""Writing results: atomically, and never inside a delivery."""

from __future__ import annotations

import datetime as dt
import errno
import math
import os
import shutil
import socket
import tempfile
import traceback
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pydantic_core
from pydantic import BaseModel

from blockqc.errors import InputError, OutputError, Problem, UsageError

_PLAIN = frozenset({str, int, bool, type(None)})


class Rows(list):
    """Table rows made by `records`: plain JSON values already, passed on by `jsonable` as
    they are (a measurement detail may hold thousands)."""


def jsonable(value: Any) -> Any:
    """Plain JSON values: numpy scalars unwrapped, NaN/NaT as null, timestamps as ISO dates.

    The plain Python types are dispatched on their exact type first and numeric arrays are
    converted whole: measurement details hold lists of thousands of small rows."""
    kind = type(value)
    if kind in _PLAIN or kind is Rows:
        return value
    if kind is float:
        return value if math.isfinite(value) else None
    if kind is dict:
        return {str(k): jsonable(v) for k, v in value.items()}
    if kind is list or kind is tuple:
        return [jsonable(v) for v in value]
    if kind is np.ndarray and value.ndim == 1 and value.dtype.kind in "biuf":
        return _numbers(value)
    return _jsonable_other(value)


def _numbers(values: np.ndarray) -> list[Any]:
    """A 1-D numeric array as plain numbers, non-finite floats as None."""
    if values.dtype.kind != "f":
        return values.tolist()
    out = values.astype(object)
    out[~np.isfinite(values)] = None
    return out.tolist()


def _jsonable_other(value: Any) -> Any:
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json", by_alias=True)
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    if isinstance(value, (pd.Timestamp, dt.date)):
        return value.isoformat()[:10] if not pd.isna(value) else None
    if value is None or value is pd.NA or value is pd.NaT:
        return None
    return value


def records(df: pd.DataFrame) -> Rows:
    """A table as JSON rows, the values of `jsonable`, converted column by column."""
    if df.shape[1] == 0:
        return Rows({} for _ in range(len(df)))
    names = [str(c) for c in df.columns]
    columns = [_column_values(col) for _, col in df.items()]
    return Rows(dict(zip(names, row, strict=True)) for row in zip(*columns, strict=True))


def _column_values(col: pd.Series) -> list[Any]:
    """One column as plain values: numbers in one numpy pass (non-finite → None), text in one
    pass when every value is text, anything else value by value."""
    kind = col.dtype.kind if isinstance(col.dtype, np.dtype) else ""
    if kind and kind in "biu":
        return col.to_numpy().tolist()
    if kind == "f":
        return _numbers(col.to_numpy())
    values = col.to_numpy(dtype=object)
    if pd.api.types.infer_dtype(values, skipna=False) == "string":  # str only: as they are
        return values.tolist()
    return [jsonable(v) for v in values]


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` via a temporary file in the same folder and an atomic rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise _named(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise _named(exc, path) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _named(exc: OSError, path: Path) -> OSError:
    """The system's refusal to write a file, named by the path asked for: not by the temporary
    file the system names, nor by none (a full disk)."""
    _, why = refusal(exc)
    if isinstance(exc, IsADirectoryError):
        return IsADirectoryError(errno.EISDIR, why, str(path))
    return OSError(exc.errno, why, str(path))


def refusal(exc: OSError) -> tuple[str, str]:
    """The path the system refused to write (its `filename`), and why, in words: a folder where
    a file goes, or a file where a folder goes, that file named itself (not the path below
    it); else the system's words."""
    path = Path(exc.filename or "")
    if exc.errno == errno.ENOTDIR:
        there = next((p for p in path.parents if p.exists() and not p.is_dir()), path)
        return str(there), "a file is there: expected a folder"
    if exc.errno == errno.EISDIR:
        return str(path), "a folder is there: expected a file"
    return str(path), exc.strerror or str(exc)


def write_text_atomic(path: Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def write_json_atomic(path: Path, obj: Any) -> None:
    """JSON (numpy values, models and dates converted by `jsonable`), atomically. A model is
    written by its own serializer, anything else once made `jsonable`: both in compiled code,
    non-finite numbers as null."""
    if isinstance(obj, BaseModel):
        data = obj.model_dump_json(indent=2, by_alias=True).encode("utf-8")
    else:
        data = pydantic_core.to_json(jsonable(obj), indent=2)  # jsonable: no NaN is left
    write_bytes_atomic(path, data + b"\n")


def check_out_dir(out: Path, inputs: Iterable[Path]) -> Path:
    """The output folder, created; refused when it lies inside (or is) one of the input
    deliveries or batches (`refuse_inside`)."""
    refuse_inside(out, inputs)
    return make_out_dir(out, out.resolve())


def refuse_inside(out: Path, inputs: Iterable[Path]) -> None:
    """Refuse an output folder that lies inside (or is) one of the inputs, or inside any
    delivery (`delivery_holding`: one a batch links in from elsewhere too), before the inputs
    are read (the folder is made once they are, `check_out_dir`)."""
    out_r = out.resolve()
    for p in inputs:
        p_r = Path(p).resolve()
        if out_r == p_r or p_r in out_r.parents:
            raise UsageError(
                f"--out {out} lies inside the input {p}: blockqc never writes into a delivery; "
                "choose an output folder outside it"
            )
    refuse_delivery(out)


def _holding_delivery(path: Path) -> Path | None:
    """The delivery (a folder holding block.yaml) that is or holds `path`, by its real path."""
    from blockqc.delivery import MANIFEST

    real = Path(os.path.realpath(path))
    return next((p for p in (real, *real.parents) if (p / MANIFEST).is_file()), None)


def refuse_delivery(out: Path, option: str = "--out") -> None:
    """Refuse an output folder that is or lies inside a delivery (a folder holding block.yaml),
    by its real path: also one a batch links in from elsewhere."""
    delivery = _holding_delivery(out)
    if delivery is not None:
        raise UsageError(
            f"{option} {out} lies inside the delivery {delivery}: blockqc never writes into a "
            "delivery; choose an output folder outside it"
        )


def refuse_delivered(inputs: Iterable[tuple[str, Path | None]]) -> None:
    """Refuse an inspector's input (option, file) that lies inside a delivery: the verdicts,
    checkpoints and plan are the inspector's, never the producer's."""
    for option, path in inputs:
        delivery = None if path is None else _holding_delivery(path)
        if delivery is not None:
            raise UsageError(
                f"{option} {path} lies inside the delivery {delivery}: the inspector's inputs "
                "never come from a delivery; keep them outside it"
            )


def template_problem(exc: BaseException, context: str = "") -> Problem | None:
    """Where a page's rendering failed, when a template did (a user's of --templates, or a stock
    one): the template's file and line, and why; None when no template is in the cause."""
    import jinja2

    what = f"{type(exc).__name__}: {exc}"
    if isinstance(exc, jinja2.TemplateSyntaxError) and exc.filename:
        return Problem(exc.filename, f"a template of --templates: {what}", line=exc.lineno)
    frames = traceback.extract_tb(exc.__traceback__)
    frame = next((f for f in reversed(frames) if f.filename.endswith(".j2")), None)
    if frame is None:
        return None
    return Problem(frame.filename, f"a template fails{context}: {what}", line=frame.lineno)


def refuse_block_folders(out: Path, block_ids: Iterable[str]) -> None:
    """Refuse an output folder where a block's folder, `<out>/<block_id>`, is a delivery (holds
    block.yaml): the block's outputs would be written into it, and a re-run's clean-up would
    remove files of the same names (checkpoints.csv) from it."""
    for block_id in block_ids:
        delivery = _delivery_at(out / str(block_id))
        if delivery is not None:
            raise UsageError(
                f"--out {out}: the outputs of block {block_id} would go into {delivery}, a "
                "delivery (it holds block.yaml); blockqc never writes into a delivery: choose an "
                "output folder outside the inputs"
            )


def refuse_holding(out: Path, deliveries: Iterable[Path]) -> None:
    """Refuse an output folder that is the folder holding a delivery inspected (its batch, by
    the path given or its real path): the blocks' folders written beside the delivery would be
    read as deliveries without block.yaml when that batch is inspected, whatever block ids
    they have."""
    out_r = Path(os.path.realpath(out))
    for d in deliveries:
        d = Path(d)
        if out_r in (Path(os.path.realpath(d.absolute().parent)), Path(os.path.realpath(d)).parent):
            raise UsageError(
                f"--out {out} is the folder holding the delivery {d}: the outputs of its blocks "
                "would be sub-folders of its batch beside the deliveries; choose an output "
                "folder outside the inputs"
            )


def _delivery_at(folder: Path) -> Path | None:
    """The folder's real path when it is a delivery (holds block.yaml)."""
    from blockqc.delivery import MANIFEST

    with suppress(OSError, ValueError):
        if (folder / MANIFEST).is_file():
            return Path(os.path.realpath(folder))
    return None


def refuse_replacing(out: Path, names: Iterable[str], inputs: Iterable[Path]) -> None:
    """Refuse an output folder where an output file (`names`) would be one of the input files:
    writing it would replace the input."""
    for p in inputs:
        p_r = Path(p).resolve()
        for name in names:
            target = out / name
            if target.resolve() == p_r or (target.exists() and target.samefile(p_r)):
                raise UsageError(
                    f"--out {out}: its {name} would replace the input {p}; choose another "
                    "output folder (or rename the input)"
                )


@contextmanager
def empty_removed(out: Path) -> Iterator[None]:
    """The output folder, absent on entry and made by the run, is removed again when the run
    leaves nothing in it: it stopped (an input error, a scheduler that cannot be reached), or
    wrote nothing (the one delivery named could not be read); a folder that was there before is
    never removed."""
    made = not (out.exists() or out.is_symlink())
    try:
        yield
    finally:
        if made:
            with suppress(OSError):
                out.rmdir()  # only when empty


#: held in an output folder while a run writes into it
LOCK_FILE = ".blockqc-lock"


@contextmanager
def out_lock(out: Path) -> Iterator[None]:
    """One run at a time writes into an output folder: another is refused (exit 2) while this
    one holds `.blockqc-lock`; a lock left by a process of this machine that no longer runs is
    taken over. The lock is written whole before it appears (a temporary file linked into
    place), so that no run reads it half-written."""
    lock = out / LOCK_FILE
    me = f"{socket.gethostname()} {os.getpid()}"
    tmp = out / f"{LOCK_FILE}.{os.getpid()}"
    try:
        try:
            tmp.write_text(me, encoding="utf-8")
        except OSError as exc:  # a full disk, a folder the system refuses writes in
            why = exc.strerror or exc
            raise UsageError(f"--out {out}: this folder cannot be written in: {why}") from None
        try:
            os.link(tmp, lock)  # fails when a lock is there
        except FileExistsError:
            holder = _lock_holder(lock)
            if holder is not None:
                raise UsageError(
                    f"--out {out}: another blockqc run is writing into it (host and process "
                    f"{holder}); wait for it to end or choose another folder (if none runs, "
                    f"delete {lock})"
                ) from None
            os.replace(tmp, lock)  # a stale lock: taken over
    finally:
        tmp.unlink(missing_ok=True)
    try:
        yield
    finally:
        if _read_lock(lock) == me:  # never another run's
            lock.unlink(missing_ok=True)


def _read_lock(lock: Path) -> str | None:
    try:
        return lock.read_text(encoding="utf-8")
    except OSError:
        return None


def _lock_holder(lock: Path) -> str | None:
    """Who holds the lock ("host pid"); None when it is stale (its process, of this machine,
    has ended, or is this one: a lock left by an earlier process of the same number, as in a
    container restarted) or unreadable."""
    try:
        host, pid = (_read_lock(lock) or "").split()
        number = int(pid)
    except ValueError:
        return None
    if host == socket.gethostname() and (number == os.getpid() or not _runs(number)):
        return None
    return f"{host} {pid}"


def _runs(pid: int) -> bool:
    """Whether a process of this machine runs (no signal is sent)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's
    return True


def make_out_dir(out: Path, out_r: Path) -> Path:
    """The output folder, created when absent; a file in its place, or one it cannot be
    created or written in, is refused (exit 2) before anything is inspected."""
    blocker = next((p for p in (out_r, *out_r.parents) if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        where = "is a file" if blocker == out_r else f"lies under the file {blocker}"
        raise UsageError(f"--out {out} {where}: give a folder")
    try:
        out_r.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out {out} cannot be created: {exc.strerror or exc}") from None
    if not os.access(out_r, os.W_OK | os.X_OK):
        raise UsageError(f"--out {out}: this folder cannot be written in")
    return out_r


#: block ids are also folder names of the outputs (contract v1.1)
BLOCK_ID_MAX = 100
#: files written into a block's folder of the outputs
BLOCK_OUTPUTS = ("results.json", "report.html", "report.pdf", "checkpoints.csv", "evidence.csv")
#: files a batch writes beside the block folders: no block id may take their names
BATCH_OUTPUTS = (
    "summary.json",
    "summary.html",
    "summary.pdf",
    "summary.csv",
    "summary.parquet",
    "acceptance.html",
    "acceptance.pdf",
)

#: names Windows keeps for devices, with or without an extension (CON, nul.txt, COM1)
WINDOWS_RESERVED = frozenset(
    ["CON", "PRN", "AUX", "NUL"] + [f"{d}{i}" for d in ("COM", "LPT") for i in "123456789¹²³"]
)

#: hidden folders of the outputs: a block's outputs written before they are put in place, and
#: the earlier run's batch outputs set aside while a batch run rewrites its blocks
STAGING_DIR = ".blockqc-staging"
PREVIOUS_SUMMARY_DIR = ".blockqc-previous-summary"


def _own_folder(path: Path) -> Path:
    """`path`, a folder blockqc keeps (made when missing); a file in its place is named."""
    if path.exists() and not path.is_dir():
        raise UsageError(
            f"{path}: a file where blockqc keeps a folder of its own: move the file away"
        )
    path.mkdir(parents=True, exist_ok=True)
    return path


def staged_folder(out: Path, name: str) -> Path:
    """A new empty folder under `out`/.blockqc-staging to write `name`'s outputs into."""
    return Path(tempfile.mkdtemp(prefix=f"{name}.", dir=_own_folder(out / STAGING_DIR)))


def publish(staged: Path, folder: Path, ours: Iterable[str], last: str) -> None:
    """Move the outputs written in `staged` into `folder`: `last` (results.json) removed first
    and moved in last, the others put in between, and those of `ours` this run did not write
    (an earlier PDF) removed. Whenever it stops, the folder holds no `last` or this run's
    outputs whole; the folder itself, and what else it holds, are left as they are."""
    folder.mkdir(exist_ok=True)
    (folder / last).unlink(missing_ok=True)
    for name in ours:
        if name == last:
            continue
        if (staged / name).exists():
            os.replace(staged / name, folder / name)
        else:
            (folder / name).unlink(missing_ok=True)
    os.replace(staged / last, folder / last)


def clear_staging(out: Path) -> None:
    """Remove what a run stopped half-way left staged (only blockqc's own outputs are there)."""
    if (out / STAGING_DIR).is_dir():
        shutil.rmtree(out / STAGING_DIR, ignore_errors=True)


def set_aside_summary(out: Path) -> None:
    """Move the earlier run's batch outputs into `out`/.blockqc-previous-summary while this run
    rewrites the blocks: a run that stops half-way leaves no summary that looks complete over
    blocks it does not describe (nor destroys it). Without batch outputs in `out`, what an
    earlier stopped run set aside stays there."""
    present = [n for n in BATCH_OUTPUTS if (out / n).is_file()]
    if not present:
        return
    aside = _own_folder(out / PREVIOUS_SUMMARY_DIR)
    for old in aside.iterdir():  # what an earlier stopped run set aside: older than these
        shutil.rmtree(old) if old.is_dir() else old.unlink()
    for name in present:
        os.replace(out / name, aside / name)


def restore_summary(out: Path) -> None:
    """Put the batch outputs set aside back (an incremental run found them unchanged)."""
    aside = out / PREVIOUS_SUMMARY_DIR
    for p in aside.iterdir():
        os.replace(p, out / p.name)
    aside.rmdir()


def drop_set_aside(out: Path) -> None:
    """Remove the batch outputs set aside, once this run's are written."""
    shutil.rmtree(out / PREVIOUS_SUMMARY_DIR, ignore_errors=True)


def block_id_problem(value: str) -> str | None:
    """Why a block id cannot be a folder name of the outputs (contract v1.1), or None."""
    if not value:
        return "the block id is empty"
    if len(value) > BLOCK_ID_MAX:
        return f"the block id has {len(value)} characters: at most {BLOCK_ID_MAX} are allowed"
    bad = sorted({c for c in value if not (c.isalnum() or c in "-_.") or not c.isprintable()})
    if bad:
        shown = ", ".join(repr(c) for c in bad[:5])
        return (
            f"the block id {value[:40]!r} holds {shown}: only letters, digits, '-', '_' and "
            "'.' are allowed (it names the output folder)"
        )
    if value.startswith("."):
        return f"the block id {value[:40]!r} starts with '.': it names the output folder"
    if value.lower() in BATCH_OUTPUTS:
        return f"the block id {value!r} is the name of a batch output file"
    if value.endswith("."):
        return f"the block id {value!r} ends with '.', which Windows drops from a folder's name"
    if value.split(".")[0].upper() in WINDOWS_RESERVED:
        return f"the block id {value!r} is a device name on Windows, no folder can take it"
    return None


#: the longest name of one output file or folder, in bytes (common file systems allow 255)
NAME_MAX_BYTES = 255


def safe_child(out_dir: Path, name: str, *, source: str | Path | None = None) -> Path:
    """`out_dir / name` for a name from an input (a block id): one plain path component that
    stays under `out_dir` once resolved, else an InputError naming `source`."""
    text = str(name)
    why = None
    if not text or text in (".", "..") or text.startswith("."):
        why = "is empty or starts with '.'"
    elif "/" in text or "\\" in text or "\0" in text or not text.isprintable():
        why = "holds a path separator or a control character"
    elif len(text.encode("utf-8")) > NAME_MAX_BYTES:
        why = f"is longer than {NAME_MAX_BYTES} bytes"
    else:
        child = out_dir / text
        root = out_dir.resolve()
        where = None  # the output folder's own problem, no fault of the input
        if child.resolve().parent != root:
            where = f"{child} leads outside the output folder (a link to {child.resolve()})"
        elif (delivery := _delivery_at(child)) is not None:
            where = f"{child} is the delivery {delivery} (it holds block.yaml), never written into"
        if where:
            raise OutputError(Problem(str(child), f"{where}: the outputs of {text!r} are refused"))
    if why:
        raise InputError(
            Problem(
                str(source or ""),
                f"the output name {text[:60]!r} {why}: refused (outputs stay under {out_dir})",
            )
        )
    return out_dir / text
