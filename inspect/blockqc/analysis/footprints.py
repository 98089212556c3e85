"""Image factors from scene footprints (§AF-4..7): covered area, images, periods, overlap degree."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
import shapely
from pyproj import CRS, Transformer
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from blockqc.errors import InputError, Problem
from blockqc.lonlat import unwrapped

#: Densify lon/lat edges to this step (degrees) before projecting, so long edges stay true.
DENSIFY_DEG = 0.01
#: Pairs whose common area is below this share of the covered area only touch: not an overlap.
TOUCH_SHARE = 1e-9
#: An intersection over union this close below --stereo-iou reaches it: the areas carry rounding
#: (two identical footprints may give 1 − 2e-16), and the bound itself is included.
IOU_ROUNDING = 1e-9


def scene_polygons(scenes: pd.DataFrame, file: str = "scenes.csv") -> np.ndarray:
    """Footprints as shapely polygons (lon/lat, a block across ±180° unwrapped as one piece:
    `lonlat.unwrapped`); InputError naming every row that is not one."""
    wkt = scenes["footprint_wkt"].astype(str).to_numpy()
    geoms = shapely.from_wkt(wkt, on_invalid="ignore")
    kinds = shapely.get_type_id(geoms)
    bad = (kinds != shapely.GeometryType.POLYGON) | ~shapely.is_valid(geoms)
    bad |= shapely.is_empty(geoms)
    if bad.any():
        raise InputError(
            [
                Problem(
                    file=file,
                    row=int(i) + 1,
                    column="footprint_wkt",
                    message="not a valid lon/lat POLYGON",
                )
                for i in np.flatnonzero(bad)
            ]
        )
    return unwrapped(geoms)


def equal_area_crs(lon: float, lat: float) -> CRS:
    """A Lambert azimuthal equal-area projection centred on (lon, lat), WGS-84, metres."""
    return CRS.from_proj4(
        f"+proj=laea +lat_0={lat:.8f} +lon_0={lon:.8f} +x_0=0 +y_0=0 +ellps=WGS84 +units=m"
    )


def block_transformer(geoms: np.ndarray) -> Transformer:
    """lon/lat → metres on the equal-area projection centred on the block's footprints."""
    c = shapely.centroid(shapely.union_all(geoms))
    return Transformer.from_crs(CRS.from_epsg(4326), equal_area_crs(c.x, c.y), always_xy=True)


def project(geoms: np.ndarray, transformer: Transformer) -> np.ndarray:
    """Densify lon/lat polygons and project them with `transformer`."""
    dense = shapely.segmentize(geoms, DENSIFY_DEG)

    def fn(xy: np.ndarray) -> np.ndarray:
        x, y = transformer.transform(xy[:, 0], xy[:, 1])
        return np.column_stack([x, y])

    return shapely.transform(dense, fn)


def acquisition_periods(dates: pd.Series, gap_days: float = 0.0) -> tuple[int, list[str]]:
    """Number of acquisition periods: distinct dates, merged when ≤ `gap_days` apart (§AF-6)."""
    d = pd.to_datetime(dates).dropna().dt.normalize().drop_duplicates().sort_values()
    if d.empty:
        return 0, []
    gaps = d.diff().dt.days.to_numpy()[1:]
    starts = np.concatenate([[True], gaps > gap_days])
    groups = np.cumsum(starts) - 1
    labels = []
    for g in range(int(groups[-1]) + 1):
        members = d[groups == g]
        first, last = members.iloc[0].date().isoformat(), members.iloc[-1].date().isoformat()
        labels.append(first if first == last else f"{first}..{last}")
    return len(labels), labels


