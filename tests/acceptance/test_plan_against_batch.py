"""`inspect --plan` checks the plan against the batch it is applied to: a unit placed in a
stratum its block.yaml does not give is refused, naming the plan's line; units no delivery is
(none sampled), another batch's name or another rule pack are said as warnings and noted in the
acceptance report, which otherwise would print the plan's numbers as if they were the batch's."""

from __future__ import annotations

import json
import re
from html import unescape
from pathlib import Path

import pytest

from blockqc.acceptance.plan import load_plan
from blockqc.acceptance.plan_check import check_strata, plan_notes
from blockqc.errors import InputError
from casekit import run_blockqc, write_delivery

#: a plan by block.yaml's `terrain`: B00, B02 flat, B01, B03 hilly; B00 and B01 sampled
PLAN = """\
plan: sampling plan
standard: GB/T 24356-2023 Inspection and acceptance of surveying and mapping products
rule_pack: global-project 1.0
batch: batch
seed: 3
strata_key: terrain
method: stratified proportional random
units: 4
sample_size: 2
lots:
- size: 4
  sample_size: 2
  census: false
  strata:
  - value: flat
    size: 2
    sample: 1
    units: [B00, B02]
    sampled: [B00]
  - value: hilly
    size: 2
    sample: 1
    units: [B01, B03]
    sampled: [B01]
  sampled: [B00, B01]
sampled: [B00, B01]
"""

BLOCKS = {f"B{i:02d}": {"terrain": "flat" if i % 2 == 0 else "hilly"} for i in range(4)}


def _plan(tmp_path: Path, *edits: tuple[str, str]):
    text = PLAN
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "plan.yaml"
    path.write_text(text, "utf-8")
    return load_plan(path), path


def _strata_problems(tmp_path: Path, blocks: dict, *edits: tuple[str, str]) -> list[str]:
    plan, path = _plan(tmp_path, *edits)
    with pytest.raises(InputError) as exc:
        check_strata(plan, path, blocks)
    return [str(p).removeprefix(f"{path}, ") for p in exc.value.problems]


def test_units_in_the_strata_their_block_yaml_gives_are_accepted(tmp_path: Path) -> None:
    plan, path = _plan(tmp_path)
    check_strata(plan, path, BLOCKS)
    check_strata(plan, path, {"B00": BLOCKS["B00"]})  # blocks not in the batch are not checked


def test_a_unit_in_another_stratum_is_refused_at_its_line(tmp_path: Path) -> None:
    """B02 (flat) and B03 (hilly) swapped: each is named where the plan lists it."""
    edits = ("units: [B00, B02]", "units: [B00, B03]"), ("units: [B01, B03]", "units: [B01, B02]")
    assert _strata_problems(tmp_path, BLOCKS, *edits) == [
        "line 18: lots.0.strata.0.units.1: block B03 is in the stratum terrain = 'flat', but its "
        "block.yaml gives terrain: 'hilly'",
        "line 23: lots.0.strata.1.units.1: block B02 is in the stratum terrain = 'hilly', but its "
        "block.yaml gives terrain: 'flat'",
    ]


def test_a_strata_key_no_block_agrees_with_is_named_once(tmp_path: Path) -> None:
    """The strata are terrain's, the key another: no unit is in its stratum by that key."""
    blocks = {b: {**d, "sensor": "GF-7"} for b, d in BLOCKS.items()}
    assert _strata_problems(tmp_path, blocks, ("strata_key: terrain", "strata_key: sensor")) == [
        "line 6: strata_key: sensor, but no block inspected lies in the stratum its block.yaml "
        "gives by this key (e.g. B00, in stratum 'flat': its block.yaml gives sensor: 'GF-7'): "
        "the plan was not drawn by this key"
    ]
    assert _strata_problems(tmp_path, BLOCKS, ("strata_key: terrain", "strata_key: zone"))[0] == (
        "line 6: strata_key: zone, but no block inspected lies in the stratum its block.yaml "
        "gives by this key (e.g. B00, in stratum 'flat': its block.yaml has no key 'zone'): "
        "the plan was not drawn by this key"
    )


def test_units_no_delivery_is_another_batch_and_pack_are_noted(tmp_path: Path) -> None:
    plan, path = _plan(tmp_path)
    notes, warnings = plan_notes(plan, path, ["B00", "B01", "B02"], "batch-2", "asprs-2023 1.0")
    assert [n.model_dump() for n in notes] == [
        {"about": "units", "plan": "4", "inspected": "3", "blocks": ["B03"]},
        {"about": "batch", "plan": "batch", "inspected": "batch-2", "blocks": []},
        {"about": "rule_pack", "plan": "global-project 1.0", "inspected": "asprs-2023 1.0",
         "blocks": []},
    ]  # fmt: skip
    assert [str(w).removeprefix(f"{path}, ") for w in warnings] == [
        "line 23: lots.0.strata.1.units.1: no delivery of the batch is block B03, a unit of the "
        "plan (a delivery withdrawn after sampling?); it is not sampled: the sample stands",
        "line 4: batch: the plan was drawn from batch 'batch'; the batch inspected is 'batch-2'",
        "line 3: rule_pack: the plan was drawn with global-project 1.0; the batch is inspected "
        "with asprs-2023 1.0",
    ]
    assert plan_notes(plan, path, list(BLOCKS), "batch", "global-project 1.0") == ([], [])
    assert plan_notes(plan, path, list(BLOCKS), None, "global-project 1.0") == ([], [])


