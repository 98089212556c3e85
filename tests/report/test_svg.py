"""The SVG canvas of the report figures: ticks, paths, rings, arrows and raster layers checked
against hand values and plain per-item constructions."""

from __future__ import annotations

import base64
import io
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blockqc.report import plots, svg, svgplot
from blockqc.report.svg import Frame
from blockqc.report.svgplot import Plot


@settings(max_examples=300, deadline=None)
@given(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.floats(1e-6, 1e6, allow_nan=False),
)
def test_nice_ticks_are_round_evenly_spaced_and_inside(lo, extent):
    extent = max(extent, abs(lo) * 1e-6)  # a window wider than float rounding of its ends
    hi = lo + extent
    ticks = svgplot.nice_ticks(lo, hi)
    assert 2 <= len(ticks) <= 7
    step = ticks[1] - ticks[0]
    assert np.allclose(np.diff(ticks), step, rtol=1e-6, atol=0)
    mantissa = step / 10 ** math.floor(math.log10(step) + 1e-12)
    assert min(abs(mantissa - m) for m in (1, 2, 2.5, 5, 10)) < 1e-6
    tol = step * 1e-6
    assert ticks[0] >= lo - tol and ticks[-1] <= hi + tol
    assert ticks[0] - step < lo + tol and ticks[-1] + step > hi - tol  # none left out
    labels = svgplot.tick_labels(ticks)
    assert len(set(labels)) == len(labels)
    assert np.allclose([float(s) for s in labels], ticks, rtol=0, atol=step * 0.01)


def test_nice_ticks_at_the_ends_of_the_float_range_by_hand():
    """Spans that overflow when subtracted (±1.7e308) or underflow to nothing."""
    # (1.7e308 − 0) / 5 = 3.4e307: the first round step above it is 5e307
    assert svgplot.nice_ticks(0.0, 1.7e308).tolist() == [0.0, 5e307, 1e308, 1.5e308]
    # (1.7e308 + 1.7e308) / 5 = 6.8e307: step 1e308
    assert svgplot.nice_ticks(-1.7e308, 1.7e308).tolist() == [-1e308, 0.0, 1e308]
    # 1e-300 / 5 = 2e-301: step 2e-301, not rounded away to 0
    assert svgplot.nice_ticks(0.0, 1e-300).tolist() == [0.0, 2e-301, 4e-301, 6e-301, 8e-301, 1e-300]
    assert svgplot.nice_ticks(5e-324, 1e-323).tolist() == [5e-324]  # a span of no width


def test_tick_labels_by_hand():
    assert svgplot.tick_labels(np.array([0.0, 0.5, 1.0, 1.5])) == ["0.0", "0.5", "1.0", "1.5"]
    assert svgplot.tick_labels(np.array([0.0, 2.5, 5.0])) == ["0.0", "2.5", "5.0"]
    assert svgplot.tick_labels(np.array([-2000.0, 0.0, 2000.0])) == ["-2000", "0", "2000"]
    assert svgplot.tick_labels(np.array([39.25, 39.5, 39.75])) == ["39.25", "39.50", "39.75"]


def test_path_d_as_written_vertex_by_vertex():
    rng = np.random.default_rng(1)
    xy = rng.uniform(-50, 500, (11, 2))
    starts = np.array([0, 4, 9])
    expected = ""
    for i, (x, y) in enumerate(xy):
        expected += ("M" if i in starts else "L") + f"{x:.1f},{y:.1f}"
        if i + 1 in (4, 9, 11):
            expected += "Z"
    assert svg.path_d(xy, starts, close=True) == expected
    assert svg.path_d(xy, starts) == expected.replace("Z", "")
    assert svg.path_d(np.zeros((0, 2)), np.zeros(0, int)) == ""


def test_frame_maps_the_window_to_the_plot_area():
    fr = Frame(10, 20, 100, 50, (0.0, 4.0), (-1.0, 1.0))
    np.testing.assert_allclose(fr.x([0, 2, 4]), [10, 60, 110])
    np.testing.assert_allclose(fr.y([-1, 0, 1]), [70, 45, 20])  # y up on the page
    fr.invert_y = True
    np.testing.assert_allclose(fr.y([-1, 1]), [20, 70])  # image lines down


