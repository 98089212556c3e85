"""RFM geometric accuracy from control points: §RA-4 RMSE and GEV, §RA-5 local distortion,
§RA-6 refined RFM from k CPs evaluated on the CPs not used for fitting.

A control point (CP) here is one feature seen at (x, y) on the corrected image and at (x′, y′)
on the reference orthoimage, both in the same projected CRS (metres); d_s is the image GSD.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Transformer

from blockqc.report.messages import translator
from blockqc.rfm.dem import DEM
from blockqc.rfm.model import RPCModel, fit_affine

FloatArray = NDArray[np.float64]
EN = translator("en")
"""The figures' labels, in English unless a page's language is given."""

REQUIREMENT_PX = 1.0
"""§RA-6 practical requirement: RMSE < 1.0 pixel."""
DISTORTION_THRESHOLD_PX = 0.5
"""**Reading** of §RA-5 (no number in the source): the smallest variation of the error vectors
across the image (RMS about their mean of the fitted low-order field) that counts as systematic
distortion; configurable."""
DISTORTION_ALPHA = 0.01
"""Significance level of the F-test of the low-order field against the mean shift alone."""


def gev(dx: ArrayLike, dy: ArrayLike, gsd: float) -> FloatArray:
    """§RA-4 geometric error value of each CP: √(dx² + dy²) / d_s, in pixels."""
    return np.hypot(np.asarray(dx, np.float64), np.asarray(dy, np.float64)) / float(gsd)


def rmse_px(dx: ArrayLike, dy: ArrayLike, gsd: float) -> float:
    """§RA-4 RMSE = √((1/n)·Σ[(x−x′)² + (y−y′)²]) / d_s, in pixels (NaN when n = 0)."""
    dx = np.asarray(dx, np.float64)
    dy = np.asarray(dy, np.float64)
    if dx.size == 0:
        return float("nan")
    return float(np.sqrt(np.mean(dx * dx + dy * dy)) / float(gsd))


def verdict(rmse: float, requirement: float = REQUIREMENT_PX) -> str:
    """'pass' when RMSE < requirement (§RA-6), 'fail' otherwise, 'error' without CPs."""
    if not np.isfinite(rmse):
        return "error"
    return "pass" if rmse < requirement else "fail"


_READING = (
    "systematic distortion is significant when a low-order field of the error vectors over the "
    "image (affine in column and row, or quadratic where it adds significantly to the affine) "
    "explains a significant share of their variance against the mean shift alone (F-test, "
    "p < {alpha:g}) and that field varies by at least {threshold:g} px RMS about the mean; the "
    "scatter left about it is matching noise (its robust spread is stated), not distortion "
    "(§RA-5 gives no number)"
)


def _design(col: FloatArray, row: FloatArray, order: int) -> FloatArray:
    """Columns 1, u, v (and u², uv, v² for order 2) of centred, scaled image positions."""
    u = (col - col.mean()) / max(float(np.ptp(col)), 1.0)
    v = (row - row.mean()) / max(float(np.ptp(row)), 1.0)
    terms = [np.ones_like(u), u, v] + ([u * u, u * v, v * v] if order == 2 else [])
    return np.column_stack(terms)


def _field_fit(design: FloatArray, e: FloatArray) -> tuple[FloatArray, float]:
    """Least-squares fit of both error components (n×2); fitted values and residual SS."""
    sol, *_ = np.linalg.lstsq(design, e, rcond=None)
    fitted = design @ sol
    return fitted, float(np.sum((e - fitted) ** 2))


def _f_test(rss_small: float, rss_big: float, extra: int, df_big: int) -> tuple[float, float]:
    """F statistic and p-value of a nested model adding `extra` parameters (both components)."""
    from scipy.special import fdtrc  # F survival function (lighter than scipy.stats)

    if rss_small <= 0.0:
        return 0.0, 1.0  # nothing to explain
    if rss_big <= rss_small * 1e-24:
        return float("inf"), 0.0  # an exact field
    stat = ((rss_small - rss_big) / extra) / (rss_big / df_big)
    return float(stat), float(fdtrc(extra, df_big, stat))


def systematic_field(
    col: FloatArray, row: FloatArray, e: FloatArray, alpha: float
) -> dict[str, float | int | str]:
    """§RA-5: the low-order field of the errors e (n×2, px) and its F-test against the mean.

    Affine (3 parameters per component) against the mean (1 each): F on (4, 2n − 6) degrees of
    freedom; quadratic (6 each) kept when it adds significantly to the affine, F on (6, 2n − 12),
    and then tested against the mean on (10, 2n − 12).
    """
    n = e.shape[0]
    rss0 = float(np.sum((e - e.mean(axis=0)) ** 2))
    fitted, rss = _field_fit(_design(col, row, 1), e)
    stat, p = _f_test(rss0, rss, 4, 2 * n - 6)
    model, affine_share = "affine", 1.0 - rss / rss0 if rss0 > 0 else 0.0
    if n >= 15:
        q_fitted, q_rss = _field_fit(_design(col, row, 2), e)
        if _f_test(rss, q_rss, 6, 2 * n - 12)[1] < alpha:
            stat, p = _f_test(rss0, q_rss, 10, 2 * n - 12)
            model, fitted, rss = "quadratic", q_fitted, q_rss
    resid = (e - fitted).ravel()
    return {
        "model": model,
        "affine_explained_share": float(affine_share),
        "explained_share": float(1.0 - rss / rss0) if rss0 > 0 else 0.0,
        "f_statistic": stat,
        "p_value": p,
        "field_rms_px": float(np.sqrt(max(rss0 - rss, 0.0) / n)),
        "noise_robust_px": float(1.4826 * np.median(np.abs(resid - np.median(resid)))),
    }


MIN_FIELD_CPS = 4
"""Fewest CPs the low-order field of §RA-5 is fitted to (the affine has 3 terms a component)."""
NO_FIELD: dict[str, float | int | str | None] = {
    "model": f"not computed: fewer than {MIN_FIELD_CPS} CPs",
    "affine_explained_share": None,
    "explained_share": None,
    "f_statistic": None,
    "p_value": None,
    "field_rms_px": None,
    "noise_robust_px": None,
}
"""The field's figures with too few CPs: every key `systematic_field` gives, none measured."""


