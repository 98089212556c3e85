"""The results documents (contract v1): results.json per block and summary.json per batch.

Produced by the engine and the batch, read by every renderer and by `blockqc report`, which
validates what it reads against these models. The JSON Schema is `blockqc schema results|summary`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from blockqc.acceptance.model import BatchDecision, Evaluation, ReportMeta
from blockqc.errors import InputError, Problem
from blockqc.outputs import block_id_problem
from blockqc.rules.model import ElementDef

Status = Literal["pass", "fail", "warn", "waived", "manual", "not_applicable", "error"]
Verdict = Literal["pass", "fail", "error"]

#: every status a rule result can take, worst first: the one order of the project
STATUS_ORDER: tuple[Status, ...] = (
    "error",
    "fail",
    "manual",
    "warn",
    "waived",
    "pass",
    "not_applicable",
)
#: the contract's listing order of the statuses (counts, tables)
STATUSES: tuple[Status, ...] = (
    "pass",
    "fail",
    "warn",
    "waived",
    "manual",
    "not_applicable",
    "error",
)


def worst_status(statuses: Iterable[str]) -> str | None:
    """The worst of some statuses by STATUS_ORDER (None when there are none)."""
    seen = set(statuses)
    return next((s for s in STATUS_ORDER if s in seen), None)


def tally(statuses: Iterable[str]) -> tuple[dict[str, int], str]:
    """The count of each status and the block's verdict from its results' statuses: error when
    a rule could not be judged, else fail when one fails, else pass."""
    counts = dict.fromkeys(STATUSES, 0)
    for status in statuses:
        counts[status] += 1
    return counts, "error" if counts["error"] else "fail" if counts["fail"] else "pass"


def block_fails(verdict: str) -> bool:
    """The one definition of a failing block: its verdict is not pass (fail, or error)."""
    return verdict != "pass"


def status_rank(status: str) -> int:
    """Position of a status in STATUS_ORDER (unknown last), for sorting worst first."""
    return STATUS_ORDER.index(status) if status in STATUS_ORDER else len(STATUS_ORDER)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


def _safe_block_id(value: str) -> str:
    why = block_id_problem(value)
    if why:
        raise ValueError(why)
    return value


class RuleResult(_Model):
    """One judgement of a rule (per group where the rule is checked per group)."""

    rule: str
    title: str
    title_zh: str = ""
    clause: str
    description: str = ""
    description_zh: str = ""
    quality_element: str = ""
    content: list[str] = Field(default_factory=list)
    inspection: Literal["general", "detailed"] = "general"
    figures: list[str] = Field(default_factory=list)
    group: dict[str, Any] = Field(default_factory=dict)
    status: Status
    statistic: str | None = None
    value: Any = None
    threshold: Any = None
    comparison: str | None = None
    threshold_text: str = ""
    unit: str = ""
    severity: Literal["fail", "warn"] = "fail"
    measurement: str | None = None  # key of the measurement judged (see BlockResults)
    detail: dict[str, Any] = Field(default_factory=dict)
    evidence: list[dict[str, Any]] = Field(default_factory=list)


class MeasurementRecord(_Model):
    """What one metric measured with one set of parameters (small tables kept for the report)."""

    key: str
    metric: str
    params: dict[str, Any] = Field(default_factory=dict)
    detail: dict[str, Any] = Field(default_factory=dict)
    tables: dict[str, list[dict[str, Any]]] = Field(default_factory=dict)
    rows: dict[str, int] = Field(default_factory=dict)  # every table's full row count
    failing_scene_points: dict[str, Any] | None = None


class BlockResults(_Model):
    """results.json: one block inspected with one rule pack."""

    block_id: str
    sensor: str | None = None
    rule_pack: str
    rule_pack_version: str = ""
    rule_pack_files: list[str] = Field(default_factory=list)
    blockqc_version: str = ""
    generated_at: str = ""
    inspector: str | None = None
    delivery: str = ""
    verdict: Verdict
    complete: bool = True
    pending_manual: list[str] = Field(default_factory=list)
    counts: dict[Status, int] = Field(default_factory=dict)
    summary: dict[str, Any] = Field(default_factory=dict)
    # columns of the delivery's tables not read (a pack with `columns: used`): their checks,
    # and those of keys over them, were not made
    not_read: dict[str, list[str]] = Field(default_factory=dict)
    # what the delivery gives that the rules read as given but an inspector should know, each
    # "file, row (line), column: why" (e.g. a tie point given two ground points); said on the
    # console as warnings
    input_warnings: list[str] = Field(default_factory=list)
    # contract v1.1: what blockqc computed itself from the delivery's geometry (§RC-1, §RC-2)
    process_data: dict[str, Any] = Field(default_factory=dict)
    elements: list[ElementDef] = Field(default_factory=list)
    scenes: list[dict[str, Any]] = Field(default_factory=list)
    results: list[RuleResult]
    measurements: list[MeasurementRecord] = Field(default_factory=list)
    # §QE: whether a sampling plan picked the block for detailed inspection (None: no plan)
    sampled: bool | None = None
    evaluation: Evaluation | None = None  # §QE score and grade, when the pack has acceptance
    meta: ReportMeta | None = None  # the filed report's particulars (--meta)

    @field_validator("block_id")
    @classmethod
    def _safe(cls, v: str) -> str:
        return _safe_block_id(v)

    def measurement(self, key: str | None) -> MeasurementRecord | None:
        return next((m for m in self.measurements if m.key == key), None) if key else None

    def measurements_of(self, metric: str) -> list[MeasurementRecord]:
        return [m for m in self.measurements if m.metric == metric]

    @property
    def fails(self) -> bool:
        return block_fails(self.verdict)


class BlockEntry(_Model):
    """One inspected block in the batch summary."""

    block_id: str
    verdict: Verdict
    path: str = ""
    results: str
    report: str
    sampled: bool = False
    failed_rules: list[str] = Field(default_factory=list)
    warned_rules: list[str] = Field(default_factory=list)
    pending_manual: list[str] = Field(default_factory=list)
    counts: dict[Status, int] = Field(default_factory=dict)
    complete: bool = True  # its results.json's: False for a sampled block not fully evaluated

    @field_validator("block_id")
    @classmethod
    def _safe(cls, v: str) -> str:
        return _safe_block_id(v)

    # a sampled block's checkpoint statistics per component and method, with their status
    checkpoints: list[dict[str, Any]] = Field(default_factory=list)
    # the block's footprint (lon/lat), for the overview map; a block across ±180° is one piece,
    # its longitudes beyond ±180° on one side (`lonlat.unwrapped`)
    extent_wkt: str | None = None
    pdf: bool = False  # report.pdf written beside report.html
    score: float | None = None  # §QE evaluation of the block, when the pack has acceptance
    grade: str | None = None
    evaluation_fails: bool | None = None
    evaluation_reasons: list[str] = Field(default_factory=list)


class Rejected(_Model):
    """A delivery that could not be inspected, and why (nothing was written for it)."""

    path: str
    problems: list[str]


class BatchCounts(_Model):
    blocks: int
    pass_: int = Field(alias="pass")
    fail: int  # failing blocks (verdict fail or error), block_fails()
    error: int = 0  # of which a rule could not be judged
    unreadable: int = 0

    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class Summary(_Model):
    """summary.json: a batch inspected with one rule pack."""

    rule_pack: str
    rule_pack_version: str = ""
    blockqc_version: str = ""
    generated_at: str = ""
    inspector: str | None = None
    verdict: Verdict
    complete: bool = True
    counts: BatchCounts
    blocks: list[BlockEntry] = Field(default_factory=list)
    rules: dict[str, dict[Status, int]] = Field(default_factory=dict)
    unreadable: list[Rejected] = Field(default_factory=list)
    acceptance: BatchDecision | None = None  # §QE-5 batch decision
    sampling: dict[str, Any] | None = None  # the sampling plan used, as read (§QE-1)
    meta: ReportMeta | None = None  # the filed report's particulars (--meta), basis filled in
    elements: list[ElementDef] = Field(default_factory=list)  # the pack's inspection contents
    sampling_table: list[dict[str, int]] = Field(default_factory=list)  # the pack's §QE-1 table


def dump(model: BaseModel) -> dict[str, Any]:
    """A results model as the JSON document (aliases, e.g. counts.pass)."""
    return model.model_dump(mode="json", by_alias=True)


def json_schema(kind: Literal["results", "summary"]) -> dict[str, Any]:
    """The published JSON Schema of results.json or summary.json."""
    model = BlockResults if kind == "results" else Summary
    schema = model.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = f"blockqc {kind}.json"
    return schema


def json_path(loc: tuple[int | str, ...]) -> str:
    """A pydantic error location as a JSON path: results[3].status."""
    out = "$"
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


def parse(doc: Any, file: str, kind: Literal["results", "summary"]) -> BlockResults | Summary:
    """Validate a results.json or summary.json document; InputError names each JSON path."""
    model = BlockResults if kind == "results" else Summary
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise InputError(
            [
                Problem(file, f"not a valid {kind}.json: at {json_path(e['loc'])}: {e['msg']}")
                for e in exc.errors()[:20]
            ]
        ) from None
