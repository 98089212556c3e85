"""Fixtures for the §AF analysis tests: small deliveries and DEMs written into tmp_path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio
from rasterio.transform import from_origin

DATA = Path(__file__).resolve().parents[1] / "data" / "analysis"
APPENDIX = (
    Path(__file__).resolve().parents[2] / "samples" / "factors" / "gf7_adjustment_experiments.csv"
)


def box_wkt(lon0: float, lat0: float, lon1: float, lat1: float) -> str:
    """A footprint whose first four vertices are the image corners in contract order:
    (line 0, sample 0) NW, (line 0, sample S) NE, (line L, sample S) SE, (line L, sample 0) SW."""
    pts = [(lon0, lat1), (lon1, lat1), (lon1, lat0), (lon0, lat0), (lon0, lat1)]
    return "POLYGON ((" + ", ".join(f"{x:.6f} {y:.6f}" for x, y in pts) + "))"


def write_delivery(
    root: Path,
    block_id: str,
    scenes: list[dict],
    tie_points: pd.DataFrame,
    checkpoints: pd.DataFrame | None = None,
) -> Path:
    """Write a contract-v1 delivery (block.yaml, scenes.csv, tie_points.csv, checkpoints.csv)."""
    folder = root / block_id
    folder.mkdir(parents=True)
    (folder / "block.yaml").write_text(
        f"block_id: {block_id}\nsensor: GF-7\ngsd_m: {{pan: 0.8, ms: 3.2}}\n"
        "spatial_reference: {geodetic_datum: WGS84, height_datum: ellipsoidal, "
        "projection: UTM, epsg: 32637}\n",
        encoding="utf-8",
    )
    pd.DataFrame(scenes).to_csv(folder / "scenes.csv", index=False)
    tie_points.to_csv(folder / "tie_points.csv", index=False)
    if checkpoints is not None:
        checkpoints.to_csv(folder / "checkpoints.csv", index=False)
    return folder


def synthetic_block(
    root: Path,
    block_id: str,
    lon0: float,
    lat0: float,
    n_scenes: int,
    n_points: int,
    seed: int,
    dates: list[str] | None = None,
) -> Path:
    """A strip of overlapping PAN scenes (each with an MS twin), tie points and checkpoints."""
    rng = np.random.default_rng(seed)
    width, height, step = 0.06, 0.08, 0.04
    scenes = []
    lines, samples = 4000, 3000
    for k in range(n_scenes):
        a, b = lon0 + k * step, lon0 + k * step + width
        date = (dates or ["2023-03-01"])[k % len(dates or ["x"])]
        for band, f in (("pan", 1), ("ms", 4)):
            scenes.append(
                {
                    "scene_id": f"{block_id}-{band.upper()}{k:02d}",
                    "band": band,
                    "acquired": date,
                    "lines": lines // f,
                    "samples": samples // f,
                    "footprint_wkt": box_wkt(a, lat0, b, lat0 + height),
                }
            )
    rows = []
    for p in range(n_points):
        k = int(rng.integers(0, n_scenes - 1))
        # a point in the overlap of scenes k and k + 1, observed on both PAN scenes
        lon = lon0 + (k + 1) * step + rng.uniform(0, width - step)
        lat = lat0 + rng.uniform(0, height)
        for kk in (k, k + 1):
            west = lon0 + kk * step
            rows.append(
                {
                    "point_id": f"P{p:05d}",
                    "scene_id": f"{block_id}-PAN{kk:02d}",
                    "line": (lat0 + height - lat) / height * lines,
                    "sample": (lon - west) / width * samples,
                    "v_line": rng.normal(0, 0.3),
                    "v_sample": rng.normal(0, 0.4),
                }
            )
    cps = pd.DataFrame(
        {
            "point_id": [f"C{i:02d}" for i in range(25)],
            "method": "high_precision",
            "reference_id": "WV-1",
            "x_m": rng.uniform(0, 1000, 25),
            "y_m": rng.uniform(0, 1000, 25),
            "z_m": rng.uniform(0, 100, 25),
        }
    )
    cps["ref_x_m"] = cps["x_m"] + rng.normal(0, 2.0, 25)
    cps["ref_y_m"] = cps["y_m"] + rng.normal(0, 3.0, 25)
    cps["ref_z_m"] = cps["z_m"] + rng.normal(0, 1.5, 25)
    return write_delivery(root, block_id, scenes, pd.DataFrame(rows), cps)


def write_dem(path: Path, z: np.ndarray, lon0: float, lat0: float, res: float, crs: str) -> Path:
    """Write a float32 GeoTIFF with its upper-left corner at (lon0, lat0)."""
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=z.shape[1],
        height=z.shape[0],
        count=1,
        dtype="float32",
        crs=crs,
        transform=from_origin(lon0, lat0, res, res),
        nodata=-9999.0,
    ) as dst:
        dst.write(z.astype("float32"), 1)
    return path


@pytest.fixture(scope="session")
def appendix() -> pd.DataFrame:
    return pd.read_csv(APPENDIX)


@pytest.fixture(scope="session")
def appendix_path() -> Path:
    return APPENDIX


@pytest.fixture(scope="session")
def data_dir() -> Path:
    return DATA


@pytest.fixture(scope="session")
def make_block():
    """Factory: make_block(root, block_id, lon0, lat0, n_scenes, n_points, seed, dates=None)."""
    return synthetic_block


@pytest.fixture(scope="session")
def dem_writer():
    """Factory: dem_writer(path, z, lon0, lat0, res, crs) writes a GeoTIFF."""
    return write_dem


@pytest.fixture(scope="session")
def footprint():
    """Factory: footprint(lon0, lat0, lon1, lat1) -> WKT with the corners in contract order."""
    return box_wkt
