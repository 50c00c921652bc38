"""A walking biped seen in a linkage: its legs, its upper body, walking postures and the gait
law (22) fitted to a step.

A biped here is what :func:`model.swap_legs` accepts: a stance leg of k links from the root
(its start H0 is the stance foot) up to the hip, at the hip a swing leg of k links mirroring
it down to the swing foot, and any upper body. Its feet are contacts (:meth:`Biped.feet`:
``model.Contact``), its legs chains of links; the seed paper's legs have two (shank,
thigh), and the walking postures and the law's fit below need two. Angles follow the project's
convention (absolute, from +x counter-clockwise): a leg standing on its foot points up
(about pi/2), a leg hanging from the hip points down (about -pi/2). The knee is bent when
psi_thigh - psi_shank > 0 for either leg (the knee ahead of the line hip-foot, walking to
+x): that difference is the knee's flexion, the same for both legs and kept by the leg swap.

The law (22), psi_j(t) = center_j + zeta_j sin(varpi_j - (1 - cos(2 pi t / P)) pi/2), runs
over half its period P from psi_j(0) to 2 center_j - psi_j(0) with zero velocity at both ends:
one step. :meth:`Biped.step_law` fits it to a step of length s and duration T (P = 2 T): the
postures at heel strike (t = T: stance foot at 0, swing foot at (s, 0), hip midway) and at
mid-step (t = T/2: hip above the stance foot, the swing foot lifted) come from inverse
kinematics of the legs; the start posture is the heel-strike posture with the legs swapped,
so the fitted law satisfies the step's periodicity exactly. Per link, center = (a + b)/2,
zeta sin(varpi) = (a - b)/2 and zeta cos(varpi) = center - m for the angles a, m, b at
t = 0, T/2, T.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

from model.contact import Contact
from model.linkage import Linkage
from model.points import LinkPoint
from model.rerooting import Rerooting, swap_legs
from planner.errors import DefinitionError, DefinitionTypeError, check_positive
from problems.gait.law import GaitLaw

HALF_PI = 0.5 * math.pi
#: Hip-to-foot distance of the guess's legs at heel strike, as a fraction of the leg length.
EXTENSION = 0.97


@dataclass(frozen=True, eq=False)
class Biped:
    """The legs and upper body of a biped linkage (see the module docstring).

    Attributes
    ----------
    linkage : the tree.
    swap : the leg swap at heel strike (:func:`model.swap_legs`).
    stance_leg : the stance leg's links from the foot (the root) up to the hip.
    swing_leg : the swing leg's links from the hip down to the foot (the end of the last).
    upper_body : names of every other link (hanging at the hip, directly or not).
    """

    linkage: Linkage
    swap: Rerooting
    stance_leg: tuple[str, ...]
    swing_leg: tuple[str, ...]
    upper_body: tuple[str, ...]

    @classmethod
    def of(cls, linkage: Linkage, swing: tuple[str, str] | None = None) -> Biped:
        """The biped of ``linkage``; raises DefinitionError saying what is missing (a tree
        that is not a biped, or legs that are not mirror images)."""
        if not isinstance(linkage, Linkage):
            raise DefinitionTypeError(
                f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
            )
        swap = swap_legs(linkage, swing)
        # The swap turns the stance leg's links up (+pi) and the swing leg's down (-pi) and
        # leaves the upper body; each leg is a chain, ordered here by depth in the tree.
        depth = [len(linkage.ancestors(i)) for i in range(linkage.n)]
        offsets = swap.angle_offsets

        def leg(sign: float) -> tuple[str, ...]:
            members = [i for i in range(linkage.n) if offsets[i] * sign > 0]
            return tuple(linkage.names[i] for i in sorted(members, key=depth.__getitem__))

        stance, swing_leg = leg(1.0), leg(-1.0)
        upper = tuple(name for name in linkage.names if name not in {*stance, *swing_leg})
        return cls(linkage, swap, stance, swing_leg, upper)

    # ---- the legs' links and the feet ------------------------------------------------
    @property
    def stance_shank(self) -> str:
        """The stance leg's link at the foot (the root)."""
        return self.stance_leg[0]

    @property
    def stance_thigh(self) -> str:
        """The stance leg's link at the hip."""
        return self.stance_leg[-1]

    @property
    def swing_thigh(self) -> str:
        """The swing leg's link at the hip."""
        return self.swing_leg[0]

    @property
    def swing_shank(self) -> str:
        """The swing leg's link at the foot."""
        return self.swing_leg[-1]

    def feet(self, friction: float | None = None) -> tuple[Contact, Contact]:
        """(stance foot, swing foot) as contacts with ``friction``: H0, the start of the
        root (named ``<root>_start``), and the end of the swing leg's last link."""
        return (
            Contact.at_root(self.linkage, friction),
            Contact(LinkPoint(self.swing_leg[-1]), friction=friction),
        )

    def _two_link_legs(self, what: str) -> None:
        if len(self.stance_leg) != 2:
            raise DefinitionError(
                f"`linkage`: {what} needs legs of two links (shank, thigh); this biped's legs "
                f"have {len(self.stance_leg)} ({', '.join(self.stance_leg)}); give the guess "
                "and postures of its own"
            )

    # ---- geometry ----------------------------------------------------------------------
    def length(self, name: str) -> float:
        return self.linkage.links[self.linkage.index(name)].length

    @property
    def leg_length(self) -> float:
        """The stance leg's links end to end (shank plus thigh), m."""
        return math.fsum(self.length(name) for name in self.stance_leg)

    @property
    def legs(self) -> tuple[str, ...]:
        """Every leg link: the stance leg up, then the swing leg down."""
        return (*self.stance_leg, *self.swing_leg)

    def index(self, name: str) -> int:
        return self.linkage.index(name)

    @property
    def total_mass(self) -> float:
        """kg."""
        return math.fsum(link.mass for link in self.linkage.links)

    @staticmethod
    def _two_links(start: complex, end: complex, first: float, second: float, turn: int):
        """Angles of a two-link chain from ``start`` to ``end`` with its joint on the side
        ``turn`` (-1: clockwise of the line start-end, +1: counter-clockwise)."""
        reach = abs(end - start)
        if reach > first + second or reach < abs(first - second):
            raise DefinitionError(
                f"`step_length`: a leg of {first:g} + {second:g} m cannot reach from "
                f"{start:.3g} to {end:.3g} ({reach:.3g} m); shorten the step"
            )
        direction = cmath.phase(end - start)
        cosine = (first**2 + reach**2 - second**2) / (2.0 * first * reach)
        angle = direction + turn * math.acos(min(1.0, max(-1.0, cosine)))
        joint = start + first * cmath.exp(1j * angle)
        return angle, cmath.phase(end - joint)

    def posture(self, hip: complex, swing_foot: complex, trunk: float = HALF_PI) -> np.ndarray:
        """Angles (n,) rad of the biped standing on its stance foot at the origin with the hip
        at ``hip`` and the swing foot at ``swing_foot`` (complex, m), knees ahead of the legs'
        lines (walking to +x), every upper-body link at the angle ``trunk`` (rad)."""
        self._two_link_legs("a walking posture")
        psi = np.full(self.linkage.n, float(trunk))
        shank, thigh = self._two_links(
            0j, hip, self.length(self.stance_shank), self.length(self.stance_thigh), -1
        )
        upper, lower = self._two_links(
            hip, swing_foot, self.length(self.swing_thigh), self.length(self.swing_shank), +1
        )
        for name, value in zip(self.legs, (shank, thigh, upper, lower), strict=True):
            psi[self.index(name)] = value
        return psi

    def step_law(
        self,
        step_length: float,
        step_time: float,
        clearance: float = 0.05,
        extension: float = EXTENSION,
    ) -> GaitLaw:
        """The law (22) fitted to one step (see the module docstring); its period is
        2 ``step_time`` and [0, step_time] is the step.

        ``clearance``: the swing foot's height at mid-step, m; ``extension``: hip-to-foot
        distance at heel strike as a fraction of the leg length (knees slightly bent).
        """
        step_length = check_positive("step_length", step_length, "m")
        step_time = check_positive("step_time", step_time, "s")
        reach = extension * self.leg_length
        if step_length / 2.0 >= reach:
            raise DefinitionError(
                f"`step_length`: {step_length:g} m is too long for legs of "
                f"{self.leg_length:g} m (at most about {2 * reach:.3g} m with the hip between "
                "the feet); shorten the step"
            )
        height = math.sqrt(reach**2 - (step_length / 2.0) ** 2)
        strike = self.posture(complex(step_length / 2.0, height), complex(step_length, 0.0))
        middle = self.posture(complex(0.0, reach), complex(0.0, clearance))
        start, _ = self.swap.map_state(strike, np.zeros_like(strike))
        center = 0.5 * (start + strike)
        along = 0.5 * (start - strike)
        across = center - middle
        zeta = np.hypot(along, across)
        varpi = np.arctan2(along, across)
        return GaitLaw(2.0 * step_time, zeta, varpi, center, name="step")


__all__ = ["Biped"]
