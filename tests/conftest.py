"""Shared test configuration.

The independent oracles live in tests/reference/ and are imported as ``reference.<module>``;
nothing in model/planner/problems imports them.
"""

import os
import sys

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, os.path.dirname(__file__))

from reference.checks import Checker


@pytest.fixture
def check():
    checker = Checker()
    yield checker
    # A test that asks for a checker and compares nothing is a broken test.
    assert checker.failed or checker.count > 0, "no comparison was made"
