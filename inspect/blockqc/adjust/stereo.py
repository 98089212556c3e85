"""Tie points between two images measured with blockqc's own matcher, as a v1.1 delivery.

Both images are orthorectified with their RPCs on one DEM onto the same grid (§RA-1); the
matcher (§RA-3) pairs their features; each match goes back to both images through the RPC that
made its ortho, at the DEM height under it. Positions in image space are therefore measured
positions of one ground feature in each image, in the convention of each RPC, whatever the error
of the RPCs (an error shifts the orthos, which the matching measures).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from pyproj import CRS, Transformer

from blockqc.adjust.synthetic import rpc_json
from blockqc.outputs import write_text_atomic
from blockqc.rfm.dem import DEM
from blockqc.rfm.model import RPCModel
from blockqc.rfm.ortho import crop_offset_from_file, ortho_grid, orthorectify, read_ortho
from blockqc.rfm.readers import open_raster


def _shape(path: Path) -> tuple[int, int]:
    with open_raster(path) as ds:
        return ds.height, ds.width


def match_pair(
    images: tuple[Path, Path],
    models: tuple[RPCModel, RPCModel],
    dem: DEM,
    grid_px: int = 12,
    **settings: object,
) -> pd.DataFrame:
    """Matches of image 2 against image 1: (line, sample) in both full images, one per cell."""
    from blockqc.matching import match_images

    offsets = [crop_offset_from_file(p) for p in images]
    grid = ortho_grid(models[0], _shape(images[0]), dem, crop_offset=offsets[0])
    with tempfile.TemporaryDirectory(prefix="blockqc-stereo-") as tmp:
        orthos = []
        for k in range(2):
            path = Path(tmp) / f"ortho{k}.tif"
            orthorectify(images[k], models[k], dem, path, grid=grid, crop_offset=offsets[k])
            orthos.append(read_ortho(path)[0])
    m = match_images(
        orthos[0],
        orthos[1],
        image_valid=np.isfinite(orthos[0]),
        reference_valid=np.isfinite(orthos[1]),
        grid=grid_px,
        **settings,
    )
    to_geo = Transformer.from_crs(grid.crs, CRS.from_epsg(4326), always_xy=True)
    out = {}
    for k, (r, c) in enumerate((("row", "col"), ("ref_row", "ref_col"))):
        x, y = grid.xy(m[r].to_numpy(np.float64), m[c].to_numpy(np.float64))
        lon, lat = (np.asarray(v) for v in to_geo.transform(x, y))
        line, sample = models[k].ground_to_image(lon, lat, dem.height(lon, lat))
        out[f"line{k + 1}"], out[f"sample{k + 1}"] = line, sample
    table = pd.DataFrame(out)
    return table[np.isfinite(table).all(axis=1)].reset_index(drop=True)


def write_pair_delivery(
    folder: Path,
    matches: pd.DataFrame,
    models: tuple[RPCModel, RPCModel],
    scene_ids: tuple[str, str],
    block_id: str,
    gsd_m: float,
) -> Path:
    """A v1.1 delivery of the two scenes: block.yaml, scenes.csv, tie_points.csv (no
    residuals: they are computed from geometry), rpc/<scene_id>.json."""
    import yaml

    folder.mkdir(parents=True, exist_ok=True)
    manifest = {
        "block_id": block_id,
        "gsd_m": {"pan": gsd_m},
        "spatial_reference": {"geodetic_datum": "WGS84", "height_datum": "ellipsoidal"},
    }
    write_text_atomic(folder / "block.yaml", yaml.safe_dump(manifest, sort_keys=False))
    rows = []
    for sid, m in zip(scene_ids, models, strict=True):
        lines, samples = int(2 * m.line_off + 1), int(2 * m.samp_off + 1)
        r = np.array([0.0, 0.0, lines - 1.0, lines - 1.0, 0.0])
        c = np.array([0.0, samples - 1.0, samples - 1.0, 0.0, 0.0])
        lon, lat, _ = m.image_to_ground(r, c, m.height_off)
        ring = ", ".join(f"{a:.7f} {b:.7f}" for a, b in zip(lon, lat, strict=True))
        rows.append((sid, "pan", "2013-08-05", lines, samples, f"POLYGON(({ring}))"))
        (folder / "rpc").mkdir(exist_ok=True)
        write_text_atomic(folder / "rpc" / f"{sid}.json", rpc_json(m))
    scenes = pd.DataFrame(
        rows, columns=["scene_id", "band", "acquired", "lines", "samples", "footprint_wkt"]
    )
    write_text_atomic(folder / "scenes.csv", scenes.to_csv(index=False))
    n = len(matches)
    ids = [f"T{i + 1:05d}" for i in range(n)]
    ties = pd.DataFrame(
        {
            "point_id": ids * 2,
            "scene_id": [scene_ids[0]] * n + [scene_ids[1]] * n,
            "line": np.r_[matches["line1"], matches["line2"]],
            "sample": np.r_[matches["sample1"], matches["sample2"]],
        }
    )
    write_text_atomic(folder / "tie_points.csv", ties.to_csv(index=False, float_format="%.4f"))
    return folder