def test_rings_select_and_centres_as_per_ring():
    import shapely

    wkts = [
        "POLYGON ((0 0, 2 0, 2 1, 0 1, 0 0))",
        None,
        "MULTIPOLYGON (((10 0, 11 0, 11 1, 10 0)), ((20 0, 24 0, 24 4, 20 4, 20 0)))",
        "POINT (5 5)",
    ]
    from blockqc.report.plots import geometries, rings_of

    rings = rings_of(geometries(wkts))
    assert rings.owner.tolist() == [0, 2, 2]
    parts = [
        np.asarray(shapely.get_coordinates(shapely.from_wkt(w)))
        for w in ("POLYGON ((0 0, 2 0, 2 1, 0 1, 0 0))",)
    ]
    expected = [parts[0][:-1].mean(axis=0), [32 / 3, 1 / 3], [22, 2]]
    np.testing.assert_allclose(rings.centres(), expected)
    kept = rings.select(np.array([False, True, True]))
    assert kept.owner.tolist() == [2, 2] and kept.ring.tolist() == [0] * 4 + [1] * 5
    np.testing.assert_allclose(kept.centres(), expected[1:])
    empty = rings.select(np.zeros(3, bool))
    assert empty.starts().size == 0 and empty.centres().shape == (0, 2)


def test_arrow_outlines_by_hand():
    out = svg.arrow_outlines(np.array([[0.0, 0.0]]), np.array([[20.0, 0.0]]), 2.0)[0]
    # shaft 2 pt wide, head 9 pt long and 6 pt wide, tip at the end
    np.testing.assert_allclose(
        out, [[0, 1], [11, 1], [11, 3], [20, 0], [11, -3], [11, -1], [0, -1]], atol=1e-12
    )
    short = svg.arrow_outlines(np.array([[0.0, 0.0]]), np.array([[0.0, 4.5]]), 2.0)[0]
    np.testing.assert_allclose(short[3], [0, 4.5])  # a short arrow keeps its tip
    np.testing.assert_allclose(short[2], [-1.5, 0])  # and its head shrinks by half
    assert svg.arrow_outlines(np.zeros((1, 2)), np.zeros((1, 2)), 1.0).shape == (0, 7, 2)


def test_wrap_keeps_every_word_and_the_width():
    title = "Tie-point residuals: mean vector per scene and cell of a 4×4 grid\n(longest 0.33 px)"
    lines = svg.wrap(title, 9, 200)
    assert " ".join(lines).replace("\n", " ").split() == title.replace("\n", " ").split()
    assert lines[-1] == "(longest 0.33 px)"
    assert all(svg.text_width(line, 9) <= 200 for line in lines if " " in line)


def test_text_width_counts_wide_characters_one_em():
    assert svg.text_width("连接点", 10) == pytest.approx(30)
    assert 0 < svg.text_width("iii", 10) < svg.text_width("MMM", 10) < 30


def _png_of(svg: str) -> np.ndarray:
    from PIL import Image

    data = re.search(r'href="data:image/png;base64,([^"]+)"', svg).group(1)
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGBA"))


def test_raster_layer_covers_what_it_draws():
    fr = Frame(0, 0, 72, 36, (0.0, 2.0), (0.0, 1.0))  # 1 in × 0.5 in: 150 × 75 pixels
    square = np.array([[[18.0, 9.0], [54.0, 9.0], [54.0, 27.0], [18.0, 27.0]]])  # points
    image = _png_of(svg.raster(fr, [("#c62828", square)]))
    assert image.shape == (75, 150, 4)
    inside, outside = image[25:50, 45:105], image[:15]
    assert (inside[..., 3] == 255).all() and (inside[..., :3] == [0xC6, 0x28, 0x28]).all()
    assert (outside[..., 3] == 0).all()
    # half the width, half the height: 75 × 37.5 pixels; the antialiased edge adds less than a
    # pixel on each side
    covered = image[..., 3].sum() / 255
    assert 75 * 37.5 <= covered <= 77 * 39.5


