"""Where the process data judged came from, as rows of the block report: what the delivery
gave, what blockqc computed itself from the delivered geometry (contract v1.1, §RC-1, §RC-2),
and the inspector's own checkpoints. Read from results.json's `process_data` alone."""

from __future__ import annotations

from typing import Any

from blockqc.report.acceptance import name_only
from blockqc.report.format import Formatter

#: process_data's keys in the order shown, each with its label's message key
LABELS = {
    "geometry": "pd_geometry",
    "tie_point_residuals": "pd_residuals",
    "residual_convention": "pd_residual_convention",
    "n_points": "pd_points",
    "n_points_single_ray": "pd_single_ray",
    "n_points_not_intersected": "pd_not_intersected",
    "n_points_height_undetermined": "pd_height_undetermined",
    "iterations": "pd_iterations",
    "observations_without_residual": "pd_observations_without_residual",
    "observations_single_ray": "pd_observations_single_ray",
    "overlaps": "pd_overlaps",
    "n_overlap_discrepancies": "pd_n_overlaps",
    "inspector_checkpoints": "pd_inspector_checkpoints",
}
#: the counts that are parts of the tie points' count, shown under it
PARTS = ("n_points_single_ray", "n_points_not_intersected", "n_points_height_undetermined")


def process_rows(process_data: dict[str, Any], f: Formatter) -> list[dict[str, Any]]:
    """A row (label, value, part: a part of the count above it) for each entry of
    process_data: the known ones in their order and language, any other by its key and value
    (none is left out)."""
    keys = [k for k in LABELS if k in process_data]
    keys += [k for k in process_data if k not in LABELS]
    return [
        {
            "label": f.t(LABELS[k]) if k in LABELS else k,
            "value": _value(process_data[k], f),
            "part": k in PARTS,
        }
        for k in keys
    ]


def _value(v: Any, f: Formatter) -> str:
    if isinstance(v, str):  # a sentence of the catalogue, else a text with its fixed phrases
        said = f.sentence(v)
        return said if said != v else f.text(v)
    if isinstance(v, dict):  # the inspector's checkpoint files: rows taken from each
        return "; ".join(f"{name_only(str(k))}: {f.t('pd_rows', n=f.num(n))}" for k, n in v.items())
    return f.num(v)
