"""How decisive is the heel strike? The touchdown's sensitivity to a millimetre of error.

    python examples/benchmarks/touchdown.py            # the six-link default step, 8 variants
    python examples/benchmarks/touchdown.py --quick    # three variants

A drive controller tracks the planned motion with an error of a few millimetres. The heel
strike happens where the real foot meets the ground: a foot that runs 1 mm low touches down
when the plan's foot is 1 mm up, before T; a foot 1 mm high touches down after T (the plan's
foot continued past T with its velocity and acceleration at T). A foot that grazes in, nearly
tangent to the ground, moves that instant by tens of milliseconds per millimetre and the step
lengthens by the foot's forward speed times that; a decisive touchdown moves it by
1 mm / v_down.

For each variant of the default walking step (0.5 m in 0.5 s, Hermite-Simpson N = 30) this
prints the cost, the landing foot's velocity at T, its height 10 and 20 ms before T, and the
touchdown shifts for errors of 1, 2 and 4 mm (early for a low foot, late for a high one, ms)
with the step-length change of the worst 2 mm shift (mm). Variants: the touchdown speed
v_td (the heel-strike row vy(T) <= -v_td) with and without the clearance profile's approach
term v_td (T - t) exp(-((T - t) / w)^4) for several windows w. The defaults of
``problems.walking.step`` (v_td = 0.3 m/s, w = 30 ms) were chosen from this table.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from problems import walking_step

ERRORS_MM = (1.0, 2.0, 4.0)


def touchdown_shifts(step, gait, errors_m):
    """(early (ms), late (ms)) touchdown shifts for foot height errors ``errors_m`` (m):
    early, the last time before T at which the planned foot is that high; late, when the
    foot continued past T with its velocity v and acceleration a at T has come down that far
    further (-v tau - a tau^2 / 2 = error)."""
    T = gait.duration
    times = np.linspace(0.0, T, 20001)
    x, xdot, _ = gait.solution.motion(times)
    n = step.linkage.n
    psi, dpsi, ddpsi = x[:, :n], x[:, n:], xdot[:, n:]
    height = step.foot.position(psi).imag
    velocity = step.foot.velocity(psi[-1:], dpsi[-1:])
    acceleration = step.foot.acceleration(psi[-1:], dpsi[-1:], ddpsi[-1:])
    v, a = float(np.imag(velocity).ravel()[0]), float(np.imag(acceleration).ravel()[0])
    forward = float(np.real(velocity).ravel()[0])
    early, late = [], []
    for error in errors_m:
        above = np.flatnonzero(height >= error)
        early.append(T - times[above[-1]] if above.size else T)
        # -v tau - a tau^2 / 2 = error, the smallest positive root
        roots = np.roots([-a / 2, -v, -error])
        positive = [r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0]
        late.append(min(positive) if positive else np.inf)
    return np.array(early), np.array(late), v, forward, height, times


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="three variants")
    args = parser.parse_args(argv)
    variants = [
        ("grazing: v_td 0, no approach", 0.0, None),
        ("v_td 0.1, no approach", 0.1, None),
        ("v_td 0.2, no approach", 0.2, None),
        ("v_td 0.3, no approach", 0.3, None),
        ("v_td 0.3, window 10 ms", 0.3, 0.010),
        ("v_td 0.3, window 20 ms", 0.3, 0.020),
        ("v_td 0.3, window 30 ms (default)", 0.3, 0.030),
        ("v_td 0.2, window 20 ms", 0.2, 0.020),
        ("v_td 0.5, window 20 ms", 0.5, 0.020),
    ]
    if args.quick:
        variants = [variants[0], variants[3], variants[6]]
    errors = np.array(ERRORS_MM) / 1000.0
    head = (
        f"{'variant':32s} {'cost':>8s} {'/graze':>6s} {'iter':>4s} {'s':>5s} "
        f"{'vy(T)':>6s} {'vx(T)':>6s} "
        f"{'h-10ms':>6s} {'h-20ms':>6s} "
        + " ".join(f"{f'early{e:g}':>7s}" for e in ERRORS_MM)
        + " "
        + " ".join(f"{f'late{e:g}':>6s}" for e in ERRORS_MM)
        + f" {'dL(2mm)':>7s}"
    )
    print("Touchdown of the six-link default step (0.5 m in 0.5 s, HS N = 30): heights in mm,")
    print("shifts in ms for a foot 1/2/4 mm low (early) or high (late), dL: step length change")
    print("of the larger 2 mm shift, mm (the foot's forward speed at T times it)")
    print(head)
    print("-" * len(head))
    baseline = None
    for label, speed, tau in variants:
        # no approach term: a window so short that the term vanishes but at T
        step = walking_step(touchdown_speed=speed, approach_time=1e-9 if tau is None else tau)
        start = time.perf_counter()
        gait = step.solve(progress=False, hold_limits=False, raise_on_failure=False, verify=False)
        seconds = time.perf_counter() - start
        early, late, v, forward, height, times = touchdown_shifts(step, gait, errors)
        baseline = gait.cost if baseline is None else baseline
        at = [height[np.searchsorted(times, gait.duration - d)] for d in (0.010, 0.020)]
        change = forward * max(early[1], late[1]) * 1000.0
        print(
            f"{label:32s} {gait.cost:8.2f} {gait.cost / baseline:6.3f} "
            f"{gait.solution.iterations:4d} {seconds:5.2f} "
            f"{v:6.3f} {forward:6.2f} {at[0] * 1000:6.2f} {at[1] * 1000:6.2f} "
            + " ".join(f"{1000 * e:7.1f}" for e in early)
            + " "
            + " ".join(f"{1000 * e:6.1f}" for e in late)
            + f" {change:7.1f}"
        )
    print("(/graze: the cost over the grazing step's, the first row, same run)")
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
