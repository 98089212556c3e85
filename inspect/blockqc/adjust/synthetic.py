"""A synthetic block with known truth, written as a contract v1.1 delivery (§RC-3 test data).

Real RPCs (e.g. the Pléiades Ventoux pair) are re-centred over a grid of scenes with a chosen
overlap by shifting their LON_OFF/LAT_OFF; alternating models give different viewing angles.
Ground points over a smooth terrain are drawn in the overlaps, projected through the true
adjusted models (contract v1.1 affine per scene, drawn from the stated a-priori accuracy), and
measured with Gaussian noise and a share of gross errors. Everything is vectorized over points
and observations; files are written with pyarrow (a 1,000-scene block in seconds).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
from numpy.typing import NDArray
from pyproj import Transformer

from blockqc.adjust.geometry import (
    RPCStack,
    affine_from_normalized,
    intersect,
    project_adjusted,
)
from blockqc.errors import UsageError
from blockqc.outputs import write_text_atomic
from blockqc.rfm.model import RPCModel
from blockqc.rfm.ortho import utm_ups_crs

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SyntheticConfig:
    """What to simulate; the a-priori σ are those the true affines are drawn from."""

    scenes: int = 16
    overlap: float = 0.25
    observations_per_scene: int = 3000
    noise_px: float = 0.3
    outlier_rate: float = 0.002
    outlier_px: tuple[float, float] = (5.0, 30.0)
    sigma_shift_px: float = 10.0
    sigma_linear_px: float = 2.0
    relief_m: float = 400.0
    terrain_above_m: float = 0.0  # the ground's mean height above the RPCs' HEIGHT_OFF
    checkpoints: int = 0
    producer_residuals: bool = True
    seed: int = 0
    block_id: str = "SYN-B01"


@dataclass
class Truth:
    """The simulated truth: affine per scene, ground point per tie point, gross-error flags."""

    scene_ids: list[str]
    lines: NDArray[np.int64]
    samples: NDArray[np.int64]
    affine: FloatArray
    point_lon: FloatArray
    point_lat: FloatArray
    point_h: FloatArray
    obs_point: NDArray[np.int64]
    obs_scene: NDArray[np.int64]
    line: FloatArray
    sample: FloatArray
    gross: NDArray[np.bool_]
    models: list[RPCModel] = field(default_factory=list)

    @property
    def n_observations(self) -> int:
        return int(self.obs_point.size)


def _shifted(model: RPCModel, dlon: float, dlat: float) -> RPCModel:
    """The same RPC moved on the ground by (dlon, dlat) degrees."""
    values = {k: getattr(model, k) for k in model.__dataclass_fields__}
    values["lon_off"] = model.lon_off + dlon
    values["lat_off"] = model.lat_off + dlat
    values["source"] = ""
    return RPCModel(**values)


def _grid(n: int) -> tuple[int, int]:
    cols = int(np.ceil(np.sqrt(n)))
    return int(np.ceil(n / cols)), cols


def _extent(model: RPCModel) -> tuple[float, float, int, int]:
    """Inner lon/lat extent of a model's image at HEIGHT_OFF, and its size (lines, samples)."""
    lines, samples = int(2 * model.line_off + 1), int(2 * model.samp_off + 1)
    rows = np.array([0.0, 0.0, lines - 1.0, lines - 1.0])
    cols = np.array([0.0, samples - 1.0, 0.0, samples - 1.0])
    lon, lat, _ = model.image_to_ground(rows, cols, model.height_off)
    lon_w = min(abs(lon[1] - lon[0]), abs(lon[3] - lon[2]))
    lat_w = min(abs(lat[2] - lat[0]), abs(lat[3] - lat[1]))
    return float(lon_w), float(lat_w), lines, samples


