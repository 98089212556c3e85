"""The overlaps' swapped-pair check against a set of (scene_a, scene_b, point_id) triples."""

from __future__ import annotations

import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.delivery import _given_swapped

ids = st.sampled_from(["A", "B", "C", "S10"])
points = st.one_of(st.none(), st.sampled_from(["p1", "p2", "P1"]))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(ids, ids, points), max_size=30))
def test_a_row_is_flagged_when_its_pair_is_also_given_the_other_way(rows) -> None:
    given_rows = set(rows)
    expected = [(b, a, p) in given_rows for a, b, p in rows]
    frame = pd.DataFrame(rows, columns=["scene_a", "scene_b", "point_id"], dtype=object)
    assert _given_swapped(frame).tolist() == expected
