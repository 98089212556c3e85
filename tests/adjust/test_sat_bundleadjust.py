"""`blockqc adjust` against sat-bundleadjust's GCP-free bundle adjustment of two SkySat images.

Data (tests/data/rfm/README.txt): the original RPCs of two SkySat frames taken 34 s apart
(`…151408…` = A, `…151442…` = B, lat 11.02 N, lon 72.71 W) and the same RPCs re-fitted by
sat-bundleadjust after its adjustment (`.rpc_adj`, IPOL 2021, Mari et al.). Everything expected
here is worked out in plain numpy from the files' coefficients (RPC00B term order,
`test_reference_block.rfm`), nothing of blockqc's geometry or adjustment used. Image size
1350 × 3200 (LINE_SCALE, SAMP_SCALE ≈ half of it); tie-point heights 0–1,000 m.

The correction sat-bundleadjust made (adjusted − original image position of ground points over
the common footprint, heights 0–1,000 m): A by 0.00–0.07 px, B by 0.17–0.21 px (mean line 0.02,
sample 0.19); per image within 0.012 px rms (0.026 max) of an affine in image space (the residue
depends on the height: a perspective camera re-fitted as an RPC, not an affine).

The delivery: 300 ground points over the overlap projected through the ADJUSTED RPCs into both
images, 0.05 px noise per coordinate, `rpc/` the ORIGINAL RPCs and `rpc_adjusted/` the refined
ones (the producer's). Adjusted with `--fix A`, the relative correction of B the data determine
is its component across the epipolar lines: along them (mostly the line direction, 0.8 px per
metre of height) a shift and tilt of B is a shift and tilt of the heights,
left to the priors (σ of a0 10 px, as its prior). The reference relative correction r of B at
each point: B's adjusted position minus B's original projection of the point seen through A's
original RPC (fixed) at A's adjusted position; its across-epipolar component is 0.187 px (rms
0.018 about that). Tolerances: on noise-free tie points the affine of B reproduces it to 0.004 px
rms (0.009 max: the non-affine residue); with 0.05 px on 600 observations the across shift is known
to about 0.05·√2/√300 = 0.004 px and the linear terms at the image edges to about 0.007 px, so
0.02 px rms and 0.05 px max, a tenth of the correction itself; σ0 within 12 % (3σ for its ~300
redundancies) of 0.05 px.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from test_reference_block import on_ground, rfm

from blockqc.rfm.readers import read_rpc

FORMATS = Path(__file__).parents[1] / "data" / "rfm" / "rpc_formats"
NAME = "20200413_1514{}_ssc4d2_0011_basic_panchromatic_dn.{}"
SCENES = {"A": "08", "B": "42"}
LINES, SAMPLES = 1350, 3200
NOISE_PX = 0.05
KEYS = {
    "line_off": "LINE_OFF", "samp_off": "SAMP_OFF", "lat_off": "LAT_OFF",
    "long_off": "LONG_OFF", "height_off": "HEIGHT_OFF", "line_scale": "LINE_SCALE",
    "samp_scale": "SAMP_SCALE", "lat_scale": "LAT_SCALE", "long_scale": "LONG_SCALE",
    "height_scale": "HEIGHT_SCALE",
}  # fmt: skip


def rpc_file(scene: str, adjusted: bool) -> Path:
    return FORMATS / NAME.format(SCENES[scene], "rpc_adj" if adjusted else "rpc")


def parse_txt(path: Path) -> dict:
    """The `KEY: value unit` RPC text (LINE_NUM_COEFF_1 … _20), as test_reference_block's
    `parse_geom` gives it."""
    kv = dict(re.findall(r"^(\w+):\s*(\S+)", path.read_text(), re.M))
    rpc: dict = {k: float(kv[v]) for k, v in KEYS.items()}
    for c in ("line_num", "line_den", "samp_num", "samp_den"):
        rpc[c] = np.array([float(kv[f"{c.upper()}_COEFF_{i}"]) for i in range(1, 21)])
    return rpc


def inside(line, samp, margin=20.0):
    return (
        (line >= margin)
        & (line <= LINES - 1 - margin)
        & (samp >= margin)
        & (samp <= SAMPLES - 1 - margin)
    )


def ground_points(orig, adj, n, seed):
    """n points over the overlap: uniform in A's image, on the ground by A's adjusted RPC at
    heights 0–1,000 m, kept where B's adjusted RPC sees them."""
    rng = np.random.default_rng(seed)
    line, samp = rng.uniform(0, LINES - 1, 8 * n), rng.uniform(0, SAMPLES - 1, 8 * n)
    h = rng.uniform(0.0, 1000.0, 8 * n)
    lon, lat = on_ground(adj["A"], line, samp, h)
    keep = inside(line, samp)
    for k in "AB":
        keep &= inside(*rfm(orig[k], lon, lat, h)) & inside(*rfm(adj[k], lon, lat, h))
    pick = np.flatnonzero(keep)[:n]
    assert pick.size == n
    return lon[pick], lat[pick], h[pick]


