"""The producer's ground points of the tie points (contract v1.1 `lon`, `lat`, `h`): columns given
together, and one ground point per point, read alike by `inspect` and `adjust`."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from geokit import ground_points, observe, write_v11

from blockqc.delivery import load_delivery
from blockqc.errors import InputError
from blockqc.geometry_inputs import ONE_GROUND_POINT, ground_disagreements


def _ties(n: int = 40) -> pd.DataFrame:
    """n points seen on L and R, each row with its point's lon, lat, h; G0000 on rows 1 and 2."""
    ground = ground_points(n, seed=3)
    ties = observe(ground, noise_px=0.0, seed=3).merge(ground, on="point_id")
    return ties.reset_index(drop=True)


# ------------------------------------------------------------------ lon, lat, h together
@pytest.mark.parametrize(
    "dropped, given, missing",
    [
        (["lat"], "'lon' and 'h'", "column 'lat'"),  # lon and h: the ground point has no lat
        (["lon"], "'lat' and 'h'", "column 'lon'"),
        (["lat", "h"], "'lon'", "column 'lat'"),
        (["lon", "lat"], "'h'", "columns 'lon' and 'lat'"),  # a height without its position
    ],
)
def test_a_ground_point_without_lon_or_lat_is_refused(tmp_path, dropped, given, missing) -> None:
    """tie_points giving lon and h without lat: inspect read the delivery and left the columns
    unread, adjust took its checkpoints' positions from the producer's adjustment, neither
    saying so. Refused, naming the file, the columns given and those missing."""
    folder = write_v11(tmp_path / "d", _ties().drop(columns=dropped))
    with pytest.raises(InputError) as exc:
        load_delivery(folder)
    (msg,) = [str(p) for p in exc.value.problems]
    assert msg.startswith(f"{folder / 'tie_points.csv'}, line 1: missing {missing}: ")
    assert f"the table gives {given}, but a ground point is lon and lat together" in msg
    assert "give lon and lat, with or without h, or none of the three" in msg


@pytest.mark.parametrize("dropped", [[], ["h"], ["lon", "lat", "h"]])
def test_lon_and_lat_with_or_without_h_are_read(tmp_path, dropped) -> None:
    """lon and lat without h are a tie point's ground position (contract v1, `factors`)."""
    folder = write_v11(tmp_path / "d", _ties().drop(columns=dropped))
    tp = load_delivery(folder).tie_points
    assert {"lon", "lat", "h"} - set(dropped) <= set(tp.columns)


@pytest.mark.parametrize(
    "emptied, said",
    [
        (["lon"], "column 'lon': lon is empty where lat is given"),
        (["lat", "h"], "column 'lat': lat is empty where lon is given"),
        (["lon", "lat"], "column 'h': h is given where lon and lat are empty"),
    ],
)
def test_a_row_giving_part_of_a_ground_point_is_refused(tmp_path, blockqc, emptied, said) -> None:
    """The columns are all there, but a row gives lat and h without lon: inspect read it, and
    adjust took the point's ground position from its other rows, or, when its rows all gave it
    so, compared the point with no checkpoint and said only that fewer could be compared.
    Refused as the columns are, naming the row."""
    ties = _ties()
    ties.loc[[0, 1], emptied] = np.nan  # both rows of G0000
    folder = write_v11(tmp_path / "d", ties)
    tp = folder / "tie_points.csv"
    whole = "a ground point is lon and lat together, and h its height: give lon and lat, with or"
    expected = [
        f"{tp}, row {row} (line {row + 1}), {said} ({whole} without h, or none of the three)"
        for row in (1, 2)
    ]
    with pytest.raises(InputError) as exc:
        load_delivery(folder)
    assert [str(p) for p in exc.value.problems] == expected
    r = blockqc("adjust", folder, "--out", tmp_path / "out")
    assert r.returncode == 2 and f"error: {expected[0]}" in r.stderr, r.stdout + r.stderr


def test_rows_without_a_ground_point_beside_rows_with_one_are_read(tmp_path) -> None:
    """A row giving none of lon, lat and h is a row without the producer's ground point."""
    ties = _ties()
    ties.loc[[0, 1], ["lon", "lat", "h"]] = np.nan
    ties.loc[[2], ["h"]] = np.nan
    tp = load_delivery(write_v11(tmp_path / "d", ties)).tie_points
    assert tp[["lon", "lat", "h"]].isna().sum().tolist() == [2, 2, 3]


def test_inspect_and_adjust_both_refuse_a_partial_ground_point(tmp_path, blockqc) -> None:
    folder = write_v11(tmp_path / "d", _ties().drop(columns=["lat"]))
    said = f"{folder / 'tie_points.csv'}, line 1: missing column 'lat': the table gives 'lon' and"
    for command in ("inspect", "adjust"):
        out = tmp_path / f"out-{command}"
        r = blockqc(command, folder, "--out", out, *(["--no-pdf"] if command == "inspect" else []))
        assert r.returncode == 2, (command, r.stdout + r.stderr)
        assert f"error: {said}" in r.stderr and "Traceback" not in r.stderr, command


