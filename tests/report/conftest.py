"""Fixtures of the report tests."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from report_helpers import make_results


@pytest.fixture
def results_doc() -> dict[str, Any]:
    return make_results()


@pytest.fixture
def results_file(tmp_path: Path, results_doc: dict[str, Any]) -> Path:
    path = tmp_path / "in" / "T-B01" / "results.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(results_doc, ensure_ascii=False, indent=2), encoding="utf-8")
    return path
