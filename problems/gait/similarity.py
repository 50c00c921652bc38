"""Walking defaults by dynamic similarity: what a walker is not told, it gets in its own units.

Two walkers whose lengths differ by a factor and whose gravity differs by another walk the
same way when every length is measured in leg lengths L, every time in sqrt(L / g) and
every speed in sqrt(g L) (the Froude number of a walk, v / sqrt(g L), is what people and
animals of all sizes keep when they walk alike; Alexander 1984). The walking problems'
defaults are stated here in those units, each the value they were tuned with on the seed
paper's six-link walker (0.86 m legs under g = 9.81 m/s^2), so that a walker scaled in size
or in gravity by any factor, given its step in the same units, solves to the same
dimensionless optimum; the six-link walker gets the numbers it always had.

Before (a fixed 0.03 s approach window, a touchdown speed growing linearly with the leg, and
nominal rates of 3 rad/s whatever the walker), with the step, the clearance and the drives
scaled by hand (measured with a throwaway script on the code before): a walker 1e-3 the size
(step 0.016 s) was reported infeasible after 313 iterations, one under 1000 g after 768, a
walker 100 times the size cost 2.76 times what similarity predicts and one under 1e-3 g 8.08
times, and one 1000 times the size failed its own check (its heel strike at 300 m/s held to
1e-6 m/s). Now each solves to the six-link's dimensionless optimum within 2e-7 and verifies
(``tests/extremes.py``'s scaled walkers; ``examples/benchmarks/similarity.py`` prints them).

The drives' limit (``torque_limit``, N m) and the step (length, time) are the user's data,
not defaults of the method: they do not scale here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The walker the defaults were tuned on: the six-link scene's legs, m, and gravity, m/s^2.
REFERENCE_LEG, REFERENCE_GRAVITY = 0.86, 9.81
#: The landing foot's least downward speed at heel strike, in sqrt(g L): 0.3 m/s for the
#: reference walker, a touchdown that a tracking error of a millimetre moves by about 3 ms
#: (1 mm / 0.3 m/s) instead of 10-30 ms at the 0.05-0.10 m/s of a grazing foot
#: (examples/benchmarks/touchdown.py measures the trade).
TOUCHDOWN_SPEED = 0.3 / math.sqrt(REFERENCE_GRAVITY * REFERENCE_LEG)
#: Window w of the clearance profile's approach term v_td (T - t) exp(-((T - t) / w)^4), in
#: sqrt(L / g): 0.03 s for the reference walker. In its last ~0.7 w the foot stays above the
#: line coming down into the landing point at v_td, so a foot that runs d low touches down at
#: most about d / v_td early (3.3 ms per mm at 0.3 m/s); the term is largest 0.71 w before T
#: (0.55 v_td w: 5 mm) and gone by 1.5 w. With the touchdown speed: touchdown shifts 2.5 /
#: 5.1 / 11.6 ms early and 2.3 / 4.5 / 8.5 ms late for 1 / 2 / 4 mm of error, against 18 /
#: 32 / 45 and 7 / 12 / 19 ms for the grazing step, for 2 % more cost
#: (examples/benchmarks/touchdown.py).
APPROACH_TIME = 0.03 / math.sqrt(REFERENCE_LEG / REFERENCE_GRAVITY)
#: Mid-swing clearance of the swing foot, in leg lengths: 0.05 m for the reference walker.
CLEARANCE = 0.05 / REFERENCE_LEG


def _rounded(value: float) -> float:
    """A default as a person reads it: 12 significant digits (the reference walker's 0.3 m/s
    is 0.3, not 0.30000000000000004)."""
    return float(f"{value:.12g}")


@dataclass(frozen=True)
class WalkerScales:
    """The units of a walker: ``leg`` (m, hip to the foot's contact point) and ``gravity``
    (m/s^2); its time sqrt(L / g), s, and speed sqrt(g L), m/s; and the walking defaults in
    them (see the module)."""

    leg: float
    gravity: float

    @property
    def time(self) -> float:
        return math.sqrt(self.leg / self.gravity)

    @property
    def speed(self) -> float:
        return math.sqrt(self.gravity * self.leg)

    @property
    def touchdown_speed(self) -> float:
        """The default touchdown speed, m/s."""
        return _rounded(TOUCHDOWN_SPEED * self.speed)

    @property
    def approach_time(self) -> float:
        """The default approach window, s."""
        return _rounded(APPROACH_TIME * self.time)

    @property
    def clearance(self) -> float:
        """The default mid-swing clearance, m."""
        return _rounded(CLEARANCE * self.leg)

    @property
    def relative(self) -> dict[str, float]:
        """This walker's length, speed and time units over the reference walker's (the
        factors by which :func:`problems.verify_gait` scales its tolerances in m, m/s and s)."""
        reference = WalkerScales(REFERENCE_LEG, REFERENCE_GRAVITY)
        return {
            "length": self.leg / reference.leg,
            "speed": self.speed / reference.speed,
            "time": self.time / reference.time,
        }


__all__ = ["APPROACH_TIME", "CLEARANCE", "TOUCHDOWN_SPEED", "WalkerScales"]