def test_many_arrows_become_one_image_few_stay_paths():

    def figure(n: int) -> str:
        plot = Plot(2.0, 3.0, title="t")
        tail = np.column_stack([np.arange(n) % 30, np.arange(n) // 30]).astype(float)
        colours = np.full(n, "#1f4e99", dtype=object)
        plot.add(svgplot.arrows(tail, np.full((n, 2), 0.4), colours, 0.6))
        plot.xlim, plot.ylim = (-1.0, 31.0), (-1.0, n / 30 + 1)
        return plot.svg("a")

    few, many = figure(svg.RASTER_ABOVE), figure(svg.RASTER_ABOVE + 1)
    assert "<image" not in few and few.count("Z") == svg.RASTER_ABOVE
    assert "<image" in many and _png_of(many)[..., 3].any()


def test_a_plot_is_well_formed_svg_with_escaped_text():
    plot = Plot(2.0, title="<b>&title</b>", xlabel="x", ylabel="y")
    plot.legend.append(svgplot.LegendEntry("a < b", "#000", "line", "3,1"))
    plot.column_labels = (np.arange(3.0), ["S-1", "<script>", "S&3"], 6.5)
    plot.xlim, plot.ylim = (-0.5, 2.5), (0.0, 10.0)
    svg = plot.svg("p")
    root = ET.fromstring(svg)
    texts = ["".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "<b>&title</b>" in texts and "a < b" in texts and "<script>" in texts
    assert root.get("width").endswith("pt") and root.get("viewBox").startswith("0 0 ")


@pytest.mark.parametrize(
    "window", [(3.0, 3.0), (5.0, 1.0), (float("nan"), 1.0), (0.0, float("inf"))]
)
def test_a_degenerate_window_still_draws(window):
    plot = Plot(2.0, 3.0, title="one value", aspect=1.0)
    plot.xlim = plot.ylim = window
    plot.add(svgplot.markers([3.0], [3.0], "o", "#000", 3.0))
    svg = plot.svg("d")
    ET.fromstring(svg)
    assert "nan" not in svg and "inf" not in svg


def _t(key: str, **kw) -> str:
    return key + "".join(f" {v}" for v in kw.values())


@pytest.mark.parametrize(
    "draw",
    [
        lambda: plots.footprints(
            [{"scene_id": "A", "footprint_wkt": "not wkt"}, {"scene_id": "B"}], {}, _t, "f"
        ),
        lambda: plots.footprints(
            [{"scene_id": "A", "footprint_wkt": "POLYGON ((1 1, 1 1, 1 1, 1 1))"}], {}, _t, "f"
        ),
        lambda: plots.scene_counts([], 100, {}, _t, "c"),
        lambda: plots.scene_counts([{"scene_id": "A", "n_points": None}], None, {}, _t, "c"),
        lambda: plots.residual_histogram({"edges_px": [0, 1], "counts": [1, 2]}, [], _t, "h"),
        lambda: plots.residual_histogram({}, [1.5], _t, "h"),
        lambda: plots.checkpoint_errors([], [], "plane", _t, "e"),
        lambda: plots.checkpoint_vectors(
            [{"component": "plane", "method": "m", "dx_m": 0.0, "dy_m": 0.0, "point_id": "P"}],
            [],
            _t,
            "v",
        ),
        lambda: plots.scene_points("S", [], [], 100, 100, 3, _t, "s"),
    ],
)
def test_figures_of_degenerate_results_are_well_formed(draw):
    """Odd results.json content (no rows, unreadable or flat footprints, missing counts, one
    zero vector) still gives a figure that parses, with no NaN or infinity written."""
    svg_text = draw()
    ET.fromstring(svg_text)
    assert "nan" not in svg_text.lower() and "inf" not in svg_text.lower()


def test_residual_map_leaves_out_cells_without_residuals() -> None:
    """A cell whose residuals are all missing (null in results.json) has no arrow; the others
    are drawn, with the longest one named in the title."""
    from report_helpers import make_results

    from blockqc.report.format import Formatter
    from blockqc.report.maps import residual_map
    from blockqc.results import BlockResults

    doc = make_results()
    sid = doc["scenes"][0]["scene_id"]
    m = next(x for x in doc["measurements"] if x["metric"] == "tie_point_errors")
    m["detail"]["residual_cells"] = [
        {"scene_id": sid, "u": 0.125, "w": 0.125, "n": 3, "v_line": 0.3, "v_sample": 0.4},
        {"scene_id": sid, "u": 0.375, "w": 0.125, "n": 2, "v_line": None, "v_sample": None},
    ]
    svg = residual_map(BlockResults.model_validate(doc), Formatter("en"))
    assert svg is not None and "nan" not in svg.lower()
    assert "0.50" in svg  # the longest arrow: √(0.3² + 0.4²) px
    assert svg.count("Z") == 1  # one arrow outline


def test_points_without_a_position_are_left_out_as_paths_and_as_images():
    for n in (3, svg.RASTER_ABOVE + 5):
        plot = Plot(2.0, 3.0, title="p")
        x = np.r_[np.linspace(0, 10, n - 2), np.nan, 1e30]
        y = np.r_[np.linspace(0, 10, n - 2), 5.0, np.nan]
        plot.add(svgplot.markers(x, y, "o", "#1f4e99", 2.0))
        plot.xlim, plot.ylim = (0.0, 10.0), (0.0, 10.0)
        text = plot.svg("n")
        ET.fromstring(text)
        assert "nan" not in text and "inf" not in text
        if n > svg.RASTER_ABOVE:
            assert _png_of(text)[..., 3].any()
        else:
            assert text.count("a1,1 0 1,0 2,0") == n - 2


def test_a_raster_of_more_colours_than_a_palette_holds_keeps_the_first():
    fr = Frame(0, 0, 36, 36, (0.0, 1.0), (0.0, 1.0))
    square = np.array([[[5.0, 5.0], [30.0, 5.0], [30.0, 30.0], [5.0, 30.0]]])
    layers = [(f"#{k:02x}0000", square) for k in range(20)]
    image = _png_of(svg.raster(fr, layers))
    assert image[37, 37, 3] == 255 and image[37, 37, 0] == 16  # the 17th colour, on top


def test_labels_that_would_overlap_are_left_out():
    from blockqc.report.plots import _apart

    centre = np.array([[0.0, 0.0], [5.0, 2.0], [30.0, 0.0], [0.0, 20.0], [np.nan, 50.0]])
    half = np.array([10.0, 10.0, 10.0, 10.0, 10.0])
    # the second box meets the first (5 < 20 across, 2 < 9 down); the others meet no kept box
    assert _apart(centre, half, 4.5) == [0, 2, 3]


def test_wrap_cuts_a_run_wider_than_a_line():
    title = "连接点残差各影像格网内平均残差矢量最长像素地面方向" * 2
    lines = svg.wrap(title, 9, 100)
    assert "".join(lines) == title and len(lines) > 1
    assert all(svg.text_width(line, 9) <= 100 for line in lines)
    assert svg.wrap("x" * 3, 9, 1) == ["x", "x", "x"]  # never an empty line, one character at least


def test_a_long_legend_label_is_cut_and_the_plot_keeps_its_frame():
    plot = Plot(2.0, 4.0, title="t")
    long = "recalculation with other software, " * 20
    plot.legend.append(svgplot.LegendEntry(long, "#000"))
    plot.xlim, plot.ylim = (0.0, 1.0), (0.0, 1.0)
    root = ET.fromstring(plot.svg("l"))
    texts = ["".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")]
    shown = next(t for t in texts if t.startswith("recalculation"))
    assert shown.endswith("…") and long.startswith(shown[:-1])
    assert svg.text_width(shown, 7) <= 4.0 * 72 / 3 + 1e-9
    frame = root.find("{http://www.w3.org/2000/svg}clipPath")[0]
    assert float(frame.get("width")) > 4.0 * 72 / 3  # the plot keeps most of the figure


def test_long_column_labels_are_cut_and_the_figure_stays_its_size():
    plot = Plot(2.5, title="t")
    labels = ["P-1", "a-point-id-far-longer-than-any-column-label-should-be-" * 3]
    plot.column_labels = (np.arange(2.0), labels, 6.5)
    plot.xlim, plot.ylim = (-0.5, 1.5), (0.0, 1.0)
    root = ET.fromstring(plot.svg("c"))
    texts = ["".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "P-1" in texts
    shown = next(t for t in texts if t.startswith("a-point"))
    assert shown.endswith("…") and svg.text_width(shown, 6.5) <= svgplot.COLUMN_LABEL_PT
    assert float(root.get("height").removesuffix("pt")) <= 2.5 * 72 + svgplot.COLUMN_LABEL_PT + 4
    assert svg.cut("short", 7, 100) == "short"


def test_residual_histogram_marks_name_the_unit_in_the_page_language():
    """A zh page's histogram marks read '0.5 像素' as its axis does, not the English 'px'."""
    from blockqc.report.messages import translator

    edges = [0.5 * i for i in range(25)]  # to 12 px: the bins beyond 10 px drawn as one
    hist = {"edges_px": edges, "counts": [5] * 24}
    for lang, px in (("en", "px"), ("zh", "像素")):
        labels = re.findall(r"<text[^>]*>([^<]*)</text>", plots.residual_histogram(
            hist, [0.5, 1.0, 1.5], translator(lang), "h"))  # fmt: skip
        assert {f"0.5 {px}", f"1 {px}", f"1.5 {px}", f"&gt; 10 {px}: 20"} <= set(labels), labels
        assert lang == "en" or not any("px" in x for x in labels)


def test_control_characters_of_delivered_ids_keep_the_figure_well_formed():
    """An escape or NUL inside a scene or point id is no character XML allows: the figure would
    not be well-formed, and WeasyPrint (which reads each figure of a PDF as XML) would drop it."""
    odd = "\x1b[31mS1\x1b]0;t\x07\x00\ud800\uffff"
    plot = Plot(2.0, title=f"scene {odd}", xlabel="x", ylabel="y")
    plot.column_labels = (np.arange(2.0), [odd, "S&2\t"], 6.5)
    plot.xlim, plot.ylim = (-0.5, 1.5), (0.0, 1.0)
    root = ET.fromstring(plot.svg("c"))
    texts = ["".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")]
    shown = "\ufffd[31mS1\ufffd]0;t\ufffd\ufffd\ufffd\ufffd"
    assert f"scene {shown}" in texts and shown in texts and "S&2\t" in texts
    assert root.get("aria-label") == f"scene {shown}"


def test_scene_counts_name_every_colour_they_draw() -> None:
    """A per-scene rule of severity warn draws its scenes orange: the legend names them (it
    named exempt, waived and failing scenes only)."""
    scenes = [{"scene_id": s, "n_points": n} for s, n in (("A", 40), ("B", 300), ("C", 12))]
    status = {"A": "warn", "C": "exempt"}
    svg_text = plots.scene_counts(scenes, 100, status, _t, "c")
    legend = re.findall(r">([^<>]+)</text>", svg_text)
    assert "status_warn" in legend and "lg_exempt" in legend
    assert plots.STATUS_COLOURS["warn"] in svg_text


def test_checkpoint_error_legend_names_the_norm_lines_drawn():
    """The plane errors' figure draws the norm at +m only (a plane error is a length), yet its
    legend read 'norm ±m' as the heights' does, where ±m is drawn."""
    from blockqc.report.messages import translator
    from blockqc.report.plots import checkpoint_errors

    points = [
        {"component": c, "method": "high_precision", "point_id": f"C{i}", "error_m": e}
        for i, (c, e) in enumerate([("plane", 3.0), ("plane", 5.0), ("height", -2.0)])
    ]
    stats = [
        {"component": c, "method": "high_precision", "norm_m": m, "bound_m": 2 * m}
        for c, m in (("plane", 10.0), ("height", 6.0))
    ]
    legends = (("en", "norm m", "norm ±m"), ("zh", "规定中误差 m", "规定中误差 ±m"))
    for lang, plane, height in legends:
        t = translator(lang)
        assert f">{plane}<" in checkpoint_errors(points, stats, "plane", t, "p")
        assert f">{height}<" in checkpoint_errors(points, stats, "height", t, "h")
