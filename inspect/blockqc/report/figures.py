"""Which figures a block report draws, chosen from the results' figure hints and measurements."""

from __future__ import annotations

from typing import Any

from blockqc.report import plots
from blockqc.report.checkpoints import checkpoint_measurement
from blockqc.report.documents import meets
from blockqc.report.format import Formatter
from blockqc.report.svg import cut
from blockqc.results import BlockResults, MeasurementRecord, RuleResult

SCENE_KEYS = ("scene_id", "scene_a", "scene_b", "pan_scene_id", "ms_scene_id")
MAX_SCENE_MAPS = 24
DEFAULT_MARKS = (0.5, 1.0, 1.5)
#: how bad a scene's worst mark is (lower is worse)
SCENE_RANK = {"error": 0, "fail": 0, "warn": 1, "waived": 2, "exempt": 3, "pass": 4}


def _hinted(results: BlockResults, hint: str) -> list[RuleResult]:
    return [r for r in results.results if hint in r.figures]


def _measurement_of(results: BlockResults, rules: list[RuleResult]) -> MeasurementRecord | None:
    return next((m for r in rules if (m := results.measurement(r.measurement))), None)


def scene_statuses(results: BlockResults, rules: list[RuleResult] | None = None) -> dict[str, str]:
    """The worst status met by each scene in the evidence, exemptions or waivers of `rules`."""
    out: dict[str, str] = {}

    def mark(scene: Any, status: str) -> None:
        key = str(scene)
        if scene is not None and SCENE_RANK.get(status, 5) < SCENE_RANK.get(out.get(key, ""), 6):
            out[key] = status

    for res in results.results if rules is None else rules:
        for row in res.detail.get("exempt") or []:
            if isinstance(row, dict):
                mark(row.get("scene_id"), "exempt")
        for label in res.detail.get("waived") or []:
            for part in str(label).split("/"):
                mark(part, "waived")
        if res.status in ("fail", "error", "warn"):
            for row in res.evidence + _beyond_evidence(results, res):
                for k in SCENE_KEYS:
                    if k in row:
                        mark(row[k], res.status)
    return out


def _beyond_evidence(results: BlockResults, res: RuleResult) -> list[dict[str, Any]]:
    """The rows of a result's measurement that do not meet its threshold, when its evidence was
    cut (`evidence_truncated`): the units beyond the worst shown fail too. Exempt rows, waived
    scenes and rows of another group are left out."""
    m = results.measurement(res.measurement)
    if not res.detail.get("evidence_truncated") or m is None:
        return []
    waived = {p for label in res.detail.get("waived") or [] for p in str(label).split("/")}
    return [
        row
        for rows in m.tables.values()
        for row in rows
        if res.statistic in row
        and any(k in row for k in SCENE_KEYS)
        and not row.get("exempt")
        and all(row.get(k, v) == v for k, v in res.group.items())
        and not waived & {str(row[k]) for k in SCENE_KEYS if k in row}
        and meets(row[res.statistic], res.threshold, res.comparison) is False
    ]


def _number(v: Any) -> float | None:
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None


def _bounds(res: RuleResult) -> tuple[float | None, float | None]:
    """A rule's lower and upper bound as its comparison reads its threshold: both of a range
    (`between`, `{min: a, max: b}`), one of `>=`/`>` or `<=`/`<`, none of `equals`/`in`."""
    th = res.threshold
    if res.comparison in ("between", "strictly_between"):
        pair = th if isinstance(th, list) and len(th) == 2 else [None, None]
        return _number(pair[0]), _number(pair[1])
    if res.comparison in (">=", ">"):
        return _number(th), None
    if res.comparison in ("<=", "<"):
        return None, _number(th)
    return None, None


def _marks(rules: list[RuleResult]) -> list[float]:
    """Every bound of the rules, to be marked on a figure: both ends of a range, and the value
    a rule's statistic must equal."""
    both = [(_number(r.threshold), None) if r.comparison == "equals" else _bounds(r) for r in rules]
    return [b for pair in both for b in pair if b is not None]


def _minimum(res: RuleResult) -> float | None:
    """A rule's lower bound, drawn as the scenes' minimum: of `min` or a range; none of a
    `max` alone (not a minimum) or of `equals`/`in`."""
    return _bounds(res)[0]


def _checkpoint_figures(results: BlockResults, f: Formatter, figs: dict[str, Any]) -> None:
    m = checkpoint_measurement(results)
    if m is None:
        return
    points, stats = m.tables.get("point", []), m.tables.get("component_method", [])
    for component in ("plane", "height"):
        if any(p.get("component") == component for p in points):
            figs["detailed"].append(
                plots.checkpoint_errors(points, stats, component, f.t, f"cp-{component}")
            )
    if any(p.get("component") == "plane" for p in points):
        if not any(p.get("x_m") is not None for p in points):
            figs["notes"].append(f.t("vector_no_positions"))
        figs["detailed"].append(plots.checkpoint_vectors(points, stats, f.t, "cp-vectors"))


