"""Batches: incremental re-runs, PDFs where someone reads them, failures recorded, dask."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
from contextlib import suppress
from pathlib import Path

import pytest

from blockqc import batch
from blockqc.errors import OutputError
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
    assert "warning" not in third.stderr  # a changed delivery is the usual case: nothing to say
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


def test_incremental_rerun_sees_a_new_folder_and_files_in_a_linked_folder(
    small_batch: Path, tmp_path: Path
):
    """An empty `RPC/` makes the reader refuse the delivery (contract v1.1 reads `rpc/`), and a
    document changed in a linked folder is a changed delivery: neither reuses the outputs."""
    out = tmp_path / "out"
    args = ("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    assert run_blockqc(*args).returncode == 1
    (small_batch / "F1-B02" / "RPC").mkdir()
    again = run_blockqc(*args)
    assert again.returncode == 2 and "RPC" in again.stderr, again.stderr
    assert again.stdout.count("outputs reused") == 2, again.stdout
    (small_batch / "F1-B02" / "RPC").rmdir()
    docs = small_batch / "F4-B02" / "documents"
    shutil.move(docs, tmp_path / "documents")
    docs.symlink_to(tmp_path / "documents", target_is_directory=True)
    assert run_blockqc(*args).returncode == 1
    report = next(p for p in (tmp_path / "documents").iterdir() if p.is_file())
    report.write_bytes(report.read_bytes() + b" ")
    third = run_blockqc(*args)
    assert third.stdout.count("outputs reused") == 2 and "F4-B02" not in [
        line.split()[0] for line in third.stdout.splitlines() if "reused" in line
    ], third.stdout


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
    # the spreadsheet has a row for it too: 3 deliveries, not 2 that pass or fail
    import pandas as pd

    table = pd.read_csv(tmp_path / "out" / "summary.csv", encoding="utf-8-sig")
    assert table["block_id"].tolist() == ["F1-B02", "F4-B02", "F3-B02"]
    assert table["verdict"].tolist()[-1] == "unreadable"
    assert "simulated defect" in table["problems"].iloc[-1]
    parquet = pd.read_parquet(tmp_path / "out" / "summary.parquet")
    assert parquet["verdict"].tolist() == table["verdict"].tolist()
    assert (tmp_path / "out" / "F4-B02" / "report.html").is_file()


def test_a_delivery_removed_while_the_batch_runs_is_named_in_words(small_batch, tmp_path):
    """A delivery moved away after the batch was read: it was 'could not be inspected:
    FileNotFoundError: [Errno 2] No such file or directory: …', in Python's words. It is
    named, with what became of it, and the other blocks go on."""
    got = batch.collect([small_batch])
    shutil.rmtree(small_batch / "F3-B02")
    writer = batch.Writer(tmp_path / "out", pdf="none")
    outcomes, summary = batch.run(got, load_pack("global-project"), writer)
    assert [o.entry is not None for o in outcomes] == [True, False, True]
    assert [str(p) for p in outcomes[1].problems] == [
        f"{small_batch / 'F3-B02'}: cannot be read: No such file or directory: moved or removed "
        "while it was being inspected? (inspect it again)"
    ]
    assert summary.counts.unreadable == 1 and batch.exit_status(outcomes) == 2


def test_the_console_says_how_many_of_the_failing_blocks_are_in_error(small_batch, tmp_path):
    """A block in error (RO-1 cannot be judged: block.yaml gives no MS GSD) is counted among
    those that fail; the last line read '3 blocks: 1 pass, 2 fail, 0 unreadable' beside one
    FAIL and one ERROR line. It now says which share is in error."""
    manifest = small_batch / "F1-B02" / "block.yaml"
    manifest.write_text(manifest.read_text(encoding="utf-8").replace("  ms: 2.6\n", ""), "utf-8")
    proc = run_blockqc("inspect", small_batch, "--out", tmp_path / "out", "--pdf", "none")
    assert proc.returncode == 2, proc.stderr
    assert "F1-B02       ERROR" in proc.stdout and "F3-B02       FAIL" in proc.stdout
    said = "3 blocks: 1 pass, 2 fail (of which 1 ERROR: a rule could not be judged), 0 unreadable"
    assert said in proc.stdout


def test_an_unreadable_delivery_says_nothing_was_written(tmp_path: Path):
    bad = tmp_path / "bad"
    shutil.copytree(SAMPLES / "batch" / "F1-B02", bad)
    (bad / "scenes.csv").unlink()
    proc = run_blockqc("inspect", bad, "--out", tmp_path / "out", "--no-pdf")
    assert proc.returncode == 2
    assert "nothing was written" in proc.stderr and "scenes" in proc.stderr


class _Backwards(batch.Runner):
    """Runs the jobs last first: blocks finishing in another order than the batch's, as those
    of a `--jobs` or Dask run do."""

    def run(self, job, todo, done) -> None:
        for p, m in reversed(todo):
            done(job(p, m))


def test_the_summary_lists_blocks_in_the_batchs_order_whatever_order_they_finish(
    small_batch, tmp_path
):
    """The console says each block as it finishes (progress); summary.json, .csv and .parquet
    list the blocks in the batch's order (its sub-folders sorted) however they finished."""
    import pyarrow.parquet as pq

    pack = load_pack("global-project")
    files = {}
    for name, runner in (("forwards", batch.Runner()), ("backwards", _Backwards())):
        said: list[str] = []
        out = tmp_path / name
        batch.run(
            batch.collect([small_batch]), pack, batch.Writer(out, pdf="none"), runner=runner,
            progress=lambda o, said=said: said.append(o.entry.block_id),
        )  # fmt: skip
        blocks = json.loads((out / "summary.json").read_text(encoding="utf-8"))["blocks"]
        assert [b["block_id"] for b in blocks] == ["F1-B02", "F3-B02", "F4-B02"]
        rows = pq.read_table(out / "summary.parquet").column("block_id").to_pylist()
        assert rows == ["F1-B02", "F3-B02", "F4-B02"]
        files[name] = (said, (out / "summary.csv").read_bytes())
    assert files["backwards"][0] == ["F4-B02", "F3-B02", "F1-B02"]
    assert files["backwards"][1] == files["forwards"][1]


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


def test_batch_folder_without_block_yaml_is_refused_by_name(small_batch: Path, tmp_path: Path):
    """Every sub-folder of a batch is a delivery: one without block.yaml is reported, never
    left out unseen; the others are inspected. A file beside them is named in a warning;
    hidden folders are not part of the batch."""
    forgot = small_batch / "F2-B02"
    shutil.copytree(SAMPLES / "batch" / "F2-B02", forgot)
    (forgot / "block.yaml").unlink()
    (small_batch / ".cache").mkdir()
    (small_batch / "transmittal.txt").write_text("3 blocks\n", encoding="utf-8")
    out = tmp_path / "out"
    proc = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf")
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{forgot / 'block.yaml'}: missing: every sub-folder of a batch is a delivery" in (
        proc.stderr
    )
    assert f"warning: {small_batch / 'transmittal.txt'}: a file beside the deliveries" in (
        proc.stderr
    )
    assert ".cache" not in proc.stderr + proc.stdout
    assert f"{forgot}  UNREADABLE" in proc.stdout
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [b["block_id"] for b in summary["blocks"]] == ["F1-B02", "F3-B02", "F4-B02"]


def test_links_of_a_batch_that_loop_are_refused_by_name(small_batch: Path, tmp_path: Path):
    """Two links of the batch leading to each other stopped the whole batch with 'error:
    Symlink loop from …' and no block inspected, where a link to nothing is refused alone.
    Each is now refused by name, as a link to nothing is, and the deliveries are inspected."""
    (small_batch / "A-link").symlink_to("B-link")
    (small_batch / "B-link").symlink_to("A-link")
    out = tmp_path / "out"
    proc = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    assert proc.returncode == 2, proc.stderr
    for name, other in (("A-link", "B-link"), ("B-link", "A-link")):
        assert (
            f"error: {small_batch / name}: a symbolic link to {other}, which leads back to "
            "itself (a loop): a delivery of the batch moved or removed?"
        ) in proc.stderr
    assert "Symlink loop" not in proc.stderr
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [b["block_id"] for b in summary["blocks"]] == ["F1-B02", "F3-B02", "F4-B02"]
    assert [u["path"] for u in summary["unreadable"]] == [
        str(small_batch / "A-link"),
        str(small_batch / "B-link"),
    ]
    again = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    assert again.returncode == 2 and again.stdout.count("outputs reused") == 3, again.stderr


