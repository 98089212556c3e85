"""CSV tables are parsed block by block from the file, not from its bytes held in memory: what
is read is what the reader of whole tables reads, whatever the blocks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc import delivery, memory
from blockqc.delivery import TIE_POINTS, _read_csv

HEADER = "point_id,scene_id,line,sample,v_line,v_sample\n"


def _rows(values: list[str]) -> str:
    return "".join(f"P{i},S{i % 3},{v},2.5,0.1,-0.2\n" for i, v in enumerate(values))


@pytest.fixture
def small_blocks(monkeypatch):
    monkeypatch.setattr(delivery, "STREAM_BYTES", 64)  # a few rows per block
    monkeypatch.setattr(delivery, "RELEASE_BYTES", 0)  # every file streamed


@given(
    st.lists(
        st.one_of(
            st.integers(-(10**6), 10**6).map(str),
            st.floats(-1e6, 1e6, allow_nan=False).map(repr),
            st.just(""),
        ),
        min_size=1,
        max_size=60,
    )
)
@settings(max_examples=60, deadline=None)
def test_a_column_read_as_the_whole_table_reader_reads_it(tmp_path_factory, values):
    """Whole numbers in the first blocks and decimals or empty cells further down (the streamed
    reader takes a column's type from its first block) come out as one float column."""
    path = tmp_path_factory.mktemp("csv") / "tie_points.csv"
    path.write_text(HEADER + _rows(values))
    old = delivery.STREAM_BYTES, delivery.RELEASE_BYTES
    delivery.STREAM_BYTES, delivery.RELEASE_BYTES = 64, 0  # every file streamed, a few rows a block
    try:
        frame, header = _read_csv(path, TIE_POINTS)
    finally:
        delivery.STREAM_BYTES, delivery.RELEASE_BYTES = old
    expected = np.array([float(v) if v else np.nan for v in values])
    got = pd.to_numeric(frame["line"], errors="coerce").to_numpy(dtype=float)
    np.testing.assert_array_equal(got, expected)
    assert header == HEADER.strip().split(",")
    assert list(frame["point_id"].astype(str)) == [f"P{i}" for i in range(len(values))]


def test_a_byte_order_mark_and_crlf_lines_over_many_blocks(tmp_path: Path, small_blocks):
    path = tmp_path / "tie_points.csv"
    text = HEADER + _rows([str(i) for i in range(50)] + ["1.5"])
    path.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    frame, header = _read_csv(path, TIE_POINTS)
    assert header[0] == "point_id" and len(frame) == 51
    assert frame["line"].iloc[-1] == 1.5 and frame["line"].iloc[0] == 0.0


def test_the_files_bytes_are_released_before_it_is_parsed(tmp_path: Path, monkeypatch):
    """A 900 MB file of 10.8 M rows was parsed from its bytes, held beside the table (3.4 GB at
    the peak of its block's inspection, 1.5 GB now): above RELEASE_BYTES they are freed and
    given back to the system first, and Arrow reads the file itself; a smaller file is parsed
    from its bytes, read once."""
    path = tmp_path / "tie_points.csv"
    path.write_text(HEADER + _rows([str(i) for i in range(2000)]))
    monkeypatch.setattr(delivery, "RELEASE_BYTES", 1000)
    events = []
    monkeypatch.setattr(memory, "release", lambda: events.append("released"))
    parse = delivery._arrow_csv

    def arrow_csv(p, data, *options):
        events.append("parsed from the file" if data is None else "parsed from bytes")
        return parse(p, data, *options)

    monkeypatch.setattr(delivery, "_arrow_csv", arrow_csv)
    frame, _ = _read_csv(path, TIE_POINTS)
    assert events == ["released", "parsed from the file"] and len(frame) == 2000
    monkeypatch.setattr(delivery, "RELEASE_BYTES", path.stat().st_size + 1)
    events.clear()
    assert len(_read_csv(path, TIE_POINTS)[0]) == 2000
    assert events == ["parsed from bytes"]
