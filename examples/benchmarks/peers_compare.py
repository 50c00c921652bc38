"""The planner against the peers a user would pick today, on the same six-link periodic gait, timed
in the same run.

    pip install rockit-meco drake                            # the peers (not dependencies)
    python examples/benchmarks/peers_compare.py              # medians of 3
    python examples/benchmarks/peers_compare.py --quick      # once

The problem is planner_bench's headline: the six-link anthropoid's periodic gait (T = 1 s,
x(0) = x(T)), minimise the integral of sum M_i^2, every angle within +-0.1 rad of the paper's
law (22), the law as the initial guess, N = 50 intervals, IPOPT at tol 1e-8. Each
side writes it in its own terms, as a user would, in the function printed with its line
count (``user lines``: the lines of its body, from the model to the result read, less blank
lines, comments and the clock):

* **ours**: ``planner.OCP``, Hermite-Simpson (separated), implicit dynamics, exact Hessian,
  as a first run (interpreted, nothing cached) and, with a C compiler, as a later run of the
  same structure (``solve(compiled=True)``: the NLP's functions from the disk cache).
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
* **Drake** (``drake``, ``MathematicalProgram``, IPOPT through Drake): the same NLP as ours
  written by hand (Hermite-Simpson separated: states at the nodes and midpoints, the two
  defects of each interval as linear constraints, since xdot = [dpsi; ddpsi] is linear in
  the variables; implicit dynamics ID(psi, dpsi, ddpsi) = M at every point through the
  model's CasADi function, its value and Jacobian handed to Drake's AutoDiff; Simpson's rule
  for the cost). Drake's IPOPT gets no Hessian (its ``IpoptSolver`` asks for L-BFGS) and
  factorises with SPRAL (Drake's IPOPT is built without MUMPS: ``linear_solver`` "mumps"
  is refused).

Each side runs alternately ``--repeat`` times; a peer that is not installed is left out.
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import inspect
import re
import statistics
import sys
import tempfile
import textwrap
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import BAND, LAW, PERIOD  # the benchmark's own headline problem

from model import Dynamics, presets
from planner import OCP, native_nlp

N = 50
TOLERANCE = 1e-8


def ours(
    N: int = N,
    transcription: str = "hermite-simpson",
    degree: int | None = None,
    compiled: bool = False,
):
    """The product: (cost, iterations, build s, solve s); ``compiled``: its NLP functions from
    the disk cache of compiled code (planner.native_nlp), else interpreted as a first run."""
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
                         options={"tol": TOLERANCE}, compiled=compiled)  # fmt: skip
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


def drake_gait(N: int = N):
    """Drake: MathematicalProgram of the same NLP as ours (Hermite-Simpson separated, implicit
    dynamics), IPOPT through Drake: (cost, iterations, build s, solve s)."""
    from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
    from pydrake.solvers import IpoptSolver, MathematicalProgram, SolverOptions

    start = time.perf_counter()
    dynamics = Dynamics(presets.six_link_anthropoid())
    residual = dynamics.function("dynamics_residual")  # ID(psi, dpsi, ddpsi) - M
    v = ca.SX.sym("v", 24)  # [psi; dpsi; ddpsi; M] at one point
    r = residual(v[:6], v[6:12], v[12:18], v[18:])
    value, jacobian = ca.Function("r", [v], [r]), ca.Function("J", [v], [ca.jacobian(r, v)])

    def at_point(w):
        if w.dtype == float:
            return np.asarray(value(w)).ravel()
        w0, dw = ExtractValue(w).ravel(), ExtractGradient(w)
        return InitializeAutoDiff(np.asarray(value(w0)).ravel(), np.asarray(jacobian(w0)) @ dw)

    prog, h, K = MathematicalProgram(), PERIOD / N, 2 * N + 1  # nodes and midpoints
    X, A, U = (
        prog.NewContinuousVariables(n, K, name) for n, name in ((12, "x"), (6, "a"), (6, "M"))
    )
    times = np.linspace(0.0, PERIOD, K)
    for j, t in enumerate(times):
        prog.AddConstraint(
            at_point, np.zeros(6), np.zeros(6), np.concatenate([X[:, j], A[:, j], U[:, j]])
        )
        prog.AddBoundingBoxConstraint(LAW.psi(t) - BAND, LAW.psi(t) + BAND, X[:6, j])
        prog.SetInitialGuess(X[:, j], np.concatenate([LAW.psi(t), LAW.dpsi(t)]))
        prog.SetInitialGuess(A[:, j], LAW.ddpsi(t))
        prog.SetInitialGuess(
            U[:, j], dynamics.inverse_dynamics(LAW.psi(t), LAW.dpsi(t), LAW.ddpsi(t))
        )
    F = np.vstack([X[6:], A])  # xdot = [dpsi; ddpsi], linear in the variables
    for k in range(0, K - 1, 2):
        a, m, b = k, k + 1, k + 2
        prog.AddLinearEqualityConstraint(
            X[:, b] - X[:, a] - h / 6 * (F[:, a] + 4 * F[:, m] + F[:, b]), np.zeros(12)
        )
        prog.AddLinearEqualityConstraint(
            X[:, m] - (X[:, a] + X[:, b]) / 2 - h / 8 * (F[:, a] - F[:, b]), np.zeros(12)
        )
        for j, weight in ((a, 1.0), (m, 4.0), (b, 1.0)):
            prog.AddQuadraticCost(
                h / 6 * weight * np.eye(6) * 2, np.zeros(6), U[:, j], is_convex=True
            )
    prog.AddLinearEqualityConstraint(X[:, 0] - X[:, -1], np.zeros(12))
    options, log = SolverOptions(), Path(tempfile.mkdtemp()) / "ipopt.txt"
    for key, setting in ((("tol", TOLERANCE), ("max_iter", 3000), ("output_file", str(log)),
                         ("file_print_level", 3))):  # fmt: skip
        options.SetOption(IpoptSolver.id(), key, setting)
    built = time.perf_counter() - start
    begin = time.perf_counter()
    result = IpoptSolver().Solve(prog, None, options)
    solve = time.perf_counter() - begin
    if not result.is_success():
        raise RuntimeError(f"Drake/IPOPT: {result.get_solution_result()}")
    iterations = int(re.findall(r"Number of Iterations\.*:\s*(\d+)", log.read_text())[-1])
    return float(result.get_optimal_cost()), iterations, built, solve


def user_lines(function) -> int:
    """Lines of ``function``'s body a user writes: from after its docstring to before its last
    ``return`` (which only hands the timings to this script), less blank lines, comments and
    the lines that read the clock."""
    source = textwrap.dedent(inspect.getsource(function))
    body = ast.parse(source).body[0].body
    if isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]
    if isinstance(body[-1], ast.Return):
        body = body[:-1]
    lines = source.splitlines()[body[0].lineno - 1 : body[-1].end_lineno]
    return sum(
        1
        for line in lines
        if line.strip() and not line.strip().startswith("#") and "perf_counter" not in line
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one run of each")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    repeat = 1 if args.quick else args.repeat
    sides = {"ours (planner.OCP), Hermite-Simpson": ours}
    if native_nlp.compiler() is not None:
        ours(compiled=True)  # compiles into the cache when it lacks this structure

        def ours_compiled():
            return ours(compiled=True)

        sides["  ours, compiled (cache warm)"] = ours_compiled
    for module, label, side, install in (
        ("rockit", "rockit, Legendre(2) collocation", rockit_gait, "pip install rockit-meco"),
        ("pydrake", "Drake MathematicalProgram, the same NLP", drake_gait, "pip install drake"),
    ):
        if importlib.util.find_spec(module) is None:
            print(f"{module} is not installed ({install}): left out")
        else:
            sides[label] = side
    if len(sides) == 1:
        return 0
    warnings.simplefilter("ignore")
    reference, *_ = ours(160, "legendre", 3)
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
            f"{label:<38} {user_lines(ours if 'ours' in label else run):>10} "
            f"{build:8.3f} {solve:8.3f} {total:8.3f} "
            f"{iterations:>6} {cost:13.6f} {cost / reference - 1:17.2e} "
            f"{total / ours_total:12.2f}"
        )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
