"""Tie-point statistics in one pass, checked against numpy and pandas as independent references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st


@given(
    st.lists(st.floats(0, 30, allow_nan=False), min_size=1, max_size=300),
    st.sampled_from([0.0, 0.05, 0.1, 1.0, 2.0, 2.05, 9.95, 10.0, 1e6, 1e300]),
)
@settings(max_examples=300, deadline=None)
def test_histogram_counts_as_numpy(values: list[float], on_edge: float) -> None:
    """The one-pass residual histogram counts exactly as np.histogram over the same edges,
    values lying on edges included."""
    from blockqc.metrics.tiepoints import histogram_counts, histogram_edges

    v = np.array([*values, on_edge])
    edges = histogram_edges(float(v.max()))
    v = np.concatenate([v, edges, np.nextafter(edges, 0), np.nextafter(edges, 99)])
    v = v[(v >= 0) & (v <= edges[-1])]
    expected, _ = np.histogram(v, bins=edges)
    assert histogram_counts(v, edges).tolist() == expected.tolist()


@given(
    st.lists(st.floats(0, 30, allow_nan=False), min_size=1, max_size=300),
    st.sampled_from([0.0, 0.05, 0.5, 1.0, 2.0, 9.95, 10.0, 12.0, 1e6, 1e300]),
    st.integers(0, 3),
    st.sampled_from([2, 7, 1 << 20]),
)
@settings(max_examples=300, deadline=None)
def test_histogram_median_as_numpy(
    values: list[float], extra: float, on_edges: int, chunk: int
) -> None:
    """The median found from the residual histogram is np.median's, to the last bit: odd and
    even counts, middle values on bin edges, in the last bin that gathers the largest errors,
    and in two different bins; the values taken a few at a time or all at once."""
    from blockqc import pieces
    from blockqc.metrics.tiepoints import histogram_counts, histogram_edges, histogram_median

    v = np.array([*values, extra])
    edges = histogram_edges(float(v.max()))
    v = np.concatenate([v, np.repeat(edges[: on_edges * 7 : 3], on_edges)])
    counts = histogram_counts(v, edges)
    old, pieces.CHUNK = pieces.CHUNK, chunk
    try:
        assert histogram_median(v, edges, counts) == np.median(v)
    finally:
        pieces.CHUNK = old


def test_histogram_median_by_hand() -> None:
    """Middle values 0.2 and 0.75 in bins apart: (0.2 + 0.75) / 2; one value more: 0.75;
    a NaN (outside every bin): numpy's NaN."""
    from blockqc.metrics.tiepoints import histogram_counts, histogram_edges, histogram_median

    v = np.array([0.1, 0.2, 0.75, 3.0])
    edges = histogram_edges(3.0)
    assert histogram_median(v, edges, histogram_counts(v, edges)) == 0.475
    w = np.append(v, 0.8)
    assert histogram_median(w, edges, histogram_counts(w, edges)) == 0.75
    x = np.append(v, np.nan)
    assert np.isnan(histogram_median(x, edges, histogram_counts(x, edges)))


def test_rms_of_errors_too_large_to_square_by_hand() -> None:
    """An error of 1e300 px: its scene's and the block's RMS stay finite (1e300/√n), the
    other scene's RMS is computed as usual."""
    import pandas as pd

    from blockqc.metrics.tiepoints import _stats

    err = pd.Series([3.0, 4.0, 1e300, 0.0])
    scene = pd.Series(["a", "a", "b", "b"], dtype="category")
    block = _stats(err, None, 1.0, 1.5).iloc[0]
    assert block["rms"] == pytest.approx(1e300 / 2.0, rel=1e-12)  # √(1e600 / 4)
    per = _stats(err, scene, 1.0, 1.5)
    assert per.loc["a", "rms"] == np.sqrt(12.5)  # √((9 + 16) / 2), unscaled
    assert per.loc["b", "rms"] == pytest.approx(1e300 / np.sqrt(2.0), rel=1e-12)
    assert per.loc["b", "max"] == 1e300 and per.loc["a", "n"] == 2


