"""A walking study: how the six-link walker's cost of transport and drive torques change with
speed (step length x step time), and a passive ankle against an actuated one.

    python examples/walking_study.py                     # 5 x 4 grid, N = 30, process pool
    python examples/walking_study.py --scheduler local   # the same on a Dask LocalCluster
    python examples/walking_study.py --quick             # 2 x 2 grid, N = 12 (the test suite)

Each point is solved warm-started from a solved neighbour; results go to the output folder
(default walking_study_out) as they arrive, so an interrupted run goes on where it stopped
when started again. Writes speed/ (the speed study: results.csv, solutions/, plots) and
ankle/ (the passive-ankle study).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from problems import Study
from problems.study.plots import save_plots


def ankle_step(ankle: str, step_length: float, N: int) -> dict:
    """The walking_step arguments of one point of the ankle study: a study's problem can be
    any function of the swept values (here a string axis) returning them, or a WalkingStep."""
    passive = ("stance_shank",) if ankle == "passive" else ()
    return {"step_length": step_length, "step_time": 0.5, "passive": passive, "N": N}


def peak_ankle_power(gait) -> float:
    """A user-defined output: the largest |M dpsi| at the stance ankle H0 over the nodes, W."""
    solution = gait.solution
    n = gait.problem.linkage.n
    return float(np.max(np.abs(solution.drives[:, 0] * solution.states[:, n])))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", default="walking_study_out", help="output folder")
    parser.add_argument("--workers", type=int, default=None, help="processes (default: cores)")
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address, or local")
    parser.add_argument("--quick", action="store_true", help="2 x 2 grid at N = 12")
    args = parser.parse_args(argv)
    folder = Path(args.output_dir)
    N = 12 if args.quick else 30
    if args.quick:
        lengths, times = np.array([0.4, 0.5]), np.array([0.45, 0.5])
    else:
        lengths, times = np.linspace(0.3, 0.6, 5), np.linspace(0.45, 0.6, 4)

    # 1. Speed: step length x step time, the six-link walking step of 'python -m problems walk'.
    speed = Study({"step_length": lengths, "step_time": times}, fixed={"N": N})
    result = speed.run(folder / "speed", workers=args.workers, scheduler=args.scheduler)
    print(f"{speed}: {result.run['points_per_minute']:.0f} points/min ({result.run['backend']})")
    print(f"{'step m':>6} {'time s':>6} {'speed':>6} {'CoT':>7} {'peak hip':>8} {'iter':>5}  start")
    for row in result.rows:
        print(
            f"{row['step_length']:6.3f} {row['step_time']:6.3f} {row.get('speed', np.nan):6.3f} "
            f"{row.get('cost_of_transport', np.nan):7.4f} "
            f"{row.get('peak_torque_stance_thigh', np.nan):8.1f} {row['iterations']:5d}  "
            f"{row['start'] or row['status']}"
        )
    cot = result.grid("cost_of_transport")  # (lengths, times), NaN where a point failed
    best = np.unravel_index(np.nanargmin(cot), cot.shape)
    print(
        f"lowest cost of transport {np.nanmin(cot):.4f} at {lengths[best[0]]:.3f} m in "
        f"{times[best[1]]:.3f} s ({lengths[best[0]] / times[best[1]]:.2f} m/s)"
    )

    # 2. A passive ankle against an actuated one, with a user-defined output.
    ankle = Study(
        {"ankle": ["actuated", "passive"], "step_length": lengths[:1] if args.quick else lengths},
        ankle_step,
        fixed={"N": N},
        outputs=(
            "cost",
            "cost_of_transport",
            "peak_torque",
            ("peak_ankle_power", peak_ankle_power),
        ),
    )
    compared = ankle.run(folder / "ankle", workers=args.workers, scheduler=args.scheduler)
    for row in compared.rows:
        print(
            f"{row['ankle']:>8} ankle, {row['step_length']:.3f} m: cost of transport "
            f"{row.get('cost_of_transport', np.nan):.4f}, peak ankle power "
            f"{row.get('peak_ankle_power', np.nan):.1f} W ({row['status']})"
        )

    for path in save_plots(result):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
