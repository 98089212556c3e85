"""Reading RPC00B models from every common format into one `RPCModel`.

Formats, told apart by their content (not their name) in `read_rpc`:

* GeoTIFF / NITF RPC tags and GDAL sidecars, through rasterio (`dataset.rpcs`);
* DigitalGlobe/Maxar `.RPB` text (`lineNumCoef = ( … );`) and XML (`<RPB><IMAGE>…`);
* DIMAP v2 XML (Pléiades, SPOT 6/7): inverse model + RFM_Validity; DIMAP counts the first pixel
  as 1, so 1 is subtracted from LINE_OFF and SAMP_OFF to reach our pixel-centre convention
  (first pixel centre at (0, 0)); checked against the OSSIM `.geom` of the same Pléiades image;
  DIMAP v3 (Pléiades Neo): GroundtoImage_Values, its first pixel ImagetoGround_Validity_Domain's
  FIRST_COL (as GDAL reads it);
* OSSIM keyword lists (`.geom`, `polynomial_format: B`), already first-pixel-centre (0, 0);
* the `KEY: value [unit]` text of IKONOS and of Chinese satellites (GF/ZY `*_rpc.txt`), also
  used by Planet and SkySat (`LINE_OFF: +015750.00 pixels`, `LINE_NUM_COEFF_1: …`);
* the JSON dictionary used by rpcm / SatNeRF (`row_offset`, `row_num`, …).

Text is UTF-8 (with or without BOM), UTF-16 with a BOM, or else Latin-1, with LF, CR LF or
CR-only line ends. Every problem is an `InputError` naming the file and the line or key that is
wrong, missing or given twice; a 21st coefficient, a second number after a value and a latitude
or longitude offset out of range are refused too (docs/rfm.md).
"""

from __future__ import annotations

import codecs
import json
import re
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING
from xml.etree import ElementTree

import numpy as np

from blockqc.errors import InputError, Problem
from blockqc.rfm.model import MIN_SCALE, OFFSET_SCALE_KEYS, RPCModel
from blockqc.textio import check_no_nul, not_a_file

if TYPE_CHECKING:
    from rasterio.io import DatasetReader

COEFF_KEYS = ("line_num", "line_den", "samp_num", "samp_den")

_TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
_NITF_MAGIC = (b"NITF", b"NSIF")


def _error(path: Path | str, message: str, line: int | None = None) -> InputError:
    return InputError(Problem(file=str(path), message=message, line=line))


def _duplicate(path: Path | str, key: str, first: int, second: int) -> InputError:
    return _error(path, f"{key} given twice, on lines {first} and {second}: expected once", second)


#: the unit words an RPC text may write after a value, by what the value measures
_UNITS = {
    "pixels": ("pixel", "pixels", "pix", "px"),
    "degrees": ("degree", "degrees", "deg"),
    "meters": ("meter", "meters", "metre", "metres", "m"),
}


#: what the offsets and scales measure, by the start of their name in each format (rpcm JSON
#: calls line and sample row and col, height alt)
_KINDS = (
    ("line", "pixels"),
    ("samp", "pixels"),
    ("row", "pixels"),
    ("col", "pixels"),
    ("lat", "degrees"),
    ("lon", "degrees"),
    ("height", "meters"),
    ("alt", "meters"),
)


def _units_of(key: str) -> tuple[str, ...]:
    """The unit words a key's value may carry: pixels for LINE/SAMP offsets and scales, degrees
    for LAT/LONG, meters for HEIGHT; a coefficient (no unit) is let carry any of them. The key
    may be named with its place (`…/RFM_Validity/LAT_OFF`, `rpc.lat_offset`)."""
    k = re.split(r"[/.]", key)[-1].lower()
    if "coef" in k:
        return ("pixels", "degrees", "meters")
    for start, kind in _KINDS:
        if k.startswith(start):
            return (kind,)
    return ("pixels", "degrees", "meters")


def _number(path: Path | str, key: str, text: str, line: int | None = None) -> float:
    """Parse one number, tolerating a trailing unit word of the key's unit ('+005124.00
    pixels'); another unit ('1.075 kilometers') would be misread, so it is refused. Python's
    digit separator is no number of these files ('1_000': C's strtod stops at the '_')."""
    tokens = text.split()
    try:
        value = float(tokens[0] if tokens and "_" not in tokens[0] else "")
    except ValueError:
        raise _error(path, f"{key}: expected a number, got {text.strip()!r}", line) from None
    kinds = _units_of(key)
    if len(tokens) > 2 or (
        len(tokens) == 2 and tokens[1].lower() not in {w for k in kinds for w in _UNITS[k]}
    ):
        raise _error(
            path,
            f"{key}: expected one number, optionally followed by its unit ("
            f"{' or '.join(repr(k) for k in kinds)}), got {text.strip()!r}",
            line,
        )
    if not np.isfinite(value):
        raise _error(path, f"{key}: expected a finite number, got {text.strip()!r}", line)
    return value


#: where a field was read: its key as the file writes it, and its line (None: not known)
Named = Mapping[str, tuple[str, int | None]]


