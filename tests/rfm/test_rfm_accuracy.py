"""§RA-4 RMSE and GEV by hand, §RA-5 distortion summary and plots, §RA-6 held-out table."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pyproj import CRS, Transformer
from rfm_helpers import VENTOUX

from blockqc.rfm import accuracy
from blockqc.rfm.dem import constant_height
from blockqc.rfm.model import ImageAffine, RefinedRFM
from blockqc.rfm.readers import read_rpc

LEFT = read_rpc(VENTOUX / "left_image.geom")
UTM31 = CRS.from_epsg(32631)


def test_rmse_and_gev_by_hand():
    # errors (m): (3, 4) → 5, (0, 1) → 1, (-6, 8) → 10; GSD 0.5 m
    dx = np.array([3.0, 0.0, -6.0])
    dy = np.array([4.0, 1.0, 8.0])
    np.testing.assert_allclose(accuracy.gev(dx, dy, 0.5), [10.0, 2.0, 20.0])
    # RMSE = √((25 + 1 + 100)/3) / 0.5 = √42 / 0.5 = 12.961481…
    assert accuracy.rmse_px(dx, dy, 0.5) == pytest.approx(np.sqrt(42.0) / 0.5, rel=1e-12)
    assert np.isnan(accuracy.rmse_px([], [], 0.5))


def test_verdict_against_the_requirement():
    assert accuracy.verdict(0.99) == "pass"
    assert accuracy.verdict(1.0) == "fail"  # §RA-6: RMSE < 1.0 px
    assert accuracy.verdict(float("nan")) == "error"


@settings(max_examples=40, deadline=None)
@given(
    d=arrays(
        np.float64,
        st.tuples(st.integers(2, 30), st.just(2)),
        elements=st.floats(-50, 50, allow_nan=False),
    ),
    k=st.floats(0.1, 10),
    seed=st.integers(0, 10),
)
def test_rmse_is_order_free_and_scales(d, k, seed):
    perm = np.random.default_rng(seed).permutation(len(d))
    r = accuracy.rmse_px(d[:, 0], d[:, 1], 0.5)
    assert accuracy.rmse_px(d[perm, 0], d[perm, 1], 0.5) == pytest.approx(r, rel=1e-12, abs=1e-12)
    assert accuracy.rmse_px(k * d[:, 0], k * d[:, 1], 0.5) == pytest.approx(
        k * r, rel=1e-9, abs=1e-9
    )


def test_pure_shift_has_no_local_distortion():
    rng = np.random.default_rng(0)
    col, row = rng.uniform(0, 1000, (2, 40))
    s = accuracy.distortion_summary(col, row, np.full(40, 1.5), np.full(40, -2.0), 0.5)
    assert s["systematic_px"] == pytest.approx(5.0)  # (3, -4) px
    assert s["local_rms_px"] == pytest.approx(0.0, abs=1e-12)
    assert s["direction_consistency"] == pytest.approx(1.0)
    assert s["significant"] is False


def test_rotation_field_is_significant_distortion():
    """Errors turning around the centre: no common direction, all explained by an affine."""
    rng = np.random.default_rng(1)
    col, row = rng.uniform(-500, 500, (2, 60))
    dx, dy = -0.004 * row, 0.004 * col  # metres; GSD 0.5 → up to ~5.6 px
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["significant"] is True
    assert s["direction_consistency"] < 0.3
    assert s["affine_explained_share"] == pytest.approx(1.0)


def test_plots_are_png():
    rng = np.random.default_rng(2)
    col, row = rng.uniform(0, 500, (2, 20))
    png = accuracy.plot_error_vectors(
        col,
        row,
        rng.normal(0, 1, 20),
        rng.normal(0, 1, 20),
        0.5,
        (500, 500),
        background=rng.normal(size=(50, 50)),
    )
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert accuracy.plot_gev_histogram(rng.uniform(0, 2, 20))[:8] == b"\x89PNG\r\n\x1a\n"


def _synthetic_cps(n: int, truth: ImageAffine, noise_px: float, seed: int):
    """CPs whose true ground is seen through `truth`: the RFM is off by that affine."""
    rng = np.random.default_rng(seed)
    row = rng.uniform(100, 41700, n)
    col = rng.uniform(100, 39100, n)
    h = 700.0
    lon, lat, _ = RefinedRFM(LEFT, truth).image_to_ground(row, col, h)
    # observations carry measurement noise
    row_obs = row + rng.normal(0, noise_px, n)
    col_obs = col + rng.normal(0, noise_px, n)
    x, y = Transformer.from_crs(4326, UTM31, always_xy=True).transform(lon, lat)
    return accuracy.ControlPoints(
        row_obs, col_obs, lon, lat, np.full(n, h), np.asarray(x), np.asarray(y)
    )


def test_refined_rfm_removes_a_known_affine_error_on_held_out_cps():
    truth = ImageAffine(a0=4.0, a1=1e-5, a2=-2e-5, b0=-3.0, b1=2e-5, b2=1e-5)
    cps = _synthetic_cps(40, truth, noise_px=0.0, seed=3)
    table = accuracy.refined_rfm_table(
        LEFT, cps, constant_height(700.0), UTM31, 0.5, ks=(6, 12), repeats=5
    )
    k0 = table.iloc[0]
    # the original RFM is wrong by the affine: ~5 px (image px ≈ ground px at 0.5 m)
    assert k0["k"] == 0 and 3.0 < k0["rmse_px_mean"] < 12.0
    assert table.loc[table.k == 6, "rmse_px_max"].item() < 1e-4
    assert table.loc[table.k == 12, "rmse_px_max"].item() < 1e-4


def test_held_out_rmse_falls_with_k_under_noise():
    truth = ImageAffine(a0=4.0, a1=1e-5, a2=-2e-5, b0=-3.0, b1=2e-5, b2=1e-5)
    cps = _synthetic_cps(60, truth, noise_px=0.5, seed=4)
    table = accuracy.refined_rfm_table(
        LEFT, cps, constant_height(700.0), UTM31, 0.5, ks=(6, 20, 40), repeats=30, seed=1
    )
    means = table.set_index("k")["rmse_px_mean"]
    assert means[0] > means[6] > means[20] > means[40]
    # with many CPs the held-out RMSE approaches the noise: ~0.5·√2 px ground ≈ 0.7 px
    assert means[40] < 1.0


def test_k_beyond_the_cps_is_reported_not_fitted():
    cps = _synthetic_cps(8, ImageAffine(), noise_px=0.0, seed=5)
    table = accuracy.refined_rfm_table(
        LEFT, cps, constant_height(700.0), UTM31, 0.5, ks=(6, 12), repeats=2
    )
    row = table.set_index("k").loc[12]
    assert row["repeats"] == 0 and np.isnan(row["rmse_px_mean"]) and "n = 8" in row["note"]


def test_batched_draws_equal_one_fit_per_draw():
    """Every draw's held-out RMSE as `held_out_rmse` computes it, one affine fit at a time."""
    truth = ImageAffine(a0=4.0, a1=1e-5, a2=-2e-5, b0=-3.0, b1=2e-5, b2=1e-5)
    cps = _synthetic_cps(30, truth, noise_px=0.7, seed=6)
    dem = constant_height(700.0)
    perms = accuracy.draws(30, 7, seed=2)
    to_map = Transformer.from_crs(4326, UTM31, always_xy=True)
    for k in (3, 6, 20):
        batch = accuracy.held_out_rmse_batch(LEFT, cps, perms, k, dem, to_map, 0.5)
        one_by_one = [
            accuracy.held_out_rmse(LEFT, cps, p[:k], p[k:], dem, UTM31, 0.5) for p in perms
        ]
        np.testing.assert_allclose(batch, one_by_one, rtol=1e-7)


