"""Solving a transcribed OCP with IPOPT through ``casadi.nlpsol``; status, progress, stats.

``casadi.nlpsol`` does not raise when IPOPT fails: :func:`solve` reads
``solver.stats()["success"]`` and ``["return_status"]`` every time. A failure raises
:class:`SolverError` with IPOPT's status, the iteration count, the worst violated constraints
by name and the last iterate as a :class:`planner.solution.Solution`; with
``raise_on_failure=False`` it returns that Solution, ``success == False``.
"Solved_To_Acceptable_Level" counts as success only with ``accept_acceptable=True``.

Progress (iteration, objective, and "infeasibility": the planner's largest violation of its
scaled constraint rows lbg <= g <= ubg, not IPOPT's inf_pr) goes through one switchable reporter:
the logger ``planner.progress`` at INFO level (``progress=True``, the default; shown when the
application configures logging, e.g. ``logging.basicConfig(level=logging.INFO)``, and by the
command line ``python -m problems`` unless ``--quiet``), a callable of a dict per iteration,
or nothing (``progress=False``). The library never prints: what IPOPT or CasADi would write
on stdout or stderr (an option's documentation when IPOPT refuses a value, warnings about NaN
in a function evaluation) is caught and turned into the error message or a log record.

Solvers are reused: the NLP takes bounds, nominal scales, a fixed T and the guess as
arguments, so solving an OCP with the same structure again (a re-solve, a warm start, a
continuation in a bound or in T, a study over such values) takes the IPOPT solver built the
first time from :data:`planner.solver_cache.SOLVERS` and skips the build
(``stats["solver_cached"]``; ``solve(..., cache=False)`` builds a fresh one).

The objective is scaled too: IPOPT sees f / f_scale, f_scale from the objective's gradient
at the initial guess when it lies outside [1e-2, 100] (:func:`objective_scale`), or given by
``ocp.scale(objective=...)``. A problem written in other units (millimetres and grams instead
of metres and kilograms) then solves like the SI one.
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from planner import native_nlp
from planner.accuracy_check import ACCURACY_WARNING, check_accuracy_of
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner.mesh_multipliers import carried_entries
from planner.native_output import captured
from planner.ocp import OCPDefinition
from planner.phases import PhasesDefinition
from planner.phases_solution import PhasesSolution
from planner.solution import Solution
from planner.solver_cache import SOLVERS, CachedSolver
from planner.transcription import Transcription, remember, transcribe

logger = logging.getLogger(__name__)
progress_logger = logging.getLogger("planner.progress")

#: IPOPT defaults of the planner; anything in ``options`` overrides them.
DEFAULT_IPOPT = {
    "print_level": 0,
    "sb": "yes",
    "hessian_approximation": "exact",
    "tol": 1e-8,
    "max_iter": 3000,
    # The NLP is already scaled by nominal magnitudes; MUMPS's own scaling analysis cost ~30%
    # of the solve time on the six-link gait (examples/benchmarks/planner_bench.py).
    "mumps_permuting_scaling": 0,
    "mumps_scaling": 0,
    # Adaptive barrier update: about half the iterations of the monotone one on the six-link
    # gait, at least as robust over band and mesh variants (planner_bench.py's before/after
    # table). AMF ordering (2): MUMPS's automatic choice (METIS from N ~ 100 on) fills more
    # on these banded KKT systems, and AMD (0), as good on trapezoid, Hermite-Simpson and
    # Radau, is 3-8x slower per factorisation on Legendre collocation (measured at N = 40
    # and 80: 98-294 ms against 31-32 ms per iteration).
    "mu_strategy": "adaptive",
    "mumps_pivot_order": 2,
    # MUMPS's working memory as a percentage over its own estimate. IPOPT's 1000 % makes
    # every factorisation allocate ten times what it needs: on the step on feet that was a
    # fifth of the solve's wall time, spent as system time (the kernel mapping fresh pages):
    # 2.72 -> 2.26 s for its first solve, the same 80 iterations (feet_levers.py). Should a
    # factorisation need more, MUMPS says so (INFO(1) = -9) and IPOPT doubles it and retries.
    "mumps_mem_percent": 100,
    # The largest multiple of the identity IPOPT adds to the Hessian to correct its inertia
    # before it gives the iteration up to its restoration phase (IPOPT's default 1e20). On
    # the scaled NLP a healthy solve stays below 1 (the gait problems: identical iterations
    # and optima with this cap); past 1e4 the step is a crawl along the gradient, and a start
    # that got there stayed: the step on feet from one of eight guesses of its phase
    # durations ran 250 iterations of 1-5 s each (MUMPS's pivots delayed, its memory doubled
    # to 3200 %, half the time in the kernel) without converging; capped, it converges in 142
    # (feet_levers.py), and the infeasible flat-footed step at 1.4 m/s fails in 117 s, not 277.
    "max_hessian_perturbation": 1e4,
}
#: IPOPT options added when :func:`solve` warm-starts the multipliers from a Solution on the
#: same NLP layout; anything in ``options`` overrides them. Start from the given primal-dual
#: point (a variable on a bound moves 1e-4 max(1, |bound|) into the interior; multipliers of
#: inactive bounds start at 1e-3) and let the adaptive barrier strategy take mu from the
#: point's complementarity (the adaptive strategy is now the default for every solve). The
#: textbook alternative, the monotone strategy with a small mu_init (1e-6) and pushes of 1e-6,
#: restarts the same problem in fewer iterations but breaks down in a continuation. Six-link
#: gait of examples/benchmarks/planner_bench.py (HS N=50, tol 1e-8), iterations of the same
#: problem / band 0.1 -> 0.09 rad / period 1 -> 1.02 s, measured when the defaults were
#: IPOPT's monotone ones: these options 6 / 24 / 35, monotone 4 / 66 / 216, primal values
#: only 23 / 31 / 42, cold 51 / 50 / 51. With today's defaults (same benchmark): the same
#: problem 6, primal only 23, cold 29; band 0.1 -> 0.11 rad 20, primal 26, cold 30.
WARM_START_IPOPT = {
    "warm_start_init_point": "yes",
    "warm_start_bound_push": 1e-4,
    "warm_start_bound_frac": 1e-4,
    "warm_start_slack_bound_push": 1e-4,
    "warm_start_slack_bound_frac": 1e-4,
    "warm_start_mult_bound_push": 1e-3,
    "mu_strategy": "adaptive",
}
#: IPOPT options over :data:`WARM_START_IPOPT` for a near restart (``solve(...,
#: near_restart=True)``): the problem changed by little since the Solution it starts from
#: (:func:`planner.hold_at_samples`'s rounds: bounds backed off by fractions of a per cent of
#: their scale, intervals cut in halves with the multipliers carried), so IPOPT starts with the
#: barrier parameter and every push off the bounds at the size of the converged point's
#: complementarity, not at WARM_START_IPOPT's 1e-4 and 1e-3 (from which IPOPT sets mu near 1e-4
#: and takes 7 iterations to bring it back to 1e-11 in each of the walking step's two hold
#: rounds; with these, 7 and 2 iterations, mu from 5e-6 and 4e-10). The re-solves of ten gait
#: problems' hold rounds (the step on feet in its three sequences and at 0.6 and 1.0 m/s; the
#: walking step plain, with double support, 0.8 m long and refined; the fixed-base gait),
#: measured: 549 IPOPT iterations under WARM_START_IPOPT, 277 with these at 1e-8 (316 at 1e-6,
#: 276 at 1e-7, 263 at 1e-9), the same optima to IPOPT's tolerance, no failure. Not for a
#: continuation (a changed parameter moves the optimum far from the start; see
#: WARM_START_IPOPT): a near restart that fails is solved again with WARM_START_IPOPT alone.
NEAR_RESTART_IPOPT = {
    "mu_init": 1e-8,
    "warm_start_bound_push": 1e-8,
    "warm_start_bound_frac": 1e-8,
    "warm_start_slack_bound_push": 1e-8,
    "warm_start_slack_bound_frac": 1e-8,
    "warm_start_mult_bound_push": 1e-8,
}
SUCCESS = ("Solve_Succeeded",)
ACCEPTABLE = "Solved_To_Acceptable_Level"
#: Stats keys of the oracle functions whose wall time is "time in function evaluations".
FUNCTION_STATS = ("nlp_f", "nlp_g", "nlp_grad", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


class SolverError(AnthropoidError):
    """IPOPT did not converge (or converged only to an acceptable level, not accepted).

    Attributes
    ----------
    status : IPOPT's return status, e.g. "Maximum_Iterations_Exceeded".
    iterations : IPOPT iterations done.
    violations : list of (constraint name, violation) at the last iterate, worst first, in
        the constraint's physical units (defects in the state's units).
    solution : the last iterate as a :class:`Solution` (``success == False``).
    """

    def __init__(self, message, status, iterations, violations, solution) -> None:
        super().__init__(message)
        self.status = status
        self.iterations = iterations
        self.violations = violations
        self.solution = solution


class _Progress(ca.Callback):
    """IPOPT iteration callback: reports iteration, objective and max constraint violation.

    One per solver; :meth:`start` sets what the next solve reports (a cached solver serves
    many solves with different bounds and reporters).
    """

    def __init__(self, n_w: int, n_g: int) -> None:
        ca.Callback.__init__(self)
        self._n_w, self._n_g = n_w, n_g
        self._lbg = self._ubg = np.zeros(n_g)
        self._report: Callable[[dict], None] | None = None
        self._scale = 1.0
        self._started = time.perf_counter()
        self.iteration = -1
        #: An exception raised by ``report``; solve() re-raises it after stopping IPOPT.
        self.error: BaseException | None = None
        self.construct("progress", {})

    def start(self, report, lbg, ubg, objective_scale: float = 1.0) -> None:
        """Set the reporter, the scaled row bounds and the objective scale of the next solve."""
        self._report = report
        self._lbg, self._ubg = np.asarray(lbg), np.asarray(ubg)
        self._scale = objective_scale
        self._started = time.perf_counter()
        self.iteration = -1
        self.error = None

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self._n_w)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self._n_g)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        self.iteration += 1
        if self._report is None:
            return [0]
        g = np.asarray(arg[ca.nlpsol_out().index("g")]).reshape(-1)
        infeasibility = (
            float(np.max(np.maximum(self._lbg - g, g - self._ubg), initial=0.0)) if g.size else 0.0
        )
        try:
            self._report(
                {
                    "iteration": self.iteration,
                    # in the objective's own units (IPOPT sees it divided by the scale)
                    "objective": float(arg[ca.nlpsol_out().index("f")]) * self._scale,
                    "infeasibility": infeasibility,
                    "seconds": time.perf_counter() - self._started,
                }
            )
        except Exception as exc:  # the user's callback: keep it, stop IPOPT, re-raise later
            self.error = exc
            return [1]
        return [0]


def _log_progress(row: Mapping[str, Any]) -> None:
    progress_logger.info(
        "iter %4d  objective %.8e  max violation %.2e  %7.2f s",
        row["iteration"],
        row["objective"],
        row["infeasibility"],
        row["seconds"],
    )


def violations(transcription: Transcription, w: np.ndarray, g: np.ndarray, count: int = 5):
    """The ``count`` worst violated constraints and bounds at (w, g), by name, worst first.

    Violations are in physical units (scaled row times its nominal scale).
    """
    w = np.asarray(w, dtype=float).reshape(-1)
    g = np.asarray(g, dtype=float).reshape(-1)
    rows = []
    if g.size:
        excess = np.maximum(transcription.lbg - g, g - transcription.ubg)
        excess = np.maximum(excess, 0.0) * transcription.g_scale
        rows.extend((transcription.g_names[i], float(excess[i])) for i in np.flatnonzero(excess))
    excess = np.maximum(np.maximum(transcription.lbx - w, w - transcription.ubx), 0.0)
    excess = excess * transcription.w_scale
    rows.extend((transcription.w_names[i], float(excess[i])) for i in np.flatnonzero(excess))
    rows.sort(key=lambda item: -item[1])
    return rows[:count]


def _non_finite(
    transcription: Transcription, solver: ca.Function, w: np.ndarray, p: np.ndarray
) -> str:
    """Where the NLP functions are NaN or inf at the scaled iterate ``w``, by name."""
    places = []
    try:
        f, grad_f = solver.get_function("nlp_grad_f")(w, p)
        g = solver.get_function("nlp_g")(w, p)
    except RuntimeError:  # the oracle itself failed: nothing more to say
        return "NaN or inf in the NLP functions"
    if not np.isfinite(float(f)):
        places.append("the objective")
    grad_f = np.asarray(grad_f).reshape(-1)
    bad = np.flatnonzero(~np.isfinite(grad_f))
    if bad.size:
        names = ", ".join(transcription.w_names[i] for i in bad[:5])
        places.append(f"the objective's gradient w.r.t. {names}")
    g = np.asarray(g).reshape(-1)
    bad = np.flatnonzero(~np.isfinite(g))
    if bad.size:
        places.append("constraints " + ", ".join(transcription.g_names[i] for i in bad[:5]))
    if not places:
        return "NaN or inf in a derivative (Jacobian or Hessian) of the NLP"
    return "NaN or inf in " + "; ".join(places)


@dataclass(frozen=True)
class _MultiplierSource:
    """A guess Solution's multipliers on a transcription's entries and nominal scales
    (lam_x (n_w,), lam_g (n_g,)), and the objective scale they were solved with: found once
    per solve, scaled to the solve's objective scale when that is known."""

    lam_x: np.ndarray
    lam_g: np.ndarray
    objective_scale: float

    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.lam_x)) and np.all(np.isfinite(self.lam_g)))

    def scaled(self, objective_scale: float) -> tuple[np.ndarray, np.ndarray] | None:
        """(lam_x, lam_g) for a solve with ``objective_scale``; None if not finite."""
        # The physical multipliers lam * f_scale / scale are invariant (the Lagrangian is
        # f / f_scale + lam^T (v / scale)): lam_new = lam_old * (new / old scale) * (old /
        # new f_scale).
        ratio = self.objective_scale / objective_scale
        scaled = _MultiplierSource(self.lam_x * ratio, self.lam_g * ratio, objective_scale)
        return (scaled.lam_x, scaled.lam_g) if scaled.finite() else None


