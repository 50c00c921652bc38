"""What the gait problems share: objectives, torque limits, the law's benchmark cost, and the
solved gait's common measurements (:class:`Gait`).

Objectives (``OBJECTIVES``), integrated over the step or period:

* ``"torque"``: sum M_i^2, N^2 m^2 (the paper's drive effort);
* ``"torque-rate"``: sum dM_i^2 (dM the derivative of the transcription's torque polynomial,
  ``planner`` Point field ``dM``), N^2 m^2/s^2, for smooth drive commands, plus
  ``REGULARISATION`` s^-2 times the torque term so that the torque level stays determined;
* ``"human"``: the joints' strength-normalised effort with their passive moments
  (:data:`problems.human.effort.HUMAN`, on point feet the stance ankle's torque on a flat
  foot, no swing ankle), in (N m)^2;
* ``"work"``: the positive mechanical power of the hinge drives sum max(0, M_i w_i) (w_i the
  hinge's relative rate: dpsi_i - dpsi_parent), smoothed as (P + sqrt(P^2 + eps^2)) / 2 with
  eps = ``WORK_EPSILON`` P_s, plus ``WORK_REGULARISATION`` P_s / L^2 times the torque term.
  L is the median torque limit (N m) and P_s = L x 1 rad/s its power scale, so the objective
  means the same in any units (millimetres and grams: W and N m are 1e9 of theirs): with the
  walking step's 150 N m, eps = 1 W and the torque term's weight 1e-3 W/(N m)^2.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from model import LinkageTrajectory
from model.linkage import Linkage
from model.linkage_naming import FORCES, centre_of_pressure_name, root_contact
from model.rotors import ground_moment_row
from planner.accuracy_check import ACCURACY_WARNING, check_accuracy_of
from planner.errors import AnthropoidError, DefinitionError, check_positive, check_real
from planner.phases_solution import PhasesSolution
from planner.problem import OCP
from planner.sampled_limits import hold_at_samples
from planner.solution import Solution
from planner.solver import solve
from planner.trajectory import Trajectory
from planner.transcription import Transcription
from problems.gait.accuracy import refine_gait
from problems.gait.biped import Biped
from problems.gait.verification import (
    GaitReport,
    GaitVerificationError,
    GaitVerificationWarning,
    verify_gait,
)
from problems.human.effort import HUMAN, human_integrand

OBJECTIVES = ("torque", "torque-rate", "work", "human")
HALF_PI = 0.5 * math.pi
#: Smoothing of max(0, P) in the positive-work objective, as a fraction of the power scale
#: (median torque limit x 1 rad/s): 1 W at 150 N m.
WORK_EPSILON = 1.0 / 150.0
#: Weight of the torque term of the work objective, times P_s / L^2 (L the median torque
#: limit): 1e-3 W/(N m)^2 at 150 N m.
WORK_REGULARISATION = 0.15
#: Weight of the torque term added to the torque-rate objective, s^-2.
REGULARISATION = 1e-3


#: The export rate at which the gait problems hold their limits unless told another, Hz
#: (what ``python -m problems walk`` writes by default).
RATE_HZ = 1000.0
#: The keyword arguments of :func:`planner.solve` (a gait's solve options may hold others,
#: for the refinement).
_SOLVE_KEYWORDS = frozenset(inspect.signature(solve).parameters) - {"problem"}


def hold_limits(problem, solution, rate_hz: float | None, options: dict, pinned=(), deadline=None):
    """``solution`` of ``problem`` (an OCP or Phases), solved again with its limits backed
    off where its exported motion at ``rate_hz`` misses them between the collocation points
    (:func:`planner.sampled_limits.hold_at_samples`; ``pinned``: rows boundary conditions
    fix at the phases' ends), with the same solve ``options``; a failed re-solve raises, and
    so does a round that would start past ``deadline`` (a ``time.perf_counter()`` instant, or
    None). ``solution`` itself when nothing misses or it failed."""
    if not solution.success:
        return solution
    kept = {key: value for key, value in options.items() if key in _SOLVE_KEYWORDS}
    kept["raise_on_failure"] = True
    kept["accuracy_warning"] = None  # measured once, on the plan the rounds end with
    # Each round restarts from the last one's multipliers, whatever the first solve started
    # from: the rounds then end where they end for every caller (a study, a single solve);
    # and a round of the same structure as the one before takes its solver from the cache.
    kept["warm_start"] = True
    # ... from near it: the margins move by fractions of a per cent, cut intervals keep
    # their motion (about half the iterations of a plain warm start; a failure retries one)
    kept["near_restart"] = True
    kept["cache"] = True

    def again(changed):
        if deadline is not None and time.perf_counter() > deadline:
            raise AnthropoidError(
                "the wall-time budget ran out in the limits' hold rounds (they had not "
                "settled); give it more time or a coarser rate"
            )
        return solve(changed, **kept)

    held = hold_at_samples(problem, rate_hz, again, solution, pinned=tuple(pinned))
    history = solution.stats.get("refinement")
    if history is not None and held is not solution:
        # The refinement reached its target with the first solve; the limits held between
        # the points moved the solution: its accuracy is measured again, and the history
        # says whether the held plan still meets the target.
        error = check_accuracy_of(held, None)["error"]
        held.stats["error_after_limits"] = error
        if history.reached and error > history.target:
            history = dataclasses.replace(
                history,
                reached=False,
                reason=f"the limits held between the points left an error of {error:.2e}",
            )
    if history is not None:
        held.stats["refinement"] = history
    return held


def refine_and_hold(problem, target: float, options: dict, hold: bool, rate_hz, pinned=()):
    """A gait problem's ``solve(accuracy=target)``: the mesh refined to the target
    (:func:`problems.gait.accuracy.refine_gait`), the limits held on the exported motion (when
    ``hold``), the accuracy of the plan that comes out measured once (and warned about).
    Returns (solution, the OCP on the refined mesh)."""
    options = dict(options)
    warning = options.pop("accuracy_warning", ACCURACY_WARNING)
    solution, final = refine_gait(problem, target, options)
    if hold:
        solution = hold_limits(final, solution, rate_hz, options, pinned)
    if solution.success:
        check_accuracy_of(solution, warning)
    return solution, final


def solve_and_hold(problem, options: dict, hold: bool, rate_hz, pinned=(), seconds=None):
    """What a gait problem's ``solve`` does with a built problem (an OCP, Phases or its
    Transcription): solve it with ``options``, hold its limits on the exported motion at
    ``rate_hz`` (when ``hold``) and measure the accuracy of the plan that comes out once
    (``options["accuracy_warning"]``, default :data:`planner.ACCURACY_WARNING`).
    ``seconds``: a wall-time budget of the whole (None: none): each solve gets it as IPOPT's
    ``max_wall_time`` (one value, so the rounds' solvers still come from the cache) and no
    hold round starts past it, so the whole takes at most about twice it."""
    options = dict(options)
    warning = options.pop("accuracy_warning", ACCURACY_WARNING)
    deadline = None
    if seconds is not None:
        seconds = check_positive("seconds", seconds, "s")
        deadline = time.perf_counter() + seconds
        options["options"] = {"max_wall_time": seconds, **(options.get("options") or {})}
    solution = solve(problem, accuracy_warning=None, **options)
    if hold:
        source = problem
        if isinstance(problem, Transcription):
            source = problem.single or problem.problem
        solution = hold_limits(source, solution, rate_hz, options, pinned, deadline)
    if solution.success and warning is not None:
        check_accuracy_of(solution, warning)
    return solution


#: Checks that compare neighbouring samples: a plan whose mesh is finer than the samples
#: somewhere (the hold's cuts) can move between two samples more than they can show.
SAMPLING_CHECKS = ("kinematics", "rates")


def verified(gait: Gait, rate_hz, verify: bool, options: Mapping[str, Any]) -> Gait:
    """A gait problem's ``solve()`` is honest: a plan that converged is verified on the
    samples it exports (:meth:`Gait.verify` at ``rate_hz``, None: the nodes; the report is
    ``gait.verification``) and, when it fails, never handed out as a plain success: it
    raises :class:`problems.GaitVerificationError` (carrying the gait and the report), or,
    with ``raise_on_failure=False`` among the solve's ``options``, warns with
    :class:`problems.GaitVerificationWarning` (``gait.verified`` is False). ``verify=False``
    skips it (``gait.verified`` is None)."""
    if not verify or not gait.success:
        return gait
    report = gait.verify(rate_hz)
    gait._cache["verification"] = report
    if report.ok:
        return gait
    at = "its nodes" if rate_hz is None else f"{rate_hz:g} Hz"
    listed = "; ".join(
        f"{c.name} misses by {-c.margin:.3g} {c.unit} at {c.where} (tolerance {c.tolerance:.0e})"
        for c in report.failures
    )
    if all(c.name in SAMPLING_CHECKS for c in report.failures):
        hint = (
            "the plan moves between two samples more than they can show (its mesh is finer "
            "than the samples there): verify and export it at a higher rate (solve(rate_hz=...)"
            ", gait.verify(rate_hz=...))"
        )
    else:
        hint = "refine the mesh (a larger N)"
    message = (
        f"the solve converged ({gait.solution.status}) but the plan fails its own verification "
        f"at {at}: {listed}; {hint}"
    )
    if options.get("raise_on_failure", True):
        raise GaitVerificationError(message, gait=gait, report=report)
    warnings.warn(message, GaitVerificationWarning, stacklevel=3)
    return gait


def total_iterations(solution) -> int:
    """IPOPT's iterations of a gait's solve: the first solve's and those of the rounds that
    held its limits at the samples."""
    held = solution.stats.get("sampled_limits")
    if held is None:
        return solution.iterations
    return int(sum(r["iterations"] for r in held["rounds"]))


def total_seconds(solution) -> tuple[float, float]:
    """(build, solve) seconds of a gait's solve, the first solve's and those of the rounds
    that held its limits at the samples."""
    held = solution.stats.get("sampled_limits")
    if held is None:
        return solution.stats["build_seconds"], solution.stats["solve_seconds"]
    rounds = held["rounds"]
    return (
        float(sum(r["build_seconds"] for r in rounds)),
        float(sum(r["solve_seconds"] for r in rounds)),
    )


def check_objective(objective: str) -> str:
    if objective not in OBJECTIVES:
        raise DefinitionError(f"`objective`: unknown {objective!r}; use one of {OBJECTIVES}")
    return objective


def joint_rates(linkage: Linkage, dpsi):
    """Each hinge's relative rate dpsi_i - dpsi_parent(i) (the root's: dpsi_root), rad/s:
    a list of expressions (SX) or a numpy array (K, n), like ``dpsi``."""
    parents = linkage.parents
    if isinstance(dpsi, np.ndarray):
        rates = dpsi.copy()
        for i, p in enumerate(parents):
            if p >= 0:
                rates[:, i] -= dpsi[:, p]
        return rates
    return [dpsi[i] - (dpsi[p] if p >= 0 else 0) for i, p in enumerate(parents)]


def objective_integrand(linkage: Linkage, objective: str, torque_limit: float = 150.0):
    """The integrand of ``objective`` as a callable of a planner Point; ``torque_limit``
    (the median |M_i| bound, N m, in the problem's units) sets the work objective's scales."""
    check_objective(objective)
    if objective == "torque":
        return lambda p: ca.sumsqr(p.M)
    if objective == "human":
        return human_integrand(linkage, HUMAN, linkage.names)
    if objective == "torque-rate":
        return lambda p: ca.sumsqr(p.dM) + REGULARISATION * ca.sumsqr(p.M)
    power_scale = check_positive("torque_limit", torque_limit)  # x 1 rad/s
    epsilon = WORK_EPSILON * power_scale
    weight = WORK_REGULARISATION / power_scale

    def positive_work(p):
        rates = joint_rates(linkage, p.dpsi)
        power = [p.M[i] * rates[i] for i in range(linkage.n)]
        smooth = [0.5 * (w + ca.sqrt(w * w + epsilon**2)) for w in power]
        return ca.sum1(ca.vertcat(*smooth)) + weight * ca.sumsqr(p.M)

    return positive_work


def torque_limits(linkage: Linkage, torque_limit, links=None) -> dict[str, float]:
    """|M_i| bounds, N m, per link name, from one number or a mapping over every link of
    ``links`` (default all; a walker on feet: its drives, the root's torque the ground's)."""
    names = linkage.names if links is None else tuple(links)
    if isinstance(torque_limit, Mapping):
        unknown = [k for k in torque_limit if k not in names]
        if unknown:
            raise DefinitionError(
                f"`torque_limit`: unknown links {unknown}; known links: {list(names)}"
            )
        limits = {k: check_real(f"torque_limit[{k}]", v) for k, v in torque_limit.items()}
        missing = [k for k in names if k not in limits]
        if missing:
            raise DefinitionError(
                f"`torque_limit`: give a limit for every link, missing {missing}; or one "
                "number for all"
            )
    else:
        value = check_real("torque_limit", torque_limit)
        limits = dict.fromkeys(names, value)
    for name, value in limits.items():
        if value <= 0:
            raise DefinitionError(f"`torque_limit`: must be > 0 N m, got {value!r} for {name!r}")
    return {name: limits[name] for name in names}


def check_links(field_name: str, names, linkage: Linkage) -> tuple[str, ...]:
    """``names`` as a tuple of link names of ``linkage``, or a DefinitionError naming the
    unknown one."""
    if isinstance(names, str):
        raise DefinitionError(f"`{field_name}`: give a sequence of link names, got {names!r}")
    names = tuple(names)
    for name in names:
        if name not in linkage.names:
            raise DefinitionError(
                f"`{field_name}`: no link called {name!r}; known links: {list(linkage.names)}"
            )
    return names


def gait_ocp(dynamics, duration: float, mesh: Mapping[str, Any], limits: Mapping[str, float]):
    """The OCP both gait problems start from: the linkage's dynamics on [0, duration] with
    ``mesh`` (N, transcription, degree, formulation) and |M_i| <= limits[name]."""
    ocp = OCP(dynamics, T=duration, **mesh)
    for name, limit in limits.items():
        ocp = ocp.bound(f"M_{name}", -limit, limit)
    return ocp


def bound_stance_hip(ocp: OCP, linkage: Linkage, stance_thigh: str, limit: float | None) -> OCP:
    """``stance hip`` rows: a biped's physical stance-hip drive, between its trunk and its
    stance thigh, carries the torques of every hinge at the stance thigh's end (the tree's
    M_trunk + M_swing_thigh: each bounded on its own by the torque limits), within +-``limit``
    N m (None: no rows)."""
    if limit is None:
        return ocp
    thigh = linkage.index(stance_thigh)
    hinges = list(linkage.children[thigh])
    return ocp.constrain(
        "stance hip",
        lambda p: ca.sum1(ca.vertcat(*[p.M[i] for i in hinges])),
        lower=-limit,
        upper=limit,
        scale=limit,
    )


def bound_joint_speeds(ocp: OCP, linkage: Linkage, biped: Biped, drives: Sequence[str],
                       limit: float | None) -> OCP:  # fmt: skip
    """``joint speeds`` rows: the rate of each physical joint whose hinge has a drive (the
    links ``drives``, each turned against its parent, the ground for the root, and the swing
    thigh against the trunk, as the robot's hip drive turns it: the model's angles are
    absolute) within +-``limit`` rad/s at every node (None: no rows). A drive turns no faster
    than its motor's speed over its ratio: a plan for ideal torque sources within it is one a
    geared drive can follow, and a light swing foot is no longer whipped round for free (a
    torque objective prices a fast, light link at almost nothing)."""
    if limit is None:
        return ocp
    names = linkage.names
    stance_thigh, swing_thigh = biped.stance_leg[-1], biped.swing_leg[0]
    trunks = [names[c] for c in linkage.children[linkage.index(stance_thigh)]
              if names[c] != swing_thigh]  # fmt: skip
    pairs = []
    for name in drives:
        parent = linkage.parents[linkage.index(name)]
        stator = None if parent < 0 else names[parent]
        if name == swing_thigh and len(trunks) == 1:
            stator = trunks[0]
        pairs.append((name, stator))

    def rates(p):
        return ca.vertcat(*[p[f"dpsi_{name}"] - (0 if stator is None else p[f"dpsi_{stator}"])
                            for name, stator in pairs])  # fmt: skip

    return ocp.constrain("joint speeds", rates, lower=-limit, upper=limit, scale=limit)


def keep_upright(ocp: OCP, upright: Sequence[str], posture: float) -> OCP:
    """``posture`` rows: each link of ``upright`` within ``posture`` rad of the vertical."""
    if not upright:
        return ocp
    return ocp.constrain(
        "posture",
        lambda p: ca.vertcat(*[p[f"psi_{name}"] - HALF_PI for name in upright]),
        lower=-posture,
        upper=posture,
    )


#: Nominal angular rate and acceleration of a gait's links, rad/s and rad/s^2, for the
#: six-link walker; another walker's in its own time unit (:func:`rate_scales`).
RATE_SCALE, ACCELERATION_SCALE = 3.0, 30.0


def rate_scales(time_unit: float = 1.0) -> dict[str, float]:
    """The nominal scales of dpsi and ddpsi for a walker whose time unit sqrt(L / g) is
    ``time_unit`` times the six-link walker's (:attr:`problems.gait.similarity.WalkerScales
    .relative`): a walker scaled in size or gravity sees the same scaled NLP, so IPOPT takes
    the same path and the accuracy check (errors per nominal scale) means the same."""
    return {"dpsi": RATE_SCALE / time_unit, "ddpsi": ACCELERATION_SCALE / time_unit**2}


def finish_gait_ocp(
    ocp: OCP, linkage: Linkage, objective: str, limits, law, time_unit: float = 1.0
) -> OCP:
    """The objective, nominal scales and the law as the guess, the same for both problems:
    angles ~1 rad, rates a few rad/s, accelerations tens of rad/s^2 (in the walker's own
    time unit, ``time_unit``: :func:`rate_scales`), torques a third of their limit (the
    law's inverse dynamics is of that size)."""
    limit = float(np.median(list(limits.values())))
    typical = limit / 3.0
    integrand = objective_integrand(linkage, objective, limit)
    rates = rate_scales(time_unit)
    ocp = ocp.minimize(integral=integrand).scale(dpsi=rates["dpsi"], M=typical)
    if ocp.system.nz:
        ocp = ocp.scale(ddpsi=rates["ddpsi"])
    return ocp.guess(law)


def centre_of_pressure(moment: np.ndarray, force: np.ndarray) -> np.ndarray:
    """x_p = M / Fy (m) of an ankle torque M (K,) N m over the ground force Fy (K,) complex
    Fx + j Fy, N: where a sole puts its pressure to transmit M; 0 where Fy <= 0 (a foot
    that carries nothing transmits no torque either: the rows -heel Fy <= M <= toe Fy)."""
    fy = np.asarray(force).imag
    safe = np.where(fy > 0, fy, 1.0)
    return np.where(fy > 0, np.asarray(moment) / safe, 0.0)


def objective_at_guess(transcription) -> float:
    """The NLP's objective at its initial guess, in the objective's physical units (a
    :class:`planner.Transcription` of an OCP or of phases)."""
    nlp = transcription.parametric_nlp
    objective = ca.Function("objective_at_guess", [nlp["x"], nlp["p"]], [transcription._objective])
    return float(objective(transcription.initial_guess(), transcription.parameter_values()))


@dataclass(frozen=True, eq=False)
class Gait:
    """A solved gait problem: the planner Solution and the measurements a study records.

    ``problem`` is the problem it solves (it provides ``linkage``, ``dynamics`` and
    ``settings()``); ``law_cost`` is the fitted law's objective on the same mesh.
    """

    problem: Any
    solution: Solution
    law_cost: float
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def cost(self) -> float:
        return self.solution.cost

    @property
    def success(self) -> bool:
        return self.solution.success

    def segments(self) -> list[tuple[Solution, float]]:
        """(Solution, start time s) of each phase: the solution itself, or each phase of a
        multi-phase solution on the common time axis."""
        if isinstance(self.solution, PhasesSolution):
            return list(zip(self.solution.phases, self.solution.starts.tolist(), strict=True))
        return [(self.solution, 0.0)]

    @property
    def duration(self) -> float:
        """The step's or period's duration, s."""
        return float(self.solution.T)

    def fine(self, count: int = 2001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(times (K,), states (K, 2n), torques (K, n)) on a uniform grid through the
        solution's interpolant (each phase's own on a multi-phase solution; cached)."""
        key = ("fine", count)
        if key not in self._cache:
            n = self.problem.linkage.n
            parts = []
            for solution, t0 in self.segments():
                share = max(2, round(count * solution.T / self.duration))
                local = np.linspace(0.0, solution.T, share)
                states, controls = solution(local)
                parts.append((local + t0, states, controls[:, :n]))
            self._cache[key] = tuple(np.concatenate(column) for column in zip(*parts, strict=True))
        return self._cache[key]

    @property
    def positive_work(self) -> float:
        """Positive mechanical work of the hinge drives over the step or period, J: the
        integral of sum max(0, M_i w_i) on a 2001-point grid (per phase)."""
        total = 0.0
        for solution, _ in self.segments():
            count = max(2, round(2001 * solution.T / self.duration))
            times = np.linspace(0.0, solution.T, count)
            states, controls = solution(times)
            n = self.problem.linkage.n
            rates = joint_rates(self.problem.linkage, states[:, n:])
            power = np.maximum(controls[:, :n] * rates, 0.0)
            total += float(np.trapezoid(power.sum(axis=1), times))
        return total

    def to_trajectory(self, rate_hz: float | None = None) -> Trajectory:
        """The solution's consistent motion at ``rate_hz`` (default the nodes;
        :meth:`planner.Solution.motion`: torques the inverse dynamics of the sampled motion),
        with the ground reaction on the root's foot (``F_<root>_start_x``, ``_y``, N), the
        centre of pressure its ankle torque implies (``CoP_<root>_start_x``, m from the
        ankle along x: M / Fy, 0 where the foot carries nothing), the contact forces of a
        phase with more contacts (zero where they are not held), and the problem's settings
        (``metadata["gait"]``). On a multi-phase solution the phases follow each other
        (``PhasesSolution.to_trajectory``); where two meet, the later phase's first sample is
        kept (after an impact) and the state just before it goes into
        ``metadata["gait"]["before_events"]``."""
        joined = self.solution.to_trajectory(rate_hz)
        contacts = [name for name in joined.extras if name.startswith(f"{FORCES}_")]
        force = self.problem.dynamics.ground_reaction(joined.psi, joined.dpsi, joined.ddpsi)
        for name in contacts:  # the root's foot takes what the other contacts do not
            value = np.asarray(joined.extras[name][0])
            force = force - (value if name.endswith("_x") else 1j * value)
        segments = self.segments()
        before = [
            {"t": float(t0 + solution.T), "x": solution.states[-1].tolist()}
            for solution, t0 in segments[:-1]
        ]
        held = self.solution.stats.get("sampled_limits")
        metadata = {
            **joined.metadata,
            # every solve's: the first and the hold rounds' (the solution's own count is the
            # last re-solve's)
            "iterations": total_iterations(self.solution),
            "solves": 1 if held is None else len(held["rounds"]),
            "gait": {
                **self.problem.settings(times=joined.time),
                "cost": self.cost,
                "law_cost": self.law_cost,
                "before_events": before,
            },
        }
        trajectory = LinkageTrajectory.from_linkage(
            joined.time,
            joined.psi,
            joined.dpsi,
            joined.torques,
            self.problem.linkage.names,
            ddpsi=joined.ddpsi,
            ground_reaction=force,
            metadata=metadata,
        )
        for name in contacts:
            trajectory = trajectory.with_extra(name, joined.extras[name][0], "N")
        root = root_contact(self.problem.linkage.names)
        moment = self._ground_moment(joined.torques, joined.ddpsi)
        trajectory = trajectory.with_extra(
            centre_of_pressure_name(root), centre_of_pressure(moment, force), "m"
        )
        return trajectory

    def _ground_moment(self, torques: np.ndarray, ddpsi: np.ndarray) -> np.ndarray:
        """The moment the ground takes at the root (K,), N m: the root's torque, less what
        a rotor geared to the ground holds of it (``model.rotors.ground_moment_row``)."""
        dynamics = getattr(self.problem, "dynamics", None)
        rotors = () if dynamics is None else dynamics.rotors
        row = ground_moment_row(rotors, self.problem.linkage.names)
        return torques[:, 0] + (ddpsi @ row if np.any(row) else 0.0)

    def centre_of_pressure(self, rate_hz: float | None = None) -> tuple[float, float]:
        """(least, largest) centre of pressure of the stance foot over the samples at
        ``rate_hz``, m from the ankle along x (M / Fy of the root's torque and ground force)."""
        trajectory = self.to_trajectory(rate_hz)
        force = trajectory.ground_reaction
        loaded = force.imag > 0
        moment = self._ground_moment(trajectory.torques, trajectory.ddpsi)
        values = centre_of_pressure(moment, force)[loaded]
        return (float(values.min()), float(values.max())) if values.size else (0.0, 0.0)

    @property
    def verification(self) -> GaitReport | None:
        """The report of the verification the problem's ``solve()`` ran on this plan's
        samples (None when it ran none: ``verify=False``, or a failed solve)."""
        return self._cache.get("verification")

    @property
    def verified(self) -> bool | None:
        """Whether the plan passed that verification (None when none ran)."""
        report = self.verification
        return None if report is None else report.ok

    def verify(self, rate_hz: float | None = RATE_HZ, **options) -> GaitReport:
        """:func:`problems.verify_gait` on the trajectory at ``rate_hz`` (default 1 kHz, what
        the files hold; None: the nodes) (``options``: ``tolerance``, ``settings``
        overrides, ...)."""
        # the samples made once per rate (:meth:`exported`): the solve's own verification,
        # the summary and the files read the same ones
        return verify_gait(self.exported(rate_hz), self.problem.linkage, **options)

    def exported(self, rate_hz: float | None = RATE_HZ) -> Trajectory:
        """:meth:`to_trajectory` at ``rate_hz``, made once (what the files hold at that rate)."""
        key = ("exported", rate_hz)
        if key not in self._cache:
            self._cache[key] = self.to_trajectory(rate_hz)
        return self._cache[key]

    def summary(self, rate_hz: float | None = RATE_HZ) -> dict[str, Any]:
        """Status, cost and law cost, positive work, peak and RMS torque per hinge (N m) of
        the exported samples at ``rate_hz`` (what a file written at that rate holds: the
        consistent motion's torques, not the solution's interpolant), IPOPT's iterations over
        every solve (the first and the hold rounds' re-solves), how many solves, build and
        solve seconds of the first."""
        exported = self.exported(rate_hz)
        times, torques = np.asarray(exported.time), np.asarray(exported.torques)
        names = self.problem.linkage.names
        rms = np.sqrt(np.trapezoid(torques**2, times, axis=0) / self.duration)
        stats = self.solution.stats
        held = stats.get("sampled_limits")
        return {
            "status": self.solution.status,
            "success": self.success,
            "cost": self.cost,
            "law_cost": self.law_cost,
            "positive_work": self.positive_work,
            "peak_torque": dict(zip(names, np.max(np.abs(torques), axis=0).tolist(), strict=True)),
            "rms_torque": dict(zip(names, rms.tolist(), strict=True)),
            "iterations": total_iterations(self.solution),
            "solves": 1 if held is None else len(held["rounds"]),
            "build_seconds": stats.get("build_seconds"),
            "solve_seconds": stats.get("solve_seconds"),
        }


__all__ = [
    "HALF_PI",
    "OBJECTIVES",
    "RATE_HZ",
    "REGULARISATION",
    "WORK_EPSILON",
    "WORK_REGULARISATION",
    "Gait",
    "centre_of_pressure",
    "check_links",
    "check_objective",
    "finish_gait_ocp",
    "gait_ocp",
    "hold_limits",
    "joint_rates",
    "keep_upright",
    "objective_at_guess",
    "objective_integrand",
    "rate_scales",
    "refine_and_hold",
    "solve_and_hold",
    "torque_limits",
    "total_iterations",
    "verified",
]
