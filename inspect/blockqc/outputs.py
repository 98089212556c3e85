"""Writing results: atomically, and never inside a delivery."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from blockqc.errors import UsageError


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` via a temporary file in the same folder and an atomic rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path: Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def write_json_atomic(path: Path, obj: Any) -> None:
    write_text_atomic(path, json.dumps(obj, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def check_out_dir(out: Path, inputs: Iterable[Path]) -> Path:
    """Refuse an output folder that lies inside (or is) one of the input deliveries or batches."""
    out_r = out.resolve()
    for p in inputs:
        p_r = Path(p).resolve()
        if out_r == p_r or p_r in out_r.parents:
            raise UsageError(
                f"--out {out} lies inside the input {p}: blockqc never writes into a delivery; "
                "choose an output folder outside it"
            )
    return out_r
