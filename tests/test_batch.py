"""Batches: incremental re-runs, PDFs where someone reads them, failures recorded, dask."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from blockqc import batch
from blockqc.inspector import load_inspector_input
from blockqc.rules import load_pack
from casekit import SAMPLES, run_blockqc


@pytest.fixture
def small_batch(tmp_path: Path) -> Path:
    """Two sample blocks that pass and one that fails (RO-3), copied so they can be changed."""
    folder = tmp_path / "batch"
    for block in ("F1-B02", "F3-B02", "F4-B02"):
        shutil.copytree(SAMPLES / "batch" / block, folder / block)
    return folder


def _mtimes(out: Path) -> dict[str, int]:
    return {p.parent.name: p.stat().st_mtime_ns for p in out.glob("*/results.json")}


def test_incremental_rerun_recomputes_only_the_changed_block(small_batch: Path, tmp_path: Path):
    out = tmp_path / "out"
    args = ("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    first = run_blockqc(*args)
    assert first.returncode == 1, first.stderr  # F3-B02 fails RO-3
    before = _mtimes(out)
    written = {p.name: p.stat().st_mtime_ns for p in out.glob("summary.*")}
    assert set(written) == {"summary.json", "summary.html", "summary.csv", "summary.parquet"}
    again = run_blockqc(*args)
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 3
    assert _mtimes(out) == before
    # nothing changed: the summary outputs are the ones already written
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("summary.*")} == written
    overlaps = small_batch / "F4-B02" / "overlaps.csv"
    overlaps.write_text(overlaps.read_text(encoding="utf-8") + "\n", encoding="utf-8")
    third = run_blockqc(*args)
    assert third.stdout.count("outputs reused") == 2, third.stdout
    after = _mtimes(out)
    assert (out / "summary.json").stat().st_mtime_ns != written["summary.json"]
    assert after["F4-B02"] != before["F4-B02"]
    assert {k: v for k, v in after.items() if k != "F4-B02"} == {
        k: v for k, v in before.items() if k != "F4-B02"
    }
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [b["verdict"] for b in summary["blocks"]] == ["pass", "fail", "pass"]
    assert (
        (out / "summary.csv")
        .read_text(encoding="utf-8-sig")
        .splitlines()[2]
        .startswith("F3-B02,fail")
    )


def test_pdf_only_for_failing_blocks(small_batch: Path, tmp_path: Path):
    out = tmp_path / "out"
    proc = run_blockqc("inspect", small_batch, "--out", out, "--pdf", "failing")
    assert proc.returncode == 1, proc.stderr
    assert sorted(p.parent.name for p in out.glob("*/report.pdf")) == ["F3-B02"]
    assert (out / "summary.pdf").is_file()
    html = (out / "summary.html").read_text(encoding="utf-8")
    assert html.count(">PDF</a>") == 1 and 'href="summary.csv"' in html


def test_a_crashing_block_is_recorded_and_the_others_go_on(small_batch, tmp_path, monkeypatch):
    real = batch.inspect_one

    def flaky(path, *args, **kwargs):
        if path.name == "F3-B02":
            raise RuntimeError("simulated defect")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "inspect_one", flaky)
    got = batch.collect([small_batch])
    writer = batch.Writer(tmp_path / "out", pdf="none")
    outcomes, summary = batch.run(got, load_pack("global-project"), writer)
    assert [o.entry is not None for o in outcomes] == [True, False, True]
    assert summary.counts.unreadable == 1 and summary.verdict == "error"
    assert "simulated defect" in summary.unreadable[0].problems[0]
    assert batch.exit_status(outcomes) == 2
    assert (tmp_path / "out" / "F4-B02" / "report.html").is_file()


def test_an_unreadable_delivery_says_nothing_was_written(tmp_path: Path):
    bad = tmp_path / "bad"
    shutil.copytree(SAMPLES / "batch" / "F1-B02", bad)
    (bad / "scenes.csv").unlink()
    proc = run_blockqc("inspect", bad, "--out", tmp_path / "out", "--no-pdf")
    assert proc.returncode == 2
    assert "nothing was written" in proc.stderr and "scenes" in proc.stderr


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_results(tmp_path: Path):
    pytest.importorskip("dask.distributed")
    verdicts = load_inspector_input(SAMPLES / "verdicts.yaml")
    pack = load_pack("global-project")
    docs = {}
    for name, runner in (("local", batch.Runner()), ("dask", batch.Runner(scheduler="local"))):
        got = batch.collect([SAMPLES / "batch"])
        out = tmp_path / name
        batch.run(got, pack, batch.Writer(out, pdf="none"), verdicts, runner=runner)
        docs[name] = {
            p.parent.name: {**json.loads(p.read_text(encoding="utf-8")), "generated_at": ""}
            for p in sorted(out.glob("*/results.json"))
        }
    assert len(docs["dask"]) == 8 and docs["dask"] == docs["local"]


def test_out_that_is_a_file_or_under_one_is_refused(tmp_path: Path):
    file = tmp_path / "a-file"
    file.write_text("x", encoding="utf-8")
    delivery = SAMPLES / "batch" / "F1-B02"
    for out, said in ((file, "is a file"), (file / "sub", "lies under the file")):
        proc = run_blockqc("inspect", delivery, "--out", out, "--no-pdf")
        assert proc.returncode == 2 and said in proc.stderr, proc.stderr
        assert "Traceback" not in proc.stderr
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    proc = run_blockqc("inspect", delivery, "--out", locked / "new", "--no-pdf")
    import os

    if os.geteuid() != 0:  # root may write anywhere
        assert proc.returncode == 2 and "cannot be created" in proc.stderr
