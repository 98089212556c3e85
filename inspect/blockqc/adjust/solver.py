"""The RFM-affine block adjustment (§3, §RC-3): Gauss–Newton with the reduced camera system.

Unknowns: six normalized affine parameters per scene (`geometry.affine_from_normalized`: a0' is
the shift at the image centre, a1', a2' the pixels the linear terms add at the image edges) and
each tie point's ground position, parametrized in local metres (east, north, h).
Observation equation per measurement (l, s) on scene j (Grodecki–Dial form, linear in the
affine): f = RFM_j(X) − (l, s) + Δ_j(l, s) = v, with Δ the contract affine at the measured
position; v = f in RFM space and M⁻¹·f (exactly computed − measured) in image space.

Normal equations [V W; Wᵀ U]: U is 3×3 per point and eliminated (Schur complement), leaving the
reduced system S = V − W·U⁻¹·Wᵀ of 6·n_scenes unknowns, assembled by vectorized sums over the
pairs of observations of each point and solved with a sparse LU. Datum without GCPs: weighted
priors on the affine parameters (a-priori RPC accuracy), height priors per point (a DEM, or a weak
one from the RPC height range), or scenes held fixed. Robust: Huber IRLS, then rejection of
observations with |v| > k·σ0 and a final least-squares pass with the image precision re-estimated.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from blockqc.adjust.geometry import (
    Intersection,
    RPCStack,
    accumulate_points,
    affine_from_normalized,
    apply_2x2,
    ground_jacobian_m,
    intersect,
    intersect_at_height,
    inv3,
    m_inverse,
    metres_to_degrees,
    normalization,
    normalized_jacobian,
    wrap_lon,
)
from blockqc.errors import InputError, Problem

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class Observations:
    """Tie observations: scene and point index per measurement (sorted by scene), line/sample."""

    scene: IntArray
    point: IntArray
    line: FloatArray
    sample: FloatArray
    n_scenes: int
    n_points: int


@dataclass(frozen=True)
class Priors:
    """The datum: affine priors (px), fixed scenes, a height prior per point (m)."""

    sigma_shift_px: float
    sigma_linear_px: float
    fixed: BoolArray
    height: FloatArray
    height_sigma: FloatArray
    height_source: str


@dataclass(frozen=True)
class Settings:
    max_iterations: int = 20
    huber_iterations: int = 2
    tol_px: float = 1e-3
    huber_k: float = 1.5
    reject_k: float = 4.0
    sigma_image_px: float = 0.5
    min_sigma_px: float = 0.01
    """Floor of the image precision used for weights and rejection (exact data)."""


@dataclass
class State:
    """Current estimate: normalized affines (n_scenes, 6) and ground points."""

    p: FloatArray
    lon: FloatArray
    lat: FloatArray
    h: FloatArray


@dataclass
class Linearization:
    f: FloatArray  # (n, 2) residual in image space, computed − measured, px
    jx: FloatArray  # (n, 2, 3) ∂f/∂(east, north, h) px/m
    g: FloatArray  # (n, 3) [1, ŝ, l̂] at the computed position: ∂f_line/∂(a0', a1', a2')


@dataclass
class Solution:
    affine: FloatArray
    affine_sigma: FloatArray
    normalized: FloatArray
    normalized_sigma: FloatArray
    lon: FloatArray
    lat: FloatArray
    h: FloatArray
    ground_sigma: FloatArray
    v_line: FloatArray
    v_sample: FloatArray
    outlier: BoolArray  # every observation left out: `rejected`, and those left without a 2nd ray
    rejected: BoolArray  # rejected by the rule |v| > k·σ0
    point_used: BoolArray
    converged: bool
    iterations: int
    sigma0_px: float
    sigma_image_px: float
    history: list[dict] = field(default_factory=list)
    message: str = ""


def prior_weights(priors: Priors, n_scenes: int) -> FloatArray:
    """Diagonal prior weights (px⁻²) of the normalized affine parameters (n_scenes, 6)."""
    sig = np.array([priors.sigma_shift_px, priors.sigma_linear_px, priors.sigma_linear_px] * 2)
    with np.errstate(divide="ignore"):
        w = np.broadcast_to(1.0 / sig**2, (n_scenes, 6)).copy()
    w[priors.fixed] = 0.0  # held by `hold_fixed` instead
    return w


def hold_fixed(
    s: sp.csc_matrix, b: FloatArray, fixed: BoolArray
) -> tuple[sp.csc_matrix, FloatArray]:
    """Hold the fixed scenes' parameters: their rows and columns become identity, Δp = 0."""
    if not fixed.any():
        return s, b
    hold = np.repeat(fixed, 6)
    keep = sp.diags((~hold).astype(float))
    s = (keep @ s @ keep + sp.diags(hold.astype(float))).tocsc()
    return s, np.where(hold, 0.0, b)


