"""Malformed inputs of every class: a clear exit 2 naming the file and the row, line or key;
legitimate variants (BOM, CRLF) giving the same results as the clean input."""

from __future__ import annotations

import csv
import json
import os
import re
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest

from casekit import extension_pack, run_blockqc, write_delivery


def _no_traceback(proc) -> None:
    assert "Traceback" not in proc.stderr + proc.stdout
    assert "internal error" not in proc.stderr


def _replace(path: Path, old: str, new: str) -> None:
    data = path.read_bytes()
    assert old.encode() in data, (path, old)
    path.write_bytes(data.replace(old.encode(), new.encode(), 1))


def _cell(path: Path, row: int, column: str, value: str) -> None:
    """Set one cell of a CSV (data row `row`, 1-based) to a raw text."""
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    rows[row][rows[0].index(column)] = value
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)


@pytest.fixture
def blockqc(capsys):
    """The command line's entry point run in this process (exit status, stdout, stderr); the
    cases where the interpreter itself could fail use a child process (run_blockqc)."""
    from blockqc.cli import main

    def run(*args: object) -> SimpleNamespace:
        capsys.readouterr()
        try:
            main([str(a) for a in args])
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        out = capsys.readouterr()
        return SimpleNamespace(returncode=code, stdout=out.out, stderr=out.err)

    return run


@pytest.fixture
def delivery(tmp_path: Path) -> Path:
    return write_delivery(tmp_path / "block")


def _refused(blockqc, delivery: Path, out: Path, *expected: str, extra: tuple = ()) -> str:
    before = sorted(str(p) for p in delivery.rglob("*"))
    p = blockqc("inspect", delivery, "--out", out, "--no-pdf", *extra)
    assert p.returncode == 2, p.stdout + p.stderr
    _no_traceback(p)
    for text in expected:
        assert text in p.stderr, p.stderr
    assert sorted(str(p) for p in delivery.rglob("*")) == before  # nothing written into it
    assert not list(out.rglob("results.json"))
    return p.stderr


# ------------------------------------------------------------------ non-finite numbers
NON_FINITE = [
    ("checkpoints.csv", 1, "x_m", "1e309", "row 1 (line 2), column 'x_m': value is not finite"),
    ("overlaps.csv", 2, "dx_m", "-inf", "row 2 (line 3), column 'dx_m': value is not finite"),
    ("tie_points.csv", 5, "v_line", "inf", "row 5 (line 6), column 'v_line': value is not finite"),
    ("edges.csv", 1, "dz_m", "inf", "row 1 (line 2), column 'dz_m': value is not finite"),
    ("pan_ms.csv", 3, "dy_m", "-1e400", "row 3 (line 4), column 'dy_m': value is not finite"),
    ("checkpoints.csv", 4, "ref_z_m", "Infinity", "row 4 (line 5), column 'ref_z_m': value is not"),
    ("scenes.csv", 2, "water_fraction", "inf", "row 2 (line 3), column 'water_fraction': value"),
    ("scenes.csv", 1, "lines", "inf", "row 1 (line 2), column 'lines': expected a whole number"),
    ("checkpoints.csv", 2, "y_m", "nan", "row 2 (line 3), column 'y_m': empty or NaN value"),
]


@pytest.mark.parametrize("file, row, column, value, message", NON_FINITE)
def test_non_finite_numbers_are_refused(
    blockqc, delivery, tmp_path, file, row, column, value, message
):
    _cell(delivery / file, row, column, value)
    _refused(blockqc, delivery, tmp_path / "out", f"{file}, {message}")


def test_non_finite_numbers_in_parquet(blockqc, delivery: Path, tmp_path: Path) -> None:
    ov = pd.read_csv(delivery / "overlaps.csv", dtype={"point_id": str})
    ov.loc[3, "dy_m"] = float("-inf")
    (delivery / "overlaps.csv").unlink()
    ov.to_parquet(delivery / "overlaps.parquet")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "overlaps.parquet, row 4, column 'dy_m': value is not finite",
    )


@pytest.mark.parametrize("value", [".inf", ".nan", "-.inf"])
def test_non_finite_gsd_in_block_yaml(blockqc, delivery: Path, tmp_path: Path, value) -> None:
    _replace(delivery / "block.yaml", "  pan: 1.0", f"  pan: {value}")
    _refused(blockqc, delivery, tmp_path / "out", "block.yaml, line 4: gsd_m.pan: Input should")


def test_non_finite_reported_figure(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "block.yaml", "reported: {}", "reported: {tie_point_error_px: .nan}")
    _refused(blockqc, delivery, tmp_path / "out", "line 17: reported.tie_point_error_px")


# ------------------------------------------------------------- crashes turned into messages
@pytest.mark.parametrize("value", ["100000000000000000000000", "1e20", "-99999999999999999999"])
def test_integer_too_large(blockqc, delivery: Path, tmp_path: Path, value: str) -> None:
    _cell(delivery / "scenes.csv", 3, "samples", value)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.csv, row 3 (line 4), column 'samples': expected a whole number",
    )


def test_epsg_too_large(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "block.yaml", "epsg: 32650", "epsg: 100000000000000000000000")
    _refused(blockqc, delivery, tmp_path / "out", "block.yaml, line 10: spatial_reference.epsg")


@pytest.mark.parametrize("given", ["EPSG:32650", "'32650'", "'epsg: 32650'"])
def test_epsg_given_as_text(blockqc, delivery: Path, tmp_path: Path, given: str) -> None:
    p = blockqc("inspect", delivery, "--out", tmp_path / "a", "--no-pdf")
    _replace(delivery / "block.yaml", "epsg: 32650", f"epsg: {given}")
    q = blockqc("inspect", delivery, "--out", tmp_path / "b", "--no-pdf")
    assert q.returncode == p.returncode, q.stderr
    read = [json.loads(next((tmp_path / d).rglob("results.json")).read_text()) for d in "ab"]
    assert read[0]["results"] == read[1]["results"]


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("epsg: 32650", "epsg: UTM 50N", "line 10: spatial_reference.epsg: expected an EPSG code"),
        ("block_id: CASE", "block_id: 101", "line 1: block_id: expected text: write the id in"),
        (
            "  pan: 1.0",
            "\tpan: 1.0",
            "not valid YAML: found character that cannot start any "
            "token: a tab; YAML indents with spaces",
        ),
    ],
)
def test_block_yaml_slips_named(
    blockqc, delivery: Path, tmp_path: Path, old: str, new: str, expected: str
) -> None:
    _replace(delivery / "block.yaml", old, new)
    _refused(blockqc, delivery, tmp_path / "out", expected)


def test_one_gsd_for_all_bands_is_refused(blockqc, delivery: Path, tmp_path: Path) -> None:
    text = (delivery / "block.yaml").read_text()
    start = text.index("gsd_m:")
    end = text.index("\n", text.index("ms:", start))
    (delivery / "block.yaml").write_text(text[:start] + "gsd_m: 1.0" + text[end:])
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "block.yaml, line 3: gsd_m: expected the ground sample distance of each band in metres, "
        "e.g. gsd_m: {pan: 1.0, ms: …} (got one number)",
    )


@pytest.mark.parametrize(
    "table, old, dup",
    [
        ("edges", "dy_m", "dx_m"),
        ("tie_points", "v_sample", "v_line"),
        ("scenes", "band", "acquired"),
    ],
)
def test_duplicate_header_names(blockqc, delivery: Path, tmp_path: Path, table, old, dup) -> None:
    path = delivery / f"{table}.csv"
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace(old, dup)
    path.write_text("\n".join(lines) + "\n")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        f"{table}.csv, line 1: column '{dup}' appears more than once in the header",
    )


@pytest.mark.parametrize("column", ["dx_m", "point_id"])
def test_list_typed_parquet_column(blockqc, delivery: Path, tmp_path: Path, column) -> None:
    edges = pd.read_csv(delivery / "edges.csv")
    edges[column] = [[1.0, 2.0]] * len(edges) if column == "dx_m" else [["a"]] * len(edges)
    (delivery / "edges.csv").unlink()
    edges.to_parquet(delivery / "edges.parquet")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        f"edges.parquet, column '{column}': a column of type list",
    )


