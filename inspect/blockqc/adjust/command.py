"""`blockqc adjust`: the independent RFM-affine block adjustment of a delivery (§RC-3)."""

from __future__ import annotations

import math
from pathlib import Path

import click
from click.core import ParameterSource

from blockqc.adjust.run import DEFAULT_DEM_SIGMA_M, AdjustConfig, run_adjust
from blockqc.adjust.solver import Settings
from blockqc.cli import GivenPath, lang_option
from blockqc.errors import UsageError
from blockqc.outputs import empty_removed, refuse_inside

#: the smallest σ or factor an option takes: below a millionth (of a pixel, of a metre) the
#: weights overflow the normal equations (1e-300 made them singular)
SMALLEST = 1e-6


class Positive(click.ParamType):
    """A number from SMALLEST to `largest`, refused (exit 2, the option named) before anything
    is read; or infinite where `infinite` (an infinite prior σ leaves its parameters free).
    Beyond `largest` a σ means nothing of an image or a DEM, and its square overflows."""

    name = "float"

    def __init__(self, largest: float, infinite: bool = False) -> None:
        self.largest = largest
        self.infinite = infinite

    def convert(self, value, param, ctx) -> float:
        number = click.FLOAT.convert(value, param, ctx)
        if SMALLEST <= number <= self.largest or (self.infinite and number == math.inf):
            return number
        expected = f"a number from {SMALLEST:g} to {self.largest:g}" + (
            " (inf: a free parameter)" if self.infinite else ""
        )
        self.fail(f"{value!r} is not {expected}", param, ctx)


def check_dem_options(dem: Path | None, geoid: Path | None) -> None:
    """Refuse the DEM's options without --dem (they would be silently ignored)."""
    if dem is not None:
        return
    ctx = click.get_current_context()
    given = ["--geoid"] if geoid is not None else []
    given += [
        f"--{name.replace('_', '-')}"
        for name in ("dem_vertical", "dem_sigma")
        if ctx.get_parameter_source(name) is ParameterSource.COMMANDLINE
    ]
    if given:
        raise UsageError(
            f"{', '.join(given)} given without --dem: the geoid and the DEM options apply to "
            "the DEM's heights only (give --dem DEM, or leave them out)"
        )


@click.command("adjust")
@click.argument("delivery", type=GivenPath("a delivery folder"))
@click.option("--out", required=True, type=GivenPath(), help="Output folder.")
@click.option("--dem", type=GivenPath("a DEM file"), help="DEM for height priors.")
@click.option(
    "--geoid",
    type=GivenPath("a geoid grid file, or egm96"),
    help="Geoid of a geoid-height DEM (needs --dem): a grid file, or egm96 (shipped).",
)
@click.option(
    "--dem-vertical",
    type=click.Choice(["geoid", "ellipsoid"]),
    default="geoid",
    show_default=True,
    help="Heights of the DEM: above the geoid (SRTM; needs --geoid) or ellipsoidal.",
)
@click.option(
    "--dem-sigma",
    type=Positive(1e5),
    default=DEFAULT_DEM_SIGMA_M,
    show_default=True,
    help="σ of DEM (m).",
)
@click.option("--fix", multiple=True, help="Hold this scene's affine at zero (repeatable).")
@click.option(
    "--sigma-shift",
    type=Positive(1e6, infinite=True),
    default=10.0,
    show_default=True,
    help="A-priori σ of a0, b0 (px).",
)
@click.option(
    "--sigma-linear",
    type=Positive(1e6, infinite=True),
    default=2.0,
    show_default=True,
    help="A-priori σ of the linear terms, in px at the image edge.",
)
@click.option(
    "--sigma-image",
    type=Positive(1e4),
    default=0.5,
    show_default=True,
    help="Starting σ of a measurement (px).",
)
@click.option(
    "--reject",
    type=Positive(1e6),
    default=4.0,
    show_default=True,
    help="Reject |v| > k·σ0: this k.",
)
@click.option("--max-iterations", default=20, show_default=True, type=click.IntRange(1, 1000))
@click.option(
    "--checkpoints",
    "n_checkpoints",
    default=30,
    show_default=True,
    type=click.IntRange(1, 1000),
    help="Points compared with the producer's (§CP-1).",
)
@lang_option("adjust.html and its figures (adjust.json is the same in either)")
def command(
    delivery: Path,
    out: Path,
    dem: Path | None,
    geoid: Path | None,
    dem_vertical: str,
    dem_sigma: float,
    fix: tuple[str, ...],
    sigma_shift: float,
    sigma_linear: float,
    sigma_image: float,
    reject: float,
    max_iterations: int,
    n_checkpoints: int,
    lang: str,
) -> None:
    """Adjust DELIVERY's block from its rpc/ and tie observations alone (§RC-3).

    Writes adjustment.csv, tie_points.csv, ground_points.csv, checkpoints.csv (method
    recalculation), adjust.json and adjust.html into --out. Exit status 0 when the adjustment
    converged, 1 when it did not (the outputs say converged: false), 2 on unreadable input.
    """
    check_dem_options(dem, geoid)
    settings = Settings(max_iterations=max_iterations, reject_k=reject, sigma_image_px=sigma_image)
    cfg = AdjustConfig(
        delivery=delivery,
        out=out,
        dem=dem,
        geoid=geoid,
        dem_vertical=dem_vertical,
        dem_sigma_m=dem_sigma,
        fix=fix,
        sigma_shift_px=sigma_shift,
        sigma_linear_px=sigma_linear,
        settings=settings,
        checkpoints=n_checkpoints,
        lang=lang,
    )
    refuse_inside(out, cfg.inputs())  # before reading; the folder is made once they are read
    with empty_removed(out):  # an input error leaves no empty folder the run made
        r = run_adjust(cfg)
    _say_results(r, out)


def _say_results(r: dict, out: Path) -> None:
    """The run's console line and warnings, and exit status 1 when it did not converge."""
    click.echo(
        f"{r['block_id']}: {r['n_scenes']} scenes, {r['n_observations']} observations, "
        f"{r['iterations']} iterations, converged {'yes' if r['converged'] else 'NO'}; "
        f"σ0 {r['sigma0_px']:.3f} px, RMS {r['rms_px_before']:.3f} → {r['rms_px_after']:.3f} px, "
        f"{r['n_outliers']} outliers, {r['n_without_second_ray']} observations left without a "
        f"second ray; results in {out.resolve()}"
    )
    for warning in r["warnings"]:
        click.echo(f"warning: {warning}", err=True)
    if not r["converged"]:
        click.echo("the adjustment did not converge: see adjust.json (history)", err=True)
        click.get_current_context().exit(1)
