"""Sampling a batch (§QE-1): sample size from the pack's table, simple or stratified random.

Pure functions of the units' ids (and their strata); the randomness is a numpy Generator made
from the seed, so one seed gives one sample. Units are sorted by id in natural order (B2 before
B10) before anything is drawn, so the order in which a batch folder lists them does not matter.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from blockqc.acceptance.model import Sampling


@dataclass
class Stratum:
    """One stratum of a (sub-)batch: its units and those drawn from it."""

    value: str
    units: list[str]
    sampled: list[str] = field(default_factory=list)


@dataclass
class Lot:
    """One batch as sampled (a batch above the table's largest size is split into lots)."""

    units: list[str]
    sample_size: int
    census: bool
    strata: list[Stratum]

    @property
    def sampled(self) -> list[str]:
        return sorted((u for s in self.strata for u in s.sampled), key=natural_key)


NUMBER = re.compile(r"[+-]?[0-9]+(?:\.[0-9]+)?")
DIGITS = re.compile(r"([0-9]+)")


def natural_key(text: str) -> tuple:
    """The order a person reads values in: numbers by value (9 before 10, 0.8 before 2.1),
    text with runs of digits compared as numbers (F9 before F10); numbers before text, and
    values that read alike (F01, F1) by their text."""
    if NUMBER.fullmatch(text):
        return (0, (float(text),), text)
    parts = DIGITS.split(text)  # text, digits, text, …: the digits at odd places
    return (1, tuple(int(p) if i % 2 else p for i, p in enumerate(parts)), text)


def sample_size(n: int, sampling: Sampling) -> int:
    """§QE-1: the table's sample size for a batch of n units; every unit when it reaches n."""
    if n < 1 or n > sampling.max_batch:
        raise ValueError(f"a batch of {n} units is outside the table (1–{sampling.max_batch})")
    row = next(r for r in sampling.table if n <= r.batch)
    return min(row.sample, n)


def split_sizes(n: int, max_batch: int) -> list[int]:
    """The fewest even batches of at most max_batch units: k = ⌈n/max⌉, sizes differ by ≤ 1."""
    k = max(1, math.ceil(n / max_batch))
    small, extra = divmod(n, k)
    return [small + 1] * extra + [small] * (k - extra)


def allocate(sizes: dict[str, int], n: int) -> dict[str, int]:
    """Proportional allocation n·N_h/N, rounded by largest remainder (Hamilton).

    Each stratum gets ⌊n·N_h/N⌋; the seats left go to the largest remainders, ties to the larger
    stratum, then to the stratum listed first.
    """
    total = sum(sizes.values())
    keys = list(sizes)
    quota = np.array([n * sizes[k] / total for k in keys])
    base = np.floor(quota + 1e-12).astype(int)
    left = n - int(base.sum())
    rem = quota - base
    order = sorted(range(len(keys)), key=lambda i: (-round(rem[i], 12), -sizes[keys[i]], i))
    for i in order[:left]:
        base[i] += 1
    return {k: int(b) for k, b in zip(keys, base, strict=True)}


def draw_lot(
    units: list[str], strata: dict[str, str] | None, sampling: Sampling, rng: np.random.Generator
) -> Lot:
    """One lot: its sample size, allocated over the strata, drawn without replacement."""
    units = sorted(units, key=natural_key)
    n = sample_size(len(units), sampling)
    groups: dict[str, list[str]] = {}
    for u in units:
        groups.setdefault(strata[u] if strata else "", []).append(u)
    groups = dict(sorted(groups.items(), key=lambda kv: natural_key(kv[0])))
    quotas = allocate({k: len(v) for k, v in groups.items()}, n)
    out = []
    for value, members in groups.items():
        picked = rng.choice(len(members), size=quotas[value], replace=False)
        out.append(Stratum(value, members, sorted((members[i] for i in picked), key=natural_key)))
    return Lot(units, n, n == len(units), out)


def draw(
    units: list[str], sampling: Sampling, seed: int, strata: dict[str, str] | None = None
) -> list[Lot]:
    """§QE-1 over a whole batch: split above the table's largest batch, then sample each lot.

    The lots are consecutive runs of the units sorted by id in natural order (B2 before B10).
    """
    if len(set(units)) != len(units):
        raise ValueError("unit ids must be unique")
    ordered = sorted(units, key=natural_key)
    rng = np.random.default_rng(seed)
    lots, start = [], 0
    for size in split_sizes(len(ordered), sampling.max_batch):
        lots.append(draw_lot(ordered[start : start + size], strata, sampling, rng))
        start += size
    return lots
