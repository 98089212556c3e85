"""Clark–Evans R of every scene's tie points: the grid search against one k-d tree (§TP-4).

    PYTHONPATH=inspect python benchmarks/clark_evans_benchmark.py DELIVERY [--repeat N]

Reads `scene_id, line, sample` of DELIVERY/tie_points.parquet with pyarrow (scene codes by
dictionary encoding) and each scene's `lines, samples` from scenes.csv, then computes R in pixel
space with Donnelly's edge correction (area lines·samples, perimeter 2·(lines + samples)), as
`metrics/tiepoints.py` does, two ways:

- `tree`: the former method, one k-d tree over every point with the scenes shifted apart and a
  query of the two nearest points;
- `grid`: `blockqc.spatial.clark_evans_grouped`.

Prints the seconds of each (best of N runs), the largest relative difference of R, and the
peak memory the grid search allocates (tracemalloc, in a run of its own).
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.compute as pc
import pyarrow.parquet as pq
from scipy.spatial import cKDTree

from blockqc.spatial import clark_evans_grouped, expected_nearest_neighbour_distance


def read_block(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, pd.DataFrame]:
    """Sample, line and scene code of each observation, and each code's scene size."""
    table = pq.read_table(folder / "tie_points.parquet", columns=["scene_id", "line", "sample"])
    scenes = pc.dictionary_encode(table["scene_id"]).combine_chunks()
    codes = scenes.indices.to_numpy(zero_copy_only=False).astype(np.int64)
    sizes = pd.read_csv(folder / "scenes.csv", dtype={"scene_id": str}).set_index("scene_id")
    sizes = sizes.reindex(scenes.dictionary.to_pylist())[["lines", "samples"]]
    return table["sample"].to_numpy(), table["line"].to_numpy(), codes, sizes


def tree_r(x, y, g, area, perimeter) -> np.ndarray:
    """R by one k-d tree over all points, each scene shifted onto its own square."""
    k = len(area)
    n = np.bincount(g, minlength=k)
    span = 4.0 * (max(np.ptp(x), np.ptp(y)) + 1.0)
    m = int(np.ceil(np.sqrt(k)))
    pts = np.column_stack([x - x.min() + (g % m) * span, y - y.min() + (g // m) * span])
    dist, _ = cKDTree(pts, balanced_tree=False).query(pts, k=2, workers=-1)
    observed = np.bincount(g, weights=dist[:, 1], minlength=k) / np.maximum(n, 1)
    r = np.full(k, np.nan)
    ok = n >= 2
    r[ok] = observed[ok] / expected_nearest_neighbour_distance(n[ok], area[ok], perimeter[ok])
    return r


def best_of(repeat: int, func, *args) -> tuple[float, np.ndarray]:
    """The shortest time of `repeat` runs, and the result."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = func(*args)
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("delivery", type=Path)
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    x, y, g, sizes = read_block(args.delivery)
    lines, samples = sizes["lines"].to_numpy(float), sizes["samples"].to_numpy(float)
    area, perimeter = lines * samples, 2 * (lines + samples)
    print(f"{len(x):,} observations in {len(sizes):,} scenes")
    t_tree, r_tree = best_of(args.repeat, tree_r, x, y, g, area, perimeter)
    t_grid, r_grid = best_of(args.repeat, clark_evans_grouped, x, y, g, area, perimeter)
    ok = np.isfinite(r_tree)
    assert np.array_equal(ok, np.isfinite(r_grid)), "the methods disagree on which R exist"
    diff = np.max(np.abs(r_grid[ok] - r_tree[ok]) / np.abs(r_tree[ok]), initial=0.0)
    print(f"tree {t_tree:.2f} s   grid {t_grid:.2f} s   ({t_tree / t_grid:.1f}×)")
    print(
        f"largest relative difference of R: {diff:.2e}   (R from {r_grid[ok].min():.4f} "
        f"to {r_grid[ok].max():.4f})"
    )
    tracemalloc.start()
    clark_evans_grouped(x, y, g, area, perimeter)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"grid search peak allocation: {peak / 2**20:.0f} MiB")


if __name__ == "__main__":
    main()
