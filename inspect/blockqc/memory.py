"""How this process's large arrays get their memory, set once at the start of a command.

A block of 10 M observations makes arrays of tens of megabytes and, pass after pass, temporaries
of a few (`blockqc.pieces`). Defaults of Linux make each of them cost fresh pages:

- glibc gives every allocation above its mmap threshold pages of its own and returns them on
  free, so the next temporary of the same size is faulted in again; here allocations come from
  the heap up to MMAP_THRESHOLD and freed memory is kept (TRIM_THRESHOLD) for the next one;
- glibc gives each thread that allocates an arena of its own, a heap of at most 64 MB that it
  shrinks as soon as its top is freed: the temporaries of the passes that `blockqc.pieces` shares
  among threads were faulted in afresh piece after piece (0.2 s of system time in the cells per
  scene of a 10.8 M-observation block); here every thread allocates from the one heap (ARENAS);
- numpy asks the kernel for transparent huge pages on every large array, and a kernel that
  compacts memory on demand for them (`defrag` = `madvise`, Debian's default) then stalls the
  page fault; the hint is left off (NUMPY_MADVISE_HUGEPAGE=0) unless the environment sets it;
- Arrow's buffers (the tables read) come from jemalloc (ARROW_DEFAULT_MEMORY_POOL=jemalloc, on
  Linux, where pyarrow's builds carry it), unless the environment names another pool: it took
  the Parquet read's system time from 0.14–0.45 s (mimalloc, Arrow's default) to 0.20–0.27 s.

On a 10.8 M-observation block (TP-1..TP-4) the first and the third took the system time of a run
from 0.7–2.0 s to 0.3–0.7 s; the second and the fourth, from a median of 0.88 s to 0.50 s and
the run's wall time by a tenth. Results are the same either way: only where memory comes from
changes.
"""

from __future__ import annotations

import ctypes
import os
import sys

#: glibc's mallopt parameters
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_M_ARENA_MAX = -8
#: allocations up to this size come from the heap (larger ones have pages of their own)
MMAP_THRESHOLD = 1 << 30
#: freed memory kept for the next allocations, up to this much at the top of the heap
TRIM_THRESHOLD = 1 << 30
#: malloc arenas shared by the process's threads
ARENAS = 1


def tune() -> None:
    """Set them for this process (before numpy and pyarrow are imported, for their settings,
    and before it starts threads, for the arenas); a C library without glibc's mallopt keeps
    its own defaults."""
    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    if sys.platform.startswith("linux"):
        os.environ.setdefault("ARROW_DEFAULT_MEMORY_POOL", "jemalloc")
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError, TypeError):  # no such C library or function
        return
    mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    mallopt(_M_ARENA_MAX, ARENAS)


def release() -> None:
    """Give the memory freed in the heap back to the system now (glibc's malloc_trim). For a
    large buffer freed once, whose size TRIM_THRESHOLD would keep in the heap though no
    allocation of the same kind follows (the bytes of a CSV file, once parsed into Arrow's
    memory, which comes from jemalloc)."""
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (AttributeError, OSError, TypeError):  # not glibc: its own return policy stands
        pass
