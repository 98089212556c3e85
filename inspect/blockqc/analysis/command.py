"""`blockqc factors`: build the §AF experiments table from deliveries, or analyse a given table."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any

import click
import pandas as pd

from blockqc.analysis.analyse import analyse
from blockqc.analysis.factors import FactorOptions, experiments_table
from blockqc.analysis.render import correlation_heatmap, render_html, structure_plot
from blockqc.analysis.table import FACTOR_COLUMNS, INDICATOR_COLUMNS, read_table, write_table_csv
from blockqc.analysis.terrain import DemSet
from blockqc.cli import GivenPath, TemplatesPath, lang_option
from blockqc.delivery import find_deliveries, load_delivery
from blockqc.errors import UsageError
from blockqc.outputs import (
    check_out_dir,
    empty_removed,
    out_lock,
    refuse_inside,
    refuse_replacing,
    write_bytes_atomic,
    write_json_atomic,
    write_text_atomic,
)
from blockqc.verification import prepare


def _finite(value: float, param: click.Parameter) -> float:
    """A number option refused when not finite (a range lets NaN through: inf would count every
    date as one period, and a NaN IoU make no two scenes one stereo unit, unsaid)."""
    if not math.isfinite(value):
        raise click.BadParameter(f"{value!r} is not a finite number", param=param)
    return value


def build_table(batch: Path, dem_paths: list[Path], options: FactorOptions) -> pd.DataFrame:
    """Read every delivery under `batch` and compute its row of the experiments table."""
    paths = find_deliveries(batch)
    dems = DemSet(dem_paths)
    deliveries = [load_delivery(p) for p in paths]
    for d in deliveries:  # contract v1.1: residuals computed where the delivery gives none
        prepare(d)
    return experiments_table(deliveries, dems, options)


#: a block whose footprint the DEM covers less than this share of is named in a warning
DEM_COVERAGE_WARN = 0.99


def _dem_coverage(table: pd.DataFrame, dems: list[Path]) -> None:
    """A DEM that covers none of the blocks is refused; a block it covers only in part, or not
    at all, is named in a warning (its terrain factors come from the part covered, or are
    missing: the block is left out of the terrain factors' correlations and of the CCA, and kept
    in the others, pairwise)."""
    share = table["dem_coverage"].to_numpy(dtype=float)
    given = ", ".join(str(d) for d in dems)
    if not (share > 0).any():
        raise UsageError(
            f"--dem {given}: covers none of the blocks' footprints (check its area and "
            "coordinate reference system)"
        )
    for block, covered in zip(table["experiment"], share, strict=True):
        if covered < DEM_COVERAGE_WARN:
            what = (
                "no terrain factors: left out of their correlations and of the CCA, kept in "
                "the others"
                if covered == 0
                else "terrain from that part"
            )
            click.echo(
                f"warning: {block}: the DEM covers {100 * covered:.0f} % of its footprint ({what})",
                err=True,
            )


#: every file this command writes into --out; those a run does not write are removed from it
OUTPUT_NAMES: tuple[str, ...] = (
    "experiments.csv",
    "factors.json",
    "correlation.csv",
    "correlation_p_values.csv",
    "cca_tests.csv",
    "cca_coefficients.csv",
    "cca_structure.csv",
    "correlation.svg",
    "correlation.png",
    "structure.svg",
    "structure.png",
    "factors.html",
)


def _remove_stale(out: Path, written: list[Path]) -> None:
    """Remove the outputs of an earlier run that this run did not write (a CCA, a figure it
    could not make), so that the folder never mixes two runs; other files are left alone."""
    made = {p.name for p in written}
    for name in OUTPUT_NAMES:
        old = out / name
        if name in made or not (old.is_file() or old.is_symlink()):
            continue
        try:
            old.unlink()
        except OSError as exc:
            raise UsageError(
                f"--out {out}: the earlier run's {name} cannot be removed: {exc.strerror or exc}"
            ) from None


def write_outputs(
    out: Path,
    table: pd.DataFrame,
    results: dict[str, Any],
    user_templates: Path | None = None,
    lang: str = "en",
) -> list[Path]:
    """Write the table, the analysis (CSV, JSON), the figures and the page (the figures and the
    page in `lang`); return the files."""
    made = {
        "correlation": correlation_heatmap(results, lang),
        "structure": structure_plot(results, lang),
    }
    figures = {name: figure for name, figure in made.items() if figure is not None}
    svgs = {name: svg for name, (svg, _) in figures.items()}
    page = render_html(results, svgs, user_templates, lang)
    written: list[Path] = []  # the page is rendered first: a template that fails leaves no file

    def text(name: str, content: str) -> None:
        write_text_atomic(out / name, content)
        written.append(out / name)

    text("experiments.csv", write_table_csv(table))
    write_json_atomic(out / "factors.json", results)
    written.append(out / "factors.json")
    for name, content in _analysis_csvs(results):
        text(name, content)
    for name, (svg, png) in figures.items():
        for suffix, data in ((".svg", svg), (".png", png)):
            write_bytes_atomic(out / f"{name}{suffix}", data)
            written.append(out / f"{name}{suffix}")
    text("factors.html", page)
    return written


def _analysis_csvs(results: dict[str, Any]) -> Iterator[tuple[str, str]]:
    """The analysis as CSV files (name, text), one at a time: the correlations and their p
    values, then the CCA's tests, coefficients and structure, of those computed."""
    corr = results["correlation"]
    if corr:
        for key, name in (("r", "correlation.csv"), ("p_value", "correlation_p_values.csv")):
            frame = pd.DataFrame(corr[key]).T.loc[results["factors"], results["indicators"]]
            yield name, frame.rename_axis("factor").to_csv(lineterminator="\n")
    res = results["cca"]
    if res:
        yield "cca_tests.csv", pd.DataFrame(res["tests"]).to_csv(index=False, lineterminator="\n")
        coef = pd.concat(
            [
                _coef_frame(res["coefficients_factors"], "factor", "U"),
                _coef_frame(res["coefficients_indicators"], "indicator", "V"),
            ]
        )
        yield "cca_coefficients.csv", coef.to_csv(index=False, lineterminator="\n")
        struct = pd.concat(
            [
                _struct_frame(res["structure_factors"], "factor", "U1", "V1"),
                _struct_frame(res["structure_indicators"], "indicator", "V1", "U1"),
            ]
        )
        yield "cca_structure.csv", struct.to_csv(index=False, lineterminator="\n")


