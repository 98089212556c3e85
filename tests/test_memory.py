"""blockqc.memory: where the large arrays' memory comes from, set at the start of a command."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from blockqc import memory

HINT = "import numpy; print(numpy._core.multiarray._get_madvise_hugepage())"


def _hint_after_tune(env: dict[str, str]) -> str:
    code = f"from blockqc import memory; memory.tune(); {HINT}"
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_numpys_huge_page_hint_is_off_unless_the_environment_sets_it():
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    assert _hint_after_tune(env) == "False"
    assert _hint_after_tune(env | {"NUMPY_MADVISE_HUGEPAGE": "1"}) == "True"


def test_every_command_tunes_the_process_first(monkeypatch):
    calls = []
    monkeypatch.setattr(memory, "tune", lambda: calls.append("tuned"))
    from blockqc.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and calls == ["tuned"]
