"""Every RPC format into one model; formats holding the same RPC agree; errors name the place."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rfm_helpers import DATA, VENTOUX

from blockqc.errors import InputError
from blockqc.rfm.model import OFFSET_SCALE_KEYS
from blockqc.rfm.readers import COEFF_KEYS, read_rpc, read_rpc_gdal, sniff_format

FORMATS = DATA / "rpc_formats"
pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def assert_same_model(a, b, offsets_tol=0.0, coeff_rtol=0.0):
    for name in OFFSET_SCALE_KEYS:
        assert getattr(a, name) == pytest.approx(getattr(b, name), abs=offsets_tol), name
    for name in COEFF_KEYS:
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=coeff_rtol, atol=0)


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("sample.RPB", "rpb"),
        ("rpc_IKONOS.txt", "txt"),
        ("20200413_151408_ssc4d2_0011_basic_panchromatic_dn.rpc", "txt"),
        ("rpc_PLEIADES.xml", "xml"),
        ("rpc_WV2.xml", "xml"),
        ("JAX_068_001_RGB.json", "json"),
        ("wv3_20_16x16.ntf", "gdal"),
    ],
)
def test_format_is_sniffed_from_content(name, kind):
    assert sniff_format(FORMATS / name) == kind


def test_dimap_and_ossim_geom_of_the_same_image_agree():
    """DIMAP counts the first pixel as 1, OSSIM as 0: after the reader's −1 they are one model."""
    dimap = read_rpc(VENTOUX / "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML")
    geom = read_rpc(VENTOUX / "left_image.geom")
    # the files: DIMAP LINE_OFF 21110.49999999999, SAMP_OFF 19208.5; .geom 21109.5, 19207.5
    assert dimap.line_off == pytest.approx(21109.5, abs=1e-9)
    assert dimap.samp_off == pytest.approx(19207.5, abs=1e-9)
    assert_same_model(dimap, geom, offsets_tol=1e-9, coeff_rtol=1e-13)
    rng = np.random.default_rng(0)
    lon = geom.lon_off + rng.uniform(-1, 1, 50) * geom.lon_scale
    lat = geom.lat_off + rng.uniform(-1, 1, 50) * geom.lat_scale
    h = rng.uniform(100, 1900, 50)
    r1, c1 = dimap.ground_to_image(lon, lat, h)
    r2, c2 = geom.ground_to_image(lon, lat, h)
    assert np.max(np.hypot(r1 - r2, c1 - c2)) < 1e-6


def test_gf_rpc_txt_fixture_agrees_with_its_source():
    gf = read_rpc(DATA / "gf_rpc_txt" / "left_image_rpc.txt")
    geom = read_rpc(VENTOUX / "left_image.geom")
    assert_same_model(gf, geom, coeff_rtol=1e-15)


def test_gf_rpc_txt_agrees_with_gdal_reading_it_as_a_sidecar(tmp_path: Path):
    """GDAL reads `<image>_rpc.txt` next to a raster: an independent parser of the same file."""
    image = tmp_path / "scene.tif"
    with rasterio.open(image, "w", driver="GTiff", width=4, height=4, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 4, 4), np.uint8))
    shutil.copy(DATA / "gf_rpc_txt" / "left_image_rpc.txt", tmp_path / "scene_rpc.txt")
    ours = read_rpc(DATA / "gf_rpc_txt" / "left_image_rpc.txt")
    assert_same_model(read_rpc_gdal(image), ours, coeff_rtol=1e-15)


def test_rpb_agrees_with_gdal_reading_it_as_a_sidecar(tmp_path: Path):
    image = tmp_path / "sample.tif"
    with rasterio.open(image, "w", driver="GTiff", width=4, height=4, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 4, 4), np.uint8))
    shutil.copy(FORMATS / "sample.RPB", tmp_path / "sample.RPB")
    assert_same_model(read_rpc_gdal(image), read_rpc(FORMATS / "sample.RPB"), coeff_rtol=1e-15)


def test_nitf_rpc00b_tre_values_by_hand():
    """Values read off the RPC00B TRE text of wv3_20 ('…17495 20749 -34.5043 -058.6024 …')."""
    m = read_rpc(FORMATS / "wv3_20_16x16.ntf")
    assert (m.line_off, m.samp_off, m.lat_off, m.lon_off, m.height_off) == (
        17495.0,
        20749.0,
        -34.5043,
        -58.6024,
        31.0,
    )
    assert (m.line_scale, m.samp_scale, m.lat_scale, m.lon_scale, m.height_scale) == (
        17996.0,
        21250.0,
        0.0531,
        0.0803,
        501.0,
    )
    assert m.line_num[2] == 1.002863 and m.samp_num[1] == -1.021695
    assert m.err_bias == 0.87 and m.err_rand == 0.33