def distortion_summary(
    col: ArrayLike,
    row: ArrayLike,
    dx: ArrayLike,
    dy: ArrayLike,
    gsd: float,
    threshold_px: float = DISTORTION_THRESHOLD_PX,
    alpha: float = DISTORTION_ALPHA,
) -> dict[str, float | int | bool | str | None]:
    """§RA-5: how error vectors vary across the image.

    Splits each CP's error (px) into the mean vector (systematic shift), a low-order field over
    the image (systematic distortion, `systematic_field`) and the scatter about it (noise);
    also the RMS about the mean, the mean resultant length of the error directions (1: all
    point the same way, 0: no common direction) and the GEV percentiles. With fewer than
    MIN_FIELD_CPS CPs the field is not fitted: its figures are None (`NO_FIELD`).
    """
    col = np.asarray(col, np.float64)
    row = np.asarray(row, np.float64)
    ex = np.asarray(dx, np.float64) / gsd
    ey = np.asarray(dy, np.float64) / gsd
    n = ex.size
    reading = _READING.format(alpha=alpha, threshold=threshold_px)
    if n == 0:
        return {"n": 0, "significant": False, "reading": reading}
    g = np.hypot(ex, ey)
    shift_and_scatter = _shift_and_scatter(ex, ey, g, gsd)
    field = NO_FIELD
    if n >= MIN_FIELD_CPS:
        field = systematic_field(col, row, np.column_stack([ex, ey]), alpha)
    p50, p90, p_max = np.percentile(g, [50, 90, 100])
    significant = field is not NO_FIELD and (
        field["p_value"] < alpha and field["field_rms_px"] >= threshold_px
    )
    return {
        "n": int(n),
        **shift_and_scatter,
        **field,
        "gev_median_px": float(p50),
        "gev_p90_px": float(p90),
        "gev_max_px": float(p_max),
        "threshold_px": float(threshold_px),
        "alpha": float(alpha),
        "significant": bool(significant),
        "reading": reading,
    }


