"""Plots (matplotlib, SVG and PNG) and the HTML page of a §AF analysis, made from its results."""

from __future__ import annotations

import io
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import jinja2
import matplotlib
import numpy as np
from markupsafe import Markup
from matplotlib.figure import Figure

from blockqc.report.figure_lang import in_language
from blockqc.report.format import Formatter, number
from blockqc.report.html import environment as report_environment
from blockqc.report.html import language_context
from blockqc.report.messages import MESSAGES, translator

TEMPLATE = "factors.html.j2"
EN = translator("en")
"""The figures' labels, in English unless a page's language is given."""


def _save(fig: Figure) -> tuple[bytes, bytes]:
    """The figure as (SVG, PNG) bytes, the SVG free of dates and random ids."""
    svg, png = io.BytesIO(), io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "blockqc", "svg.fonttype": "none"}):
        fig.savefig(svg, format="svg", metadata={"Date": None}, bbox_inches="tight")
    fig.savefig(png, format="png", dpi=120, metadata={"Software": None}, bbox_inches="tight")
    return svg.getvalue(), png.getvalue()


def labels_in(results: dict[str, Any], lang: str) -> dict[str, str]:
    """The factors' and indicators' labels in `lang` (results.json's, in English, for en)."""
    if lang == "en":
        return dict(results["labels"])
    t = translator(lang)
    keys = {
        c: "clark_evans" if c == "tp_nn_coefficient" else f"af_label_{c}" for c in results["labels"]
    }
    return {c: t(k) if k in MESSAGES else results["labels"][c] for c, k in keys.items()}