def _build(
    path: Path | str, values: Mapping[str, object], named: Named | None = None, **extra: object
) -> RPCModel:
    """The model of the fields read (`named`: where each was read, for the messages)."""
    missing = [k for k in (*OFFSET_SCALE_KEYS, *COEFF_KEYS) if k not in values]
    if missing:
        raise _error(path, f"missing RPC field(s): {', '.join(missing)}")
    _check_scales(path, values, named or {})
    for key in COEFF_KEYS:
        arr = np.asarray(values[key], dtype=np.float64)
        if arr.shape != (20,):
            raise _error(path, f"{key}: expected 20 coefficients, got {arr.size}")
    _check_ground_offsets(path, values)
    kwargs = {k: values[k] for k in (*OFFSET_SCALE_KEYS, *COEFF_KEYS)}
    return RPCModel(source=str(path), **kwargs, **extra)  # type: ignore[arg-type]


def _check_scales(path: Path | str, values: Mapping[str, object], named: Named) -> None:
    """Each scale of magnitude at least MIN_SCALE (the model divides by it), refused naming its
    key as the file writes it, and its line."""
    for name in OFFSET_SCALE_KEYS:
        value = float(values[name])  # type: ignore[arg-type]
        if name.endswith("_scale") and abs(value) < MIN_SCALE:
            key, line = named.get(name, (name.upper(), None))
            raise _error(
                path, f"{key}: expected a scale of magnitude at least {MIN_SCALE:g} (the model "
                f"divides by it), got {value:g}", line,
            )  # fmt: skip


def _check_ground_offsets(path: Path | str, values: Mapping[str, object]) -> None:
    """LAT_OFF in [-90, 90] and LONG_OFF in [-180, 360] degrees (longitudes -180…180 or 0…360)."""
    lat, lon = float(values["lat_off"]), float(values["lon_off"])  # type: ignore[arg-type]
    for key, value in (("LAT_OFF", lat), ("LONG_OFF", lon)):
        if not np.isfinite(value):
            raise _error(path, f"{key}: expected a finite number of degrees, got {value!r}")
    if not -90.0 <= lat <= 90.0:
        raise _error(
            path,
            f"LAT_OFF (latitude offset): expected degrees in [-90, 90], got {lat!r} "
            "(latitude and longitude swapped?)",
        )
    if not -180.0 <= lon <= 360.0:
        raise _error(
            path, f"LONG_OFF (longitude offset): expected degrees in [-180, 360], got {lon!r}"
        )


# -- KEY: value text (IKONOS, GF/ZY *_rpc.txt, Planet, SkySat) --------------------------------
_TXT_NAMES = {
    "LINE_OFF": "line_off",
    "SAMP_OFF": "samp_off",
    "LAT_OFF": "lat_off",
    "LONG_OFF": "lon_off",
    "HEIGHT_OFF": "height_off",
    "LINE_SCALE": "line_scale",
    "SAMP_SCALE": "samp_scale",
    "LAT_SCALE": "lat_scale",
    "LONG_SCALE": "lon_scale",
    "HEIGHT_SCALE": "height_scale",
}
_KV_LINE = re.compile(r"^\s*([A-Za-z0-9_.]+)\s*([:=])\s*(.*?)\s*;?\s*$")
#: the formats whose keys are followed by a colon, named when one is followed by "="
_TXT_COLON = (
    "the KEY: value text of IKONOS, GF/ZY, Planet and SkySat, as GDAL reads it; GDAL does not "
    "read '='"
)
_GEOM_COLON = "an OSSIM keyword list"


def _key_values(
    path: Path, text: str, colon_of: str, upper: bool = False
) -> dict[str, tuple[str, int]]:
    """`key: value` lines → {key: (value, line number)}; lines without a colon are skipped.

    A key written `key = value` is refused, naming `colon_of` (the format whose separator is
    the colon); a key given twice is too (with `upper`, keys are upper-cased before
    comparing)."""
    out: dict[str, tuple[str, int]] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        m = _KV_LINE.match(raw)
        if m is None:
            continue
        key = m.group(1).upper() if upper else m.group(1)
        if m.group(2) == "=":
            raise _error(
                path, f"{raw.strip()}: expected '{m.group(1)}: value', a colon after the key (the "
                f"separator of {colon_of})", number,
            )  # fmt: skip
        if key in out:
            raise _duplicate(path, key, out[key][1], number)
        out[key] = (m.group(3), number)
    return out


def _named(kv: Mapping[str, tuple[str, int]], names: Mapping[str, str]) -> Named:
    """Where each field of `names` (key → field) was read: its key and line."""
    return {name: (key, kv[key][1]) for key, name in names.items() if key in kv}


def _kv_number(path: Path, kv: Mapping[str, tuple[str, int]], key: str) -> float:
    if key not in kv:
        raise _error(path, f"missing key {key}")
    return _number(path, key, *kv[key])


