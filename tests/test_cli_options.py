"""Command-line options and paths: contradictions, empty or impossible paths, a closed pipe and
colours are handled with a message (exit 2) or quietly, never an internal error."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from casekit import SAMPLES, run_blockqc

SAMPLE = SAMPLES / "batch" / "F1-B01"
DEM = SAMPLES.parent / "tests" / "data" / "rfm" / "phr_ventoux" / "srtm_N44E005_crop.tif"


def _refused(p: subprocess.CompletedProcess, *words: str) -> None:
    assert p.returncode == 2, p.stdout + p.stderr
    assert "internal error" not in p.stderr and "Traceback" not in p.stderr, p.stderr
    for w in words:
        assert w in p.stderr, p.stderr


@pytest.mark.parametrize(
    "args, words",
    [
        (("--out", ""), "Invalid value for '--out': an empty path"),
        (("--out", "o", "--no-pdf", "--pdf", "all"), "--no-pdf contradicts --pdf all"),
        (("--out", "o", "--jobs", "2", "--scheduler", "local"), "give one of them"),
    ],
)
def test_contradicting_or_empty_options_are_refused(tmp_path, args, words):
    p = run_blockqc("inspect", SAMPLE, *args, cwd=tmp_path)
    _refused(p, words)
    assert list(tmp_path.iterdir()) == []  # nothing written, not even a folder


def test_a_symbolic_link_loop_or_a_name_too_long_is_named(tmp_path):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    _refused(run_blockqc("inspect", SAMPLE, "--out", tmp_path / "a"), "leads back to itself")
    _refused(run_blockqc("inspect", tmp_path / "a", "--out", tmp_path / "o"), "Symlink loop")
    long = tmp_path / ("x" * 300)  # NAME_MAX is 255 bytes
    _refused(run_blockqc("inspect", SAMPLE, "--out", long), "File name too long")
    _refused(run_blockqc("inspect", long, "--out", tmp_path / "o"), "File name too long")


def test_a_reader_that_stops_reading_does_not_stop_the_run(tmp_path):
    """`blockqc inspect BATCH | head -1`: every block is inspected and the summary written."""
    batch = tmp_path / "batch"
    for name in ("F1-B02", "F3-B02", "F4-B02"):
        shutil.copytree(SAMPLES / "batch" / name, batch / name)
    cmd = [sys.executable, "-m", "blockqc", "inspect", str(batch), "--out", str(tmp_path / "o"),
           "--pdf", "none"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().startswith("F1-B02")
    proc.stdout.close()  # as head does after its line
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 1 and "Traceback" not in err, err  # F3-B02 fails RO-3
    assert (tmp_path / "o" / "summary.json").is_file()


@pytest.mark.parametrize("closed", ["stdout", "stderr"])
def test_a_run_started_with_an_output_stream_closed_is_done_as_any(tmp_path, closed):
    """`blockqc inspect … >&-` (a job started without a stdout, or a stderr): Python gives no
    stream, and the run ended in an internal error and a traceback (exit 1 or 2) once the
    outputs were written. It now ends as any, its exit status that of its blocks."""
    batch = tmp_path / "batch"
    for name in ("F1-B02", "F4-B02"):
        shutil.copytree(SAMPLES / "batch" / name, batch / name)
    fd = 1 if closed == "stdout" else 2
    cmd = [sys.executable, "-m", "blockqc", "inspect", str(batch), "--out", str(tmp_path / "o"),
           "--pdf", "none"]  # fmt: skip
    other = subprocess.PIPE
    proc = subprocess.run(
        cmd, stdout=other, stderr=other, text=True, timeout=600, preexec_fn=lambda: os.close(fd)
    )
    said = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "Traceback" not in said and "internal error" not in said, said
    assert (tmp_path / "o" / "summary.json").is_file()


def test_a_reader_of_both_streams_that_stops_reading_leaves_the_exit_status(tmp_path):
    """`blockqc inspect BATCH 2>&1 | head -1`: the warnings said once the blocks are written
    met a closed pipe, and the run ended in a traceback with exit 1 ("some block fails") over
    a batch that passes. It ends as a run whose reader stays, exit 0."""
    batch = tmp_path / "batch"
    for name in ("F1-B02", "F4-B02", "F2-B01"):
        shutil.copytree(SAMPLES / "batch" / name, batch / name)
    out = tmp_path / "o"
    assert run_blockqc("inspect", batch, "--out", out, "--pdf", "none").returncode == 0
    shutil.rmtree(batch / "F2-B01")  # withdrawn: its outputs in OUT are warned of at the end
    read, write = os.pipe()
    cmd = [sys.executable, "-m", "blockqc", "inspect", str(batch), "--out", str(out),
           "--pdf", "none"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=write, stderr=write)
    os.close(write)
    with os.fdopen(read) as reader:
        assert reader.readline().startswith("F1-B02")
    assert proc.wait(timeout=600) == 0
    assert json.loads((out / "summary.json").read_text(encoding="utf-8"))["counts"]["blocks"] == 2


def test_no_colour_codes_with_no_color_or_into_a_pipe(tmp_path):
    batch = tmp_path / "batch"
    for name in ("F1-B02", "F3-B02"):
        shutil.copytree(SAMPLES / "batch" / name, batch / name)
    env = {**os.environ, "NO_COLOR": "1"}
    p = subprocess.run(
        [sys.executable, "-m", "blockqc", "inspect", str(batch), "--out", str(tmp_path / "o"),
         "--pdf", "none", "--progress"],
        capture_output=True, text=True, env=env, timeout=600,
    )  # fmt: skip
    assert p.returncode == 1, p.stderr
    assert "\x1b[" not in p.stderr + p.stdout
    assert "F3-B02       FAIL" in p.stderr and "[progress.description]" not in p.stderr


def test_a_folder_given_for_a_file_is_called_a_folder(tmp_path):
    _refused(run_blockqc("rules", "list", "--rules", tmp_path), "is a folder, not a rule pack file")
    p = run_blockqc("inspect", SAMPLE, "--checkpoints", tmp_path, "--out", tmp_path / "o")
    _refused(p, f"{tmp_path}: a folder (expected a checkpoints table)")
    p = run_blockqc("inspect", SAMPLE, "--checkpoints", os.devnull, "--out", tmp_path / "o")
    _refused(p, f"{os.devnull}: not a file (expected a checkpoints table)")


def test_output_inside_a_delivery_a_batch_links_to_is_refused(tmp_path):
    """A batch's delivery may be a link to a folder elsewhere: --out inside that folder lies
    inside the delivery, though not inside the batch."""
    real = tmp_path / "real" / "F1-B01"
    shutil.copytree(SAMPLE, real)
    batch = tmp_path / "batch"
    batch.mkdir()
    (batch / "F1-B01").symlink_to(real)
    before = sorted(p.name for p in real.rglob("*"))
    p = run_blockqc("inspect", batch, "--out", real / "out", "--pdf", "none")
    _refused(
        p,
        f"error: --out {real / 'out'} lies inside the delivery {real}: blockqc never "
        "writes into a delivery; choose an output folder outside it",
    )
    assert sorted(p.name for p in real.rglob("*")) == before


def _process(code: str) -> subprocess.CompletedProcess:
    """A child interpreter running `code`, which ends by calling blockqc.cli.run()."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)


