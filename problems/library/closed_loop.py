"""A walk sequence in closed loop: a finite-horizon LQR along every step of the walk, and the
walk simulated through its starts, speed changes and stop in the product's hybrid simulation.

The gains. Each step's plan is linearised at the control instants (the digital plant's RK4
period Jacobians A_k, B_k, :func:`problems.control.lqr.linearise_along`) and through its heel
strike (the saltation matrix S_j of the impact and leg swap into the next step's labels). One
backward Riccati pass runs over the whole walk (:func:`problems.control.lqr.riccati_sweep`,
Bryson's weights :class:`problems.control.lqr.LqrWeights`), from the cost-to-go of what
follows its last step: quiet standing's (the infinite-horizon LQR of the final pose at rest,
the periodic recursion of one period at that pose), or, for a walk that ends walking, the last
gait's periodic LQR. The steps of a transition thus get gains that know the gait they lead
into; the repeated periodic steps far from a transition get the periodic gains.

The law, per step j, indexed by tau: the step's phase s (the hip's progress over the stance
foot, as the periodic step's controller uses) where its plan's hip always advances, else the
time t since the step began (a start shifts the weight back first, a stop may too: a phase
would not increase there). A step begins at the swing foot's touchdown, so an early or late
strike starts the next step's law where it happens:

    M = clip(M_ff,j(tau) + alpha K_j(tau) (x_ref,j(tau) - x), -limit, limit),

held at its last sample past the step's planned end. alpha in [0, 1] is the largest that
keeps the stance foot's ground force, as the plan's model predicts it, loaded and in the
friction cone (:func:`contact_limited`; 1 when the feedback does not endanger the contact;
``contact_aware=False``: always 1). Measured on the walk 0 -> 1.0 -> 1.4 -> 0.6 -> 0 m/s:
without it a 10 N s push backwards in the speed-up fells the walker in both simulations (the
correction pulls the stance foot off the ground); with it both walk on
(examples/benchmarks/walk_sequence.py).

The simulation (:func:`simulate_sequence`): each step by :func:`problems.control.simulation
.simulate_walking` (the same plant, contact checks, impact and leg swap), the state carried
from one step into the next; a walk that ends standing ends with its last foot set down
beside the stance foot and ``stand`` s of standing past the plan's end (on the stance foot,
the other at the ground beside it, unloaded: both at one point), its contacts checked and
the resting foot within :data:`problems.control.simulation.STAND_HEIGHT` of the ground.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError, check_integer, check_positive, check_real
from problems.control.feedback import with_gains
from problems.control.lqr import (
    LqrWeights,
    linearise_along,
    periodic_riccati,
    riccati_sweep,
    weight_matrices,
)
from problems.control.simulation import (
    Disturbances,
    Plant,
    WalkingRun,
    disturbed_plant,
    simulate_walking,
)
from problems.control.tracking import GaitReference, TimedReference
from problems.library.sequence import WalkSequence

#: the seconds a walk that ends at rest is simulated standing after its last landing
STAND = 1.0
#: the least normal force the feedback leaves on the stance foot, a fraction of the weight
#: (0.02 and 0.1 walk the same cases of examples/benchmarks/walk_sequence.py)
LEAST_LOAD = 0.05
#: the simulated ground's friction coefficient: the plans run along their own cone (mu 0.8)
#: right after a heel strike, so the feedback needs a little more (as the periodic step's
#: closed loop: ``walk --ground-friction``)
GROUND_MU = 1.0
#: s: the stretch of standing's periods one cycle of its Riccati recursion runs over
STANDING_STRETCH = 0.5


@dataclass(frozen=True, eq=False)
class SequenceFeedback:
    """The gains along a walk: per step its reference (``references``, the plan's samples at
    the control rate), control instants ``times`` (K_j,) s and ``gains`` (K_j, n, 2n) N m/rad
    and N m s/rad on x = (psi, dpsi); ``limits`` (n,) N m the drives' torque limits."""

    sequence: WalkSequence
    references: tuple[TimedReference, ...]
    times: tuple[np.ndarray, ...]
    gains: tuple[np.ndarray, ...]
    limits: np.ndarray
    weights: LqrWeights
    control_rate_hz: float

    phased: tuple = ()
    phases: tuple = ()
    contact: object = None

    def law(self, j: int, t: float, x: np.ndarray) -> np.ndarray:
        """Step j's torques at t s since its start in state x (2n,), N m (clipped): by the
        phase (the hip's progress) where the step's hip always advances, else by the time."""
        reference = self.phased[j] if self.phased else None
        if reference is not None:
            s = reference.phase(x[: reference.n])
            x_ref, feedforward = reference.at_phase(s)
            grid, at = self.phases[j], s
        else:
            x_ref, feedforward = self.references[j].at_time(t)
            grid, at = self.times[j], t
        table = self.gains[j]
        k = int(np.clip(np.searchsorted(grid, at, side="right") - 1, 0, grid.size - 1))
        if k + 1 < grid.size and at > grid[k]:
            w = (at - grid[k]) / (grid[k + 1] - grid[k])
            gain = (1.0 - w) * table[k] + w * table[k + 1]
        else:
            gain = table[k]
        torques = np.clip(feedforward + gain @ (x_ref - x), -self.limits, self.limits)
        if self.contact is not None:
            feedforward = np.clip(feedforward, -self.limits, self.limits)
            torques = contact_limited(self.contact, x, feedforward, torques)
        return torques


