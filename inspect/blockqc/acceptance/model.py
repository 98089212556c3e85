"""The `acceptance:` section of a rule pack: the standard's mechanics as data (§QE-1..6)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from blockqc.schema import did_you_mean
from blockqc.yamlio import Text

ErrorClass = Literal["A", "B", "C", "D"]

#: words that read as a passing verdict (a decision, a rule's status, an inspector's verdict):
#: the fail grade cannot be named so, or failing blocks would be graded "pass"
PASSING_WORDS = ("pass", "passed", "conditional_pass", "waived")


def _score(v: float) -> float:
    """Scores are 0 to 100 (§QE-3, §QE-4): a bound outside is never or always reached."""
    if not 0 <= v <= 100:
        raise ValueError(f"expected a score from 0 to 100, got {v:g}")
    return v


#: a score bound (a grade's lowest score, element_fail_below)
Score = Annotated[float, AfterValidator(_score)]


class _M(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class _Pack(_M):
    """What a pack writes: a number is a number, never true/false (`sample: yes` is not 1) nor
    text ("20"), refused rather than converted."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


class ScoreDef(_Pack):
    """How a rule's results are scored: `accuracy` against a norm (§QE-3), else by deduction."""

    kind: Literal["accuracy", "deduction"] = "deduction"
    # the norm m0 (an expression over the pack's constants); none: the result's upper bound
    norm: float | int | str | None = None

    @field_validator("norm", mode="before")
    @classmethod
    def _positive(cls, v: Any) -> Any:
        """m0 divides the score (§QE-3): a number at or below 0 (or true/false) cannot be meant;
        an expression is checked when the pack is loaded."""
        if isinstance(v, bool):
            raise ValueError("expected a number above 0 or an expression, got true/false")
        if isinstance(v, (int, float)) and not v > 0:
            raise ValueError(f"the norm m0 divides the accuracy score: expected above 0, got {v}")
        return v


class SampleRow(_Pack):
    """One line of the sampling table: batches of up to `batch` units give `sample` units."""

    batch: int = Field(gt=0)
    sample: int = Field(gt=0)

    @model_validator(mode="after")
    def _not_more(self) -> SampleRow:
        if self.sample > self.batch:
            raise ValueError(f"sample {self.sample} is larger than its batch {self.batch}")
        return self


class Sampling(_Pack):
    """§QE-1: the sample size by batch size; larger batches split into the fewest even batches."""

    table: list[SampleRow] = Field(min_length=1)

    @field_validator("table")
    @classmethod
    def _ascending(cls, table: list[SampleRow]) -> list[SampleRow]:
        """Said at the table's line, naming the rows (not at `sampling:`)."""
        for i, (a, b) in enumerate(zip(table, table[1:], strict=False), start=2):
            if b.batch <= a.batch:
                raise ValueError(
                    f"row {i} (batch {b.batch}) follows row {i - 1} (batch {a.batch}): batch "
                    "sizes must be strictly ascending"
                )
            if b.sample < a.sample:  # §QE-1: a larger batch never gets a smaller sample
                raise ValueError(
                    f"row {i}: batches of up to {b.batch} give a sample of {b.sample}, below "
                    f"the {a.sample} of batches of up to {a.batch} (row {i - 1}): the sample "
                    "grows with the batch (a digit missing?)"
                )
        return table

    @property
    def max_batch(self) -> int:
        return self.table[-1].batch


class Deduction(_Pack):
    """§QE-4: score = 100 − (B·nB + C·nC + D·nD)/t."""

    B: float = Field(default=12, ge=0)
    C: float = Field(default=4, ge=0)
    D: float = Field(default=1, ge=0)
    t: float = Field(default=1, gt=0)


class AccuracyScore(_Pack):
    """§QE-3: 100 for m ≤ full·m0, else floor + span·(m0 − m)/((1 − full)·m0) up to m0."""

    full: float = Field(default=0.3, gt=0, lt=1)
    floor: float = Field(default=60, ge=0, le=100)
    span: float = Field(default=40, gt=0, le=100)


