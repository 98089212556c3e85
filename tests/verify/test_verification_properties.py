"""Properties of the process-data verification (§RC-1, §RC-2) on the real Ventoux RPCs."""

from __future__ import annotations

import numpy as np
import pandas as pd
from geokit import FILES
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.delivery import Delivery, Manifest
from blockqc.geometry_inputs import BlockGeometry
from blockqc.rfm.model import ImageAffine, RefinedRFM
from blockqc.rfm.readers import read_rpc
from blockqc.verification import compute

RPCS = [read_rpc(f) for f in FILES.values()]
SCENES = list(FILES)


def _delivery(obs: pd.DataFrame, affine: np.ndarray) -> Delivery:
    geo = BlockGeometry(
        original=dict(zip(SCENES, RPCS, strict=True)),
        scene_ids=SCENES,
        adjusted=RPCS,
        affine=affine,
        source="adjustment.csv",
    )
    manifest = Manifest.model_validate({"block_id": "P", "gsd_m": {"pan": 0.7}})
    return Delivery(path=None, manifest=manifest, scenes=None, tie_points=obs, geometry=geo)  # type: ignore[arg-type]


def _observe(seed: int, n: int, noise: float, affine: np.ndarray) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rpc = RPCS[0]
    lon = rpc.lon_off + rng.uniform(-0.03, 0.03, n)
    lat = rpc.lat_off + rng.uniform(-0.03, 0.03, n)
    h = rpc.height_off + rng.uniform(-400, 400, n)
    parts = []
    for k, sid in enumerate(SCENES):
        model = RefinedRFM(RPCS[k], ImageAffine(*(-affine[k])))
        line, sample = model.ground_to_image(lon, lat, h)
        parts.append(
            pd.DataFrame(
                {
                    "point_id": [f"Q{i}" for i in range(n)],
                    "scene_id": sid,
                    "line": line + rng.normal(0, noise, n),
                    "sample": sample + rng.normal(0, noise, n),
                }
            )
        )
    return pd.concat(parts, ignore_index=True)


affines = st.tuples(*[st.floats(-5, 5), st.floats(-1e-4, 1e-4), st.floats(-1e-4, 1e-4)] * 2).map(
    lambda t: np.array(t, dtype=float)
)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), a=affines, b=affines)
def test_exact_rays_give_zero_residuals(seed: int, a: np.ndarray, b: np.ndarray) -> None:
    affine = np.stack([a, b])
    obs = _observe(seed, 25, 0.0, affine)
    pdata = compute(_delivery(obs, affine))
    assert np.abs(pdata.observations[["v_line_computed", "v_sample_computed"]]).max().max() < 1e-5
    assert np.allclose(pdata.overlaps[["dx_m", "dy_m"]], 0.0, atol=1e-4)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), a=affines, b=affines)
def test_residuals_do_not_depend_on_row_order(seed: int, a: np.ndarray, b: np.ndarray) -> None:
    affine = np.stack([a, b])
    obs = _observe(seed, 25, 0.5, affine)
    first = compute(_delivery(obs, affine)).observations.set_index(["point_id", "scene_id"])
    shuffled = obs.sample(frac=1.0, random_state=seed).reset_index(drop=True)
    again = compute(_delivery(shuffled, affine)).observations.set_index(["point_id", "scene_id"])
    cols = ["v_line_computed", "v_sample_computed"]
    assert np.allclose(again.loc[first.index, cols], first[cols], atol=1e-7)
    # two rays: the residuals of a point on the two scenes are not all zero with noise
    assert np.abs(first[cols].to_numpy()).max() > 0.01
