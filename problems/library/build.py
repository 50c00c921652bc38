"""Building a gait library: one periodic step per speed, on point feet or on feet, planned,
verified at every exported sample, given its feedback (on point feet the periodic LQR and its
closed loop's Floquet multipliers; on feet the joint PD of
:class:`problems.control.feet_law.FeetLaw`, the law the step on feet walks with in MuJoCo,
and its largest multiplier's modulus alone, from how a push dies out in the product's
simulation on feet: :mod:`problems.control.feet_multiplier`; the rest NaN).

The speeds are solved in order from the middle of the grid outward; each step after the first
starts from its neighbour's solution (:meth:`planner.OCP.guess`: re-gridded in normalised time;
the same mesh, so IPOPT also starts from its multipliers), which takes about half the
iterations of a start from the gait law (22 against 43 over 0.4-1.8 m/s, the limits' hold
rounds included: examples/benchmarks/gait_library.py). A speed whose warm start fails is solved
again from the gait law; a step that still fails, or whose exported samples fail their
verification, stops the build with the speed named.
"""

from __future__ import annotations

import itertools
import time
import warnings
from collections.abc import Callable, Sequence

import numpy as np

from model.linkage import Linkage
from model.linkage_naming import root_contact
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import AnthropoidError, DefinitionError, check_positive
from problems.control.feedback import design_feedback, gains_from
from problems.control.feet_law import FeetLaw
from problems.control.feet_multiplier import dominant_multiplier
from problems.control.linearisation import fixed_point
from problems.library.library import GaitLibrary, LibraryGait
from problems.walking.footed import footed_step_at, step_at_speed
from problems.walking.step import walking_step

#: the rate of the stored samples, Hz (the torque files')
RATE_HZ = 1000.0
#: the estimate of |lambda_1| on feet (problems.control.feet_multiplier): a 6 N s push, 14
#: steps on an 8 kHz clock (about 17 s a gait; at 16 kHz, 3 N s and 24 steps the 1 m/s
#: step's agrees to 0.005: examples/benchmarks/feet_simulation.py table 7)
FEET_ESTIMATE = {"push": 6.0, "steps": 14, "rate_hz": 8000.0}
#: the closed loop's fixed point to this (max |P(x) - x|, rad and rad/s): its multipliers
#: agree to 1e-8 with the search run to 1e-10 (the 1 m/s step), one Newton step (0.26 s) fewer
FIXED_POINT_TOLERANCE = 1e-6


def _order(count: int) -> list[int]:
    """Indices from the middle outward: each one's neighbour toward the middle comes first."""
    middle = count // 2
    order = [middle]
    for offset in range(1, count):
        for k in (middle + offset, middle - offset):
            if 0 <= k < count:
                order.append(k)
    return order


def build_library(
    speeds: Sequence[float],
    linkage: Linkage | None = None,
    *,
    feet: bool = False,
    multipliers: bool = True,
    progress: Callable[[str], None] | None = None,
    compiled: bool | None = None,
    **step_options,
) -> GaitLibrary:
    """The library of periodic steps at ``speeds`` m/s (increasing; each step's length and
    time from :func:`problems.walking.footed.step_at_speed`) on point feet
    (:func:`problems.walking_step`; ``linkage`` default the six-link scene) or, with ``feet``,
    on feet (:func:`problems.footed_step`; default ``model.presets.anthropoid_with_feet``),
    ``step_options`` as for that function; ``multipliers``: compute each point-foot closed
    loop's Floquet multipliers (the return map's eigenvalues at its fixed point; none on
    feet); ``progress``: called with a line per gait; ``compiled``: the NLP's functions and
    the point-foot simulation's period Jacobians as native code (True: compiled into the disk
    cache first where it does not hold them, once per structure and linkage; None: what the
    cache holds; False: interpreted; :func:`planner.solve`, :class:`problems.control.
    simulation.Plant`)."""
    speeds = [check_positive(f"speeds[{k}]", v, "m/s") for k, v in enumerate(speeds)]
    if not speeds or any(b <= a for a, b in itertools.pairwise(speeds)):
        raise DefinitionError(f"`speeds`: one or more, strictly increasing, got {speeds}")
    if not isinstance(feet, bool):
        raise DefinitionError(f"`feet`: True (steps on feet) or False (point feet), got {feet!r}")
    gaits: dict[int, LibraryGait] = {}
    solved: dict[int, object] = {}
    for k in _order(len(speeds)):
        clock = time.perf_counter()
        step = _step(speeds[k], linkage, feet, step_options)
        neighbours = [j for j in (k - 1, k + 1) if j in solved]
        gait = None
        if neighbours:
            warm = solved[min(neighbours, key=lambda j: abs(speeds[j] - speeds[k]))]
            try:
                gait = step.solve(
                    step.problem.guess(warm.solution), progress=False, compiled=compiled
                )
            except AnthropoidError:  # a failed solve, hold or verification
                gait = None  # from the law, below
        if gait is None:
            try:
                # verified at every sample, or raises
                gait = step.solve(progress=False, compiled=compiled)
            except AnthropoidError as error:
                raise AnthropoidError(
                    f"the library's step at {speeds[k]:g} m/s: {error}"
                ) from error
        solved[k] = gait
        gaits[k] = (_feet_gait if feet else _library_gait)(gait, speeds[k], multipliers, compiled)
        if progress is not None:
            progress(f"{speeds[k]:.3f} m/s: {gaits[k].iterations} iterations, "
                     f"{time.perf_counter() - clock:.2f} s")  # fmt: skip
    first = solved[0]
    return GaitLibrary(
        tuple(gaits[k] for k in range(len(speeds))),
        first.problem.linkage,
        RATE_HZ,
        {"feet": "feet" if feet else "points",
         "step_at_speed": "length 0.5 sqrt(v / 1 m/s) m, time length / v",
         "options": {k: v for k, v in step_options.items() if isinstance(v, int | float | str)},
         "order": "from the middle outward, each warm-started from its neighbour"},
    )  # fmt: skip