def test_a_batch_inside_the_batch_is_said_to_be_one(small_batch: Path, tmp_path: Path):
    """A sub-folder without block.yaml whose own sub-folders are deliveries: refused as before,
    and said to be a batch whose deliveries are not inspected."""
    inner = small_batch / "resubmitted"
    for name in ("F2-B02", "F2-B01", "F1-B01", "F4-B01"):
        shutil.copytree(SAMPLES / "batch" / name, inner / name)
    proc = run_blockqc("inspect", small_batch, "--out", tmp_path / "out", "--no-pdf")
    assert proc.returncode == 2, proc.stderr
    assert (
        f"{inner / 'block.yaml'}: missing: every sub-folder of a batch is a delivery and needs its "
        "block.yaml (folders named '.…' are left out); it holds deliveries (F1-B01, F2-B01, "
        "F2-B02 and 1 more): a batch inside the batch, whose deliveries are not inspected; give "
        "it as a batch of its own"
    ) in proc.stderr


@pytest.mark.parametrize(
    ("address", "says"),
    [
        ("bogus", "expected 'local' or tcp|tls|ws|wss|ucx://HOST:PORT"),
        ("", "expected 'local' or tcp|tls|ws|wss|ucx://HOST:PORT"),
        ("inproc://x", "expected 'local' or tcp|tls|ws|wss|ucx://HOST:PORT"),
        ("tcp://", "expected HOST:PORT after the scheme"),
        ("tcp://:8786", "expected HOST:PORT after the scheme"),
        ("tcp://localhost:abc", "the port 'abc' is not a number from 1 to 65535"),
        ("tcp://localhost:65536", "the port '65536' is not a number from 1 to 65535"),
    ],
)
def test_scheduler_address_refused_before_anything_runs(
    small_batch: Path, tmp_path: Path, address: str, says: str
):
    out = tmp_path / "out"
    proc = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf", "--scheduler", address)
    assert proc.returncode == 2
    shown = address or "''"  # an empty address is refused, not read as no --scheduler
    assert f"--scheduler {shown}: {says}" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists() or not any(out.iterdir())


def test_a_scheduler_that_does_not_answer_leaves_the_earlier_summary_in_place(
    small_batch, tmp_path
):
    """Nothing answering at the address was found once the run had set the earlier run's
    summary aside: exit 2, and the batch's summary gone from the output folder although no
    block was touched. It is now refused before anything of the folder is set aside."""
    pytest.importorskip("dask.distributed")
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    before = {q: q.read_bytes() for q in out.rglob("*") if q.is_file()}
    p = run_blockqc(
        "inspect", small_batch, "--out", out, "--no-pdf", "--scheduler", "tcp://127.0.0.1:1"
    )
    assert p.returncode == 2 and "no scheduler answers there" in p.stderr, p.stderr
    assert "earlier run's batch summary is kept" not in p.stderr
    assert {q: q.read_bytes() for q in out.rglob("*") if q.is_file()} == before


class _Service:
    """A TCP service on a free port of this machine that is no Dask scheduler: it writes
    `greeting` to each client that connects (nothing: it waits, as a web server does)."""

    def __init__(self, greeting: bytes):
        import threading

        self.server = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.server.getsockname()[1]}"
        self.greeting, self.clients = greeting, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        with suppress(OSError):
            while True:
                client, _ = self.server.accept()
                self.clients.append(client)
                client.sendall(self.greeting)

    def close(self) -> None:
        for client in self.clients:
            client.close()
        self.server.close()


def test_a_service_that_is_no_scheduler_is_refused_at_once(small_batch, tmp_path):
    """--scheduler naming a port where another service answers: the client read the service's
    text as the length of a message and stopped with 'internal error: MemoryError: Unable to
    allocate 3.07 EiB'; a web server (the dashboard's port) kept it waiting for ever. Both are
    refused before anything runs (exit 2), naming the address."""
    pytest.importorskip("dask.distributed")
    service = _Service(b"HTTP/1.1 400 Bad Request\r\n\r\n")
    try:
        out = tmp_path / "out"
        args = ("inspect", small_batch, "--out", out, "--no-pdf", "--scheduler", service.address)
        proc = run_blockqc(*args)
    finally:
        service.close()
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == (
        f"error: --scheduler {service.address}: something answers there, but no Dask "
        "scheduler (it began b'HTTP/1.1')\n"
    )
    assert not out.exists()


def test_a_silent_service_is_no_scheduler(monkeypatch):
    from blockqc import distributed
    from blockqc.errors import UsageError

    monkeypatch.setattr(distributed, "GREETING_S", 0.5)
    service = _Service(b"")
    try:
        with pytest.raises(UsageError) as exc:
            distributed.check_reachable(service.address)
    finally:
        service.close()
    assert str(exc.value) == (
        f"--scheduler {service.address}: something answers there, but no Dask scheduler: it "
        "said nothing within 0.5 s, where a scheduler greets a client at once (the dashboard's "
        "port, 8787, for the scheduler's, 8786?)"
    )


def test_scheduler_addresses_accepted():
    from blockqc.distributed import check_scheduler

    for address in ("local", "tcp://10.0.0.5:8786", "tls://[::1]:8786", "ws://host.example:1"):
        assert check_scheduler(address) == address


