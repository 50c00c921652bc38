"""The numbers the feedback guide (examples/feedback.md) quotes beside the closed-loop tables.

    python examples/benchmarks/feedback_checks.py              # about 2 minutes
    python examples/benchmarks/feedback_checks.py --weights    # + the weights' trade (~12 min)

Printed, all measured in this run:

1. the double-support step: the return map's exact Jacobian against central differences of
   the product's simulation (phase PD on both branches, references at 777 Hz off the control
   instants), the closed-loop and open-loop multipliers under the LQR, and the closed chain
   under the plan's torques (each quarter millisecond's midpoint) against the plan over 20 ms;
2. the fixed-base gait: the closed loop's orbit against the plan's start, MuJoCo's orbit
   against the product's (when MuJoCo is installed), the multipliers;
3. with ``--weights``: three sets of LQR weights on the default step, each with its largest
   multiplier and gain, whether the rigid model survives a start 0.02 rad off, the largest
   pushes, and the MuJoCo run on a ground 5 mm higher (when MuJoCo is installed).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))

from reference.checks import central_jacobian  # the tests' own difference oracle

from problems import periodic_gait, walking_step
from problems.control.feedback import PUSH_STEPS, design_feedback
from problems.control.linearisation import fixed_point
from problems.control.lqr import LqrWeights, SwitchedLQR, linearise_double_support
from problems.control.simulation import Disturbances, Plant, largest_push, simulate_walking
from problems.control.tracking import GaitReference, PhasePD
from problems.pinned.feedback import (
    closed_loop_orbit,
    design_pinned_feedback,
    run_pinned_in_mujoco,
    simulate_periods,
)


def _mujoco():
    try:
        import mujoco  # noqa: F401 - whether the extra is there
    except ImportError:
        return None
    from problems.control.mujoco import run_in_mujoco

    return run_in_mujoco


def double_support() -> None:
    step = walking_step(double_support=0.05)
    gait = step.solve(progress=False)
    plant = Plant(step.linkage, mu=1.5)
    n = plant.n
    single, double = GaitReference.branches(gait, rate_hz=777.0)
    parents = step.linkage.parents
    pd = SwitchedLQR(PhasePD(single, parents, 1000.0, 60.0), PhasePD(double, parents, 1000.0, 60.0))
    options = {"step_time": step.step_time, "step_length": step.step_length}
    found = fixed_point(plant, pd, single.states[0], double_support=double, **options)

    def next_start(x):
        return simulate_walking(
            x, pd, steps=1, linkage=step.linkage, mu=1.5, check_contacts=False,
            lift_off=lambda y: double.phase(y[:n]) - 1.0, **options,
        ).end  # fmt: skip

    difference = central_jacobian(next_start, found.start, 1e-7)
    error = np.abs(difference - found.jacobian).max() / np.abs(found.jacobian).max()
    print("double-support step (0.05 s), ground mu 1.5:")
    print(f"  return map's exact Jacobian against central differences: {error:.1e} relative "
          f"(phase PD, whose own largest |lambda| is {found.spectral_radius:.3f})")  # fmt: skip
    feedback = design_feedback(gait, ground_mu=1.5)
    loop = fixed_point(plant, feedback.controller, feedback.reference.states[0],
                       double_support=feedback.double[0], **options)  # fmt: skip
    along = linearise_double_support(plant, feedback.reference, feedback.double[0], 1e-3)
    print(f"  LQR: largest |lambda| closed loop {loop.spectral_radius:.3f}, open loop "
          f"{abs(along.open_loop_multipliers[0]):.3g}")  # fmt: skip
    fine = GaitReference.branches(gait, rate_hz=10000.0)[1]
    x = fine.at_time(0.0)[0]
    for k in range(80):
        x = np.asarray(plant.advance_double(x, fine.at_time((k + 0.5) * 2.5e-4)[1], 2.5e-4))
        x = x.ravel()
    drift = np.abs(x[:n] - fine.at_time(0.02)[0][:n]).max()
    print(f"  the closed chain under the plan's torques, 20 ms: {drift:.1e} rad from the plan")


def fixed_base(run_in_mujoco) -> None:
    gait = periodic_gait().solve(progress=False)
    feedback = design_pinned_feedback(gait)
    orbit = closed_loop_orbit(feedback)
    n = len(feedback.names)
    offset = np.abs(orbit.start[:n] - feedback.reference.states[0][:n]).max()
    print("fixed-base gait (HS N = 50):")
    print(f"  largest |lambda| open loop {abs(feedback.open_loop_multipliers[0]):.2g}, closed "
          f"loop {orbit.spectral_radius:.4f}; the orbit {1000 * offset:.2f} mrad from the "
          "plan's start")  # fmt: skip
    error = np.r_[np.full(n, 0.02), np.zeros(n)]
    product = simulate_periods(feedback, periods=6, initial=error)
    print(f"  a start 0.02 rad off, |psi - psi_plan(0)| at each period's start: "
          f"{np.array2string(product.deviation, precision=6)}")  # fmt: skip
    if run_in_mujoco is not None:
        engine = run_pinned_in_mujoco(feedback, periods=6, initial=error)
        apart = np.abs(engine.starts[-1][:n] - product.starts[-1][:n]).max()
        print(f"  MuJoCo: {np.array2string(engine.deviation, precision=6)}; its orbit "
              f"{1000 * apart:.2f} mrad from the product's")  # fmt: skip


def weights_trade(run_in_mujoco) -> None:
    step = walking_step()
    gait = step.solve(progress=False)
    n = step.linkage.n
    print("LQR weights on the default step (ground mu 1.0):")
    print(
        f"  {'angle rad':>9} {'rate rad/s':>10} {'torque N m':>10} {'|lambda|':>8} "
        f"{'max K':>8} {'start 0.02':>10} {'push fwd/back N s':>17} {'MuJoCo +5 mm':>12}"
    )
    for weights in (LqrWeights(), LqrWeights(0.05, 1.0, 50.0), LqrWeights(0.03, 0.3, 20.0)):
        feedback = design_feedback(gait, ground_mu=1.0, weights=weights)
        options = feedback.simulation_options
        start = feedback.reference.states[0]
        loop = fixed_point(feedback.plant, feedback.controller, start,
                           step_time=step.step_time, step_length=step.step_length)  # fmt: skip
        initial = Disturbances(initial=np.r_[np.full(n, 0.02), np.zeros(n)])
        rigid = simulate_walking(start, feedback.controller, steps=10, disturbances=initial,
                                 **options)  # fmt: skip

        def walk(disturbances, feedback=feedback, options=options, start=start):
            return simulate_walking(start, feedback.controller, steps=PUSH_STEPS,
                                    disturbances=disturbances, **options)  # fmt: skip

        forward, _ = largest_push(walk, direction=1.0, steps=PUSH_STEPS)
        back, _ = largest_push(walk, direction=-1.0, steps=PUSH_STEPS)
        engine = "-"
        if run_in_mujoco is not None:
            run = run_in_mujoco(feedback, steps=20, disturbances=Disturbances(ground_rise=0.005))
            engine = f"{run.walked}/20"
        print(f"  {weights.angle:9g} {weights.rate:10g} {weights.torque:10g} "
              f"{loop.spectral_radius:8.3f} {np.abs(feedback.gains.gains).max():8.3g} "
              f"{rigid.walked:>7}/10 {forward:8.1f} / {back:6.1f} {engine:>12}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", action="store_true", help="also the weights' trade")
    args = parser.parse_args()
    run_in_mujoco = _mujoco()
    double_support()
    fixed_base(run_in_mujoco)
    if args.weights:
        weights_trade(run_in_mujoco)


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
