"""A block whose scenes straddle ±180°: the same verdicts, numbers and maps as the same block
anywhere else. The block here is a sample delivery moved in longitude until it straddles the
antimeridian, its longitudes written within ±180° as the contract wants them."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import shapely
from pyproj import Transformer

from blockqc.analysis.footprints import footprint_factors
from blockqc.report import plots
from blockqc.report.overview import block_extent
from blockqc.report.svgplot import tick_labels
from casekit import SAMPLES

SOURCE = SAMPLES / "batch" / "F1-B01"  # lon 40.03…40.49, EPSG:32637
SHIFT = 139.64  # its centre (40.26) to 179.90: the block spans 179.67…−179.87
EPSG = 32660  # UTM zone 60N, holding the block's centre


def _wrap(lon: np.ndarray | float) -> np.ndarray:
    return (np.asarray(lon, float) + 180.0) % 360.0 - 180.0


def _moved_scenes(scenes: pd.DataFrame) -> pd.DataFrame:
    geoms = shapely.from_wkt(scenes["footprint_wkt"].to_numpy(dtype=object))
    moved = shapely.transform(
        geoms, lambda xy: np.column_stack([_wrap(xy[:, 0] + SHIFT), xy[:, 1]])
    )
    return scenes.assign(footprint_wkt=shapely.to_wkt(moved, rounding_precision=7))


def _moved_checkpoints(cp: pd.DataFrame) -> pd.DataFrame:
    """The checkpoints moved with the block, into its new zone; each keeps its dx, dy (the
    reference moved by the same metres), as a block measured there would give them."""
    lon, lat = Transformer.from_crs(32637, 4326, always_xy=True).transform(cp.x_m, cp.y_m)
    x, y = Transformer.from_crs(4326, EPSG, always_xy=True).transform(_wrap(lon + SHIFT), lat)
    return cp.assign(
        x_m=x, y_m=y, ref_x_m=x - (cp.x_m - cp.ref_x_m), ref_y_m=y - (cp.y_m - cp.ref_y_m)
    )


def _moved_delivery(to: Path) -> Path:
    shutil.copytree(SOURCE, to)
    _moved_scenes(pd.read_csv(SOURCE / "scenes.csv")).to_csv(to / "scenes.csv", index=False)
    tp = pd.read_csv(SOURCE / "tie_points.csv", dtype={"point_id": str})
    tp.assign(lon=_wrap(tp["lon"] + SHIFT)).to_csv(to / "tie_points.csv", index=False)
    cp = pd.read_csv(SOURCE / "checkpoints.csv")
    _moved_checkpoints(cp).to_csv(to / "checkpoints.csv", index=False, float_format="%.4f")
    manifest = (SOURCE / "block.yaml").read_text()
    (to / "block.yaml").write_text(re.sub(r"epsg: \d+", f"epsg: {EPSG}", manifest))
    return to


def test_the_moved_block_straddles_the_antimeridian() -> None:
    lon = shapely.get_coordinates(
        shapely.from_wkt(_moved_scenes(pd.read_csv(SOURCE / "scenes.csv"))["footprint_wkt"])
    )[:, 0]
    assert lon.max() > 179.8 and lon.min() < -179.8 and np.abs(lon).min() > 179.6


def test_footprint_factors_do_not_change_across_the_antimeridian() -> None:
    """§AF-4..7 read the footprints as they are: the moved block's covered area was that of
    polygons 359.6° wide (1.16e6 km² where the block covers 1438 km², 72 overlapping pairs for
    42)."""
    scenes = pd.read_csv(SOURCE / "scenes.csv")
    here, there = footprint_factors(scenes), footprint_factors(_moved_scenes(scenes))
    assert there.covered_area_km2 == pytest.approx(here.covered_area_km2, rel=1e-6)
    assert 1000 < there.covered_area_km2 < 2000  # 4 × 4 footprints of about 11 km, overlapping
    assert there.overlap_degree == pytest.approx(here.overlap_degree, rel=1e-6)
    assert there.overlapping_pairs == here.overlapping_pairs
    assert there.footprint_units == here.footprint_units


def test_maps_of_the_moved_block_are_framed_on_it() -> None:
    """The footprint, overlap and residual maps framed −180…180 (the footprints drawn round
    the globe as thin bands); the block is 0.46° wide, and its ticks say −179.9 east of 180."""
    moved = _moved_scenes(pd.read_csv(SOURCE / "scenes.csv"))
    rings = plots.rings_of(plots.geometries(moved["footprint_wkt"].tolist()))
    plot = plots.lonlat_plot(rings, lambda key, **kw: key, "map")
    west, east = plot.xlim
    assert east - west == pytest.approx((40.488122 - 40.033269) * 1.06, rel=1e-3)  # 3 % pads
    assert _wrap(west) == pytest.approx(40.033269 + SHIFT - 0.03 * (40.488122 - 40.033269))


def test_longitude_ticks_east_of_180_are_written_within() -> None:
    assert tick_labels(np.array([179.9, 180.0, 180.1]), lon=True) == ["179.9", "180.0", "-179.9"]
    assert tick_labels(np.array([-180.2, -180.0]), lon=True) == ["179.8", "-180.0"]
    assert tick_labels(np.array([179.9, 180.1])) == ["179.9", "180.1"]


def test_the_overview_outline_of_the_moved_block_is_the_block() -> None:
    """A block's outline on the batch's overview map was the union of footprints 359.6° wide."""
    scenes = pd.read_csv(SOURCE / "scenes.csv")
    here = shapely.from_wkt(block_extent(scenes.to_dict("records")))
    there = shapely.from_wkt(block_extent(_moved_scenes(scenes).to_dict("records")))
    assert there.area == pytest.approx(here.area, rel=1e-3)
    assert there.bounds[2] - there.bounds[0] == pytest.approx(
        here.bounds[2] - here.bounds[0], abs=1e-6
    )


def _numbers(doc: object, path: str = "") -> dict[str, object]:
    """Every leaf of a results document by its path, the projected coordinates left out (the
    block moved to another zone) and the spatial reference's (its zone, said apart)."""
    if isinstance(doc, dict):
        out: dict[str, object] = {}
        for k, v in doc.items():
            if k not in (
                "x_m",
                "y_m",
                "ref_x_m",
                "ref_y_m",
                "footprint_wkt",
                "generated_at",
                "delivery",
            ):
                out.update(_numbers(v, f"{path}/{k}"))
        return out
    if isinstance(doc, list):
        out = {}
        for i, v in enumerate(doc):
            out.update(_numbers(v, f"{path}[{i}]"))
        return out
    return {path: doc}


