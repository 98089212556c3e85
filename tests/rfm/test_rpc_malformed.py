"""Malformed RPC files are refused with the file, key and line; odd encodings and line ends read.

Each bad file is a real one of tests/data/rfm edited in tmp_path; line numbers are those of the
real files (gf_rpc_txt has 90 lines, LINE_OFF on line 1; left_image.geom has 190 lines, line_off
on line 83; sample.RPB has lineOffset on line 7 and END_GROUP on line 101).
"""

from __future__ import annotations

import codecs
import re
from pathlib import Path

import numpy as np
import pytest
from rfm_helpers import DATA, VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.model import OFFSET_SCALE_KEYS
from blockqc.rfm.readers import COEFF_KEYS, read_rpc, sniff_format

FORMATS = DATA / "rpc_formats"
GF_TXT = DATA / "gf_rpc_txt" / "left_image_rpc.txt"
GEOM = VENTOUX / "left_image.geom"
FIELDS = (*OFFSET_SCALE_KEYS, *COEFF_KEYS)


def assert_identical(a, b):
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def refused(path: Path):
    """The one problem `read_rpc` reports for `path` (it must refuse it)."""
    with pytest.raises(InputError) as err:
        read_rpc(path)
    (problem,) = err.value.problems
    assert problem.file == str(path)
    return problem


def edited(tmp_path: Path, source: Path, name: str, old: str, new: str) -> Path:
    text = source.read_text()
    assert old in text
    out = tmp_path / name
    out.write_text(text.replace(old, new, 1))
    return out


def appended(tmp_path: Path, source: Path, name: str, line: str) -> Path:
    out = tmp_path / name
    out.write_text(source.read_text() + line + "\n")
    return out


# -- a key given twice -------------------------------------------------------------------------
@pytest.mark.parametrize("line", ["LINE_OFF: 21110.5", "line_off: 21110.5 pixels"])
def test_txt_key_given_twice_names_both_lines(tmp_path: Path, line: str):
    problem = refused(appended(tmp_path, GF_TXT, "dup_rpc.txt", line))
    assert problem.line == 91
    assert "LINE_OFF given twice, on lines 1 and 91" in problem.message


def test_geom_key_given_twice_names_both_lines(tmp_path: Path):
    problem = refused(appended(tmp_path, GEOM, "dup.geom", "line_off:  21110.5"))
    assert problem.line == 191
    assert "line_off given twice, on lines 83 and 191" in problem.message


def test_rpb_key_given_twice_names_both_lines(tmp_path: Path):
    bad = edited(
        tmp_path, FORMATS / "sample.RPB", "dup.RPB", "END_GROUP", "\tlineOffset = 600.0;\nEND_GROUP"
    )
    problem = refused(bad)
    assert problem.line == 101
    assert "lineOffset given twice, on lines 7 and 101" in problem.message


def test_json_key_given_twice_is_named(tmp_path: Path):
    old = '"row_offset": 405.51806724276,'
    bad = edited(
        tmp_path, FORMATS / "JAX_068_001_RGB.json", "dup.json", old, old + ' "row_offset": 1.0,'
    )
    assert "'row_offset' given twice" in refused(bad).message


def test_xml_element_given_twice_is_named(tmp_path: Path):
    old = "<LATOFFSET>2.679000000000000e+01</LATOFFSET>"
    bad = edited(
        tmp_path, FORMATS / "rpc_WV3_RPB_only.xml", "dup.xml", old, old + "<LATOFFSET>3</LATOFFSET>"
    )
    assert "RPB/IMAGE/LATOFFSET given 2 times" in refused(bad).message


# -- numbers beyond the 20 coefficients or after the value ---------------------------------------
def test_txt_21st_coefficient_is_refused(tmp_path: Path):
    problem = refused(appended(tmp_path, GF_TXT, "c21_rpc.txt", "LINE_NUM_COEFF_21: +1.0E-05"))
    assert problem.line == 91 and problem.message.startswith("LINE_NUM_COEFF_21:")
    assert "has 20 coefficients" in problem.message


def test_geom_21st_coefficient_is_refused(tmp_path: Path):
    problem = refused(appended(tmp_path, GEOM, "c21.geom", "line_num_coeff_20:  1e-05"))
    assert problem.line == 191 and problem.message.startswith("line_num_coeff_20:")
    assert "has 20 coefficients" in problem.message