@given(
    st.lists(
        st.tuples(st.sampled_from(["s1", "s2", "s3", None]), st.floats(0, 3, allow_nan=False)),
        min_size=1,
        max_size=200,
    ),
    st.booleans(),
)
@settings(max_examples=200, deadline=None)
def test_per_scene_statistics_as_a_pandas_groupby(rows, categorical: bool) -> None:
    """Per scene: n, median, RMS, mean, max and the share in (1.0, 1.5] as pandas computes them
    from a frame grouped by scene (rows of no scene left out); ids as Categorical or text."""
    import pandas as pd

    from blockqc.metrics.tiepoints import _stats

    frame = pd.DataFrame(rows, columns=["scene", "e"])
    scene = frame["scene"].astype("category" if categorical else object)
    got = _stats(frame["e"], scene, 1.0, 1.5)
    g = frame.dropna(subset=["scene"]).groupby("scene")["e"]
    assert sorted(got.index) == sorted(g.groups)
    for sid, e in g:
        row = got.loc[sid]
        inside = int(((e > 1.0) & (e <= 1.5)).sum())
        assert row["n"] == len(e) and row["n_in_interval"] == inside
        assert row["median"] == pytest.approx(e.median(), abs=1e-12)
        assert row["mean"] == pytest.approx(e.mean(), abs=1e-12)
        assert row["max"] == e.max()
        assert row["rms"] == pytest.approx(np.sqrt((e**2).mean()), abs=1e-12)
        assert row["share_in_interval"] == pytest.approx(100.0 * inside / len(e))


@given(st.lists(st.sampled_from(["a", "b", "c", "d", None]), max_size=100), st.booleans())
@settings(max_examples=200, deadline=None)
def test_distinct_count_as_nunique(values, categorical: bool) -> None:
    """The count of distinct ids, missing ones aside, as pandas' nunique; a Categorical's
    unused categories are not counted."""
    import pandas as pd

    from blockqc.delivery import distinct_count

    s = pd.Series(values, dtype=object)
    if categorical:
        s = s.astype(pd.CategoricalDtype(["a", "b", "c", "d", "unused"]))
    assert distinct_count(s) == len({v for v in values if v is not None})


@given(
    st.lists(st.sampled_from(["a", "b", "c", "x", None]), max_size=100),
    st.lists(st.floats(-0.5, 2000.5, allow_nan=False), min_size=100, max_size=100),
    st.integers(1, 7),
)
@settings(max_examples=200, deadline=None)
def test_scene_positions_and_cells_as_written(ids, positions, k: int) -> None:
    """Each row's scene position as a lookup per row (get_indexer), a Categorical's or not;
    its cell along an axis as the formula min(max(trunc(position / extent × k), 0), k − 1)."""
    import pandas as pd

    from blockqc.delivery import scene_positions
    from blockqc.metrics.tiepoints import _cell_along

    scenes = pd.Series(["c", "a", "b"])
    expected = [["c", "a", "b"].index(v) if v in ("a", "b", "c") else -1 for v in ids]
    for s in (pd.Series(ids, dtype=object), pd.Series(ids, dtype="category")):
        assert scene_positions(s, scenes).tolist() == expected
    code = np.array([i for i in expected if i >= 0], dtype=np.int64)
    extent = np.array([2000.0, 1000.0, 3.0])
    pos = np.array(positions[: code.size])
    want = [min(max(int(p / extent[c] * k), 0), k - 1) for p, c in zip(pos, code, strict=True)]
    assert _cell_along(pos, extent, code, k).tolist() == want