@pytest.mark.parametrize("broken", ["[1, 2]", "{", '{"key": 3}', '"text"', "\udcff"])
def test_incremental_broken_caches_mean_inspect_again(
    small_batch: Path, tmp_path: Path, broken: str
):
    """A block's or the summary's cache file that is not what blockqc wrote (any JSON, or none)
    is no cache: the block is inspected and the summary written again, never a traceback."""
    out = tmp_path / "out"
    args = ("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    assert run_blockqc(*args).returncode == 1
    data = broken.encode("utf-8", "surrogateescape")
    (out / "F1-B02" / ".blockqc-cache.json").write_bytes(data)
    (out / ".blockqc-summary-cache.json").write_bytes(data)
    summary_before = (out / "summary.json").stat().st_mtime_ns
    again = run_blockqc(*args)
    assert again.returncode == 1 and "Traceback" not in again.stderr, again.stderr
    assert again.stdout.count("outputs reused") == 2, again.stdout
    assert "F1-B02       PASS" in again.stdout
    cache = str(out / "F1-B02" / ".blockqc-cache.json")
    assert f"warning: {cache}: " in again.stderr  # said, not silent
    assert "not trusted, the block was inspected again" in again.stderr
    assert (out / "summary.json").stat().st_mtime_ns != summary_before
    assert run_blockqc(*args).stdout.count("outputs reused") == 3  # caches written afresh


def _edit_cache(cache: dict, edit: str) -> None:
    if edit == "verdict":  # the failing block's line made to pass
        cache["entry"].update(verdict="pass", failed_rules=[])
    elif edit == "count":
        cache["rules"]["RO-3"]["fail"] = "1"
    else:
        cache["errors"] = 5


@pytest.mark.parametrize("edit", ["verdict", "count", "errors"])
def test_incremental_cache_edited_by_hand_is_not_trusted(small_batch, tmp_path, edit):
    """A block's cache whose line was edited (its key kept) is no cache: the block is inspected
    again, as a fresh run inspects it; it was taken as written (a failing block said to pass,
    exit 0), or stopped the run (a count or its errors of another type: an internal error)."""
    out, fresh = tmp_path / "out", tmp_path / "fresh"
    assert _incremental(small_batch, out).returncode == 1
    path = out / "F3-B02" / ".blockqc-cache.json"
    cache = json.loads(path.read_text(encoding="utf-8"))
    _edit_cache(cache, edit)
    path.write_text(json.dumps(cache), encoding="utf-8")
    again = _incremental(small_batch, out)
    assert again.returncode == 1 and "error" not in again.stderr, again.stderr
    assert again.stdout.count("outputs reused") == 2 and "F3-B02       FAIL" in again.stdout
    assert f"warning: {path}: edited since it was written" in again.stderr, again.stderr
    assert run_blockqc("inspect", small_batch, "--out", fresh, "--no-pdf").returncode == 1

    def blocks(folder: Path) -> list[dict]:
        return json.loads((folder / "summary.json").read_text(encoding="utf-8"))["blocks"]

    assert blocks(out) == blocks(fresh)
    assert _incremental(small_batch, out).stdout.count("outputs reused") == 3


def test_incremental_summary_rewritten_when_an_acceptance_page_is_gone(
    small_batch: Path, tmp_path: Path
):
    """The summary's cache vouches for every file written from it: the acceptance pages too."""
    out = tmp_path / "out"
    args = ("inspect", small_batch, "--out", out, "--no-pdf", "--incremental")
    assert run_blockqc(*args).returncode == 1
    assert (out / "acceptance.html").is_file()
    (out / "acceptance.html").unlink()
    assert run_blockqc(*args).stdout.count("outputs reused") == 3
    assert (out / "acceptance.html").is_file()


def test_incremental_summary_follows_where_the_plan_differs_from_the_batch(small_batch, tmp_path):
    """A plan drawn on a batch folder of another name is noted in the summary when the folder
    is inspected, not when its deliveries are named one by one: the same deliveries, whose
    outputs are reused, but not the same summary."""
    plan, lot = tmp_path / "plan.yaml", tmp_path / "lot7"
    assert run_blockqc("sample", small_batch, "--seed", 1, "--out", plan).returncode == 0
    small_batch.rename(lot)
    out, fresh = tmp_path / "out", tmp_path / "fresh"
    args = ("--no-pdf", "--plan", plan)
    assert run_blockqc("inspect", lot, "--out", out, "--incremental", *args).returncode == 1
    one_by_one = sorted(lot.iterdir())
    again = run_blockqc("inspect", *one_by_one, "--out", out, "--incremental", *args)
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 3, again.stdout
    assert run_blockqc("inspect", *one_by_one, "--out", fresh, *args).returncode == 1

    def notes(folder: Path) -> list[dict]:
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
        return summary["acceptance"]["plan_notes"]

    assert notes(out) == notes(fresh) == []
    assert run_blockqc("inspect", lot, "--out", out, "--incremental", *args).returncode == 1
    assert [n["about"] for n in notes(out)] == ["batch"]


def _inspector_checkpoints(path: Path, blocks: list[str], last: str = "0") -> Path:
    """The first five checkpoints of each sample block as the inspector's (recalculation); the
    last block's first x_m ends in `last` (one digit: the file keeps its size)."""
    rows = []
    for block in blocks:
        lines = (SAMPLES / "batch" / block / "checkpoints.csv").read_text("utf-8").splitlines()
        rows[:1] = [lines[0] + ",block_id"]
        for line in lines[1:6]:
            point, _, *values = line.split(",")
            rows.append(",".join([f"R-{point}", "recalculation", *values, block]))
    point, method, ref, x, *rest = rows[-5].split(",")
    rows[-5] = ",".join([point, method, ref, x[:-1] + last, *rest])
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_incremental_inspector_checkpoints_of_one_block_changed(tmp_path):
    """The inspector's checkpoint file changed in one block's rows: that block is inspected
    again, the others' outputs reused (every block was inspected again)."""
    batch_dir, out, fresh = tmp_path / "batch", tmp_path / "out", tmp_path / "fresh"
    for block in ("F1-B01", "F1-B02", "F3-B01"):
        shutil.copytree(SAMPLES / "batch" / block, batch_dir / block)
    cps = _inspector_checkpoints(tmp_path / "cps.csv", ["F1-B01", "F3-B01"], "1")
    assert _incremental(batch_dir, out, "--checkpoints", cps).returncode == 1
    size = cps.stat().st_size
    _inspector_checkpoints(cps, ["F1-B01", "F3-B01"], "7")
    assert cps.stat().st_size == size
    again = _incremental(batch_dir, out, "--checkpoints", cps)
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 2, again.stdout
    lines = again.stdout.splitlines()[:-1]  # the blocks' lines, not the batch's
    assert [line.split()[0] for line in lines if "reused" not in line] == ["F3-B01"]
    fresh_run = run_blockqc("inspect", batch_dir, "--out", fresh, "--no-pdf", "--checkpoints", cps)
    assert fresh_run.returncode == 1
    for name in ("F3-B01/checkpoints.csv", "F1-B01/checkpoints.csv", "summary.csv"):
        assert (out / name).read_text("utf-8") == (fresh / name).read_text("utf-8"), name
    without = _incremental(batch_dir, out)  # F1-B02 has no rows: it was inspected as without
    assert without.stdout.count("outputs reused") == 1, without.stdout


def test_incremental_plan_changed_inspects_the_blocks_it_samples_otherwise(tmp_path):
    """Another plan: the blocks sampled by one plan and not the other are inspected again, those
    it samples or leaves as before are not (every block was), and the summary follows it."""
    import yaml

    out, fresh = tmp_path / "out", tmp_path / "fresh"
    batch_dir = shutil.copytree(SAMPLES / "batch", tmp_path / "batch")
    plans = [tmp_path / "p1.yaml", tmp_path / "p2.yaml"]
    for seed, plan in enumerate(plans, 1):
        assert run_blockqc("sample", batch_dir, "--seed", seed, "--out", plan).returncode == 0
    first, second = ({*yaml.safe_load(p.read_text("utf-8"))["sampled"]} for p in plans)
    assert first != second
    assert _incremental(batch_dir, out, "--plan", plans[0]).returncode == 1
    again = _incremental(batch_dir, out, "--plan", plans[1])
    lines = again.stdout.splitlines()[:-1]  # the blocks' lines, not the batch's
    inspected = {line.split()[0] for line in lines if "reused" not in line}
    assert inspected == first ^ second, again.stdout
    fresh_run = run_blockqc("inspect", batch_dir, "--out", fresh, "--no-pdf", "--plan", plans[1])
    assert fresh_run.returncode == 1
    for name in ("summary.json", *(f"{b}/results.json" for b in ("F1-B01", "F3-B01"))):
        got, want = (json.loads((f / name).read_text("utf-8")) for f in (out, fresh))
        assert {**got, "generated_at": ""} == {**want, "generated_at": ""}, name


@pytest.mark.parametrize("name", ["summary.json", "summary.html", "acceptance.html"])
def test_incremental_summary_rewritten_when_an_output_is_cut(small_batch, tmp_path, name):
    """A summary output cut short (a copy or a disk that failed) is written again, as a block's
    are: the summary's cache vouches for the size of every file written from it."""
    out, fresh = tmp_path / "out", tmp_path / "fresh"
    args = ("inspect", small_batch, "--no-pdf")
    assert run_blockqc(*args, "--out", out, "--incremental").returncode == 1
    cut = (out / name).read_bytes()[:100]
    (out / name).write_bytes(cut)
    again = run_blockqc(*args, "--out", out, "--incremental")
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 3, again.stdout
    assert run_blockqc(*args, "--out", fresh).returncode == 1
    assert (out / name).stat().st_size == (fresh / name).stat().st_size > len(cut)


def test_dask_block_of_a_worker_that_dies_runs_again(tmp_path: Path):
    """A worker process that dies in the middle of a block (killed, out of memory) takes no
    block with it: the scheduler gives the block to a worker again, and every outcome arrives."""
    from blockqc.distributed import run_on_dask

    marker = tmp_path / "died-once"

    def job(path: Path, manifest: object) -> str:
        import os

        if path.name == "B" and not marker.exists():
            marker.write_text("the worker died here", encoding="utf-8")
            os._exit(1)
        return path.name

    got: list[str] = []
    run_on_dask("local", job, [(tmp_path / name, None) for name in "ABC"], got.append)
    assert marker.exists() and sorted(got) == ["A", "B", "C"]


def test_dask_block_whose_workers_all_die_is_not_inspected_and_the_others_go_on(tmp_path):
    """A block that kills every worker that runs it (out of memory each time): the scheduler
    gives up on it (KilledWorker), which stopped the whole run as an internal error, with no
    summary. It is now recorded as not inspected, as with --jobs, and the others go on."""
    pytest.importorskip("dask.distributed")

    def job(path: Path, manifest: object) -> str:
        import os

        if path.name == "B":
            os._exit(1)
        return path.name

    got: list = []
    todo = [(tmp_path / name, None) for name in "ABC"]
    batch.Runner(scheduler="local").run(job, todo, got.append)
    assert sorted(o for o in got if isinstance(o, str)) == ["A", "C"]
    (lost,) = [o for o in got if isinstance(o, batch.Outcome)]
    assert lost.path == tmp_path / "B" and lost.entry is None
    assert lost.problems[0].message == (
        "could not be inspected: every worker that ran it died (killed, or out of memory)"
    )


def test_a_scheduler_whose_workers_run_elsewhere_gets_the_paths_of_the_deliveries(
    small_batch, tmp_path
):
    """A batch named by a relative path (`blockqc inspect batch --scheduler tcp://…`): the
    workers, started in folders of their own, looked for it there, and every delivery was
    unreadable ("No such file or directory: 'batch/F1-B02'"). They now get its full path."""
    distributed = pytest.importorskip("dask.distributed")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    with distributed.LocalCluster(
        n_workers=0, processes=False, protocol="tcp", dashboard_address=":0"
    ) as cluster:
        worker = subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", cluster.scheduler_address,
             "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
            cwd=elsewhere, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        try:
            with distributed.Client(cluster) as client:
                client.wait_for_workers(1, timeout=60)
            p = run_blockqc(
                "inspect", small_batch.name, "--out", "out", "--no-pdf",
                "--scheduler", cluster.scheduler_address, cwd=small_batch.parent,
            )  # fmt: skip
        finally:
            worker.terminate()
            worker.wait(timeout=60)
    assert p.returncode == 1 and "UNREADABLE" not in p.stdout, p.stdout + p.stderr
    doc = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert sorted(b["path"] for b in doc["blocks"]) == [
        str(small_batch / name) for name in ("F1-B02", "F3-B02", "F4-B02")
    ]


def test_dask_block_that_raises_once_is_retried(tmp_path: Path):
    """A task that raises (a file briefly unreachable on the shared disk) is retried."""
    from blockqc.distributed import run_on_dask

    marker = tmp_path / "raised-once"

    def job(path: Path, manifest: object) -> str:
        if not marker.exists():
            marker.write_text("raised", encoding="utf-8")
            raise OSError("the shared disk did not answer")
        return path.name

    got: list[str] = []
    run_on_dask("local", job, [(tmp_path / "A", None)], got.append)
    assert got == ["A"]


def _ctrl_c_here(path: Path, manifest: object) -> str:
    """What a Ctrl-C sent to the worker process running this task would do there."""
    import signal

    return "ignored" if signal.getsignal(signal.SIGINT) == signal.SIG_IGN else "raised"


def test_ctrl_c_reaching_a_local_dask_worker_is_left_to_the_main_process(tmp_path: Path):
    """Ctrl-C in a terminal during a `--scheduler local` run reaches the cluster's worker
    processes too: each printed 'Process Dask Worker process (from Nanny): Traceback …
    KeyboardInterrupt' over the console. They now leave it to blockqc's process."""
    from blockqc.distributed import run_on_dask

    got: list[str] = []
    run_on_dask("local", _ctrl_c_here, [(tmp_path / "A", None)], got.append)
    assert got == ["ignored"]


def _waits_for(marker: Path, name: str):
    def job(path: Path, manifest: object) -> str:
        import time

        for _ in range(100):  # at most 10 s
            if marker.exists():
                break
            time.sleep(0.1)
        return f"{name}:{path.name}"

    return job


def test_dask_runs_sharing_a_scheduler_get_their_own_outcomes(tmp_path: Path):
    """Two runs on one scheduler (two inspectors' batches on a shared cluster): every task was
    keyed inspect-0, inspect-1 …, and a run submitting a key the scheduler held got the other
    run's outcome, its block line in place of its own. Each run's tasks are now its own."""
    import threading
    import time

    from blockqc.distributed import run_on_dask

    LocalCluster = pytest.importorskip("dask.distributed").LocalCluster
    marker = tmp_path / "second-run-done"
    first: list[str] = []
    second: list[str] = []
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        address = cluster.scheduler_address
        job = _waits_for(marker, "first")
        todo = [(tmp_path / "F1-B01", None)]
        running = threading.Thread(target=run_on_dask, args=(address, job, todo, first.append))
        running.start()
        try:
            time.sleep(1)  # the first run's task is on the scheduler
            run_on_dask(
                address, lambda p, m: f"second:{p.name}", [(tmp_path / "F2-B01", None)],
                second.append,
            )  # fmt: skip
        finally:
            marker.write_text("done", encoding="utf-8")
            running.join()
    assert second == ["second:F2-B01"] and first == ["first:F1-B01"]


def test_a_report_failing_after_results_json_leaves_no_results(small_batch, tmp_path, monkeypatch):
    """results.json is written before the report: when the report fails, results.json goes too,
    so that no block folder holds results without their report."""

    def broken(folder, results, **kwargs):
        raise RuntimeError("simulated report defect")

    monkeypatch.setattr(batch, "write_block_report", broken)
    got = batch.collect([small_batch / "F1-B02"])
    with pytest.raises(OutputError, match="simulated report defect"):  # no fault of the delivery
        batch.run(got, load_pack("global-project"), batch.Writer(tmp_path / "out"))
    assert not (tmp_path / "out" / "F1-B02").exists()


def test_an_unreadable_block_leaves_no_earlier_results_behind(small_batch: Path, tmp_path: Path):
    """A block read and passed, then broken: its earlier outputs are removed, so that no
    results.json says pass for a delivery that could not be inspected; other files stay."""
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    (out / "F1-B02" / "notes.txt").write_text("the inspector's own file")
    tie_points = small_batch / "F1-B02" / "tie_points.csv"
    lines = tie_points.read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    cells = lines[1].split(",")
    cells[header.index("v_line")] = "abc"
    tie_points.write_text("\n".join([lines[0], ",".join(cells), *lines[2:]]) + "\n")
    again = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf")
    assert again.returncode == 2 and "tie_points.csv" in again.stderr
    assert sorted(p.name for p in (out / "F1-B02").iterdir()) == ["notes.txt"]
    assert (out / "F4-B02" / "results.json").is_file()


def _incremental(small_batch: Path, out: Path, *extra: object):
    return run_blockqc("inspect", small_batch, "--out", out, "--no-pdf", "--incremental", *extra)


def test_incremental_key_holds_the_packs_columns_and_the_inspectors_name(small_batch, tmp_path):
    out = tmp_path / "out"
    verdicts = tmp_path / "v.yaml"
    verdicts.write_text("inspector: Li Wei\n", encoding="utf-8")
    assert _incremental(small_batch, out, "--verdicts", verdicts).returncode == 1
    verdicts.write_text("inspector: Zhang San\n", encoding="utf-8")
    again = _incremental(small_batch, out, "--verdicts", verdicts)
    assert again.stdout.count("outputs reused") == 0, again.stdout  # every report names him
    results = json.loads((out / "F1-B02" / "results.json").read_text(encoding="utf-8"))
    assert "Zhang San" in json.dumps(results)
    pack = tmp_path / "p.yaml"
    pack.write_text("pack: p\nversion: '1'\nextends: global-project\n", encoding="utf-8")
    args = ("--verdicts", verdicts, "--rules", pack)
    assert _incremental(small_batch, out, *args).stdout.count("outputs reused") == 0
    assert _incremental(small_batch, out, *args).stdout.count("outputs reused") == 3
    pack.write_text(pack.read_text(encoding="utf-8") + "columns: used\n", encoding="utf-8")
    assert _incremental(small_batch, out, *args).stdout.count("outputs reused") == 0


def test_incremental_delivery_named_by_another_path_is_written_again(small_batch, tmp_path):
    """The outputs record each delivery's path as given: the batch named by a relative path
    after an absolute one writes what a fresh run writes, never the earlier path."""
    out, fresh = tmp_path / "out", tmp_path / "fresh"
    assert _incremental(small_batch, out).returncode == 1
    relative = ("inspect", "batch", "--no-pdf")
    again = run_blockqc(*relative, "--out", out, "--incremental", cwd=tmp_path)
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 0, again.stdout
    assert run_blockqc(*relative, "--out", fresh, cwd=tmp_path).returncode == 1

    def paths(folder: Path) -> list[str]:
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
        block = json.loads((folder / "F1-B02" / "results.json").read_text(encoding="utf-8"))
        return [b["path"] for b in summary["blocks"]] + [block["delivery"]]

    expected = ["batch/F1-B02", "batch/F3-B02", "batch/F4-B02", "batch/F1-B02"]
    assert paths(out) == paths(fresh) == expected
    assert (out / "summary.csv").read_text("utf-8") == (fresh / "summary.csv").read_text("utf-8")


def test_incremental_pdf_engine_without_pdfs_reuses_the_outputs(small_batch, tmp_path):
    """--pdf-engine with no PDF written changes no output (it is said to be unused): every
    block's outputs are reused (every block was inspected again)."""
    out = tmp_path / "out"
    assert _incremental(small_batch, out).returncode == 1
    again = _incremental(small_batch, out, "--pdf-engine", "chromium")
    assert "--pdf-engine chromium: not used" in again.stderr
    assert again.returncode == 1 and again.stdout.count("outputs reused") == 3, again.stdout


@pytest.mark.parametrize("change", ["truncate results.json", "delete evidence.csv"])
def test_incremental_block_with_an_output_cut_or_gone_is_written_again(
    small_batch, tmp_path, change
):
    out = tmp_path / "out"
    assert _incremental(small_batch, out).returncode == 1
    verb, name = change.split()
    if verb == "truncate":
        (out / "F4-B02" / name).write_text('{"trunc', encoding="utf-8")
    else:
        (out / "F4-B02" / name).unlink()
    again = _incremental(small_batch, out)
    assert again.stdout.count("outputs reused") == 2, again.stdout
    why = "changed since written: results.json" if verb == "truncate" else "an output is gone"
    assert f"warning: {out / 'F4-B02'}: {why}" in again.stderr, again.stderr
    assert json.loads((out / "F4-B02" / "results.json").read_text("utf-8"))["verdict"] == "pass"
    assert (out / "F4-B02" / "evidence.csv").is_file()


def test_a_run_stopped_while_writing_leaves_no_key_vouching_for_it(
    small_batch, tmp_path, monkeypatch
):
    """Stopped (Ctrl-C) between results.json and the report: the block's and the summary's
    keys are gone, so the next incremental run writes both again."""
    out = tmp_path / "out"
    pack = load_pack("global-project")
    got = batch.collect([small_batch])
    batch.run(got, pack, batch.Writer(out, pdf="none"), incremental=True)
    assert (out / "F1-B02" / ".blockqc-cache.json").is_file()
    tie_points = small_batch / "F1-B02" / "tie_points.csv"
    tie_points.write_text(tie_points.read_text(encoding="utf-8") + "\n", encoding="utf-8")

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "write_block_report", stopped)
    with pytest.raises(KeyboardInterrupt):
        batch.run(
            batch.collect([small_batch]), pack, batch.Writer(out, pdf="none"), incremental=True
        )
    assert not (out / "F1-B02" / ".blockqc-cache.json").exists()
    assert not (out / ".blockqc-summary-cache.json").exists()