class Grade(_Pack):
    """A grade and its lowest score (inclusive)."""

    id: Text
    min: Score
    title: Text
    title_zh: str = ""


def _mins(grades: list[Grade]) -> str:
    """The grades as listed, with their lowest scores: 'excellent 90, good 95, pass 60'."""
    return ", ".join(f"{g.id} {g.min:g}" for g in grades)


def _known_grade(gid: str, info: ValidationInfo) -> str:
    """A grade named by `better_than`, `batch_default` or a batch grade is one of `grades`
    (listed best first; nothing to check against when the grades themselves are refused)."""
    if "grades" not in info.data:
        return gid
    ids = [g.id for g in info.data["grades"]]
    if gid not in ids:
        hint = did_you_mean(ids)(gid)
        raise ValueError(f"grade '{gid}' is not one of the grades ({', '.join(ids)}){hint}")
    return gid


#: a grade's id where one of the pack's grades is meant
GradeRef = Annotated[str, AfterValidator(_known_grade)]


class BatchGrade(_Pack):
    """§QE-5: a batch grade when enough of the sample's units are good or better and excellent."""

    grade: str
    better_pct: float = Field(ge=0, le=100)  # units graded `better_than` or above, in %
    top_pct: float = Field(ge=0, le=100)  # units of the top grade, in %


def _batch_grade_known(v: BatchGrade, info: ValidationInfo) -> BatchGrade:
    _known_grade(v.grade, info)
    return v


class Weights(_Pack):
    """§QE-4: weights of the quality elements and, within each element, of its items."""

    elements: dict[str, Annotated[float, Field(ge=0)]] = Field(default_factory=dict)
    items: dict[str, Annotated[float, Field(ge=0)]] = Field(default_factory=dict)


class Acceptance(_Pack):
    """Everything §QE needs, as a pack states it."""

    standard: str = ""
    standard_zh: str = ""
    basis: list[str] = Field(default_factory=list)  # inspection basis (standards, design)
    basis_zh: list[str] = Field(default_factory=list)
    sampling: Sampling
    default_error_class: ErrorClass = "C"
    deduction: Deduction = Field(default_factory=Deduction)
    accuracy: AccuracyScore = Field(default_factory=AccuracyScore)
    element_fail_below: Score = 60  # §QE-2: a unit fails with any element below this
    grades: list[Grade] = Field(min_length=1)  # best first; below the last: the fail grade
    fail_grade: Grade
    # §QE-5 "good or better"; a default too must name a grade
    better_than: GradeRef = Field(default="good", validate_default=True)
    batch_grades: list[Annotated[BatchGrade, AfterValidator(_batch_grade_known)]] = Field(
        default_factory=list
    )  # best first
    batch_default: GradeRef = Field(default="pass", validate_default=True)
    weights: Weights = Field(default_factory=Weights)

    @field_validator("fail_grade")
    @classmethod
    def _fail_grade_apart(cls, v: Grade, info: ValidationInfo) -> Grade:
        """The fail grade's id names it alone, and does not read as passing."""
        ids = [g.id for g in info.data.get("grades", [])]
        if v.id in ids:
            raise ValueError(
                f"id '{v.id}' is also the id of a grade ({', '.join(ids)}): failing blocks "
                "would be graded like blocks of that grade; give the fail grade an id of its "
                "own, e.g. fail"
            )
        if v.id.strip().lower() in PASSING_WORDS:
            raise ValueError(
                f"id '{v.id}' reads as a passing verdict: failing blocks would be graded "
                f"'{v.id}'; give the fail grade an id such as fail"
            )
        return v

    @field_validator("batch_grades")
    @classmethod
    def _batch_best_first(cls, v: list[BatchGrade], info: ValidationInfo) -> list[BatchGrade]:
        """The first batch grade whose shares hold is given: a worse one listed before a better
        one would be given in its place."""
        ids = [g.id for g in info.data.get("grades", [])]
        named = [b.grade for b in v if b.grade in ids]  # an unknown one: _grades says so
        ranks = [ids.index(g) for g in named]
        if ranks != sorted(set(ranks)):
            raise ValueError(
                f"list them best first, in the order of grades ({', '.join(ids)}), each once: "
                f"got {', '.join(named)}"
            )
        return v

    @field_validator("grades")
    @classmethod
    def _grades(cls, grades: list[Grade]) -> list[Grade]:
        """Said at the line of `grades:`, with the other problems of the section."""
        mins = [g.min for g in grades]
        if any(a <= b for a, b in zip(mins, mins[1:], strict=False)):
            raise ValueError(
                "list them best first, each lowest score below the one before (of two grades "
                f"from the same score the second would never be given): got {_mins(grades)}"
            )
        listed = [g.id for g in grades]
        twice = sorted({i for i in listed if listed.count(i) > 1})
        if twice:
            raise ValueError(f"each grade has an id of its own: {', '.join(twice)} twice")
        return grades

    def grade(self, score: float) -> Grade:
        """The grade of a score that has not failed otherwise (§QE-5)."""
        return next((g for g in self.grades if score >= g.min), self.fail_grade)

    def grade_by_id(self, gid: str) -> Grade:
        return next((g for g in [*self.grades, self.fail_grade] if g.id == gid), self.fail_grade)