def warm_start_multipliers(
    transcription: Transcription, objective_scale: float = 1.0
) -> tuple[np.ndarray, np.ndarray] | None:
    """(lam_x0 (n_w,), lam_g0 (n_g,)) for ``transcription`` from its OCP's guess, or None.

    Multipliers are reused when the OCP's last guess is a converged :class:`Solution` that
    carries finite multipliers of an NLP with the same :attr:`Transcription.signature` (same
    transcription, degree, N, variables and constraint rows): a re-solve, or a continuation
    in a bound, a cost weight or another parameter. They are re-scaled to this transcription's
    nominal scales (a changed bound may change a default scale) and to ``objective_scale``,
    the objective scale of this solve. Otherwise (another mesh or transcription, a
    Trajectory, a failed solve, a later guess over the Solution's) None: the guess is primal
    only.
    """
    source = _multiplier_source(transcription)
    return None if source is None else source.scaled(objective_scale)


def _multiplier_source(transcription: Transcription) -> _MultiplierSource | None:
    """The multipliers :func:`warm_start_multipliers` reuses, before the objective scale."""
    source = transcription.guess_solution()
    if not isinstance(source, Solution | PhasesSolution):
        return None
    if source.lam_x is None or source.lam_g is None or not source.success:
        logger.debug("multipliers not reused: the guess Solution has none or failed")
        return None
    old = source.transcription
    lam_g_old, g_scale_old = source.lam_g, old.g_scale
    lam_x_old, w_scale_old = source.lam_x, old.w_scale
    if source.nlp_signature != transcription.signature:
        rows = _same_rows(old, transcription)
        if rows is None:
            carried = _across_cut(source, transcription)
            if carried is None:
                logger.debug(
                    "multipliers not reused: NLP layout %s differs from the guess's %s",
                    transcription.signature,
                    source.nlp_signature,
                )
                return None
            lam_x_old, w_scale_old, lam_g_old, g_scale_old = carried
        else:
            # The same variables with rows added or removed (limits added at samples): each
            # row the two share keeps its multiplier, a new row starts at 0.
            lam_g_old, g_scale_old = _gathered(source.lam_g, old.g_scale, rows)
    return _MultiplierSource(
        lam_x_old * (transcription.w_scale / w_scale_old),
        lam_g_old * (transcription.g_scale / g_scale_old),
        float(source.stats.get("objective_scale", 1.0)),
    )


