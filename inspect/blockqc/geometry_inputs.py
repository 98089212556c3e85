"""Contract v1.1 geometry of a delivery: each scene's RPC and the producer's adjustment (§RC).

`rpc/<scene_id>.<ext>` holds the original RPCs (any format `blockqc.rfm.readers` reads); the
producer's adjustment is either `adjustment.csv` (a Grodecki–Dial affine per scene, in the
contract's form `l = RFM_l + a0 + a1·s + a2·l`, `s = RFM_s + b0 + b1·s + b2·l`, pixels) or refined
RPCs in `rpc_adjusted/<scene_id>.<ext>`. Nothing here writes to the delivery.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from blockqc import grouped
from blockqc.errors import InputError, Problem
from blockqc.rfm.model import DOMAIN_REACH, RPCModel, boxes_meet, wrap_lon
from blockqc.rfm.readers import read_rpc
from blockqc.schema import MAX_ROWS_LISTED, did_you_mean, visible_name
from blockqc.textio import dangling_link, listed, unreadable_folder

RPC_DIR = "rpc"
ADJUSTED_DIR = "rpc_adjusted"
#: the folders of a delivery's geometry, read by these names only
GEOMETRY_DIRS = (RPC_DIR, ADJUSTED_DIR)
AFFINE_KEYS = ("a0", "a1", "a2", "b0", "b1", "b2")


@dataclass
class BlockGeometry:
    """The delivered geometry: original RPCs and, when given, the producer's adjusted models.

    `adjusted` lists, per observed scene (`scene_ids` order), the RPC the adjusted projection
    starts from and `affine` its contract parameters (n, 6: a0 a1 a2 b0 b1 b2): the original RPC
    with adjustment.csv's row, or the refined RPC of rpc_adjusted/ with zeros.
    """

    original: dict[str, RPCModel] = field(default_factory=dict)
    scene_ids: list[str] = field(default_factory=list)
    adjusted: list[RPCModel] | None = None
    affine: np.ndarray | None = None
    source: str | None = None  # "adjustment.csv" or "rpc_adjusted/": where the adjustment is
    #: the files of rpc/ by scene id (those named as no scene left out)
    files: dict[str, Path] = field(default_factory=dict)
    #: what the geometry lacks that the inspection does without, said (`scenes_without_rpc`)
    warnings: list[Problem] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when the producer's adjusted model of every observed scene is known."""
        return self.adjusted is not None


def _scan(folder: Path, scene_ids: set[str], problems: list[Problem]) -> dict[str, Path] | None:
    """The RPC files of a folder by scene id; other names and doubles are problems. An entry
    named as a scene's is taken whatever it is (`read_rpc` says what, when it is no file).
    None when the folder cannot be read (said)."""
    try:
        entries = listed(folder)
    except OSError as exc:
        problems.append(unreadable_folder(folder, exc))
        return None
    found: dict[str, Path] = {}
    for entry in entries:
        f = Path(entry.path)
        # the file's whole name when it is a scene's (ZY3.L, no extension), else its stem
        sid = f.name if f.name in scene_ids or "." not in f.name else f.name.rsplit(".", 1)[0]
        if sid not in scene_ids and not entry.is_file():
            problems.append(Problem(str(f), "expected an RPC file named <scene_id>.<ext>"))
        elif sid not in scene_ids:
            problems.append(
                Problem(
                    str(f),
                    f"no scene '{visible_name(sid)}' in the scenes table: expected "
                    f"<scene_id>.<ext>{_likely_scene(sid, scene_ids)}",
                )
            )
        elif sid in found:
            problems.append(
                Problem(str(f), f"scene '{sid}' already has an RPC file here: {found[sid].name}")
            )
        else:
            found[sid] = f
    return found


#: what a vendor writes after the scene's name in its RPC file's (L_rpc.txt, L.RPC.xml)
_VENDOR_SUFFIX = re.compile(r"[._-]?(rpc|rpb|rpc00b)$", re.I)


def _likely_scene(name: str, scene_ids: set[str]) -> str:
    """The 'did you mean' of an RPC file named as no scene: the scene its name is, without a
    vendor's suffix (L_rpc), in another case (l) or close to it; '' when none is."""
    hint = did_you_mean(sorted(scene_ids, key=str))
    bare = _VENDOR_SUFFIX.sub("", name)
    return (hint(bare) if bare else "") or hint(name)


