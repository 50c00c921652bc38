"""The study machinery's throughput on the README's 63-point grid (issue #35's target: >= 1000
points a minute with the compiled cache warm), and where a point's time goes.

    python examples/benchmarks/study_throughput.py [--write]   # about 2 min

Table 1: ``python -m problems study --step-length-m 0.3:0.7:9 --step-time-s 0.4:0.7:7`` (the
walking step, Hermite-Simpson N = 30; each point warm-started from its neighbour along lines of
the step time; the process pool of 2 workers), each run into a fresh folder, with the compiled
NLP functions of the step's structure in the disk cache (compiled first when missing: the
cache of ``planner/native_nlp.py``) and interpreted (``ANTHROPOID_COMPILE=never``); points per
minute, IPOPT iterations per point, the ratio to the target.

Table 2: the same lines solved one point after another in this process (compiled), each piece
of a point timed as the study's worker runs it (``problems.study.point``): defining the step,
rebuilding the neighbour's solution as this point's guess (a transcription), IPOPT's first
solve and the hold rounds' re-solves (planner.hold_at_samples: the limits held between the
collocation points), the checks of the motion at the samples between the rounds, the rest of
the solve (transcriptions, the accuracy estimate, the verification at 1 kHz), the outputs and
the warm-start record; medians and totals over the warm points (the 9 cold line heads apart).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from problems.study.point import (
    PointSpec,
    _outputs,
    guess_from,
    trajectory_bytes,
    warm_record,
)

LENGTHS = np.linspace(0.3, 0.7, 9)
TIMES = np.linspace(0.4, 0.7, 7)
TARGET = 1000.0  # points a minute


def _study(folder: Path, compiled: bool) -> dict:
    environment = {**os.environ, "MPLBACKEND": "Agg"}
    if not compiled:
        environment["ANTHROPOID_COMPILE"] = "never"
    argv = [sys.executable, "-m", "problems", "study", "--step-length-m", "0.3:0.7:9",
            "--step-time-s", "0.4:0.7:7", "--no-plots", "-q",
            "--output-dir", str(folder)]  # fmt: skip
    clock = time.perf_counter()
    run = subprocess.run(argv, env=environment, capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - clock
    line = next(text for text in run.stdout.splitlines() if text.startswith("this run:"))
    iterations = int(line.rsplit(";", 1)[1].split()[0])
    return {"seconds": seconds, "iterations": iterations, "line": line}


def throughput_table(repeat: int) -> None:
    from problems import walking_step

    # the compiled cache warm: the default step's structure compiled (once, into the cache)
    walking_step(N=30).solve(compiled=True, progress=False)
    print("Table 1: the README's 63-point study on the pool of 2 workers\n")
    print("| functions | wall s (median) | points/min | best | IPOPT iterations | it/point | "
          "target / points/min |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="study-throughput-") as scratch:
        for compiled in (True, False):
            runs = [_study(Path(scratch) / f"{compiled}-{k}", compiled) for k in range(repeat)]
            wall = statistics.median(r["seconds"] for r in runs)
            best = min(r["seconds"] for r in runs)
            rate = 63 * 60.0 / wall
            iterations = runs[-1]["iterations"]
            print(f"| {'compiled (cache warm)' if compiled else 'interpreted'} | {wall:.1f} | "
                  f"{rate:.0f} | {63 * 60.0 / best:.0f} | {iterations} | {iterations / 63:.1f} | "
                  f"{TARGET / rate:.2f} |")  # fmt: skip
    print()


def _point(spec: PointSpec, values: dict, start) -> tuple[dict, dict]:
    """One point as the worker solves it, each piece timed; (times s, the record)."""
    times: dict[str, float] = {}
    clock = time.perf_counter()
    step = spec.step(values)
    times["define"] = time.perf_counter() - clock
    clock = time.perf_counter()
    problem = step.problem if start is None else guess_from(step, start)
    times["guess"] = time.perf_counter() - clock
    clock = time.perf_counter()
    gait = step.solve(problem, progress=False, raise_on_failure=False, warm_start=True)
    solve = time.perf_counter() - clock
    rounds = gait.solution.stats["sampled_limits"]["rounds"]
    times["first solve"] = rounds[0]["solve_seconds"]
    times["re-solves"] = sum(r["solve_seconds"] for r in rounds[1:])
    times["checks"] = sum(r["check_seconds"] for r in rounds)
    times["rest of the solve"] = solve - times["first solve"] - times["re-solves"] - times["checks"]
    clock = time.perf_counter()
    trajectory = gait.to_trajectory()
    _outputs(spec, gait, trajectory)
    record = {"id": "", **warm_record(gait.solution), "trajectory": trajectory_bytes(trajectory)}
    times["outputs and record"] = time.perf_counter() - clock
    times["iterations first"] = rounds[0]["iterations"]
    times["iterations re-solves"] = sum(r["iterations"] for r in rounds[1:])
    times["re-solve count"] = len(rounds) - 1
    return times, record


def breakdown_table() -> None:
    spec = PointSpec(fixed={"N": 30})
    warm: list[dict] = []
    clock = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for length in LENGTHS:
            start = None
            for duration in TIMES:
                times, start = _point(spec, {"step_length": float(length),
                                             "step_time": float(duration)}, start)  # fmt: skip
                if len(warm) < 9 * 6 and duration != TIMES[0]:
                    warm.append(times)
    total = time.perf_counter() - clock
    seconds = [key for key in warm[0] if not key.startswith(("iterations", "re-solve count"))]
    whole = [sum(t[key] for key in seconds) for t in warm]
    rate = 63 * 60 / total
    print(f"Table 2: a warm point's time, serial, compiled ({len(warm)} warm points; the whole "
          f"63-point grid in {total:.1f} s, {rate:.0f} points/min on one core)\n")  # fmt: skip
    print("| piece | median ms | share of the total |")
    print("|---|---|---|")
    for key in seconds:
        share = sum(t[key] for t in warm) / sum(whole)
        print(f"| {key} | {1000 * statistics.median(t[key] for t in warm):.1f} | "
              f"{100 * share:.0f} % |")  # fmt: skip
    print(f"| the point | {1000 * statistics.median(whole):.1f} | 100 % |\n")
    first = statistics.median(t["iterations first"] for t in warm)
    again = statistics.median(t["iterations re-solves"] for t in warm)
    count = statistics.mean(t["re-solve count"] for t in warm)
    print(f"IPOPT iterations per warm point (medians): first solve {first:g}, hold re-solves "
          f"{again:g} over {count:.2f} re-solves a point (mean)\n")  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each study")
    args = parser.parse_args(argv)
    throughput_table(args.repeat)
    breakdown_table()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
