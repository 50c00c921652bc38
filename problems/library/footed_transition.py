"""Speed changes on feet: from one periodic step on feet to another in k steps solved
together (:func:`footed_transition_problem`, planned and verified by
:func:`problems.library.transition.plan_transition`).

Step j of k is the gaits' own step on feet (:func:`problems.walking.footed.resized`: the
walker, its feet, the contact sequence, limits, objective, rotors and mesh of the gait it
starts from) at the ramp's speed v_j = v_a + (v_b - v_a) j / k, its phase durations free with
their own parameters (``T_flat_j``, ``T_heel_j``: static parameters are shared by name). Its
phases keep every row of the periodic step (the flat foot's centre of pressure, the heel
rise, the strike's impulses in their cones, the double support's held heel and unloading
rear foot, clearance, ranges, drives); only the periodicity goes:

* within a step the phases join as in the periodic step (the heel rises with the torques
  continuous; the strike's impact map into the double support);
* step j's toe-off joins step j + 1's first phase through the leg swap, x_{j+1}(0) =
  swap(x_j(T_j)), the join a periodic step makes with itself;
* the first step starts at gait a's x(0) (its state after a's own toe-off: the swap of a's
  last state), so a step of a ends and the transition begins there; the flat foot's
  ``foot flat`` row at that start is left out (a's state satisfies it and the fixed state
  would make it a dependent row);
* the last step ends at gait b's last state, before b's toe-off, so the next step of b starts
  at b's x(0) exactly.

From quiet standing (``start`` :data:`STANDING`): at t = 0 both
feet lie flat side by side (the planar picture: the swing foot's ball at the stance ball, both
soles flat) and the body is at rest (dpsi = 0, and ddpsi = 0 but for the welded stance foot's,
which its bound holds at 0 already: the standing torques hold the pose statically and the
plan's torques start from them). The pose itself is planned: the whole weight on the stance
foot at t = 0, its centre of pressure on the sole like every other instant (the swing foot
touches the ground unloaded and lifts, as the point-foot start's does). The first step walks
from there at the ramp's first speed (its ball lands one step length ahead of the stance
ball: the swing foot travels one step length, where a periodic step's travels two), under a
clearance floor that starts flat (:data:`problems.walking.step.LIFT_TIME`). Its first phase
must be the flat foot (the human cycle or the flat-footed one; a toe-walking step starts on
the ball and is refused).

To quiet standing (``end`` :data:`STANDING`): the last step is a stop
(:func:`problems.walking.footed.stopping`): one flat phase in which the swing foot swings
from behind, over a floor that ends flat, and sets down flat with its ball at the stance
ball while the body comes to rest (dpsi = 0, ddpsi = 0 but the welded stance foot's): the
start's standing pose, reached instead of left. No strike (the foot sets down at rest) and
no leg swap follow it; the steps before it are the gait's own at the ramp's speeds down to
the stop.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from planner.errors import DefinitionError, check_integer
from planner.problem import Phases
from problems.library.library import _guessed
from problems.library.ramp import speed_ramp
from problems.walking.footed import FootedGait, FootedStep, resized, standing_rows, stopping
from problems.walking.step import LIFT_TIME

#: the first phase's rows a fixed start makes dependent (the gait there satisfied them; a
#: standing start states the stance foot's angle in its own row, its rate fixed at rest)
START_ROWS = ("foot flat",)
#: quiet standing as a transition's end (:data:`problems.library.transition.STANDING`)
STANDING = "standing"


#: A stop's duration, a multiple of the ramp's step time there (the time of its first speed):
#: left free, its optimum ran to whatever bound it had (1.5 and 3 times tried, in scratch runs
#: before the stop's floor lost its approach term; holding the pose costs the drives little,
#: so slower is cheaper), so it is fixed at the first of those
STOP_TIME = 1.5


def _checked_gait(field: str, gait) -> FootedGait | str:
    """``gait`` when it is a solved periodic step on feet or quiet standing, else a refusal
    naming ``field``."""
    if isinstance(gait, str) and gait == STANDING:
        return gait
    if not isinstance(gait, FootedGait) or not isinstance(gait.problem, FootedStep):
        raise DefinitionError(
            f"`{field}`: a solved periodic step on feet (FootedGait of problems.footed_step)"
            f" or {STANDING!r}, got {type(gait).__name__}"
        )
    return gait


def _step_guess(step: FootedStep, nearest: FootedGait) -> Phases:
    """``step``'s phases guessed from the gait ``nearest`` phase by phase (its motion in each
    phase's normalised time, its phase durations scaled to the step's time)."""
    durations = np.array(nearest.durations()) * step.step_time / nearest.duration
    segments = nearest.segments()
    return _guessed(step.phases, lambda p: segments[p][0], durations)


def _checked_ends(start, end) -> tuple[FootedGait | str, FootedGait | str]:
    """``start`` and ``end`` when they make a transition on feet (gaits of one walker and one
    sequence, or quiet standing at one end whose gait begins with the flat foot), else a
    refusal naming the field."""
    start, end = _checked_gait("start", start), _checked_gait("end", end)
    if start == STANDING and end == STANDING:
        raise DefinitionError("`start`, `end`: a transition from standing to standing is no walk")
    for field, gait, other, what in (("end", end, start, "start from"),
                                     ("start", start, end, "stop at")):  # fmt: skip
        if other == STANDING and gait.problem.sequence[0] != "flat":
            raise DefinitionError(
                f"`{field}`: a {what} quiet standing has the stance foot flat; this gait's "
                f"steps begin with {gait.problem.sequence[0]!r} ({gait.problem.sequence_name}):"
                " plan the walk in the human or the flat-footed sequence"
            )
    if STANDING not in (start, end):
        if start.problem.sequence != end.problem.sequence:
            raise DefinitionError(
                f"`end`: its contact phases {end.problem.sequence} are not the start's "
                f"{start.problem.sequence}; a transition joins steps of one sequence"
            )
        if start.problem.linkage.names != end.problem.linkage.names:
            raise DefinitionError(
                "`end`: another walker than the start's; join gaits of one walker"
            )
    return start, end


def footed_transition_problem(start, end, steps: int) -> tuple[Phases, tuple[FootedStep, ...]]:
    """(Phases, the k FootedSteps) of a speed change on feet from the gait ``start`` (or
    quiet standing) to the gait ``end`` (or quiet standing) in ``steps`` steps (see the
    module); each step's phases are named ``"step <j> <phase>"``."""
    start, end = _checked_ends(start, end)
    k = check_integer("steps", steps, 1)
    starting, stopping_at = start == STANDING, end == STANDING
    gaits = tuple(g for g in (start, end) if g != STANDING)
    template = gaits[0].problem  # the steps are the (first) gait's own, resized
    n = template.linkage.n
    first_state = None if starting else start.segments()[0][0].states[0]
    last_state = None if stopping_at else end.segments()[-1][0].states[-1]
    entries, mappings, controls, problems = [], [], [], []
    ramp = speed_ramp(start, end, k)
    for j, (speed, length, duration) in enumerate(ramp):
        nearest = min(gaits, key=lambda g: abs(g.speed - speed))
        if stopping_at and j == k - 1:  # sets the swing foot down beside the stance foot
            step = stopping(template, STOP_TIME * duration, label=f"_{j + 1}")
            phases = _stop_guess(step, nearest)
        else:
            lifted = replace(template, lift_time=LIFT_TIME) if starting and j == 0 else template
            step = resized(lifted, length, duration, label=f"_{j + 1}")
            phases = _step_guess(step, nearest)
        last = len(phases.phases) - 1
        for p, (name, ocp) in enumerate(phases.phases):
            if j == 0 and p == 0:
                rows = tuple(c for c in ocp.constraints if c.name not in START_ROWS)
                ocp = replace(ocp, constraints=rows)
                if starting:
                    ocp = standing_rows(step, ocp, "start")
                else:
                    ocp = ocp.initial(psi=first_state[:n].tolist(),
                                      dpsi=first_state[n:].tolist())  # fmt: skip
            if j == k - 1 and p == last and not stopping_at:
                ocp = ocp.final(psi=last_state[:n].tolist(), dpsi=last_state[n:].tolist())
            entries.append((f"step {j + 1} {name}", ocp))
        mappings += list(phases.mappings)
        controls += list(phases.controls)
        if j < k - 1:  # toe-off: the legs swap into the next step
            mappings.append(step.biped.swap.state_function())
            controls.append("jump")
        problems.append(step)
    problem = Phases(tuple(entries), mappings=tuple(mappings), controls=tuple(controls))
    return problem, tuple(problems)


