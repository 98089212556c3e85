"""Times blockqc's tie-point rules against a Great Expectations suite of the same checks.

    python benchmarks/tie_point_benchmark.py DELIVERY [--repeat R] [--ge-python PATH]
    python benchmarks/tie_point_benchmark.py --generate N [--scenes S] --out FOLDER [...]

DELIVERY holds its tie points as tie_points.parquet. Four commands, each run as its own process
and timed by the wall clock (min and median of R runs; each round runs them in an order
rotated by one, so that no command always follows the same one):

1. read: pyarrow reads the five columns the tie-point rules need, `scene_id, line, sample,
   v_line, v_sample`, of tie_points.parquet (read3: the three the Great Expectations suite
   reads, `scene_id, v_line, v_sample`, printed beside it);
2. ge: benchmarks/ge_tie_points.py, the Great Expectations suite of TP-1..TP-4;
3. blockqc_tp: `blockqc inspect DELIVERY --rules tie_points_tp_only.yaml --pdf none` (TP-1..TP-4,
   reading only the columns they use: `columns: used`);
4. blockqc_pack: `blockqc inspect DELIVERY --pdf none` (the whole stock pack, every column read
   and checked, HTML report).

blockqc runs as an installed package does, from its modules compiled to bytecode (pip compiles
them on install; GE's interpreter has its own): they are compiled once before the first round,
so that a checkout in an environment writing no bytecode (PYTHONDONTWRITEBYTECODE) does not
compile them again in every run (about 0.07 s a run).

GE runs in its own interpreter: `--ge-python`, else benchmarks/.venv-ge, created on first use
from benchmarks/requirements-ge.txt. The verdicts of GE and of blockqc's TP-1..TP-4 are printed
side by side. `--generate N` first writes a block of about N observations over about S scenes
(blockqc.simulate, tie points converted to Parquet) into FOLDER, then times it.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

HERE = Path(__file__).resolve().parent
TP_PACK = HERE / "tie_points_tp_only.yaml"
GE_SCRIPT = HERE / "ge_tie_points.py"
GE_VENV = HERE / ".venv-ge"
RULES = ("TP-1", "TP-2", "TP-3", "TP-4")
READ = (
    "import sys, pyarrow.parquet as pq; "
    "t = pq.read_table(sys.argv[1], columns=sys.argv[2].split(',')); "
    "print(t.num_rows)"
)
READ5 = "scene_id,line,sample,v_line,v_sample"
READ3 = "scene_id,v_line,v_sample"


def generate(n_obs: int, n_scenes: int, out: Path) -> Path:
    """A block of about n_obs observations over about n_scenes scenes, tie points in Parquet."""
    from blockqc.simulate import Layout, Options, simulate

    side = max(2, round(math.sqrt(n_scenes / 3)))  # three scenes per footprint, two PAN
    layout = Layout(rows=side, cols=side, obs_per_scene=max(1, round(n_obs / (2 * side * side))))
    t0 = time.perf_counter()
    (block_id,) = simulate(out, Options(fields=(1,), blocks_per_field=1, layout=layout))
    block = out / block_id
    csv = block / "tie_points.csv"
    text = {"point_id": pa.string(), "scene_id": pa.string()}
    table = pacsv.read_csv(csv, convert_options=pacsv.ConvertOptions(column_types=text))
    pq.write_table(table, block / "tie_points.parquet")
    csv.unlink()  # a delivery gives a table once: CSV or Parquet
    print(
        f"generated {block}: {side}x{side} footprints ({3 * side * side} scenes), "
        f"{table.num_rows:,} observations in {time.perf_counter() - t0:.1f} s"
    )
    return block


def compile_blockqc() -> None:
    """blockqc's modules compiled to bytecode beside them (__pycache__), as on install."""
    import compileall

    import blockqc

    if not compileall.compile_dir(Path(blockqc.__file__).parent, quiet=1):
        sys.exit("blockqc's modules could not be compiled")


def ge_python(given: str | None) -> str:
    """The interpreter with Great Expectations: the one given, else benchmarks/.venv-ge."""
    if given:
        return given
    python = GE_VENV / "bin" / "python"
    if not python.exists():
        print(f"creating {GE_VENV} (Great Expectations, benchmarks/requirements-ge.txt)")
        subprocess.run([sys.executable, "-m", "venv", str(GE_VENV)], check=True)
        pip = [str(python), "-m", "pip", "install", "-q", "-r", str(HERE / "requirements-ge.txt")]
        subprocess.run(pip, check=True)
    return str(python)


def timed(name: str, cmd: list[str], ok: tuple[int, ...] = (0,)) -> tuple[float, str]:
    """Wall-clock seconds of one command run as its own process, and what it printed."""
    t0 = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if run.returncode not in ok:
        sys.exit(f"{name} exited with {run.returncode}:\n{run.stdout}{run.stderr}")
    return seconds, run.stdout


