"""Batched fast NCC and its sub-pixel peak (§RA-3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from blockqc.matching.ncc import extract_patches, ncc_search, ncc_surfaces, subpixel_peak


def test_ncc_surfaces_equal_direct_correlation_coefficients():
    rng = np.random.default_rng(3)
    templates = rng.normal(size=(4, 7, 7))
    windows = rng.normal(size=(4, 12, 12))
    windows[2, 3:10, 1:8] = 3.0 * templates[2] + 5.0  # a perfect match at lag (3, 1)
    got = ncc_surfaces(templates, windows)
    assert got.shape == (4, 6, 6)
    for k in range(4):
        for u in range(6):
            for v in range(6):
                sub = windows[k, u : u + 7, v : v + 7].ravel()
                expected = np.corrcoef(templates[k].ravel(), sub)[0, 1]
                assert got[k, u, v] == pytest.approx(expected, abs=1e-9)
    assert got[2, 3, 1] == pytest.approx(1.0)


def test_flat_window_or_template_gives_zero_not_nan():
    rng = np.random.default_rng(0)
    templates = np.stack([rng.normal(size=(5, 5)), np.full((5, 5), 600.0)])
    windows = np.stack([np.full((9, 9), 700.0), rng.normal(600, 50, (9, 9))])
    got = ncc_surfaces(templates, windows)
    assert np.isfinite(got).all() and (got == 0).all()


@given(st.floats(-0.49, 0.49), st.floats(-0.49, 0.49), st.floats(-0.4, 0.4))
@settings(max_examples=40, deadline=None)
def test_subpixel_peak_of_a_quadratic_is_exact(y0, x0, cross):
    # f = 1 - (x-x0)² - (y-y0)² + cross·(x-x0)(y-y0): a 2-D quadratic with its maximum at
    # (y0, x0) relative to the centre sample (2, 2); the 3×3 fit reproduces it exactly.
    yy, xx = np.mgrid[-2:3, -2:3].astype(float)
    f = 1 - (xx - x0) ** 2 - (yy - y0) ** 2 + cross * (xx - x0) * (yy - y0)
    pos, peak, inside = subpixel_peak(f[None])
    assert inside[0]
    assert pos[0] == pytest.approx([2 + y0, 2 + x0], abs=1e-9)
    assert peak[0] == f.max()


def test_peak_on_the_border_is_flagged():
    f = np.zeros((1, 5, 5))
    f[0, 0, 3] = 1.0
    _, _, inside = subpixel_peak(f)
    assert not inside[0]


def fourier_shifted(image: np.ndarray, shift: tuple[float, float]) -> np.ndarray:
    """out(r, c) = image(r + dr, c + dc), exactly for a periodic band-limited image."""
    spectrum = ndimage.fourier_shift(np.fft.fft2(image), (-shift[0], -shift[1]))
    return np.fft.ifft2(spectrum).real.astype(np.float32)


@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))
@example(dr=0.5, dc=0.5)
@example(dr=-0.5, dc=0.25)
@settings(max_examples=25, deadline=None)
def test_ncc_search_recovers_a_subpixel_shift_of_a_real_crop(forest, dr, dc):
    moved = fourier_shifted(forest, (dr, dc))  # moved(p) = forest(p + d): forest is the reference
    # The matcher smooths both chunks (ncc_sigma = 1 px) before the NCC; so does the test.
    image = ndimage.gaussian_filter(moved, 1.0)
    reference = ndimage.gaussian_filter(forest, 1.0)
    points = np.array([[r, c] for r in range(60, 200, 35) for c in range(60, 200, 35)])
    ref_pos, peak, inside = ncc_search(image, points, reference, points, half=10, radius=3)
    assert inside.all() and (peak > 0.9).all()
    err = ref_pos - points - [dr, dc]
    # The parabola through the NCC peak is biased by up to ~0.11 px at single weakly textured
    # points (a scan of 17 × 17 shifts over the half-pixel square: worst 0.109 px, RMS per shift
    # at most 0.031 px): every point within 0.15 px, the points together within 0.05 px RMS.
    assert np.abs(err).max() < 0.15
    assert np.sqrt(np.mean(err**2)) < 0.05


def test_extract_patches_are_the_slices():
    image = np.arange(100.0).reshape(10, 10)
    got = extract_patches(image, np.array([[3, 4], [5, 5]]), 2)
    assert np.array_equal(got[0], image[1:6, 2:7])
    assert np.array_equal(got[1], image[3:8, 3:8])


def test_flat_part_of_a_window_beside_texture_gives_zero_not_nan_or_one():
    # A reference whose empty part holds 0 without a declared no-data value: the sub-windows
    # over the zeros have no variance, but the integral images' rounding, from the bright
    # half, left a residue there that was divided by ~0 (NCC ±1 after clipping, or NaN).
    rng = np.random.default_rng(1)
    window = np.zeros((1, 61, 61))
    window[0, :, :30] = rng.uniform(800, 1200, (61, 30))
    template = rng.uniform(800, 1200, (1, 21, 21))
    with np.errstate(all="raise"):
        got = ncc_surfaces(template, window)
    assert np.isfinite(got).all()
    assert (got[0, :, 30:] == 0.0).all()  # lags whose sub-window lies on the zeros only
    sub = window[0, 5:26, 2:23].ravel()
    expected = np.corrcoef(template[0].ravel(), sub)[0, 1]
    assert got[0, 5, 2] == pytest.approx(expected, abs=1e-9)
