"""Human segment parameters from a published anthropometric table, and the foot built from it.

Source: D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Wiley,
2009, chapter 4: table 4.1 (segment mass as a fraction of body mass, centre of mass from the
proximal end as a fraction of the segment's length, radius of gyration about the centre of
mass as a fraction of the length; Dempster's cadaver data) and figure 4.1 (segment lengths as
fractions of body height H, after Drillis and Contini).

The seed paper's six-link scene (``scene.md``) is this table for a person of 1.75 m and 70 kg:
its shank is 0.246 H = 0.43 m and 0.0465 M = 3.3 kg with the centre of mass 0.433 of the way
from the knee, its thigh 0.245 H = 0.43 m and 0.100 M = 7.0 kg, 0.433 from the hip
(``tests/test_anthropometry.py`` checks it). The feet below complete that person.

The foot (Winter's segment: lateral malleolus to the head of the second metatarsal) is a rigid
body with three points that matter, in the foot's own frame with the ankle at the origin, x
forward and y up when the sole lies flat on the ground:

* the ankle hinge, 0.039 H above the sole (figure 4.1's ankle height);
* the ball of the foot (the heads of the metatarsals), where the foot pivots when the heel
  rises: the *toe* contact, 0.75 of the foot's length from the back of the heel;
* the *heel* contact, at the back of the heel; the ankle stands 0.20 of the foot's length
  ahead of it.

The foot's length heel to tip is 0.152 H (figure 4.1); the toes beyond the ball are not a
separate body (the issue's walker pivots at the ball, as most walking models' feet do). The
two placements along the sole (0.20, 0.75) are this module's choice, not the table's: typical
values for an adult foot, named below so that a user can change them. The centre of mass lies
halfway between the ankle and the ball (Winter: 0.50 of the segment), the radius of gyration
0.475 of that segment's length.
"""

from __future__ import annotations

import cmath
from dataclasses import dataclass

from planner.errors import DefinitionError, check_positive

# ---- Winter (2009), table 4.1 and figure 4.1 ---------------------------------------------------
#: Segment mass / body mass.
FOOT_MASS, SHANK_MASS, THIGH_MASS = 0.0145, 0.0465, 0.100
#: Centre of mass from the proximal end / segment length (shank: from the knee; thigh: from
#: the hip; foot: from the ankle towards the second metatarsal head).
FOOT_COM, SHANK_COM, THIGH_COM = 0.50, 0.433, 0.433
#: Radius of gyration about the centre of mass / segment length.
FOOT_GYRATION, SHANK_GYRATION, THIGH_GYRATION = 0.475, 0.302, 0.323
#: Lengths / body height: ankle height, knee to ankle, hip to knee, foot heel to tip.
ANKLE_HEIGHT, SHANK_LENGTH, THIGH_LENGTH, FOOT_LENGTH = 0.039, 0.246, 0.245, 0.152

# ---- this module's placements along the sole (see the module's docstring) ----------------------
#: The ankle ahead of the back of the heel, fraction of the foot's length.
ANKLE_FROM_HEEL = 0.20
#: The ball of the foot (the toe contact) ahead of the back of the heel, fraction of the length.
BALL_FROM_HEEL = 0.75


@dataclass(frozen=True)
class FootGeometry:
    """A foot of a person of ``height`` m and ``mass`` kg (Winter's table; see the module).

    Points are complex numbers in the foot's frame, m: the ankle at 0, x forward, y up when
    the sole is flat. ``heel`` and ``toe`` (the ball) lie on the sole, y = -ankle height.
    """

    height: float = 1.75
    mass: float = 70.0
    ankle_from_heel: float = ANKLE_FROM_HEEL
    ball_from_heel: float = BALL_FROM_HEEL

    def __post_init__(self) -> None:
        check_positive("height", self.height, "m")
        check_positive("mass", self.mass, "kg")
        if not 0.0 <= self.ankle_from_heel < self.ball_from_heel <= 1.0:
            raise DefinitionError(
                f"`ankle_from_heel`, `ball_from_heel`: need 0 <= ankle < ball <= 1 (fractions of "
                f"the foot's length from the back of the heel), got {self.ankle_from_heel!r}, "
                f"{self.ball_from_heel!r}"
            )

    @property
    def length(self) -> float:
        """Heel to tip, m."""
        return FOOT_LENGTH * self.height

    @property
    def ankle_height(self) -> float:
        """The ankle hinge above the sole, m."""
        return ANKLE_HEIGHT * self.height

    @property
    def heel(self) -> complex:
        """The back of the heel from the ankle, m."""
        return complex(-self.ankle_from_heel * self.length, -self.ankle_height)

    @property
    def toe(self) -> complex:
        """The ball of the foot (the toe contact) from the ankle, m."""
        return complex((self.ball_from_heel - self.ankle_from_heel) * self.length,
                       -self.ankle_height)  # fmt: skip

    @property
    def sole(self) -> float:
        """Heel to ball, m: the part of the sole that carries the foot."""
        return abs(self.toe - self.heel)

    @property
    def segment(self) -> float:
        """Ankle to ball, m: the link's length (Winter's segment, to the metatarsal heads)."""
        return abs(self.toe)

    @property
    def segment_mass(self) -> float:
        """kg."""
        return FOOT_MASS * self.mass

    @property
    def inertia(self) -> float:
        """About the centre of mass, kg m^2: m (0.475 l)^2."""
        return self.segment_mass * (FOOT_GYRATION * self.segment) ** 2

    @property
    def flat_angle_from_ankle(self) -> float:
        """The absolute angle of the link ankle -> ball when the sole is flat, rad (< 0: the
        ball lies below the ankle)."""
        return cmath.phase(self.toe)

    def point_on_link(self, point: complex, from_ankle: bool) -> tuple[float, float]:
        """(along, lateral), fractions of :attr:`segment`, of a point of the foot (its frame,
        from the ankle) on the link that runs ankle -> ball (``from_ankle``) or ball -> ankle."""
        start, axis = (0j, self.toe) if from_ankle else (self.toe, -self.toe)
        local = (point - start) / axis  # the axis as the unit, its normal to the left
        return float(local.real), float(local.imag)


__all__ = ["FootGeometry"]
