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


def _run(code: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return run


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="jemalloc is chosen on Linux")
def test_arrows_buffers_come_from_jemalloc_unless_the_environment_names_a_pool():
    code = (
        "from blockqc import memory; memory.tune(); import pyarrow as pa; "
        "print(pa.default_memory_pool().backend_name)"
    )
    env = {k: v for k, v in os.environ.items() if k != "ARROW_DEFAULT_MEMORY_POOL"}
    assert _run(code, env).stdout.strip() == "jemalloc"
    assert _run(code, env | {"ARROW_DEFAULT_MEMORY_POOL": "system"}).stdout.strip() == "system"


ARENAS = """
import ctypes, threading
{tune}
import numpy as np
def work():  # a pass's temporaries, made by a thread of its own
    for _ in range(3):
        np.ones(1 << 20).sum()
threads = [threading.Thread(target=work) for _ in range(3)]
for t in threads: t.start()
for t in threads: t.join()
ctypes.CDLL(None).malloc_stats()  # glibc: one 'Arena N:' paragraph per arena, on stderr
"""


def _arenas(tuned: bool) -> int:
    tune = "from blockqc import memory; memory.tune()" if tuned else ""
    run = _run(ARENAS.format(tune=tune), dict(os.environ))
    return run.stderr.count("Arena ")


@pytest.mark.skipif(
    not hasattr(__import__("ctypes").CDLL(None), "malloc_stats"), reason="not glibc"
)
def test_threads_allocate_from_one_arena():
    """Without tune(), each thread that allocates gets a malloc arena of its own, a heap that
    glibc shrinks (and the next temporary faults in afresh); after it, one arena serves all."""
    assert _arenas(tuned=False) > 1
    assert _arenas(tuned=True) == 1


RELEASE = """
{tune}
from blockqc import memory
def rss():
    status = dict(line.split(":", 1) for line in open("/proc/self/status"))
    return int(status["VmRSS"].split()[0]) // 1024
data = b"x" * (300 << 20)  # a file's bytes, read whole
del data
kept = rss()
memory.release()
print(kept, rss())
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="no /proc")
@pytest.mark.skipif(not hasattr(__import__("ctypes").CDLL(None), "malloc_trim"), reason="not glibc")
def test_a_large_buffer_freed_is_given_back_to_the_system_on_release():
    """tune()'s heap keeps 300 MB freed (for the next temporaries); release() gives it back."""
    tune = "from blockqc import memory; memory.tune()"
    kept, released = map(int, _run(RELEASE.format(tune=tune), dict(os.environ)).stdout.split())
    assert kept - released > 250
