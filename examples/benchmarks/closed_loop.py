"""What the feedback of a walking step costs to design and to check, against its solve.

    python examples/benchmarks/closed_loop.py            # six-link and five-link, medians of 3
    python examples/benchmarks/closed_loop.py --repeat 1

For the default steps (0.5 m in 0.5 s, Hermite-Simpson N = 30) this times, in one run:
the solve (``WalkingStep.solve``, its hold rounds included); the design (the plan linearised
along its 1 kHz control instants, the strike's saltation matrix, the periodic Riccati
recursion); the closed loop's periodic gait and Floquet multipliers (``fixed_point``: maps
without their Jacobian while the loop contracts, then the exact return map at the fixed
point); one return map with its exact Jacobian and one without; 50 simulated steps in the
product's hybrid simulation; 20 steps in MuJoCo (when installed). The same for the six-link
step with a 0.05 s double support
(ground friction 1.5; in MuJoCo its feedback waits for the soft touchdown, see
run_in_mujoco) and for the paper's
fixed-base periodic gait (``problems.pinned.feedback``: the period's LQR, the closed loop's
orbit, 20 periods in the product and in MuJoCo). Ratios are to the solve's median of the
same problem in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from model import presets
from problems import walking_step
from problems.control.feedback import design_feedback
from problems.control.linearisation import fixed_point, return_map
from problems.control.simulation import simulate_walking


def _median(function, repeat):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def _rows(linkage, repeat: int, run_in_mujoco) -> list[tuple[str, float, str]]:
    step = walking_step(linkage)
    solve, gait = _median(lambda: step.solve(progress=False), repeat)
    rows = [("solve (HS N = 30, holds included)", solve, f"cost {gait.cost:.2f}")]
    design, feedback = _median(lambda: design_feedback(gait, ground_mu=1.0), repeat)
    rows.append(("design: linearise + periodic LQR", design,
                 f"{feedback.gains.cycles} Riccati sweeps"))  # fmt: skip
    options = {"step_time": step.step_time, "step_length": step.step_length}
    start = feedback.reference.states[0]
    plant, controller = feedback.plant, feedback.controller
    one, _ = _median(lambda: return_map(plant, controller, start, **options), repeat)
    rows.append(("one exact return map", one, ""))
    alone, _ = _median(
        lambda: return_map(plant, controller, start, jacobian=False, **options), repeat
    )
    rows.append(("one return map, P(x) alone", alone, ""))
    loop_time, loop = _median(lambda: fixed_point(plant, controller, start, **options), repeat)
    rows.append(("periodic gait + multipliers", loop_time,
                 f"largest |lambda| {loop.spectral_radius:.3f}"))  # fmt: skip
    walk_time, run = _median(
        lambda: simulate_walking(start, controller, linkage=step.linkage, mu=1.0, steps=50,
                                 **options), repeat)  # fmt: skip
    rows.append(("50 steps, product's simulation", walk_time, f"walked {run.walked}"))
    if run_in_mujoco is not None:
        engine_time, engine = _median(lambda: run_in_mujoco(feedback, steps=20), repeat)
        rows.append(("20 steps in MuJoCo", engine_time, f"walked {engine.walked}"))
    return rows


def _double_support_rows(repeat: int, run_in_mujoco) -> list[tuple[str, float, str]]:
    step = walking_step(double_support=0.05)
    solve, gait = _median(lambda: step.solve(progress=False), repeat)
    rows = [("solve (HS N = 30 + 12, holds incl.)", solve, f"cost {gait.cost:.2f}")]
    design, feedback = _median(lambda: design_feedback(gait, ground_mu=1.5), repeat)
    rows.append(("design: linearise + periodic LQR", design,
                 f"{feedback.gains.cycles} Riccati sweeps"))  # fmt: skip
    options = {"step_time": step.step_time, "step_length": step.step_length,
               "double_support": feedback.double[0]}  # fmt: skip
    start = feedback.reference.states[0]
    loop_time, loop = _median(
        lambda: fixed_point(feedback.plant, feedback.controller, start, **options), repeat
    )
    rows.append(("periodic gait + multipliers", loop_time,
                 f"largest |lambda| {loop.spectral_radius:.3f}"))  # fmt: skip
    walk_time, run = _median(
        lambda: simulate_walking(start, feedback.controller, steps=50,
                                 **feedback.simulation_options), repeat)  # fmt: skip
    rows.append(("50 steps, product's simulation", walk_time, f"walked {run.walked}"))
    if run_in_mujoco is not None:
        engine_time, engine = _median(lambda: run_in_mujoco(feedback, steps=20), repeat)
        rows.append(("20 steps in MuJoCo", engine_time, f"walked {engine.walked}"))
    return rows


def _pinned_rows(repeat: int, mujoco_installed: bool) -> list[tuple[str, float, str]]:
    from problems.pinned.feedback import (
        closed_loop_orbit,
        design_pinned_feedback,
        run_pinned_in_mujoco,
        simulate_periods,
    )
    from problems.pinned.gait import periodic_gait

    problem = periodic_gait()
    solve, gait = _median(lambda: problem.solve(progress=False), repeat)
    rows = [("solve (HS N = 50, holds included)", solve, f"cost {gait.cost:.2f}")]
    design, feedback = _median(lambda: design_pinned_feedback(gait), repeat)
    rows.append(("design: linearise + periodic LQR", design,
                 f"open loop |lambda| {abs(feedback.open_loop_multipliers[0]):.2g}"))  # fmt: skip
    orbit_time, orbit = _median(lambda: closed_loop_orbit(feedback), repeat)
    rows.append(("periodic orbit + multipliers (Newton)", orbit_time,
                 f"largest |lambda| {orbit.spectral_radius:.4f}"))  # fmt: skip
    sim_time, run = _median(lambda: simulate_periods(feedback, periods=20), repeat)
    rows.append(("20 periods, product's simulation", sim_time,
                 f"largest |psi - psi_ref| {run.deviation.max():.1e} rad"))  # fmt: skip
    if mujoco_installed:
        engine_time, engine = _median(lambda: run_pinned_in_mujoco(feedback, periods=20), repeat)
        rows.append(("20 periods in MuJoCo", engine_time,
                     f"largest |psi - psi_ref| {engine.deviation.max():.1e} rad"))  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (median)")
    args = parser.parse_args()
    try:
        import mujoco  # noqa: F401 - whether the extra is there

        from problems.control.mujoco import run_in_mujoco
    except ImportError:
        run_in_mujoco = None
    bipeds = {"six-link": presets.six_link_anthropoid, "five-link": presets.five_link_biped}
    head = f"{'biped':<10} {'what':<37} {'median s':>9} {'/ solve':>8}  result"
    print("Feedback of the default walking step: design and checks against the solve")
    print(f"(medians of {args.repeat}; the machine is shared: compare ratios in one run)")
    print(head)
    print("-" * (len(head) + 30))
    tables = {name: _rows(linkage(), args.repeat, run_in_mujoco)
              for name, linkage in bipeds.items()}  # fmt: skip
    tables["six, DS"] = _double_support_rows(args.repeat, run_in_mujoco)
    tables["fixed base"] = _pinned_rows(args.repeat, run_in_mujoco is not None)
    for name, rows in tables.items():
        solve = rows[0][1]
        for what, seconds, result in rows:
            print(f"{name:<10} {what:<37} {seconds:9.3f} {seconds / solve:8.2f}  {result}")


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
