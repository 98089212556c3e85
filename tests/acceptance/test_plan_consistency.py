"""`inspect --plan` refuses a plan whose parts disagree, or that lacks a field, naming the plan
file, the line and the field; `blockqc sample --strata` refuses a key that is not text or a
number."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.acceptance.command import read_units
from blockqc.acceptance.plan import load_plan
from blockqc.errors import InputError
from casekit import run_blockqc, write_delivery

#: a plan as `blockqc sample --strata test_field` writes it: 4 blocks in 2 strata, 3 sampled
PLAN = """\
plan: sampling plan
standard: GB/T 24356-2023 Inspection and acceptance of surveying and mapping products
rule_pack: global-project 1.0
batch: batch
seed: 7
strata_key: test_field
method: stratified proportional random
units: 4
sample_size: 3
lots:
- size: 4
  sample_size: 3
  census: false
  strata:
  - value: '1'
    size: 2
    sample: 2
    units: [F1-B01, F1-B02]
    sampled: [F1-B01, F1-B02]
  - value: '2'
    size: 2
    sample: 1
    units: [F2-B01, F2-B02]
    sampled: [F2-B02]
  sampled: [F1-B01, F1-B02, F2-B02]
sampled: [F1-B01, F1-B02, F2-B02]
"""


def _refusal(tmp_path: Path, old: str, new: str) -> list[str]:
    path = tmp_path / "plan.yaml"
    assert old in PLAN
    path.write_text(PLAN.replace(old, new, 1), "utf-8")
    with pytest.raises(InputError) as exc:
        load_plan(path)
    return [str(p).removeprefix(f"{path}, ") for p in exc.value.problems]


def test_a_consistent_plan_is_read(tmp_path: Path) -> None:
    (tmp_path / "plan.yaml").write_text(PLAN, "utf-8")
    assert load_plan(tmp_path / "plan.yaml").sampled == ["F1-B01", "F1-B02", "F2-B02"]


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (  # the top-level sample is another than the lots': it would decide the acceptance
            "\nsampled: [F1-B01, F1-B02, F2-B02]\n",
            "\nsampled: [F2-B01]\n",
            "line 26: sampled: F2-B01 disagrees with the sampled blocks of its lots: "
            "F1-B01, F1-B02, F2-B02",
        ),
        (
            "units: 4\n",
            "units: 40\n",
            "line 8: units: 40, but its lots list 4 unit(s): F1-B01, F1-B02, F2-B01, F2-B02",
        ),
        (
            "  sample_size: 3\n",
            "  sample_size: 2\n",
            "line 12: lots.0.sample_size: 2, but the lot samples 3 unit(s): F1-B01, F1-B02, F2-B02",
        ),
        (
            "    sample: 2\n",
            "    sample: 1\n",
            "line 17: lots.0.strata.0.sample: 1, but the stratum samples 2 unit(s): F1-B01, F1-B02",
        ),
        (
            "strata_key: test_field\n",
            "strata_key: null\n",
            "line 7: method: stratified proportional random, but with no strata_key the method "
            "is simple random",
        ),
    ],
)
def test_parts_that_disagree_are_refused(tmp_path: Path, old, new, expected) -> None:
    assert _refusal(tmp_path, old, new) == [expected]


def test_a_missing_sampled_is_refused_not_taken_as_none(tmp_path: Path) -> None:
    problems = _refusal(tmp_path, "\nsampled: [F1-B01, F1-B02, F2-B02]\n", "\n")
    assert problems == ["line 1: sampled: Field required"]


def test_inspect_refuses_an_inconsistent_plan_and_writes_nothing(tmp_path: Path) -> None:
    for block in ("F1-B01", "F1-B02", "F2-B01", "F2-B02"):
        write_delivery(tmp_path / "batch" / block, {"manifest": {"block_id": block}})
    plan = tmp_path / "plan.yaml"
    plan.write_text(PLAN.replace("\nsampled: [F1-B01, F1-B02, F2-B02]\n", "\nsampled: [F2-B01]\n"))
    out = tmp_path / "out"
    r = run_blockqc("inspect", tmp_path / "batch", "--plan", plan, "--out", out, "--no-pdf")
    assert r.returncode == 2
    assert f"error: {plan}, line 26: sampled: F2-B01 disagrees with" in r.stderr
    assert "Traceback" not in r.stderr and not list(out.glob("**/*.json"))


def _batch(root: Path, values: list[object]) -> Path:
    for i, value in enumerate(values):
        write_delivery(root / f"B{i:02d}", {"manifest": {"block_id": f"B{i:02d}", "zone": value}})
    return root


def test_strata_by_text_or_number_or_a_key_of_a_mapping(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", ["north", 2, 3.5])
    assert read_units(batch, "zone")[1] == {"B00": "north", "B01": "2", "B02": "3.5"}
    batch = _batch(tmp_path / "nested", [{"class": "flat"}, {"class": "hilly"}])
    assert read_units(batch, "zone.class")[1] == {"B00": "flat", "B01": "hilly"}


@pytest.mark.parametrize(
    ("value", "why"),
    [
        ({"class": "flat"}, "a mapping (stratify by one of its keys, e.g. 'zone.class')"),
        (["a", "b"], "a list"),
        (True, "true/false"),
        (None, "empty"),
        ("", "blank text"),
        ("  ", "blank text"),
    ],
)
def test_a_stratum_that_is_not_text_or_a_number_is_refused(tmp_path: Path, value, why) -> None:
    batch = _batch(tmp_path / "batch", ["north", value])
    with pytest.raises(InputError) as exc:
        read_units(batch, "zone")
    manifest = batch / "B01" / "block.yaml"
    line = _key_line(manifest, "zone:")
    assert [str(p) for p in exc.value.problems] == [
        f"{manifest}, line {line}: key 'zone' is {why}: a stratum is text or a number"
    ]


def _key_line(path: Path, start: str) -> int:
    lines = path.read_text(encoding="utf-8").splitlines()
    return next(i for i, x in enumerate(lines, 1) if x.startswith(start))


def test_a_missing_strata_key_is_named_as_a_key_of_block_yaml(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", [{"class": "flat"}])
    manifest = batch / "B00" / "block.yaml"
    line = f", line {_key_line(manifest, 'zone:')}"
    for key, where, hint in (
        ("producer", "", ""),
        ("zone.klass", line, "; did you mean 'zone.class'?"),
        ("Zone.class", "", "; did you mean 'zone.class'?"),
        ("zome", "", "; did you mean 'zone'?"),
        ("zone.size", line, ""),
    ):
        with pytest.raises(InputError) as exc:
            read_units(batch, key)
        assert [str(p) for p in exc.value.problems] == [
            f"{manifest}{where}: no key '{key}' in block.yaml to stratify by{hint}"
        ]


def _refused(tmp_path: Path, edits: list[tuple[str, str]]) -> list[str]:
    """The problems of PLAN with every edit made (each `old` once)."""
    text = PLAN
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "plan.yaml"
    path.write_text(text, "utf-8")
    with pytest.raises(InputError) as exc:
        load_plan(path)
    return [str(p).removeprefix(f"{path}, ") for p in exc.value.problems]


def test_a_block_sampled_twice_is_refused_where_it_is_listed_again(tmp_path: Path) -> None:
    """Every count made to agree: F2-B02 would be counted twice in a sample of 4 blocks."""
    edits = [
        ("    sample: 1\n", "    sample: 2\n"),
        ("sampled: [F2-B02]", "sampled: [F2-B02, F2-B02]"),
        ("  sample_size: 3\n  census: false", "  sample_size: 4\n  census: true"),
        ("sample_size: 3\n", "sample_size: 4\n"),
        ("  sampled: [F1-B01, F1-B02, F2-B02]", "  sampled: [F1-B01, F1-B02, F2-B02, F2-B02]"),
        ("\nsampled: [F1-B01, F1-B02, F2-B02]", "\nsampled: [F1-B01, F1-B02, F2-B02, F2-B02]"),
    ]
    assert _refused(tmp_path, edits) == [
        "line 24: lots.0.strata.1.sampled.1: F2-B02 is listed more than once",
        "line 25: lots.0.sampled.3: F2-B02 is listed more than once",
        "line 26: sampled.3: F2-B02 is listed more than once",
    ]


def test_a_unit_listed_twice_in_its_stratum_is_refused(tmp_path: Path) -> None:
    edits = [
        ("units: [F2-B01, F2-B02]", "units: [F2-B01, F2-B02, F2-B02]"),
        ("    size: 2\n    sample: 1\n", "    size: 3\n    sample: 1\n"),
        ("- size: 4\n", "- size: 5\n"),
        ("units: 4\n", "units: 5\n"),
    ]
    assert _refused(tmp_path, edits) == [
        "line 23: lots.0.strata.1.units.2: F2-B02 is listed more than once"
    ]


def test_strata_without_a_strata_key_are_refused(tmp_path: Path) -> None:
    edits = [
        ("strata_key: test_field", "strata_key: null"),
        ("method: stratified proportional random", "method: simple random"),
    ]
    assert _refused(tmp_path, edits) == [
        "line 14: lots.0.strata: without strata_key a lot is one stratum, of value ''"
    ]


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        ("seed: 7", "seed: -5", "line 5: seed: expected a whole number ≥ 0, got a number (-5)"),
        ("seed: 7", "seed: true", "line 5: seed: expected a whole number, got true/false (true)"),
        ("seed: 7", 'seed: "7"', "line 5: seed: expected a whole number, got text '7'"),
        ("units: 4", 'units: "4"', "line 8: units: expected a whole number, got text '4'"),
        ("units: 4", "units: 4.0", "line 8: units: expected a whole number, got a number (4.0)"),
        (
            "census: false",
            'census: "no"',
            "line 13: lots.0.census: expected true or false, got text 'no'",
        ),
        (
            "census: false",
            "census: 0",
            "line 13: lots.0.census: expected true or false, got a number (0)",
        ),
        (
            "strata_key: test_field",
            'strata_key: ""',
            "line 6: strata_key: expected a block.yaml key (not empty), got text ''",
        ),
        (
            "value: '1'",
            "value: 1",
            "line 15: lots.0.strata.0.value: expected text, got a number (1)",
        ),
    ],
)
def test_types_blockqc_sample_would_not_write_are_refused(tmp_path: Path, old, new, expected):
    """Each read as `blockqc sample` writes it: never converted (true is not seed 1)."""
    assert _refusal(tmp_path, old, new) == [expected]


def test_a_misspelt_key_is_refused_with_the_key_it_resembles(tmp_path: Path) -> None:
    """A key of the plan misspelt was refused as unknown, without the key it stands for."""
    assert _refusal(tmp_path, "census: false", "censuss: false") == [
        "line 11: lots.0.census: Field required",
        "line 13: lots.0.censuss: unknown key; did you mean 'census'?",
    ]
    assert _refusal(tmp_path, "census: false", "census: false\n  colour: red") == [
        "line 14: lots.0.colour: unknown key"  # like no key of a lot: no hint
    ]


def test_two_strata_of_one_value_in_a_lot_are_refused(tmp_path: Path) -> None:
    """Stratum '1' split in two by hand, every count kept: `blockqc sample` draws one stratum
    per value, so the plan was accepted as a stratification no seed draws."""
    edits = [
        (
            "  - value: '1'\n    size: 2\n    sample: 2\n    units: [F1-B01, F1-B02]\n"
            "    sampled: [F1-B01, F1-B02]\n",
            "  - value: '1'\n    size: 1\n    sample: 1\n    units: [F1-B01]\n"
            "    sampled: [F1-B01]\n"
            "  - value: '1'\n    size: 1\n    sample: 1\n    units: [F1-B02]\n"
            "    sampled: [F1-B02]\n",
        ),
    ]
    assert _refused(tmp_path, edits) == [
        "line 20: lots.0.strata.1.value: '1' is the value of an earlier stratum of the lot: "
        "one value, one stratum"
    ]


def test_a_lot_or_a_stratum_without_units_is_refused(tmp_path: Path) -> None:
    """Counts of 0 agree with empty lists: a lot or stratum of no units was read unsaid."""
    lot = "- size: 0\n  sample_size: 0\n  census: true\n  strata: []\n  sampled: []\n"
    assert _refused(tmp_path, [("\nsampled: [F1", f"\n{lot}sampled: [F1")]) == [
        "line 29: lots.1.strata: a lot is at least one stratum of units; it lists none"
    ]
    stratum = "  - value: '3'\n    size: 0\n    sample: 0\n    units: []\n    sampled: []\n"
    at = "  sampled: [F1-B01, F1-B02, F2"
    assert _refused(tmp_path, [(at, f"{stratum}{at}")]) == [
        "line 28: lots.0.strata.2.units: a stratum lists its units, at least one"
    ]


@pytest.mark.parametrize(
    ("text", "read"),
    [("010", 8), ("0x10", 16), ("1_000", 1000), ("1:30", 90), ("1_0.5", 10.5)],
)
def test_a_stratum_yaml_reads_as_another_number_than_written_is_refused(
    tmp_path: Path, text: str, read: float
) -> None:
    """YAML 1.1 reads `zone: 010` as the octal number 8 (0x10 as 16, 1_000 as 1000, 1:30 as
    90): the plan said stratum 8 of a block whose block.yaml says 010, unsaid."""
    batch = _batch(tmp_path / "batch", ["north", 7])
    manifest = batch / "B01" / "block.yaml"
    lines = manifest.read_text(encoding="utf-8").replace("zone: 7", f"zone: {text}")
    manifest.write_text(lines, encoding="utf-8")
    with pytest.raises(InputError) as exc:
        read_units(batch, "zone")
    assert [str(p) for p in exc.value.problems] == [
        f"{manifest}, line {_key_line(manifest, 'zone:')}: key 'zone' is written {text}, which "
        f"YAML reads as the number {read}: write the number in decimal digits, or in quotes "
        f"('{text}') to keep it as text"
    ]


def test_numbers_written_in_decimal_digits_or_quoted_are_strata_as_written(tmp_path) -> None:
    batch = _batch(tmp_path / "batch", [10, 0.8, -3, "007"])
    assert read_units(batch, "zone")[1] == {"B00": "10", "B01": "0.8", "B02": "-3", "B03": "007"}