# ------------------------------------------------------------------ what results.json records
class ErrorRecord(_M):
    """One error found: the rule (and group) that failed, its class, value and threshold."""

    rule: str
    error_class: ErrorClass
    group: dict[str, object] = Field(default_factory=dict)
    value: object = None
    threshold: object = None
    reason: str = ""  # e.g. "medium error beyond the norm"
    # as the rule's result gives them, so that pages show the value and threshold as it does
    comparison: str | None = None
    unit: str = ""
    norm: float | None = None  # of an error beyond the norm (§QE-3): the norm m0 it exceeds


class AccuracyRecord(_M):
    """A mathematical-accuracy result scored against its norm (§QE-3)."""

    rule: str
    group: dict[str, object] = Field(default_factory=dict)
    value: float
    norm: float
    score: float | None  # None: beyond the norm, an A-class error


class _Scored(_M):
    """What an element and an item share: id, titles, weight, whether inspected, score."""

    id: str
    title: str = ""
    title_zh: str = ""
    weight: float
    inspected: bool
    score: float | None = None


class ItemScore(_Scored):
    """A quality item (sub-element): its score, weight, errors and accuracy scores."""

    counts: dict[str, int] = Field(default_factory=dict)  # errors by class
    deduction: float = 0.0  # (B·nB + C·nC + D·nD)/t
    accuracy: list[AccuracyRecord] = Field(default_factory=list)
    errors: list[ErrorRecord] = Field(default_factory=list)


class ElementScore(_Scored):
    """A quality element: the weighted mean of its inspected items."""

    items: list[ItemScore] = Field(default_factory=list)


class Evaluation(_M):
    """A block's quality evaluation (§QE-2..5): score, grade, and why it fails."""

    standard: str = ""
    standard_zh: str = ""
    score: float | None = None
    grade: str | None = None  # a grade id of the pack (e.g. excellent … fail)
    grade_title: str = ""
    grade_title_zh: str = ""
    fails: bool = False
    complete: bool = True
    reasons: list[str] = Field(default_factory=list)  # why it fails or is incomplete
    element_fail_below: float = 60.0  # the pack's bound below which an element fails (§QE-2)
    counts: dict[str, int] = Field(default_factory=dict)  # errors by class over the block
    elements: list[ElementScore] = Field(default_factory=list)
    # errors of rules that decide no content of the pack's tree: the block's, in no item
    other_errors: list[ErrorRecord] = Field(default_factory=list)


