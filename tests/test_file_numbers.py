"""Numbers that agree with the file: what a walking plan reports (peaks, iterations, its
sample grid) is what its exported samples hold (issue #37's list).

Oracles: the file written and read back from disk (its torque columns, its times), the hold
rounds' own records of their iterations, the phases' starts.
"""

import numpy as np
import pytest

from model import LinkageTrajectory
from problems import walking_step
from problems.cli.common import phase_starts, sample_grid


@pytest.fixture(scope="module")
def point_gait():
    return walking_step().solve()


def _written(gait, tmp_path):
    path = tmp_path / "torques.csv"
    gait.to_trajectory(1000.0).save(path)
    return LinkageTrajectory.load(path)


@pytest.mark.parametrize("which", ["point", "feet"])
def test_printed_peaks_are_the_files(which, point_gait, footed_gait, tmp_path):
    gait = point_gait if which == "point" else footed_gait
    written = _written(gait, tmp_path)
    peaks = np.max(np.abs(written.torques), axis=0)
    summary = gait.summary()
    for name, value in zip(written.link_names, peaks, strict=True):
        assert summary["peak_torque"][name] == pytest.approx(value, rel=1e-9, abs=1e-9), name


@pytest.mark.parametrize("which", ["point", "feet"])
def test_the_sidecar_counts_every_solves_iterations(which, point_gait, footed_gait, tmp_path):
    gait = point_gait if which == "point" else footed_gait
    rounds = gait.solution.stats["sampled_limits"]["rounds"]
    assert len(rounds) >= 2  # the first solve and at least one hold round
    written = _written(gait, tmp_path)
    total = sum(r["iterations"] for r in rounds)
    assert written.metadata["iterations"] == total == gait.summary()["iterations"]
    assert written.metadata["solves"] == len(rounds)
    assert total > gait.solution.iterations  # the last re-solve's count alone


def test_a_footed_file_is_on_a_grid_per_phase_and_says_so(footed_gait, tmp_path):
    """Each phase sampled every ms from its own start (the interval before a join shorter),
    and the words the command prints say that, with the phases' starts."""
    written = _written(footed_gait, tmp_path)
    times = np.asarray(written.time)
    starts = [t0 for _, t0 in footed_gait.segments()]
    for k, t0 in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else times[-1] + 1.0
        inside = times[(times >= t0 - 1e-12) & (times < end - 1e-12)]
        assert inside[0] == pytest.approx(t0, abs=1e-12)
        np.testing.assert_allclose(np.diff(inside)[:-1], 1e-3, atol=1e-9)
    words = sample_grid(times, 1000.0, phase_starts(written))
    assert words.startswith(f"{times.size} samples every 1 ms from the start of each phase")
    assert "heel rise" in words and "double" in words


def test_the_grid_in_words():
    assert sample_grid(np.arange(501) / 1000.0, 1000.0) == "501 samples every 1 ms from t = 0"
    words = sample_grid(np.zeros(3), 1000.0, [("single", 0.0), ("double", 0.4)])
    assert words == "3 samples every 1 ms from the start of each phase (single 0 s, double 0.4 s)"


def test_progress_lines_are_not_caught_as_ipopt_output(tmp_path):
    """A progress line written while the planner captures descriptor 2 (a solver being
    built) reaches the terminal, not the capture that is logged as IPOPT's output."""
    import subprocess
    import sys

    script = (
        "import sys\n"
        "from problems.cli.common import Reporter\n"
        "from planner.native_output import captured\n"
        "report = Reporter(sys.stderr)\n"
        "with captured() as text:\n"
        "    report.step('heartbeat while building')\n"
        "print('CAPTURED:' + repr(text[0]))\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            timeout=60)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "heartbeat while building" in result.stderr
    assert "heartbeat" not in result.stdout
