"""The rational function model (RPC00B) and its image-space affine refinement (§3).

Conventions, used everywhere in `blockqc.rfm`:

* Image coordinates are (row, col) = (line, sample) in pixels with the **pixel-centre** convention:
  the centre of the first pixel of the image the RPCs describe is (0, 0). This is the convention of
  the RPC00B numbers themselves (NITF STDI-0002, OSSIM, rpcm, shareloc).
* GDAL's RPC transformer (rasterio's `RPCTransformer`) uses the pixel-**corner** convention: its
  (col, row) = (0.5, 0.5) is the centre of the first pixel, so GDAL = ours + 0.5.
* DIMAP (Pléiades, SPOT 6/7) RPC files count the first pixel as 1; the reader subtracts 1 from
  LINE_OFF and SAMP_OFF (see `blockqc.rfm.readers`).
* Ground coordinates are WGS-84 longitude and latitude in degrees and **ellipsoidal** height in
  metres (§MB-2); a geoid-referenced DEM must be converted first (`blockqc.rfm.dem`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from blockqc.errors import InputError, Problem

FloatArray = NDArray[np.float64]
HeightSource = float | ArrayLike | Callable[[FloatArray, FloatArray], FloatArray]

# Exponents of (L = longitude, P = latitude, H = height) of the 20 RPC00B terms, in order:
# 1, L, P, H, LP, LH, PH, L², P², H², PLH, L³, LP², LH², L²P, P³, PH², L²H, P²H, H³.
RPC00B_EXPONENTS: tuple[tuple[int, int, int], ...] = (
    (0, 0, 0),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (1, 1, 0),
    (1, 0, 1),
    (0, 1, 1),
    (2, 0, 0),
    (0, 2, 0),
    (0, 0, 2),
    (1, 1, 1),
    (3, 0, 0),
    (1, 2, 0),
    (1, 0, 2),
    (2, 1, 0),
    (0, 3, 0),
    (0, 1, 2),
    (2, 0, 1),
    (0, 2, 1),
    (0, 0, 3),
)

NEWTON_MAX_ITER = 30
"""Newton steps allowed for image→ground at a fixed height."""
NEWTON_TOL_PX = 1e-9
"""Newton stops when every point's image residual is below this (pixels)."""
DEM_MAX_ITER = 30
"""Height updates allowed for image→ground on a DEM."""
DEM_TOL_M = 1e-5
"""DEM iteration stops when no point's height changes by more than this (metres)."""
DEM_LEVELS = 64
"""Heights scanned along a line of sight when the DEM iteration does not converge."""
DEM_BISECTIONS = 48
"""Halvings of the bracketing interval after the scan (2630 m / 2⁴⁸ ≈ 1e-11 m)."""
SURFACE_TOL_M = 1e-3
"""A crossing found by bisection lies this close to the surface (bilinear heights are
continuous: the last bracket leaves it far closer); beyond, the ray met a void."""


def _powers(x: FloatArray) -> list[FloatArray | float]:
    return [1.0, x, x * x, x * x * x]


def _evaluate(
    lon_n: FloatArray,
    lat_n: FloatArray,
    h_n: FloatArray,
    coeffs: FloatArray,
    derivatives: bool = False,
) -> tuple[FloatArray, FloatArray | None, FloatArray | None]:
    """Evaluate k polynomials (coeffs: k×20) at normalized points, term by term.

    Returns values (k×n) and, if asked, their derivatives with respect to L and P (k×n each).
    Memory stays at a few arrays of n points, whatever k.
    """
    pl, pp, ph = _powers(lon_n), _powers(lat_n), _powers(h_n)
    n = lon_n.shape
    k = coeffs.shape[0]
    val = np.zeros((k, *n))
    d_l = np.zeros((k, *n)) if derivatives else None
    d_p = np.zeros((k, *n)) if derivatives else None
    for j, (el, ep, eh) in enumerate(RPC00B_EXPONENTS):
        c = coeffs[:, j].reshape((k,) + (1,) * len(n))
        term = pl[el] * pp[ep] * ph[eh]
        val += c * term
        if derivatives:
            if el:
                d_l += c * (el * pl[el - 1] * pp[ep] * ph[eh])
            if ep:
                d_p += c * (ep * pl[el] * pp[ep - 1] * ph[eh])
    return val, d_l, d_p


