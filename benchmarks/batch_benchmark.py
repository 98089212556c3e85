"""Times `blockqc inspect` over a generated batch: HTML per block, PDFs of failing blocks, summary.

    python benchmarks/batch_benchmark.py --blocks 1000 --observations 100000000 [--jobs 2]
        [--pdf-engine auto|weasyprint|chromium] [--incremental]

The batch is written to disk block by block, never held in memory: the sample generator makes
one delivery per published test field at the observations per block asked for, and every block
of the batch is a copy of one of them (tables hard-linked, block.yaml rewritten with its own
block id and the reported figures kept). The inspection runs as its own process; its wall time
the peak resident memory of its largest process and the CPU time of all its processes are
measured. The PDFs are made by Chromium when one is installed (`--pdf-engine auto`, about a
quarter of WeasyPrint's CPU per PDF), else by WeasyPrint, blockqc's default. The CPU time is
printed as `cpu C s (c s/block)`: that of the processes the inspection waited for. Chromium's
page processes are not among them (the browser forks them from a process of its own), so the
busy CPU time of the whole machine over the run is printed beside it, from /proc/stat where
there is one, `machine cpu C s (c s/block)`: it counts every process of the machine, so it is
the inspection's own on a machine otherwise idle. With --incremental the inspection runs with
`--incremental`, then again on the unchanged batch, then again after one block's block.yaml got
a new modification time; each re-run prints

    rerun (unchanged|one block changed): T s, K of N blocks inspected again

The last line is always that of the first run, printed after any re-runs:

    batch: N blocks, M observations, T s, peak G GB, B blocks/s
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from blockqc.simulate import Layout, Options, simulate


def templates(folder: Path, obs_per_block: int, seed: int) -> list[Path]:
    """One generated delivery per test field with about `obs_per_block` observations."""
    per_scene = 300
    pan_scenes = max(8, obs_per_block / per_scene)
    side = max(2, round(math.sqrt(pan_scenes / 2)))
    per_scene = max(50, round(obs_per_block / (2 * side * side)))
    layout = Layout(rows=side, cols=side, obs_per_scene=per_scene)
    simulate(folder, Options(seed=seed, blocks_per_field=1, layout=layout))
    return sorted(p for p in folder.iterdir() if (p / "block.yaml").is_file())


def write_batch(batch: Path, blocks: int, sources: list[Path]) -> int:
    """`blocks` deliveries, each a hard-linked copy of a template with its own block id."""
    total = 0
    for i in range(blocks):
        src = sources[i % len(sources)]
        dst = batch / f"B{i:05d}"
        shutil.copytree(src, dst, copy_function=os.link)
        manifest = yaml.safe_load((src / "block.yaml").read_text(encoding="utf-8"))
        manifest["block_id"] = dst.name
        (dst / "block.yaml").unlink()  # a link to the template's: replace, never write through
        (dst / "block.yaml").write_text(yaml.safe_dump(manifest, allow_unicode=True), "utf-8")
        with open(dst / "tie_points.csv", "rb") as fh:
            total += sum(chunk.count(b"\n") for chunk in iter(lambda: fh.read(1 << 20), b"")) - 1
    return total


def machine_busy() -> float | None:
    """Seconds of CPU time the whole machine has spent busy since it started (every core, idle
    and waiting for I/O left out), from /proc/stat; None where there is none."""
    try:
        with open("/proc/stat", encoding="ascii") as fh:
            ticks = [int(v) for v in fh.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    busy = sum(ticks) - ticks[3] - ticks[4]  # the fourth and fifth: idle, waiting for I/O
    return busy / os.sysconf("SC_CLK_TCK")


def inspect(root: Path, args: argparse.Namespace) -> tuple[float, float, float | None, list[str]]:
    """One `blockqc inspect` of the batch as its own process: wall time, the CPU time of the
    processes it waited for, the machine's busy CPU time over the run (None where unknown),
    its lines."""
    cmd = [sys.executable, "-m", "blockqc", "inspect", str(root / "batch"),
           "--out", str(root / "out"), "--pdf", args.pdf, "--pdf-engine", args.pdf_engine,
           "--jobs", str(args.jobs), "--no-progress"]  # fmt: skip
    cmd += ["--incremental"] if args.incremental else []
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    machine = machine_busy()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    machine_after = machine_busy()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):
        sys.exit(f"inspect failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    busy = None if machine is None or machine_after is None else machine_after - machine
    return wall, cpu, busy, proc.stdout.strip().splitlines()


def rerun(root: Path, args: argparse.Namespace, what: str) -> None:
    """Time a re-run; count the blocks inspected again (not reported as reused)."""
    wall, _, _, lines = inspect(root, args)
    blocks = [x for x in lines if x[:1] == "B"]
    again = sum("outputs reused" not in x for x in blocks)
    print(f"rerun ({what}): {wall:.1f} s, {again} of {len(blocks)} blocks inspected again")


def pdf_engine(asked: str) -> str:
    """The engine asked for; for `auto`, Chromium when one is found, else WeasyPrint."""
    if asked != "auto":
        return asked
    from blockqc.report.chromium import ChromiumProblem, find_chromium

    try:
        find_chromium()
    except ChromiumProblem:
        return "weasyprint"
    return "chromium"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=100)
    ap.add_argument("--observations", type=int, default=10_000_000)
    ap.add_argument("--jobs", type=int, default=0, help="inspect --jobs (0: every core)")
    ap.add_argument("--pdf", default="failing", choices=["all", "failing", "sampled", "none"])
    ap.add_argument(
        "--pdf-engine",
        default="auto",
        choices=["auto", "weasyprint", "chromium"],
        help="auto (the default): Chromium when one is installed, else WeasyPrint",
    )
    ap.add_argument("--seed", type=int, default=20231)
    ap.add_argument("--keep", type=Path, help="keep the batch and outputs in this folder")
    ap.add_argument("--incremental", action="store_true", help="then time unchanged re-runs")
    args = ap.parse_args()
    args.pdf_engine = pdf_engine(args.pdf_engine)

    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        sources = templates(root / "templates", args.observations // args.blocks, args.seed)
        n_obs = write_batch(root / "batch", args.blocks, sources)
        took = time.perf_counter() - t0
        print(f"generated {args.blocks} blocks, {n_obs} observations in {took:.1f} s; "
              f"PDFs by {args.pdf_engine}", flush=True)  # fmt: skip
        wall, cpu, busy, lines = inspect(root, args)
        peak_gb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024**2
        print(lines[-1])
        print(f"cpu {cpu:.0f} s ({cpu / args.blocks:.2f} s/block)", flush=True)
        if busy is not None:
            print(f"machine cpu {busy:.0f} s ({busy / args.blocks:.2f} s/block)", flush=True)
        if args.incremental:
            rerun(root, args, "unchanged")
            manifest = root / "batch" / f"B{args.blocks // 2:05d}" / "block.yaml"
            os.utime(manifest, ns=(time.time_ns(), manifest.stat().st_mtime_ns + 1_000_000_000))
            rerun(root, args, "one block changed")
        print(
            f"batch: {args.blocks} blocks, {n_obs} observations, {wall:.1f} s, "
            f"peak {peak_gb:.2f} GB, {args.blocks / wall:.2f} blocks/s"
        )  # the last line, whatever was re-run


if __name__ == "__main__":
    main()
