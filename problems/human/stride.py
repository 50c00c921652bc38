"""One leg's stride of a planned periodic walking step, as a :class:`GaitRecording`.

A planned step (the point-foot ``walking_step`` or the ``footed_step``) is half a stride of a
symmetric gait: the step after it is the same motion with the legs swapped. Leg A, the stance
leg of the step (duration T, its swing foot striking at t_s: the double support's start, T
without one), walks its cycle from its own heel strike, which happened one step earlier as the
swing leg's, so over the cycle time tau in [0, 2T):

* [0, T - t_s): the double support after its strike, A the front foot: the swing leg's values
  at t = t_s + tau;
* [T - t_s, 2T - t_s): A the stance leg through the step: the stance leg's at
  t = tau - (T - t_s); its toe-off at the end (stance fraction (2T - t_s) / 2T);
* [2T - t_s, 2T): A swinging in the next step: the swing leg's at t = tau - (2T - t_s).

The pieces are read from the exported samples (``Gait.to_trajectory`` or a torques.csv with
its sidecar): angles and moments through :mod:`problems.human.joints`, the ground force on A's
foot from the file's ``F_<root>_start_x/_y`` (the stance foot) and the other ``F_*`` columns
(the front foot in the double support), in body weights, body weight from the file's model.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from model.linkage import Linkage
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems.human.joints import Body, Leg, body_of, leg_angles, leg_moments
from problems.human.recording import GaitRecording

#: Samples per % of the cycle of the stride's uniform grid.
PER_PERCENT = 10
_STEPS = ("walking_step", "footed_step")


def _settings(trajectory: Trajectory) -> Mapping[str, Any]:
    settings = trajectory.metadata.get("gait") if trajectory.metadata else None
    if not isinstance(settings, Mapping) or settings.get("problem") not in _STEPS:
        found = None if not isinstance(settings, Mapping) else settings.get("problem")
        raise DefinitionError(
            "`trajectory`: a stride is built from a planned walking step (walking_step or "
            f"footed_step) with its settings in metadata['gait'], got {found!r}"
            + (
                "; a torques.csv read without its sidecar torques.csv.meta.json has none: put "
                "it back beside the CSV file"
                if not trajectory.metadata
                else ""
            )
        )
    return settings


def strike_time(settings: Mapping[str, Any], duration: float) -> float:
    """t_s, s: when the swing foot strikes within the step (the double support's start; the
    step's end without one)."""
    phases = settings.get("phases")
    if phases:
        if "double" not in phases:
            return duration
        ends = [event["t"] for event in settings.get("before_events", [])]
        k = list(phases).index("double")
        if len(ends) < k or k == 0:
            raise DefinitionError(
                "`trajectory`: its metadata['gait']['before_events'] do not say when the "
                "double support starts"
            )
        return float(ends[k - 1])
    return duration - float(settings.get("double_support") or 0.0)


def foot_forces(trajectory: LinkageTrajectory, root: str) -> tuple[np.ndarray, np.ndarray]:
    """(the stance foot's, the front foot's) ground force, complex (K,) N."""
    extras = trajectory.extras
    rear = np.asarray(trajectory.ground_reaction)
    front = np.zeros(rear.shape, dtype=complex)
    for name in extras:
        if not name.startswith("F_") or name.startswith(f"F_{root}_start"):
            continue
        values = np.asarray(trajectory.column(name), dtype=float)
        front = front + (values if name.endswith("_x") else 1j * values)
    return rear, front


def _leg_channels(
    body: Body, leg: Leg, trajectory: LinkageTrajectory, mass: float, force: np.ndarray
) -> dict[str, np.ndarray]:
    names = trajectory.link_names
    psi = {name: trajectory.psi[:, i] for i, name in enumerate(names)}
    torques = {name: trajectory.torques[:, i] for i, name in enumerate(names)}
    weight = mass * float(trajectory.metadata["model"]["gravity"])
    return {
        **leg_angles(body, leg, psi),
        **leg_moments(body, leg, torques, mass),
        "force_x": force.real / weight,
        "force_y": force.imag / weight,
    }


def step_stride(trajectory: Trajectory, *, body_mass: float | None = None) -> GaitRecording:
    """The stride of the step's stance leg (see the module) on a uniform grid of
    :data:`PER_PERCENT` samples per % of the cycle.

    Parameters
    ----------
    trajectory : the step's exported samples with their metadata (``gait.to_trajectory(
        rate_hz)``, ``LinkageTrajectory.load("torques.csv")``).
    body_mass : kg, for the moments per kg and the forces in body weights; default the sum
        of the link masses of the file's model.
    """
    if not isinstance(trajectory, Trajectory):
        raise DefinitionTypeError(
            f"`trajectory`: must be a planner.Trajectory, got {type(trajectory).__name__}"
        )
    trajectory = LinkageTrajectory.of(trajectory)
    settings = _settings(trajectory)
    model = trajectory.metadata.get("model")
    if not isinstance(model, Mapping):
        raise DefinitionError("`trajectory`: its metadata has no 'model' (the linkage)")
    linkage = Linkage.from_parameters(model)
    if tuple(trajectory.link_names) != linkage.names:
        raise DefinitionError(
            f"`trajectory`: its links {list(trajectory.link_names)} are not its model's "
            f"{list(linkage.names)}"
        )
    body = body_of(linkage, settings.get("neutral_ankles"))
    mass = sum(link.mass for link in linkage.links) if body_mass is None else float(body_mass)
    if not mass > 0:
        raise DefinitionError(f"`body_mass`: must be > 0 kg, got {body_mass!r}")
    time = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
    T = float(time[-1])
    if not math.isclose(T, float(settings["step_time"]), rel_tol=1e-6):
        raise DefinitionError(
            f"`trajectory`: {T:g} s of samples for a step of {settings['step_time']:g} s: give "
            "the whole step"
        )
    t_s = strike_time(settings, T)
    rear, front = foot_forces(trajectory, linkage.names[0])
    stance = _leg_channels(body, body.stance, trajectory, mass, rear)
    swing = _leg_channels(body, body.swing, trajectory, mass, front)
    # where two phases meet the file holds both sides' samples at one time: keep the later
    keep = np.append(np.diff(time) > 0, True)
    pieces = [
        (time >= t_s, time - t_s, swing),
        (np.ones(time.shape, bool), time + (T - t_s), stance),
        (time < t_s, time + (2 * T - t_s), swing),
    ]
    tau = np.concatenate([shift[mask & keep] for mask, shift, _ in pieces])
    order = np.argsort(tau, kind="stable")
    tau = tau[order]
    unique = np.append(np.diff(tau) > 0, True)
    grid = np.linspace(0.0, 100.0, 100 * PER_PERCENT + 1)
    channels = {}
    for name in stance:
        values = np.concatenate([channels_[name][mask & keep] for mask, _, channels_ in pieces])
        values = values[order][unique]
        channels[name] = np.interp(grid, 100.0 * tau[unique] / (2 * T), values)
    kind = "on feet" if body.stance.foot is not None else "on point feet"
    return GaitRecording(
        grid,
        channels,
        stance_fraction=(2 * T - t_s) / (2 * T),
        stride_time=2 * T,
        stride_length=2 * float(settings["step_length"]),
        body_mass=mass,
        source=f"planned step {kind} ({settings['step_length']:.4g} m in {T:.4g} s), the "
        "stride of its stance leg",
    )
