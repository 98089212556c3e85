"""Unit tests: UTM/UPS zone expectations, the expression evaluator, tie-point statistics."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.metrics.spatial_ref import (
    SpatialParams,
    expected_epsg,
    normalize_datum,
    normalize_height_datum,
    utm_zone,
)
from blockqc.metrics.tiepoints import _stats, tie_point_error_px
from blockqc.rfm.model import lon_extent
from blockqc.rules.expr import ExpressionError, evaluate

P = SpatialParams()


@pytest.mark.parametrize(
    ("lon", "zone"),
    [
        *[(-180.0, 1), (-177.0, 1), (-174.0, 2), (0.0, 31), (116.3, 50), (179.99, 60)],
        # beyond ±180°: round the globe
        *[(180.0, 60), (180.01, 1), (200.0, 4), (-185.0, 60), (-190.0, 59), (540.0, 1)],
    ],
)
def test_utm_zone(lon: float, zone: int) -> None:
    assert utm_zone(lon) == zone


def test_expected_epsg_north_south_straddle_and_polar() -> None:
    assert expected_epsg(116.2, 116.4, 39.8, 40.0, P) == [32650]
    assert expected_epsg(-47.1, -46.9, -23.6, -23.4, P) == [32723]  # São Paulo, zone 23S
    assert expected_epsg(119.5, 120.5, 29.9, 30.1, P) == [32650, 32651]  # straddles 120° E
    assert expected_epsg(10.0, 20.0, 84.9, 85.1, P) == [32661]  # UPS north
    assert expected_epsg(10.0, 20.0, -81.1, -80.9, P) == [32761]  # UPS south
    assert expected_epsg(10.0, 20.0, 83.8, 84.0, P) == [32632, 32633, 32634]


def test_the_projection_note_is_said_by_mb3_alone(tmp_path) -> None:
    """§MB-3 'report it': a straddled edge, or why the projection fails, is the note of MB-3's
    result (it was in the measurement only, so the report said nothing), and not repeated
    under the datum rules MB-1 and MB-2; a block plainly in its zone has none to say."""
    from blockqc.delivery import load_delivery
    from blockqc.engine import inspect_delivery
    from blockqc.rules import load_pack
    from blockqc.rules.casebase import write_delivery

    pack = load_pack("global-project")
    base = write_delivery(tmp_path / "delivery")  # 116.3 E in EPSG:32650, its zone
    got = {r.rule: r.detail for r in inspect_delivery(load_delivery(base), pack).results}
    for rule in ("MB-1", "MB-2", "MB-3"):
        assert "note" not in got[rule] and "projection_note" not in got[rule]
    yaml = base / "block.yaml"
    yaml.write_text(yaml.read_text("utf-8").replace("32650", "32651"), "utf-8")
    got = {r.rule: r.detail for r in inspect_delivery(load_delivery(base), pack).results}
    expected = "EPSG:32651 (UTM zone 51N) delivered, expected EPSG:32650 (UTM zone 50N)"
    assert got["MB-3"]["note"] == expected
    for rule in ("MB-1", "MB-2"):
        assert "note" not in got[rule] and "projection_note" not in got[rule]


def test_a_block_across_the_equator_may_use_either_hemisphere() -> None:
    """0.2 S…0.1 N at 36.5…37.0 E: zone 37 north or south; wholly south, 37S only."""
    assert expected_epsg(36.5, 37.0, -0.2, 0.1, P) == [32637, 32737]
    assert expected_epsg(36.5, 37.0, -0.5, -0.2, P) == [32737]
    assert expected_epsg(36.5, 37.0, 0.0, 0.3, P) == [32637]  # on the equator: north


def test_a_block_across_180_degrees_is_in_zones_60_and_1() -> None:
    """Fiji: footprints from 179.8°E to 179.6°W; the plain mean of the bounds (0.1°) would ask
    for zone 31 and the zones between."""
    west, east = lon_extent(np.array([179.8, 179.9, -179.9, -179.6]))
    assert (west, east) == pytest.approx((179.8, 180.4))
    assert expected_epsg(west, east, -17.9, -17.7, P) == [32701, 32760]
    assert expected_epsg(*lon_extent(np.array([178.0, 179.5])), -17.9, -17.7, P) == [32760]
    assert expected_epsg(*lon_extent(np.array([-179.5, -178.0])), -17.9, -17.7, P) == [32701]


def test_a_block_across_180_degrees_is_judged_on_its_own_zone() -> None:
    from types import SimpleNamespace

    from blockqc.metrics.spatial_ref import spatial_reference

    def judged(epsg: int) -> pd.Series:
        sr = SimpleNamespace(epsg=epsg, geodetic_datum="WGS84", height_datum="EGM96")
        sr.projection = "UTM"
        footprints = [
            "POLYGON((179.80 -18, 179.95 -18, 179.95 -17.8, 179.80 -17.8, 179.80 -18))",
            "POLYGON((179.90 -18, -179.9 -18, -179.9 -17.8, 179.90 -17.8, 179.90 -18))",
        ]
        d = SimpleNamespace(
            manifest=SimpleNamespace(spatial_reference=sr),
            scenes=pd.DataFrame({"footprint_wkt": footprints}),
        )
        m = spatial_reference(d, P, None)
        return m.tables["block"].df.iloc[0], m.detail

    for epsg in (32760, 32701):
        block, detail = judged(epsg)
        assert block["projection_ok"], detail["note"]
    assert detail["extent_lonlat"] == [179.8, -18.0, -179.9, -17.8]  # west > east: across 180°
    assert detail["centre_lon"] == pytest.approx(179.95)
    block, detail = judged(32730)  # the Greenwich zone, half the globe away
    assert not block["projection_ok"]
    assert detail["expected_epsg"] == [32701, 32760]


@settings(max_examples=300, deadline=None)
@given(
    west=st.floats(-180.0, 179.999),
    span=st.floats(0.0, 179.0),
    at=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=30),
)
def test_lon_extent_is_the_shortest_arc_holding_every_longitude(west, span, at) -> None:
    """Longitudes drawn on an arc of less than 180° from `west`, written in −180…180: the
    extent found lies on that arc, holds every one, and is no longer than the arc."""
    on_arc = west + span * np.array(at)
    written = (on_arc + 180.0) % 360.0 - 180.0
    lo, hi = lon_extent(written)
    assert hi - lo <= span + 1e-9
    assert lo >= -180.0 and hi < lo + 180.0
    assert np.all((written - lo) % 360.0 <= (hi - lo) + 1e-9)
    assert (lo - on_arc.min() + 1e-9) % 360.0 <= 2e-9


def test_datum_names() -> None:
    for name in ("WGS84", "WGS 84", "wgs-84", "EPSG:4326", "WGS_1984"):
        assert normalize_datum(name) == "WGS84"
    assert normalize_datum("CGCS2000") == "CGCS2000"
    # §MB-1: WGS 84 with its realization, or followed by 'coordinate system' in Chinese, is
    # WGS 84 (it failed MB-1, an A-class error, where 'G1762' alone passed)
    for name in (
        "WGS 84 (G1762)",
        "WGS84 (G2139)",
        "WGS-84 G1674",
        "WGS-84坐标系",
        "WGS84 大地坐标系",
    ):
        assert normalize_datum(name) == "WGS84", name
    for name in ("CGCS2000 坐标系", "ITRF2014", "PZ-90 (G1762)", "Beijing 1954"):
        assert normalize_datum(name) != "WGS84", name
    assert normalize_height_datum("WGS84 ellipsoid") == "ellipsoidal"
    # §MB-2's own words, and the pack's zh title (椭球高（大地高）): ellipsoidal heights, not a
    # failure of MB-2 as an unknown height datum
    for name in (
        "geodetic height",
        "ellipsoid height",
        "WGS84 ellipsoidal height",
        "WGS 84 geodetic heights",
        "大地高",
        "椭球高",
        "WGS-84 大地高",
    ):
        assert normalize_height_datum(name) == "ellipsoidal", name
    for name in ("CGCS2000 ellipsoidal height", "EGM96 height", "正常高", "orthometric height"):
        assert normalize_height_datum(name) != "ellipsoidal", name
    assert normalize_height_datum("egm2008") == "EGM2008"


def test_expressions() -> None:
    c = {"norm": {"plane_m": 10, "height_m": 6}, "k": [1, 2]}
    assert evaluate("2*sqrt(2)*norm.plane_m", c) == pytest.approx(20 * math.sqrt(2))
    assert evaluate("max(norm.plane_m, 12) - -1", c) == 13.0
    assert evaluate("k", c) == [1.0, 2.0]
    for bad, msg in [
        ("open('x')", "not allowed"),
        ("norm.missing", "unknown constant"),
        ("norm.__class__", "unknown constant"),
        ("(1).real", "not allowed"),
        ("1 if 1 else 0", "not allowed"),
        ("1/0", "cannot evaluate"),
        ("10.0**1000", "cannot evaluate"),
        ("2 +", "malformed"),
    ]:
        with pytest.raises(ExpressionError, match=msg):
            evaluate(bad, c)


@settings(max_examples=100, deadline=None)
@given(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.floats(0.001, 1e3))
def test_expression_arithmetic_matches_python(a: float, b: float, c: float) -> None:
    consts = {"a": a, "b": b, "c": c}
    assert evaluate("a + b * c - a / c", consts) == pytest.approx(
        a + b * c - a / c, rel=1e-12, abs=1e-9
    )
    assert evaluate("sqrt(abs(a)) + min(a, b)", consts) == pytest.approx(
        math.sqrt(abs(a)) + min(a, b), rel=1e-12, abs=1e-12
    )


def test_tie_point_statistics_by_hand() -> None:
    err = pd.Series(
        tie_point_error_px(np.array([0.3, 0.6, 0.0, 1.2, 0.9]), np.array([0.4, 0.8, 1.0, 0.9, 1.2]))
    )
    # errors 0.5, 1.0, 1.0, 1.5, 1.5: median 1.0, RMS √(6.75/5), in (1.0, 1.5]: two of five
    s = _stats(err, None, 1.0, 1.5).iloc[0]
    assert s["median"] == pytest.approx(1.0)
    assert s["rms"] == pytest.approx(math.sqrt((0.25 + 1 + 1 + 2.25 + 2.25) / 5))
    assert s["max"] == pytest.approx(1.5)
    assert s["share_in_interval"] == pytest.approx(40.0)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e15, 1e15), st.floats(-1e15, 1e15)), max_size=50))
def test_tie_point_error_is_the_formula_as_written(v) -> None:
    # √(v_l² + v_s²) in IEEE arithmetic, one observation at a time (Python's own floats)
    vl, vs = np.array([a for a, _ in v]), np.array([b for _, b in v])
    expected = [math.sqrt(a * a + b * b) for a, b in v]
    assert tie_point_error_px(vl, vs).tolist() == expected
    out = np.full(len(v), -1.0)
    assert tie_point_error_px(vl, vs, out=out) is out and out.tolist() == expected


def test_tie_point_error_of_squares_that_overflow() -> None:
    # 3e200² overflows: the magnitude is still 5e200 (np.hypot), not inf
    err = tie_point_error_px(np.array([3e200, 0.3]), np.array([4e200, 0.4]))
    assert err.tolist() == pytest.approx([5e200, 0.5], rel=1e-15)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-2, 2), st.floats(-2, 2)), min_size=1, max_size=200),
    st.randoms(use_true_random=False),
    st.floats(0.1, 10),
)
def test_tie_point_statistics_properties(v, rnd, k) -> None:
    vl, vs = (np.array(x) for x in zip(*v, strict=True))
    base = _stats(pd.Series(tie_point_error_px(vl, vs)), None, 1.0, 1.5).iloc[0]
    order = np.arange(len(vl))
    rnd.shuffle(order)
    shuffled = _stats(pd.Series(tie_point_error_px(vl[order], vs[order])), None, 1.0, 1.5).iloc[0]
    scaled = _stats(pd.Series(tie_point_error_px(k * vl, k * vs)), None, 1.0, 1.5).iloc[0]
    for col in ("median", "rms", "max", "share_in_interval"):
        assert shuffled[col] == pytest.approx(base[col], rel=1e-12, abs=1e-12)
    for col in ("median", "rms", "max", "mean"):
        assert scaled[col] == pytest.approx(k * base[col], rel=1e-9, abs=1e-12)
    assert base["median"] <= base["max"] and base["rms"] <= base["max"] + 1e-12


def test_a_value_differing_only_by_case_is_suggested_before_a_near_one() -> None:
    """gf7-1010000-f meant GF7-1010000-F, not -M (closer by difflib's ratio, case counted)."""
    from blockqc.schema import did_you_mean

    hint = did_you_mean(["GF7-1010000-M", "GF7-1010000-F", "GF7-1010000-B"])
    assert hint("gf7-1010000-f") == "; did you mean 'GF7-1010000-F'?"
    assert hint("GF7-1010000-X") == "; did you mean 'GF7-1010000-M'?"
    assert did_you_mean(["DOC-1", "DOC-3"])("doc-3") == "; did you mean 'DOC-3'?"
    assert did_you_mean(["DOC-1"])("TP-9") == ""


def test_the_worst_of_units_between_two_bounds_is_the_farthest_outside_them() -> None:
    """threshold {min: 280, max: 400} on per-scene counts: the worst is the count farthest
    beyond either bound (271, 9 below; 277 was reported, as if only a maximum were set)."""
    from blockqc.engine import _order, worst
    from blockqc.rules.model import Threshold

    th = Threshold(min=280, max=400)
    counts = pd.Series([277, 271, 300, 405], index=[10, 11, 12, 13])  # ints, not from 0
    ok = np.array([False, False, True, False])
    assert worst(counts, ok, th, 280.0, 400.0) == 271  # 9 below, against 405: 5 above
    assert worst(counts.iloc[[0, 3]], ok[[0, 3]], th, 280.0, 400.0) == 405  # 5 above, 3 below
    assert worst(counts.iloc[[2]], ok[[2]], th, 280.0, 400.0) == 300  # all pass: the nearest
    frame = pd.DataFrame({"n_points": counts})
    ordered = _order(frame, "n_points", None, 280.0, 400.0)["n_points"].tolist()
    assert ordered == [271, 405, 277, 300]
    assert worst(counts, ok, Threshold(min=280), 280.0, None) == 271
    assert worst(counts, ok, Threshold(max=400), None, 400.0) == 405


def test_a_filter_of_text_on_a_true_false_or_number_column_is_refused() -> None:
    """where: {gross: "no"} selected no row, silently (the rule then not applicable, or its
    evidence empty); a text value against true/false or numbers is now the rule's error."""
    from blockqc.engine import _filter

    df = pd.DataFrame({"gross": [True, False], "n": [1.0, 2.0], "component": ["plane", "h"]})
    for where, kind in (({"gross": "no"}, "true/false"), ({"n": "2"}, "numbers")):
        with pytest.raises(ValueError, match=f"selects nothing: the column .* holds {kind}"):
            _filter(df, where)
    assert _filter(df, {"gross": False})["n"].tolist() == [2.0]
    assert _filter(df, {"gross": 0})["n"].tolist() == [2.0]  # as pandas compares
    assert _filter(df, {"component": "plane", "n": 1})["n"].tolist() == [1.0]


def test_yaml_merge_keys_are_overridden_by_keys_of_their_own(tmp_path) -> None:
    """`<<: *base` then `id: PR-2` (standard YAML) was refused as a duplicate key 'id'; a key
    written twice in one mapping still is."""
    from blockqc.errors import InputError
    from blockqc.yamlio import load_yaml

    path = tmp_path / "merge.yaml"
    path.write_text(
        "rules:\n  - &base {id: PR-1, unit: points, threshold: {min: 280}}\n"
        "  - <<: *base\n    id: PR-2\n    threshold: {min: 250}\n",
        encoding="utf-8",
    )
    first, second = load_yaml(path)["rules"]
    assert second == {"id": "PR-2", "unit": "points", "threshold": {"min": 250}}
    assert first["id"] == "PR-1" and second.key_lines["id"] == 4
    path.write_text("a: 1\nb: 2\na: 3\n", encoding="utf-8")
    with pytest.raises(InputError, match="duplicate key 'a' \\(first on line 1\\)"):
        load_yaml(path)