def _kv_coeffs(
    path: Path,
    kv: Mapping[str, tuple[str, int]],
    key_of: Callable[[str, int], str],
    numbers: range,
    pattern: re.Pattern[str],
) -> dict[str, list[float]]:
    """The four polynomials (COEFF_KEYS), read from the keys `key_of(name, i)`, i in `numbers`;
    another key matching `pattern` (a 21st coefficient) is refused."""
    keys = {name: [key_of(name, i) for i in numbers] for name in COEFF_KEYS}
    known = {key for names in keys.values() for key in names}
    for key, (_, line) in kv.items():
        if pattern.fullmatch(key) and key not in known:
            raise _error(
                path,
                f"{key}: an RPC00B polynomial has 20 coefficients, "
                f"numbered {numbers[0]} to {numbers[-1]}",
                line,
            )
    return {name: [_kv_number(path, kv, key) for key in names] for name, names in keys.items()}


_TXT_COEFF = re.compile(r"(LINE|SAMP)_(NUM|DEN)_COEFF_\d+")


def _txt_coeff_key(name: str, i: int) -> str:
    return f"{name.upper()}_COEFF_{i}"


def read_rpc_txt(path: Path, text: str | None = None) -> RPCModel:
    """The `KEY: value [unit]` format (IKONOS, GF/ZY `_rpc.txt`, Planet, SkySat)."""
    path = Path(path)
    text = _read_text(path) if text is None else text
    kv = _key_values(path, text, _TXT_COLON, upper=True)
    values: dict[str, object] = {
        name: _kv_number(path, kv, key) for key, name in _TXT_NAMES.items()
    }
    values.update(_kv_coeffs(path, kv, _txt_coeff_key, range(1, 21), _TXT_COEFF))
    extra = {}
    for key, name in (("ERR_BIAS", "err_bias"), ("ERR_RAND", "err_rand")):
        if key in kv:
            extra[name] = _kv_number(path, kv, key)
    return _build(path, values, _named(kv, _TXT_NAMES), **extra)


# -- OSSIM keyword list (.geom) ---------------------------------------------------------------
_GEOM_NAMES = {
    "line_off": "line_off",
    "samp_off": "samp_off",
    "lat_off": "lat_off",
    "long_off": "lon_off",
    "height_off": "height_off",
    "line_scale": "line_scale",
    "samp_scale": "samp_scale",
    "lat_scale": "lat_scale",
    "long_scale": "lon_scale",
    "height_scale": "height_scale",
}


_GEOM_COEFF = re.compile(r"(line|samp)_(num|den)_coeff_\d+")


def _geom_coeff_key(name: str, i: int) -> str:
    return f"{name}_coeff_{i:02d}"


def read_rpc_geom(path: Path, text: str | None = None) -> RPCModel:
    """OSSIM keyword list (`.geom`); only `polynomial_format: B` (RPC00B order) is accepted."""
    path = Path(path)
    text = _read_text(path) if text is None else text
    kv = _key_values(path, text, _GEOM_COLON)
    values: dict[str, object] = {
        name: _kv_number(path, kv, key) for key, name in _GEOM_NAMES.items()
    }
    values.update(_kv_coeffs(path, kv, _geom_coeff_key, range(20), _GEOM_COEFF))
    _rpc00b_order(path, kv)
    _no_geom_adjustment(path, kv)
    return _build(path, values, _named(kv, _GEOM_NAMES))


def _rpc00b_order(path: Path, kv: Mapping[str, tuple[str, int]]) -> None:
    """The term order of a `.geom` must be stated and be B: OSSIM requires `polynomial_format`
    and reads the same 20 numbers in another order for A (RPC00A)."""
    if "polynomial_format" not in kv:
        raise _error(
            path,
            "missing key polynomial_format: expected B (RPC00B term order); OSSIM requires it, "
            "and without it the order of the 20 coefficients (RPC00A or B) is unknown",
        )
    value, line = kv["polynomial_format"]
    if value.strip().upper() != "B":
        raise _error(
            path, f"polynomial_format: only B (RPC00B term order) is supported, got {value!r}", line
        )


_GEOM_ADJUSTMENT = re.compile(r"(adjustment_\d+\.adj_param_\d+)\.parameter")


def _no_geom_adjustment(path: Path, kv: Mapping[str, tuple[str, int]]) -> None:
    """Refuse an OSSIM adjustment in force (a parameter of the current adjustment whose offset
    center + parameter·sigma is not 0: OSSIM moves the image by it, in pixels, scale or
    rotation): blockqc reads the RPC alone, and would measure the model as unadjusted. Other
    adjustments saved in the file are not applied by OSSIM either."""
    current = kv.get("current_adjustment") or kv.get("current_adjustement") or ("0", None)
    in_force = f"adjustment_{current[0].strip()}."
    for key, (value, line) in kv.items():
        m = _GEOM_ADJUSTMENT.fullmatch(key)
        if m is None or not key.startswith(in_force):
            continue
        param = m.group(1)
        parts = {f: kv.get(f"{param}.{f}", ("0", line)) for f in ("center", "sigma")}
        offset = _number(path, key, value, line) * _number(path, f"{param}.sigma", *parts["sigma"])
        offset += _number(path, f"{param}.center", *parts["center"])
        if offset != 0:
            what = kv.get(f"{param}.description", ("an adjustable parameter", line))[0].strip()
            raise _error(
                path,
                f"{key}: an OSSIM adjustment in force ({what}: center + parameter·sigma = "
                f"{offset:g}), which blockqc does not apply: expected the RPC without it (the "
                "current adjustment's parameters and centers 0), or the adjusted model as RPCs",
                line,
            )


