"""Passes a piece at a time (blockqc.pieces): every piece once, results in the order of the
pieces whatever the threads, one thread after single_thread()."""

from __future__ import annotations

import threading
import time

import numpy as np

from blockqc import pieces


def test_each_piece_once_in_order(monkeypatch) -> None:
    monkeypatch.setattr(pieces, "CHUNK", 3)
    values = np.arange(10.0)
    got = pieces.each(lambda a: values[a : a + pieces.CHUNK].sum(), len(values))
    assert got == [3.0, 12.0, 21.0, 9.0]  # 0+1+2, 3+4+5, 6+7+8, 9
    assert pieces.each(lambda a: a, 0) == []


def test_results_in_order_when_pieces_end_out_of_order(monkeypatch) -> None:
    """On two threads the first pieces are made to end last: the results still come back in
    the order of the pieces, and their total is added in that order."""
    monkeypatch.setattr(pieces, "CHUNK", 1)
    monkeypatch.setattr(pieces, "THREADS", 2)

    def slow_first(a: int) -> int:
        time.sleep(0.02 * (4 - a))
        return a

    assert pieces.each(slow_first, 5) == [0, 1, 2, 3, 4]
    assert pieces.total(lambda a: [a], 4, []) == [0, 1, 2, 3]  # lists add in order
    assert pieces.total(lambda a: a, 0, "none") == "none"


def test_single_thread_runs_here(monkeypatch) -> None:
    monkeypatch.setattr(pieces, "CHUNK", 1)
    monkeypatch.setattr(pieces, "THREADS", 2)
    pieces.single_thread()
    assert pieces.THREADS == 1
    assert set(pieces.each(lambda a: threading.get_ident(), 50)) == {threading.get_ident()}