def _read_models(
    folder: Path, needed: list[str], scene_ids: set[str], problems: list[Problem]
) -> tuple[dict[str, RPCModel], dict[str, Path]]:
    """Read the RPC of every needed scene from a folder; list every missing or unreadable one.
    Each model counts image positions as its file does (a DIMAP file's first pixel is (1, 1)):
    the tie points on its scene are measured in that convention (contract v1.1). The models
    read, and the folder's files by scene id."""
    if not folder.is_dir():
        link = dangling_link(folder)
        what = f"{link}: " if link else ""
        problems.append(
            Problem(str(folder), f"{what}expected a folder of RPC files <scene_id>.<ext>")
        )
        return {}, {}
    files = _scan(folder, scene_ids, problems)
    models: dict[str, RPCModel] = {}
    if files is None:
        return models, {}
    for sid in needed:
        if sid not in files:
            problems.append(
                Problem(
                    str(folder),
                    f"no RPC for scene '{sid}', which has tie-point observations "
                    f"(expected {folder.name}/{sid}.<ext>)",
                )
            )
            continue
        try:
            models[sid] = read_rpc(files[sid]).in_file_convention()
        except InputError as exc:
            problems.extend(exc.problems)
    for sid in sorted(set(files) - set(needed)):  # scenes without observations: still read
        try:
            models[sid] = read_rpc(files[sid]).in_file_convention()
        except InputError as exc:
            problems.extend(exc.problems)
    return models, files


def _with_affine(
    geometry: BlockGeometry,
    table: pd.DataFrame,
    file: Path,
    needed: list[str],
    scenes: pd.DataFrame,
    scenes_file: str,
) -> list[Problem]:
    """The adjusted models from rpc/ and adjustment.csv; every observed scene needs its row."""
    rows = table.set_index("scene_id")
    problems = [
        Problem(str(file), f"no row for scene '{sid}', which has tie-point observations")
        for sid in needed
        if sid not in rows.index
    ]
    problems += [
        Problem(
            str(file),
            f"a term {c!r} the contract's affine does not have (a0, a1, a2, b0, b1, b2): the "
            "residuals would be those of another model than the producer's; give the affine "
            f"in the contract's form, or the adjusted model as refined RPCs in {ADJUSTED_DIR}/",
            column=c,
        )
        for c in table.columns
        if re.fullmatch(r"[ab]\d+", str(c).strip(), re.I) and c not in AFFINE_KEYS
    ]
    problems += _rows_without_rpc(geometry, table, file, set(scenes["scene_id"]) - set(needed))
    problems += _distorting(table, file)
    problems += _far_offsets(table, file, scenes, scenes_file)
    if problems or any(sid not in geometry.original for sid in needed):
        return problems  # the missing RPCs are reported by _read_models
    geometry.scene_ids = list(needed)
    geometry.adjusted = [geometry.original[sid] for sid in needed]
    geometry.affine = rows.loc[needed, list(AFFINE_KEYS)].to_numpy(dtype=float)
    return problems


def _rows_without_rpc(
    geometry: BlockGeometry, table: pd.DataFrame, file: Path, unobserved: set[str]
) -> list[Problem]:
    """Rows for a scene of scenes.csv without observations that has no RPC file in rpc/ (an
    observed scene's is said by _read_models, an unknown scene's with the table): the affine
    refines the scene's original RPC, which is not delivered; `blockqc adjust` needs it."""
    ids = table["scene_id"]
    bad = [i for i, sid in enumerate(ids) if sid in unobserved and sid not in geometry.files]
    return [
        Problem.at_row(
            file,
            i,
            f"scene '{ids.iloc[i]}' has no RPC file in {RPC_DIR}/ (expected {RPC_DIR}/"
            f"{ids.iloc[i]}.<ext>): the affine of this row refines the scene's original RPC",
            column="scene_id",
        )
        for i in bad
    ]


def scenes_without_rpc(folder: Path, scene_ids: list[str], files: dict[str, Path]) -> list[Problem]:
    """The scenes of scenes.csv without an RPC file in rpc/ and without tie-point observations
    (those with observations are refused by _read_models): the inspection does without them,
    and says so; `blockqc adjust` leaves them out too (no observation ties them to the block)."""
    missing = [s for s in scene_ids if s not in files]
    if not missing:
        return []
    shown = ", ".join(f"'{s}'" for s in missing[:10]) + (" …" if len(missing) > 10 else "")
    return [
        Problem(
            str(folder),
            f"no RPC file for scene(s) {shown} of the scenes table, which have no tie-point "
            f"observations (expected {RPC_DIR}/<scene_id>.<ext> for every scene): inspected "
            "without them; blockqc adjust leaves them out, not adjusted",
        )
    ]