def test_ragged_row_names_its_line(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "tie_points.csv", "\nPS1-001,S1,", "\nPS1-001,S1,7,")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.csv, line 3: not a readable CSV table: 7 fields where the header has 6",
    )


def test_deeply_nested_yaml(delivery: Path, tmp_path: Path) -> None:
    (delivery / "block.yaml").write_text("block_id: " + "[" * 50000 + "]" * 50000 + "\n")
    _refused(run_blockqc, delivery, tmp_path / "out", "block.yaml, line 1: not accepted: nested")


def test_deeply_nested_verdicts_and_pack(blockqc, delivery: Path, tmp_path: Path) -> None:
    deep = "{a: " * 3000 + "1" + "}" * 3000
    v = tmp_path / "verdicts.yaml"
    v.write_text(f"inspector: A\nverdicts: {deep}\n")
    extra = ("--verdicts", v)
    _refused(blockqc, delivery, tmp_path / "o1", f"{v}, line 2: not accepted: nested", extra=extra)
    pack = tmp_path / "pack.yaml"
    pack.write_text(f"pack: p\nextends: global-project\nconstants: {deep}\n")
    extra = ("--rules", pack)
    _refused(blockqc, delivery, tmp_path / "o2", f"{pack}, line 3: not accepted", extra=extra)


def test_yaml_alias_bomb_is_refused_unexpanded(delivery: Path, tmp_path: Path) -> None:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 9):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    v = tmp_path / "verdicts.yaml"
    v.write_text("\n".join(lines) + "\n")
    extra = ("--verdicts", v)
    msg = f"{v}, line 6: not accepted: alias"
    _refused(run_blockqc, delivery, tmp_path / "out", msg, extra=extra)


def test_numbers_yaml_reads_otherwise_than_written_are_refused_each_at_its_line(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    """YAML 1.1 reads `epsg: 032650` as the octal number 13736 (MB-3 then failed the block on
    'EPSG:13736 delivered'), 1_0 as 10 and 1:30 as 90: each is refused at its line, saying how
    it is written and what YAML reads."""
    manifest = delivery / "block.yaml"
    _replace(manifest, "epsg: 32650", "epsg: 032650")
    _replace(manifest, "pan: 1.0", "pan: 1_0")
    _replace(manifest, "ms: 4.0", "ms: 1:30")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        f"{manifest}, line 4: key 'pan' is written 1_0, which YAML reads as the number 10: write "
        "the number in decimal digits, or in quotes ('1_0') to keep it as text",
        f"{manifest}, line 5: key 'ms' is written 1:30, which YAML reads as the number 90",
        f"{manifest}, line 10: key 'epsg' is written 032650, which YAML reads as the number 13736",
    )


def test_numbers_in_decimal_digits_are_read_as_written(blockqc, delivery, tmp_path) -> None:
    """Leading zeros of a decimal fraction, a sign, an exponent and quoted digits are as meant."""
    _replace(delivery / "block.yaml", "pan: 1.0", "pan: +01.0e0")
    _replace(delivery / "block.yaml", "block_id: CASE", "block_id: '0012'")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    _no_traceback(p)
    results = json.loads((tmp_path / "out" / "0012" / "results.json").read_text())
    assert results["block_id"] == "0012"
    assert next(r for r in results["results"] if r["rule"] == "MB-3")["status"] == "pass"


def test_absurdly_large_manifest_is_refused(blockqc, delivery: Path, tmp_path: Path) -> None:
    with (delivery / "block.yaml").open("a") as fh:
        fh.write("notes:\n" + "  - filler text of a manifest far too large\n" * 200_000)
    _refused(blockqc, delivery, tmp_path / "out", "MiB: files of this kind are limited to 2 MiB")


def test_deeply_nested_json_given_to_report(tmp_path: Path) -> None:
    f = tmp_path / "results.json"
    f.write_text('{"block_id": "A", "verdict": "pass", "results": ' + "[" * 100000 + "]" * 100000)
    p = run_blockqc("report", f, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 2
    _no_traceback(p)
    assert f"{f}: is not accepted: JSON nested too deeply" in p.stderr


# -------------------------------------------------------------------------- encodings
def test_gbk_scene_ids(blockqc, delivery: Path, tmp_path: Path) -> None:
    for name in ("scenes.csv", "tie_points.csv"):
        text = (delivery / name).read_text().replace("S3,", "场景3,")
        (delivery / name).write_bytes(text.encode("gbk"))
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.csv, line 4: byte 0xb3 at character 1 is not UTF-8",
        "UTF-8 text (it looks like GBK / GB18030",
    )


@pytest.mark.parametrize(("encoding", "order"), [("utf-16-le", "LE"), ("utf-16-be", "BE")])
@pytest.mark.parametrize("scene", ["S3", "场景3"])
def test_utf16_without_a_byte_order_mark(blockqc, delivery, tmp_path, encoding, order, scene):
    """A table of UTF-16 text without its byte order mark was said to hold a NUL byte (the
    file may be damaged), or, holding Chinese, to look like Latin-1."""
    for name in ("scenes.csv", "tie_points.csv", "block.yaml"):
        text = (delivery / name).read_text().replace("S3,", f"{scene},")
        (delivery / name).write_bytes(text.encode(encoding))
    said = (
        ", line 1: every other byte is NUL (0x00): the file must be UTF-8 text (it looks like "
        f"UTF-16{order} without a byte order mark; save it as UTF-8)"
    )
    stderr = _refused(blockqc, delivery, tmp_path / "out", *(n + said for n in ("scenes.csv",)))
    assert "tie_points.csv" + said in stderr and "block.yaml" + said in stderr


def test_utf16_with_a_byte_order_mark(blockqc, delivery, tmp_path) -> None:
    (delivery / "scenes.csv").write_text((delivery / "scenes.csv").read_text(), "utf-16")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.csv, line 1: byte 0xff at character 1 is not UTF-8: the file must be UTF-8 "
        "text (it looks like UTF-16; save it as UTF-8)",
    )


def test_latin1_manifest_names_line(blockqc, delivery: Path, tmp_path: Path) -> None:
    data = (delivery / "block.yaml").read_bytes().replace(b"GF-7", "GF-7 Müller".encode("latin-1"))
    (delivery / "block.yaml").write_bytes(data)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "block.yaml, line 2: byte 0xfc at character 15 is not UTF-8",
        "Latin-1 / Windows-1252",
    )


def test_bom_crlf_and_trailing_commas_give_the_same_results(blockqc, tmp_path: Path) -> None:
    clean = write_delivery(tmp_path / "clean")
    variant = write_delivery(tmp_path / "variant")
    edges = variant / "edges.csv"
    edges.write_text(edges.read_text().replace("\n", ",,\n"))  # empty unnamed columns
    for f in [*variant.glob("*.csv"), variant / "block.yaml"]:
        f.write_bytes(b"\xef\xbb\xbf" + f.read_bytes().replace(b"\n", b"\r\n"))
    docs = []
    for d, out in ((clean, "o1"), (variant, "o2")):
        p = blockqc("inspect", d, "--out", tmp_path / out, "--no-pdf")
        assert p.returncode == 0, p.stderr
        doc = json.loads((tmp_path / out / "CASE" / "results.json").read_text())
        docs.append({k: v for k, v in doc.items() if k not in ("generated_at", "delivery")})
    assert docs[0] == docs[1]


# ------------------------------------------------------------ bad input treated as absent
def test_dangling_symlink_for_a_table(blockqc, delivery: Path, tmp_path: Path) -> None:
    (delivery / "checkpoints.csv").unlink()
    os.symlink(tmp_path / "nowhere.csv", delivery / "checkpoints.csv")
    why = f"checkpoints.csv: a symbolic link to {tmp_path / 'nowhere.csv'}, which does not exist"
    _refused(blockqc, delivery, tmp_path / "out", f"{why}: expected the checkpoints table")