def test_txt_second_number_after_a_value_is_refused(tmp_path: Path):
    old = "LINE_NUM_COEFF_7: -2.911986523175590E-05"
    bad = edited(tmp_path, GF_TXT, "two_rpc.txt", old, old + " 7.0")
    problem = refused(bad)
    assert problem.line == 17 and problem.message.startswith(
        "LINE_NUM_COEFF_7: expected one number"
    )
    assert "-2.911986523175590E-05 7.0" in problem.message


def test_geom_second_number_after_a_value_is_refused(tmp_path: Path):
    old = "line_num_coeff_06:  -2.91198652317559e-05"
    problem = refused(edited(tmp_path, GEOM, "two.geom", old, old + " 7.0"))
    assert problem.line == 69 and problem.message.startswith("line_num_coeff_06: expected one")


def test_unit_words_after_values_are_still_read(tmp_path: Path):
    """gf_rpc_txt carries 'pixels', 'degrees', 'meters'; a coefficient may carry a unit too."""
    old = "LINE_NUM_COEFF_7: -2.911986523175590E-05"
    good = edited(tmp_path, GF_TXT, "unit_rpc.txt", old, old + " pixels")
    assert read_rpc(good).line_num[6] == -2.91198652317559e-05


# -- the separator of a KEY: value text ---------------------------------------------------------
IKONOS = FORMATS / "rpc_IKONOS.txt"


@pytest.mark.parametrize(
    ("source", "name", "message"),
    [
        (
            IKONOS,
            "eq_rpc.txt",
            "LINE_OFF = +005124.00 pixels: expected 'LINE_OFF: value', a colon after the key (the "
            "separator of the KEY: value text of IKONOS, GF/ZY, Planet and SkySat, as GDAL reads "
            "it; GDAL does not read '=')",
        ),
        (
            GEOM,
            "eq.geom",
            "adjustment_0.adj_param_0.center =  0: expected 'adjustment_0.adj_param_0.center: "
            "value', a colon after the key (the separator of an OSSIM keyword list)",
        ),
    ],
    ids=["_rpc.txt", ".geom"],
)
def test_key_equals_value_is_refused_naming_the_colon(
    tmp_path: Path, source: Path, name: str, message: str
):
    """'LINE_OFF = +005124.00 pixels' in an _rpc.txt, which GDAL does not read: its format was
    told by a colon only ('not a known RPC format') while the reader took '=' too. Both now
    take the file for the format its keys show and refuse the '=' on its first line."""
    text = re.sub(r"^([\w.]+):", r"\1 =", source.read_text(), flags=re.M)
    bad = tmp_path / name
    bad.write_text(text)
    assert sniff_format(bad) == ("geom" if source == GEOM else "txt")
    problem = refused(bad)
    assert (problem.line, problem.message) == (1, message)


def test_one_key_equals_value_among_colons_is_refused(tmp_path: Path):
    """One line written with '=' among the colons: it was read as if written with one."""
    bad = edited(tmp_path, IKONOS, "one_rpc.txt", "LAT_SCALE:", "LAT_SCALE =")
    problem = refused(bad)
    assert problem.line == 8
    assert problem.message.startswith(
        "LAT_SCALE = +00.06610000 degrees: expected 'LAT_SCALE: value', a colon after the key"
    )


# -- latitude / longitude offsets ---------------------------------------------------------------
def test_latitude_and_longitude_swapped_is_refused(tmp_path: Path):
    """rpc_PLANET_L1B.txt with LAT_OFF and LONG_OFF exchanged: LAT_OFF 151.7593."""
    text = (FORMATS / "rpc_PLANET_L1B.txt").read_text()
    text = text.replace("LAT_OFF: -32.85", "@").replace("LONG_OFF: 151.7593", "LONG_OFF: -32.85")
    bad = tmp_path / "swapped_rpc.txt"
    bad.write_text(text.replace("@", "LAT_OFF: 151.7593"))
    message = refused(bad).message
    assert message.startswith("LAT_OFF") and "151.7593" in message and "[-90, 90]" in message


@pytest.mark.parametrize("lon", ["+361", "-180.5"])
def test_longitude_offset_out_of_range_is_refused(tmp_path: Path, lon: str):
    bad = edited(tmp_path, GF_TXT, "lon_rpc.txt", "LONG_OFF: +5.28464655928485", f"LONG_OFF: {lon}")
    message = refused(bad).message
    assert message.startswith("LONG_OFF") and "[-180, 360]" in message


def test_latitude_offset_out_of_range_in_json_is_refused(tmp_path: Path):
    old = '"lat_offset": 30.348745058662'
    bad = edited(tmp_path, FORMATS / "JAX_068_001_RGB.json", "lat.json", old, '"lat_offset": -90.5')
    assert refused(bad).message.startswith("LAT_OFF")


