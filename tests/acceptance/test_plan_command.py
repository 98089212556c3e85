"""`blockqc sample` and `inspect --plan` on real command lines."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
import yaml

from casekit import base_tables, run_blockqc, write_delivery


def _batch(root: Path, n: int, with_cps: set[int] = frozenset()) -> Path:
    """n tiny deliveries (ids B00…); strata by a `terrain` key: 'flat' for even i, else 'hilly'."""
    for i in range(n):
        case = {"manifest": {"block_id": f"B{i:02d}", "terrain": "flat" if i % 2 == 0 else "hilly"}}
        if i not in with_cps:
            case["remove_tables"] = ["checkpoints"]
        write_delivery(root / f"B{i:02d}", case)
    return root


def test_sample_command_reproducible_and_stratified(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 5)
    a = run_blockqc(
        "sample", batch, "--seed", 4, "--strata", "terrain", "--out", tmp_path / "a.yaml"
    )
    b = run_blockqc(
        "sample", batch, "--seed", 4, "--strata", "terrain", "--out", tmp_path / "b.yaml"
    )
    assert a.returncode == 0 == b.returncode, a.stderr
    pa, pb = (yaml.safe_load((tmp_path / f).read_text()) for f in ("a.yaml", "b.yaml"))
    assert pa["sampled"] == pb["sampled"] and len(pa["sampled"]) == 3
    # 3 flat, 2 hilly: quotas 1.8 and 1.2 → 1 + 1, the seat left to the larger remainder (.8)
    per = {s["value"]: s["sample"] for s in pa["lots"][0]["strata"]}
    assert per == {"flat": 2, "hilly": 1}
    assert pa["batch"] == "batch"  # the folder's name, never a path of this machine


def test_sample_command_names_a_missing_key(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 2)
    r = run_blockqc(
        "sample", batch, "--seed", 1, "--strata", "producer", "--out", tmp_path / "p.yaml"
    )
    assert r.returncode == 2
    assert "block.yaml" in r.stderr and "no key 'producer'" in r.stderr
    assert not (tmp_path / "p.yaml").exists()


def test_sample_refuses_an_empty_strata_key(tmp_path: Path) -> None:
    """An empty --strata is no key: it would draw a simple random sample, said to be none."""
    batch = _batch(tmp_path / "batch", 2)
    r = run_blockqc("sample", batch, "--seed", 1, "--strata", "", "--out", tmp_path / "p.yaml")
    assert r.returncode == 2, r.stderr
    assert (
        "error: --strata '': expected a block.yaml key to stratify by (e.g. test_field); "
        "leave --strata out for simple random sampling"
    ) in r.stderr
    assert not (tmp_path / "p.yaml").exists()


def test_sample_refuses_a_plan_inside_a_delivery_the_batch_links_to(tmp_path: Path) -> None:
    real = _batch(tmp_path / "real", 1) / "B00"
    batch = tmp_path / "batch"
    batch.mkdir()
    (batch / "B00").symlink_to(real)
    r = run_blockqc("sample", batch, "--seed", 1, "--out", real / "p.yaml")
    assert r.returncode == 2, r.stderr
    assert (
        f"error: --out {real / 'p.yaml'} lies inside the delivery {real}: blockqc never writes "
        "into a delivery; choose an output folder outside it"
    ) in r.stderr
    assert not (real / "p.yaml").exists()


def test_sample_refused_leaves_no_folder_it_made(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 2)
    out = tmp_path / "new" / "p.yaml"
    r = run_blockqc("sample", batch, "--seed", 1, "--strata", "producer", "--out", out)
    assert r.returncode == 2 and "no key 'producer'" in r.stderr, r.stderr
    r = run_blockqc("sample", batch, "--seed", 1, "--out", tmp_path / "new" / "p.txt")
    assert r.returncode == 2
    assert f"error: --out {tmp_path / 'new' / 'p.txt'}: the plan is a YAML file (.yaml)" in (
        r.stderr
    )
    assert not (tmp_path / "new").exists()


#: the fields of a plan that say what it is and where it comes from (every one is required)
ABOUT = {
    "plan": "sampling plan",
    "standard": "GB/T 24356-2023 Inspection and acceptance of surveying and mapping products",
    "rule_pack": "global-project 1.0",
    "batch": "batch",
    "strata_key": None,
    "method": "simple random",
}


def _write_plan_b00_b02(path: Path) -> None:
    """A plan over B00..B03 (one lot, one stratum) that samples B00 and B02."""
    stratum = {"value": "", "size": 4, "sample": 2, "units": ["B00", "B01", "B02", "B03"]}
    sampled = ["B00", "B02"]
    lot = {"size": 4, "sample_size": 2, "census": False}
    lot |= {"strata": [stratum | {"sampled": sampled[:]}], "sampled": sampled[:]}
    plan = {**ABOUT, "seed": 0, "units": 4, "sample_size": 2, "lots": [lot], "sampled": sampled}
    path.write_text(yaml.safe_dump(plan))


def test_a_sampled_block_without_checkpoints_is_not_said_unsampled(tmp_path: Path) -> None:
    """A block the plan samples, delivered without checkpoints: its checkpoint rules kept the
    metric's reason 'no checkpoints: the block was not sampled for detailed inspection' beside
    the plan's 'sampled …, incomplete', and its report said both; the reason is the plan's."""
    from blockqc.acceptance.plan import NO_CHECKPOINTS, apply_plan
    from blockqc.delivery import load_delivery
    from blockqc.engine import inspect_delivery
    from blockqc.report.html import render_block
    from blockqc.rules import load_pack

    case = {"manifest": {"block_id": "B00"}, "remove_tables": ["checkpoints"]}
    delivery = load_delivery(write_delivery(tmp_path / "B00", case))
    results = apply_plan(inspect_delivery(delivery, load_pack("global-project")), True)
    for r in results.results:
        if r.rule in ("CP-1", "CP-2", "CP-3", "CP-4"):
            assert r.detail["reason"] == NO_CHECKPOINTS, r.rule
    for lang in ("en", "zh"):
        page = render_block(results.model_dump(mode="json"), lang=lang)
        assert "not sampled" not in page and "未抽为详查样本" not in page


def test_inspect_with_plan(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 4, with_cps={0, 1})
    _write_plan_b00_b02(tmp_path / "plan.yaml")
    out = tmp_path / "out"
    r = run_blockqc("inspect", batch, "--plan", tmp_path / "plan.yaml", "--out", out, "--no-pdf")
    assert r.returncode == 0, r.stderr
    res = {b: json.loads((out / b / "results.json").read_text()) for b in ("B00", "B01", "B02")}
    cp2 = {b: next(x for x in d["results"] if x["rule"] == "CP-2") for b, d in res.items()}
    assert cp2["B00"]["status"] == "pass"  # sampled, with checkpoints
    assert cp2["B01"]["status"] == "not_applicable"  # has checkpoints, not sampled
    assert "not sampled" in cp2["B01"]["detail"]["reason"]
    assert res["B02"]["complete"] is False  # sampled without checkpoints: incomplete, said so
    assert "no checkpoints" in cp2["B02"]["detail"]["plan"]
    assert res["B02"]["evaluation"]["complete"] is False
    summary = json.loads((out / "summary.json").read_text())
    assert summary["acceptance"]["sample"] == ["B00", "B02"]
    assert summary["acceptance"]["decision"] == "incomplete"
    # the batch is not complete either: B02 is not fully evaluated (the summary said complete)
    assert summary["complete"] is False
    assert {b["block_id"]: b["complete"] for b in summary["blocks"]}["B02"] is False


def test_the_inspectors_checkpoints_of_a_block_not_sampled_are_said_not_judged(
    tmp_path: Path,
) -> None:
    """The inspector's own checkpoints of a block the plan does not sample: its checkpoint
    rules are not applicable, so the rows judged nothing, and nothing said so."""
    batch = _batch(tmp_path / "batch", 4, with_cps={0, 1})
    plan = tmp_path / "plan.yaml"
    _write_plan_b00_b02(plan)
    cps = base_tables()["checkpoints"].head(3).assign(method="recalculation")
    mine = tmp_path / "mine.csv"
    pd.concat([cps.assign(block_id="B00"), cps.assign(block_id="B01")]).to_csv(mine, index=False)
    out = tmp_path / "out"
    args = ("inspect", batch, "--plan", plan, "--checkpoints", mine, "--out", out, "--no-pdf")
    r = run_blockqc(*args)
    assert r.returncode == 0, r.stderr
    said = [line for line in r.stderr.splitlines() if "checkpoint(s) of block" in line]
    assert said == [
        f"warning: {mine}: 3 checkpoint(s) of block B01, which the plan {plan} does not sample: "
        "not judged (under --plan only the sampled blocks are inspected in detail)"
    ]
    results = json.loads((out / "B01" / "results.json").read_text())["results"]
    assert next(x for x in results if x["rule"] == "CP-2")["status"] == "not_applicable"

    # rows of the sampled block alone: every one judged, nothing to say
    cps.assign(block_id="B00").to_csv(mine, index=False)
    r = run_blockqc(*args)
    assert r.returncode == 0, r.stderr
    assert "checkpoint(s) of block" not in r.stderr


def test_inspect_plan_refuses_a_block_outside_it(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 2)
    plan = {
        **ABOUT,
        "seed": 0,
        "units": 1,
        "sample_size": 1,
        "sampled": ["B00"],
        "lots": [
            {
                "size": 1,
                "sample_size": 1,
                "census": True,
                "sampled": ["B00"],
                "strata": [
                    {"value": "", "size": 1, "sample": 1, "units": ["B00"], "sampled": ["B00"]}
                ],
            }
        ],
    }
    (tmp_path / "plan.yaml").write_text(yaml.safe_dump(plan))
    r = run_blockqc("inspect", batch, "--plan", tmp_path / "plan.yaml", "--out", tmp_path / "o")
    assert r.returncode == 2 and "block B01 is not in the plan's batch" in r.stderr


def _manifests(root: Path, n: int) -> Path:
    """n block folders holding a block.yaml only (all `blockqc sample` reads); 3 producers."""
    for i in range(n):
        d = root / f"G{i:04d}"
        d.mkdir(parents=True)
        doc = {"block_id": f"G{i:04d}", "gsd_m": {"pan": 1.0}, "producer": f"P{i % 3}"}
        (d / "block.yaml").write_text(yaml.safe_dump(doc))
    return root


@pytest.mark.parametrize(("n", "expected"), [(8, 3), (150, 13), (700, 56)])
def test_sample_generated_batches(tmp_path: Path, n: int, expected: int) -> None:
    batch = _manifests(tmp_path / "b", n)
    plans = []
    for name in ("a", "b"):
        r = run_blockqc(
            "sample",
            batch,
            "--seed",
            2026,
            "--strata",
            "producer",
            "--out",
            tmp_path / f"{name}.yaml",
        )
        assert r.returncode == 0, r.stderr
        plans.append(yaml.safe_load((tmp_path / f"{name}.yaml").read_text()))
    assert plans[0]["sampled"] == plans[1]["sampled"]  # one seed, one sample
    assert len(plans[0]["sampled"]) == expected
    strata = plans[0]["lots"][0]["strata"]
    for s in strata:  # proportional: within one unit of n·N_h/N
        assert abs(s["sample"] - expected * s["size"] / n) < 1
        assert all(u in s["units"] for u in s["sampled"])


def test_bad_plan_file_is_named(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 1)
    (tmp_path / "plan.yaml").write_text("seed: x\nunits: 1\n")
    r = run_blockqc("inspect", batch, "--plan", tmp_path / "plan.yaml", "--out", tmp_path / "o")
    assert r.returncode == 2
    assert "plan.yaml" in r.stderr and "seed" in r.stderr and "Traceback" not in r.stderr


def test_meta_in_block_report_and_filed_report(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 2, with_cps={0})
    meta = tmp_path / "meta.yaml"
    meta.write_text("report_number: QC-7\nproject: P\nproducer: Q\nprepared: A\napproved: C\n")
    out = tmp_path / "out"
    r = run_blockqc("inspect", batch, "--meta", meta, "--out", out, "--no-pdf")
    assert r.returncode == 0, r.stderr
    block = (out / "B00" / "report.html").read_text()
    assert "QC-7" in block and "Prepared by: A" in block
    assert str(tmp_path) not in block  # the delivery is named, not placed on this machine
    filed = (out / "acceptance.html").read_text()
    assert "QC-7" in filed and "GB/T 24356-2023" in filed  # basis from the pack
    bad = tmp_path / "bad.yaml"
    bad.write_text("report_numbr: 1\n")
    r = run_blockqc("inspect", batch, "--meta", bad, "--out", tmp_path / "o2", "--no-pdf")
    assert r.returncode == 2 and "bad.yaml" in r.stderr and "report_numbr" in r.stderr


def test_particulars_of_an_acceptance_page_not_written_are_warned_of(tmp_path: Path) -> None:
    """`handling` and `annexes` are shown on the batch's acceptance page only: given for one
    delivery, or with a pack without `acceptance:`, they went unused with nothing said."""
    batch = _batch(tmp_path / "batch", 2, with_cps={0, 1})
    meta = tmp_path / "meta.yaml"
    meta.write_text("report_number: QC-7\nhandling: returned\nannexes: [a.pdf]\n")
    one = run_blockqc("inspect", batch / "B00", "--meta", meta, "--out", tmp_path / "a", "--no-pdf")
    other = run_blockqc(
        "inspect", batch, "--rules", "asprs-2023", "--meta", meta, "--out", tmp_path / "b",
        "--no-pdf",
    )  # fmt: skip
    for r, why in ((one, "a batch"), (other, "a pack with an acceptance: section")):
        assert r.returncode in (0, 1), r.stderr
        assert "meta.yaml: handling, annexes: shown on the batch's acceptance page" in r.stderr
        assert f"(it needs {why})" in r.stderr
    whole = run_blockqc("inspect", batch, "--meta", meta, "--out", tmp_path / "c", "--no-pdf")
    assert whole.returncode == 0 and "acceptance page only" not in whole.stderr
    assert "a.pdf" in (tmp_path / "c" / "acceptance.html").read_text()


def test_pdf_sampled_follows_the_plan(tmp_path: Path) -> None:
    """`--pdf sampled`: the plan's blocks (B00 with checkpoints, B02 without); without a plan,
    the blocks that carry checkpoints (B00, B01)."""
    batch = _batch(tmp_path / "batch", 4, with_cps={0, 1})
    _write_plan_b00_b02(tmp_path / "plan.yaml")
    with_plan, without = tmp_path / "with", tmp_path / "without"
    r = run_blockqc(
        "inspect", batch, "--plan", tmp_path / "plan.yaml", "--out", with_plan, "--pdf", "sampled"
    )
    assert r.returncode == 0, r.stderr
    assert sorted(p.parent.name for p in with_plan.glob("*/report.pdf")) == ["B00", "B02"]
    r = run_blockqc("inspect", batch, "--out", without, "--pdf", "sampled")
    assert r.returncode == 0, r.stderr
    assert sorted(p.parent.name for p in without.glob("*/report.pdf")) == ["B00", "B01"]


def _line(path: Path, text: str, after: str = "") -> int:
    """The line of `path` holding `text` (after the line holding `after`)."""
    lines = path.read_text().splitlines()
    start = lines.index(after) + 1 if after else 0
    return lines.index(text, start) + 1


def test_inspect_plan_names_the_line_of_a_sampled_block_not_inspected(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 2)  # B00, B01: the plan samples B00 and B02
    plan = tmp_path / "plan.yaml"
    _write_plan_b00_b02(plan)
    r = run_blockqc("inspect", batch, "--plan", plan, "--out", tmp_path / "o", "--no-pdf")
    line = _line(plan, "- B02", after="sampled:")
    assert r.returncode == 2, r.stderr
    assert (
        f"{plan}, line {line}: sampled: block B02 is sampled by the plan but not among the "
        "deliveries inspected (B00, B01)"
    ) in r.stderr


def test_inspect_plan_with_a_sampled_block_whose_block_yaml_cannot_be_read(tmp_path: Path) -> None:
    """B02, sampled, with a block.yaml refused (a GSD below 0): the plan was refused as sampling
    "a block not among the deliveries inspected", the run stopped there and B02's own problem
    went unsaid. The sampled blocks are now checked when every block id is known: the batch is
    inspected, B02 refused with its problem, and the decision left incomplete for want of it."""
    batch = _batch(tmp_path / "batch", 4, with_cps={0})
    manifest = batch / "B02" / "block.yaml"
    manifest.write_text(manifest.read_text().replace("pan: 1.0", "pan: -1.0"))
    plan = tmp_path / "plan.yaml"
    _write_plan_b00_b02(plan)
    out = tmp_path / "o"
    r = run_blockqc("inspect", batch, "--plan", plan, "--out", out, "--no-pdf")
    assert r.returncode == 2, r.stderr
    assert "not among the deliveries inspected" not in r.stderr
    assert "no delivery of the batch is block B02" not in r.stderr  # it is there, and sampled
    assert f"{manifest}" in r.stderr and "gsd_m.pan" in r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["acceptance"]["decision"] == "incomplete"


def test_inspect_plan_names_the_line_of_its_units_for_a_block_outside_it(tmp_path: Path) -> None:
    batch = _batch(tmp_path / "batch", 5)  # B04 is not among the plan's units B00..B03
    plan = tmp_path / "plan.yaml"
    _write_plan_b00_b02(plan)
    r = run_blockqc("inspect", batch, "--plan", plan, "--out", tmp_path / "o", "--no-pdf")
    assert r.returncode == 2, r.stderr
    assert (
        f"{plan}, line {_line(plan, 'units: 4')}: units: block B04 is not in the plan's batch "
        "(its 4 units: B00, B01, B02, B03)"
    ) in r.stderr


def test_sample_names_a_stray_file_and_a_strata_key_left_out(tmp_path: Path) -> None:
    """As inspect does, sample warns of a file beside the deliveries (not drawn from); a block
    whose block.yaml leaves the strata key out is told so ("no key"), not that it is empty."""
    batch = _batch(tmp_path / "batch", 3)
    (batch / "notes.txt").write_text("x", encoding="utf-8")
    p = run_blockqc("sample", batch, "--seed", 1, "--out", tmp_path / "a.yaml")
    assert p.returncode == 0, p.stderr
    assert f"warning: {batch / 'notes.txt'}: a file beside the deliveries" in p.stderr
    p = run_blockqc(
        "sample", batch, "--seed", 1, "--strata", "sampled", "--out", tmp_path / "b.yaml"
    )
    assert p.returncode == 2
    assert "block.yaml: no key 'sampled' in block.yaml to stratify by" in p.stderr


def test_sample_names_a_link_to_a_delivery_of_the_batch(tmp_path: Path) -> None:
    """A sub-folder linking to another delivery of the batch is one unit: the plan counted 3
    units of 4 sub-folders unsaid, where inspect warns that it inspects it once."""
    batch = _batch(tmp_path / "batch", 3)
    (batch / "B03").symlink_to(batch / "B01", target_is_directory=True)
    p = run_blockqc("sample", batch, "--seed", 1, "--out", tmp_path / "a.yaml")
    assert p.returncode == 0, p.stderr
    assert f"warning: {batch / 'B03'}: named more than once, drawn from once" in p.stderr
    assert yaml.safe_load((tmp_path / "a.yaml").read_text())["units"] == 3


def test_sample_names_its_plan_file_not_the_folder_as_out(tmp_path: Path) -> None:
    """`--out notes.txt/plan.yaml` was 'error: --out …/notes.txt is a file', and a plan inside
    the batch '--out BATCH lies inside the input BATCH': the folder named as the --out given."""
    batch = _batch(tmp_path / "batch", 2)
    (tmp_path / "notes.txt").write_text("x", encoding="utf-8")
    p = run_blockqc("sample", batch, "--seed", 1, "--out", tmp_path / "notes.txt" / "plan.yaml")
    assert p.returncode == 2
    plan, file = tmp_path / "notes.txt" / "plan.yaml", tmp_path / "notes.txt"
    assert f"error: --out {plan} lies under the file {file}: give a folder" in p.stderr
    p = run_blockqc("sample", batch, "--seed", 1, "--out", batch / "plan.yaml")
    assert p.returncode == 2
    assert f"error: --out {batch / 'plan.yaml'} lies inside the input {batch}" in p.stderr
    assert not (batch / "plan.yaml").exists()


def test_a_sampled_block_swapped_by_hand_is_said(tmp_path: Path) -> None:
    """A plan edited by hand, one flat block sampled swapped for the flat block left out (in the
    stratum, the lot and the plan alike, so that its counts agree): its seed does not draw that
    block, which is said at the plan's sampled: line and noted; the plan as drawn says nothing."""
    batch = _batch(tmp_path / "batch", 5)
    drawn = tmp_path / "drawn.yaml"
    r = run_blockqc("sample", batch, "--seed", 4, "--strata", "terrain", "--out", drawn)
    assert r.returncode == 0, r.stderr
    plan = yaml.safe_load(drawn.read_text())
    flat = next(s for s in plan["lots"][0]["strata"] if s["value"] == "flat")
    (out_block,) = [u for u in flat["units"] if u not in flat["sampled"]]  # 3 flat, 2 sampled
    gone = flat["sampled"][0]

    def swap(units: list[str]) -> list[str]:
        return sorted(out_block if u == gone else u for u in units)

    edited = {**plan, "sampled": swap(plan["sampled"])}
    edited["lots"][0]["sampled"] = swap(plan["lots"][0]["sampled"])
    flat["sampled"] = swap(flat["sampled"])
    (tmp_path / "edited.yaml").write_text(yaml.safe_dump(edited, sort_keys=False))

    r = run_blockqc("inspect", batch, "--plan", drawn, "--out", tmp_path / "o1", "--no-pdf")
    assert r.returncode in (0, 1), r.stderr
    assert "seed" not in r.stderr
    summary = json.loads((tmp_path / "o1" / "summary.json").read_text())
    assert summary["acceptance"]["plan_notes"] == []

    r = run_blockqc(
        "inspect", batch, "--plan", tmp_path / "edited.yaml", "--out", tmp_path / "o2", "--no-pdf"
    )
    assert r.returncode in (0, 1), r.stderr
    assert "Traceback" not in r.stderr
    line = 1 + next(
        i for i, t in enumerate((tmp_path / "edited.yaml").read_text().splitlines())
        if t.startswith("sampled:")
    )  # fmt: skip
    assert (
        f"warning: {tmp_path / 'edited.yaml'}, line {line}: sampled: the plan's seed 4 draws "
        f"{', '.join(plan['sampled'])} from its 5 units by the pack's table (§QE-1); the plan "
        f"samples {', '.join(edited['sampled'])}"
    ) in r.stderr
    notes = json.loads((tmp_path / "o2" / "summary.json").read_text())["acceptance"]["plan_notes"]
    assert notes == [
        {"about": "seed", "plan": "4", "inspected": ", ".join(plan["sampled"]),
         "blocks": [out_block]}
    ]  # fmt: skip


