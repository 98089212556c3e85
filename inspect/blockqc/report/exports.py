"""Machine-readable exports beside the report: the checkpoint table and the failing evidence."""

from __future__ import annotations

import csv
import io
import json
from pathlib import PurePath
from typing import Any

from blockqc.report.checkpoints import checkpoint_points
from blockqc.results import STATUSES, BlockResults, Summary

CHECKPOINT_COLUMNS = [
    "component",
    "method",
    "point_id",
    "reference_id",
    "dx_m",
    "dy_m",
    "dz_m",
    "error_m",
    "abs_error_m",
    "bound_m",
    "gross",
]
EVIDENCE_COLUMNS = [
    "block_id",
    "rule",
    "group",
    "status",
    "clause",
    "value",
    "threshold",
    "unit",
    "row",
]


#: first characters that make a spreadsheet read a cell as a formula (OWASP CSV injection)
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def neutralise(text: str) -> str:
    """A text cell a spreadsheet would run as a formula, prefixed with ' so it stays text;
    numbers written as text (-3.2, +1e5) are left as they are."""
    if not text.startswith(FORMULA_START):
        return text
    try:
        float(text)
        return text
    except ValueError:
        return "'" + text


def _cell(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, dict | list):
        return neutralise(json.dumps(v, ensure_ascii=False))
    if isinstance(v, str):
        return neutralise(v)
    return v


def _csv(header: list[str], rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=header, lineterminator="\r\n", extrasaction="ignore")
    writer.writerow({k: neutralise(str(k)) for k in header})
    for r in rows:
        writer.writerow({k: _cell(r.get(k)) for k in header})
    return "\ufeff" + buf.getvalue()  # a BOM, so that spreadsheets read UTF-8


def _union(first: list[str], rows: list[dict[str, Any]]) -> list[str]:
    keys = list(first)
    for r in rows:
        keys += [k for k in r if k not in keys]
    return keys


def checkpoints_csv(results: BlockResults) -> str:
    """Every checkpoint of every component and method, as measured."""
    rows = [{"block_id": results.block_id, **p} for p in checkpoint_points(results)]
    return _csv(_union(["block_id", *CHECKPOINT_COLUMNS], rows), rows)


def evidence_csv(results: BlockResults) -> str:
    """One row per evidence row of every result that is not a pass (fail, error, warn, waived)."""
    rows = []
    for res in results.results:
        if res.status not in ("fail", "error", "warn", "waived"):
            continue
        base = {
            "block_id": results.block_id,
            "rule": res.rule,
            "group": ";".join(f"{k}={v}" for k, v in res.group.items()),
            "status": res.status,
            "clause": res.clause,
            "value": res.value,
            "threshold": res.threshold,
            "unit": res.unit,
        }
        if not res.evidence:
            rows.append({**base, "row": ""})
        for i, e in enumerate(res.evidence, start=1):
            rows.append(
                {**{f"evidence_{k}" if k in base else k: v for k, v in e.items()}, **base, "row": i}
            )
    return _csv(_union(EVIDENCE_COLUMNS, rows), rows)


SUMMARY_COLUMNS = ["block_id", "verdict", "sampled", "failed_rules", "warned_rules",
                   "pending_manual", *(f"n_{s}" for s in STATUSES), "report", "path",
                   "problems"]  # fmt: skip


def summary_rows(summary: Summary) -> list[dict[str, Any]]:
    """One row per delivery of the batch (lists joined with spaces), for spreadsheets: a
    delivery that could not be read is a row too, verdict `unreadable`, named by its folder,
    with its problems."""
    unread = [
        {
            "block_id": PurePath(u.path).name,
            "verdict": "unreadable",
            "sampled": None,
            **{f"n_{s}": 0 for s in STATUSES},
            "path": u.path,
            "problems": "; ".join(u.problems),
        }
        for u in summary.unreadable
    ]
    return [
        {
            "block_id": b.block_id,
            "verdict": b.verdict,
            "sampled": b.sampled,
            "failed_rules": " ".join(b.failed_rules),
            "warned_rules": " ".join(b.warned_rules),
            "pending_manual": " ".join(b.pending_manual),
            **{f"n_{s}": b.counts.get(s, 0) for s in STATUSES},
            "report": b.report,
            "path": b.path,
        }
        for b in summary.blocks
    ] + unread


def summary_csv(summary: Summary) -> str:
    return _csv(SUMMARY_COLUMNS, summary_rows(summary))


def summary_parquet(summary: Summary) -> bytes:
    """The same table as Parquet (typed columns), for analysis tools."""
    import io as _io

    import pandas as pd

    buf = _io.BytesIO()
    pd.DataFrame(summary_rows(summary), columns=SUMMARY_COLUMNS).to_parquet(buf, index=False)
    return buf.getvalue()


__all__ = ["checkpoints_csv", "evidence_csv", "summary_csv", "summary_parquet"]
