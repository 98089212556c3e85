"""Test helpers: the command line in a child process, the samples, and the rule-case base
delivery (which lives in the package, `blockqc.rules.casebase`, so that any pack's cases run)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from blockqc.rules.casebase import base_manifest, base_tables, write_delivery
from blockqc.rules.cases import aggregate_status

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"

__all__ = [
    "ROOT",
    "SAMPLES",
    "aggregate_status",
    "base_manifest",
    "base_tables",
    "run_blockqc",
    "write_delivery",
]


def run_blockqc(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the real command line in a child process (exit status, stdout, stderr)."""
    return subprocess.run(
        [sys.executable, "-m", "blockqc", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )


def extension_pack(
    tmp_path: Path, body: str, name: str = "project", extends: str = "global-project"
) -> Path:
    """A pack file `<name>.yaml` extending `extends` with `body` (YAML text), in tmp_path."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"pack: {name}\nextends: {extends}\n{body}", "utf-8")
    return path


def lint_messages(path: Path) -> list[str]:
    """Every problem `blockqc rules lint` finds in a pack file, as printed."""
    from blockqc.rules.lint import lint

    return [str(p) for p in lint(path)[1]]
