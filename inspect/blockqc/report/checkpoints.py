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
