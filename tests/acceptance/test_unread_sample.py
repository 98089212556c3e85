"""A delivery of the batch that could not be read: a sampled one (by the plan) leaves the batch
decision incomplete and is named as not read in summary.json and on the acceptance pages;
without a plan any one does (it may carry checkpoints, so be of the sample)."""

from __future__ import annotations

import json
import re
from html import unescape
from pathlib import Path

import yaml

from casekit import run_blockqc, write_delivery

#: a plan over B00..B03 sampling B00 and B02 (simple random, one lot)
PLAN = {
    "plan": "sampling plan",
    "standard": "GB/T 24356-2023 Inspection and acceptance of surveying and mapping products",
    "rule_pack": "global-project 1.0",
    "batch": "batch",
    "seed": 0,
    "strata_key": None,
    "method": "simple random",
    "units": 4,
    "sample_size": 2,
    "lots": [
        {
            "size": 4,
            "sample_size": 2,
            "census": False,
            "strata": [
                {
                    "value": "",
                    "size": 4,
                    "sample": 2,
                    "units": ["B00", "B01", "B02", "B03"],
                    "sampled": ["B00", "B02"],
                }
            ],
            "sampled": ["B00", "B02"],
        }
    ],
    "sampled": ["B00", "B02"],
}


def _inspect(
    tmp_path: Path, broken: str | None, plan: bool, folder: str | None = None
) -> tuple[dict, str]:
    """Four deliveries with checkpoints, DOC-3 passed by the inspector, `broken`'s scenes.csv
    naming a band 'pann' (with `folder`: its folder so named, its block.yaml not YAML); the
    summary's acceptance and the acceptance page's text."""
    batch = tmp_path / "batch"
    for b in ("B00", "B01", "B02", "B03"):
        write_delivery(batch / b, {"manifest": {"block_id": b}})
    if broken and folder:
        (batch / broken).rename(batch / folder)
        (batch / folder / "block.yaml").write_text("block_id: [B02\n")
    elif broken:
        scenes = batch / broken / "scenes.csv"
        head, first, *rest = scenes.read_text().splitlines(keepends=True)
        assert ",pan," in first
        scenes.write_text(head + first.replace(",pan,", ",pann,", 1) + "".join(rest))
    verdicts = tmp_path / "verdicts.yaml"
    verdicts.write_text("inspector: I\nverdicts:\n  DOC-3: {status: pass}\n")
    args = ["--verdicts", verdicts, "--out", tmp_path / "out", "--no-pdf"]
    if plan:
        (tmp_path / "plan.yaml").write_text(yaml.safe_dump(PLAN))
        args += ["--plan", tmp_path / "plan.yaml"]
    r = run_blockqc("inspect", batch, *args)
    assert r.returncode == (2 if broken else 0), r.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    page = (tmp_path / "out" / "acceptance.html").read_text()
    text = re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", page.split("</style>")[1])))
    return summary["acceptance"], text


def test_with_every_block_read_the_sample_passes(tmp_path: Path) -> None:
    a, _ = _inspect(tmp_path, None, plan=True)
    assert a["decision"] == "pass" and a["unreadable"] == []


def test_a_sampled_block_not_read_leaves_the_decision_incomplete(tmp_path: Path) -> None:
    a, text = _inspect(tmp_path, "B02", plan=True)
    assert a["decision"] == "incomplete"
    assert a["sample"] == ["B00", "B02"] and a["unreadable"] == ["B02"]
    assert a["batch_grade"] is None and a["mean_score"] is None
    assert "Decision Not decided: the sample is incomplete" in text
    assert "Sampled blocks that could not be read: B02" in text  # in the sampling section
    assert "B02 yes – could not be read (see summary.json)" in text  # among the problems
    assert "Accepted" not in text


def test_a_block_not_sampled_and_not_read_is_named_but_does_not_decide(tmp_path: Path) -> None:
    a, text = _inspect(tmp_path, "B03", plan=True)
    assert a["decision"] == "pass" and a["unreadable"] == ["B03"]
    assert "Blocks not sampled that could not be read (returned for correction): B03" in text
    assert "No quality problem was found." not in text


def test_without_a_plan_a_block_not_read_leaves_the_decision_incomplete(tmp_path: Path) -> None:
    a, text = _inspect(tmp_path, "B03", plan=False)
    assert a["decision"] == "incomplete" and a["unreadable"] == ["B03"]
    assert a["sample"] == ["B00", "B01", "B02"]  # the blocks read that carry checkpoints
    assert (
        "Blocks that could not be read: without a sampling plan, whether they carry "
        "checkpoints, so belong to the sample, is not known: B03"
    ) in text


def test_a_sampled_block_whose_block_yaml_cannot_be_read_leaves_the_decision_incomplete(
    tmp_path: Path,
) -> None:
    """B02 (sampled) in a folder X2, its block.yaml not read: the delivery is named by its
    folder, so it was taken for one not sampled, and the sample's B00 alone accepted the batch.
    B02 is among no block read: X2 may be it, and the decision is incomplete."""
    a, text = _inspect(tmp_path, "B02", plan=True, folder="X2")
    assert a["decision"] == "incomplete" and a["unreadable"] == ["X2"]
    assert a["batch_grade"] is None and a["mean_score"] is None
    assert (
        "Blocks that could not be read (the plan's sampled B02, not among the blocks read, may "
        "be one of them): X2"
    ) in text
    assert "X2 – – could not be read (see summary.json)" in text  # among the problems
    assert "not sampled" not in text and "Accepted" not in text