def test_tie_points_of_some_bands_taken_once_and_again_when_replaced(tmp_path) -> None:
    """The PAN scenes' tie points are taken once for every measurement that asks; all scenes'
    are the delivery's own frame; a replaced tie-point frame is taken again."""
    from blockqc.delivery import load_delivery
    from blockqc.metrics.tiepoints import _select
    from casekit import write_delivery

    d = load_delivery(write_delivery(tmp_path / "block"))
    scenes, pan = _select(d, ["pan"])
    assert set(scenes["band"]) == {"pan"} and _select(d, ["pan"])[1] is pan
    assert set(pan["scene_id"]) == set(scenes["scene_id"]) & set(d.tie_points["scene_id"])
    assert _select(d, None)[1] is d.tie_points
    two = _select(d, ["pan"], ["scene_id", "line"])[1]
    assert list(two.columns) == ["scene_id", "line"] and two.index.equals(pan.index)
    assert _select(d, ["pan"], ["scene_id", "line"])[1] is two
    assert (two["line"] == d.tie_points["line"].iloc[two.index]).all()  # the index: positions
    d.tie_points = d.tie_points.iloc[:10]
    assert len(_select(d, ["pan"])[1]) <= 10


@pytest.mark.parametrize("categorical", [True, False])
def test_positions_outside_their_scene_by_hand(categorical: bool) -> None:
    """Scene A is 100 lines × 50 samples: line 100.4 lies inside (half a pixel of slack),
    100.6 and −0.6 outside; a row of an unknown scene or of no scene is outside only below
    −0.5 (its scene is reported apart)."""
    import pandas as pd

    from blockqc.delivery import _consistency_masks

    scene = pd.Series(["A", "A", "A", "X", None, None, "A"])
    tp = pd.DataFrame(
        {
            "scene_id": scene.astype("category") if categorical else scene,
            "line": [100.4, 100.6, -0.6, 500.0, 7.0, -3.0, 10.0],
            "sample": [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 50.6],
        }
    )
    scenes = pd.DataFrame({"scene_id": ["A"], "lines": [100], "samples": [50]})
    masks = {col: m for _, col, m, _ in _consistency_masks({"tie_points": tp, "scenes": scenes})}
    assert masks["line"].tolist() == [False, True, True, False, False, True, False]
    assert masks["sample"].tolist() == [False, False, False, False, False, False, True]


@pytest.mark.parametrize("categorical", [True, False])
def test_a_row_of_no_scene_alone_outside(categorical: bool) -> None:
    """Every row of scene A inside: the one row of no scene at line −3 is still found."""
    import pandas as pd

    from blockqc.delivery import _consistency_masks

    scene = pd.Series(["A", None, "A"])
    tp = pd.DataFrame(
        {
            "scene_id": scene.astype("category") if categorical else scene,
            "line": [5.0, -3.0, 6.0],
            "sample": [1.0, 1.0, 1.0],
        }
    )
    scenes = pd.DataFrame({"scene_id": ["A"], "lines": [100], "samples": [50]})
    masks = {col: m for _, col, m, _ in _consistency_masks({"tie_points": tp, "scenes": scenes})}
    assert masks["line"].tolist() == [False, True, False]


@given(
    st.lists(st.lists(st.integers(0, 39999) | st.none(), max_size=20), min_size=1, max_size=4),
    st.sampled_from([1, 126, 127, 32766, 32767, 40000]),
)
@settings(max_examples=200, deadline=None)
def test_dictionary_indices_as_codes(chunks: list[list[int | None]], n: int) -> None:
    """A column's dictionary indices, in chunks, with missing values, become the codes pandas
    itself makes of them: the same values (missing −1) and pandas' integer type for n
    categories."""
    import pandas as pd
    import pyarrow as pa

    from blockqc.delivery import _codes

    chunks = [[None if v is None else v % n for v in c] for c in chunks]
    indices = pa.chunked_array([pa.array(c, pa.int32()) for c in chunks], pa.int32())
    flat = np.array([-1 if v is None else v for c in chunks for v in c], dtype=np.int64)
    want = pd.Categorical.from_codes(flat, categories=pd.RangeIndex(n)).codes
    got = _codes(indices, n)
    assert got.dtype == want.dtype and got.tolist() == want.tolist()