#: the largest size of an affine's terms per pixel (a1, a2, b1, b2): an adjustment corrects the
#: image by parts per thousand or less; terms beyond rotate, scale, collapse or mirror it (or
#: were written per normalised coordinate, not per pixel)
AFFINE_LIMIT = 0.1


def _distorting(table: pd.DataFrame, file: Path) -> list[Problem]:
    """Rows whose affine is no correction: a term per pixel beyond ±AFFINE_LIMIT (non-finite
    values are the table's own problems)."""
    linear = ("a1", "a2", "b1", "b2")
    a = table[list(linear)].to_numpy(dtype=float)
    with np.errstate(invalid="ignore"):  # NaN cells: the table's own problem
        bad = np.flatnonzero((np.abs(a) > AFFINE_LIMIT).any(axis=1))
    return [
        Problem.at_row(
            file,
            i,
            f"scene '{table['scene_id'].iloc[i]}': the affine's terms per pixel (a1, a2, b1, b2) "
            f"are ({', '.join(f'{v:g}' for v in a[i])}); expected each within ±{AFFINE_LIMIT:g} "
            "(an adjustment corrects the image by parts per thousand; larger terms rotate, "
            "scale, collapse or mirror it, or are not per pixel)",
            column="a1, a2, b1, b2",
        )
        for i in bad
    ]


#: how many times its image's size (lines for a0, samples for b0) an affine's offset may be: an
#: adjustment moves the image by pixels, at most hundreds of them, and a0, b0 also take up what
#: the terms per pixel add across the image (at most AFFINE_LIMIT of its size each); an offset
#: of several image sizes puts every tie point off its scene (a value in other units than
#: pixels, or a no-data marker), and the rays of the adjusted model meet nowhere. The bound is
#: generous: any real adjustment stays well within one image size
OFFSET_LIMIT_IMAGES = 3.0


def _far_offsets(
    table: pd.DataFrame, file: Path, scenes: pd.DataFrame, scenes_file: str
) -> list[Problem]:
    """Rows whose offset a0 or b0 is beyond OFFSET_LIMIT_IMAGES times the scene's lines or
    samples (scenes.csv), each named with its row, column, value and bound. Scenes without a
    size, and non-finite values, are their tables' own problems."""
    if not {"lines", "samples"} <= set(scenes.columns):
        return []
    size = scenes.drop_duplicates("scene_id").set_index("scene_id")
    problems = []
    for key, extent in (("a0", "lines"), ("b0", "samples")):
        image = table["scene_id"].map(size[extent]).to_numpy(dtype=float, na_value=np.nan)
        value = table[key].to_numpy(dtype=float)
        with np.errstate(invalid="ignore"):  # NaN: no size, or no value (said elsewhere)
            far = np.flatnonzero(np.abs(value) > OFFSET_LIMIT_IMAGES * image)
        problems += [
            Problem.at_row(
                file,
                i,
                f"scene '{table['scene_id'].iloc[i]}': {key} is {value[i]:g} px; expected "
                f"within ±{OFFSET_LIMIT_IMAGES * image[i]:g} px, {OFFSET_LIMIT_IMAGES:g} times "
                f"the scene's {image[i]:g} {extent} in {scenes_file} (an adjustment moves the "
                "image by pixels, at most hundreds of them: this offset puts every tie point "
                "off its scene; a value in other units, or a no-data marker?)",
                column=key,
            )
            for i in far
        ]
    return problems


def _refined(geometry: BlockGeometry, models: dict[str, RPCModel], needed: list[str]) -> None:
    """The adjusted models from rpc_adjusted/: refined RPCs, no affine on top."""
    if all(sid in models for sid in needed):
        geometry.scene_ids = list(needed)
        geometry.adjusted = [models[sid] for sid in needed]
        geometry.affine = np.zeros((len(needed), len(AFFINE_KEYS)))


def given(path: Path) -> bool:
    """Whether the delivery gives this file or folder: there, or a link of its name (to
    nothing, said when read, rather than taken for an input not given)."""
    return path.exists() or path.is_symlink()


def has_geometry(path: Path) -> bool:
    """Whether a delivery gives its geometry (contract v1.1): rpc/, rpc_adjusted/ or an
    adjustment table."""
    return given(path / RPC_DIR) or gives_adjustment(path)