def test_meta_particulars_yaml_reads_otherwise_are_refused_saying_what_the_file_gives(
    tmp_path: Path,
) -> None:
    """report_number: 2024 reads as a number, prepared: yes as true: each is refused at its
    line, saying what it was read as and to quote it; a list given as text says so."""
    from blockqc.acceptance.plan import load_meta
    from blockqc.errors import InputError

    meta = tmp_path / "meta.yaml"
    meta.write_text("report_number: 2024\nproject: P\nprepared: yes\nannexes: notes\n")
    with pytest.raises(InputError) as exc:
        load_meta(meta)
    assert [str(p).removeprefix(f"{meta}, ") for p in exc.value.problems] == [
        "line 1: report_number: expected text, got a number (2024): put it in quotes to keep it "
        "as written",
        "line 3: prepared: expected text, got true/false (true): put it in quotes to keep it as "
        "written",
        "line 4: annexes: expected a list, got text 'notes'",
    ]


def test_a_misspelt_meta_key_is_refused_with_the_key_it_resembles(tmp_path: Path) -> None:
    from blockqc.acceptance.plan import load_meta
    from blockqc.errors import InputError

    meta = tmp_path / "meta.yaml"
    meta.write_text("report_numbr: QC-1\nproject: P\ncolour: red\n")
    with pytest.raises(InputError) as exc:
        load_meta(meta)
    assert [str(p).removeprefix(f"{meta}, ") for p in exc.value.problems] == [
        "line 1: report_numbr: unknown key; did you mean 'report_number'?",
        "line 3: colour: unknown key",
    ]


