"""The planner against the peers a user would pick today, on the same six-link periodic gait, timed
in the same run.

    pip install rockit-meco                                  # the peer (not a dependency)
    python examples/benchmarks/peers_compare.py              # medians of 3
    python examples/benchmarks/peers_compare.py --quick      # once

The problem is planner_bench's headline: the six-link anthropoid's periodic gait (T = 1 s,
x(0) = x(T)), minimise the integral of sum M_i^2, every angle within +-0.1 rad of the paper's
law (22), the law as the initial guess, N = 50 intervals, IPOPT with MUMPS at tol 1e-8. Each
side writes it in its own terms, as a user would, in the function printed with its line
count (``user lines``: the function's lines less blank lines, comments and its docstring):

* **ours**: ``planner.OCP``, Hermite-Simpson (separated), implicit dynamics, exact Hessian.
* **rockit** (``rockit-meco``, CasADi-based, the closest peer): no Hermite-Simpson; its
  ``DirectCollocation`` with Legendre points of degree 2 (one control per interval, the
  states' polynomial of degree 2), the explicit forward dynamics of the same model
  (``model.Dynamics``'s "ode": rockit takes an ODE; the mass-matrix solve is inside), the
  band at the collocation points as well as the nodes (``grid="integrator_roots"``; at the
  nodes alone it is another, looser problem), exact Hessian.

The optimum is checked against the continuous problem's, taken from ours at N = 160 with
Legendre(3) (its angles converge as N^-6, planner_bench): each cost's relative distance
from it says how far each mesh of 50 intervals is from the optimum both approximate.
Build = everything from the model to a solver ready to run (for rockit its ``solve`` call
less IPOPT's own time, which includes its evaluation of the guess); solve = IPOPT's wall time.
Drake (``drake``: ``MathematicalProgram`` with IPOPT) is measured in the issue that asked for
this comparison, not here yet: see the note in examples/README.md.
"""

from __future__ import annotations

import argparse
import inspect
import statistics
import sys
import time
import warnings
from pathlib import Path

import casadi as ca

sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import BAND, LAW, PERIOD  # the benchmark's own headline problem

from model import Dynamics, presets
from planner import OCP

N = 50
TOLERANCE = 1e-8


def ours(N: int = N, transcription: str = "hermite-simpson", degree: int | None = None):
    """The product: (cost, iterations, build s, solve s)."""
    start = time.perf_counter()
    dynamics = Dynamics(presets.six_link_anthropoid())
    ocp = (
        OCP(dynamics, T=PERIOD, N=N, transcription=transcription, degree=degree)
        .constrain("near_law", lambda p: p.psi - LAW.psi(p.t), lower=-BAND, upper=BAND)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(LAW)
    )
    defined = time.perf_counter() - start
    solution = ocp.solve(progress=False, accuracy_warning=None, cache=False,
                         options={"tol": TOLERANCE})  # fmt: skip
    stats = solution.stats
    return (
        solution.cost,
        solution.iterations,
        defined + stats["build_seconds"],
        stats["solve_seconds"],
    )


def rockit_gait(N: int = N):
    """rockit: (cost, iterations, build s, solve s)."""
    from rockit import DirectCollocation, Ocp

    start = time.perf_counter()
    ode = Dynamics(presets.six_link_anthropoid()).function("ode")
    ocp = Ocp(T=PERIOD)
    x = ocp.state(12)
    M = ocp.control(6)
    ocp.set_der(x, ode(x, M))
    near_law = x[:6] - LAW.psi(ocp.t)
    ocp.subject_to(-BAND <= (near_law <= BAND), grid="integrator_roots")
    ocp.subject_to(ocp.at_t0(x) == ocp.at_tf(x))
    ocp.add_objective(ocp.integral(ca.sumsqr(M)))
    ocp.set_initial(x, ca.vertcat(LAW.psi(ocp.t), LAW.dpsi(ocp.t)))
    ocp.solver("ipopt", {"ipopt.tol": TOLERANCE, "ipopt.print_level": 0, "ipopt.sb": "yes",
                         "print_time": False, "record_time": True})  # fmt: skip
    ocp.method(DirectCollocation(N=N, degree=2, scheme="legendre"))
    solution = ocp.solve()
    total = time.perf_counter() - start
    stats = solution.stats
    solve = float(stats["t_wall_total"])
    return float(solution.value(ocp.objective)), int(stats["iter_count"]), total - solve, solve


def user_lines(function) -> int:
    """Lines of ``function`` a user writes: no blank line, comment or docstring, no timing."""
    source = inspect.getsource(function).splitlines()
    body = [line.strip() for line in source[1:]]
    count, in_doc = 0, False
    for line in body:
        if line.startswith('"""'):
            in_doc = not (line.count('"""') == 2) and not in_doc
            continue
        if in_doc:
            in_doc = '"""' not in line
            continue
        if not line or line.startswith("#") or "perf_counter" in line or line.startswith("return"):
            continue
        count += 1
    return count


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one run of each")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    repeat = 1 if args.quick else args.repeat
    try:
        import rockit  # noqa: F401
    except ImportError:
        print("rockit is not installed (pip install rockit-meco): nothing to compare")
        return 0
    warnings.simplefilter("ignore")
    reference, *_ = ours(160, "legendre", 3)
    sides = {
        "ours (planner.OCP), Hermite-Simpson": ours,
        "rockit, Legendre(2) collocation": rockit_gait,
    }
    rows = []
    for _ in range(repeat):  # alternating, so that the machine's noise falls on both
        for label, run in sides.items():
            rows.append((label, run()))
    print(
        f"six-link periodic gait, N = {N}, tol {TOLERANCE:g}, medians of {repeat}; the "
        f"continuous optimum from ours at N = 160, Legendre(3): {reference:.6f}"
    )
    head = (
        f"{'side':<38} {'user lines':>10} {'build s':>8} {'solve s':>8} {'total s':>8} "
        f"{'iters':>6} {'cost':>13} {'cost/optimum - 1':>17} {'total / ours':>12}"
    )
    print(head)
    print("-" * len(head))
    ours_total = None
    for label, run in sides.items():
        results = [r for name, r in rows if name == label]
        cost = results[-1][0]
        build = statistics.median(r[2] for r in results)
        solve = statistics.median(r[3] for r in results)
        total = statistics.median(r[2] + r[3] for r in results)
        iterations = results[-1][1]
        ours_total = total if ours_total is None else ours_total
        print(
            f"{label:<38} {user_lines(run):>10} {build:8.3f} {solve:8.3f} {total:8.3f} "
            f"{iterations:>6} {cost:13.6f} {cost / reference - 1:17.2e} "
            f"{total / ours_total:12.2f}"
        )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
