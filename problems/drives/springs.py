"""Parallel springs beside the drives, designed with the gait (issue #36, part 5).

A torsion spring between the two links of a joint, in parallel with its drive, gives the joint
tau_s = -k (q - q_0): q the robot's joint angle (:func:`problems.robot.controller.joint_maps`,
q = a . psi + const, rad), ``k`` its stiffness (N m/rad), ``q_0`` the angle at which it is
slack. The hinge torque of the plan stays the whole torque the links feel, so the spring does
not enter the equations of motion: it takes its share off the drive, whose gear then gives the
links

    tau_out = tau - tau_s - N J a_r = tau + k (q - q_0) - N J a_r

(:meth:`problems.drives.loop.MountedDrive.joint_terms`). Both legs carry one (the legs swap at
every heel strike: a walker's springs are symmetric, as its drives are), and one spring design
serves every phase of a step on feet.

Either number may be given or left to the plan: ``None`` makes it a static parameter of the NLP
(:meth:`planner.OCP.param`: one decision variable for the whole step, shared by the phases on
feet), chosen with the motion for the step's objective (the electrical energy, the copper
losses) within the drives' limits; a number fixes it. So the stiffness and the rest angle are
designed by gradient with the gait, in the one NLP, not by a search around it: they do not
touch the dynamics, unlike a gear ratio (:mod:`problems.drives.codesign`).

The spring stores energy and gives it back (no loss is modelled); over a periodic step its two
copies' energy returns to its start (the angles are continuous through the heel strike and the
legs swap), so the drives' net mechanical work equals the hinges' (a test's oracle).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError

#: the joints a spring may sit beside (both legs' copies)
SPRING_JOINTS = ("hip", "knee", "ankle")
#: the stiffness bound of a designed spring, N m/rad (a stiff ankle spring of a prosthesis is
#: a few hundred N m/rad)
MAX_STIFFNESS = 600.0


@dataclass(frozen=True)
class ParallelSpring:
    """A torsion spring beside ``joint``'s drive in both legs (see the module).

    Parameters
    ----------
    joint : "hip", "knee" or "ankle".
    stiffness : k, N m/rad (>= 0), or None: designed with the gait within [0, ``max_stiffness``].
    rest : q_0, rad, the joint angle (the robot's, :func:`problems.robot.controller.
        joint_maps`) at which the spring is slack, or None: designed within [-pi, pi].
    max_stiffness : the designed stiffness's upper bound, N m/rad (> 0).
    """

    joint: str
    stiffness: float | None = None
    rest: float | None = None
    max_stiffness: float = MAX_STIFFNESS

    def __post_init__(self) -> None:
        if self.joint not in SPRING_JOINTS:
            raise DefinitionError(
                f"`ParallelSpring.joint`: one of {', '.join(SPRING_JOINTS)}, got {self.joint!r}"
            )
        for name, low, high, unit in (("stiffness", 0.0, math.inf, "N m/rad"),
                                      ("rest", -math.pi, math.pi, "rad")):  # fmt: skip
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
                raise DefinitionTypeError(
                    f"`ParallelSpring.{name}`: a number ({unit}) or None (designed), got {value!r}"
                )
            if not (math.isfinite(value) and low <= value <= high):
                raise DefinitionError(
                    f"`ParallelSpring.{name}`: must be within [{low:g}, {high:g}] {unit}, got "
                    f"{value!r}; give None to design it with the gait"
                )
            object.__setattr__(self, name, float(value))
        maximum = self.max_stiffness
        if not (isinstance(maximum, int | float) and math.isfinite(maximum) and maximum > 0):
            raise DefinitionError(
                f"`ParallelSpring.max_stiffness`: a positive number of N m/rad, got {maximum!r}"
            )
        if self.stiffness is not None and self.stiffness > maximum:
            raise DefinitionError(
                f"`ParallelSpring.stiffness`: {self.stiffness:g} N m/rad is over max_stiffness "
                f"{maximum:g}; raise max_stiffness"
            )

    @property
    def names(self) -> tuple[str, str]:
        """The static parameters' names: (stiffness, rest)."""
        return f"spring_k_{self.joint}", f"spring_rest_{self.joint}"

    def declare(self, ocp):
        """``ocp`` (a planner OCP) with the spring's two static parameters: free within their
        bounds when designed, fixed (lower = upper) when given."""
        k_name, rest_name = self.names
        if self.stiffness is None:
            # not 0: at k = 0 the rest angle does nothing, and the NLP's gradient with it
            ocp = ocp.param(k_name, 0.0, self.max_stiffness, guess=0.1 * self.max_stiffness,
                            scale=0.25 * self.max_stiffness)  # fmt: skip
        else:
            ocp = ocp.param(k_name, self.stiffness, self.stiffness, guess=self.stiffness,
                            scale=max(self.stiffness, 1.0))  # fmt: skip
        if self.rest is None:
            return ocp.param(rest_name, -math.pi, math.pi, guess=0.0, scale=1.0)
        return ocp.param(rest_name, self.rest, self.rest, guess=self.rest, scale=1.0)


def check_springs(springs) -> tuple[ParallelSpring, ...]:
    """``springs`` as a tuple of :class:`ParallelSpring`, one per joint at most."""
    if isinstance(springs, ParallelSpring):
        springs = (springs,)
    if not isinstance(springs, Sequence) or not all(isinstance(s, ParallelSpring) for s in springs):
        raise DefinitionTypeError(
            f"`springs`: a sequence of problems.drives.ParallelSpring, got {springs!r}"
        )
    joints = [s.joint for s in springs]
    twice = sorted({j for j in joints if joints.count(j) > 1})
    if twice:
        raise DefinitionError(f"`springs`: one spring a joint, got two at {twice}")
    return tuple(springs)


def spring_values(solution, springs: Sequence[ParallelSpring]) -> dict[str, tuple[float, float]]:
    """{joint: (k N m/rad, q_0 rad)} of a solved plan's springs (its static parameters)."""
    values = {}
    for spring in check_springs(springs):
        k_name, rest_name = spring.names
        if k_name not in solution.params or rest_name not in solution.params:
            raise DefinitionError(
                f"`solution`: no spring parameters for the {spring.joint} in it; plan it with "
                "with_drives(..., springs=...)"
            )
        values[spring.joint] = (float(solution.params[k_name]), float(solution.params[rest_name]))
    return values


def spring_torque(stiffness, rest, angle):
    """tau_s = -k (q - q_0), N m, in the joint's sense: numpy arrays or CasADi expressions."""
    return -stiffness * (angle - rest)


def designed(springs: Mapping[str, tuple[float, float]]) -> str:
    """The springs as one line: "ankle 212 N m/rad, slack at -3.1 deg; ..."."""
    return "; ".join(
        f"{joint} {k:.0f} N m/rad, slack at {math.degrees(rest):.1f} deg"
        for joint, (k, rest) in springs.items()
    )


__all__ = [
    "MAX_STIFFNESS",
    "SPRING_JOINTS",
    "ParallelSpring",
    "check_springs",
    "designed",
    "spring_torque",
    "spring_values",
]
