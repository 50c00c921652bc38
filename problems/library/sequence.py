"""A walker's day as one plan: quiet standing, walks at commanded speeds, the steps between
them, standing again; one file of every step, verified step by step from that file.

:func:`plan_sequence` takes the commanded speeds (e.g. 0, 1.0, 1.4, 0.6, 0 m/s: 0 is quiet
standing, allowed at the ends), plans the periodic point-foot gait of each speed
(:func:`problems.walking_step` at :func:`problems.walking.footed.step_at_speed`, each
warm-started from the one before), and between each pair the transition
(:func:`problems.library.transition.plan_transition`: as many steps as the limits need);
each speed's gait is walked ``steps_at_speed`` times between its transitions.

:meth:`WalkSequence.trajectory` is the whole walk at ``rate_hz`` on one time axis, in the
model's labels (the stance leg is always ``stance_*``: the legs swap at every heel strike),
with the channels ``step`` (its index from 0), ``phase`` (t / T within the step), ``speed``
(the step's own length / time, m/s: 0 for a step that ends at rest) and ``foothold_x`` (the
stance foot's world x, m). A step's last sample (just before its heel strike) shares its
instant with the next step's first (just after): the table keeps the one after, the one before
goes into the sidecar (``metadata["sequence"]["steps"][j]["before_impact"]``: x, ddpsi, M
and the ground force), with each step's settings, so :func:`verify_sequence` checks every step
from the file alone: the physics at every sample, and each heel strike against the next
step's first row (``join angles``, ``impact momentum``, ``foot at rest``: the states at
every boundary equal after the impact map). Before its first row and after its last the
walker stands: both rows are at rest and their torques hold it.

On feet (``plan_sequence(..., feet=True)``) each step is a step on feet
(:func:`problems.walking.footed.footed_step_at`, its changes those of
:mod:`problems.library.footed_transition`); a step ends at its toe-off, where the legs swap
without an impact (its heel strike lies inside it, its state before in its settings'
``before_events``). The file carries each step's own channels as well (the front foot's force
``F_swing_heel_x``/``_y``, the centre of pressure; the law's when it has one), the sidecar
each step's last sample with those channels (``before_impact["extras"]``) and its phases, and
:func:`verify_sequence` checks each step with the step on feet's verification, its toe-off
against the next step's first row (``join angles``, ``join rates``). A walk on feet may start
from quiet standing (both feet flat side by side at rest,
:mod:`problems.library.footed_transition`) and end at it (a stop: its last step one flat
phase that sets the swing foot down beside the stance foot, the body at rest; its rows carry
the front foot's force channels, zero, and its end is checked against standing).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from model.linkage import Linkage
from model.linkage_naming import acceleration_names, contact_force_names, root_contact
from model.linkage_trajectory import LinkageTrajectory
from model.rerooting import swap_legs
from planner.errors import DefinitionError, DefinitionTypeError, check_integer, check_real
from planner.trajectory import Trajectory
from problems.gait.problem import RATE_HZ
from problems.gait.verification import GaitReport, verify_gait
from problems.library.library import GaitLibrary
from problems.library.transition import (
    MAX_STEPS,
    RETRY_ITERATIONS,
    SEARCH_ITERATIONS,
    STANDING,
    Transition,
    plan_transition,
    standing_after,
)
from problems.walking.footed import footed_step_at, step_at_speed
from problems.walking.step import WalkingGait, WorldMotion, walking_step, world_motion

FORMAT = "anthropoid-planner walk sequence"
VERSION = 1
#: the kinds of steps a sequence holds
KINDS = ("start", "gait", "change", "stop")
#: periodic steps walked at each commanded speed between its transitions
STEPS_AT_SPEED = 8


def checked_speeds(speeds: Sequence[float]) -> tuple[float, ...]:
    """The commanded speeds, m/s: at least two, >= 0, 0 (standing) only first or last, no two
    neighbours equal."""
    try:
        values = tuple(check_real(f"speeds[{k}]", v) for k, v in enumerate(speeds))
    except TypeError as error:
        raise DefinitionError(f"`speeds`: a list of speeds in m/s, got {speeds!r}") from error
    if len(values) < 2:
        raise DefinitionError(f"`speeds`: two or more (e.g. 0,1.0,0), got {list(values)}")
    for k, v in enumerate(values):
        if v < 0 or (v == 0 and 0 < k < len(values) - 1):
            raise DefinitionError(
                f"`speeds[{k}]`: {v:g} m/s; speeds are >= 0, and 0 (standing) only first or "
                "last (to stop and start again, plan two sequences)"
            )
    for k, (a, b) in enumerate(itertools.pairwise(values)):
        if a == b:
            raise DefinitionError(
                f"`speeds[{k + 1}]`: {b:g} m/s repeats the speed before it; give each speed "
                "once (steps_at_speed sets how long it is walked)"
            )
    return values


@dataclass(frozen=True, eq=False)
class SequenceStep:
    """One step of a sequence: ``kind`` (:data:`KINDS`), the solved ``gait`` (its problem a
    WalkingStep: length, time, settings), ``start`` s on the sequence's clock, ``foothold``
    m (the stance foot's world x)."""

    kind: str
    gait: WalkingGait
    start: float
    foothold: float

    @property
    def speed(self) -> float:
        """The step's own length / time, m/s (0 for a step that ends at rest)."""
        problem = self.gait.problem
        return problem.step_length / problem.step_time


@dataclass(frozen=True, eq=False)
class WalkSequence:
    """A planned sequence (see the module): the commanded ``speeds``, each speed's periodic
    ``gaits`` ({speed: WalkingGait}), the ``transitions`` between them, and every step in
    order (``steps``)."""

    speeds: tuple[float, ...]
    gaits: dict[float, WalkingGait]
    transitions: tuple[Transition, ...]
    steps: tuple[SequenceStep, ...]

    @property
    def linkage(self) -> Linkage:
        return self.steps[0].gait.problem.linkage

    @property
    def duration(self) -> float:
        last = self.steps[-1]
        return last.start + last.gait.duration

    @cached_property
    def _trajectory(self) -> LinkageTrajectory:
        return _stitched(self, RATE_HZ)

    def trajectory(self, rate_hz: float = RATE_HZ, channels=None) -> LinkageTrajectory:
        """The whole walk at ``rate_hz`` (see the module for its channels and sidecar);
        ``channels``: None, or a callable (j, step j's exported samples) -> those samples with
        its law's channels (``phase``, gains, ...), which the file then carries (its
        ``phase`` the law's index in place of t / T)."""
        if rate_hz == RATE_HZ and channels is None:
            return self._trajectory
        return _stitched(self, rate_hz, channels)

    def world(self, rate_hz: float = 100.0) -> WorldMotion:
        """The walk in world coordinates (:func:`problems.walking.step.world_motion`)."""
        return sequence_world(self.trajectory(rate_hz), self.steps[0].gait.problem)

    def verify(self) -> SequenceReport:
        """:func:`verify_sequence` of :meth:`trajectory` (what the file holds)."""
        return verify_sequence(self.trajectory(), self.linkage)


def _step_settings(exported: Trajectory) -> dict[str, Any]:
    """The settings a verification reads of a step's exported samples (its metadata's
    ``gait``: the problem's settings and, on feet, the states before its events; the law, a
    guess, left out)."""
    settings = dict(exported.metadata.get("gait") or {})
    settings.pop("law", None)
    return settings


def _step_channels(exported: LinkageTrajectory) -> dict[str, str]:
    """{name: unit} of the step's extras beyond its accelerations and root ground reaction:
    on feet the front foot's force and the root's centre of pressure, and the law's channels
    when a step carries them."""
    standard = set(acceleration_names(exported.link_names))
    standard |= set(contact_force_names(root_contact(exported.link_names)))
    return {name: unit for name, (_, unit) in exported.extras.items() if name not in standard}


def _stitched(sequence: WalkSequence, rate_hz: float, channels=None) -> LinkageTrajectory:
    """One trajectory of every step (each step's samples but its last, the last step's all).
    ``channels``: None, or a callable (j, step j's exported samples) -> those samples with
    the law's channels (``phase``, gains), which the file then carries in place of t / T."""
    names = sequence.linkage.names
    keys = ("t", "psi", "dpsi", "ddpsi", "M", "F", "step", "phase", "speed", "foothold")
    columns: dict[str, list] = {key: [] for key in keys}
    own_columns: dict[str, list] = {}
    units: dict[str, str] | None = None
    described = []
    last = len(sequence.steps) - 1
    for j, step in enumerate(sequence.steps):
        exported = LinkageTrajectory.of(step.gait.exported(rate_hz))
        if channels is not None:
            exported = LinkageTrajectory.of(channels(j, exported))
        own = _step_channels(exported)
        if units is None:
            units = own
        elif own != units:
            raise DefinitionError(
                f"`sequence`: step {j}'s channels {sorted(own)} are not step 0's "
                f"{sorted(units)}; a sequence's steps are of one kind"
            )
        keep = slice(None) if j == last else slice(0, -1)
        local = np.asarray(exported.time, dtype=float)
        count = local[keep].size
        columns["t"].append(step.start + local[keep])
        for key, values in (("psi", exported.psi), ("dpsi", exported.dpsi),
                            ("ddpsi", exported.ddpsi), ("M", exported.torques),
                            ("F", exported.ground_reaction)):  # fmt: skip
            columns[key].append(np.asarray(values)[keep])
        for name in own:
            own_columns.setdefault(name, []).append(np.asarray(exported.extras[name][0])[keep])
        columns["step"].append(np.full(count, float(j)))
        columns["phase"].append(local[keep] / local[-1])
        columns["speed"].append(np.full(count, step.speed))
        columns["foothold"].append(np.full(count, step.foothold))
        problem = step.gait.problem
        described.append({
            "index": j, "kind": step.kind, "start_s": step.start, "foothold_m": step.foothold,
            "step_length_m": problem.step_length, "step_time_s": problem.step_time,
            "speed_m_s": step.speed, "before_impact": _last_sample(exported, step.start, own),
            "settings": _step_settings(exported),
        })  # fmt: skip
        if exported.metadata.get("phases"):  # a step of several phases: where each lies
            described[-1]["phases"] = exported.metadata["phases"]
    stacked = {key: np.concatenate(parts) for key, parts in columns.items()}
    first = sequence.steps[0].gait
    metadata = {
        "sequence": {
            "format": FORMAT, "version": VERSION, "commanded_speeds_m_s": list(sequence.speeds),
            "rate_hz": rate_hz, "steps": described,
            "transitions": [_transition_summary(t, rate_hz) for t in sequence.transitions],
            "labels": "the model's: the legs swap at every step (stance_* is the stance leg "
                      "of the row's step); a step's last sample, at the instant of the next "
                      "step's first row, is its before_impact (before the heel strike on "
                      "point feet, before the leg swap at toe-off on feet)",
            "standing": "before the first row and after the last the walker stands at rest, "
                        "holding those rows' torques" if sequence.speeds[0] == 0
                        or sequence.speeds[-1] == 0 else "the walk starts and ends walking",
        },
        "gait": {**_step_settings(first.exported(rate_hz)), "problem": "walk_sequence"},
        # the walker the file is of, as every planned file states it (Linkage.from_parameters)
        "model": first.problem.linkage.parameters(),
    }  # fmt: skip
    trajectory = LinkageTrajectory.from_linkage(
        stacked["t"], stacked["psi"], stacked["dpsi"], stacked["M"], names,
        ddpsi=stacked["ddpsi"], ground_reaction=stacked["F"], metadata=metadata,
    )  # fmt: skip
    for key, unit in (("step", "1"), ("phase", "1"), ("speed", "m/s"), ("foothold", "m")):
        name = "foothold_x" if key == "foothold" else key
        trajectory = trajectory.with_extra(name, stacked[key], unit)
    for name, unit in (units or {}).items():  # the steps' own channels (the law's phase too)
        trajectory = trajectory.with_extra(name, np.concatenate(own_columns[name]), unit)
    return trajectory


def _last_sample(exported: LinkageTrajectory, start: float, own) -> dict[str, Any]:
    """A step's last sample as the sidecar keeps it (``before_impact``): t on the walk's
    clock, x, ddpsi, M, F (the root's ground force) and, when the step has channels of its
    own, their values (``extras``)."""
    force = complex(np.asarray(exported.ground_reaction)[-1])
    before = {
        "t": start + float(exported.time[-1]),
        "x": [float(v) for v in (*np.asarray(exported.psi)[-1], *np.asarray(exported.dpsi)[-1])],
        "ddpsi": np.asarray(exported.ddpsi)[-1].tolist(),
        "M": np.asarray(exported.torques)[-1].tolist(),
        "F": [force.real, force.imag],
    }
    if own:
        before["extras"] = {name: float(exported.extras[name][0][-1]) for name in own}
    return before


def _transition_summary(transition: Transition, rate_hz: float) -> dict[str, Any]:
    return {
        "from_m_s": transition.speeds[0], "to_m_s": transition.speeds[1],
        "steps": transition.steps, "iterations": transition.iterations,
        "peak_torques_N_m": transition.peak_torques(rate_hz),
        "attempts": [{"steps": k, "outcome": why} for k, why in transition.attempts],
    }  # fmt: skip


def _gaits(speeds, linkage, library, say, step_options, feet) -> dict[float, Any]:
    """Each commanded speed's periodic gait: solved from its neighbour's solution, or from
    the library's blend; on feet :func:`problems.walking.footed.footed_step_at`."""
    gaits: dict[float, Any] = {}
    previous = None
    for v in sorted({v for v in speeds if v > 0}):
        length, duration = step_at_speed(v)
        if library is not None:
            gaits[v] = library.solve_at(v, **step_options)
            say(f"gait at {v:g} m/s from the library: {length:.3f} m in {duration:.3f} s, "
                "verified")  # fmt: skip
            continue
        if feet:
            step = footed_step_at(v, **step_options)
            problem = step.phases if previous is None else step.phases.guess(previous.solution)
            gaits[v] = previous = step.solve(problem)
        else:
            step = walking_step(linkage, length, duration, **step_options)
            ocp = step.ocp if previous is None else step.ocp.guess(previous.solution)
            gaits[v] = previous = step.solve(ocp, progress=False)
        say(f"gait at {v:g} m/s{' on feet' if feet else ''}: {length:.3f} m in "
            f"{duration:.3f} s, verified")  # fmt: skip
    return gaits


def _checked_feet(speeds, linkage, library, step_options) -> dict[str, Any]:
    """The options of a walk on feet (``footed_step_at``'s, the walker's too; a library's
    own), what it cannot do refused by name."""
    if library is None:
        return step_options if linkage is None else {**step_options, "linkage": linkage}
    if not library.feet:
        raise DefinitionError(
            "`library`: its gaits walk on point feet; a walk on feet (feet=True) needs a "
            "library on feet (build_library(..., feet=True))"
        )
    if linkage is not None and linkage is not library.linkage:
        raise DefinitionError(
            "`linkage`: a walk from a library walks the library's walker; give one of linkage "
            "and library"
        )
    return {**library.settings.get("options", {}), **step_options}


def plan_sequence(
    speeds: Sequence[float],
    linkage: Linkage | None = None,
    *,
    steps_at_speed: int = STEPS_AT_SPEED,
    max_steps: int = MAX_STEPS,
    library=None,
    feet: bool = False,
    transition_iterations: int = SEARCH_ITERATIONS,
    retry_iterations: int | None = RETRY_ITERATIONS,
    transition_steps: Sequence[int | None] | None = None,
    progress: Callable[[str], None] | None = None,
    **step_options,
) -> WalkSequence:
    """The walk through ``speeds`` m/s (see the module): each speed's periodic gait walked
    ``steps_at_speed`` times (>= 1), transitions of up to ``max_steps`` steps between them;
    ``step_options`` as for :func:`problems.walking_step` (limits, mesh, ...), the same for
    every step. ``library``: a :class:`problems.library.GaitLibrary` whose walker and build
    options the walk takes, each speed's gait solved from the library's blend there
    (:meth:`GaitLibrary.solve_at`: a grid speed's own gait, or the step between two of them
    solved exactly); the speeds must lie within its grid. ``feet``: every step on feet
    (:func:`problems.walking.footed.footed_step_at`, ``step_options`` its options, e.g.
    ``speed_limit``; the transitions :mod:`problems.library.footed_transition`), from 0 (quiet
    standing) first or a speed, ending at a speed. ``transition_iterations``: IPOPT's
    iterations for each count a transition tries;
    ``retry_iterations``: a second pass's, for the counts that stopped on the first cap when
    none solved (:func:`plan_transition`; None: no second pass; on feet slowing from 1.4 m/s
    needs it: 1.4 -> 1.2 m/s failed 1-3 steps at 300 and solved in 1 at 1000).
    ``transition_steps``: one count per transition, in order (None or 0: searched as above),
    a count given solved in that many steps only, in one try at the larger of the two caps
    (its wall time capped as a search's try): a walk whose counts an earlier run found
    planned again without the failed tries (on feet the start from standing alone spent 35
    minutes in them). Every step is
    verified at every exported sample (the transitions' as they are planned, the whole walk
    again by :meth:`WalkSequence.verify`)."""
    speeds = checked_speeds(speeds)
    repeats = check_integer("steps_at_speed", steps_at_speed, 1)
    iterations = check_integer("transition_iterations", transition_iterations, 1)
    forced = checked_transition_counts(transition_steps, len(speeds) - 1)
    say = progress or (lambda _: None)
    if library is not None and not isinstance(library, GaitLibrary):
        raise DefinitionTypeError(
            f"`library`: a problems.library.GaitLibrary (build_library, or GaitLibrary.load of "
            f"its file), got {type(library).__name__}"
        )
    if library is not None and library.feet and not feet:
        raise DefinitionError(
            "`library`: its gaits walk on feet; plan the walk on feet (feet=True), or give a "
            "point-foot library (build_library(..., feet=False))"
        )
    if feet:
        step_options, linkage = _checked_feet(speeds, linkage, library, step_options), None
    elif library is not None:
        if linkage is not None and linkage is not library.linkage:
            raise DefinitionError(
                "`linkage`: a walk from a library walks the library's walker; give one of "
                "linkage and library"
            )
        linkage = library.linkage
        step_options = {**library.settings.get("options", {}), **step_options}
    gaits = _gaits(speeds, linkage, library, say, step_options, feet)
    ends = [STANDING if v == 0 else gaits[v] for v in speeds]
    transitions = []
    # on feet a transition's steps are the start gait's own, resized: no options of their own
    transition_options = {} if feet else step_options
    for a, b in itertools.pairwise(ends):
        label = f"{speeds[len(transitions)]:g} -> {speeds[len(transitions) + 1]:g} m/s"
        count = forced[len(transitions)]
        # a count given has one try: at the second pass's cap when that is the larger
        cap = iterations if count is None else max(iterations, retry_iterations or 0)
        transition = plan_transition(
            a, b, steps=count, max_steps=max_steps, options={"max_iter": cap},
            retry_iterations=retry_iterations if count is None else None,
            progress=lambda line, label=label: say(f"{label}: {line}"), **transition_options,
        )  # fmt: skip
        transitions.append(transition)
    pieces: list[tuple[str, Any]] = []
    for k, transition in enumerate(transitions):
        if k == 0 and speeds[0] > 0:
            pieces += [("gait", gaits[speeds[0]])] * repeats
        kind = "start" if speeds[k] == 0 else "stop" if speeds[k + 1] == 0 else "change"
        pieces += [(kind, gait) for gait in transition.gaits]
        if speeds[k + 1] > 0:
            pieces += [("gait", gaits[speeds[k + 1]])] * repeats
    steps, clock, foothold = [], 0.0, 0.0
    for kind, gait in pieces:
        steps.append(SequenceStep(kind, gait, clock, foothold))
        clock += gait.duration
        foothold += gait.problem.step_length
    return WalkSequence(speeds, gaits, tuple(transitions), tuple(steps))


def checked_transition_counts(counts, transitions: int) -> tuple[int | None, ...]:
    """``transition_steps`` checked: one entry per transition, each None or 0 (searched) or
    a count of steps >= 1."""
    if counts is None:
        return (None,) * transitions
    counts = tuple(counts)
    if len(counts) != transitions:
        raise DefinitionError(
            f"`transition_steps`: one count per transition, {transitions} for these speeds, "
            f"got {len(counts)} ({list(counts)!r}); give 0 (or None) where the count is searched"
        )
    checked = []
    for k, count in enumerate(counts):
        if count is None or (isinstance(count, int | np.integer) and count == 0):
            checked.append(None)
            continue
        checked.append(check_integer(f"transition_steps[{k}]", count, 1))
    return tuple(checked)


@dataclass(frozen=True)
class SequenceReport:
    """Each step's :class:`GaitReport` (``reports``, in order) and the steps' kinds."""

    reports: tuple[GaitReport, ...]
    kinds: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return all(report.ok for report in self.reports)

    def worst(self, name: str) -> float:
        """The worst margin of check ``name`` over every step that has it."""
        margins = [c.margin for r in self.reports for c in r.checks if c.name == name]
        return min(margins) if margins else math.nan

    def __str__(self) -> str:
        failed = [j for j, r in enumerate(self.reports) if not r.ok]
        head = (f"{len(self.reports)} steps verified: all checks passed" if not failed else
                f"{len(failed)} of {len(self.reports)} steps failed: {failed}")  # fmt: skip
        lines = [head]
        for name in ("dynamics", "join angles", "join rates", "impact momentum", "foot at rest"):
            if not math.isnan(self.worst(name)):  # the checks this walk's steps have
                lines.append(f"  worst {name}: {self.worst(name):+.3e}")
        for j in failed:
            lines.append(f"step {j} ({self.kinds[j]}):\n{self.reports[j]}")
        return "\n".join(lines)


def _step_rows(trajectory: LinkageTrajectory, described: dict, j: int):
    """Step j's samples from the whole walk's rows and its last sample (``before_impact``),
    with its own channels (on feet the front foot's force) and its phases' metadata."""
    step = np.asarray(trajectory.extras["step"][0])
    rows = np.flatnonzero(step == j)
    n = len(trajectory.link_names)
    before = described["before_impact"]
    x = np.asarray(before["x"], dtype=float)
    time = np.asarray(trajectory.time)[rows] - described["start_s"]
    # the step's own channels the rows still carry (a derived one a user dropped, such as a
    # centre of pressure, is not needed: a missing force fails the dynamics by name)
    own = {k: v for k, v in (before.get("extras") or {}).items() if k in trajectory.extras}
    values = [np.asarray(trajectory.psi)[rows], np.asarray(trajectory.dpsi)[rows],
              np.asarray(trajectory.ddpsi)[rows], np.asarray(trajectory.torques)[rows],
              np.asarray(trajectory.ground_reaction)[rows],
              *(np.asarray(trajectory.extras[name][0])[rows] for name in own)]  # fmt: skip
    if time.size and abs(time[-1] - (before["t"] - described["start_s"])) < 1e-12:
        # the last step keeps its final sample in the table
        time, values = time[:-1], [a[:-1] for a in values]
    psi, dpsi, ddpsi, torques, force, *channels = values
    piece = LinkageTrajectory.from_linkage(
        np.append(time, before["t"] - described["start_s"]),
        np.vstack([psi, x[:n]]), np.vstack([dpsi, x[n:]]),
        np.vstack([torques, before["M"]]), trajectory.link_names,
        ddpsi=np.vstack([ddpsi, before["ddpsi"]]),
        ground_reaction=np.append(force, complex(*before["F"])),
        metadata={"gait": described["settings"], "phases": described.get("phases")},
    )  # fmt: skip
    for (name, last), column in zip(own.items(), channels, strict=True):
        piece = piece.with_extra(name, np.append(column, last), trajectory.extras[name][1])
    return LinkageTrajectory.of(piece)


def sequence_steps(trajectory: Trajectory) -> list[tuple[dict[str, Any], LinkageTrajectory]]:
    """Each step of a walk sequence's samples (``WalkSequence.trajectory`` or its file read
    back) as (its entry of ``metadata["sequence"]["steps"]``: kind, start, settings, law,
    ...; its samples on its own clock, from 0, with the sample before its heel strike last,
    ``metadata["gait"]`` its settings). Step j's samples but the last are the file's rows
    with ``step`` = j; the last step's are all of them."""
    trajectory = _checked_sequence(trajectory)
    described = trajectory.metadata["sequence"]["steps"]
    return [(entry, _step_rows(trajectory, entry, j)) for j, entry in enumerate(described)]


def _checked_sequence(trajectory: Trajectory) -> LinkageTrajectory:
    trajectory = LinkageTrajectory.of(trajectory)
    meta = trajectory.metadata.get("sequence")
    if not meta or meta.get("format") != FORMAT or "step" not in trajectory.extras:
        raise DefinitionError(
            "`trajectory`: not a walk sequence (its metadata has no 'sequence' of format "
            f"{FORMAT!r}, or it has no 'step' channel); plan one with plan_sequence"
        )
    return trajectory


def verify_sequence(trajectory: Trajectory, linkage: Linkage, **options) -> SequenceReport:
    """Every step of a walk sequence checked from its samples (``WalkSequence.trajectory``
    or the file it was saved to, read back): :func:`problems.verify_gait` of each step (its
    rows and its pre-impact sample from the sidecar), its heel strike against the next
    step's first row; the last step's against its own end at rest when the walk ends
    standing; the first step's start at rest when it starts standing. ``options`` go to
    :func:`problems.verify_gait` (``tolerance``, ...)."""
    trajectory = _checked_sequence(trajectory)
    meta = trajectory.metadata["sequence"]
    steps = meta["steps"]
    first_rows = {}
    step_column = np.asarray(trajectory.extras["step"][0])
    x_all = np.hstack([np.asarray(trajectory.psi), np.asarray(trajectory.dpsi)])
    for j in range(len(steps)):
        rows = np.flatnonzero(step_column == j)
        if rows.size == 0:
            raise DefinitionError(f"`trajectory`: step {j} has no rows")
        first_rows[j] = x_all[rows[0]]
    speeds = meta["commanded_speeds_m_s"]
    swap = swap_legs(linkage)
    reports = []
    for j, described in enumerate(steps):
        settings: dict[str, Any] = {}
        if j + 1 < len(steps):
            settings["next_state"] = first_rows[j + 1].tolist()
        elif speeds[-1] == 0:
            settings["next_state"] = standing_after(swap, described["before_impact"]["x"])
        if j == 0 and speeds[0] == 0:
            settings["start"] = STANDING
        piece = _step_rows(trajectory, described, j)
        reports.append(verify_gait(piece, linkage, settings=settings, **options))
    return SequenceReport(tuple(reports), tuple(s["kind"] for s in steps))


def sequence_world(trajectory: Trajectory, problem) -> WorldMotion:
    """A walk sequence's trajectory in world coordinates (``problem``: a WalkingStep of the
    walker, for its biped and dynamics)."""
    trajectory = LinkageTrajectory.of(trajectory)
    step = np.asarray(trajectory.extras["step"][0]).astype(int)
    footholds_x = np.asarray(trajectory.extras["foothold_x"][0])
    count = int(step.max()) + 1
    footholds = np.zeros(count + 1, dtype=complex)
    for j in range(count):
        footholds[j] = footholds_x[np.flatnonzero(step == j)[0]]
    meta = trajectory.metadata.get("sequence", {}).get("steps")
    footholds[count] = footholds[count - 1] + (meta[-1]["step_length_m"] if meta else 0.0)
    states = np.hstack([np.asarray(trajectory.psi), np.asarray(trajectory.dpsi)])
    return world_motion(problem.biped, problem.dynamics, np.asarray(trajectory.time), states,
                        step, footholds, problem.corners)  # fmt: skip


__all__ = [
    "KINDS",
    "STEPS_AT_SPEED",
    "SequenceReport",
    "SequenceStep",
    "WalkSequence",
    "checked_speeds",
    "checked_transition_counts",
    "plan_sequence",
    "sequence_steps",
    "sequence_world",
    "verify_sequence",
]