def make_scenes(
    models: Sequence[RPCModel], cfg: SyntheticConfig, rng: np.random.Generator
) -> tuple[list[RPCModel], NDArray[np.int64], NDArray[np.int64], FloatArray, tuple]:
    """Scenes on a grid (alternating base models), their sizes, true affines and grid steps."""
    if not models or cfg.scenes < 2 or not 0.05 <= cfg.overlap <= 0.45:
        raise UsageError("a synthetic block needs ≥ 1 RPC, ≥ 2 scenes and an overlap in 5–45 %")
    ext = [_extent(m) for m in models]
    lon_w = min(e[0] for e in ext)
    lat_w = min(e[1] for e in ext)
    step = (lon_w * (1 - cfg.overlap), lat_w * (1 - cfg.overlap))
    nr, nc = _grid(cfg.scenes)
    base = models[0]
    out, lines, samples = [], [], []
    for k in range(cfg.scenes):
        r, c = divmod(k, nc)
        m = models[(r + c) % len(models)]
        # put every model's footprint centre where the grid cell says
        dlon = base.lon_off - m.lon_off + c * step[0]
        dlat = base.lat_off - m.lat_off - r * step[1]
        out.append(_shifted(m, dlon, dlat))
        lines.append(ext[(r + c) % len(models)][2])
        samples.append(ext[(r + c) % len(models)][3])
    lines_a, samples_a = np.array(lines), np.array(samples)
    sig = [cfg.sigma_shift_px, cfg.sigma_linear_px, cfg.sigma_linear_px] * 2
    p = rng.normal(0.0, 1.0, (cfg.scenes, 6)) * np.array(sig)
    affine = affine_from_normalized(p, lines_a, samples_a)
    return out, lines_a, samples_a, affine, (nr, nc, step, lon_w, lat_w)


def terrain(lon: FloatArray, lat: FloatArray, h0: float, relief: float) -> FloatArray:
    """A smooth ellipsoidal-height surface for the simulated ground."""
    return h0 + relief * np.sin(lon * 2 * np.pi / 0.37) * np.cos(lat * 2 * np.pi / 0.29)


def _candidates(
    lon: FloatArray, lat: FloatArray, scenes: list[RPCModel], layout: tuple
) -> NDArray[np.int64]:
    """The (up to) 4 grid scenes each ground point can fall in, −1 where none (n, 4)."""
    nr, nc, step, lon_w, lat_w = layout
    west = scenes[0].lon_off - lon_w / 2
    north = scenes[0].lat_off + lat_w / 2
    c0 = np.floor((lon - west) / step[0]).astype(np.int64)
    r0 = np.floor((north - lat) / step[1]).astype(np.int64)
    out = np.full((lon.size, 4), -1, np.int64)
    for j, (dr, dc) in enumerate(((0, 0), (0, -1), (-1, 0), (-1, -1))):
        r, c = r0 + dr, c0 + dc
        k = r * nc + c
        ok = (r >= 0) & (r < nr) & (c >= 0) & (c < nc) & (k < len(scenes))
        out[ok, j] = k[ok]
    return out


def _observe(
    stack: RPCStack,
    affine: FloatArray,
    lines: NDArray[np.int64],
    samples: NDArray[np.int64],
    lon: FloatArray,
    lat: FloatArray,
    h: FloatArray,
    cand: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], FloatArray, FloatArray]:
    """True image positions of each point on each candidate scene it falls in (≥ 2 scenes)."""
    pt = np.repeat(np.arange(lon.size), cand.shape[1])
    sc = cand.ravel()
    keep = sc >= 0
    pt, sc = pt[keep], sc[keep]
    line, samp = project_adjusted(stack, affine, sc, lon[pt], lat[pt], h[pt])
    margin = 20.0
    inside = (line >= margin) & (line <= lines[sc] - 1 - margin)
    inside &= (samp >= margin) & (samp <= samples[sc] - 1 - margin)
    pt, sc, line, samp = pt[inside], sc[inside], line[inside], samp[inside]
    count = np.bincount(pt, minlength=lon.size)
    multi = count[pt] >= 2
    return pt[multi], sc[multi], line[multi], samp[multi]


def _draw_points(
    n: int, scenes: list[RPCModel], layout: tuple, rng: np.random.Generator, cfg: SyntheticConfig
) -> tuple[FloatArray, FloatArray, FloatArray]:
    nr, nc, step, lon_w, lat_w = layout
    west = scenes[0].lon_off - lon_w / 2
    north = scenes[0].lat_off + lat_w / 2
    lon = west + rng.uniform(0.0, (nc - 1) * step[0] + lon_w, n)
    lat = north - rng.uniform(0.0, (nr - 1) * step[1] + lat_w, n)
    h0 = scenes[0].height_off + cfg.terrain_above_m
    return lon, lat, terrain(lon, lat, h0, cfg.relief_m)


