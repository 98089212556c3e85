"""adjust's warning of scenes corrected far beyond their a-priori σ (blockqc.adjust.run), on
normalized affines written by hand: a0' … b2' are the shift at the image centre and the pixels
the linear terms add at the image edge (adjust.geometry.affine_from_normalized)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from blockqc.adjust.run import prior_warnings
from blockqc.adjust.solver import Priors
from blockqc.report.format import Formatter

TAIL = (
    "no RPC bias is believed that large: check that each scene's RPC (rpc/) is its own and its "
    "tie points' image coordinates are in its pixels, or give the RPCs' real a-priori accuracy"
)
HEAD = (
    "scene(s) corrected far beyond the a-priori σ of their RPCs (the shift at the image centre "
    "against --sigma-shift, or a linear term at the image edge against --sigma-linear, more "
    "than 5 times)"
)


def _warnings(rows: list[list[float]], fixed: list[bool], shift=10.0, linear=2.0) -> list[str]:
    n = len(rows)
    priors = Priors(shift, linear, np.array(fixed), np.zeros(1), np.ones(1), "none")
    sol = SimpleNamespace(normalized=np.array(rows, dtype=float))
    return prior_warnings(sol, priors, [{"scene_id": f"S{k}"} for k in range(n)])


def test_corrections_within_five_sigma_are_not_warned_of():
    rows = [[30.0, 0, 0, 40.0, 0, 0], [0, 10.0, -10.0, 0, 9.9, 0], [49.9, 0, 0, 0, 0, 0]]
    assert _warnings(rows, [False] * 3) == []  # 50 px shift = 5 σ; 10 px at the edge = 5 σ


def test_the_farthest_are_named_first_and_a_held_scene_never():
    rows = [
        [1000.0, 0, 0, 0, 0, 0],  # held (--fix): its affine is zero in truth; never named
        [0, 0, 0, 60.0, 0, 0],  # 6 σ of shift
        [30.0, 0, 0, 40.0, 0, 0],  # 50 px: 5 σ, not beyond
        [0, 0, 0, 0, 0, -30.0],  # 15 σ of a linear term
        [80.0, 0, 0, 60.0, 0, 0],  # 100 px: 10 σ
    ]
    fixed = [True, False, False, False, False]
    assert _warnings(rows, fixed) == [f"3 {HEAD}: S3 (15 σ); S4 (10 σ); S1 (6 σ); {TAIL}"]


def test_beyond_five_scenes_the_rest_are_counted():
    rows = [[0, 0, 0, 0, 0, 2.0 * (11 + k)] for k in range(7)]  # 11 … 17 σ
    said = _warnings(rows, [False] * 7)
    named = "S6 (17 σ); S5 (16 σ); S4 (15 σ); S3 (14 σ); S2 (13 σ)"
    assert said == [f"7 {HEAD}: {named}, and 2 more (adjustment.csv); {TAIL}"]
    zh = Formatter("zh").sentence(said[0])
    assert zh.startswith("7 景影像的改正量远超其 RPC 的先验 σ") and named in zh
    assert "另有 2 景（adjustment.csv）" in zh


def test_free_priors_warn_of_nothing():
    assert _warnings([[1e6, 0, 0, 0, 0, 0]], [False], shift=np.inf, linear=np.inf) == []