def _across_cut(source, new: Transcription):
    """(lam_x, w_scale, lam_g, g_scale) of ``source``'s NLP carried onto ``new``'s entries
    when ``new``'s mesh is the source's with intervals cut in halves
    (:mod:`planner.mesh_multipliers`; an entry without a source starts at 0), or None."""
    old = source.transcription
    entries = carried_entries(old, new)
    if entries is None:
        return None
    (w_rows, w_factors), (g_rows, g_factors) = entries
    logger.debug("multipliers carried across a mesh cut")
    return (
        *_gathered(source.lam_x, old.w_scale, w_rows, w_factors),
        *_gathered(source.lam_g, old.g_scale, g_rows, g_factors),
    )


def _gathered(lam, scale, rows, factors=1.0) -> tuple[np.ndarray, np.ndarray]:
    """(multipliers, their nominal scales) of the old NLP's entries ``rows`` (-1: none, a 0
    multiplier of scale 1), the multipliers times ``factors``."""
    known = rows >= 0
    at = np.maximum(rows, 0)
    return np.where(known, lam[at] * factors, 0.0), np.where(known, scale[at], 1.0)


def _same_rows(old: Transcription, new: Transcription) -> np.ndarray | None:
    """For two NLPs with the same variables (by name, in order): the index of each of
    ``new``'s rows among ``old``'s rows by name (-1 for a row ``old`` lacks); None when the
    variables differ or a row name repeats."""
    if tuple(old.w_names) != tuple(new.w_names):
        return None
    index = {name: i for i, name in enumerate(old.g_names)}
    if len(index) != len(old.g_names) or len(set(new.g_names)) != len(new.g_names):
        return None
    return np.array([index.get(name, -1) for name in new.g_names], dtype=int)


