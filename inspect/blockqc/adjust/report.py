"""Figures and the HTML page of a block adjustment (one artist per figure layer, not per scene)."""

from __future__ import annotations

import dataclasses
import io
import math
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from blockqc.lonlat import centre_lon, unwrap_about, unwrapped
from blockqc.outputs import write_bytes_atomic
from blockqc.report.messages import translator

if TYPE_CHECKING:
    from blockqc.adjust.run import Block
    from blockqc.adjust.solver import Solution

MAX_VECTORS = 20000
"""Residual vectors drawn at most (an even subsample of the kept observations)."""

SCENE_MAPS = 16
"""Scenes given a residual vector map of their own (largest RMS after adjustment first)."""
SCENE_CELLS = 8
"""Cells per side of a scene's map: each arrow is the mean residual of one cell."""
EN = translator("en")
"""The figures' labels, in English unless a page's language is given."""


def _png(fig: object) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, bbox_inches="tight")  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return buf.getvalue()


def _figure(w: float = 7.0, h: float = 4.0, ncols: int = 1) -> tuple:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(1, ncols, figsize=(w, h))


def plot_convergence(history: list[dict], t: Callable[..., str] = EN) -> bytes:
    fig, ax = _figure(7.0, 3.2)
    it = [h["iteration"] for h in history]
    ax.semilogy(it, [max(h["rms_px"], 1e-6) for h in history], "o-", label=t("ad_lg_rms"))
    step = [max(h["max_affine_step_px"], h["max_ground_step_px"], 1e-9) for h in history]
    ax.semilogy(it, step, "s--", label=t("ad_lg_update"))
    for i, h in enumerate(history):
        if i and h["phase"] != history[i - 1]["phase"]:
            ax.axvline(h["iteration"] - 0.5, color="0.6", lw=0.8)
    ax.set_xlabel(t("ad_ax_iteration"))
    ax.set_ylabel(t("ad_ax_log_px"))
    ax.legend()
    return _png(fig)


def plot_histograms(v_before: np.ndarray, v_after: np.ndarray, t: Callable[..., str] = EN) -> bytes:
    fig, axes = _figure(9.0, 3.2, ncols=2)
    titles = (t("ad_fig_before"), t("ad_fig_after"))
    for ax, v, title in zip(axes, (v_before, v_after), titles, strict=True):
        v = v[np.isfinite(v)]
        hi = float(np.percentile(v, 99.5)) if v.size else 1.0
        ax.hist(np.clip(v, 0, hi), bins=60, range=(0, max(hi, 1e-6)), color="#4575b4")
        ax.set_title(title)
        ax.set_xlabel(t("ad_ax_clipped"))
        ax.set_ylabel(t("ax_observations"))
    return _png(fig)


