"""The long tables of the discrepancy metrics (§RO-1..3): a row per point and component."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from blockqc.metrics import discrepancies


def _table() -> pd.DataFrame:
    """Three points of two pairs, the second point without a height discrepancy."""
    return pd.DataFrame(
        {
            "scene_a": ["A", "A", "B"],
            "scene_b": ["B", "B", "C"],
            "point_id": ["p1", "p2", "p3"],
            "dx_m": [3.0, 0.0, 1.0],
            "dy_m": [4.0, 1.0, 0.0],
            "dz_m": [-2.0, np.nan, 0.5],
        }
    )


def test_each_row_holds_its_component_as_a_code_over_plane_and_height() -> None:
    """Plane rows first (√(dx² + dy²): 5, 1, 1), then the heights given (|dz|: 2, 0.5)."""
    long = discrepancies._long(_table(), ["scene_a", "scene_b", "point_id"])
    assert long["component"].dtype == pd.CategoricalDtype(["plane", "height"])
    assert long["component"].tolist() == ["plane"] * 3 + ["height"] * 2
    assert long["point_id"].tolist() == ["p1", "p2", "p3", "p1", "p3"]
    assert long["value_m"].tolist() == [5.0, 1.0, 1.0, 2.0, 0.5]


def test_the_statistics_per_component_and_pair() -> None:
    """Plane A/B: 5 and 1 (RMS √13); B/C: 1. Height A/B: 2; B/C: 0.5 (RMS of both √2.125)."""
    long = discrepancies._long(_table(), ["scene_a", "scene_b", "point_id"])
    pair = discrepancies._agg(long, ["component", "scene_a", "scene_b"])
    got = list(zip(pair["component"], pair["scene_a"], pair["scene_b"], pair["n"], strict=True))
    assert got == [("plane", "A", "B", 2), ("plane", "B", "C", 1), ("height", "A", "B", 1)] + [
        ("height", "B", "C", 1)
    ]
    assert pair["rms_m"].tolist() == pytest.approx([np.sqrt(13.0), 1.0, 2.0, 0.5])
    comp = discrepancies._agg(long, ["component"])
    assert comp["component"].tolist() == ["plane", "height"]
    assert comp["rms_m"].tolist() == pytest.approx([3.0, np.sqrt(2.125)])
    assert comp["max_m"].tolist() == [5.0, 2.0]
    assert comp["mean_m"].tolist() == pytest.approx([7.0 / 3.0, 1.25])
