"""Gait benchmark: the walking step and the fixed-base periodic gait, timed and compared with
the gait law (22) they start from.

    python examples/benchmarks/gait_bench.py            # medians of 5 solves of each
    python examples/benchmarks/gait_bench.py --quick    # smoke run (once each, coarse)

Printed, measured in one run:

1. per problem (the six-link walking step, Hermite-Simpson N = 30, and the fixed-base gait
   of the "walking" law, N = 50; also five-link, and other transcriptions of the step):
   NLP size, define time (``walking_step``/``periodic_gait``: model and OCP), build time
   (transcription and IPOPT setup, a solver built each time; and the build when the solver
   is cached), solve time, IPOPT iterations (build, solve and iterations summed over the
   first solve and the warm re-solves that hold the limits at the 1 kHz samples, with the
   first solve's iterations and the re-solves' count beside), the optimum and the law's
   cost on the same mesh, the ratio, and the verification (at 1 kHz); medians over
   ``--repeat`` runs;
2. the issue's targets next to the medians (define + build + solve at most 0.4 s for the
   walking step, 0.5 s for the fixed-base gait), as ratios;
3. mesh refinement of the walking step: cost at N = 30, 60, 120 and the spread;
4. the double support: the step with the legs swapping at heel strike against a double-support
   phase of 0.05 and 0.1 s (cost, cost of transport, impulse, peak torques, times);
5. local optima of the fixed-base gait on one mesh: IPOPT started from the law (the default),
   the law shifted by half a period, the law reversed in time, the "paper22" law and the
   standing pose, with the costs it reaches.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from model import presets
from problems import GaitLaw, periodic_gait, walking_step
from problems.gait.problem import total_iterations, total_seconds

#: Targets of the walking issue, s, for define + build + solve.
TARGETS = {"walking step": 0.4, "fixed-base gait": 0.5}


def _timed(define, repeats: int) -> dict:
    """Define, solve ``repeats`` times with a freshly built solver each time; medians of the
    times, the last result's numbers; and the median build when the solver is cached (a
    repeated solve of the same structure, as in a study)."""
    defines, builds, solves, cached = [], [], [], []
    result = None
    for _ in range(repeats):
        start = time.perf_counter()
        problem = define()
        defines.append(time.perf_counter() - start)
        result = problem.solve(progress=False, cache=False)
        build, solve = total_seconds(result.solution)  # with the rounds that hold the limits
        builds.append(build)
        solves.append(solve)
        again = problem.solve(
            progress=False, hold_limits=False, verify=False
        )  # builds and keeps it
        again = problem.solve(progress=False, hold_limits=False, verify=False)
        cached.append(again.solution.stats["build_seconds"])
    stats = result.solution.stats
    rounds = stats.get("sampled_limits", {}).get("rounds", [{}])
    return {
        "cached_build": statistics.median(cached),
        "variables": stats["n_variables"],
        "define": statistics.median(defines),
        "build": statistics.median(builds),
        "solve": statistics.median(solves),
        "iterations": total_iterations(result.solution),
        "first": rounds[0].get("iterations", result.solution.iterations),
        "rounds": len(rounds) - 1,
        "cost": result.cost,
        "law_cost": result.law_cost,
        "verified": result.verify().ok,
    }


def problems_table(quick: bool) -> list[tuple[str, callable]]:
    five = presets.five_link_biped()
    walking = GaitLaw.preset("walking")
    five_law = GaitLaw(walking.period, walking.zeta[:5], walking.varpi[:5], walking.center[:5])
    rows = [
        ("walking step", "six-link HS N=30", lambda: walking_step(N=30)),
        ("fixed-base gait", "six-link HS N=50", lambda: periodic_gait(N=50)),
    ]
    if not quick:
        rows += [
            ("walking step", "five-link HS N=30", lambda: walking_step(five, N=30)),
            (
                "walking step",
                "six trapezoid N=60",
                lambda: walking_step(N=60, transcription="trapezoid"),
            ),
            (
                "walking step",
                "six radau(3) N=20",
                lambda: walking_step(N=20, transcription="radau", degree=3),
            ),
            (
                "walking step",
                "six HS N=30 explicit",
                lambda: walking_step(N=30, formulation="explicit"),
            ),
            ("fixed-base gait", "five-link HS N=50", lambda: periodic_gait(five, five_law, N=50)),
        ]
    return rows


def double_support_rows(quick: bool, repeats: int) -> list[dict]:
    """The six-link step (0.5 m in 0.5 s, HS N = 30) with the legs swapping at heel strike
    (an instantaneous double support) and with a double support of 0.05 and 0.1 s; a fresh
    solver per solve."""
    rows = []
    for duration in (0.0, 0.1) if quick else (0.0, 0.05, 0.1):
        solves, result = [], None
        for _ in range(repeats):
            result = walking_step(N=15 if quick else 30, double_support=duration).solve(
                progress=False, cache=False
            )
            solves.append(total_seconds(result.solution))
        summary = result.summary()
        rows.append(
            {
                "double support": duration,
                "cost": result.cost,
                "peak": summary["peak_torque"],
                "cot": summary["cost_of_transport"],
                "impulse": float(np.hypot(*summary["impulse"])),
                "iterations": total_iterations(result.solution),
                "build": statistics.median(b for b, _ in solves),
                "solve": statistics.median(s for _, s in solves),
                "verified": result.verify().ok,
            }
        )
    return rows


def local_optima(quick: bool) -> list[tuple[str, str, int, float]]:
    problem = periodic_gait(N=30 if quick else 50)
    law = problem.law
    standing = {"psi": [np.pi / 2] * 2 + [-np.pi / 2] * 2 + [np.pi / 2] * 2, "dpsi": 0.0}
    starts = {
        "the law (default)": problem.ocp,
        "law shifted by T/2": problem.ocp.guess(lambda t: law((t + law.period / 2) % law.period)),
        "law reversed in time": problem.ocp.guess(lambda t: law(law.period - t)),
        "paper22 law": problem.ocp.guess(GaitLaw.preset("paper22")),
        "standing pose": problem.ocp.guess(**standing),
    }
    rows = []
    for label, ocp in starts.items():
        result = problem.solve(ocp, progress=False, raise_on_failure=False)
        rows.append((label, result.solution.status, result.solution.iterations, result.cost))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="once each, coarse: a smoke run")
    parser.add_argument("--repeat", type=int, default=None, help="solves per median (5)")
    options = parser.parse_args(argv)
    repeats = options.repeat or (1 if options.quick else 5)

    print(f"Gait problems (medians of {repeats}; times in ms; law: the fitted gait law (22) "
          "on the same mesh)")  # fmt: skip
    print("(build, solve, iter: the first solve and the warm re-solves that hold the limits at "
          "the 1 kHz samples, 'holds' of them; first: the first solve's iterations)")  # fmt: skip
    header = (
        f"{'problem':<16}{'case':<22}{'vars':>6}{'define':>8}{'build':>8}{'solve':>8}"
        f"{'total':>8}{'iter':>6}{'first':>6}{'holds':>6}{'optimum':>11}{'law':>11}"
        f"{'law/opt':>9}  verified"
    )
    print(header)
    print("-" * len(header))
    headline = {}
    for kind, case, define in problems_table(options.quick):
        r = _timed(define, repeats)
        total = r["define"] + r["build"] + r["solve"]
        headline.setdefault(kind, (case, total, r))
        print(
            f"{kind:<16}{case:<22}{r['variables']:>6d}{1e3 * r['define']:>8.1f}"
            f"{1e3 * r['build']:>8.1f}{1e3 * r['solve']:>8.1f}{1e3 * total:>8.1f}"
            f"{r['iterations']:>6d}{r['first']:>6d}{r['rounds']:>6d}{r['cost']:>11.2f}"
            f"{r['law_cost']:>11.4g}"
            f"{r['law_cost'] / r['cost']:>9.0f}  {'yes' if r['verified'] else 'NO'}"
        )
    print("build with the solver cached (the same structure solved again, as in a study), ms:")
    print(
        "  "
        + ", ".join(f"{case} {1e3 * r['cached_build']:.1f}" for case, _, r in headline.values())
    )
    print()
    print("Targets of the walking issue (define + build + solve, medians):")
    for kind, (case, total, _) in headline.items():
        target = TARGETS[kind]
        print(
            f"  {kind:<16} {case:<22} {1e3 * total:7.1f} ms, target {1e3 * target:.0f} ms: "
            f"{total / target:.2f}x the target"
        )
    print()
    print("Mesh refinement of the six-link walking step (Hermite-Simpson):")
    meshes = (15, 30) if options.quick else (30, 60, 120)
    costs = [walking_step(N=N).solve(progress=False).cost for N in meshes]
    for N, cost in zip(meshes, costs, strict=True):
        print(f"  N = {N:<4} cost {cost:.4f}")
    print(f"  spread (max / min - 1): {max(costs) / min(costs) - 1:.2e}")
    print()
    print(
        "Double support (six-link, 0.5 m in 0.5 s): legs swapping at heel strike (0 s) against "
        "a double-support phase (planner.Phases); peak |M| per hinge, N m"
    )
    names = None
    for r in double_support_rows(options.quick, repeats):
        names = names or list(r["peak"])
        if r is not None and r["double support"] == 0.0:
            print(
                f"  {'double support':>14} {'cost':>9} {'CoT':>6} {'impulse':>8} {'iter':>5} "
                f"{'build ms':>9} {'solve ms':>9}  peak |M| " + " ".join(f"{n:>12}" for n in names)
            )
        print(
            f"  {r['double support']:>12.2f} s {r['cost']:>9.2f} {r['cot']:>6.3f} "
            f"{r['impulse']:>6.2f}Ns {r['iterations']:>5d} {1e3 * r['build']:>9.1f} "
            f"{1e3 * r['solve']:>9.1f}  {'':>8} "
            + " ".join(f"{r['peak'][n]:>12.1f}" for n in names)
            + ("" if r["verified"] else "  NOT VERIFIED")
        )
    print()
    print("Local optima of the six-link fixed-base gait (walking law, one mesh), by start:")
    for label, status, iterations, cost in local_optima(options.quick):
        print(f"  {label:<24} {status:<26} {iterations:>4d} iterations, cost {cost:.4f}")
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