def test_the_process_ends_with_its_exit_status_after_its_output_and_exit_handlers():
    """run() ends the process without Python's teardown: what it printed is all there, the exit
    handlers registered (files to finish, temporary folders to remove) have run, and the exit
    status is the command's."""
    ok = _process(
        "import atexit, sys\n"
        "from blockqc.cli import run\n"
        "atexit.register(lambda: print('handler ran'))\n"
        "sys.argv = ['blockqc', 'rules', 'list']\n"
        "run()\n"
    )
    assert ok.returncode == 0, ok.stderr
    assert "TP-1" in ok.stdout and ok.stdout.endswith("handler ran\n")
    refused = _process(
        "import sys\n"
        "from blockqc.cli import run\n"
        "sys.argv = ['blockqc', 'inspect', '/no/such/delivery', '--out', '/no/such/out']\n"
        "run()\n"
        "print('never here')\n"
    )
    assert refused.returncode == 2 and "never here" not in refused.stdout
    assert "/no/such/delivery" in refused.stderr and "Traceback" not in refused.stderr


def test_under_a_profiler_the_process_ends_as_python_does(tmp_path):
    """cProfile writes its profile when the command returns: run() leaves the ending to Python."""
    out = tmp_path / "run.prof"
    p = subprocess.run(
        [sys.executable, "-m", "cProfile", "-o", str(out), "-m", "blockqc", "--version"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert p.returncode == 0, p.stderr
    assert out.stat().st_size > 0


def _files(folder):
    return {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_output_whose_block_folder_is_the_delivery_is_refused(tmp_path):
    """--out the folder that holds the delivery: <out>/<block_id> would be the delivery itself,
    its checkpoints.csv replaced by the export of the same name. Refused before anything is
    written, for one delivery and for a batch given beside it."""
    batch = tmp_path / "batch"
    shutil.copytree(SAMPLE, batch / "F1-B01")
    before = _files(tmp_path)
    p = run_blockqc("inspect", batch / "F1-B01", "--out", batch, "--pdf", "none")
    _refused(
        p,
        f"error: --out {batch}: the outputs of block F1-B01 would go into {batch / 'F1-B01'}, "
        "a delivery (it holds block.yaml); blockqc never writes into a delivery",
    )
    assert _files(tmp_path) == before


def test_output_that_is_the_folder_holding_the_delivery_is_refused_whatever_its_name(tmp_path):
    """The same --out, the delivery's folder not named by its block id: F1-B01/ was written
    beside the delivery in its batch, which then held a sub-folder without block.yaml, an
    unreadable delivery (exit 2) at its next inspection. Refused, as when the names agree."""
    batch = tmp_path / "batch"
    shutil.copytree(SAMPLE, batch / "delivered")
    before = _files(tmp_path)
    p = run_blockqc("inspect", batch / "delivered", "--out", batch, "--pdf", "none")
    _refused(p, f"error: --out {batch} is the folder holding the delivery {batch / 'delivered'}")
    assert _files(tmp_path) == before and sorted(batch.iterdir()) == [batch / "delivered"]
    p = run_blockqc("inspect", "delivered", "--out", ".", "--pdf", "none", cwd=batch)
    _refused(p, "error: --out . is the folder holding the delivery delivered")


def test_writer_never_writes_into_nor_clears_a_delivery(tmp_path):
    """The last guard, wherever a block's folder is named (a worker, a re-run's clean-up): a
    block folder that is a delivery is refused, and nothing of it is removed."""
    from blockqc.batch import Writer
    from blockqc.errors import OutputError
    from blockqc.outputs import safe_child

    shutil.copytree(SAMPLE, tmp_path / "F1-B01")
    before = _files(tmp_path)
    with pytest.raises(OutputError, match="is the delivery .* never written into"):
        safe_child(tmp_path, "F1-B01")
    Writer(tmp_path).discard("F1-B01")
    assert _files(tmp_path) == before


def test_a_delivery_path_that_is_not_utf8_is_refused_by_name(tmp_path):
    """A folder name that is no UTF-8 text (bytes a Linux file system keeps as given): the
    outputs name each delivery by its path in UTF-8, so it is refused up front with its bytes
    shown, for one delivery, a batch and the factor analysis; nothing is written."""
    batch = tmp_path / "batch"
    shutil.copytree(SAMPLES / "batch" / "F1-B02", batch / "F1-B02")
    bad = os.fsdecode(os.fsencode(batch) + b"/x\xff")
    try:
        shutil.copytree(SAMPLE, bad)
    except OSError:  # a file system that keeps only UTF-8 names
        pytest.skip("this file system refuses a name that is not UTF-8")
    words = f"error: {batch}/x\\xff: a path that is not UTF-8 text"
    for args in (
        ("inspect", bad, "--out", tmp_path / "o", "--pdf", "none"),
        ("inspect", batch, "--out", tmp_path / "o", "--pdf", "none"),
        ("factors", batch, "--out", tmp_path / "o", "--dem", DEM),
    ):
        _refused(run_blockqc(*args), words)
        assert not (tmp_path / "o").exists()


def test_a_link_to_nothing_in_a_batch_is_an_unreadable_delivery(tmp_path):
    """A batch's delivery given as a link whose folder moved: not a file beside the deliveries
    (a warning, the batch complete without it) but a delivery that cannot be read (exit 2)."""
    batch = tmp_path / "batch"
    shutil.copytree(SAMPLES / "batch" / "F1-B02", batch / "F1-B02")
    (batch / "F9-B09").symlink_to(tmp_path / "moved")
    p = run_blockqc("inspect", batch, "--out", tmp_path / "o", "--pdf", "none")
    _refused(
        p,
        f"error: {batch / 'F9-B09'}: a symbolic link to {tmp_path / 'moved'}, which does not exist",
    )
    assert "beside the deliveries" not in p.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text(encoding="utf-8"))
    assert summary["counts"]["unreadable"] == 1 and not summary["complete"]


@pytest.mark.parametrize(
    "given",
    [
        ("inspect", "{link}", "--out", "{out}"),
        ("inspect", "{batch}", "--rules", "{link}", "--out", "{out}"),
        ("inspect", "{batch}", "--checkpoints", "{link}", "--out", "{out}"),
        ("inspect", "{batch}", "--templates", "{link}", "--out", "{out}"),
        ("sample", "{batch}", "--seed", "1", "--rules", "{link}", "--out", "{out}/plan.yaml"),
        ("adjust", "{link}", "--out", "{out}"),
        ("factors", "--table", "{link}", "--out", "{out}"),
    ],
    ids=["delivery", "rules", "checkpoints", "templates", "sample-rules", "adjust", "table"],
)
def test_an_input_linking_to_nothing_is_said_to_be_such_a_link(tmp_path, given):
    """An input given as a symbolic link whose file or folder was moved was said not to be
    there ('no such file or folder', 'no such rule pack', "Directory 'tpl' does not exist"),
    as if the name were wrong. It is now said to be a link to nothing, naming where it leads,
    as --plan, --verdicts and --meta said it."""
    link = tmp_path / "linked"
    link.symlink_to(tmp_path / "moved")
    batch = SAMPLES / "batch"
    args = [a.format(link=link, batch=batch, out=tmp_path / "o") for a in given]
    p = run_blockqc(*args)
    assert p.returncode == 2, p.stderr
    assert f"{link}: a symbolic link to {tmp_path / 'moved'}, which does not exist" in p.stderr
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "o").exists()


def test_a_rule_pack_from_a_pipe_is_read_and_a_device_without_end_is_refused(tmp_path):
    """--rules <(…) names a pipe, not a regular file: read as the file it stands for; a
    device that never ends (/dev/zero) is read up to the limit of YAML files, then refused."""
    pack = (SAMPLES.parent / "rules" / "global-project.yaml").read_text(encoding="utf-8")
    p = subprocess.run(
        [sys.executable, "-m", "blockqc", "rules", "list", "--rules", "/dev/stdin"],
        input=pack, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert p.returncode == 0, p.stderr
    assert "MB-1" in p.stdout
    if os.path.exists("/dev/zero"):
        p = run_blockqc("rules", "list", "--rules", "/dev/zero")
        _refused(p, "/dev/zero: gives more than 2 MiB, the limit for files of this kind")


def test_a_scheduler_nothing_answers_at_is_refused_at_once(tmp_path):
    """Connection refused, or a host no name service knows: said so (the client waited its 20 s
    timeout, then spoke of a timeout), exit 2, nothing written."""
    pytest.importorskip("dask.distributed")
    for address, words in (
        ("tcp://127.0.0.1:1", "no scheduler answers there (Connection refused)"),
        ("tcp://no-such-host.invalid:8786", "unknown host no-such-host.invalid"),
    ):
        p = run_blockqc("inspect", SAMPLE, "--scheduler", address, "--out", tmp_path / "o")
        _refused(p, f"--scheduler {address}: {words}")
        assert not (tmp_path / "o").exists()


def test_an_empty_plan_path_is_refused_as_such(tmp_path):
    """`sample --out ''` named the current folder: "--out .: the plan is a YAML file"."""
    p = run_blockqc("sample", SAMPLES / "batch", "--seed", "1", "--out", "", cwd=tmp_path)
    _refused(p, "Invalid value for '--out': an empty path: give the plan's file (plan.yaml)")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "args, words",
    [
        (("factors", SAMPLES / "batch", "--out", "o", "--period-gap-days", "nan"),
         "'--period-gap-days': nan is not a finite number"),
        (("factors", SAMPLES / "batch", "--out", "o", "--stereo-iou", "nan"),
         "'--stereo-iou': nan is not a finite number"),
        (("simulate", "o", "--obs-per-scene", "1000000000"),
         "1000000000 is not in the range 10<=x<=100000"),
        (("simulate",), "Missing argument 'OUT'"),
    ],
)  # fmt: skip
def test_values_no_run_can_take_are_refused(tmp_path, args, words):
    """NaN days made every date one period, recorded as null; a NaN IoU made no two scenes of
    a day one stereo unit (every overlap degree changed, unsaid); a billion observations per
    scene ran out of memory (an internal error)."""
    _refused(run_blockqc(*args, cwd=tmp_path), words)
    assert list(tmp_path.iterdir()) == []


def test_the_faults_are_listed_without_an_output_folder(tmp_path):
    p = run_blockqc("simulate", "--list-faults", cwd=tmp_path)
    assert p.returncode == 0 and "sparse-scene" in p.stdout, p.stderr


@pytest.mark.parametrize(
    "args, words",
    [
        (("--rules", "global-project", "--rules", SAMPLES / "packs" / "strict-project.yaml"),
         "--rules given twice: give it once"),
        (("--out=a", "--no-pdf"), "--out given twice: give it once"),
        (("--verdicts", SAMPLES / "verdicts.yaml", "--verdicts=x.yaml"), "--verdicts given twice"),
    ],
)  # fmt: skip
def test_an_option_of_one_value_given_twice_is_refused(tmp_path, args, words):
    """The last one was used, the first dropped unsaid (the strict pack replaced by the stock
    one, the outputs written into the second folder only)."""
    _refused(run_blockqc("inspect", SAMPLE, "--out", "o", *args, cwd=tmp_path), words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "args, words",
    [
        (("factors", SAMPLES / "batch", "--dem", SAMPLES / "dem", "--dem", SAMPLES / "dem"),
         f"--dem {SAMPLES / 'dem'} given twice: give each --dem once"),
        (("inspect", SAMPLE, "--checkpoints=a.csv", "--checkpoints", "a.csv"),
         "--checkpoints a.csv given twice: give each --checkpoints once"),
        (("simulate", "s", "--fault", "tp-noise", "--fault=tp-noise"),
         "--fault tp-noise given twice: give each --fault once"),
    ],
)  # fmt: skip
def test_one_value_of_a_repeatable_option_given_twice_is_refused(tmp_path, args, words):
    """`factors --dem D --dem D` read the tiles twice without a word; `--fix S --fix S` and
    `--fault F --fault F` (another value meant, perhaps) were taken once, unsaid."""
    _refused(run_blockqc(*args, "--out", "o", cwd=tmp_path), words)
    assert list(tmp_path.iterdir()) == []


def test_a_pdf_engine_for_no_pdf_is_said_unused(tmp_path):
    p = run_blockqc("inspect", SAMPLE, "--out", "o", "--no-pdf", "--pdf-engine", "chromium",
                    cwd=tmp_path)  # fmt: skip
    assert p.returncode in (0, 1), p.stderr
    assert "warning: --pdf-engine chromium: not used, no PDF is written" in p.stderr


@pytest.mark.parametrize("option", ["--verdicts", "--checkpoints"])
def test_an_inspectors_input_from_inside_the_delivery_is_refused(tmp_path, option):
    """The DOC-3 verdict was taken from a verdicts file the producer delivered."""
    delivery = shutil.copytree(SAMPLE, tmp_path / "d")
    source = SAMPLES / "verdicts.yaml" if option == "--verdicts" else SAMPLE / "checkpoints.csv"
    planted = delivery / "documents" / f"inspector{source.suffix}"
    shutil.copy(source, planted)
    p = run_blockqc("inspect", delivery, "--out", tmp_path / "o", option, planted)
    _refused(p, f"{option} {planted} lies inside the delivery {delivery}")
    assert not (tmp_path / "o").exists()


def test_empty_inputs_and_a_folder_for_an_output_file_are_named(tmp_path):
    """'' was read as the current folder ("--out lies inside the input ."), an empty --rules
    gave "is a folder" naming nothing, and a folder in the place of sample's --out file was
    named by a temporary file of blockqc's."""
    _refused(run_blockqc("inspect", "", "--out", "o", cwd=tmp_path),
             "'PATHS...': an empty path: give a delivery or a batch folder")  # fmt: skip
    _refused(run_blockqc("inspect", SAMPLE, "--rules", "", "--out", "o", cwd=tmp_path),
             "error: <rules>: an empty rule pack name")  # fmt: skip
    (tmp_path / "plan.yaml").mkdir()
    p = run_blockqc("sample", SAMPLES / "batch", "--seed", "7", "--out", "plan.yaml", cwd=tmp_path)
    _refused(p, "error: plan.yaml: a folder is there: expected a file")
    assert ".tmp" not in p.stderr


@pytest.mark.parametrize(
    "args",
    [
        ("inspect", SAMPLE, "--out", "o", "-j2", "-j1"),
        ("rules", "list", "--rules", "global-project", "--rules", "global-project"),
    ],
)
def test_repeated_short_options_and_rules_subcommands_are_refused_too(tmp_path, args):
    """-j2 -j1 kept the last unsaid, and the rules subcommands were not checked at all."""
    _refused(run_blockqc(*args, cwd=tmp_path), "given twice: give it once")


@pytest.mark.parametrize(
    "args, named",
    [
        (("sample", "", "--seed", "7", "--out", "../plan.yaml"), "'BATCH': an empty path"),
        (("report", "", "--out", "../r"), "'RESULTS...': an empty path"),
        (("adjust", "", "--out", "../a"), "'DELIVERY': an empty path"),
        (("adjust", SAMPLE, "--out", "../a", "--dem", ""), "'--dem': an empty path"),
        (("adjust", SAMPLE, "--out", "../a", "--dem", DEM, "--geoid", ""), "'--geoid': an empty"),
        (("inspect", SAMPLE, "--out", "../o", "--verdicts", ""), "'--verdicts': an empty path"),
        (("inspect", SAMPLE, "--out", "../o", "--checkpoints", ""), "'--checkpoints': an empty"),
        (("inspect", SAMPLE, "--out", "../o", "--plan", ""), "'--plan': an empty path"),
        (("inspect", SAMPLE, "--out", "../o", "--meta", ""), "'--meta': an empty path"),
        (("simulate", "../s", "--dem-dir", ""), "'--dem-dir': an empty path"),
    ],
)
def test_an_empty_input_path_is_refused_not_read_as_the_current_folder(tmp_path, args, named):
    """'' was read as the current folder: `sample ""` run inside a batch drew a plan from it
    (exit 0), `report ""` re-rendered the results there, and `--verdicts ""` was named '.'
    ("is a folder", or "lies inside the delivery" run inside one)."""
    here = tmp_path / "batch"
    shutil.copytree(SAMPLES / "batch", here, ignore=shutil.ignore_patterns("F[2-4]-*"))
    p = run_blockqc(*args, cwd=here)
    _refused(p, named)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["batch"]  # nothing written


@pytest.mark.parametrize(
    "args, words",
    [
        (("report", SAMPLE, "--out", "o", "--no-pdf", "--pdf"), "--no-pdf contradicts --pdf"),
        (
            ("inspect", SAMPLE, "--out", "o", "--progress", "--no-progress"),
            "--progress contradicts --no-progress",
        ),  # fmt: skip
        (
            (
                "factors",
                "--table",
                "t.csv",
                "--out",
                "o",
                "--no-edge-correction",
                "--edge-correction",
            ),
            "--no-edge-correction contradicts --edge-correction",
        ),  # fmt: skip
    ],
)
def test_a_switch_given_both_ways_is_refused(tmp_path, args, words):
    """`report … --no-pdf --pdf` wrote the PDFs (the last kept unsaid, exit 0), where `inspect
    --no-pdf --pdf all` is refused."""
    p = run_blockqc(*args, cwd=tmp_path)
    _refused(p, words, "give one of them")
    assert list(tmp_path.iterdir()) == []