def test_digitalglobe_xml_values_by_hand():
    m = read_rpc(FORMATS / "rpc_WV3_RPB_only.xml")
    assert (m.line_off, m.samp_off, m.lat_off, m.lon_off, m.height_off) == (
        11984.0,
        17589.0,
        26.79,
        80.9911,
        53.0,
    )
    assert m.line_num[0] == -3.450710e-03 and m.samp_den[19] == 0.0


def test_ikonos_txt_values_by_hand():
    m = read_rpc(FORMATS / "rpc_IKONOS.txt")  # 'LINE_OFF: +005124.00 pixels' …
    assert (m.line_off, m.samp_off, m.lat_off, m.lon_off, m.height_off) == (
        5124.0,
        6334.0,
        -34.903,
        -56.1722,
        28.0,
    )
    assert m.line_num[1] == 1.221942364020734


def test_json_values_by_hand():
    m = read_rpc(FORMATS / "JAX_068_001_RGB.json")
    assert m.line_off == 405.51806724276 and m.samp_off == 371.692595898949
    assert m.height_off == -21.0 and m.line_den[0] == 1.0 and m.samp_num[19] == 7.6381e-06


# -- errors name the file and the line or key ------------------------------------------------
def test_missing_key_is_named(tmp_path: Path):
    text = (DATA / "gf_rpc_txt" / "left_image_rpc.txt").read_text()
    bad = tmp_path / "bad_rpc.txt"
    bad.write_text(text.replace("SAMP_DEN_COEFF_7:", "SAMP_DEN_COEF_7:"))
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    assert "missing key SAMP_DEN_COEFF_7" in str(err.value) and "bad_rpc.txt" in str(err.value)


def test_bad_number_names_the_line(tmp_path: Path):
    lines = (DATA / "gf_rpc_txt" / "left_image_rpc.txt").read_text().splitlines()
    lines[2] = "LAT_OFF: north degrees"
    bad = tmp_path / "bad_rpc.txt"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    problem = err.value.problems[0]
    assert problem.line == 3 and "LAT_OFF" in problem.message


def test_geom_in_rpc00a_order_is_refused(tmp_path: Path):
    text = (
        (VENTOUX / "left_image.geom")
        .read_text()
        .replace("polynomial_format:  B", "polynomial_format:  A")
    )
    bad = tmp_path / "a.geom"
    bad.write_text(text)
    with pytest.raises(InputError, match="only B"):
        read_rpc(bad)


def test_rpb_with_19_coefficients_names_the_key(tmp_path: Path):
    text = (FORMATS / "sample.RPB").read_text()
    head, tail = text.split("sampDenCoef = (", 1)
    tail = tail.split(",", 1)[1]  # drop the first coefficient
    bad = tmp_path / "bad.RPB"
    bad.write_text(head + "sampDenCoef = (" + tail)
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    assert "sampDenCoef" in str(err.value) and "got 19" in str(err.value)
    assert err.value.problems[0].line is not None


@pytest.mark.parametrize("first", [0, 1])
def test_dimap_v3_of_pleiades_neo_is_read_with_its_own_first_pixel(tmp_path: Path, first: int):
    """DIMAP v3 (Pléiades Neo) names the ground→image RPCs GroundtoImage_Values and gives the
    first pixel in RFM_Validity/ImagetoGround_Validity_Domain/FIRST_COL (0 for Neo), as GDAL
    reads it (offsets minus FIRST_COL). It was refused: "missing element …/Inverse_Model". The
    Ventoux v2 file rewritten so, its offsets counted from `first`: the same model as v2's."""
    v2 = VENTOUX / "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML"
    text = v2.read_text().replace("Inverse_Model>", "GroundtoImage_Values>")
    domain = (
        f"<ImagetoGround_Validity_Domain><FIRST_ROW>{first}</FIRST_ROW><FIRST_COL>{first}"
        "</FIRST_COL><LAST_ROW>42274</LAST_ROW><LAST_COL>38414</LAST_COL>"
        "</ImagetoGround_Validity_Domain>"
    )
    text = text.replace("<RFM_Validity>", "<RFM_Validity>" + domain, 1)
    for key, value in (("LINE_OFF", "21110.49999999999"), ("SAMP_OFF", "19208.5")):
        counted = float(value) - 1 + first  # the v2 offsets count from 1
        text = text.replace(f"<{key}>{value}</{key}>", f"<{key}>{counted!r}</{key}>", 1)
    v3 = tmp_path / "RPC_PNEO.XML"
    v3.write_text(text)
    neo, old = read_rpc(v3), read_rpc(v2)
    assert neo.first_pixel == first
    assert neo.line_off == pytest.approx(21109.5, abs=1e-9)
    assert neo.samp_off == pytest.approx(19207.5, abs=1e-9)
    assert_same_model(neo, old, offsets_tol=1e-9, coeff_rtol=0.0)