@given(
    st.lists(st.sampled_from(["a", "b", "c", "m"]), min_size=1, max_size=80),
    st.lists(st.floats(-0.5, 1000.5, allow_nan=False), min_size=160, max_size=160),
    st.integers(1, 4),
    st.booleans(),
    st.sampled_from([1, 7, 1 << 20]),
)
@settings(max_examples=200, deadline=None)
def test_cells_per_scene_as_counted_row_by_row(ids, positions, k, categorical, chunk) -> None:
    """Observations and covered cells of each PAN scene as counted one row at a time with the
    formula of _cell_along; rows on the MS scene m (not checked) are left out, whether or not
    any row lies on one, and whether the scene ids are a Categorical or not."""
    import pandas as pd

    from blockqc import pieces
    from blockqc.metrics.tiepoints import DistributionParams, _per_scene_cells

    scenes = pd.DataFrame(
        {
            "scene_id": ["c", "a", "b"],
            "band": "pan",
            "lines": [1000, 400, 3],
            "samples": [7, 900, 1000],
        }
    )
    sid = pd.Series(ids, dtype="category" if categorical else object)
    tp = pd.DataFrame(
        {"scene_id": sid, "line": positions[: len(ids)], "sample": positions[80 : 80 + len(ids)]}
    )
    old, pieces.CHUNK = pieces.CHUNK, chunk
    try:
        got = _per_scene_cells(scenes, tp, DistributionParams(grid=k))
    finally:
        pieces.CHUNK = old
    size = scenes.set_index("scene_id")
    cells: dict[str, list[tuple[int, int]]] = {s: [] for s in size.index}
    for s, line, sample in tp.itertuples(index=False):
        if s in cells:
            i = min(max(int(line / size.loc[s, "lines"] * k), 0), k - 1)
            j = min(max(int(sample / size.loc[s, "samples"] * k), 0), k - 1)
            cells[s].append((i, j))
    assert got["n_points"].tolist() == [len(cells[s]) for s in scenes["scene_id"]]
    assert got["cells_covered"].tolist() == [len(set(cells[s])) for s in scenes["scene_id"]]


def test_the_counts_beside_the_block_statistics_are_whole_numbers(tmp_path) -> None:
    """TP-1 and TP-3 give the block's counts beside their statistic; they were written as
    floats (n 1378.0, n_points 606.0, n_in_interval 3.0), each now the whole number counted
    here with the csv module over the sample block's PAN observations."""
    import csv
    import json
    import math
    from pathlib import Path

    from casekit import run_blockqc

    block = Path(__file__).parents[1] / "samples" / "batch" / "F1-B01"
    with (block / "scenes.csv").open(newline="", encoding="utf-8") as fh:
        pan = {r["scene_id"] for r in csv.DictReader(fh) if r["band"] == "pan"}
    with (block / "tie_points.csv").open(newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh) if r["scene_id"] in pan]
    errors = [math.hypot(float(r["v_line"]), float(r["v_sample"])) for r in rows]
    expected = {
        "n": len(rows),
        "n_points": len({r["point_id"] for r in rows}),
        "n_in_interval": sum(1.0 < e <= 1.5 for e in errors),
        "n_other_bands": 0,
    }
    out = tmp_path / "out"
    proc = run_blockqc("inspect", block, "--out", out, "--pdf", "none")
    assert proc.returncode in (0, 1), proc.stderr
    results = json.loads((out / "F1-B01" / "results.json").read_text(encoding="utf-8"))
    for res in (r for r in results["results"] if r["rule"] in ("TP-1", "TP-3")):
        counts = {k: res["detail"][k] for k in expected}
        assert counts == expected and all(type(v) is int for v in counts.values()), res["rule"]


