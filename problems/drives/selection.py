"""Choosing each drive's motor and gearbox from a catalogue for a duty cycle of plans.

Every combination of a catalogue's motors and gearboxes (:class:`problems.drives.catalogue.
Drive`) is held against each drive's duty (:class:`problems.drives.requirements.Plan`: torque,
speed and acceleration at every sample), at the motor through the gearbox
(:meth:`Drive.at_motor`), limit by limit, each with its margin 1 - need / capacity (>= 0: met):

* ``gearbox peak torque``: max |tau| against the gearbox's repeated peak;
* ``gearbox rated torque``: the output's RMS torque over the duty against its rated torque;
* ``motor peak torque``: max |tau_m| against the motor's peak;
* ``motor continuous torque``: the motor's RMS torque over the duty against its continuous
  torque (the thermal limit: copper losses grow with tau_m^2);
* ``speed``: max |N dq| against the lower of the motor's and the gearbox's input speed;
* ``voltage``: max |R i + k_t N dq| against the supply: the torque-speed line a motor at its
  supply voltage cannot pass;
* ``reflected inertia`` (when the caller caps it): the rotor's and gearbox's inertia seen at
  the joint, (J_m + J_g) N^2 kg m^2, against the cap. A plan made for ideal torques does not
  feel it, but the walker carrying the drive does: through a high ratio a light foot's drive
  can outweigh the foot, and at the heel strike the geared ankle then throws the stance ball
  off the ground (no footed step exists with the six-link walker's ankles through 50:1 of the
  example catalogue's motors: ``examples/benchmarks/drives_on_feet.py``).

The candidates that meet every limit are ranked by mass (motor plus gearbox) or by the
electrical energy per step over the duty (int u i dt per step, time-weighted by the plans'
shares; regeneration counted as recovered, or, with ``regenerate=False``, dissipated: only
the positive part drawn). A drive no candidate fits is refused, naming the limit that its
closest candidate (the one whose worst margin is largest) misses and by how much.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np

from planner.errors import AnthropoidError, DefinitionError
from problems.drives.catalogue import Drive, Gearbox, Motor
from problems.drives.requirements import DriveRequirements, Plan

RANKS = ("mass", "energy")


class DriveSelectionError(AnthropoidError):
    """No catalogue drive meets some drive's duty (the message names each and its limit)."""


@dataclass(frozen=True)
class Check:
    """One limit of a candidate: ``need`` and ``capacity`` in ``unit``."""

    limit: str
    need: float
    capacity: float
    unit: str

    @property
    def margin(self) -> float:
        """1 - need / capacity: the fraction of the capacity left (< 0: exceeded)."""
        return 1.0 - self.need / self.capacity


@dataclass(frozen=True)
class Candidate:
    """A catalogue drive held against one drive's duty: its ``checks`` and the electrical
    ``energy_per_step`` J."""

    drive: Drive
    checks: tuple[Check, ...]
    energy_per_step: float

    @property
    def fits(self) -> bool:
        return all(c.margin >= 0.0 for c in self.checks)

    @property
    def binding(self) -> Check:
        """The check with the least margin."""
        return min(self.checks, key=lambda c: c.margin)


def evaluate(drive: Drive, plans: Sequence[Plan], name: str, regenerate: bool = True,
             inertia_cap: float | None = None) -> Candidate:  # fmt: skip
    """``drive`` held against the duty of joint ``name`` over ``plans`` (see the module), and
    its reflected inertia against ``inertia_cap`` kg m^2 when given (math.inf: reported,
    never binding)."""
    peaks = {"output": 0.0, "motor": 0.0, "speed": 0.0, "voltage": 0.0}
    squares = {"output": 0.0, "motor": 0.0}
    energy = 0.0
    for plan in plans:
        integrals = {"output": 0.0, "motor": 0.0, "energy": 0.0}
        for step in plan.steps:
            tau, dq, time = step.torques[name], step.speeds[name], step.time
            motor = drive.at_motor(tau, dq, step.acceleration(name))
            power = motor["power"] if regenerate else np.maximum(motor["power"], 0.0)
            integrals["output"] += float(np.trapezoid(tau**2, time))
            integrals["motor"] += float(np.trapezoid(motor["torque"] ** 2, time))
            integrals["energy"] += float(np.trapezoid(power, time))
            peaks["output"] = max(peaks["output"], float(np.max(np.abs(tau))))
            peaks["motor"] = max(peaks["motor"], float(np.max(np.abs(motor["torque"]))))
            peaks["speed"] = max(peaks["speed"], float(np.max(np.abs(motor["speed"]))))
            peaks["voltage"] = max(peaks["voltage"], float(np.max(np.abs(motor["voltage"]))))
        squares["output"] += plan.share * integrals["output"] / plan.duration
        squares["motor"] += plan.share * integrals["motor"] / plan.duration
        energy += plan.share * integrals["energy"] / len(plan.steps)
    m, g = drive.motor, drive.gearbox
    checks = (
        Check("gearbox peak torque", peaks["output"], g.peak_torque, "N m"),
        Check(
            "gearbox rated torque", float(np.sqrt(squares["output"])), g.continuous_torque, "N m"
        ),
        Check("motor peak torque", peaks["motor"], m.peak_torque, "N m"),
        Check(
            "motor continuous torque", float(np.sqrt(squares["motor"])), m.continuous_torque, "N m"
        ),
        Check("speed", peaks["speed"], min(m.max_speed, g.max_input_speed), "rad/s"),
        Check("voltage", peaks["voltage"], m.voltage, "V"),
    )
    if inertia_cap is not None:
        checks += (Check("reflected inertia", drive.inertia * g.ratio**2, inertia_cap,
                         "kg m^2"),)  # fmt: skip
    return Candidate(drive, checks, energy)