# -- DigitalGlobe .RPB ------------------------------------------------------------------------
_RPB_NAMES = {
    "lineOffset": "line_off",
    "sampOffset": "samp_off",
    "latOffset": "lat_off",
    "longOffset": "lon_off",
    "heightOffset": "height_off",
    "lineScale": "line_scale",
    "sampScale": "samp_scale",
    "latScale": "lat_scale",
    "longScale": "lon_scale",
    "heightScale": "height_scale",
}
_RPB_COEFF = {
    "lineNumCoef": "line_num",
    "lineDenCoef": "line_den",
    "sampNumCoef": "samp_num",
    "sampDenCoef": "samp_den",
}
_RPB_ITEM = re.compile(r"(\w+)\s*=\s*(\([^)]*\)|[^;\n]*);", re.S)  # a plain value ends on its line


#: an .RPB's items by key in lower case (GDAL reads its keys in any case: LINEOFFSET,
#: lineoffset): value, line, and the key as the file writes it (for the messages)
_RpbItems = dict[str, tuple[str, int, str]]


def _rpb_items(path: Path, text: str) -> _RpbItems:
    """The `key = value;` items of an .RPB; a key given twice, in any case, is refused."""
    items: _RpbItems = {}
    for m in _RPB_ITEM.finditer(text):
        key, line = m.group(1), text.count("\n", 0, m.start(2)) + 1
        if key.lower() in items:
            raise _duplicate(path, key, items[key.lower()][1], line)
        items[key.lower()] = (m.group(2), line, key)
    return items


def _rpb_item(path: Path, text: str, items: _RpbItems, key: str) -> tuple[str, int, str]:
    """The item of `key` (its usual spelling), whatever the case the file writes it in."""
    if key.lower() not in items:
        raise _rpb_missing(path, text, key)
    return items[key.lower()]


def _rpb_coeffs(path: Path, raw: str, key: str, line: int) -> list[float]:
    """The 20 numbers of a `( v, v, … )` list (`key` as the file writes it)."""
    parts = [p.strip() for p in raw.strip().strip("()").split(",")]
    if len(parts) > 1 and not parts[-1]:
        parts.pop()  # a trailing comma before ')'
    if "" in parts and parts != [""]:
        at = parts.index("") + 1
        raise _error(
            path, f"{key}: coefficient {at} is empty (two commas with no number between): "
            "expected 20 numbers separated by commas", line,
        )  # fmt: skip
    parts = [p for p in parts if p]
    if len(parts) != 20:
        raise _error(path, f"{key}: expected 20 coefficients, got {len(parts)}", line)
    return [_number(path, key, p, line) for p in parts]


def read_rpc_rpb(path: Path, text: str | None = None) -> RPCModel:
    """DigitalGlobe `.RPB`: `key = value;` with the coefficients as `( v, v, … );` lists; keys
    in any case (`lineOffset`, `LINEOFFSET`), as GDAL reads them."""
    path = Path(path)
    text = _read_text(path) if text is None else text
    items = _rpb_items(path, text)
    values: dict[str, object] = {}
    for key, name in _RPB_NAMES.items():
        raw, line, written = _rpb_item(path, text, items, key)
        values[name] = _number(path, written, raw, line)
    for key, name in _RPB_COEFF.items():
        raw, line, written = _rpb_item(path, text, items, key)
        values[name] = _rpb_coeffs(path, raw, written, line)
    extra = {}
    for key, name in (("errBias", "err_bias"), ("errRand", "err_rand")):
        if key.lower() in items:
            raw, line, written = items[key.lower()]
            extra[name] = _number(path, written, raw, line)
    named = {name: (items[k.lower()][2], items[k.lower()][1]) for k, name in _RPB_NAMES.items()}
    return _build(path, values, named, **extra)


def _rpb_missing(path: Path, text: str, key: str) -> InputError:
    """A key the .RPB does not give: missing, or written without the ';' that ends its value
    (the value of a list, `( … )`, may run over several lines)."""
    found = re.search(rf"^\s*{key}\s*=", text, re.M | re.I)
    if found is None:
        return _error(path, f"missing key {key}")
    line = text.count("\n", 0, found.start()) + 1
    form = "( v, …, v );" if key in _RPB_COEFF else "value;"
    return _error(
        path,
        f"{key}: expected '{key} = {form}', found no ';' ending it (a ';' left out, or the file "
        "cut short?)",
        line,
    )


# -- XML: DIMAP v2 and DigitalGlobe -----------------------------------------------------------
def _xml_one(path: Path, parent: ElementTree.Element, tag: str, where: str) -> ElementTree.Element:
    found = parent.findall(tag)
    if not found:
        raise _error(path, f"missing element {where}/{tag}")
    if len(found) > 1:
        raise _error(path, f"element {where}/{tag} given {len(found)} times: expected once")
    return found[0]