@pytest.mark.parametrize("name", ["edges.csv", "checkpoints.parquet", "scenes.csv"])
def test_folder_named_like_a_table(blockqc, delivery: Path, tmp_path: Path, name: str) -> None:
    for f in delivery.glob(name.split(".")[0] + ".*"):
        f.unlink()
    (delivery / name).mkdir()
    table = name.split(".")[0]
    why = f"{name}: is a folder, not a file: expected the {table} table"
    _refused(blockqc, delivery, tmp_path / "out", why)


def test_pipe_named_like_a_table(blockqc, delivery: Path, tmp_path: Path) -> None:
    (delivery / "edges.csv").unlink()
    os.mkfifo(delivery / "edges.csv")
    why = "edges.csv: is not a regular file (a pipe, socket or device): expected the edges table"
    _refused(blockqc, delivery, tmp_path / "out", why)


@pytest.mark.parametrize("table", ["checkpoints", "overlaps", "tie_points"])
def test_header_only_table(blockqc, delivery: Path, tmp_path: Path, table: str) -> None:
    path = delivery / f"{table}.csv"
    path.write_text(path.read_text().splitlines()[0] + "\n")
    _refused(blockqc, delivery, tmp_path / "out", f"{table}.csv: the table has a header but no")


def test_self_intersecting_footprint(blockqc, delivery: Path, tmp_path: Path) -> None:
    scenes = pd.read_csv(delivery / "scenes.csv")
    scenes.loc[2, "footprint_wkt"] = "POLYGON((116 39, 116.02 38.98, 116.02 39, 116 38.98, 116 39))"
    scenes.to_csv(delivery / "scenes.csv", index=False)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.csv, row 3 (line 4), column 'footprint_wkt': not a valid polygon",
    )


def test_one_part_multipolygon_footprint_is_that_polygon(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    import shapely

    scenes = pd.read_csv(delivery / "scenes.csv")
    given = scenes.loc[2, "footprint_wkt"]
    ring = given[given.index("((") + 2 : given.rindex("))")]
    scenes.loc[2, "footprint_wkt"] = f"MULTIPOLYGON((({ring})))"  # as GIS exports write it
    scenes.to_csv(delivery / "scenes.csv", index=False)
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode in (0, 1), p.stderr
    (results,) = (tmp_path / "out").rglob("results.json")
    read = json.loads(results.read_text())["scenes"][2]["footprint_wkt"]
    assert read.startswith("POLYGON")
    assert shapely.equals(shapely.from_wkt(read), shapely.from_wkt(given))
    scenes.loc[2, "footprint_wkt"] = f"MULTIPOLYGON((({ring})), ((0 0, 1 0, 1 1, 0 0)))"
    scenes.to_csv(delivery / "scenes.csv", index=False)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out2",
        "scenes.csv, row 3 (line 4), column 'footprint_wkt': expected a WKT polygon in lon/lat "
        "degrees (a MULTIPOLYGON of one part is read as that polygon)",
    )


def test_missing_templates_folder(blockqc, delivery: Path, tmp_path: Path) -> None:
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--templates", tmp_path / "nothing")
    assert p.returncode == 2
    assert "nothing" in p.stderr and "does not exist" in p.stderr
    assert not (tmp_path / "out").exists()


def test_half_given_reference_and_self_overlap(blockqc, delivery: Path, tmp_path: Path) -> None:
    _cell(delivery / "checkpoints.csv", 5, "ref_y_m", "")
    _cell(delivery / "overlaps.csv", 2, "scene_b", "S1")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "checkpoints.csv, row 5 (line 6), column 'ref_y_m': ref_y_m is empty where ref_x_m",
        "overlaps.csv, row 2 (line 3), column 'scene_b': scene_b is scene_a",
    )


def test_an_overlap_point_given_in_both_orders_is_refused(blockqc, delivery, tmp_path) -> None:
    # row 4 repeats row 1's point O0 of the pair S1/S2 as S2/S1: it would be judged twice
    _cell(delivery / "overlaps.csv", 4, "point_id", "O0")
    _cell(delivery / "overlaps.csv", 4, "scene_a", "S2")
    _cell(delivery / "overlaps.csv", 4, "scene_b", "S1")
    message = "the same point of this pair is also given with scene_a and scene_b swapped"
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        f"overlaps.csv, row 1 (line 2): {message}",
        f"overlaps.csv, row 4 (line 5): {message}",
    )


@pytest.mark.parametrize("neighbour", ["CASE", "case"])
def test_an_edge_against_the_block_itself_is_refused(blockqc, delivery, tmp_path, neighbour):
    _cell(delivery / "edges.csv", 3, "neighbour_block", neighbour)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "edges.csv, row 3 (line 4), column 'neighbour_block': neighbour_block names this "
        f"block (block_id CASE in block.yaml): expected an adjacent block, got '{neighbour}'",
    )


def test_a_footprint_with_a_hole_is_refused(blockqc, delivery, tmp_path) -> None:
    outline = "116.3 39.9, 116.32 39.9, 116.32 39.88, 116.3 39.88, 116.3 39.9"
    hole = "116.305 39.895, 116.31 39.895, 116.31 39.89, 116.305 39.895"
    _cell(delivery / "scenes.csv", 2, "footprint_wkt", f"POLYGON(({outline}), ({hole}))")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.csv, row 2 (line 3), column 'footprint_wkt': a footprint is the outline of "
        "an image: expected a polygon without holes",
    )


# ------------------------------------------------ problems together, "did you mean"
def test_missing_document_reported_with_table_errors(blockqc, delivery, tmp_path) -> None:
    (delivery / "documents" / "technical_design.pdf").unlink()
    _cell(delivery / "tie_points.csv", 3, "v_line", "abc")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.csv, row 3 (line 4), column 'v_line': expected a number, got 'abc'",
        "block.yaml: documents.technical_design: documents/technical_design.pdf is missing",
    )


def test_a_column_repeated_in_another_case_is_refused(blockqc, delivery, tmp_path) -> None:
    """`Dz_m` beside `dz_m`: which one is meant cannot be told, and the other would go unread."""
    edges = pd.read_csv(delivery / "edges.csv", dtype=str)
    edges.assign(Dz_m="99", DX_M="1").to_csv(delivery / "edges.csv", index=False)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "edges.csv, line 1: column 'DX_M' repeats column 'dx_m' in another case: give it once",
        "edges.csv, line 1: column 'Dz_m' repeats column 'dz_m' in another case: give it once",
    )


def test_a_document_present_in_other_case_is_pointed_to(blockqc, delivery, tmp_path) -> None:
    """block.yaml names documents/technical_design.pdf, the delivery holds .PDF: missing (names
    are matched exactly), and the message says where the file is."""
    docs = delivery / "documents"
    (docs / "technical_design.pdf").rename(docs / "technical_design.PDF")
    hint = (
        "(documents/technical_design.PDF is there: file names are matched exactly, in their case)"
    )
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    (results,) = (tmp_path / "out").rglob("results.json")
    doc1 = next(r for r in json.loads(results.read_text())["results"] if r["rule"] == "DOC-1")
    assert doc1["status"] == "fail", p.stderr
    assert doc1["evidence"][0]["problem"] == f"documents/technical_design.pdf does not exist {hint}"
    _cell(delivery / "tie_points.csv", 3, "v_line", "abc")  # unreadable: listed with the rest
    _refused(
        blockqc,
        delivery,
        tmp_path / "out2",
        "block.yaml: documents.technical_design: documents/technical_design.pdf is missing from "
        f"the delivery {hint}",
    )


def test_document_paths_written_with_windows_separators(blockqc, delivery, tmp_path) -> None:
    text = (delivery / "block.yaml").read_text()
    (delivery / "block.yaml").write_text(text.replace("documents/", "documents\\"))
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    (results,) = (tmp_path / "out").rglob("results.json")
    doc1 = next(r for r in json.loads(results.read_text())["results"] if r["rule"] == "DOC-1")
    assert doc1["status"] == "pass", (p.stderr, doc1)
    text = (delivery / "block.yaml").read_text()
    (delivery / "block.yaml").write_text(
        text.replace("documents\\technical_design.pdf", "..\\technical_design.pdf")
    )
    p = blockqc("inspect", delivery, "--out", tmp_path / "out2", "--no-pdf")
    (results,) = (tmp_path / "out2").rglob("results.json")
    doc1 = next(r for r in json.loads(results.read_text())["results"] if r["rule"] == "DOC-1")
    assert doc1["status"] == "fail"
    assert doc1["evidence"][0]["problem"] == (
        "..\\technical_design.pdf points outside the delivery"
    )


