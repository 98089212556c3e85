"""What the report's figures and tables take from a results.json's free-form parts (scenes,
measurement tables and details): the ids they are drawn by, and the numbers they draw, checked
before `blockqc report` renders a hand-edited or damaged file, so that it is refused with the
field named rather than failing inside a figure."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

from blockqc.errors import Problem
from blockqc.results import BlockResults

#: by metric and table: the keys every row must give, and the keys that are numbers (or null)
TABLES: dict[tuple[str, str], tuple[tuple[str, ...], tuple[str, ...]]] = {
    ("checkpoint_accuracy", "point"): (
        ("component", "method", "point_id"),
        ("error_m", "dx_m", "dy_m", "dz_m", "x_m", "y_m"),
    ),
    ("checkpoint_accuracy", "component_method"): (
        ("component", "method"),
        ("norm_m", "bound_m"),
    ),
    ("overlap_discrepancy", "point"): (("scene_a", "scene_b"), ("dx_m", "dy_m")),
    ("tie_point_distribution", "scene"): (("scene_id",), ("n_points",)),
}
#: the keys of a residual cell (the residual map) and of a scene (maps, captions)
CELL = (("scene_id",), ("u", "w", "v_line", "v_sample"))
SCENE = (("scene_id",), ("lines", "samples"))
MOST = 20


def is_number(v: Any) -> bool:
    """A number (int or float), not true/false."""
    return isinstance(v, int | float) and not isinstance(v, bool)


def _rows(where: str, rows: Any, keys: tuple[tuple[str, ...], tuple[str, ...]]) -> Iterator[str]:
    """Why the rows at `where` cannot be drawn: not a list of objects, a key missing, or a value
    that is not a number (or null)."""
    if not isinstance(rows, list):
        yield f"{where}: expected a list of rows, not {type(rows).__name__}"
        return
    required, numbers = keys
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            yield f"{where}[{i}]: expected an object, not {row!r}"
            continue
        for k in required:
            if row.get(k) is None:
                yield f"{where}[{i}]: no {k} (the report draws each row by it)"
        for k in numbers:
            if row.get(k) is not None and not is_number(row[k]):
                yield f"{where}[{i}].{k}: expected a number or null, not {row[k]!r}"


def _numbers(where: str, values: Any) -> Iterator[str]:
    if not isinstance(values, list):
        yield f"{where}: expected a list of numbers, not {type(values).__name__}"
        return
    for i, v in enumerate(values):
        if not is_number(v):
            yield f"{where}[{i}]: expected a number, not {v!r}"


def _measurement(i: int, m: Any) -> Iterator[str]:
    at = f"$.measurements[{i}]"
    for (metric, table), keys in TABLES.items():
        if m.metric == metric and table in m.tables:
            yield from _rows(f"{at}.tables.{table}", m.tables[table], keys)
    hist = m.detail.get("histogram")
    if isinstance(hist, dict):
        for k in ("edges_px", "counts"):
            yield from _numbers(f"{at}.detail.histogram.{k}", hist.get(k) or [])
    if m.detail.get("residual_cells"):
        yield from _rows(f"{at}.detail.residual_cells", m.detail["residual_cells"], CELL)
    for scene, pts in (m.failing_scene_points or {}).items():
        where = f"{at}.failing_scene_points.{scene}"
        if not isinstance(pts, dict):
            yield f"{where}: expected an object of line and sample, not {pts!r}"
            continue
        for k in ("line", "sample"):
            yield from _numbers(f"{where}.{k}", pts.get(k) or [])


def drawn_problems(path: Path, doc: BlockResults) -> list[Problem]:
    """What the figures and tables of the block report could not draw (the first MOST)."""
    found = list(_rows("$.scenes", doc.scenes, SCENE))
    for i, m in enumerate(doc.measurements):
        found += _measurement(i, m)
    return [Problem(str(path), why) for why in found[:MOST]]
