"""Homogenization (§RA-3): one CP per cell, BRIEF by smallest Hamming, else NCC by largest."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.matching import COLUMNS, homogenize


def candidates() -> pd.DataFrame:
    rows = [
        # cell (0, 0): two BRIEF and a stronger-looking NCC -> the BRIEF with Hamming 12
        (10.0, 20.0, "brief", 30.0),
        (390.0, 5.0, "brief", 12.0),
        (200.0, 200.0, "ncc", 0.99),
        # cell (0, 1): NCC only -> the largest coefficient, 0.93
        (100.0, 450.0, "ncc", 0.81),
        (120.0, 799.0, "ncc", 0.93),
        # cell (2, 0): a single BRIEF
        (805.0, 0.0, "brief", 50.0),
        # pixel 399 belongs to cell 0, pixel 400 to cell 1 (pixel-centre convention)
        (399.0, 1200.0, "ncc", 0.75),
        (400.0, 1200.0, "ncc", 0.70),
    ]
    df = pd.DataFrame(rows, columns=["row", "col", "kind", "score"])
    df["ref_row"] = df["row"] + 1.5
    df["ref_col"] = df["col"] - 2.25
    return df


def test_one_cp_per_cell_with_the_preference_rule():
    out = homogenize(candidates(), 400)
    assert list(out.columns) == COLUMNS
    got = {(r.cell_row, r.cell_col): (r.row, r.col, r.kind, r.score) for r in out.itertuples()}
    assert got == {
        (0, 0): (390.0, 5.0, "brief", 12.0),
        (0, 1): (120.0, 799.0, "ncc", 0.93),
        (2, 0): (805.0, 0.0, "brief", 50.0),
        (0, 3): (399.0, 1200.0, "ncc", 0.75),
        (1, 3): (400.0, 1200.0, "ncc", 0.70),
    }
    assert (out["ref_row"] - out["row"] == 1.5).all()


@given(st.randoms(use_true_random=False))
@settings(max_examples=20, deadline=None)
def test_order_of_the_input_does_not_matter(random):
    df = candidates()
    order = list(range(len(df)))
    random.shuffle(order)
    pd.testing.assert_frame_equal(homogenize(df.iloc[order], 400), homogenize(df, 400))


def test_empty_input_gives_empty_table_with_columns():
    out = homogenize(candidates().iloc[:0], 400)
    assert out.empty and list(out.columns) == COLUMNS


@given(st.integers(0, 1000))
@settings(max_examples=20, deadline=None)
def test_each_cell_keeps_its_best(seed):
    rng = np.random.default_rng(seed)
    n = 300
    df = pd.DataFrame(
        {
            "row": rng.integers(0, 2000, n).astype(float),
            "col": rng.integers(0, 2000, n).astype(float),
            "kind": rng.choice(["brief", "ncc"], n),
        }
    )
    df["score"] = np.where(df["kind"] == "brief", rng.integers(0, 128, n), rng.uniform(0.7, 1, n))
    df["ref_row"], df["ref_col"] = df["row"], df["col"]
    out = homogenize(df, 400)
    assert not out.duplicated(["cell_row", "cell_col"]).any()
    for (cr, cc), group in df.groupby([df["row"] // 400, df["col"] // 400]):
        kept = out[(out.cell_row == cr) & (out.cell_col == cc)].iloc[0]
        brief = group[group.kind == "brief"]
        if len(brief):
            assert kept.kind == "brief" and kept.score == brief.score.min()
        else:
            assert kept.kind == "ncc" and kept.score == group.score.max()