@dataclass(frozen=True)
class FootprintFactors:
    """§AF-4..7 of one block, with the counts behind them."""

    covered_area_km2: float
    images_number: int
    images_periods: int
    overlap_degree: float  # area seen by ≥ 2 footprint units / covered area
    overlap_pairwise_sum: float  # Σ over unit pairs of the pair's common area / covered area
    footprint_units: int  # stereo pairs (same date, nearly the same footprint) or single images
    overlapping_pairs: int  # pairs of footprint units that overlap
    periods: list[str]
    images_band: str

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def select_images(
    scenes: pd.DataFrame, band: str = "pan", file: str = "scenes.csv"
) -> pd.DataFrame:
    """The scenes counted as images: one band ('pan', 'ms') or 'all'."""
    if band == "all":
        sel = scenes
    else:
        sel = scenes[scenes["band"].astype(str).str.strip().str.lower() == band]
    if sel.empty:
        raise InputError(
            Problem(file=file, column="band", message=f"no scene with band '{band}' to count")
        )
    return sel


def _overlapping_pairs(
    proj: np.ndarray, covered: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index pairs i < j of polygons with a common area, those common parts and their areas."""
    i, j = shapely.STRtree(proj).query(proj, predicate="intersects")
    keep = i < j
    i, j = i[keep], j[keep]
    common = shapely.intersection(proj[i], proj[j])
    areas = shapely.area(common)
    real = areas > TOUCH_SHARE * covered
    return np.column_stack([i[real], j[real]]), common[real], areas[real]


def footprint_units(proj: np.ndarray, days: np.ndarray, stereo_iou: float) -> np.ndarray:
    """Label scenes of one stereo acquisition alike: same day and intersection over union of
    the footprints ≥ `stereo_iou` (linked transitively); every other scene is its own unit."""
    n = len(proj)
    covered = float(shapely.union_all(proj).area)
    pairs, _, areas = _overlapping_pairs(proj, covered)
    if len(pairs) == 0:
        return np.arange(n)
    a, b = pairs[:, 0], pairs[:, 1]
    iou = areas / (shapely.area(proj[a]) + shapely.area(proj[b]) - areas)
    link = (iou >= stereo_iou - IOU_ROUNDING) & (days[a] == days[b])
    graph = coo_matrix((np.ones(int(link.sum())), (a[link], b[link])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def footprint_factors(
    scenes: pd.DataFrame,
    band: str = "pan",
    period_gap_days: float = 0.0,
    transformer: Transformer | None = None,
    file: str = "scenes.csv",
    stereo_iou: float = 0.8,
) -> FootprintFactors:
    """Covered area (union), images, periods and overlap degree of the footprints (§AF-4..7).

    The overlap is taken between footprint units: the scenes of one stereo acquisition (forward
    and backward views of the same ground, `footprint_units`) form one unit, so that a stereo
    pair alone has overlap degree 0, as in the published table.
    """
    sel = select_images(scenes, band, file)
    geoms = scene_polygons(sel, file)
    tr = transformer or block_transformer(geoms)
    proj = project(geoms, tr)
    covered = float(shapely.union_all(proj).area)
    days = pd.to_datetime(sel["acquired"]).dt.normalize().to_numpy()
    labels = footprint_units(proj, days, stereo_iou)
    n_units = int(labels.max()) + 1 if len(labels) else 0
    units = np.array([shapely.union_all(proj[labels == k]) for k in range(n_units)])
    _, common, areas = _overlapping_pairs(units, covered)
    multi = float(shapely.union_all(common).area) if len(common) else 0.0
    n_periods, period_labels = acquisition_periods(sel["acquired"], period_gap_days)
    return FootprintFactors(
        covered_area_km2=covered / 1e6,
        images_number=int(len(sel)),
        images_periods=n_periods,
        overlap_degree=multi / covered if covered > 0 else float("nan"),
        overlap_pairwise_sum=float(areas.sum()) / covered if covered > 0 else float("nan"),
        footprint_units=n_units,
        overlapping_pairs=int(len(areas)),
        periods=period_labels,
        images_band=band,
    )


def footprint_corners(scenes: pd.DataFrame, file: str = "scenes.csv") -> np.ndarray:
    """The first four footprint vertices per scene, shape (n, 4, 2): (l0,s0),(l0,S),(L,S),(L,s0)."""
    geoms = scene_polygons(scenes, file)
    rings = shapely.get_exterior_ring(geoms)
    counts = shapely.get_num_points(rings)
    if (counts < 5).any():
        rows = np.flatnonzero(counts < 5)
        raise InputError(
            [
                Problem(
                    file=file,
                    row=int(r) + 1,
                    column="footprint_wkt",
                    message="footprint needs its four image corners as first vertices",
                )
                for r in rows
            ]
        )
    pts = np.stack([shapely.get_coordinates(shapely.get_point(rings, k)) for k in range(4)], 1)
    return pts


def tie_point_lonlat(tie_points: pd.DataFrame, scenes: pd.DataFrame) -> pd.DataFrame:
    """Ground position (lon, lat) of each distinct tie point (§AF-8..10).

    Uses the `lon`/`lat` columns when present and complete; otherwise maps each observation's
    (line, sample) bilinearly between its scene's four footprint corners and averages per point.
    """
    tp = tie_points
    if {"lon", "lat"} <= set(tp.columns) and tp[["lon", "lat"]].notna().all().all():
        lon = tp["lon"].to_numpy(dtype=float)
        lat = tp["lat"].to_numpy(dtype=float)
    else:
        lon, lat = _observation_lonlat(tp, scenes)
    return _mean_per_point(tp["point_id"].astype(str).to_numpy(), lon, lat)


def _observation_lonlat(tp: pd.DataFrame, scenes: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Each observation's (line, sample) mapped bilinearly between its scene's four footprint
    corners; InputError naming the first rows whose scene scenes.csv does not list."""
    sc = scenes.drop_duplicates("scene_id").reset_index(drop=True)
    corners = footprint_corners(sc)
    idx = pd.Index(sc["scene_id"].astype(str)).get_indexer(tp["scene_id"].astype(str))
    if (idx < 0).any():
        rows = np.flatnonzero(idx < 0)[:20]
        raise InputError(
            [
                Problem(
                    file="tie_points.csv",
                    row=int(r) + 1,
                    column="scene_id",
                    message="scene not listed in scenes.csv",
                )
                for r in rows
            ]
        )
    c = corners[idx]
    u = (tp["sample"].to_numpy(dtype=float) / sc["samples"].to_numpy(dtype=float)[idx])[:, None]
    v = (tp["line"].to_numpy(dtype=float) / sc["lines"].to_numpy(dtype=float)[idx])[:, None]
    xy = (
        ((1 - u) * (1 - v)) * c[:, 0]
        + (u * (1 - v)) * c[:, 1]
        + (u * v) * c[:, 2]
        + ((1 - u) * v) * c[:, 3]
    )
    return xy[:, 0], xy[:, 1]


def _mean_per_point(point_id: np.ndarray, lon: np.ndarray, lat: np.ndarray) -> pd.DataFrame:
    """The mean lon/lat of the observations of each point, sorted by point id."""
    frame = pd.DataFrame({"point_id": point_id, "lon": lon, "lat": lat})
    # average longitudes relative to each point's first one, so ±180° does not split a point
    ref = frame.groupby("point_id", sort=False)["lon"].transform("first")
    frame["dlon"] = (frame["lon"] - ref + 180.0) % 360.0 - 180.0
    frame["ref"] = ref
    g = frame.groupby("point_id", sort=True).agg(
        ref=("ref", "first"), dlon=("dlon", "mean"), lat=("lat", "mean")
    )
    out = pd.DataFrame(
        {
            "point_id": g.index.to_numpy(),
            "lon": (((g["ref"] + g["dlon"] + 180.0) % 360.0) - 180.0).to_numpy(),
            "lat": g["lat"].to_numpy(),
        }
    )
    return out.reset_index(drop=True)