def test_refined_rfm_table_solves_all_draws_of_a_k_together(monkeypatch):
    """§RA-6 cost: one image→ground on the DEM per k, not one per draw."""
    from blockqc.rfm.model import RPCModel

    cps = _synthetic_cps(30, ImageAffine(a0=2.0), noise_px=0.3, seed=7)
    calls = []
    original = RPCModel.image_to_ground

    def counting(self, *args, **kwargs):
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(RPCModel, "image_to_ground", counting)
    table = accuracy.refined_rfm_table(
        LEFT, cps, constant_height(700.0), UTM31, 0.5, ks=(6, 12), repeats=25
    )
    assert (table.repeats[1:] == 25).all() and np.isfinite(table.rmse_px_mean).all()
    assert len(calls) <= 3


def test_draws_on_collinear_cps_are_left_out_not_fatal():
    """Seven of ten CPs on one line: some 3-CP draws cannot fix an affine."""
    cps = _synthetic_cps(10, ImageAffine(a0=2.0), noise_px=0.0, seed=8)
    line = np.linspace(1000.0, 30000.0, 7)
    row = cps.row.copy()
    col = cps.col.copy()
    row[:7], col[:7] = line, line
    lon, lat, _ = LEFT.image_to_ground(row + 2.0, col, 700.0)
    x, y = Transformer.from_crs(4326, UTM31, always_xy=True).transform(lon, lat)
    cps = accuracy.ControlPoints(row, col, lon, lat, np.full(10, 700.0), *map(np.asarray, (x, y)))
    table = accuracy.refined_rfm_table(
        LEFT, cps, constant_height(700.0), UTM31, 0.5, ks=(3,), repeats=40
    )
    row3 = table.set_index("k").loc[3]
    assert "collinear" in row3["note"] and row3["rmse_px_max"] < 1e-4