def _xml_number(path: Path, parent: ElementTree.Element, tag: str, where: str) -> float:
    el = _xml_one(path, parent, tag, where)
    if el.text is None:
        raise _error(path, f"missing element {where}/{tag}")
    return _number(path, f"{where}/{tag}", el.text)


#: the ground→image RPCs of DIMAP v2 (Pléiades, SPOT 6/7) and of DIMAP v3 (Pléiades Neo)
DIMAP_GROUND_TO_IMAGE = ("Inverse_Model", "GroundtoImage_Values")
#: DIMAP v3's first pixel (v2 counts from 1): <this>/FIRST_COL wherever it is, as GDAL reads it
DIMAP_V3_DOMAIN = "ImagetoGround_Validity_Domain"


def _read_dimap(path: Path, root: ElementTree.Element) -> RPCModel:
    base = "Rational_Function_Model/Global_RFM"
    found = [(t, root.find(f"{base}/{t}")) for t in DIMAP_GROUND_TO_IMAGE]
    tag, inverse = next(((t, e) for t, e in found if e is not None), (None, None))
    validity = root.find(f"{base}/RFM_Validity")
    if inverse is None:
        v2, v3 = DIMAP_GROUND_TO_IMAGE
        raise _error(
            path, f"missing element {base}/{v2} (DIMAP v2) or {base}/{v3} (DIMAP v3): the "
            "ground→image RPCs",
        )  # fmt: skip
    if validity is None:
        raise _error(path, f"missing element {base}/RFM_Validity (offsets and scales)")
    where = f"{base}/{tag}"
    extra = [c.tag for c in inverse if _TXT_COEFF.fullmatch(c.tag) and not _in_1_to_20(c.tag)]
    if extra:
        raise _error(
            path, f"{where}/{extra[0]}: an RPC00B polynomial has 20 coefficients, numbered 1 to 20"
        )
    values: dict[str, object] = {}
    for kind in ("LINE", "SAMP"):
        for part in ("NUM", "DEN"):
            values[f"{kind.lower()}_{part.lower()}"] = [
                _xml_number(path, inverse, f"{kind}_{part}_COEFF_{i}", where) for i in range(1, 21)
            ]
    where = f"{base}/RFM_Validity"
    for key, name in _TXT_NAMES.items():
        values[name] = _xml_number(path, validity, key, where)
    # DIMAP counts the first pixel from 1 (v2) or from v3's FIRST_COL; ours is (0, 0) (pixel
    # centres in all)
    domain = root.find(f".//{DIMAP_V3_DOMAIN}")
    first = 1.0
    if domain is not None:
        first = _xml_number(path, domain, "FIRST_COL", DIMAP_V3_DOMAIN)
    values["line_off"] = float(values["line_off"]) - first  # type: ignore[arg-type]
    values["samp_off"] = float(values["samp_off"]) - first  # type: ignore[arg-type]
    named = {name: (f"{where}/{key}", None) for key, name in _TXT_NAMES.items()}
    return _build(path, values, named, first_pixel=first)


def _in_1_to_20(tag: str) -> bool:
    return 1 <= int(tag.rsplit("_", 1)[1]) <= 20


_DG_NAMES = {
    "LINEOFFSET": "line_off",
    "SAMPOFFSET": "samp_off",
    "LATOFFSET": "lat_off",
    "LONGOFFSET": "lon_off",
    "HEIGHTOFFSET": "height_off",
    "LINESCALE": "line_scale",
    "SAMPSCALE": "samp_scale",
    "LATSCALE": "lat_scale",
    "LONGSCALE": "lon_scale",
    "HEIGHTSCALE": "height_scale",
}


def _read_dg_xml(path: Path, image: ElementTree.Element) -> RPCModel:
    where = "RPB/IMAGE"
    values: dict[str, object] = {}
    for key, name in _DG_NAMES.items():
        values[name] = _xml_number(path, image, key, where)
    for kind in ("LINE", "SAMP"):
        for part in ("NUM", "DEN"):
            tag = f"{kind}{part}COEF"
            holder = _xml_one(path, image, f"{tag}List", where)
            text = " ".join((el.text or "") for el in holder.iter(tag))
            tokens = text.split()
            if len(tokens) != 20:
                raise _error(
                    path, f"{where}/{tag}List: expected 20 coefficients, got {len(tokens)}"
                )
            values[f"{kind.lower()}_{part.lower()}"] = [
                _number(path, f"{where}/{tag}List", t) for t in tokens
            ]
    extra = {}
    for key, name in (("ERRBIAS", "err_bias"), ("ERRRAND", "err_rand")):
        el = image.find(key)
        if el is not None and el.text:
            extra[name] = _number(path, f"{where}/{key}", el.text)
    named = {name: (f"{where}/{key}", None) for key, name in _DG_NAMES.items()}
    return _build(path, values, named, **extra)


