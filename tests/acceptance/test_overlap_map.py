"""The overlap-discrepancy map: per scene pair mean vector, RMS and largest discrepancy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.report.format import Formatter
from blockqc.report.maps import _overlap_points, _pairs, overlap_map
from blockqc.rules import load_pack
from casekit import write_delivery


def test_pairs_by_hand() -> None:
    rows = [
        {"scene_a": "A", "scene_b": "B", "dx_m": 3.0, "dy_m": 4.0},
        {"scene_a": "A", "scene_b": "B", "dx_m": -3.0, "dy_m": 4.0},
    ]
    table = _pairs(rows)
    assert len(table) == 1
    p = table.iloc[0]
    # mean (0, 4); both discrepancies 5 m: RMS 5, max 5
    assert (p["scene_a"], p["scene_b"]) == ("A", "B")
    assert (p["dx"], p["dy"], p["rms"], p["max"]) == (0.0, 4.0, 5.0, 5.0)


def test_map_of_a_delivery(tmp_path) -> None:
    # the case delivery: 5 overlap points S1/S2 with dx 3, dy 4 → one pair, RMS 5 m
    res = inspect_delivery(
        load_delivery(write_delivery(tmp_path / "d")), load_pack("global-project")
    )
    rows, judge = _overlap_points(res)
    assert len(rows) == 5 and math.isclose(judge.threshold, 2 * math.sqrt(2) * 10)
    svg = overlap_map(res, Formatter("en"))
    assert svg is not None and svg.startswith("<svg")


@pytest.mark.parametrize(
    ("comparison", "threshold", "red"),
    [
        ("<=", 5.0, False),  # on an inclusive bound: passes (it was drawn red, 5 ≥ 5)
        ("<", 5.0, True),  # on a strict bound: fails
        ("<", 5.0 * (1 + 1e-10), True),  # within a billionth of it: on it, fails (was green)
        ("<", 5.01, False),
        ("<=", 4.99, True),
    ],
)
def test_a_pair_is_red_as_the_rule_judges_its_largest_discrepancy(
    tmp_path, comparison, threshold, red
) -> None:
    """The pair's colour follows the rule's comparison, as the engine judges it (rules.model
    .within): the case delivery's pair S1/S2 has every plane discrepancy √(3² + 4²) = 5 m."""
    res = inspect_delivery(
        load_delivery(write_delivery(tmp_path / "d")), load_pack("global-project")
    )
    ro3 = next(r for r in res.results if r.rule == "RO-3" and r.group == {"component": "plane"})
    ro3.threshold, ro3.comparison = threshold, comparison
    svg = overlap_map(res, Formatter("en"))
    assert ('fill="#c62828"' in svg) is red and ('fill="#2e7d32"' in svg) is not red


def _one_pair(tmp_path, dx: list[float], dy: list[float]):
    """The case delivery inspected, its pair S1/S2's plane discrepancies set to (dx, dy)."""
    res = inspect_delivery(
        load_delivery(write_delivery(tmp_path / "d")), load_pack("global-project")
    )
    rows, _ = _overlap_points(res)
    assert len(rows) == len(dx)
    for r, x, y in zip(rows, dx, dy, strict=True):
        r["dx_m"], r["dy_m"] = x, y
    return res


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_a_failing_pairs_label_is_the_discrepancy_that_fails(tmp_path, lang) -> None:
    """Four discrepancies of 5 m and one of 30 m (above RO-3's 2√2·10 = 28.28 m): RMS
    √((4·25 + 900)/5) = √200 = 14.14 m, under the bound. The pair is red, and its label was
    '14.14', a red number under the limit; it is now the 30 m that fails, and the title says
    what the label and the red are."""
    res = _one_pair(tmp_path, [3.0, 3.0, 3.0, 3.0, 18.0], [4.0, 4.0, 4.0, 4.0, 24.0])
    svg = overlap_map(res, Formatter(lang))
    labels = _labels(svg)
    assert [(c, s) for _, _, c, s in labels] == [("#c62828", "30")]
    assert "14.14" not in svg
    said = {
        "en": ("largest discrepancy in m; red: the largest fails RO-3 (&lt; 28.28 m)"),
        "zh": "旁注最大接边差（m）；红色：最大接边差不满足 RO-3（&lt; 28.28 m）",
    }
    assert said[lang] in svg