def with_sequence_gains(feedback: SequenceFeedback, trajectory):
    """The walk's trajectory (``WalkSequence.trajectory`` at the control rate) with each
    sample's gains (columns ``K_<hinge>__<state>``), ``phase`` the index of its step's law
    (the hip's progress s for a step indexed by the phase, t / T otherwise), the law in
    ``metadata["feedback"]`` and each step's index and hip range in
    ``metadata["sequence"]["steps"][j]["law"]``."""
    trajectory = LinkageTrajectory.of(trajectory)
    step_column = np.asarray(trajectory.extras["step"][0]).astype(int)
    starts = [s.start for s in feedback.sequence.steps]
    local = np.asarray(trajectory.time) - np.asarray(starts)[step_column]
    n = len(trajectory.link_names)
    gains = np.zeros((local.size, n, 2 * n))
    index = np.asarray(trajectory.extras["phase"][0], dtype=float).copy()
    described = trajectory.metadata["sequence"]["steps"]
    steps = []
    for j, entry in enumerate(described):
        rows = np.flatnonzero(step_column == j)
        times, table = feedback.times[j], feedback.gains[j]
        for a in range(n):
            for b in range(2 * n):
                gains[rows, a, b] = np.interp(local[rows], times, table[:, a, b])
        reference = feedback.phased[j] if feedback.phased else None
        law = {"indexed_by": "time"}
        if reference is not None:
            index[rows] = [reference.phase(p) for p in np.asarray(trajectory.psi)[rows]]
            law = {"indexed_by": "phase", "hip_ahead_m": list(reference.hip_range)}
        steps.append({**entry, "law": law})
    names = trajectory.link_names
    out = LinkageTrajectory.of(trajectory.with_extra("phase", index, "1"))
    law = {
        "law": "M = clip(M_ff + K (x_ref - x), -limit, limit) per step, x = (psi, dpsi) in the "
               "step's labels; each step's row j of the file: indexed by its 'phase' (the "
               "hip's progress s = (x_hip - d0) / (d1 - d0) over the stance foot, hip_ahead_m "
               "[d0, d1]) where its law's indexed_by is 'phase', else by t / T since its "
               "touchdown; a step starts at the swing foot's touchdown",
        "design": "finite-horizon LQR along the whole walk (Bryson's weights), from standing's "
                  "stationary LQR (or the last gait's periodic one) backwards through every "
                  "heel strike",
        "contact": None if feedback.contact is None else (
            "the feedback part K (x_ref - x) is scaled by the largest alpha in [0, 1] that "
            f"keeps the stance foot's ground force, as the model predicts it from x and the "
            f"torques, at Fy >= {LEAST_LOAD:g} of the weight and inside the friction cone of "
            f"mu = {feedback.contact.mu:g} (the plan's): it needs the model"),
        "weights": feedback.weights.as_metadata(),
        "limits_N_m": [float(v) for v in feedback.limits],
        "control_rate_hz": feedback.control_rate_hz,
    }  # fmt: skip
    out = with_gains(out, names, index, gains, law)
    sequence = {**trajectory.metadata["sequence"], "steps": steps}
    return out.with_metadata(sequence=sequence)


def _phase_index(gait, problem, times, rate_hz: float) -> tuple:
    """(GaitReference, the phases (K,) of the control instants ``times``) of a step whose
    hip advances all along, else (None, None): that step's law goes by the time."""
    try:
        reference = GaitReference(gait.exported(rate_hz), problem.dynamics,
                                  problem.biped.stance_thigh)  # fmt: skip
    except DefinitionError:  # the hip stalls or goes back somewhere
        return None, None
    n = reference.n
    grid = np.array([reference.phase(reference.at_time(t)[0][:n]) for t in times])
    return (reference, grid) if np.all(np.diff(grid) > 0) else (None, None)