def test_did_you_mean_method_and_scene(blockqc, delivery: Path, tmp_path: Path) -> None:
    _cell(delivery / "checkpoints.csv", 2, "method", "high_precison")
    _cell(delivery / "tie_points.csv", 10, "scene_id", "S01")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "checkpoints.csv, row 2 (line 3), column 'method': expected one of high_precision, "
        "same_accuracy, recalculation, got 'high_precison'; did you mean 'high_precision'?",
        "tie_points.csv, row 10 (line 11), column 'scene_id': unknown scene_id (not in "
        "scenes.csv), got 'S01'; did you mean 'S1'?",
    )


# ------------------------------------------------------------------------- path safety
@pytest.mark.parametrize(
    "block_id, why",
    [
        ("../x", "holds '/'"),
        ("ABSOLUTE", "holds '/'"),  # an absolute path under this test's folder
        ("..", "starts with '.'"),
        ("a/b", "holds '/'"),
        ('"a\\0b"', "holds '\\x00'"),
        ("A" * 101, "has 101 characters: at most 100"),
        ("summary.json", "is the name of a batch output file"),
        ('"a b"', "holds ' '"),
        ("CON", "is a device name on Windows"),
        ("nul.v2", "is a device name on Windows"),
        ("Com1", "is a device name on Windows"),
        ("F1-B01.", "ends with '.', which Windows drops"),
    ],
)
def test_unsafe_block_id(blockqc, delivery: Path, tmp_path: Path, block_id: str, why) -> None:
    block_id = str(tmp_path / "abs") if block_id == "ABSOLUTE" else block_id
    _replace(delivery / "block.yaml", "block_id: CASE", f"block_id: {block_id}")
    _refused(blockqc, delivery, tmp_path / "out", "block.yaml, line 1: block_id: ", why)
    assert not (tmp_path / "x").exists() and not (tmp_path / "abs").exists()


def test_block_id_within_the_contract_is_accepted(blockqc, delivery: Path, tmp_path) -> None:
    _replace(delivery / "block.yaml", "block_id: CASE", "block_id: F1-B01_v2.1")
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "out" / "F1-B01_v2.1" / "results.json").is_file()


def test_report_refuses_an_unsafe_block_id(blockqc, delivery: Path, tmp_path: Path) -> None:
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 0, p.stderr
    f = tmp_path / "out" / "CASE" / "results.json"
    doc = json.loads(f.read_text())
    doc["block_id"] = "../../escaped"
    f.write_text(json.dumps(doc))
    p = blockqc("report", f, "--out", tmp_path / "re", "--no-pdf")
    assert p.returncode == 2
    _no_traceback(p)
    assert f"{f}: not a valid results.json: at $.block_id:" in p.stderr
    assert "the block id '../../escaped' holds '/'" in p.stderr
    assert not (tmp_path / "escaped").exists()


def test_safe_child(tmp_path: Path) -> None:
    from blockqc.errors import InputError, OutputError
    from blockqc.outputs import safe_child

    assert safe_child(tmp_path, "F1-B01") == tmp_path / "F1-B01"
    for name in ("..", "../x", "/etc", "a/b", "a\0b", "", "x" * 300, ".hidden"):
        with pytest.raises(InputError):  # the name's own fault
            safe_child(tmp_path, name)
    (tmp_path / "link").symlink_to(tmp_path.parent)
    with pytest.raises(OutputError, match="leads outside the output folder"):  # the folder's
        safe_child(tmp_path, "link")


# ------------------------------------------------------------------------ verdicts file
def _verdicts(tmp_path: Path, text: str) -> Path:
    v = tmp_path / "verdicts.yaml"
    v.write_text(text)
    return v


VERDICT_CASES = [
    ("verdicts:\n  CP-2: {status: pass}\n", "line 3: rule CP-2 is judged from the delivery"),
    (
        "verdicts:\n  DOC-4: {status: pass}\n",
        "line 3: a verdict for rule 'DOC-4', which the rule pack does not hold; did you mean "
        "'DOC-3'?",
    ),
    (
        "blocks:\n  CAS:\n    verdicts: {DOC-3: {status: pass}}\n",
        "line 3: block 'CAS' is not one of the blocks inspected (CASE); did you mean 'CASE'?",
    ),
    ("date: 2026-11-21\n", "line 2: date: unknown key\n"),
    (
        "verdict:\n  DOC-3: {status: pass}\n",
        "line 2: verdict: unknown key; did you mean 'verdicts'?",
    ),
    (
        "waivers:\n  TP-4: {reason: sea, scene: [S1]}\n",
        "line 3: waivers.TP-4.scene: unknown key; did you mean 'scenes'?",
    ),
    (
        "blocks:\n  CASE:\n    verdict: {DOC-3: {status: pass}}\n",
        "line 4: blocks.CASE.verdict: unknown key; did you mean 'verdicts'?",
    ),
    ("waivers:\n  RO-3: {reason: sea}\n", "line 3: rule RO-3 is not waivable"),
    ("waivers:\n  CP-4: {reason: x}\n", "line 3: rule CP-4 is not waivable"),
    ("waivers:\n  CP-5: {reason: x}\n", "line 3: rule CP-5 is not waivable"),
    (
        "waivers:\n  TP-4:\n    reason: sea\n    scenes: [S1, S7]\n",
        "line 5: a waiver for scene 'S7', which is not a scene of any block inspected",
    ),
    (
        "blocks:\n  CASE:\n    waivers:\n      TP-5: {reason: sea, scenes: [S22]}\n",
        "line 5: a waiver for scene 'S22', which is not a scene of block CASE; did you mean",
    ),
    (
        "waivers:\n  TP-4: {reason: x, pairs: [[S1, Q2]]}\n",
        "line 3: a waiver for scene 'Q2', which is not a scene of any block inspected",
    ),
    (
        "waivers:\n  TP-4: {reason: sea, scenes: []}\n",
        "line 3: waivers.TP-4.scenes: an empty list waives nothing",
    ),
    ("verdicts:\n  DOC-3: {status: conditional_pass}\n", "line 3: verdicts.DOC-3: a conditional"),
    (
        "waivers:\n  TP-5: {reason: x, points: [PS1-000]}\n",
        "line 3: rule TP-5 is judged per scene: list the scenes to waive under 'scenes'",
    ),
    (
        "verdicts:\n  DOC-3: {status: maybe}\n",
        "line 3: verdicts.DOC-3.status: Input should be 'pass', 'conditional_pass', 'rework' "
        "or 'fail'",
    ),
]


@pytest.mark.parametrize("text, message", VERDICT_CASES)
def test_verdicts_file_nothing_dropped(blockqc, delivery, tmp_path, text, message) -> None:
    v = _verdicts(tmp_path, "inspector: A\n" + text)
    _refused(blockqc, delivery, tmp_path / "out", f"{v}, {message}", extra=("--verdicts", v))


def _doc3(tmp_path: Path, blockqc, delivery: Path, status: str) -> tuple[int, dict]:
    v = _verdicts(tmp_path, f"verdicts:\n  DOC-3: {{status: {status}, note: 'fix table 3'}}\n")
    out = tmp_path / f"out-{status}"
    p = blockqc("inspect", delivery, "--verdicts", v, "--out", out, "--no-pdf")
    _no_traceback(p)
    doc = json.loads((out / "CASE" / "results.json").read_text())
    return p.returncode, next(r for r in doc["results"] if r["rule"] == "DOC-3") | {
        "verdict": doc["verdict"]
    }


