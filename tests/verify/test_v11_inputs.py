"""Contract v1.1 inputs: bad geometry refused with file and row; `inspect --checkpoints`."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pandas as pd
import pytest
from geokit import ground_points, observe, write_v11

from blockqc.delivery import load_delivery
from blockqc.errors import InputError
from casekit import base_tables, write_delivery


@pytest.fixture(scope="module")
def tie_points() -> pd.DataFrame:
    return observe(ground_points(12, seed=3), noise_px=0.0, seed=3)


def _problems(folder: Path) -> list[str]:
    with pytest.raises(InputError) as exc:
        load_delivery(folder)
    return [str(p) for p in exc.value.problems]


def test_missing_rpc_names_scene_and_folder(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "R.geom").unlink()
    (msg,) = _problems(folder)
    assert str(folder / "rpc") in msg and "no RPC for scene 'R'" in msg and "rpc/R.<ext>" in msg


def test_unreadable_rpc_names_the_file(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "R.geom").write_text("this is not an RPC\n")
    (msg,) = _problems(folder)
    assert msg.startswith(str(folder / "rpc" / "R.geom"))


def test_adjustment_row_for_unknown_scene(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    with open(folder / "adjustment.csv", "a") as fh:
        fh.write("X9,0,0,0,0,0,0\n")
    (msg,) = _problems(folder)
    assert "adjustment.csv, row 3 (line 4), column 'scene_id'" in msg and "'X9'" in msg


def _with_scene_m(folder: Path) -> Path:
    """A scene M in scenes.csv (L's row under another id), without RPC file nor tie points."""
    scenes = pd.read_csv(folder / "scenes.csv")
    scenes = pd.concat([scenes, scenes.iloc[[0]].assign(scene_id="M")])
    scenes.to_csv(folder / "scenes.csv", index=False)
    return folder


def test_adjustment_row_for_a_scene_without_rpc_is_refused_by_both_commands(
    tmp_path, tie_points, blockqc
) -> None:
    """A row of adjustment.csv for scene M, in scenes.csv but without RPC file nor tie points:
    inspect passed it over unsaid, adjust refused 'no RPC for scene(s) M'. Both refuse the
    row, by the loading of the geometry they share."""
    folder = _with_scene_m(write_v11(tmp_path / "d", tie_points))
    with open(folder / "adjustment.csv", "a") as fh:
        fh.write("M,0,0,0,0,0,0\n")
    expected = (
        f"{folder / 'adjustment.csv'}, row 3 (line 4), column 'scene_id': scene 'M' has no RPC "
        "file in rpc/ (expected rpc/M.<ext>): the affine of this row refines the scene's "
        "original RPC"
    )
    assert _problems(folder) == [expected]
    for command, extra in (("inspect", ("--no-pdf",)), ("adjust", ())):
        proc = blockqc(command, folder, "--out", tmp_path / command, *extra)
        assert proc.returncode == 2, command
        assert f"error: {expected}\n" in proc.stderr and "Traceback" not in proc.stderr


def test_a_scene_without_rpc_nor_observations_is_said_by_inspect(tmp_path, tie_points) -> None:
    """Scene M in scenes.csv, without RPC file, tie points or adjustment row: inspected without
    it, as the contract allows, but no longer unsaid (adjust leaves it out, said)."""
    from blockqc.engine import input_warnings

    folder = _with_scene_m(write_v11(tmp_path / "d", tie_points))
    d = load_delivery(folder)
    assert input_warnings(d) == [
        f"{folder / 'rpc'}: no RPC file for scene(s) 'M' of the scenes table, which have no "
        "tie-point observations (expected rpc/<scene_id>.<ext> for every scene): inspected "
        "without them; blockqc adjust leaves them out, not adjusted"
    ]
    assert input_warnings(load_delivery(write_v11(tmp_path / "full", tie_points))) == []


def test_adjustment_non_finite_and_missing_row(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "adjustment.csv").write_text("scene_id,a0,a1,a2,b0,b1,b2\nL,0,inf,0,0,0,0\n")
    msgs = _problems(folder)
    assert any("row 1 (line 2), column 'a1'" in m and "not finite" in m for m in msgs)
    assert any("no row for scene 'R'" in m for m in msgs)


def test_adjustment_with_terms_the_affine_has_not_is_refused(tmp_path, tie_points) -> None:
    """a3, b3 (a second-order model) were kept and ignored: the residuals judged were those of
    the affine alone, not of the producer's model."""
    folder = write_v11(tmp_path / "d", tie_points)
    table = pd.read_csv(folder / "adjustment.csv").assign(a3=1e-6, B3=0.0, note="v2")
    table.to_csv(folder / "adjustment.csv", index=False)
    msgs = _problems(folder)
    assert [m.split(": a term")[0] for m in msgs] == [
        f"{folder / 'adjustment.csv'}, column 'a3'",
        f"{folder / 'adjustment.csv'}, column 'B3'",
    ]  # the note, a column of no model, is kept and ignored as in any table


def test_adjustment_without_rpc_folder(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    shutil.rmtree(folder / "rpc")
    msgs = _problems(folder)
    assert any("rpc/ is missing" in m for m in msgs)


def test_rpc_for_unknown_scene_and_no_residuals_without_adjustment(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points.drop(columns=[]), adjustment=False)
    shutil.copy(folder / "rpc" / "L.geom", folder / "rpc" / "Z.geom")
    msgs = _problems(folder)
    assert any(m.startswith(str(folder / "rpc" / "Z.geom")) for m in msgs)
    assert any("missing column 'v_line'" in m and "rpc_adjusted" in m for m in msgs)


GEOMETRY_BELOW = (
    "not read there: the geometry of contract v1.1 is read from the delivery's own folder "
    "({0}/ beside block.yaml)"
)


@pytest.mark.parametrize(
    ("moved", "to", "meant"),
    [
        ("rpc", "geometry/rpc", "rpc"),
        ("rpc", "documents/annex/RPC", "rpc"),
        ("rpc_adjusted", "producer/rpc_adjusted", "rpc_adjusted"),
    ],
)
def test_geometry_in_a_sub_folder_is_refused_not_taken_for_v1(
    tmp_path, tie_points, moved, to, meant
) -> None:
    """The geometry a folder or more down (rpc/ moved to geometry/rpc/, adjustment.csv not
    given) was not looked for: the delivery was judged as one of contract v1, without
    geometry. It is refused naming the folder, as RPC/ beside block.yaml is."""
    ties = tie_points.assign(v_line=0.0, v_sample=0.0)  # residuals delivered: v1 reads them
    folder = write_v11(tmp_path / "d", ties, adjustment=False)
    if moved == "rpc_adjusted":  # the original RPCs beside block.yaml, the refined ones not
        shutil.copytree(folder / "rpc", folder / "rpc_adjusted")
    (folder / to).parent.mkdir(parents=True, exist_ok=True)
    (folder / moved).rename(folder / to)
    assert _problems(folder) == [f"{folder / to}: {GEOMETRY_BELOW.format(meant)}"]


@pytest.mark.parametrize("where", ["geometry", "geometry/2024/final"])
def test_an_adjustment_table_in_a_sub_folder_is_refused(tmp_path, tie_points, where) -> None:
    """Refused one folder down ('holds a adjustment table'), not looked for further down."""
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / where).mkdir(parents=True)
    (folder / "adjustment.csv").rename(folder / where / "adjustment.csv")
    msgs = _problems(folder)
    assert (
        f"{folder / where}: holds an adjustment table, not read there: tables are read from "
        "the delivery's own folder (adjustment.csv or adjustment.parquet beside block.yaml)"
    ) in msgs


def test_a_copy_of_the_geometry_below_the_geometry_read_is_left_as_a_document(
    tmp_path, tie_points
) -> None:
    """rpc/ and adjustment.csv beside block.yaml, and a copy of both in documents/annex/: the
    geometry is read from the delivery's own folder, the copy is a document."""
    folder = write_v11(tmp_path / "d", tie_points)
    annex = folder / "documents" / "annex"
    shutil.copytree(folder / "rpc", annex / "rpc")
    shutil.copy(folder / "adjustment.csv", annex / "adjustment.csv")
    d = load_delivery(folder)
    assert d.geometry is not None and d.geometry.complete
    assert sorted(d.geometry.original) == ["L", "R"]


def test_an_rpc_file_named_with_an_invisible_character_shows_it(tmp_path, tie_points) -> None:
    """rpc/L\u200b.geom (a zero-width space pasted after the scene id) was said to be of "no
    scene 'L'", the scene that has no RPC, as if they were one: the character is shown."""
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "L.geom").rename(folder / "rpc" / "L\u200b.geom")
    msgs = _problems(folder)
    assert "no scene 'L\\u200b' in the scenes table" in msgs[0]
    assert "no RPC for scene 'L'" in msgs[1]


