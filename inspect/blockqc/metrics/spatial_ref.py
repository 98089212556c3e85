"""Mathematical basis: geodetic datum, height datum, projection and UTM zone (§MB-1..3)."""

from __future__ import annotations

import math
import re

import pandas as pd
import shapely
from pydantic import BaseModel, ConfigDict

from blockqc.delivery import Delivery, SpatialReference, canonical_epsg
from blockqc.metrics import Measure, Measurement, Scope, Table, metric
from blockqc.rfm.model import lon_extent

_WGS84 = {"WGS84", "WGS1984", "EPSG4326", "WORLDGEODETICSYSTEM1984", "G1762", "ITRF-WGS84"}
#: names of heights above the WGS-84 ellipsoid (§MB-2 calls them geodetic (ellipsoidal)
#: heights; 大地高 and 椭球高 in Chinese), written alone, after 'WGS 84' and before 'height(s)'
_ELLIPSOIDAL = {
    f"{datum}{name}{height}"
    for datum in ("", "WGS84", "WGS1984")
    for name in ("ELLIPSOIDAL", "ELLIPSOID", "GEODETIC")
    for height in ("", "HEIGHT", "HEIGHTS")
}
_ELLIPSOIDAL |= {
    f"{datum}{name}" for datum in ("", "WGS84", "WGS1984") for name in ("大地高", "椭球高")
}
_ELLIPSOIDAL |= {"EPSG4979"}


class SpatialParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    ups_north_lat: float = 84.0  # UPS north of this latitude (§MB-3)
    ups_south_lat: float = -80.0  # UPS south of this latitude
    # also allow the zones of the UTM grid's exceptions (Norway 32V, Svalbard 31X…37X), as the
    # official grid and GIS tools give them
    grid_exceptions: bool = True


def _key(text: str | None) -> str:
    return re.sub(r"[\s_\-:.]", "", (text or "").upper())


#: what may follow a datum's name and leave it the same datum: a realization of WGS 84
#: ('WGS 84 (G1762)') and the words 'coordinate system' in Chinese ('WGS-84 坐标系')
_DATUM_SUFFIX = re.compile(r"(\(?G\d{3,4}\)?)?(大地坐标系|坐标系)?$")


def normalize_datum(text: str | None) -> str | None:
    """'WGS 84', 'WGS-84', 'EPSG:4326', 'WGS_1984', 'WGS 84 (G1762)', 'WGS84 坐标系' … →
    'WGS84'; other names upper-cased."""
    if not text:
        return None
    names = {_key(x) for x in _WGS84}
    key = _key(text)
    wgs84 = key in names or _DATUM_SUFFIX.sub("", key, count=1) in names
    return "WGS84" if wgs84 else text.strip().upper()


def normalize_height_datum(text: str | None) -> str | None:
    """'ellipsoid', 'WGS84 ellipsoidal', 'geodetic' … → 'ellipsoidal'; geoid models upper-cased."""
    if not text:
        return None
    return "ellipsoidal" if _key(text) in _ELLIPSOIDAL else text.strip().upper()


def utm_zone(lon: float) -> int:
    """UTM zone number of a longitude (1..60; 180° is zone 60's east edge, a longitude beyond
    ±180° is taken round the globe); the Norway/Svalbard exceptions are `exception_zone`'s."""
    return int(min(60, math.floor((wrap_lon(lon) + 180.0) / 6.0) + 1))


def wrap_lon(lon: float) -> float:
    """A longitude in −180…180 (180 kept)."""
    return lon if -180.0 <= lon <= 180.0 else (lon + 180.0) % 360.0 - 180.0


def expected_epsg(
    lon_min: float, lon_max: float, lat_min: float, lat_max: float, p: SpatialParams
) -> list[int]:
    """EPSG codes a block may use: UTM of its extent's centre longitude, either neighbour when
    the extent straddles a zone edge, either hemisphere when it straddles the equator (Reading
    of §MB-3), and the zone of the grid's exceptions there (Norway, Svalbard); UPS in polar
    regions."""
    lat = (lat_min + lat_max) / 2
    if lat > p.ups_north_lat:
        return [32661]
    if lat < p.ups_south_lat:
        return [32761]
    bases = [32600, 32700] if lat_min < 0 <= lat_max else [32600 if lat >= 0 else 32700]
    centre = (lon_min + lon_max) / 2  # an extent across ±180° ends east of 180 (lon_extent)
    ends = (centre, lon_min, lon_max)
    zones = {utm_zone(x) for x in ends}
    if p.grid_exceptions:
        zones |= {z for x in ends if (z := exception_zone(x, lat)) is not None}
    return [base + z for base in bases for z in sorted(zones)]