def read_rpc_xml(path: Path, text: str | None = None) -> RPCModel:
    """DIMAP v2 (Pléiades, SPOT 6/7) or DigitalGlobe XML (`<isd>…<RPB><IMAGE>` or `<RPB>`)."""
    path = Path(path)
    text = _read_text(path) if text is None else text
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as exc:
        line = exc.position[0] if getattr(exc, "position", None) else None
        raise _error(path, f"not well-formed XML: {exc}", line) from None
    if root.tag == "Dimap_Document":
        return _read_dimap(path, root)
    images = root.findall("IMAGE") if root.tag == "RPB" else root.findall(".//RPB/IMAGE")
    if len(images) > 1:
        raise _error(
            path, f"{len(images)} RPB/IMAGE elements: expected the RPCs of one image (which of "
            "them is the scene's?)",
        )  # fmt: skip
    if images:
        return _read_dg_xml(path, images[0])
    raise _error(
        path,
        f"XML root <{root.tag}> holds no RPCs this reader knows "
        "(expected a DIMAP Dimap_Document or a DigitalGlobe RPB/IMAGE element)",
    )


# -- JSON (rpcm / SatNeRF) --------------------------------------------------------------------
_JSON_NAMES = {
    "row_offset": "line_off",
    "col_offset": "samp_off",
    "lat_offset": "lat_off",
    "lon_offset": "lon_off",
    "alt_offset": "height_off",
    "row_scale": "line_scale",
    "col_scale": "samp_scale",
    "lat_scale": "lat_scale",
    "lon_scale": "lon_scale",
    "alt_scale": "height_scale",
    "row_num": "line_num",
    "row_den": "line_den",
    "col_num": "samp_num",
    "col_den": "samp_den",
}


def _json_object(path: Path, pairs: list[tuple[str, object]]) -> dict[str, object]:
    """A JSON object, refusing a key given twice (`json.loads` would keep the last)."""
    out: dict[str, object] = {}
    for key, value in pairs:
        if key in out:
            raise _error(path, f"key {key!r} given twice in one JSON object: expected once")
        out[key] = value
    return out


def read_rpc_json(path: Path, text: str | None = None) -> RPCModel:
    """The JSON dictionary of rpcm / SatNeRF (`{"rpc": {"row_offset": …, "row_num": […]}}`)."""
    path = Path(path)
    text = _read_text(path) if text is None else text
    try:
        doc = json.loads(text, object_pairs_hook=lambda pairs: _json_object(path, pairs))
    except json.JSONDecodeError as exc:
        raise _error(path, f"not valid JSON: {exc.msg}", exc.lineno) from None
    d = doc.get("rpc", doc) if isinstance(doc, dict) else None
    if not isinstance(d, dict):
        raise _error(path, "expected a JSON object with an 'rpc' object")
    values: dict[str, object] = {}
    for key, name in _JSON_NAMES.items():
        if key not in d:
            raise _error(path, f"missing key rpc.{key}")
        v = d[key]
        if name in COEFF_KEYS:
            if not isinstance(v, list) or len(v) != 20:
                raise _error(path, f"rpc.{key}: expected a list of 20 numbers")
            values[name] = [_number(path, f"rpc.{key}", str(x)) for x in v]
        else:
            values[name] = _number(path, f"rpc.{key}", str(v))
    return _build(path, values, {name: (f"rpc.{key}", None) for key, name in _JSON_NAMES.items()})


# -- GDAL (GeoTIFF / NITF tags, GDAL sidecars) ------------------------------------------------
#: GDAL drivers of raw binary rasters, with the bytes of header their data file starts with: a
#: file of theirs cut short is read by GDAL (small grids at least) with its missing rows as 0,
#: without a word — a geoid grid's undulation N = 0, the heights off by tens of metres
RAW_HEADER_BYTES = {"GTX": 40, "ENVI": 0, "EHdr": 0, "ISCE": 0, "GenBin": 0}


def check_whole(ds: DatasetReader, path: Path | str, what: str) -> None:
    """Refuse a raw binary raster whose data file is shorter than its header and values."""
    header = RAW_HEADER_BYTES.get(ds.driver)
    if header is None or not ds.files:
        return
    item = np.dtype(ds.dtypes[0]).itemsize
    need = header + ds.width * ds.height * ds.count * item
    size = Path(ds.files[0]).stat().st_size
    if size < need:
        raise _error(
            path,
            f"the {what} is cut short: {size} bytes, expected at least {need} ({header} of "
            f"header and {ds.width} × {ds.height} × {ds.count} values of {item} bytes); GDAL "
            "would read the values missing as 0",
        )


def open_raster(path: Path | str) -> DatasetReader:
    """`rasterio.open` without GDAL's 'no geotransform' warning, which every image in sensor
    geometry would raise; an unreadable file is an InputError naming it. (rasterio is imported
    here: a delivery's RPCs are mostly text, and GDAL takes a tenth of a second to load.)"""
    import rasterio
    from rasterio.errors import NotGeoreferencedWarning, RasterioIOError

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        try:
            ds = rasterio.open(path)
        except RasterioIOError as exc:
            raise _error(path, f"cannot open as a raster: {exc}") from None
    try:
        check_whole(ds, path, "raster")
    except InputError:
        ds.close()
        raise
    return ds


