"""Documents and reports: present, inside the delivery and readable (§DOC-1)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from blockqc.delivery import Delivery, document_path, other_case
from blockqc.metrics import Measure, Measurement, Scope, Table, metric

REQUIRED = [
    "technical_design",
    "inspection_report",
    "technical_summary",
    "relative_orientation_report",
    "absolute_orientation_report",
]

# the first bytes a readable file of each kind starts with
_MAGIC = {
    ".pdf": b"%PDF-",
    ".docx": b"PK",
    ".xlsx": b"PK",
    ".odt": b"PK",
    ".zip": b"PK",
    ".doc": b"\xd0\xcf\x11\xe0",
    ".xls": b"\xd0\xcf\x11\xe0",
}


class DocumentParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    required: list[str] = Field(default_factory=lambda: list(REQUIRED))


def check_document(root: Path, rel: str | None) -> tuple[bool, bool, int, str]:
    """(present, readable, size, problem) of one declared document path inside the delivery."""
    if not rel:
        return False, False, 0, "not declared in block.yaml documents"
    try:
        path = document_path(root, rel).resolve()
    except (OSError, RuntimeError):  # Python 3.11 raises RuntimeError on a loop of links
        return False, False, 0, f"{rel}: a symbolic link that leads back to itself"
    if root.resolve() not in path.parents:
        return False, False, 0, f"{rel} points outside the delivery"
    if path.is_dir():
        return False, False, 0, f"{rel} is a folder, not a document file"
    if document_path(root, rel).is_symlink() and not path.exists():
        return False, False, 0, f"{rel} is a symbolic link to a file that does not exist"
    if path.exists() and not path.is_file():
        return False, False, 0, f"{rel} is not a regular file (a pipe, socket or device)"
    if not path.is_file():
        return False, False, 0, f"{rel} does not exist{other_case(root, rel)}"
    size = path.stat().st_size
    if size == 0:
        return True, False, 0, f"{rel} is empty"
    try:
        with path.open("rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        return True, False, size, f"{rel} cannot be read: {exc.strerror}"
    magic = _MAGIC.get(path.suffix.lower())
    if magic and not head.startswith(magic):
        return True, False, size, f"{rel} is not a valid {path.suffix.lower()[1:].upper()} file"
    if path.suffix.lower() in {".txt", ".md"}:
        try:
            path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            return True, False, size, f"{rel} is not UTF-8 text"
    return True, True, size, ""


@metric(
    "documents",
    tie_points=(),
    params=DocumentParams,
    scopes={
        "document": Scope(
            {"ok": "true/false", "present": "true/false", "readable": "true/false"},
            keys=("kind",),
            columns=("path", "required", "size_bytes", "problem"),
        ),
        "block": Scope({"n_missing": "documents"}),
    },
)
def documents(d: Delivery, p: DocumentParams, measure: Measure) -> Measurement:
    """Every document required or declared in block.yaml: in the delivery, readable (§DOC-1).

    A declared document that is missing is the producer's manifest wrong, whatever its kind."""
    declared = d.manifest.documents
    kinds = list(dict.fromkeys(p.required + list(declared)))
    rows = []
    for kind in kinds:  # a handful of documents, not a hot path
        present, readable, size, problem = check_document(d.path, declared.get(kind))
        rows.append(
            {
                "kind": kind,
                "path": declared.get(kind),
                "required": kind in p.required,
                "present": present,
                "readable": readable,
                "size_bytes": size,
                "ok": readable or (kind not in p.required and kind not in declared),
                "problem": problem,
            }
        )
    table = pd.DataFrame(rows)
    block = pd.DataFrame({"n_missing": [int((~table["ok"]).sum())]})
    return Measurement(tables={"document": Table(table, keys=["kind"]), "block": Table(block)})
