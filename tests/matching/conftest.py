"""Fixtures for the §RA-3 matching tests: small real image crops (see tests/data/matching)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.errors import NotGeoreferencedWarning

DATA = Path(__file__).resolve().parents[1] / "data" / "matching"


def read_crop(name: str) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(DATA / name) as ds:
            return ds.read(1).astype(np.float32)


@pytest.fixture(scope="session")
def forest() -> np.ndarray:
    """256×256 Pleiades PAN crop over Mont Ventoux (forest and meadows)."""
    return read_crop("phr_ventoux_left_256.tif")


@pytest.fixture(scope="session")
def city() -> np.ndarray:
    """256×256 WorldView-3 PAN crop over Buenos Aires (dense buildings)."""
    return read_crop("wv3_20_256.tif")
