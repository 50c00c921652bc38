"""How long the default step on feet takes, against the point-foot step, and why.

    python examples/benchmarks/feet_times.py              # medians of 3
    python examples/benchmarks/feet_times.py --repeat 1

For the default walking step (point feet, HS N = 30) and the default step on feet (three phases,
HS 20 + 10 + 30 intervals), in one run, alternating: the whole solve as ``step.solve()`` runs it
(the first solve and the warm re-solves that hold the limits at the 1 kHz samples), interpreted
and with the compiled NLP functions from the disk cache (``compiled=True``; the first compiled
run of each structure compiles it, minutes for the step on feet: that run is left out of the
medians), where its seconds go (IPOPT's solves, the transcriptions and solver set-ups, the
motion's checks at the samples, the rest), a hold round's transcription built and copied,
and the first solve's breakdown per IPOPT iteration: the NLP functions, MUMPS (the
linear-algebra floor IPOPT cannot avoid) and the NLP's size.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from solve_breakdown import breakdown  # the breakdown of one solve, per iteration

from planner import AccuracyWarning, Transcription, native_nlp
from problems import footed_step, walking_step

STEPS = {"point feet (walking_step)": walking_step, "feet (footed_step)": footed_step}


def timed(make, compiled: bool) -> tuple[float, int, float, dict[str, float]]:
    """(seconds of step.solve(), IPOPT iterations of all its solves, cost, its seconds by
    stage: IPOPT's solves, the transcriptions and solver set-ups, the motion's checks at the
    samples; "other" the rest: the law's cost, the accuracy check, the gait's assembly)."""
    step = make()
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        gait = step.solve(compiled=compiled)
    seconds = time.perf_counter() - start
    stats = gait.solution.stats
    rounds = stats.get("sampled_limits", {}).get("rounds") or [
        {"iterations": gait.solution.iterations, "solve_seconds": stats["solve_seconds"],
         "build_seconds": stats["build_seconds"], "check_seconds": 0.0}
    ]  # fmt: skip
    stages = {
        "IPOPT": sum(r["solve_seconds"] for r in rounds),
        "builds": sum(r["build_seconds"] for r in rounds),
        "checks": sum(r["check_seconds"] for r in rounds),
    }
    stages["other"] = seconds - sum(stages.values())
    return seconds, sum(r["iterations"] for r in rounds), gait.cost, stages


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    modes = [False] + ([True] if native_nlp.compiler() is not None else [])
    for make in STEPS.values():  # the compiled libraries made (or found) before timing
        if True in modes:
            timed(make, True)
    runs = {(label, mode): [] for label in STEPS for mode in modes}
    for _ in range(args.repeat):
        for label, make in STEPS.items():
            for mode in modes:
                runs[label, mode].append(timed(make, mode))
    print(f"The default step, solved as step.solve() does (limits held), medians of {args.repeat}")
    head = (f"{'step':<28} {'functions':<12} {'solve s':>8} {'/ point feet':>12} "
            f"{'iterations':>10} {'cost':>10}")  # fmt: skip
    print(head)
    print("-" * len(head))
    base = {m: statistics.median(r[0] for r in runs[next(iter(STEPS)), m]) for m in modes}
    for (label, mode), values in runs.items():
        seconds = statistics.median(v[0] for v in values)
        functions = "compiled" if mode else "interpreted"
        print(f"{label:<28} {functions:<12} {seconds:8.2f} {seconds / base[mode]:12.2f} "
              f"{values[-1][1]:10d} {values[-1][2]:10.3f}")  # fmt: skip
    print()
    print(f"Where the whole solve's seconds go, medians of {args.repeat}: IPOPT's solves, the "
          "transcriptions and solver set-ups (multipliers carried included), the motion's "
          "checks at the samples, the rest")  # fmt: skip
    head = (f"{'step':<28} {'functions':<12} {'whole':>6} {'IPOPT':>6} {'builds':>6} "
            f"{'checks':>6} {'other':>6}")  # fmt: skip
    print(head)
    print("-" * len(head))
    for (label, mode), values in runs.items():
        functions = "compiled" if mode else "interpreted"
        cells = [statistics.median(v[0] for v in values)] + [
            statistics.median(v[3][stage] for v in values)
            for stage in ("IPOPT", "builds", "checks", "other")
        ]
        print(f"{label:<28} {functions:<12} " + " ".join(f"{c:6.2f}" for c in cells))
    print()
    print(f"A hold round's transcription of the step's last problem (margins backed off), ms, "
          f"medians of {5 * args.repeat}: built (Transcription) and copied from the last one "
          "(Transcription.for_problem, what planner.solve does when only margins and guesses "
          "change)")  # fmt: skip
    head = f"{'step':<28} {'built':>7} {'copied':>7} {'ratio':>6}"
    print(head)
    print("-" * len(head))
    for label, make in STEPS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            held = make().solve().solution.stats["sampled_limits"]["problem"]
        built, copied = [], []
        for _ in range(5 * args.repeat):
            start = time.perf_counter()
            transcription = Transcription(held)
            built.append(time.perf_counter() - start)
            start = time.perf_counter()
            transcription.for_problem(held)
            copied.append(time.perf_counter() - start)
        b, c = statistics.median(built) * 1e3, statistics.median(copied) * 1e3
        print(f"{label:<28} {b:7.1f} {c:7.1f} {b / c:6.1f}")
    print()
    print("The first solve per IPOPT iteration, ms (interpreted; medians of 1)")
    head = f"{'step':<28} {'iter':>5} {'wall':>7} {'functions':>9} {'MUMPS':>7} {'IPOPT':>7}"
    print(head)
    print("-" * len(head))
    for label, make in STEPS.items():
        step = make()
        problem = getattr(step, "phases", None) or step.ocp
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            row = breakdown(problem, 1)
        functions = sum(row[k] for k in ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"))
        print(f"{label:<28} {row['iterations']:5.0f} {row['wall']:7.2f} {functions:9.2f} "
              f"{row['linear']:7.2f} {row['ipopt']:7.2f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
