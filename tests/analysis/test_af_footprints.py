"""Image factors (§AF-4..7) against geodesic areas; tie-point ground positions from corners."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import shapely
from pyproj import Geod

from blockqc.analysis.footprints import (
    acquisition_periods,
    footprint_factors,
    scene_polygons,
    tie_point_lonlat,
)
from blockqc.errors import InputError

GEOD = Geod(ellps="WGS84")


def geodesic_km2(geom) -> float:
    return abs(GEOD.geometry_area_perimeter(shapely.segmentize(geom, 0.001))[0]) / 1e6


def scenes_frame(footprint, boxes, dates, band="pan"):
    return pd.DataFrame(
        {
            "scene_id": [f"S{i}" for i in range(len(boxes))],
            "band": band,
            "acquired": pd.to_datetime(dates),
            "lines": 1000,
            "samples": 2000,
            "footprint_wkt": [footprint(*b) for b in boxes],
        }
    )


def test_three_scenes(footprint):
    boxes = [(40.0, 39.0, 40.4, 39.3), (40.3, 39.0, 40.7, 39.3), (40.2, 39.2, 40.5, 39.5)]
    sc = scenes_frame(footprint, boxes, ["2023-01-01", "2023-01-01", "2023-02-10"])
    ms = sc.assign(scene_id=sc["scene_id"] + "m", band="ms")
    f = footprint_factors(pd.concat([sc, ms], ignore_index=True))
    polys = [shapely.box(*b) for b in boxes]
    union = shapely.union_all(polys)
    pairs = [shapely.intersection(polys[i], polys[j]) for i, j in ((0, 1), (0, 2), (1, 2))]
    seen_twice = shapely.union_all(pairs)
    assert f.images_number == 3  # PAN only by default
    assert f.covered_area_km2 == pytest.approx(geodesic_km2(union), rel=1e-4)
    assert f.overlap_degree == pytest.approx(
        geodesic_km2(seen_twice) / geodesic_km2(union), rel=1e-4
    )
    assert f.overlap_pairwise_sum == pytest.approx(
        sum(geodesic_km2(p) for p in pairs) / geodesic_km2(union), rel=1e-4
    )
    assert f.overlap_pairwise_sum > f.overlap_degree  # a corner is seen three times
    assert f.overlapping_pairs == 3 and f.footprint_units == 3
    assert f.images_periods == 2
    assert footprint_factors(pd.concat([sc, ms]), band="all").images_number == 6


def test_single_scene_and_touching_scenes(footprint):
    one = footprint_factors(scenes_frame(footprint, [(5.0, 44.0, 5.5, 44.5)], ["2020-06-01"]))
    assert one.overlap_degree == 0.0 and one.overlapping_pairs == 0 and one.images_number == 1
    touch = footprint_factors(
        scenes_frame(
            footprint, [(5.0, 44.0, 5.5, 44.5), (5.5, 44.0, 6.0, 44.5)], ["2020-06-01"] * 2
        )
    )
    assert touch.overlap_degree == 0.0 and touch.overlapping_pairs == 0


def test_periods_reading():
    dates = pd.Series(
        pd.to_datetime(
            ["2023-01-01", "2023-01-01", "2023-01-03", "2023-01-20", "2023-03-01", "2023-03-02"]
        )
    )
    assert acquisition_periods(dates)[0] == 5
    n, labels = acquisition_periods(dates, gap_days=2)
    assert n == 3
    assert labels == ["2023-01-01..2023-01-03", "2023-01-20", "2023-03-01..2023-03-02"]
    assert acquisition_periods(dates, gap_days=60)[0] == 1


def test_bad_footprint_is_named(footprint):
    sc = scenes_frame(footprint, [(5.0, 44.0, 5.5, 44.5)] * 2, ["2020-06-01"] * 2)
    sc.loc[1, "footprint_wkt"] = "POLYGON ((5 44, 5.5 44"
    with pytest.raises(InputError) as err:
        scene_polygons(sc)
    assert [(p.row, p.column) for p in err.value.problems] == [(2, "footprint_wkt")]


def test_no_scene_of_the_band(footprint):
    sc = scenes_frame(footprint, [(5.0, 44.0, 5.5, 44.5)], ["2020-06-01"], band="ms")
    with pytest.raises(InputError, match="band 'pan'"):
        footprint_factors(sc)


def test_tie_point_positions_from_corners(footprint):
    # a rotated footprint: corners NW, NE, SE, SW moved so that bilinear weights matter
    wkt = "POLYGON ((10 50, 11 50.2, 11.1 49.5, 10.05 49.4, 10 50))"
    sc = pd.DataFrame(
        {
            "scene_id": ["A"],
            "band": ["pan"],
            "acquired": ["2021-01-01"],
            "lines": [1000],
            "samples": [2000],
            "footprint_wkt": [wkt],
        }
    )
    tp = pd.DataFrame(
        {
            "point_id": ["p1", "p2", "p3", "p3"],
            "scene_id": ["A"] * 4,
            "line": [0.0, 1000.0, 500.0, 500.0],
            "sample": [2000.0, 0.0, 1000.0, 1000.0],
            "v_line": 0.0,
            "v_sample": 0.0,
        }
    )
    pos = tie_point_lonlat(tp, sc).set_index("point_id")
    assert tuple(pos.loc["p1"]) == pytest.approx((11.0, 50.2))
    assert tuple(pos.loc["p2"]) == pytest.approx((10.05, 49.4))
    # image centre = mean of the four corners under bilinear interpolation
    assert tuple(pos.loc["p3"]) == pytest.approx(
        ((10 + 11 + 11.1 + 10.05) / 4, (50 + 50.2 + 49.5 + 49.4) / 4)
    )
    assert len(pos) == 3


def test_tie_point_positions_given_and_averaged_across_180():
    tp = pd.DataFrame(
        {
            "point_id": ["a", "a", "b"],
            "scene_id": "S",
            "line": 0.0,
            "sample": 0.0,
            "v_line": 0.0,
            "v_sample": 0.0,
            "lon": [179.9, -179.9, 3.0],
            "lat": [10.0, 10.2, 4.0],
        }
    )
    pos = tie_point_lonlat(tp, pd.DataFrame()).set_index("point_id")
    assert abs(pos.loc["a", "lon"]) == pytest.approx(180.0)
    assert pos.loc["a", "lat"] == pytest.approx(10.1)
    assert tuple(pos.loc["b"]) == (3.0, 4.0)
    assert np.isfinite(pos.to_numpy(float)).all()


def test_stereo_pairs_are_one_unit(footprint):
    """Forward and backward views of one acquisition do not overlap each other (§AF-7 reading):
    a single stereo pair has overlap degree 0, as row 12 of the published table."""
    a, b = (40.0, 39.0, 40.4, 39.3), (40.2, 39.0, 40.6, 39.3)
    a_back = (40.01, 39.0, 40.41, 39.3)  # the backward view, shifted a little
    pair = footprint_factors(scenes_frame(footprint, [a, a_back], ["2023-01-01"] * 2))
    assert pair.footprint_units == 1 and pair.overlap_degree == 0.0 and pair.images_number == 2
    two = footprint_factors(
        scenes_frame(footprint, [a, a_back, b, b], ["2023-01-01"] * 2 + ["2023-02-01"] * 2)
    )
    assert two.footprint_units == 2 and two.images_number == 4
    union = shapely.union_all([shapely.box(*a), shapely.box(*a_back), shapely.box(*b)])
    common = shapely.intersection(
        shapely.union_all([shapely.box(*a), shapely.box(*a_back)]), shapely.box(*b)
    )
    assert two.overlap_degree == pytest.approx(geodesic_km2(common) / geodesic_km2(union), rel=1e-4)
    # the same ground on another day is another image
    repeat = footprint_factors(scenes_frame(footprint, [a, a], ["2023-01-01", "2023-03-01"]))
    assert repeat.footprint_units == 2 and repeat.overlap_degree == pytest.approx(1.0)
    # grouping can be made stricter than the shift between the views
    strict = footprint_factors(
        scenes_frame(footprint, [a, a_back], ["2023-01-01"] * 2), stereo_iou=0.99
    )
    assert strict.footprint_units == 2 and strict.overlap_degree > 0.9


def test_identical_footprints_are_one_unit_at_stereo_iou_one():
    """The bound is included: two views of one footprint (intersection over union 1) are one unit
    at --stereo-iou 1. The areas' rounding made the ratio of this footprint 1 − 2e-16, two
    units, and an overlap degree of 1 for a single stereo pair."""
    wkt = (
        "POLYGON((40.137376 39.714500, 40.266579 39.724953, 40.280159 39.625500, "
        "40.150956 39.615047, 40.137376 39.714500))"
    )
    sc = pd.DataFrame(
        {
            "scene_id": ["F", "B"],
            "band": "pan",
            "acquired": pd.to_datetime(["2021-04-11"] * 2),
            "lines": 13915,
            "samples": 13915,
            "footprint_wkt": [wkt, wkt],
        }
    )
    f = footprint_factors(sc, stereo_iou=1.0)
    assert f.footprint_units == 1 and f.images_number == 2
    assert f.overlap_degree == 0.0 and f.overlapping_pairs == 0