@pytest.mark.parametrize(
    "status, rc, rule_status, verdict",
    [
        ("pass", 0, "pass", "pass"),
        ("conditional_pass", 0, "pass", "pass"),
        ("rework", 1, "fail", "fail"),
        ("fail", 1, "fail", "fail"),
    ],
)
def test_verdict_statuses(blockqc, delivery, tmp_path, status, rc, rule_status, verdict) -> None:
    got_rc, res = _doc3(tmp_path, blockqc, delivery, status)
    assert (got_rc, res["status"], res["value"], res["verdict"]) == (
        rc,
        rule_status,
        status,
        verdict,
    )
    assert res["detail"]["note"] == "fix table 3"
    if status == "conditional_pass":
        assert res["detail"]["condition"] == "fix table 3"


def test_whole_rule_waiver_covers_every_unit(blockqc, tmp_path: Path) -> None:
    drop = {"tie_points": [{"where": {"scene_id": "S2"}, "keep_first": 50}]}
    d = write_delivery(tmp_path / "block", {"drop": drop})
    v = _verdicts(tmp_path, "waivers:\n  TP-4: {reason: open sea}\n")
    p = blockqc("inspect", d, "--verdicts", v, "--out", tmp_path / "out", "--no-pdf")
    _no_traceback(p)
    doc = json.loads((tmp_path / "out" / "CASE" / "results.json").read_text())
    tp4 = next(r for r in doc["results"] if r["rule"] == "TP-4")
    assert tp4["status"] == "waived"
    assert tp4["detail"]["waived"] == ["S2"] and tp4["detail"]["waiver_reason"] == "open sea"


def _short_scenes(tmp_path: Path) -> Path:
    """The base block with 50 tie points kept in S1, 80 in S2 and 10 in S3, a water scene."""
    drop = {
        "tie_points": [
            {"where": {"scene_id": "S1"}, "keep_first": 50},
            {"where": {"scene_id": "S2"}, "keep_first": 80},
            {"where": {"scene_id": "S3"}, "keep_first": 10},
        ]
    }
    water = {"scenes": [{"where": {"scene_id": "S3"}, "values": {"water_fraction": 0.9}}]}
    return write_delivery(tmp_path / "block", {"drop": drop, "set": water})


@pytest.mark.parametrize(
    "scenes, status, value, evidence, waived",
    [
        ("[S1]", "fail", 80, [("S2", 80)], ["S1"]),  # the failure: S2's 80 points, not S1's 50
        ("[S2, S1]", "waived", 50, [("S1", 50), ("S2", 80)], ["S1", "S2"]),  # all waived: shown
    ],
)
def test_waived_scene_gives_no_figure_of_a_failure(
    blockqc, tmp_path: Path, scenes, status, value, evidence, waived
) -> None:
    d = _short_scenes(tmp_path)
    v = _verdicts(tmp_path, f"waivers:\n  TP-4: {{scenes: {scenes}, reason: cloud}}\n")
    p = blockqc("inspect", d, "--verdicts", v, "--out", tmp_path / "out", "--no-pdf")
    _no_traceback(p)
    doc = json.loads((tmp_path / "out" / "CASE" / "results.json").read_text())
    tp4 = next(r for r in doc["results"] if r["rule"] == "TP-4")
    assert (tp4["status"], tp4["value"]) == (status, value)
    assert [(e["scene_id"], e["n_points"]) for e in tp4["evidence"]] == evidence
    assert sorted(tp4["detail"]["waived"]) == waived
    assert [x["scene_id"] for x in tp4["detail"]["exempt"]] == ["S3"]  # water: not judged
    html = (tmp_path / "out" / "CASE" / "report.html").read_text()
    assert f">{value} points<" in html


def test_a_waived_result_is_shown_with_its_evidence_among_the_failures(
    blockqc, tmp_path: Path
) -> None:
    """What a waiver covers is seen with its values: TP-4 waived for S1 (50 points) and S2 (80),
    both below 100, is listed in the section of failures with both scenes as evidence."""
    d = _short_scenes(tmp_path)
    v = _verdicts(tmp_path, "waivers:\n  TP-4: {scenes: [S2, S1], reason: cloud}\n")
    p = blockqc("inspect", d, "--verdicts", v, "--out", tmp_path / "out", "--no-pdf")
    _no_traceback(p)
    html = (tmp_path / "out" / "CASE" / "report.html").read_text()
    failures = html.split('<section id="failures">')[1].split("</section>")[0]
    tp4 = failures.split("<h3>TP-4")[1].split('<div class="failure">')[0]
    assert '<span class="status waived">waived</span>' in tp4
    rows = re.findall(r"<tr><td>(S\d)</td><td>PAN</td><td[^>]*>0</td><td[^>]*>(\d+)</td>", tp4)
    assert rows == [("S1", "50"), ("S2", "80")]


#: RO-1 (per pair of PAN and MS scenes) and RO-3 (per point of a pair of scenes) made waivable
WAIVABLE = "overrides:\n  RO-1: {waivable: true}\n  RO-3: {waivable: true}\n"
# the base block's overlaps: points O0..O4 of the pair S1/S2; its pan_ms: R0..R4 of S1/M1
UNIT_WAIVER_CASES = [
    (
        "waivers:\n  RO-3: {reason: x, points: [P2]}\n",
        "line 2: a waiver for point 'P2', which is not a point in the overlaps table of any "
        "block inspected",
    ),
    (
        "waivers:\n  RO-3: {reason: x, scenes: [S1]}\n",
        "line 2: rule RO-3 is judged per point: list the pairs of scenes to waive under 'pairs', "
        "the point ids under 'points' or the units (scene_a/scene_b/point_id) under 'units' "
        "('scenes' would match none)",
    ),
    (
        "waivers:\n  RO-1: {reason: x, pairs: [[S1, S2]]}\n",
        "line 2: a waiver for pair 'S1/S2', which is not a pair in the pan_ms table of any "
        "block inspected; did you mean 'S1/M1'?",
    ),
    (
        "blocks:\n  CASE:\n    waivers:\n      RO-3: {reason: x, units: [S2/S1/O2]}\n",
        "line 4: a waiver for unit 'S2/S1/O2', which is not a unit in the overlaps table "
        "(scene_a/scene_b/point_id) of block CASE; did you mean 'S1/S2/O2'?",
    ),
    (
        "waivers:\n  RO-1: {reason: x, points: [R0]}\n",
        "line 2: rule RO-1 is judged per pair: list the pairs of scenes to waive under 'pairs' "
        "or the units (pan_scene_id/ms_scene_id) under 'units' ('points' would match none)",
    ),
    (
        "waivers:\n  RO-3:\n    reason: x\n    pairs: [[S1, S2]]\n    units: [S1/S2]\n",
        "line 5: a waiver for unit 'S1/S2', which is not a unit in the overlaps table "
        "(scene_a/scene_b/point_id) of any block inspected",
    ),
]


@pytest.mark.parametrize("text, message", UNIT_WAIVER_CASES)
def test_waiver_of_pairs_and_points_matching_nothing(
    blockqc, delivery, tmp_path, text, message
) -> None:
    pack = extension_pack(tmp_path, WAIVABLE)
    v = _verdicts(tmp_path, text)
    extra = ("--verdicts", v, "--rules", pack)
    _refused(blockqc, delivery, tmp_path / "out", f"{v}, {message}", extra=extra)


@pytest.mark.parametrize(
    "named, waived",
    [
        ("points: [O2]", ["S1/S2/O2"]),  # the point of each pair holding it
        ("pairs: [[S2, S1]]", ["S1/S2/O2", "S1/S2/O4"]),  # every point of the pair, any order
        ("units: [S1/S2/O4]", ["S1/S2/O4"]),
    ],
)
def test_waiver_of_points_and_pairs_of_a_per_point_rule(
    blockqc, tmp_path: Path, named, waived
) -> None:
    too_far = [{"where": {"point_id": {"in": ["O2", "O4"]}}, "values": {"dx_m": 30.0}}]
    d = write_delivery(tmp_path / "block", {"set": {"overlaps": too_far}})  # plane √916 m
    v = _verdicts(tmp_path, f"waivers:\n  RO-3: {{reason: sea, {named}}}\n")
    pack = extension_pack(tmp_path, WAIVABLE)
    out = tmp_path / "out"
    p = blockqc("inspect", d, "--verdicts", v, "--rules", pack, "--out", out, "--no-pdf")
    _no_traceback(p)
    doc = json.loads((out / "CASE" / "results.json").read_text())
    plane = next(
        r for r in doc["results"] if r["rule"] == "RO-3" and r["group"]["component"] == "plane"
    )
    assert plane["detail"]["waived"] == waived and plane["detail"]["waiver_reason"] == "sea"
    assert plane["status"] == ("fail" if len(waived) == 1 else "waived")