def gives_adjustment(path: Path) -> bool:
    """Whether a delivery gives the producer's adjustment (rpc_adjusted/ or an adjustment
    table), read or not: the residuals blockqc computes from it may stand in for v_line and
    v_sample."""
    return given(path / ADJUSTED_DIR) or any(
        given(path / f"adjustment.{ext}") for ext in ("csv", "parquet")
    )


def load_geometry(
    path: Path, tables: dict[str, pd.DataFrame], files: dict[str, Path]
) -> tuple[BlockGeometry | None, list[Problem]]:
    """Read rpc/, adjustment.csv and rpc_adjusted/ of a delivery (contract v1.1), if present."""
    rpc_dir, adj_dir = path / RPC_DIR, path / ADJUSTED_DIR
    adjustment = tables.get("adjustment")
    if not given(rpc_dir) and not given(adj_dir) and adjustment is None:
        return None, []
    scenes = tables.get("scenes")
    tie_points = tables.get("tie_points")
    if scenes is None or tie_points is None or "scene_id" not in tie_points:
        return None, []  # the tables' own problems are reported
    problems: list[Problem] = []
    scene_ids = set(scenes["scene_id"].dropna())
    needed = [s for s in pd.unique(tie_points["scene_id"].dropna()) if s in scene_ids]
    geometry = BlockGeometry()
    if adjustment is not None and given(adj_dir):
        problems.append(
            Problem(
                str(path),
                f"both {files['adjustment'].name} and {ADJUSTED_DIR}/ give the producer's "
                "adjustment: give one",
            )
        )
    if given(rpc_dir):
        problems += _read_original(geometry, rpc_dir, scenes, needed, files["scenes"].name)
    elif adjustment is not None:
        problems.append(
            Problem(
                str(files["adjustment"]),
                f"the adjustment refines the original RPCs, but {RPC_DIR}/ is missing "
                f"(expected {RPC_DIR}/<scene_id>.<ext> for every scene)",
            )
        )
    if given(adj_dir):
        refined, _ = _read_models(adj_dir, needed, scene_ids, problems)
        problems.extend(domain_problems(scenes, refined, files["scenes"].name))
        _refined(geometry, refined, needed)
        geometry.source = f"{ADJUSTED_DIR}/"
    elif adjustment is not None and given(rpc_dir):
        geometry.source = files["adjustment"].name
        if not {"scene_id", *AFFINE_KEYS} <= set(adjustment.columns):
            return geometry, problems  # the missing columns are reported with the table
        problems.extend(
            _with_affine(
                geometry, adjustment, files["adjustment"], needed, scenes, files["scenes"].name
            )
        )
    return geometry, problems


def _read_original(
    geometry: BlockGeometry, rpc_dir: Path, scenes: pd.DataFrame, needed: list, scenes_file: str
) -> list[Problem]:
    """The original RPCs of rpc/ into `geometry`, with the scenes that have none said (a
    warning when they have no observations either); their problems."""
    problems: list[Problem] = []
    scene_ids = set(scenes["scene_id"].dropna())
    geometry.original, geometry.files = _read_models(rpc_dir, needed, scene_ids, problems)
    problems.extend(domain_problems(scenes, geometry.original, scenes_file))
    unobserved = [s for s in pd.unique(scenes["scene_id"].dropna()) if s not in needed]
    geometry.warnings = scenes_without_rpc(rpc_dir, unobserved, geometry.files)
    return problems


def _bounds(wkt: object) -> tuple[float, float, float, float] | None:
    """lon/lat bounds of a footprint WKT; None when empty or unreadable (reported elsewhere)."""
    import shapely

    if not isinstance(wkt, str):
        return None
    try:
        geom = shapely.from_wkt(wkt)
    except shapely.errors.ShapelyError:
        return None
    if geom is None or geom.is_empty:
        return None
    return tuple(float(v) for v in geom.bounds)  # type: ignore[return-value]


#: an RPC is read up to this many of its scales from its offsets (normalised coordinates within
#: ±REACH): a footprint beyond is not of the scene the RPC describes
REACH = DOMAIN_REACH