def nlp_solver(
    transcription: Transcription,
    options: Mapping[str, Any] | None = None,
    report: Callable[[dict], None] | None = None,
    expand: bool = False,
    *,
    library: Path | None = None,
    progress: bool = True,
) -> ca.Function:
    """A new ``casadi.nlpsol`` IPOPT solver of a transcription (planner defaults + ``options``).

    The solver takes the NLP parameters ``p`` (:meth:`Transcription.parameter_values`) with
    the bounds. Its oracle functions (``solver.get_function("nlp_jac_g")``,
    ``"nlp_hess_l"``) are the derivatives IPOPT uses, functions of (w, p). ``report``
    receives a dict per iteration (see :func:`solve`). ``expand``: expand an MX NLP to SX
    before the derivatives are generated (CasADi's ``expand`` option; ~4x the build, ~0.6x
    the evaluation time). ``library``: the NLP's functions compiled (:mod:`planner.native_nlp`,
    made from :func:`nlp_oracle`) instead of generated here. ``progress``: attach the
    per-iteration callback that reports progress (False: no Python runs per iteration, and
    ``report`` must be None). :func:`solve` keeps the solvers it builds here in
    :data:`planner.solver_cache.SOLVERS`.
    """
    ipopt = dict(DEFAULT_IPOPT)
    if options is not None:
        if not isinstance(options, Mapping):
            raise DefinitionTypeError(
                f"`options`: must be a dict of IPOPT options, got {options!r}"
            )
        ipopt.update(options)
    solver_options: dict[str, Any] = {
        "ipopt": ipopt,
        "print_time": False,
        # NaN in a function evaluation: solve() names the rows itself (_non_finite).
        "show_eval_warnings": False,
        # The multipliers of the parameters (scales, T) mean nothing here; CasADi would
        # generate a gradient function for them and evaluate it after every solve.
        "calc_lam_p": False,
    }
    callback = None
    if progress:
        callback = _Progress(transcription.n_w, transcription.n_g)
        callback.start(report, transcription.lbg, transcription.ubg)
        solver_options["iteration_callback"] = callback
    elif report is not None:
        raise DefinitionError("`report`: needs a solver with progress=True")
    problem: Any = transcription.parametric_nlp
    if library is not None:
        problem = str(library)
    elif isinstance(problem["x"], ca.MX) and expand:
        solver_options["expand"] = True
    elif isinstance(problem["x"], ca.MX):
        problem = nlp_oracle(transcription)
    try:
        with captured() as output:
            solver = ca.nlpsol("planner", "ipopt", problem, solver_options)
    except RuntimeError as exc:
        # IPOPT rejects unknown or ill-typed options while the solver is built, and prints
        # the option's documentation on stdout: that text (caught) goes into the message.
        said = " ".join(output[0].split())
        said = f"; IPOPT said: {said[:400]}" if said else ""
        raise DefinitionError(
            f"`options`: IPOPT refused the options {_user_options(options)}{said} "
            f"({_first_line(exc)})"
        ) from exc
    if output[0].strip():
        logger.warning("IPOPT/CasADi wrote while the solver was built: %s", output[0].strip())
    # The Python callback must live as long as the solver (CasADi holds only a reference):
    # the solver object keeps it, and solve() reads the callback's error from there.
    solver._planner_progress = callback
    return solver