def test_verdicts_file_checked_beside_an_unreadable_delivery(blockqc, tmp_path: Path) -> None:
    """B01's scenes.csv cannot be read: block ids are still checked, and scenes and points
    against the deliveries that could be read; B01's own waivers are not (its scenes unknown)."""
    for b in ("B00", "B01"):
        write_delivery(tmp_path / "batch" / b, {"manifest": {"block_id": b}})
    _cell(tmp_path / "batch" / "B01" / "scenes.csv", 1, "band", "pann")
    text = (
        "blocks:\n"
        "  F9-B99:\n"
        "    verdicts: {DOC-3: {status: pass}}\n"
        "  B00:\n"
        "    waivers: {TP-4: {reason: x, scenes: [S11]}}\n"
        "  B01:\n"
        "    waivers: {TP-4: {reason: x, scenes: [ZZ]}}\n"
        "waivers:\n"
        "  TP-4: {reason: x, scenes: [NO-SUCH-SCENE]}\n"
        "  RO-3: {reason: x, points: [Q9]}\n"
    )
    v = _verdicts(tmp_path, text)
    extra = ("--verdicts", v, "--rules", extension_pack(tmp_path, WAIVABLE))
    err = _refused(
        blockqc,
        tmp_path / "batch",
        tmp_path / "out",
        f"{v}, line 2: block 'F9-B99' is not one of the blocks inspected (B00, B01)",
        f"{v}, line 5: a waiver for scene 'S11', which is not a scene of block B00; did you mean "
        "'S1'?",
        f"{v}, line 9: a waiver for scene 'NO-SUCH-SCENE', which is not a scene of any block "
        "inspected (the scenes of B01 could not be read)",
        f"{v}, line 10: a waiver for point 'Q9', which is not a point in the overlaps table of "
        "any block inspected",
        extra=extra,
    )
    assert "'ZZ'" not in err and err.count(f"{v}, ") == 4


def test_verdicts_file_checked_beside_an_unreadable_block_yaml(blockqc, tmp_path: Path) -> None:
    """B01's block.yaml cannot be read, so its block id is unknown: a block id not inspected
    may be its own and is not refused; scenes are checked against B00."""
    for b in ("B00", "B01"):
        write_delivery(tmp_path / "batch" / b, {"manifest": {"block_id": b}})
    (tmp_path / "batch" / "B01" / "block.yaml").write_text("block_id: [\n")
    text = (
        "blocks:\n  F9-B99:\n    verdicts: {DOC-3: {status: pass}}\n"
        "waivers:\n  TP-4: {reason: x, scenes: [NO-SUCH-SCENE]}\n"
    )
    v = _verdicts(tmp_path, text)
    err = _refused(
        blockqc,
        tmp_path / "batch",
        tmp_path / "out",
        f"{v}, line 5: a waiver for scene 'NO-SUCH-SCENE', which is not a scene of any block "
        f"inspected (the block.yaml of {tmp_path / 'batch' / 'B01'} could not be read)",
        extra=("--verdicts", v),
    )
    assert "F9-B99" not in err and err.count(f"{v}, ") == 1


def test_terminal_controls_of_inputs_shown_escaped_on_the_console(blockqc, tmp_path: Path) -> None:
    """A delivery folder's name and a waived scene holding an escape sequence or
    a right-to-left override: the console shows them escaped, never for a terminal to obey (a
    title-setting OSC or a bell, which no colour stripping removes)."""
    write_delivery(tmp_path / "batch" / "B00", {"manifest": {"block_id": "B00"}})
    odd = tmp_path / "batch" / "x\x1b]0;owned\x07\u202e"
    odd.mkdir()
    v = _verdicts(tmp_path, 'waivers:\n  TP-4: {reason: x, scenes: ["\\e]0;t\\a"]}\n')
    extra = ("--verdicts", v, "--rules", extension_pack(tmp_path, WAIVABLE))
    proc = blockqc("inspect", tmp_path / "batch", "--out", tmp_path / "out", *extra)
    assert proc.returncode == 2
    assert "\x1b" not in proc.stderr and "\x07" not in proc.stderr and "\u202e" not in proc.stderr
    assert "a waiver for scene '\\x1b]0;t\\x07'" in proc.stderr
    (v.unlink(), _no_traceback(proc))
    proc = blockqc("inspect", tmp_path / "batch", "--out", tmp_path / "out", "--no-progress")
    shown = f"{tmp_path / 'batch'}/x\\x1b]0;owned\\x07\\u202e"
    assert f"{shown}  UNREADABLE" in proc.stdout and f"error: {shown}/block.yaml" in proc.stderr
    text = proc.stdout + proc.stderr
    assert "\x1b]" not in text and "\x07" not in text and "\u202e" not in text


# ---------------------------------------------------------------------- exports and plots
def test_formula_cells_neutralised_in_exports(blockqc, delivery: Path, tmp_path: Path) -> None:
    text = (delivery / "checkpoints.csv").read_text()
    text = text.replace("\nC00,", '\n"=HYPERLINK(""http://x"",""y"")",', 1)
    text = text.replace("\nC01,", "\n@SUM(A1),", 1).replace("\nC02,", "\n+cmd|' /C calc'!A0,", 1)
    (delivery / "checkpoints.csv").write_text(text)
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 0, p.stderr
    rows = pd.read_csv(tmp_path / "out" / "CASE" / "checkpoints.csv", encoding="utf-8-sig")
    ids = set(rows["point_id"])
    assert {'\'=HYPERLINK("http://x","y")', "'@SUM(A1)", "'+cmd|' /C calc'!A0"} <= ids
    assert not any(str(i).startswith(("=", "+", "@")) for i in ids)
    assert rows["dx_m"].dtype.kind == "f"  # numbers stay numbers


@pytest.mark.parametrize(
    "text, expected",
    [
        ("=1+2", "'=1+2"),
        ("-3.2", "-3.2"),
        ("+1e5", "+1e5"),
        ("-cmd", "'-cmd"),
        ("@x", "'@x"),
        ("\tx", "'\tx"),
        ("\r=x", "'\r=x"),
        ("S1", "S1"),
    ],
)
def test_neutralise(text: str, expected: str) -> None:
    from blockqc.report.exports import neutralise

    assert neutralise(text) == expected


def test_huge_residual_and_mathtext_point_id(blockqc, delivery: Path, tmp_path: Path) -> None:
    _cell(delivery / "tie_points.csv", 1, "v_line", "1000000.0")
    _cell(delivery / "tie_points.csv", 2, "point_id", "$\\alpha^{$")
    text = (delivery / "checkpoints.csv").read_text().replace("\nC00,", "\n$x_{1$,", 1)
    (delivery / "checkpoints.csv").write_text(text)
    p = blockqc("inspect", delivery, "--out", tmp_path / "out", "--no-pdf")
    assert p.returncode == 1, p.stderr  # TP-2 fails: the 1e6 px residual
    _no_traceback(p)
    doc = json.loads((tmp_path / "out" / "CASE" / "results.json").read_text())
    errors = next(m for m in doc["measurements"] if m["metric"] == "tie_point_errors")
    hist = errors["detail"]["histogram"]
    assert len(hist["edges_px"]) == 202  # 0..10 px by 0.05, then one bin up to 1e6 px
    assert hist["edges_px"][-1] == pytest.approx(1e6, rel=1e-6)
    assert sum(hist["counts"]) == 484 and hist["counts"][-1] == 1
    assert "$x_{1$" in (tmp_path / "out" / "CASE" / "report.html").read_text()


