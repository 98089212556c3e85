"""Incremental inspection: a block's outputs are reused while nothing that made them changed.

The key of a block is a SHA-256 over its delivery's path (as given, which its outputs record,
and where it leads) and files (relative path, size, modification time and change time of each — the
quick check of make and rsync, and the inode's change time, which no program sets back: a file
rewritten gets a new one even when its size and modification time are kept), the inspector
(name, verdicts and waivers for the block), the resolved rule pack (its rules, constants, files
and the columns it reads), the output options, and blockqc itself (its version, and the size and
time of each of its modules, its report font and templates, so that a changed blockqc recomputes
too). It is kept beside the block's outputs in `.blockqc-cache.json` with the block's line of the
summary and the size of each output, so that a re-run reads nothing else of an unchanged block,
and a missing or cut output is written again; a digest of it all seals the file, so that one
edited by hand is not trusted (the block is inspected again, and the run says so: `Untrusted`).
The versions of the libraries that make the numbers and the pages count too (`DEPENDENCIES`),
and so does the Chromium that writes the PDFs (BLOCKQC_CHROMIUM's, or the one on the PATH) and
whether it tags them (BLOCKQC_PDF_TAGGED).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import pydantic_core
import yaml
from pydantic import BaseModel, StrictInt, StrictStr, TypeAdapter, ValidationError

from blockqc import __version__
from blockqc.outputs import BATCH_OUTPUTS, BLOCK_OUTPUTS, jsonable, write_json_atomic
from blockqc.results import BlockEntry

CACHE_FILE = ".blockqc-cache.json"
#: beside the batch summary: the key of the blocks' lines it was written from
SUMMARY_CACHE_FILE = ".blockqc-summary-cache.json"
#: the summary outputs always written (its PDFs and acceptance pages are listed in the cache)
SUMMARY_OUTPUTS = tuple(n for n in BATCH_OUTPUTS if n.startswith("summary.") and n != "summary.pdf")
#: outputs that must still be there, at the size written, for a block's outputs to be reused
#: (its PDF too when it has one)
OUTPUTS = tuple(n for n in BLOCK_OUTPUTS if n != "report.pdf")
#: a block's results per rule and status, and its rules in error ("RULE: why") or warnings, as
#: cached
_RULES = TypeAdapter(dict[str, dict[str, StrictInt]])
_ERRORS = TypeAdapter(list[StrictStr])


#: the distributions whose versions make a block's numbers or pages (blockqc's own dependencies,
#: and Pillow, which measures the figures' text and encodes their raster layers: `report.svg`)
DEPENDENCIES = (
    "numpy",
    "scipy",
    "pandas",
    "pyarrow",
    "pydantic",
    "pyyaml",
    "jinja2",
    "rasterio",
    "opencv-python-headless",
    "matplotlib",
    "shapely",
    "pyproj",
    "weasyprint",
    "pillow",
)


class Untrusted(Exception):
    """A block's cache that is there but cannot vouch for its outputs: broken, edited by hand, or
    an output gone or cut since it was written (the block is inspected again)."""


@dataclass
class Cached:
    key: str
    entry: BlockEntry
    rules: dict[str, dict[str, int]]
    grade: Any = None  # the block's §QE grade (BlockGrade), when the pack has acceptance
    sizes: dict[str, int] | None = None  # of the outputs, as written
    errors: list[str] | None = None  # the block's rules in error, "RULE: why"
    warnings: list[str] | None = None  # what its delivery gives that is said (`delivery_warnings`)


def _sha(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(json.dumps(part, sort_keys=True, default=str).encode("utf-8"))
        h.update(b"\0")
    return h.hexdigest()


def _tree(folder: Path) -> list[tuple[str, int, int, int]]:
    """(relative path, size, mtime and ctime in ns) of every file and folder under `folder`, in
    path order: a folder's name counts (size -2), since the reader reads an empty one too (a
    misnamed `RPC/` is refused); linked folders are followed, each real folder once. The ctime
    (the inode's last change, which no program sets back) tells a file rewritten whose size and
    mtime were kept or set back (`cp -p`, `rsync -a`, `touch -r` of an older copy)."""
    out, seen = [], set()
    for root, dirs, files in os.walk(folder, followlinks=True):
        try:
            st = os.stat(root)
        except OSError:
            continue
        if (st.st_dev, st.st_ino) in seen:  # a link back to a folder already walked
            dirs.clear()
            continue
        seen.add((st.st_dev, st.st_ino))
        dirs.sort()
        here = Path(root).relative_to(folder)
        out += [(f"{here / name}{os.sep}", -2, 0, 0) for name in dirs]
        for name in sorted(files):
            p = Path(root) / name
            try:
                st = p.stat()
            except OSError:
                out.append((str(p.relative_to(folder)), -1, -1, -1))  # dangling: changes the key
                continue
            out.append((str(p.relative_to(folder)), st.st_size, st.st_mtime_ns, st.st_ctime_ns))
    return out


def run_digest(pack: Any, writer: Any, extra: Any = None, inspector: str | None = None) -> str:
    """What every block of a run shares: the resolved pack, output options, the inspector's name,
    the report particulars, blockqc (each block's rows of the inspector's checkpoint files, and
    whether the sampling plan samples it, are in its own key: `delivery_fingerprint`)."""
    meta = getattr(extra, "meta", None)
    acceptance = getattr(pack, "acceptance", None)
    rules = [r.model_dump(mode="json") for r in pack.rules]
    elements = [e.model_dump(mode="json") for e in pack.elements]
    templates = _tree(writer.templates) if writer.templates else None
    return _sha(
        _blockqc(),
        (pack.name, pack.version, pack.chain, pack.columns, pack.disabled),
        pack.constants,
        rules,
        elements,
        writer.lang,
        writer.pdf,
        writer.pdf_engine if writer.pdf != "none" else None,  # no PDF: no engine used
        _chromium(writer),
        str(writer.templates),
        templates,
        inspector,
        None if meta is None else meta.model_dump(mode="json"),
        None if acceptance is None else acceptance.model_dump(mode="json"),
    )


def _blockqc() -> tuple[str, list, list, dict[str, str | None]]:
    """blockqc's version, the size and time of its modules, its report font (in the PDFs and
    the figures) and stock templates, and the versions of the libraries it computes and renders
    with."""
    from blockqc.resources import templates_dir

    package = Path(__file__).resolve().parent
    modules = [f for f in _tree(package) if f[0].endswith((".py", ".otf"))]
    return __version__, modules, _tree(templates_dir()), _versions(DEPENDENCIES)


def _versions(names: tuple[str, ...]) -> dict[str, str | None]:
    """Each installed distribution's version; None for one not installed."""
    found: dict[str, str | None] = {}
    for name in names:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = None
    return found