def test_dimap_without_ground_to_image_rpcs_names_both_versions(tmp_path: Path):
    text = (FORMATS / "rpc_PLEIADES.xml").read_text()
    bad = tmp_path / "dimap.xml"
    bad.write_text(text.replace("Inverse_Model", "Inverse_Modl"))
    with pytest.raises(InputError, match="Inverse_Model .DIMAP v2. or .*GroundtoImage_Values"):
        read_rpc(bad)


def test_broken_xml_names_the_line(tmp_path: Path):
    bad = tmp_path / "broken.xml"
    bad.write_text("<?xml version='1.0'?>\n<isd>\n<RPB>\n</isd>\n")
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    assert err.value.problems[0].line == 4


def test_unknown_format_and_missing_file(tmp_path: Path):
    other = tmp_path / "notes.txt"
    other.write_text("hello\n")
    with pytest.raises(InputError, match="not a known RPC format"):
        read_rpc(other)
    with pytest.raises(InputError, match="no such file"):
        read_rpc(tmp_path / "absent.RPB")


def test_raster_without_rpc(tmp_path: Path):
    image = tmp_path / "plain.tif"
    with rasterio.open(image, "w", driver="GTiff", width=2, height=2, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 2, 2), np.uint8))
    with pytest.raises(InputError, match="carries no RPCs"):
        read_rpc(image)


def test_rpb_error_figures_after_begin_group_are_read():
    """`BEGIN_GROUP = IMAGE` ends with its line, no ';': the errBias and errRand after it (lines
    5 and 6 of sample.RPB, 0.02 and 0.03) are their own items."""
    m = read_rpc(FORMATS / "sample.RPB")
    assert (m.err_bias, m.err_rand) == (0.02, 0.03)
    assert (m.line_off, m.samp_off, m.lat_off, m.lon_off) == (531.0, 1278.0, 37.6198, -122.3733)


def _numbers(m) -> np.ndarray:
    """The 90 numbers of an RPC00B model: 10 offsets and scales, 4 × 20 coefficients."""
    return np.concatenate(
        [[getattr(m, k) for k in OFFSET_SCALE_KEYS], *(getattr(m, k) for k in COEFF_KEYS)]
    )


@pytest.mark.parametrize("spell", [str.upper, str.lower], ids=["LINEOFFSET", "lineoffset"])
def test_rpb_keys_in_another_case_are_read_as_the_usual(tmp_path: Path, spell):
    """GDAL reads an .RPB whose keys are written LINEOFFSET or lineoffset (for lineOffset): it
    was 'missing key lineOffset' or 'not a known RPC format'. Its 90 numbers are the usual
    file's, its error figures too."""
    usual = FORMATS / "sample.RPB"
    text = re.sub(r"^(\s*)(\w+)(\s*=)", lambda m: m[1] + spell(m[2]) + m[3], usual.read_text(),
                  flags=re.M)  # fmt: skip
    assert "lineOffset" not in text and "lineNumCoef" not in text
    other = tmp_path / "case.RPB"
    other.write_text(text)
    assert sniff_format(other) == "rpb"
    got, expected = read_rpc(other), read_rpc(usual)
    assert _numbers(got).size == 90
    np.testing.assert_array_equal(_numbers(got), _numbers(expected))
    assert (got.err_bias, got.err_rand) == (0.02, 0.03)


def test_rpb_key_given_twice_in_two_cases_is_refused(tmp_path: Path):
    text = (FORMATS / "sample.RPB").read_text()
    bad = tmp_path / "twice.RPB"
    bad.write_text(text.replace("END_GROUP", "\tLINEOFFSET = 600.0;\nEND_GROUP", 1))
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    (problem,) = err.value.problems
    assert problem.message == "LINEOFFSET given twice, on lines 7 and 101: expected once"
    assert problem.line == 101


def test_rpb_key_in_another_case_is_named_as_written(tmp_path: Path):
    text = (FORMATS / "sample.RPB").read_text()
    text = text.replace("heightScale =  580.00;", "HEIGHTSCALE = x;")
    bad = tmp_path / "bad.RPB"
    bad.write_text(text)
    with pytest.raises(InputError) as err:
        read_rpc(bad)
    (problem,) = err.value.problems
    assert problem.message == "HEIGHTSCALE: expected a number, got 'x'"
    assert problem.line == 16