def domain_problem(model: RPCModel, sid: str, wkt: object, table: str) -> Problem | None:
    """A problem when the RPC's ground domain (LON_OFF ± REACH·LON_SCALE, LAT_OFF ±
    REACH·LAT_SCALE) does not overlap the scene's footprint: an RPC that cannot describe the
    scene (another scene's file, offsets and scales swapped …); None when it does or the
    footprint is unreadable."""
    box = _bounds(wkt)
    if box is None:
        return None
    west, south, east, north = box
    lon0, lat0, lon1, lat1 = domain = model.ground_domain(REACH)
    if boxes_meet(box, domain):  # longitudes ±180° and 0..360° alike
        return None
    return Problem(
        model.source,
        f"the RPC's ground domain (lon {lon0:.4f}..{lon1:.4f}, lat {lat0:.4f}..{lat1:.4f}: "
        f"LON_OFF ± {REACH:g}·LON_SCALE, LAT_OFF ± {REACH:g}·LAT_SCALE) does not overlap the "
        f"footprint_wkt of scene '{sid}' in {table} (lon {west:.4f}..{east:.4f}, lat "
        f"{south:.4f}..{north:.4f}): expected the RPC of this scene (another scene's file, or "
        "offsets and scales swapped?)",
    )


def domain_problems(
    scenes: pd.DataFrame, models: dict[str, RPCModel], table: str = "scenes.csv"
) -> list[Problem]:
    """`domain_problem` of every scene with both an RPC and a footprint, and `extent_problem`
    of every scene with an RPC and its size."""
    problems = []
    ids = scenes["scene_id"].astype(str)
    if "footprint_wkt" in scenes:
        for sid, wkt in zip(ids, scenes["footprint_wkt"], strict=True):
            found = domain_problem(models[sid], sid, wkt, table) if sid in models else None
            if found is not None:
                problems.append(found)
    if {"lines", "samples"} <= set(scenes.columns):
        for sid, lines, samples in zip(ids, scenes["lines"], scenes["samples"], strict=True):
            found = (
                extent_problem(models[sid], sid, lines, samples, table) if sid in models else None
            )
            if found is not None:
                problems.append(found)
    return problems


def extent_problem(
    model: RPCModel, sid: str, lines: Any, samples: Any, table: str
) -> Problem | None:
    """A problem when the scene's image (lines × samples) reaches beyond the RPC's image domain
    (LINE_OFF + REACH·LINE_SCALE, SAMP_OFF + REACH·SAMP_SCALE): the RPC of a smaller image
    (the MS image's given for the PAN); None when it fits or the size is missing."""
    if pd.isna(lines) or pd.isna(samples):
        return None
    _, last_line, _, last_sample = model.image_domain(REACH)
    if lines <= last_line and samples <= last_sample:
        return None
    return Problem(
        model.source,
        f"the RPC's image domain (lines to {last_line:.0f}, samples to {last_sample:.0f}: "
        f"LINE_OFF + {REACH:g}·LINE_SCALE, SAMP_OFF + {REACH:g}·SAMP_SCALE) does not hold scene "
        f"'{sid}' of {table} ({int(lines)} lines × {int(samples)} samples): expected the RPC of "
        "this scene (another scene's file, e.g. the MS image's given for the PAN?)",
    )


def residual_column_problems(
    columns: Collection[str] | None, file: Path | None, adjustment: bool
) -> list[Problem]:
    """v_line/v_sample: both given, or both absent with the producer's adjustment (`adjustment`:
    the delivery gives it, `gives_adjustment`). `columns`: the tie_points table's columns (read
    or not), None without the table."""
    if columns is None:
        return []
    have = [c for c in ("v_line", "v_sample") if c in columns]
    # with an adjustment given, its own problems (if any, or those of the tables it is read
    # against) are what the user needs to read, even when it could not be read
    if len(have) == 2 or (not have and adjustment):
        return []
    missing = [c for c in ("v_line", "v_sample") if c not in have]
    why = (
        "give both residual columns"
        if have
        else "they may be absent only when the delivery gives its geometry: rpc/ with "
        "adjustment.csv, or rpc_adjusted/"
    )
    return [
        Problem(
            str(file or "tie_points.csv"),
            f"missing column '{c}' (expected a column of numbers; {why})",
        )
        for c in missing
    ]


#: how far the rows of one point may put its delivered ground point apart (°, °, m): the same
#: point written on each of its rows, to round-off
GROUND_AGREEMENT = {"lon": 1e-7, "lat": 1e-7, "h": 0.01}
#: the tie_points columns of the producer's ground point (contract v1.1), given together
GROUND_COLUMNS = tuple(GROUND_AGREEMENT)
#: what the rows of a point that give two ground points were expected to give
ONE_GROUND_POINT = (
    "expected one ground point per point (the producer's), the same on each of its rows"
)