def models():
    orig = {k: parse_txt(rpc_file(k, False)) for k in SCENES}
    adj = {k: parse_txt(rpc_file(k, True)) for k in SCENES}
    return orig, adj


def write_delivery(folder: Path, seed=3, swap=False) -> dict:
    """block.yaml, scenes.csv, tie_points.csv (no residuals: the producer's refined RPCs are
    given), rpc/ the original RPCs (A's and B's exchanged with `swap`), rpc_adjusted/."""
    orig, adj = models()
    lon, lat, h = ground_points(orig, adj, 300, seed)
    rng = np.random.default_rng(seed + 1)
    rows = []
    for k in "AB":
        line, samp = rfm(adj[k], lon, lat, h)
        line, samp = line + rng.normal(0, NOISE_PX, h.size), samp + rng.normal(0, NOISE_PX, h.size)
        rows += [(f"P{i:03d}", k, a, b) for i, (a, b) in enumerate(zip(line, samp, strict=True))]
    cols = ["point_id", "scene_id", "line", "sample"]
    (folder / "rpc").mkdir(parents=True)
    (folder / "rpc_adjusted").mkdir()
    pd.DataFrame(rows, columns=cols).to_csv(folder / "tie_points.csv", index=False)
    scenes = []
    for k, other in (("A", "B"), ("B", "A")):
        shutil.copy(rpc_file(other if swap else k, False), folder / "rpc" / f"{k}.rpc")
        shutil.copy(rpc_file(k, True), folder / "rpc_adjusted" / f"{k}.rpc_adj")
        cl = np.array([0.0, 0, LINES - 1, LINES - 1, 0])
        cs = np.array([0.0, SAMPLES - 1, SAMPLES - 1, 0, 0])
        lon_c, lat_c = on_ground(orig[k], cl, cs, 500.0)
        ring = ", ".join(f"{x:.7f} {y:.7f}" for x, y in zip(lon_c, lat_c, strict=True))
        scenes.append((k, "pan", "2020-04-13", LINES, SAMPLES, f"POLYGON(({ring}))"))
    cols = ["scene_id", "band", "acquired", "lines", "samples", "footprint_wkt"]
    pd.DataFrame(scenes, columns=cols).to_csv(folder / "scenes.csv", index=False)
    (folder / "block.yaml").write_text(
        "block_id: SKYSAT-BA\nsensor: SkySat\ngsd_m: {pan: 0.8}\nspatial_reference:\n"
        "  geodetic_datum: WGS84\n  height_datum: ellipsoidal\n"
    )
    return {"orig": orig, "adj": adj, "lon": lon, "lat": lat, "h": h}


def relative_correction(block) -> tuple[np.ndarray, np.ndarray]:
    """Per point, sat-bundleadjust's correction of B relative to A held at its original RPC
    (B adjusted − B original at the point A's original RPC puts under A's adjusted position,
    at the point's height), and the unit vector across B's epipolar line there."""
    orig, adj, lon, lat, h = (block[k] for k in ("orig", "adj", "lon", "lat", "h"))
    line_a, samp_a = rfm(adj["A"], lon, lat, h)

    def seen_in_b(height):
        return np.column_stack(
            rfm(orig["B"], *on_ground(orig["A"], line_a, samp_a, height), height)
        )

    r = np.column_stack(rfm(adj["B"], lon, lat, h)) - seen_in_b(h)
    along = seen_in_b(h + 1.0) - seen_in_b(h)
    along /= np.hypot(*along.T)[:, None]
    return r, np.column_stack([-along[:, 1], along[:, 0]])