#: the UTM grid's exceptions: (south, north, west, east, zone), degrees
GRID_EXCEPTIONS = (
    (56.0, 64.0, 3.0, 12.0, 32),  # south-west Norway: 32V widened west to 3° E
    (72.0, 84.0, 0.0, 9.0, 31),  # Svalbard: 31X, 33X, 35X, 37X, 12° wide
    (72.0, 84.0, 9.0, 21.0, 33),
    (72.0, 84.0, 21.0, 33.0, 35),
    (72.0, 84.0, 33.0, 42.0, 37),
)


def exception_zone(lon: float, lat: float) -> int | None:
    """The zone the UTM grid's exceptions give at (lon, lat), or None outside them."""
    lon = wrap_lon(lon)
    return next((z for s, n, w, e, z in GRID_EXCEPTIONS if s <= lat < n and w <= lon < e), None)


def delivered_epsg(sr) -> int | None:
    """The EPSG code stated in block.yaml, or one derived from `projection: UTM` + `zone: 50N`."""
    if sr is None:
        return None
    return int(sr.epsg) if sr.epsg is not None else sr.zone_epsg()


def describe_epsg(code: int | None) -> str:
    if code is None:
        return "not stated"
    if canonical_epsg(code) != code:
        return f"EPSG:{code} ({describe_epsg(canonical_epsg(code)).split(' (', 1)[1]}"
    if 32601 <= code <= 32660 or 32701 <= code <= 32760:
        return f"EPSG:{code} (UTM zone {code % 100}{'N' if code < 32700 else 'S'})"
    if code in (32661, 32761):
        return f"EPSG:{code} (UPS {'north' if code == 32661 else 'south'})"
    return f"EPSG:{code}"


def zone_name(code: int | None) -> str | None:
    """'38N', '50S', 'UPS N', 'UPS S' for a UTM/UPS code; None for another code or none."""
    code = canonical_epsg(code)
    if code is None:
        return None
    if 32601 <= code <= 32660 or 32701 <= code <= 32760:
        return f"{code % 100}{'N' if code < 32700 else 'S'}"
    if code in (32661, 32761):
        return f"UPS {'N' if code == 32661 else 'S'}"
    return None


def _zones(codes: list[int]) -> dict[str, str]:
    """The codes a block may use and their zones, as evidence: '32637 / 32638', '37N / 38N'."""
    return {
        "expected_epsg": " / ".join(str(c) for c in codes),
        "expected_zone": " / ".join(str(zone_name(c)) for c in codes),
    }


#: projection names (spaces, case and punctuation aside) that say UTM — GDAL and ESRI call a
#: UTM code's projection Transverse_Mercator — and that say UPS; Gauss–Krüger is a transverse
#: Mercator of other zones and scale, never a UTM code's
_UTM_NAMES = ("UTM", "TRANSVERSEMERCATOR")
_UPS_NAMES = ("UPS", "UNIVERSALPOLARSTEREOGRAPHIC", "POLARSTEREOGRAPHIC")
_NOT_UTM = ("GAUSS", "KRUGER", "KRUEGER", "KRÜGER")


def _projection_problem(projection: str | None, code: int | None) -> str | None:
    """Why the stated projection name contradicts the EPSG code (a Gauss–Krüger projection
    stated beside a UTM code), or None when it agrees or none is stated."""
    if not projection or code is None or zone_name(code) is None:
        return None
    key = _key(projection)
    polar = canonical_epsg(code) in (32661, 32761)
    names = _UPS_NAMES if polar else _UTM_NAMES
    if any(name in key for name in names) and not any(name in key for name in _NOT_UTM):
        return None
    wanted = "UPS" if polar else "UTM"
    return f"projection '{projection}' stated beside {describe_epsg(code)}: expected {wanted}"


