"""§QE-1 sampling: the table, splitting, largest-remainder allocation, reproducible draws."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from blockqc.acceptance.sampling import allocate, draw, sample_size, split_sizes
from blockqc.rules import load_pack

SAMPLING = load_pack("global-project").acceptance.sampling


@pytest.mark.parametrize(
    ("n", "expected"),
    [
        (1, 1),  # the sample (3) reaches the batch: every unit
        (2, 2),
        (3, 3),
        (8, 3),
        (20, 3),
        (21, 5),
        (100, 10),
        (150, 13),
        (200, 15),
        (201, 17),
        (232, 17),
        (233, 20),
        (487, 30),
        (488, 40),
        (686, 40),
        (687, 56),
        (700, 56),
        (1000, 56),
    ],
)
def test_sample_size_by_the_table(n: int, expected: int) -> None:
    assert sample_size(n, SAMPLING) == expected


def test_sample_size_outside_the_table() -> None:
    with pytest.raises(ValueError, match="outside the table"):
        sample_size(1001, SAMPLING)


def test_split_into_fewest_even_batches() -> None:
    # 2500 > 1000: ⌈2500/1000⌉ = 3 lots, 2500 = 834 + 833 + 833
    assert split_sizes(2500, 1000) == [834, 833, 833]
    assert split_sizes(1001, 1000) == [501, 500]
    assert split_sizes(1000, 1000) == [1000]


def test_allocate_largest_remainder() -> None:
    # n = 13 over 50/30/20 of 100: quotas 6.5, 3.9, 2.6 → floors 6, 3, 2 (11); the two seats
    # left go to the largest remainders .9 (b) and .6 (c)
    assert allocate({"a": 50, "b": 30, "c": 20}, 13) == {"a": 6, "b": 4, "c": 3}
    # equal remainders and sizes: the strata listed first
    assert allocate({"a": 1, "b": 1, "c": 1}, 2) == {"a": 1, "b": 1, "c": 0}
    # equal remainders (.5 each): the larger stratum first
    assert allocate({"a": 2, "b": 6}, 1) == {"a": 0, "b": 1}


@given(st.lists(st.integers(1, 200), min_size=1, max_size=8), st.data())
def test_allocate_is_proportional(sizes: list[int], data: st.DataObject) -> None:
    total = sum(sizes)
    n = data.draw(st.integers(0, total))
    got = allocate({f"s{i}": s for i, s in enumerate(sizes)}, n)
    assert sum(got.values()) == n
    for i, s in enumerate(sizes):
        assert abs(got[f"s{i}"] - n * s / total) < 1
        assert 0 <= got[f"s{i}"] <= s


@pytest.mark.parametrize(("n", "expected"), [(8, 3), (150, 13), (700, 56), (2500, 3 * 56)])
def test_draw_sizes_and_reproducible(n: int, expected: int) -> None:
    ids = [f"B{i:04d}" for i in range(n)]
    lots = draw(ids, SAMPLING, seed=11)
    sampled = [u for lot in lots for u in lot.sampled]
    assert len(sampled) == expected == len(set(sampled))
    assert set(sampled) <= set(ids)
    again = draw(list(reversed(ids)), SAMPLING, seed=11)  # listing order does not matter
    assert [lot.sampled for lot in again] == [lot.sampled for lot in lots]
    assert [lot.sampled for lot in draw(ids, SAMPLING, seed=12)] != [lot.sampled for lot in lots]


def test_draw_stratified_proportional() -> None:
    # 150 blocks: 75 hilly, 45 flat, 30 mountain; n = 13 → 6.5, 3.9, 2.6 → 6, 4, 3 (as above)
    ids = [f"B{i:03d}" for i in range(150)]
    strata = {
        u: "hilly" if i < 75 else "flat" if i < 120 else "mountain" for i, u in enumerate(ids)
    }
    (lot,) = draw(ids, SAMPLING, seed=3, strata=strata)
    got = {s.value: len(s.sampled) for s in lot.strata}
    assert got == {"flat": 4, "hilly": 6, "mountain": 3}
    for s in lot.strata:
        assert all(strata[u] == s.value for u in s.sampled)


def test_census_when_the_sample_reaches_the_batch() -> None:
    (lot,) = draw(["A", "B"], SAMPLING, seed=1)
    assert lot.census and lot.sampled == ["A", "B"]


def test_strata_in_natural_order() -> None:
    # 8 blocks in strata 8, 9, 10, 11 (2 each): n = 3, quotas 0.75 each, every remainder and
    # size equal, so the seats go to the strata first in order: 8, 9 and 10 — not 10, 11, 8
    # (the order of the values as text)
    ids = [f"B{i}" for i in range(1, 9)]
    strata = {u: str(8 + (i // 2)) for i, u in enumerate(ids)}
    (lot,) = draw(ids, SAMPLING, seed=5, strata=strata)
    assert [s.value for s in lot.strata] == ["8", "9", "10", "11"]
    assert [len(s.sampled) for s in lot.strata] == [1, 1, 1, 0]


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        (["F10", "F9", "F1"], ["F1", "F9", "F10"]),
        (["10", "9", "100"], ["9", "10", "100"]),
        (["2.1", "0.8", "10.5", "0.75"], ["0.75", "0.8", "2.1", "10.5"]),
        (["hilly", "flat", "mountain"], ["flat", "hilly", "mountain"]),
        (["zone-12b", "zone-2b", "zone-12a"], ["zone-2b", "zone-12a", "zone-12b"]),
        (["flat", "10", "9"], ["9", "10", "flat"]),
    ],
)
def test_strata_values_read_as_a_person_reads_them(values: list[str], expected: list[str]) -> None:
    ids = [f"B{i}" for i in range(len(values) * 2)]
    strata = {u: values[i % len(values)] for i, u in enumerate(ids)}
    (lot,) = draw(ids, SAMPLING, seed=1, strata=strata)
    assert [s.value for s in lot.strata] == expected


def test_lots_are_runs_of_the_block_ids_in_natural_order() -> None:
    # 1001 > 1000: two lots of 501 and 500, B1…B501 and B502…B1001 (as text, B1000 and B1001
    # would sort right after B100 and fall in the first lot)
    ids = [f"B{i}" for i in range(1001, 0, -1)]
    lots = draw(ids, SAMPLING, seed=4)
    assert [lot.units for lot in lots] == [
        [f"B{i}" for i in range(1, 502)],
        [f"B{i}" for i in range(502, 1002)],
    ]
    for lot in lots:
        assert lot.sampled == sorted(lot.sampled, key=lambda u: int(u[1:]))


def test_a_stratum_lists_its_units_in_natural_order() -> None:
    (lot,) = draw([f"F{i}-B{j}" for i in (10, 9) for j in (12, 2)], SAMPLING, seed=4)
    assert lot.strata[0].units == ["F9-B2", "F9-B12", "F10-B2", "F10-B12"]