def _shift_and_scatter(
    ex: FloatArray, ey: FloatArray, g: FloatArray, gsd: float
) -> dict[str, float]:
    """The mean error vector (px and m), the RMS about it, the standard deviations and the mean
    resultant length of the error directions, of CP errors (`ex`, `ey`) of length `g` (px)."""
    n = ex.size
    mx, my = float(ex.mean()), float(ey.mean())
    nz = g > 0
    resultant = (
        float(np.hypot(np.mean(ex[nz] / g[nz]), np.mean(ey[nz] / g[nz]))) if nz.any() else 1.0
    )
    return {
        "mean_dx_px": mx,
        "mean_dy_px": my,
        "mean_dx_m": mx * gsd,
        "mean_dy_m": my * gsd,
        "systematic_px": float(np.hypot(mx, my)),
        "local_rms_px": float(np.sqrt(np.mean((ex - mx) ** 2 + (ey - my) ** 2))),
        "std_dx_px": float(ex.std(ddof=1)) if n > 1 else 0.0,
        "std_dy_px": float(ey.std(ddof=1)) if n > 1 else 0.0,
        "direction_consistency": resultant,
    }


# -- plots (§RA-5) ---------------------------------------------------------------------------
def _figure_png(fig: object) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")  # type: ignore[attr-defined]
    import matplotlib.pyplot as plt

    plt.close(fig)  # type: ignore[arg-type]
    return buf.getvalue()


def _vector_layout(shape: tuple[int, int]) -> tuple[object, object, object, float]:
    """Figure, image axes, colour-bar axes and inches per image pixel for an image
    of `shape`: the axes keep the image's aspect within 5 × 6 inches, with fixed margins in
    inches for the title, the labels, the key row under the axes and the colour bar."""
    import matplotlib.pyplot as plt

    height, width = max(shape[0], 1), max(shape[1], 1)
    scale = min(5.0 / width, 6.0 / height)  # inches per pixel
    aw, ah = max(width * scale, 0.4), max(height * scale, 0.4)
    left, right, bottom, top = 0.9, 1.2, 1.0, 0.45
    fw, fh = left + aw + right, bottom + ah + top
    fig = plt.figure(figsize=(fw, fh))
    ax = fig.add_axes((left / fw, bottom / fh, aw / fw, ah / fh))
    cax = fig.add_axes(((left + aw + 0.25) / fw, bottom / fh, 0.15 / fw, ah / fh))
    return fig, ax, cax, scale


def _scale_key(fig: object, key_px: float, length_in: float, t: Callable[..., str] = EN) -> None:
    """The arrow of `key_px` pixels of error, `length_in` inches long as on the image axes, in
    its own row at the bottom-left of the figure (inside the saved area, whatever the aspect)."""
    fw, fh = fig.get_size_inches()  # type: ignore[attr-defined]
    kax = fig.add_axes((0.1 / fw, 0.02 / fh, (fw - 0.2) / fw, 0.3 / fh))  # type: ignore[attr-defined]
    kax.set_xlim(0.0, fw - 0.2)  # data units are inches
    kax.set_ylim(0.0, 0.3)
    kax.set_axis_off()
    kax.annotate(
        "",
        xy=(0.8 + length_in, 0.15),
        xytext=(0.8, 0.15),
        arrowprops={"arrowstyle": "-|>", "color": "black", "shrinkA": 0, "shrinkB": 0},
    )
    kax.text(0.8 + length_in + 0.1, 0.15, t("ra_key_error", px=f"{key_px:g}"), va="center")


