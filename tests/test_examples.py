"""The examples run as a user runs them (a subprocess each), in their --quick form."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from planner.trajectory import Trajectory
from problems import GaitLaw

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(script: str, *argv) -> str:
    env = dict(os.environ, MPLBACKEND="Agg")
    result = subprocess.run(
        [sys.executable, str(EXAMPLES / script), "--quick", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    return result.stdout


def test_first_then_second_problem(tmp_path):
    out = _run("first_problem.py", "--output-dir", tmp_path)
    for name in ("first_problem.csv", "first_problem.json", "first_problem.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert "max|M|" in out
    profile = Trajectory.load(tmp_path / "first_problem.csv")
    law = GaitLaw.preset("paper22")
    np.testing.assert_array_equal(profile.psi, law.psi(profile.time))
    assert profile.time.size == 1001  # 1 kHz over one period

    out = _run("second_problem.py", "--output-dir", tmp_path)
    assert (tmp_path / "second_problem.png").stat().st_size > 0
    motion = Trajectory.load(tmp_path / "second_problem.csv")
    assert motion.time[-1] == 0.4
    horizon = float(re.search(r"stays within 1e-6 rad of the law for ([0-9.]+) s", out).group(1))
    assert horizon >= 0.2  # measured 0.27 s from the 1 kHz file
    rate = float(re.search(r"grows ~exp\(([0-9.]+) t\)", out).group(1))
    assert 15.0 < rate < 40.0


def test_second_problem_writes_its_input_when_missing(tmp_path):
    out = _run("second_problem.py", "--output-dir", tmp_path / "fresh")
    assert "(it was missing)" in out
    assert (tmp_path / "fresh" / "first_problem.csv").exists()