def design_sequence_feedback(
    sequence: WalkSequence,
    *,
    weights: LqrWeights | None = None,
    control_rate_hz: float = 1000.0,
    contact_aware: bool = True,
) -> SequenceFeedback:
    """The finite-horizon LQR along ``sequence`` (see the module); ``contact_aware``: the
    law scales its feedback down where the plan's model predicts it would unload the stance
    foot or take it out of its friction cone (:func:`contact_limited`)."""
    weights = weights or LqrWeights()
    period = 1.0 / check_positive("control_rate_hz", control_rate_hz, "Hz")
    steps = sequence.steps
    first = steps[0].gait.problem
    plant = Plant(first.linkage, first.mu)
    n = plant.n
    passive = [first.linkage.index(name) for name in first.passive]
    active, q, r = weight_matrices(n, weights, passive)
    ends_standing = sequence.speeds[-1] == 0
    linearised: dict[tuple[int, bool], object] = {}  # a repeated gait's linearisation, once
    references = []
    alongs = []
    for j, step in enumerate(steps):
        reference = TimedReference(step.gait.exported(control_rate_hz))
        event = None if (ends_standing and j == len(steps) - 1) else "strike"
        key = (id(step.gait), event is None)
        if key not in linearised:
            linearised[key] = linearise_along(plant, reference, period, event)
        references.append(reference)
        alongs.append(linearised[key])
    b_lists = [[None if b is None else b[:, active] for b in a.inputs] for a in alongs]
    if ends_standing:
        x_end, m_end = references[-1].at_time(references[-1].duration)
        a, b, _ = (np.asarray(v) for v in plant.advance_jacobian(x_end, m_end, period))
        # the stationary LQR of standing: the periodic recursion over a stretch of identical
        # periods (one period a cycle would need thousands of cycles to converge)
        count = int(np.ceil(STANDING_STRETCH / period))
        _, cost, _ = periodic_riccati([a] * count, [b[:, active]] * count, np.eye(2 * n), q, r)
    else:
        last = alongs[-1]
        _, cost, _ = periodic_riccati(last.states, b_lists[-1], last.jump, q, r)
    gains: list[np.ndarray] = [np.empty(0)] * len(steps)
    for j in range(len(steps) - 1, -1, -1):
        along = alongs[j]
        table, cost = riccati_sweep(along.states, b_lists[j], along.jump.T @ cost @ along.jump,
                                    q, r)  # fmt: skip
        full = np.zeros((len(along.times), n, 2 * n))
        full[:, active, :] = table
        gains[j] = full
    limits = np.array([first.torque_limit[name] for name in first.linkage.names])
    indexed: dict[int, tuple] = {}  # a repeated gait's phase index, once
    for step, along in zip(steps, alongs, strict=True):
        if id(step.gait) not in indexed:
            indexed[id(step.gait)] = _phase_index(step.gait, first, along.times, control_rate_hz)
    phased, phases = zip(*(indexed[id(step.gait)] for step in steps), strict=True)
    return SequenceFeedback(sequence, tuple(references), tuple(a.times for a in alongs),
                            tuple(gains), limits, weights, float(control_rate_hz),
                            tuple(phased), tuple(phases),
                            plant if contact_aware else None)  # fmt: skip


def contact_limited(plant: Plant, x: np.ndarray, feedforward: np.ndarray, torques: np.ndarray):
    """``torques`` with their feedback part (``torques - feedforward``) scaled by the largest
    alpha in [0, 1] that keeps the stance foot's ground force, as the plan's model predicts it
    (``plant.observe``: linear in the torques), pressing (Fy >= :data:`LEAST_LOAD` of the
    weight) and inside the plan's friction cone (``plant.mu``): the drives do not pull the
    foot off the ground or make it slip to correct an error (alpha 0 keeps the plan's own
    torques, whose force the plan held in the cone). A row the plan's torques already miss
    here (the body is off its plan) restricts alpha only when the feedback makes it worse."""
    weight = plant.biped.total_mass * plant.dynamics.linkage.gravity
    before = np.asarray(plant.observe(x, feedforward)[0]).ravel()
    after = np.asarray(plant.observe(x, torques)[0]).ravel()
    alpha = 1.0
    rows0 = np.array([before[1] - LEAST_LOAD * weight, plant.mu * before[1] - before[0],
                      plant.mu * before[1] + before[0]])  # fmt: skip
    rows1 = np.array([after[1] - LEAST_LOAD * weight, plant.mu * after[1] - after[0],
                      plant.mu * after[1] + after[0]])  # fmt: skip
    for g0, g1 in zip(rows0, rows1, strict=True):
        if g1 >= 0.0 or g1 >= g0:
            continue  # the full feedback keeps this row, or does not make it worse
        alpha = min(alpha, g0 / (g0 - g1) if g0 > 0.0 else 0.0)
    return feedforward + alpha * (torques - feedforward)


