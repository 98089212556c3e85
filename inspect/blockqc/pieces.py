"""Passes over millions of rows a piece at a time, the pieces shared among threads.

A piece is CHUNK rows: its temporaries stay a few megabytes, so that a pass makes no row-sized
copy. numpy releases the interpreter lock in its loops over arrays, so the pieces of one pass
run on THREADS cores at once; the results come back in the order of the pieces, so that sums
over them are the same whatever the number of threads. A worker process of a batch run with
`--jobs` sets THREADS to 1: its processes already share the cores.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

#: rows worked through at once
CHUNK = 1 << 20
#: threads that share the pieces of a pass
THREADS = min(os.cpu_count() or 1, 4)

T = TypeVar("T")
_pool: ThreadPoolExecutor | None = None


def starts(n: int) -> range:
    """The first row of each piece of n rows."""
    return range(0, n, CHUNK)


def each(func: Callable[[int], T], n: int) -> list[T]:
    """func(a) for the first row a of each piece of n rows, in the order of the pieces; the
    pieces run on THREADS threads when there are several (func must not call `each`)."""
    return shared(func, starts(n))


def shared(func: Callable[[Any], T], items: Sequence[Any]) -> list[T]:
    """func(item) for each item, in their order, on THREADS threads when there are several
    items (func must not call `shared` or `each`)."""
    if THREADS <= 1 or len(items) <= 1:
        return [func(item) for item in items]
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(THREADS, thread_name_prefix="blockqc-pieces")
    return list(_pool.map(func, items))


def total(func: Callable[[int], Any], n: int, none: Any) -> Any:
    """The sum of func(a) over the pieces of n rows (`each`), added in the order of the
    pieces into `none` (an array is added to in place); `none` when there are no rows."""
    out = none
    for part in each(func, n):
        out += part
    return out


def _forgotten() -> None:
    global _pool
    _pool = None  # a forked process has none of its parent's threads


os.register_at_fork(after_in_child=_forgotten)


def single_thread() -> None:
    """Every pass in this process on one thread (a worker process among others)."""
    global THREADS
    THREADS = 1