#: the ten normalisation constants of an RPC00B model
OFFSET_SCALE_KEYS = (
    "line_off",
    "samp_off",
    "lat_off",
    "lon_off",
    "height_off",
    "line_scale",
    "samp_scale",
    "lat_scale",
    "lon_scale",
    "height_scale",
)


#: the largest coefficient accepted: those of a normalized RPC are of order 1 (the largest
#: among 47 real ones of seven vendors is 235); far beyond, the model overflows (1e300)
MAX_COEFFICIENT = 1e6
#: the smallest scale accepted: a line/sample scale is about half the image, a lat/lon one at
#: least thousandths of a degree (the smallest met: 0.002°), a height one metres
MIN_SCALE = 1e-9
#: a denominator's constant term (its value at the normalized domain's centre) is refused at or
#: below this share of its largest coefficient: the model would divide by zero there
CENTRE_DEN_MIN = 1e-9
#: an RPC is read up to this many of its scales from its offsets (normalized coordinates within
#: ±DOMAIN_REACH): its polynomials are fitted over ±1, and an image, a footprint or a height far
#: beyond is not one the RPC describes (another image's RPC, offsets and scales swapped …)
DOMAIN_REACH = 2.0


def wrap_lon(lon: ArrayLike) -> FloatArray:
    """Longitudes (or their differences) brought within [−180°, 180°); those already within are
    kept as they are (adding and taking away 180° would round them off by up to 3e-14°)."""
    lon = np.asarray(lon, np.float64)
    with np.errstate(invalid="ignore"):
        out = (lon < -180.0) | (lon >= 180.0)
        return np.where(out, (lon + 180.0) % 360.0 - 180.0, lon)


def lon_extent(lon: np.ndarray) -> tuple[float, float]:
    """West and east ends of the shortest arc of longitude holding every `lon` (degrees): the
    circle less its widest gap between neighbouring longitudes, so that a block across ±180°
    spans 179.8…180.4, not −179.6…179.8 round the globe; east may exceed 180."""
    lon = np.sort(np.mod(np.asarray(lon, np.float64) + 180.0, 360.0) - 180.0)
    if lon.size == 0:
        return float("nan"), float("nan")
    gaps = np.append(np.diff(lon), lon[0] + 360.0 - lon[-1])  # the last: across ±180°
    widest = int(np.argmax(gaps))
    if widest == len(lon) - 1:
        return float(lon[0]), float(lon[-1])
    return float(lon[widest + 1]), float(lon[widest] + 360.0)


def lon_turn(box: Sequence[float], other: Sequence[float]) -> float:
    """The multiple of 360° that brings the first lon/lat box's longitudes (west, south, east,
    north) nearest the second's (longitudes −180…180 or 0…360)."""
    return 360.0 * round(((other[0] + other[2]) - (box[0] + box[2])) / 720.0)


def boxes_meet(box: Sequence[float], other: Sequence[float]) -> bool:
    """Whether two lon/lat boxes (west, south, east, north) overlap, the first turned by
    `lon_turn`."""
    west, south, east, north = box
    o_west, o_south, o_east, o_north = other
    turn = lon_turn(box, other)
    return west + turn <= o_east and east + turn >= o_west and south <= o_north and north >= o_south