# ------------------------------------------------------------------ one ground point per point
def _frame(rows: list[tuple[str, float, float, float]]) -> pd.DataFrame:
    ids = pd.Categorical([r[0] for r in rows])  # as the readers give point_id
    values = np.array([r[1:] for r in rows], dtype=float)
    return pd.DataFrame(
        {"point_id": ids, "lon": values[:, 0], "lat": values[:, 1], "h": values[:, 2]}
    )


def test_rows_giving_their_point_another_ground_point_are_found() -> None:
    """Each row against the first of its point that gives the column: beyond 1e-7° or 0.01 m;
    longitudes modulo 360° (179.99999999° and -180.00000001° are one); the first few listed,
    the others counted."""
    nan = float("nan")
    rows = [
        ("A", 5.28, 44.1, 800.0),
        ("A", 5.2801, 44.1, 800.004),  # row 2: lon 1e-4° off; h 4 mm, round-off
        ("B", 179.99999999, 44.2, 10.0),
        ("B", -180.00000001, 44.2, 10.0),  # the same longitude across ±180°
        ("C", nan, 44.3, 5.0),  # C's first lon is on row 6
        ("C", 7.5, 44.3, 5.0),
        ("C", 7.5, 44.3, 5.5),  # row 7: h 0.5 m off row 5
    ]
    rows += [("D", 1.0 + (k > 0), 44.4, 1.0) for k in range(7)]  # rows 9..14 each 1° off row 8
    got = [str(p) for p in ground_disagreements(Path("t.csv"), _frame(rows), "why")]
    assert got == [
        "t.csv, row 2 (line 3), column 'lon': point 'A' is given lon 5.2801 here and 5.28 on "
        "row 1: why",
        *(
            f"t.csv, row {r} (line {r + 1}), column 'lon': point 'D' is given lon 2 here and 1 "
            f"on row 8: why"
            for r in (9, 10, 11, 12)
        ),
        "t.csv, column 'lon': 2 more rows give their point another lon than its first row: why",
        "t.csv, row 7 (line 8), column 'h': point 'C' is given h 5.5 here and 5 on row 5: why",
    ]


def test_points_of_one_ground_point_each_give_nothing_shuffled_or_not() -> None:
    """Rows of one point apart (not grouped), each point's values the same: nothing."""
    ties = _ties(200)
    ties = ties.sample(frac=1.0, random_state=1).reset_index(drop=True)
    ties["point_id"] = ties["point_id"].astype("category")
    assert ground_disagreements(Path("t.csv"), ties, "why") == []
    ties.loc[ties.index[-1], "lat"] += 1e-6  # the last row of a point whose first is earlier
    (p,) = ground_disagreements(Path("t.csv"), ties, "why")
    assert p.row == len(ties) and p.column == "lat"


def _two_ground_points(tmp_path: Path) -> Path:
    """G0000 at lon 5.28 on row 1 (scene L) and 5.2801 on row 2 (scene R)."""
    ties = _ties()
    assert list(ties.loc[:1, "point_id"]) == ["G0000", "G0000"]
    ties.loc[:1, "lon"] = [5.28, 5.2801]
    return write_v11(tmp_path / "d", ties)


def test_inspect_says_what_adjust_refuses(tmp_path, blockqc) -> None:
    """A point given lon 5.28 on row 1 and 5.2801 on row 2: adjust refused it, inspect said
    nothing. inspect now says it as a warning (RC-1 `ground: delivered` back-projects each
    row's own ground point), on the console and in results.json, in adjust's words."""
    folder = _two_ground_points(tmp_path)
    said = (
        f"{folder / 'tie_points.csv'}, row 2 (line 3), column 'lon': point 'G0000' is given lon "
        f"5.2801 here and 5.28 on row 1: {ONE_GROUND_POINT}"
    )
    out = tmp_path / "out"
    r = blockqc("inspect", folder, "--out", out, "--no-pdf")
    assert r.returncode in (0, 1), r.stderr
    assert f"warning: {said}; judged as given (RC-1 with ground: delivered" in r.stderr
    doc = json.loads((out / "CASE" / "results.json").read_text(encoding="utf-8"))
    (kept,) = doc["input_warnings"]
    assert kept.startswith(said)
    r = blockqc("adjust", folder, "--out", tmp_path / "adjusted")
    assert r.returncode == 2 and f"error: {said}\n" in r.stderr, r.stderr


def test_inspect_says_nothing_of_points_with_one_ground_point(tmp_path, blockqc) -> None:
    out = tmp_path / "out"
    r = blockqc("inspect", write_v11(tmp_path / "d", _ties()), "--out", out, "--no-pdf")
    assert r.returncode in (0, 1), r.stderr
    assert "is given lon" not in r.stderr and "warning" not in r.stderr
    doc = json.loads((out / "CASE" / "results.json").read_text(encoding="utf-8"))
    assert doc["input_warnings"] == []


def test_no_numpy_warning_from_the_check() -> None:
    """A point without any value (all NaN) meets ±inf in the extremes: no RuntimeWarning."""
    frame = _frame([("A", float("nan"), 44.0, 1.0), ("A", float("nan"), 44.0, 1.0)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert ground_disagreements(Path("t.csv"), frame, "why") == []
