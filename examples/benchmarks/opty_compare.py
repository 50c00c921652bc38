"""Our planner against opty on the same six-link periodic gait, timed in the same run.

What is compared
----------------
The problem is the planner benchmark's six-link periodic gait, built by
``planner_bench.paper22_gait`` (scene.md anthropoid, T = 1 s, x(0) = x(T), minimise the
integral of sum M_i^2, every angle within +-0.1 rad of the paper22 law, the law as initial
guess, N = 50 intervals). The opty problem is *generated from that OCP value*: period, N,
variable bounds, periodicity, path constraints (affine in the state and torques plus any
function of time, like the band around the law: the time part enters opty as a known
trajectory, the bounds as ``eom_bounds``) and the integral objective are read from the OCP,
so the two sides cannot drift apart. Differences that remain, by design of each tool:

- transcription: ours is Hermite-Simpson (separated), implicit dynamics (ddpsi variables,
  inverse-dynamics residual, no mass-matrix solve); opty collocates its own way: "midpoint"
  (states and torques averaged over each interval, derivatives as (x_{k+1} - x_k) / h) or
  "backward euler", at the same N + 1 nodes. The six-link equations for opty are sympy
  expressions of the DESIGN.md closed form (``_six_link_sympy.py``), first order with
  dpsi' in place of ddpsi, so opty too is "implicit" (no mass-matrix inverse). They are
  checked against ``model.Dynamics.inverse_dynamics`` at random states (to 1e-10 N m) before
  anything is timed.
- objective: the OCP's integrand, evaluated by a CasADi Function inside opty's objective and
  gradient callbacks with the quadrature that matches opty's transcription (midpoint or
  right-point rule; opty's own ``create_objective_function`` has a midpoint gradient that is
  not the gradient of its midpoint objective, so it is not used).
- path constraint points: ours at every dynamics point (nodes and midpoints for
  Hermite-Simpson); opty's midpoint method on interval averages, backward euler at the nodes.
- Hessian: ours is exact (CasADi); opty gives IPOPT no Hessian, so cyipopt runs IPOPT with
  ``hessian_approximation = limited-memory`` (L-BFGS). The "ours, L-BFGS" row switches ours
  to the same approximation to separate the Hessian's share from the rest; the "ours
  trapezoid" row has opty's node count (N + 1 points).
- IPOPT: ours is CasADi's bundled IPOPT; opty's is Debian's coinor-libipopt-dev (3.11.9),
  both with MUMPS; the same tol and max_iter.
- guess: opty starts from the planner's own guess at its nodes (the gait law, torques by
  inverse dynamics), taken from the same OCP refined to a trapezoidal mesh (nodes only).

Build time: ours = OCP definition (where the SX equations are generated) + transcription +
``nlpsol`` setup (the planner's ``build_seconds``); opty = sympy equations + ``opty.Problem``
(symbolic Jacobian, C code generation and a Cython compile of two modules). The compile is
skipped when opty finds the same module in a cache directory (``tmp_dir``); the "cached"
column is that warm build, the cold build is the one a user pays on a new problem.
Each number is the median of the repeats; ratios are ours / opty, measured in this run.

Installing opty (not a dependency of the project; CI skips this script)::

    apt-get install -y coinor-libipopt-dev pkg-config liblapack-dev libblas-dev
    pip install cyipopt opty

(liblapack-dev and libblas-dev provide the -llapack/-lblas link names that cyipopt's build
asks for; without them its wheel fails to link.)

Run: ``python examples/benchmarks/opty_compare.py`` (3 repeats) or ``--quick`` (1 repeat).
Without opty or cyipopt it prints one line saying so and exits 0.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

INSTALL_HINT = (
    "apt-get install -y coinor-libipopt-dev pkg-config liblapack-dev libblas-dev && "
    "pip install cyipopt opty"
)
IPOPT_OPTIONS = {"tol": 1e-8, "max_iter": 3000}
CHECK_TOLERANCE = 1e-10  # N m, sympy equations against model.Dynamics
#: IPOPT's ApplicationReturnStatus codes (cyipopt returns the number), named as CasADi names them.
IPOPT_STATUS = {
    0: "Solve_Succeeded",
    1: "Solved_To_Acceptable_Level",
    2: "Infeasible_Problem_Detected",
    3: "Search_Direction_Becomes_Too_Small",
    4: "Diverging_Iterates",
    5: "User_Requested_Stop",
    6: "Feasible_Point_Found",
    -1: "Maximum_Iterations_Exceeded",
    -2: "Restoration_Failed",
    -3: "Error_In_Step_Computation",
    -4: "Maximum_CpuTime_Exceeded",
    -10: "Not_Enough_Degrees_Of_Freedom",
    -11: "Invalid_Problem_Definition",
    -12: "Invalid_Option",
    -13: "Invalid_Number_Detected",
    -100: "Unrecoverable_Exception",
    -101: "NonIpopt_Exception_Thrown",
    -102: "Insufficient_Memory",
    -199: "Internal_Error",
}


def opty_missing() -> str | None:
    """None when opty and cyipopt import, else the reason (the ImportError's message)."""
    try:
        import cyipopt  # noqa: F401
        import opty  # noqa: F401
        import sympy  # noqa: F401
    except ImportError as exc:  # any missing piece (or a cyipopt built against no IPOPT)
        return str(exc)
    return None


# ---- the problem ------------------------------------------------------------------------------
def planner_problem(N: int = 50, transcription: str = "hermite-simpson"):
    """The planner benchmark's six-link periodic gait OCP (Hermite-Simpson, implicit).

    Built by ``planner_bench.paper22_gait`` with a fresh ``model.Dynamics`` each call, so that
    our build time includes generating the SX equations, as opty's includes the sympy ones.
    """
    from planner_bench import paper22_gait

    return paper22_gait(N, transcription, None, "implicit")


def check_equations(dynamics, samples: int = 5, seed: int = 0) -> float:
    """Worst |M_sympy - M_model| (N m) at random states; raises above CHECK_TOLERANCE."""
    import _six_link_sympy as six

    names = tuple(row[0] for row in six.SCENE)
    if tuple(dynamics.names) != names:
        raise ValueError(f"the OCP's linkage {dynamics.names} is not the scene.md six-link {names}")
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(samples):
        psi, dpsi, ddpsi = rng.uniform(-3, 3, 6), rng.uniform(-6, 6, 6), rng.uniform(-30, 30, 6)
        model = np.asarray(dynamics.inverse_dynamics(psi, dpsi, ddpsi))
        worst = max(worst, float(np.max(np.abs(six.inverse_dynamics(psi, dpsi, ddpsi) - model))))
    if not worst <= CHECK_TOLERANCE:
        raise RuntimeError(
            f"sympy six-link equations differ from model.Dynamics by {worst:.3e} N m "
            f"(> {CHECK_TOLERANCE:g}); opty would solve another problem"
        )
    return worst


# ---- opty side -------------------------------------------------------------------------------
@dataclass
class OptyBuild:
    problem: object
    guess: np.ndarray
    seconds: float


def _objective_functions(ocp, method: str, n_free: int, input_order: list[int]):
    """CasADi (J(w), dJ/dw(w)) on opty's free vector with the quadrature of ``method``."""
    import casadi as ca

    from planner.ocp import Point, evaluate_expression

    system = ocp.system
    n, nx, nu, N = ocp.dynamics.n, system.nx, system.nu, ocp.N
    nodes, h, T = N + 1, ocp.T / N, ocp.T
    x, u, z, t = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("z", system.nz), ca.SX.sym("t")
    point = Point(system, x, u, z, t, T)
    integrand = sum(
        evaluate_expression("integral", term.integral, point)
        for term in ocp.objective
        if term.integral is not None
    )
    L = ca.Function("L", [x, u, z, t], [integrand]).map(N)
    w = ca.SX.sym("w", n_free)
    X = ca.reshape(w[: nx * nodes], nodes, nx).T  # (nx, nodes): opty stores state by state
    U_sorted = ca.reshape(w[nx * nodes : (nx + nu) * nodes], nodes, nu).T
    U = ca.vertcat(*[U_sorted[input_order[i], :] for i in range(nu)])  # back to link order
    dpsi = X[n:, :]
    Zk = (dpsi[:, 1:] - dpsi[:, :-1]) / h  # ddpsi as opty discretises dpsi'
    k = np.arange(N)
    if method == "midpoint":
        Xk, Uk = 0.5 * (X[:, :-1] + X[:, 1:]), 0.5 * (U[:, :-1] + U[:, 1:])
        tk = (k + 0.5) * h
    else:  # backward euler: the right end of each interval
        Xk, Uk = X[:, 1:], U[:, 1:]
        tk = (k + 1.0) * h
    J = h * ca.sum2(L(Xk, Uk, Zk, ca.DM(tk).T))
    for objective_term in ocp.objective:
        if objective_term.terminal is None:
            continue
        xT = ca.SX.sym("xT", nx)
        point = Point(system, xT, U[:, -1], ca.SX.zeros(system.nz), T, T, {"x0": X[:, 0]})
        term = evaluate_expression("terminal", objective_term.terminal, point)
        J = J + ca.substitute(term, xT, X[:, -1])
    value = ca.Function("J", [w], [J])
    gradient = ca.Function("dJ", [w], [ca.gradient(J, w)])
    return value, gradient


def _path_rows(ocp, states, torques, t):
    """opty rows for the OCP's path constraints, which must be affine in x and u with constant
    coefficients plus any function of time c0(t): g = A x + B u + c0(t).

    c0 enters opty as a known trajectory sampled at the nodes; the bounds become opty's
    ``eom_bounds``. Returns (rows, lower, upper, known trajectory map).
    """
    import casadi as ca
    import sympy as sm

    from planner.ocp import Point, evaluate_expression

    system, nodes = ocp.system, ocp.N + 1
    other = [c.name for c in ocp.constraints if c.where != "path"]
    if other:
        raise NotImplementedError(f"opty_compare: boundary constraints {other} are not translated")
    x, u, z = ca.SX.sym("x", system.nx), ca.SX.sym("u", system.nu), ca.SX.sym("z", system.nz)
    ts = ca.SX.sym("t")
    times = np.linspace(0.0, ocp.T, nodes)
    rows, lower, upper, known = [], [], [], {}
    for c in ocp.constraints:
        g = evaluate_expression(c.name, c.expression, Point(system, x, u, z, ts, ocp.T))
        A, B = ca.jacobian(g, x), ca.jacobian(g, u)
        if ca.depends_on(g, z) or ca.depends_on(ca.horzcat(A, B), ca.vertcat(x, u, ts)):
            raise NotImplementedError(
                f"opty_compare: path constraint {c.name!r} is not affine in (x, u) with constant "
                "coefficients; it is not translated"
            )
        A, B = np.array(ca.evalf(A)), np.array(ca.evalf(B))
        offset = ca.Function("c0", [ts], [ca.substitute(g, ca.vertcat(x, u, z), 0)])
        values = np.array(offset.map(nodes)(times[None, :]))  # (size, nodes)
        for r in range(g.size1()):
            c0 = sm.Function(f"c0_{c.name}_{r}")(t)
            known[c0] = values[r]
            expr = c0 + sum(sm.Float(A[r, j]) * states[j] for j in range(system.nx) if A[r, j])
            expr += sum(sm.Float(B[r, j]) * torques[j] for j in range(system.nu) if B[r, j])
            rows.append(expr)
            lower.append(float(c.lower[r]))
            upper.append(float(c.upper[r]))
    return rows, lower, upper, known


def _instance_constraints(ocp, states, T):
    """opty instance constraints for the OCP's periodicity (identity or a constant linear map)."""
    import casadi as ca
    import sympy as sm

    if ocp.periodicity is None:
        return []
    mapping = ocp.periodicity[0]
    nx = len(states)
    end = [s.func(T) for s in states]
    if mapping is None:
        return [s.func(0.0) - e for s, e in zip(states, end, strict=True)]
    x = ca.SX.sym("x", nx)
    y = mapping(x)
    y = ca.vertcat(*y) if isinstance(y, list | tuple) else y
    A = ca.jacobian(y, x)
    if ca.depends_on(A, x):
        raise NotImplementedError("opty_compare: a nonlinear periodicity map is not translated")
    A = np.array(ca.evalf(A))
    b = np.array(ca.evalf(ca.substitute(y, x, ca.DM.zeros(nx)))).reshape(-1)
    return [
        states[i].func(0.0)
        - (sum(sm.Float(A[i, j]) * end[j] for j in range(nx) if A[i, j] != 0) + b[i])
        for i in range(nx)
    ]


def opty_guess(ocp, states_order, input_order) -> np.ndarray:
    """The planner's guess at the N + 1 nodes, laid out as opty's free vector."""
    nodal = ocp.refine(transcription="trapezoid").transcribe()
    values = nodal.unpack(nodal.initial_guess())
    X, U = values["X"], values["U"]  # (N + 1, nx), (N + 1, nu), link order
    U_sorted = U[:, [input_order.index(i) for i in range(U.shape[1])]]
    return np.concatenate([X.T.reshape(-1), U_sorted.T.reshape(-1)])


def build_opty(ocp, method: str, tmp_dir: str | None = None) -> OptyBuild:
    """opty.Problem for the OCP with ``method``; the build is timed (compile included)."""
    import _six_link_sympy as six
    from opty import Problem
    from opty.utils import sort_sympy

    system = ocp.system
    if ocp.free_time:
        raise NotImplementedError("opty_compare: a free duration is not translated to opty")
    if system.formulation != "implicit" or system.drives is None:
        raise NotImplementedError("opty_compare: expects the implicit six-link OCP")
    nodes, T = ocp.N + 1, float(ocp.T)
    start = time.perf_counter()
    eom, psi, dpsi, torques, t = six.opty_equations()
    states = psi + dpsi  # system.state_names order: psi_<link>..., dpsi_<link>...
    by_name = {f.func.__name__: f for f in states + torques}
    sorted_inputs = sort_sympy(torques)
    input_order = [sorted_inputs.index(f) for f in torques]  # link i -> row in opty's inputs
    bounds = {}
    for name in system.state_names + system.control_names:
        lo, hi = ocp.variable_bounds(name)
        if np.isfinite(lo) or np.isfinite(hi):
            bounds[by_name[name]] = (float(lo), float(hi))
    for name in system.aux_names:
        if np.any(np.isfinite(ocp.variable_bounds(name))):
            raise NotImplementedError(f"opty_compare: opty has no variable for the bound on {name}")
    n_free = (len(states) + len(torques)) * nodes
    value, gradient = _objective_functions(ocp, method, n_free, input_order)

    def objective(free):
        return float(value(free))

    def objective_gradient(free):
        return np.asarray(gradient(free)).reshape(-1)

    rows, lower, upper, known = _path_rows(ocp, states, torques, t)
    first = eom.shape[0]
    eom_bounds = {first + i: bounds for i, bounds in enumerate(zip(lower, upper, strict=True))}
    if rows:
        import sympy as sm

        eom = eom.col_join(sm.Matrix(rows))
    problem = Problem(
        objective,
        objective_gradient,
        eom,
        states,
        nodes,
        T / ocp.N,
        known_trajectory_map=known,
        instance_constraints=_instance_constraints(ocp, states, T),
        time_symbol=t,
        bounds=bounds,
        integration_method=method,
        tmp_dir=tmp_dir,
        eom_bounds=eom_bounds or None,
    )
    seconds = time.perf_counter() - start
    if list(problem.collocator.unknown_input_trajectories) != sorted_inputs:
        raise RuntimeError("opty ordered its inputs differently from sort_sympy; layout broken")
    for key, val in {**IPOPT_OPTIONS, "print_level": 0, "sb": "yes"}.items():
        problem.add_option(key, val)
    return OptyBuild(problem, opty_guess(ocp, states, input_order), seconds)


def solve_opty(build: OptyBuild) -> dict:
    """Solve once from the guess; iterations from opty's per-iteration objective record."""
    problem = build.problem
    problem.obj_value = []
    start = time.perf_counter()
    free, info = problem.solve(build.guess.copy())
    seconds = time.perf_counter() - start
    return {
        "build": build.seconds,
        "solve": seconds,
        "iterations": len(problem.obj_value) - 1,
        "cost": float(info["obj_val"]),
        "status": IPOPT_STATUS.get(int(info["status"]), f"status {info['status']}"),
        "success": int(info["status"]) == 0,  # as ours: "acceptable" is not success
        "free": free,
        "n_var": problem.num_free,
        "n_con": problem.num_constraints,
    }


# ---- our side ------------------------------------------------------------------------------
def solve_ours(transcription: str = "hermite-simpson", hessian: str = "exact", N: int = 50):
    """Define (timed: the SX equations are generated here), transcribe and solve once."""
    from planner.solver import solve

    start = time.perf_counter()
    ocp = planner_problem(N, transcription)
    define = time.perf_counter() - start
    options = dict(IPOPT_OPTIONS, hessian_approximation=hessian)
    solution = solve(ocp, options=options, raise_on_failure=False, progress=False)
    stats = solution.stats
    return {
        "build": define + stats["build_seconds"],
        "solve": stats["solve_seconds"],
        "iterations": stats["iterations"],
        "cost": solution.cost,
        "status": solution.status,
        "success": solution.success,
        "solution": solution,
        "n_var": stats["n_variables"],
        "n_con": stats["n_constraints"],
    }


# ---- table -----------------------------------------------------------------------------------
def _median(runs: list[dict], key: str) -> float:
    return float(statistics.median(r[key] for r in runs))


def _psi(run: dict, ocp) -> np.ndarray:
    """Angles at the N + 1 nodes, (N + 1, n) rad, of an opty run or one of ours."""
    nodes, n = ocp.N + 1, ocp.dynamics.n
    if "free" in run:
        return run["free"][: n * nodes].reshape(n, nodes).T
    return np.asarray(run["solution"].state(np.linspace(0.0, ocp.T, nodes)))[:, :n]


LABEL = 36


def print_table(rows: list[tuple[str, list[dict], list[float] | None]], ocp) -> None:
    """Rows of medians; the first row (ours, exact Hessian) is the reference of the ratios."""
    ours = rows[0][1]
    ref_build, ref_solve = _median(ours, "build"), _median(ours, "solve")
    ref_ms = 1e3 * ref_solve / max(_median(ours, "iterations"), 1)
    ref_psi = _psi(ours[0], ocp)
    print(
        f"{'':<{LABEL}} {'':>5} {'':>5} {'':>8} {'cached':>7} {'':>8} {'':>5} {'':>6} "
        f"{'':>10} {'psi gap':>7} {'-------- ours/opty --------':>27}"
    )
    print(
        f"{'method':<{LABEL}} {'vars':>5} {'cons':>5} {'build s':>8} {'build s':>7} "
        f"{'solve s':>8} {'iter':>5} {'ms/it':>6} {'cost':>10} {'rad':>7} {'build':>6} "
        f"{'cached':>6} {'solve':>6} {'ms/it':>6}  IPOPT status"
    )
    for label, runs, cached_runs in rows:
        build, solve, iters = (_median(runs, k) for k in ("build", "solve", "iterations"))
        ms = 1e3 * solve / max(iters, 1)
        gap = float(np.max(np.abs(_psi(runs[0], ocp) - ref_psi)))
        if cached_runs:
            cached = float(statistics.median(cached_runs))
            ratios = (
                f"{ref_build / build:6.3g} {ref_build / cached:6.3g} "
                f"{ref_solve / solve:6.3g} {ref_ms / ms:6.3g}"
            )
            cached_s = f"{cached:7.3f}"
        else:
            ratios, cached_s = f"{'':>6} {'':>6} {'':>6} {'':>6}", f"{'-':>7}"
        statuses = sorted({r["status"] for r in runs})
        print(
            f"{label:<{LABEL}} {runs[0]['n_var']:>5} {runs[0]['n_con']:>5} {build:8.3f} "
            f"{cached_s} {solve:8.3f} {iters:5.0f} {ms:6.2f} {_median(runs, 'cost'):10.2f} "
            f"{gap:7.1e} {ratios}  {'; '.join(statuses)}"
        )


def versions() -> str:
    import casadi
    import cyipopt
    import opty
    import sympy

    bundled = sorted(Path(casadi.__file__).parent.glob("libipopt.so.*.*"))
    ours_ipopt = bundled[-1].name.removeprefix("libipopt.so.") if bundled else "?"
    theirs = ".".join(map(str, getattr(cyipopt, "IPOPT_VERSION", ("?",))))
    return (
        f"casadi {casadi.__version__} (IPOPT {ours_ipopt}); opty {opty.__version__}, "
        f"cyipopt {cyipopt.__version__} (IPOPT {theirs}), sympy {sympy.__version__}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat (smoke run)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per row (median)")
    parser.add_argument("--N", type=int, default=50, help="mesh intervals (default 50)")
    parser.add_argument(
        "--methods",
        default="midpoint,backward euler",
        help="opty integration methods, comma-separated (default both)",
    )
    args = parser.parse_args(argv)
    missing = opty_missing()
    if missing is not None:
        print(
            f"opty_compare: skipped, opty/cyipopt not importable ({missing}); to run it: "
            f"{INSTALL_HINT}"
        )
        return 0
    repeats = 1 if args.quick else max(1, args.repeats)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]

    ocp = planner_problem(args.N)
    worst = check_equations(ocp.dynamics)
    print(f"sympy equations vs model.Dynamics.inverse_dynamics: max |dM| = {worst:.1e} N m")
    print(ocp)
    print(f"repeats: {repeats} (medians); IPOPT options {IPOPT_OPTIONS}; {versions()}")
    print()

    N = args.N
    rows: list[tuple[str, list[dict], list[float] | None]] = []
    for label, transcription, hessian in (
        ("ours hermite-simpson, exact Hessian", "hermite-simpson", "exact"),
        ("ours hermite-simpson, L-BFGS", "hermite-simpson", "limited-memory"),
        ("ours trapezoid, exact Hessian", "trapezoid", "exact"),
    ):
        runs = [solve_ours(transcription, hessian, N) for _ in range(repeats)]
        rows.append((label, runs, None))
    for method in methods:
        runs = [solve_opty(build_opty(planner_problem(N), method)) for _ in range(repeats)]
        with tempfile.TemporaryDirectory(prefix="opty_compare_") as cache:
            build_opty(planner_problem(N), method, tmp_dir=cache)  # compiles into the cache
            cached = [
                build_opty(planner_problem(N), method, tmp_dir=cache).seconds
                for _ in range(repeats)
            ]
        rows.append((f"opty {method}, L-BFGS", runs, cached))
    print_table(rows, ocp)
    print()
    print(
        "ratios: ours (first row) / opty, < 1 means ours is faster; 'cached': opty's build "
        "when its compiled modules are found in tmp_dir (no Cython compile)."
    )
    print(
        "psi gap: max |psi - psi of the first row| over links and nodes: do they find the "
        "same gait? Costs differ by discretisation error (different transcriptions)."
    )
    print(
        "near_law band: ours at nodes and midpoints (Hermite-Simpson) or nodes (trapezoid); "
        "opty midpoint on interval averages, backward euler at nodes 1..N."
    )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
