"""What the hold rounds' near restarts and the cap on the Hessian's regularisation change.

    ANTHROPOID_CACHE=/tmp/feetcache python examples/benchmarks/hold_restarts.py

1. Ten gait problems solved as ``step.solve()`` does (limits held at the 1 kHz samples,
   compiled functions from the disk cache): the re-solves' IPOPT iterations with the plain warm
   start (``planner.solver.NEAR_RESTART_IPOPT`` emptied for the run) and with the near
   restarts (the default), and the costs.
2. The step on feet's first solve from two guesses of its phase durations (shares of the step
   time: the default, and 0.45 / 0.30 / 0.25) with the planner's cap on the regularisation
   (``max_hessian_perturbation`` 1e4) and with IPOPT's own (1e20), each stopped after 60 s.
3. The walking step's closed loop in MuJoCo on a ground 1 cm lower (``pip install
   ".[mujoco]"``), 6 steps, from the plan's start and from seven starts perturbed by 1e-7 rad
   (a fixed seed): how many walk all 6.
"""

from __future__ import annotations

import dataclasses
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np

import planner.solver as solver_module
from planner import SolverError, solve
from problems import footed_step, footed_step_at, periodic_gait, walking_step
from problems.walking import footed

CASES = {
    "feet human": lambda: footed_step(),
    "feet flat-footed": lambda: footed_step(phases="flat-footed"),
    "feet toe-walking": lambda: footed_step(phases="toe-walking"),
    "feet 1.0 m/s": lambda: footed_step_at(1.0),
    "feet 0.6 m/s": lambda: footed_step_at(0.6),
    "walk": lambda: walking_step(),
    "walk DS 0.1 s": lambda: walking_step(double_support=0.1),
    "walk 0.8 m": lambda: walking_step(step_length=0.8),
    "walk precise": lambda: walking_step(accuracy="precise"),
    "fixed-base gait": lambda: periodic_gait(),
}


def _rounds(make) -> tuple[list[int], float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gait = make().solve(compiled=True)
    rounds = gait.solution.stats.get("sampled_limits", {}).get("rounds", [])
    return [r["iterations"] for r in rounds], gait.cost


def restarts() -> None:
    print("1. The hold rounds' re-solves: IPOPT iterations (first solve, then each re-solve)")
    head = f"{'problem':<18} {'plain warm start':<34} {'near restart':<34} {'cost change':>11}"
    print(head)
    print("-" * len(head))
    near = dict(solver_module.NEAR_RESTART_IPOPT)
    totals = [0, 0]
    for label, make in CASES.items():
        solver_module.NEAR_RESTART_IPOPT = {}
        try:
            plain, plain_cost = _rounds(make)
        finally:
            solver_module.NEAR_RESTART_IPOPT = near
        ours, cost = _rounds(make)
        totals[0] += sum(plain[1:])
        totals[1] += sum(ours[1:])
        print(f"{label:<18} {plain!s:<34} {ours!s:<34} {abs(cost / plain_cost - 1):11.1e}",
              flush=True)  # fmt: skip
    print(f"re-solve iterations in all: plain {totals[0]}, near {totals[1]} "
          f"({totals[1] / totals[0]:.2f}x)")  # fmt: skip


def regularisation_cap() -> None:
    print("2. The step on feet's first solve: the regularisation capped at 1e4 or not (60 s)")
    head = f"{'guessed shares':<18} {'cap':>6} {'result':<32} {'iterations':>10} {'wall s':>7}"
    print(head)
    print("-" * len(head))
    key = footed.SEQUENCES["human"]
    default = footed.SHARES[key]
    try:
        for shares in (default, (0.45, 0.30, 0.25)):
            footed.SHARES[key] = shares
            for cap in (1e4, 1e20):
                options = {"max_hessian_perturbation": cap, "max_wall_time": 60.0}
                start = time.perf_counter()
                try:
                    s = solve(footed_step().phases, progress=False, compiled=True,
                              accuracy_warning=None, options=options)  # fmt: skip
                    result, iterations = f"cost {s.cost:.8f}", s.iterations
                except SolverError as error:
                    result, iterations = error.status, error.iterations
                print(f"{'/'.join(f'{v:.2f}' for v in shares):<18} {cap:6.0e} {result:<32} "
                      f"{iterations:10d} {time.perf_counter() - start:7.2f}",
                      flush=True)  # fmt: skip
    finally:
        footed.SHARES[key] = default


def mujoco_lower_ground() -> None:
    try:
        from problems.control.feedback import design_feedback, disturbance_cases
        from problems.control.mujoco import run_in_mujoco
    except ImportError:
        print('3. skipped: MuJoCo is not installed (pip install ".[mujoco]")')
        return
    gait = walking_step().solve(progress=False)
    feedback = design_feedback(gait, ground_mu=1.0)
    base = disturbance_cases(feedback)["ground -1 cm"]
    rng = np.random.default_rng(1)
    walked = []
    for k in range(8):
        offset = np.zeros(2 * len(feedback.names)) if k == 0 else rng.standard_normal(
            2 * len(feedback.names)) * 1e-7  # fmt: skip
        disturbed = dataclasses.replace(base, initial=offset)
        run = run_in_mujoco(feedback, steps=6, disturbances=disturbed)
        walked.append(run.walked)
    print("3. The walking step in MuJoCo on a ground 1 cm lower, 6 steps: steps walked from the "
          f"plan's start, then from seven starts 1e-7 rad off: {walked} "
          f"({sum(w == 6 for w in walked)} of 8 walk all 6)")  # fmt: skip


def main() -> int:
    restarts()
    print()
    regularisation_cap()
    print()
    mujoco_lower_ground()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
