"""Helpers of the report tests: a hand-written results.json, and the Debian tools they need."""

from __future__ import annotations

import math
import os
import shutil
from typing import Any

import pytest

XSS = "<script>alert(1)</script>"
BAD_SCENE = f"S-003{XSS}"


def _point(
    component: str,
    method: str,
    pid: str,
    ref: str,
    dx: float | None,
    dy: float | None,
    dz: float | None,
    bound: float,
    x: float,
    y: float,
) -> dict[str, Any]:
    err = math.hypot(dx, dy) if component == "plane" else dz
    return {
        "component": component,
        "method": method,
        "point_id": pid,
        "reference_id": ref,
        "dx_m": dx,
        "dy_m": dy,
        "dz_m": dz,
        "error_m": err,
        "abs_error_m": abs(err),
        "bound_m": bound,
        "gross": abs(err) > bound,
        "x_m": x,
        "y_m": y,
    }


def _hand_results() -> dict[str, Any]:
    """A small results.json written by hand (not by the engine) touching every report section."""
    # Eight high-precision plane checkpoints, three of them gross (bound 2·10 m), like field 3 of
    # DOMAIN §CP; four same-accuracy plane and height checkpoints.
    hp = [
        (3.0, 4.0),
        (6.0, 8.0),
        (-9.0, 12.0),
        (12.0, -16.0),
        (1.0, 1.0),
        (21.0, 0.0),
        (0.0, -25.0),
        (30.0, 0.0),
    ]
    points = [
        _point(
            "plane",
            "high_precision",
            f"C{i:02d}",
            f"WV-{i // 3}",
            dx,
            dy,
            None,
            20.0,
            500000 + 1000 * i,
            4400000 + 700 * (i % 3),
        )
        for i, (dx, dy) in enumerate(hp)
    ]
    sa = [(2.0, 1.0, 3.0), (-1.0, 2.0, -2.0), (4.0, -3.0, 1.0), (0.5, 0.5, -4.0)]
    for i, (dx, dy, dz) in enumerate(sa):
        points.append(
            _point(
                "plane",
                "same_accuracy",
                f"G{i:02d}",
                "GoogleEarth",
                dx,
                dy,
                None,
                28.28,
                501000 + 900 * i,
                4401000 + 400 * i,
            )
        )
        points.append(
            _point(
                "height",
                "same_accuracy",
                f"G{i:02d}",
                "GoogleEarth",
                None,
                None,
                dz,
                16.97,
                501000 + 900 * i,
                4401000 + 400 * i,
            )
        )
    stats = [
        {
            "component": "plane",
            "method": "high_precision",
            "n_total": 8,
            "n": 5,
            "n_gross": 3,
            "gross_rate": 37.5,
            "medium_error": 10.4,
            "statistic": "mean",
            "used_mean": True,
            "max_error": 20.0,
            "norm_m": 10.0,
            "bound_m": 20.0,
        },
        {
            "component": "plane",
            "method": "same_accuracy",
            "n_total": 4,
            "n": 4,
            "n_gross": 0,
            "gross_rate": 0.0,
            "medium_error": 2.1,
            "statistic": "mean",
            "used_mean": True,
            "max_error": 5.0,
            "norm_m": 10.0,
            "bound_m": 28.28,
        },
        {
            "component": "height",
            "method": "same_accuracy",
            "n_total": 4,
            "n": 4,
            "n_gross": 0,
            "gross_rate": 0.0,
            "medium_error": 1.77,
            "statistic": "mean",
            "used_mean": True,
            "max_error": 4.0,
            "norm_m": 6.0,
            "bound_m": 16.97,
        },
    ]

    def res(
        rule: str,
        title: str,
        clause: str,
        status: str,
        value: Any,
        threshold: Any,
        comparison: str | None,
        unit: str = "",
        group: dict | None = None,
        detail: dict | None = None,
        evidence: list | None = None,
    ) -> dict[str, Any]:
        return {
            "rule": rule,
            "title": title,
            "clause": clause,
            "group": group or {},
            "status": status,
            "value": value,
            "threshold": threshold,
            "comparison": comparison,
            "threshold_text": "",
            "unit": unit,
            "severity": "fail",
            "detail": detail or {},
            "evidence": evidence or [],
        }

    sparse = {
        "scene_id": BAD_SCENE,
        "band": "pan",
        "water_fraction": 0.0,
        "n_points": 40,
        "cells_covered": 2,
        "cells_expected": 9,
        "coverage": 2 / 9,
        "clark_evans": 0.4,
    }
    results = [
        res(
            "MB-1",
            "Geodetic coordinate system is WGS-84",
            "§MB-1",
            "pass",
            "WGS84",
            ["WGS84"],
            "in",
        ),
        res(
            "MB-2",
            "Heights are ellipsoidal (WGS-84)",
            "§MB-2",
            "pass",
            "ellipsoidal",
            ["ellipsoidal"],
            "in",
        ),
        res(
            "MB-3",
            "UTM projection in the block's zone (UPS in polar regions)",
            "§MB-3",
            "pass",
            True,
            True,
            "equals",
        ),
        res("TP-1", "Tie-point error statistic", "§TP-1", "pass", 0.31, 0.5, "<=", "px"),
        res(
            "TP-4",
            "At least 100 tie points in every scene",
            "§TP-4",
            "fail",
            40,
            100.0,
            ">=",
            "points",
            detail={
                "n_units": 4,
                "n_offending": 1,
                "exempt": [
                    {"scene_id": "S-SEA", "exempt_reason": "water_fraction 0.82 ≥ 0.5 (mostly sea)"}
                ],
            },
            evidence=[sparse],
        ),
        res(
            "TP-5",
            "Tie points uniformly distributed in every scene",
            "§TP-4",
            "fail",
            2 / 9,
            1.0,
            ">=",
            "share of cells",
            evidence=[sparse],
        ),
        res(
            "RO-3",
            "Each adjacent-image discrepancy below 2√2·m",
            "§RO-3",
            "fail",
            38.98,
            28.284271247461902,
            "<",
            "m",
            group={"component": "plane"},
            detail={"n_units": 40, "n_offending": 2},
            evidence=[
                {
                    "scene_a": "S-001",
                    "scene_b": "S-002",
                    "point_id": "O7",
                    "component": "plane",
                    "value_m": 38.98,
                    "dx_m": 34.58,
                    "dy_m": 17.99,
                    "dz_m": None,
                },
                {
                    "scene_a": "S-001",
                    "scene_b": "S-002",
                    "point_id": "O9",
                    "component": "plane",
                    "value_m": 30.5,
                    "dx_m": 30.0,
                    "dy_m": 5.5,
                    "dz_m": None,
                },
            ],
        ),
        res(
            "CP-2",
            "Checkpoint plane medium error within the norm",
            "§CP-5",
            "fail",
            10.4,
            10.0,
            "<=",
            "m",
            group={"component": "plane", "method": "high_precision"},
            detail={"n_total": 8, "n": 5, "n_gross": 3, "statistic": "mean", "used_mean": True},
        ),
        res(
            "CP-2",
            "Checkpoint plane medium error within the norm",
            "§CP-5",
            "pass",
            2.1,
            10.0,
            "<=",
            "m",
            group={"component": "plane", "method": "same_accuracy"},
        ),
        res(
            "CP-3",
            "Checkpoint height medium error within the norm",
            "§CP-5",
            "pass",
            1.77,
            6.0,
            "<=",
            "m",
            group={"component": "height", "method": "same_accuracy"},
        ),
        res(
            "CP-4",
            "Gross-error rate below 5 %",
            "§CP-6",
            "fail",
            37.5,
            5.0,
            "<",
            "%",
            group={"component": "plane", "method": "high_precision"},
            evidence=[p for p in points if p["gross"]],
        ),
        res(
            "DOC-1",
            "Required documents present and readable",
            "§DOC-1",
            "waived",
            False,
            True,
            "equals",
            detail={
                "n_units": 5,
                "n_offending": 1,
                "waived": ["absolute_orientation_report"],
                "waiver_reason": f"delivered later {XSS}",
            },
        ),
        res(
            "DOC-3",
            "Standardization of the documents",
            "§DOC-3",
            "pass",
            "pass",
            None,
            None,
            detail={"note": f"follows the template {XSS}", "decided_by": "inspector"},
        ),
    ]
    scenes = []
    for i, sid in enumerate(["S-001", "S-002", BAD_SCENE, "S-SEA"]):
        lon, lat = 40.0 + 0.1 * i, 39.3
        ring = [
            (lon, lat),
            (lon + 0.12, lat),
            (lon + 0.12, lat + 0.1),
            (lon, lat + 0.1),
            (lon, lat),
        ]
        wkt = "POLYGON((" + ", ".join(f"{x} {y}" for x, y in ring) + "))"
        scenes.append(
            {
                "scene_id": sid,
                "band": "pan",
                "acquired": "2021-06-30",
                "lines": 12000,
                "samples": 12000,
                "water_fraction": 0.82 if sid == "S-SEA" else 0.0,
                "footprint_wkt": wkt,
            }
        )
    counts = {
        "pass": 7,
        "fail": 5,
        "warn": 0,
        "waived": 1,
        "manual": 0,
        "not_applicable": 0,
        "error": 0,
    }
    return {
        "block_id": "T-B01",
        "sensor": "ZY-3",
        "rule_pack": "global-project",
        "rule_pack_version": "1.0",
        "rule_pack_files": ["rules/global-project.yaml"],
        "blockqc_version": "0.1.0",
        "generated_at": "2026-11-20T08:00:00Z",
        "inspector": f"Wang Fang {XSS}",
        "delivery": "/data/T-B01",
        "verdict": "fail",
        "complete": True,
        "pending_manual": [],
        "counts": counts,
        "summary": {
            "scenes": 4,
            "tie_point_observations": 900,
            "tie_points": 400,
            "checkpoints": 12,
        },
        "results": results,
        "measurements": {
            "scenes": scenes,
            "tie_point_errors": {
                "detail": {
                    "histogram": {
                        "edges_px": [round(0.1 * i, 1) for i in range(21)],
                        "counts": [
                            5,
                            40,
                            90,
                            120,
                            110,
                            80,
                            50,
                            30,
                            15,
                            8,
                            4,
                            2,
                            1,
                            0,
                            0,
                            1,
                            0,
                            0,
                            0,
                            0,
                        ],
                    },
                    "interval_px": [1.0, 1.5],
                }
            },
            "tie_point_distribution": {
                "detail": {"grid": 3, "exempt_water_fraction": 0.5},
                "scene": [
                    {"scene_id": "S-001", "n_points": 310, "coverage": 1.0, "exempt": False},
                    {"scene_id": "S-002", "n_points": 290, "coverage": 1.0, "exempt": False},
                    {"scene_id": BAD_SCENE, "n_points": 40, "coverage": 2 / 9, "exempt": False},
                    {"scene_id": "S-SEA", "n_points": 12, "coverage": 1 / 9, "exempt": True},
                ],
                "failing_scene_points": {
                    BAD_SCENE: {
                        "line": [100.0 + 50 * (i % 8) for i in range(40)],
                        "sample": [200.0 + 90 * (i // 8) for i in range(40)],
                    }
                },
            },
            "checkpoint_accuracy": {
                "detail": {
                    "agreement": [
                        {
                            "component": "plane",
                            "methods": ["high_precision", "same_accuracy"],
                            "medium_error": [10.4, 2.1],
                            "spread_m": 8.3,
                            "agree": False,
                        }
                    ]
                },
                "block": [{"n_points": 12, "n_rows": 16}],
                "component_method": stats,
                "point": points,
            },
        },
    }


def make_results() -> dict[str, Any]:
    """The hand-made results as the stock pack would report them (results.json, contract v1):
    each result carries its rule's contents, inspection and figure hints from the pack, and names
    the measurement it judged."""
    from blockqc.rules import load_pack

    doc = _hand_results()
    pack = load_pack("global-project")
    legacy = doc.pop("measurements")
    doc["scenes"] = legacy.pop("scenes")
    doc["elements"] = [e.model_dump() for e in pack.elements]
    doc["measurements"] = [
        {
            "key": name,
            "metric": name,
            "detail": m.get("detail", {}),
            "tables": {k: v for k, v in m.items() if k not in ("detail", "failing_scene_points")},
            "failing_scene_points": m.get("failing_scene_points"),
        }
        for name, m in legacy.items()
    ]
    elements = pack.content_ids()
    for res in doc["results"]:
        rule = pack.rule(res["rule"])
        res["title_zh"] = rule.title_zh
        res["content"] = [
            c
            for c, where in rule.content.items()
            if all(res["group"].get(k, v) == v for k, v in where.items())
        ]
        res["quality_element"] = elements[res["content"][0]] if res["content"] else ""
        res["inspection"] = rule.inspection
        res["figures"] = list(rule.figures)
        res["measurement"] = rule.metric if rule.metric in legacy else None
    return doc


def summary_entry(block_id: str, verdict: str, **fields: Any) -> dict[str, Any]:
    """One block's line of a hand-written summary.json (its report and results by block id)."""
    return {
        "block_id": block_id,
        "verdict": verdict,
        "report": f"{block_id}/report.html",
        "results": f"{block_id}/results.json",
        "sampled": False,
        "failed_rules": [],
        "warned_rules": [],
        "pending_manual": [],
        **fields,
    }


def results_entry(doc: dict[str, Any], **fields: Any) -> dict[str, Any]:
    """A summary line of a sampled block that agrees with its results document: the rules it
    fails (or errs on) and warns of, its pending items and checkpoint statistics."""
    from blockqc.report import checkpoint_rows
    from blockqc.results import BlockResults

    statuses = [(r["rule"], r["status"]) for r in doc["results"]]
    made = {
        "sampled": True,
        "failed_rules": sorted({rule for rule, s in statuses if s in ("fail", "error")}),
        "warned_rules": sorted({rule for rule, s in statuses if s == "warn"}),
        "pending_manual": doc.get("pending_manual", []),
        "checkpoints": checkpoint_rows(BlockResults.model_validate(doc)),
    }
    return summary_entry(doc["block_id"], doc["verdict"], **{**made, **fields})


def make_summary(blocks: list[dict[str, Any]], rules: dict | None = None) -> dict[str, Any]:
    """A hand-written summary.json over the given block lines (counts from their verdicts)."""
    failing = sum(b["verdict"] != "pass" for b in blocks)
    return {
        "rule_pack": "global-project",
        "rule_pack_version": "1.0",
        "blockqc_version": "0.1.0",
        "generated_at": "2026-11-20T08:00:00Z",
        "inspector": None,
        "verdict": "fail" if failing else "pass",
        "complete": True,
        "counts": {
            "blocks": len(blocks),
            "pass": len(blocks) - failing,
            "fail": failing,
            "error": 0,
            "unreadable": 0,
        },
        "blocks": blocks,
        "rules": rules or {},
        "unreadable": [],
    }


def require_tool(name: str) -> str:
    """The path of a Debian tool; skip when absent, unless BLOCKQC_REQUIRE_BROWSER is set."""
    found = shutil.which(name)
    if found:
        return found
    if os.environ.get("BLOCKQC_REQUIRE_BROWSER"):
        pytest.fail(f"{name} is required (BLOCKQC_REQUIRE_BROWSER is set) but not installed")
    pytest.skip(f"{name} is not installed (apt-get install chromium poppler-utils)")


def require_chromium() -> str:
    """The Chromium that `--pdf-engine chromium` would use; skip when there is none, unless
    BLOCKQC_REQUIRE_BROWSER is set."""
    from blockqc.report.chromium import ChromiumProblem, find_chromium

    try:
        return find_chromium()
    except ChromiumProblem as exc:
        if os.environ.get("BLOCKQC_REQUIRE_BROWSER"):
            pytest.fail(f"Chromium is required (BLOCKQC_REQUIRE_BROWSER is set): {exc}")
        pytest.skip(str(exc))
