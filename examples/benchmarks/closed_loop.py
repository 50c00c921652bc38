"""What the feedback of a walking step costs to design and to check, against its solve.

    python examples/benchmarks/closed_loop.py            # six-link and five-link, medians of 3
    python examples/benchmarks/closed_loop.py --repeat 1

For the default steps (0.5 m in 0.5 s, Hermite-Simpson N = 30) this times, in one run:
the solve (``WalkingStep.solve``, its hold rounds included); the design (the plan linearised
along its 1 kHz control instants, the strike's saltation matrix, the periodic Riccati
recursion); the closed loop's periodic gait and Floquet multipliers (Newton on the exact
return map); one return map; 50 simulated steps in the product's hybrid simulation; 20 steps
in MuJoCo (when installed). Ratios are to the solve's median in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import time

from model import presets
from problems import walking_step
from problems.walking_feedback import design_feedback
from problems.walking_linearisation import fixed_point, return_map
from problems.walking_simulation import simulate_walking


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
    loop_time, loop = _median(lambda: fixed_point(plant, controller, start, **options), repeat)
    rows.append(("periodic gait + multipliers (Newton)", loop_time,
                 f"largest |lambda| {loop.spectral_radius:.3f}"))  # fmt: skip
    walk_time, run = _median(
        lambda: simulate_walking(start, controller, linkage=step.linkage, mu=1.0, steps=50,
                                 **options), repeat)  # fmt: skip
    rows.append(("50 steps, product's simulation", walk_time, f"walked {run.walked}"))
    if run_in_mujoco is not None:
        engine_time, engine = _median(lambda: run_in_mujoco(feedback, steps=20), repeat)
        rows.append(("20 steps in MuJoCo", engine_time, f"walked {engine.walked}"))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (median)")
    args = parser.parse_args()
    try:
        import mujoco  # noqa: F401 - whether the extra is there

        from problems.walking_mujoco import run_in_mujoco
    except ImportError:
        run_in_mujoco = None
    bipeds = {"six-link": presets.six_link_anthropoid, "five-link": presets.five_link_biped}
    head = f"{'biped':<10} {'what':<37} {'median s':>9} {'/ solve':>8}  result"
    print("Feedback of the default walking step: design and checks against the solve")
    print(f"(medians of {args.repeat}; the machine is shared: compare ratios in one run)")
    print(head)
    print("-" * (len(head) + 30))
    for name, linkage in bipeds.items():
        rows = _rows(linkage(), args.repeat, run_in_mujoco)
        solve = rows[0][1]
        for what, seconds, result in rows:
            print(f"{name:<10} {what:<37} {seconds:9.3f} {seconds / solve:8.2f}  {result}")


if __name__ == "__main__":
    main()
