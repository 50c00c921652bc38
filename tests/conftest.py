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


@pytest.fixture(scope="session")
def footed_gait():
    """The default step on feet, solved once for the session (~8 s): its tests, its law's
    and its MuJoCo walks read it, none changes it."""
    from problems import footed_step

    return footed_step().solve()


# Compiled NLP functions (planner.native_nlp): the suite never compiles in the background
# (tests/test_native_nlp.py turns it on where it tests it) and writes no user cache.
os.environ.setdefault("ANTHROPOID_COMPILE", "never")


@pytest.fixture(scope="session", autouse=True)
def _private_compile_cache(tmp_path_factory):
    """A cache folder of the session's own for compiled NLPs (command-line tests' processes
    inherit it), unless the caller named one."""
    if "ANTHROPOID_CACHE" in os.environ:
        yield
        return
    os.environ["ANTHROPOID_CACHE"] = str(tmp_path_factory.mktemp("compiled-nlp"))
    yield
    del os.environ["ANTHROPOID_CACHE"]


@pytest.fixture
def nlp_cache(tmp_path, monkeypatch):
    """A compiled-NLP cache folder of the test's own (``$ANTHROPOID_CACHE``), the automatic
    mode on, no solver kept and nothing remembered of other folders
    (tests/test_native_nlp.py, tests/test_native_cache.py)."""
    from planner import native_cache
    from planner.solver_cache import SOLVERS

    root = tmp_path / "cache"
    monkeypatch.setenv("ANTHROPOID_CACHE", str(root))
    monkeypatch.setenv("ANTHROPOID_COMPILE", "auto")
    native_cache.forget()
    SOLVERS.clear()
    yield root
    native_cache.forget()
    SOLVERS.clear()


def human_gait_data(name: str = "Winter_Appendix_data.xlsx"):
    """A file of the shared human walking data (``../shared/human_gait/`` beside the clone,
    or the folder ``$ANTHROPOID_HUMAN_GAIT`` names), or None."""
    from pathlib import Path

    folders = [os.environ.get("ANTHROPOID_HUMAN_GAIT")]
    root = Path(__file__).resolve().parent.parent
    folders += [root.parent / "shared" / "human_gait", root.parent.parent / "shared" / "human_gait"]
    for folder in folders:
        if folder and (Path(folder) / name).is_file():
            return Path(folder) / name
    return None


@pytest.fixture(scope="session")
def winter_xlsx():
    """Winter's appendix workbook (the shared data; CI has it beside the clone)."""
    path = human_gait_data()
    if path is None:
        pytest.skip(
            "the shared human walking data (../shared/human_gait/) is not beside the "
            "clone; set ANTHROPOID_HUMAN_GAIT to its folder"
        )
    return path
