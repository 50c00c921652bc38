"""A walk through speeds on feet under its drives' law: each step's joint PD around its own
plan (:class:`problems.control.feet_law.FeetLaw`), in the walk's file, in the product's own
simulation on feet (:mod:`problems.control.feet_simulation`) and in MuJoCo.

Why each step's own law and not one finite-horizon LQR along the walk (what the point-foot
walk has, :mod:`problems.library.closed_loop`): the periodic step on feet runs under joint PD
already (its LQR through the feet's four contact modes is open work), and a step of a speed
change is a step on feet like any other (the start gait's step, resized), so its plan carries
the same law. The law hands over at the leg swap, where the next step's plan starts
(:func:`problems.control.mujoco_feet.run_feet_steps_in_mujoco`). The first step of a start
from quiet standing has a hip at rest that sways back before it walks off: its law follows
the plan by the time since the step began until the hip advances for good, then by the
phase (``FeetLaw.indexed_by`` "time", in the file's law of that step). A stop at quiet
standing (the walk's last step) has no phase either (its hip sways back and settles): its law
follows it by the time since it began and then holds its last sample, both feet flat side by
side at rest (``FeetLaw.indexed_by`` "time, then held"); in MuJoCo the walk ends standing
that way for :data:`problems.control.mujoco_feet.STAND` s.

In the file (:func:`with_feet_laws`) every row carries its step's law as the single step's
file does (``phase``: the hip's progress s over the stance ball, ``double_support``, the gains
``K_<hinge>__<state>``), the law in ``metadata["feedback"]`` and each step's own gains and
hip range in ``metadata["sequence"]["steps"][j]["law"]``.
"""

from __future__ import annotations

from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError
from problems.control.feet_law import CONTROL_RATE_HZ, HELD, FeetLaw

#: the closed loop's cases: label -> (mass scale, push N s at the middle of the first step
#: that changes speed); as the point-foot walk's (walk --speeds --feedback)
CASES = {"as planned": (1.0, 0.0), "mass +10 %": (1.1, 0.0), "push 10 N s": (1.0, 10.0)}


def sequence_laws(sequence, rate_hz: float = CONTROL_RATE_HZ) -> tuple[FeetLaw, ...]:
    """One :class:`FeetLaw` per step of a walk on feet (``WalkSequence`` of
    ``plan_sequence(..., feet=True)``), made once per distinct plan (a speed's periodic
    step repeats)."""
    from problems.walking.footed import FootedGait

    gaits = [step.gait for step in sequence.steps]
    if not all(isinstance(gait, FootedGait) for gait in gaits):
        raise DefinitionError(
            "`sequence`: a walk on feet (plan_sequence(..., feet=True)); its steps are "
            f"{sorted({type(g).__name__ for g in gaits})}"
        )
    made: dict[int, FeetLaw] = {}
    return tuple(made.setdefault(id(gait), FeetLaw(gait, rate_hz=rate_hz)) for gait in gaits)


def with_feet_laws(sequence, laws, rate_hz: float = CONTROL_RATE_HZ) -> LinkageTrajectory:
    """The walk's trajectory at ``rate_hz`` with every row's law (see the module): ``laws``
    one per step (:func:`sequence_laws`)."""
    laws = tuple(laws)
    if len(laws) != len(sequence.steps):
        raise DefinitionError(f"`laws`: one per step, {len(sequence.steps)}, got {len(laws)}")
    described = {}

    def channels(j, exported):
        out = laws[j].channels(exported)
        described[j] = out.metadata["feedback"]
        return out

    trajectory = sequence.trajectory(rate_hz, channels=channels)
    steps = trajectory.metadata["sequence"]["steps"]
    for j, entry in enumerate(steps):
        single = laws[j].references[0]  # the single support's, or a stop's only one
        law = described[j]
        entry["law"] = {"indexed_by": laws[j].indexed_by, "kp": law["kp"], "kd": law["kd"]}
        if laws[j].indexed_by != HELD:  # a stop reads no phase: no hip range
            entry["law"]["hip_ahead_m"] = list(single.hip_range)
        if laws[j].indexed_by == "time":  # by the time since the step began up to here
            entry["law"]["time_indexed_until_s"] = single.time_indexed_until
        elif laws[j].indexed_by == HELD:  # a stop: by the time, then its last row held
            entry["law"]["held_after_s"] = single.duration
            entry["law"]["standing"] = law["standing"]
    first = {key: value for key, value in described[0].items()
             if key not in ("kp", "kd", "standing")}  # fmt: skip
    first["indexed_by"] = (
        "each step's own (sequence.steps[j].law.indexed_by): 'phase', or 'time' for a step "
        "whose hip does not always advance (a start from rest), followed by the time since "
        "the step began up to its law's time_indexed_until_s, then by the phase, or 'time, "
        "then held' for a stop at quiet standing, followed by the time since it began and "
        "its last row held after its law's held_after_s"
    )
    first["gains_per_step"] = (
        "each step's kp and kd (per branch and hinge) and its phase's "
        "hip range: sequence.steps[j].law; its K in its rows"
    )
    return LinkageTrajectory.of(trajectory.with_metadata(feedback=first))


def walk_in_mujoco(sequence, laws, cases=None):
    """The walk on feet in MuJoCo under its laws, once per case ({label: (mass scale, push
    N s)}, default :data:`CASES`; the push at the middle of the first step that changes speed,
    else of the second step): ({label: MujocoRun}, the push's step). A walk that ends at
    quiet standing stands for :data:`problems.control.mujoco_feet.STAND` s after its stop
    and has walked it only if it came to rest there."""
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco

    return _walk_cases(run_feet_steps_in_mujoco, sequence, laws, cases)


def walk_in_simulation(sequence, laws, cases=None):
    """:func:`walk_in_mujoco` in the product's own simulation on feet
    (:func:`problems.control.feet_simulation.simulate_feet_steps`: the plan's equations on a
    floating base, compliant heels and balls): ({label: FeetRun}, the push's step)."""
    from problems.control.feet_simulation import simulate_feet_steps

    return _walk_cases(simulate_feet_steps, sequence, laws, cases)


def _walk_cases(walk, sequence, laws, cases):
    from problems.control.simulation import Disturbances

    kinds = [step.kind for step in sequence.steps]
    push_step = kinds.index("change") if "change" in kinds else min(1, len(kinds) - 1)
    gaits = [step.gait for step in sequence.steps]
    runs = {}
    for label, (mass, push) in (cases or CASES).items():
        disturbances = Disturbances(mass_scale=mass, push=push, push_step=push_step)
        runs[label] = walk(gaits, disturbances=disturbances, laws=laws)
    return runs, push_step


__all__ = ["CASES", "sequence_laws", "walk_in_mujoco", "walk_in_simulation", "with_feet_laws"]
