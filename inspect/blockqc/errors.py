"""One small hierarchy of user-facing errors: each names the file and the row, line or column."""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass
from pathlib import Path

#: the marks that reorder the text after them (embeddings, overrides, isolates)
_BIDI = frozenset("\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def shown(text: str) -> str:
    """`text` from an input as a console line shows it: control characters (an escape sequence
    in an id or a folder's name, which a terminal would obey) and the marks that reorder the
    line written as escapes (`\\x1b`, `\\u202e`)."""
    return "".join(
        (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")
        if c in _BIDI or unicodedata.category(c) == "Cc"
        else c
        for c in text
    )


@dataclass(frozen=True)
class Problem:
    """One problem found in an input: where it is and what was expected."""

    file: str
    message: str
    row: int | None = None  # 1-based data row (CSV: the header is line 1, data row 1 is line 2)
    line: int | None = None  # 1-based line in a text file (YAML, CSV)
    column: str | None = None

    @classmethod
    def at_row(cls, file: Path | str, i: int, message: str, column: str | None = None) -> Problem:
        """The problem of a table's row at position i (0-based), with its line in a CSV file
        (the header on line 1)."""
        line = int(i) + 2 if str(file).lower().endswith(".csv") else None
        return cls(str(file), message, row=int(i) + 1, line=line, column=column)

    def __str__(self) -> str:
        where = [self.file] if self.file else []
        if self.row is not None and self.line is not None:
            where.append(f"row {self.row} (line {self.line})")
        elif self.row is not None:
            where.append(f"row {self.row}")
        elif self.line is not None:
            where.append(f"line {self.line}")
        if self.column is not None:
            where.append(f"column '{self.column}'")
        text = f"{', '.join(where)}: {self.message}" if where else self.message
        return shown(text)  # printed on the console, listed in the summary


class BlockqcError(Exception):
    """Base of every error blockqc reports to a user as a message (exit status 2)."""

    exit_code = 2

    def __init__(self, problems: list[Problem] | Problem | str, file: str | Path | None = None):
        if isinstance(problems, str):
            problems = [Problem(str(file) if file else "", problems)]
        elif isinstance(problems, Problem):
            problems = [problems]
        self.problems: list[Problem] = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class InputError(BlockqcError):
    """A delivery, an inspector's file or another input could not be read as its contract says."""


class OutputError(BlockqcError):
    """The outputs could not be written (a folder that refuses them, a template of --templates
    that fails): the run stops, and no delivery is blamed for it."""


class RuleError(BlockqcError):
    """A rule pack could not be read, validated or evaluated."""


class UsageError(BlockqcError):
    """The command line asks for something that cannot be done (e.g. writing into a delivery)."""
