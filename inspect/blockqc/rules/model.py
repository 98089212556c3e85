"""The rule language: what a pack file may say, validated by pydantic (unknown keys refused)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator, model_validator

from blockqc.acceptance.model import Acceptance, ErrorClass, ScoreDef
from blockqc.errors import Problem
from blockqc.yamlio import Text, worded_pattern


def _not_bool(v: Any) -> Any:
    """A bound is a number or an expression: true/false (YAML also reads yes/no so) is refused,
    as it is for a constant, rather than read as 1 or 0."""
    if isinstance(v, bool):
        raise ValueError(
            f"expected a number or an expression, got {str(v).lower()} "
            "(YAML reads yes/no as true/false)"
        )
    return v


#: a number, or an arithmetic expression over the pack's constants, e.g. "2*sqrt(2)*norm.plane_m"
Expr = Annotated[float | int | str, BeforeValidator(_not_bool)]


#: what a rule may ask the report to draw from its results (§2 report figures)
FigureHint = Literal[
    "residual_histogram",  # the rule's threshold marked on the tie-point residual histogram
    "scene_counts",  # the rule's threshold as the minimum on the per-scene counts chart
    "scene_points",  # the tie-point layout of every scene the rule fails
]


class Titled(BaseModel):
    """Something the report names in both languages."""

    model_config = ConfigDict(extra="forbid")
    id: str = Field(
        pattern=worded_pattern(
            r"^[A-Za-z][A-Za-z0-9_]*$", "an id of letters, digits and _, starting with a letter"
        )
    )
    title: Text
    title_zh: str = ""


class ContentDef(Titled):
    """An inspection content (DOMAIN §2), decided by the rules that name it."""


class ItemDef(Titled):
    """A quality item: its contents and how they are checked."""

    method: str = ""
    method_zh: str = ""
    contents: list[ContentDef] = Field(default_factory=list)


class ElementDef(Titled):
    """A quality element (data, layout, attachment quality) and its items."""

    items: list[ItemDef] = Field(default_factory=list)


def merge_elements(base: list[ElementDef], extra: list[ElementDef]) -> list[ElementDef]:
    """A project's elements merged into its parent's by id: the titles (and an item's method)
    of elements, items and contents it gives again replaced, new parts appended."""
    out = [e.model_copy(deep=True) for e in base]
    for e in extra:
        mine = next((x for x in out if x.id == e.id), None)
        if mine is None:
            out.append(e.model_copy(deep=True))
            continue
        mine.title, mine.title_zh = e.title, e.title_zh or mine.title_zh
        for item in e.items:
            old = next((x for x in mine.items if x.id == item.id), None)
            if old is None:
                mine.items.append(item.model_copy(deep=True))
                continue
            old.title, old.title_zh = item.title, item.title_zh or old.title_zh
            old.method, old.method_zh = item.method or old.method, item.method_zh or old.method_zh
            for c in item.contents:
                known = next((x for x in old.contents if x.id == c.id), None)
                if known is None:
                    old.contents.append(c.model_copy(deep=True))
                else:  # retitled, as elements and items are
                    known.title, known.title_zh = c.title, c.title_zh or known.title_zh
    return out


#: a value within this share of a bound's magnitude is on the bound: the binary rounding of
#: decimal inputs (an RMS of exactly 1.2 m computed as 1.2000000000000002) neither fails an
#: inclusive bound nor passes an exclusive one
ON_BOUND = 1e-9


def within(v: Any, lo: Any, hi: Any, inclusive: bool) -> Any:
    """Whether v (a number, or element by element an array) lies within the bounds lo and hi
    (None: no bound), a value within ON_BOUND of a bound's magnitude being on it; with
    `inclusive`, a value on a bound passes."""
    ok = True
    if hi is not None:
        on = ON_BOUND * abs(hi)
        ok = ok & ((v <= hi + on) if inclusive else (v < hi - on))
    if lo is not None:
        on = ON_BOUND * abs(lo)
        ok = ok & ((v >= lo - on) if inclusive else (v > lo + on))
    return ok


class Threshold(BaseModel):
    """What passes: a lower and/or upper bound (inclusive or not, a value within ON_BOUND of a
    bound's magnitude on it), or allowed values."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    min: Expr | None = None
    max: Expr | None = None
    inclusive: bool = True
    equals: bool | str | float | None = None
    in_: list[str | float] | None = Field(default=None, alias="in")

    @field_validator("in_", mode="before")
    @classmethod
    def _listed(cls, value: Any) -> Any:
        """Values of `in:` are numbers or texts: YAML's yes/no is no value (it was read as
        0.0), a NaN matches nothing."""
        for v in value if isinstance(value, list) else []:
            if isinstance(v, bool):
                raise ValueError(
                    f"{str(v).lower()} (YAML reads yes/no so): for true/false write equals: "
                    "true or equals: false; a text, in quotes"
                )
            if isinstance(v, float) and not math.isfinite(v):
                raise ValueError(f"{v} matches nothing: expected finite numbers or texts")
        return value

    @model_validator(mode="after")
    def _one_kind(self) -> Threshold:
        bounds = self.min is not None or self.max is not None
        kinds = sum([bounds, self.equals is not None, self.in_ is not None])
        if kinds != 1:
            raise ValueError("give exactly one of: min and/or max; equals; in")
        if "inclusive" in self.model_fields_set and not bounds:
            raise ValueError("inclusive applies to min and max only (equals and in match exactly)")
        return self

    def describe(self, lo: float | str | None = None, hi: float | str | None = None) -> str:
        """Human form, e.g. '≤ 0.5', '< 28.28', '20 … 50', '= true'; bounds as numbers or text."""
        if self.equals is not None:
            return f"= {str(self.equals).lower() if isinstance(self.equals, bool) else self.equals}"
        if self.in_ is not None:
            return "one of " + ", ".join(map(str, self.in_))
        le, ge = ("≤", "≥") if self.inclusive else ("<", ">")

        def num(v: float | str) -> str:
            return f"{v:g}" if isinstance(v, (int, float)) else str(v)

        if lo is not None and hi is not None:
            return f"{num(lo)} {'…' if self.inclusive else '<…<'} {num(hi)}"
        if hi is not None:
            return f"{le} {num(hi)}"
        return f"{ge} {num(lo)}"


Scalar = str | float | bool


def selected(value: Scalar | list[Scalar]) -> list[str]:
    """The group values a content selector takes (one value or a list), as text."""
    return [str(v) for v in (value if isinstance(value, list) else [value])]


class Rule(BaseModel):
    """One rule: a registered metric measured at a scope, a statistic, a threshold, a severity."""

    model_config = ConfigDict(extra="forbid")
    id: str = Field(
        pattern=worded_pattern(
            r"^[A-Z][A-Z0-9]*(-[A-Za-z0-9]+)+$",
            "a rule id such as PR-1 or TP-10: capital letters and digits starting with a "
            "capital, then one or more parts of letters and digits each after a '-'",
        )
    )
    title: str = Field(min_length=1)
    clause: str = Field(min_length=1)
    title_zh: str = ""
    description: str = ""
    description_zh: str = ""
    # the inspection content(s) the rule decides (ids of the pack's `elements:` tree): one id, a
    # list, or {content id: {group column: value or [values]}} where results of a group decide
    # one content
    content: dict[str, dict[str, Scalar | list[Scalar]]] = Field(default_factory=dict)
    quality_element: str = ""  # an element id, for a rule that decides no content of the tree
    inspection: Literal["general", "detailed"] = "general"  # DOMAIN §2: every block / sampled
    figures: list[FigureHint] = Field(default_factory=list)
    metric: str | None = None
    params: dict[str, Any] = Field(default_factory=dict)
    # a scope the metric declares (blockqc.metrics registry), checked when the pack is loaded
    scope: str = Field(
        default="block",
        pattern=worded_pattern(
            r"^[a-z][a-z0-9_]*$", "a scope name of lower-case letters, digits and _ (scene …)"
        ),
    )
    where: dict[str, str | float | bool] = Field(default_factory=dict)
    statistic: str | None = None
    threshold: Threshold | None = None
    # one threshold per group value instead, e.g. {plane: {max: ...}, height: {max: ...}}
    thresholds: dict[str, Threshold] | None = None
    unit: str = ""
    severity: Literal["fail", "warn"] = "fail"
    waivable: bool = False
    manual: bool = False
    evidence_from: str | None = None  # another scope of the metric listing the offending units
    evidence_where: dict[str, str | float | bool] = Field(default_factory=dict)
    evidence_limit: int = Field(default=50, ge=0)
    error_class: ErrorClass | None = None  # §QE-2 class of its failure (default: the pack's)
    score: ScoreDef | None = None  # §QE-3 mathematical accuracy, or deduction (the default)

    @field_validator("content", mode="before")
    @classmethod
    def _content(cls, v: Any) -> Any:
        if isinstance(v, str):
            return {v: {}} if v else {}
        if isinstance(v, list):
            return {c: {} for c in v}
        return v

    @field_validator("clause")
    @classmethod
    def _clause(cls, v: str) -> str:
        if not v.startswith("§"):
            raise ValueError("a clause cites DOMAIN.md, e.g. '§CP-5'")
        return v

    @model_validator(mode="after")
    def _complete(self) -> Rule:
        if self.manual:
            if self.metric or self.threshold or self.thresholds:
                raise ValueError("a manual rule takes the inspector's verdict: no metric/threshold")
            return self
        missing = [k for k in ("metric", "statistic") if getattr(self, k) is None]
        if self.threshold is None and not self.thresholds:
            missing.append("threshold")
        if missing:
            raise ValueError(f"an automatic rule needs {', '.join(missing)} (or manual: true)")
        if self.threshold is not None and self.thresholds:
            raise ValueError("give either threshold or thresholds (one per group), not both")
        return self

    def all_thresholds(self) -> dict[str, Threshold]:
        """Every threshold of the rule by group value ('' for a single threshold)."""
        if self.thresholds:
            return dict(self.thresholds)
        return {"": self.threshold} if self.threshold is not None else {}


class PackFile(BaseModel):
    """The top level of a rule pack file."""

    model_config = ConfigDict(extra="forbid")
    pack: str = Field(
        min_length=1,
        pattern=worded_pattern(
            r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
            "a pack name of letters, digits, _, . and -, starting with a letter or digit",
        ),
    )
    version: str = "1"
    title: str = ""
    description: str = ""
    extends: str | None = None
    elements: list[ElementDef] = Field(default_factory=list)
    acceptance: dict[str, Any] | None = None  # §QE mechanics, merged down the extends chain
    constants: dict[str, Any] = Field(default_factory=dict)
    rules: list[dict[str, Any]] = Field(default_factory=list)
    overrides: dict[str, dict[str, Any]] = Field(default_factory=dict)
    disable: list[str] = Field(default_factory=list)
    # which columns of the tie points are read: all (every column checked), or used (those the
    # pack's rules read; the others, and the checks over them, are named as not made)
    columns: Literal["all", "used"] | None = None

    @field_validator("version", mode="before")
    @classmethod
    def _version_text(cls, v: Any) -> Any:
        """A version is a text: YAML reads `1.10` as the number 1.1, so a number is refused
        with the quoted form to write."""
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            raise ValueError(
                f'a version is a text: write it in quotes (version: "{v}"), since YAML reads '
                "an unquoted version as a number (1.10 as 1.1)"
            )
        return v


@dataclass
class Pack:
    """A resolved rule pack: its own name and version, the chain it extends, constants, rules."""

    name: str
    version: str
    title: str
    description: str
    constants: dict[str, Any]
    rules: list[Rule]
    elements: list[ElementDef] = field(default_factory=list)
    chain: list[str] = field(default_factory=list)  # files, the pack's own first
    disabled: list[str] = field(default_factory=list)
    origin: dict[str, tuple[str, int | None]] = field(default_factory=dict)  # id -> (file, line)
    # id -> [(file, line, fields written)]: the definition first, then each override
    history: dict[str, list[tuple[str, int | None, dict[str, Any]]]] = field(default_factory=dict)
    acceptance: Acceptance | None = None  # §QE: sampling, classes, scores, grades
    columns: Literal["all", "used"] = "all"  # the tie points' columns read (PackFile.columns)
    # what lint could not check without a delivery and does not refuse the pack for: warnings
    notes: list[Problem] = field(default_factory=list)
    # (what, id) -> (file, line) of the file that last writes each element, item and content
    title_sites: dict[tuple[str, str], tuple[str, int | None]] = field(default_factory=dict)

    def rule(self, rule_id: str) -> Rule:
        """The rule of that id, compared case-insensitively (`tp-1` is TP-1)."""
        for r in self.rules:
            if r.id.upper() == rule_id.upper():
                return r
        raise KeyError(rule_id)

    def content_ids(self) -> dict[str, str]:
        """Every content id of the pack's tree with the id of its element."""
        return {c.id: e.id for e in self.elements for i in e.items for c in i.contents}
