"""Problems benchmark: the numbers that the guides' sections on the paper's errata and on the
first and second problems of dynamics quote, measured in one run on the six-link scene and
the benchmark law "paper22".

    python examples/benchmarks/problems_bench.py            # wall times: medians of 5 runs
    python examples/benchmarks/problems_bench.py --quick    # smoke run (each case once)

Printed:

* errata: the largest change of each hinge torque over one period (2001 times) when the
  paper's printed (16)-(17) replace the corrected equations. The printed equations are the
  test suite's transcription of the paper, tests/reference/paper_equations.py (an oracle the
  library never imports; this script runs from a clone, as the tests do);
* the instability of the upright pose: the largest real part of the linearisation's
  eigenvalues (``problems.upright_instability_rate``), 1/s;
* replays of the law's own exact torques (``problems.replay_law``, 1 s, 200 Hz output unless
  stated): per integrator and integration interval, how long the motion stays within 1e-6 rad
  of the law, the growth rate of the deviation fitted over ``FIT_WINDOW``, and the wall time;
* replays of a 1 kHz torque file (``torques_along`` written to CSV and read back; a not-a-knot
  cubic spline between samples) with cvodes at 1e-12, as ``examples/second_problem.py`` runs
  it, and at 1e-10 with 100 Hz output, the defaults of ``python -m problems simulate``.

Horizons and rates do not depend on the machine; wall times do, and nothing here asserts them.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from model import Dynamics, LinkageTrajectory, presets
from problems import GaitLaw, replay_law, torques_along, upright_instability_rate

TESTS = Path(__file__).resolve().parents[2] / "tests"

#: (label, options of replay_law) for the exact torques; the guides' replay table.
EXACT_CASES = (
    ("rk (RK4), 8 steps per 1 ms interval", {"method": "rk", "steps": 8, "max_interval": 1e-3}),
    (
        "collocation, 8 steps per 1 ms interval",
        {"method": "collocation", "steps": 8, "max_interval": 1e-3},
    ),
    (
        "cvodes 1e-12, 10 ms intervals (100 Hz output)",
        {"rtol": 1e-12, "atol": 1e-12, "rate_hz": 100},
    ),
    ("cvodes 1e-12, 5 ms intervals (defaults)", {"rtol": 1e-12, "atol": 1e-12}),
    ("cvodes 1e-12, 1 ms intervals", {"rtol": 1e-12, "atol": 1e-12, "max_interval": 1e-3}),
)

#: (label, options of replay_law) for the 1 kHz file.
FILE_CASES = (
    ("cvodes 1e-12 (examples/second_problem.py)", {"rtol": 1e-12, "atol": 1e-12}),
    ("cvodes 1e-10, 100 Hz output (CLI defaults)", {"rtol": 1e-10, "atol": 1e-10, "rate_hz": 100}),
)


def errata_table(dynamics, law: GaitLaw) -> list[str]:
    """Largest |M_printed - M_corrected| per link along ``law``, N m."""
    sys.path.insert(0, str(TESTS))
    from reference import paper_equations as paper

    t = np.linspace(0.0, law.period, 2001)
    psi, dpsi, ddpsi = law(t)
    literal = paper.paper_literal_torques(dynamics.linkage, psi, dpsi, ddpsi)
    corrected = torques_along(dynamics, law, t).torques
    change = np.max(np.abs(literal - corrected), axis=0)
    return [
        f"errata: max |M_i(printed (16)-(17)) - M_i(corrected)| along {law.name!r}, "
        "2001 times over one period, N m",
        "".join(f"{'M_' + str(i + 1):>10}" for i in range(change.size)),
        "".join(f"{v:10.2f}" if v > 1e-9 else f"{v:10.1e}" for v in change),
    ]


def replay_rows(dynamics, law: GaitLaw, cases, repeat: int, torques=None) -> list[str]:
    """One row per case: horizon (s), growth rate (1/s), median wall time (ms)."""
    rows = [f"{'integration':<48}{'within 1e-6 rad':>16}{'growth 1/s':>12}{'wall ms':>10}"]
    for label, options in cases:
        walls = []
        for _ in range(repeat):
            start = time.perf_counter()
            report = replay_law(dynamics, law, 1.0, torques=torques, **options)
            walls.append(time.perf_counter() - start)
        rows.append(
            f"{label:<48}{report.horizon:>14.3f} s{report.growth_rate:>12.1f}"
            f"{1e3 * statistics.median(walls):>10.1f}"
        )
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: each case once")
    parser.add_argument("--repeat", type=int, default=5, help="runs per case (median)")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else max(1, args.repeat)
    dynamics = Dynamics(presets.six_link_anthropoid())
    law = GaitLaw.preset("paper22")

    print("\n".join(errata_table(dynamics, law)))
    rate = upright_instability_rate(dynamics, np.full(dynamics.n, np.pi / 2))
    print(f"\nupright pose (every psi = pi/2): linearised instability rate {rate:.1f} /s")

    print(f"\nreplay of the exact law torques over 1 s; wall ms: median of {repeat} run(s)")
    print("\n".join(replay_rows(dynamics, law, EXACT_CASES, repeat)))

    with tempfile.TemporaryDirectory() as folder:
        path = torques_along(dynamics, law, np.linspace(0.0, law.period, 1001)).save(
            Path(folder) / "torques.csv"
        )
        profile = LinkageTrajectory.load(path)
    print("\nreplay of a 1 kHz torque file (not-a-knot cubic spline between its samples)")
    print("\n".join(replay_rows(dynamics, law, FILE_CASES, repeat, torques=profile)))
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
