"""Multi-ray geometry over a block's adjusted scene models: projection, intersection (§RC).

Observations are (scene index, line, sample) rows; a tie point's rays are intersected by least
squares in a local east/north/up frame (metres) with Gauss–Newton steps, every point at once: the
3×3 normal equations of all points are assembled with `bincount` and solved in one batch. Scene
models are evaluated scene by scene (one vectorized call per scene).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from blockqc.geometry_inputs import SceneModel
from blockqc.rfm.model import FloatArray

WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3
MAX_ITER = 30
"""Gauss–Newton steps allowed per intersection."""
TOL_M = 1e-5
"""Iteration stops when no point moves by more than this (metres)."""
STEP_M = 1.0
"""Finite-difference step of the partials (metres); RFMs are smooth at this scale."""
MAX_CONDITION = 1e12
"""Normal matrices worse conditioned than this leave a point undetermined (parallel rays)."""


def radii(lat_deg: FloatArray, h: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Metres per radian of longitude and latitude on the WGS-84 ellipsoid at height h."""
    phi = np.radians(lat_deg)
    w = np.sqrt(1.0 - WGS84_E2 * np.sin(phi) ** 2)
    n = WGS84_A / w
    m = WGS84_A * (1.0 - WGS84_E2) / w**3
    return (n + h) * np.cos(phi), m + h


@dataclass
class Rays:
    """Observations grouped by scene: index arrays per scene model, built once."""

    models: Sequence[SceneModel]
    scene: np.ndarray  # model index per observation
    groups: list[tuple[int, np.ndarray]]

    @classmethod
    def of(cls, models: Sequence[SceneModel], scene: np.ndarray) -> Rays:
        order = np.argsort(scene, kind="stable")
        ids, starts = np.unique(scene[order], return_index=True)
        parts = np.split(order, starts[1:])
        return cls(models, scene, [(int(k), p) for k, p in zip(ids, parts, strict=True)])

    def project(
        self, lon: FloatArray, lat: FloatArray, h: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Ground → (line, sample) of each observation's scene."""
        line = np.full(self.scene.shape, np.nan)
        sample = np.full(self.scene.shape, np.nan)
        for k, idx in self.groups:
            line[idx], sample[idx] = self.models[k].ground_to_image(lon[idx], lat[idx], h[idx])
        return line, sample

    def at_height(
        self, line: FloatArray, sample: FloatArray, h: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Each observation intersected alone with the surface of height h (§RC-2)."""
        lon = np.full(self.scene.shape, np.nan)
        lat = np.full(self.scene.shape, np.nan)
        for k, idx in self.groups:
            lon[idx], lat[idx], _ = self.models[k].image_to_ground(line[idx], sample[idx], h[idx])
        return lon, lat


def _height_offset(model: SceneModel) -> float:
    rpc = getattr(model, "rpc", model)
    return float(getattr(rpc, "height_off", 0.0))


def start_values(
    rays: Rays, point: np.ndarray, n_points: int, line: FloatArray, sample: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each point's mean single-ray position at its scenes' mean height offset."""
    h_obs = np.array([_height_offset(m) for m in rays.models])[rays.scene]
    count = np.bincount(point, minlength=n_points).astype(float)
    h = np.bincount(point, h_obs, n_points) / np.maximum(count, 1)
    lon_o, lat_o = rays.at_height(line, sample, h[point])
    ok = np.isfinite(lon_o) & np.isfinite(lat_o)
    n_ok = np.bincount(point[ok], minlength=n_points).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        lon = np.bincount(point[ok], lon_o[ok], n_points) / n_ok
        lat = np.bincount(point[ok], lat_o[ok], n_points) / n_ok
    return lon, lat, h


def _normal(point: np.ndarray, n_points: int, jac: FloatArray, res: FloatArray):
    """Per-point 3×3 normal matrices and right-hand sides from per-observation rows."""
    # jac: (n_obs, 2, 3) partials of (line, sample) by (east, north, up); res: (n_obs, 2)
    nn = np.einsum("oij,oik->ojk", jac, jac).reshape(-1, 9)
    rhs = np.einsum("oij,oi->oj", jac, res)
    mat = np.stack([np.bincount(point, nn[:, k], n_points) for k in range(9)], axis=1)
    vec = np.stack([np.bincount(point, rhs[:, k], n_points) for k in range(3)], axis=1)
    return mat.reshape(n_points, 3, 3), vec


def _solve(mat: FloatArray, vec: FloatArray) -> tuple[FloatArray, np.ndarray]:
    """Batched solve; points whose matrix is singular or ill-conditioned get NaN."""
    finite = np.isfinite(mat).all(axis=(1, 2)) & np.isfinite(vec).all(axis=1)
    safe = np.where(finite[:, None, None], mat, np.eye(3))
    ok = finite & (np.linalg.cond(safe) < MAX_CONDITION)
    safe = np.where(ok[:, None, None], safe, np.eye(3))
    step = np.linalg.solve(safe, np.where(ok[:, None], vec, 0.0)[..., None])[..., 0]
    step[~ok] = np.nan
    return step, ok


@dataclass
class Intersection:
    """Ground points of a multi-ray intersection, per point (NaN where undetermined)."""

    lon: FloatArray
    lat: FloatArray
    h: FloatArray
    n_rays: np.ndarray
    converged: np.ndarray
    iterations: int


def intersect(
    rays: Rays, point: np.ndarray, n_points: int, line: FloatArray, sample: FloatArray
) -> Intersection:
    """Least-squares ground point of every tie point seen on ≥ 2 rays (§RC-1), all at once."""
    n_rays = np.bincount(point, minlength=n_points)
    lon, lat, h = start_values(rays, point, n_points, line, sample)
    active = n_rays >= 2
    lon[~active] = lat[~active] = h[~active] = np.nan
    moved = np.full(n_points, np.inf)
    it = 0
    for it in range(1, MAX_ITER + 1):
        e_m, n_m = radii(lat, h)
        base = np.stack(rays.project(lon[point], lat[point], h[point]), axis=1)
        d_lon, d_lat = np.degrees(STEP_M / e_m), np.degrees(STEP_M / n_m)
        cols = [
            rays.project(lon[point] + d_lon[point], lat[point], h[point]),
            rays.project(lon[point], lat[point] + d_lat[point], h[point]),
            rays.project(lon[point], lat[point], h[point] + STEP_M),
        ]
        jac = np.stack([(np.stack(c, axis=1) - base) / STEP_M for c in cols], axis=2)
        res = np.stack([line, sample], axis=1) - base
        mat, vec = _normal(point, n_points, jac, res)
        step, ok = _solve(mat, vec)
        lon = lon + np.degrees(step[:, 0] / e_m)
        lat = lat + np.degrees(step[:, 1] / n_m)
        h = h + step[:, 2]
        moved = np.where(ok, np.abs(step).max(axis=1), np.nan)
        if not np.any(moved[active] > TOL_M):
            break
    converged = active & (moved <= TOL_M)
    lon[~converged] = lat[~converged] = h[~converged] = np.nan
    return Intersection(lon, lat, h, n_rays, converged, it)
