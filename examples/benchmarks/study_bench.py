"""Study benchmark: a 7 x 7 grid of six-link walking steps (Hermite-Simpson, N = 30), points
per minute serial cold, serial warm-started, on a process pool and on a Dask LocalCluster.

    python examples/benchmarks/study_bench.py            # medians of 3 runs of each
    python examples/benchmarks/study_bench.py --quick    # smoke run: 2 x 2 grid, N = 12, once

The grid: step length 0.3..0.7 m (7) x step time 0.4..0.7 s (7), the default outputs (cost,
cost of transport, torques, friction use, accuracy estimate, verification), IPOPT's iteration
limit 500 per attempt (the command line's default). Each run goes to a fresh folder, so every
point is solved; a run's time is the wall time of ``Study.run`` including starting the pool or
the cluster. Rows:

* serial cold: one process, every point from the gait law (ordering "cold");
* serial warm: one process, continuation along lines of the step time (each point from its
  predecessor), with the primal point only, and with IPOPT's multipliers too;
* pool: the local process pool with 2 workers, ordering "lines" and "coarse";
* Dask: a LocalCluster of 2 single-threaded worker processes started for the run, "lines".

Printed: points per minute (median, and the best run, the least disturbed on a shared
machine), their ratios to serial cold, the wall and startup times, the processor time per
point (in the workers: what a point costs whatever else runs), IPOPT iterations over the
grid, the failed points, and how far each row's costs lie from serial warm (0 where the same
continuation ran: the transfer of warm starts between processes is exact); the load average
before and after.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

from problems import Study
from problems.study.backends import available_cores


def _axes(quick: bool) -> dict[str, np.ndarray]:
    if quick:
        return {"step_length": np.array([0.4, 0.5]), "step_time": np.array([0.45, 0.5])}
    return {"step_length": np.linspace(0.3, 0.7, 7), "step_time": np.linspace(0.4, 0.7, 7)}


def _run(study: Study, folder: Path, **options) -> dict:
    shutil.rmtree(folder, ignore_errors=True)
    result = study.run(folder, **options)
    costs = {row["point"]: row["cost"] for row in result.solved}
    cpu = sum(row["cpu_seconds"] for row in result.rows)
    return {
        **result.run,
        "costs": costs,
        "failed_points": [r["point"] for r in result.failed],
        "cpu": cpu,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each configuration")
    parser.add_argument("--quick", action="store_true", help="2 x 2 grid, N = 12, one run")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask row")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    N = 12 if args.quick else 30
    axes = _axes(args.quick)
    options = {"fixed": {"N": N}, "ipopt": {"max_iter": 500}}
    study = Study(axes, **options)
    with_multipliers = Study(axes, multipliers=True, **options)
    cases = [
        ("serial cold", study, {"workers": 1, "ordering": "cold"}),
        ("serial warm (primal)", study, {"workers": 1, "ordering": "lines"}),
        ("serial warm (+multipliers)", with_multipliers, {"workers": 1, "ordering": "lines"}),
        ("pool 2 workers, lines", study, {"workers": 2, "ordering": "lines"}),
        ("pool 2 workers, coarse", study, {"workers": 2, "ordering": "coarse"}),
    ]
    if not args.no_dask:
        cases.append(
            (
                "Dask LocalCluster 2, lines",
                study,
                {"workers": 2, "scheduler": "local", "ordering": "lines"},
            )
        )
    points = len(study)
    load = os.getloadavg()[0]
    print(
        f"study_bench: {'x'.join(str(len(v)) for v in axes.values())} grid ({points} points) of "
        f"six-link walking steps, hermite-simpson N = {N}; {available_cores()} cores; medians "
        f"of {repeat} run(s); load average {load:.2f} before",
        flush=True,
    )
    results = {}
    with tempfile.TemporaryDirectory(prefix="study-bench-") as scratch:
        for k in range(repeat):
            for label, which, run_options in cases:
                folder = Path(scratch) / f"{k}-{len(results)}"
                outcome = _run(which, folder, **run_options)
                results.setdefault(label, []).append(outcome)
                print(
                    f"  run {k + 1}: {label:<28} {outcome['seconds']:7.2f} s "
                    f"({outcome['startup_seconds']:.2f} s startup), "
                    f"{outcome['iterations']} iterations",
                    file=sys.stderr,
                    flush=True,
                )
    reference = results["serial warm (primal)"][-1]["costs"]
    base = statistics.median(r["points_per_minute"] for r in results["serial cold"])
    print()
    best_base = max(r["points_per_minute"] for r in results["serial cold"])
    print(
        f"{'configuration':<28} {'points/min':>10} {'ratio':>6} {'best':>6} {'ratio':>6} "
        f"{'wall s':>7} {'startup s':>9} {'CPU s/pt':>8} {'iterations':>10} {'it/point':>8} "
        f"{'failed':>6} {'max |dcost|/cost':>16}"
    )
    for label, runs in results.items():
        rate = statistics.median(r["points_per_minute"] for r in runs)
        best = max(r["points_per_minute"] for r in runs)
        wall = statistics.median(r["seconds"] for r in runs)
        startup = statistics.median(r["startup_seconds"] for r in runs)
        cpu = statistics.median(r["cpu"] for r in runs) / points
        iterations = runs[-1]["iterations"]
        costs = runs[-1]["costs"]
        common = [p for p in costs if p in reference]
        spread = max((abs(costs[p] - reference[p]) / reference[p] for p in common), default=0.0)
        print(
            f"{label:<28} {rate:10.1f} {rate / base:6.2f} {best:6.1f} {best / best_base:6.2f} "
            f"{wall:7.2f} {startup:9.2f} {cpu:8.3f} {iterations:10d} {iterations / points:8.1f} "
            f"{len(runs[-1]['failed_points']):6d} {spread:16.1e}"
        )
    print(
        f"load average {os.getloadavg()[0]:.2f} after (the machine is shared: wall times move "
        "with it, iterations and CPU s per point hardly)"
    )
    cold = results["serial cold"][-1]["costs"]
    other = [
        p for p in cold if p in reference and abs(cold[p] - reference[p]) > 1e-6 * reference[p]
    ]
    print(
        f"\ncold and warm reach different local optima at {len(other)} of {points} points"
        + (
            ": " + ", ".join(f"{p} {cold[p]:.6f} cold / {reference[p]:.6f} warm" for p in other[:6])
            if other
            else ""
        )
    )
    lines = statistics.median(r["points_per_minute"] for r in results["pool 2 workers, lines"])
    coarse = statistics.median(r["points_per_minute"] for r in results["pool 2 workers, coarse"])
    print(
        f"ordering on the pool: lines {lines:.1f}, coarse {coarse:.1f} points/min "
        f"(coarse/lines {coarse / lines:.2f})"
    )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
