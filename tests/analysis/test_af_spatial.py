"""Clark–Evans R (§AF-10): random ≈ 1, square lattice ≈ 2, clustered ≪ 1; unit-free."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import CRS, Transformer

from blockqc.analysis.factors import tie_point_factors
from blockqc.analysis.footprints import equal_area_crs
from blockqc.spatial import clark_evans, mean_nearest_neighbour_distance


def test_uniform_random_is_about_one():
    rng = np.random.default_rng(7)
    n, side = 20_000, 5000.0
    x, y = rng.uniform(0, side, n), rng.uniform(0, side, n)
    raw = clark_evans(x, y, side**2)
    corrected = clark_evans(x, y, side**2, perimeter=4 * side)
    # standard error of R for a Poisson pattern: 0.26136 / √(n·ρ) / (0.5/√ρ) ≈ 0.0037 here;
    # without correction the edge effect adds about 0.0514·P / (0.5·√(A·n)) = +0.003
    assert raw == pytest.approx(1.0, abs=0.02)
    assert corrected == pytest.approx(1.0, abs=0.015)
    assert corrected < raw


def test_square_lattice_is_about_two():
    k, d = 60, 25.0
    yy, xx = np.mgrid[0:k, 0:k] * d
    # area of the lattice's cells: R = d / (0.5·d) = 2 exactly
    assert clark_evans(xx.ravel(), yy.ravel(), (k * d) ** 2) == pytest.approx(2.0, abs=1e-12)
    # area of the bounding box of the points: a little denser, still > 1.9
    assert clark_evans(xx.ravel(), yy.ravel(), ((k - 1) * d) ** 2) > 1.9


def test_clustered_is_small():
    rng = np.random.default_rng(11)
    centres = rng.uniform(0, 10_000, size=(40, 2))
    pts = np.repeat(centres, 100, axis=0) + rng.normal(0, 30.0, size=(4000, 2))
    assert clark_evans(pts[:, 0], pts[:, 1], 10_000.0**2) < 0.5


def test_hand_example():
    # four points on a 1×2 rectangle's corners in a 10×10 area: r̄ = 1, expected 0.5·√(100/4)
    x, y = np.array([0.0, 1.0, 0.0, 1.0]), np.array([0.0, 0.0, 2.0, 2.0])
    assert mean_nearest_neighbour_distance(x, y) == 1.0
    assert clark_evans(x, y, 100.0) == pytest.approx(1.0 / 2.5)


def test_degenerate_inputs():
    assert math.isnan(clark_evans(np.array([1.0]), np.array([2.0]), 10.0))
    assert math.isnan(clark_evans(np.array([1.0, 2.0]), np.array([2.0, 3.0]), 0.0))
    # non-finite coordinates are dropped
    x = np.array([0.0, 1.0, np.nan, 0.0, 1.0])
    y = np.array([0.0, 0.0, 5.0, 2.0, 2.0])
    assert clark_evans(x, y, 100.0) == pytest.approx(0.4)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    scale=st.floats(min_value=1e-3, max_value=1e4),
    dx=st.floats(min_value=-1e5, max_value=1e5),
)
def test_unit_free(seed, scale, dx):
    """Same R in metres or pixels: scaling coordinates by s and the area by s² changes nothing;
    neither do translation and point order."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0, 100, 300), rng.uniform(0, 100, 300)
    base = clark_evans(x, y, 1e4)
    order = rng.permutation(300)
    moved = clark_evans(x[order] * scale + dx, y[order] * scale, 1e4 * scale**2)
    assert moved == pytest.approx(base, rel=1e-6)


def test_tie_point_factors_measure_in_metres():
    """A square lattice of tie points, square in metres at 60° N (so not in degrees): R = 2."""
    k, d = 40, 500.0
    laea = equal_area_crs(10.0, 60.0)
    to_ll = Transformer.from_crs(laea, CRS.from_epsg(4326), always_xy=True)
    gx, gy = np.meshgrid((np.arange(k) - k / 2 + 0.5) * d, (np.arange(k) - k / 2 + 0.5) * d)
    lon, lat = to_ll.transform(gx.ravel(), gy.ravel())
    tp = pd.DataFrame(
        {
            "point_id": np.repeat([f"p{i}" for i in range(k * k)], 2),
            "scene_id": "S",
            "line": 0.0,
            "sample": 0.0,
            "v_line": 0.0,
            "v_sample": 0.0,
            "lon": np.repeat(lon, 2),
            "lat": np.repeat(lat, 2),
        }
    )
    to_m = Transformer.from_crs(CRS.from_epsg(4326), laea, always_xy=True)
    f = tie_point_factors(tp, pd.DataFrame(), (k * d) ** 2 / 1e6, to_m)
    assert f.tp_number == k * k  # points, not observations
    assert f.tp_density_per_km2 == pytest.approx(4.0)
    assert f.tp_nn_coefficient == pytest.approx(2.0, abs=1e-6)
