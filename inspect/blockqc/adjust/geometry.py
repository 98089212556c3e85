"""Vectorized RFM geometry over many scenes at once: projection, partials, intersection (§3, §RC).

Conventions (as `blockqc.rfm.model`): image (line, sample) in pixels, pixel-centre convention;
ground (lon°, lat°, ellipsoidal h m).

Adjusted projection of contract v1.1 (DELIVERY.md), affine array shape (n_scenes, 6) ordered
a0 a1 a2 b0 b1 b2, with (l, s) the image position:

    l = RFM_l(φ, λ, h) + a0 + a1·s + a2·l,    s = RFM_s(φ, λ, h) + b0 + b1·s + b2·l.

It is implicit in (l, s); ground → image solves the 2×2 linear system exactly
    (1 − a2)·l − a1·s = RFM_l + a0,   −b2·l + (1 − b1)·s = RFM_s + b0.
The contract's parameters are the NEGATED parameters of `blockqc.rfm.model.ImageAffine`
(DOMAIN.md §3 writes RFM = l + Δl; the contract writes l = RFM + Δl): `ImageAffine(-a0, …, -b2)`
is the same model, which `tests/adjust/test_geometry.py` checks.

Image → ground and intersection work in RFM space: a measured (l, s) is moved to the RFM's
(l − a0 − a1·s − a2·l, s − b0 − b1·s − b2·l) (exact, no iteration), and ground coordinates are
sought that the plain RFM maps there. The misclosure f = RFM(X) − that position is the residual
in RFM space; the residual in image space, computed − measured, is exactly M⁻¹·f with
M = [[1 − a2, −a1], [−b2, 1 − b1]] (`image_residuals`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from blockqc.errors import InputError, Problem
from blockqc.rfm.model import RPC00B_EXPONENTS, RPCModel, wrap_lon

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

CHUNK = 131072
"""Observations evaluated per pass (bounds the memory of the gathered coefficients)."""
BATCH = 262144
"""Observations intersected at once (bounds the memory of an intersection's iterations)."""


def _monomials(ln: FloatArray, pn: FloatArray, hn: FloatArray) -> FloatArray:
    """The 20 RPC00B terms at normalized points, (20, n)."""
    pw = [[None, x, x * x, x * x * x] for x in (ln, pn, hn)]
    out = np.empty((20, ln.size))
    for j, e in enumerate(RPC00B_EXPONENTS):
        factors = [pw[a][k] for a, k in enumerate(e) if k]
        if not factors:
            out[j] = 1.0
        elif len(factors) == 1:
            out[j] = factors[0]
        else:
            np.multiply(factors[0], factors[1], out=out[j])
            if len(factors) == 3:
                out[j] *= factors[2]
    return out


def _derivative_map(axis: int) -> FloatArray:
    """D (20×20) with ∂term_j/∂x_axis = Σ_k D[j, k]·term_k: the RPC00B terms are every monomial
    of degree ≤ 3, so each derivative is a multiple of another term."""
    index = {e: k for k, e in enumerate(RPC00B_EXPONENTS)}
    d = np.zeros((20, 20))
    for j, e in enumerate(RPC00B_EXPONENTS):
        if e[axis]:
            lower = list(e)
            lower[axis] -= 1
            d[j, index[tuple(lower)]] = e[axis]
    return d


@dataclass(frozen=True, eq=False)
class RPCStack:
    """The RPC00B models of many scenes stacked: coeffs (n, 4, 20), offsets and scales (n, 5).

    Offsets/scales columns: line, samp, lat, lon, height. `project` evaluates observations on
    different scenes in one vectorized pass, indexed by `scene_index`.
    """

    coeffs: FloatArray
    offsets: FloatArray
    scales: FloatArray
    sources: tuple[str, ...] = ()
    with_partials: FloatArray = field(init=False, repr=False)
    """(n, 16, 20): the 4 polynomials, then their L, P and H derivatives, as coefficients."""

    def __post_init__(self) -> None:
        maps = [np.eye(20)] + [_derivative_map(a) for a in range(3)]
        stacked = np.concatenate([self.coeffs @ m for m in maps], axis=1)
        object.__setattr__(self, "with_partials", stacked)

    @classmethod
    def from_models(cls, models: Sequence[RPCModel]) -> RPCStack:
        if len(models) == 0:
            raise InputError(Problem("<rpc>", "no RPC model given"))
        coeffs = np.stack(
            [np.stack([m.line_num, m.line_den, m.samp_num, m.samp_den]) for m in models]
        )
        keys = ("line", "samp", "lat", "lon", "height")
        offsets = np.array([[getattr(m, f"{k}_off") for k in keys] for m in models], np.float64)
        scales = np.array([[getattr(m, f"{k}_scale") for k in keys] for m in models], np.float64)
        return cls(coeffs, offsets, scales, tuple(m.source for m in models))

    @property
    def n_scenes(self) -> int:
        return int(self.coeffs.shape[0])

    def project(
        self,
        scene_index: ArrayLike,
        lon: ArrayLike,
        lat: ArrayLike,
        h: ArrayLike,
        partials: bool = False,
    ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """Plain RFM ground → image: (line, sample) px and, if asked, J (n, 2, 3).

        J holds ∂(line, sample)/∂(lon°, lat°, h m) for each observation. Observations are
        taken in scene order (a stable sort unless already sorted) and in chunks of CHUNK, so
        that each scene's polynomials are one matrix product over its slice of observations.
        """
        idx = np.asarray(scene_index, np.int64).ravel()
        lon, lat, h = (np.asarray(v, np.float64).ravel() for v in (lon, lat, h))
        n = idx.size
        order = None if n < 2 or np.all(idx[1:] >= idx[:-1]) else np.argsort(idx, kind="stable")
        if order is not None:
            idx, lon, lat, h = idx[order], lon[order], lat[order], h[order]
        line, samp = np.empty(n), np.empty(n)
        jac = np.empty((n, 2, 3)) if partials else None
        # many small products: BLAS threads only contend (measured 2–3× slower with two)
        with threadpool_limits(1, user_api="blas"):
            for start in range(0, n, CHUNK):
                sl = slice(start, min(n, start + CHUNK))
                out = self._project_chunk(idx[sl], lon[sl], lat[sl], h[sl], partials)
                line[sl], samp[sl] = out[0], out[1]
                if jac is not None:
                    jac[sl] = out[2]
        if order is not None:
            inv = np.empty_like(order)
            inv[order] = np.arange(n)
            line, samp = line[inv], samp[inv]
            jac = None if jac is None else jac[inv]
        return line, samp, jac

    def _polynomials(self, idx: IntArray, terms: FloatArray, partials: bool) -> FloatArray:
        """Values (1 or 4 groups) × 4 polynomials × n; idx sorted, one product per scene."""
        coeffs = self.with_partials if partials else self.coeffs
        k = coeffs.shape[1]
        out = np.empty((k, idx.size))
        cuts = np.flatnonzero(np.diff(idx)) + 1
        bounds = np.concatenate([[0], cuts, [idx.size]])
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            out[:, a:b] = coeffs[idx[a]] @ terms[:, a:b]
        return out.reshape(k // 4, 4, idx.size)

    def _project_chunk(
        self, idx: IntArray, lon: FloatArray, lat: FloatArray, h: FloatArray, partials: bool
    ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        off, sc = self.offsets[idx], self.scales[idx]
        # longitudes taken about each RPC's LON_OFF (modulo 360°): the scenes of a block across
        # the antimeridian write their LON_OFF within ±180°, some near 180°, some near −180°
        ln = wrap_lon(lon - off[:, 3]) / sc[:, 3]
        pn = (lat - off[:, 2]) / sc[:, 2]
        hn = (h - off[:, 4]) / sc[:, 4]
        p = self._polynomials(idx, _monomials(ln, pn, hn), partials)
        v = p[0]
        inv_l, inv_s = 1.0 / v[1], 1.0 / v[3]
        r_l, r_s = v[0] * inv_l, v[2] * inv_s
        line = r_l * sc[:, 0] + off[:, 0]
        samp = r_s * sc[:, 1] + off[:, 1]
        if not partials:
            return line, samp, None
        d = p[1:]  # (3 axes, 4 polynomials, n)
        per_ground = 1.0 / sc[:, [3, 2, 4]].T  # lon, lat, h
        jac = np.empty((idx.size, 2, 3))
        jac[:, 0, :] = ((d[:, 0] - r_l * d[:, 1]) * (inv_l * sc[:, 0] * per_ground)).T
        jac[:, 1, :] = ((d[:, 2] - r_s * d[:, 3]) * (inv_s * sc[:, 1] * per_ground)).T
        return line, samp, jac


def check_affine(affine: ArrayLike, n_scenes: int) -> FloatArray:
    """The affine array as (n_scenes, 6) floats, or an InputError saying what is wrong."""
    a = np.asarray(affine, np.float64)
    if a.shape != (n_scenes, 6) or not np.all(np.isfinite(a)):
        raise InputError(
            Problem("<affine>", f"expected {n_scenes}×6 finite numbers, got shape {a.shape}")
        )
    return a


def to_rfm_space(
    affine: FloatArray, scene_index: IntArray, line: FloatArray, samp: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Measured (l, s) → the RFM's (l − a0 − a1·s − a2·l, s − b0 − b1·s − b2·l); exact."""
    a = affine[scene_index]
    return (
        line - a[:, 0] - a[:, 1] * samp - a[:, 2] * line,
        samp - a[:, 3] - a[:, 4] * samp - a[:, 5] * line,
    )


def m_inverse(affine: FloatArray, scene_index: IntArray) -> FloatArray:
    """M⁻¹ per observation (n, 2, 2), M = [[1 − a2, −a1], [−b2, 1 − b1]] of its scene."""
    a = affine[scene_index]
    m11, m12, m21, m22 = 1.0 - a[:, 2], -a[:, 1], -a[:, 5], 1.0 - a[:, 4]
    det = m11 * m22 - m12 * m21
    return np.stack([np.stack([m22, -m12], 1), np.stack([-m21, m11], 1)], 1) / det[:, None, None]


def apply_2x2(m: FloatArray, x_line: FloatArray, x_samp: FloatArray) -> tuple[FloatArray, ...]:
    """m·(x_line, x_samp) per observation; x may carry trailing axes (e.g. 3 ground partials)."""
    ex = (slice(None),) + (None,) * (np.ndim(x_line) - 1)
    return m[:, 0, 0][ex] * x_line + m[:, 0, 1][ex] * x_samp, (
        m[:, 1, 0][ex] * x_line + m[:, 1, 1][ex] * x_samp
    )


def from_rfm_space(
    affine: FloatArray, scene_index: IntArray, line_r: FloatArray, samp_r: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The RFM's (l_r, s_r) → image (l, s): solves the contract's 2×2 system exactly."""
    a = affine[scene_index]
    return apply_2x2(m_inverse(affine, scene_index), line_r + a[:, 0], samp_r + a[:, 3])


def image_residuals(
    affine: FloatArray, scene_index: IntArray, f_line: FloatArray, f_samp: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Residuals in RFM space f → computed − measured in image space, M⁻¹·f (exact)."""
    return apply_2x2(m_inverse(affine, scene_index), f_line, f_samp)


def project_adjusted(
    stack: RPCStack,
    affine: ArrayLike,
    scene_index: ArrayLike,
    lon: ArrayLike,
    lat: ArrayLike,
    h: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """Adjusted ground → image of the contract (module docstring), vectorized over scenes."""
    a = check_affine(affine, stack.n_scenes)
    idx = np.asarray(scene_index, np.int64).ravel()
    line_r, samp_r, _ = stack.project(idx, lon, lat, h)
    return from_rfm_space(a, idx, line_r, samp_r)


WGS84_A = 6378137.0
"""Semi-major axis of the WGS-84 ellipsoid (m)."""
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
"""First eccentricity squared of the WGS-84 ellipsoid."""


def radii_of_curvature(lat_deg: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """WGS-84 meridional (M) and prime-vertical (N) radii of curvature at latitude φ, metres."""
    w = np.sqrt(1.0 - WGS84_E2 * np.sin(np.radians(lat_deg)) ** 2)
    return WGS84_A * (1.0 - WGS84_E2) / w**3, WGS84_A / w


def metres_to_degrees(lat: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Degrees per metre east and north at each latitude, on the WGS84 ellipsoid: the prime
    vertical radius N·cos φ east, the meridian radius M north (metres on the ground, so that
    the points' σ in metres are; a sphere of radius a is 0.7 % off at the equator)."""
    m, n = radii_of_curvature(lat)
    return np.degrees(1.0 / (n * np.cos(np.radians(lat)))), np.degrees(1.0 / m)


def ground_jacobian_m(jac: FloatArray, lat: FloatArray) -> FloatArray:
    """∂(line, sample)/∂(east m, north m, h m) from the degree partials J (n, 2, 3)."""
    deg_e, deg_n = metres_to_degrees(lat)
    out = jac.copy()
    out[:, :, 0] *= deg_e[:, None]
    out[:, :, 1] *= deg_n[:, None]
    return out


def ray_tilts(
    stack: RPCStack, scene: IntArray, lon: FloatArray, lat: FloatArray, h: FloatArray
) -> FloatArray:
    """(n, 2): how far each observation's ray moves east and north (m) per metre of height at
    its ground point, the image position held: −A⁻¹·b, A = ∂(line, sample)/∂(east, north),
    b = ∂(line, sample)/∂h. The distance between two rays' tilts is their base-to-height ratio."""
    _, _, jac = stack.project(scene, lon, lat, h, partials=True)
    j = ground_jacobian_m(jac, np.asarray(lat, np.float64))
    a, b, c, d = j[:, 0, 0], j[:, 0, 1], j[:, 1, 0], j[:, 1, 1]
    hl, hs = j[:, 0, 2], j[:, 1, 2]
    with np.errstate(all="ignore"):  # a singular A (no ground shift moves the image): NaN
        det = a * d - b * c
        return np.column_stack([-(d * hl - b * hs) / det, -(a * hs - c * hl) / det])


def inv3(u: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Inverses of symmetric 3×3 matrices (n, 3, 3) by cofactors; ok=False where singular."""
    a, b, c = u[:, 0, 0], u[:, 0, 1], u[:, 0, 2]
    d, e, f = u[:, 1, 1], u[:, 1, 2], u[:, 2, 2]
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * c00 + b * c01 + c * c02
    scale = np.maximum(np.abs(a * d * f), np.finfo(float).tiny)
    ok = np.isfinite(det) & (np.abs(det) > 1e-12 * scale)
    safe = np.where(ok, det, 1.0)
    rows = [(c00, c01, c02), (c01, c11, c12), (c02, c12, c22)]
    inv = np.stack([np.stack(r, -1) for r in rows], axis=1) / safe[:, None, None]
    inv[~ok] = np.nan
    return inv, ok


def accumulate_points(
    point_index: IntArray, n_points: int, jx: FloatArray, f: FloatArray, w: FloatArray | float
) -> tuple[FloatArray, FloatArray]:
    """Per point U = Σ w·Jxᵀ·Jx (n_points, 3, 3) and g = Σ w·Jxᵀ·f (n_points, 3)."""
    u = np.empty((n_points, 3, 3))
    g = np.empty((n_points, 3))
    for i in range(3):
        for j in range(i, 3):
            val = w * (jx[:, 0, i] * jx[:, 0, j] + jx[:, 1, i] * jx[:, 1, j])
            u[:, i, j] = u[:, j, i] = np.bincount(point_index, val, minlength=n_points)
        gi = w * (jx[:, 0, i] * f[:, 0] + jx[:, 1, i] * f[:, 1])
        g[:, i] = np.bincount(point_index, gi, minlength=n_points)
    return u, g


def intersect_at_height(
    stack: RPCStack,
    affine: ArrayLike,
    scene_index: ArrayLike,
    line: ArrayLike,
    sample: ArrayLike,
    h: ArrayLike,
    max_iter: int = 30,
    tol_px: float = 1e-8,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Each observation alone on the ground at its given ellipsoidal height (§RC-2).

    Newton on (lon, lat) per observation with the analytic partials; returns lon, lat and a
    convergence flag (NaN position where it did not converge). The observations are taken in
    scene order, BATCH at a time (moved to RFM space a batch at a time too): the memory of the
    iterations stays bounded, and each batch's observations are projected without sorting them
    again at every iteration.
    """
    a = check_affine(affine, stack.n_scenes)
    idx = np.asarray(scene_index, np.int64).ravel()
    h = np.broadcast_to(np.asarray(h, np.float64).ravel(), idx.shape)
    line = np.asarray(line, np.float64).ravel()
    sample = np.asarray(sample, np.float64).ravel()
    order = np.argsort(idx, kind="stable")
    lon, lat, ok = np.empty(idx.size), np.empty(idx.size), np.empty(idx.size, bool)
    for start in range(0, idx.size, BATCH):
        rows = order[start : start + BATCH]
        tl, ts = to_rfm_space(a, idx[rows], line[rows], sample[rows])
        lon[rows], lat[rows], ok[rows] = _on_ground(
            stack, idx[rows], tl, ts, h[rows], max_iter, tol_px
        )
    return lon, lat, ok


def _on_ground(
    stack: RPCStack,
    idx: IntArray,
    tl: FloatArray,
    ts: FloatArray,
    h: FloatArray,
    max_iter: int,
    tol_px: float,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """`intersect_at_height` of observations in RFM space (tl, ts), idx sorted. An observation
    the model cannot put on the ground (a position far off its image, a model that degenerates
    there) may step to a singular or infinite position: it leaves the iterations unconverged,
    its position NaN, without numpy's warnings on the console."""
    lon = stack.offsets[idx, 3].copy()
    lat = stack.offsets[idx, 2].copy()
    ok = np.zeros(idx.size, bool)
    act = np.flatnonzero(np.isfinite(tl) & np.isfinite(ts) & np.isfinite(h))
    for _ in range(max_iter):
        if act.size == 0:
            break
        with np.errstate(all="ignore"):  # diverging: non-finite, dropped below
            pl, ps, jac = stack.project(idx[act], lon[act], lat[act], h[act], partials=True)
            el, es = tl[act] - pl, ts[act] - ps
            j00, j01, j10, j11 = jac[:, 0, 0], jac[:, 0, 1], jac[:, 1, 0], jac[:, 1, 1]
            det = j00 * j11 - j01 * j10
            lon[act] += (j11 * el - j01 * es) / det
            lat[act] += (j00 * es - j10 * el) / det
            done = (np.abs(el) < tol_px) & (np.abs(es) < tol_px)
        ok[act[done]] = True
        act = act[~done & np.isfinite(lon[act]) & np.isfinite(lat[act])]
    lon = wrap_lon(lon)
    lon[~ok] = np.nan
    lat[~ok] = np.nan
    return lon, lat, ok


@dataclass(frozen=True)
class Intersection:
    """Ground points (per point), residuals computed − measured (per observation), flags."""

    lon: FloatArray
    lat: FloatArray
    h: FloatArray
    v_line: FloatArray
    v_sample: FloatArray
    converged: NDArray[np.bool_]
    iterations: int


def _start(
    stack: RPCStack,
    a: FloatArray,
    idx: IntArray,
    pidx: IntArray,
    n_points: int,
    line: FloatArray,
    samp: FloatArray,
    h0: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Starting lon/lat per point: the mean of its observations put on the ground at h0
    (longitudes about the first one's, so that 179.99° and −179.99° average to 180°)."""
    lon, lat, ok = intersect_at_height(stack, a, idx, line, samp, h0[pidx], tol_px=1e-3)
    cnt = np.bincount(pidx, ok.astype(float), minlength=n_points)
    ref = np.zeros(n_points)
    given = np.flatnonzero(ok)
    points, first = np.unique(pidx[given], return_index=True)
    ref[points] = lon[given[first]]
    east = np.where(ok, wrap_lon(lon - ref[pidx]), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        lon0 = ref + np.bincount(pidx, east, minlength=n_points) / cnt
        lat0 = np.bincount(pidx, np.where(ok, lat, 0.0), minlength=n_points) / cnt
    return lon0, lat0


def intersect(
    stack: RPCStack,
    affine: ArrayLike,
    scene_index: ArrayLike,
    point_index: ArrayLike,
    line: ArrayLike,
    sample: ArrayLike,
    height_prior: tuple[ArrayLike, ArrayLike] | None = None,
    weights: ArrayLike | None = None,
    max_iter: int = 10,
    tol_m: float = 1e-4,
) -> Intersection:
    """Multi-ray least-squares intersection of tie points, vectorized per point (§RC-1).

    Gauss–Newton on each point's (east, north, h) in local metres with 3×3 normal equations;
    the cost is Σ w·|v|² over its observations (v = M⁻¹·f the image residual, computed −
    measured, f the RFM-space misclosure; weights w in px⁻², 1 by default) plus, with
    `height_prior` = (value m, σ m) per point, ((h − value)/σ)².
    Points need ≥ 2 rays, or 1 ray and a height prior; others get NaN and converged False.
    """
    a = check_affine(affine, stack.n_scenes)
    idx = np.asarray(scene_index, np.int64).ravel()
    pidx = np.asarray(point_index, np.int64).ravel()
    line = np.asarray(line, np.float64).ravel()
    samp = np.asarray(sample, np.float64).ravel()
    n_points = int(pidx.max()) + 1 if pidx.size else 0
    w = None if weights is None else np.asarray(weights, np.float64).ravel()
    if height_prior is None:
        h_p = np.bincount(pidx, stack.offsets[idx, 4], n_points) / np.bincount(pidx, None, n_points)
        w_h = np.zeros(n_points)
    else:
        h_p = np.broadcast_to(np.asarray(height_prior[0], np.float64), (n_points,)).copy()
        w_h = 1.0 / np.broadcast_to(np.asarray(height_prior[1], np.float64), (n_points,)) ** 2
    lon, lat = _start(stack, a, idx, pidx, n_points, line, samp, h_p)
    pts = _Points(lon, lat, h_p.copy(), h_p, w_h, np.zeros(n_points, bool), np.ones(n_points, bool))
    pts.unobserved(np.bincount(pidx, minlength=n_points) == 0)
    rays = _Rays(stack, a, idx, pidx, np.argsort(pidx, kind="stable"), line, samp, w)
    iterations = 0
    for _ in range(max_iter):
        iterations += 1
        rays.step(pts, tol_m)
        if not pts.todo.any():
            break
    v_line, v_sample = rays.residuals(pts)
    return Intersection(wrap_lon(pts.lon), pts.lat, pts.h, v_line, v_sample, pts.conv, iterations)


@dataclass(frozen=True)
class _Points:
    """The points of an intersection: position, height prior (value, weight), which have
    converged and which still move (neither converged nor singular); changed in place."""

    lon: FloatArray
    lat: FloatArray
    h: FloatArray
    h_p: FloatArray
    w_h: FloatArray
    conv: NDArray[np.bool_]
    todo: NDArray[np.bool_]

    def unobserved(self, none: NDArray[np.bool_]) -> None:
        """Points without an observation: no position (their normal matrix is singular)."""
        self.lon[none] = self.lat[none] = self.h[none] = np.nan
        self.todo[none] = False

    def step(self, t: IntArray, u: FloatArray, g: FloatArray, tol_m: float) -> None:
        """One Gauss–Newton step of the points t from the normal equations (u, g) of their
        observations, the height prior added here; a singular u leaves the point NaN."""
        u[:, 2, 2] += self.w_h[t]
        g[:, 2] += self.w_h[t] * (self.h[t] - self.h_p[t])
        u_inv, ok = inv3(u)
        step = -np.einsum("nij,nj->ni", u_inv, g)
        deg_e, deg_n = metres_to_degrees(self.lat[t])
        self.lon[t] += step[:, 0] * deg_e
        self.lat[t] += step[:, 1] * deg_n
        self.h[t] += step[:, 2]
        self.conv[t] = ok & np.all(np.abs(step) < tol_m, axis=1)
        self.todo[t] = ok & ~self.conv[t]


@dataclass(frozen=True)
class _Rays:
    """The observations of an intersection: scene, point, measured (line, sample) and weight
    (None: 1) each; `by_point` the observations ordered by point (stable: each point's in the
    caller's order)."""

    stack: RPCStack
    affine: FloatArray
    idx: IntArray
    pidx: IntArray
    by_point: IntArray
    line: FloatArray
    samp: FloatArray
    w: FloatArray | None

    def batches(self, points: NDArray[np.bool_] | None = None) -> list[IntArray]:
        """The observations of `points` (all by default) in point order, in batches of about
        BATCH that each hold every observation of their points (cut where a point begins): the
        memory stays bounded, and each point's sums take its observations in the same order as
        one pass over all would."""
        order = self.by_point
        if points is not None and not points.all():
            order = order[points[self.pidx[order]]]
        p = self.pidx[order]
        cuts = np.unique(np.r_[0, np.searchsorted(p, p[BATCH::BATCH]), order.size])
        return [order[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]

    def misclosure(self, rows: IntArray, pts: _Points) -> tuple[IntArray, FloatArray, FloatArray]:
        """The points of observations `rows`, their image residuals v = M⁻¹·f (n, 2) and the
        partials M⁻¹·J in metres (n, 2, 3) at the points' (lon, lat, h)."""
        p, idx = self.pidx[rows], self.idx[rows]
        tl, ts = to_rfm_space(self.affine, idx, self.line[rows], self.samp[rows])
        f, jx = _misclosure(self.stack, idx, pts.lon[p], pts.lat[p], pts.h[p], tl, ts)
        m_inv = m_inverse(self.affine, idx)
        v = np.stack(apply_2x2(m_inv, f[:, 0], f[:, 1]), axis=1)
        jx[:, 0, :], jx[:, 1, :] = apply_2x2(m_inv, jx[:, 0, :], jx[:, 1, :])
        return p, v, jx

    def step(self, pts: _Points, tol_m: float) -> None:
        """One Gauss–Newton step of the points still moving, a batch at a time: each batch's
        points from `accumulate_points` of its observations."""
        for rows in self.batches(pts.todo):
            p, v, jx = self.misclosure(rows, pts)
            lo, hi = p[0], p[-1] + 1
            u, g = accumulate_points(
                p - lo, hi - lo, jx, v, 1.0 if self.w is None else self.w[rows]
            )
            t = np.flatnonzero(pts.todo[lo:hi])
            pts.step(lo + t, u[t], g[t], tol_m)

    def residuals(self, pts: _Points) -> tuple[FloatArray, FloatArray]:
        """The image residuals (line, sample) of every observation at the points' positions."""
        v_line, v_sample = np.empty(self.idx.size), np.empty(self.idx.size)
        for rows in self.batches():
            _, v, _ = self.misclosure(rows, pts)
            v_line[rows], v_sample[rows] = v[:, 0], v[:, 1]
        return v_line, v_sample


def _misclosure(
    stack: RPCStack,
    idx: IntArray,
    lon: FloatArray,
    lat: FloatArray,
    h: FloatArray,
    tl: FloatArray,
    ts: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """RFM-space misclosure f = RFM(X) − target (n, 2) and its partials in metres (n, 2, 3)."""
    pl, ps, jac = stack.project(idx, lon, lat, h, partials=True)
    return np.stack([pl - tl, ps - ts], axis=1), ground_jacobian_m(jac, lat)


def normalization(lines: ArrayLike, samples: ArrayLike) -> tuple[FloatArray, ...]:
    """Image centre (l_c, s_c) and half sizes (L, S) per scene for the normalized affine."""
    lines = np.asarray(lines, np.float64)
    samples = np.asarray(samples, np.float64)
    return (lines - 1.0) / 2.0, (samples - 1.0) / 2.0, lines / 2.0, samples / 2.0


def affine_from_normalized(p: ArrayLike, lines: ArrayLike, samples: ArrayLike) -> FloatArray:
    """Normalized parameters → the contract's a0 a1 a2 b0 b1 b2 (n, 6).

    Normalized: Δl = a0' + a1'·(s − s_c)/S + a2'·(l − l_c)/L (same for b), so a0' is the shift at
    the image centre and a1', a2' the pixels the linear terms add at the image edges.
    """
    p = np.asarray(p, np.float64)
    lc, sc, hl, hs = normalization(lines, samples)
    out = np.empty_like(p)
    for k in (0, 3):
        out[:, k + 1] = p[:, k + 1] / hs
        out[:, k + 2] = p[:, k + 2] / hl
        out[:, k] = p[:, k] - out[:, k + 1] * sc - out[:, k + 2] * lc
    return out


def affine_to_normalized(a: ArrayLike, lines: ArrayLike, samples: ArrayLike) -> FloatArray:
    """The contract's a0 … b2 (n, 6) → normalized parameters (inverse of the above)."""
    a = np.asarray(a, np.float64)
    lc, sc, hl, hs = normalization(lines, samples)
    out = np.empty_like(a)
    for k in (0, 3):
        out[:, k + 1] = a[:, k + 1] * hs
        out[:, k + 2] = a[:, k + 2] * hl
        out[:, k] = a[:, k] + a[:, k + 1] * sc + a[:, k + 2] * lc
    return out


def normalized_jacobian(lines: ArrayLike, samples: ArrayLike) -> FloatArray:
    """∂(contract a0 … b2)/∂(normalized a0' … b2') per scene (n, 6, 6), for covariances."""
    lc, sc, hl, hs = normalization(lines, samples)
    n = np.asarray(lc).size
    jac = np.zeros((n, 6, 6))
    for k in (0, 3):
        jac[:, k, k] = 1.0
        jac[:, k, k + 1] = -sc / hs
        jac[:, k, k + 2] = -lc / hl
        jac[:, k + 1, k + 1] = 1.0 / hs
        jac[:, k + 2, k + 2] = 1.0 / hl
    return jac