def nlp_oracle(transcription: Transcription) -> ca.Function:
    """The MX NLP (x, p) -> (f, g) that IPOPT's solver is built from, named ``nlp``, with the
    constraint Jacobian's AD mode chosen by :func:`jacobian_mode` (the compiled library of
    :mod:`planner.native_nlp` is generated from this very Function)."""
    problem = transcription.parametric_nlp
    return ca.Function(
        "nlp",
        [problem["x"], problem["p"]],
        [problem["f"], problem["g"]],
        ["x", "p"],
        ["f", "g"],
        {"ad_weight": jacobian_mode(problem["g"], problem["x"])},
    )


def jacobian_mode(g: ca.MX, w: ca.MX) -> float:
    """CasADi's ``ad_weight`` for the NLP's constraint Jacobian: 1.0 (reverse mode) unless it
    needs more than twice the sweeps of forward mode (colourings of its sparsity), then 0.0.

    Reverse mode is the faster one on the gait problems, even with a few more sweeps: the
    six-link gait needs 14 adjoint instead of 21 forward sweeps, 25% less time in nlp_jac_g
    (planner_bench.py, Hermite-Simpson N=50); the walking step (N = 30) 24 adjoint against 21
    forward sweeps, 0.107 s against 0.134 s in nlp_jac_g over a solve. But a variable in every
    row (a free duration T, a static parameter) makes every pair of rows share a column: one
    adjoint sweep per row, a build and an evaluation growing as N^2 (measured, a free-time
    double integrator at N = 400: 1600 adjoint against 6 forward sweeps, 5.8 s against
    0.34 s in all; 33 s at N = 1000).
    """
    pattern = ca.jacobian_sparsity(g, w)
    forward = pattern.uni_coloring().size2()
    reverse = pattern.T.uni_coloring().size2()
    return 1.0 if reverse <= 2 * forward else 0.0


def _user_options(options) -> dict:
    return dict(options) if isinstance(options, Mapping) else {}