def _chromium(writer: Any) -> tuple[str, int, int, bool] | None:
    """The Chromium that writes the PDFs (path, size, time) and whether it tags them
    (BLOCKQC_PDF_TAGGED=1: another PDF, twice the size): the program `find_chromium` takes,
    named by BLOCKQC_CHROMIUM or found on the PATH; None when it writes none."""
    from blockqc.report.chromium import TAGGED, ChromiumProblem, find_chromium

    if writer.pdf == "none" or writer.pdf_engine != "chromium":
        return None
    try:
        program = find_chromium()
        st = Path(program).stat()
    except (ChromiumProblem, OSError):
        return None  # no Chromium: the run stops before any block (check_pdf_engine)
    return (program, st.st_size, st.st_mtime_ns, os.environ.get(TAGGED) == "1")


def delivery_fingerprint(
    path: Path,
    digest: str,
    block_input: BaseModel | None,
    checkpoints: Any = None,
    sampled: bool | None = None,
    manifest: BaseModel | None = None,
) -> str:
    """The key of one block: its delivery's path (as given, which its results.json and line of
    the summary record, and where it leads), files, verdicts, its rows of the inspector's
    checkpoint files (a DataFrame, their file named in each), whether the plan samples it (None
    without a plan), its block.yaml as read (a batch reads them all before the first block: one
    edited meanwhile is in its files, not in its results; written back as YAML, which writes
    whatever YAML read: bytes of `!!binary`, a `!!set` in order) and the run's digest."""
    verdicts = block_input.model_dump(mode="json") if block_input is not None else None
    where = (str(path), str(Path(path).resolve()))
    rows = None  # none given for it: the delivery's own checkpoints, as without the files
    if checkpoints is not None and not checkpoints.empty:
        rows = checkpoints.drop(columns="_row").to_csv(index=False)
    read = None if manifest is None else yaml.safe_dump(manifest.model_dump(), sort_keys=True)
    return _sha(digest, where, _tree(Path(path)), verdicts, rows, sampled, read)


