"""The synthetic truth block: a readable v1.1 delivery whose numbers follow from the truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from blockqc.adjust.geometry import RPCStack, project_adjusted
from blockqc.adjust.synthetic import SyntheticConfig, simulate_truth, synthetic_block
from blockqc.delivery import load_delivery
from blockqc.rfm.readers import read_rpc

DATA = Path(__file__).parents[1] / "data" / "rfm" / "phr_ventoux"
MODELS = [read_rpc(DATA / "left_image.geom"), read_rpc(DATA / "right_image.geom")]


def test_delivery_reads_back_and_holds_the_truth(tmp_path):
    cfg = SyntheticConfig(scenes=6, observations_per_scene=400, checkpoints=25, seed=3)
    truth, folder = synthetic_block(MODELS, cfg, tmp_path / "blk")
    d = load_delivery(folder)
    assert len(d.scenes) == 6 and len(d.tie_points) == truth.n_observations
    assert len(d.checkpoints) == 25
    per_point = d.tie_points.groupby("point_id", observed=True).size()
    assert per_point.min() >= 2 and per_point.max() <= 4
    adj = pd.read_csv(folder / "adjustment.csv")
    np.testing.assert_allclose(adj[["a0", "a1", "a2", "b0", "b1", "b2"]], truth.affine)
    rpc = read_rpc(folder / "rpc" / "S0004.json")
    lon, lat, h = truth.point_lon[:5], truth.point_lat[:5], truth.point_h[:5]
    np.testing.assert_allclose(
        rpc.ground_to_image(lon, lat, h), truth.models[3].ground_to_image(lon, lat, h), atol=1e-9
    )


def test_measurements_are_the_true_projection_plus_noise():
    cfg = SyntheticConfig(scenes=4, observations_per_scene=2000, noise_px=0.5, seed=5)
    truth = simulate_truth(MODELS, cfg)
    stack = RPCStack.from_models(truth.models)
    p = truth.obs_point
    ground = truth.point_lon[p], truth.point_lat[p], truth.point_h[p]
    line, samp = project_adjusted(stack, truth.affine, truth.obs_scene, *ground)
    err = np.r_[truth.line - line, truth.sample - samp][np.r_[~truth.gross, ~truth.gross]]
    assert abs(err.std() - 0.5) < 0.02 and abs(err.mean()) < 0.02
    big = np.hypot(truth.line - line, truth.sample - samp)[truth.gross]
    assert np.all(big > 5.0 - 4 * 0.5)
