"""The point-foot step with a double support walked in MuJoCo (issue #35, part 4), and what
its touchdown rule does.

    python examples/benchmarks/double_support_mujoco.py [--write]   # about 8 minutes

The default step (0.5 m in 0.5 s, Hermite-Simpson N = 30) with a double support of 0.05 s and
of 0.1 s, its feedback the periodic LQR through the held heel strike and the lift-off
(``design_feedback``, ground friction 1.5: the plan lifts its rear foot along its cone's
edge), walked 20 steps under each of the closed-loop check's disturbances:

Table 1: in the product's simulation (rigid ground, pinned feet, instantaneous impacts) and
in MuJoCo (soft contacts, soled feet; the double support's feedback held back for
``SOFT_SETTLE`` s after the touchdown and ramped in over ``SOFT_RAMP`` s, the rule the file's
law states) and, for the 0.05 s step, in MuJoCo with the feedback at once (the rigid
ground's law); the largest pushes at mid-step of the second step that the walker survives
for 10 steps (bisection to 0.5 N s).

Table 2: the settle swept on the 0.05 s step (ramp ``SOFT_RAMP``): the steps walked of 20 as
planned and 10 % heavier, the largest tracking error, and each step's double support in
MuJoCo (from the touchdown to the rear foot's lift-off; planned 0.05 s).

Table 3: the landing foot's horizontal speed at heel strike bounded (``walking_step(...,
landing_speed=)``) on the 0.05 s step: the plan's cost and its foot's speed before the
strike, the disturbances in the rigid model and in MuJoCo (settled), the largest slip of a
stance foot in MuJoCo as planned, the pushes.
"""

from __future__ import annotations

import sys

from problems import walking_step
from problems.control.feedback import design_feedback, disturbance_cases
from problems.control.lqr import SOFT_RAMP, SOFT_SETTLE
from problems.control.simulation import Disturbances, simulate_walking

GROUND_MU = 1.5
STEPS = 20
SETTLES = (0.0, 0.005, 0.01, 0.015, 0.02, 0.03)


LANDING_SPEEDS = (None, 1.0, 0.5)


def _feedback(double_support: float):
    gait = walking_step(double_support=double_support).solve(progress=False)
    return design_feedback(gait, ground_mu=GROUND_MU)


def _rigid_runs(feedback) -> dict:
    """The closed-loop check's disturbances, each walked 20 steps in the product's simulation."""
    start = feedback.reference.states[0]
    return {label: simulate_walking(start, feedback.controller, steps=STEPS,
                                    disturbances=disturbances, **feedback.simulation_options)
            for label, disturbances in disturbance_cases(feedback).items()}  # fmt: skip


def _walked(run) -> str:
    return f"{run.walked}/{STEPS}" + ("" if run.fell is None else " fell")


def battery_table() -> None:
    from problems.control.mujoco import mujoco_check, run_in_mujoco

    settle = f"{1000 * SOFT_SETTLE:g} ms, ramp {1000 * SOFT_RAMP:g} ms"
    print(f"Table 1: 20 steps under each disturbance; the rigid model, MuJoCo with the settle "
          f"({settle}), MuJoCo at once\n")  # fmt: skip
    print("| double support | case | product's simulation | MuJoCo, settled | MuJoCo, at once |")
    print("|---|---|---|---|---|")
    pushes = []
    for double_support in (0.05, 0.1):
        feedback = _feedback(double_support)
        rigid = _rigid_runs(feedback)
        settled = mujoco_check(feedback, steps=STEPS)
        at_once = None
        if double_support == 0.05:
            at_once = {
                label: run_in_mujoco(
                    feedback,
                    steps=STEPS,
                    disturbances=disturbances,
                    touchdown_settle=0.0,
                    touchdown_ramp=0.0,
                )
                for label, disturbances in disturbance_cases(feedback).items()
            }
        for label in disturbance_cases(feedback):
            name = "closed loop" if label == "plan" else label
            once = "" if at_once is None else _walked(at_once[label])
            print(f"| {double_support:g} s | {label} | {_walked(rigid[label])} | "
                  f"{_walked(settled.runs[name])} | {once} |")  # fmt: skip
        pushes.append((double_support, settled.pushes))
    print()
    for double_support, (forward, back) in pushes:
        print(f"largest pushes survived in MuJoCo with a {double_support:g} s double support: "
              f"forward {forward:.1f} N s, back {back:.1f} N s")  # fmt: skip
    print()