@in_language
def correlation_heatmap(results: dict[str, Any], lang: str = "en") -> tuple[bytes, bytes] | None:
    """Heatmap of the factors × indicators Pearson matrix, r in each cell (* for p < 0.05); its
    text in `lang`."""
    corr = results.get("correlation")
    if not corr:
        return None
    factors, indicators = results["factors"], results["indicators"]
    t, labels = translator(lang), labels_in(results, lang)
    r = np.array(
        [
            [np.nan if corr["r"][f][i] is None else corr["r"][f][i] for i in indicators]
            for f in factors
        ]
    )
    p = np.array(
        [
            [np.nan if corr["p_value"][f][i] is None else corr["p_value"][f][i] for i in indicators]
            for f in factors
        ]
    )
    fig = Figure(figsize=(1.1 * len(indicators) + 3.2, 0.45 * len(factors) + 1.4))
    ax = fig.subplots()
    im = ax.imshow(np.ma.masked_invalid(r), cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto")
    ax.set_xticks(range(len(indicators)), [labels[i] for i in indicators])
    ax.set_yticks(range(len(factors)), [labels[f] for f in factors])
    ax.xaxis.tick_top()
    for (a, b), v in np.ndenumerate(r):
        text = "–" if not np.isfinite(v) else f"{v:.2f}" + ("*" if p[a, b] < 0.05 else "")
        ax.text(
            b,
            a,
            text,
            ha="center",
            va="center",
            fontsize=8,
            color="white" if np.isfinite(v) and abs(v) > 0.6 else "black",
        )
    fig.colorbar(im, ax=ax, fraction=0.05, pad=0.02, label=t("af_ax_pearson"))
    ax.set_title(t("af_fig_correlation", n=_n_text(corr, t)), fontsize=9, pad=28)
    return _save(fig)


def _n_text(corr: dict[str, Any], t: Callable[..., str] = EN) -> str:
    lo, hi = corr["n_min"], corr["n_max"]
    return f"n = {lo}" if lo == hi else t("af_n_cells", low=lo, high=hi)


@in_language
def structure_plot(results: dict[str, Any], lang: str = "en") -> tuple[bytes, bytes] | None:
    """Structure coefficients of factors and indicators on the first canonical variates U1, V1;
    the text in `lang`."""
    res = results.get("cca")
    if not res:
        return None
    t, labels = translator(lang), labels_in(results, lang)
    fig = Figure(figsize=(9.5, 0.42 * max(len(results["factors"]), 5) + 1.3))
    axes = fig.subplots(1, 2)
    panels = (
        ("factors", res["structure_factors"], "U1", "V1", t("af_fig_factors")),
        ("indicators", res["structure_indicators"], "V1", "U1", t("af_fig_indicators")),
    )
    for ax, (_, struct, own, other, title) in zip(axes, panels, strict=True):
        names = list(struct)
        own_v = np.array([struct[n][own] for n in names], dtype=float)
        other_v = np.array([struct[n][other] for n in names], dtype=float)
        ypos = np.arange(len(names))[::-1]
        ax.barh(ypos, own_v, color=np.where(own_v >= 0, "#b2182b", "#2166ac"), alpha=0.8)
        ax.plot(other_v, ypos, "o", color="black", markersize=4)
        ax.axvline(0, color="grey", lw=0.8)
        for lim in (-0.5, 0.5):
            ax.axvline(lim, color="grey", lw=0.5, ls=":")
        ax.set_yticks(ypos, [labels[n] for n in names])
        ax.set_xlim(-1, 1)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(t("af_ax_structure"))
    r1 = res["tests"][0]["canonical_correlation"]
    # r₁ outside the catalogue: the packaged CJK font has no subscript one (DejaVu draws it)
    fig.suptitle(t("af_fig_first_pair", r=f"r₁ = {r1:.3f}"), fontsize=10)
    fig.tight_layout()
    return _save(fig)


def environment(user_templates: Path | None = None) -> jinja2.Environment:
    """The report environment (autoescape, strict, user templates first) plus its filters."""
    env = report_environment(user_templates)
    env.filters["num"] = _fmt
    env.filters["cell"] = _cell
    return env


def _fmt(v: Any, digits: int = 3) -> str:
    """A number for a table cell: fixed decimals (one from a thousand up), '–' when missing."""
    big = isinstance(v, float | np.floating) and np.isfinite(v) and abs(v) >= 1000
    return number(v, 1 if big else digits)


def _cell(v: Any) -> str:
    """A table cell: whole numbers without decimals, others as `_fmt`."""
    if isinstance(v, float | np.floating) and np.isfinite(v) and float(v).is_integer():
        return number(v)
    return _fmt(v, 3)


def render_html(
    results: dict[str, Any],
    figures: dict[str, bytes],
    user_templates: Path | None = None,
    lang: str = "en",
) -> str:
    """The page in `lang` (en, zh), from the results dictionary and the SVG figures (inlined,
    so it stands alone)."""
    svgs = {name: Markup(_strip_xml_header(data.decode("utf-8"))) for name, data in figures.items()}
    return (
        environment(user_templates)
        .get_template(TEMPLATE)
        .render(r=results, figures=svgs, **_language(results, lang))
    )


def _language(results: dict[str, Any], lang: str) -> dict[str, Any]:
    """The page's words in `lang`: the catalogue's, the labels of the factors and indicators
    (`label`, `labels_of` a list of them), the experiments table's headings (`column`) and
    cells (`cell_of`)."""
    ctx = language_context(lang)
    labels, f = labels_in(results, lang), ctx["f"]

    def column(c: str) -> str:
        if c in labels:
            return labels[c]
        return (
            f.t(f"af_col_{c}")
            if lang == "zh" and f"af_col_{c}" in MESSAGES
            else c.replace("_", " ")
        )

    return ctx | {
        "label": labels.__getitem__,
        "labels_of": lambda columns: ("、" if lang == "zh" else ", ").join(
            map(labels.get, columns)
        ),
        "column": column,
        "cell_of": partial(_cell_of, f),
        "n_text": partial(_n_text, t=f.t),
    }


def _cell_of(f: Formatter, column: str, v: Any) -> str:
    """A cell of the experiments table: the methods and the band of the residuals named in the
    page's language, other values as `_cell`."""
    if f.lang == "en" or not isinstance(v, str) or not v:
        return _cell(v)
    if column.endswith("_method"):
        return f.method(v)
    if column == "residual_band":
        return f.t("af_band_all") if v == "all" else f.cell(v.lower())
    return v


def _strip_xml_header(svg: str) -> str:
    start = svg.find("<svg")
    return svg[start:] if start >= 0 else svg