def _coef_frame(coef: dict[str, dict[str, float]], group: str, prefix: str) -> pd.DataFrame:
    frame = pd.DataFrame(coef).T
    frame.columns = [f"pair_{c.removeprefix(prefix)}" for c in frame.columns]
    frame.insert(0, "variable", frame.index)
    frame.insert(0, "group", group)
    return frame.reset_index(drop=True)


def _struct_frame(
    struct: dict[str, dict[str, float]], group: str, own: str, other: str
) -> pd.DataFrame:
    frame = pd.DataFrame(struct).T
    return pd.DataFrame(
        {
            "group": group,
            "variable": list(frame.index),
            "on_own_first_variate": frame[own].to_numpy(),
            "on_other_first_variate": frame[other].to_numpy(),
        }
    )


def _refuse_batch_options() -> None:
    """With --table, the options that build the table from deliveries would be ignored."""
    ctx = click.get_current_context()
    given = [
        p.opts[0]
        for p in ctx.command.params
        if p.name in _BATCH_ONLY
        and ctx.get_parameter_source(p.name) not in (None, click.core.ParameterSource.DEFAULT)
    ]
    if given:
        raise UsageError(
            f"{', '.join(given)}: options that build the table from BATCH's deliveries; --table "
            "gives the table itself (leave them out)"
        )


#: the options of BATCH alone (the parameters of `command` they set)
_BATCH_ONLY = ("dems", "images_band", "period_gap_days", "overlap", "stereo_iou", "edge_correction")