def test_longitudes_0_to_360_and_negative_scales_are_read(tmp_path: Path):
    """LONG_OFF 200 (0…360 convention) is accepted; rpc_PLANET_L1B.txt has LAT_SCALE -0.0234."""
    good = edited(tmp_path, GF_TXT, "east_rpc.txt", "LONG_OFF: +5.28464655928485", "LONG_OFF: 200")
    assert read_rpc(good).lon_off == 200.0
    assert read_rpc(FORMATS / "rpc_PLANET_L1B.txt").lat_scale == -0.0234


DIMAP_VALIDITY = "Rational_Function_Model/Global_RFM/RFM_Validity"


@pytest.mark.parametrize(
    "source, old, new, key, line",
    [
        (GF_TXT, "HEIGHT_SCALE: +885", "HEIGHT_SCALE: 0", "HEIGHT_SCALE", 10),
        (GEOM, "height_scale:  885", "height_scale:  0", "height_scale", 39),
        (FORMATS / "sample.RPB", "heightScale =  580.00;", "heightScale = 0;", "heightScale", 16),
        (
            FORMATS / "rpc_PLEIADES.xml",
            "<HEIGHT_SCALE>80</HEIGHT_SCALE>",
            "<HEIGHT_SCALE>0</HEIGHT_SCALE>",
            f"{DIMAP_VALIDITY}/HEIGHT_SCALE",
            None,
        ),
    ],
    ids=lambda v: v.name if isinstance(v, Path) else None,
)
def test_zero_scale_is_refused_naming_the_key_as_written_and_its_line(
    tmp_path: Path, source: Path, old: str, new: str, key: str, line: int | None
):
    """The model divides by its scales: a zero is refused with the key as the file writes it
    (heightScale in an .RPB, not HEIGHT_SCALE) and its line (none in XML)."""
    problem = refused(edited(tmp_path, source, source.name, old, new))
    assert problem.message == (
        f"{key}: expected a scale of magnitude at least 1e-09 (the model divides by it), got 0"
    )
    assert problem.line == line


def test_a_coefficient_far_beyond_order_one_is_refused_naming_it(tmp_path: Path):
    """1e300 in a numerator: the model overflows wherever it is evaluated (rays that never
    meet, a singular adjustment): refused at the file, naming the coefficient."""
    old = "LINE_NUM_COEFF_2: +2.040590314623190E-02"
    bad = edited(tmp_path, GF_TXT, "huge_rpc.txt", old, "LINE_NUM_COEFF_2: 1e300")
    assert refused(bad).message.startswith("LINE_NUM holds 1e+300: the coefficients of a")


def test_a_vanishing_scale_is_refused_naming_it(tmp_path: Path):
    bad = edited(tmp_path, GF_TXT, "tiny_rpc.txt", "HEIGHT_SCALE: +885", "HEIGHT_SCALE: 1e-300")
    problem = refused(bad)
    assert problem.line == 10
    assert problem.message.startswith("HEIGHT_SCALE: expected a scale of magnitude at least 1e-09")
    assert problem.message.endswith("got 1e-300")


# -- line ends, encodings, folders -------------------------------------------------------------
@pytest.mark.parametrize("source", [GF_TXT, GEOM, FORMATS / "sample.RPB"], ids=lambda p: p.name)
def test_cr_only_line_ends_are_read(tmp_path: Path, source: Path):
    old_mac = tmp_path / source.name
    old_mac.write_bytes(source.read_bytes().replace(b"\n", b"\r"))
    assert_identical(read_rpc(old_mac), read_rpc(source))


def test_cr_only_line_ends_keep_line_numbers(tmp_path: Path):
    lines = GF_TXT.read_text().splitlines()
    lines[2] = "LAT_OFF: north degrees"
    bad = tmp_path / "cr_rpc.txt"
    bad.write_bytes("\r".join(lines).encode())
    assert refused(bad).line == 3


@pytest.mark.parametrize(
    "source",
    [GF_TXT, GEOM, FORMATS / "sample.RPB", FORMATS / "JAX_068_001_RGB.json"]
    + [FORMATS / "rpc_PLEIADES.xml", FORMATS / "rpc_WV3_RPB_only.xml"],
    ids=lambda p: p.name,
)
def test_utf16_with_byte_order_mark_is_read(tmp_path: Path, source: Path):
    wide = tmp_path / source.name
    wide.write_text(source.read_text(), encoding="utf-16")  # writes a BOM
    assert_identical(read_rpc(wide), read_rpc(source))


