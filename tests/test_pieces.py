"""Passes a piece at a time (blockqc.pieces): every piece once, results in the order of the
pieces whatever the threads, one thread after single_thread()."""

from __future__ import annotations

import threading

import numpy as np

from blockqc import pieces


def test_each_piece_once_in_order(monkeypatch) -> None:
    monkeypatch.setattr(pieces, "CHUNK", 3)
    values = np.arange(10.0)
    got = pieces.each(lambda a: values[a : a + pieces.CHUNK].sum(), len(values))
    assert got == [3.0, 12.0, 21.0, 9.0]  # 0+1+2, 3+4+5, 6+7+8, 9
    assert pieces.each(lambda a: a, 0) == []


def test_single_thread_runs_here(monkeypatch) -> None:
    monkeypatch.setattr(pieces, "CHUNK", 1)
    monkeypatch.setattr(pieces, "THREADS", 2)
    seen = set(pieces.each(lambda a: threading.get_ident(), 50))
    assert len(seen) >= 1
    pieces.single_thread()
    assert pieces.THREADS == 1
    assert set(pieces.each(lambda a: threading.get_ident(), 50)) == {threading.get_ident()}