def test_histogram_edges_bounded() -> None:
    from blockqc.metrics.tiepoints import histogram_edges

    assert len(histogram_edges(0.3)) == 41  # [0, 2] px in 0.05 px bins
    assert histogram_edges(3.04)[-1] == pytest.approx(3.1)
    e = histogram_edges(1e9)
    assert len(e) == 202 and e[-2] == pytest.approx(10.0) and e[-1] == 1e9


def test_misspelt_manifest_key(blockqc, delivery: Path, tmp_path: Path) -> None:
    _replace(delivery / "block.yaml", "reported: {}", "reportd: {tie_point_error_px: 0.3}")
    _replace(delivery / "block.yaml", "  height_datum:", "  hieght_datum:")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "block.yaml, line 17: reportd: unknown key; did you mean 'reported'?",
        "block.yaml, line 8: spatial_reference.hieght_datum: unknown key; did you mean",
    )


def test_tie_point_outside_its_scene(blockqc, delivery: Path, tmp_path: Path) -> None:
    _cell(delivery / "tie_points.csv", 7, "line", "5000")
    _cell(delivery / "tie_points.csv", 8, "sample", "-3")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.csv, row 7 (line 8), column 'line': line lies outside its scene",
        "tie_points.csv, row 8 (line 9), column 'sample': sample lies outside its scene (0 to "
        "the scene's samples in scenes.csv), got -3",
    )


def test_parquet_repeated_column_and_binary_text(blockqc, delivery: Path, tmp_path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    edges = pd.read_csv(delivery / "edges.csv", dtype=str)
    (delivery / "edges.csv").unlink()
    cols = [pa.array(edges[c]) for c in edges] + [pa.array(edges["dx_m"])]
    pq.write_table(pa.Table.from_arrays(cols, names=[*edges.columns, "dx_m"]), delivery / "e.pq")
    (delivery / "e.pq").rename(delivery / "edges.parquet")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "edges.parquet: column 'dx_m' appears more than once",
    )
    ids = pa.array([s.encode() for s in edges["point_id"]], pa.binary())
    table = pa.table({**{c: pa.array(edges[c].astype(float)) for c in ("dx_m", "dy_m", "dz_m")}})
    table = table.append_column("neighbour_block", pa.array(edges["neighbour_block"]))
    pq.write_table(table.append_column("point_id", ids), delivery / "edges.parquet")
    p = blockqc("inspect", delivery, "--out", tmp_path / "ok", "--no-pdf")
    assert p.returncode == 0, p.stderr
    doc = json.loads((tmp_path / "ok" / "CASE" / "results.json").read_text())
    edges_m = next(m for m in doc["measurements"] if m["metric"] == "edge_discrepancy")
    points = edges_m["tables"]["point"]
    assert {r["point_id"] for r in points} == {"E0", "E1", "E2", "E3", "E4"}


@pytest.mark.parametrize("stored", ["bytes", "text", "dictionary"])
def test_parquet_text_that_is_not_utf8_is_refused_at_its_row(
    blockqc, delivery: Path, tmp_path: Path, stored: str
) -> None:
    """Bytes that are not UTF-8, in a column of bytes, of text (Arrow keeps them as read) or
    of text read as a dictionary (the scene ids), in a later row group: refused at their row."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    tp = pd.read_csv(delivery / "tie_points.csv", dtype={"point_id": str, "scene_id": str})
    (delivery / "tie_points.csv").unlink()
    column = "scene_id" if stored == "dictionary" else "point_id"
    raw = [s.encode() for s in tp[column]]
    raw[6] = b"P\xff7"  # row 7
    values = pa.array(raw, pa.binary())
    if stored != "bytes":  # the same bytes typed as text, unchecked
        values = pa.Array.from_buffers(pa.string(), len(values), values.buffers())
    table = pa.table({c: tp[c] for c in tp}).set_column(
        list(tp.columns).index(column), column, values
    )
    pq.write_table(table, delivery / "tie_points.parquet", row_group_size=4)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        f"tie_points.parquet, row 7, column '{column}': text that is not UTF-8 (got the bytes "
        "b'P\\xff7'): expected UTF-8",
    )


def test_parquet_footprints_stored_as_wkb_are_said_to_be(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    """Footprints as WKB, the binary geometry GeoParquet stores, were refused as "text that is
    not UTF-8 … expected UTF-8": what the bytes are, and what is expected, is said."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    import shapely

    scenes = pd.read_csv(delivery / "scenes.csv", dtype={"scene_id": str})
    (delivery / "scenes.csv").unlink()
    wkb = shapely.to_wkb(shapely.from_wkt(scenes["footprint_wkt"].to_numpy()))
    table = pa.table({c: scenes[c] for c in scenes}).set_column(
        list(scenes.columns).index("footprint_wkt"), "footprint_wkt", pa.array(wkb, pa.binary())
    )
    pq.write_table(table, delivery / "scenes.parquet")
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "scenes.parquet, row 1, column 'footprint_wkt': a geometry in WKB (binary, as GeoParquet "
        "stores geometries): expected the footprint as WKT text",
    )


# ------------------------------------------------ tie-point keys held as Categoricals
def test_categorical_keys_by_hand() -> None:
    import pyarrow as pa

    from blockqc.delivery import _categorical

    col = pa.chunked_array([pa.array([" P1", "P2 ", "", None, "P1"]), pa.array(["  ", "P3"])])
    cat = _categorical(col)
    assert list(cat.categories) == ["P1", "P2", "P3"]
    assert cat.codes.tolist() == [0, 1, -1, -1, 0, -1, 2]  # blank and missing cells: missing


def test_categorical_keys_from_dictionaries_by_hand() -> None:
    """Dictionary columns (Parquet's, one dictionary per chunk): unified, stripped, and right
    even when a dictionary repeats a value (Arrow allows it)."""
    import pyarrow as pa

    from blockqc.delivery import _categorical

    first = pa.DictionaryArray.from_arrays(pa.array([0, 1, 0, None], pa.int32()), ["S1", "S2 "])
    second = pa.DictionaryArray.from_arrays(pa.array([1, 0], pa.int32()), ["S3", "S2"])
    cat = _categorical(pa.chunked_array([first, second]))
    assert sorted(cat.categories) == ["S1", "S2", "S3"]
    assert [cat.categories[c] if c >= 0 else None for c in cat.codes] == [
        "S1", "S2", "S1", None, "S2", "S3"
    ]  # fmt: skip
    repeated = pa.DictionaryArray.from_arrays(pa.array([0, 1, 2], pa.int32()), ["A", "B", "A"])
    cat = _categorical(pa.chunked_array([repeated]))
    assert list(cat.categories) == ["A", "B"] and cat.codes.tolist() == [0, 1, 0]
    empty = pa.chunked_array([], type=pa.dictionary(pa.int32(), pa.string()))  # no row group
    assert len(_categorical(empty)) == 0


def test_parquet_tie_points_empty_dictionary_ids(blockqc, delivery: Path, tmp_path: Path) -> None:
    """An empty table whose ids are dictionaries (an empty Categorical written out) is refused
    as an empty table, not as an unreadable file."""

    tp = _read_tie_points(delivery)
    (delivery / "tie_points.csv").unlink()
    empty = tp.iloc[:0].astype({"scene_id": "category"})
    empty.to_parquet(delivery / "tie_points.parquet", index=False)
    _refused(blockqc, delivery, tmp_path / "out", "tie_points.parquet: the table has a header")


def _read_tie_points(delivery: Path) -> pd.DataFrame:
    """The delivery's tie points as written (ids as text, numbers parsed back exactly)."""
    ids = {"point_id": str, "scene_id": str}
    return pd.read_csv(delivery / "tie_points.csv", dtype=ids, engine="pyarrow")


def _tie_points_as_parquet(delivery: Path, edit=None) -> None:
    tp = _read_tie_points(delivery)
    if edit is not None:
        edit(tp)
    (delivery / "tie_points.csv").unlink()
    tp.to_parquet(delivery / "tie_points.parquet", index=False)


