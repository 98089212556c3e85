"""Tables written as JSON rows: the column-wise conversion against the value-by-value one."""

from __future__ import annotations

import errno
import json
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.cli import main
from blockqc.errors import UsageError
from blockqc.outputs import jsonable, out_lock, records, write_json_atomic
from casekit import write_delivery

floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
text = st.one_of(st.none(), st.text(max_size=5))


@given(
    st.integers(0, 12).flatmap(
        lambda n: st.tuples(
            st.lists(floats, min_size=n, max_size=n),
            st.lists(st.integers(-(2**62), 2**62), min_size=n, max_size=n),
            st.lists(st.booleans(), min_size=n, max_size=n),
            st.lists(text, min_size=n, max_size=n),
        )
    )
)
@settings(max_examples=200, deadline=None)
def test_records_as_value_by_value(columns: tuple[list, list, list, list]) -> None:
    """Column by column gives what converting each value of `to_dict` gives: NaN and
    infinities null, numpy numbers plain, missing text null, categories as their text, text
    as it is."""
    f, i, b, s = columns
    df = pd.DataFrame({"f": f, "i": i, "b": b, "s": pd.Series(s, dtype=object)})
    df["c"] = df["s"].astype("category")
    df["t"] = pd.Series([str(v) for v in i], dtype=object)  # text only: converted at once
    df["d"] = pd.to_datetime(pd.Series(["2024-05-01"] * len(df)))
    expected = jsonable(df.to_dict("records"))
    got = records(df)
    assert json.dumps(got) == json.dumps(expected)
    assert all(type(r["f"]) in (float, type(None)) for r in got)
    # the rows are plain already: converting them again passes them on as they are
    assert jsonable({"rows": got})["rows"] is got
    assert jsonable(list(got)) == got


def test_records_by_hand() -> None:
    df = pd.DataFrame({"x": [1.5, np.nan, np.inf], "n": np.array([1, 2, 3], dtype=np.int32)})
    assert records(df) == [{"x": 1.5, "n": 1}, {"x": None, "n": 2}, {"x": None, "n": 3}]
    assert records(pd.DataFrame(index=[0, 1])) == [{}, {}]


def test_written_json_has_no_non_finite_numbers(tmp_path) -> None:
    path = tmp_path / "x.json"
    write_json_atomic(path, {"a": [np.float64("nan"), np.int64(3), math.inf], "b": "λ"})
    assert (
        path.read_text(encoding="utf-8")
        == '{\n  "a": [\n    null,\n    3,\n    null\n  ],\n  "b": "λ"\n}\n'
    )


def _plain(value):
    """jsonable written as a plain chain of isinstance checks: the reference."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    return value


_leaf = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**40), 2**40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=3),
    st.lists(st.floats(allow_nan=True, width=32), max_size=4).map(
        lambda v: np.array(v, dtype=np.float32)
    ),
    st.lists(st.integers(-5, 5), max_size=4).map(np.array),
    st.lists(st.booleans(), max_size=3).map(np.array),
    st.floats(allow_nan=True).map(np.float64),
    st.integers(-5, 5).map(np.int32),
)


@settings(max_examples=300, deadline=None)
@given(
    st.recursive(
        _leaf,
        lambda inner: st.one_of(
            st.lists(inner, max_size=4),
            st.lists(inner, max_size=3).map(tuple),
            st.dictionaries(st.one_of(st.text(max_size=2), st.integers(0, 9)), inner, max_size=3),
        ),
        max_leaves=20,
    )
)
def test_jsonable_as_the_plain_chain(value) -> None:
    got, expected = jsonable(value), _plain(value)
    assert json.dumps(got, allow_nan=False) == json.dumps(expected, allow_nan=False)
    assert type(got) is type(expected)


def test_a_plan_the_disk_has_no_room_for_is_named(tmp_path, monkeypatch, capsys) -> None:
    """A write the system refuses (a full disk) said only "No space left on device", naming no
    file; a refused temporary file was named instead of the plan asked for."""
    batch = tmp_path / "batch"
    write_delivery(batch / "B00", {"manifest": {"block_id": "B00"}})
    plan = tmp_path / "plans" / "plan.yaml"

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(SystemExit) as exc:
        main(["sample", str(batch), "--seed", "1", "--out", str(plan)])
    assert exc.value.code == 2
    assert capsys.readouterr().err == f"error: {plan}: No space left on device\n"
    assert list(plan.parent.iterdir()) == []  # no temporary file left behind
    monkeypatch.undo()
    with pytest.raises(SystemExit) as exc:
        main(["sample", str(batch), "--seed", "1", "--out", str(plan)])
    assert exc.value.code == 0 and plan.is_file()


def test_an_output_folder_the_lock_cannot_be_written_in_is_refused(tmp_path, monkeypatch) -> None:
    """The lock written into a full disk's folder stopped the run with "No space left on
    device" (no file named) and left its half-written temporary file there."""
    written = Path.write_text

    def full(self: Path, *args, **kwargs):
        if not self.name.startswith(".blockqc-lock"):
            return written(self, *args, **kwargs)
        self.touch()  # opened, then nothing fits
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(UsageError) as exc, out_lock(tmp_path):
        pass
    assert str(exc.value) == (
        f"--out {tmp_path}: this folder cannot be written in: No space left on device"
    )
    assert list(tmp_path.iterdir()) == []