def _coefficient_problem(name: str, arr: FloatArray) -> str | None:
    """What makes one of the four coefficient arrays (`name`: line_num, line_den, samp_num,
    samp_den) unusable, or None: not 20 finite numbers, a coefficient far from order 1, or a
    denominator that is zero everywhere or at the centre of the normalized domain."""
    if arr.shape != (20,):
        return f"{name} must hold 20 finite numbers, got shape {arr.shape}"
    if not np.all(np.isfinite(arr)):
        i = int(np.flatnonzero(~np.isfinite(arr))[0])
        return (
            f"{name.upper()} holds {arr[i]} (coefficient {i + 1} of 20): expected 20 finite numbers"
        )
    if np.abs(arr).max() > MAX_COEFFICIENT:
        return (
            f"{name.upper()} holds {arr[np.abs(arr).argmax()]:g}: the coefficients of a normalized "
            f"RPC are of order 1 (at most {MAX_COEFFICIENT:g} is accepted)"
        )
    if name.endswith("_den") and not np.any(arr):
        return (
            f"{name.upper()} holds 20 zeros: a denominator that is zero everywhere divides by "
            "zero (its constant term is normally 1)"
        )
    if name.endswith("_den") and abs(arr[0]) <= CENTRE_DEN_MIN * np.abs(arr).max():
        return (
            f"{name.upper()}'s constant term is {arr[0]:g}: the denominator is zero at the centre "
            "of the normalized domain (the image centre), where the model divides by zero (the "
            "term is normally 1)"
        )
    return None


