"""Reproducible sample deliveries mirroring the four published test fields (DOMAIN.md §CP).

Each field is a few blocks of GF-7-like stereo scenes (forward and backward PAN plus backward MS
per footprint) with tie-point residuals, PAN–MS, overlap and edge discrepancies, documents, and
one sampled block whose checkpoint errors are drawn so that their statistics reproduce the
published ones (medium or mean error, maximum error, number of gross errors). Faults can be
switched on to make any rule fail.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from pyproj import Transformer

from blockqc.errors import UsageError
from blockqc.outputs import empty_removed, refuse_delivery, write_bytes_atomic, write_text_atomic
from blockqc.resources import _CHECKOUT

FAULTS = {
    "sparse-scene": "one PAN scene keeps only 60 tie points (TP-4)",
    "clustered-scene": "one PAN scene's tie points crowd into one corner (TP-5)",
    "tp-noise": "tie-point residuals twice as large (TP-1, TP-2, TP-3)",
    "tp-outlier": "a few tie-point observations beyond 1.5 px (TP-2)",
    "sea-scene": "one PAN scene mostly sea, with few tie points (TP-4 exemption, shown)",
    "pan-ms-shift": "one PAN/MS pair misregistered by 1.5 MS pixels (RO-1)",
    "edge-shift": "discrepancies with the neighbouring block beyond 2·m (RO-2)",
    "overlap-shift": "some adjacent-image pairs offset beyond 2√2·m (RO-3)",
    "wrong-zone": "projected in the neighbouring UTM zone (MB-3)",
    "geoid-heights": "heights stated above the EGM96 geoid (MB-2)",
    "missing-document": "the absolute orientation report is missing (DOC-1)",
    "misreported": "the reported tie-point error differs from the process data (DOC-2)",
}

#: the footprints a block needs for a fault to act on it: the PAN scene it alters (the 6th, the
#: 7th, the 3rd; two PAN scenes a footprint), a pair of adjacent footprints
FAULT_FOOTPRINTS = {"sparse-scene": 3, "clustered-scene": 4, "sea-scene": 2, "overlap-shift": 2}

DOCUMENTS = {
    "technical_design": "documents/technical_design.pdf",
    "technical_summary": "documents/technical_summary.pdf",
    "inspection_report": "documents/inspection_report.pdf",
    "relative_orientation_report": "documents/relative_orientation.pdf",
    "absolute_orientation_report": "documents/absolute_orientation.pdf",
}


@dataclass(frozen=True)
class CheckSet:
    """Checkpoints of one method and component with the published statistics to reproduce."""

    method: str
    component: str  # plane | height
    n: int  # all checkpoints N, gross errors included
    medium: float  # M1/M2, or the mean error when N < 20 (§CP-7)
    max_error: float
    n_gross: int


@dataclass(frozen=True)
class FieldSpec:
    number: int
    lon0: float  # west edge of the field's first block
    lat0: float  # south edge
    geoid_n: float  # EGM96 undulation at the field (m)
    dem: str  # DEM tile in samples/dem
    checks: tuple[CheckSet, ...]
    hp_references: tuple[int, ...]  # checkpoints per high-precision reference image
    stereo_reference: bool  # high-precision references give heights too
    faults: frozenset[str] = frozenset()


# Published results (DOMAIN.md §CP, four test fields).
FIELDS = {
    1: FieldSpec(
        1,
        40.04,
        39.62,
        29.64,
        "srtm_40E39N_demcompare.tif",
        (
            CheckSet("high_precision", "plane", 36, 3.33, 8.94, 0),
            CheckSet("high_precision", "height", 36, 2.69, 7.39, 0),
        ),
        (3,) * 12,
        True,
    ),
    2: FieldSpec(
        2,
        5.10,
        44.55,
        51.73,
        "srtm_N44E005.tif",
        (
            CheckSet("high_precision", "plane", 30, 6.22, 17.67, 1),
            CheckSet("same_accuracy", "height", 30, 1.92, 6.78, 0),
            CheckSet("recalculation", "plane", 30, 5.28, 14.44, 1),
            CheckSet("recalculation", "height", 30, 2.84, 9.36, 0),
        ),
        (3,) * 10,
        False,
    ),
    3: FieldSpec(
        3,
        40.04,
        39.22,
        29.64,
        "srtm_40E39N_demcompare.tif",
        (
            CheckSet("high_precision", "plane", 8, 15.7, 18.25, 3),
            CheckSet("same_accuracy", "plane", 23, 7.14, 16.85, 2),
            CheckSet("same_accuracy", "height", 24, 2.94, 11.21, 2),
        ),
        (3, 3, 2),
        False,
        frozenset({"overlap-shift"}),
    ),
    4: FieldSpec(
        4,
        5.10,
        44.10,
        51.73,
        "srtm_N44E005.tif",
        (
            CheckSet("same_accuracy", "plane", 25, 2.26, 5.57, 0),
            CheckSet("same_accuracy", "height", 25, 3.09, 11.96, 0),
        ),
        (),
        False,
    ),
}

NORM = {"plane": 10.0, "height": 6.0}
FACTOR = {
    "high_precision": 2.0,
    "same_accuracy": 2 * math.sqrt(2),
    "recalculation": 2 * math.sqrt(2),
}
DIVISOR = {"high_precision": 1.0, "same_accuracy": 2.0, "recalculation": 2.0}


@dataclass
class Layout:
    """Block geometry: a grid of footprints of `size_deg`, overlapping by `overlap`."""

    rows: int = 4
    cols: int = 4
    size_deg: float = 0.1
    overlap: float = 0.2
    obs_per_scene: int = 300
    gsd_pan: float = 0.8
    gsd_ms: float = 2.6
    rotation_deg: float = 6.0

    @property
    def extent_deg(self) -> tuple[float, float]:
        step = self.size_deg * (1 - self.overlap)
        return (self.size_deg + (self.cols - 1) * step, self.size_deg + (self.rows - 1) * step)


@dataclass
class Options:
    seed: int = 20231
    fields: tuple[int, ...] = (1, 2, 3, 4)
    blocks_per_field: int = 2
    layout: Layout = field(default_factory=Layout)
    faults: frozenset[str] = frozenset()


def _affine_corners(lon_c: float, lat_c: float, w: float, h: float, rot: float) -> np.ndarray:
    """Footprint corners in image order: (0,0), (0,samples), (lines,samples), (lines,0)."""
    k = 1.0 / math.cos(math.radians(lat_c))  # keep the shape square on the ground
    local = np.array([[-w / 2, h / 2], [w / 2, h / 2], [w / 2, -h / 2], [-w / 2, -h / 2]])
    c, s = math.cos(math.radians(rot)), math.sin(math.radians(rot))
    xy = local @ np.array([[c, s], [-s, c]])
    return np.column_stack([lon_c + xy[:, 0] * k, lat_c + xy[:, 1]])


def _wkt(corners: np.ndarray) -> str:
    ring = np.vstack([corners, corners[:1]])
    return "POLYGON((" + ", ".join(f"{x:.6f} {y:.6f}" for x, y in ring) + "))"


def _image_coords(
    corners: np.ndarray, lon: np.ndarray, lat: np.ndarray, lines: int, samples: int
) -> tuple[np.ndarray, np.ndarray]:
    """Invert the parallelogram footprint: lon/lat → (line, sample)."""
    o = corners[0]
    e_s = (corners[1] - o) / samples
    e_l = (corners[3] - o) / lines
    m = np.column_stack([e_s, e_l])
    sol = np.linalg.solve(m, np.vstack([lon - o[0], lat - o[1]]))
    return sol[1], sol[0]


def _errors_with_stats(rng: np.random.Generator, cs: CheckSet) -> np.ndarray:
    """|Δ| of N checkpoints whose medium (or mean) error, max and gross count are as published."""
    bound = FACTOR[cs.method] * NORM[cs.component]
    n = cs.n - cs.n_gross
    gross = rng.uniform(1.08, 1.6, cs.n_gross) * bound
    use_mean = cs.n < 20
    for attempt in range(1200):
        # realistic (Rayleigh) shapes first; narrower ones when the published max is tight
        lo = (attempt - 200) / 1000
        rest = rng.rayleigh(1.0, n - 1) if lo < 0 else rng.uniform(lo, 1.0, n - 1)
        if use_mean:  # n·mean·√divisor = Σ|Δ|
            total = cs.medium * math.sqrt(DIVISOR[cs.method]) * n - cs.max_error
            scale = total / rest.sum()
        else:  # ΣΔ² = divisor·n·M²
            total = DIVISOR[cs.method] * n * cs.medium**2 - cs.max_error**2
            scale = math.sqrt(total / (rest**2).sum()) if total > 0 else -1.0
        values = rest * scale
        if scale > 0 and values.max() < cs.max_error:
            return np.concatenate([[cs.max_error], values, gross])
    raise ValueError(f"cannot draw {cs}: the published figures are inconsistent")


class _Block:
    """Builds one block's tables."""

    def __init__(
        self,
        spec: FieldSpec,
        index: int,
        opts: Options,
        rng: np.random.Generator,
        faults: frozenset[str],
    ):
        self.spec, self.index, self.opts, self.rng, self.faults = spec, index, opts, rng, faults
        self.lay = opts.layout
        w, _ = self.lay.extent_deg
        self.block_id = block_id(spec.number, index)
        self.lon0 = spec.lon0 + index * (w - self.lay.size_deg * self.lay.overlap) / math.cos(
            math.radians(spec.lat0)
        )
        self.lat0 = spec.lat0

    def scenes(self) -> pd.DataFrame:
        lay = self.lay
        step = lay.size_deg * (1 - lay.overlap)
        k = 1.0 / math.cos(math.radians(self.lat0))
        size_m = lay.size_deg * 111_320.0
        lines = int(round(size_m / lay.gsd_pan))
        rows = []
        base = np.datetime64("2021-03-02") + np.int64(self.spec.number * 40)
        for c in range(lay.cols):  # one orbit per column
            date = base + np.int64(c * 23 + (c % 2) * 180)
            for r in range(lay.rows):
                lon_c = self.lon0 + (lay.size_deg / 2 + c * step) * k
                lat_c = self.lat0 + lay.size_deg / 2 + r * step
                corners = _affine_corners(
                    lon_c, lat_c, lay.size_deg, lay.size_deg, lay.rotation_deg
                )
                fp = f"{self.spec.number}{self.index + 1:02d}{c:02d}{r:02d}"
                for view, band, n in (
                    ("F", "pan", lines),
                    ("B", "pan", lines),
                    ("M", "ms", int(round(lines * lay.gsd_pan / lay.gsd_ms))),
                ):
                    rows.append(
                        {
                            "scene_id": f"GF7-{fp}-{view}",
                            "band": band,
                            "acquired": str(date),
                            "lines": n,
                            "samples": n,
                            "footprint_wkt": _wkt(corners),
                            "water_fraction": 0.0,
                            "_corners": corners,
                            "_col": c,
                            "_row": r,
                        }
                    )
        df = pd.DataFrame(rows)
        if "sea-scene" in self.faults:
            df.loc[df.index[3], "water_fraction"] = 0.82
        return df

    def tie_points(self, scenes: pd.DataFrame) -> pd.DataFrame:
        """Ground points seen on every PAN scene covering them; residuals ~ N(0, σ) px."""
        lay, rng = self.lay, self.rng
        pan = scenes[scenes["band"] == "pan"].reset_index(drop=True)
        w, h = lay.extent_deg
        k = 1.0 / math.cos(math.radians(self.lat0))
        # each ground point is seen on ~2.9 PAN scenes on average (stereo + overlaps)
        n_ground = int(len(pan) * lay.obs_per_scene / 2.9)
        lon = self.lon0 + rng.uniform(0, w * k, n_ground)
        lat = self.lat0 + rng.uniform(0, h, n_ground)
        parts = []
        for i, sc in pan.iterrows():  # per scene: a vectorized inversion of its footprint
            line, sample = _image_coords(sc["_corners"], lon, lat, sc["lines"], sc["samples"])
            inside = (line >= 0) & (line < sc["lines"]) & (sample >= 0) & (sample < sc["samples"])
            idx = np.flatnonzero(inside)
            parts.append(
                pd.DataFrame(
                    {
                        "gp": idx,
                        "scene_id": sc["scene_id"],
                        "scene_no": i,
                        "line": line[idx],
                        "sample": sample[idx],
                    }
                )
            )
        obs = pd.concat(parts, ignore_index=True)
        seen = obs.groupby("gp")["scene_id"].transform("size")
        obs = obs[seen >= 2].reset_index(drop=True)
        obs = self._scene_faults(obs, pan)
        sigma = 0.28 * (2.0 if "tp-noise" in self.faults else 1.0)
        v = rng.normal(0.0, sigma, (len(obs), 2))
        err = np.hypot(v[:, 0], v[:, 1])
        cap = 1.45 if "tp-noise" not in self.faults else 2.5
        v *= np.minimum(1.0, cap / np.maximum(err, 1e-12))[:, None]  # producer's outlier cut
        if "tp-outlier" in self.faults:
            bad = rng.choice(len(obs), 4, replace=False)
            v[bad] = rng.uniform(1.3, 1.6, (4, 2))
        obs["v_line"], obs["v_sample"] = v[:, 0].round(4), v[:, 1].round(4)
        obs["point_id"] = f"T{self.spec.number}{self.index + 1:02d}-" + obs["gp"].astype(
            str
        ).str.zfill(6)
        obs["lon"], obs["lat"] = lon[obs["gp"]].round(7), lat[obs["gp"]].round(7)
        obs["line"], obs["sample"] = obs["line"].round(2), obs["sample"].round(2)
        return obs[["point_id", "scene_id", "line", "sample", "v_line", "v_sample", "lon", "lat"]]

    def _scene_faults(self, obs: pd.DataFrame, pan: pd.DataFrame) -> pd.DataFrame:
        rng = self.rng
        if "sparse-scene" in self.faults:
            sid = pan["scene_id"].iloc[5]
            mine = np.flatnonzero(obs["scene_id"].to_numpy() == sid)
            drop = rng.choice(mine, max(0, len(mine) - 60), replace=False)
            obs = obs.drop(index=drop)
        if "clustered-scene" in self.faults:  # same points, squeezed into one corner
            sc = pan.iloc[6]
            mine = (obs["scene_id"] == sc["scene_id"]).to_numpy()
            obs.loc[mine, ["line", "sample"]] = obs.loc[mine, ["line", "sample"]] / 3.0
        if "sea-scene" in self.faults:
            sid = pan["scene_id"].iloc[2]  # row 3 of scenes.csv: the F view of footprint 1
            mine = np.flatnonzero(obs["scene_id"].to_numpy() == sid)
            drop = rng.choice(mine, max(0, len(mine) - 40), replace=False)
            obs = obs.drop(index=drop)
        return obs.reset_index(drop=True)

    def pan_ms(self, scenes: pd.DataFrame) -> pd.DataFrame:
        rng = self.rng
        b = scenes[scenes["scene_id"].str.endswith("-B")]["scene_id"].to_numpy()
        m = np.char.replace(b.astype(str), "-B", "-M")
        n = 15
        pan_id, ms_id = np.repeat(b, n), np.repeat(m, n)
        d = rng.normal(0.3, 0.8, (len(pan_id), 2))
        if "pan-ms-shift" in self.faults:
            d[:n] += 1.5 * self.lay.gsd_ms / math.sqrt(2)  # 1.5 MS pixels along the diagonal
        return pd.DataFrame(
            {
                "pan_scene_id": pan_id,
                "ms_scene_id": ms_id,
                "point_id": [f"R{i:05d}" for i in range(len(pan_id))],
                "dx_m": d[:, 0].round(3),
                "dy_m": d[:, 1].round(3),
            }
        )

    def overlaps(self, scenes: pd.DataFrame) -> pd.DataFrame | None:
        """Adjacent footprints (grid neighbours), backward PAN views, 20 points a pair; None for
        a block of one footprint (no adjacent images)."""
        rng = self.rng
        b = scenes[scenes["scene_id"].str.endswith("-B")].set_index(["_col", "_row"])["scene_id"]
        pairs = [
            (b[(c, r)], b[(c + dc, r + dr)])
            for (c, r) in b.index
            for dc, dr in ((1, 0), (0, 1))
            if (c + dc, r + dr) in b.index
        ]
        if not pairs:
            return None
        n = 20
        a, bb = np.repeat([p[0] for p in pairs], n), np.repeat([p[1] for p in pairs], n)
        d = rng.normal(0.0, 4.0, (len(a), 3))
        d[:, 2] *= 0.7
        d = np.clip(d, -14, 14)
        if "overlap-shift" in self.faults:  # two pairs offset beyond 2√2·m = 28.3 m
            for p in sorted({1, 4} & set(range(len(pairs)))) or [0]:
                sl = slice(p * n, p * n + 8)
                d[sl, 0] += rng.uniform(24, 30, 8)
                d[sl, 1] += rng.uniform(8, 14, 8)
        return pd.DataFrame(
            {
                "scene_a": a,
                "scene_b": bb,
                "point_id": [f"O{i:05d}" for i in range(len(a))],
                "dx_m": d[:, 0].round(3),
                "dy_m": d[:, 1].round(3),
                "dz_m": d[:, 2].round(3),
            }
        )

    def edges(self, neighbours: list[str]) -> pd.DataFrame | None:
        if not neighbours:
            return None
        rng = self.rng
        rows = []
        for nb in neighbours:
            d = np.clip(rng.normal(0.0, 4.0, (25, 3)), -15, 15)
            d[:, 2] = np.clip(d[:, 2], -9, 9)
            if "edge-shift" in self.faults:
                d[:3, 0] = 22 + np.abs(d[:3, 0])  # beyond 2·m = 20 m whatever the draw
            rows.append(
                pd.DataFrame(
                    {
                        "neighbour_block": nb,
                        "point_id": [f"E{nb}-{i:03d}" for i in range(25)],
                        "dx_m": d[:, 0].round(3),
                        "dy_m": d[:, 1].round(3),
                        "dz_m": d[:, 2].round(3),
                    }
                )
            )
        return pd.concat(rows, ignore_index=True)

    def checkpoints(self, epsg: int, dem: Path) -> pd.DataFrame:
        """Checkpoints on clear features; errors reproduce the field's published statistics."""
        rng, spec = self.rng, self.spec
        n_points = max(cs.n for cs in spec.checks)
        w, h = self.lay.extent_deg
        k = 1.0 / math.cos(math.radians(self.lat0))
        lon = self.lon0 + rng.uniform(0.05, 0.95, n_points) * w * k
        lat = self.lat0 + rng.uniform(0.05, 0.95, n_points) * h
        x, y = Transformer.from_crs(4326, epsg, always_xy=True).transform(lon, lat)
        z = _sample_dem(dem, lon, lat) + spec.geoid_n
        ids = np.array([f"C{spec.number}{self.index + 1:02d}-{i:02d}" for i in range(n_points)])
        refs = np.repeat(
            [f"WV-{spec.number}-{i + 1:02d}" for i in range(len(spec.hp_references))],
            spec.hp_references,
        )
        frames: dict[str, pd.DataFrame] = {}
        for cs in spec.checks:
            err = rng.permutation(_errors_with_stats(rng, cs))
            f = frames.setdefault(
                cs.method,
                pd.DataFrame(
                    {
                        "point_id": ids,
                        "method": cs.method,
                        "reference_id": np.resize(refs, n_points)
                        if cs.method == "high_precision" and len(refs)
                        else {
                            "same_accuracy": "GoogleEarth",
                            "recalculation": "independent-BA",
                        }.get(cs.method, "WV"),
                        "x_m": x.round(3),
                        "y_m": y.round(3),
                        "z_m": z.round(3),
                        "ref_x_m": np.nan,
                        "ref_y_m": np.nan,
                        "ref_z_m": np.nan,
                    }
                ),
            )
            sel = np.arange(cs.n)
            if cs.component == "plane":
                theta = rng.uniform(0, 2 * np.pi, cs.n)
                f.loc[sel, "ref_x_m"] = (x[sel] - err * np.cos(theta)).round(3)
                f.loc[sel, "ref_y_m"] = (y[sel] - err * np.sin(theta)).round(3)
            else:
                sign = rng.choice([-1.0, 1.0], cs.n)
                f.loc[sel, "ref_z_m"] = (z[sel] - sign * err).round(3)
        out = pd.concat(frames.values(), ignore_index=True)
        used = out[["ref_x_m", "ref_y_m", "ref_z_m"]].notna().any(axis=1)
        return out[used].reset_index(drop=True)