def test_a_lot_sampled_below_the_packs_table_is_noted_and_warned(tmp_path: Path) -> None:
    """§QE-1 (stock table): a lot of 4 units is sampled with 3; the plan draws 2 (edited by
    hand, or drawn with another table). The sample stands, and this is said at its line."""
    from blockqc.rules import load_pack

    sampling = load_pack("global-project").acceptance.sampling
    plan, path = _plan(tmp_path)
    notes, warnings = plan_notes(plan, path, list(BLOCKS), "batch", "global-project 1.0", sampling)
    assert [n.model_dump() for n in notes] == [
        {"about": "sample_size", "plan": "2", "inspected": "3", "blocks": []}
    ]
    assert [str(w).removeprefix(f"{path}, ") for w in warnings] == [
        "line 25: lots[0]: 2 of the lot's 4 units sampled; the pack's table (§QE-1) asks 3: "
        "the batch is judged on the smaller sample"
    ]
    three, path = _plan(
        tmp_path,
        ("sample_size: 2\nlots", "sample_size: 3\nlots"),
        ("  sample_size: 2\n", "  sample_size: 3\n"),
        ("    sample: 1\n    units: [B00, B02]\n    sampled: [B00]",
         "    sample: 2\n    units: [B00, B02]\n    sampled: [B00, B02]"),
        ("  sampled: [B00, B01]\nsampled: [B00, B01]",
         "  sampled: [B00, B01, B02]\nsampled: [B00, B01, B02]"),
    )  # fmt: skip
    assert plan_notes(three, path, list(BLOCKS), "batch", "global-project 1.0", sampling) == (
        [],
        [],
    )


def test_inspect_states_a_unit_withdrawn_in_its_warnings_and_reports(tmp_path: Path) -> None:
    """B03 was withdrawn after sampling: 2 of the plan's 4 units drawn, 3 inspected, said why."""
    for b in ("B00", "B01", "B02"):
        write_delivery(tmp_path / "batch" / b, {"manifest": {"block_id": b, **BLOCKS[b]}})
    (tmp_path / "plan.yaml").write_text(PLAN, "utf-8")
    out = tmp_path / "out"
    r = run_blockqc(
        "inspect", tmp_path / "batch", "--plan", tmp_path / "plan.yaml", "--out", out, "--no-pdf"
    )
    assert r.returncode == 0, r.stderr
    assert (
        f"warning: {tmp_path / 'plan.yaml'}, line 23: lots.0.strata.1.units.1: no delivery of "
        "the batch is block B03"
    ) in r.stderr
    notes = json.loads((out / "summary.json").read_text())["acceptance"]["plan_notes"]
    assert notes == [
        {"about": "units", "plan": "4", "inspected": "3", "blocks": ["B03"]},
        # 2 of 4 drawn where the stock table asks 3 (batches of 1–20: 3, or every unit)
        {"about": "sample_size", "plan": "2", "inspected": "3", "blocks": []},
    ]
    page = (out / "acceptance.html").read_text()
    text = re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", page.split("</style>")[1])))
    assert (
        "2 of 4 blocks drawn by stratified proportional random sampling (seed 3). Strata by "
        "block.yaml key 'terrain'. Units of the plan not among the 3 deliveries inspected (1 of "
        "its 4; withdrawn after sampling?), none of them sampled, so the sample stands: B03."
    ) in text


def test_a_lot_above_the_packs_largest_batch_is_noted_when_sampled_below_it(
    tmp_path: Path,
) -> None:
    """A pack whose table stops at batches of 2 splits a lot of 4 into two lots of 2, and asks
    2 of each: the plan's 2 of 4 (drawn with another table) were judged with nothing said."""
    from blockqc.acceptance.model import Sampling

    sampling = Sampling.model_validate({"table": [{"batch": 2, "sample": 2}]})
    plan, path = _plan(tmp_path)
    notes, warnings = plan_notes(plan, path, list(BLOCKS), "batch", "global-project 1.0", sampling)
    assert [n.model_dump() for n in notes] == [
        {"about": "sample_size", "plan": "2", "inspected": "4", "blocks": []}
    ]
    assert [str(w).removeprefix(f"{path}, ") for w in warnings] == [
        "line 25: lots[0]: 2 of the lot's 4 units sampled; the pack's table (§QE-1) asks 4 (the "
        "lot is above its largest batch, 2: it splits it into 2 lots of 2, 2): the batch is "
        "judged on the smaller sample"
    ]


