"""The §RA-3 matcher: Harris + 512-bit BRIEF, NCC for the corners left, RANSAC, one CP per cell.

The image and the reference are on the same CRS and resolution (§RA-2), so the geometry is
already close: matches are only sought within a small search window around the position the
geotransforms predict. The image is processed in chunks of B×B pixels; the reference chunk is the
one around the same geographic centre, enlarged by the search radius and the patch margins.
"""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd

from blockqc.errors import InputError, Problem
from blockqc.matching.brief import brief_descriptors, brief_pattern, match_brief, smooth_for_brief
from blockqc.matching.grid import COLUMNS, homogenize
from blockqc.matching.harris import harris_corners
from blockqc.matching.ncc import ncc_search
from blockqc.matching.ransac import ransac_inliers
from blockqc.matching.settings import MatchSettings, make_settings

CANDIDATE_COLUMNS = ["row", "col", "ref_row", "ref_col", "kind", "score"]


def match_images(
    image: np.ndarray,
    reference: np.ndarray,
    *,
    image_valid: np.ndarray | None = None,
    reference_valid: np.ndarray | None = None,
    offset: tuple[float, float] = (0.0, 0.0),
    chunk: int = 5000,
    grid: int = 400,
    **settings: object,
) -> pd.DataFrame:
    """Match `image` against `reference` per §RA-3 and keep one CP per `grid`×`grid` cell.

    image, reference: 2-D floating arrays of one dtype on the same CRS and resolution; the
    reference may be larger and shifted, `offset` being the expected (ref_row − row,
    ref_col − col) from the two geotransforms. *_valid: optional boolean masks (False = no
    data); non-finite pixels are treated as no data too. Further keyword arguments are the
    fields of `MatchSettings` (search_radius, template, harris_*, brief_*, max_hamming,
    min_ncc, ransac_* …) with the defaults documented there.

    Returns a DataFrame with one row per kept CP: row, col (image pixels, centre of pixel (0, 0)
    at (0.0, 0.0)), ref_row, ref_col (reference pixels, sub-pixel), kind ('brief' | 'ncc'),
    score (Hamming distance for BRIEF, NCC coefficient for NCC), cell_row, cell_col.
    """
    _check_grid(grid)
    candidates = match_candidates(
        image,
        reference,
        image_valid=image_valid,
        reference_valid=reference_valid,
        offset=offset,
        chunk=chunk,
        grid=grid,
        **settings,
    )
    return homogenize(candidates, grid)


def match_candidates(
    image: np.ndarray,
    reference: np.ndarray,
    *,
    image_valid: np.ndarray | None = None,
    reference_valid: np.ndarray | None = None,
    offset: tuple[float, float] = (0.0, 0.0),
    chunk: int = 5000,
    grid: int = 400,
    **settings: object,
) -> pd.DataFrame:
    """Every match that survives RANSAC, before homogenization (same columns minus the cells).

    `grid` only spreads the Harris corners (`corners_per_cell` per cell); see `match_images`.
    """
    s = make_settings(**settings)
    _check_grid(grid)
    if isinstance(image, np.ndarray) and isinstance(reference, np.ndarray):
        if image.dtype != reference.dtype:
            raise _input_error(
                f"image and reference must have the same dtype, got {image.dtype} and "
                f"{reference.dtype}"
            )
    image, image_valid = _checked_image(image, image_valid, "image")
    reference, reference_valid = _checked_image(reference, reference_valid, "reference")
    offset = _checked_offset(offset)
    if not isinstance(chunk, (int, np.integer)) or isinstance(chunk, bool):
        raise _input_error(f"chunk must be an integer number of pixels, got {chunk!r}")
    if chunk < s.template or chunk < s.brief_patch:
        raise _input_error(
            f"chunk ({chunk} px) must be at least the template ({s.template} px) and the BRIEF "
            f"patch ({s.brief_patch} px)"
        )
    frames = [
        _match_chunk(image, image_valid, reference, reference_valid, offset, window, grid, s)
        for window in _chunks(image.shape, int(chunk))
    ]
    frames = [f for f in frames if not f.empty]
    if not frames:
        return _empty(CANDIDATE_COLUMNS)
    return pd.concat(frames, ignore_index=True)