def _sample_dem(dem: Path, lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
    """Nearest DEM cell at each lon/lat; outside the tile or in a void, the tile's mean height."""
    import rasterio

    with rasterio.open(dem) as src:
        a = src.read(1).astype(float)
        if src.nodata is not None:
            a[a == src.nodata] = np.nan
        row, col = rasterio.transform.rowcol(src.transform, lon, lat)
    row, col = np.asarray(row), np.asarray(col)
    ok = (row >= 0) & (row < a.shape[0]) & (col >= 0) & (col < a.shape[1])
    z = np.full(len(lon), np.nanmean(a))
    z[ok] = a[row[ok], col[ok]]
    return np.where(np.isfinite(z), z, np.nanmean(a))


def minimal_pdf(lines: Iterable[str]) -> bytes:
    """A small valid one-page PDF with the given lines of text (Helvetica)."""
    text = (
        "BT /F1 11 Tf 56 780 Td 14 TL "
        + " ".join(
            "(" + s.replace("\\", "\\\\").replace("(", "\\(").replace(")", "\\)") + ") '"
            for s in lines
        )
        + " ET"
    )
    objs = [
        b"<< /Type /Catalog /Pages 2 0 R >>",
        b"<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
        b"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 595 842] /Contents 4 0 R "
        b"/Resources << /Font << /F1 5 0 R >> >> >>",
        b"<< /Length %d >>\nstream\n" % len(text)
        + text.encode("latin-1", "replace")
        + b"\nendstream",
        b"<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica >>",
    ]
    out = bytearray(b"%PDF-1.4\n")
    offsets = []
    for i, body in enumerate(objs, 1):
        offsets.append(len(out))
        out += b"%d 0 obj\n" % i + body + b"\nendobj\n"
    xref = len(out)
    out += b"xref\n0 %d\n0000000000 65535 f \n" % (len(objs) + 1)
    out += b"".join(b"%010d 00000 n \n" % o for o in offsets)
    out += b"trailer\n<< /Size %d /Root 1 0 R >>\nstartxref\n%d\n%%%%EOF\n" % (len(objs) + 1, xref)
    return bytes(out)


def _write_csv(path: Path, df: pd.DataFrame) -> None:
    write_text_atomic(path, df.to_csv(index=False, lineterminator="\n"))


def write_block(out: Path, spec: FieldSpec, index: int, opts: Options, dem_dir: Path) -> str:
    """Write one delivery folder; return its block id."""
    faults = frozenset(opts.faults | spec.faults)
    rng = np.random.default_rng([opts.seed, spec.number, index])
    b = _Block(spec, index, opts, rng, faults)
    folder = out / b.block_id
    scenes = b.scenes()
    tp = b.tie_points(scenes)
    zone = int((b.lon0 + b.lay.extent_deg[0] / 2 / math.cos(math.radians(b.lat0)) + 180) // 6) + 1
    epsg = 32600 + zone + (1 if "wrong-zone" in faults else 0)
    sampled = index == 0
    neighbours = [
        f"F{spec.number}-B{j + 1:02d}"
        for j in (index - 1, index + 1)
        if 0 <= j < opts.blocks_per_field
    ]
    reported = _reported_figures(tp, faults)
    docs = dict(DOCUMENTS)
    manifest = _manifest(b, spec, epsg, docs, reported, sampled, faults)
    if sampled:
        cp = b.checkpoints(epsg, dem_dir / spec.dem)
        _write_csv(folder / "checkpoints.csv", cp)
        reported.update(_checkpoint_figures(spec))
    write_text_atomic(
        folder / "block.yaml", yaml.safe_dump(manifest, sort_keys=False, allow_unicode=True)
    )
    _write_tables(folder, b, scenes, tp, neighbours)
    _write_documents(folder, b.block_id, spec.number, docs, faults)
    return b.block_id


def _reported_figures(tp: pd.DataFrame, faults: frozenset[str]) -> dict[str, float]:
    """block.yaml's reported tie point errors (the median understated when misreported)."""
    err = np.hypot(tp["v_line"], tp["v_sample"])
    reported = {
        "tie_point_error_px": round(float(err.median()), 2),
        "tie_point_max_error_px": round(float(err.max()), 2),
    }
    if "misreported" in faults:
        reported["tie_point_error_px"] = round(float(err.median()) * 0.7, 2)
    return reported


def _checkpoint_figures(spec: FieldSpec) -> dict[str, float]:
    """block.yaml's reported checkpoint medium errors: those of the field's first plane and
    height check sets."""
    plane = [cs for cs in spec.checks if cs.component == "plane"]
    height = [cs for cs in spec.checks if cs.component == "height"]
    figures = {}
    if plane:
        figures["checkpoint_plane_medium_error_m"] = plane[0].medium
    if height:
        figures["checkpoint_height_medium_error_m"] = height[0].medium
    return figures


def _manifest(
    b: _Block,
    spec: FieldSpec,
    epsg: int,
    docs: dict[str, str],
    reported: dict[str, float],
    sampled: bool,
    faults: frozenset[str],
) -> dict[str, object]:
    """block.yaml's content."""
    return {
        "block_id": b.block_id,
        "sensor": "GF-7",
        "gsd_m": {"pan": b.lay.gsd_pan, "ms": b.lay.gsd_ms},
        "spatial_reference": {
            "geodetic_datum": "WGS84",
            "height_datum": "EGM96" if "geoid-heights" in faults else "ellipsoidal",
            "projection": "UTM",
            "epsg": epsg,
        },
        "documents": docs,
        "reported": reported,
        "test_field": spec.number,
        "sampled": sampled,
    }


def _write_tables(
    folder: Path, b: _Block, scenes: pd.DataFrame, tp: pd.DataFrame, neighbours: list[str]
) -> None:
    """The delivery's scenes, tie points, pan/MS pairs, and its overlaps and edges if any."""
    _write_csv(folder / "scenes.csv", scenes[[c for c in scenes if not c.startswith("_")]])
    _write_csv(folder / "tie_points.csv", tp)
    _write_csv(folder / "pan_ms.csv", b.pan_ms(scenes))
    overlaps = b.overlaps(scenes)
    if overlaps is not None:
        _write_csv(folder / "overlaps.csv", overlaps)
    edges = b.edges(neighbours)
    if edges is not None:
        _write_csv(folder / "edges.csv", edges)


def _write_documents(
    folder: Path, block: str, field_number: int, docs: dict[str, str], faults: frozenset[str]
) -> None:
    """The delivery's documents, each a one-page PDF (the orientation report left out when
    missing)."""
    for kind, rel in docs.items():
        if kind == "absolute_orientation_report" and "missing-document" in faults:
            continue
        write_bytes_atomic(
            folder / rel,
            minimal_pdf(
                [
                    f"{kind.replace('_', ' ').title()} - block {block}",
                    "GF-7 regional block adjustment without ground control points",
                    f"Test field {field_number}, sample delivery generated by blockqc simulate",
                ]
            ),
        )


def default_dem_dir() -> Path:
    """samples/dem of the checkout (editable install), else of the working folder."""
    checkout = _CHECKOUT / "samples" / "dem"
    return checkout if checkout.is_dir() else Path("samples") / "dem"


def block_id(field_number: int, index: int) -> str:
    """The id (and folder name) of a field's index-th block (from 0)."""
    return f"F{field_number}-B{index + 1:02d}"


def _holds_something(folder: Path) -> bool:
    """Whether a delivery folder to write is there already and not an empty folder."""
    if not (folder.exists() or folder.is_symlink()):
        return False
    return not folder.is_dir() or any(folder.iterdir())


def prepare_out(out: Path | str, ids: list[str]) -> Path:
    """OUT, created: refused (exit 2) when empty, when it is or lies inside a delivery (a folder
    holding block.yaml), when it cannot be made or written in, or when a delivery folder to write
    already holds something (old files would stay beside new ones)."""
    if not str(out):
        raise UsageError("OUT is empty: give the folder to write the deliveries into")
    out = Path(out)
    refuse_delivery(out, "OUT")
    try:
        out.mkdir(parents=True, exist_ok=True)
        taken = [out / i for i in ids if _holds_something(out / i)]
    except FileExistsError:
        raise UsageError(
            f"OUT {out} is not a folder (a file, or a link that loops or leads nowhere): "
            "give a folder"
        ) from None
    except OSError as exc:
        raise UsageError(f"OUT {out} cannot be created or read: {exc.strerror or exc}") from None
    if taken:
        raise UsageError(
            f"OUT {out}: the delivery folder {taken[0]} already exists and is not empty: "
            "choose an empty or new folder"
        )
    if not os.access(out, os.W_OK | os.X_OK):
        raise UsageError(f"OUT {out}: this folder cannot be written in")
    return out


def _fault_beyond_layout(opts: Options) -> str | None:
    """Why a fault asked for cannot act on these blocks (None when all can): it would be left
    out unsaid, or fail on a scene the block does not have."""
    lay = opts.layout
    footprints = lay.rows * lay.cols
    for name in (f for f in FAULTS if f in opts.faults):
        need = FAULT_FOOTPRINTS.get(name, 1)
        if footprints < need:
            return (
                f"--fault {name} needs blocks of at least {need} footprints "
                f"(--grid {lay.rows}x{lay.cols} has {footprints}): {FAULTS[name]}"
            )
    if "edge-shift" in opts.faults and opts.blocks_per_field < 2:
        return (
            "--fault edge-shift needs adjacent blocks (--blocks-per-field 2 or more): "
            f"{FAULTS['edge-shift']}"
        )
    return None


def _dem_tiles_missing(dem_dir: Path, fields: Iterable[int]) -> str | None:
    """What is missing of the DEM folder or of a field's tile in it (a symbolic link to nothing
    said so, with where it leads: textio.not_there); None when every tile is there."""
    from blockqc.textio import not_there

    if not dem_dir.is_dir():
        return f"DEM folder {dem_dir}: {not_there(dem_dir, 'not found (give --dem-dir)')}"
    for f in fields:
        tile = dem_dir / FIELDS[f].dem
        if not tile.is_file():
            what = not_there(tile, "")
            return (
                f"DEM folder {dem_dir}: {f'{tile.name}: {what}' if what else f'no {tile.name}'}, "
                f"the DEM tile of test field {f} (its checkpoint heights are sampled from it; "
                "the tiles are in samples/dem of the checkout)"
            )
    return None


def simulate(out: Path | str, opts: Options, dem_dir: Path | None = None) -> list[str]:
    """Write a batch of deliveries for the chosen fields into OUT (new or empty delivery
    folders only); return the block ids."""
    unknown = sorted(set(opts.faults) - set(FAULTS))
    if unknown:
        raise UsageError(f"unknown fault {', '.join(unknown)} (known: {', '.join(FAULTS)})")
    beyond = _fault_beyond_layout(opts)
    if beyond:
        raise UsageError(beyond)
    bad = [f for f in opts.fields if f not in FIELDS]
    if bad:
        raise UsageError(f"unknown test field {bad[0]} (fields: 1, 2, 3, 4)")
    dem_dir = dem_dir or default_dem_dir()
    if missing := _dem_tiles_missing(dem_dir, opts.fields):
        raise UsageError(missing)
    from blockqc.rfm.readers import open_raster

    for f in opts.fields:  # each tile opens before any delivery is written, not between fields
        open_raster(dem_dir / FIELDS[f].dem).close()
    ids = [block_id(f, i) for f in opts.fields for i in range(opts.blocks_per_field)]
    with empty_removed(Path(out)):  # a failure leaves no empty folder the run made
        out = prepare_out(out, ids)
        return [
            write_block(out, FIELDS[f], i, opts, dem_dir)
            for f in opts.fields
            for i in range(opts.blocks_per_field)
        ]


__all__ = ["FAULTS", "FIELDS", "Layout", "Options", "simulate", "replace"]