@pytest.mark.parametrize(
    ("name", "sid"),
    [("L_rpc.txt", "L_rpc"), ("L_RPC.TXT", "L_RPC"), ("L.rpc.geom", "L.rpc"), ("l.geom", "l")],
)
def test_a_misnamed_rpc_file_names_the_likely_scene(tmp_path, tie_points, name, sid) -> None:
    """rpc/L_rpc.txt (a vendor's suffix kept) and rpc/l.geom (another case) were of 'no scene'
    without a word of scene L, which then had no RPC: the likely scene is named."""
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "L.geom").rename(folder / "rpc" / name)
    msgs = _problems(folder)
    assert msgs[0] == (
        f"{folder / 'rpc' / name}: no scene '{sid}' in the scenes table: expected "
        "<scene_id>.<ext>; did you mean 'L'?"
    )
    assert "no RPC for scene 'L'" in msgs[1]


def test_an_rpc_file_of_no_scene_alike_is_named_without_a_guess(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    shutil.copy(folder / "rpc" / "L.geom", folder / "rpc" / "notes_rpc.txt")
    assert _problems(folder) == [
        f"{folder / 'rpc' / 'notes_rpc.txt'}: no scene 'notes_rpc' in the scenes table: "
        "expected <scene_id>.<ext>"
    ]


def test_an_rpc_entry_that_is_no_file_is_said_to_be_what_it_is(tmp_path, tie_points) -> None:
    """rpc/L.geom a link to a file that does not exist, rpc/R a folder: each was said to be
    'expected an RPC file named <scene_id>.<ext>', which it is, and its scene to have 'no
    RPC' beside it. Each is now said to be what it is, once."""
    folder = write_v11(tmp_path / "d", tie_points)
    rpc = folder / "rpc"
    (rpc / "L.geom").unlink()
    (rpc / "L.geom").symlink_to(tmp_path / "moved" / "L.geom")
    (rpc / "R.geom").unlink()
    (rpc / "R").mkdir()
    assert _problems(folder) == [
        f"{rpc / 'L.geom'}: a symbolic link to {tmp_path / 'moved' / 'L.geom'}, which does not "
        "exist: expected an RPC file",
        f"{rpc / 'R'}: is a folder, not a file: expected an RPC file",
    ]


@pytest.mark.parametrize("name", ["rpc", "rpc_adjusted"])
def test_a_geometry_folder_linked_to_nothing_is_refused(tmp_path, tie_points, name) -> None:
    """rpc/ or rpc_adjusted/ a link to a folder moved away, the tie points giving residuals: a
    delivery without adjustment.csv was inspected as one of contract v1, or without the
    producer's adjustment, without a word (rpc/ with adjustment.csv was said to be missing)."""
    residuals = tie_points.assign(v_line=0.0, v_sample=0.0)
    folder = write_v11(tmp_path / "d", residuals, adjustment=False)
    if name == "rpc":
        shutil.rmtree(folder / "rpc")
    (folder / name).symlink_to(tmp_path / "moved")
    assert _problems(folder) == [
        f"{folder / name}: a symbolic link to {tmp_path / 'moved'}, which does not exist: "
        "expected a folder of RPC files <scene_id>.<ext>"
    ]


def test_an_rpc_folder_holding_a_folder_of_no_scene_names_it(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "old").mkdir()
    assert _problems(folder) == [
        f"{folder / 'rpc' / 'old'}: expected an RPC file named <scene_id>.<ext>"
    ]


def test_refined_rpc_of_another_place_is_refused(tmp_path, tie_points) -> None:
    """rpc_adjusted/R with its latitude and longitude offsets swapped (lon ~44°, lat ~5°): its
    ground domain was checked for rpc/ only, so every point was left not intersected and,
    without delivered residuals, the tie-point rules judged none of them."""
    import dataclasses

    from geokit import FILES

    from blockqc.adjust.synthetic import rpc_json
    from blockqc.rfm.readers import read_rpc

    folder = write_v11(tmp_path / "d", tie_points, adjustment=False)
    (folder / "rpc_adjusted").mkdir()
    for sid, f in FILES.items():
        rpc = read_rpc(f)
        if sid == "R":
            rpc = dataclasses.replace(rpc, lat_off=rpc.lon_off, lon_off=rpc.lat_off)
        (folder / "rpc_adjusted" / f"{sid}.json").write_text(rpc_json(rpc))
    (msg,) = _problems(folder)
    assert msg.startswith(f"{folder / 'rpc_adjusted' / 'R.json'}: the RPC's ground domain")
    assert "does not overlap the footprint_wkt of scene 'R' in scenes.csv" in msg


def test_the_rpc_of_a_smaller_image_is_refused(tmp_path, tie_points) -> None:
    """The MS image's RPC (10,556 lines) given for the PAN scene R (about 42,000): same place,
    so the ground domain passed; RC-1 then failed at 20,000 px, naming no file."""
    from geokit import RPCS

    from blockqc.rfm.readers import read_rpc

    folder = write_v11(tmp_path / "d", tie_points)
    shutil.copy(RPCS / "lowres_color_image.geom", folder / "rpc" / "R.geom")
    ms = read_rpc(RPCS / "lowres_color_image.geom")
    lines, samples = (
        pd.read_csv(folder / "scenes.csv").set_index("scene_id").loc["R", ["lines", "samples"]]
    )
    (msg,) = _problems(folder)
    assert msg.startswith(
        f"{folder / 'rpc' / 'R.geom'}: the RPC's image domain (lines to "
        f"{ms.line_off + 2 * ms.line_scale:.0f}, samples to {ms.samp_off + 2 * ms.samp_scale:.0f}"
    )
    assert f"does not hold scene 'R' of scenes.csv ({lines} lines × {samples} samples)" in msg


def test_rpc_files_of_dotted_scene_ids_with_or_without_extension(tmp_path, tie_points) -> None:
    """Scene ids ZY3.L and ZY3.R: rpc/ZY3.L.geom was read, rpc/ZY3.L (no extension) refused
    as 'no scene ZY3'."""
    folder = write_v11(tmp_path / "d", tie_points.assign(scene_id="ZY3." + tie_points["scene_id"]))
    scenes = pd.read_csv(folder / "scenes.csv")
    scenes.assign(scene_id="ZY3." + scenes["scene_id"]).to_csv(folder / "scenes.csv", index=False)
    adjustment = pd.read_csv(folder / "adjustment.csv")
    adjustment.assign(scene_id="ZY3." + adjustment["scene_id"]).to_csv(
        folder / "adjustment.csv", index=False
    )
    (folder / "rpc" / "L.geom").rename(folder / "rpc" / "ZY3.L")
    (folder / "rpc" / "R.geom").rename(folder / "rpc" / "ZY3.R.geom")
    d = load_delivery(folder)
    assert sorted(d.geometry.original) == ["ZY3.L", "ZY3.R"]


def test_bad_geometry_exits_2(tmp_path, tie_points, blockqc) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    (folder / "rpc" / "L.geom").unlink()
    proc = blockqc("inspect", folder, "--out", tmp_path / "out", "--no-pdf")
    assert proc.returncode == 2
    assert "no RPC for scene 'L'" in proc.stderr and "Traceback" not in proc.stderr


# ------------------------------------------------------------------ inspect --checkpoints
def _recalculation(n: int = 25, gross_m: float = 25.0) -> pd.DataFrame:
    """The delivered checkpoints' positions against a recalculation: Δ plane 5 m, height 2 m,
    except the first point, 25 m off in plane (inside 2√2·m = 28.3 m, a gross error at 2·m)."""
    cp = base_tables()["checkpoints"].head(n).copy()
    cp["method"] = "recalculation"
    cp["reference_id"] = "recalc"
    cp.loc[0, ["ref_x_m", "ref_y_m"]] = cp.loc[0, ["x_m", "y_m"]].to_numpy() - [15.0, 20.0]
    assert math.hypot(15.0, 20.0) == gross_m
    return cp


def _cp(doc: dict, rule: str, component: str, method: str) -> dict:
    return next(
        r
        for r in doc["results"]
        if r["rule"] == rule and r["group"] == {"component": component, "method": method}
    )


def test_checkpoints_merged_as_recalculation(tmp_path, blockqc) -> None:
    folder = write_delivery(tmp_path / "d")
    extra = tmp_path / "recalc.csv"
    _recalculation().to_csv(extra, index=False)
    out = tmp_path / "out"
    proc = blockqc("inspect", folder, "--out", out, "--no-pdf", "--checkpoints", extra)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    doc = json.loads((out / "CASE" / "results.json").read_text())
    plane = _cp(doc, "CP-2", "plane", "recalculation")
    # M2 = √(ΣΔ²/(2n)) over 25 points: 24 at 5 m and one at 25 m (§CP-5)
    assert plane["value"] == pytest.approx(math.sqrt((24 * 25 + 625) / 50))
    assert plane["detail"]["n_gross"] == 0  # 25 m ≤ 2√2·10 m: not gross for recalculation
    height = _cp(doc, "CP-3", "height", "recalculation")
    assert height["value"] == pytest.approx(2 / math.sqrt(2))
    # beside the delivered high-precision method
    assert _cp(doc, "CP-2", "plane", "high_precision")["value"] == pytest.approx(5.0)
    assert doc["process_data"]["inspector_checkpoints"] == {str(extra): 25}
    report = (out / "CASE" / "report.html").read_text()
    assert "High-precision data / Recalculation with other software" in report


def test_checkpoints_conflicts_and_blocks_exit_2(tmp_path, blockqc) -> None:
    batch = tmp_path / "batch"
    write_delivery(batch / "a")
    write_delivery(batch / "b", {"manifest": {"block_id": "CASE-B"}})
    dup = tmp_path / "dup.csv"
    base_tables()["checkpoints"].head(2).to_csv(dup, index=False)
    args = ("--no-pdf", "--checkpoints")
    proc = blockqc("inspect", batch / "a", "--out", tmp_path / "o1", *args, dup)
    assert proc.returncode == 2
    assert f"{dup}, row 1" in proc.stderr and "is also in" in proc.stderr
    plain = tmp_path / "plain.csv"
    _recalculation(3).to_csv(plain, index=False)
    proc = blockqc("inspect", batch, "--out", tmp_path / "o2", *args, plain)
    assert proc.returncode == 2 and "block_id" in proc.stderr
    named = tmp_path / "named.csv"
    _recalculation(3).assign(block_id="NOPE").to_csv(named, index=False)
    proc = blockqc("inspect", batch, "--out", tmp_path / "o3", "--no-pdf", "--checkpoints", named)
    assert (
        proc.returncode == 2
        and "no block 'NOPE'" in proc.stderr
        and f"{named}, row 1" in proc.stderr
    )


def test_a_file_of_several_blocks_numbers_each_blocks_points(tmp_path, blockqc) -> None:
    """Block ids are text as block.yaml gives them ('0012', not 12), and each block may number
    its points as the others do: a point id given again in one block is still refused."""
    batch = tmp_path / "batch"
    for block_id in ("0012", "0013"):
        write_delivery(batch / block_id, {"manifest": {"block_id": block_id}})
    both = tmp_path / "recalc.csv"
    rows = [_recalculation(3).assign(block_id=b) for b in ("0012", "0013")]
    pd.concat(rows).to_csv(both, index=False)
    out = tmp_path / "out"
    proc = blockqc("inspect", batch, "--out", out, "--no-pdf", "--checkpoints", both)
    assert proc.returncode in (0, 1), proc.stderr
    for block_id in ("0012", "0013"):
        doc = json.loads((out / block_id / "results.json").read_text())
        assert doc["process_data"]["inspector_checkpoints"] == {str(both): 3}
    pd.concat([*rows, rows[0].head(1)]).to_csv(both, index=False)
    proc = blockqc("inspect", batch, "--out", tmp_path / "o2", "--no-pdf", "--checkpoints", both)
    assert proc.returncode == 2
    assert f"{both}, row 7 (line 8): duplicated key (block_id, point_id, method)" in proc.stderr


def test_checkpoints_of_a_block_whose_manifest_cannot_be_read_are_not_unknown(
    tmp_path, blockqc
) -> None:
    """A batch block whose block.yaml is refused (a GSD below 0) has a block id no run knows:
    its checkpoint rows were refused as naming "no block among the deliveries inspected", the
    run stopped there and the block.yaml's own problem went unsaid. Block ids are now checked
    when every block id is known, as a verdicts file's are."""
    batch = tmp_path / "batch"
    write_delivery(batch / "a")
    write_delivery(batch / "b", {"manifest": {"block_id": "CASE-B", "gsd_m": {"pan": -1.0}}})
    both = tmp_path / "recalc.csv"
    rows = [_recalculation(3).assign(block_id=b) for b in ("CASE", "CASE-B")]
    pd.concat(rows).to_csv(both, index=False)
    out = tmp_path / "out"
    proc = blockqc("inspect", batch, "--out", out, "--no-pdf", "--checkpoints", both)
    assert proc.returncode == 2, proc.stderr
    assert "no block 'CASE-B'" not in proc.stderr
    assert f"{batch / 'b' / 'block.yaml'}" in proc.stderr and "gsd_m.pan" in proc.stderr
    doc = json.loads((out / "CASE" / "results.json").read_text())
    assert doc["process_data"]["inspector_checkpoints"] == {str(both): 3}


def test_rows_refused_across_the_inspectors_files_name_their_lines(tmp_path, blockqc) -> None:
    """A checkpoint given in two files, and a row without its block_id, were named by their row
    alone, where every other refused row of a CSV file is named by its line too."""
    write_delivery(tmp_path / "a")
    first, second = tmp_path / "first.csv", tmp_path / "second.csv"
    _recalculation(3).to_csv(first, index=False)
    _recalculation(3).iloc[[1]].to_csv(second, index=False)
    proc = blockqc(
        "inspect", tmp_path / "a", "--out", tmp_path / "o", "--no-pdf",
        "--checkpoints", first, "--checkpoints", second,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert f"{second}, row 1 (line 2): checkpoint" in proc.stderr and "is also in" in proc.stderr
    _recalculation(3).assign(block_id=["CASE", "", "CASE"]).to_csv(first, index=False)
    args = ("--no-pdf", "--checkpoints", first)
    proc = blockqc("inspect", tmp_path / "a", "--out", tmp_path / "o", *args)
    assert proc.returncode == 2, proc.stderr
    assert f"{first}, row 2 (line 3), column 'block_id': empty" in proc.stderr


@pytest.mark.parametrize("header", ["Block_ID", "blockid", "block-id"])
def test_a_misspelt_block_id_column_is_refused(tmp_path, blockqc, header) -> None:
    """Its blocks would go unread and every row be merged into the one block inspected."""
    write_delivery(tmp_path / "a")
    extra = tmp_path / "recalc.csv"
    _recalculation(3).assign(**{header: "OTHER-BLOCK"}).to_csv(extra, index=False)
    proc = blockqc(
        "inspect", tmp_path / "a", "--out", tmp_path / "o", "--no-pdf", "--checkpoints", extra
    )
    assert proc.returncode == 2, proc.stderr
    assert (
        f"error: {extra}, line 1: column '{header}': did you mean 'block_id'? (the block of each "
        "row is read from it)"
    ) in proc.stderr


def test_the_same_checkpoints_file_given_twice_is_named_once(tmp_path, blockqc) -> None:
    """Named again, by the same path or another path to it (a link): refused as the file given
    twice, not row by row as checkpoints that are also in themselves. The same path is refused
    as any repeated value of a repeatable option is, before anything is read."""
    write_delivery(tmp_path / "a")
    extra = tmp_path / "recalc.csv"
    _recalculation(3).to_csv(extra, index=False)
    (tmp_path / "link.csv").symlink_to(extra)
    for again in (extra, tmp_path / "link.csv"):
        proc = blockqc(
            "inspect", tmp_path / "a", "--out", tmp_path / "o", "--no-pdf",
            "--checkpoints", extra, "--checkpoints", again,
        )  # fmt: skip
        assert proc.returncode == 2, proc.stderr
        said = (
            f"Error: --checkpoints {extra} given twice: give each --checkpoints once"
            if again == extra
            else f"error: {again}: given twice to --checkpoints (also as {extra}): give it once"
        )
        assert said in proc.stderr
        assert "is also in" not in proc.stderr and not (tmp_path / "o").exists()


def test_rpc_adjusted_equals_adjustment_csv(tmp_path) -> None:
    """A shift-only adjustment (a0, b0) is the same model as RPCs with LINE_OFF + a0 and
    SAMP_OFF + b0: rpc_adjusted/ and rpc/ + adjustment.csv give the same residuals."""
    import dataclasses

    from geokit import FILES

    from blockqc.adjust.synthetic import rpc_json
    from blockqc.engine import inspect_delivery
    from blockqc.results import dump
    from blockqc.rfm.model import ImageAffine, RefinedRFM
    from blockqc.rfm.readers import read_rpc
    from blockqc.rules import load_pack

    shift = {"L": (3.0, -1.5), "R": (-2.5, 0.75)}
    ground = ground_points(20, seed=5)
    rows = []
    for sid, f in FILES.items():
        model = RefinedRFM(read_rpc(f), ImageAffine(a0=-shift[sid][0], b0=-shift[sid][1]))
        line, sample = model.ground_to_image(ground["lon"], ground["lat"], ground["h"])
        rows.append(pd.DataFrame({"point_id": ground["point_id"], "scene_id": sid}))
        rows[-1]["line"] = line + 4.0 * (sid == "L")  # one ray off: non-zero residuals
        rows[-1]["sample"] = sample
    obs = pd.concat(rows, ignore_index=True)
    a = write_v11(tmp_path / "a", obs, adjustment=False)
    (a / "adjustment.csv").write_text(
        "scene_id,a0,a1,a2,b0,b1,b2\n"
        + "".join(f"{s},{x},0,0,{y},0,0\n" for s, (x, y) in shift.items())
    )
    b = write_v11(tmp_path / "b", obs, adjustment=False)
    (b / "rpc_adjusted").mkdir()
    for sid, f in FILES.items():
        rpc = read_rpc(f)
        moved = dataclasses.replace(
            rpc, line_off=rpc.line_off + shift[sid][0], samp_off=rpc.samp_off + shift[sid][1]
        )
        (b / "rpc_adjusted" / f"{sid}.json").write_text(rpc_json(moved))
    got = {}
    for name, folder in (("a", a), ("b", b)):
        d = load_delivery(folder)
        doc = dump(inspect_delivery(d, load_pack("global-project")))
        got[name] = d.tie_points[["v_line", "v_sample"]].to_numpy()
        assert doc["process_data"]["geometry"] == (
            "adjustment.csv" if name == "a" else "rpc_adjusted/"
        )
    assert abs(got["a"]).max() > 0.1
    assert got["a"] == pytest.approx(got["b"], abs=1e-6)


def test_adjust_checkpoints_flow_into_inspect(tmp_path, blockqc) -> None:
    """`blockqc adjust`'s checkpoints.csv (method recalculation) through `inspect --checkpoints`
    into the results and the report, beside the delivered high-precision checkpoints."""
    import yaml
    from geokit import FILES

    from blockqc.adjust.synthetic import SyntheticConfig, synthetic_block
    from blockqc.rfm.readers import read_rpc

    models = [read_rpc(f) for f in FILES.values()]
    cfg = SyntheticConfig(scenes=6, observations_per_scene=400, checkpoints=25, seed=4)
    _, folder = synthetic_block(models, cfg, tmp_path / "d")
    manifest = yaml.safe_load((folder / "block.yaml").read_text())
    manifest["gsd_m"]["ms"] = 4 * manifest["gsd_m"]["pan"]  # RO-1's threshold names gsd.ms
    (folder / "block.yaml").write_text(yaml.safe_dump(manifest))
    proc = blockqc("adjust", folder, "--out", tmp_path / "adj")
    assert proc.returncode == 0, proc.stderr
    recalc = tmp_path / "adj" / "checkpoints.csv"
    out = tmp_path / "out"
    proc = blockqc("inspect", folder, "--out", out, "--no-pdf", "--checkpoints", recalc)
    assert proc.returncode in (0, 1), proc.stdout + proc.stderr
    doc = json.loads((out / manifest["block_id"] / "results.json").read_text())
    cp = pd.read_csv(recalc)
    d_plane = ((cp["x_m"] - cp["ref_x_m"]) ** 2 + (cp["y_m"] - cp["ref_y_m"]) ** 2).to_numpy()
    plane = _cp(doc, "CP-2", "plane", "recalculation")
    assert plane["detail"]["statistic"] == "M2"
    gross = d_plane > (2 * math.sqrt(2) * 10) ** 2
    kept = d_plane[~gross]
    assert plane["value"] == pytest.approx(math.sqrt(kept.sum() / (2 * kept.size)), rel=1e-9)
    assert _cp(doc, "CP-2", "plane", "high_precision")["status"] in ("pass", "fail")
    report = (out / manifest["block_id"] / "report.html").read_text()
    assert "High-precision data / Recalculation with other software" in report


def test_adjustment_missing_column_is_named_not_a_crash(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    table = pd.read_csv(folder / "adjustment.csv").drop(columns=["b2"])
    table.to_csv(folder / "adjustment.csv", index=False)
    msgs = _problems(folder)
    assert any("adjustment.csv" in m and "missing column 'b2'" in m for m in msgs), msgs
    # the tie points give no residuals, as the geometry allows: not a second, wrong problem
    # saying they may be absent only when the delivery gives its geometry (it does)
    assert not any("v_line" in m or "v_sample" in m for m in msgs), msgs


@pytest.mark.parametrize(
    "damage",
    [
        "adjustment.csv: scene_id;a0;a1;a2;b0;b1;b2",  # semicolons: the table cannot be read
        "adjustment.csv: ",  # empty
        "scenes.csv: ",  # the adjustment is read, but the scenes it refers to cannot be
    ],
)
def test_an_unreadable_table_does_not_say_the_residuals_must_be_given(
    tmp_path, tie_points, damage
) -> None:
    """The tie points give no residuals, and the delivery gives rpc/ and adjustment.csv. When
    the adjustment table (or the scenes table the geometry is read against) could not be
    read, two more problems said 'missing column v_line … they may be absent only when the
    delivery gives its geometry: rpc/ with adjustment.csv', which it does: only the table's
    own problem is said."""
    folder = write_v11(tmp_path / "d", tie_points)
    name, text = damage.split(": ")
    (folder / name).write_text(text + "\n" if text else "")
    msgs = _problems(folder)
    assert msgs and all(m.startswith(str(folder / name)) for m in msgs), msgs


def test_residuals_absent_without_any_adjustment_are_still_refused(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points, adjustment=False)
    tp = str(folder / "tie_points.csv")
    why = (
        "they may be absent only when the delivery gives its geometry: rpc/ with "
        "adjustment.csv, or rpc_adjusted/"
    )
    assert _problems(folder) == [
        f"{tp}: missing column 'v_line' (expected a column of numbers; {why})",
        f"{tp}: missing column 'v_sample' (expected a column of numbers; {why})",
    ]


def test_rpc_denominator_of_zeros_is_refused() -> None:
    import dataclasses

    from blockqc.rfm.model import RPCModel

    fields = {f.name for f in dataclasses.fields(RPCModel)}
    model = dict.fromkeys(fields & {f"{a}_{b}" for a in ("line", "samp", "lat", "lon", "height")
                                    for b in ("off", "scale")}, 1.0)  # fmt: skip
    model.update(line_num=[1.0] * 20, samp_num=[1.0] * 20, samp_den=[1.0] + [0.0] * 19)
    model.update(line_den=[0.0] * 20, source="rpc/S1.json")
    with pytest.raises(InputError) as exc:
        RPCModel(**model)
    assert "rpc/S1.json" in str(exc.value.problems[0]) and "LINE_DEN" in str(exc.value.problems[0])


@pytest.mark.parametrize(
    "row, terms",
    [
        ("L,0,0,1,0,0,0", "0, 1, 0, 0"),  # a2 = 1: (1 − 1) l, the affine collapses the lines
        ("L,0,0,2,0,0,0", "0, 2, 0, 0"),  # (1 − 2) l: the lines mirrored
        ("L,0,1,1,0,1,-1", "1, 1, 1, -1"),  # a quarter turn (determinant 1)
        ("L,0,0,-0.4,0,0.3,0", "0, -0.4, 0.3, 0"),  # lines stretched 1.4×, samples 0.7×
        ("L,0,0.2,0,0,0,-0.2", "0.2, 0, 0, -0.2"),  # a turn of 11°
    ],
)
def test_an_affine_that_cannot_be_a_correction_is_refused(tmp_path, tie_points, row, terms):
    """A determinant between 0.5 and 2 let rotations and stretches through (RC-1 then failed at
    thousands of pixels without saying why)."""
    folder = write_v11(tmp_path / "d", tie_points)
    lines = (folder / "adjustment.csv").read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("L,"))
    lines[at] = row
    (folder / "adjustment.csv").write_text("\n".join(lines) + "\n")
    (msg,) = _problems(folder)
    assert f"adjustment.csv, row {at} (line {at + 1}), column 'a1, a2, b1, b2'" in msg
    assert f"scene 'L': the affine's terms per pixel (a1, a2, b1, b2) are ({terms}); " in msg
    assert "expected each within ±0.1" in msg


def test_an_affine_of_a_real_correction_is_read(tmp_path, tie_points) -> None:
    folder = write_v11(tmp_path / "d", tie_points)
    lines = (folder / "adjustment.csv").read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("L,"))
    lines[at] = "L,12.5,2e-4,-3e-4,-8.0,1e-4,5e-5"  # det = (1 + 3e-4)(1 − 1e-4) − 1e-8
    (folder / "adjustment.csv").write_text("\n".join(lines) + "\n")
    assert load_delivery(folder).geometry.affine is not None


def test_checkpoint_rows_refused_beyond_the_tenth_are_counted(tmp_path, blockqc) -> None:
    """27 rows naming a block not inspected, or points the delivery has: the first 10 were
    listed, by row only, and the other 17 went unsaid; their count is now given, and the line
    of each row listed."""
    batch = tmp_path / "batch"
    write_delivery(batch / "a")
    write_delivery(batch / "b", {"manifest": {"block_id": "CASE-B"}})
    named = tmp_path / "named.csv"
    base_tables()["checkpoints"].assign(block_id="NOPE").to_csv(named, index=False)
    proc = blockqc("inspect", batch, "--out", tmp_path / "o1", "--no-pdf", "--checkpoints", named)
    assert proc.returncode == 2, proc.stderr
    assert f"{named}, row 10 (line 11), column 'block_id': no block 'NOPE'" in proc.stderr
    assert "row 11 " not in proc.stderr
    assert f"{named}, column 'block_id': no block among the deliveries inspected: 17 more" in (
        proc.stderr
    )
    dup = tmp_path / "dup.csv"
    base_tables()["checkpoints"].to_csv(dup, index=False)
    proc = blockqc(
        "inspect", batch / "a", "--out", tmp_path / "o2", "--no-pdf", "--checkpoints", dup
    )
    assert proc.returncode == 2, proc.stderr
    assert f"{dup}, row 10 (line 11): checkpoint C09 (high_precision) is also in" in proc.stderr
    assert f"{dup}: a checkpoint the delivery also has: 17 more rows like this" in proc.stderr