def test_inspect_judges_the_moved_block_as_the_block(tmp_path: Path, blockqc) -> None:
    """Every rule's status, value and detail agree; only the zone, EPSG and note of the
    spatial reference differ, the moved block lying across the edge of zones 60 and 1."""
    moved = _moved_delivery(tmp_path / "batch" / "F1-B01")
    results = []
    for name, delivery in (("here", SOURCE), ("there", moved)):
        proc = blockqc("inspect", delivery, "--out", tmp_path / name, "--no-pdf")
        assert proc.returncode == 0, proc.stderr
        results.append(json.loads((tmp_path / name / "F1-B01" / "results.json").read_text()))
    assert [r["status"] for r in results[0]["results"]] == [
        r["status"] for r in results[1]["results"]
    ]
    for r in results:  # the spatial reference's measurement: the zone, said apart below
        r["measurements"] = [m for m in r["measurements"] if m["metric"] != "spatial_reference"]
    here, there = (_numbers(r) for r in results)
    spatial = ("/zone", "/epsg", "/expected_epsg", "/expected_zone", "/note")
    differ = {
        k
        for k in here.keys() | there.keys()
        if not _same(here.get(k), there.get(k)) and not k.endswith(spatial)
    }
    assert differ == set()
    mb3 = [r for r in results[1]["results"] if r["rule"] == "MB-3"]
    assert mb3[0]["detail"]["zone"] == "60N" and "zone edge" in mb3[0]["detail"]["note"]


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)
    return a == b


def test_the_adjustment_figures_draw_the_moved_block_as_one_piece() -> None:
    """adjust's residual-vector map drew the points at ±180 (a frame −180…180) and the
    per-scene precision map put a scene's centre, the mean of 179.9 and −179.9, at 0°."""
    from blockqc.adjust.report import _drawn, _footprints

    @dataclasses.dataclass
    class Points:  # the solution's longitudes, all the maps unwrap
        lon: np.ndarray

    tp = pd.read_csv(SOURCE / "tie_points.csv")
    drawn, centre = _drawn(Points(_wrap(tp["lon"].to_numpy() + SHIFT)))
    assert np.ptp(drawn.lon) == pytest.approx(np.ptp(tp["lon"]), abs=1e-9)
    scenes = _moved_scenes(pd.read_csv(SOURCE / "scenes.csv"))
    rings = np.concatenate(
        _footprints(SimpleNamespace(data=SimpleNamespace(scenes=scenes)), centre)
    )
    assert np.ptp(rings[:, 0]) == pytest.approx(40.488122 - 40.033269, abs=1e-6)
    assert abs(rings[:, 0].mean() - drawn.lon.mean()) < 0.5  # the outlines round the points


@pytest.mark.parametrize(
    ("xlim", "expected"),
    [
        # a block across ±180° drawn unwrapped west of -180: read within ±180
        ((-180.25, -179.75), ["179.8", "179.9", "-180.0", "-179.9", "-179.8"]),
        # east of 180 alike
        ((179.75, 180.25), ["179.8", "179.9", "180.0", "-179.9", "-179.8"]),
    ],
)
def test_adjust_maps_read_longitudes_within_180(xlim, expected) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from blockqc.adjust.report import EN, _lon_axis

    fig, ax = plt.subplots()
    ax.set_xlim(*xlim)
    _lon_axis(ax, EN)
    fig.canvas.draw()
    shown = [t.get_text() for t in ax.get_xticklabels()]
    plt.close(fig)
    assert shown == expected
    assert ax.get_xlim() == xlim  # the map's extent kept