@click.command("factors")
@click.argument("batch", required=False, type=GivenPath("a batch folder", exists=True))
@click.option(
    "--dem",
    "dems",
    multiple=True,
    type=GivenPath("a DEM", exists=True),
    help="DEM GeoTIFF (or other raster) or a folder of tiles; may be repeated.",
)
@click.option(
    "--table",
    "table_path",
    type=GivenPath("a table of indicators", exists=True, dir_okay=False),
    help="Analyse this experiments table (CSV, columns as the appendix table).",
)
@click.option(
    "--out",
    required=True,
    type=GivenPath(file_okay=False),
    help="Output folder: never inside BATCH; it may be the folder of --table unless one of "
    "its outputs would replace the table.",
)
@click.option(
    "--images-band",
    type=click.Choice(["pan", "ms", "all"]),
    default="pan",
    show_default=True,
    help="Which scenes count as images (§AF-5).",
)
@click.option(
    "--period-gap-days",
    type=click.FloatRange(min=0),
    callback=lambda ctx, param, v: _finite(v, param),
    default=0.0,
    show_default=True,
    help="Acquisition dates at most this many days apart form one period (§AF-6).",
)
@click.option(
    "--overlap",
    type=click.Choice(["union", "pairwise_sum"]),
    default="union",
    show_default=True,
    help="Overlap degree reading (§AF-7), see docs/factors.md.",
)
@click.option(
    "--stereo-iou",
    type=click.FloatRange(min=0.0, max=1.0, min_open=True),
    callback=lambda ctx, param, v: _finite(v, param),
    default=0.8,
    show_default=True,
    help="Same-day scenes whose footprints overlap this much (intersection over union) are one "
    "stereo unit for the overlap degree (§AF-7).",
)
@click.option(
    "--edge-correction/--no-edge-correction",
    default=False,
    show_default=True,
    help="Donnelly's edge correction in the Clark–Evans coefficient (§AF-10).",
)
@click.option(
    "--templates",
    "user_templates",
    type=TemplatesPath("factors"),
    help="A folder whose factors.html.j2 overrides the stock page.",
)
@lang_option("factors.html and its figures (factors.json is the same in either)")
def command(
    batch: Path | None,
    dems: tuple[Path, ...],
    table_path: Path | None,
    out: Path,
    images_band: str,
    period_gap_days: float,
    overlap: str,
    stereo_iou: float,
    edge_correction: bool,
    user_templates: Path | None,
    lang: str,
) -> int:
    """Adjustment factors, accuracy indicators, their correlation and CCA (DOMAIN.md §5).

    Either BATCH (a batch or one delivery) with --dem, to build the experiments table from the
    deliveries and analyse it, or --table CSV to analyse a table of experiments.
    """
    if (batch is None) == (table_path is None):
        raise UsageError("give either BATCH (with --dem) or --table CSV, not both or neither")
    if table_path is not None:
        _refuse_batch_options()
    options = FactorOptions(
        images_band=images_band,
        period_gap_days=period_gap_days,
        overlap=overlap,
        stereo_iou=stereo_iou,
        edge_correction=edge_correction,
    )
    table, source = _experiments(batch, dems, table_path, out, options)
    with empty_removed(out):  # a failure leaves no empty folder the run made
        out = check_out_dir(out, [batch] if batch is not None else [])  # once the inputs are read
        results = analyse(table, source)
        if batch is not None:
            results["options"] = asdict(options) | {"dem": [str(d) for d in dems]}
        with out_lock(out):  # one run at a time writes into a folder, as inspect's
            written = write_outputs(out, table, results, user_templates, lang)
            _remove_stale(out, written)
    _say_results(results, written, out)
    return 0


def _experiments(
    batch: Path | None,
    dems: tuple[Path, ...],
    table_path: Path | None,
    out: Path,
    options: FactorOptions,
) -> tuple[pd.DataFrame, str]:
    """The experiments table and where it comes from: built from BATCH's deliveries and the
    DEM (an --out inside BATCH refused, the blocks the DEM covers in part named), or read from
    --table (an --out where an output would replace it refused)."""
    if batch is not None:
        if not dems:
            raise UsageError("BATCH needs --dem: a DEM file or folder of tiles covering the blocks")
        refuse_inside(out, [batch])
        table = build_table(batch, list(dems), options)
        _dem_coverage(table, list(dems))
        return table, str(batch)
    assert table_path is not None
    refuse_replacing(out, OUTPUT_NAMES, [table_path])
    return read_table(table_path), str(table_path)


def _say_results(results: dict[str, Any], written: list[Path], out: Path) -> None:
    """Say how many experiments were analysed, that no correlation was computed when none was,
    the first canonical correlation and its test (or why the CCA was not computed), and the
    files written."""
    n_f, n_i = len(FACTOR_COLUMNS), len(INDICATOR_COLUMNS)
    if results["cca"]:
        r1 = results["cca"]["tests"][0]
        cca_line = (
            f"first canonical correlation {r1['canonical_correlation']:.4f}, "
            f"Bartlett chi2 {r1['chi2']:.2f} on {r1['df']} df, p = {r1['p_value']:.3g}"
        )
    else:
        cca_line = "CCA not computed: " + "; ".join(results["cca_not_computed"])
    if results["correlation"] is None:
        cca_line = f"no correlation computed ({results['correlation_note']}); {cca_line}"
    click.echo(
        f"{results['n_used']} of {results['n_rows']} experiments analysed "
        f"({n_f} factors x {n_i} indicators); {cca_line}"
    )
    click.echo(f"wrote {len(written)} files to {out} (page: {out / 'factors.html'})")
