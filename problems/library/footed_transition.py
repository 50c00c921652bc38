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
clearance floor that starts flat (:data:`LIFT_TIME`). Its first phase must be the flat foot
(the human cycle or the flat-footed one; a toe-walking step starts on the ball and is
refused).

Not on feet yet: stopping at quiet standing (both feet flat at rest at the end is a double
support of its own, not a phase this step has).
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, check_integer
from planner.problem import Phases
from problems.gait.problem import rate_scales
from problems.library.library import _guessed
from problems.library.ramp import speed_ramp
from problems.walking.footed import FootedGait, FootedStep, resized

#: the first phase's rows a fixed start makes dependent (the gait there satisfied them; a
#: standing start states the stance foot's angle in its own row, its rate fixed at rest)
START_ROWS = ("foot flat",)
#: quiet standing as a transition's end (:data:`problems.library.transition.STANDING`)
STANDING = "standing"
#: s: the first step of a start from standing lifts its swing foot from rest under a floor
#: that starts flat over this time (:attr:`problems.walking.footed.FootedStep.lift_time`):
#: under the periodic step's floor, which curves up at once, the foot jerked off the ground
#: in the first 10 ms (the swing knee -80.6 N m at 3 ms, the ground's torque on the stance
#: foot -159 N m; measured at 0 -> 1 m/s)
LIFT_TIME = 0.05


def _checked_gait(field: str, gait, standing: bool = False) -> FootedGait | str:
    """``gait`` when it is a solved periodic step on feet (or, with ``standing``, quiet
    standing), else a refusal naming ``field``."""
    if standing and gait == STANDING:
        return gait
    if isinstance(gait, str) and gait == STANDING:
        raise DefinitionError(
            f"`{field}`: stopping at quiet standing on feet is not planned yet (both feet flat "
            "at rest at the end is a double support the step on feet does not have); end the "
            "walk at a speed"
        )
    if not isinstance(gait, FootedGait) or not isinstance(gait.problem, FootedStep):
        raise DefinitionError(
            f"`{field}`: a solved periodic step on feet (FootedGait of problems.footed_step)"
            f"{f' or {STANDING!r}' if standing else ''}, got {type(gait).__name__}"
        )
    return gait


def _standing_start(step: FootedStep, ocp):
    """The first phase of ``step`` (its flat foot) starting from quiet standing (see the
    module): ``standing feet`` (the swing ball at the stance ball, m), ``standing flat`` (both
    soles flat, rad), at rest (dpsi = 0; ``at rest``: ddpsi = 0 but the welded root's)."""
    n = step.linkage.n
    root, foot = step.biped.stance_leg[0], step.biped.swing_leg[-1]
    flat_stance, flat_swing = step.flat_angles
    swing_toe = step.point("swing_toe").function("position")
    stance_toe = step.point("stance_toe").function("position")

    def feet(p):
        return ca.vertcat(*swing_toe(p.x[:n])) - ca.vertcat(*stance_toe(p.x[:n]))

    moving = [i for i in range(n) if step.linkage.names[i] != root]
    scale = rate_scales(step.time_unit)["ddpsi"]  # the accelerations' nominal size
    return (
        ocp.boundary("standing feet", feet, at="start", lower=[0.0, 0.0], upper=[0.0, 0.0],
                     scale=step.leg_length)
        .boundary("standing flat", lambda p: ca.vertcat(p[f"psi_{root}"] - flat_stance,
                                                        p[f"psi_{foot}"] - flat_swing),
                  at="start", lower=[0.0, 0.0], upper=[0.0, 0.0])
        .initial(dpsi=[0.0] * n)
        .boundary("at rest", lambda p: p.ddpsi[moving], at="start", lower=0.0, upper=0.0,
                  scale=scale)
    )  # fmt: skip


def _step_guess(step: FootedStep, nearest: FootedGait) -> Phases:
    """``step``'s phases guessed from the gait ``nearest`` phase by phase (its motion in each
    phase's normalised time, its phase durations scaled to the step's time)."""
    durations = np.array(nearest.durations()) * step.step_time / nearest.duration
    segments = nearest.segments()
    return _guessed(step.phases, lambda p: segments[p][0], durations)


def footed_transition_problem(start, end, steps: int) -> tuple[Phases, tuple[FootedStep, ...]]:
    """(Phases, the k FootedSteps) of a speed change on feet from the gait ``start`` to the
    gait ``end`` in ``steps`` steps (see the module); each step's phases are named
    ``"step <j> <phase>"``."""
    start = _checked_gait("start", start, standing=True)
    end = _checked_gait("end", end)
    standing = start == STANDING
    if standing and end.problem.sequence[0] != "flat":
        raise DefinitionError(
            f"`end`: a start from quiet standing begins with the stance foot flat; this gait's "
            f"steps begin with {end.problem.sequence[0]!r} ({end.problem.sequence_name}): plan "
            "the walk in the human or the flat-footed sequence"
        )
    if not standing and start.problem.sequence != end.problem.sequence:
        raise DefinitionError(
            f"`end`: its contact phases {end.problem.sequence} are not the start's "
            f"{start.problem.sequence}; a transition joins steps of one sequence"
        )
    if not standing and start.problem.linkage.names != end.problem.linkage.names:
        raise DefinitionError("`end`: another walker than the start's; join gaits of one walker")
    k = check_integer("steps", steps, 1)
    template = end.problem if standing else start.problem
    n = template.linkage.n
    first_state = None if standing else start.segments()[0][0].states[0]
    last_state = end.segments()[-1][0].states[-1]
    entries, mappings, controls, problems = [], [], [], []
    ramp = speed_ramp(start, end, k)
    gaits = (end,) if standing else (start, end)
    for j, (speed, length, duration) in enumerate(ramp):
        lifted = replace(template, lift_time=LIFT_TIME) if standing and j == 0 else template
        step = resized(lifted, length, duration, label=f"_{j + 1}")
        nearest = min(gaits, key=lambda g: abs(g.speed - speed))
        phases = _step_guess(step, nearest)
        last = len(phases.phases) - 1
        for p, (name, ocp) in enumerate(phases.phases):
            if j == 0 and p == 0:
                rows = tuple(c for c in ocp.constraints if c.name not in START_ROWS)
                ocp = replace(ocp, constraints=rows)
                if standing:
                    ocp = _standing_start(step, ocp)
                else:
                    ocp = ocp.initial(psi=first_state[:n].tolist(),
                                      dpsi=first_state[n:].tolist())  # fmt: skip
            if j == k - 1 and p == last:
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


def step_parts(solution, problems: tuple[FootedStep, ...]) -> list:
    """Each step's phases of a solved transition as a solution of its own
    (``PhasesSolution.part``)."""
    parts = []
    for j, step in enumerate(problems):
        names = [f"step {j + 1} {name}" for name in step.sequence]
        parts.append(solution.part(names[0], names[-1]))
    return parts


__all__ = ["STANDING", "footed_transition_problem", "step_parts"]