def plot_error_vectors(
    col: ArrayLike,
    row: ArrayLike,
    dx: ArrayLike,
    dy: ArrayLike,
    gsd: float,
    shape: tuple[int, int],
    title: str = "CP error vectors",
    background: NDArray[np.floating] | None = None,
    t: Callable[..., str] = EN,
) -> bytes:
    """PNG of every CP's error vector drawn at its position on the image (§RA-5).

    `background` (optional) is the image, possibly decimated, drawn in grey under the vectors.
    The scale key sits in its own row under the axes, whatever the image's aspect.
    """
    import matplotlib

    matplotlib.use("Agg")
    ex = np.asarray(dx, np.float64) / gsd
    ey = np.asarray(dy, np.float64) / gsd
    g = np.hypot(ex, ey)
    fig, ax, cax, inch_per_px = _vector_layout(shape)
    if background is not None and np.isfinite(background).any():
        _draw_background(ax, background, shape)
    if g.size:
        _draw_vectors(fig, ax, cax, (col, row), (ex, ey, g), inch_per_px, t)
    else:
        cax.set_axis_off()
    ax.set_xlim(0, shape[1])
    ax.set_ylim(shape[0], 0)
    ax.set_xlabel(t("ra_ax_column"))
    ax.set_ylabel(t("ra_ax_row"))
    ax.set_title(_wrapped(title, fig, ax), loc="left", parse_math=False)  # names: "$" as typed
    return _figure_png(fig)


def _draw_background(ax: object, background: NDArray[np.floating], shape: tuple[int, int]) -> None:
    """The image in grey on the axes, over the extent of an image of `shape`, its contrast
    stretched between the 2nd and the 98th percentile."""
    lo, hi = np.nanpercentile(background, [2, 98])
    extent = (-0.5, shape[1] - 0.5, shape[0] - 0.5, -0.5)
    ax.imshow(  # type: ignore[attr-defined]
        background,
        cmap="gray",
        vmin=lo,
        vmax=hi,
        alpha=0.6,
        extent=extent,
        interpolation="nearest",
    )


def _draw_vectors(
    fig: object,
    ax: object,
    cax: object,
    at: tuple[ArrayLike, ArrayLike],
    errors: tuple[FloatArray, FloatArray, FloatArray],
    inch_per_px: float,
    t: Callable[..., str],
) -> None:
    """The error vectors (ex, ey) in pixels, of lengths g, drawn at `at` (col, row), the
    largest 0.4 inch long on the page, with the scale key and the colour bar of the GEV."""
    ex, ey, g = errors
    biggest = float(g.max())
    # arrows scaled so the largest is 0.4 inch long on the page; the key gives the scale
    scale = biggest / (0.4 / inch_per_px) if biggest > 0 else 1.0
    # map y points north, image rows point south: an error dy > 0 is drawn upward
    q = ax.quiver(  # type: ignore[attr-defined]
        *(np.asarray(v, np.float64) for v in at),
        ex,
        -ey,
        g,
        angles="xy",
        scale_units="xy",
        scale=scale,
        cmap="viridis",
        units="inches",
        width=0.012,
    )
    if biggest > 0:  # one significant digit: 5.1 → 5, 0.37 → 0.4, 2e-9 → 2e-9
        key = float(f"{biggest:.1g}")
        _scale_key(fig, key, key / scale * inch_per_px, t)
    fig.colorbar(q, cax=cax, label=t("ra_ax_gev"))  # type: ignore[attr-defined]


def _wrapped(title: str, fig: object, ax: object) -> str:
    """`title` in lines that fit between the axes' left edge and the figure's right edge (long
    file names broken), so that a long name does not widen the figure and shrink the image."""
    import textwrap

    from matplotlib import rcParams
    from matplotlib.font_manager import FontProperties

    size = FontProperties(size=rcParams["axes.titlesize"]).get_size_in_points()
    width = fig.get_size_inches()[0] * (1.0 - ax.get_position().x0)  # type: ignore[attr-defined]
    chars = max(int(width * 72.0 / (0.65 * size)), 10)  # 0.65 em: a wide average glyph
    return textwrap.fill(title, chars, break_on_hyphens=False)