class BlockGrade(_M):
    """One block's line of the batch decision."""

    block_id: str
    sampled: bool
    score: float | None = None
    grade: str | None = None
    fails: bool = False
    complete: bool = True
    reasons: list[str] = Field(default_factory=list)
    # its general inspection: the rules that failed (fail or error); any makes its verdict fail
    failed_rules: list[str] = Field(default_factory=list)
    a_errors: list[ErrorRecord] = Field(default_factory=list)  # the A-class errors, named
    low_elements: list[dict[str, Any]] = Field(default_factory=list)  # id, titles, score


class PlanNote(_M):
    """Where the sampling plan differs from the batch inspected without changing its sample: its
    `units` that no delivery is (none sampled), another `batch`, `rule_pack` or `standard`
    named, a lot's `sample_size` below the pack's table (`plan`: units sampled, `inspected`: the
    table's), a sample its `seed` does not draw (`plan`: the seed, `inspected`: what it draws,
    `blocks`: the plan's sampled blocks it does not draw)."""

    about: Literal["units", "batch", "rule_pack", "standard", "sample_size", "seed"]
    plan: str  # what the plan says (units: its number of units)
    inspected: str  # what was inspected (units: the number of deliveries)
    blocks: list[str] = Field(default_factory=list)  # units: those no delivery is; seed: not drawn


class BatchDecision(_M):
    """§QE-5: the sample judged, its mean score and grade, the batch grade and the acceptance."""

    standard: str = ""
    # the pack's grades, the fail grade last: their titles are what the pages show
    grades: list[Grade] = Field(default_factory=list)
    sample_source: str = ""  # "plan" (a sampling plan) or "checkpoints" (blocks that have them)
    sample: list[str] = Field(default_factory=list)
    failing: list[BlockGrade] = Field(default_factory=list)  # sampled blocks that fail
    incomplete: list[str] = Field(default_factory=list)  # sampled blocks not fully evaluated
    mean_score: float | None = None
    sample_grade: str | None = None
    better_pct: float | None = None  # share of sampled units graded good or better
    top_pct: float | None = None  # share graded excellent
    batch_grade: str | None = None
    decision: Literal["pass", "fail", "incomplete"] = "incomplete"
    returned: list[BlockGrade] = Field(default_factory=list)  # unsampled blocks that fail
    # deliveries that could not be read, by block id (by folder name when block.yaml could not
    # be): a sampled one leaves the decision incomplete; without a plan any one does
    unreadable: list[str] = Field(default_factory=list)
    plan_notes: list[PlanNote] = Field(default_factory=list)  # the plan against the batch
    blocks: list[BlockGrade] = Field(default_factory=list)


#: the keys naming the documents a report's acceptance rests on (§QE-6)
BASIS_KEYS = ("basis", "basis_zh")


def empty_basis(data: Any) -> list[str]:
    """The basis keys a mapping (a --meta file, a pack's `acceptance:`) gives as an empty list:
    a report states the documents its acceptance rests on (§QE-6), so an empty list says none a
    page can show; where the key is left out, the basis is taken from elsewhere, which an empty
    list would stand in for. Said as f"{key}: {EMPTY_BASIS} {how to leave it out}"."""
    if not isinstance(data, dict):
        return []
    return [k for k in BASIS_KEYS if isinstance(data.get(k), list) and not data[k]]


#: what an empty basis is told, before where the basis comes from with the key left out
EMPTY_BASIS = "give at least one document, or leave the key out"


class ReportMeta(_M):
    """The filed report's particulars (§QE-6) from `--meta FILE`; basis: the pack's by default."""

    report_number: str = ""
    project: str = ""
    project_zh: str = ""
    producer: str = ""
    producer_zh: str = ""
    inspection_unit: str = ""  # who inspects (the inspection centre)
    inspection_unit_zh: str = ""
    basis: list[str] = Field(default_factory=list)
    basis_zh: list[str] = Field(default_factory=list)
    handling: str = ""  # how the main problems were handled
    handling_zh: str = ""
    prepared: str = ""
    reviewed: str = ""
    approved: str = ""
    annexes: list[str] = Field(default_factory=list)
