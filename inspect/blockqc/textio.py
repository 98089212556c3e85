"""Reading input files as UTF-8: size limits, a byte-order mark, and errors that name the line."""

from __future__ import annotations

import csv
import errno
import io
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from blockqc.errors import BlockqcError, InputError, Problem

BOM = b"\xef\xbb\xbf"
UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")


def _likely_encoding(data: bytes) -> str:
    """A cheap guess at the encoding of bytes that are not UTF-8 (only for the message)."""
    if data.startswith(UTF16_BOMS):
        return "UTF-16"
    high = np.frombuffer(data, dtype=np.uint8) >= 0x80
    paired = high[:-1] & high[1:]  # GBK writes each Chinese character as two high bytes
    if high.any() and 2 * paired.sum() >= 0.8 * high.sum():
        try:
            data.decode("gb18030")
            return "GBK / GB18030"
        except UnicodeDecodeError:
            pass
    return "Latin-1 / Windows-1252"


def _utf16_order(data: bytes) -> str | None:
    """'LE' or 'BE' when the file starts as UTF-16 text without its byte order mark: of its
    first pairs of bytes, nine in ten or more hold a NUL in the same place (an ASCII character)
    and none is NUL twice; else None. A file damaged or padded with zeros is not such."""
    head = np.frombuffer(data, dtype=np.uint8, count=min(len(data), 1024) // 2 * 2)
    if head.size < 8 or data.startswith(UTF16_BOMS):
        return None
    first, second = head[0::2] == 0, head[1::2] == 0
    for order, zeros, other in (("LE", second, first), ("BE", first, second)):
        if zeros.mean() >= 0.9 and not (zeros & other).any():
            return order
    return None


def _not_utf8(encoding: str) -> str:
    """What is said of a file in another encoding than UTF-8."""
    return f"the file must be UTF-8 text (it looks like {encoding}; save it as UTF-8)"


def utf16_problem(path: Path, data: bytes) -> Problem | None:
    """The problem of a file of UTF-16 text without its byte order mark (its NUL bytes are no
    damage, and its bytes no other 8-bit encoding), or None."""
    order = _utf16_order(data)
    if order is None:
        return None
    encoding = f"UTF-16{order} without a byte order mark"
    return Problem(str(path), f"every other byte is NUL (0x00): {_not_utf8(encoding)}", line=1)


def utf8_problem(path: Path, data: bytes, exc: UnicodeDecodeError) -> Problem:
    """The line and column of the first byte that is not UTF-8, and the likely encoding."""
    line = data.count(b"\n", 0, exc.start) + 1
    column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
    return utf16_problem(path, data) or Problem(
        str(path),
        f"byte 0x{data[exc.start]:02x} at character {column} is not UTF-8: "
        + _not_utf8(_likely_encoding(data)),
        line=line,
    )


def listed(folder: str | Path) -> list[os.DirEntry]:
    """A folder's entries, sorted, those named with a leading '.' left out. OSError when it
    cannot be listed, or when its entries cannot be reached (its names readable, but without
    search permission: each file in it would fail when looked at)."""
    with os.scandir(folder) as it:
        entries = sorted((e for e in it if not e.name.startswith(".")), key=lambda e: e.name)
    if entries:
        entries[0].stat(follow_symlinks=False)
    return entries


def unreadable_folder(folder: Path, exc: OSError) -> Problem:
    """A folder of the input that cannot be read (`listed`), in the words said of a file that
    cannot be read (`read_bytes`)."""
    return Problem(
        str(folder), f"cannot be read: {exc.strerror or exc}: expected a readable folder"
    )


def unreadable_path(where: Path, exc: OSError) -> Problem:
    """A file or folder of an input that could not be read, in words rather than Python's: the
    path the system named (else `where`) and why; one no longer there is said to have gone
    since the run began (a delivery moved or removed while a batch ran)."""
    path = exc.filename if exc.filename else where
    why = exc.strerror or str(exc)
    if exc.errno == errno.ENOENT:
        why += ": moved or removed while it was being inspected? (inspect it again)"
    return Problem(str(path), f"cannot be read: {why}")


def dangling_link(path: Path) -> str | None:
    """A link to nothing, said with what it names: to no file or folder, or back to itself
    through other links (a loop); None when the path is no such link."""
    if not path.is_symlink():
        return None
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return f"a symbolic link to {os.readlink(path)}, which leads back to itself (a loop)"
        if exc.errno in (errno.ENOENT, errno.ENOTDIR):
            return f"a symbolic link to {os.readlink(path)}, which does not exist"
    return None


def not_there(path: Path, missing: str) -> str:
    """What to say of an input that is not there: a symbolic link to nothing (or a loop) named
    with where it leads (`dangling_link`), else `missing` ('no such file' …); a link whose
    target was moved is not said to be missing itself."""
    return dangling_link(path) or missing


def real_path(path: Path) -> Path:
    """Where a path leads, its links followed; a loop of links left where it loops, not raised
    as Path.resolve raises it (RuntimeError), so that it is refused by name (`dangling_link`)."""
    return Path(os.path.realpath(path))


def not_a_file(path: Path) -> str | None:
    """What an input named as a file is when it is none (a link to nothing, a folder, a pipe,
    a socket or a device), to be followed by what was expected; None when it is a file or not
    there."""
    if link := dangling_link(path):
        return link
    if path.is_dir():
        return "is a folder, not a file"
    if path.exists() and not path.is_file():
        return "is not a regular file (a pipe, socket or device)"
    return None


def read_bytes(path: Path, max_bytes: int | None, error: type[BlockqcError] = InputError) -> bytes:
    """Read a regular file whole, refusing folders, dangling links and absurd sizes."""
    if link := dangling_link(path):
        raise error(Problem(str(path), f"{link}: expected a file"))
    if path.is_dir():
        raise error(Problem(str(path), "is a folder: expected a file"))
    try:
        size = path.stat().st_size
        if max_bytes is not None and size > max_bytes:
            raise error(
                Problem(
                    str(path),
                    f"is {size / 2**20:.1f} MiB: files of this kind are limited to "
                    f"{_mib(max_bytes)} MiB",
                )
            )
        with path.open("rb") as fh:  # at most the limit from a pipe or a device too
            data = fh.read() if max_bytes is None else fh.read(max_bytes + 1)
        if max_bytes is not None and len(data) > max_bytes:
            message = f"gives more than {_mib(max_bytes)} MiB, the limit for files of this kind"
            raise error(Problem(str(path), message))
        return data
    except FileNotFoundError:
        raise error(Problem(str(path), "file not found")) from None
    except OSError as exc:
        raise error(Problem(str(path), f"cannot be read: {exc.strerror or exc}")) from None


def _mib(n: int) -> str:
    return f"{n / 2**20:g}"


def check_utf8(path: Path, data: bytes, error: type[BlockqcError] = InputError) -> None:
    """Raise `error` naming the line when `data` is not UTF-8 (plain ASCII is checked at once,
    without decoding)."""
    if not data.isascii():
        decode_utf8(path, data, error)


def check_no_nul(path: Path, data: bytes, error: type[BlockqcError] = InputError) -> None:
    """Raise `error` naming the line of the first NUL byte: text tables hold none, and a cell
    holding one would be read as text with it (a file damaged, or padded with zeros)."""
    at = data.find(b"\0")
    if at < 0:
        return
    wide = utf16_problem(path, data)
    if wide is not None:
        raise error(wide)
    line = data.count(b"\n", 0, at) + 1
    column = at - (data.rfind(b"\n", 0, at) + 1) + 1
    more = data.count(b"\0", at + 1)
    also = f" ({more} more in the file)" if more else ""
    raise error(
        Problem(
            str(path),
            f"a NUL byte (0x00) at character {column}{also}: expected text, which holds none "
            "(the file may be damaged or padded with zeros); remove it",
            line=line,
        )
    )


def decode_utf8(path: Path, data: bytes, error: type[BlockqcError] = InputError) -> str:
    """UTF-8 text without its byte-order mark; other encodings are refused with the line."""
    wide = utf16_problem(path, data)
    if wide is not None:  # ASCII characters in UTF-16 decode as UTF-8, each beside a NUL
        raise error(wide)
    try:
        return data.removeprefix(BOM).decode("utf-8")
    except UnicodeDecodeError as exc:
        exc.start += len(BOM) if data.startswith(BOM) else 0
        raise error(utf8_problem(path, data, exc)) from None


def read_text(path: Path, max_bytes: int | None, error: type[BlockqcError] = InputError) -> str:
    """A text file's contents as UTF-8 (BOM dropped; CRLF is left to the parsers)."""
    return decode_utf8(path, read_bytes(path, max_bytes, error), error)


#: separators typed by Chinese input methods: no column name holds one, so that a header
#: holding one in any name (some of its commas typed so) is refused
WIDE_SEPARATORS = {"，": "full-width commas ('，')", "；": "full-width semicolons ('；')"}


def wide_separated(text: str) -> str:
    """What a row of a CSV table whose fields came out too few is separated by, when its text
    holds a full-width separator (typed by a Chinese input method): ' (its values are separated
    by full-width commas ('，'): expected ',')'; else ''."""
    found = [name for sep, name in WIDE_SEPARATORS.items() if sep in text]
    return f" (its values are separated by {found[0]}: expected ',')" if found else ""


#: separators of other CSV dialects (spreadsheets set to some locales export with ';'), spaces
#: last: a header separated by semicolons may hold spaces too
OTHER_SEPARATORS = {
    **WIDE_SEPARATORS,
    ";": "semicolons",
    "\t": "tabs",
    "|": "vertical bars",
    " ": "spaces",
}


def header_problem(path: Path, header: list[str], columns: int = 2) -> Problem | None:
    """What makes a CSV's first record no header, to report once rather than every column
    missing: a line of spaces, a comment line, a spreadsheet's `sep=,` line, or (for a table
    of more than one column) another dialect's separator. None when the header is not such."""
    line = ",".join(header)
    if line and not line.strip():  # an empty line is skipped; one of spaces is a record
        return Problem(
            str(path),
            "a line of spaces only where the header row is expected: remove it so that the "
            "first line names the columns",
            line=1,
        )
    if line.lstrip().startswith("#"):
        shown = line.strip() if len(line.strip()) <= 60 else line.strip()[:59] + "…"
        return Problem(
            str(path),
            f"a comment line ('{shown}') where the header row is expected: contract tables "
            "have no comment lines; remove it so that the first line names the columns",
            line=1,
        )
    if re.fullmatch(r"sep=.?", line.strip(), re.IGNORECASE):  # Excel's dialect line
        return Problem(
            str(path),
            f"a spreadsheet's separator line ('{line.strip()}') where the header row is "
            "expected: contract tables have none; remove it so that the first line names the "
            "columns",
            line=1,
        )
    return separator_problem(path, header) if columns > 1 else None


def separator_problem(path: Path, header: list[str]) -> Problem | None:
    """A CSV header read as one name that holds another dialect's separator, or holding a
    full-width one in any name: the problem to report once, rather than every column missing
    (None when the header is not such)."""
    one = header if len(header) == 1 else []
    found = [
        name
        for sep, name in OTHER_SEPARATORS.items()
        if any(sep in h.strip() for h in (header if sep in WIDE_SEPARATORS else one))
    ]
    if not found:
        return None
    return Problem(
        str(path),
        f"columns separated by {found[0]}, not by commas: blockqc reads CSV tables "
        "comma-separated (RFC 4180); export the table with ',' as the separator",
        line=1,
    )


def located(problems: list[Problem]) -> list[Problem]:
    """The problems of CSV rows, each with the line its row starts on: a row's line is row + 1
    only while no quoted field runs over several lines and no empty line (skipped by the
    readers) lies above it. The file is read again only when one of them is in it."""
    wanted: dict[str, int] = {}
    for p in problems:
        if _by_row(p):
            wanted[p.file] = max(wanted.get(p.file, 0), p.row)
    lines = {f: row_lines(Path(f), last) for f, last in wanted.items()}
    return [
        replace(p, line=lines[p.file].get(p.row, p.line)) if _by_row(p) else p for p in problems
    ]


def _by_row(p: Problem) -> bool:
    """A problem located by a CSV row whose line was counted as row + 1."""
    return p.row is not None and p.line == p.row + 1 and p.file.lower().endswith(".csv")


#: bytes searched for quotes and line ends at once (no mask of the whole file)
PIECE_BYTES = 1 << 26


def _line_end_quoted(data: bytes) -> bool:
    """Whether a line end lies after an odd number of quotes, within a quoted field: then a
    row may span lines (quotes counted in pieces, without parsing the file)."""
    view = np.frombuffer(data, dtype=np.uint8)
    quotes = 0  # quotes before the piece
    for at in range(0, view.size, PIECE_BYTES):
        piece = view[at : at + PIECE_BYTES]
        q = np.flatnonzero(piece == 34)
        if q.size or quotes % 2:
            ends = np.flatnonzero((piece == 10) | (piece == 13))
            if ((np.searchsorted(q, ends) + quotes) % 2).any():
                return True
        quotes += q.size
    return False


def row_lines(path: Path, last: int) -> dict[int, int]:
    """The line each data row (1-based, up to `last`) of a CSV starts on, for the rows not on
    line row + 1; empty when every row is (or the file cannot be read again)."""
    try:
        data = path.read_bytes().removeprefix(BOM)
    except OSError:
        return {}
    empty = (b"\n\n", b"\r\r", b"\r\n\r\n")
    if not any(e in data for e in empty) and data[:1] not in (b"\n", b"\r"):
        if not _line_end_quoted(data):
            return {}
    reader = csv.reader(io.StringIO(data.decode("utf-8", errors="replace"), newline=""))
    out: dict[int, int] = {}
    row, end = -1, 0  # row 0: the header; end: the last line read
    try:
        for record in reader:
            start, end = end + 1, reader.line_num
            if not record:  # an empty line, skipped by the readers
                continue
            row += 1
            if row > last:
                break
            if row and start != row + 1:
                out[row] = start
    except csv.Error:  # a field beyond the csv module's limit: the lines found so far
        pass
    return out
