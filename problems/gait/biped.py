"""A walking biped seen in a linkage: its legs, its upper body, walking postures and the gait
law (22) fitted to a step.

A biped here is what :func:`model.swap_legs` accepts: the root is the stance shank (from the
stance foot H0), its one child the stance thigh, and at the thigh's end (the hip) hang a
two-link swing leg mirroring the stance leg and any upper body. Angles follow the project's
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

from model.linkage import Linkage
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
    stance_shank, stance_thigh, swing_thigh, swing_shank : link names.
    upper_body : names of every other link (hanging at the hip, directly or not).
    """

    linkage: Linkage
    swap: Rerooting
    stance_shank: str
    stance_thigh: str
    swing_thigh: str
    swing_shank: str
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
        names = linkage.names
        stance_shank = names[0]
        stance_thigh = names[linkage.children[0][0]]
        swing_shank = swap.root_point.link
        swing_thigh = names[linkage.parents[linkage.index(swing_shank)]]
        legs = {stance_shank, stance_thigh, swing_thigh, swing_shank}
        upper = tuple(name for name in names if name not in legs)
        return cls(linkage, swap, stance_shank, stance_thigh, swing_thigh, swing_shank, upper)

    # ---- geometry ----------------------------------------------------------------------
    def length(self, name: str) -> float:
        return self.linkage.links[self.linkage.index(name)].length

    @property
    def leg_length(self) -> float:
        """Shank plus thigh, m."""
        return self.length(self.stance_shank) + self.length(self.stance_thigh)

    @property
    def legs(self) -> tuple[str, str, str, str]:
        return (self.stance_shank, self.stance_thigh, self.swing_thigh, self.swing_shank)

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