def test_a_block_yaml_edited_while_the_batch_runs_is_inspected_again(small_batch, tmp_path):
    """A batch reads every block.yaml before its first block: F4-B02's reported tie-point
    error edited from 0.33 to 0.05 px meanwhile, its results were made from 0.33 under a key
    of the edited file, and the next incremental run reused them (DOC-2 passing a figure the
    block.yaml no longer gives). The key holds block.yaml as read: the block is inspected
    again, with 0.05."""
    out = tmp_path / "out"
    got = batch.collect([small_batch])  # every block.yaml read here
    manifest = small_batch / "F4-B02" / "block.yaml"
    text = manifest.read_text(encoding="utf-8")
    assert "tie_point_error_px: 0.33\n" in text
    edited = text.replace("tie_point_error_px: 0.33", "tie_point_error_px: 0.05")
    manifest.write_text(edited, encoding="utf-8")
    batch.run(got, load_pack("global-project"), batch.Writer(out, pdf="none"), incremental=True)
    again = _incremental(small_batch, out)
    lines = [line for line in again.stdout.splitlines() if line.startswith("F4-B02")]
    assert lines and "outputs reused" not in lines[0], again.stdout
    results = json.loads((out / "F4-B02" / "results.json").read_text(encoding="utf-8"))
    figures = [
        row
        for m in results["measurements"]
        for row in (m.get("tables") or {}).get("figure", [])
        if row.get("reported") is not None
    ]
    assert 0.05 in [row["reported"] for row in figures] and 0.33 not in [
        row["reported"] for row in figures
    ]