def plot_vectors(
    block: Block, sol: Solution, footprints: list, t: Callable[..., str] = EN
) -> bytes:
    """Every kept observation's residual vector at its ground point, scene outlines behind."""
    from matplotlib.collections import LineCollection

    fig, ax = _figure(8.0, 8.0)
    if footprints:
        ax.add_collection(LineCollection(footprints, colors="0.75", linewidths=0.5))
    kept = np.flatnonzero(~sol.outlier)
    kept = kept[:: max(1, kept.size // MAX_VECTORS)]
    pt = block.obs.point[kept]
    arrows = ax.quiver(
        sol.lon[pt],
        sol.lat[pt],
        sol.v_sample[kept],
        -sol.v_line[kept],
        angles="uv",
        color="#d73027",
        width=0.0015,
    )
    _vector_key(ax, arrows, np.hypot(sol.v_line[kept], sol.v_sample[kept]), t)
    ax.set_ylabel(t("ax_lat"))
    ax.set_aspect(1.0 / max(math.cos(math.radians(float(np.nanmean(sol.lat)))), 0.1))
    ax.autoscale_view()
    _lon_axis(ax, t)
    ax.set_title(t("ad_fig_vectors"))
    return _png(fig)


def _vector_key(ax: Any, arrows: Any, length: np.ndarray, t: Callable[..., str] = EN) -> None:
    """The scale of the residual vectors: an arrow of their 95th percentile to one significant
    digit (0.37 → 0.4 px), under the map's bottom-right corner."""
    length = length[np.isfinite(length)]
    if length.size == 0 or not np.percentile(length, 95) > 0:
        return
    key = float(f"{np.percentile(length, 95):.1g}")
    label = t("px_value", px=f"{key:g}")
    ax.quiverkey(arrows, 0.84, -0.062, key, label, labelpos="E", coordinates="axes")


def scene_cell_means(block: Block, sol: Solution, k: int = SCENE_CELLS) -> tuple[np.ndarray, ...]:
    """Mean kept residual (v_line, v_sample) and count per scene and k×k image cell (ns, k, k)."""
    obs, kept = block.obs, ~sol.outlier
    row = np.clip((obs.line / block.lines[obs.scene] * k).astype(int), 0, k - 1)
    col = np.clip((obs.sample / block.samples[obs.scene] * k).astype(int), 0, k - 1)
    code = (obs.scene * k + row) * k + col
    size = obs.n_scenes * k * k
    n = np.bincount(code, kept.astype(float), size)
    with np.errstate(invalid="ignore", divide="ignore"):
        vl = np.bincount(code, np.where(kept, sol.v_line, 0.0), size) / n
        vs = np.bincount(code, np.where(kept, sol.v_sample, 0.0), size) / n
    shape = (obs.n_scenes, k, k)
    return vl.reshape(shape), vs.reshape(shape), n.reshape(shape)


def plot_scene_vectors(
    block: Block, sol: Solution, summary: dict, t: Callable[..., str] = EN
) -> bytes:
    """Residual vector maps of the scenes with the largest RMS: cell means in image space."""
    rms = np.array([np.nan if s["rms_px"] is None else s["rms_px"] for s in summary["scenes"]])
    order = np.argsort(-np.nan_to_num(rms, nan=-1.0), kind="stable")[:SCENE_MAPS]
    vl, vs, n = scene_cell_means(block, sol)
    k = SCENE_CELLS
    cols = min(4, order.size)
    rows = math.ceil(order.size / cols)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        rows, cols, figsize=(2.4 * cols, 2.8 * rows), squeeze=False, layout="constrained"
    )
    ref = float(np.nanmax(np.hypot(vl[order], vs[order]), initial=0.0)) or 1.0
    centre = (np.arange(k) + 0.5) / k
    u, w = np.meshgrid(centre, centre, indexing="ij")  # u: line fraction, w: sample fraction
    for ax, s in zip(axes.ravel(), order, strict=False):
        ok = n[s] > 0
        ax.quiver(w[ok], u[ok], vs[s][ok], -vl[s][ok], angles="uv", scale=ref * k * 0.9,
                  scale_units="width", color="#d73027", width=0.012)  # fmt: skip
        ax.set(xlim=(0, 1), ylim=(1, 0), xticks=[], yticks=[], aspect="equal")
        _scene_title(ax, summary["scenes"][s]["scene_id"], rms[s], bool(ok.any()), t)
    for ax in axes.ravel()[order.size :]:
        ax.axis("off")
    fig.suptitle(t("ad_fig_scene_vectors", k=k, n=order.size, ref=f"{ref:.3f}"), fontsize=9)
    return _png(fig)


def _scene_title(
    ax: Any, scene_id: str, rms: float, drawn: bool, t: Callable[..., str] = EN
) -> None:
    """A scene map's title, its id wrapped to the map's width (28 characters at 8 pt), and a
    word inside a map left empty because no kept observation falls in the scene."""
    import textwrap

    name = textwrap.fill(str(scene_id), 28, break_on_hyphens=False)
    title = f"{name}\n{t('px_value', px=_fmt(rms))}"
    ax.set_title(title, fontsize=8, parse_math=False)  # an id: "$" as typed
    if not drawn:
        ax.text(0.5, 0.5, t("ad_no_kept"), ha="center", va="center", fontsize=8,
                color="0.4", transform=ax.transAxes)  # fmt: skip


def plot_scene_precision(
    block: Block, sol: Solution, summary: dict, t: Callable[..., str] = EN
) -> bytes:
    fig, ax = _figure(8.0, 6.0)
    obs = block.obs
    n = np.maximum(np.bincount(obs.scene, None, obs.n_scenes), 1)
    lon = np.bincount(obs.scene, np.nan_to_num(sol.lon[obs.point]), obs.n_scenes) / n
    lat = np.bincount(obs.scene, np.nan_to_num(sol.lat[obs.point]), obs.n_scenes) / n
    sig = np.array([s["sigma_shift_centre_px"] for s in summary["scenes"]])
    art = ax.scatter(lon, lat, c=sig, cmap="viridis", s=30)
    fig.colorbar(art, ax=ax, label=t("ad_ax_sigma_shift"))
    _lon_axis(ax, t)
    ax.set_ylabel(t("ax_lat"))
    ax.set_title(t("ad_fig_precision"))
    return _png(fig)


def _lon_axis(ax: Any, t: Callable[..., str]) -> None:
    """The longitude axis of a map, its ticks labelled within ±180° (a block across the
    antimeridian is drawn unwrapped, 179.9 … 180.1, and read -179.9 east of 180)."""
    from blockqc.report.svgplot import tick_labels

    ax.set_xlabel(t("ax_lon"))
    lo, hi = ax.get_xlim()
    ticks = np.array([v for v in ax.get_xticks() if lo <= v <= hi])
    if ticks.size and np.abs(ticks).max() > 180.0:
        ax.set_xticks(ticks, tick_labels(ticks, lon=True))
        ax.set_xlim(lo, hi)


def _footprints(block: Block, centre: float) -> list:
    """The scenes' outlines (lon/lat), unwrapped nearest `centre` (`lonlat`: a block across
    ±180° drawn as one piece, with its points)."""
    import shapely

    text = block.data.scenes["footprint_wkt"].astype(str).to_numpy(dtype=object)
    geoms = unwrapped(shapely.from_wkt(text, on_invalid="ignore"), centre)
    rings = shapely.get_exterior_ring(geoms[shapely.get_type_id(geoms) == 3])  # polygons
    xy, owner = shapely.get_coordinates(rings, return_index=True)
    return np.split(xy, np.flatnonzero(np.diff(owner)) + 1) if len(xy) else []


def _drawn(sol: Solution) -> tuple[Solution, float]:
    """The solution with its points' longitudes unwrapped about their centre, for the maps
    (a block across ±180° drawn as one piece: `lonlat`), and that centre."""
    centre = centre_lon(sol.lon[np.isfinite(sol.lon)])
    if not np.isfinite(centre):
        return sol, 0.0
    return dataclasses.replace(sol, lon=unwrap_about(sol.lon, centre)), centre


def write_figures(
    out: Path, block: Block, sol: Solution, summary: dict, v_before: np.ndarray, lang: str = "en"
) -> dict[str, str]:
    """The five PNG figures of the page (v_before: |v| per observation before adjustment), their
    text in `lang`."""
    from blockqc.report.figure_lang import figure_language

    kept = ~sol.outlier
    v_after = np.hypot(sol.v_line, sol.v_sample)[kept]
    v_before = v_before[kept]
    t = translator(lang)
    drawn, centre = _drawn(sol)
    with figure_language(lang):
        files = {
            "convergence": ("convergence.png", plot_convergence(summary["history"], t)),
            "residual_histogram": ("residual_histogram.png", plot_histograms(v_before, v_after, t)),
            "residual_vectors": (
                "residual_vectors.png",
                plot_vectors(block, drawn, _footprints(block, centre), t),
            ),
            "scene_vectors": ("scene_vectors.png", plot_scene_vectors(block, sol, summary, t)),
            "scene_precision": (
                "scene_precision.png",
                plot_scene_precision(block, drawn, summary, t),
            ),
        }
    for name, data in files.values():
        write_bytes_atomic(out / name, data)
    return {k: v[0] for k, v in files.items()}


def _fmt(value: object, digits: int = 3, t: Callable[..., str] = EN) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    if isinstance(value, bool):
        return t("yes") if value else t("no")
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def render_html(summary: dict, template_dir: Path | None = None, lang: str = "en") -> str:
    """adjust.html from adjust.json's content in `lang` (en, zh); a user's `adjust.html.j2` may
    override."""
    from blockqc.report.html import environment, language_context

    template = environment(template_dir).get_template("adjust.html.j2")
    return template.render(
        r=summary, fmt=partial(_fmt, t=translator(lang)), **language_context(lang)
    )