def blockqc_statuses(out: Path) -> dict[str, str]:
    """The worst status of each of TP-1..TP-4 in the one results.json under `out`."""
    from blockqc.results import worst_status

    (path,) = out.glob("*/results.json")
    results = json.loads(path.read_text(encoding="utf-8"))["results"]
    return {
        rule: worst_status(r["status"] for r in results if r["rule"] == rule) or "absent"
        for rule in RULES
    }


def one_round(
    block: Path, python_ge: str, tmp: Path, turn: int = 0
) -> tuple[dict[str, float], dict]:
    """The five commands once, in an order rotated by `turn` (so that over the rounds each
    command also runs after each other one: a command that frees much memory slows the next
    one's first touch of memory on some machines); their times, GE's verdicts and blockqc's
    statuses."""
    blockqc = [sys.executable, "-m", "blockqc", "inspect", str(block), "--pdf", "none"]
    shutil.rmtree(tmp / "tp", ignore_errors=True)
    shutil.rmtree(tmp / "pack", ignore_errors=True)
    parquet = str(block / "tie_points.parquet")
    commands = {
        "read": ([sys.executable, "-c", READ, parquet, READ5], (0,)),
        "read3": ([sys.executable, "-c", READ, parquet, READ3], (0,)),
        "ge": ([python_ge, str(GE_SCRIPT), str(block)], (0, 1)),
        "blockqc_tp": ([*blockqc, "--rules", str(TP_PACK), "--out", str(tmp / "tp")], (0, 1)),
        "blockqc_pack": ([*blockqc, "--out", str(tmp / "pack")], (0, 1)),
    }
    names = list(commands)
    times, printed = {}, {}
    for name in names[turn % len(names) :] + names[: turn % len(names)]:
        times[name], printed[name] = timed(name, *commands[name])
    seen = {
        "observations": int(printed["read"].split()[0]),
        "ge_output": printed["ge"],
        "ge": json.loads(printed["ge"].strip().splitlines()[-1].removeprefix("verdicts ")),
        "tp": blockqc_statuses(tmp / "tp"),
        "pack": blockqc_statuses(tmp / "pack"),
    }
    return {name: times[name] for name in names}, seen


def compare(seen: dict) -> int:
    """Print GE's verdict and blockqc's statuses per rule; return the number of disagreements."""
    print(seen["ge_output"].rstrip())
    print("rule  ge     blockqc_tp  blockqc_pack")
    disagree = 0
    for rule in RULES:
        ge = "pass" if seen["ge"].get(rule) else "fail"
        tp, pack = seen["tp"][rule], seen["pack"][rule]
        same = ge == tp == pack
        disagree += not same
        print(f"{rule}  {ge:5}  {tp:10}  {pack:12}  {'agree' if same else 'DISAGREE'}")
    return disagree


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("delivery", nargs="?", type=Path, help="a delivery with tie_points.parquet")
    ap.add_argument(
        "--generate", type=int, metavar="N", help="first write a block of N observations"
    )
    ap.add_argument("--scenes", type=int, default=3000, help="scenes of the generated block")
    ap.add_argument("--out", type=Path, help="folder for the generated block")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--ge-python", help="an interpreter with great_expectations installed")
    args = ap.parse_args()
    if (args.delivery is None) == (args.generate is None) or (args.generate and not args.out):
        ap.error("give DELIVERY, or --generate N with --out FOLDER")
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    block = generate(args.generate, args.scenes, args.out) if args.generate else args.delivery
    if not (block / "tie_points.parquet").is_file():
        ap.error(
            f"{block / 'tie_points.parquet'} not found: the benchmark reads Parquet tie points"
        )
    python_ge = ge_python(args.ge_python)
    compile_blockqc()
    rounds = []
    with tempfile.TemporaryDirectory() as tmp:
        for turn in range(args.repeat):
            times, seen = one_round(block, python_ge, Path(tmp), turn)
            rounds.append(times)
    disagree = compare(seen)
    report(rounds, seen["observations"], disagree)


def report(rounds: list[dict[str, float]], n_obs: int, disagree: int) -> None:
    """Each command's min and median, then the one summary line (min times, their ratios)."""
    best = {}
    for name in rounds[0]:
        values = [r[name] for r in rounds]
        best[name] = min(values)
        print(
            f"{name:13} min {min(values):7.2f} s  median {statistics.median(values):7.2f} s"
            f"  ({len(values)} run{'s' if len(values) > 1 else ''})"
        )
    print(f"verdicts: {'all agree' if not disagree else f'{disagree} rule(s) disagree'}")
    r, g, t, p = (best[k] for k in ("read", "ge", "blockqc_tp", "blockqc_pack"))
    print(
        f"tie points: {n_obs} observations, read {r:.2f} s, ge {g:.2f} s, blockqc_tp {t:.2f} s, "
        f"blockqc_pack {p:.2f} s, ge/tp {g / t:.2f}, tp/read {t / r:.2f}, pack/read {p / r:.2f}"
    )


if __name__ == "__main__":
    main()