def test_strata_numerically_equal_in_block_yaml_are_one_stratum(tmp_path: Path) -> None:
    """work_unit 1 (B00) and 1.0 (B01) are the one work unit, YAML reads both as the number 1;
    they were strata '1' and '1.0'. Strata 1 (2 units) and 2 (2 units) share a sample of 3:
    quotas 1.5 and 1.5, the seat left to the first in order, so stratum 1 gives both units."""
    units = {"B00": 1, "B01": 1.0, "B02": 2, "B03": 2}
    for block, unit in units.items():
        case = {"manifest": {"block_id": block, "work_unit": unit}}
        write_delivery(tmp_path / "batch" / block, {**case, "remove_tables": ["checkpoints"]})
    assert "work_unit: 1.0" in (tmp_path / "batch" / "B01" / "block.yaml").read_text()
    plan = tmp_path / "plan.yaml"
    r = run_blockqc(
        "sample", tmp_path / "batch", "--seed", 5, "--strata", "work_unit", "--out", plan
    )
    assert r.returncode == 0, r.stderr
    strata = yaml.safe_load(plan.read_text())["lots"][0]["strata"]
    got = [(s["value"], s["units"], s["sample"]) for s in strata]
    assert got == [("1", ["B00", "B01"], 2), ("2", ["B02", "B03"], 1)]


