"""Second problem of dynamics: integrate the six-link anthropoid under exported torques.

Reads the torque profile written by ``examples/first_problem.py`` (and writes it first if it
is missing), integrates the twelfth-order system from the file's first state with CasADi's
cvodes, and compares the motion with the gait law it came from: the law recorded in the
file's metadata (so a file made with ``--law walking`` is compared with "walking"), or
``--law`` for a file without one. The upright linkage is
unstable: the open-loop replay follows the law while the integration and interpolation errors
are small and then diverges exponentially; the script prints how long it stays within
1e-6 rad and the fitted growth rate.

    python examples/second_problem.py                       # 1 s horizon
    python examples/second_problem.py --quick               # what the test suite runs
    python examples/first_problem.py --law walking && python examples/second_problem.py

Writes second_problem.csv (the simulated motion) and second_problem.png (deviation from the law
against time, log scale) to the output folder (default: first_problem_out).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from model import Dynamics, LinkageTrajectory, presets
from problems import LAW_PRESETS, GaitLaw, fit_growth_rate, simulate, torques_along
from problems.cli.common import positive


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--law",
        choices=sorted(LAW_PRESETS),
        help="gait law for a file without one in its metadata, and for writing a missing "
        "file (default: the file's law, else paper22)",
    )
    parser.add_argument("--output-dir", default="first_problem_out", help="folder of the files")
    parser.add_argument("--horizon-s", type=positive("s"), default=1.0, help="simulated time, s")
    parser.add_argument("--quick", action="store_true", help="0.8 s horizon")
    args = parser.parse_args(argv)

    dynamics = Dynamics(presets.six_link_anthropoid())
    folder = Path(args.output_dir)
    folder.mkdir(parents=True, exist_ok=True)
    source = folder / "first_problem.csv"
    if not source.exists():
        law = GaitLaw.preset(args.law or "paper22")
        profile = torques_along(dynamics, law, np.linspace(0.0, law.period, 1001))
        profile.save(source)
        print(f"wrote {source} (it was missing)")
    profile = LinkageTrajectory.load(source)
    if "law" in profile.metadata:  # written by torques_along: the law it was made from
        law = GaitLaw.from_dict(profile.metadata["law"])
        if args.law is not None and law != GaitLaw.preset(args.law):
            parser.error(
                f"--law {args.law} differs from the law {law.name!r} that {source} was made "
                "from; leave --law out to use the file's"
            )
    else:
        law = GaitLaw.preset(args.law or "paper22")
    print(f"comparing with {law}")

    horizon = min(0.8 if args.quick else args.horizon_s, float(profile.time[-1]))
    x0 = np.concatenate([profile.psi[0], profile.dpsi[0]])
    motion = simulate(dynamics, profile, x0, (0.0, horizon), rate_hz=200.0, rtol=1e-12, atol=1e-12)
    motion.save(folder / "second_problem.csv")

    deviation = np.max(np.abs(motion.psi - law.psi(motion.time)), axis=1)
    above = np.nonzero(deviation > 1e-6)[0]
    stays = motion.time[above[0]] if above.size else motion.time[-1]
    rate = fit_growth_rate(motion.time, deviation)  # 1/s, fit over FIT_WINDOW (1e-7..1e-3 rad)
    print(f"simulated {horizon:g} s with cvodes in {motion.metadata['wall_seconds']:.2f} s")
    print("t (s)   max_i |psi_i - law_i| (rad)")
    for k in np.linspace(0, motion.time.size - 1, 9).round().astype(int):
        print(f"{motion.time[k]:5.2f}   {deviation[k]:.3e}")
    whole = "" if above.size else " (the whole run)"
    print(f"stays within 1e-6 rad of the law for {stays:.3f} s{whole}")
    if np.isfinite(rate):
        print(f"deviation grows ~exp({rate:.1f} t)")
    else:
        print("deviation too small to fit a growth rate (it stays below 1e-7 rad)")

    os.environ.setdefault("MPLBACKEND", "Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6, 3.5))
    axis.semilogy(motion.time, np.maximum(deviation, 1e-16))
    axis.axhline(1e-6, color="grey", linestyle=":")
    axis.set_xlabel("t (s)")
    axis.set_ylabel("max |psi - psi_law| (rad)")
    axis.set_title("Replay of the law's torques (open loop)")
    figure.tight_layout()
    figure.savefig(folder / "second_problem.png", dpi=100)
    plt.close("all")
    print(f"wrote {folder / 'second_problem.csv'} and {folder / 'second_problem.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