def linearize(
    stack: RPCStack,
    obs: Observations,
    norm: tuple[FloatArray, ...],
    state: State,
    partials: bool = True,
) -> Linearization:
    """Residuals in image space (computed − measured) and their partials at the estimate.

    The residual is v = M⁻¹·f, f the misclosure in RFM space with the measured (l, s) in the
    affine terms and M = [[1 − a2, −a1], [−b2, 1 − b1]]; the affine's partials are taken at the
    computed position (measured + v). Minimizing f instead would weigh the noise by M, and the
    noise in the measured (l, s) would pull the scale terms a2, b1 of every scene the same way
    (a bias of the datum the priors alone fix).
    """
    lc, sc, hl, hs = (x[obs.scene] for x in norm)
    g = np.stack([np.ones(obs.line.size), (obs.sample - sc) / hs, (obs.line - lc) / hl], 1)
    pt = obs.point
    rl, rs, jac = stack.project(obs.scene, state.lon[pt], state.lat[pt], state.h[pt], partials)
    pa = state.p[obs.scene]
    f_line = rl - obs.line + np.einsum("ij,ij->i", g, pa[:, :3])
    f_samp = rs - obs.sample + np.einsum("ij,ij->i", g, pa[:, 3:])
    m_inv = m_inverse(affine_from_normalized(state.p, *_sizes(norm)), obs.scene)
    v = np.stack(apply_2x2(m_inv, f_line, f_samp), 1)
    g[:, 1] += v[:, 1] / hs
    g[:, 2] += v[:, 0] / hl
    if jac is None:
        return Linearization(v, np.zeros((0, 2, 3)), g)
    jx = ground_jacobian_m(jac, state.lat[pt])  # the RPC partials of v: M⁻¹·J
    jx[:, 0, :], jx[:, 1, :] = apply_2x2(m_inv, jx[:, 0, :], jx[:, 1, :])
    return Linearization(v, jx, g)


@dataclass(frozen=True)
class Pairs:
    """Unordered pairs (o1, o2) of distinct observations of one point, and the scene-pair
    blocks they fall in: `block` per pair, indexing (`rows`, `cols`) scene pairs."""

    o1: IntArray
    o2: IntArray
    block: IntArray
    rows: IntArray
    cols: IntArray


