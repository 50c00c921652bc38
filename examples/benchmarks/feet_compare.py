"""What feet change: the walking step on feet against the point-foot step, at three speeds.

    python examples/benchmarks/feet_compare.py           # 0.6, 1.0, 1.4 m/s
    python examples/benchmarks/feet_compare.py --quick   # 1.0 m/s only

The same body (the six-link scene; with feet, Winter's feet added: +2.0 kg) at the same
speeds: step length 0.5 (v / 1 m/s)^(1/2) m and step time length / v (both grow with
speed, as in human walking), the same ground (mu 0.8), drives |M| <= 150 N m, the same
objective (the integral of the drives' sum M^2; seven drives with feet, both ankles, against
six), each plan verified at every sample of its 1 kHz file (``verify_gait``).

* **point foot**: ``walking_step(L, T)``: single support on a pinned foot whose ankle torque
  keeps its centre of pressure on a 0.20 m sole (the foot stays flat: no heel rise), heel
  strike and leg swap in one instant;
* **feet**: ``footed_step(L, T)`` (``problems.walking.footed``): flat foot, heel rise on the
  ball, heel strike, a double support rolling the front foot down, toe-off; phase durations
  free;
* **flat-footed** and **toe-walking**: ``footed_step(L, T, phases=...)``, the same feet
  walking other contact sequences: no heel rise (the stance foot flat until toe-off, flat
  under the rear leg in the double support), or on the balls of the feet (the swing ball
  strikes and holds).

Per plan: cost, cost of transport (positive drive work / (m g L)), positive work per step,
peak |M| at the ankles, the knees and the hip (the largest over both legs; at the hip the
swing thigh's and the torso's torques), and one leg's
vertical ground reaction through its stance, from its heel strike to its toe-off: its peaks
in the first and last halves and the valley between them, in body weights (a double hump:
two peaks above the valley), and the ankle's push-off: the largest positive power of the
stance ankle (W), when (% of the stance) and its positive work (J).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

from planner import AccuracyWarning, SampleLimitError, SolverError
from problems import walking_step
from problems.gait.problem import joint_rates
from problems.walking.footed import footed_step, push_off, step_at_speed

SPEEDS = (0.6, 1.0, 1.4)
#: The feet's other contact sequences, planned beside the human cycle.
OTHER_SEQUENCES = ("flat-footed", "toe-walking")


def point_foot_stance(gait) -> dict[str, np.ndarray]:
    """The stance leg of a point-foot step (single support only): time from heel strike,
    ground force on the stance foot, ankle power M_0 dpsi_0."""
    step = gait.problem
    n = step.linkage.n
    times = np.linspace(0.0, gait.duration, 801)
    x, xdot, u = gait.solution.motion(times)
    force = step.dynamics.ground_reaction(x[:, :n], x[:, n:], xdot[:, n:])
    rates = joint_rates(step.linkage, x[:, n:])
    return {"time": times, "force": force, "ankle_power": u[:, 0] * rates[:, 0]}


def humps(time: np.ndarray, fy: np.ndarray) -> tuple[float, float, float]:
    """(first-half peak, valley between the peaks, second-half peak) of fy (K,)."""
    middle = 0.5 * (time[0] + time[-1])
    first, second = (
        np.argmax(np.where(time <= middle, fy, -np.inf)),
        np.argmax(np.where(time > middle, fy, -np.inf)),
    )
    valley = float(np.min(fy[first : second + 1]))
    return float(fy[first]), valley, float(fy[second])


def measure(gait, stance, label: str) -> dict:
    step = gait.problem
    linkage, biped = step.linkage, step.biped
    weight = biped.total_mass * linkage.gravity
    peaks = gait.summary()["peak_torque"]  # M_i acts at the start hinge of link i

    def peak(links) -> float:
        return max(peaks[name] for name in links)

    stance_leg, swing_leg = biped.stance_leg, biped.swing_leg
    # ankles: the shanks' starts on the stance side, the swing foot's start with feet
    ankle = peak([stance_leg[-2], *swing_leg[2:]])
    knee = peak([stance_leg[-1], swing_leg[1]])  # the thigh and the swing shank start there
    hip = peak([linkage.names[c] for c in linkage.children[linkage.index(stance_leg[-1])]])
    fy = stance["force"].imag / weight
    first, valley, second = humps(stance["time"], fy)
    push = push_off(stance)
    report = gait.verify()
    return {
        "label": label,
        "cost": gait.cost,
        "cot": gait.cost_of_transport,
        "work": gait.positive_work,
        "ankle": ankle,
        "knee": knee,
        "hip": hip,
        "humps": (first, valley, second),
        "push": (push["power"], 100.0 * push["at"], push["work"]),
        "verified": report.ok,
        "failures": [c.name for c in report.failures],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1.0 m/s only")
    args = parser.parse_args()
    speeds = (1.0,) if args.quick else SPEEDS
    rows, failed = [], []
    for speed in speeds:
        length, duration = step_at_speed(speed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            start = time.perf_counter()
            point = walking_step(step_length=length, step_time=duration).solve()
            point_seconds = time.perf_counter() - start
            start = time.perf_counter()
            feet = footed_step(step_length=length, step_time=duration).solve()
            feet_seconds = time.perf_counter() - start
            others = []
            for name in OTHER_SEQUENCES:
                start = time.perf_counter()
                try:
                    other = footed_step(step_length=length, step_time=duration,
                                        phases=name).solve()  # fmt: skip
                except (SolverError, SampleLimitError) as error:
                    # a sequence this body cannot walk at this speed is a result: printed
                    failed.append((speed, name, str(error).split(";")[0]))
                    continue
                others.append((other, other.stance(), name, time.perf_counter() - start))
        for gait, stance, label, seconds in (
            (point, point_foot_stance(point), "point foot", point_seconds),
            (feet, feet.stance(), "feet", feet_seconds),
            *others,
        ):
            row = measure(gait, stance, label)
            row.update(speed=speed, length=length, duration=duration, seconds=seconds)
            if label != "point foot":
                row["phases"] = dict(zip(gait.problem.sequence, gait.durations(), strict=True))
            rows.append(row)
    print("What feet change (six-link scene, the same speeds, objective and limits; medians: "
          "one solve each)")  # fmt: skip
    head = (
        f"{'v m/s':>5} {'L m':>5} {'T s':>5} {'model':<11} {'cost':>8} {'CoT':>6} {'W+ J':>6} "
        f"{'ankle':>6} {'knee':>6} {'hip':>6} {'Fy hump1':>8} {'valley':>6} {'hump2':>6} "
        f"{'push W':>7} {'at %':>5} {'W J':>5} {'solve s':>7} verified"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        first, valley, second = r["humps"]
        peak, when, work = r["push"]
        print(
            f"{r['speed']:5.1f} {r['length']:5.3f} {r['duration']:5.3f} {r['label']:<11} "
            f"{r['cost']:8.1f} {r['cot']:6.3f} {r['work']:6.1f} {r['ankle']:6.1f} "
            f"{r['knee']:6.1f} {r['hip']:6.1f} {first:8.2f} {valley:6.2f} {second:6.2f} "
            f"{peak:7.0f} {when:5.0f} {work:5.1f} {r['seconds']:7.2f} "
            + ("yes" if r["verified"] else "NO: " + ", ".join(r["failures"]))
        )
    print()
    for speed, name, reason in failed:
        print(f"{speed:5.1f} {name}: no plan ({reason})")
    print()
    print("feet: phase durations, s")
    for r in rows:
        if "phases" in r:
            print(f"  {r['speed']:.1f} m/s {r['label']:<11}: "
                  + ", ".join(f"{name} {d:.3f}" for name, d in r["phases"].items()))  # fmt: skip
    return 0 if all(r["verified"] for r in rows) else 1


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
