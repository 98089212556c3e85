"""Fast normalized cross-correlation of many templates at once, with a sub-pixel peak (§RA-3).

Lewis' fast NCC: the numerator is a cross-correlation computed by FFT, the window variances come
from integral images (cumulative sums). Every template is searched in its own window; all of them
go through one batched FFT, so there is no Python loop over corners.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import fft

_BATCH = 2048


def extract_patches(image: np.ndarray, centres: np.ndarray, half: int) -> np.ndarray:
    """Return (n, 2·half+1, 2·half+1) copies of the square patches of `image` at `centres`."""
    size = 2 * half + 1
    view = sliding_window_view(image, (size, size))
    centres = np.asarray(centres, dtype=np.int64).reshape(-1, 2)
    return view[centres[:, 0] - half, centres[:, 1] - half]


def ncc_surfaces(templates: np.ndarray, windows: np.ndarray) -> np.ndarray:
    """Return the NCC of each template at every position fully inside its window.

    templates: (n, t, t); windows: (n, s, s) with s ≥ t. Result (n, s-t+1, s-t+1), entry [k, u, v]
    being the NCC of templates[k] with windows[k, u:u+t, v:v+t]. Flat templates or windows give 0.
    """
    n, t, _ = templates.shape
    s = windows.shape[1]
    lags = s - t + 1
    out = np.empty((n, lags, lags), dtype=np.float64)
    length = fft.next_fast_len(s, real=True)
    area = float(t * t)
    for start in range(0, n, _BATCH):
        tpl_raw = templates[start : start + _BATCH].astype(np.float64)
        win = windows[start : start + _BATCH].astype(np.float64)
        # centred: the NCC does not change, and the integral images' rounding shrinks
        win -= win.mean(axis=(1, 2), keepdims=True)
        tpl = tpl_raw - tpl_raw.mean(axis=(1, 2), keepdims=True)
        tpl_norm = np.sqrt(np.einsum("kij,kij->k", tpl, tpl))
        spec = fft.rfft2(win, s=(length, length), axes=(1, 2))
        spec *= np.conj(fft.rfft2(tpl, s=(length, length), axes=(1, 2)))
        corr = fft.irfft2(spec, s=(length, length), axes=(1, 2))[:, :lags, :lags]
        # Window sums by integral images: sum over win[u:u+t, v:v+t] for every lag (u, v).
        sums = _box_sums(win, t, lags)
        sums_sq = _box_sums(win * win, t, lags)
        var = np.maximum(sums_sq - sums * sums / area, 0.0)
        denom = np.sqrt(var) * tpl_norm[:, None, None]
        # Flat window or template: variance lost in the rounding of the sums, NCC undefined -> 0.
        # The sums' rounding grows with the whole window's energy, not the sub-window's: a flat
        # sub-window (zeros) beside bright texture can keep a rounding residue of either sign.
        flat_tpl = tpl_norm**2 <= 1e-9 * np.einsum("kij,kij->k", tpl_raw, tpl_raw)
        energy = np.einsum("kij,kij->k", win, win)[:, None, None]
        tiny = (var <= 1e-9 * np.abs(sums_sq)) | (var <= 1e-9 * energy) | flat_tpl[:, None, None]
        tiny |= ~(denom > 0)
        ncc = np.zeros_like(corr)
        np.divide(corr, denom, out=ncc, where=~tiny)
        out[start : start + _BATCH] = ncc
    return np.clip(out, -1.0, 1.0)


def _box_sums(values: np.ndarray, t: int, lags: int) -> np.ndarray:
    integral = np.zeros((values.shape[0], values.shape[1] + 1, values.shape[2] + 1))
    integral[:, 1:, 1:] = values.cumsum(axis=1).cumsum(axis=2)
    return (
        integral[:, t : t + lags, t : t + lags]
        - integral[:, :lags, t : t + lags]
        - integral[:, t : t + lags, :lags]
        + integral[:, :lags, :lags]
    )


def subpixel_peak(surfaces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Locate each surface's maximum with sub-pixel precision.

    A 2-D quadratic f = a + b·x + c·y + d·x² + e·xy + g·y² is fitted by least squares to the 3×3
    neighbourhood of the integer peak and its stationary point taken; when that fit is not a
    maximum or falls outside the 3×3 (more than a pixel away), the separable 1-D parabolas
    through the centre row and column are used instead. Returns the (row, col) peak positions
    in surface coordinates (float, (n, 2)), the peak values and a flag that is False when the
    peak lies on the surface border (the true maximum may lie outside the window).
    """
    n, h, w = surfaces.shape
    flat = surfaces.reshape(n, -1)
    idx = flat.argmax(axis=1)
    pr, pc = np.divmod(idx, w)
    peak = flat[np.arange(n), idx]
    inside = (pr > 0) & (pr < h - 1) & (pc > 0) & (pc < w - 1)
    r = np.clip(pr, 1, h - 2)
    c = np.clip(pc, 1, w - 2)
    k = np.arange(n)[:, None, None]
    dr = np.arange(-1, 2)[None, :, None]
    dc = np.arange(-1, 2)[None, None, :]
    z = surfaces[k, r[:, None, None] + dr, c[:, None, None] + dc]  # (n, 3, 3), z[:, y+1, x+1]

    # Least-squares 2-D quadratic on the 3x3 grid (x along columns, y along rows).
    col_sum = z.sum(axis=1)  # over rows -> per x
    row_sum = z.sum(axis=2)  # over cols -> per y
    b = (col_sum[:, 2] - col_sum[:, 0]) / 6.0
    cy = (row_sum[:, 2] - row_sum[:, 0]) / 6.0
    d = (col_sum[:, 2] + col_sum[:, 0] - 2.0 * col_sum[:, 1]) / 6.0
    g = (row_sum[:, 2] + row_sum[:, 0] - 2.0 * row_sum[:, 1]) / 6.0
    e = (z[:, 2, 2] - z[:, 2, 0] - z[:, 0, 2] + z[:, 0, 0]) / 4.0
    det = 4.0 * d * g - e * e
    safe = np.where(np.abs(det) > 1e-15, det, 1.0)
    x2 = (-2.0 * g * b + e * cy) / safe
    y2 = (-2.0 * d * cy + e * b) / safe
    good2 = (det > 1e-15) & (d < 0) & (np.abs(x2) <= 1.0) & (np.abs(y2) <= 1.0)

    # Fallback: separable parabolas through the centre row and column.
    den_x = z[:, 1, 0] - 2.0 * z[:, 1, 1] + z[:, 1, 2]
    den_y = z[:, 0, 1] - 2.0 * z[:, 1, 1] + z[:, 2, 1]
    x1 = np.where(den_x < 0, 0.5 * (z[:, 1, 0] - z[:, 1, 2]) / np.where(den_x < 0, den_x, 1), 0)
    y1 = np.where(den_y < 0, 0.5 * (z[:, 0, 1] - z[:, 2, 1]) / np.where(den_y < 0, den_y, 1), 0)
    x = np.where(good2, x2, np.clip(x1, -0.5, 0.5))
    y = np.where(good2, y2, np.clip(y1, -0.5, 0.5))
    position = np.column_stack([pr + y, pc + x])
    return position, peak, inside


def ncc_search(
    image: np.ndarray,
    image_points: np.ndarray,
    reference: np.ndarray,
    ref_centres: np.ndarray,
    *,
    half: int,
    radius: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Search the template around each image point within ±radius of its reference centre.

    Points must be at least `half` (image) and `half + radius` (reference) from the borders.
    Returns sub-pixel reference positions (n, 2), NCC peaks (n,) and a peak-inside flag (n,).
    """
    if len(image_points) == 0:
        return np.empty((0, 2)), np.empty(0), np.empty(0, dtype=bool)
    templates = extract_patches(image, image_points, half)
    windows = extract_patches(reference, ref_centres, half + radius)
    surfaces = ncc_surfaces(templates, windows)
    position, peak, inside = subpixel_peak(surfaces)
    ref_pos = np.asarray(ref_centres, dtype=np.float64) - radius + position
    return ref_pos, peak, inside