def plot_gev_histogram(
    g: ArrayLike, requirement: float = REQUIREMENT_PX, t: Callable[..., str] = EN
) -> bytes:
    """PNG histogram of the GEVs with the requirement line (§RA-5), its text by `t`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    g = np.asarray(g, np.float64)
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    if g.size:
        ax.hist(g, bins=min(40, max(5, g.size // 3)), color="#4477aa", edgecolor="white")
    ax.axvline(
        requirement, color="#cc3311", linestyle="--", label=t("px_value", px=f"{requirement:g}")
    )
    ax.set_xlabel(t("ra_ax_gev"))
    ax.set_ylabel(t("ra_ax_cps"))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: no 0.25 of a CP
    ax.legend()
    ax.set_title(t("ra_fig_histogram"), loc="left")
    return _figure_png(fig)


# -- §RA-6 refined RFM from k CPs, held-out evaluation -------------------------------------
@dataclass(frozen=True)
class ControlPoints:
    """CPs for refinement: observed full-image (row, col) and reference ground (lon, lat, h)."""

    row: FloatArray
    col: FloatArray
    lon: FloatArray
    lat: FloatArray
    h: FloatArray
    ref_x: FloatArray
    ref_y: FloatArray


def held_out_rmse(
    rpc: RPCModel,
    cps: ControlPoints,
    fit_idx: NDArray[np.intp],
    check_idx: NDArray[np.intp],
    dem: DEM,
    crs: CRS,
    gsd: float,
) -> float:
    """RMSE (§RA-4, px) on the check CPs of the RFM refined with the fit CPs (§3 affine).

    Each check CP's observed image position goes to the ground on the DEM with the refined RFM,
    and is compared with its reference position.
    """
    refined, _ = fit_affine(
        rpc, cps.lon[fit_idx], cps.lat[fit_idx], cps.h[fit_idx], cps.row[fit_idx], cps.col[fit_idx]
    )
    lon, lat, _ = refined.image_to_ground(cps.row[check_idx], cps.col[check_idx], dem)
    x, y = Transformer.from_crs(CRS.from_epsg(4326), crs, always_xy=True).transform(lon, lat)
    dx = np.asarray(x) - cps.ref_x[check_idx]
    dy = np.asarray(y) - cps.ref_y[check_idx]
    ok = np.isfinite(dx) & np.isfinite(dy)
    return rmse_px(dx[ok], dy[ok], gsd)


MIN_CHECK_CPS = 10
"""§RA-6 rows measured on fewer held-out CPs than this are flagged (an RMSE from a handful of
points varies by tens of percent from draw to draw)."""


def draws(n: int, repeats: int, seed: int) -> NDArray[np.intp]:
    """`repeats` random orders of the n CPs (fixed seed): draw r fits on perms[r, :k]."""
    rng = np.random.default_rng(seed)
    return np.array([rng.permutation(n) for _ in range(repeats)], dtype=np.intp).reshape(-1, n)


def _batch_affines(
    row: FloatArray, col: FloatArray, row_r: FloatArray, col_r: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """The §3 affine of every draw at once (draws × k CPs), centred and scaled as `fit_affine`:
    returns the solutions (draws × 3 × 2), the centres and scales, and the draws of full rank."""
    r0 = row.mean(axis=1, keepdims=True)
    c0 = col.mean(axis=1, keepdims=True)
    sr = np.maximum(np.abs(row - r0).max(axis=1, keepdims=True), 1.0)
    sc = np.maximum(np.abs(col - c0).max(axis=1, keepdims=True), 1.0)
    design = np.stack([np.ones_like(row), (col - c0) / sc, (row - r0) / sr], axis=-1)
    rhs = np.stack([row_r - row, col_r - col], axis=-1)
    sol = np.linalg.pinv(design) @ rhs
    full = np.linalg.matrix_rank(design) == 3
    return sol, np.stack([r0, c0, sr, sc], axis=-1)[:, 0, :], design, full


def held_out_rmse_batch(
    rpc: RPCModel,
    cps: ControlPoints,
    perms: NDArray[np.intp],
    k: int,
    dem: DEM,
    to_map: Transformer,
    gsd: float,
) -> FloatArray:
    """`held_out_rmse` of every draw at once: one affine solve for all draws, one image→ground
    on the DEM for all their check CPs. NaN for a draw whose fit CPs are collinear."""
    fit, check = perms[:, :k], perms[:, k:]
    rr, cc = cps.row[check], cps.col[check]
    d_row = np.zeros(check.shape)  # k = 0: the original RFM
    d_col = np.zeros(check.shape)
    full = np.ones(check.shape[0], dtype=bool)
    if k > 0:
        row_r, col_r = rpc.ground_to_image(cps.lon[fit], cps.lat[fit], cps.h[fit])
        sol, centre, _, full = _batch_affines(cps.row[fit], cps.col[fit], row_r, col_r)
        r0, c0, sr, sc = (centre[:, i : i + 1] for i in range(4))
        u = (cc - c0) / sc
        v = (rr - r0) / sr
        d_row = sol[:, 0:1, 0] + sol[:, 1:2, 0] * u + sol[:, 2:3, 0] * v
        d_col = sol[:, 0:1, 1] + sol[:, 1:2, 1] * u + sol[:, 2:3, 1] * v
    lon, lat, _ = rpc.image_to_ground((rr + d_row).ravel(), (cc + d_col).ravel(), dem)
    x, y = to_map.transform(lon, lat)
    dx = np.asarray(x).reshape(check.shape) - cps.ref_x[check]
    dy = np.asarray(y).reshape(check.shape) - cps.ref_y[check]
    ok = np.isfinite(dx) & np.isfinite(dy)
    sq = np.where(ok, dx * dx + dy * dy, 0.0).sum(axis=1)
    count = ok.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rmse = np.sqrt(sq / count) / float(gsd)
    return np.where(full & (count > 0), rmse, np.nan)


def k_warnings(ks: tuple[int, ...], n: int) -> list[str]:
    """§RA-6 values of k the n CPs cannot support (no or few CPs left to check on)."""
    out = []
    for k in ks:
        if k >= n:
            out.append(EN("ra_warn_k_unsupported", k=k, n=n))
        elif n - k < MIN_CHECK_CPS:
            out.append(EN("ra_warn_k_few_checks", k=k, left=n - k, min=MIN_CHECK_CPS))
    return out


def _row(k: int, n_check: int, repeats: int, v: FloatArray, note: str) -> dict[str, object]:
    finite = v[np.isfinite(v)]
    return {
        "k": int(k),
        "n_check": int(n_check),
        "repeats": int(repeats),
        "rmse_px_mean": float(finite.mean()) if finite.size else float("nan"),
        "rmse_px_min": float(finite.min()) if finite.size and repeats > 1 else float("nan"),
        "rmse_px_max": float(finite.max()) if finite.size and repeats > 1 else float("nan"),
        "note": note,
    }


def refined_rfm_table(
    rpc: RPCModel,
    cps: ControlPoints,
    dem: DEM,
    crs: CRS,
    gsd: float,
    ks: tuple[int, ...] = (6, 12, 16, 20),
    repeats: int = 100,
    seed: int = 0,
) -> pd.DataFrame:
    """§RA-6: for each k, refine the RFM from k CPs drawn at random and measure the RMSE on the
    CPs *not* drawn; `repeats` draws per k (fixed seed) give the mean and spread. All draws of
    one k are solved and evaluated together (`held_out_rmse_batch`).

    The first row (k = 0) is the original RFM evaluated the same way on all CPs.
    """
    n = cps.row.size
    to_map = Transformer.from_crs(CRS.from_epsg(4326), crs, always_xy=True)
    everyone = np.arange(n, dtype=np.intp)[None, :]
    zero = held_out_rmse_batch(rpc, cps, everyone, 0, dem, to_map, gsd) if n else np.array([])
    rows = [_row(0, n, 1, zero, "original RFM")]
    for k in ks:
        if k < 3 or k >= n:
            note = f"needs 3 ≤ k < n CPs (n = {n})"
            rows.append(_row(k, max(n - k, 0), 0, np.array([]), note))
            continue
        v = held_out_rmse_batch(rpc, cps, draws(n, repeats, seed + k), k, dem, to_map, gsd)
        note = "refined RFM (image-space affine), held-out CPs"
        if n - k < MIN_CHECK_CPS:
            note += f"; only {n - k} check CPs"
        if np.isnan(v).any():
            note += f"; {int(np.isnan(v).sum())} draws with collinear CPs left out"
        rows.append(_row(k, n - k, repeats, v, note))
    return pd.DataFrame(rows)
