"""The first solve of the default step on feet under the options that could cut its time.

    python examples/benchmarks/feet_levers.py

The default step on feet's first solve (from the law's guess, compiled NLP functions from the
disk cache; ``feet_times.py`` has the whole solve) under IPOPT's and MUMPS's options: MUMPS's
working memory (IPOPT's default 1000 % against the planner's 100 %), the fill-reducing
ordering, the barrier parameter's oracle and strategy, the inertia test, the push of the
guess off its bounds; and with the durations fixed at the optimum's (free durations couple
every defect row of a phase to its duration, a dense column of the KKT system). Per row:
IPOPT iterations, wall time, MUMPS per iteration (its factorisations, several per iteration
when the Hessian is regularised), the optimum (a different one is a different local
minimum). Then the first solve's iterations from other guesses of the phase durations under
the defaults and the two options that took fewer iterations from the default guess: whether
an option is a lever or the luck of one starting point. Then the whole solve (limits held at
the samples, interpreted) on coarser meshes: time, IPOPT iterations (all solves, and each;
the re-solves after a mesh cut start from the multipliers carried onto the cut mesh), cost,
and whether the accuracy check warned.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from solve_breakdown import _ipopt_timers  # IPOPT's timers from its journal

from planner import AccuracyWarning, Transcription, native_nlp, solve
from problems import footed_step
from problems.walking import footed

#: label -> IPOPT options of the first solve (over the planner's defaults)
LEVERS = {
    "defaults (AMF ordering, adaptive mu)": {},
    "MUMPS memory 1000 % (IPOPT's default)": {"mumps_mem_percent": 1000},
    "MUMPS ordering AMD (0)": {"mumps_pivot_order": 0},
    "MUMPS ordering PORD (4)": {"mumps_pivot_order": 4},
    "MUMPS ordering METIS (5)": {"mumps_pivot_order": 5},
    "MUMPS ordering QAMD (6)": {"mumps_pivot_order": 6},
    "mu oracle probing": {"mu_oracle": "probing"},
    "monotone mu, mu_init 0.01": {"mu_strategy": "monotone", "mu_init": 0.01},
    "no inertia test of the regularisation": {"neg_curv_test_reg": "no"},
    "linear solver SPRAL": {"linear_solver": "spral"},
    "bound push and fraction 1e-4": {"bound_push": 1e-4, "bound_frac": 1e-4},
}
#: options of the first solve tried from other guesses of the phase durations (the label's
#: options of LEVERS)
ACROSS_GUESSES = ("defaults (AMF ordering, adaptive mu)", "monotone mu, mu_init 0.01",
                  "bound push and fraction 1e-4")  # fmt: skip
#: the guessed durations' shares of the step time (flat, heel rise, double support): the
#: default's first, then others a user could as well have chosen (human gait: about half the
#: step flat, a fifth to a quarter in double support)
GUESSED_SHARES = [
    (0.38, 0.38, 0.24),
    (0.5, 0.3, 0.2),
    (0.45, 0.3, 0.25),
    (0.5, 0.25, 0.25),
    (0.55, 0.25, 0.2),
    (0.4, 0.4, 0.2),
    (0.6, 0.2, 0.2),
    (0.35, 0.4, 0.25),
]
#: a first solve from another guess stops here (counted as failed)
GUESS_LIMITS = {"max_iter": 250, "max_wall_time": 15.0}
#: meshes (flat, heel rise, double support) of the whole solve against the default
MESHES = [(20, 10, 30), (16, 8, 24), (14, 7, 21), (12, 6, 18)]


def _guessed_from(shares: tuple[float, ...]):
    """The default step on feet with its free durations guessed at ``shares`` of the step
    time (the module's table of guessed shares swapped for the build: the step reads it
    when its phases and guesses are made, here, and never after)."""
    saved = footed.SHARES[footed.PHASES]
    footed.SHARES[footed.PHASES] = shares
    try:
        return footed_step()
    finally:
        footed.SHARES[footed.PHASES] = saved


def first_solve(step, options: dict) -> dict:
    """The first solve of ``step`` (compiled functions): iterations, wall s, MUMPS ms per
    iteration, cost."""
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "ipopt.txt"
        options = {"print_timing_statistics": "yes", "output_file": str(log),
                   "file_print_level": 3, **options}  # fmt: skip
        with warnings.catch_warnings():  # a failed solve's plan may warn; it is not used
            warnings.simplefilter("ignore", AccuracyWarning)
            solution = solve(Transcription(step.phases), progress=False, options=options,
                             compiled=True, warm_start=False, raise_on_failure=False)  # fmt: skip
        timers = _ipopt_timers(log)
    iterations = max(solution.stats["iterations"], 1)
    if not solution.success:
        return {"iterations": iterations, "failed": True}
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
        durations = step.solve(compiled=True, hold_limits=False, verify=False).durations()
    fixed = footed_step(durations=durations)
    first_solve(fixed, {})
    rows["durations fixed at the optimum's"] = first_solve(fixed, {})
    print("The first solve of the default step on feet under other options (compiled)")
    head = (f"{'options':<40} {'iter':>5} {'regularised':>11} {'wall s':>7} "
            f"{'MUMPS ms/iter':>13} {'cost':>10}")  # fmt: skip
    print(head)
    print("-" * len(head))
    for label, row in rows.items():
        if row.get("failed"):
            print(f"{label:<40} {row['iterations']:5d} failed")
            continue
        print(f"{label:<40} {row['iterations']:5d} {row['regularised']:11d} {row['wall']:7.2f} "
              f"{row['linear']:13.1f} {row['cost']:10.4f}")  # fmt: skip
    print()
    print(
        "The first solve's IPOPT iterations from other guesses of the phase durations "
        f"(shares of the step time; 'fail': none within {GUESS_LIMITS['max_iter']} "
        f"iterations or {GUESS_LIMITS['max_wall_time']:g} s)"
    )
    head = f"{'options':<40} " + " ".join(f"{'/'.join(f'{v:.2f}' for v in g):>14}"
                                          for g in GUESSED_SHARES) + f" {'median':>7}"  # fmt: skip
    print(head)
    print("-" * len(head))
    for label in ACROSS_GUESSES:
        counts = []
        for shares in GUESSED_SHARES:
            guessed = _guessed_from(shares)
            row = first_solve(guessed, {**LEVERS[label], **GUESS_LIMITS})
            counts.append(None if row.get("failed") else row["iterations"])
        # a failure ranks above every count in the median
        ranked = sorted(c if c is not None else 10**9 for c in counts)
        middle = statistics.median(ranked)  # >= 10**9 / 2: a failure among the middle two
        cells = " ".join(f"{'fail' if c is None else c:>14}" for c in counts)
        print(f"{label:<40} {cells} {'fail' if middle >= 10**9 / 2 else f'{middle:g}':>7}")
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