TEXT_FORMATS = [GF_TXT, GEOM, FORMATS / "sample.RPB", FORMATS / "JAX_068_001_RGB.json"] + [
    FORMATS / "rpc_PLEIADES.xml",
    FORMATS / "rpc_WV3_RPB_only.xml",
]


@pytest.mark.parametrize("pad", [100, 6000], ids=["100 NULs", "6000 NULs"])
@pytest.mark.parametrize("source", TEXT_FORMATS, ids=lambda p: p.name)
def test_trailing_nul_padding_is_ignored(tmp_path: Path, source: Path, pad: int):
    """Text padded with NUL bytes to a fixed record size, which GDAL reads: a file of less
    than 4 KB with its padding was 'cannot open as a raster', one of more (left_image.geom, 7.5
    KB) read. Either is read, padded or not, as the file without the padding."""
    padded = tmp_path / source.name
    padded.write_bytes(source.read_bytes() + b"\0" * pad)
    assert_identical(read_rpc(padded), read_rpc(source))


@pytest.mark.parametrize(
    ("source", "at", "line", "column"),
    [(GF_TXT, "LINE_NUM_COEFF_7:", 17, 18), (GEOM, "line_num_coeff_06:", 69, 19)],
    ids=["small _rpc.txt", "geom over 4 KB"],
)
def test_a_nul_byte_inside_the_text_is_refused_naming_its_line(
    tmp_path: Path, source: Path, at: str, line: int, column: int
):
    """A NUL byte within the text, not at its end, is no padding: in a file of less than 4 KB
    it was 'cannot open as a raster', in one of more read as if absent. Both are refused with
    the line and the character, the padding after it not counted."""
    text = source.read_bytes()
    assert at.encode() in text
    damaged = tmp_path / source.name
    damaged.write_bytes(text.replace(at.encode(), at.encode() + b"\0", 1) + b"\0" * 50)
    problem = refused(damaged)
    assert problem.line == line
    assert problem.message == (
        f"a NUL byte (0x00) at character {column}: expected text, which holds none (the file "
        "may be damaged or padded with zeros); remove it"
    )


def test_a_file_of_nul_bytes_only_is_said_to_be_empty(tmp_path: Path):
    blank = tmp_path / "S1_rpc.txt"
    blank.write_bytes(b"\0" * 512)
    assert refused(blank).message == (
        "empty (512 bytes of white space or NUL): expected an RPC file (its copy cut short?)"
    )


def test_big_endian_utf16_is_read(tmp_path: Path):
    wide = tmp_path / "be_rpc.txt"
    wide.write_bytes(codecs.BOM_UTF16_BE + GF_TXT.read_text().encode("utf-16-be"))
    assert_identical(read_rpc(wide), read_rpc(GF_TXT))


def test_broken_utf16_names_the_encoding(tmp_path: Path):
    bad = tmp_path / "odd_rpc.txt"
    bad.write_bytes(GF_TXT.read_text().encode("utf-16") + b"\x00")  # an odd number of bytes
    assert "UTF-16" in refused(bad).message


def test_folder_is_not_called_missing(tmp_path: Path):
    folder = tmp_path / "rpc.txt"
    folder.mkdir()
    message = refused(folder).message
    assert "folder" in message and "no such file" not in message


# -- an OSSIM adjustment in force ---------------------------------------------------------------
def test_geom_with_an_ossim_adjustment_in_force_is_refused(tmp_path: Path):
    """OSSIM moves the image by center + parameter·sigma (0.1 × 50 = 5 px in track): read as
    the RPC alone, an adjusted image was measured as if unadjusted."""
    old = "adjustment_0.adj_param_0.parameter:  0\n"
    bad = edited(tmp_path, GEOM, "adjusted.geom", old, old.replace("0\n", "0.1\n"))
    problem = refused(bad)
    assert problem.line == 4 and problem.message.startswith(
        "adjustment_0.adj_param_0.parameter: an OSSIM adjustment in force (intrack_offset: "
        "center + parameter·sigma = 5)"
    )
    # parameters at 0 (every .geom of the Pléiades data) move nothing: the RPC alone is read
    assert_identical(read_rpc(GEOM), read_rpc(edited(tmp_path, GEOM, "zero.geom", old, old)))