@dataclass(frozen=True)
class Selection:
    """Per drive of the requirements: ``ranked`` candidates that fit, best first (empty:
    none), ``closest`` the best of those that do not (by worst margin), ``rank`` the order."""

    ranked: dict[str, tuple[Candidate, ...]]
    closest: dict[str, Candidate | None]
    rank: str

    def best(self, drive: str) -> Candidate | None:
        candidates = self.ranked[drive]
        return candidates[0] if candidates else None

    @property
    def refused(self) -> dict[str, str]:
        """{drive: why} for every drive no candidate fits."""
        out = {}
        for drive, candidates in self.ranked.items():
            if candidates:
                continue
            near = self.closest[drive]
            check = near.binding
            out[drive] = (
                f"{drive}: no catalogue drive fits; the closest, {near.drive.name}, misses its "
                f"{check.limit}: needs {check.need:.3g} {check.unit}, has {check.capacity:.3g} "
                f"{check.unit} ({100 * -check.margin:.0f} % over)"
            )
        return out

    def table(self) -> str:
        """The chosen drive per joint with each limit's margin (%), markdown."""
        any_candidate = next(
            (c for d in self.ranked for c in (*self.ranked[d], self.closest[d]) if c), None
        )
        if any_candidate is None:
            return ""
        limits = [c.limit for c in any_candidate.checks]  # every candidate's, in one order
        lines = [
            "| drive | chosen (motor + gearbox) | mass kg | energy per step J | "
            + " | ".join(f"{limit} margin" for limit in limits)
            + " |",
            "|---|---|---|---|" + "---|" * len(limits),
        ]
        for drive, candidates in self.ranked.items():
            if not candidates:
                lines.append(f"| {drive} | none fits |  |  |" + " |" * len(limits))
                continue
            best = candidates[0]
            margins = " | ".join(f"{100 * c.margin:.0f} %" for c in best.checks)
            lines.append(f"| {drive} | {best.drive.name} | {best.drive.mass:.3f} | "
                         f"{best.energy_per_step:.2f} | {margins} |")  # fmt: skip
        return "\n".join(lines)


def select(
    requirements: DriveRequirements,
    motors: Sequence[Motor],
    gearboxes: Sequence[Gearbox],
    *,
    rank: str = "mass",
    regenerate: bool = True,
    drives: Sequence[str] | None = None,
    reflected_inertia: Mapping[str, float] | None = None,
) -> Selection:
    """Every combination of ``motors`` and ``gearboxes`` held against each drive's duty in
    ``requirements`` (or the named ``drives``), the fitting ones ranked by ``rank`` ("mass" or
    "energy": the electrical energy per step, ``regenerate``: recovered braking energy counts);
    see the module. ``reflected_inertia`` caps (J_m + J_g) N^2, kg m^2, by drive
    (``right_ankle``) or by joint (``ankle``: both legs'). Raises nothing for a drive that
    nothing fits: :attr:`Selection.refused` says why (:func:`require` raises)."""
    if rank not in RANKS:
        raise DefinitionError(f"`rank`: one of {RANKS}, got {rank!r}")
    if not motors or not gearboxes:
        raise DefinitionError("`motors`, `gearboxes`: give at least one of each")
    names = list(requirements.names if drives is None else drives)
    unknown = [d for d in names if d not in requirements.names]
    if unknown:
        raise DefinitionError(f"`drives`: {unknown} are not among {list(requirements.names)}")
    combinations = [Drive(m, g) for m in motors for g in gearboxes]
    caps = _inertia_caps(reflected_inertia, names)

    def order(candidate: Candidate) -> tuple[float, float]:
        mass, energy = candidate.drive.mass, candidate.energy_per_step
        return (mass, energy) if rank == "mass" else (energy, mass)

    ranked, closest = {}, {}
    for name in names:
        candidates = [evaluate(d, requirements.plans, name, regenerate, caps.get(name))
                      for d in combinations]  # fmt: skip
        ranked[name] = tuple(sorted((c for c in candidates if c.fits), key=order))
        misses = [c for c in candidates if not c.fits]
        closest[name] = max(misses, key=lambda c: c.binding.margin) if misses else None
    return Selection(ranked, closest, rank)


def _inertia_caps(caps: Mapping[str, float] | None, names: Sequence[str]) -> dict[str, float]:
    """{drive: cap kg m^2} of every drive in ``names`` (math.inf where none is given) from
    ``caps`` by drive or by joint; {} without caps."""
    if not caps:
        return {}
    joints = {name.rpartition("_")[2] for name in names}
    unknown = sorted(set(caps) - set(names) - joints)
    if unknown:
        raise DefinitionError(f"`reflected_inertia`: {unknown} name no drive; give drives "
                              f"{list(names)} or joints {sorted(joints)}")  # fmt: skip
    out = {}
    for name in names:
        value = caps.get(name, caps.get(name.rpartition("_")[2], math.inf))
        if isinstance(value, bool) or not isinstance(value, Real) or not value > 0:
            raise DefinitionError(
                f"`reflected_inertia[{name!r}]`: a cap in kg m^2 > 0, got {value!r}"
            )
        out[name] = float(value)
    return out


def require(selection: Selection) -> Selection:
    """``selection`` when every drive has a fit, else :class:`DriveSelectionError` naming
    each refused drive's limit."""
    refused = selection.refused
    if refused:
        raise DriveSelectionError("; ".join(refused.values()))
    return selection


__all__ = [
    "RANKS",
    "Candidate",
    "Check",
    "DriveSelectionError",
    "Selection",
    "evaluate",
    "require",
    "select",
]
