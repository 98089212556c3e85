"""Delivered geometry under which no ray can be followed: an affine offset of no adjustment, an
RPC that degenerates. Named by file, row and column, exit 2, and no numpy warning on the
console."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pandas as pd
import pytest
from geokit import FILES, ground_points, observe, write_v11

from blockqc.adjust.geometry import RPCStack, intersect, intersect_at_height
from blockqc.delivery import load_delivery
from blockqc.errors import InputError
from blockqc.rfm.readers import read_rpc

VENTOUX = FILES["L"].parent


@pytest.fixture(scope="module")
def tie_points() -> pd.DataFrame:
    """40 points seen on L and R, without the producer's ground points (the checkpoints of
    `adjust` then come from intersecting the producer's adjustment)."""
    return observe(ground_points(40, seed=3), noise_px=0.2, seed=3)


def _set_affine(folder, scene: str, column: str, value: float) -> int:
    """Put `value` in `column` of the scene's adjustment.csv row; the row's number."""
    table = pd.read_csv(folder / "adjustment.csv")
    at = int(np.flatnonzero(table["scene_id"] == scene)[0])
    table.loc[at, column] = value
    table.to_csv(folder / "adjustment.csv", index=False)
    return at + 1


# ------------------------------------------------------------------ an offset of no adjustment
@pytest.mark.parametrize(
    "scene, column, value, extent",
    [("L", "a0", 1e12, "lines"), ("R", "b0", -2e5, "samples"), ("L", "b0", 1.2e5, "samples")],
)
def test_an_offset_of_several_images_is_refused(tmp_path, tie_points, scene, column, value, extent):
    """a0 of scene L 1e12 px: adjust converged and wrote its checkpoints' header only (five
    numpy RuntimeWarnings on the console), inspect put RO-3/RO-4 in error. Refused on reading,
    naming the row, the column, the value and the bound: three times the scene's size."""
    folder = write_v11(tmp_path / "d", tie_points)
    row = _set_affine(folder, scene, column, value)
    size = int(pd.read_csv(folder / "scenes.csv").set_index("scene_id").loc[scene, extent])
    with pytest.raises(InputError) as exc:
        load_delivery(folder)
    (msg,) = [str(p) for p in exc.value.problems]
    assert msg == (
        f"{folder / 'adjustment.csv'}, row {row} (line {row + 1}), column '{column}': scene "
        f"'{scene}': {column} is {value:g} px; expected within ±{3 * size} px, 3 times the "
        f"scene's {size} {extent} in scenes.csv (an adjustment moves the image by pixels, at "
        "most hundreds of them: this offset puts every tie point off its scene; a value in "
        "other units, or a no-data marker?)"
    )


def test_a_large_offset_within_the_bound_is_read(tmp_path, tie_points) -> None:
    """Twice the image's lines: beyond any real adjustment, within the generous bound (RC-1
    then says its rays do not meet, `test_verification`)."""
    folder = write_v11(tmp_path / "d", tie_points)
    lines = int(pd.read_csv(folder / "scenes.csv").set_index("scene_id").loc["L", "lines"])
    _set_affine(folder, "L", "a0", 2 * lines)
    assert load_delivery(folder).geometry.affine[0, 0] == 2 * lines


def test_both_commands_refuse_the_offset_without_numpy_warnings(tmp_path, tie_points, blockqc):
    folder = write_v11(tmp_path / "d", tie_points)
    _set_affine(folder, "L", "a0", 1e12)
    said = f"{folder / 'adjustment.csv'}, row 1 (line 2), column 'a0': scene 'L': a0 is 1e+12 px"
    for command, extra in (("adjust", ()), ("inspect", ("--no-pdf",))):
        r = blockqc(command, folder, "--out", tmp_path / f"out-{command}", *extra)
        assert r.returncode == 2, (command, r.stdout + r.stderr)
        assert f"error: {said}" in r.stderr, (command, r.stderr)
        assert "Warning" not in r.stderr and "Traceback" not in r.stderr, (command, r.stderr)


@pytest.mark.parametrize("a0", [1e6, 1e12])
def test_rays_that_cannot_reach_the_ground_leave_no_numpy_warning(a0) -> None:
    """The intersections meet such offsets when called on their own (the reader refuses them in
    a delivery): a Newton step that diverges is no convergence, said by its flag, not by numpy's
    'invalid value encountered in divide' on the console."""
    stack = RPCStack.from_models([read_rpc(f) for f in FILES.values()])
    affine = np.zeros((2, 6))
    affine[0, 0] = a0
    line, sample = np.array([16599.5, 16095.4]), np.array([15272.5, 15255.7])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, _, ok = intersect_at_height(stack, affine, [0, 1], line, sample, [800.0, 800.0])
        intersect(stack, affine, [0, 1], [0, 0], line, sample)
    assert ok.tolist() == [False, True]  # L's ray, a0 pixels off its image, reaches no ground


# ------------------------------------------------------------------ an RPC that degenerates
def _with_lat_scale(folder, value: str) -> None:
    """rpc/L.geom with LAT_SCALE `value` (degrees; the reader's floor is 1e-9)."""
    path = folder / "rpc" / "L.geom"
    text, n = re.subn(r"(?m)^lat_scale:.*$", f"lat_scale:  {value}", path.read_text())
    assert n == 1
    path.write_text(text)


@pytest.mark.parametrize("dem", [False, True])
def test_rays_that_do_not_intersect_name_the_rpc(tmp_path, tie_points, blockqc, dem) -> None:
    """lat_scale 1e-8 in rpc/L.geom: adjust printed 'RuntimeWarning: Mean of empty slice' and
    'σ0 cannot be estimated: the 0 observations of the 0 point(s) seen on two or more scenes'
    though all 40 points are on both scenes (with --dem, it blamed the DEM). It now says that
    their rays do not intersect, as inspect does, and names the RPC that puts none of its
    scene's observations on the ground."""
    folder = write_v11(tmp_path / "d", tie_points)
    _with_lat_scale(folder, "1e-8")
    dem_args = (
        "--dem",
        VENTOUX / "srtm_N44E005_crop.tif",
        "--geoid",
        VENTOUX / "egm96_15_crop.gtx",
    )
    r = blockqc("adjust", folder, "--out", tmp_path / "out", *(dem_args if dem else ()))
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr == (
        f"error: {folder / 'rpc' / 'L.geom'}: the rays of the 40 tie points seen on two or more "
        "scenes do not intersect with the delivered geometry: this RPC puts none of the 40 "
        "tie-point observations of its scene on the ground at their points' prior heights "
        "(expected the RPC of the scene: a scale, an offset or a coefficient wrong?)\n"
    )
    assert not (tmp_path / "out").exists()


def test_the_same_block_with_its_rpc_as_delivered_is_adjusted(tmp_path, tie_points, blockqc):
    folder = write_v11(tmp_path / "d", tie_points)
    _with_lat_scale(folder, "0.0989506933075148")  # as the file gives it
    r = blockqc("adjust", folder, "--out", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert "converged yes" in r.stdout and "Warning" not in r.stderr