def test_k_warnings_name_unsupported_and_thin_rows():
    warnings = accuracy.k_warnings((6, 12, 16, 20), 18)
    assert len(warnings) == 3
    assert "k = 12 leaves 6 CPs" in warnings[0] and "k = 20 needs more than 20" in warnings[2]
    assert accuracy.k_warnings((6, 12), 60) == []


def _noise_field(n: int, sigma_px: float, seed: int, gsd: float = 0.5):
    rng = np.random.default_rng(seed)
    col, row = rng.uniform(0, 5000, (2, n))
    dx, dy = rng.normal(0.0, sigma_px * gsd, (2, n)) + np.array([[1.0], [-0.5]])
    return col, row, dx, dy


def test_matching_noise_is_not_distortion():
    """0.5 px of matching noise about a shift: the RMS about the mean (0.7 px) exceeds 0.5 px,
    but no field over the image explains it."""
    col, row, dx, dy = _noise_field(200, 0.5, seed=11)
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["local_rms_px"] > 0.6
    assert s["significant"] is False and s["p_value"] > 0.01
    assert s["noise_robust_px"] == pytest.approx(0.5, abs=0.08)
    assert s["mean_dx_m"] == pytest.approx(1.0, abs=0.05) and s["mean_dx_px"] == pytest.approx(
        2.0, abs=0.1
    )


def test_f_statistic_against_an_independent_fit():
    """F = ((RSS_mean − RSS_affine)/4) / (RSS_affine/(2n − 6)), fits by scikit-learn."""
    from scipy.stats import f as f_dist
    from sklearn.linear_model import LinearRegression

    col, row, dx, dy = _noise_field(80, 0.5, seed=12)
    dx = dx + 0.0002 * col  # a weak scale error along columns
    e = np.column_stack([dx, dy]) / 0.5
    X = np.column_stack([col, row])
    rss_a = float(np.sum((e - LinearRegression().fit(X, e).predict(X)) ** 2))
    rss_0 = float(np.sum((e - e.mean(axis=0)) ** 2))
    f = ((rss_0 - rss_a) / 4) / (rss_a / (2 * 80 - 6))
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["model"] == "affine"
    assert s["f_statistic"] == pytest.approx(f, rel=1e-9)
    assert s["p_value"] == pytest.approx(f_dist.sf(f, 4, 154), rel=1e-9)
    assert s["field_rms_px"] == pytest.approx(np.sqrt((rss_0 - rss_a) / 80), rel=1e-9)


