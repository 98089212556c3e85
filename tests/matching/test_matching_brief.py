"""BRIEF descriptors and Hamming matching (§RA-3)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from blockqc.matching.brief import (
    N_BITS,
    brief_descriptors,
    brief_pattern,
    hamming,
    match_brief,
    smooth_for_brief,
)


def slow_brief(smoothed: np.ndarray, row: int, col: int, pattern: np.ndarray) -> np.ndarray:
    """One descriptor the long way: one comparison per pair, bits packed by hand, MSB first."""
    out = np.zeros(N_BITS // 8, dtype=np.uint8)
    for i, (dr1, dc1, dr2, dc2) in enumerate(pattern.tolist()):
        if smoothed[row + dr1, col + dc1] < smoothed[row + dr2, col + dc2]:
            out[i // 8] |= 1 << (7 - i % 8)
    return out


def test_pattern_is_fixed_and_inside_the_patch():
    a = brief_pattern(48, 512)
    assert a.shape == (512, 4)
    assert np.array_equal(a, brief_pattern(48, 512))
    assert np.abs(a).max() <= 24
    assert not np.array_equal(a, brief_pattern(48, 513))
    # Gaussian pattern N(0, S²/25): standard deviation S/5 = 9.6 px, clipping only trims tails.
    assert 8.5 < a.std() < 10.5


def test_descriptor_has_512_bits_and_matches_slow_reference(forest):
    smoothed = smooth_for_brief(forest, 2.0)
    pattern = brief_pattern(48, 512)
    points = np.array([[30, 30], [100, 57], [128, 128], [200, 225], [225, 31]])
    desc = brief_descriptors(smoothed, points, pattern)
    assert desc.shape == (5, 64) and desc.dtype == np.uint8
    assert np.unpackbits(desc, axis=1).shape[1] == 512
    for k, (r, c) in enumerate(points):
        assert np.array_equal(desc[k], slow_brief(smoothed, r, c, pattern))


def test_same_patch_gives_distance_zero(forest, city):
    pattern = brief_pattern(48, 512)
    points = np.array([[60, 60], [120, 180], [190, 90]])
    a = brief_descriptors(smooth_for_brief(forest, 2.0), points, pattern)
    # The same patch elsewhere: paste the forest into a larger canvas of city pixels.
    canvas = np.tile(city, (2, 2))
    canvas[40:296, 70:326] = forest
    b = brief_descriptors(smooth_for_brief(canvas, 2.0), points + [40, 70], pattern)
    assert np.array_equal(hamming(a, b), [0, 0, 0])
    # Different patches differ in about half of the bits.
    other = brief_descriptors(smooth_for_brief(city, 2.0), points, pattern)
    assert (hamming(a, other) > 100).all()


descriptor = arrays(np.uint8, (64,))


@given(descriptor, descriptor)
@settings(max_examples=50, deadline=None)
def test_hamming_equals_direct_bit_count(a, b):
    expected = (int.from_bytes(a.tobytes(), "big") ^ int.from_bytes(b.tobytes(), "big")).bit_count()
    assert hamming(a, b) == expected
    assert hamming(a[None], b[None])[0] == expected


@given(st.integers(0, 10_000))
@settings(max_examples=20, deadline=None)
def test_match_brief_mutual_ratio_and_window(seed):
    rng = np.random.default_rng(seed)
    n = 30
    desc_img = rng.integers(0, 256, (n, 64), dtype=np.uint8)
    pos_img = rng.uniform(0, 1000, (n, 2))
    # The reference holds the same corners, slightly noisy descriptors, within the window,
    # plus unrelated distractors.
    flip = (rng.random((n, 512)) < 0.05).astype(np.uint8)
    desc_true = desc_img ^ np.packbits(flip, axis=1)
    pos_true = pos_img + rng.uniform(-3, 3, (n, 2))
    desc_far = desc_img.copy()  # identical descriptors but outside the search window
    pos_far = pos_img + 40.0
    distractors = rng.integers(0, 256, (n, 64), dtype=np.uint8)
    pos_distr = pos_img + rng.uniform(-5, 5, (n, 2))
    desc_ref = np.concatenate([desc_true, desc_far, distractors])
    pos_ref = np.concatenate([pos_true, pos_far, pos_distr])
    i, j, d = match_brief(
        desc_img, pos_img, desc_ref, pos_ref, radius=8, max_distance=128, ratio=0.9
    )
    assert np.array_equal(np.sort(i), np.arange(n))
    assert np.array_equal(j, i)  # every accepted match is the planted one
    assert np.array_equal(d, hamming(desc_img[i], desc_true[i]))