def _chunks(shape: tuple[int, ...], size: int) -> list[tuple[int, int, int, int]]:
    rows, cols = shape
    return [
        (r0, min(r0 + size, rows), c0, min(c0 + size, cols))
        for r0 in range(0, rows, size)
        for c0 in range(0, cols, size)
    ]


def _erode(mask: np.ndarray, radius: int) -> np.ndarray:
    """True where the whole (2·radius+1)² square around the pixel is True and inside the array."""
    kernel = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
    eroded = cv2.erode(mask.astype(np.uint8), kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return eroded.astype(bool)


def _match_chunk(
    image: np.ndarray,
    image_valid: np.ndarray,
    reference: np.ndarray,
    reference_valid: np.ndarray,
    offset: tuple[float, float],
    window: tuple[int, int, int, int],
    grid: int,
    s: MatchSettings,
) -> pd.DataFrame:
    """The matches of one chunk of the image: its Harris corners matched by BRIEF and refined
    by NCC, the corners left searched by NCC alone, then RANSAC over the chunk's matches."""
    off = np.rint(np.asarray(offset)).astype(np.int64)
    img, usable, i0 = _image_chunk(image, image_valid, window, s.margin)
    found = _reference_chunk(reference, reference_valid, window, off, s)
    if found is None or not usable.any():
        return _empty(CANDIDATE_COLUMNS)
    ref, ref_usable, search_usable, r0 = found
    # corners only where the reference can hold their match, so that a cell the reference covers
    # in part does not spend its corners_per_cell on the part it does not cover
    usable &= _reachable(usable.shape, ref_usable, search_usable, i0 + off - r0, s.search_radius)
    harris = _harris(s)
    pts = harris_corners(img, usable, cell_of=(i0[0], i0[1], grid), **harris)
    if len(pts) == 0:
        return _empty(CANDIDATE_COLUMNS)
    ref_cell = (r0[0] - off[0], r0[1] - off[1], grid)
    ref_pts = harris_corners(ref, ref_usable, cell_of=ref_cell, **harris)
    pts_global = pts + i0
    bi, bj, bd = _brief_matches(img, pts, pts_global, ref, ref_pts, ref_pts + r0 - off, s)
    if s.ncc_sigma > 0:  # NCC compares the images smoothed alike
        img = cv2.GaussianBlur(img, (0, 0), s.ncc_sigma)
        ref = cv2.GaussianBlur(ref, (0, 0), s.ncc_sigma)
    # sub-pixel refinement of each BRIEF match by NCC in a small window around its corner
    b_ok, b_ref, _ = _ncc_kept(img, pts[bi], ref, ref_pts[bj], s.refine_radius, s)
    bi, bd, b_ref = bi[b_ok], bd[b_ok], b_ref[b_ok]
    ni, n_ref, n_peak = _ncc_matches(img, pts, ref, pts_global + off - r0, bi, search_usable, s)
    src = np.concatenate([pts_global[bi], pts_global[ni]]).astype(np.float64)
    dst = np.concatenate([b_ref, n_ref]) + r0
    kind = np.array(["brief"] * len(bi) + ["ncc"] * len(ni), dtype=object)
    score = np.concatenate([bd.astype(np.float64), n_peak])
    return _consistent(src, dst, kind, score, s)


def _consistent(
    src: np.ndarray, dst: np.ndarray, kind: np.ndarray, score: np.ndarray, s: MatchSettings
) -> pd.DataFrame:
    """The chunk's matches (image position `src`, reference position `dst`, their kind and
    score) as CANDIDATE_COLUMNS, less those that RANSAC finds disagree with the chunk's common
    geometry."""
    keep = ransac_inliers(
        src,
        dst,
        model=s.ransac_model,
        threshold=s.ransac_threshold,
        iterations=s.ransac_iterations,
        seed=s.ransac_seed,
        window=2 * s.search_radius + 1,
    )
    return pd.DataFrame(
        {
            "row": src[keep, 0],
            "col": src[keep, 1],
            "ref_row": dst[keep, 0],
            "ref_col": dst[keep, 1],
            "kind": kind[keep],
            "score": score[keep],
        }
    )


def _image_chunk(
    image: np.ndarray, valid: np.ndarray, window: tuple[int, int, int, int], margin: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chunk of the image with the margin its patches need, where corners may lie (valid
    pixels of the chunk proper, the margin's width from any invalid one), and its origin."""
    r0, r1, c0, c1 = window
    rows, cols = image.shape
    ir0, ir1 = max(r0 - margin, 0), min(r1 + margin, rows)
    ic0, ic1 = max(c0 - margin, 0), min(c1 + margin, cols)
    usable = _erode(valid[ir0:ir1, ic0:ic1], margin)
    core = np.zeros_like(usable)
    core[r0 - ir0 : r1 - ir0, c0 - ic0 : c1 - ic0] = True
    return image[ir0:ir1, ic0:ic1], usable & core, np.array([ir0, ic0])


def _reference_chunk(
    reference: np.ndarray,
    valid: np.ndarray,
    window: tuple[int, int, int, int],
    off: np.ndarray,
    s: MatchSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The reference around the chunk's centre, enlarged by the search radius and the margins:
    the chunk, where its corners may lie, where a search window fits, and its origin; None
    when it is smaller than a template."""
    r0, r1, c0, c1 = window
    ref_rows, ref_cols = reference.shape
    m = s.margin + s.search_radius + s.refine_radius + 1
    rr0, rr1 = max(r0 + off[0] - m, 0), min(r1 + off[0] + m, ref_rows)
    rc0, rc1 = max(c0 + off[1] - m, 0), min(c1 + off[1] + m, ref_cols)
    if rr1 - rr0 < s.template or rc1 - rc0 < s.template:
        return None
    ref_valid = valid[rr0:rr1, rc0:rc1]
    corners = _erode(ref_valid, max(s.brief_half, s.template_half + s.refine_radius))
    search = _erode(ref_valid, s.template_half + s.search_radius)
    return reference[rr0:rr1, rc0:rc1], corners, search, np.array([rr0, rc0])


def _reachable(
    shape: tuple[int, ...],
    ref_usable: np.ndarray,
    search_usable: np.ndarray,
    shift: np.ndarray,
    radius: int,
) -> np.ndarray:
    """Image-chunk pixels whose expected reference position (pixel + `shift` in the reference
    chunk) can hold a match: a reference corner within `radius` (BRIEF) or a whole NCC search
    window (`search_usable`)."""
    kernel = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
    near = cv2.dilate(ref_usable.astype(np.uint8), kernel).astype(bool)
    reach = near | search_usable
    out = np.zeros(shape, dtype=bool)
    rows = np.arange(shape[0]) + shift[0]
    cols = np.arange(shape[1]) + shift[1]
    in_r = (rows >= 0) & (rows < reach.shape[0])
    in_c = (cols >= 0) & (cols < reach.shape[1])
    out[np.ix_(in_r, in_c)] = reach[np.ix_(rows[in_r], cols[in_c])]
    return out


def _harris(s: MatchSettings) -> dict[str, float]:
    """The Harris detector's settings, as `harris_corners` takes them."""
    return dict(
        block=s.harris_block,
        ksize=s.harris_ksize,
        k=s.harris_k,
        quality=s.harris_quality,
        min_distance=s.harris_min_distance,
        per_cell=s.corners_per_cell,
    )


def _brief_matches(
    img: np.ndarray,
    pts: np.ndarray,
    pts_global: np.ndarray,
    ref: np.ndarray,
    ref_pts: np.ndarray,
    ref_in_image: np.ndarray,
    s: MatchSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """512-bit BRIEF descriptors matched by Hamming distance within the search window: the
    image corners, their reference corners and the distances."""
    pattern = brief_pattern(s.brief_patch, s.brief_seed)
    desc = brief_descriptors(smooth_for_brief(img, s.brief_sigma), pts, pattern)
    ref_desc = brief_descriptors(smooth_for_brief(ref, s.brief_sigma), ref_pts, pattern)
    return match_brief(
        desc,
        pts_global,
        ref_desc,
        ref_in_image,
        radius=s.search_radius,
        max_distance=s.max_hamming,
        ratio=s.hamming_ratio,
    )


def _ncc_matches(
    img: np.ndarray,
    pts: np.ndarray,
    ref: np.ndarray,
    centres: np.ndarray,
    matched: np.ndarray,
    search_usable: np.ndarray,
    s: MatchSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """NCC search for every corner not `matched`, around its expected position in the reference
    chunk (`centres`): the corners found, their positions in the chunk and their peaks."""
    left = np.ones(len(pts), dtype=bool)
    left[matched] = False
    rows, cols = ref.shape
    left &= (centres[:, 0] >= 0) & (centres[:, 0] < rows)
    left &= (centres[:, 1] >= 0) & (centres[:, 1] < cols)
    left[left] = search_usable[centres[left, 0], centres[left, 1]]
    ni = np.flatnonzero(left)
    ok, found, peak = _ncc_kept(img, pts[ni], ref, centres[ni], s.search_radius, s)
    return ni[ok], found[ok], peak[ok]


def _ncc_kept(
    img: np.ndarray,
    pts: np.ndarray,
    ref: np.ndarray,
    centres: np.ndarray,
    radius: int,
    s: MatchSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`ncc_search` of the corners around `centres` within `radius`, and which of them to keep:
    the peak found inside the window and at least `min_ncc`."""
    found, peak, inside = ncc_search(img, pts, ref, centres, half=s.template_half, radius=radius)
    return inside & (peak >= s.min_ncc), found, peak


def _empty(columns: list[str]) -> pd.DataFrame:
    dtypes = {"kind": "object", "cell_row": "int64", "cell_col": "int64"}
    return pd.DataFrame({c: pd.Series(dtype=dtypes.get(c, "float64")) for c in columns})


def _input_error(message: str) -> InputError:
    return InputError(Problem(file="<arguments>", message=message))


def _check_grid(grid: object) -> None:
    if not isinstance(grid, (int, np.integer)) or isinstance(grid, bool) or grid < 1:
        raise _input_error(f"grid must be a positive integer number of pixels, got {grid!r}")


def _checked_image(array: object, valid: object, name: str) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(array, np.ndarray):
        raise _input_error(f"{name} must be a numpy array, got {type(array).__name__}")
    if array.ndim != 2:
        raise _input_error(f"{name} must be 2-D (rows, cols), got {array.ndim} dimension(s)")
    if not np.issubdtype(array.dtype, np.floating):
        raise _input_error(f"{name} must be a floating array (float32), got {array.dtype}")
    if min(array.shape) == 0:
        raise _input_error(f"{name} is empty (shape {array.shape})")
    finite = np.isfinite(array)
    if valid is None:
        mask = finite
    else:
        if not isinstance(valid, np.ndarray) or valid.dtype != bool:
            raise _input_error(f"{name}_valid must be a boolean numpy array")
        if valid.shape != array.shape:
            raise _input_error(
                f"{name}_valid has shape {valid.shape}, {name} has shape {array.shape}"
            )
        mask = valid & finite
    clean = np.where(mask, array, 0).astype(np.float32) if not finite.all() else array
    return np.ascontiguousarray(clean, dtype=np.float32), mask


def _checked_offset(offset: object) -> tuple[float, float]:
    try:
        values = np.asarray(offset, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise _input_error(f"offset must be two numbers (rows, cols), got {offset!r}") from exc
    if values.size != 2 or not np.isfinite(values).all():
        raise _input_error(f"offset must be two finite numbers (rows, cols), got {offset!r}")
    return float(values[0]), float(values[1])


__all__ = ["COLUMNS", "MatchSettings", "match_candidates", "match_images"]
