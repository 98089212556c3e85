"""`blockqc rfm-accuracy`: is an image's RFM good to better than one pixel? (§RA)"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import click
from pyproj import CRS
from pyproj.exceptions import CRSError

from blockqc.cli import GivenPath, lang_option
from blockqc.errors import UsageError
from blockqc.matching.settings import MatchSettings
from blockqc.outputs import check_out_dir, empty_removed, refuse_replacing
from blockqc.report.format import number_beside
from blockqc.rfm.pipeline import (
    METHODS,
    OUTPUT_NAMES,
    REFERENCE_GSD_RATIO,
    RfmAccuracyConfig,
    run_rfm_accuracy,
)


def _offset(value: str | None, option: str = "--crop-offset") -> tuple[float, float] | None:
    if value is None or value == "auto":
        return None
    try:
        row, col = (float(v) for v in value.split(","))
    except ValueError:
        row = col = math.nan
    if not (math.isfinite(row) and math.isfinite(col)):
        raise UsageError(
            f"{option} is 'auto' or ROW,COL in pixels (two finite numbers), got {value!r}"
        )
    return row, col


#: the smallest matching chunk: the matcher's BRIEF patch and NCC template must fit in it
MIN_CHUNK = max(MatchSettings().template, MatchSettings().brief_patch)
MAX_REPEATS = 10_000
"""Most random draws per k of §RA-6 (--repeats): all draws of a k are solved at once, and
10^8 of them took 23 GB; beyond 10^4 the mean RMSE of a row no longer changes."""


def _ks(value: str) -> tuple[int, ...]:
    try:
        ks = tuple(int(v) for v in value.split(",") if v.strip())
    except ValueError:
        raise UsageError(f"--k is a comma-separated list of integers, got {value!r}") from None
    if not ks or min(ks) < 3:
        raise UsageError(
            f"--k values must be at least 3 (the affine has 6 parameters), got {value!r}"
        )
    twice = sorted({k for k in ks if ks.count(k) > 1})
    if twice:
        shown = ", ".join(str(k) for k in twice)
        raise UsageError(f"--k gives {shown} more than once ({value!r}): give each k once")
    return ks


def _crs(text: str | None) -> CRS | None:
    """--crs: a projected CRS pyproj knows; None (not given) for the UTM zone of the scene."""
    if text is None:
        return None
    if not text.strip():
        raise UsageError(
            "--crs is empty: give a projected CRS (e.g. EPSG:32631), or leave --crs out for "
            "the UTM zone of the scene centre"
        )
    try:
        crs = CRS.from_user_input(text)
    except CRSError:
        raise UsageError(f"--crs {text!r} is not a CRS pyproj knows") from None
    if not crs.is_projected:
        raise UsageError(f"--crs {text!r} must be a projected CRS (metres)")
    from blockqc.rfm.ortho import units_not_metres

    units = units_not_metres(crs)
    if units:
        raise UsageError(
            f"--crs {text!r} is in {', '.join(sorted(units))}: expected a projected CRS in "
            "metres (the CPs' positions and shifts are given in metres)"
        )
    return crs


INDEPENDENT = (
    "a reference must be independent of the image (a reference orthoimage, or another image "
    "of the scene with its own RPCs)"
)


def refuse_self_reference(image: Path, reference: Path) -> None:
    """The image given as its own reference, or a copy of it, would measure nothing but the
    resampling (0.045 px, "pass", on the Ventoux image)."""
    import filecmp

    if os.path.samefile(image, reference):
        raise UsageError(f"--reference {reference} is the image {image} itself: {INDEPENDENT}")
    if filecmp.cmp(image, reference, shallow=False):
        raise UsageError(
            f"--reference {reference} holds the same bytes as the image {image} (a copy of the "
            f"image): {INDEPENDENT}"
        )


def refuse_foreign_results(out: Path) -> None:
    """Refuse an --out holding a results.json that rfm-accuracy did not write (an `inspect`
    block's, another tool's): the run would replace it and the files beside it."""
    found = out / "results.json"
    if not found.is_file():
        return
    try:
        kind = json.loads(found.read_text(encoding="utf-8")).get("kind")
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        kind = None
    if kind != "rfm_accuracy":
        raise UsageError(
            f"--out {out}: {found} is not the results of an rfm-accuracy run (another tool's, "
            "e.g. an inspect block's); the run would replace it and the files beside it: "
            "choose another output folder"
        )


def _geoid(value: str | None, offset: float | None) -> str | Path | None:
    """--geoid: 'egm96' or an existing grid file; exclusive with --geoid-offset."""
    if value is not None and offset is not None:
        raise UsageError("give --geoid or --geoid-offset, not both")
    if offset is not None and not (math.isfinite(offset) and abs(offset) <= 150.0):
        raise UsageError(f"--geoid-offset is a geoid undulation in metres (±150), got {offset!r}")
    if value is None or value.lower() == "egm96":
        return value and "egm96"
    path = Path(value)
    if not path.is_file():
        raise UsageError(f"--geoid is 'egm96' or a geoid grid file; {value!r} is neither")
    return path


_path = GivenPath("a file", exists=True, dir_okay=False)


def _finite(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    """A FloatRange lets nan and inf pass: refused here."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"expected a finite number, got {value}", param=param)
    return value