def test_a_number_in_quotes_beside_the_same_number_is_refused_naming_both(tmp_path: Path) -> None:
    """work_unit '1.0' (text, B00) and 1.0 (a number, B01): one stratum or two cannot be told;
    stratum '1.0' (text) and stratum 1 (the number) would be drawn apart. Refused at the text's
    line, naming the block.yaml that gives the number; '1' in quotes beside 1 reads alike."""
    units = {"B00": "1.0", "B01": 1.0, "B02": "2", "B03": 2}
    for block, unit in units.items():
        case = {"manifest": {"block_id": block, "work_unit": unit}}
        write_delivery(tmp_path / "batch" / block, {**case, "remove_tables": ["checkpoints"]})
    text = tmp_path / "batch" / "B00" / "block.yaml"
    line = text.read_text().splitlines().index("work_unit: '1.0'") + 1
    plan = tmp_path / "plan.yaml"
    r = run_blockqc(
        "sample", tmp_path / "batch", "--seed", 5, "--strata", "work_unit", "--out", plan
    )
    assert r.returncode == 2, r.stderr
    assert (
        f"error: {text}, line {line}: key 'work_unit' is the text '1.0', and "
        f"{tmp_path / 'batch' / 'B01' / 'block.yaml'} gives the number 1: one stratum or two? "
        "write them alike (both numbers, or the same text in quotes)"
    ) in r.stderr
    assert "'2'" not in r.stderr and not plan.exists()