def ground_column_problems(columns: Collection[str] | None, file: Path | None) -> list[Problem]:
    """lon and lat together, h only with them: one of lon and lat, or h without both, is no
    ground point; inspect would keep the columns unread and adjust take its positions elsewhere,
    both without a word (as ref_x_m without ref_y_m in checkpoints). lon and lat without h are
    a tie point's ground position (contract v1, read by `blockqc factors`; adjust then
    intersects the producer's). `columns`: the tie_points table's columns (read or not), None
    without the table."""
    if columns is None:
        return []
    given = [c for c in GROUND_COLUMNS if c in columns]
    missing = [c for c in ("lon", "lat") if c not in columns]
    if not given or not missing:
        return []
    name = str(file or "tie_points.csv")
    return [
        Problem(
            name,
            f"missing column{'s' if len(missing) > 1 else ''} {_and(missing)}: the table gives "
            f"{_and(given)}, but a ground point is lon and lat together, and h its height (the "
            "producer's ground point: lon, lat, h ellipsoidal, contract v1.1); give lon and lat, "
            "with or without h, or none of the three",
            line=1 if name.lower().endswith(".csv") else None,
        )
    ]


def _and(names: list[str]) -> str:
    """'a', or 'a' and 'b': one or two of the ground columns, as a message lists them."""
    return " and ".join(f"'{n}'" for n in names)


def ground_disagreements(file: Path, tie_points: pd.DataFrame, why: str) -> list[Problem]:
    """Rows whose producer's ground point (lon, lat, h) differs from that of the first row of
    their point giving one, beyond GROUND_AGREEMENT (longitudes modulo 360°): "point 'P' is
    given lon x here and y on row r: `why`", the first few per column and a count of the rest.

    Vectorised for tables of millions of rows: each point's smallest and largest value (one
    grouped pass per column) find the points whose rows may differ, and only their rows are
    compared with their first."""
    given = [c for c in GROUND_COLUMNS if c in tie_points.columns]
    if not given or "point_id" not in tie_points.columns or tie_points.empty:
        return []
    ids = tie_points["point_id"]
    point, k = grouped.key_codes(ids)
    groups = grouped.Groups(point, k)
    problems: list[Problem] = []
    for c in given:
        v = tie_points[c].to_numpy(np.float64, na_value=np.nan)
        rows = _disagreeing(v, point, groups, GROUND_AGREEMENT[c], c == "lon")
        if rows is None:
            continue
        problems += _ground_problems(file, ids, c, v, point, k, rows, why)
    return problems


def _disagreeing(
    v: np.ndarray, point: np.ndarray, groups: grouped.Groups, tol: float, lon: bool
) -> np.ndarray | None:
    """The rows (given, of a point) of the points whose values spread beyond `tol` (longitudes
    both as given and modulo 360°: 179.9° and -180.1° are one), None when there are none."""
    with np.errstate(invalid="ignore"):  # a point without a value: -inf - inf
        low, high = groups.extremes(v)
        wide = high - low > tol
        if lon and wide.any():
            low, high = groups.extremes(np.mod(v, 360.0))
            wide &= high - low > tol
    if not wide.any():
        return None
    return np.flatnonzero((point >= 0) & wide[point] & np.isfinite(v))


def _ground_problems(
    file: Path,
    ids: pd.Series,
    column: str,
    v: np.ndarray,
    point: np.ndarray,
    k: int,
    rows: np.ndarray,
    why: str,
) -> list[Problem]:
    """The rows among `rows` whose value differs from their point's first beyond the
    tolerance, each against that first row."""
    first, first_row = np.full(k, np.nan), np.zeros(k, np.int64)
    points, at = np.unique(point[rows], return_index=True)
    first[points], first_row[points] = v[rows[at]], rows[at]
    diff = v[rows] - first[point[rows]]
    if column == "lon":
        diff = wrap_lon(diff)
    bad = rows[np.abs(diff) > GROUND_AGREEMENT[column]]
    out = [
        Problem.at_row(
            file,
            i,
            f"point '{ids.iloc[i]}' is given {column} {v[i]:.10g} here and "
            f"{first[point[i]]:.10g} on row {first_row[point[i]] + 1}: {why}",
            column=column,
        )
        for i in bad[:MAX_ROWS_LISTED]
    ]
    if bad.size > MAX_ROWS_LISTED:
        out.append(
            Problem(
                str(file),
                f"{bad.size - MAX_ROWS_LISTED} more rows give their point another {column} than "
                f"its first row: {why}",
                column=column,
            )
        )
    return out