def test_the_files_read_as_their_coefficients_say():
    """blockqc's reader of the SkySat `KEY: value unit` text gives the plain RPC00B evaluation
    of the coefficients (original and refined files), and the refined RPCs move A by under
    0.1 px and B by 0.15–0.25 px over the overlap."""
    orig, adj = models()
    rng = np.random.default_rng(0)
    lon, lat = -72.7085 + rng.uniform(-0.008, 0.008, 50), 11.0146 + rng.uniform(-0.003, 0.003, 50)
    h = rng.uniform(0.0, 1000.0, 50)
    for k in SCENES:
        for adjusted, rpc in ((False, orig[k]), (True, adj[k])):
            ours = np.column_stack(read_rpc(rpc_file(k, adjusted)).ground_to_image(lon, lat, h))
            assert np.abs(ours - np.column_stack(rfm(rpc, lon, lat, h))).max() < 1e-6
    block = {"orig": orig, "adj": adj}
    block.update(zip(("lon", "lat", "h"), ground_points(orig, adj, 300, 3), strict=True))
    ground = (block["lon"], block["lat"], block["h"])
    move = {k: np.hypot(*np.subtract(rfm(adj[k], *ground), rfm(orig[k], *ground))) for k in SCENES}
    assert move["A"].max() < 0.1
    assert 0.15 < move["B"].min() and move["B"].max() < 0.25
    r, across = relative_correction(block)
    assert 0.17 < np.mean(np.sum(r * across, axis=1)) < 0.21


def run(blockqc, folder: Path, out: Path, *options):
    r = blockqc("adjust", folder, "--out", out, *options)
    assert r.returncode == 0, r.stderr
    res = json.loads((out / "adjust.json").read_text())
    adj = pd.read_csv(out / "adjustment.csv").set_index("scene_id")
    return res, adj


def test_relative_correction_reproduces_sat_bundleadjust(tmp_path, blockqc):
    folder = tmp_path / "skysat"
    block = write_delivery(folder)
    res, adj = run(blockqc, folder, tmp_path / "out", "--fix", "A")
    assert res["converged"] and res["n_outliers"] == 0 and res["warnings"] == []
    assert 0.88 * NOISE_PX < res["sigma0_px"] < 1.12 * NOISE_PX
    assert res["rms_px_after"] < 0.5 * res["rms_px_before"]
    assert (adj.loc["A", ["a0", "a1", "a2", "b0", "b1", "b2"]] == 0).all()
    r, across = relative_correction(block)
    ties = pd.read_csv(folder / "tie_points.csv")
    line, samp = (ties.loc[ties["scene_id"] == "B", c].to_numpy() for c in ("line", "sample"))
    b = adj.loc["B"]
    delta = np.column_stack([b.a0 + b.a1 * samp + b.a2 * line, b.b0 + b.b1 * samp + b.b2 * line])
    off = np.sum((delta - r) * across, axis=1)
    assert np.sqrt(np.mean(off**2)) < 0.02
    assert np.abs(off).max() < 0.05


def test_exchanged_rpc_files_leave_a_residual_far_above_the_noise(tmp_path, blockqc):
    """A's original RPC given for B and B's for A: the affine takes up hundreds of pixels and
    what it cannot leaves σ0 over 10 times the 0.05 px of the measurements."""
    folder = tmp_path / "swapped"
    write_delivery(folder, swap=True)
    res, adj = run(blockqc, folder, tmp_path / "out", "--fix", "A")
    assert res["sigma0_px"] > 10 * NOISE_PX
    assert abs(adj.loc["B", "b0"]) > 100


def test_exchanged_rpc_files_are_warned_of_by_the_correction_beyond_its_prior(tmp_path, blockqc):
    """The same exchange: B's shift at the image centre, worked out from its affine in
    adjustment.csv (Δl = a0 + a1·s + a2·l at the centre), is far beyond the 10 px a-priori σ,
    and the warning names B with it; A, held, is not named."""
    folder = tmp_path / "swapped"
    write_delivery(folder, swap=True)
    res, adj = run(blockqc, folder, tmp_path / "out", "--fix", "A")
    b = adj.loc["B"]
    lc, sc = (LINES - 1) / 2, (SAMPLES - 1) / 2
    shift = np.hypot(b.a0 + b.a1 * sc + b.a2 * lc, b.b0 + b.b1 * sc + b.b2 * lc)
    assert shift > 5 * 10
    assert res["warnings"] == [
        "1 scene(s) corrected far beyond the a-priori σ of their RPCs (the shift at the image "
        "centre against --sigma-shift, or a linear term at the image edge against "
        f"--sigma-linear, more than 5 times): B ({shift / 10:.0f} σ); no RPC bias "
        "is believed that large: check that each scene's RPC (rpc/) is its own and its tie "
        "points' image coordinates are in its pixels, or give the RPCs' real a-priori accuracy"
    ]
