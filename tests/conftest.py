from __future__ import annotations

import os

import pytest
from hypothesis import settings

from casekit import run_blockqc

# CI draws the same examples on every run (HYPOTHESIS_PROFILE=ci, set by .ci/run), so that a
# run on a clean checkout does not depend on the examples drawn; elsewhere they are random.
settings.register_profile("ci", derandomize=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture
def blockqc():
    """The real command line, run in a child process."""
    return run_blockqc
