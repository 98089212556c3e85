"""How this process's large arrays get their memory, set once at the start of a command.

A block of 10 M observations makes arrays of tens of megabytes and, pass after pass, temporaries
of a few (`blockqc.pieces`). Two defaults of Linux make each of them cost fresh pages:

- glibc gives every allocation above its mmap threshold pages of its own and returns them on
  free, so the next temporary of the same size is faulted in again; here allocations come from
  the heap up to MMAP_THRESHOLD and freed memory is kept (TRIM_THRESHOLD) for the next one;
- numpy asks the kernel for transparent huge pages on every large array, and a kernel that
  compacts memory on demand for them (`defrag` = `madvise`, Debian's default) then stalls the
  page fault; the hint is left off (NUMPY_MADVISE_HUGEPAGE=0) unless the environment sets it.

On a 10.8 M-observation block (TP-1..TP-4) this took the system time of a run from 0.7–2.0 s to
0.3 s. Results are the same either way: only where memory comes from changes.
"""

from __future__ import annotations

import ctypes
import os

#: glibc's mallopt parameters
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: allocations up to this size come from the heap (larger ones have pages of their own)
MMAP_THRESHOLD = 1 << 30
#: freed memory kept for the next allocations, up to this much at the top of the heap
TRIM_THRESHOLD = 1 << 30


def tune() -> None:
    """Set the two for this process (before numpy is imported, for its hint); a C library
    without glibc's mallopt keeps its own defaults."""
    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError, TypeError):  # no such C library or function
        return
    mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
