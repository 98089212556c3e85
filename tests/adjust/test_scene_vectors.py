"""The per-scene residual vector map's cell means, by hand."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from blockqc.adjust.report import plot_scene_vectors, scene_cell_means


def _block_and_solution() -> tuple[SimpleNamespace, SimpleNamespace]:
    # two scenes of 100 × 200 px; 2×2 cells: scene 0 has two observations in its top-left
    # cell and one in its bottom-right; scene 1 one observation, an outlier (left out)
    obs = SimpleNamespace(
        scene=np.array([0, 0, 0, 1]),
        line=np.array([10.0, 40.0, 90.0, 5.0]),
        sample=np.array([20.0, 90.0, 150.0, 5.0]),
        n_scenes=2,
    )
    block = SimpleNamespace(
        obs=obs, lines=np.array([100.0, 100.0]), samples=np.array([200.0, 200.0])
    )
    sol = SimpleNamespace(
        v_line=np.array([0.2, 0.4, -1.0, 9.0]),
        v_sample=np.array([0.0, 0.2, 0.5, 9.0]),
        outlier=np.array([False, False, False, True]),
    )
    return block, sol


def test_cell_means_by_hand() -> None:
    block, sol = _block_and_solution()
    vl, vs, n = scene_cell_means(block, sol, k=2)
    assert n[0].tolist() == [[2.0, 0.0], [0.0, 1.0]]
    assert np.isclose(vl[0, 0, 0], 0.3)
    assert np.isclose(vs[0, 0, 0], 0.1)
    assert np.isclose(vl[0, 1, 1], -1.0) and np.isclose(vs[0, 1, 1], 0.5)
    assert n[1].sum() == 0 and np.isnan(vl[1]).all()  # the outlier is not drawn


def test_scene_maps_render_worst_first() -> None:
    block, sol = _block_and_solution()
    summary = {"scenes": [{"scene_id": "A", "rms_px": 0.6}, {"scene_id": "B", "rms_px": None}]}
    png = plot_scene_vectors(block, sol, summary)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_long_scene_ids_do_not_overlap_and_an_empty_map_says_why(monkeypatch) -> None:
    """Two scenes named as Pléiades names them (46 characters): their titles ran into each other
    and under the figure's title; scene B, whose only observation is an outlier, was an empty
    frame. The titles now wrap apart and B's map says it has no kept observation."""
    import matplotlib.pyplot as plt
    from matplotlib.text import Text

    import blockqc.adjust.report as report

    kept = []
    monkeypatch.setattr(report, "_png", lambda fig: kept.append(fig) or b"")
    block, sol = _block_and_solution()
    ids = [f"PHR1B_P_201308051042194_SEN_690908101-00{i}_R1C{i}" for i in (1, 2)]
    rms = (0.6, None)
    summary = {"scenes": [{"scene_id": i, "rms_px": r} for i, r in zip(ids, rms, strict=True)]}
    plot_scene_vectors(block, sol, summary)
    fig = kept[0]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    titles = [fig._suptitle] + [ax.title for ax in fig.axes if ax.title.get_text()]
    assert len(titles) == 3
    for i in (1, 2):  # every character of each id is shown
        assert ids[i - 1] in "".join(titles[i].get_text().split())
    boxes = [t.get_window_extent(renderer) for t in titles]
    assert not any(a.overlaps(b) for j, a in enumerate(boxes) for b in boxes[j + 1 :])
    empty = [t.get_text() for t in fig.axes[1].findobj(Text) if t is not fig.axes[1].title]
    assert "no kept observation" in empty
    plt.close(fig)


def test_the_residual_vector_map_has_a_scale(monkeypatch) -> None:
    """The map of every kept residual vector over the block drew the arrows with no key, so an
    inspector could not tell a 0.3 px residual from a 3 px one; it now shows an arrow of the
    vectors' 95th percentile, to one significant digit, with its length in pixels."""
    import matplotlib.pyplot as plt
    from matplotlib.quiver import QuiverKey

    import blockqc.adjust.report as report

    kept = []
    monkeypatch.setattr(report, "_png", lambda fig: kept.append(fig) or b"")
    rng = np.random.default_rng(5)
    n = 400
    v_line, v_sample = rng.normal(0.0, 0.2, (2, n))
    outlier = np.zeros(n, bool)
    outlier[:5] = True
    v_line[:5] = 40.0  # rejected: not drawn, not in the key
    block = SimpleNamespace(obs=SimpleNamespace(point=np.arange(n)))
    sol = SimpleNamespace(
        lon=rng.uniform(5.0, 5.2, n), lat=rng.uniform(44.0, 44.2, n),
        v_line=v_line, v_sample=v_sample, outlier=outlier,
    )  # fmt: skip
    report.plot_vectors(block, sol, [])
    fig = kept[0]
    keys = [a for a in fig.axes[0].get_children() if isinstance(a, QuiverKey)]
    assert len(keys) == 1
    p95 = np.sort(np.hypot(v_line[5:], v_sample[5:]))[int(round(0.95 * (n - 6)))]
    assert keys[0].text.get_text() == f"{float(f'{p95:.1g}'):g} px"
    plt.close(fig)


def test_the_convergence_and_residual_plots_label_their_vertical_axes(monkeypatch) -> None:
    """The convergence plot (RMS and largest update, log scale) and the two residual histograms
    had no label on their vertical axis: what the bars count, and in what the curves are, was
    left to guess."""
    import matplotlib.pyplot as plt

    import blockqc.adjust.report as report

    kept = []
    monkeypatch.setattr(report, "_png", lambda fig: kept.append(fig) or b"")
    history = [
        {"iteration": i, "phase": p, "rms_px": r, "max_affine_step_px": s, "max_ground_step_px": s}
        for i, p, r, s in ((1, "huber", 6.8, 27.0), (2, "huber", 0.6, 2.7), (3, "ls", 0.25, 1e-3))
    ]
    report.plot_convergence(history)
    report.plot_histograms(np.array([6.0, 7.5, 9.0]), np.array([0.1, 0.2, 0.3]))
    labels = [ax.get_ylabel() for fig in kept for ax in fig.axes]
    assert labels == ["px (log scale)", "observations", "observations"]
    for fig in kept:
        plt.close(fig)


def test_a_scene_id_with_dollar_signs_is_drawn_as_typed() -> None:
    """A scene id 'S$_$1' was read by matplotlib as mathematics on its residual map's title, and
    blockqc adjust stopped with an internal error (a mathtext ParseSyntaxException) after the
    adjustment had converged; the id is drawn as typed."""
    block, sol = _block_and_solution()
    summary = {"scenes": [{"scene_id": "S$_$1", "rms_px": 0.6}, {"scene_id": "B", "rms_px": None}]}
    assert plot_scene_vectors(block, sol, summary)[:8] == b"\x89PNG\r\n\x1a\n"
