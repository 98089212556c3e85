"""A small contract v1.1 delivery over real RPCs, with residuals from an independent solver.

Two PAN scenes with the real RPCs of the Pléiades Ventoux stereo pair (tests/data/rfm), a known
producer's affine per scene, tie points at random ground positions observed on both scenes
through the adjusted models plus Gaussian noise. The residuals a producer would deliver are
computed here with scipy's least_squares per point over `blockqc.rfm.model.RefinedRFM` — an
implementation independent of the vectorized intersection under test.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from scipy.optimize import least_squares

from blockqc.rfm.model import ImageAffine, RefinedRFM
from blockqc.rfm.readers import read_rpc
from casekit import ROOT, write_delivery

RPCS = ROOT / "tests" / "data" / "rfm" / "phr_ventoux"
FILES = {"L": RPCS / "left_image.geom", "R": RPCS / "right_image.geom"}
#: the producer's adjustment, contract form: l = RFM_l + a0 + a1·s + a2·l (pixels)
AFFINE = {
    "L": (1.5, 2e-5, -1e-5, -0.8, 1e-5, 3e-5),
    "R": (-2.0, -1e-5, 2e-5, 1.2, -2e-5, 1e-5),
}
KEYS = ("a0", "a1", "a2", "b0", "b1", "b2")


def adjusted_models() -> dict[str, RefinedRFM]:
    """The contract's affine is ImageAffine with negated parameters (RFM = l + Δl there)."""
    return {
        s: RefinedRFM(read_rpc(f), ImageAffine(*(-a for a in AFFINE[s]))) for s, f in FILES.items()
    }


def ground_points(n: int, seed: int) -> pd.DataFrame:
    rpc = read_rpc(FILES["L"])
    rng = np.random.default_rng(seed)
    return pd.DataFrame(
        {
            "point_id": [f"G{i:04d}" for i in range(n)],
            "lon": rpc.lon_off + rng.uniform(-0.03, 0.03, n),
            "lat": rpc.lat_off + rng.uniform(-0.03, 0.03, n),
            "h": rpc.height_off + rng.uniform(-300.0, 300.0, n),
        }
    )


def observe(ground: pd.DataFrame, noise_px: float, seed: int) -> pd.DataFrame:
    """Observations of every ground point on both scenes through the adjusted models."""
    models = adjusted_models()
    rng = np.random.default_rng(seed + 1)
    parts = []
    for sid, m in models.items():
        line, sample = m.ground_to_image(ground["lon"], ground["lat"], ground["h"])
        parts.append(
            pd.DataFrame(
                {
                    "point_id": ground["point_id"],
                    "scene_id": sid,
                    "line": line + rng.normal(0.0, noise_px, len(ground)),
                    "sample": sample + rng.normal(0.0, noise_px, len(ground)),
                }
            )
        )
    return pd.concat(parts, ignore_index=True).sort_values(["point_id", "scene_id"])


def reference_residuals(obs: pd.DataFrame, start: pd.DataFrame) -> pd.DataFrame:
    """computed − measured per observation, by scipy least squares point by point."""
    models = adjusted_models()
    out = []
    for pid, g in obs.groupby("point_id", sort=False):
        x0 = start.set_index("point_id").loc[pid, ["lon", "lat", "h"]].to_numpy(float)
        scale = np.array([1e-5, 1e-5, 1.0])

        def resid(x, g=g, x0=x0, scale=scale):
            lon, lat, h = x0 + x * scale
            r = [np.array(models[s].ground_to_image(lon, lat, h)) for s in g["scene_id"]]
            return (np.array(r) - g[["line", "sample"]].to_numpy()).ravel()

        sol = least_squares(resid, np.zeros(3), xtol=1e-14, ftol=1e-14, gtol=1e-14)
        v = resid(sol.x).reshape(-1, 2)
        out.append(g.assign(v_line=v[:, 0], v_sample=v[:, 1]))
    return pd.concat(out)


def scenes_table() -> pd.DataFrame:
    rows = []
    for sid, f in FILES.items():
        rpc = read_rpc(f)
        lines, samples = int(2 * rpc.line_off), int(2 * rpc.samp_off)
        corners = np.array([[0, 0], [0, samples], [lines, samples], [lines, 0], [0, 0]], float)
        lon, lat, _ = rpc.image_to_ground(corners[:, 0], corners[:, 1], rpc.height_off)
        wkt = "POLYGON((" + ", ".join(f"{x} {y}" for x, y in zip(lon, lat, strict=True)) + "))"
        rows.append((sid, "pan", "2013-08-05", lines, samples, wkt))
    cols = ["scene_id", "band", "acquired", "lines", "samples", "footprint_wkt"]
    return pd.DataFrame(rows, columns=cols)


def write_v11(
    folder: Path, tie_points: pd.DataFrame, adjustment: bool = True, overlaps: bool = False
) -> Path:
    """A delivery (casekit's manifest and documents) with the Ventoux scenes and geometry."""
    # the base tables' checkpoints are another area's metres, not about Ventoux
    remove = ["pan_ms", "checkpoints"] + ([] if overlaps else ["overlaps"])
    write_delivery(folder, {"remove_tables": remove})
    manifest = yaml.safe_load((folder / "block.yaml").read_text())
    manifest["spatial_reference"]["epsg"] = 32631
    (folder / "block.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    scenes_table().to_csv(folder / "scenes.csv", index=False)
    tie_points.to_csv(folder / "tie_points.csv", index=False)
    (folder / "rpc").mkdir()
    for sid, f in FILES.items():
        shutil.copy(f, folder / "rpc" / f"{sid}.geom")
    if adjustment:
        rows = [(sid, *AFFINE[sid]) for sid in FILES]
        pd.DataFrame(rows, columns=["scene_id", *KEYS]).to_csv(
            folder / "adjustment.csv", index=False
        )
    return folder
