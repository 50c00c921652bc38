"""First problem of dynamics: the drive torques of the six-link anthropoid along law (22).

The seed paper's Discussion: substitute the walking law (22) into the equations of motion and
solve them algebraically for the hinge torques. Here the law is a ``problems.GaitLaw``, the
equations are the model's inverse dynamics, and the result is a ``Trajectory`` that exports and
plots like any planner solution.

    python examples/first_problem.py                      # law "paper22", one period, 1 kHz
    python examples/first_problem.py --law walking --output-dir out
    python examples/first_problem.py --quick              # what the test suite runs

Writes to the output folder (default: first_problem_out):
    first_problem.csv / .json    t, psi_i (rad), dpsi_i (rad/s), M_i (N m), ddpsi_i, Fx, Fy (N)
    first_problem.png            angles and torques against time
    first_problem_sticks.png     stick figures along the period (not with --quick)
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from model import Dynamics, presets
from problems import LAW_PRESETS, GaitLaw, torques_along
from problems.cli.common import MAX_RATE_HZ, positive


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--law", default="paper22", choices=sorted(LAW_PRESETS), help="gait-law preset"
    )
    parser.add_argument(
        "--rate-hz",
        type=positive("Hz", MAX_RATE_HZ),
        default=1000.0,
        help="samples per second, Hz, in (0, 1e6] (default: 1000)",
    )
    parser.add_argument("--output-dir", default="first_problem_out", help="output folder")
    parser.add_argument("--quick", action="store_true", help="skip the stick-figure strip")
    args = parser.parse_args(argv)

    dynamics = Dynamics(presets.six_link_anthropoid())
    law = GaitLaw.preset(args.law)
    samples = max(2, round(law.period * args.rate_hz) + 1)
    profile = torques_along(dynamics, law, np.linspace(0.0, law.period, samples))

    folder = Path(args.output_dir)
    folder.mkdir(parents=True, exist_ok=True)
    profile.save(folder / "first_problem.csv")
    profile.save(folder / "first_problem.json")

    os.environ.setdefault("MPLBACKEND", "Agg")
    import matplotlib.pyplot as plt

    from model import drawing
    from planner import plots

    plots.plot_trajectory(profile).savefig(folder / "first_problem.png", dpi=100)
    if not args.quick:
        strip = drawing.stick_figure_strip(dynamics, profile)
        strip.savefig(folder / "first_problem_sticks.png", dpi=100)
    plt.close("all")

    print(law)
    print("t (s)   " + "".join(f"{'M_' + str(i + 1):>10}" for i in range(dynamics.n)) + "  (N m)")
    for k in np.linspace(0, samples - 1, 11).round().astype(int):
        row = profile.torques[k]
        print(f"{profile.time[k]:5.2f}   " + "".join(f"{v:10.2f}" for v in row))
    peak = np.max(np.abs(profile.torques), axis=0)
    print("max|M| " + "".join(f"{v:10.2f}" for v in peak))
    print(f"wrote {folder / 'first_problem.csv'} ({samples} samples) and plots in {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