@pytest.mark.parametrize(
    ("old", "new", "line", "expected"),
    [
        ("HEIGHT_OFF: +0028.000 meters", "HEIGHT_OFF: +0.028 kilometers", 5, "'meters'"),
        ("LAT_OFF: -34.90300000 degrees", "LAT_OFF: -34.90300000 pixels", 3, "'degrees'"),
        ("LAT_SCALE: +00.06610000 degrees", "LAT_SCALE: +00.0011537 radians", 8, "'degrees'"),
        ("LINE_OFF: +005124.00 pixels", "LINE_OFF: +005124.00 meters", 1, "'pixels'"),
    ],
)
def test_a_unit_word_of_another_unit_is_refused(tmp_path: Path, old, new, line, expected):
    """The unit word was read as any word: 0.028 kilometers became 0.028 m, radians degrees."""
    problem = refused(edited(tmp_path, FORMATS / "rpc_IKONOS.txt", "unit_rpc.txt", old, new))
    key = new.split(":")[0]
    assert problem.line == line
    assert problem.message == (
        f"{key}: expected one number, optionally followed by its unit ({expected}), got "
        f"{new.split(': ')[1]!r}"
    )


def test_dimap_21st_coefficient_is_refused(tmp_path: Path):
    """Every other format refused it; DIMAP read the 20 it looked for and ignored the rest."""
    source = FORMATS / "rpc_PLEIADES.xml"
    text = source.read_text()
    at = text.rindex("</LINE_NUM_COEFF_20>") + len("</LINE_NUM_COEFF_20>")  # Inverse_Model's
    bad = tmp_path / "c21.xml"
    bad.write_text(text[:at] + "<LINE_NUM_COEFF_21>1e-05</LINE_NUM_COEFF_21>" + text[at:])
    problem = refused(bad)
    assert problem.message == (
        "Rational_Function_Model/Global_RFM/Inverse_Model/LINE_NUM_COEFF_21: an RPC00B "
        "polynomial has 20 coefficients, numbered 1 to 20"
    )


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("cut.geom", "adjustment_0.adj_param_0.center:  0\nline_off:  21110.5\n",
         "missing key samp_off"),
        ("cut_rpc.txt", "LINE_OFF: +005124.00 pixels\n", "missing key SAMP_OFF"),
    ],
)  # fmt: skip
def test_a_cut_rpc_file_is_read_and_its_missing_key_named(tmp_path: Path, name, text, message):
    """A .geom header or a text of one key was 'not a known RPC format'."""
    path = tmp_path / name
    path.write_text(text)
    assert refused(path).message == message


def test_utf16_text_without_its_byte_order_mark_is_named(tmp_path: Path):
    """It went to GDAL as a raster: 'not recognized as being in a supported file format'."""
    path = tmp_path / "le_rpc.txt"
    path.write_bytes(GF_TXT.read_text().encode("utf-16-le"))
    assert refused(path).message.startswith("UTF-16 text without a byte-order mark")


def test_only_the_current_ossim_adjustment_counts(tmp_path: Path):
    """OSSIM applies the adjustment `current_adjustment` names: another one saved in the file
    is not in force (it was refused as if it were)."""
    saved = (
        "adjustment_1.adj_param_0.center:  0\nadjustment_1.adj_param_0.description:  "
        "intrack_offset\nadjustment_1.adj_param_0.parameter:  0.2\n"
        "adjustment_1.adj_param_0.sigma:  50\n"
    )
    inactive = appended(tmp_path, GEOM, "saved.geom", saved)
    assert_identical(read_rpc(inactive), read_rpc(GEOM))
    old = "current_adjustment:  0"
    current = edited(tmp_path, inactive, "current.geom", old, "current_adjustment:  1")
    assert refused(current).message.startswith(
        "adjustment_1.adj_param_0.parameter: an OSSIM adjustment in force (intrack_offset: "
        "center + parameter·sigma = 10)"
    )


def test_a_binary_of_small_values_is_not_taken_for_utf16_text():
    """A raw raster whose first values are 0 or below 256 (every other byte 0) went to the
    UTF-16 message, not to GDAL, which reads its RPCs from a sidecar."""
    from blockqc.rfm.readers import _utf16_without_bom

    assert not _utf16_without_bom(bytes(200))
    assert not _utf16_without_bom(np.arange(100, dtype="<u2").tobytes())
    assert _utf16_without_bom("LINE_OFF: 5124 pixels\nSAMP_OFF: 1\n".encode("utf-16-le"))
    assert _utf16_without_bom("LINE_OFF: 5124 pixels\nSAMP_OFF: 1\n".encode("utf-16-be"))


DIMAP = VENTOUX / "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML"