@contextmanager
def reading_pixels(path: Path | str, what: str) -> Iterator[None]:
    """Around a read of a raster's pixels: a file GDAL opens but cannot read (cut short,
    damaged) is an InputError naming it, the `what` it is and what GDAL said, not rasterio's
    'Read failed. See previous exception for details.' without a file."""
    from rasterio.errors import RasterioIOError, WarpOperationError

    try:
        yield
    except (RasterioIOError, WarpOperationError) as exc:
        said = str(exc.__cause__ or exc)
        raise _error(
            path, f"cannot read the {what}'s pixels: {said} (a file cut short or damaged?)"
        ) from None


NO_RPCS = "the raster carries no RPCs (no RPC tags, no RPC sidecar found by GDAL)"


def read_rpc_gdal(path: Path, missing: str = NO_RPCS) -> RPCModel:
    """RPCs GDAL finds for a raster (TIFF tags, NITF RPC00B TRE, `_rpc.txt` / `.RPB` sidecars);
    `missing` is the message when there are none."""
    path = Path(path)
    with open_raster(path) as ds:
        _check_sidecars(ds.files[1:])
        _check_nitf_tre(path, ds)
        try:
            rpcs = ds.rpcs
        except ValueError as exc:  # rasterio's float() of a value GDAL passed on
            raise _error(path, f"GDAL's RPC metadata: {exc}") from None
    if rpcs is None:
        raise _error(path, missing)
    values = {
        "line_off": rpcs.line_off,
        "samp_off": rpcs.samp_off,
        "lat_off": rpcs.lat_off,
        "lon_off": rpcs.long_off,
        "height_off": rpcs.height_off,
        "line_scale": rpcs.line_scale,
        "samp_scale": rpcs.samp_scale,
        "lat_scale": rpcs.lat_scale,
        "lon_scale": rpcs.long_scale,
        "height_scale": rpcs.height_scale,
        "line_num": rpcs.line_num_coeff,
        "line_den": rpcs.line_den_coeff,
        "samp_num": rpcs.samp_num_coeff,
        "samp_den": rpcs.samp_den_coeff,
    }
    return _build(path, values, err_bias=rpcs.err_bias, err_rand=rpcs.err_rand)


_SIDECAR = re.compile(r"(\.rpb|_rpc\.txt|\.xml)$", re.I)


def _check_sidecars(files: list[str]) -> None:
    """The RPC sidecars GDAL read for a raster (`.RPB`, `_rpc.txt`, DigitalGlobe or DIMAP
    `.XML`), read again by blockqc's readers: GDAL takes '+0.028 kilometers' for 0.028 m and
    a key given twice or a 21st coefficient without a word; they are refused here, naming the
    sidecar, its line and key, as when the file is given as the RPC file."""
    for name in files:
        side = Path(name)
        low = side.name.lower()
        if low.endswith(".aux.xml") or not _SIDECAR.search(low):
            continue
        if low.endswith(".xml") and not re.search(r"<(RPB|Global_RFM)>", _read_text(side)):
            continue  # an XML of the product without RPCs
        read_rpc(side)


def _check_nitf_tre(path: Path, ds: DatasetReader) -> None:
    """Every field of a NITF RPC00A/B TRE must be a number: GDAL reads '+2.40X507E-3' as 2.40
    and '01X495' as 1 without a word."""
    if "xml:TRE" not in ds.tag_namespaces():
        return
    root = ElementTree.fromstring(ds.tags(ns="xml:TRE")["xml:TRE"])
    for tre in root.iter("tre"):
        if tre.get("name") not in ("RPC00A", "RPC00B"):
            continue
        for label, value in _tre_fields(tre):
            _number(path, f"NITF {tre.get('name')} TRE field {label}", value)


def _tre_fields(tre: ElementTree.Element) -> list[tuple[str, str]]:
    """(name, value) of a TRE's fields, a repeated one numbered from 1 (LINE_NUM_COEFF 1…20)."""
    out = []
    for child in tre:
        if child.tag == "field":
            out.append((child.get("name", ""), child.get("value", "")))
        for group in child.iter("group"):
            index = int(group.get("index", "0")) + 1
            for field in group.iter("field"):
                out.append((f"{field.get('name', '')} {index}", field.get("value", "")))
    return out


# -- sniffing -------------------------------------------------------------------------------
_UTF16_BOMS = (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)