def test_a_plan_drawn_under_another_standard_is_noted_and_warned(tmp_path: Path) -> None:
    """The plan names the standard it was drawn under (line 2): another than the pack's
    `acceptance.standard` is said, as another rule pack is; the same one says nothing."""
    stock = "GB/T 24356-2023 Inspection and acceptance of surveying and mapping products"
    old = "GB/T 24356-2009 Inspection and acceptance of surveying and mapping products"
    plan, path = _plan(tmp_path, (f"standard: {stock}", f"standard: {old}"))
    notes, warnings = plan_notes(
        plan, path, list(BLOCKS), "batch", "global-project 1.0", standard=stock
    )
    assert [n.model_dump() for n in notes] == [
        {"about": "standard", "plan": old, "inspected": stock, "blocks": []}
    ]
    assert [str(w).removeprefix(f"{path}, ") for w in warnings] == [
        f"line 2: standard: the plan was drawn under {old}; the batch is judged under {stock}"
    ]
    same, path = _plan(tmp_path)
    assert plan_notes(same, path, list(BLOCKS), "batch", "global-project 1.0", standard=stock) == (
        [],
        [],
    )


def test_inspect_states_a_plan_drawn_under_another_standard(tmp_path: Path) -> None:
    for b in BLOCKS:
        write_delivery(tmp_path / "batch" / b, {"manifest": {"block_id": b, **BLOCKS[b]}})
    old = "GB/T 24356-2009 Inspection and acceptance of surveying and mapping products"
    text = re.sub(r"(?m)^standard: .*$", f"standard: {old}", PLAN)
    (tmp_path / "plan.yaml").write_text(text, "utf-8")
    out = tmp_path / "out"
    r = run_blockqc(
        "inspect", tmp_path / "batch", "--plan", tmp_path / "plan.yaml", "--out", out, "--no-pdf"
    )
    assert r.returncode == 0, r.stderr
    assert (
        f"warning: {tmp_path / 'plan.yaml'}, line 2: standard: the plan was drawn under {old}"
    ) in r.stderr
    notes = json.loads((out / "summary.json").read_text())["acceptance"]["plan_notes"]
    assert {"about": "standard", "plan": old, "blocks": []}.items() <= notes[-1].items()
    page = (out / "acceptance.html").read_text()
    flat = re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", page.split("</style>")[1])))
    assert f"The plan was drawn under {old}; the batch is judged under GB/T 24356-2023" in flat


def test_a_stratum_written_with_a_decimal_point_still_holds_its_blocks(tmp_path: Path) -> None:
    """A plan drawn when a block.yaml's 1.0 was stratum '1.0' (now read as the number 1, stratum
    '1') still places its blocks: the plan's value and the block's number are equal."""
    edits = (
        ("strata_key: terrain", "strata_key: test_field"),
        ("value: flat", "value: '1.0'"),
        ("value: hilly", "value: '2'"),
    )
    plan, path = _plan(tmp_path, *edits)
    blocks = {f"B{i:02d}": {"test_field": 1.0 if i % 2 == 0 else 2} for i in range(4)}
    check_strata(plan, path, blocks)


def test_a_block_yaml_key_of_bytes_does_not_stop_sample_or_inspect_plan(tmp_path: Path) -> None:
    """A key no rule reads holding bytes that are not UTF-8 (label: !!binary "/w==", 0xFF):
    `sample --strata` and `inspect --plan` stopped with an internal error (UnicodeDecodeError
    while reading the strata); they run, and the block is inspected as without the key."""
    import shutil

    from casekit import SAMPLES

    batch = tmp_path / "batch"
    for block in ("F1-B02", "F3-B02", "F4-B02"):
        shutil.copytree(SAMPLES / "batch" / block, batch / block)
    manifest = batch / "F1-B02" / "block.yaml"
    manifest.write_text(
        manifest.read_text(encoding="utf-8") + 'label: !!binary "/w=="\n', encoding="utf-8"
    )
    plan = tmp_path / "plan.yaml"
    drawn = run_blockqc("sample", batch, "--seed", 1, "--strata", "test_field", "--out", plan)
    assert drawn.returncode == 0, drawn.stderr
    done = run_blockqc("inspect", batch, "--plan", plan, "--out", tmp_path / "out", "--no-pdf")
    assert done.returncode == 1, done.stderr  # F3-B02 fails RO-3
    assert "internal error" not in done.stderr
    assert (tmp_path / "out" / "F1-B02" / "results.json").is_file()