def _first_line(exc: BaseException) -> str:
    """The last non-empty line of a CasADi error (its first lines are a stack of places)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__


def _cache_key(
    transcription: Transcription,
    options: Mapping[str, Any] | None,
    expand: bool,
    progress: bool = True,
    compiled: bool = True,
) -> tuple:
    """The cache key of a solver: the NLP structure, the expansion, the IPOPT options it was
    built with, whether it reports progress (a solver without the callback runs no Python
    per iteration) and whether it may run compiled functions (``solve(compiled=False)``
    never takes the solver a compiled library was swapped into)."""
    return (
        transcription.structure_key,
        bool(expand),
        json.dumps(dict(options or {}), sort_keys=True, default=repr),
        bool(progress),
        bool(compiled),
    )


#: The range of the objective's largest gradient (w.r.t. the scaled variables) that is left
#: as it is; outside it the objective is scaled to the nearest end. The upper end is IPOPT's
#: own ``nlp_scaling_max_gradient``: within [1e-2, 1e8] times it, IPOPT's gradient-based
#: scaling does the same, so an SI problem solves exactly as IPOPT alone solves it; the
#: scaling here adds what IPOPT leaves out (factors below its ``nlp_scaling_min_value``
#: 1e-8, and any scaling up). Measured on the test suite's problems: their largest
#: gradients lie between 0.125 and 1.3e4.
OBJECTIVE_GRADIENT_RANGE = (1e-2, 100.0)


def objective_scale(transcription: Transcription, solver: ca.Function, w0: np.ndarray) -> float:
    """The objective's nominal magnitude f_scale (IPOPT minimises f / f_scale) for a solve
    from the scaled guess ``w0``.

    ``ocp.scale(objective=...)`` when given; else, when the OCP's last guess is a Solution
    of an NLP with the same layout (a re-solve, a continuation in a bound or a weight), the
    scale that Solution was solved with (the scaled problem, and the meaning of its
    multipliers, stay the same); otherwise from g, the largest |df/dw| at ``w0`` (w the
    scaled variables: the change of f when one variable moves by its nominal scale): 1 when
    g lies in :data:`OBJECTIVE_GRADIENT_RANGE` [1e-2, 100], else g divided by the nearer end.
    Where g vanishes (a guess at a minimum of f, e.g. zero torques for a sum of squared
    torques) it is taken one nominal scale further, at w0 + 1 within the bounds; 1 when that
    vanishes too.

    Why this rule: IPOPT scales an objective down to a largest gradient of 100 by itself, but
    never by a factor below 1e-8 and never up, so a problem written in millimetres and grams
    (torques 1e9 times larger, their squares 1e18) left IPOPT a badly scaled objective
    (Maximum_Iterations_Exceeded for a pendulum swing-up that SI solves in 13 iterations).
    Scaling every objective to a fixed gradient instead changes SI problems that IPOPT
    handles well: measured, a warm start from a coarse solution took 20-27 iterations
    instead of 6 (the objective smaller, IPOPT's initial bound multipliers of 1 too large
    for it). Dividing by f(w0) loosens IPOPT's tolerance: the six-link gait's guess costs
    1.26e6, its optimum 4.56e4, and with f / f(w0) the optimum came out 0.21 too high at
    ``tol`` 1e-8.
    """
    given = transcription.given_objective_scale
    if given is not None:
        return given
    source = transcription.guess_solution()
    if (
        isinstance(source, Solution | PhasesSolution)
        and source.nlp_signature == transcription.signature
    ):
        previous = source.stats.get("objective_scale")
        if isinstance(previous, float) and math.isfinite(previous) and previous > 0:
            return previous
    gradient_function = solver.get_function("nlp_grad_f")
    parameters = transcription.parameter_values()
    for point in (w0, np.clip(w0 + 1.0, transcription.lbx, transcription.ubx)):
        try:
            gradient = np.asarray(gradient_function(point, parameters)[1])
        except RuntimeError:  # the oracle failed (NaN in the guess): IPOPT will say so
            return 1.0
        largest = float(np.max(np.abs(gradient), initial=0.0))
        if not math.isfinite(largest):
            return 1.0
        if largest > 0.0:
            low, high = OBJECTIVE_GRADIENT_RANGE
            return largest / high if largest > high else largest / low if largest < low else 1.0
    return 1.0


def solve(
    problem: OCPDefinition | PhasesDefinition | Transcription,
    *,
    options: Mapping[str, Any] | None = None,
    accept_acceptable: bool = False,
    raise_on_failure: bool = True,
    progress: bool | Callable[[dict], None] = True,
    expand: bool | None = None,
    guess: np.ndarray | None = None,
    warm_start: bool = True,
    near_restart: bool = False,
    cache: bool = True,
    compiled: bool | None = None,
    accuracy_warning: float | None = ACCURACY_WARNING,
) -> Solution:
    """Solve an OCP (or an already built Transcription) with IPOPT.

    Parameters
    ----------
    problem : the OCP, transcribed here, or a :class:`Transcription` to reuse.
    options : IPOPT options (``{"max_iter": 50, "tol": 1e-10}``), over the planner defaults
        :data:`DEFAULT_IPOPT` (exact Hessian, ``tol`` 1e-8, adaptive barrier update, AMF
        ordering in MUMPS with 100 % working memory, the Hessian's regularisation capped at
        1e4, quiet). Keys are IPOPT's own names.
    accept_acceptable : count "Solved_To_Acceptable_Level" as success.
    raise_on_failure : raise :class:`SolverError` on failure (default); otherwise return the
        last iterate with ``success == False``.
    progress : True logs every iteration on the ``planner.progress`` logger (INFO: shown
        when the application configures logging, and by the command line), a callable
        receives {"iteration", "objective", "infeasibility", "seconds"} dicts, False reports
        nothing. An exception raised by the callable stops IPOPT and is re-raised from here.
    expand : True: the solver evaluates the NLP expanded to SX (~0.7x the solve time of the
        default, for ~8x its build: it pays from a few solves of one structure, and the
        solver is cached); False (default): the MX NLP, the SX point Function mapped over the
        mesh (fastest build). Only for an OCP (a Transcription keeps the symbols it was built
        with). ``planner_bench.py`` measures the break-even number of solves.
    guess : a scaled decision vector to start from (default: the OCP's guesses).
    warm_start : when the OCP's last guess is a converged Solution of an NLP with the same
        layout (:attr:`Transcription.signature`: same transcription, degree, N, variables and
        constraint rows; bounds, scales, cost and T may differ), or with the same variables
        and rows added or removed (matched by name, new rows starting at 0: limits added at
        samples, :mod:`planner.sampled_limits`), also start IPOPT from that Solution's
        multipliers (``lam_x0``, ``lam_g0``) with the options
        :data:`WARM_START_IPOPT` (``options`` override them). False: primal guess only, as
        for any other guess. Ignored with an explicit ``guess`` vector, and when the layouts
        differ (coarse-to-fine, another transcription): then the guess is re-gridded only.
    near_restart : with a warm start, the OCP differs from the Solution it starts from by
        little (bounds moved by a fraction of their scale, intervals cut in halves): IPOPT
        starts with :data:`NEAR_RESTART_IPOPT` too (the barrier parameter and the pushes off
        the bounds at 1e-8: about half the iterations of a plain warm start on the rounds of
        :func:`planner.hold_at_samples`); should that solve fail, the problem is solved again
        with the plain warm start (``stats["near_restart_failed"]`` then holds the failed
        try's status, iterations and seconds). Ignored without a warm start.
    cache : take the IPOPT solver from :data:`planner.solver_cache.SOLVERS` when one was
        built for the same NLP structure and options, and keep a new one there (default);
        False builds a private solver.
    compiled : the NLP's functions compiled to native code (:mod:`planner.native_nlp`, a
        disk cache per structure): True compiles now when the cache lacks them (seconds:
        about 11 s for the six-link walking step) and solves with them (~0.6x the time per
        iteration); False never; None (default) follows ``$ANTHROPOID_COMPILE``: ``auto``
        uses compiled functions the cache holds and, when a C compiler is there, compiles a
        structure in the background once this process has spent about as long solving it
        as the compilation will take (:func:`planner.native_nlp.worth_compiling`); ``never``.
        ``stats["compiled"]`` says whether this solve ran compiled.
    accuracy_warning : after a successful solve, the largest per-interval re-integration
        error per nominal state scale is measured (``stats["accuracy"]``) and an
        :class:`planner.AccuracyWarning` raised above this (default 1e-2,
        :data:`planner.accuracy_check.ACCURACY_WARNING`); None skips the measurement.

    Returns
    -------
    Solution, with ``stats``: transcription_seconds, solver_setup_seconds (0-ish for a cached
    solver), build_seconds, solve_seconds, iterations, function_seconds (wall time in NLP
    function evaluations), warm_start (whether IPOPT started from a Solution's multipliers),
    near_restart (whether with :data:`NEAR_RESTART_IPOPT`),
    solver_cached (whether the solver was reused), objective_scale, ipopt (the raw
    ``solver.stats()``).
    """
    if isinstance(problem, OCPDefinition | PhasesDefinition):
        # Always the MX transcription: it builds in milliseconds and its structure key is
        # cheap; the expansion to SX happens once, inside the (cached) solver.
        transcription = transcribe(problem)  # a recent one's copy when only margins changed
    elif isinstance(problem, Transcription):
        if expand is not None:
            raise DefinitionError("`expand`: applies when solving an OCP, not a Transcription")
        transcription = problem
        remember(transcription)  # its re-solves with other margins copy it
    else:
        raise DefinitionTypeError(
            "`problem`: must be a planner.OCP, a planner.Phases or a transcription of one, "
            f"got {type(problem).__name__}"
        )
    if progress is True:
        report = _log_progress if progress_logger.isEnabledFor(logging.INFO) else None
    elif progress is False or progress is None:
        report = None
    elif callable(progress):
        report = progress
    else:
        raise DefinitionTypeError(f"`progress`: must be a bool or a callable, got {progress!r}")
    if not isinstance(warm_start, bool):
        raise DefinitionTypeError(f"`warm_start`: must be True or False, got {warm_start!r}")
    if not isinstance(near_restart, bool):
        raise DefinitionTypeError(f"`near_restart`: must be True or False, got {near_restart!r}")
    if not isinstance(cache, bool):
        raise DefinitionTypeError(f"`cache`: must be True or False, got {cache!r}")
    if options is not None and not isinstance(options, Mapping):
        raise DefinitionTypeError(f"`options`: must be a dict of IPOPT options, got {options!r}")
    if compiled is not None and not isinstance(compiled, bool):
        raise DefinitionTypeError(
            f"`compiled`: must be True, False or None (automatic), got {compiled!r}"
        )
    native = "never" if compiled is False else "now" if compiled else native_nlp.mode()

    warm = False
    solver_options = options
    if warm_start and guess is None:
        user = dict(options or {})
        if str(user.get("warm_start_init_point", "yes")).lower() == "yes":
            # found once: the multipliers are scaled to the solve's objective below
            source = _multiplier_source(transcription)
            warm = source is not None and source.finite()
        if warm:
            near = NEAR_RESTART_IPOPT if near_restart else {}
            solver_options = {**WARM_START_IPOPT, **near, **user}

    w0 = transcription.initial_guess() if guess is None else np.asarray(guess, dtype=float)
    if w0.shape != (transcription.n_w,):
        raise DefinitionError(
            f"`guess`: expected a decision vector of shape ({transcription.n_w},), got {w0.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(w0))
    if bad.size:
        # IPOPT would start, evaluate NaN everywhere and stop (Invalid_Number_Detected).
        names = getattr(transcription, "w_names", ())
        which = ", ".join(names[i] if i < len(names) else f"entry {i}" for i in bad[:3])
        raise DefinitionError(
            f"`guess`: contains NaN or inf at {bad.size} of {w0.size} entries ({which}"
            f"{', ...' if bad.size > 3 else ''}); give finite values"
        )
    start = time.perf_counter()

    expand = bool(expand)
    # No Python per IPOPT iteration unless someone reads the progress.
    with_progress = report is not None
    library_key = transcription.structure_key if native != "never" else None
    library = native_nlp.ready(library_key) if library_key is not None else None

    def build(library: Path | None = None) -> CachedSolver:
        begin = time.perf_counter()
        options = {"expand": expand, "progress": with_progress}
        try:
            solver = nlp_solver(transcription, solver_options, library=library, **options)
        except DefinitionError:
            if library is None:
                raise
            # A library that does not load (another machine's, damaged): the interpreted
            # solver, which raises the options' own error if they were the trouble.
            solver = nlp_solver(transcription, solver_options, **options)
            native_nlp.discard(library)
            library = None
        seconds = time.perf_counter() - begin
        return CachedSolver(solver, solver._planner_progress, seconds, library=library)

    cached = False
    key = _cache_key(transcription, solver_options, expand, with_progress, native != "never")
    if cache:
        entry, cached = SOLVERS.get(key, lambda: build(library))
        if not entry.lock.acquire(blocking=False):  # busy in another thread: a private one
            entry, cached = build(library), False
            entry.lock.acquire()
    else:
        entry = build(library)
        entry.lock.acquire()
    try:
        if library_key is not None and entry.library is None:
            # An interpreted solver: compiled functions ready since, asked for now, or worth
            # starting in the background (native_nlp.library_for says which).
            library = native_nlp.library_for(
                library_key, native, entry, lambda: nlp_oracle(transcription)
            )
            if library is not None:
                fresh = build(library)
                entry.value, entry.extra, entry.library = fresh.value, fresh.extra, fresh.library
        solver, callback = entry.value, entry.extra
        entry.uses += 1
        f_scale = objective_scale(transcription, solver, w0)
        multipliers = source.scaled(f_scale) if warm else None
        if callback is not None:
            callback.start(report, transcription.lbg, transcription.ubg, f_scale)
        parameters = transcription.parameter_values(f_scale)
        setup_seconds = time.perf_counter() - start
        arguments = {
            "x0": w0,
            "p": parameters,
            "lbx": transcription.lbx,
            "ubx": transcription.ubx,
            "lbg": transcription.lbg,
            "ubg": transcription.ubg,
        }
        if multipliers is not None:
            arguments["lam_x0"], arguments["lam_g0"] = multipliers
        start = time.perf_counter()
        result = solver(**arguments)
        solve_seconds = time.perf_counter() - start
        entry.solve_seconds += solve_seconds
        stats = solver.stats()
        if callback is not None and callback.error is not None:
            raise callback.error
    finally:
        entry.lock.release()
    status = str(stats.get("return_status", "unknown"))
    if status == "Invalid_Option":
        # IPOPT checks some option values only when it starts (e.g. a linear solver that is
        # not installed): a definition error, not a failed solve.
        raise DefinitionError(
            f"`options`: IPOPT refused the options {_user_options(options)} (status Invalid_Option)"
        )
    success = bool(stats.get("success", False)) and status in SUCCESS
    if status == ACCEPTABLE and accept_acceptable:
        success = True
    function_seconds = sum(float(stats.get(f"t_wall_{name}", 0.0)) for name in FUNCTION_STATS)
    iterations = int(stats.get("iter_count", 0))
    summary = {
        "transcription_seconds": transcription.build_seconds,
        "solver_setup_seconds": setup_seconds,
        "build_seconds": transcription.build_seconds + setup_seconds,
        "solve_seconds": solve_seconds,
        "iterations": iterations,
        "function_seconds": function_seconds,
        "warm_start": multipliers is not None,
        "near_restart": near_restart and multipliers is not None,
        "solver_cached": cached,
        "compiled": entry.library is not None,
        "objective_scale": f_scale,
        "n_variables": transcription.n_w,
        "n_constraints": transcription.n_g,
        "ipopt": stats,
    }
    w = np.asarray(result["x"]).reshape(-1)
    g = np.asarray(result["g"]).reshape(-1)
    solution = transcription.solution(
        w,
        cost=float(result["f"]) * f_scale,
        status=status,
        success=success,
        stats=summary,
        lam_g=np.asarray(result["lam_g"]).reshape(-1),
        lam_x=np.asarray(result["lam_x"]).reshape(-1),
    )
    logger.debug(
        "%s: %s in %d iterations, build %.3f s (solver %s), solve %.3f s",
        transcription.label,
        status,
        iterations,
        summary["build_seconds"],
        "cached" if cached else "built",
        solve_seconds,
    )
    if not success and near_restart and multipliers is not None:
        # The start was not as near as the caller said: the plain warm start, whose larger
        # pushes and barrier parameter let IPOPT move further.
        logger.info(
            "%s: the near restart failed (%s after %d iterations); solving again with the "
            "plain warm start",
            transcription.label,
            status,
            iterations,
        )
        # the transcription made above, unless an expanded solver needs the OCP itself
        again = solve(
            problem if expand else transcription,
            options=options,
            accept_acceptable=accept_acceptable,
            raise_on_failure=raise_on_failure,
            progress=progress,
            expand=True if expand else None,
            guess=guess,
            warm_start=warm_start,
            cache=cache,
            compiled=compiled,
            accuracy_warning=accuracy_warning,
        )
        again.stats["near_restart_failed"] = {
            "status": status,
            "iterations": iterations,
            "solve_seconds": solve_seconds,
        }
        return again
    if success and accuracy_warning is not None:
        check_accuracy_of(solution, accuracy_warning)
    if not success and raise_on_failure:
        worst = violations(transcription, w, g)
        listed = "; ".join(f"{name}: {value:.3g}" for name, value in worst) or "none"
        hint = " (pass accept_acceptable=True to accept it)" if status == ACCEPTABLE else ""
        if status == "Invalid_Number_Detected":
            hint = f" ({_non_finite(transcription, solver, w, parameters)})"
        raise SolverError(
            f"IPOPT failed with status {status}{hint} after {iterations} iterations; "
            f"worst violations: {listed}",
            status,
            iterations,
            worst,
            solution,
        )
    return solution