@dataclass(frozen=True, eq=False)
class RPCModel:
    """One scene's RPC00B model: ten offsets/scales and the 4×20 coefficients (§3).

    `ground_to_image` is direct; `image_to_ground` iterates (Newton at a height, then on a DEM).
    Pixel-centre convention, first pixel centre (0, 0); ellipsoidal heights (module docstring).
    """

    line_off: float
    samp_off: float
    lat_off: float
    lon_off: float
    height_off: float
    line_scale: float
    samp_scale: float
    lat_scale: float
    lon_scale: float
    height_scale: float
    line_num: FloatArray
    line_den: FloatArray
    samp_num: FloatArray
    samp_den: FloatArray
    source: str = ""
    """File the model was read from (for messages)."""
    err_bias: float | None = None
    err_rand: float | None = None
    first_pixel: float = 0.0
    """The first pixel's line and sample in the file's own convention (DIMAP: 1), whose
    offsets the reader turned to a first pixel of 0 (`in_file_convention` turns them back)."""

    def __post_init__(self) -> None:
        for name in ("line_num", "line_den", "samp_num", "samp_den"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            message = _coefficient_problem(name, arr)
            if message is not None:
                raise InputError(Problem(file=self.source or "<rpc>", message=message))
            object.__setattr__(self, name, arr)
        for name in OFFSET_SCALE_KEYS:
            value = float(getattr(self, name))
            scale = name.endswith("_scale")
            if not np.isfinite(value) or (scale and abs(value) < MIN_SCALE):
                raise InputError(
                    Problem(
                        file=self.source or "<rpc>",
                        message=f"{name.upper()} must be a finite number"
                        + (f" of magnitude at least {MIN_SCALE:g}" if scale else "")
                        + f", got {value!r}",
                    )
                )
            object.__setattr__(self, name, value)

    def in_file_convention(self) -> RPCModel:
        """The model for image positions counted as its file counts them (a DIMAP file's from
        1), as the positions measured on its scene are (contract v1.1)."""
        if not self.first_pixel:
            return self
        shift = self.first_pixel
        return replace(
            self, line_off=self.line_off + shift, samp_off=self.samp_off + shift, first_pixel=0.0
        )

    def image_domain(self, reach: float = DOMAIN_REACH) -> tuple[float, float, float, float]:
        """First and last line, first and last sample of the image the model describes:
        LINE_OFF ± reach·LINE_SCALE, SAMP_OFF ± reach·SAMP_SCALE."""
        line, samp = reach * abs(self.line_scale), reach * abs(self.samp_scale)
        first_line, first_sample = self.line_off - line, self.samp_off - samp
        return first_line, self.line_off + line, first_sample, self.samp_off + samp

    def ground_domain_in_image(self) -> tuple[float, float, float, float] | None:
        """First and last line, first and last sample of the image positions of the RPC's
        ground domain (offsets ± one scale, 5 × 5 × 3 nodes): the image the RPC was fitted
        to, also when its LINE/SAMP offsets and scales do not span it (s2p's crops of a
        Pléiades scene: LINE_OFF 19403.5, LINE_SCALE 512 for rows 0..1023); None when no node
        has a finite position."""
        u = np.linspace(-1.0, 1.0, 5)
        lon, lat, h = np.meshgrid(u, u, np.array([-1.0, 0.0, 1.0]), indexing="ij")
        row, col = self.ground_to_image(
            self.lon_off + lon * self.lon_scale,
            self.lat_off + lat * self.lat_scale,
            self.height_off + h * self.height_scale,
        )
        ok = np.isfinite(row) & np.isfinite(col)
        if not ok.any():
            return None
        row, col = row[ok], col[ok]
        return float(row.min()), float(row.max()), float(col.min()), float(col.max())

    def ground_domain(self, reach: float = DOMAIN_REACH) -> tuple[float, float, float, float]:
        """West, south, east, north (degrees) of the ground the model describes: LONG_OFF ±
        reach·LONG_SCALE, LAT_OFF ± reach·LAT_SCALE."""
        lon, lat = reach * abs(self.lon_scale), reach * abs(self.lat_scale)
        return self.lon_off - lon, self.lat_off - lat, self.lon_off + lon, self.lat_off + lat

    def height_domain(self, reach: float = DOMAIN_REACH) -> tuple[float, float]:
        """Lowest and highest ellipsoidal height (m) the model describes: HEIGHT_OFF ±
        reach·HEIGHT_SCALE."""
        h = reach * abs(self.height_scale)
        return self.height_off - h, self.height_off + h

    # -- helpers -------------------------------------------------------------------------------
    @property
    def _coeffs(self) -> FloatArray:
        return np.stack([self.line_num, self.line_den, self.samp_num, self.samp_den])

    def normalize_ground(
        self, lon: ArrayLike, lat: ArrayLike, h: ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Normalized (L, P, H); a longitude in the other convention than LONG_OFF's (−180…180
        or 0…360: −4.8° for LONG_OFF 355.3°) is taken the same way round the globe."""
        lon, lat, h = np.broadcast_arrays(
            np.asarray(lon, np.float64), np.asarray(lat, np.float64), np.asarray(h, np.float64)
        )
        return (
            wrap_lon(lon - self.lon_off) / self.lon_scale,
            (lat - self.lat_off) / self.lat_scale,
            (h - self.height_off) / self.height_scale,
        )

    # -- ground → image ------------------------------------------------------------------------
    def ground_to_image(
        self, lon: ArrayLike, lat: ArrayLike, h: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """(lon°, lat°, ellipsoidal h m) → (row, col) px, pixel-centre convention; vectorized."""
        ln, pn, hn = self.normalize_ground(lon, lat, h)
        v, _, _ = _evaluate(ln, pn, hn, self._coeffs)
        row = v[0] / v[1] * self.line_scale + self.line_off
        col = v[2] / v[3] * self.samp_scale + self.samp_off
        return row, col

    # -- image → ground ------------------------------------------------------------------------
    def _solve_at_height(
        self, row: FloatArray, col: FloatArray, h: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Newton iteration on (lon, lat) so that ground_to_image(lon, lat, h) = (row, col)."""
        rn = (row - self.line_off) / self.line_scale
        cn = (col - self.samp_off) / self.samp_scale
        hn = (h - self.height_off) / self.height_scale
        ln = np.zeros_like(rn)
        pn = np.zeros_like(rn)
        active = np.isfinite(rn) & np.isfinite(cn) & np.isfinite(hn)
        ln[~active] = np.nan
        pn[~active] = np.nan
        idx = np.flatnonzero(active.ravel())
        lf, pf = ln.ravel(), pn.ravel()
        rf, cf, hf = rn.ravel(), cn.ravel(), hn.ravel()
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # `bad` catches them
            idx = self._newton(idx, lf, pf, rf, cf, hf)
        if idx.size:
            # did not converge (outside the model's domain): no position rather than a wrong one
            lf[idx] = np.nan
            pf[idx] = np.nan
        lon = lf.reshape(rn.shape) * self.lon_scale + self.lon_off
        lat = pf.reshape(rn.shape) * self.lat_scale + self.lat_off
        return lon, lat

    def _newton(
        self,
        idx: NDArray[np.intp],
        lf: FloatArray,
        pf: FloatArray,
        rf: FloatArray,
        cf: FloatArray,
        hf: FloatArray,
    ) -> NDArray[np.intp]:
        """Newton steps on the normalized (lon, lat) `lf`, `pf` of the points `idx` (updated in
        place; a step that is not finite gives NaN); returns the points not converged."""
        coeffs = self._coeffs
        tol_r = NEWTON_TOL_PX / abs(self.line_scale)
        tol_c = NEWTON_TOL_PX / abs(self.samp_scale)
        for _ in range(NEWTON_MAX_ITER):
            if idx.size == 0:
                break
            L, P, H = lf[idx], pf[idx], hf[idx]
            v, dl, dp = _evaluate(L, P, H, coeffs, derivatives=True)
            f_r = v[0] / v[1]
            f_c = v[2] / v[3]
            # derivatives of the ratios: (N'D − ND')/D²
            r_l = (dl[0] * v[1] - v[0] * dl[1]) / v[1] ** 2
            r_p = (dp[0] * v[1] - v[0] * dp[1]) / v[1] ** 2
            c_l = (dl[2] * v[3] - v[2] * dl[3]) / v[3] ** 2
            c_p = (dp[2] * v[3] - v[2] * dp[3]) / v[3] ** 2
            e_r = rf[idx] - f_r
            e_c = cf[idx] - f_c
            det = r_l * c_p - r_p * c_l
            step_l = (e_r * c_p - r_p * e_c) / det
            step_p = (r_l * e_c - e_r * c_l) / det
            bad = ~(np.isfinite(step_l) & np.isfinite(step_p))
            lf[idx] = np.where(bad, np.nan, L + step_l)
            pf[idx] = np.where(bad, np.nan, P + step_p)
            done = ((np.abs(e_r) < tol_r) & (np.abs(e_c) < tol_c)) | bad
            idx = idx[~done]
        return idx

    def image_to_ground(
        self, row: ArrayLike, col: ArrayLike, height: HeightSource
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(row, col) px → (lon°, lat°, h m) at a given height, or on a DEM by iteration.

        `height` is a number or array of ellipsoidal heights, or a callable h(lon, lat) such as
        a `blockqc.rfm.dem.DEM`; with a callable the height is updated from the DEM until it
        changes by less than DEM_TOL_M, starting from the callable's `mean_height` when it has
        one (else HEIGHT_OFF); rays where that does not converge are searched for their first
        crossing of the surface. Points whose ray meets no DEM value get NaN.
        """
        row, col = np.broadcast_arrays(np.asarray(row, np.float64), np.asarray(col, np.float64))
        if not callable(height):
            h = np.broadcast_to(np.asarray(height, np.float64), row.shape).astype(np.float64)
            lon, lat = self._solve_at_height(row, col, h)
            return lon, lat, h
        start = getattr(height, "mean_height", None)
        if start is None or not np.isfinite(start):
            start = self.height_off
        h = np.full(row.shape, float(start), dtype=np.float64)
        lon, lat = self._solve_at_height(row, col, h)
        change = np.full(row.shape, np.inf)
        for _ in range(DEM_MAX_ITER):
            h_new = np.broadcast_to(np.asarray(height(lon, lat), np.float64), row.shape).copy()
            change = np.abs(h_new - h)
            h = h_new
            lon, lat = self._solve_at_height(row, col, h)
            if not np.any(change > DEM_TOL_M):
                break
        # fixed-point iteration fails where tan(slope)·tan(incidence) ≥ 1 or where the start
        # falls off a small DEM: search those rays for their first crossing of the surface
        bad = ~(change <= DEM_TOL_M)
        if bad.any():
            lon_b, lat_b, h_b = self._first_crossing(row[bad], col[bad], height)
            lon[bad], lat[bad], h[bad] = lon_b, lat_b, h_b
        return lon, lat, h

    def _first_crossing(
        self,
        row: FloatArray,
        col: FloatArray,
        height: Callable[[FloatArray, FloatArray], FloatArray],
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Highest intersection of each pixel's line of sight with the surface h(lon, lat):
        scan DEM_LEVELS heights from the top of the height range down to the first level where
        the ray is at or below the surface, then bisect (DEM_BISECTIONS halvings). A ray whose
        bisection ends off the surface (it bisected into a void, whose samples read as below
        the surface, and stopped at its edge) gets NaN: it meets no DEM value there."""
        lo = self.height_off - abs(self.height_scale)
        hi = self.height_off + abs(self.height_scale)
        span = getattr(height, "height_range", None)
        if span is not None and np.all(np.isfinite(span)):
            lo, hi = min(lo, span[0] - 1.0), max(hi, span[1] + 1.0)
        n = row.size
        above = np.full(n, np.nan)  # a height where the ray is above the surface
        below = np.full(n, np.nan)  # the next level down, where it is at or below
        f_prev = np.full(n, np.nan)
        level_prev = hi
        for level in np.linspace(hi, lo, DEM_LEVELS):
            hh = np.full(n, level)
            lon, lat = self._solve_at_height(row, col, hh)
            f = np.asarray(height(lon, lat), dtype=np.float64) - level
            cross = np.isnan(below) & (f_prev < 0) & (f >= 0)
            above[cross] = level_prev
            below[cross] = level
            f_prev, level_prev = f, level
        found = np.isfinite(below)
        a, b = above[found], below[found]
        r, c = row[found], col[found]
        for _ in range(DEM_BISECTIONS):
            mid = 0.5 * (a + b)
            lon, lat = self._solve_at_height(r, c, mid)
            f = np.asarray(height(lon, lat), dtype=np.float64) - mid
            up = f < 0
            a = np.where(up, mid, a)
            b = np.where(up, b, mid)
        h = np.full(n, np.nan)
        h[found] = 0.5 * (a + b)
        lon, lat = self._solve_at_height(row, col, h)
        off = ~(np.abs(np.asarray(height(lon, lat), dtype=np.float64) - h) <= SURFACE_TOL_M)
        h[off], lon[off], lat[off] = np.nan, np.nan, np.nan
        return lon, lat, h


@dataclass(frozen=True)
class ImageAffine:
    """Image-space affine correction of §3: Δl = a0 + a1·s + a2·l, Δs = b0 + b1·s + b2·l.

    With (l, s) the observed image position, the RFM position of the ground point is
    (l + Δl, s + Δs): F_l = P1/P2 − l − Δl = 0 and F_s = P3/P4 − s − Δs = 0.
    """

    a0: float = 0.0
    a1: float = 0.0
    a2: float = 0.0
    b0: float = 0.0
    b1: float = 0.0
    b2: float = 0.0

    def delta(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """(Δl, Δs) at observed image positions."""
        row = np.asarray(row, np.float64)
        col = np.asarray(col, np.float64)
        return (
            self.a0 + self.a1 * col + self.a2 * row,
            self.b0 + self.b1 * col + self.b2 * row,
        )

    def to_rfm_space(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Observed (l, s) → the RFM's (l + Δl, s + Δs)."""
        dl, ds = self.delta(row, col)
        return np.asarray(row, np.float64) + dl, np.asarray(col, np.float64) + ds

    def from_rfm_space(self, row_r: ArrayLike, col_r: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """The RFM's (l_r, s_r) → observed (l, s): solves the 2×2 linear system exactly.

        (1 + a2)·l + a1·s = l_r − a0 and b2·l + (1 + b1)·s = s_r − b0.
        """
        rr = np.asarray(row_r, np.float64) - self.a0
        cc = np.asarray(col_r, np.float64) - self.b0
        m11, m12, m21, m22 = 1.0 + self.a2, self.a1, self.b2, 1.0 + self.b1
        det = m11 * m22 - m12 * m21
        return (m22 * rr - m12 * cc) / det, (m11 * cc - m21 * rr) / det

    def as_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in ("a0", "a1", "a2", "b0", "b1", "b2")}


@dataclass(frozen=True, eq=False)
class RefinedRFM:
    """An RPC model with its image-space affine refinement (§3); same interface as RPCModel."""

    rpc: RPCModel
    affine: ImageAffine = field(default_factory=ImageAffine)

    @property
    def source(self) -> str:
        return self.rpc.source

    def ground_to_image(
        self, lon: ArrayLike, lat: ArrayLike, h: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """(lon°, lat°, h m) → observed (row, col) px, pixel-centre convention."""
        row_r, col_r = self.rpc.ground_to_image(lon, lat, h)
        return self.affine.from_rfm_space(row_r, col_r)

    def image_to_ground(
        self, row: ArrayLike, col: ArrayLike, height: HeightSource
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Observed (row, col) px → (lon°, lat°, h m); see RPCModel.image_to_ground."""
        row_r, col_r = self.affine.to_rfm_space(row, col)
        return self.rpc.image_to_ground(row_r, col_r, height)


def fit_affine(
    rpc: RPCModel,
    lon: ArrayLike,
    lat: ArrayLike,
    h: ArrayLike,
    row: ArrayLike,
    col: ArrayLike,
) -> tuple[RefinedRFM, FloatArray]:
    """Least-squares fit of the six §3 affine parameters from ≥ 3 control points.

    Control point i: ground (lon, lat, h) and observed image position (row, col). Since the
    observations enter the design matrix directly, the problem is linear and solved in one step:
    l_rfm − l = a0 + a1·s + a2·l, s_rfm − s = b0 + b1·s + b2·l. Returns the refined model and the
    image residuals (n×2: row, col, px) of the fitted points.
    """
    row = np.asarray(row, np.float64).ravel()
    col = np.asarray(col, np.float64).ravel()
    n = row.size
    if n < 3:
        raise InputError(
            Problem(
                file=rpc.source or "<rpc>", message=f"the affine refinement needs ≥ 3 CPs, got {n}"
            )
        )
    row_r, col_r = rpc.ground_to_image(
        np.asarray(lon, np.float64).ravel(),
        np.asarray(lat, np.float64).ravel(),
        np.asarray(h, np.float64).ravel(),
    )
    # centre and scale the design matrix for conditioning, then map the solution back
    r0, c0 = row.mean(), col.mean()
    sr = max(float(np.abs(row - r0).max()), 1.0)
    sc = max(float(np.abs(col - c0).max()), 1.0)
    design = np.column_stack([np.ones(n), (col - c0) / sc, (row - r0) / sr])
    rhs = np.column_stack([row_r - row, col_r - col])
    sol, *_ = np.linalg.lstsq(design, rhs, rcond=None)
    if np.linalg.matrix_rank(design) < 3:
        raise InputError(
            Problem(
                file=rpc.source or "<rpc>",
                message="the control points are collinear: the affine refinement is undetermined",
            )
        )
    affine = _unscaled(sol, (r0, c0), (sr, sc))
    residuals = rhs - design @ sol
    return RefinedRFM(rpc, affine), residuals


def _unscaled(
    sol: FloatArray, centre: tuple[float, float], scale: tuple[float, float]
) -> ImageAffine:
    """The affine parameters of a solution over image positions centred on `centre` (row,
    col) and divided by `scale` (row, col), in plain pixels."""
    (r0, c0), (sr, sc) = centre, scale
    k_a, k_b = sol[:, 0], sol[:, 1]
    a1, a2 = k_a[1] / sc, k_a[2] / sr
    b1, b2 = k_b[1] / sc, k_b[2] / sr
    return ImageAffine(
        a0=float(k_a[0] - a1 * c0 - a2 * r0),
        a1=float(a1),
        a2=float(a2),
        b0=float(k_b[0] - b1 * c0 - b2 * r0),
        b1=float(b1),
        b2=float(b2),
    )