@click.command("rfm-accuracy")
@click.argument("image", type=_path)
@click.option(
    "--rpc",
    type=_path,
    help="RPC file of IMAGE (any supported format); default: the RPCs GDAL finds for IMAGE.",
)
@click.option(
    "--dem", required=True, type=_path, help="DEM (any GDAL raster: SRTM .hgt, GeoTIFF …)."
)
@click.option(
    "--geoid",
    help="Geoid of a DEM in geoid heights: 'egm96' (the global EGM96 grid shipped with blockqc) "
    "or a geoid grid file (e.g. egm96_15.gtx); h = H + N.",
)
@click.option(
    "--geoid-offset",
    type=float,
    help="A constant geoid undulation N in metres (h = H + N), instead of --geoid.",
)
@click.option(
    "--dem-vertical",
    type=click.Choice(["auto", "geoid", "ellipsoid"]),
    default="auto",
    show_default=True,
    help="What the DEM heights are measured from; 'auto': what the DEM declares (compound or "
    "3-D CRS; SRTM .hgt is EGM96), else --geoid/--geoid-offset must say.",
)
@click.option(
    "--reference",
    required=True,
    type=_path,
    help="Reference orthoimage (georeferenced), or a same-accuracy image in sensor geometry "
    "with RPCs.",
)
@click.option(
    "--reference-rpc",
    type=_path,
    help="RPC file of a sensor-geometry reference (it is then orthorectified on the image grid).",
)
@click.option(
    "--out",
    "out",
    required=True,
    type=GivenPath(file_okay=False),
    help="Output folder (not one holding another tool's results.json).",
)
@click.option(
    "--crs",
    "crs_text",
    help="Output CRS (e.g. EPSG:32631, the block's); default: UTM zone of the scene centre.",
)
@click.option(
    "--gsd",
    type=click.FloatRange(min=0, min_open=True),
    callback=_finite,
    help="Output GSD in metres (a finite number > 0); default: the image GSD at its centre "
    "(errors in pixels are always the image's).",
)
@click.option(
    "--crop-offset",
    default="auto",
    show_default=True,
    help="ROW,COL of IMAGE's first pixel in the full image of the RPCs; 'auto' reads a crop's "
    "pixel geotransform.",
)
@click.option(
    "--reference-crop-offset",
    default="auto",
    show_default=True,
    help="The same for a sensor-geometry reference.",
)
@click.option(
    "--grid",
    "match_grid",
    type=click.IntRange(min=1),
    help="Homogenization cell (px): one CP per cell (§RA-3); default: chosen from the image "
    "size (≥ ~50 CPs where the texture allows, at most 400 px).",
)
@click.option(
    "--chunk",
    "match_chunk",
    type=click.IntRange(min=MIN_CHUNK),
    default=5000,
    show_default=True,
    help=f"Matching chunk B (px) (§RA-3), at least {MIN_CHUNK} (the BRIEF patch).",
)
@click.option(
    "--margin",
    type=click.IntRange(min=0),
    default=32,
    show_default=True,
    help="Reference margin around the image grid (px).",
)
@click.option(
    "--k",
    "k_text",
    default="6,12,16,20",
    show_default=True,
    help="Numbers of CPs used to refine the RFM (§RA-6), each at least 3 and given once.",
)
@click.option(
    "--repeats",
    type=click.IntRange(1, MAX_REPEATS),
    default=100,
    show_default=True,
    help=f"Random draws per k (at most {MAX_REPEATS}).",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Seed of the random draws (§RA-6), ≥ 0.",
)
@click.option(
    "--requirement",
    type=click.FloatRange(min=0, min_open=True, max=1e6),
    callback=_finite,
    default=1.0,
    show_default=True,
    help="RMSE requirement in pixels.",
)
@click.option(
    "--reference-gsd-ratio",
    "reference_gsd_ratio",
    type=click.FloatRange(min=1, max=1e6),
    callback=_finite,
    default=REFERENCE_GSD_RATIO,
    show_default=True,
    help="Warn when the reference's pixels are more than this many times the image's GSD.",
)
@click.option(
    "--method",
    type=click.Choice(METHODS),
    default="same_accuracy",
    show_default=True,
    help="Checkpoint method of the reference (contract v1).",
)
@click.option(
    "--export-checkpoints",
    is_flag=True,
    help="Also write checkpoints.csv (contract v1) for `blockqc inspect`.",
)
@click.option(
    "--dem-fill-voids",
    "dem_fill",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Close DEM voids up to ~2·N cells across (holes of a photogrammetric DSM); 0: none.",
)
@click.option(
    "--refined-ortho",
    is_flag=True,
    help="Also orthorectify IMAGE with the RFM refined from every CP (ortho_refined.tif).",
)
@lang_option("report.html and its figures (results.json is the same in either)")
def command(image: Path, reference: Path, out: Path, requirement: float, **options: Any) -> None:
    """Measure the geometric accuracy of IMAGE's RFM against a reference orthoimage (§RA).

    Orthorectifies IMAGE with its RPCs and the DEM, brings the reference onto the same grid,
    matches them automatically, and writes the CP table (cps.csv), results.json, the error-vector
    plot, the GEV histogram, the refined-RFM table and report.html into --out.
    Exit status 0 when the RMSE meets the requirement, 1 when it does not.
    """
    given = _given(image, reference, requirement, options)
    inputs = _input_files(
        (image, given["rpc"], given["dem"], reference, given["reference_rpc"]), given["geoid"]
    )
    refuse_replacing(out, OUTPUT_NAMES, inputs)
    refuse_foreign_results(out)
    with empty_removed(out):  # an input error leaves no empty folder the run made
        out_dir = check_out_dir(out, inputs)
        results = run_rfm_accuracy(RfmAccuracyConfig(out=out_dir, **given))
    _say_results(results, image.name, requirement, out_dir)