def point_pairs(obs: Observations) -> Pairs:
    """All unordered pairs of distinct observations of the same point (a loop over the few
    distinct numbers of observations per point, vectorized inside)."""
    order = np.argsort(obs.point, kind="stable")
    counts = np.bincount(obs.point, minlength=obs.n_points)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    first, second = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for k in np.unique(counts[counts >= 2]):
        s = starts[counts == k]
        for i in range(k):
            for j in range(i + 1, k):
                first.append(order[s + i])
                second.append(order[s + j])
    o1, o2 = np.concatenate(first), np.concatenate(second)
    ns = obs.n_scenes
    key, block = np.unique(obs.scene[o1] * ns + obs.scene[o2], return_inverse=True)
    return Pairs(o1, o2, block.ravel(), key // ns, key % ns)


Cols = list[FloatArray]


def _cols(a: FloatArray) -> Cols:
    """The columns of an (n, k) array as contiguous 1-D arrays."""
    return [np.ascontiguousarray(a[:, i]) for i in range(a.shape[1])]


def _dot3(a: Cols, b: Cols) -> FloatArray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _sym_apply(u: Cols, v: Cols) -> Cols:
    """Symmetric 3×3 matrices (u00, u01, u02, u11, u12, u22 per row) times 3-vectors."""
    return [
        u[0] * v[0] + u[1] * v[1] + u[2] * v[2],
        u[1] * v[0] + u[3] * v[1] + u[4] * v[2],
        u[2] * v[0] + u[4] * v[1] + u[5] * v[2],
    ]


def _block_sums(
    key: IntArray,
    n_keys: int,
    k: list[list[FloatArray]],
    ga: Cols,
    gb: Cols,
    symmetric: bool = False,
) -> FloatArray:
    """Σ over rows with the same key of kron(K, ga·gbᵀ): (n_keys, 6, 6) with index c·3+i.

    K is given as k[c][d] (1-D per row). With `symmetric` (K symmetric, ga = gb) only the upper
    triangle is summed and mirrored.
    """
    out = np.empty((n_keys, 6, 6))
    for r in range(6):
        c, i = divmod(r, 3)
        for q in range(r if symmetric else 0, 6):
            d, j = divmod(q, 3)
            out[:, r, q] = np.bincount(key, k[c][d] * ga[i] * gb[j], n_keys)
            if symmetric:
                out[:, q, r] = out[:, r, q]
    return out


def _coo(rows: IntArray, cols: IntArray, blocks: FloatArray) -> tuple[IntArray, ...]:
    """COO triplets of 6×6 blocks placed at (6·row, 6·col)."""
    r = (6 * rows)[:, None, None] + np.arange(6)[None, :, None]
    c = (6 * cols)[:, None, None] + np.arange(6)[None, None, :]
    r, c = np.broadcast_arrays(r, c)
    return r.ravel(), c.ravel(), blocks.ravel()


def reduced_system(
    obs: Observations,
    lin: Linearization,
    w: FloatArray,
    u_inv: FloatArray,
    gx: FloatArray,
    pairs: Pairs,
    prior_w: FloatArray,
    p: FloatArray,
) -> tuple[sp.csc_matrix, FloatArray]:
    """The reduced camera system S·Δp = b after eliminating every point (Schur complement)."""
    ns, pt = obs.n_scenes, obs.point
    u = [u_inv[:, i, j][pt] for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]
    j0, j1 = _cols(lin.jx[:, 0, :]), _cols(lin.jx[:, 1, :])
    y0, y1 = _sym_apply(u, j0), _sym_apply(u, j1)  # U⁻¹·Jxᵀ, line and sample columns
    del u
    w2 = w * w
    k01 = -w2 * _dot3(j0, y1)
    k_diag = [[w - w2 * _dot3(j0, y0), k01], [k01, w - w2 * _dot3(j1, y1)]]
    g = _cols(lin.g)
    diag = _block_sums(obs.scene, ns, k_diag, g, g, symmetric=True)
    del k_diag, k01
    diag[:, np.arange(6), np.arange(6)] += prior_w
    o1, o2 = pairs.o1, pairs.o2
    ww = -w[o1] * w[o2]
    a = [[c[o1] for c in j0], [c[o1] for c in j1]]
    b = [[c[o2] for c in y0], [c[o2] for c in y1]]
    k_off = [[ww * _dot3(a[c], b[d]) for d in range(2)] for c in range(2)]
    del a, b
    off = _block_sums(pairs.block, pairs.rows.size, k_off, [c[o1] for c in g], [c[o2] for c in g])
    kr, kc = pairs.rows, pairs.cols
    parts = [
        _coo(np.arange(ns), np.arange(ns), diag),
        _coo(kr, kc, off),
        _coo(kc, kr, off.transpose(0, 2, 1)),
    ]
    rows, cols, vals = (np.concatenate([q[i] for q in parts]) for i in range(3))
    s = sp.coo_matrix((vals, (rows, cols)), shape=(6 * ns, 6 * ns)).tocsc()
    return s, _reduced_rhs(obs, lin, w, u_inv, gx, prior_w, p)


def _scene_sum(obs: Observations, w: FloatArray, g: FloatArray, q: FloatArray) -> FloatArray:
    """Σ_o w·[g·q_line, g·q_sample] per scene, (n_scenes, 6)."""
    out = np.empty((obs.n_scenes, 6))
    for c in range(2):
        for i in range(3):
            out[:, c * 3 + i] = np.bincount(obs.scene, w * g[:, i] * q[:, c], obs.n_scenes)
    return out


def _reduced_rhs(
    obs: Observations,
    lin: Linearization,
    w: FloatArray,
    u_inv: FloatArray,
    gx: FloatArray,
    prior_w: FloatArray,
    p: FloatArray,
) -> FloatArray:
    """b = −g_a + Σ W·U⁻¹·g_x (flattened, 6·n_scenes)."""
    ga = _scene_sum(obs, w, lin.g, lin.f) + prior_w * p
    yx = np.matmul(u_inv, gx[:, :, None])[obs.point]
    q = np.matmul(lin.jx, yx)[:, :, 0]
    return (-ga + _scene_sum(obs, w, lin.g, q)).ravel()


#: the file a problem of the adjustment itself names: the block (`run.named_block` names its
#: delivery instead)
BLOCK = "<block>"
SINGULAR = (
    "the block adjustment is singular: the datum is not fixed (give finite a-priori "
    "affine σ, --fix a scene or --dem) or some scene has too few tie observations"
)


def check_datum(priors: Priors) -> None:
    """Without a fixed scene, infinite a-priori σ leave the block's common shift and linear
    terms free: no tie observation fixes them, so the system is singular (refused up front,
    as the image noise would hide the defect from the factorization)."""
    free = not np.isfinite(priors.sigma_shift_px) or not np.isfinite(priors.sigma_linear_px)
    if free and not priors.fixed.any():
        raise InputError(Problem(BLOCK, SINGULAR))


def solve_reduced(s: sp.csc_matrix, b: FloatArray) -> tuple[FloatArray, spla.SuperLU]:
    """Sparse LU of the reduced system; a singular one is an InputError saying why."""
    message = SINGULAR
    diag = s.diagonal()
    if not np.all(np.isfinite(diag)) or diag.min() <= 0:
        raise InputError(Problem(BLOCK, message))
    scale = sp.diags(1.0 / np.sqrt(diag))
    try:
        lu = spla.splu((scale @ s @ scale).tocsc())  # unit diagonal: pivots comparable
    except RuntimeError:
        raise InputError(Problem(BLOCK, message)) from None
    d = np.abs(lu.U.diagonal())
    if not np.all(np.isfinite(d)) or d.min() <= 1e-13:
        raise InputError(Problem(BLOCK, message))
    return scale @ lu.solve(scale @ b), lu


def back_substitute(
    obs: Observations,
    lin: Linearization,
    w: FloatArray,
    u_inv: FloatArray,
    gx: FloatArray,
    dp: FloatArray,
) -> FloatArray:
    """Point updates Δx = U⁻¹·(−g_x − Σ Wᵀ·Δp) in (east, north, h) metres, (n_points, 3)."""
    d = dp.reshape(-1, 6)[obs.scene]
    t_line = np.einsum("ni,ni->n", lin.g, d[:, :3])
    t_samp = np.einsum("ni,ni->n", lin.g, d[:, 3:])
    wt = w[:, None] * (lin.jx[:, 0, :] * t_line[:, None] + lin.jx[:, 1, :] * t_samp[:, None])
    acc = np.stack([np.bincount(obs.point, wt[:, i], obs.n_points) for i in range(3)], 1)
    return np.einsum("nij,nj->ni", u_inv, -gx - acc)


@dataclass
class Step:
    """One Gauss–Newton step: the linearization it used, its LU, the largest updates."""

    lin: Linearization
    w: FloatArray
    s: sp.csc_matrix
    lu: spla.SuperLU
    u_inv: FloatArray
    max_dp: float
    max_dx: float
    max_dx_px: float


def gauss_newton_step(
    stack: RPCStack,
    obs: Observations,
    norm: tuple[FloatArray, ...],
    state: State,
    weigh: Callable[[FloatArray], FloatArray],
    priors: Priors,
    pairs: Pairs,
    used: BoolArray,
) -> Step:
    """Linearize, weigh (`weigh(f)`), eliminate the points, solve the reduced system and
    update `state` in place."""
    lin = linearize(stack, obs, norm, state)
    w = weigh(lin.f)
    u, gx = accumulate_points(obs.point, obs.n_points, lin.jx, lin.f, w)
    wh = np.where(used, 1.0 / priors.height_sigma**2, 0.0)
    u[:, 2, 2] += wh
    gx[:, 2] += wh * (state.h - priors.height)
    u[~used] = np.eye(3)
    u_inv, ok = inv3(u)
    if not np.all(ok):
        bad = int(np.flatnonzero(~ok)[0])
        raise InputError(Problem(BLOCK, f"tie point #{bad + 1}: its rays do not fix its position"))
    u_inv[~used] = 0.0
    prior_w = prior_weights(priors, obs.n_scenes)
    s_mat, b = reduced_system(obs, lin, w, u_inv, gx, pairs, prior_w, state.p)
    s_mat, b = hold_fixed(s_mat, b, priors.fixed)
    dp, lu = solve_reduced(s_mat, b)
    dx = back_substitute(obs, lin, w, u_inv, gx, dp)
    state.p += dp.reshape(-1, 6)
    deg_e, deg_n = metres_to_degrees(state.lat)
    state.lon += dx[:, 0] * deg_e
    state.lat += dx[:, 1] * deg_n
    state.h += dx[:, 2]
    moved = np.matmul(lin.jx, dx[obs.point][:, :, None])[:, :, 0]
    return Step(
        lin,
        w,
        s_mat,
        lu,
        u_inv,
        float(np.abs(dp).max()),
        float(np.abs(dx[used]).max(initial=0.0)),
        float(np.abs(moved[w > 0]).max(initial=0.0)),
    )


def huber_weights(f: FloatArray, kept: BoolArray, k: float) -> tuple[FloatArray, float]:
    """Huber weight per observation on |f| against a robust scale (Rayleigh median / 1.1774)."""
    norm = np.hypot(f[:, 0], f[:, 1])
    scale = max(float(np.median(norm[kept])) / np.sqrt(2 * np.log(2)), 1e-3)
    w = np.minimum(1.0, k * scale / np.maximum(norm, 1e-300))
    return np.where(kept, w, 0.0), scale


def sigma0(
    f: FloatArray,
    w: FloatArray,
    priors: Priors,
    used: BoolArray,
    q_hh: FloatArray,
    affine_share: float = 0.0,
) -> float:
    """σ0 of the image observations: √(vᵀPv / r), unitless (1 when σ_image was right).

    r = 2·n_kept − 6·n_scenes − 3·n_points + Σ w·Q over the priors: each prior takes over the
    share w·Q of its parameter (Q the parameter's cofactor), so a weak height prior frees no
    image redundancy and a datum prior frees almost one (variance component of the images).
    `q_hh` is each point's height cofactor; `affine_share` Σ w·Q over the affine priors.
    """
    wh = np.where(used, 1.0 / priors.height_sigma**2, 0.0)
    vpv = float(np.sum(w * np.sum(f**2, axis=1)))
    n_kept = int(np.count_nonzero(w > 0))
    r = 2 * n_kept - 3 * int(used.sum()) + float(np.sum(wh * np.nan_to_num(q_hh)))
    r += affine_share - 6 * priors.fixed.size
    return float(np.sqrt(vpv / r)) if r >= 1.0 else float("nan")  # below one: no estimate


def iterate(
    ctx: Context,
    state: State,
    weigh: Callable[[FloatArray], FloatArray],
    phase: str,
    budget: int,
) -> tuple[bool, Step]:
    """Gauss–Newton steps until every update moves every observation by less than tol_px
    (affine steps in px, ground steps through their partials), at most `budget` steps."""
    step = None
    for _ in range(max(1, budget)):
        step = gauss_newton_step(
            ctx.stack, ctx.obs, ctx.norm, state, weigh, ctx.priors, ctx.pairs, ctx.used
        )
        kept = ctx.kept
        rms = float(np.sqrt(np.mean(np.sum(step.lin.f[kept] ** 2, axis=1)))) if kept.any() else 0
        ctx.history.append(
            {
                "iteration": len(ctx.history) + 1,
                "phase": phase,
                "rms_px": rms,
                "max_affine_step_px": step.max_dp,
                "max_ground_step_m": step.max_dx,
                "max_ground_step_px": step.max_dx_px,
            }
        )
        if step.max_dp < ctx.settings.tol_px and step.max_dx_px < ctx.settings.tol_px:
            return True, step
    assert step is not None
    return False, step


@dataclass
class Context:
    """What every step needs: geometry, observations, datum, settings, masks and history."""

    stack: RPCStack
    obs: Observations
    norm: tuple[FloatArray, ...]
    priors: Priors
    settings: Settings
    pairs: Pairs
    kept: BoolArray
    used: BoolArray
    history: list[dict] = field(default_factory=list)

    def drop_weak_points(self) -> None:
        """Points with fewer than two kept observations leave the adjustment."""
        count = np.bincount(self.obs.point, self.kept.astype(float), self.obs.n_points)
        self.used &= count >= 2
        self.kept &= self.used[self.obs.point]


DENSE_LIMIT = 12000
"""Largest reduced system (6·n_scenes) inverted densely for the full affine covariance."""


def _dense_covariance(s: sp.csc_matrix, fixed: BoolArray) -> tuple[FloatArray, FloatArray]:
    """S⁻¹ by dense Cholesky (LAPACK potrf/potri); held parameters get zero rows/columns."""
    import scipy.linalg as sla

    n = s.shape[0]
    ns = n // 6
    factor, info = sla.lapack.dpotrf(s.toarray(), lower=True, overwrite_a=True)
    full, info2 = sla.lapack.dpotri(factor, lower=True, overwrite_c=True)
    if info or info2:
        raise InputError(Problem(BLOCK, "the reduced normal matrix is not positive definite"))
    for i0 in range(0, n, 512):  # mirror the lower triangle, a band at a time (no n² copies)
        i1 = min(n, i0 + 512)
        band = full[i0:i1, i0:i1]
        band[np.triu_indices(i1 - i0, 1)] = band.T[np.triu_indices(i1 - i0, 1)]
        full[i0:i1, i1:] = full[i1:, i0:i1].T
    hold = np.repeat(fixed, 6)
    full[hold, :] = 0.0
    full[:, hold] = 0.0
    blocks = full.reshape(ns, 6, ns, 6)[np.arange(ns), :, np.arange(ns), :]
    return blocks, full


def affine_covariance(s: sp.csc_matrix, fixed: BoolArray) -> tuple[FloatArray, FloatArray | None]:
    """Diagonal 6×6 blocks of S⁻¹ (n_scenes, 6, 6) and, when small enough, the whole S⁻¹.

    Dense Cholesky inverse up to DENSE_LIMIT unknowns; beyond, the needed columns are solved
    from the sparse LU, 600 at a time, and only the diagonal blocks are kept.
    """
    n = s.shape[0]
    ns = n // 6
    if n <= DENSE_LIMIT:
        with threadpool_limits(os.cpu_count() or 1, user_api="blas"):
            return _dense_covariance(s, fixed)
    blocks = np.empty((ns, 6, 6))
    lu = spla.splu(s)
    for start in range(0, ns, 100):
        stop = min(ns, start + 100)
        rhs = np.zeros((n, 6 * (stop - start)))
        rhs[6 * start : 6 * stop, :] = np.eye(6 * (stop - start))
        cols = lu.solve(rhs)[6 * start : 6 * stop, :]
        k = stop - start
        blocks[start:stop] = cols.reshape(k, 6, k, 6)[np.arange(k), :, np.arange(k), :]
    blocks[fixed] = 0.0
    return blocks, None


def point_covariance(
    obs: Observations, pairs: Pairs, step: Step, full: FloatArray | None, chunk: int = 400_000
) -> FloatArray:
    """Per point variance factors (n_points, 3) in (east, north, h) m: diag(U⁻¹ + Σ Aᵀ·C·A').

    A_o = W_o·U⁻¹ = w_o·[g_o ⊗ y_o,lineᵀ; g_o ⊗ y_o,sampleᵀ] (y = U⁻¹·Jxᵀ) couples observation o
    to its scene's affine, C the affine part of S⁻¹, summed over the ordered pairs of the point's
    observations: (Aᵀ·C·A')_ii = w·w'·Σ_cd (g_oᵀ·C_cd·g_o')·y_c,i·y'_d,i.
    Without the full S⁻¹ (a very large block) only U⁻¹ is used (the affines held fixed).
    """
    var = np.einsum("nii->ni", step.u_inv).copy()
    if full is None:
        return var
    pt = obs.point
    u = [step.u_inv[:, i, j][pt] for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]
    y = np.stack(
        [np.stack(_sym_apply(u, _cols(step.lin.jx[:, c, :])), 1) for c in range(2)], 1
    )  # (n, 2 rows, 3)
    del u
    n = pt.size
    first = np.concatenate([np.arange(n), pairs.o1, pairs.o2])
    second = np.concatenate([np.arange(n), pairs.o2, pairs.o1])
    ns = obs.n_scenes
    c4 = full.reshape(ns, 6, ns, 6)
    for start in range(0, first.size, chunk):
        p1, p2 = first[start : start + chunk], second[start : start + chunk]
        c = c4[obs.scene[p1], :, obs.scene[p2], :]  # (m, 6, 6)
        g1, g2 = step.lin.g[p1], step.lin.g[p2]
        ww = step.w[p1] * step.w[p2]
        t = np.zeros((p1.size, 3))
        for ci in range(2):
            for di in range(2):
                block = c[:, 3 * ci : 3 * ci + 3, 3 * di : 3 * di + 3]
                m = np.einsum("ni,nij,nj->n", g1, block, g2)
                t += (ww * m)[:, None] * y[p1, ci, :] * y[p2, di, :]
        for i in range(3):
            var[:, i] += np.bincount(pt[p1], t[:, i], obs.n_points)
    return var


def affine_share(q_affine: FloatArray, priors: Priors) -> float:
    """Σ w·Q over the affine priors (the image redundancy they take over), held parameters 1."""
    prior_w = prior_weights(priors, q_affine.shape[0])
    share = np.where(prior_w > 0, prior_w * np.einsum("nii->ni", q_affine), 0.0)
    share[priors.fixed] = 1.0  # held parameters take no image redundancy
    return float(share.sum())


#: the affine priors' share is left out of σ0 inside the iterations when, even at its largest
#: (one per parameter), it would move σ0 by less than this (a large block: 6·n_scenes ≪ 2·n)
SHARE_NEGLIGIBLE = 0.005


def loop_affine_share(step: Step, ctx: Context) -> float:
    """The affine priors' share of σ0's redundancy at a step of the σ/rejection loop, so that
    the σ the weights and the rejection use is the σ0 reported; on a small block it is several
    redundancies (a 3-scene block: 11, σ used 11 % above the σ0 reported without it). Computed
    only when it can matter: it needs the diagonal of S⁻¹."""
    n_kept = int(np.count_nonzero(step.w > 0))
    r = 2 * n_kept - 3 * int(ctx.used.sum()) - 6 * ctx.obs.n_scenes
    if r >= 1 and 6 * ctx.obs.n_scenes / (2 * r) < SHARE_NEGLIGIBLE:
        return 6.0 * float(ctx.priors.fixed.sum())  # the held parameters' exact share
    return affine_share(affine_covariance(step.s, ctx.priors.fixed)[0], ctx.priors)


def fixed_weights(kept: BoolArray, sig: float) -> Callable[[FloatArray], FloatArray]:
    """Least-squares weights 1/σ² (px⁻²) on the kept observations, 0 on the others."""
    w = np.where(kept, 1.0 / sig**2, 0.0)
    return lambda f: w


def _original(
    stack: RPCStack, obs: Observations, priors: Priors, weights: FloatArray | None
) -> Intersection:
    """The points intersected with the original RPCs (zero affines) and their height priors,
    from the observations of nonzero `weights` (None: all)."""
    zero = np.zeros((obs.n_scenes, 6))
    prior = (priors.height, priors.height_sigma)
    return intersect(
        stack, zero, obs.scene, obs.point, obs.line, obs.sample, height_prior=prior, weights=weights
    )


def initial_state(stack: RPCStack, obs: Observations, priors: Priors) -> tuple[State, BoolArray]:
    """Zero affines; points intersected with the original RPCs (and their height priors); and
    each point's convergence flag."""
    res = _original(stack, obs, priors, None)
    ok = res.converged & np.isfinite(res.lon) & np.isfinite(res.h)
    lon = np.where(ok, res.lon, np.nan)
    state = State(np.zeros((obs.n_scenes, 6)), lon, res.lat.copy(), res.h.copy())
    return state, ok


def refuse_without_intersection(
    stack: RPCStack, obs: Observations, priors: Priors, used: BoolArray
) -> None:
    """Refuse a block whose points seen on two or more scenes all have rays that the original
    RPCs do not intersect (as `blockqc inspect` says it of the delivered geometry): nothing is
    left to adjust. The RPC files to blame are named when they can be told: those that put
    none of their scene's observations on the ground alone, at the points' prior heights (a
    scale or an offset wrong); else the folder of the RPCs."""
    multi = int(np.count_nonzero(np.bincount(obs.point, minlength=obs.n_points) >= 2))
    if used.any() or not multi:
        return  # some point to adjust; or none on two scenes, which the inputs refuse
    why = (
        f"the rays of the {multi} tie points seen on two or more scenes do not intersect with "
        "the delivered geometry"
    )
    zero = np.zeros((obs.n_scenes, 6))
    _, _, ok = intersect_at_height(
        stack, zero, obs.scene, obs.line, obs.sample, priors.height[obs.point]
    )
    seen = np.bincount(obs.scene, minlength=obs.n_scenes)
    grounded = np.bincount(obs.scene, ok, minlength=obs.n_scenes)
    blamed = [k for k in np.flatnonzero((seen > 0) & (grounded == 0)) if k < len(stack.sources)]
    if blamed:
        raise InputError(
            [
                Problem(
                    stack.sources[k],
                    f"{why}: this RPC puts none of the {seen[k]} tie-point observations of its "
                    "scene on the ground at their points' prior heights (expected the RPC of "
                    "the scene: a scale, an offset or a coefficient wrong?)",
                )
                for k in blamed
            ]
        )
    folder = str(Path(stack.sources[0]).parent) if stack.sources else BLOCK
    raise InputError(
        Problem(
            folder,
            f"{why} (the RPCs of this folder): expected RPCs whose rays of each tie point meet",
        )
    )


MAX_ROUNDS = 12
"""Rounds of σ re-estimation and rejection (one observation per point and round)."""


def largest_per_point(point: IntArray, kept: BoolArray, v: FloatArray, bound: float) -> BoolArray:
    """The kept observations with |v| > bound that have the largest |v| of their point: one
    per point and round, so that a gross error does not take its point's good rays with it."""
    size = np.hypot(v[:, 0], v[:, 1])
    cand = np.flatnonzero(kept & (size > bound))
    out = np.zeros(point.size, bool)
    if cand.size:
        order = cand[np.lexsort((-size[cand], point[cand]))]
        _, first = np.unique(point[order], return_index=True)
        out[order[first]] = True
    return out


@threadpool_limits.wrap(limits=1, user_api="blas")
def adjust(
    stack: RPCStack,
    obs: Observations,
    lines: FloatArray,
    samples: FloatArray,
    priors: Priors,
    settings: Settings,
) -> tuple[Solution, FloatArray, FloatArray]:
    """Run the block adjustment; returns the solution and the residuals before (v_l, v_s).

    BLAS runs single-threaded in the iterations (many small products, where threads only
    contend); the dense covariance may use every core.
    """
    check_datum(priors)
    ctx, state = _start(stack, obs, normalization(lines, samples), priors, settings)
    sig = settings.sigma_image_px

    def huber(f: FloatArray) -> FloatArray:
        return huber_weights(f, ctx.kept, settings.huber_k)[0] / sig**2

    _, step = iterate(ctx, state, huber, "huber", settings.huber_iterations)
    converged, step, weights_sig, rejected = _reject_rounds(ctx, state, step, sig)
    sol = _solution(ctx, state, step, weights_sig, converged, rejected)
    before = _original(stack, obs, priors, (~sol.outlier).astype(float))  # the same rays as after
    return sol, before.v_line, before.v_sample


def _start(
    stack: RPCStack,
    obs: Observations,
    norm: tuple[FloatArray, ...],
    priors: Priors,
    settings: Settings,
) -> tuple[Context, State]:
    """The context and the initial state: every observation kept, the points the original RPCs
    intersect used (those left with fewer than two observations dropped; a block with none
    refused), the others placed at the RPCs' offsets and their height priors."""
    state, ok = initial_state(stack, obs, priors)
    ctx = Context(
        stack,
        obs,
        norm,
        priors,
        settings,
        point_pairs(obs),
        kept=np.ones(obs.point.size, bool),
        used=ok.copy(),
    )
    ctx.drop_weak_points()
    refuse_without_intersection(stack, obs, priors, ctx.used)
    state.lon = np.where(ctx.used, state.lon, stack.offsets[0, 3])
    state.lat = np.where(ctx.used, state.lat, stack.offsets[0, 2])
    state.h = np.where(ctx.used, state.h, priors.height)
    return ctx, state


def _reject_rounds(
    ctx: Context, state: State, step: Step, sig: float
) -> tuple[bool, Step, float, BoolArray]:
    """After the Huber phase, rounds of σ re-estimation and rejection (the largest |v| > k·σ0 of
    each point), each followed by least-squares steps with weights 1/σ², until neither the σ
    nor the rejections change at a converged solution, or the iterations or rounds run out.
    Returns whether it settled converged, the last step, the σ of its weights and the
    observations rejected."""
    obs, priors, settings = ctx.obs, ctx.priors, ctx.settings
    converged = False
    settled = False  # the σ and the rejections no longer change at a converged solution
    rejected = np.zeros(obs.point.size, bool)
    weights_sig = sig  # the σ of the last step's weights
    for round_ in range(MAX_ROUNDS + 1):
        share = loop_affine_share(step, ctx)
        s0 = sigma0(step.lin.f, step.w, priors, ctx.used, step.u_inv[:, 2, 2], share) * sig
        s0 = max(s0, settings.min_sigma_px) if np.isfinite(s0) else sig
        new = largest_per_point(obs.point, ctx.kept, step.lin.f, settings.reject_k * s0)
        changed = abs(s0 / sig - 1.0) > 0.02 or bool(new.any())
        if not changed and converged:
            settled = True
            break
        budget = settings.max_iterations - sum(h["phase"] == "ls" for h in ctx.history)
        if budget <= 0 or round_ == MAX_ROUNDS:
            break
        ctx.kept &= ~new
        rejected |= new
        ctx.drop_weak_points()
        sig = s0
        converged, step = iterate(ctx, state, fixed_weights(ctx.kept, sig), "ls", budget)
        weights_sig = sig
    return converged and settled, step, weights_sig, rejected


def _solution(
    ctx: Context, state: State, last: Step, sig: float, converged: bool, rejected: BoolArray
) -> Solution:
    """Final residuals, σ0 and the precision of every parameter (σ0²·S⁻¹ and the points');
    `sig`: the σ of the last step's weights, of which σ0 (unitless) is the variance factor;
    `rejected`: the observations the rule |v| > k·σ0 rejected."""
    obs, lines, samples = ctx.obs, *_sizes(ctx.norm)
    kept = ctx.kept.copy()
    step = last
    lin = linearize(ctx.stack, obs, ctx.norm, state, partials=False)
    q_affine, full = affine_covariance(step.s, ctx.priors.fixed)
    q_ground = point_covariance(obs, ctx.pairs, step, full)
    share = affine_share(q_affine, ctx.priors)
    s0 = sigma0(lin.f, step.w, ctx.priors, ctx.used, q_ground[:, 2], share)
    affine = affine_from_normalized(state.p, lines, samples)
    blocks = q_affine * s0**2
    jac = normalized_jacobian(lines, samples)
    contract = np.einsum("nij,njk,nlk->nil", jac, blocks, jac)
    ground = q_ground * s0**2
    vl, vs = lin.f[:, 0].copy(), lin.f[:, 1].copy()
    return Solution(
        affine=affine,
        affine_sigma=np.sqrt(np.einsum("nii->ni", contract)),
        normalized=state.p.copy(),
        normalized_sigma=np.sqrt(np.einsum("nii->ni", blocks)),
        lon=wrap_lon(state.lon),
        lat=state.lat,
        h=state.h,
        ground_sigma=np.sqrt(ground),
        v_line=vl,
        v_sample=vs,
        outlier=~kept,
        rejected=rejected,
        point_used=ctx.used.copy(),
        converged=converged and step.max_dp < 10 * ctx.settings.tol_px,
        iterations=len(ctx.history),
        sigma0_px=float(s0 * sig),
        sigma_image_px=float(sig),
        history=ctx.history,
    )


def _sizes(norm: tuple[FloatArray, ...]) -> tuple[FloatArray, FloatArray]:
    """(lines, samples) back from the normalization (half sizes L, S)."""
    return 2.0 * norm[2], 2.0 * norm[3]