def test_an_empty_basis_in_a_meta_file_is_refused_at_its_line(tmp_path: Path) -> None:
    """`basis: []` says the report rests on no document, yet the filed report showed the
    pack's three (GB/T 24356-2023 …) as the file's basis. An empty basis (or basis_zh) is now
    refused at its line, saying what to give."""
    from blockqc.acceptance.plan import load_meta
    from blockqc.errors import InputError

    meta = tmp_path / "meta.yaml"
    meta.write_text("report_number: QC-7\nbasis: []\nbasis_zh: []\n", encoding="utf-8")
    with pytest.raises(InputError) as got:
        load_meta(meta)
    assert [(p.line, p.message.split(":")[0]) for p in got.value.problems] == [
        (2, "basis"),
        (3, "basis_zh"),
    ]
    assert got.value.problems[0].message == (
        "basis: give at least one document, or leave the key out to use the rule pack's basis"
    )
    meta.write_text("report_number: QC-7\nbasis: [Design of the project]\n", encoding="utf-8")
    assert load_meta(meta).basis == ["Design of the project"]


def test_a_basis_given_in_english_alone_is_not_shown_as_the_packs_in_chinese() -> None:
    """A meta file's own basis without basis_zh: the pages in Chinese showed the pack's three
    documents instead (its basis_zh). They now show the file's basis; the pack's basis, in
    both languages, is shown where the file gives none."""
    from blockqc.acceptance.model import ReportMeta
    from blockqc.batch import _meta
    from blockqc.resources import rules_dir
    from blockqc.rules import load_pack

    pack = load_pack("global-project")
    stock = yaml.safe_load((rules_dir() / "global-project.yaml").read_text(encoding="utf-8"))
    own = _meta(ReportMeta(basis=["Design of the project"]), pack)
    assert (own.basis, own.basis_zh) == (["Design of the project"], [])
    none = _meta(ReportMeta(report_number="QC-7"), pack)
    expected = (stock["acceptance"]["basis"], stock["acceptance"]["basis_zh"])
    assert (none.basis, none.basis_zh) == expected and len(expected[1]) == 3