def _given(image: Path, reference: Path, requirement: float, options: dict[str, Any]) -> dict:
    """The fields of the run's RfmAccuracyConfig but its output folder, from the command's
    options (named as the fields are, but for the texts read here: CRS, k values, geoid, crop
    offsets)."""
    given = dict(options)
    crs = _crs(given.pop("crs_text"))
    ks = _ks(given.pop("k_text"))
    refuse_self_reference(image, reference)
    return {
        **given,
        "image": image,
        "reference": reference,
        "requirement_px": requirement,
        "crs": crs,
        "ks": ks,
        "geoid": _geoid(given["geoid"], given["geoid_offset"]),
        "crop_offset": _offset(given["crop_offset"]),
        "reference_crop_offset": _offset(given["reference_crop_offset"], "--reference-crop-offset"),
    }


def _input_files(paths: tuple[Path | None, ...], geoid: str | Path | None) -> list[Path]:
    """The files the run reads: those given, and the geoid when a file (not a model's name)."""
    inputs = [p for p in paths if p is not None]
    if isinstance(geoid, Path):
        inputs.append(geoid)
    return inputs


def _say_results(results: dict[str, object], name: str, requirement: float, out_dir: Path) -> None:
    """The run's warnings, its console line, and exit status 1 when the RMSE fails the
    requirement."""
    for warning in results.get("warnings") or []:  # type: ignore[union-attr]
        click.echo(f"warning: {warning}", err=True)
    acc = results["accuracy"]
    click.echo(console_line(name, results, requirement, out_dir))
    if acc["verdict"] != "pass":  # type: ignore[index]
        click.get_current_context().exit(1)


def console_line(name: str, results: dict, requirement: float, out_dir: Path) -> str:
    """One line: CPs (and the bands matched when an input has several), RMSE, the systematic
    shift (mean dx, dy in metres and pixels), verdict."""
    acc, d = results["accuracy"], results["distortion"]
    rmse = acc["rmse_px"]
    shift = ""
    if d.get("mean_dx_m") is not None:
        shift = (
            f", shift dx {d['mean_dx_m']:+.2f} m ({d['mean_dx_px']:+.2f} px) "
            f"dy {d['mean_dy_m']:+.2f} m ({d['mean_dy_px']:+.2f} px)"
        )
    image, reference = results["image_bands"], results["reference"]["bands"]
    bands = ""
    if image["count"] > 1 or reference["count"] > 1:
        bands = (
            f" matched on the image's {image['matched_on']} and the reference's "
            f"{reference['matched_on']}"
        )
    return (
        f"{name}: {acc['n']} CPs{bands}, RMSE "
        + (f"{number_beside(rmse, acc['requirement_px'])} px" if rmse is not None else "n/a")
        + shift
        + f" → {acc['verdict']} (requirement < {requirement:g} px); results in {out_dir}"
    )
