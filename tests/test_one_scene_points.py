"""Tie points observed on one scene only: counted as delivered, and said in the report and on
the console (they tie no scenes together)."""

from __future__ import annotations

import csv
import json
import shutil
from collections import Counter
from pathlib import Path

from casekit import run_blockqc

SAMPLE = Path(__file__).parents[1] / "samples" / "batch" / "F1-B01"


def _with_lone_points(tmp_path: Path, rows: tuple[int, ...]) -> tuple[Path, int]:
    """The sample block with the observations at `rows` given point ids of their own; the
    number of points then seen on one scene, counted here with the csv module."""
    block = Path(shutil.copytree(SAMPLE, tmp_path / "F1-B01"))
    path = block / "tie_points.csv"
    with path.open(newline="", encoding="utf-8") as fh:
        table = list(csv.reader(fh))
    for i, row in enumerate(rows):
        table[1 + row][0] = f"LONE-{i}"
    with path.open("w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(table)
    counts = Counter(r[0] for r in table[1:])
    return block, sum(1 for n in counts.values() if n == 1)


def test_points_on_one_scene_are_counted_and_said(tmp_path: Path):
    block, lone = _with_lone_points(tmp_path, (0, 5, 17))
    assert lone >= 3
    out = tmp_path / "out"
    proc = run_blockqc("inspect", block, "--out", out, "--pdf", "none")
    assert proc.returncode in (0, 1), proc.stderr
    results = json.loads((out / "F1-B01" / "results.json").read_text(encoding="utf-8"))
    assert results["summary"]["tie_points_on_one_scene"] == lone
    said = f"{lone} of {results['summary']['tie_points']} tie points are observed on one scene"
    assert said in proc.stderr
    html = (out / "F1-B01" / "report.html").read_text(encoding="utf-8")
    assert f"{lone} of the tie points are observed on one scene only" in html


def test_a_block_whose_points_all_tie_scenes_says_nothing(tmp_path: Path):
    block, lone = _with_lone_points(tmp_path, ())
    assert lone == 0  # the sample's points are each on two scenes or more
    out = tmp_path / "out"
    proc = run_blockqc("inspect", block, "--out", out, "--pdf", "none", "--lang", "zh")
    results = json.loads((out / "F1-B01" / "results.json").read_text(encoding="utf-8"))
    assert results["summary"]["tie_points_on_one_scene"] == 0
    assert "one scene only" not in proc.stderr
    assert "仅在一景影像上有观测" not in (out / "F1-B01" / "report.html").read_text("utf-8")


def test_an_incremental_rerun_says_them_again(tmp_path: Path):
    """A block whose outputs were reused unchanged said nothing of its points on one scene
    (the rules in error of a reused block are said again; these were not)."""
    block, lone = _with_lone_points(tmp_path, (0, 5, 17))
    out = tmp_path / "out"
    args = ("inspect", block, "--out", out, "--pdf", "none", "--incremental")
    first = run_blockqc(*args)
    again = run_blockqc(*args)
    assert "outputs reused" in again.stdout, again.stdout
    said = [x for x in first.stderr.splitlines() if "observed on one scene" in x]
    assert len(said) == 1 and said == [
        x for x in again.stderr.splitlines() if "observed on one scene" in x
    ]