def simulate_truth(models: Sequence[RPCModel], cfg: SyntheticConfig) -> Truth:
    """Scenes, true affines, ground points and measured observations (noise and gross errors)."""
    rng = np.random.default_rng(cfg.seed)
    scenes, lines, samples, affine, layout = make_scenes(models, cfg, rng)
    stack = RPCStack.from_models(scenes)
    target = cfg.scenes * cfg.observations_per_scene
    pilot = 20000
    lon, lat, h = _draw_points(pilot, scenes, layout, rng, cfg)
    pt, *_ = _observe(
        stack, affine, lines, samples, lon, lat, h, _candidates(lon, lat, scenes, layout)
    )
    per_candidate = max(pt.size / pilot, 1e-3)
    n = int(target / per_candidate)
    lon, lat, h = _draw_points(n, scenes, layout, rng, cfg)
    cand = _candidates(lon, lat, scenes, layout)
    pt, sc, line, samp = _observe(stack, affine, lines, samples, lon, lat, h, cand)
    used, pt = np.unique(pt, return_inverse=True)
    line = line + rng.normal(0.0, cfg.noise_px, line.size)
    samp = samp + rng.normal(0.0, cfg.noise_px, samp.size)
    gross = rng.random(line.size) < cfg.outlier_rate
    size = rng.uniform(*cfg.outlier_px, int(gross.sum()))
    angle = rng.uniform(0.0, 2 * np.pi, size.size)
    line[gross] += size * np.cos(angle)
    samp[gross] += size * np.sin(angle)
    return Truth(
        scene_ids=[f"S{k + 1:04d}" for k in range(cfg.scenes)],
        lines=lines,
        samples=samples,
        affine=affine,
        point_lon=lon[used],
        point_lat=lat[used],
        point_h=h[used],
        obs_point=pt.astype(np.int64),
        obs_scene=sc,
        line=line,
        sample=samp,
        gross=gross,
        models=scenes,
    )


def rpc_json(model: RPCModel) -> str:
    """An RPC model as the rpcm JSON dictionary (read back by `blockqc.rfm.readers`)."""
    d = {
        "row_offset": model.line_off,
        "col_offset": model.samp_off,
        "lat_offset": model.lat_off,
        "lon_offset": model.lon_off,
        "alt_offset": model.height_off,
        "row_scale": model.line_scale,
        "col_scale": model.samp_scale,
        "lat_scale": model.lat_scale,
        "lon_scale": model.lon_scale,
        "alt_scale": model.height_scale,
        "row_num": model.line_num.tolist(),
        "row_den": model.line_den.tolist(),
        "col_num": model.samp_num.tolist(),
        "col_den": model.samp_den.tolist(),
    }
    return json.dumps({"rpc": d}, indent=1) + "\n"


def _ids(prefix: str, values: NDArray[np.int64], width: int) -> pa.Array:
    text = pc.cast(pa.array(values + 1), pa.string())
    return pc.binary_join_element_wise(prefix, pc.utf8_lpad(text, width, "0"), "")


def _write_csv(path: Path, table: pa.Table) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    pacsv.write_csv(table, tmp)
    tmp.replace(path)


def _footprints(truth: Truth, stack: RPCStack) -> list[str]:
    """Each scene's footprint polygon (lon/lat WKT) at its RPC's HEIGHT_OFF."""
    from blockqc.adjust.geometry import intersect_at_height

    n = len(truth.scene_ids)
    idx = np.repeat(np.arange(n), 4)
    rows = np.stack([np.zeros(n), np.zeros(n), truth.lines - 1.0, truth.lines - 1.0], 1).ravel()
    cols = np.stack([np.zeros(n), truth.samples - 1.0, truth.samples - 1.0, np.zeros(n)], 1)
    lon, lat, _ = intersect_at_height(
        stack, truth.affine, idx, rows, cols.ravel(), stack.offsets[idx, 4]
    )
    lon, lat = lon.reshape(n, 4), lat.reshape(n, 4)
    out = []
    for k in range(n):
        ring = [f"{lon[k, j]:.7f} {lat[k, j]:.7f}" for j in (0, 1, 2, 3, 0)]
        out.append(f"POLYGON(({', '.join(ring)}))")
    return out


def _manifest(cfg: SyntheticConfig, truth: Truth) -> str:
    import yaml

    crs = utm_ups_crs(float(np.mean(truth.point_lon)), float(np.mean(truth.point_lat)))
    doc = {
        "block_id": cfg.block_id,
        "sensor": "synthetic (re-centred real RPCs)",
        "gsd_m": {"pan": 0.7},
        "spatial_reference": {
            "geodetic_datum": "WGS84",
            "height_datum": "ellipsoidal",
            "projection": "UTM",
            "epsg": int(crs.to_epsg()),
        },
    }
    return yaml.safe_dump(doc, sort_keys=False)


