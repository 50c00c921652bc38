"""The speeds, step lengths and step times of a transition's steps: a linear ramp of speed
from one end to the other, each step at :func:`problems.walking.footed.step_at_speed`."""

from __future__ import annotations

from problems.walking.footed import step_at_speed


def end_speed(end) -> float:
    """A transition end's speed, m/s: a gait's, or 0 for quiet standing (a string)."""
    return 0.0 if isinstance(end, str) else float(end.speed)


def speed_ramp(start, end, k: int) -> list[tuple[float, float, float]]:
    """(speed m/s, step length m, step time s) of each of k steps from ``start`` to ``end``
    (gaits, or quiet standing given as a string): step j of k at v_a + (v_b - v_a) j / k; the
    last step into a gait takes that gait's length and time; a step at rest (a stop's last)
    has length 0 and the time of the ramp's first speed."""
    v_a, v_b = end_speed(start), end_speed(end)
    first = abs(v_b - v_a) / k
    plan = []
    for j in range(1, k + 1):
        v = v_a + (v_b - v_a) * j / k
        if j == k and not isinstance(end, str):
            length, duration = end.problem.step_length, end.problem.step_time
        elif v > 0:
            length, duration = step_at_speed(v)
        else:
            length, duration = 0.0, step_at_speed(first)[1]
        plan.append((v, length, duration))
    return plan


__all__ = ["end_speed", "speed_ramp"]