def settle_table() -> None:
    from problems.control.mujoco import run_in_mujoco

    feedback = _feedback(0.05)
    print("Table 2: the settle on the 0.05 s double support in MuJoCo (ramp "
          f"{1000 * SOFT_RAMP:g} ms)\n")  # fmt: skip
    print("| settle ms | as planned | 10 % heavier | largest tracking error rad | "
          "double support s (min-max) |")  # fmt: skip
    print("|---|---|---|---|---|")
    for settle in SETTLES:
        runs = [
            run_in_mujoco(
                feedback,
                steps=STEPS,
                disturbances=disturbances,
                touchdown_settle=settle,
                touchdown_ramp=SOFT_RAMP,
            )
            for disturbances in (Disturbances(), Disturbances(mass_scale=1.1))
        ]
        steps = runs[0].steps
        tracking = max((r.tracking for r in steps), default=float("nan"))
        spans = [r.double_support for r in steps]
        span = f"{min(spans):.3f}-{max(spans):.3f}" if spans else ""
        print(f"| {1000 * settle:g} | {_walked(runs[0])} | {_walked(runs[1])} | "
              f"{tracking:.3f} | {span} |")  # fmt: skip
    print()


def landing_table() -> None:
    from problems.control.mujoco import mujoco_check

    print("Table 3: the landing foot's horizontal speed at heel strike bounded, 0.05 s double "
          "support; each case: rigid model / MuJoCo settled, of 20 steps\n")  # fmt: skip
    columns = []
    for bound in LANDING_SPEEDS:
        step = walking_step(double_support=0.05, landing_speed=bound)
        gait = step.solve(progress=False)
        feedback = design_feedback(gait, ground_mu=GROUND_MU)
        n = len(feedback.names)
        before = feedback.reference.states[-1]  # the state before the held strike
        speed = complex(feedback.plant.foot.velocity(before[:n], before[n:]))
        columns.append((gait.cost, speed, _rigid_runs(feedback), mujoco_check(feedback, STEPS)))
    heads = ["free" if b is None else f"{b:g} m/s" for b in LANDING_SPEEDS]
    print("| landing speed bound | " + " | ".join(heads) + " |")
    print("|---" * (len(heads) + 1) + "|")
    print("| the plan's cost | " + " | ".join(f"{c[0]:.1f}" for c in columns) + " |")
    print("| foot before the strike (x, y), m/s | "
          + " | ".join(f"{c[1].real:+.2f}, {c[1].imag:+.2f}" for c in columns) + " |")  # fmt: skip
    for label in columns[0][2]:
        name = "closed loop" if label == "plan" else label
        cells = [f"{_walked(c[2][label])} / {_walked(c[3].runs[name])}" for c in columns]
        print(f"| {label} | " + " | ".join(cells) + " |")
    slips = [max((r.slip for r in c[3].runs["closed loop"].steps), default=float("nan"))
             for c in columns]  # fmt: skip
    print("| largest slip in MuJoCo as planned, mm | "
          + " | ".join(f"{1000 * v:.1f}" for v in slips) + " |")  # fmt: skip
    print(
        "| pushes in MuJoCo, forward / back, N s | "
        + " | ".join(f"{c[3].pushes[0]:.1f} / {c[3].pushes[1]:.1f}" for c in columns)
        + " |"
    )
    print()


def main() -> int:
    try:
        import mujoco  # noqa: F401 - whether the extra is there
    except ImportError:
        print('MuJoCo is not installed: pip install ".[mujoco]"')
        return 1
    battery_table()
    settle_table()
    landing_table()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