def test_incremental_runs_key_a_block_yaml_of_any_yaml_values(small_batch, tmp_path):
    """Keys no rule reads may hold what YAML reads besides text and numbers: bytes that are not
    UTF-8 (!!binary "/w==" is 0xFF), a set, a date. The block was refused in incremental runs
    (UnicodeDecodeError while keying its block.yaml); it is inspected, and a re-run reuses it
    (the set's order, which changes from one process to the next, does not change its key)."""
    out = tmp_path / "out"
    manifest = small_batch / "F1-B02" / "block.yaml"
    extra = 'label: !!binary "/w=="\ntags: !!set {west, east, north}\ndelivered: 2024-05-01\n'
    manifest.write_text(manifest.read_text(encoding="utf-8") + extra, encoding="utf-8")
    first = _incremental(small_batch, out)
    assert first.returncode == 1, first.stderr  # F3-B02 fails RO-3, as without the keys
    assert "UNREADABLE" not in first.stdout and (out / "F1-B02" / "results.json").is_file()
    again = _incremental(small_batch, out)
    assert again.stdout.count("outputs reused") == 3, again.stdout


def test_summary_pdf_of_an_earlier_run_is_removed(small_batch: Path, tmp_path: Path):
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--pdf", "failing").returncode == 1
    assert (out / "summary.pdf").is_file() and (out / "acceptance.pdf").is_file()
    assert run_blockqc("inspect", small_batch, "--out", out, "--pdf", "none").returncode == 1
    assert not (out / "summary.pdf").exists() and not (out / "acceptance.pdf").exists()
    assert not (out / "F3-B02" / "report.pdf").exists()


def test_a_delivery_whose_block_yaml_went_leaves_no_earlier_results(small_batch, tmp_path):
    """Its block id is found by its path in the last summary: its outputs are removed."""
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    (small_batch / "F1-B02" / "block.yaml").unlink()
    again = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf")
    assert again.returncode == 2 and "F1-B02" in again.stderr
    assert not (out / "F1-B02").exists()
    assert (out / "F4-B02" / "results.json").is_file()


def test_a_delivery_whose_block_yaml_went_after_a_stopped_run_leaves_no_earlier_results(
    small_batch, tmp_path
):
    """The last summary set aside by a run that stopped half-way: the block id was looked for
    in <out>/summary.json only, not found, and the block's earlier results.json was left (its
    pass taken for the unreadable delivery's). The summary set aside is read too."""
    from blockqc.outputs import set_aside_summary

    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    set_aside_summary(out)  # as a run stopped while writing the blocks leaves it
    (small_batch / "F1-B02" / "block.yaml").unlink()
    again = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf")
    assert again.returncode == 2 and "F1-B02" in again.stderr
    assert not (out / "F1-B02").exists()
    assert (out / "F4-B02" / "results.json").is_file()


def test_a_block_inspected_alone_removes_the_batch_summary_that_lists_it(small_batch, tmp_path):
    """The summary would go on giving the block's earlier verdict beside its new results."""
    out = tmp_path / "out"
    assert _incremental(small_batch, out).returncode == 1
    manifest = small_batch / "F1-B02" / "block.yaml"
    text = manifest.read_text(encoding="utf-8")
    manifest.write_text(text.replace("tie_point_error_px: 0.", "tie_point_error_px: 9."))
    alone = run_blockqc("inspect", small_batch / "F1-B02", "--out", out, "--no-pdf")
    assert alone.returncode == 1, alone.stderr  # DOC-2 now fails
    assert f"{out / 'summary.json'}" in alone.stderr and "F1-B02" in alone.stderr
    assert not [p.name for p in out.iterdir() if p.name.startswith(("summary", "acceptance"))]
    assert not (out / ".blockqc-summary-cache.json").exists()
    assert (out / "F4-B02" / "results.json").is_file()