@pytest.mark.parametrize(
    ("source", "old", "new", "key", "expected"),
    [
        (
            DIMAP,
            "<LAT_OFF>44.13716599373447</LAT_OFF>",
            "<LAT_OFF>44.13716599373447 meters</LAT_OFF>",
            "Rational_Function_Model/Global_RFM/RFM_Validity/LAT_OFF",
            "'degrees'",
        ),
        (
            FORMATS / "rpc_WV2.xml",
            "<HEIGHTOFFSET>97</HEIGHTOFFSET>",
            "<HEIGHTOFFSET>97 pixels</HEIGHTOFFSET>",
            "RPB/IMAGE/HEIGHTOFFSET",
            "'meters'",
        ),
        (
            FORMATS / "JAX_068_001_RGB.json",
            '"alt_offset": -21.0',
            '"alt_offset": "-21.0 degrees"',
            "rpc.alt_offset",
            "'meters'",
        ),
        (
            FORMATS / "JAX_068_001_RGB.json",
            '"row_scale": 417.504728605983',
            '"row_scale": "417.504728605983 m"',
            "rpc.row_scale",
            "'pixels'",
        ),
    ],
    ids=["dimap", "digitalglobe-xml", "json-alt", "json-row"],
)
def test_a_unit_word_of_another_unit_is_refused_in_xml_and_json(
    tmp_path: Path, source, old, new, key, expected
):
    """The key came with its place (`…/RFM_Validity/LAT_OFF`, `rpc.alt_offset`), which matched
    no unit: any unit word was let through, 44.137 meters read as 44.137 degrees."""
    problem = refused(edited(tmp_path, source, "unit" + source.suffix, old, new))
    value = new.split(">")[1].split("<")[0] if "<" in new else new.split(": ")[1].strip('"')
    assert problem.message == (
        f"{key}: expected one number, optionally followed by its unit ({expected}), got {value!r}"
    )


def test_unit_words_of_their_unit_are_read_in_xml(tmp_path: Path):
    text = DIMAP.read_text()
    unit = tmp_path / "unit.XML"
    unit.write_text(
        text.replace("<LAT_OFF>44.13716599373447<", "<LAT_OFF>44.13716599373447 degrees<").replace(
            "<LINE_OFF>21110.49999999999<", "<LINE_OFF>21110.49999999999 pixels<"
        )
    )
    assert_identical(read_rpc(unit), read_rpc(DIMAP))


def test_a_digit_separator_is_not_a_number(tmp_path: Path):
    """Python's float() reads '21_109.5' as 21109.5 and it was taken; no RPC format writes a
    digit separator, and a C reader (strtod) stops at it: the file is malformed, not read."""
    bad = edited(tmp_path, GF_TXT, "sep_rpc.txt", "LINE_OFF: +21109.5 pixels", "LINE_OFF: 21_109.5")
    problem = refused(bad)
    assert problem.line == 1
    assert problem.message == "LINE_OFF: expected a number, got '21_109.5'"


def test_a_geom_that_does_not_state_its_term_order_is_refused(tmp_path: Path):
    """Without `polynomial_format` the .geom was read as RPC00B; OSSIM refuses such a file (a
    required keyword), and RPC00A holds the same 20 numbers in another order."""
    problem = refused(edited(tmp_path, GEOM, "noformat.geom", "polynomial_format:  B\n", ""))
    assert problem.message.startswith(
        "missing key polynomial_format: expected B (RPC00B term order); OSSIM requires it"
    )


def test_an_rpb_cut_before_its_coefficients_is_read_and_its_missing_key_named(tmp_path: Path):
    """Its first 16 lines (header and offsets, up to heightScale) were 'not a known RPC format':
    an .RPB was recognised by its lineNumCoef alone."""
    lines = (FORMATS / "sample.RPB").read_text().splitlines(keepends=True)
    assert lines[16].strip().startswith("lineNumCoef")
    cut = tmp_path / "cut.RPB"
    cut.write_text("".join(lines[:16]))
    assert refused(cut).message == "missing key lineNumCoef"


@pytest.mark.parametrize(
    ("old", "new", "line", "expected"),
    [
        ("lineOffset =   531.0;", "lineOffset =   531.0", 7, "'lineOffset = value;'"),
        ("\t\t 1.342808018e-02);", "\t\t 1.342808018e-02)", 17, "'lineNumCoef = ( v, …, v );'"),
    ],
)
def test_an_rpb_value_without_its_semicolon_is_named_not_called_missing(
    tmp_path: Path, old, new, line, expected
):
    """The key is there but its value has no ';': it was 'missing key lineOffset'."""
    problem = refused(edited(tmp_path, FORMATS / "sample.RPB", "nosemi.RPB", old, new))
    assert problem.line == line
    key = expected[1:].split(" ")[0]
    assert problem.message == (
        f"{key}: expected {expected}, found no ';' ending it (a ';' left out, or the file cut "
        "short?)"
    )


