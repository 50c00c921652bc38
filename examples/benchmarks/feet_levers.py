"""The first solve of the default step on feet under the options that could cut its time.

    python examples/benchmarks/feet_levers.py

The default step on feet's first solve (from the law's guess, compiled NLP functions from the
disk cache; ``feet_times.py`` has the whole solve) under IPOPT's and MUMPS's options: the
fill-reducing ordering, the barrier parameter's oracle and strategy, the inertia test; and
with the durations fixed at the optimum's (free durations couple every defect row of a phase
to its duration, a dense column of the KKT system). Per row: IPOPT iterations, wall time,
MUMPS per iteration (its factorisations, several per iteration when the Hessian is
regularised), the optimum (a different one is a different local minimum). Then the whole
solve (limits held at the samples, interpreted) on coarser meshes: time, IPOPT iterations
(all solves, and each: the re-solves after a mesh cut restart IPOPT's multipliers cold),
cost, and whether the accuracy check warned.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from solve_breakdown import _ipopt_timers  # IPOPT's timers from its journal

from planner import AccuracyWarning, Transcription, native_nlp, solve
from problems import footed_step

#: label -> IPOPT options of the first solve (over the planner's defaults)
LEVERS = {
    "defaults (AMF ordering, adaptive mu)": {},
    "MUMPS ordering AMD (0)": {"mumps_pivot_order": 0},
    "MUMPS ordering PORD (4)": {"mumps_pivot_order": 4},
    "MUMPS ordering METIS (5)": {"mumps_pivot_order": 5},
    "MUMPS ordering QAMD (6)": {"mumps_pivot_order": 6},
    "mu oracle probing": {"mu_oracle": "probing"},
    "monotone mu, mu_init 0.01": {"mu_strategy": "monotone", "mu_init": 0.01},
    "no inertia test of the regularisation": {"neg_curv_test_reg": "no"},
    "linear solver SPRAL": {"linear_solver": "spral"},
}
#: meshes (flat, heel rise, double support) of the whole solve against the default
MESHES = [(20, 10, 30), (16, 8, 24), (14, 7, 21), (12, 6, 18)]


def first_solve(step, options: dict) -> dict:
    """The first solve of ``step`` (compiled functions): iterations, wall s, MUMPS ms per
    iteration, cost."""
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "ipopt.txt"
        options = {"print_timing_statistics": "yes", "output_file": str(log),
                   "file_print_level": 3, **options}  # fmt: skip
        solution = solve(Transcription(step.phases), progress=False, options=options,
                         compiled=True, warm_start=False)  # fmt: skip
        timers = _ipopt_timers(log)
    iterations = max(solution.stats["iterations"], 1)
    # the iterations whose Hessian IPOPT regularised (its inertia correction: a
    # factorisation or more besides the iteration's own)
    sizes = solution.stats["ipopt"]["iterations"]["regularization_size"]
    return {"iterations": iterations, "wall": solution.stats["solve_seconds"],
            "linear": 1000.0 * timers["linear"] / iterations, "cost": solution.cost,
            "regularised": sum(1 for size in sizes if size > 0)}  # fmt: skip


def main() -> int:
    if native_nlp.compiler() is None:
        print("feet_levers times the compiled functions: no C compiler here")
        return 1
    step = footed_step()
    first_solve(step, {})  # the compiled functions made (or found) before timing
    rows = {label: first_solve(step, options) for label, options in LEVERS.items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        durations = step.solve(compiled=True, hold_limits=False).durations()
    fixed = footed_step(durations=durations)
    first_solve(fixed, {})
    rows["durations fixed at the optimum's"] = first_solve(fixed, {})
    print("The first solve of the default step on feet under other options (compiled)")
    head = (f"{'options':<40} {'iter':>5} {'regularised':>11} {'wall s':>7} "
            f"{'MUMPS ms/iter':>13} {'cost':>10}")  # fmt: skip
    print(head)
    print("-" * len(head))
    for label, row in rows.items():
        print(f"{label:<40} {row['iterations']:5d} {row['regularised']:11d} {row['wall']:7.2f} "
              f"{row['linear']:13.1f} {row['cost']:10.4f}")  # fmt: skip
    print()
    print("The whole solve (limits held at the samples) on coarser meshes, interpreted")
    head = (f"{'mesh':<14} {'solve s':>8} {'iterations':>10} {'cost':>10}  {'accuracy':<8}  "
            "iterations per solve (* after a mesh cut)")  # fmt: skip
    print(head)
    print("-" * len(head))
    for mesh in MESHES:
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", AccuracyWarning)
            gait = footed_step(N=mesh).solve(compiled=False)
        seconds = time.perf_counter() - start
        rounds = gait.solution.stats["sampled_limits"]["rounds"]
        warned = any(issubclass(w.category, AccuracyWarning) for w in caught)
        # a round's "split" cuts intervals for the next solve (its multipliers carried onto
        # the cut mesh: planner/mesh_multipliers.py)
        per_solve = [f"{r['iterations']}{'*' if k and rounds[k - 1]['split'] else ''}"
                     for k, r in enumerate(rounds)]  # fmt: skip
        print(f"{'/'.join(map(str, mesh)):<14} {seconds:8.2f} "
              f"{sum(r['iterations'] for r in rounds):10d} {gait.cost:10.4f}  "
              f"{'warned' if warned else 'passed':<8}  {' '.join(per_solve)}")  # fmt: skip
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