def test_a_block_inspected_alone_keeps_a_summary_that_does_not_list_it(small_batch, tmp_path):
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    other = shutil.copytree(SAMPLES / "batch" / "F2-B02", tmp_path / "F2-B02")
    alone = run_blockqc("inspect", other, "--out", out, "--no-pdf")
    assert alone.returncode == 0, alone.stderr
    assert (out / "summary.json").is_file() and "summary" not in alone.stderr


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_file_where_a_block_folder_goes_stops_the_batch_blaming_no_delivery(
    small_batch, tmp_path, jobs
):
    """The outputs of a block cannot be written: the run stops (exit 2) naming the folder. The
    delivery is not listed as unreadable (the filed report would return it to its producer),
    and no summary presents the blocks written before as the batch."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "F1-B02").write_text("not a folder", encoding="utf-8")
    p = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf", "--jobs", jobs)
    assert p.returncode == 2 and "internal error" not in p.stderr, p.stderr
    assert f"{out / 'F1-B02'}: the outputs of block F1-B02 could not be written" in p.stderr
    assert "UNREADABLE" not in p.stdout + p.stderr
    assert not (out / "summary.json").exists()
    assert (out / "F1-B02").read_text(encoding="utf-8") == "not a folder"


class _DiesOn:
    """A job whose worker process dies on one block: once (a marker file left), or always."""

    def __init__(self, job: batch.Job, name: str, marker: Path | None):
        self.job, self.name, self.marker = job, name, marker
        self.writer = job.writer

    def __call__(self, path: Path, manifest=None):
        if path.name == self.name and (self.marker is None or not self.marker.exists()):
            if self.marker is not None:
                self.marker.write_text("died here", encoding="utf-8")
            os._exit(1)
        return self.job(path, manifest)


@pytest.mark.parametrize("dies", ["once", "always"])
def test_a_worker_process_that_dies_takes_no_other_block_with_it(small_batch, tmp_path, dies):
    got = batch.collect([small_batch])
    job = batch.Job(load_pack("global-project"), None, batch.Writer(tmp_path / "out", pdf="none"))
    marker = tmp_path / "died-once" if dies == "once" else None
    outcomes: list[batch.Outcome] = []
    todo = [(p, got.manifests.get(p)) for p in got.deliveries]
    batch.Runner(jobs=2).run(_DiesOn(job, "F3-B02", marker), todo, outcomes.append)
    by_name = {o.path.name: o for o in outcomes}
    assert sorted(by_name) == ["F1-B02", "F3-B02", "F4-B02"]
    assert by_name["F1-B02"].entry is not None and by_name["F4-B02"].entry is not None
    if dies == "once":
        assert by_name["F3-B02"].entry.verdict == "fail"  # RO-3, as published
    else:
        assert "died, again when it ran alone" in by_name["F3-B02"].problems[0].message
        assert not (tmp_path / "out" / "F3-B02").exists()


def test_a_second_run_into_the_same_output_folder_is_refused(tmp_path: Path):
    from blockqc.errors import UsageError
    from blockqc.outputs import LOCK_FILE, out_lock

    lock = tmp_path / LOCK_FILE
    running = f"{socket.gethostname()} {os.getppid()}"  # a process of this machine that runs
    lock.write_text(running, encoding="utf-8")
    with pytest.raises(UsageError, match="another blockqc run is writing into it"):
        with out_lock(tmp_path):
            pass
    assert lock.read_text(encoding="utf-8") == running  # its lock left as it was
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], text=True,
                           capture_output=True).stdout.split()[0]  # fmt: skip
    for stale in (ended, str(os.getpid())):  # ended; or this very number (a container restarted)
        lock.write_text(f"{socket.gethostname()} {stale}", encoding="utf-8")
        with out_lock(tmp_path):  # taken over
            assert lock.read_text(encoding="utf-8").endswith(f" {os.getpid()}")
        assert not lock.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no temporary lock left


@pytest.mark.parametrize("command", ["report", "factors"])
def test_report_and_factors_take_the_output_folders_lock(tmp_path: Path, command: str):
    """Not only inspect: a report re-rendered, or a factor analysis, into a folder another run
    is writing into is refused, nothing of it written there (they wrote beside it)."""
    from blockqc.outputs import LOCK_FILE

    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_FILE).write_text(f"{socket.gethostname()} {os.getppid()}", encoding="utf-8")
    if command == "report":
        first = tmp_path / "first"
        sample = SAMPLES / "batch" / "F1-B02"
        assert run_blockqc("inspect", sample, "--out", first, "--no-pdf").returncode == 0
        args = ["report", first, "--out", out, "--no-pdf"]
    else:
        table = SAMPLES / "factors" / "gf7_adjustment_experiments.csv"
        args = ["factors", "--table", table, "--out", out]
    p = run_blockqc(*args)
    assert p.returncode == 2 and "another blockqc run is writing into it" in p.stderr, p.stderr
    assert sorted(f.name for f in out.iterdir()) == [LOCK_FILE]


def test_outputs_of_a_withdrawn_delivery_are_said_and_not_rendered_again(
    small_batch: Path, tmp_path: Path
):
    """F4-B02 withdrawn between two runs into the same folder: its old outputs stay (never
    deleted) but are said, and `blockqc report OUT` renders the summary's blocks only."""
    out = tmp_path / "out"
    assert run_blockqc("inspect", small_batch, "--out", out, "--no-pdf").returncode == 1
    shutil.move(small_batch / "F4-B02", tmp_path / "F4-B02")
    again = run_blockqc("inspect", small_batch, "--out", out, "--no-pdf")
    assert again.returncode == 1
    assert f"warning: {out / 'F4-B02'}: outputs of block F4-B02, which this batch" in again.stderr
    assert (out / "F4-B02" / "results.json").is_file()
    rendered = tmp_path / "rendered"
    r = run_blockqc("report", out, "--out", rendered, "--no-pdf")
    assert r.returncode == 0, r.stderr
    assert f"warning: {out / 'F4-B02' / 'results.json'}: a block the summary" in r.stderr
    assert sorted(p.parent.name for p in rendered.glob("*/report.html")) == ["F1-B02", "F3-B02"]


def _earlier_run(small_batch: Path, out: Path) -> dict[str, bytes]:
    """A first run's outputs, with an earlier PDF beside F1-B02's results; their bytes."""
    got = batch.collect([small_batch])
    batch.run(got, load_pack("global-project"), batch.Writer(out, pdf="none"))
    (out / "F1-B02" / "report.pdf").write_bytes(b"%PDF-1.7 an earlier run's")
    (out / "F1-B02" / "notes.txt").write_text("the inspector's", encoding="utf-8")
    return {str(p.relative_to(out)): p.read_bytes() for p in out.rglob("*") if p.is_file()}


def test_a_run_stopped_half_way_leaves_no_summary_over_blocks_it_does_not_describe(
    small_batch, tmp_path, monkeypatch
):
    """Interrupted after rewriting F1-B02: its folder is this run's whole (the earlier PDF not
    beside its new results, the inspector's file kept), the others the earlier run's, and the
    earlier summary, which no longer describes them, set aside rather than left or deleted."""
    out = tmp_path / "out"
    earlier = _earlier_run(small_batch, out)
    real = batch.inspect_one

    def stopped(path, *args, **kwargs):
        if path.name == "F3-B02":
            raise KeyboardInterrupt
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "inspect_one", stopped)
    with pytest.raises(KeyboardInterrupt):
        batch.run(batch.collect([small_batch]), load_pack("global-project"),
                  batch.Writer(out, pdf="none"))  # fmt: skip
    assert sorted(p.name for p in (out / "F1-B02").iterdir()) == [
        "checkpoints.csv", "evidence.csv", "notes.txt", "report.html", "results.json",
    ]  # fmt: skip
    for name in ("F3-B02/results.json", "F4-B02/report.html"):
        assert (out / name).read_bytes() == earlier[name]
    assert not list(out.glob("summary.*"))
    aside = out / ".blockqc-previous-summary"
    assert (aside / "summary.json").read_bytes() == earlier["summary.json"]
    # the next run writes its own summary and leaves nothing hidden behind
    monkeypatch.setattr(batch, "inspect_one", real)
    batch.run(batch.collect([small_batch]), load_pack("global-project"),
              batch.Writer(out, pdf="none"))  # fmt: skip
    assert (out / "summary.json").is_file()
    assert not aside.exists() and not (out / ".blockqc-staging").exists()


def _with_a_failing_template(batch_dir: Path, out: Path, tmp_path: Path, page: str):
    """inspect with `--templates` whose `page` fails on every results: exit 2, said."""
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / page).write_text("{{ no_such_name.x }}\n", encoding="utf-8")
    p = run_blockqc("inspect", batch_dir, "--out", out, "--no-pdf", "--templates", mine)
    assert p.returncode == 2 and "a template fails" in p.stderr, p.stderr
    return p


def test_outputs_that_cannot_be_written_leave_the_earlier_ones_whole(small_batch, tmp_path):
    """A template failing on a block: exit 2, and the earlier run's outputs are all there as
    they were (they were removed), the summary set aside and said where."""
    out = tmp_path / "out"
    earlier = _earlier_run(small_batch, out)
    p = _with_a_failing_template(small_batch, out, tmp_path, "block.html.j2")
    assert (
        f"note: the earlier run's batch summary is kept in {out / '.blockqc-previous-summary'}"
        in p.stderr
    )
    now = {str(q.relative_to(out)): q.read_bytes() for q in out.rglob("*") if q.is_file()}
    moved = {k.replace(".blockqc-previous-summary/", ""): v for k, v in now.items()}
    assert moved == earlier


def test_a_block_folder_keeps_its_link_mode_and_other_files(small_batch, tmp_path):
    """Outputs are put into the block's folder, not the folder replaced: a link to a folder
    kept beside it in OUT stays a link, the inspector's files and subfolders stay, and a new
    folder takes the mode the umask gives (a staged folder was 0700: nobody else could read
    the reports)."""
    out = tmp_path / "out"
    real = out / "F1-B02.kept"
    (real / "photos").mkdir(parents=True)
    (real / "notes.txt").write_text("the inspector's", encoding="utf-8")
    (out / "F1-B02").symlink_to(real)
    batch.run(batch.collect([small_batch]), load_pack("global-project"),
              batch.Writer(out, pdf="none"))  # fmt: skip
    assert (out / "F1-B02").is_symlink() and (real / "results.json").is_file()
    assert (real / "notes.txt").read_text(encoding="utf-8") == "the inspector's"
    assert (real / "photos").is_dir()
    umask = os.umask(0)
    os.umask(umask)
    assert (out / "F4-B02").stat().st_mode & 0o777 == 0o777 & ~umask
    assert (out / "F4-B02" / "report.html").stat().st_mode & 0o777 == 0o644


def test_a_summary_that_fails_to_be_written_leaves_no_mix_of_two_runs(small_batch, tmp_path):
    """The summary page failing once the blocks are written: the earlier run's summary.csv,
    .parquet, .html were put back and then only partly replaced, beside this run's
    summary.json. Now the earlier ones stay set aside, said so; and this run's summary.json,
    which was left without its pages while the run said it stopped before writing its own, is
    not put in place either: the summary's files are written apart and put in place together."""
    out = tmp_path / "out"
    earlier = _earlier_run(small_batch, out)
    p = _with_a_failing_template(small_batch, out, tmp_path, "summary.html.j2")
    assert "note: the earlier run's batch summary is kept in" in p.stderr
    aside = out / ".blockqc-previous-summary"
    for name in ("summary.json", "summary.html", "summary.csv", "summary.parquet"):
        assert (aside / name).read_bytes() == earlier[name], name
    assert sorted(q.name for q in out.iterdir() if q.is_file()) == []
    assert not (out / ".blockqc-staging").exists()