def test_a_passing_pairs_label_is_its_largest_discrepancy(tmp_path) -> None:
    """Discrepancies of 5, 5, 5, 5 and 25 m: largest 25 m, under 28.28 m: green, '25'."""
    res = _one_pair(tmp_path, [3.0, 3.0, 3.0, 3.0, 15.0], [4.0, 4.0, 4.0, 4.0, 20.0])
    labels = _labels(overlap_map(res, Formatter("en")))
    assert [(c, s) for _, _, c, s in labels] == [("#2e7d32", "25")]


def test_residual_vectors_by_hand() -> None:
    from blockqc.report.maps import residual_vectors

    # image corners (0,0) (0,S) (L,S) (L,0) at lon/lat (0,1) (1,1) (1,0) (0,0): samples run
    # east, lines run south; a residual along the samples points east, along the lines south
    corners = np.array([[[0, 1], [1, 1], [1, 0], [0, 0]]], dtype=float)
    cells = [
        {"scene_id": "S", "u": 0.5, "w": 0.5, "v_line": 0.0, "v_sample": 0.3},
        {"scene_id": "S", "u": 0.25, "w": 0.75, "v_line": 0.4, "v_sample": 0.0},
    ]
    cells.append(
        {"scene_id": "T", "u": 0.5, "w": 0.5, "v_line": 1.0, "v_sample": 1.0}
    )  # no corners
    v = residual_vectors(cells, np.array(["S"], dtype=object), corners)
    assert v.shape == (2, 4)
    np.testing.assert_allclose(v[0], [0.5, 0.5, 0.3, 0.0], atol=1e-12)
    np.testing.assert_allclose(v[1], [0.75, 0.75, 0.0, -0.4], atol=1e-12)


def test_residual_cells_by_hand() -> None:
    import pandas as pd

    from blockqc.metrics.tiepoints import residual_cells

    scenes = pd.DataFrame({"scene_id": ["S"], "lines": [100], "samples": [100]})
    tp = pd.DataFrame(
        {
            "scene_id": ["S", "S", "S"],
            "line": [10.0, 20.0, 99.0],  # cells (0, 0), (0, 0), (3, 3) of a 4×4 grid
            "sample": [5.0, 24.0, 80.0],
            "v_line": [0.1, 0.3, -0.2],
            "v_sample": [0.0, 0.2, 0.4],
        }
    )
    got = residual_cells(tp, scenes)
    assert got == [
        {"scene_id": "S", "u": 0.125, "w": 0.125, "n": 2, "v_line": 0.2, "v_sample": 0.1},
        {"scene_id": "S", "u": 0.875, "w": 0.875, "n": 1, "v_line": -0.2, "v_sample": 0.4},
    ]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["S10", "S2", "a", "Z"]),
            st.floats(0, 120, allow_nan=False),
            st.floats(0, 80, allow_nan=False),
            st.one_of(st.floats(-2, 2), st.just(float("nan"))),
            st.floats(-2, 2),
        ),
        min_size=1,
        max_size=60,
    ),
    st.booleans(),
)
def test_residual_cells_as_a_pandas_groupby(rows, categorical) -> None:
    import pandas as pd

    from blockqc.metrics.tiepoints import residual_cells

    tp = pd.DataFrame(rows, columns=["scene_id", "line", "sample", "v_line", "v_sample"])
    if categorical:
        tp["scene_id"] = tp["scene_id"].astype(pd.CategoricalDtype(["Z", "a", "S2", "S10", "X"]))
    scenes = pd.DataFrame(
        {"scene_id": ["S10", "S2", "a", "Z"], "lines": [100, 100, 50, 200], "samples": [80] * 4}
    )
    size = scenes.set_index("scene_id")
    k = 4
    frame = pd.DataFrame(
        {
            "scene_id": tp["scene_id"].astype(str).to_numpy(dtype=object),
            "u": (
                np.clip(
                    np.floor(tp["line"] / tp["scene_id"].astype(str).map(size["lines"]) * k),
                    0,
                    k - 1,
                )
                + 0.5
            )
            / k,
            "w": (
                np.clip(
                    np.floor(tp["sample"] / tp["scene_id"].astype(str).map(size["samples"]) * k),
                    0,
                    k - 1,
                )
                + 0.5
            )
            / k,
            "v_line": tp["v_line"],
            "v_sample": tp["v_sample"],
        }
    )
    g = frame.groupby(["scene_id", "u", "w"], sort=True)
    out = g.agg(n=("v_line", "size"), v_line=("v_line", "mean"), v_sample=("v_sample", "mean"))
    expected = out.reset_index().round(6).to_dict("records")
    got = residual_cells(tp, scenes)
    assert [(c["scene_id"], c["u"], c["w"], c["n"]) for c in got] == [
        (c["scene_id"], c["u"], c["w"], c["n"]) for c in expected
    ]
    for a, b in zip(got, expected, strict=True):
        for key in ("v_line", "v_sample"):
            if b[key] != b[key]:  # NaN: a cell whose residuals are all missing
                assert a[key] is None
            else:
                assert a[key] == pytest.approx(b[key], abs=2e-6)