def _histogram(results: BlockResults, f: Formatter, figs: dict[str, Any]) -> None:
    rules = _hinted(results, "residual_histogram")
    m = _measurement_of(results, rules)
    hist = m.detail.get("histogram") if m else None
    if not isinstance(hist, dict) or not hist.get("counts"):
        return
    marks = set(_marks(rules))
    interval = m.detail.get("interval_px")
    if isinstance(interval, list):
        marks.update(float(v) for v in interval if isinstance(v, int | float))
    marks_list = sorted(marks) or list(DEFAULT_MARKS)
    figs["general"].append(plots.residual_histogram(hist, marks_list, f.t, "tp-hist"))


def _scene_counts(results: BlockResults, f: Formatter, figs: dict[str, Any]) -> None:
    rules = _hinted(results, "scene_counts")
    m = _measurement_of(results, rules)
    per_scene = m.tables.get("scene") if m else None
    if not per_scene:
        return
    minimum = next((m for r in rules if (m := _minimum(r)) is not None), None)
    statuses = scene_statuses(results, rules)
    figs["general"].append(plots.scene_counts(per_scene, minimum, statuses, f.t, "tp-counts"))


#: the caption of a scene map (a third of the page wide): two lines of 7.5 pt at most
CAPTION_PT, CAPTION_ROOM_PT = 7.5, 2 * 150.0


def _scene_names(sid: str) -> dict[str, str]:
    """A scene map's id, in full and cut with an ellipsis to fit its caption."""
    return {"scene": sid, "scene_short": cut(sid, CAPTION_PT, CAPTION_ROOM_PT)}


def _scene_maps(results: BlockResults, f: Formatter, figs: dict[str, Any]) -> None:
    """The tie-point layout of each scene a `scene_points` rule fails."""
    rules = [r for r in _hinted(results, "scene_points") if r.status in ("fail", "error")]
    failing = list(
        dict.fromkeys(str(e["scene_id"]) for r in rules for e in r.evidence if "scene_id" in e)
    )
    beyond = {  # failing too, beyond the evidence kept (their points are not kept either)
        str(e["scene_id"]) for r in rules for e in _beyond_evidence(results, r) if "scene_id" in e
    }
    total = len(beyond.union(failing))
    measured = [m for r in rules if (m := results.measurement(r.measurement))]
    kept = {k: v for m in measured for k, v in (m.failing_scene_points or {}).items()}
    grid = int(next((m.detail["grid"] for m in measured if "grid" in m.detail), 3))
    size = {str(s["scene_id"]): s for s in results.scenes}
    for i, sid in enumerate(failing[:MAX_SCENE_MAPS]):
        pts, scene = kept.get(sid), size.get(sid, {})
        if not pts or not scene.get("lines") or not scene.get("samples"):
            caption = f.t("no_points_kept")
            figs["scene_maps"].append({**_scene_names(sid), "svg": None, "caption": caption})
            continue
        lines, samples = pts.get("line", []), pts.get("sample", [])
        svg = plots.scene_points(
            sid, lines, samples, scene["lines"], scene["samples"], grid, f.t, f"scene-{i}"
        )
        caption = f.t("scene_points_caption", n=len(lines), k=grid)
        figs["scene_maps"].append({**_scene_names(sid), "svg": svg, "caption": caption})
    drawn = min(len(failing), MAX_SCENE_MAPS)
    if total > drawn:
        figs["general_notes"].append(f.t("maps_capped", n=drawn, total=total))


def block_figures(results: BlockResults, f: Formatter, statuses: dict[str, str]) -> dict[str, Any]:
    """The SVG figures of a block report, by section, and the notes of each (`general_notes`
    under the general inspection's figures, `notes` under the checkpoints')."""
    figs: dict[str, Any] = {
        "general": [],
        "detailed": [],
        "scene_maps": [],
        "general_notes": [],
        "notes": [],
    }
    _checkpoint_figures(results, f, figs)
    _histogram(results, f, figs)
    _scene_counts(results, f, figs)
    if any(s.get("footprint_wkt") for s in results.scenes):
        figs["general"].append(plots.footprints(results.scenes, statuses, f.t, "footprints"))
    _scene_maps(results, f, figs)
    from blockqc.report.maps import overlap_map, residual_map

    for draw, unkept in ((residual_map, _residuals_not_kept), (overlap_map, _overlaps_not_kept)):
        if (svg := draw(results, f)) is not None:
            figs["general"].append(svg)
        elif note := unkept(results, f):
            figs["general_notes"].append(note)
    return figs


def _residuals_not_kept(results: BlockResults, f: Formatter) -> str | None:
    """Why the residual map is not drawn when results.json keeps no residual cells for the
    block's size (more than MAX_SCENES_FOR_CELLS scenes); None otherwise."""
    from blockqc.metrics.tiepoints import MAX_SCENES_FOR_CELLS

    m, n = next(iter(results.measurements_of("tie_point_errors")), None), len(results.scenes)
    if m is None or m.detail.get("residual_cells") or n <= MAX_SCENES_FOR_CELLS:
        return None
    return f.t("residual_map_not_kept", n=n, most=MAX_SCENES_FOR_CELLS)


def _overlaps_not_kept(results: BlockResults, f: Formatter) -> str | None:
    """Why the adjacent-image map is not drawn when results.json does not keep the block's
    discrepancy points (too many); None otherwise."""
    m = next(iter(results.measurements_of("overlap_discrepancy")), None)
    n = m.rows.get("point", 0) if m is not None else 0
    return f.t("overlap_map_not_kept", n=n) if n and "point" not in m.tables else None