def test_a_digitalglobe_imd_is_not_taken_for_a_cut_rpb(tmp_path: Path):
    """An .IMD (image metadata, no RPCs) shares BEGIN_GROUP and satId with an .RPB."""
    imd = tmp_path / "scene.IMD"
    imd.write_text('BEGIN_GROUP = IMAGE_1\n\tsatId = "WV02";\nEND_GROUP = IMAGE_1\nEND;\n')
    assert refused(imd).message.startswith("not a known RPC format")


# -- RPCs GDAL reads for a raster: its sidecars and NITF TRE, read with blockqc's rules ---------
NOT_GEOREFERENCED = "ignore::rasterio.errors.NotGeoreferencedWarning"


def raster_with_sidecar(tmp_path: Path, name: str, text: str) -> Path:
    """A 4 × 4 GeoTIFF `scene.tif` with `text` beside it as `name` (scene.RPB, scene_rpc.txt)."""
    import rasterio

    image = tmp_path / "scene.tif"
    profile = {"driver": "GTiff", "width": 4, "height": 4, "count": 1, "dtype": "uint8"}
    with rasterio.open(image, "w", **profile) as ds:
        ds.write(np.zeros((1, 4, 4), np.uint8))
    (tmp_path / name).write_text(text)
    return image


@pytest.mark.parametrize(
    ("name", "source", "old", "new", "line", "message"),
    [
        ("scene_rpc.txt", "rpc_IKONOS.txt", "HEIGHT_OFF: +0028.000 meters",
         "HEIGHT_OFF: +0.028 kilometers", 5,
         "HEIGHT_OFF: expected one number, optionally followed by its unit ('meters'), got "
         "'+0.028 kilometers'"),
        ("scene_rpc.txt", "rpc_IKONOS.txt", "LINE_SCALE: +005124.00 pixels",
         "LINE_SCALE: +005124.00 pixels\nLINE_OFF: +009999.00 pixels", 7,
         "LINE_OFF given twice, on lines 1 and 7: expected once"),
        ("scene.RPB", "sample.RPB", "lineOffset =   531.0;", "lineOffset =   53X1.0;", 7,
         "lineOffset: expected a number, got '53X1.0'"),
    ],
)  # fmt: skip
@pytest.mark.filterwarnings(NOT_GEOREFERENCED)
def test_a_malformed_sidecar_gdal_reads_is_refused_naming_it(
    tmp_path: Path, name, source, old, new, line, message
):
    """Given the image without --rpc, GDAL read the sidecar: 0.028 km became 0.028 m, the
    second LINE_OFF was taken, and '53X1.0' stopped the run with a ValueError of rasterio."""
    text = (FORMATS / source).read_text()
    assert old in text
    image = raster_with_sidecar(tmp_path, name, text.replace(old, new, 1))
    problem = refused_raster(image)
    assert (problem.file, problem.line, problem.message) == (str(tmp_path / name), line, message)


def refused_raster(image: Path):
    with pytest.raises(InputError) as err:
        read_rpc(image)
    (problem,) = err.value.problems
    return problem


@pytest.mark.filterwarnings(NOT_GEOREFERENCED)
def test_a_nitf_rpc_tre_field_that_is_no_number_is_refused(tmp_path: Path):
    """GDAL reads the TRE's '+2.40X507E-3' as 2.40: LINE_NUM_COEFF 1 was 1000 times too large."""
    data = (FORMATS / "wv3_20_16x16.ntf").read_bytes()
    assert data.count(b"+2.401507E-3") == 1
    bad = tmp_path / "bad.ntf"
    bad.write_bytes(data.replace(b"+2.401507E-3", b"+2.40X507E-3"))
    problem = refused_raster(bad)
    assert problem.file == str(bad)
    assert problem.message == (
        "NITF RPC00B TRE field LINE_NUM_COEFF 1: expected a number, got '+2.40X507E-3'"
    )


@pytest.mark.filterwarnings(NOT_GEOREFERENCED)
def test_rasters_whose_rpcs_gdal_reads_from_sidecars_are_read(tmp_path: Path):
    for name, source in (("scene.RPB", "sample.RPB"), ("scene_rpc.txt", "rpc_IKONOS.txt")):
        folder = tmp_path / name.replace(".", "_")
        folder.mkdir()
        image = raster_with_sidecar(folder, name, (FORMATS / source).read_text())
        assert_identical(read_rpc(image), read_rpc(FORMATS / source))


