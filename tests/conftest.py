from __future__ import annotations

import pytest

from casekit import run_blockqc


@pytest.fixture
def blockqc():
    """The real command line, run in a child process."""
    return run_blockqc