def test_outputs_that_cannot_be_written_are_not_retried_on_dask():
    """Dask runs a failed task again (meant for a worker that died): a template failing on a
    block failed three times. The task hands the failure back; the run stops at once."""
    from blockqc.distributed import _Stopped, _task
    from blockqc.errors import OutputError, Problem

    def failing(path, manifest):
        raise OutputError(Problem(str(path), "cannot be written"))

    stopped = _task(failing, Path("F1-B01"), None)
    assert isinstance(stopped, _Stopped) and stopped.problems[0].message == "cannot be written"
    assert _task(lambda path, manifest: "outcome", Path("F1-B01"), None) == "outcome"


def test_sigterm_stops_a_run_as_ctrl_c_does(small_batch, tmp_path):
    """Terminated, a run left its lock, its staged outputs and the summary set aside unsaid.
    It now ends as on Ctrl-C: exit 143, said, the lock and staging cleared."""
    import signal

    out = tmp_path / "out"
    _earlier_run(small_batch, out)
    proc = subprocess.Popen(
        [sys.executable, "-m", "blockqc", "inspect", small_batch, "--out", out, "--pdf", "none"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    proc.stdout.readline()  # the first block written
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    if proc.returncode in (0, 1):
        pytest.skip("the run ended before the signal reached it")
    assert proc.returncode == 143 and "terminated" in err, err
    assert not (out / ".blockqc-lock").exists() and not (out / ".blockqc-staging").exists()
    assert "note: the earlier run's batch summary is kept in" in err


class _Slow:
    """A job of half a second that leaves a mark when it runs (picklable, for a pool)."""

    def __init__(self, marks: Path):
        self.marks = marks

    def __call__(self, path, manifest):
        import time

        (self.marks / path.name).touch()
        time.sleep(0.5)
        return path


def test_an_interrupt_while_waiting_drops_the_jobs_not_begun(tmp_path):
    """Ctrl-C or SIGTERM reaching the main process while it waits for the pool: the `with`
    waited for every job of the batch (hours on a large one) before stopping."""

    marks = tmp_path / "marks"
    marks.mkdir()
    todo = [(tmp_path / f"B{i:02d}", None) for i in range(12)]

    with _interrupted_after(1.2), pytest.raises(KeyboardInterrupt):
        batch._pooled(_Slow(marks), todo, lambda outcome: None, 2)
    assert len(list(marks.iterdir())) < len(todo)


@contextlib.contextmanager
def _interrupted_after(seconds: float):
    """Ctrl-C as the main thread meets it, `seconds` after entering (SIGALRM raising
    KeyboardInterrupt); the alarm and its handler undone on leaving."""
    import signal

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)


class _Finishing:
    """A job of half a second that leaves a mark once it has finished (picklable)."""

    def __init__(self, marks: Path):
        self.marks = marks

    def __call__(self, path, manifest):
        import time

        time.sleep(0.5)
        (self.marks / path.name).touch()
        return path.name


def test_blocks_finished_while_a_stopped_run_waits_are_said(tmp_path):
    """SIGTERM or Ctrl-C while a pool runs: the blocks its workers were writing were finished,
    outputs whole, but never handed on, so the console gave no line of them. Every job that
    finished is now handed on before the run stops."""

    marks = tmp_path / "marks"
    marks.mkdir()
    todo = [(tmp_path / f"B{i:02d}", None) for i in range(12)]
    got: list[str] = []

    with _interrupted_after(1.2), pytest.raises(KeyboardInterrupt):
        batch._pooled(_Finishing(marks), todo, got.append, 2)
    finished = sorted(p.name for p in marks.iterdir())
    assert 0 < len(finished) < len(todo)
    assert sorted(got) == finished


def _terminated_after_one_block(out: Path, *options: str, again: float | None = None):
    """A run of the sample batch sent SIGTERM once it has said its first block (and `again`
    seconds later once more); its console (stdout, stderr)."""
    import signal
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "blockqc", "inspect", SAMPLES / "batch", "--out", out,
         "--pdf", "none", "--no-progress", *options],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    first = proc.stdout.readline()
    proc.send_signal(signal.SIGTERM)
    if again is not None:
        time.sleep(again)
        proc.send_signal(signal.SIGTERM)
    rest, err = proc.communicate(timeout=120)
    if proc.returncode in (0, 1):
        pytest.skip("the run ended before the signal reached it")
    assert proc.returncode == 143, err
    return first + rest, err


@pytest.mark.parametrize("options", [("--jobs", "2"), ("--scheduler", "local")])
def test_a_terminated_batch_says_every_block_it_kept(tmp_path, options):
    """Terminated after its first block, a `--jobs 2` run said that block alone, and then
    'terminated', while more blocks were written whole on disk; on a local Dask cluster the
    blocks being written were cut off or finished unsaid. Each block written now has its line,
    and the last line says how many were finished and kept."""
    if options[0] == "--scheduler":
        pytest.importorskip("dask.distributed")
    out = tmp_path / "out"
    lines, err = _terminated_after_one_block(out, *options)
    said = sorted(line.split()[0] for line in lines.splitlines())
    on_disk = sorted(p.parent.name for p in out.glob("*/results.json"))
    assert said == on_disk
    last = err.strip().splitlines()[-1]
    assert last == (
        f"terminated: {len(on_disk)} of 8 blocks finished, their outputs kept in {out} "
        "(each whole; an --incremental run reuses them)"
    )


def test_a_stopped_dask_run_leaves_dasks_log_lines_off_the_console(tmp_path):
    """SIGTERM twice (the second stops the wait for the blocks being written) during a
    `--scheduler local` run: dask's workers and nannies printed their log over the console
    ('distributed.worker.state_machine - WARNING - Async instruction … ended with
    CancelledError', 'distributed.nanny - WARNING - Worker process still alive after 4.0
    seconds, killing'). The console now holds blockqc's lines alone."""
    pytest.importorskip("dask.distributed")
    _, err = _terminated_after_one_block(tmp_path / "out", "--scheduler", "local", again=0.2)
    assert "distributed." not in err, err
    assert err.strip().splitlines()[-1].startswith("terminated: ")


def test_a_dask_run_that_ends_leaves_dasks_logging_as_it_was(tmp_path):
    """Dask's warnings are quieted only when a run stops: a run that ends leaves the levels of
    dask's loggers as they were, so that its warnings and errors are still said."""
    import logging

    pytest.importorskip("dask.distributed")
    from blockqc.distributed import run_on_dask

    names = ("distributed", "distributed.nanny", "distributed.worker")
    before = [logging.getLogger(n).getEffectiveLevel() for n in names]
    got: list[str] = []
    run_on_dask("local", _ctrl_c_here, [(tmp_path / "A", None)], got.append)
    assert got == ["ignored"]
    assert [logging.getLogger(n).getEffectiveLevel() for n in names] == before
    assert logging.getLogger("distributed").getEffectiveLevel() < logging.ERROR


class _CtrlC:
    """A job whose worker gets the Ctrl-C a terminal sends to every process of the run, then
    finishes its block (picklable, for a pool)."""

    def __call__(self, path, manifest):
        import signal
        import time

        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.2)
        return path.name


def test_ctrl_c_reaching_a_worker_leaves_its_block_to_finish(tmp_path):
    """Ctrl-C in a terminal reaches the workers of a `--jobs` run too: each printed Python's
    traceback ('Process ForkProcess-2: Traceback … KeyboardInterrupt') over the console and
    dropped the block it was writing. The main process alone now stops the run; a worker
    finishes its block."""
    got: list[str] = []
    todo = [(tmp_path / "A", None), (tmp_path / "B", None)]
    try:
        lost = batch._pooled(_CtrlC(), todo, got.append, 2)
    except KeyboardInterrupt:
        pytest.fail("a worker's Ctrl-C interrupted the block it was writing")
    assert lost == [] and sorted(got) == ["A", "B"]


class _Pid:
    """A job that writes its worker's process id, then waits a minute (picklable)."""

    def __init__(self, marks: Path):
        self.marks = marks

    def __call__(self, path, manifest):
        import os
        import time

        (self.marks / path.name).write_text(str(os.getpid()))
        time.sleep(60)
        return path


@pytest.mark.skipif(sys.platform != "linux", reason="the parent's death is signalled on Linux")
def test_workers_end_when_the_main_process_is_killed(tmp_path):
    """The main process of a `--jobs` run killed (SIGKILL, out of memory): its workers went on
    writing into --out, then waited for ever, holding their memory."""
    import os
    import time

    marks = tmp_path / "marks"
    marks.mkdir()
    script = (
        "import sys; from pathlib import Path; import test_batch as t; from blockqc import batch; "
        "todo = [(Path(f'B{i}'), None) for i in range(2)]; "
        "batch._pooled(t._Pid(Path(sys.argv[1])), todo, lambda outcome: None, 2)"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), *sys.path])}
    main = subprocess.Popen([sys.executable, "-c", script, str(marks)], env=env)
    deadline = time.monotonic() + 60
    workers: list[int] = []
    while len(workers) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)  # a mark is made, then written: counted once written
        workers = [int(text) for p in marks.iterdir() if (text := p.read_text())]
    assert len(workers) == 2
    main.kill()
    main.wait(timeout=30)
    deadline = time.monotonic() + 10
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers)


