"""The checkpoint statistics of a block (§CP), found through the results that judged them."""

from __future__ import annotations

from typing import Any

from blockqc.results import BlockResults, MeasurementRecord, worst_status


def checkpoint_measurement(results: BlockResults) -> MeasurementRecord | None:
    """The measurement the detailed inspection judged per component and method (§CP)."""
    for res in results.results:
        if res.inspection == "detailed" and {"component", "method"} <= set(res.group):
            m = results.measurement(res.measurement)
            if m is not None and "component_method" in m.tables:
                return m
    return None


def checkpoint_rows(results: BlockResults) -> list[dict[str, Any]]:
    """Each component and method's checkpoint statistics with the worst status judged on it."""
    m = checkpoint_measurement(results)
    if m is None:
        return []
    status_of: dict[tuple[str, str], list[str]] = {}
    for res in results.results:
        g = res.group
        if res.inspection == "detailed" and "component" in g and "method" in g:
            status_of.setdefault((g["component"], g["method"]), []).append(res.status)
    return [
        {**s, "status": worst_status(status_of.get((s["component"], s["method"]), []))}
        for s in m.tables["component_method"]
    ]


def checkpoint_points(results: BlockResults) -> list[dict[str, Any]]:
    """Every checkpoint of every component and method, as measured."""
    m = checkpoint_measurement(results)
    return list(m.tables.get("point", [])) if m else []


def axis_statistics(results: BlockResults) -> dict[tuple[str, str], dict[str, Any]]:
    """Per component and method, over the retained checkpoints: mean (bias), std, RMS per axis."""
    import numpy as np

    out: dict[tuple[str, str], dict[str, Any]] = {}
    points = [p for p in checkpoint_points(results) if not p.get("gross")]
    keys = {(p["component"], p["method"]) for p in points}
    for comp, method in keys:
        rows = [p for p in points if (p["component"], p["method"]) == (comp, method)]
        stats: dict[str, Any] = {}
        for axis in ("dx_m", "dy_m") if comp == "plane" else ("dz_m",):
            v = np.array([r.get(axis) for r in rows], dtype=float)
            v = v[np.isfinite(v)]
            if v.size:
                stats[axis] = {
                    "mean": float(v.mean()),
                    "std": float(v.std(ddof=1)) if v.size > 1 else None,
                    "rms": float(np.sqrt(np.mean(v**2))),
                }
        out[(comp, method)] = stats
    return out


def failed_criteria(results: BlockResults) -> dict[tuple[str, str], list[str]]:
    """Per component and method, the statistics of the detailed rules that failed there."""
    out: dict[tuple[str, str], list[str]] = {}
    for res in results.results:
        g = res.group
        if res.inspection == "detailed" and {"component", "method"} <= set(g):
            if res.status in ("fail", "warn") and res.statistic:
                out.setdefault((g["component"], g["method"]), []).append(res.statistic)
    return out