def test_adjust_maps_of_a_block_elsewhere_keep_their_ticks() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from blockqc.adjust.report import EN, _lon_axis

    fig, ax = plt.subplots()
    ax.set_xlim(5.1, 5.5)
    before = list(ax.get_xticks())
    _lon_axis(ax, EN)
    assert list(ax.get_xticks()) == before
    assert ax.get_xlabel() == "longitude (°)"
    plt.close(fig)


DEM = SAMPLES / "dem" / "srtm_40E39N_demcompare.tif"  # lon 40…40.8333, 1/1200° cells


def _split_dem(to: Path, shift: float = SHIFT) -> Path:
    """The sample DEM moved with the block, as real tiles are: split at 180°, into a tile
    179.64…180 and one -180…-179.47 (its column 432 lies at 40 + 432/1200 = 40.36, moved to
    180), in a folder as --dem takes it; `shift` 0: split there, not moved."""
    import rasterio
    from rasterio.transform import Affine

    to.mkdir()
    with rasterio.open(DEM) as src:
        z, profile, t = src.read(1), src.profile, src.transform
    cut = round((180.0 - SHIFT - t.c) / t.a)
    assert cut == 432 and math.isclose(t.c + cut * t.a + SHIFT, 180.0, abs_tol=1e-9)
    for name, part, west in (
        ("west.tif", z[:, :cut], t.c + shift),
        ("east.tif", z[:, cut:], -180.0 if shift else t.c + cut * t.a),
    ):
        moved = Affine(t.a, 0.0, west, 0.0, t.e, t.f)
        h, w = part.shape
        with rasterio.open(to / name, "w", **{**profile, "width": w, "height": h}) as dst:
            dst.transform = moved
            dst.write(part, 1)
    return to


@pytest.mark.parametrize("max_pixels", [16_000_000, 50_000])  # read as is, or averaged k × k
def test_terrain_factors_of_the_moved_block_over_tiles_split_at_180(tmp_path, max_pixels) -> None:
    """§AF-1..3 of the moved block over the DEM moved alike, split at 180° as real tiles are:
    only the tile on the side of the block's centre was read (the block, unwrapped to
    179.67…180.13, met the tile -180…-179.47 nowhere): dem_coverage 0.72, a mean elevation of
    1641.5 m where the block's is 1683.1 m. The tile beyond ±180° is now read turned beside
    the block: the factors are the block's over the same tiles unmoved (over the DEM whole
    where it is read cell by cell; read averaged k × k, a DEM in two tiles averages the cells
    either side of their seam apart)."""
    from blockqc.analysis.footprints import scene_polygons
    from blockqc.analysis.terrain import DemSet

    scenes = pd.read_csv(SOURCE / "scenes.csv")
    here = shapely.union_all(scene_polygons(scenes, "scenes.csv"))
    there = shapely.union_all(scene_polygons(_moved_scenes(scenes), "scenes.csv"))
    whole = DemSet([DEM], max_pixels).factors(here)
    a = DemSet([_split_dem(tmp_path / "here", 0.0)], max_pixels).factors(here)
    b = DemSet([_split_dem(tmp_path / "dem")], max_pixels).factors(there)
    assert whole.dem_coverage == 1.0 and (a.resolution_factor > 1) is (max_pixels < 1e6)
    if a.resolution_factor == 1:
        assert a.mean_elevation_m == pytest.approx(whole.mean_elevation_m, rel=1e-12)
    assert b.dem_coverage == pytest.approx(1.0, abs=1e-12)
    assert (b.n_pixels, b.resolution_factor) == (a.n_pixels, a.resolution_factor)
    for key in ("mean_elevation_m", "mean_slope_deg", "mean_roughness_m"):
        assert getattr(b, key) == pytest.approx(getattr(a, key), rel=1e-9), key
    assert sorted(Path(f).name for f in b.dem_files) == ["east.tif", "west.tif"]


def test_blockqc_factors_of_the_moved_block_are_the_blocks(tmp_path: Path, blockqc) -> None:
    rows = []
    for name, delivery, dem in (
        ("here", SOURCE, DEM),
        ("there", _moved_delivery(tmp_path / "F1-B01"), _split_dem(tmp_path / "dem")),
    ):
        run = blockqc("factors", delivery, "--dem", dem, "--out", tmp_path / name)
        assert run.returncode == 0, run.stderr
        rows.append(pd.read_csv(tmp_path / name / "experiments.csv").iloc[0])
    here, there = rows
    for key in ("mean_elevation_m", "mean_slope_deg", "mean_roughness_m", "dem_coverage"):
        assert there[key] == pytest.approx(here[key], rel=1e-9), key
    assert there["images_area_km2"] == pytest.approx(here["images_area_km2"], rel=1e-6)
