"""The same gaits in SI and in millimetres and grams: IPOPT's iterations and the largest
differences of the answers, converted back to SI.

    python examples/benchmarks/units_compare.py            # the walking step (HS N = 30), with
                                                           # a 0.1 s double support (N = 20,
                                                           # tol 1e-10), the fixed-base gait
    python examples/benchmarks/units_compare.py --quick    # the walking step at N = 12 only

Millimetres and grams: lengths x 1e3 (mm), masses x 1e3 (g), J x 1e9 (g mm^2), gravity 9810
mm/s^2, torque limits x 1e9 (g mm^2/s^2 = 1e-9 N m), step length and clearance x 1e3 (mm).
Every nominal scale of the problems derives from their own data (leg length, weight, step
length and time, torque limit), so IPOPT sees the same scaled NLP in both unit systems and
should take the same iterations to the same gait. Printed per problem: status and iterations
in each system, the largest |psi_mm - psi_si| (rad), the largest differences of the rates and
the torques relative to their largest SI values, the relative difference of the costs, and the
ratio of the objective scales (1e18 for a torque-squared objective).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from model import Linkage, presets
from problems import periodic_gait, walking_step


def problem(kind: str, linkage: Linkage, length: float, torque: float, **options):
    if kind == "walk":
        return walking_step(
            linkage,
            0.5 * length,
            0.5,
            torque_limit=150.0 * torque,
            clearance=0.05 * length,
            **options,
        )
    return periodic_gait(linkage, torque_limit=300.0 * torque, margin=0.02 * length, **options)


def compare(label: str, kind: str, tol: float = 1e-8, **options) -> str:
    six = presets.six_link_anthropoid()
    ipopt = {"tol": tol}
    si = problem(kind, six, 1.0, 1.0, **options).solve(
        progress=False, raise_on_failure=False, options=ipopt
    )
    mm = problem(kind, six.in_units(length=1e3, mass=1e3), 1e3, 1e9, **options).solve(
        progress=False, raise_on_failure=False, options=ipopt
    )
    a, b = si.to_trajectory(), mm.to_trajectory()
    angles = np.max(np.abs(b.psi - a.psi))
    rates = np.max(np.abs(b.dpsi - a.dpsi)) / np.max(np.abs(a.dpsi))
    torques = np.max(np.abs(b.torques / 1e9 - a.torques)) / np.max(np.abs(a.torques))
    cost = abs(mm.cost / 1e18 - si.cost) / abs(si.cost)
    ratio = mm.solution.stats["objective_scale"] / si.solution.stats["objective_scale"]
    return (
        f"{label:38s} {si.solution.status:16s} {si.solution.iterations:4d}  "
        f"{mm.solution.status:16s} {mm.solution.iterations:4d}  {angles:9.1e} {rates:9.1e} "
        f"{torques:9.1e} {cost:9.1e}  {ratio:.6g}"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the walking step at N = 12 only")
    args = parser.parse_args(argv)
    print(
        f"{'problem':38s} {'SI status':16s} {'iter':>4s}  {'mm/g status':16s} {'iter':>4s}  "
        f"{'|dpsi| rad':>9s} {'rates':>9s} {'torques':>9s} {'cost':>9s}  f_scale mm/SI"
    )
    if args.quick:
        print(compare("walking step, HS N = 12", "walk", N=12))
        return 0
    print(compare("walking step, HS N = 30", "walk"))
    # The double support's optimum is flat: at tol 1e-8 two solves whose starts differ by
    # rounding end up to 5e-6 apart in torque (either unit system), at 1e-10 3e-7 apart.
    print(compare("walk, double support 0.1 s, tol 1e-10", "walk", 1e-10, double_support=0.1, N=20))
    print(compare("fixed-base gait, HS N = 50", "gait"))
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