def read_cached(folder: Path, key: str) -> Cached | None:
    """The block's cached line when its key matches, its seal holds and its outputs are all
    still there, at the size they were written; None when there is no cache or the block
    changed; `Untrusted` (why) when the cache is broken or edited, or an output gone or cut."""
    path = folder / CACHE_FILE
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise Untrusted(f"{path}: not readable ({exc})") from None
    try:
        if not isinstance(doc, dict) or doc.pop("seal", None) != _sha(doc):
            raise Untrusted(f"{path}: edited since it was written (its seal does not hold)")
        if doc["key"] != key:
            return None  # something that made the block changed: the usual case, said by no one
        cached = _cached(doc, key)
    except (KeyError, TypeError, AttributeError, ValidationError) as exc:
        raise Untrusted(f"{path}: not a cache of this blockqc ({type(exc).__name__})") from None
    names = [*OUTPUTS, "report.pdf"] if cached.entry.pdf else list(OUTPUTS)
    try:
        now = _sizes(folder, names)
    except OSError as exc:
        raise Untrusted(f"{folder}: an output is gone since it was written ({exc})") from None
    changed = [n for n in names if now[n] != cached.sizes.get(n)]
    if changed:
        raise Untrusted(f"{folder}: changed since written: {', '.join(changed)}")
    return cached


def _cached(doc: dict[str, Any], key: str) -> Cached:
    """The cached line of a sealed cache document."""
    from blockqc.acceptance.model import BlockGrade

    entry = BlockEntry.model_validate(doc["entry"])
    grade = BlockGrade.model_validate(doc["grade"]) if doc["grade"] else None
    rules, errors = _RULES.validate_python(doc["rules"]), _ERRORS.validate_python(doc["errors"])
    warnings = _ERRORS.validate_python(doc["warnings"])
    return Cached(key, entry, rules, grade, dict(doc["sizes"]), errors, warnings)


def _sizes(folder: Path, names: list[str]) -> dict[str, int]:
    """The size of each output (OSError when one is missing)."""
    return {name: (folder / name).stat().st_size for name in names}


def write_cached(folder: Path, cached: Cached) -> None:
    """The block's key and line, and the size of each of its outputs as now written, sealed
    with a digest of them all (`read_cached`)."""
    names = [*OUTPUTS, "report.pdf"] if cached.entry.pdf else list(OUTPUTS)
    doc = {
        "key": cached.key,
        "entry": cached.entry,
        "rules": cached.rules,
        "grade": cached.grade,
        "sizes": _sizes(folder, names),
        "errors": cached.errors or [],
        "warnings": cached.warnings or [],
    }
    plain = json.loads(pydantic_core.to_json(jsonable(doc)))  # as it will be read back
    write_json_atomic(folder / CACHE_FILE, {**plain, "seal": _sha(plain)})


def forget_block(folder: Path) -> None:
    """Drop a block's key before its outputs are rewritten: a run stopped half-way must not
    leave a key that vouches for outputs it did not finish."""
    (folder / CACHE_FILE).unlink(missing_ok=True)


def summary_key(digest: str, block_keys: list[str | None], summary: Any) -> str | None:
    """The key of a batch summary: the run's digest, the inspector, the key of every block in
    order, the sampling plan and the batch decision (which also says where the plan differs
    from the batch: its folder's name, its units, that no block's key holds); None when some
    block has none (inspected without a key, or unreadable)."""
    if any(k is None for k in block_keys):
        return None
    decision = summary.acceptance.model_dump(mode="json") if summary.acceptance else None
    return _sha(digest, summary.inspector, block_keys, summary.sampling, decision)


def summary_unchanged(out: Path, key: str | None, held: Path | None = None) -> bool:
    """Whether the summary outputs of `out` (held in `held`, where they were set aside while
    the blocks were written) were written from the same blocks' lines and are all still there,
    at the size they were written: an unchanged batch then rewrites nothing."""
    if key is None:
        return False
    held = out if held is None else held
    try:
        doc = json.loads((out / SUMMARY_CACHE_FILE).read_text(encoding="utf-8"))
        sizes = {str(name): size for name, size in doc["sizes"].items()}
        names = set(SUMMARY_OUTPUTS) | set(sizes)
        return doc["key"] == key and _sizes(held, sorted(names)) == sizes
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False  # none, or a broken one, or an output gone: write the summary again


def forget_summary(out: Path) -> None:
    """Drop the summary's key before its outputs are rewritten (a run stopped half-way must not
    leave a key that vouches for them)."""
    (out / SUMMARY_CACHE_FILE).unlink(missing_ok=True)


def remember_summary(out: Path, key: str | None, written: list[Path]) -> None:
    """The summary's key and the size of each file written from it (PDFs, acceptance pages)."""
    if key is not None:
        sizes = _sizes(out, sorted(p.name for p in written))
        write_json_atomic(out / SUMMARY_CACHE_FILE, {"key": key, "sizes": sizes})