def test_an_affine_field_above_the_threshold_is_distortion():
    col, row, dx, dy = _noise_field(100, 0.3, seed=13)
    dx = dx + 0.0006 * (col - 2500)  # ±1.5 px along columns, field RMS ≈ 0.87 px
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["significant"] is True and s["p_value"] < 1e-6 and s["field_rms_px"] > 0.5


def test_a_significant_but_tiny_field_is_not_flagged():
    col, row, dx, dy = _noise_field(3000, 0.3, seed=14)
    dx = dx + 0.00012 * (col - 2500)  # field RMS ≈ 0.17 px: real but below the threshold
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["p_value"] < 1e-6 and s["field_rms_px"] < 0.5 and s["significant"] is False


def test_a_bowl_is_fitted_by_the_quadratic():
    col, row, dx, dy = _noise_field(150, 0.2, seed=15)
    u = (col - 2500) / 2500
    dx = dx + 1.0 * (u * u) * 0.5  # up to 1 px at the edges, no affine part
    s = accuracy.distortion_summary(col, row, dx, dy, 0.5)
    assert s["model"] == "quadratic" and s["significant"] is False  # field RMS ≈ 0.3 px
    s = accuracy.distortion_summary(col, row, dx * 3, dy, 0.5)
    assert s["model"] == "quadratic" and s["significant"] is True


@settings(max_examples=30, deadline=None)
@given(
    a=st.floats(-0.002, 0.002),
    b=st.floats(-0.002, 0.002),
    shift=st.floats(-5, 5),
    seed=st.integers(0, 100),
)
def test_an_exact_affine_field_is_explained_and_measured(a, b, shift, seed):
    rng = np.random.default_rng(seed)
    col, row = rng.uniform(0, 4000, (2, 30))
    dx = shift + a * (col - 2000)
    dy = b * (row - 2000)
    s = accuracy.distortion_summary(col, row, dx, dy, 1.0)
    field = np.sqrt(np.mean((dx - dx.mean()) ** 2 + (dy - dy.mean()) ** 2))
    assert s["field_rms_px"] == pytest.approx(field, rel=1e-6, abs=1e-9)
    assert s["significant"] is bool(field >= 0.5 and field > 1e-9)


@pytest.mark.parametrize("shape", [(4000, 800), (600, 4000), (500, 500)])
def test_vector_plot_scale_key_is_inside_the_figure_and_clear_of_the_axes(monkeypatch, shape):
    """The key (arrow and label) lies inside the saved figure and does not overlap the image
    axes, their tick labels or the column label, for tall, wide and square images."""
    import re

    from matplotlib.text import Text

    kept = []
    monkeypatch.setattr(accuracy, "_figure_png", lambda fig: kept.append(fig) or b"")
    rng = np.random.default_rng(3)
    col, row = rng.uniform(0, shape[1], 30), rng.uniform(0, shape[0], 30)
    accuracy.plot_error_vectors(col, row, rng.normal(0, 1, 30), rng.normal(0, 1, 30), 0.5, shape)
    fig = kept[0]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    keys = [t for t in fig.findobj(Text) if re.match(r"^\d+(\.\d+)? px", t.get_text())]
    assert keys, "no scale key"
    box = keys[0].get_window_extent(renderer)
    inside = fig.bbox
    assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0
    assert box.y1 <= inside.y1
    assert not box.overlaps(fig.axes[0].get_tightbbox(renderer))
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_vector_plot_of_vanishing_errors_keeps_its_size():
    """Errors of 1e-9 px (a reference identical to the image): a key of 1e-09 px, same figure."""
    col, row = np.linspace(0, 500, 20), np.linspace(0, 480, 20)
    png = accuracy.plot_error_vectors(col, row, np.full(20, 5e-10), np.zeros(20), 0.5, (480, 520))
    import io

    from PIL import Image

    assert max(Image.open(io.BytesIO(png)).size) < 2000


