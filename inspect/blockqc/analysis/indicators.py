"""Accuracy indicators of §AF: δ_l, δ_s from tie-point residuals; δ_X, δ_Y, δ_H from checkpoints."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

#: Checkpoint methods tried in turn for each object-space component (the first with ≥ 2 values).
DEFAULT_METHOD_ORDER: tuple[str, ...] = ("high_precision", "same_accuracy", "recalculation")


def rmse_about_mean(values: np.ndarray | pd.Series) -> float:
    """RMSE about the mean, √(Σ(v − v̄)² / (m − 1)) over the finite values (§AF); NaN if m < 2."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size < 2:
        return float("nan")
    return float(np.std(v, ddof=1))


@dataclass(frozen=True)
class Indicators:
    """The five §AF accuracy indicators of one block, with the counts and methods behind them."""

    l_rmse_px: float
    s_rmse_px: float
    x_rmse_m: float
    y_rmse_m: float
    h_rmse_m: float
    n_tie_observations: int
    n_plane_checkpoints: int
    n_height_checkpoints: int
    plane_method: str | None
    height_method: str | None

    def as_dict(self) -> dict[str, float | int | str | None]:
        return asdict(self)


def image_indicators(tie_points: pd.DataFrame) -> tuple[float, float, int]:
    """δ_l, δ_s over every tie-point observation's residuals v_line, v_sample (px), and m."""
    vl = tie_points["v_line"].to_numpy(dtype=float)
    vs = tie_points["v_sample"].to_numpy(dtype=float)
    ok = np.isfinite(vl) & np.isfinite(vs)
    return rmse_about_mean(vl[ok]), rmse_about_mean(vs[ok]), int(ok.sum())


def object_indicators(
    checkpoints: pd.DataFrame | None,
    method_order: Sequence[str] = DEFAULT_METHOD_ORDER,
) -> tuple[float, float, float, int, int, str | None, str | None]:
    """δ_X, δ_Y, δ_H over checkpoint differences (measured − reference), one method per component.

    Plane (X, Y) and height are each taken from the first method in `method_order` that gives at
    least two differences for that component, so that one point measured by two methods is not
    counted twice. Gross errors are not removed: §AF's indicators are spreads of all differences.
    """
    nan = float("nan")
    if checkpoints is None or len(checkpoints) == 0:
        return nan, nan, nan, 0, 0, None, None
    cp = checkpoints
    method = cp["method"].astype(str).str.strip()
    dx = cp["x_m"].to_numpy(dtype=float) - cp["ref_x_m"].to_numpy(dtype=float)
    dy = cp["y_m"].to_numpy(dtype=float) - cp["ref_y_m"].to_numpy(dtype=float)
    dz = cp["z_m"].to_numpy(dtype=float) - cp["ref_z_m"].to_numpy(dtype=float)
    plane_ok = np.isfinite(dx) & np.isfinite(dy)
    height_ok = np.isfinite(dz)
    known = list(method_order) + sorted(set(method) - set(method_order))

    def pick(ok: np.ndarray) -> tuple[str | None, np.ndarray]:
        for m in known:
            sel = ok & (method == m).to_numpy()
            if sel.sum() >= 2:
                return m, sel
        return None, np.zeros_like(ok)

    pm, psel = pick(plane_ok)
    hm, hsel = pick(height_ok)
    return (
        rmse_about_mean(dx[psel]) if pm else nan,
        rmse_about_mean(dy[psel]) if pm else nan,
        rmse_about_mean(dz[hsel]) if hm else nan,
        int(psel.sum()),
        int(hsel.sum()),
        pm,
        hm,
    )


def block_indicators(
    tie_points: pd.DataFrame,
    checkpoints: pd.DataFrame | None,
    method_order: Sequence[str] = DEFAULT_METHOD_ORDER,
) -> Indicators:
    """All five §AF indicators of one delivery's tie points and checkpoints."""
    dl, ds, m = image_indicators(tie_points)
    dx, dy, dh, n_p, n_h, pm, hm = object_indicators(checkpoints, method_order)
    return Indicators(dl, ds, dx, dy, dh, m, n_p, n_h, pm, hm)
