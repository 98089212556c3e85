"""Incremental inspection: a block's outputs are reused while nothing that made them changed.

The key of a block is a SHA-256 over its delivery's files (relative path, size and modification
time of each — the quick check of make and rsync: a file rewritten with new content gets a new
time), the inspector's verdicts and waivers for the block, the resolved rule pack, the output
options and blockqc's version. It is kept beside the block's outputs in `.blockqc-cache.json`
with the block's line of the summary, so that a re-run reads nothing else of an unchanged block.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from blockqc import __version__
from blockqc.outputs import write_json_atomic
from blockqc.results import BlockEntry

CACHE_FILE = ".blockqc-cache.json"
#: beside the batch summary: the key of the blocks' lines it was written from
SUMMARY_CACHE_FILE = ".blockqc-summary-cache.json"
SUMMARY_OUTPUTS = ("summary.json", "summary.html", "summary.csv", "summary.parquet")
#: outputs that must still be there for a block's outputs to be reused
OUTPUTS = ("results.json", "report.html")


@dataclass
class Cached:
    key: str
    entry: BlockEntry
    rules: dict[str, dict[str, int]]
    grade: Any = None  # the block's §QE grade (BlockGrade), when the pack has acceptance


def _sha(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(json.dumps(part, sort_keys=True, default=str).encode("utf-8"))
        h.update(b"\0")
    return h.hexdigest()


def _tree(folder: Path) -> list[tuple[str, int, int]]:
    """(relative path, size, mtime in ns) of every file under `folder`, in path order."""
    out = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in sorted(files):
            p = Path(root) / name
            try:
                st = p.stat()
            except OSError:
                out.append((str(p.relative_to(folder)), -1, -1))  # dangling: changes the key
                continue
            out.append((str(p.relative_to(folder)), st.st_size, st.st_mtime_ns))
    return out


def run_digest(pack: Any, writer: Any, extra: Any = None) -> str:
    """What every block of a run shares: the resolved pack, output options, the inspector's
    checkpoint files (their rows), the sampling plan and report particulars, blockqc's version."""
    checkpoints = getattr(extra, "checkpoints", None)
    plan, meta = getattr(extra, "plan", None), getattr(extra, "meta", None)
    acceptance = getattr(pack, "acceptance", None)
    rules = [r.model_dump(mode="json") for r in pack.rules]
    elements = [e.model_dump(mode="json") for e in pack.elements]
    templates = _tree(writer.templates) if writer.templates else None
    return _sha(
        __version__,
        pack.name,
        pack.version,
        pack.constants,
        rules,
        elements,
        writer.lang,
        writer.pdf,
        writer.pdf_engine,
        str(writer.templates),
        templates,
        None if checkpoints is None else checkpoints.rows.to_csv(index=False),
        None if plan is None else plan.model_dump(mode="json"),
        None if meta is None else meta.model_dump(mode="json"),
        None if acceptance is None else acceptance.model_dump(mode="json"),
    )


def delivery_fingerprint(path: Path, digest: str, block_input: BaseModel | None) -> str:
    """The key of one block: its delivery's files, its verdicts and the run's digest."""
    verdicts = block_input.model_dump(mode="json") if block_input is not None else None
    return _sha(digest, str(Path(path).resolve()), _tree(Path(path)), verdicts)


def read_cached(folder: Path, key: str) -> Cached | None:
    """The block's cached line when its key matches and its outputs are all still there."""
    try:
        doc = json.loads((folder / CACHE_FILE).read_text(encoding="utf-8"))
        if doc.get("key") != key or not all((folder / f).is_file() for f in OUTPUTS):
            return None
        entry = BlockEntry.model_validate(doc["entry"])
        if entry.pdf and not (folder / "report.pdf").is_file():
            return None
        from blockqc.acceptance.model import BlockGrade

        grade = BlockGrade.model_validate(doc["grade"]) if doc.get("grade") else None
        return Cached(key, entry, doc["rules"], grade)
    except (OSError, ValueError, KeyError, TypeError, AttributeError, ValidationError):
        return None  # no cache, or a broken one: inspect again


def write_cached(folder: Path, cached: Cached) -> None:
    doc = {"key": cached.key, "entry": cached.entry, "rules": cached.rules, "grade": cached.grade}
    write_json_atomic(folder / CACHE_FILE, doc)


def summary_key(digest: str, block_keys: list[str | None], inspector: str | None) -> str | None:
    """The key of a batch summary: the run's digest, the inspector and the key of every block
    in order; None when some block has none (inspected without a key, or unreadable)."""
    if any(k is None for k in block_keys):
        return None
    return _sha(digest, inspector, block_keys)


def summary_unchanged(out: Path, key: str | None) -> bool:
    """Whether the summary outputs in `out` were written from the same blocks' lines and are
    all still there: an unchanged batch then rewrites nothing."""
    if key is None:
        return False
    try:
        doc = json.loads((out / SUMMARY_CACHE_FILE).read_text(encoding="utf-8"))
        files = [str(f) for f in doc["files"]]
        return doc["key"] == key and all((out / f).is_file() for f in [*SUMMARY_OUTPUTS, *files])
    except (OSError, ValueError, KeyError, TypeError):
        return False  # none, or a broken one: write the summary again


def forget_summary(out: Path) -> None:
    """Drop the summary's key before its outputs are rewritten (a run stopped half-way must not
    leave a key that vouches for them)."""
    (out / SUMMARY_CACHE_FILE).unlink(missing_ok=True)


def remember_summary(out: Path, key: str | None, written: list[Path]) -> None:
    """The summary's key and the files written from it (PDFs, the acceptance pages)."""
    if key is not None:
        files = sorted(p.name for p in written)
        write_json_atomic(out / SUMMARY_CACHE_FILE, {"key": key, "files": files})
