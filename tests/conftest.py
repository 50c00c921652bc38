"""Shared test configuration.

The independent oracles live in tests/reference/ and are imported as ``reference.<module>``;
nothing in model/planner/problems imports them.
"""

import os
import sys

os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, os.path.dirname(__file__))
