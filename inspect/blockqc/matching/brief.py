"""512-bit BRIEF descriptors and Hamming matching, vectorized over keypoints (§RA-3).

BRIEF (Calonder et al., ECCV 2010): smooth the image, compare the intensities of 512 fixed point
pairs drawn in a patch around the keypoint, one bit per pair. The pairs follow the paper's
isotropic Gaussian pattern (G II): both points ~ N(0, S²/25), S the patch side, clipped to the
patch. OpenCV's headless build has no BRIEF extractor, hence this implementation.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np
from scipy.spatial import cKDTree

N_BITS = 512
_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.uint8)


@lru_cache(maxsize=16)
def brief_pattern(patch: int, seed: int) -> np.ndarray:
    """Return the fixed (512, 4) int offsets (dr1, dc1, dr2, dc2) of the BRIEF point pairs."""
    rng = np.random.default_rng(seed)
    half = patch // 2
    offsets = np.rint(rng.normal(0.0, patch / 5.0, size=(N_BITS, 4)))
    pattern = np.clip(offsets, -half, half).astype(np.int64)
    pattern.setflags(write=False)
    return pattern


def smooth_for_brief(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing applied before the BRIEF tests (9x9 kernel at sigma 2 in the paper)."""
    size = 2 * int(np.ceil(2 * sigma)) + 1
    return cv2.GaussianBlur(np.asarray(image, dtype=np.float32), (size, size), sigma)


def brief_descriptors(smoothed: np.ndarray, points: np.ndarray, pattern: np.ndarray) -> np.ndarray:
    """Return (n, 64) uint8 packed 512-bit descriptors of the (row, col) `points`.

    Bit i is 1 when smoothed[p + (dr1, dc1)] < smoothed[p + (dr2, dc2)]; bits are packed
    big-endian (np.packbits). Points must lie at least patch/2 pixels from the border.
    """
    points = np.asarray(points, dtype=np.int64).reshape(-1, 2)
    r = points[:, :1]
    c = points[:, 1:]
    first = smoothed[r + pattern[:, 0], c + pattern[:, 1]]
    second = smoothed[r + pattern[:, 2], c + pattern[:, 3]]
    return np.packbits(first < second, axis=1)


def hamming(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamming distance between packed descriptors (broadcasting over leading axes)."""
    return _POPCOUNT[np.bitwise_xor(a, b)].sum(axis=-1, dtype=np.int64)


def match_brief(
    desc_img: np.ndarray,
    pos_img: np.ndarray,
    desc_ref: np.ndarray,
    pos_ref: np.ndarray,
    *,
    radius: float,
    max_distance: int,
    ratio: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Match descriptors within a search window: mutual nearest, ratio test, distance cap.

    `pos_ref` is expressed in image coordinates (expected offset removed), so a reference corner
    is a candidate for an image corner when both coordinates differ by at most `radius`.
    Returns indices into the image corners, into the reference corners, and the distances.
    """
    empty = np.empty(0, dtype=np.int64)
    if len(pos_img) == 0 or len(pos_ref) == 0:
        return empty, empty, empty
    tree_img = cKDTree(np.asarray(pos_img, dtype=np.float64))
    tree_ref = cKDTree(np.asarray(pos_ref, dtype=np.float64))
    pairs = tree_img.sparse_distance_matrix(tree_ref, radius, p=np.inf, output_type="ndarray")
    if pairs.size == 0:
        return empty, empty, empty
    i = pairs["i"].astype(np.int64)
    j = pairs["j"].astype(np.int64)
    d = hamming(desc_img[i], desc_ref[j])
    order = np.lexsort((d, i))  # by image corner, then distance
    i, j, d = i[order], j[order], d[order]
    best_i, best_j, best_d, best_second = _best_two_per_image_corner(i, j, d)
    # Mutual check: the image corner must also be the best candidate of its reference corner.
    best_of_ref = _best_per_reference_corner(i, j, d, len(pos_ref))
    keep = (
        (best_of_ref[best_j] == best_i)
        & (best_d <= max_distance)
        & ((best_second == np.iinfo(np.int64).max) | (best_d < ratio * best_second))
    )
    return best_i[keep], best_j[keep], best_d[keep]


def _best_two_per_image_corner(
    i: np.ndarray, j: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Best and second-best candidate per image corner, of candidate pairs (image corner `i`,
    reference corner `j`, distance `d`) sorted by image corner then distance: the image corner,
    its best reference corner, their distance, and the second-best distance (the int64 maximum
    when the corner has a single candidate)."""
    first = np.ones(i.size, dtype=bool)
    first[1:] = i[1:] != i[:-1]
    has_second = np.zeros(i.size, dtype=bool)
    has_second[:-1] = first[:-1] & ~first[1:]
    second_d = np.full(i.size, np.iinfo(np.int64).max)
    second_d[:-1] = np.where(has_second[:-1], d[1:], second_d[:-1])
    return i[first], j[first], d[first], second_d[first]


def _best_per_reference_corner(
    i: np.ndarray, j: np.ndarray, d: np.ndarray, n_ref: int
) -> np.ndarray:
    """For each of the `n_ref` reference corners, the image corner of its best candidate pair
    (-1 for none), ties going to the pair first in the order given."""
    order_j = np.lexsort((d, j))
    jj = j[order_j]
    first_j = np.ones(jj.size, dtype=bool)
    first_j[1:] = jj[1:] != jj[:-1]
    best_of_ref = np.full(n_ref, -1, dtype=np.int64)
    best_of_ref[jj[first_j]] = i[order_j][first_j]
    return best_of_ref