def _judged_as_csv(blockqc, delivery: Path, tmp_path: Path, as_parquet) -> None:
    """The delivery inspected as given (CSV), then once `as_parquet()` has written its tie
    points as Parquet in their place: every rule judged alike, with the same value."""
    first = blockqc("inspect", delivery, "--out", tmp_path / "csv", "--no-pdf")
    as_parquet()
    second = blockqc("inspect", delivery, "--out", tmp_path / "pq", "--no-pdf")
    assert first.returncode == second.returncode, second.stderr
    a, b = (json.loads((tmp_path / d / "CASE" / "results.json").read_text()) for d in ("csv", "pq"))
    assert [(r["rule"], r["status"], r["value"]) for r in a["results"]] == [
        (r["rule"], r["status"], r["value"]) for r in b["results"]
    ]


def test_parquet_tie_points_with_padded_ids_judge_as_csv(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    def pad(tp: pd.DataFrame) -> None:  # ids padded with spaces: the same ids once stripped
        tp["point_id"] = " " + tp["point_id"]
        tp["scene_id"] = tp["scene_id"] + "  "

    _judged_as_csv(blockqc, delivery, tmp_path, partial(_tie_points_as_parquet, delivery, pad))


def test_parquet_tie_points_duplicated_key(blockqc, delivery: Path, tmp_path: Path) -> None:
    def damage(tp: pd.DataFrame) -> None:  # row 4 repeats row 3 once its id is stripped
        tp.loc[3, ["point_id", "scene_id"]] = [tp.loc[2, "point_id"] + " ", tp.loc[2, "scene_id"]]

    _tie_points_as_parquet(delivery, damage)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.parquet, row 3: duplicated key (point_id, scene_id)",
        "tie_points.parquet, row 4: duplicated key (point_id, scene_id)",
    )


def test_parquet_tie_points_blank_scene(blockqc, delivery: Path, tmp_path: Path) -> None:
    def damage(tp: pd.DataFrame) -> None:
        tp.loc[5, "scene_id"] = "   "

    _tie_points_as_parquet(delivery, damage)
    err = _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.parquet, row 6, column 'scene_id': empty value where one is required",
    )
    assert "unknown scene_id" not in err


def test_parquet_tie_points_written_from_categoricals(blockqc, delivery: Path, tmp_path: Path):
    """Ids stored as Parquet dictionaries (a pandas Categorical written out) are stripped and
    checked like plain text: a blank one is refused."""

    def damage(tp: pd.DataFrame) -> None:
        tp.loc[4, "point_id"] = " "
        tp["point_id"] = tp["point_id"].astype("category")
        tp["scene_id"] = (tp["scene_id"] + " ").astype("category")

    _tie_points_as_parquet(delivery, damage)
    _refused(
        blockqc,
        delivery,
        tmp_path / "out",
        "tie_points.parquet, row 5, column 'point_id': empty value where one is required",
    )


def test_parquet_tie_points_with_a_pandas_index_judge_as_csv(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    """Tie points written by pandas with their own index (rows renumbered from 1000): the index
    is one more column, kept untouched, and the rows judge as the CSV's."""

    def with_index() -> None:
        tp = _read_tie_points(delivery)
        (delivery / "tie_points.csv").unlink()
        tp.set_axis(tp.index + 1000).to_parquet(delivery / "tie_points.parquet", index=True)

    _judged_as_csv(blockqc, delivery, tmp_path, with_index)


@pytest.mark.parametrize("blank", [False, True])
def test_parquet_point_ids_encoded_while_reading_give_the_same(
    delivery: Path, monkeypatch, blank: bool
) -> None:
    """Point ids encoded by a second thread while the other columns are read (a large file)
    give the same tie points, or the same problems, as when they are encoded after the read."""
    from concurrent.futures import ThreadPoolExecutor

    from blockqc import delivery as reader
    from blockqc.errors import InputError

    def pad(tp: pd.DataFrame) -> None:
        tp["point_id"] = " " + tp["point_id"]
        if blank:
            tp.loc[4, "point_id"] = " "

    _tie_points_as_parquet(delivery, pad)

    def read() -> pd.DataFrame | list[str]:
        try:
            return reader.load_delivery(delivery).tie_points
        except InputError as exc:
            return [str(p) for p in exc.problems]

    after = read()
    encoders = []
    monkeypatch.setattr(reader, "EARLY_ROWS", 1)
    monkeypatch.setattr(
        reader, "ThreadPoolExecutor", lambda n: encoders.append(n) or ThreadPoolExecutor(n)
    )
    early = read()
    assert encoders == [1]  # the tie points' ids, and no other table's
    if blank:
        assert early == after and any("row 5, column 'point_id'" in m for m in early)
    else:
        pd.testing.assert_frame_equal(early, after)


def test_a_corrupt_row_group_of_a_parquet_table_is_located(blockqc, delivery, tmp_path):
    """A page of one row group damaged: the message was Arrow's alone ('Unexpected end of
    stream'), naming neither the row group nor its rows."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    text = {"point_id": pa.string(), "scene_id": pa.string()}
    table = pacsv.read_csv(
        delivery / "tie_points.csv", convert_options=pacsv.ConvertOptions(column_types=text)
    )
    (delivery / "tie_points.csv").unlink()
    target = delivery / "tie_points.parquet"
    size = len(table) // 3 + 1  # three row groups
    pq.write_table(table, target, row_group_size=size, compression="none")
    chunk = pq.ParquetFile(target).metadata.row_group(1).column(4)  # v_line of group 1
    data = bytearray(target.read_bytes())
    start = chunk.data_page_offset
    data[start : start + 24] = b"\xff" * 24  # its page header
    target.write_bytes(bytes(data))
    p = blockqc("inspect", delivery, "--out", tmp_path / "out")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    rows = f"rows {size + 1}–{2 * size}"
    assert f"tie_points.parquet: not a readable Parquet table (row group 1, {rows})" in p.stderr
    assert all(c.isprintable() for c in p.stderr.replace("\n", ""))  # Arrow quotes the bytes


def test_parquet_ids_stored_as_decimal_numbers_are_read_as_their_whole_numbers(
    blockqc, delivery: Path, tmp_path: Path
) -> None:
    """Scene ids 1001… in scenes.csv, and tie points written from a numeric array (ids as
    doubles, 1001.0): the ids were read as '1001.0', unknown, with "did you mean '1010'?"; a
    point id as '3.0' where the same file read column by column (`columns: used`) gave '3'.
    A double holding a whole number is read as that number's text, as an integer id is."""
    numbers = {f"S{i}": str(1000 + i) for i in range(1, 5)} | {"M1": "1005"}
    for name in ("scenes", "tie_points", "overlaps", "pan_ms"):
        table = pd.read_csv(delivery / f"{name}.csv", dtype=str, keep_default_na=False)
        table = table.replace(numbers)
        table.to_csv(delivery / f"{name}.csv", index=False)

    def as_doubles(tp: pd.DataFrame) -> None:
        tp["scene_id"] = tp["scene_id"].astype(float)
        tp["point_id"] = pd.factorize(tp["point_id"])[0] + 1.0

    _judged_as_csv(
        blockqc, delivery, tmp_path, partial(_tie_points_as_parquet, delivery, as_doubles)
    )
    from blockqc.delivery import read_table
    from blockqc.schema import TIE_POINTS

    tp, problems = read_table(delivery / "tie_points.parquet", TIE_POINTS)
    assert problems == [] and tp["point_id"].iloc[0] == "1" and tp["scene_id"].iloc[0] == "1001"

    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(delivery / "tie_points.parquet")
    ids = table.column("scene_id").to_numpy().copy()
    ids[2] = float("nan")  # stored as a value, not as a null: no id
    table = table.set_column(1, "scene_id", pa.array(ids, from_pandas=False))
    pq.write_table(table, delivery / "tie_points.parquet")
    _refused(
        blockqc,
        delivery,
        tmp_path / "nan",
        "tie_points.parquet, row 3, column 'scene_id': empty value where one is required",
    )
