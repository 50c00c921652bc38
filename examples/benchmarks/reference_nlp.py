"""The planner's NLP against the same NLP written by hand in CasADi SX, per IPOPT iteration.

    python examples/benchmarks/reference_nlp.py             # medians of 5
    python examples/benchmarks/reference_nlp.py --quick     # medians of 1

The problem is planner_bench's headline, the six-link periodic gait (Hermite-Simpson
separated, N = 50, implicit dynamics, exact Hessian, MUMPS, the planner's IPOPT options). The
reference is what an expert would write without the planner: every variable and row in one
SX expression graph (states at the nodes and midpoints, accelerations and torques at the
same points; the two Hermite-Simpson defects of each interval; ID(psi, dpsi, ddpsi) = M at
every point through the model's SX function, mapped; the band around the law as the
variables' bounds; x(0) = x(T); Simpson's rule for the integral of sum M^2), handed to
``nlpsol`` as SX. Both sides solve with IPOPT's ``bound_relax_factor`` 0: IPOPT relaxes
every bound by 1e-8 of its magnitude by default, and the band written as bounds on angles
of 1-3 rad (the reference) is relaxed 10-30 times more than the same band as rows scaled to
+-1 (the planner), which moves the optimum by 6e-7 of the cost; unrelaxed, both reach the
same optimum to 1e-11. The planner writes the band as constraint rows, the reference as
bounds, so IPOPT's iterations differ a little. The solves, each from a solver built
beforehand:

* the planner as it runs by default (the MX NLP: mapped SX functions, interpreted);
* the planner with the NLP expanded to SX (``solve(expand=True)``);
* the planner with its NLP compiled (``solve(compiled=True)``, :mod:`planner.native_nlp`),
  when a C compiler is there;
* the reference.

Printed: build and solve seconds, iterations, ms per iteration and its ratio to the
reference's (medians of the solves, alternating between the sides).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import BAND, LAW, PERIOD, paper22_gait  # the benchmark's own headline

from model import Dynamics, presets
from planner import native_nlp, solve
from planner.solver import DEFAULT_IPOPT
from planner.solver_cache import SOLVERS
from planner.transcription import Transcription

N = 50
#: Over the planner's defaults, for both sides (see the module's docstring).
IPOPT = {"bound_relax_factor": 0.0}


def reference_solver(N: int = N):
    """(solve() -> (cost, iterations, seconds), build seconds): the hand-written SX NLP."""
    start = time.perf_counter()
    dynamics = Dynamics(presets.six_link_anthropoid())
    residual = dynamics.function("dynamics_residual").map(2 * N + 1)
    K, h = 2 * N + 1, PERIOD / N  # points: nodes and midpoints
    X, A, U = ca.SX.sym("x", 12, K), ca.SX.sym("a", 6, K), ca.SX.sym("M", 6, K)
    F = ca.vertcat(X[6:, :], A)  # xdot = [dpsi; ddpsi]
    a, m, b = range(0, K - 2, 2), range(1, K - 1, 2), range(2, K, 2)
    simpson = X[:, b] - X[:, a] - h / 6 * (F[:, a] + 4 * F[:, m] + F[:, b])
    midpoint = X[:, m] - (X[:, a] + X[:, b]) / 2 - h / 8 * (F[:, a] - F[:, b])
    dynamics_rows = residual(X[:6, :], X[6:, :], A, U)
    g = ca.vertcat(ca.vec(simpson), ca.vec(midpoint), ca.vec(dynamics_rows), X[:, 0] - X[:, -1])
    weights = np.ones(K)
    weights[1::2], weights[2:-1:2] = 4.0, 2.0
    f = h / 6 * ca.sum2(ca.sum1(U**2) * ca.DM(weights).T)
    w = ca.vertcat(ca.vec(X), ca.vec(A), ca.vec(U))
    ipopt = {**DEFAULT_IPOPT, **IPOPT}
    options = {"ipopt": ipopt, "print_time": False, "record_time": True}
    solver = ca.nlpsol("reference", "ipopt", {"x": w, "f": f, "g": g}, options)
    times = np.linspace(0.0, PERIOD, K)
    psi, dpsi, ddpsi = LAW.psi(times), LAW.dpsi(times), LAW.ddpsi(times)
    torques = dynamics.inverse_dynamics(psi, dpsi, ddpsi)
    lower = {"x": np.full((12, K), -np.inf), "a": np.full((6, K), -np.inf)}
    upper = {"x": np.full((12, K), np.inf), "a": np.full((6, K), np.inf)}
    lower["x"][:6], upper["x"][:6] = (psi - BAND).T, (psi + BAND).T

    def bounds(side):
        return np.concatenate([side["x"].T.ravel(), side["a"].T.ravel(),
                               np.full(6 * K, -np.inf if side is lower else np.inf)])  # fmt: skip

    guess = np.concatenate(
        [np.hstack([psi, dpsi]).ravel(), ddpsi.ravel(), np.asarray(torques).ravel()]
    )
    arguments = {"x0": guess, "lbx": bounds(lower), "ubx": bounds(upper), "lbg": 0, "ubg": 0}
    built = time.perf_counter() - start

    def run():
        begin = time.perf_counter()
        result = solver(**arguments)
        seconds = time.perf_counter() - begin
        stats = solver.stats()
        if not stats["success"]:
            raise RuntimeError(f"reference: {stats['return_status']}")
        return float(result["f"]), int(stats["iter_count"]), seconds

    return run, built


def planner_solver(how: str):
    """(solve() -> (cost, iterations, seconds), build seconds) of the planner's headline."""
    start = time.perf_counter()
    ocp = paper22_gait(N)
    problem = ocp if how == "expanded" else Transcription(ocp)
    extra = {"expanded": {"expand": True}, "compiled": {"compiled": True}}.get(how, {})
    extra.setdefault("compiled", how == "compiled")
    extra["options"] = IPOPT

    def run():
        solution = solve(problem, progress=False, warm_start=False, accuracy_warning=None,
                         **extra)  # fmt: skip
        return solution.cost, solution.iterations, solution.stats["solve_seconds"]

    first = solve(problem, progress=False, accuracy_warning=None, **extra)  # builds, caches
    built = time.perf_counter() - start - first.stats["solve_seconds"]
    return run, built


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one solve each")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    repeat = 1 if args.quick else args.repeat
    SOLVERS.clear()
    sides = {"reference (hand-written SX)": reference_solver()}
    sides["planner, default (MX, interpreted)"] = planner_solver("interpreted")
    sides["planner, expand=True (SX)"] = planner_solver("expanded")
    if native_nlp.compiler() is not None:
        sides["planner, compiled=True"] = planner_solver("compiled")
    else:
        print("(no C compiler: the compiled planner is left out)")
    runs: dict[str, list] = {label: [] for label in sides}
    for _ in range(repeat):  # alternating: the machine's noise falls on every side alike
        for label, (run, _) in sides.items():
            runs[label].append(run())
    print(f"six-link periodic gait, Hermite-Simpson N = {N}, exact Hessian, MUMPS; a solver "
          f"built beforehand; medians of {repeat}")  # fmt: skip
    head = (f"{'side':<36} {'build s':>8} {'solve s':>8} {'iters':>6} {'ms/iter':>8} "
            f"{'/ reference':>11} {'cost':>14} {'|dcost|/cost':>12}")  # fmt: skip
    print(head)
    print("-" * len(head))
    reference_cost = runs["reference (hand-written SX)"][0][0]
    reference_per = None
    for label, (_, built) in sides.items():
        cost, iterations, _ = runs[label][-1]
        solve_s = statistics.median(r[2] for r in runs[label])
        per = statistics.median(1000.0 * r[2] / max(r[1], 1) for r in runs[label])
        reference_per = per if reference_per is None else reference_per
        print(f"{label:<36} {built:8.3f} {solve_s:8.3f} {iterations:6d} {per:8.2f} "
              f"{per / reference_per:11.2f} {cost:14.6f} "
              f"{abs(cost - reference_cost) / reference_cost:12.1e}")  # fmt: skip
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