def _stop_guess(step: FootedStep, nearest: FootedGait) -> Phases:
    """A stop's one phase guessed from the gait ``nearest``'s flat phase (it starts where
    the stop does, after a toe-off) on an eased clock, blended into quiet standing: the
    stop's time t in [0, T] reads the flat phase at sigma = 1 - (1 - t / T)^2 of its duration
    (the gait's rates at 0, at rest at T), and the pose moves from it to the standing pose
    (the flat phase's last, the swing leg laid along the stance leg) by the smoothstep
    b = 6 tau^5 - 15 tau^4 + 10 tau^3 (b' = b'' = 0 at both ends): a guess that ends where
    the stop must, at rest, not at the flat phase's own end (the swing foot in the air at
    mid-swing, moving)."""
    flat = nearest.segments()[0][0]
    n = step.linkage.n
    names = step.linkage.names
    T_flat, T = float(flat.T), step.step_time
    standing = np.asarray(flat.states[-1][:n], dtype=float).copy()
    for stance, swing in zip(step.biped.stance_leg, reversed(step.biped.swing_leg), strict=True):
        # the swing chain runs hip -> foot: its links point the other way (psi - pi)
        standing[names.index(swing)] = standing[names.index(stance)] - np.pi
    standing[names.index(step.biped.stance_leg[0])] = step.flat_angles[0]
    standing[names.index(step.biped.swing_leg[-1])] = step.flat_angles[1]

    def pose(t):
        tau = np.clip(np.asarray(t, dtype=float) / T, 0.0, 1.0)
        x, _, _ = flat.motion((1.0 - (1.0 - tau) ** 2) * T_flat)
        blend = (tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2))[:, None]
        return (1.0 - blend) * x[:, :n] + blend * standing[None, :]

    def guess(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        delta = 1e-4 * T
        before, here, after = pose(t - delta), pose(t), pose(t + delta)
        return here, (after - before) / (2 * delta), (after - 2 * here + before) / delta**2

    return _guessed(step.phases, lambda p: guess, np.array([T]))


def step_parts(solution, problems: tuple[FootedStep, ...]) -> list:
    """Each step's phases of a solved transition as a solution of its own
    (``PhasesSolution.part``)."""
    parts = []
    for j, step in enumerate(problems):
        names = [f"step {j + 1} {name}" for name in step.sequence]
        parts.append(solution.part(names[0], names[-1]))
    return parts


__all__ = ["STANDING", "footed_transition_problem", "step_parts"]