@pytest.mark.filterwarnings(NOT_GEOREFERENCED)
@pytest.mark.parametrize(
    ("field", "index", "message"),
    [
        ("line_num_coeff", 2, "LINE_NUM holds nan (coefficient 3 of 20): expected 20 finite "
         "numbers"),
        ("lat_off", None, "LAT_OFF: expected a finite number of degrees, got nan"),
    ],
)  # fmt: skip
def test_a_nan_in_geotiff_rpc_tags_is_named(tmp_path: Path, field, index, message):
    """NaN in a GeoTIFF's RPC tags: 'line_num must hold 20 finite numbers, got shape (20,)',
    and for LAT_OFF 'expected degrees in [-90, 90], got nan (latitude and longitude
    swapped?)'."""
    import rasterio
    from rasterio.rpc import RPC

    with rasterio.open(FORMATS / "wv3_20_16x16.ntf") as ds:
        values = ds.rpcs.to_dict()
    if index is None:
        values[field] = float("nan")
    else:
        values[field] = [float("nan") if i == index else v for i, v in enumerate(values[field])]
    image = tmp_path / "nan.tif"
    profile = {"driver": "GTiff", "width": 4, "height": 4, "count": 1, "dtype": "uint8"}
    with rasterio.open(image, "w", rpcs=RPC(**values), **profile) as ds:
        ds.write(np.zeros((1, 4, 4), np.uint8))
    assert refused_raster(image).message == message


def test_a_denominator_of_zero_at_the_centre_is_refused(tmp_path: Path):
    """SAMP_DEN's constant term 0 (the denominator's value at the centre of the normalized
    domain; 1 in every RPC): the sample divides by zero at the image centre. It was read, and
    the commands then blamed the DEM ("the DEM does not cover the image footprint")."""
    bad = edited(tmp_path, GEOM, "l.geom", "samp_den_coeff_00:  1\n", "samp_den_coeff_00:  0\n")
    problem = refused(bad)
    assert "SAMP_DEN" in problem.message and "centre" in problem.message
    small = edited(
        tmp_path, GEOM, "s.geom", "samp_den_coeff_00:  1\n", "samp_den_coeff_00:  1e-3\n"
    )
    assert read_rpc(small).samp_den[0] == 1e-3  # small, yet not nothing: read


def test_rpb_empty_coefficient_between_commas_is_refused(tmp_path: Path):
    """lineNumCoef with its second coefficient left empty ('9.3e-03,,-2.36e+00') and a 21st
    written after: 20 numbers, one of them shifted to another term, were read without a word.
    A trailing comma before ')' stays allowed."""
    bad = edited(
        tmp_path, FORMATS / "sample.RPB", "gap.RPB",
        "\t\t-5.508823053e-01,\n", "\t\t,\n",
    )  # fmt: skip
    text = bad.read_text().replace("lineNumCoef = (", "lineNumCoef = (\n\t\t 1.0e-09,", 1)
    bad.write_text(text)
    problem = refused(bad)
    assert problem.line == 17 and "lineNumCoef" in problem.message
    assert "coefficient 3 is empty" in problem.message
    source = (FORMATS / "sample.RPB").read_text()
    trailing = tmp_path / "trailing.RPB"
    trailing.write_text(source.replace(");", ",);"))
    assert_identical(read_rpc(trailing), read_rpc(FORMATS / "sample.RPB"))


def test_digitalglobe_xml_with_two_rpb_blocks_is_refused(tmp_path: Path):
    """An isd XML holding two <RPB> blocks (two images' RPCs pasted into one file): the first
    was read and the second passed over unsaid; which one is the scene's is not known."""
    text = (FORMATS / "rpc_WV2.xml").read_text()
    start, end = text.index("<RPB>"), text.index("</RPB>") + len("</RPB>")
    two = tmp_path / "two.xml"
    two.write_text(text[:end] + text[start:end] + text[end:])
    problem = refused(two)
    assert "2 RPB/IMAGE elements" in problem.message


@pytest.mark.parametrize("content", [b"", b" \n\t\r\n"])
def test_an_empty_rpc_file_is_said_to_be_empty(tmp_path: Path, content: bytes):
    """An RPC file of 0 bytes (a copy cut short) was called 'not a known RPC format', as if
    written in another format; it is said to be empty."""
    empty = tmp_path / "S1_rpc.txt"
    empty.write_bytes(content)
    problem = refused(empty)
    assert problem.message.startswith(f"empty ({len(content)} bytes")