def _decode(path: Path, data: bytes) -> str:
    """UTF-8 (with or without BOM), UTF-16 with a BOM, else Latin-1."""
    if data.startswith(_UTF16_BOMS):
        try:
            return data.decode("utf-16")
        except UnicodeDecodeError:
            raise _error(
                path, "starts with a UTF-16 byte-order mark but is not valid UTF-16 text"
            ) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _read_text(path: Path) -> str:
    """The file's text with its line ends (CR LF, or CR alone as on old Macs) made LF, and
    without the NUL bytes that pad it to its end (fixed-size records, as GDAL reads them); a
    NUL byte within the text is refused, naming its line."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _error(path, f"cannot read: {exc.strerror or exc}") from None
    text = _decode(path, data).replace("\r\n", "\n").replace("\r", "\n").rstrip("\0")
    if "\0" in text:
        check_no_nul(path, text.encode("utf-8"))
    return text


def _nul_padded(path: Path, head: bytes) -> bool:
    """Whether the NUL bytes of a file's first bytes (`head`) are the padding of a text: NUL
    bytes alone from the first of them to the file's end."""
    if b"\0" in head.rstrip(b"\0"):
        return False
    with open(path, "rb") as fh:
        fh.seek(len(head))
        while chunk := fh.read(1 << 20):
            if chunk.count(0) != len(chunk):
                return False
    return True


def sniff_format(path: Path) -> str:
    """Name of the RPC format of a file, from its content: gdal, xml, json, rpb, geom or txt."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise _error(path, f"cannot read: {exc.strerror or exc}") from None
    if head[:4] in _TIFF_MAGIC or head[:4] in _NITF_MAGIC:
        return "gdal"
    if head.startswith(_UTF16_BOMS):
        return _text_format(_read_text(path))
    if b"\0" in head and _utf16_without_bom(head):
        raise _error(
            path,
            "UTF-16 text without a byte-order mark: save it as UTF-8 (or UTF-16 with its "
            "byte-order mark)",
        )
    return "gdal" if _binary(path, head) else _text_format(_read_text(path))


def _binary(path: Path, head: bytes) -> bool:
    """Whether a file (its first bytes `head`) is no text: it holds a NUL byte that is not the
    padding of a text to its end, after bytes that are not the start of an RPC text (an RPC
    text holding a NUL byte is read as text, and its line named by _read_text)."""
    try:
        data = head if b"\0" in head else path.read_bytes()
    except OSError as exc:
        raise _error(path, f"cannot read: {exc.strerror or exc}") from None
    at = data.find(b"\0")
    if at < 0:
        return False
    padded = _nul_padded(path, head) if data is head else data.count(0, at) == len(data) - at
    return not padded and _text_format(_decode(path, data[:at])) == "unknown"


def _text_format(text: str) -> str:
    """The format a text's keys show: xml, json, rpb, geom, txt, or unknown."""
    stripped = text.lstrip()
    if stripped.startswith("<"):
        return "xml"
    if stripped.startswith("{"):
        return "json"
    if re.search(r"\blineNumCoef\s*=", text, re.I):
        return "rpb"
    if re.search(r"^\s*line_num_coeff_00\s*[:=]", text, re.M):
        return "geom"
    if re.search(r"^\s*LINE_NUM_COEFF_1\s*[:=]", text, re.M | re.I):
        return "txt"
    # a file cut short: read by the reader its keys point to, which names what is missing
    if re.search(r"^\s*(line_off|polynomial_format|adjustment_\d+\.[\w.]+)\s*[:=]", text, re.M):
        return "geom"
    if re.search(r"^\s*LINE_OFF\s*[:=]", text, re.M | re.I):
        return "txt"
    if re.search(r"^\s*(lineOffset\s*=|SpecId\s*=\s*\"?RPC00B)", text, re.M | re.I):
        return "rpb"
    return "unknown"


def _utf16_without_bom(head: bytes) -> bool:
    """Text of ASCII characters in UTF-16 without its byte-order mark: every other byte 0, the
    others printable text with a key's colon or equals sign and a line end (a raster of small
    or no-data values also has every other byte 0, but not text)."""
    pairs = head[: len(head) // 2 * 2][:200]
    for zeros, text in ((pairs[1::2], pairs[0::2]), (pairs[0::2], pairs[1::2])):
        if len(text) >= 8 and not any(zeros):
            printable = all(32 <= b < 127 or b in b"\t\r\n" for b in text)
            if printable and b"\n" in text and (b":" in text or b"=" in text):
                return True
    return False


_READERS: dict[str, Callable[[Path], RPCModel]] = {
    "gdal": read_rpc_gdal,
    "xml": read_rpc_xml,
    "json": read_rpc_json,
    "rpb": read_rpc_rpb,
    "geom": read_rpc_geom,
    "txt": read_rpc_txt,
}


def read_rpc(path: str | Path) -> RPCModel:
    """Read an RPC00B model from any supported file, choosing the reader from the content."""
    path = Path(path)
    if what := not_a_file(path):
        raise _error(path, f"{what}: expected an RPC file")
    if not path.is_file():
        raise _error(path, "no such file")
    kind = sniff_format(path)
    size = path.stat().st_size
    if kind == "unknown" and not _read_text(path).strip():
        blank = " of white space or NUL" if size else ""
        raise _error(
            path, f"empty ({size} bytes{blank}): expected an RPC file (its copy cut short?)"
        )
    if kind == "unknown":
        raise _error(
            path,
            "not a known RPC format (GeoTIFF/NITF tags, DigitalGlobe .RPB or XML, DIMAP XML, "
            "OSSIM .geom, KEY: value _rpc.txt, rpcm JSON)",
        )
    return _READERS[kind](path)
