"""End to end: real crops warped by a known displacement are matched back (§RA-3)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from blockqc.errors import InputError
from blockqc.matching import COLUMNS, match_candidates, match_images

RFM_DATA = Path(__file__).resolve().parents[1] / "data" / "rfm" / "phr_ventoux"


def warped(reference: np.ndarray, shift: tuple[float, float], seed: int = 0) -> np.ndarray:
    """image(r, c) = reference(r + dr, c + dc), cubic spline, with a gain, an offset and noise."""
    moved = ndimage.shift(
        reference.astype(np.float64), (-shift[0], -shift[1]), order=3, mode="reflect"
    )
    noise = np.random.default_rng(seed).normal(0, 3.0, reference.shape)
    return (0.9 * moved + 40 + noise).astype(np.float32)


def rms_error(cps: pd.DataFrame, shift: tuple[float, float], offset=(0.0, 0.0)) -> float:
    dr = cps["ref_row"] - cps["row"] - offset[0] - shift[0]
    dc = cps["ref_col"] - cps["col"] - offset[1] - shift[1]
    return float(np.sqrt(np.mean(dr**2 + dc**2)))


@pytest.mark.parametrize("crop", ["forest", "city"])
def test_known_shift_is_recovered(crop, request):
    reference = request.getfixturevalue(crop)
    shift = (2.3, -1.6)
    cps = match_images(warped(reference, shift), reference, grid=128)
    assert list(cps.columns) == COLUMNS
    assert len(cps) == 4  # one CP in each of the 2x2 cells of 128 px
    assert not cps.duplicated(["cell_row", "cell_col"]).any()
    assert set(cps["kind"]) <= {"brief", "ncc"}
    assert rms_error(cps, shift) < 0.2
    everything = match_candidates(warped(reference, shift), reference, grid=128)
    assert len(everything) > 20 and rms_error(everything, shift) < 0.2


@given(st.floats(-6.0, 6.0), st.floats(-6.0, 6.0))
@settings(max_examples=8, deadline=None)
def test_any_shift_within_the_search_window_is_recovered(city, dr, dc):
    cps = match_candidates(warped(city, (dr, dc), seed=3), city, grid=128)
    assert len(cps) > 20
    assert rms_error(cps, (dr, dc)) < 0.2


def test_ncc_alone_when_no_brief_match_is_accepted(forest):
    shift = (-0.4, 1.3)
    cps = match_candidates(warped(forest, shift), forest, grid=128, max_hamming=0)
    assert len(cps) > 20 and (cps["kind"] == "ncc").all()
    assert rms_error(cps, shift) < 0.2
    assert (cps["score"] >= 0.7).all()


def test_offset_places_the_image_inside_a_larger_reference(forest):
    # The image covers reference rows 40..199 and columns 30..219, plus a sub-pixel shift.
    shift = (0.35, -0.6)
    image = warped(forest, shift)[40:200, 30:220]
    cps = match_candidates(image, forest, offset=(40.0, 30.0), grid=100)
    assert len(cps) > 10
    assert rms_error(cps, shift, offset=(40.0, 30.0)) < 0.2
    assert cps["row"].between(0, 159).all() and cps["col"].between(0, 189).all()


def test_no_cp_outside_the_valid_masks(forest):
    shift = (1.0, 1.0)
    image = warped(forest, shift)
    image_valid = np.ones(image.shape, dtype=bool)
    image_valid[:, 128:] = False  # right half outside the orthorectified footprint
    image[:, 128:] = np.nan
    cps = match_candidates(image, forest, image_valid=image_valid, grid=128)
    assert len(cps) > 5 and (cps["col"] < 128).all()
    assert rms_error(cps, shift) < 0.2
    reference_valid = np.ones(forest.shape, dtype=bool)
    reference_valid[:128] = False
    cps = match_candidates(
        image, forest, image_valid=image_valid, reference_valid=reference_valid, grid=128
    )
    assert (cps["ref_row"] >= 128).all()


def test_chunks_give_the_same_geometry(city):
    shift = (1.7, 2.2)
    image = warped(city, shift)
    whole = match_candidates(image, city, grid=64)
    chunked = match_candidates(image, city, grid=64, chunk=100)
    assert rms_error(chunked, shift) < 0.2
    # Chunking moves corners in and out of the per-cell selection but finds as many matches.
    assert len(chunked) > 0.8 * len(whole)


def test_unrelated_noise_gives_no_cp(forest):
    noise = np.random.default_rng(1).normal(600, 100, forest.shape).astype(np.float32)
    assert match_images(noise, forest, grid=128).empty


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"image": np.zeros((64, 64), np.float64)}, "same dtype"),
        ({"image": np.zeros((4, 64, 64), np.float32)}, "2-D"),
        (
            {"image": np.zeros((64, 64), np.uint16), "reference": np.zeros((64, 64), np.uint16)},
            "floating",
        ),
        ({"chunk": 15}, "chunk"),
        ({"grid": 0}, "grid"),
        ({"offset": (1.0,)}, "offset"),
        ({"image_valid": np.ones((10, 10), bool)}, "image_valid"),
        ({"template": 20}, "odd"),
        ({"search_radius": 0}, "search_radius"),
        ({"ransac_model": "homography"}, "ransac_model"),
        ({"no_such_setting": 1}, "unknown"),
    ],
)
def test_bad_arguments_raise_input_error(kwargs, fragment):
    args = {"image": np.zeros((64, 64), np.float32), "reference": np.zeros((64, 64), np.float32)}
    args.update(kwargs)
    with pytest.raises(InputError) as info:
        match_images(args.pop("image"), args.pop("reference"), **args)
    assert fragment in str(info.value)
    assert info.value.problems[0].file == "<arguments>"


def test_a_cell_the_reference_covers_in_part_keeps_its_cp(forest):
    """The reference has data only on a 100 px square inside one 256 px cell: the cell's
    corners are taken where the reference can hold their match, so the square gives the cell
    its CP (the 24 strongest corners of the whole cell, all off the square, gave none)."""
    shift = (0.4, -0.3)
    reference_valid = np.zeros(forest.shape, dtype=bool)
    reference_valid[78:178, 78:178] = True
    cps = match_images(warped(forest, shift), forest, reference_valid=reference_valid, grid=256)
    assert len(cps) == 1
    assert cps["ref_row"].between(78, 177).all() and cps["ref_col"].between(78, 177).all()
    assert rms_error(cps, shift) < 0.2


@pytest.mark.parametrize(
    ("setting", "fragment"),
    [
        ({"brief_seed": -1}, "brief_seed must be zero or a positive integer, got -1"),
        ({"ransac_seed": -3}, "ransac_seed must be zero or a positive integer, got -3"),
        ({"brief_seed": 1.5}, "brief_seed must be an integer, got 1.5"),
        ({"brief_sigma": float("nan")}, "brief_sigma must be a finite number, got nan"),
        ({"ncc_sigma": float("inf")}, "ncc_sigma must be a finite number, got inf"),
        ({"ransac_threshold": float("inf")}, "ransac_threshold must be a finite number"),
        ({"harris_k": float("nan")}, "harris_k must be a finite number, got nan"),
        ({"harris_ksize": 3.0}, "harris_ksize must be an integer, got 3.0"),
        ({"min_ncc": "0.7"}, "min_ncc must be a finite number, got '0.7'"),
        ({"corners_per_cell": True}, "corners_per_cell must be an integer, got True"),
    ],
)
def test_settings_of_the_wrong_kind_raise_input_error(forest, setting, fragment):
    """A seed numpy cannot take, a NaN or infinite number, a float where OpenCV needs an
    integer, a text for a number: InputError naming the setting, not a traceback from numpy or
    OpenCV mid-run, nor a run that silently finds nothing (NaN Harris k) or keeps every match
    (an infinite RANSAC threshold)."""
    with pytest.raises(InputError) as info:
        match_images(warped(forest, (0.4, -0.3)), forest, grid=128, **setting)
    assert info.value.problems[0].file == "<arguments>"
    assert fragment in info.value.problems[0].message


def test_numpy_integers_are_settings_like_any_integer(forest):
    image = warped(forest, (0.4, -0.3))
    given = match_images(
        image, forest, grid=128, search_radius=np.int64(8), brief_seed=np.int32(512)
    )
    assert given.equals(match_images(image, forest, grid=128))


def test_an_unrelated_reference_gives_no_cp():
    """The reference shows the ground 150 px away from the image's (a wrong georeferencing),
    far beyond the ±8 px search window: every match is wrong, and the 4 that agreed with one
    affine by chance were kept as CPs."""
    with rasterio.open(RFM_DATA / "left_image.tif") as ds:
        scene = ds.read(1).astype(np.float32)
    image, reference = scene[:300, :300].copy(), scene[150:450, 150:450].copy()
    for grid in (16, 64):
        assert match_images(image, reference, grid=grid).empty
