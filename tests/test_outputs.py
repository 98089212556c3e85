"""Tables written as JSON rows: the column-wise conversion against the value-by-value one."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.outputs import jsonable, records, write_json_atomic

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
    infinities null, numpy numbers plain, missing text null, categories as their text."""
    f, i, b, s = columns
    df = pd.DataFrame({"f": f, "i": i, "b": b, "s": pd.Series(s, dtype=object)})
    df["c"] = df["s"].astype("category")
    df["d"] = pd.to_datetime(pd.Series(["2024-05-01"] * len(df)))
    expected = jsonable(df.to_dict("records"))
    got = records(df)
    assert json.dumps(got) == json.dumps(expected)
    assert all(type(r["f"]) in (float, type(None)) for r in got)


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