def _step(speed: float, linkage: Linkage | None, feet: bool, options: dict):
    """The periodic step at ``speed`` m/s, on point feet or on feet."""
    if feet:
        return footed_step_at(speed, linkage=linkage, **options)
    length, duration = step_at_speed(speed)
    return walking_step(linkage, length, duration, **options)


def _feet_gait(gait, speed: float, multipliers: bool, compiled=None) -> LibraryGait:
    """One step on feet's samples, verification, contact phases and joint PD gains, and
    (``multipliers``) its closed loop's |lambda_1| first among NaN (see the module; NaN
    with a warning where the estimate cannot be made: the push falls or dies out at once)."""
    law = FeetLaw(gait, rate_hz=RATE_HZ)
    profile = law.channels(gait.exported(RATE_HZ))
    linked = LinkageTrajectory.of(profile)
    root = f"F_{root_contact(linked.link_names)}_"  # the stance foot's: from the motion
    contacts = [key for key in profile.extras if key.startswith("F_") and not key.startswith(root)]
    settings = dict(profile.metadata.get("gait", {}))
    settings["before_events"] = _before_events(
        gait, settings.get("before_events") or [], len(linked.link_names)
    )
    values = np.full(2 * len(linked.link_names), np.nan + 0j)
    if multipliers:
        values[0] = _feet_modulus(gait, law, speed)
    return _sampled_gait(
        gait, speed, profile, values, settings,
        segments=tuple(zip(gait.problem.sequence, gait.durations(), strict=True)),
        extras={key: np.asarray(profile.extras[key][0], dtype=float)
                for key in (*contacts, "double_support")},
    )  # fmt: skip


def _feet_modulus(gait, law: FeetLaw, speed: float) -> float:
    """|lambda_1| of the step on feet's closed loop (:data:`FEET_ESTIMATE`; a push that
    fells the walk halved once), or NaN with a warning naming why not."""
    push = FEET_ESTIMATE["push"]
    for attempt in (push, push / 2.0):
        try:
            return dominant_multiplier(gait, law=law, **{**FEET_ESTIMATE, "push": attempt}).modulus
        except DefinitionError as error:
            why = str(error)
            if "pushed walk fell" not in why:
                break
    warnings.warn(f"the gait at {speed:g} m/s: no |lambda_1| on feet: {why}", stacklevel=3)
    return float("nan")


def _sampled_gait(gait, speed, profile, multipliers, settings, **on_feet) -> LibraryGait:
    """The :class:`LibraryGait` of ``gait`` at ``speed`` m/s from ``profile`` (its samples at
    :data:`RATE_HZ` with the feedback's phase and gains, ``problems.control.feedback
    .with_gains``), its ``multipliers`` (2n,) and ``settings``; ``on_feet``: the segments
    and extras of a step on feet."""
    linked = LinkageTrajectory.of(profile)
    return LibraryGait(
        speed=float(speed),
        step_length=float(gait.problem.step_length),
        step_time=float(gait.problem.step_time),
        time=np.asarray(profile.time, dtype=float) - float(profile.time[0]),
        psi=np.asarray(linked.psi), dpsi=np.asarray(linked.dpsi),
        ddpsi=np.asarray(linked.ddpsi), torques=np.asarray(linked.torques),
        phase=np.asarray(profile.extras["phase"][0]),
        gains=gains_from(profile, linked.link_names), multipliers=multipliers,
        iterations=int(profile.metadata.get("iterations") or 0),
        settings=settings, law=_law(profile.metadata.get("feedback", {})), **on_feet,
    )  # fmt: skip


def _before_events(gait, events: list, n: int) -> list:
    """The exported state before each phase's end (``{"t", "x"}``) with the accelerations
    ``ddpsi`` and torques ``torques`` there too, from the phase's consistent motion at its
    end: what a blend needs to reach an impact's instant without extrapolating (the samples
    stop up to one sample period short of it)."""
    completed = []
    for event, (solution, _) in zip(events, gait.segments()[:-1], strict=True):
        _, xdot, controls = solution.motion(np.array([float(solution.T)]))
        completed.append({**event, "ddpsi": np.asarray(xdot)[0, n:].tolist(),
                          "torques": np.asarray(controls)[0, :n].tolist()})  # fmt: skip
    return completed


def _law(feedback: dict) -> dict:
    """The feedback's description as the library file keeps it: its words and numbers, not
    the per-sample tables the gains arrays already hold."""
    return {key: value for key, value in feedback.items() if key not in ("state", "gains")}


def _library_gait(gait, speed: float, multipliers: bool, compiled=None) -> LibraryGait:
    """One point-foot gait's samples, verification, periodic LQR gains and (with
    ``multipliers``) its closed loop's Floquet multipliers; ``compiled`` as for
    :func:`build_library`."""
    feedback = design_feedback(gait, compiled=compiled)
    profile = feedback.channels(gait.exported(RATE_HZ))
    values = np.full(2 * gait.problem.linkage.n, np.nan + 0j)
    if multipliers:
        step = feedback.step
        loop = fixed_point(feedback.plant, feedback.controller, feedback.reference.states[0],
                           step_time=step.step_time, step_length=step.step_length,
                           control_rate_hz=feedback.control_rate_hz,
                           tolerance=FIXED_POINT_TOLERANCE)  # fmt: skip
        values = np.asarray(loop.multipliers, dtype=complex)
    return _sampled_gait(gait, speed, profile, values, profile.metadata.get("gait", {}))


__all__ = ["RATE_HZ", "build_library"]