@metric(
    "spatial_reference",
    tie_points=(),
    params=SpatialParams,
    scopes={
        "block": Scope(
            {
                "geodetic_datum": "name",
                "height_datum": "name",
                "projection_ok": "true/false",
                "epsg": "EPSG code",
            },
            columns=("projection", "zone", "expected_epsg", "expected_zone", "projection_note"),
            notes={"projection_ok": "projection_note"},
        )
    },
    param_units={"ups_north_lat": "degrees", "ups_south_lat": "degrees"},
)
def spatial_reference(d: Delivery, p: SpatialParams, measure: Measure) -> Measurement:
    """The block's stated datum, height datum and projection against its extent (§MB-1..3)."""
    sr = d.manifest.spatial_reference
    extent = _block_extent(d)
    allowed = expected_epsg(*extent, p)
    code = delivered_epsg(sr)
    named = _projection_problem(sr.projection if sr else None, code)
    ok = canonical_epsg(code) in allowed and named is None
    plain_grid = p.model_copy(update={"grid_exceptions": False})
    plain = expected_epsg(*extent, plain_grid)
    straddles = len(plain) > 1
    in_zone = ok and not straddles and canonical_epsg(code) in plain  # nothing more to say
    note = named if named is not None else _zone_note(code, ok, allowed, plain, extent)
    block = _block_table(sr, code, allowed, ok, "" if in_zone else note)
    return Measurement(
        tables={"block": Table(block)},
        detail=_detail(sr, extent, allowed, straddles, note),
    )


def _block_extent(d: Delivery) -> tuple[float, float, float, float]:
    """The block's footprints' extent: lon_min, lon_max (west, east: across ±180° east is beyond
    180°), lat_min, lat_max."""
    geoms = shapely.from_wkt(d.scenes["footprint_wkt"].to_numpy(dtype=object))
    _, lat_min, _, lat_max = shapely.total_bounds(geoms)
    lon_min, lon_max = lon_extent(shapely.get_coordinates(geoms)[:, 0])
    return lon_min, lon_max, lat_min, lat_max


def _zone_note(
    code: int | None,
    ok: bool,
    allowed: list[int],
    plain: list[int],
    extent: tuple[float, float, float, float],
) -> str:
    """MB-3's note on the zone delivered: none stated, one the grid's exceptions give, one of
    the zones a block straddling an edge may take, the block's zone, or not the zone expected."""
    lon_min, lon_max, lat_min, lat_max = extent
    if code is None:
        return "block.yaml states no EPSG code (nor projection UTM with a zone such as 50N)"
    if ok and canonical_epsg(code) not in plain:
        return (
            f"{describe_epsg(code)} is the zone the UTM grid's exceptions give here (Norway, "
            "Svalbard)"
        )
    if ok and len(plain) > 1:
        edges = []
        if len({c % 100 for c in plain}) > 1:
            edges.append(f"a zone edge (lon {lon_min:.3f}…{wrap_lon(lon_max):.3f})")
        if len({c // 100 for c in plain}) > 1:
            edges.append(f"the equator (lat {lat_min:.3f}…{lat_max:.3f})")
        return (
            f"the block straddles {' and '.join(edges)}; {describe_epsg(code)} is one of the "
            "neighbours allowed"
        )
    if ok:
        return f"{describe_epsg(code)} is the block's zone"
    return f"{describe_epsg(code)} delivered, expected " + " or ".join(
        describe_epsg(c) for c in allowed
    )


def _block_table(
    sr: SpatialReference | None, code: int | None, allowed: list[int], ok: bool, note: str
) -> pd.DataFrame:
    """The block's row: what block.yaml states, the zones allowed, and whether the projection
    is one of them (`note`: MB-3's note, blank when there is no more to say than the zone)."""
    return pd.DataFrame(
        {
            "geodetic_datum": [normalize_datum(sr.geodetic_datum if sr else None)],
            "height_datum": [normalize_height_datum(sr.height_datum if sr else None)],
            "projection": [(sr.projection if sr else None)],
            "epsg": [code],
            "zone": [zone_name(code)],
            **{k: [v] for k, v in _zones(allowed).items()},
            "projection_ok": [ok],
            # MB-3's note when there is more to say than the zone (§MB-3 'report it')
            "projection_note": [note],
        }
    )


def _detail(
    sr: SpatialReference | None,
    extent: tuple[float, float, float, float],
    allowed: list[int],
    straddles: bool,
    note: str,
) -> dict[str, object]:
    """The measurement's detail: the block's centre and extent, the zones expected, MB-3's
    note and the datums as stated."""
    lon_min, lon_max, lat_min, lat_max = extent
    lat_c = (lat_min + lat_max) / 2
    return {
        "centre_lon": round(wrap_lon((lon_min + lon_max) / 2), 6),
        "centre_lat": round(float(lat_c), 6),
        # west > east for a block across ±180° (as a GeoJSON bbox gives it)
        "extent_lonlat": [
            round(float(v), 6) for v in (lon_min, lat_min, wrap_lon(lon_max), lat_max)
        ],
        "expected_epsg": allowed,
        "straddles_zone_edge": straddles,
        "note": note,
        "stated": {
            "geodetic_datum": sr.geodetic_datum if sr else None,
            "height_datum": sr.height_datum if sr else None,
        },
    }
