"""The steps between gaits: from one periodic gait (or quiet standing) to another (or to
standing at rest), planned as one multi-phase problem of as many steps as the limits need.

A transition of k steps is k single supports on point feet (:func:`problems.walking_step`'s
rows: friction, clearance, knees, ground, centre of pressure, posture, torque bounds), joined
by the heel strike and leg swap (``WalkingStep.step_map``: x_{j+1}(0) = Delta(x_j(T_j))),
solved together (:class:`planner.Phases`), so the change is shared among the steps. Its ends:

* from a gait a: x_1(0) = a's x(0), the state right after a's heel strike: a step of a ends
  and the transition's first step starts there (the join a -> transition is a's own impact);
* into a gait b: x_k(T_k) = b's x(T), the state before b's heel strike: the impact that ends
  the transition is b's own, so the next step of b starts at b's x(0) exactly;
* from quiet standing: at t = 0 both feet on the ground at one point (the planar picture of
  feet side by side), the body at rest (dpsi = 0, ddpsi = 0: the standing torques hold the
  pose statically and the plan's torques start from them); the pose itself is planned, its
  centre of pressure on the sole like every other instant;
* to standing at rest: the last step sets the swing foot down beside the stance foot with
  dpsi = ddpsi = 0 (no impact: the foot lands at rest, ``touchdown_speed`` 0 for that step).

Each step also keeps the stance foot loaded, its normal force at least ``support`` (default
:data:`SUPPORT`) of the weight (``support`` rows).

Rows that only read an end's fixed state (lift off at a fixed start; landing, heel strike and
impulse at a fixed end) are left out: the gait whose state it is satisfied them already.

Step j of k (1..k) walks at v_j = v_a + (v_b - v_a) j / k with the step length and time of
:func:`problems.walking.footed.step_at_speed` (standing is v = 0: its step has length 0 and
the time of the ramp's first speed). ``steps=None`` finds k: 1, 2, ... ``max_steps``, the
first whose problem solves within the limits and whose every step passes its verification
(a faster change needs larger torques; the limits decide how many steps it takes).

On feet (both ends periodic steps on feet, :class:`problems.walking.footed.FootedGait`, or
quiet standing into one), the steps are the gaits' own contact phases with the same ends and
the same search: :mod:`problems.library.footed_transition` (:data:`STANDING`, an end that is
quiet standing, not a gait, is defined there).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from planner.errors import (
    AnthropoidError,
    DefinitionError,
    check_integer,
    check_positive,
    check_real,
)
from planner.phases_solution import PhasesSolution
from planner.problem import Phases
from planner.solver import SolverError
from planner.transcription import Transcription
from problems.gait.problem import RATE_HZ, rate_scales, solve_and_hold, total_iterations
from problems.gait.verification import GaitReport, verify_gait
from problems.library.footed_transition import STANDING, footed_transition_problem, step_parts
from problems.library.ramp import end_speed, speed_ramp
from problems.walking.footed import PINNED as FOOTED_PINNED
from problems.walking.footed import FootedGait, FootedStep
from problems.walking.step import LAND_TIME, PINNED, WalkingGait, WalkingStep, walking_step

#: the largest number of steps a transition's search tries by default
MAX_STEPS = 6
#: IPOPT iterations a try of the search may take: a transition that solves takes 20-70 (the
#: six-link walker, 0-1.4 m/s); an infeasible count runs to IPOPT's infeasibility detection
#: (about 600), which this cuts short; a count that needs more is taken as failed, and the
#: next count tried.
SEARCH_ITERATIONS = 300
#: the wall time a try of a transition may take, s, its limits' hold rounds included (each
#: solve capped at it, no round started past it): on feet a count that does not settle can
#: spend 20 minutes in hold rounds (1.0 -> 1.4 m/s unbounded, examples/feet.md), while the
#: tries that solved took 11-130 s alone on this machine and 344 s beside two other jobs
#: (0.6 -> 1.0 m/s in 3 steps)
SEARCH_SECONDS = 600.0
#: IPOPT iterations of the search's second pass: when no count solved within the first
#: pass's cap, the counts that stopped on that cap (not on infeasibility, the wall time, a
#: hold round or the verification) are tried again, fewest steps first, with this many. On
#: feet slowing from 1.4 m/s stops on 300 in every count and 1.4 -> 1.2 m/s solves in one
#: step at 1000 (scratch runs); a count that is infeasible fails the first pass on its own.
RETRY_ITERATIONS = 1000
#: IPOPT's status when it stopped on its iteration cap
_CAPPED = "Maximum_Iterations_Exceeded"
#: how an attempt of the second pass begins its outcome in ``Transition.attempts``
RETRIED = "again at"
#: the stance foot's least normal force in a transition, a fraction of the weight: without it
#: the optimum of a speed-up from 1.0 to 1.4 m/s unloads the stance foot to 4 % of the weight
#: right after the heel strike (the body falls forward nearly free), which the product's
#: simulation of the walk 10 % heavier or lighter turns into a foot pulled off the ground;
#: the periodic gaits at 0.6-1.4 m/s start their steps at 14-21 % (measured)
SUPPORT = 0.1
#: the rows a fixed start or end makes constants (the gait there satisfied them already)
START_ROWS = ("lift off",)
END_ROWS = ("landing", "heel strike", "impulse")


def _checked_end(field: str, end):
    if isinstance(end, str):
        if end != STANDING:
            raise DefinitionError(f"`{field}`: a WalkingGait or {STANDING!r}, got {end!r}")
        return end
    problem = getattr(end, "problem", None)
    if not isinstance(end, WalkingGait) or not isinstance(problem, WalkingStep):
        raise DefinitionError(
            f"`{field}`: a solved periodic walking step (WalkingGait of problems.walking_step) "
            f"or {STANDING!r}, got {type(end).__name__}"
        )
    if problem.double_support > 0:
        raise DefinitionError(
            f"`{field}`: transitions join single-support steps; this gait has a "
            f"{problem.double_support:g} s double support (plan it with double_support=0)"
        )
    return end


@dataclass(frozen=True, eq=False)
class Transition:
    """A planned transition: ``start`` and ``end`` (gaits or :data:`STANDING`), its steps
    (``gaits``: one :class:`WalkingGait` per step, each its phase of ``solution`` with the
    step's own problem), ``reports`` (each step's verification against the next step's first
    state, or the end's), ``attempts`` ((step count, outcome) of the search)."""

    start: object
    end: object
    gaits: tuple[WalkingGait, ...]
    solution: PhasesSolution
    reports: tuple[GaitReport, ...]
    attempts: tuple[tuple[int, str], ...]

    @property
    def steps(self) -> int:
        return len(self.gaits)

    @property
    def speeds(self) -> tuple[float, float]:
        """(from, to), m/s (standing is 0)."""
        return end_speed(self.start), end_speed(self.end)

    @property
    def duration(self) -> float:
        return math.fsum(gait.duration for gait in self.gaits)

    def peak_torques(self, rate_hz: float = RATE_HZ) -> dict[str, float]:
        """The largest |M| of each hinge over the transition's samples exported at ``rate_hz``
        (what a file written at that rate holds), N m; on feet the drives' only (the root's
        torque is the ground's on the stance foot)."""
        problem = self.gaits[0].problem
        names = problem.linkage.names
        peaks = np.max([np.max(np.abs(g.exported(rate_hz).torques), axis=0)
                        for g in self.gaits], 0)  # fmt: skip
        drives = problem.drives if isinstance(problem, FootedStep) else names
        return {name: float(peak) for name, peak in zip(names, peaks, strict=True)
                if name in drives}  # fmt: skip

    @property
    def iterations(self) -> int:
        return total_iterations(self.solution)


def _open(ocp, drop):
    """The step's OCP without its periodicity and without the rows named in ``drop``."""
    rows = tuple(c for c in ocp.constraints if c.name not in drop)
    return replace(ocp, periodicity=None, constraints=rows)


def _at_rest(step: WalkingStep, ocp, at: str):
    """Quiet standing at ``at`` ("start" or "end"): the swing foot on the ground at the
    stance foot, dpsi = 0 and ddpsi = 0 (the pose held statically)."""
    n = step.linkage.n
    position = step.foot.function("position")
    leg = step.biped.leg_length
    ocp = ocp.boundary(
        "feet together", lambda p: ca.vertcat(*position(p.x[:n])), at=at,
        lower=[0.0, 0.0], upper=[0.0, 0.0], scale=leg,
    )  # fmt: skip
    rest = [0.0] * n
    ocp = ocp.initial(dpsi=rest) if at == "start" else ocp.final(dpsi=rest)
    scale = rate_scales(step.time_unit)["ddpsi"]  # the accelerations' nominal size
    return ocp.boundary("at rest", lambda p: p.ddpsi, at=at, lower=0.0, upper=0.0, scale=scale)


def _supported(step: WalkingStep, ocp, least: float):
    """``support`` rows: the stance foot's normal force at least ``least`` of the weight."""
    if least <= 0:
        return ocp
    reaction = step.dynamics.function("ground_reaction")
    weight = step.biped.total_mass * step.linkage.gravity
    return ocp.constrain("support", lambda p: reaction(p.psi, p.dpsi, p.ddpsi)[1],
                         lower=least * weight, scale=weight)  # fmt: skip


def transition_problem(
    start, end, steps: int, *, support: float = SUPPORT, **step_options
) -> tuple:
    """(Phases, the k WalkingSteps) of a transition of ``steps`` steps (see the module);
    ``support``: the stance foot's least normal force, a fraction of the weight."""
    start, end = _checked_end("start", start), _checked_end("end", end)
    k = check_integer("steps", steps, 1)
    support = check_real("support", support)
    if not 0.0 <= support < 1.0:
        raise DefinitionError(f"`support`: a fraction of the weight in [0, 1), got {support!r}")
    if isinstance(start, str) and isinstance(end, str):
        raise DefinitionError("`start`, `end`: a transition from standing to standing is no walk")
    guesses = [g for g in (start, end) if not isinstance(g, str)]
    linkage = guesses[0].problem.linkage  # the walker of the gaits it joins
    n = linkage.n
    phases, problems = None, []
    ramp = speed_ramp(start, end, k)
    for j, (speed, length, duration) in enumerate(ramp):
        last = j == k - 1
        options = dict(step_options)
        if last and isinstance(end, str):
            options["touchdown_speed"] = 0.0  # the foot sets down at rest ...
            options["land_time"] = LAND_TIME  # ... under a floor that ends flat
        # the law guesses a step of some length: a stop's last one lands at 0
        guide = length if length > 0 else ramp[0][1] or 0.5
        step = walking_step(linkage, guide, duration, **options)
        drop = set(START_ROWS if j == 0 else ()) | set(END_ROWS if last else ())
        ocp = _supported(step, _open(step.ocp, drop), support)
        if j == 0:
            if isinstance(start, str):
                ocp = _at_rest(step, ocp, "start")
            else:
                x = start.segments()[0][0].states[0]
                ocp = ocp.initial(psi=x[:n].tolist(), dpsi=x[n:].tolist())
        if last:
            if isinstance(end, str):
                ocp = _at_rest(step, ocp, "end")
                step = replace(step, step_length=0.0)
            else:
                x = end.segments()[0][0].states[-1]
                ocp = ocp.final(psi=x[:n].tolist(), dpsi=x[n:].tolist())
        nearest = min(guesses, key=lambda g: abs(g.speed - speed))
        ocp = ocp.guess(nearest.solution)
        step = replace(step, ocp=ocp)
        name = f"step {j + 1}"
        if phases is None:
            phases = Phases.sequence((name, ocp))
        else:
            phases = phases.then(name, ocp, mapping=problems[-1].step_map)
        problems.append(step)
    return phases, tuple(problems)


def standing_after(swap, x_end) -> list[float]:
    """The state (2n,) a walk that ends at rest stands in after its last step, in the next
    step's labels (what its heel strike is checked against): the last pose relabelled
    (``swap``: :func:`model.swap_legs`), the rates 0 (the foot sets down at rest)."""
    x_end = np.asarray(x_end, dtype=float)
    n = x_end.size // 2
    psi, _ = swap.map_state(x_end[:n], x_end[n:])
    return [*np.asarray(psi, dtype=float).tolist(), *([0.0] * n)]


def _verify_steps(gaits, start, end, rate_hz: float) -> tuple[GaitReport, ...]:
    """Each step's samples verified, its impact against the next step's first state (the
    end's: a gait b's x(0), or the standing pose relabelled at rest)."""
    reports = []
    for j, gait in enumerate(gaits):
        trajectory = gait.exported(rate_hz)
        settings: dict = {}
        if j + 1 < len(gaits):
            settings["next_state"] = gaits[j + 1].solution.states[0].tolist()
        elif isinstance(end, str):
            settings["next_state"] = standing_after(gait.problem.biped.swap,
                                                    gait.solution.states[-1])  # fmt: skip
        else:
            settings["next_state"] = end.segments()[0][0].states[0].tolist()
        if j == 0 and isinstance(start, str):
            settings["start"] = STANDING
        report = verify_gait(trajectory, gait.problem.linkage, settings=settings)
        report.raise_if_failed()
        reports.append(report)
    return tuple(reports)


def _problem(start, end, k: int, step_options: dict):
    """(Phases, the steps' problems, on feet or not) of the transition in ``k`` steps; bad
    input raises here, before any solve."""
    footed = isinstance(start, FootedGait) or isinstance(end, FootedGait)
    if footed:
        return (*footed_transition_problem(start, end, k), True)
    return (*transition_problem(start, end, k, **step_options), False)


def _solved(phases, problems, footed: bool, ipopt: dict, rate_hz: float, seconds=None):
    """(the solution, one gait per step) of a transition's problem, its limits held at
    ``rate_hz`` within ``seconds`` of wall time (None: no cap); raises
    :class:`planner.AnthropoidError` when IPOPT or a hold round fails or the time runs out."""
    solve_options = {"progress": False, "options": ipopt}
    pinned = FOOTED_PINNED if footed else PINNED
    solution = solve_and_hold(Transcription(phases), solve_options, True, rate_hz, pinned,
                              seconds)  # fmt: skip
    if not solution.success:
        raise AnthropoidError(f"IPOPT: {solution.status}")
    if footed:  # each step's three phases a solution of their own
        parts = step_parts(solution, problems)
        gaits = tuple(FootedGait(problem, part, math.nan)
                      for problem, part in zip(problems, parts, strict=True))  # fmt: skip
    else:
        gaits = tuple(WalkingGait(problem, part, math.nan)
                      for problem, part in zip(problems, solution.phases, strict=True))  # fmt: skip
    return solution, gaits


def plan_transition(
    start,
    end,
    *,
    steps: int | None = None,
    max_steps: int = MAX_STEPS,
    rate_hz: float = RATE_HZ,
    progress: Callable[[str], None] | None = None,
    options: dict | None = None,
    try_seconds: float | None = SEARCH_SECONDS,
    retry_iterations: int | None = RETRY_ITERATIONS,
    **step_options,
) -> Transition:
    """The transition from ``start`` to ``end`` (each a solved periodic :class:`WalkingGait`
    on point feet without a double support, or :data:`STANDING`; or both solved periodic
    steps on feet, :class:`problems.walking.footed.FootedGait` of one contact sequence: a
    speed change on feet, :mod:`problems.library.footed_transition`) in ``steps`` steps, or in
    the fewest of 1..``max_steps`` that solve and verify (``steps=None``); ``step_options``
    as for :func:`problems.walking_step` (limits, mesh; the same for every step and best the
    same as the gaits'; on feet none: the steps take the start gait's); ``options``: IPOPT's
    (a search's tries are capped at :data:`SEARCH_ITERATIONS` unless ``max_iter`` is given);
    ``try_seconds``: each count's wall time, s, its limits' hold rounds included (None: no
    cap; a try past it fails and the next count is tried). ``retry_iterations``: when a
    search's first pass solves no count, the counts that stopped on its iteration cap are
    tried again with this many IPOPT iterations, fewest steps first (None, or a number not
    above the first cap: no second pass; a forced ``steps`` count has none). Every step is
    verified at every exported sample at ``rate_hz``, its impact against the next step's
    first state.

    Raises :class:`planner.AnthropoidError` naming each count tried and why it failed when
    none does."""
    counts = [check_integer("steps", steps, 1)] if steps is not None else None
    if try_seconds is not None:
        try_seconds = check_positive("try_seconds", try_seconds, "s")
    if retry_iterations is not None:
        retry_iterations = check_integer("retry_iterations", retry_iterations, 1)
    if counts is None:
        counts = list(range(1, check_integer("max_steps", max_steps, 1) + 1))
    footed = isinstance(start, FootedGait) or isinstance(end, FootedGait)
    if footed and step_options:
        raise DefinitionError(
            f"`step_options` ({', '.join(sorted(step_options))}): on feet every step of a "
            "transition takes the options of the gait it starts from; plan the gaits with them"
        )
    ipopt = dict(options or {})
    if steps is None:
        ipopt.setdefault("max_iter", SEARCH_ITERATIONS)
    attempts: list[tuple[int, str]] = []

    def attempt(k: int, ipopt: dict, retry: int | None = None):
        """(the transition in ``k`` steps or None, whether its failure was IPOPT's iteration
        cap); each outcome goes into ``attempts`` (a second pass's begins with RETRIED)."""
        again = f"{RETRIED} {retry} iterations" if retry else ""
        which, prefix = f"{k} step(s) {again}".rstrip(), f"{again}: " if retry else ""
        phases, problems, footed = _problem(start, end, k, step_options)
        try:
            solution, gaits = _solved(phases, problems, footed, ipopt, rate_hz, try_seconds)
            reports = _verify_steps(gaits, start, end, rate_hz)
        except AnthropoidError as error:  # a failed solve, hold or verification
            why = str(error).splitlines()[0]
            attempts.append((k, prefix + why[:300]))
            if progress is not None:
                progress(f"{which}: failed ({why[:120]})")
            return None, _stopped_on_cap(error)
        attempts.append((k, prefix + "solved and verified"))
        if progress is not None:
            progress(f"{which}: solved and verified, {total_iterations(solution)} iterations")
        return Transition(start, end, gaits, solution, reports, tuple(attempts)), False

    capped = []
    for k in counts:
        transition, on_cap = attempt(k, ipopt)
        if transition is not None:
            return transition
        if on_cap:
            capped.append(k)
    if steps is None and retry_iterations is not None and retry_iterations > ipopt["max_iter"]:
        longer = {**ipopt, "max_iter": retry_iterations}
        for k in capped:
            transition, _ = attempt(k, longer, retry_iterations)
            if transition is not None:
                return transition
    v_a, v_b = end_speed(start), end_speed(end)
    tried = "; ".join(f"{k} step(s): {why}" for k, why in attempts)
    raise AnthropoidError(
        f"no transition from {v_a:g} to {v_b:g} m/s within the limits in {counts[0]}.."
        f"{counts[-1]} steps ({tried}); allow more steps (max_steps), larger torque limits, or "
        "a smaller speed change"
    )


def _stopped_on_cap(error: BaseException) -> bool:
    """Whether ``error`` (or an error it was raised from: a hold round's) is IPOPT stopping
    on its iteration cap."""
    while error is not None:
        if isinstance(error, SolverError) and error.status == _CAPPED:
            return True
        error = error.__cause__
    return False


__all__ = [
    "MAX_STEPS",
    "RETRIED",
    "RETRY_ITERATIONS",
    "STANDING",
    "Transition",
    "plan_transition",
    "standing_after",
    "transition_problem",
]
