"""Shared helpers of the RFM tests: the real RPCs of tests/data/rfm and GDAL's RPC transformer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rasterio.rpc import RPC
from rasterio.transform import RPCTransformer

from blockqc.rfm.model import RPCModel

DATA = Path(__file__).resolve().parents[1] / "data" / "rfm"
VENTOUX = DATA / "phr_ventoux"

REAL_RPC_FILES = sorted(
    [p for p in (DATA / "rpc_formats").iterdir() if p.is_file()]
    + [
        VENTOUX / "left_image.geom",
        VENTOUX / "right_image.geom",
        VENTOUX / "lowres_color_image.geom",
        VENTOUX / "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML",
        DATA / "gf_rpc_txt" / "left_image_rpc.txt",
    ]
)


def ventoux_config(out: Path, **options):
    """The Ventoux left image against the right one as a same-accuracy reference (EGM96),
    writing into `out`; `options` set (or replace) the run's other fields."""
    from blockqc.rfm.pipeline import RfmAccuracyConfig

    fields = {
        "image": VENTOUX / "left_image.tif",
        "rpc": VENTOUX / "left_image.geom",
        "dem": VENTOUX / "srtm_N44E005_crop.tif",
        "geoid": "egm96",
        "reference": VENTOUX / "right_image.tif",
        "reference_rpc": VENTOUX / "right_image.geom",
    }
    return RfmAccuracyConfig(out=out, **(fields | options))


# ASP's sample.RPB has denominators reaching -15 inside the normalized cube: it is one-to-one
# (and physical) only near its centre, so its round trips use that part of the domain.
DOMAIN = {"sample.RPB": 0.25}


def domain(path: Path) -> float:
    return DOMAIN.get(path.name, 1.0)


def gdal_transformer(m: RPCModel, **options: object) -> RPCTransformer:
    """GDAL's RPC transformer for the same 90 numbers (an independent implementation)."""
    rpc = RPC(
        height_off=m.height_off,
        height_scale=m.height_scale,
        lat_off=m.lat_off,
        lat_scale=m.lat_scale,
        long_off=m.lon_off,
        long_scale=m.lon_scale,
        line_off=m.line_off,
        line_scale=m.line_scale,
        samp_off=m.samp_off,
        samp_scale=m.samp_scale,
        line_num_coeff=list(m.line_num),
        line_den_coeff=list(m.line_den),
        samp_num_coeff=list(m.samp_num),
        samp_den_coeff=list(m.samp_den),
    )
    return RPCTransformer(rpc, **options)


def ground_sample(
    m: RPCModel, n: int, seed: int, extent: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random ground points inside the model's normalized cube shrunk by `extent`."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-extent, extent, (3, n))
    return (
        m.lon_off + u[0] * m.lon_scale,
        m.lat_off + u[1] * m.lat_scale,
        m.height_off + u[2] * m.height_scale,
    )