def _tie_table(truth: Truth, stack: RPCStack, residuals: bool) -> tuple[pa.Table, tuple | None]:
    """tie_points: measured positions and, if asked, the producer's residuals and ground point
    (the truth's adjustment: intersection of the measured rays with the true affines)."""
    width = max(7, len(str(truth.point_lon.size)))
    cols = {
        "point_id": _ids("P", truth.obs_point, width),
        "scene_id": pa.array(np.asarray(truth.scene_ids)[truth.obs_scene]),
        "line": np.round(truth.line, 4),
        "sample": np.round(truth.sample, 4),
    }
    if not residuals:
        return pa.table(cols), None
    res = intersect(stack, truth.affine, truth.obs_scene, truth.obs_point, truth.line, truth.sample)
    cols["v_line"] = np.round(res.v_line, 4)
    cols["v_sample"] = np.round(res.v_sample, 4)
    cols["lon"] = np.round(res.lon[truth.obs_point], 9)
    cols["lat"] = np.round(res.lat[truth.obs_point], 9)
    cols["h"] = np.round(res.h[truth.obs_point], 4)
    return pa.table(cols), (res.lon, res.lat, res.h)


def _checkpoints(
    truth: Truth, ground: tuple, cfg: SyntheticConfig, epsg: int, rng: np.random.Generator
) -> pa.Table:
    """Checkpoints: the producer's ground points against the true ones (high-precision)."""
    pick = rng.choice(truth.point_lon.size, size=cfg.checkpoints, replace=False)
    to_utm = Transformer.from_crs(4326, epsg, always_xy=True)
    x, y = to_utm.transform(ground[0][pick], ground[1][pick])
    rx, ry = to_utm.transform(truth.point_lon[pick], truth.point_lat[pick])
    return pa.table(
        {
            "point_id": _ids("P", pick, max(7, len(str(truth.point_lon.size)))),
            "method": ["high_precision"] * pick.size,
            "reference_id": ["truth"] * pick.size,
            "x_m": np.round(x, 3),
            "y_m": np.round(y, 3),
            "z_m": np.round(ground[2][pick], 3),
            "ref_x_m": np.round(rx, 3),
            "ref_y_m": np.round(ry, 3),
            "ref_z_m": np.round(truth.point_h[pick], 3),
        }
    )


def write_delivery(truth: Truth, cfg: SyntheticConfig, folder: str | Path) -> Path:
    """Write the block as a contract v1.1 delivery folder (rpc/ as rpcm JSON, adjustment.csv)."""
    import yaml

    folder = Path(folder)
    (folder / "rpc").mkdir(parents=True, exist_ok=True)
    stack = RPCStack.from_models(truth.models)
    manifest = _manifest(cfg, truth)
    write_text_atomic(folder / "block.yaml", manifest)
    n = len(truth.scene_ids)
    scenes = {
        "scene_id": truth.scene_ids,
        "band": ["pan"] * n,
        "acquired": ["2024-05-01"] * n,
        "lines": truth.lines,
        "samples": truth.samples,
        "footprint_wkt": _footprints(truth, stack),
    }
    _write_csv(folder / "scenes.csv", pa.table(scenes))
    for sid, model in zip(truth.scene_ids, truth.models, strict=True):
        write_text_atomic(folder / "rpc" / f"{sid}.json", rpc_json(model))
    adj = {"scene_id": truth.scene_ids}
    for k, name in enumerate(("a0", "a1", "a2", "b0", "b1", "b2")):
        adj[name] = truth.affine[:, k]
    _write_csv(folder / "adjustment.csv", pa.table(adj))
    ties, ground = _tie_table(truth, stack, cfg.producer_residuals or cfg.checkpoints > 0)
    _write_csv(folder / "tie_points.csv", ties)
    if cfg.checkpoints > 0 and ground is not None:
        epsg = int(yaml.safe_load(manifest)["spatial_reference"]["epsg"])
        rng = np.random.default_rng(cfg.seed + 1)
        _write_csv(folder / "checkpoints.csv", _checkpoints(truth, ground, cfg, epsg, rng))
    return folder


def synthetic_block(
    models: Sequence[RPCModel], cfg: SyntheticConfig, folder: str | Path
) -> tuple[Truth, Path]:
    """Simulate and write a synthetic block; returns the truth and the delivery folder."""
    truth = simulate_truth(models, cfg)
    return truth, write_delivery(truth, cfg, folder)