class SequenceController:
    """The simulation's controller of one step of the walk at a time (:meth:`select`)."""

    def __init__(self, feedback: SequenceFeedback) -> None:
        self.feedback = feedback
        self.step = 0

    def select(self, j: int) -> None:
        self.step = j

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        return self.feedback.law(self.step, t, x)


@dataclass(frozen=True)
class SequenceRun:
    """A simulated walk: ``runs`` (each step's :class:`WalkingRun`), ``fell`` (why it ended
    early, or None), ``planned`` steps, ``stood`` (it ended standing on both feet for the
    ``stand`` s asked), and per walked step its ``durations`` s and ``lengths`` m against the
    plan's."""

    runs: tuple[WalkingRun, ...]
    fell: str | None
    planned: int
    stood: bool
    durations: np.ndarray = field(default_factory=lambda: np.empty(0))
    lengths: np.ndarray = field(default_factory=lambda: np.empty(0))

    @property
    def walked(self) -> int:
        return sum(run.walked for run in self.runs)

    @property
    def completed(self) -> bool:
        """Every planned step walked (and, for a walk that ends at rest, standing after)."""
        return self.fell is None and self.walked == self.planned


@dataclass(frozen=True)
class SequenceDisturbances:
    """What the simulated walk meets: ``mass_scale`` (the body's masses and inertias times
    this), a forward ``push`` N s on the torso's centre of mass during step ``push_step`` at
    ``push_at`` of its planned time, ``initial`` (2n,) added to the first state."""

    mass_scale: float = 1.0
    push: float = 0.0
    push_step: int = 0
    push_at: float = 0.5
    initial: np.ndarray | None = None

    def __post_init__(self) -> None:
        check_positive("mass_scale", self.mass_scale)
        check_real("push", self.push)
        check_integer("push_step", self.push_step, 0)
        if not 0.0 <= check_real("push_at", self.push_at) < 1.0:
            raise DefinitionError(f"`push_at`: a fraction in [0, 1), got {self.push_at!r}")


def simulate_sequence(
    feedback: SequenceFeedback,
    disturbances: SequenceDisturbances | None = None,
    *,
    stand: float = STAND,
    ground_mu: float = GROUND_MU,
    substeps: int = 2,
) -> SequenceRun:
    """The walk of ``feedback.sequence`` under its law in the product's hybrid simulation
    (see the module), on a ground of friction coefficient ``ground_mu``."""
    disturbances = disturbances or SequenceDisturbances()
    sequence = feedback.sequence
    steps = sequence.steps
    first = steps[0].gait.problem
    linkage = first.linkage
    plant = disturbed_plant(linkage, ground_mu, substeps, disturbances.mass_scale)
    controller = SequenceController(feedback)
    x = steps[0].gait.solution.states[0].copy()
    if disturbances.initial is not None:
        x = x + np.asarray(disturbances.initial, dtype=float)
    ends_standing = sequence.speeds[-1] == 0
    runs, durations, lengths = [], [], []
    fell = None
    previous_length = first.step_length
    for j, step in enumerate(steps):
        problem = step.gait.problem
        controller.select(j)
        last_stop = ends_standing and j == len(steps) - 1
        length = problem.step_length if problem.step_length > 0 else previous_length
        pushed = disturbances.push != 0.0 and j == disturbances.push_step
        run = simulate_walking(
            x, controller, linkage=linkage, step_time=problem.step_time, step_length=length,
            mu=ground_mu, steps=1, plant=plant,
            disturbances=Disturbances(push=disturbances.push if pushed else 0.0, push_step=0,
                                      push_at=disturbances.push_at),
            control_rate_hz=feedback.control_rate_hz, substeps=substeps,
            stand=stand if last_stop else None,
        )  # fmt: skip
        runs.append(run)
        if run.fell is not None:
            fell = f"step {j} ({step.kind}): {run.fell}"
            break
        record = run.steps[0]
        durations.append(record.duration - record.double_support)
        lengths.append(record.length)
        previous_length = problem.step_length or previous_length
        x = run.end
    stood = fell is None and ends_standing
    return SequenceRun(tuple(runs), fell, len(steps), stood, np.asarray(durations),
                       np.asarray(lengths))  # fmt: skip


__all__ = [
    "STAND",
    "SequenceController",
    "SequenceDisturbances",
    "SequenceFeedback",
    "SequenceRun",
    "design_sequence_feedback",
    "simulate_sequence",
]