def test_vector_plot_title_of_long_file_names_stays_within_the_figure(monkeypatch):
    """A 140-character image name: the title ran on one line far past the figure's right edge,
    so the saved PNG was twice as wide and the page shrank the image under it; the title now
    wraps inside the figure, every character of the names kept."""
    from matplotlib.text import Text

    kept = []
    monkeypatch.setattr(accuracy, "_figure_png", lambda fig: kept.append(fig) or b"")
    name = "left_image_" * 12 + "x.tif"
    title = f"CP error vectors, {name} vs right_image.tif"
    rng = np.random.default_rng(4)
    col, row = rng.uniform(0, 500, (2, 10))
    dx, dy = rng.normal(0, 1, (2, 10))
    accuracy.plot_error_vectors(col, row, dx, dy, 0.5, (500, 500), title=title)
    fig = kept[0]
    fig.canvas.draw()
    shown = [t for t in fig.findobj(Text) if "CP error vectors" in t.get_text()]
    assert len(shown) == 1
    assert "".join(shown[0].get_text().split()) == "".join(title.split())
    box = shown[0].get_window_extent(fig.canvas.get_renderer())
    assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_gev_histogram_counts_whole_cps(monkeypatch):
    """Five CPs (a run with a large --grid): the count axis was ticked 0.25, 0.50 … 1.75 CPs; it
    is ticked in whole CPs, up to the tallest bar (two CPs here)."""
    kept = []
    monkeypatch.setattr(accuracy, "_figure_png", lambda fig: kept.append(fig) or b"")
    accuracy.plot_gev_histogram([5.3, 5.6, 7.1, 8.0, 9.4])
    fig = kept[0]
    fig.canvas.draw()
    ax = fig.axes[0]
    low, high = ax.get_ylim()
    ticks = [t for t in ax.get_yticks() if low <= t <= high]
    assert ticks and all(float(t).is_integer() for t in ticks)
    assert max(p.get_height() for p in ax.patches) == 2
    import matplotlib.pyplot as plt

    plt.close(fig)


@pytest.mark.parametrize("name", ["a$_$b.tif", "scene_$x$_1.tif"])
def test_vector_plot_title_shows_dollar_signs_as_typed(monkeypatch, name):
    """An image named with '$' signs: matplotlib read its title as mathematics, so 'a$_$b.tif'
    stopped rfm-accuracy with an internal error (a mathtext ParseSyntaxException) after all the
    matching, and 'scene_$x$_1.tif' came out as 'scene_x_1.tif' with an italic x. The names are
    now drawn as typed."""
    from matplotlib.text import Text

    kept = []
    monkeypatch.setattr(accuracy, "_figure_png", lambda fig: kept.append(fig) or b"")
    title = f"CP error vectors, {name} vs right_image.tif"
    xy, d = np.array([10.0, 20.0]), np.array([0.1, 0.2])
    accuracy.plot_error_vectors(xy, xy, d, d, 0.5, (50, 50), title=title)
    fig = kept[0]
    fig.canvas.draw()  # mathematics would be parsed (and fail) here
    (shown,) = [t for t in fig.findobj(Text) if "CP error vectors" in t.get_text()]
    assert shown.get_text() == title
    # as typed, the two '$' take room: wider than the title drawn without them
    bare = fig.text(0, 0, title.replace("$", ""), fontproperties=shown.get_fontproperties())
    renderer = fig.canvas.get_renderer()
    dollar = bare.get_window_extent(renderer).width / len(bare.get_text())  # about one glyph
    assert shown.get_window_extent(renderer).width > bare.get_window_extent(renderer).width + dollar
    import matplotlib.pyplot as plt

    plt.close(fig)
