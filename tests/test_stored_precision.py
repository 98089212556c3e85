"""Ground columns a Parquet table stores as float32: read as stored, and said with the
resolution the type gives them, in metres, and the rules whose figures they bound."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from blockqc.checkpoint_inputs import load_checkpoint_files, merge_checkpoints
from blockqc.delivery import load_delivery
from blockqc.engine import input_warnings
from blockqc.report.build import INPUT_WARNINGS
from blockqc.report.format import Formatter
from casekit import SAMPLES

SOURCE = SAMPLES / "batch" / "F1-B01"
DEGREE_M = 2 * math.pi * 6_378_137 / 360  # a degree along the equator, 111 319.49 m
SAID = (
    "(the resolution of each at its largest value) stored as float32, not float64: the figures "
    "of {figures} are no finer than that"
)


def _float32_step(largest: float) -> float:
    """float32's spacing at `largest`: 2^(e − 23) for 2^e ≤ largest < 2^(e+1) (24-bit
    significand)."""
    return 2.0 ** (math.floor(math.log2(largest)) - 23)


def _parquet(frame: pd.DataFrame, path: Path, single: list[str]) -> None:
    """`frame` written as Parquet, the `single` columns as float32."""
    frame = frame.astype({c: np.float32 for c in single})
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)


def _delivery(tmp_path: Path, shift: float = 0.0, single: bool = True) -> Path:
    """The sample block with its tie points in Parquet, lon and lat float32 (or float64),
    their longitudes moved by `shift` degrees."""
    folder = tmp_path / "F1-B01"
    shutil.copytree(SOURCE, folder)
    tp = pd.read_csv(folder / "tie_points.csv", dtype={"point_id": str})
    (folder / "tie_points.csv").unlink()
    tp["lon"] += shift
    _parquet(tp, folder / "tie_points.parquet", ["lon", "lat"] if single else [])
    return folder


def test_float32_tie_point_coordinates_are_said_with_their_resolution(tmp_path) -> None:
    """lon near 100.5° holds to 2^-17° = 7.6e-6° (0.849 m east-west at most), lat near 40° to
    2^-18° (0.425 m): read as stored, unsaid."""
    folder = _delivery(tmp_path, shift=60.0)
    d = load_delivery(folder)
    lon, lat = (
        pd.read_parquet(folder / "tie_points.parquet")[c].abs().max() for c in "lon lat".split()
    )
    assert 100 < lon < 128 and 32 < lat < 64
    steps = f"lon {_float32_step(lon) * DEGREE_M:.3g} m, lat {_float32_step(lat) * DEGREE_M:.3g} m"
    assert steps == "lon 0.849 m, lat 0.425 m"
    expected = f"{folder / 'tie_points.parquet'}: {steps} " + SAID.format(figures="RC-1, CP-2")
    assert input_warnings(d) == [expected]


def test_a_resolution_beyond_a_tenth_of_the_plane_norm_is_said_as_coarse(tmp_path) -> None:
    """lon near 170.5°: 2^-16° = 1.70 m, more than 1 m (0.1 of the 10 m plane norm)."""
    folder = _delivery(tmp_path, shift=130.0)
    (warning,) = input_warnings(load_delivery(folder))
    assert warning == (
        f"{folder / 'tie_points.parquet'}: lon 1.7 m, lat 0.425 m (the resolution of each at "
        "its largest value) stored as float32, not float64: coarser than 0.1 of the plane norm "
        "(1 m), the figures of RC-1, CP-2 may be off by that much; write these columns as "
        "float64 (double)"
    )
    assert _float32_step(170.5) * DEGREE_M == pytest.approx(1.6986, abs=1e-4)


def test_float32_checkpoints_are_said_per_column(tmp_path) -> None:
    folder = _delivery(tmp_path, single=False)
    cp = pd.read_csv(folder / "checkpoints.csv")
    (folder / "checkpoints.csv").unlink()
    _parquet(cp, folder / "checkpoints.parquet", ["x_m", "y_m", "z_m"])
    d = load_delivery(folder)
    largest = {c: cp[c].abs().max() for c in ("x_m", "y_m", "z_m")}
    steps = ", ".join(f"{c} {_float32_step(v):.3g} m" for c, v in largest.items())
    assert steps.startswith("x_m 0.0625 m, y_m 0.5 m, z_m ")
    assert input_warnings(d) == [
        f"{folder / 'checkpoints.parquet'}: {steps} " + SAID.format(figures="CP-2, CP-4, CP-3")
    ]
    assert d.checkpoints["y_m"].iloc[0] == np.float32(cp["y_m"].iloc[0])  # read as stored


def test_float64_and_csv_tables_say_nothing(tmp_path) -> None:
    assert input_warnings(load_delivery(_delivery(tmp_path, single=False))) == []
    assert input_warnings(load_delivery(SOURCE)) == []


def test_the_inspectors_float32_checkpoints_are_said_too(tmp_path) -> None:
    folder = tmp_path / "d"
    shutil.copytree(SOURCE, folder)
    cp = pd.read_csv(folder / "checkpoints.csv")
    (folder / "checkpoints.csv").unlink()
    mine = tmp_path / "mine.parquet"
    _parquet(cp.head(5), mine, ["ref_y_m"])
    d = load_delivery(folder)
    merge_checkpoints(d, load_checkpoint_files([mine]).for_block("F1-B01", True))
    step = _float32_step(cp["ref_y_m"].head(5).abs().max())
    assert input_warnings(d) == [
        f"{mine}: ref_y_m {step:.3g} m " + SAID.format(figures="CP-2, CP-4")
    ]


def test_the_warning_in_chinese(tmp_path) -> None:
    folder = _delivery(tmp_path, shift=130.0)
    (warning,) = input_warnings(load_delivery(folder))
    shown = Formatter("zh").sentence(warning.removeprefix(f"{folder}/"), INPUT_WARNINGS)
    assert shown == (
        "tie_points.parquet：lon 1.7 m, lat 0.425 m（各列在其最大值处的分辨率）以 float32 而非 "
        "float64 存储：粗于平面限值的 0.1（1 m），RC-1, CP-2 的数值可能因此偏差同样大小；请以 "
        "float64（双精度）写出这些列"
    )


def test_inspect_says_it_and_goes_on(tmp_path, blockqc) -> None:
    folder = _delivery(tmp_path, shift=60.0)
    proc = blockqc("inspect", folder, "--out", tmp_path / "out", "--no-pdf")
    assert proc.returncode == 0, proc.stderr
    assert f"warning: {folder / 'tie_points.parquet'}: lon 0.849 m, lat 0.425 m (" in proc.stderr


def test_adjust_says_it_too(tmp_path, blockqc) -> None:
    """The producer's ground points (lon, lat, h) of float32 tie points give the checkpoints of
    blockqc adjust: said in adjust.json and on the console as inspect says it."""
    import json

    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    ventoux = Path(__file__).parent / "data" / "rfm" / "phr_ventoux"
    models = [read_rpc(ventoux / f"{side}_image.geom") for side in ("left", "right")]
    cfg = SyntheticConfig(scenes=2, observations_per_scene=60, checkpoints=0, seed=5)
    _, folder = synthetic_block(models, cfg, tmp_path / "blk")
    tp = pd.read_csv(folder / "tie_points.csv", dtype={"point_id": str, "scene_id": str})
    (folder / "tie_points.csv").unlink()
    _parquet(tp, folder / "tie_points.parquet", ["lon", "lat", "h"])
    steps = ", ".join(
        f"{c} {_float32_step(tp[c].abs().max()) * (DEGREE_M if c != 'h' else 1):.3g} m"
        for c in ("lon", "lat", "h")
    )
    expected = f"{folder / 'tie_points.parquet'}: {steps} " + SAID.format(
        figures="RC-1, CP-2, CP-3"
    )
    proc = blockqc("adjust", folder, "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert f"warning: {expected}\n" in proc.stderr
    assert expected in json.loads((tmp_path / "out" / "adjust.json").read_text())["warnings"]