def _alive(pid: int) -> bool:
    """Whether the process runs (a zombie, ended but not yet reaped, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_incremental_key_holds_the_libraries_versions(monkeypatch, tmp_path):
    """Another numpy (or any library the numbers and pages are made with) is another key: the
    blocks are inspected again."""
    from blockqc import cache

    pack, writer = load_pack("global-project"), batch.Writer(tmp_path, pdf="none")
    before = cache.run_digest(pack, writer)
    assert cache.run_digest(pack, writer) == before
    real = cache.metadata.version
    monkeypatch.setattr(
        cache.metadata, "version", lambda name: "0.0.1" if name == "numpy" else real(name)
    )
    assert cache.run_digest(pack, writer) != before


def test_incremental_key_holds_pillows_version(monkeypatch, tmp_path):
    """Pillow measures the figures' text and encodes their raster layers (report.svg): another
    Pillow is another key, as another numpy is; it was left out, and the pages of the earlier
    one reused."""
    from blockqc import cache

    pack, writer = load_pack("global-project"), batch.Writer(tmp_path, pdf="none")
    before = cache.run_digest(pack, writer)
    real = cache.metadata.version
    monkeypatch.setattr(
        cache.metadata, "version", lambda name: "0.0.1" if name == "pillow" else real(name)
    )
    assert cache.run_digest(pack, writer) != before


def test_incremental_key_holds_blockqcs_report_font(monkeypatch, tmp_path):
    """The packaged font (report/fonts/*.otf) is embedded in the PDFs and measures figure text
    where DejaVu Sans is missing: a font replaced (a checkout updated) is another key, as a
    module changed is; only the modules were keyed, and the earlier font's PDFs reused."""
    from blockqc import cache

    package = tmp_path / "blockqc"
    fonts = package / "report" / "fonts"
    fonts.mkdir(parents=True)
    (package / "cache.py").write_text("", encoding="utf-8")
    font = fonts / "BlockqcSansSC-Regular.otf"
    font.write_bytes(b"OTTO" + b"\0" * 60)
    monkeypatch.setattr(cache, "__file__", str(package / "cache.py"))
    pack, writer = load_pack("global-project"), batch.Writer(tmp_path / "out", pdf="none")
    before = cache.run_digest(pack, writer)
    assert cache.run_digest(pack, writer) == before
    font.write_bytes(b"OTTO" + b"\1" * 80)
    assert cache.run_digest(pack, writer) != before


def test_incremental_key_holds_the_chromium_writing_the_pdfs(monkeypatch, tmp_path):
    """BLOCKQC_CHROMIUM naming another program is another key when it writes the PDFs, and no
    other key when no PDF is written."""
    from blockqc import cache

    pack = load_pack("global-project")
    one, other = tmp_path / "chrome-a", tmp_path / "chrome-b"
    one.write_text("a", encoding="utf-8")
    other.write_text("bb", encoding="utf-8")
    for program in (one, other):
        program.chmod(0o755)  # a program BLOCKQC_CHROMIUM may name

    def digest(program: Path, pdf: str) -> str:
        monkeypatch.setenv("BLOCKQC_CHROMIUM", str(program))
        return cache.run_digest(pack, batch.Writer(tmp_path, pdf=pdf, pdf_engine="chromium"))

    assert digest(one, "all") != digest(other, "all")
    assert digest(one, "none") == digest(other, "none")


def test_incremental_key_holds_whether_chromium_tags_the_pdfs(monkeypatch, tmp_path):
    """BLOCKQC_PDF_TAGGED=1 has Chromium write another PDF (tagged: about twice the bytes): an
    untagged one of an earlier run was reused in its place. It is another key when Chromium
    writes the PDFs, and no other key when no PDF is written."""
    from blockqc import cache

    pack = load_pack("global-project")
    program = tmp_path / "chrome"
    program.write_text("a", encoding="utf-8")
    program.chmod(0o755)
    monkeypatch.setenv("BLOCKQC_CHROMIUM", str(program))

    def digest(tagged: str | None, pdf: str) -> str:
        if tagged is None:
            monkeypatch.delenv("BLOCKQC_PDF_TAGGED", raising=False)
        else:
            monkeypatch.setenv("BLOCKQC_PDF_TAGGED", tagged)
        return cache.run_digest(pack, batch.Writer(tmp_path, pdf=pdf, pdf_engine="chromium"))

    assert digest(None, "all") != digest("1", "all")
    assert digest(None, "all") == digest("0", "all")  # only 1 tags them
    assert digest(None, "none") == digest("1", "none")


def test_incremental_rerun_sees_a_file_rewritten_with_its_size_and_time_kept(
    small_batch: Path, tmp_path: Path
):
    """A residual's last digit corrected (-0.6294 to -0.6291 px), the file's size the same and
    its mtime set back, as `cp -p` or `rsync -a` of an edited copy keeps it: the block was taken
    as unchanged."""
    out = tmp_path / "out"
    assert _incremental(small_batch, out).returncode == 1
    tie_points = small_batch / "F1-B02" / "tie_points.csv"
    st = tie_points.stat()
    lines = tie_points.read_text(encoding="utf-8").splitlines(keepends=True)
    cells = lines[1].split(",")
    cells[4] = cells[4][:-1] + ("1" if cells[4][-1] != "1" else "2")  # the same length
    lines[1] = ",".join(cells)
    tie_points.write_text("".join(lines), encoding="utf-8")
    os.utime(tie_points, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert tie_points.stat().st_size == st.st_size
    again = _incremental(small_batch, out)
    assert again.stdout.count("outputs reused") == 2, again.stdout


def test_sampled_false_beside_checkpoints_is_said(tmp_path: Path):
    """F1-B01 carries checkpoints; its block.yaml made to say `sampled: false` was inspected in
    detail without a word (without a plan the blocks with checkpoints are the sample). It is
    said; F1-B02 (sampled: false, no checkpoints) and F2-B01 (sampled: true) are not named."""
    folder = tmp_path / "batch"
    for block in ("F1-B01", "F1-B02", "F2-B01"):
        shutil.copytree(SAMPLES / "batch" / block, folder / block)
    manifest = folder / "F1-B01" / "block.yaml"
    text = manifest.read_text(encoding="utf-8")
    assert "sampled: true\n" in text
    manifest.write_text(text.replace("sampled: true\n", "sampled: false\n"), encoding="utf-8")
    proc = run_blockqc("inspect", folder, "--out", tmp_path / "out", "--pdf", "none")
    assert proc.returncode == 0, proc.stderr
    warned = [line for line in proc.stderr.splitlines() if "sampled: false" in line]
    assert warned == [
        f"warning: {manifest}: sampled: false, but its checkpoints are given (checkpoints.csv): "
        "without a --plan a block that carries checkpoints is inspected in detail (its "
        "checkpoint rules judged) and counted in the sample"
    ]
    results = json.loads((tmp_path / "out" / "F1-B01" / "results.json").read_text("utf-8"))
    cp2 = [r for r in results["results"] if r["rule"] == "CP-2"]
    assert cp2 and all(r["status"] == "pass" for r in cp2)  # judged in detail, as warned


def test_table_files_read_as_no_table_are_said(tmp_path: Path):
    """A delivery's table file of a name no table of the contract is read from
    (checkpoints_extra.csv beside checkpoints.csv, tie_points_part2.parquet, gcp.xlsx) was
    passed over without a word: the inspector reading the results would take its rows for
    judged. Each is named in a warning; block.yaml, the contract's tables and documents/ are
    not."""
    block = tmp_path / "F1-B01"
    shutil.copytree(SAMPLES / "batch" / "F1-B01", block)
    extra = [
        block / "checkpoints_extra.csv",
        block / "gcp.xlsx",
        block / "tie_points_part2.parquet",
    ]
    shutil.copy(block / "checkpoints.csv", extra[0])
    extra[1].write_bytes(b"PK")
    extra[2].write_bytes(b"PAR1")
    (block / "notes.txt").write_text("producer's notes\n", encoding="utf-8")
    proc = run_blockqc("inspect", block, "--out", tmp_path / "out", "--pdf", "none")
    assert proc.returncode == 0, proc.stderr
    warned = [line for line in proc.stderr.splitlines() if "no table of the contract" in line]
    assert warned == [
        f"warning: {f}: not read: no table of the contract is read from it (a delivery's tables "
        "are scenes, tie_points, pan_ms, overlaps, edges, checkpoints, adjustment, each .csv or "
        ".parquet)"
        for f in sorted(extra)
    ]