def test_the_labels_of_a_large_map_are_the_failing_pairs_then_the_largest() -> None:
    """30 pairs (more than MAX_PAIR_LABELS = 24): pairs 3 and 17 fail (17's the larger), then
    the 22 others of largest discrepancy, largest first. Largest discrepancy of pair i:
    1 + i/10, but pair 29's is 0.5 and pair 5's missing (NaN, never taken before a number)."""
    from blockqc.report.maps import _labelled

    rms = 1 + np.arange(30) / 10
    rms[29], rms[5] = 0.5, np.nan
    bad = np.zeros(30, bool)
    bad[[3, 17]] = True
    others = [i for i in range(28, -1, -1) if i not in (3, 5, 17)][:22]  # 28, 27, …, 6, 4
    assert _labelled(rms, bad).tolist() == [17, 3, *others]
    assert _labelled(rms[:24], bad[:24]).tolist() == list(range(24))  # few pairs: every one


def _grid_block(tmp_path):
    """Field 3 (published as failing RO-3) as one block of 8 × 8 footprints, inspected."""
    from blockqc.simulate import Layout, Options, simulate

    layout = Layout(rows=8, cols=8, obs_per_scene=100)
    (bid,) = simulate(tmp_path, Options(fields=(3,), blocks_per_field=1, layout=layout))
    return inspect_delivery(load_delivery(tmp_path / bid), load_pack("global-project"))


def _labels(svg: str) -> list[tuple[float, float, str, str]]:
    import re

    found = re.findall(
        r'<text x="([\d.]+)" y="([\d.]+)" font-size="6"[^>]*fill="(#[0-9a-f]+)"[^>]*>([\d.]+)<',
        svg,
    )
    return [(float(x), float(y), colour, s) for x, y, colour, s in found]


def test_an_8x8_grid_labels_every_failing_pair_and_the_largest_others(tmp_path) -> None:
    """An 8 × 8 grid has 112 overlapping pairs: their RMS labels (the first 60 pairs by
    scene id) crowded one another and the arrows, the eastern half of the map unlabelled. Now
    the failing pairs are labelled in red, then the others of largest discrepancy, 24 labels
    at most, none over another (boxes of 0.6 em a character, 1 em high); the title says so.
    Each label is the pair's largest discrepancy, the figure RO-3 judges."""
    from blockqc.report.format import number

    res = _grid_block(tmp_path)
    rows, judge = _overlap_points(res)
    worst: dict[tuple[str, str], list[float]] = {}
    for r in rows:  # per pair: the plane discrepancies (by hand, not the map's groupby)
        worst.setdefault((r["scene_a"], r["scene_b"]), []).append(math.hypot(r["dx_m"], r["dy_m"]))
    rms = {p: max(d) for p, d in worst.items()}  # the largest, as RO-3 judges each point
    failing = {p for p, d in worst.items() if max(d) >= judge.threshold}
    assert judge.comparison == "<" and len(worst) > 100 and 0 < len(failing) < 24
    labels = _labels(overlap_map(res, Formatter("en")))
    red = sorted(s for _, _, c, s in labels if c == "#c62828")
    assert red == sorted(number(rms[p]) for p in failing)
    green = [float(s) for _, _, c, s in labels if c == "#2e7d32"]
    passing = sorted((v for p, v in rms.items() if p not in failing), reverse=True)
    assert len(red) + len(green) <= 24 and len(green) >= 12  # some left out where they crowd
    assert min(green) >= passing[24 - len(red) - 1] - 0.005  # of the largest
    boxes = [(x, x + 3.6 * len(s), y) for x, y, _, s in labels]
    for i, (a0, a1, ay) in enumerate(boxes):
        for b0, b1, by in boxes[i + 1 :]:
            assert not (a0 < b1 and b0 < a1 and abs(ay - by) < 6.0), labels
    title = f"largest discrepancy in m of the {len(failing)} failing pairs and of the"
    assert title in overlap_map(res, Formatter("en"))
