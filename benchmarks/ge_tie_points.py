"""The stock pack's tie-point checks TP-1..TP-4 as a Great Expectations suite, for comparison.

    python benchmarks/ge_tie_points.py DELIVERY

Runs in an interpreter with `great_expectations` (benchmarks/requirements-ge.txt), not in
blockqc's. Reads `scene_id, v_line, v_sample` of DELIVERY/tie_points.parquet with pyarrow and the
scenes' bands and water fractions from scenes.csv, computes each observation's error
√(v_l² + v_s²) in pandas, and validates (GE 1.x, ephemeral context, pandas data source):

- TP-1: the median error of the PAN scenes' observations ≤ 0.5 px;
- TP-2: the largest error ≤ 1.5 px;
- TP-3: at least 95 % of the errors ≤ 1.0 px (`mostly=0.95`);
- TP-4: every PAN scene that is not mostly water (water_fraction < 0.5) holds ≥ 100 observations.

Prints each expectation's result and observed value, the suite's success, and one last line
`verdicts {"TP-1": true, …}` (JSON) for benchmarks/tie_point_benchmark.py. Exit status 0 when
every expectation holds, 1 when one does not, 2 when the delivery cannot be read.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import great_expectations as gx
import great_expectations.expectations as gxe
import numpy as np
import pandas as pd
import pyarrow.parquet as pq

COLUMNS = ["scene_id", "v_line", "v_sample"]
EXEMPT_WATER_FRACTION = 0.5  # the stock pack's TP-4 `exempt_water_fraction`


def read_delivery(folder: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """PAN observations with their error column, and the observation count of each PAN scene."""
    scenes = pd.read_csv(folder / "scenes.csv", dtype={"scene_id": str, "band": str})
    pan = scenes[scenes["band"] == "pan"]
    tp = pq.read_table(folder / "tie_points.parquet", columns=COLUMNS).to_pandas()
    tp = tp[tp["scene_id"].isin(pan["scene_id"])]
    tp = tp.assign(error_px=np.sqrt(tp["v_line"] ** 2 + tp["v_sample"] ** 2))
    water = pan["water_fraction"].fillna(0.0) if "water_fraction" in pan else 0.0
    land = pan.loc[water < EXEMPT_WATER_FRACTION, "scene_id"]
    counts = tp.groupby("scene_id").size().reindex(land, fill_value=0)
    per_scene = pd.DataFrame({"scene_id": counts.index, "n_points": counts.to_numpy()})
    return tp[["scene_id", "error_px"]], per_scene


def suites() -> tuple[gx.ExpectationSuite, gx.ExpectationSuite]:
    """The observations' suite (TP-1..TP-3) and the scenes' suite (TP-4)."""
    errors = gx.ExpectationSuite(
        name="tie_point_errors",
        expectations=[
            gxe.ExpectColumnMedianToBeBetween(
                column="error_px", max_value=0.5, meta={"rule": "TP-1"}
            ),
            gxe.ExpectColumnMaxToBeBetween(column="error_px", max_value=1.5, meta={"rule": "TP-2"}),
            gxe.ExpectColumnValuesToBeBetween(
                column="error_px", max_value=1.0, mostly=0.95, meta={"rule": "TP-3"}
            ),
        ],
    )
    counts = gx.ExpectationSuite(
        name="tie_points_per_scene",
        expectations=[
            gxe.ExpectColumnValuesToBeBetween(
                column="n_points", min_value=100, meta={"rule": "TP-4"}
            )
        ],
    )
    return errors, counts


def validate(context: Any, name: str, suite: gx.ExpectationSuite, frame: pd.DataFrame) -> Any:
    """One dataframe asset, a whole-dataframe batch definition, a validation definition, run."""
    asset = context.data_sources.add_pandas(name).add_dataframe_asset(name=name)
    batch = asset.add_batch_definition_whole_dataframe(name)
    suite = context.suites.add(suite)
    definition = context.validation_definitions.add(
        gx.ValidationDefinition(name=name, data=batch, suite=suite)
    )
    return definition.run(batch_parameters={"dataframe": frame})


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    folder = Path(argv[0])
    try:
        observations, per_scene = read_delivery(folder)
    except (OSError, KeyError, ValueError) as exc:
        print(f"{folder}: cannot read the tie points or scenes: {exc}", file=sys.stderr)
        return 2
    context = gx.get_context(mode="ephemeral")
    errors, counts = suites()
    runs = [
        validate(context, "observations", errors, observations),
        validate(context, "scenes", counts, per_scene),
    ]
    verdicts = {}
    for run in runs:
        for r in run.results:
            rule = r.expectation_config.meta["rule"]
            verdicts[rule] = bool(r.success)
            print(f"{rule} {r.expectation_config.type}: success={r.success} {_observed(r.result)}")
    success = all(run.success for run in runs)
    print(f"observations {len(observations)}, scenes {len(per_scene)}, success={success}")
    print("verdicts " + json.dumps(verdicts))
    return 0 if success else 1


def _observed(result: dict) -> str:
    """What an expectation saw: its observed value, or the share of unexpected values."""
    if "observed_value" in result:
        return f"observed {result['observed_value']}"
    return (
        f"unexpected {result.get('unexpected_count')} of {result.get('element_count')} "
        f"({result.get('unexpected_percent', 0.0):.3f} %)"
    )


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
