"""The inspector's input, never inside a delivery: verdicts for manual items and waivers."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from blockqc.errors import InputError, Problem
from blockqc.yamlio import load_yaml, pydantic_problems


class Verdict(BaseModel):
    model_config = ConfigDict(extra="forbid")
    status: Literal["pass", "fail"]
    note: str = ""


class Waiver(BaseModel):
    """Waives a waivable rule: for the units listed, or for the whole rule when none are."""

    model_config = ConfigDict(extra="forbid")
    reason: str = Field(min_length=1)
    scenes: list[str] = Field(default_factory=list)
    pairs: list[tuple[str, str]] = Field(default_factory=list)
    points: list[str] = Field(default_factory=list)
    units: list[str] = Field(default_factory=list)  # other units by key, e.g. a document kind

    def labels(self) -> set[str]:
        """Unit labels this waiver covers: ids, and pairs in both orders ("A/B", "B/A")."""
        out = set(self.scenes) | set(self.points) | set(self.units)
        for a, b in self.pairs:
            out |= {f"{a}/{b}", f"{b}/{a}"}
        return out

    @property
    def whole_rule(self) -> bool:
        return not (self.scenes or self.pairs or self.points or self.units)


class BlockInput(BaseModel):
    model_config = ConfigDict(extra="forbid")
    verdicts: dict[str, Verdict] = Field(default_factory=dict)
    waivers: dict[str, Waiver] = Field(default_factory=dict)


class InspectorInput(BaseModel):
    """verdicts.yaml: the inspector, and verdicts/waivers for every block or per block id."""

    model_config = ConfigDict(extra="forbid")
    inspector: str | None = None
    date: str | None = None
    verdicts: dict[str, Verdict] = Field(default_factory=dict)
    waivers: dict[str, Waiver] = Field(default_factory=dict)
    blocks: dict[str, BlockInput] = Field(default_factory=dict)

    def for_block(self, block_id: str) -> BlockInput:
        own = self.blocks.get(block_id, BlockInput())
        return BlockInput(
            verdicts={**self.verdicts, **own.verdicts}, waivers={**self.waivers, **own.waivers}
        )


def load_inspector_input(path: Path) -> InspectorInput:
    data = load_yaml(path)
    if data is None:
        return InspectorInput()
    if not isinstance(data, dict):
        raise InputError(
            Problem(str(path), "expected a mapping (inspector, verdicts, waivers)", line=1)
        )
    try:
        return InspectorInput.model_validate(data)
    except ValidationError as exc:
        raise InputError(pydantic_problems(exc, path, data)) from None