def test_a_failing_scenes_map_points_spread_over_it_as_its_tie_points_do(tmp_path) -> None:
    """The map of a scene failing TP-5 keeps at most 2000 of its points: its first 2000 rows
    were kept, so a table written in the order of line showed the top of the scene alone (3
    of 9 cells holding points, of a scene whose tie points are in 8). The points kept are
    now spread over the table's rows: they hold the same 8 cells, counted here with numpy."""
    import pandas as pd

    from blockqc.delivery import load_delivery
    from blockqc.metrics.tiepoints import DistributionParams, tie_point_distribution
    from casekit import write_delivery

    block = write_delivery(tmp_path / "block")
    tp = pd.read_csv(block / "tie_points.csv", dtype={"point_id": str})
    rng = np.random.default_rng(11)
    line, sample = rng.uniform(0, 1000, 6000), rng.uniform(0, 1000, 6000)
    keep = ~((line >= 2000 / 3) & (sample >= 2000 / 3))  # the lower right of 3×3 cells: none
    order = np.argsort(line[keep])  # in the order of line
    line, sample = line[keep][order], sample[keep][order]
    s1 = pd.DataFrame({"point_id": [f"Q{i}" for i in range(line.size)], "scene_id": "S1",
                       "line": line, "sample": sample, "v_line": 0.1, "v_sample": 0.1})  # fmt: skip
    pd.concat([tp[tp["scene_id"] != "S1"], s1]).to_csv(block / "tie_points.csv", index=False)

    def cells(lines, samples) -> set[tuple[int, int]]:
        i, j = (np.floor(np.asarray(v) / 1000 * 3).astype(int).tolist() for v in (lines, samples))
        return set(zip(i, j, strict=True))

    assert len(cells(line, sample)) == 8
    m = tie_point_distribution(load_delivery(block), DistributionParams(bands=["pan"]), None)
    shown = m.unit_points(["S1"])["S1"]
    assert len(shown["line"]) <= 2000
    assert cells(shown["line"], shown["sample"]) == cells(line, sample)


def test_a_scene_without_tie_points_is_no_evidence_of_the_block_errors(tmp_path) -> None:
    """TP-1 and TP-3 judge the block and list the scenes beyond the threshold; a scene holding
    no tie point (no median, no share) was listed among them, so that a mostly-sea scene
    exempt from TP-4 was drawn failing on the report's map. The evidence is now the scenes
    whose own figure is beyond it, found here with pandas: the three land scenes, not S4."""
    import json

    import pandas as pd

    from blockqc.report.figures import scene_statuses
    from blockqc.results import BlockResults
    from casekit import run_blockqc, write_delivery

    block = write_delivery(tmp_path / "block")
    tp = pd.read_csv(block / "tie_points.csv", dtype={"point_id": str})
    tp[["v_line", "v_sample"]] *= 4  # each error 1.2 px: TP-1 (≤ 0.5 px) and TP-3 fail
    tp = tp[tp["scene_id"] != "S4"]
    tp.to_csv(block / "tie_points.csv", index=False)
    scenes = pd.read_csv(block / "scenes.csv")
    scenes["water_fraction"] = np.where(scenes["scene_id"] == "S4", 0.9, 0.0)
    scenes.to_csv(block / "scenes.csv", index=False)

    errors = np.hypot(tp["v_line"], tp["v_sample"]).groupby(tp["scene_id"])
    share = errors.apply(lambda e: ((e > 1.0) & (e <= 1.5)).mean())
    beyond = {"TP-1": errors.median() > 0.5, "TP-3": share > 0.05}
    proc = run_blockqc("inspect", block, "--out", tmp_path / "out", "--pdf", "none")
    assert proc.returncode == 1, proc.stderr
    doc = json.loads((tmp_path / "out" / "CASE" / "results.json").read_text(encoding="utf-8"))
    for res in (r for r in doc["results"] if r["rule"] in ("TP-1", "TP-3")):
        assert res["status"] == "fail", res["rule"]
        listed = sorted(e["scene_id"] for e in res["evidence"])
        assert listed == sorted(beyond[res["rule"]][beyond[res["rule"]]].index), res["rule"]
    assert scene_statuses(BlockResults.model_validate(doc))["S4"] == "exempt"
