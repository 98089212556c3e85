"""Times the stock pack over a generated block of about one million tie-point observations.

    python benchmarks/inspect_benchmark.py [--observations 1000000] [--repeat 3]

Prints the time to read and validate the delivery, the time to judge the pack's rules, and
tie-point observations per second for the whole inspection (read + judge).
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from pathlib import Path

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.simulate import Layout, Options, simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--observations", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--obs-per-scene", type=int, default=1250)
    args = ap.parse_args()

    pan_scenes = args.observations / args.obs_per_scene  # two PAN scenes per footprint
    side = max(2, round(math.sqrt(pan_scenes / 2)))
    layout = Layout(rows=side, cols=side, obs_per_scene=args.obs_per_scene)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        simulate(Path(tmp), Options(fields=(1,), blocks_per_field=1, layout=layout))
        block = Path(tmp) / "F1-B01"
        print(
            f"generated {side}x{side} footprints ({3 * side * side} scenes) "
            f"in {time.perf_counter() - t0:.1f} s"
        )
        pack = load_pack("global-project")
        reads, judges = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            d = load_delivery(block)
            t1 = time.perf_counter()
            r = inspect_delivery(d, pack)
            t2 = time.perf_counter()
            reads.append(t1 - t0)
            judges.append(t2 - t1)
        n = len(d.tie_points)
        read, judge = statistics.median(reads), statistics.median(judges)
        print(f"tie-point observations: {n:,}; scenes: {len(d.scenes)}; verdict {r.verdict}")
        print(
            f"read + validate: {read:.2f} s   judge {len(pack.rules)} rules: {judge:.2f} s   "
            f"(median of {args.repeat})"
        )
        print(
            f"throughput: {n / (read + judge):,.0f} observations/s "
            f"(judging alone {n / judge:,.0f}/s)"
        )


if __name__ == "__main__":
    main()
