"""Where a solve's milliseconds go: NLP functions, the linear solver, IPOPT's own work, and
what the product adds around IPOPT.

    python examples/benchmarks/solve_breakdown.py             # medians of 3
    python examples/benchmarks/solve_breakdown.py --repeat 5

For each problem, a solve from its default guess with a solver built beforehand (the solve
alone: what a study, a refinement or a continuation repeats), split by IPOPT's own timers
(``print_timing_statistics``) and CasADi's per-function timers:

* functions: the objective and constraints (f, g), their gradient and Jacobian (grad_f,
  jac_g) and the Lagrangian's Hessian (hess_l), CasADi's wall time for each;
* linear solver: MUMPS inside IPOPT's augmented-system solve (``StdAugSystemSolverMultiSolve``:
  the factorisations and back-solves of every iteration); the floor IPOPT cannot avoid;
* IPOPT: the rest of its algorithm (``OverallAlgorithm`` less the two above and the
  callback);
* callback: the product's per-iteration Python callback (CasADi's ``callback_fun`` timer),
  which IPOPT calls from inside its algorithm;
* outside: the wall time of the solver call less IPOPT's ``OverallAlgorithm``: CasADi's own
  work around IPOPT (argument checks, copies) and anything else the product adds per call.

The last rows solve the six-link walking step again with its NLP expanded to SX (CasADi's
``expand``; ``planner.solve(ocp, expand=True)``), and the walking step, the fixed-base gait
and the planner headline with their NLP functions compiled to native code
(``solve(compiled=True)``, :mod:`planner.native_nlp`; the disk cache is the user's, so a
second run of this script compiles nothing): what a structure solved more than once can
save per iteration. The solves report no progress, so no Python runs per iteration (the
callback column is zero; before issue 21 every solver carried the product's callback).

The columns are ms per iteration; ``/ floor`` is the solve's wall time over the linear
solver's: how far the solve is from what the linear algebra alone would take. Medians of
``--repeat`` solves per problem, all in one run (the machine is shared: compare the ratios).
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import paper22_gait  # the benchmark's own headline problem

from model import presets
from planner import native_nlp, solve
from planner.transcription import Transcription
from problems import periodic_gait, walking_step

FUNCTIONS = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
TIMERS = {
    "overall": "OverallAlgorithm",
    "linear": "StdAugSystemSolverMultiSolve",
    "functions": "Function Evaluations",
}


def problems() -> dict:
    """label -> OCP of the problems broken down."""
    five = presets.five_link_biped()
    return {
        "walking step, six-link, HS N = 30": walking_step().ocp,
        "walking step, five-link, HS N = 6": walking_step(five, N=6).ocp,
        "walking step, five-link, HS N = 100": walking_step(five, N=100).ocp,
        "fixed-base gait, six-link, HS N = 50": periodic_gait().ocp,
        "planner headline (paper22 band), HS N = 50": paper22_gait(50),
    }


def _ipopt_timers(path: Path) -> dict[str, float]:
    """Wall seconds of IPOPT's timers named in TIMERS, from its timing statistics."""
    text = path.read_text()
    out = {}
    for key, name in TIMERS.items():
        # the journal may hold earlier solves too: the last report is this solve's
        found = re.findall(rf"^\s*{re.escape(name)}\.*:.*wall:\s*([0-9.eE+-]+)\)", text, re.M)
        if not found:
            raise RuntimeError(f"IPOPT's timing statistics lack {name!r}:\n{text[-2000:]}")
        out[key] = float(found[-1])
    return out


def breakdown(ocp, repeat: int, how: str = "interpreted") -> dict:
    """Medians of ``repeat`` solves of ``ocp`` (one solver, built before the first): "interpreted"
    (the MX NLP in CasADi's virtual machine, no compilation: the default without a compiler),
    "expanded" (the NLP expanded to SX, ``planner.solve(ocp, expand=True)``) or "compiled"
    (``compiled=True``: native code from the disk cache, compiled first when it lacks it)."""
    problem, extra = (ocp, {"expand": True}) if how == "expanded" else (Transcription(ocp), {})
    extra["compiled"] = how == "compiled"
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "ipopt.txt"
        options = {"print_timing_statistics": "yes", "output_file": str(log),
                   "file_print_level": 3}  # fmt: skip
        solve(problem, progress=False, options=options, **extra)  # builds and caches the solver
        for _ in range(repeat):
            solution = solve(problem, progress=False, options=options, warm_start=False,
                             **extra)  # fmt: skip
            stats = solution.stats
            ipopt = stats["ipopt"]
            timers = _ipopt_timers(log)
            iterations = max(stats["iterations"], 1)
            row = {name: ipopt.get(f"t_wall_{name}", 0.0) for name in FUNCTIONS}
            row["callback"] = ipopt.get("t_wall_callback_fun", 0.0)
            row["linear"] = timers["linear"]
            row["ipopt"] = (
                timers["overall"] - timers["functions"] - timers["linear"] - row["callback"]
            )
            row["outside"] = stats["solve_seconds"] - timers["overall"]
            row["wall"] = stats["solve_seconds"]
            row = {key: 1000.0 * value / iterations for key, value in row.items()}
            row["iterations"] = stats["iterations"]
            row["cost"] = solution.cost
            rows.append(row)
    return {key: statistics.median(r[key] for r in rows) for key in rows[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="solves per problem (median)")
    args = parser.parse_args()
    columns = ("wall", "nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l", "linear",
               "ipopt", "callback", "outside")  # fmt: skip
    heads = ("wall", "f", "g", "grad_f", "jac_g", "hess_l", "linear", "IPOPT", "callbk",
             "outside")  # fmt: skip
    print("Where a solve's time goes, ms per iteration (medians of "
          f"{args.repeat}; a solver built beforehand; the machine is shared)")  # fmt: skip
    head = f"{'problem':<44} {'iter':>4} " + " ".join(f"{h:>7}" for h in heads)
    print(head + f" {'/ floor':>8} {'functions':>9}")
    print("-" * (len(head) + 19))
    cases = [(label, ocp, "interpreted") for label, ocp in problems().items()]
    cases.append(("  the same six-link step, NLP expanded to SX", walking_step().ocp, "expanded"))
    if native_nlp.compiler() is not None:
        compiled = {
            "  the same six-link step, compiled": walking_step().ocp,
            "  the same fixed-base gait, compiled": periodic_gait().ocp,
            "  the same planner headline, compiled": paper22_gait(50),
        }
        cases.extend((label, ocp, "compiled") for label, ocp in compiled.items())
    else:
        print("(no C compiler: the compiled rows are left out)")
    for label, ocp, how in cases:
        row = breakdown(ocp, args.repeat, how)
        functions = sum(row[name] for name in FUNCTIONS)
        cells = " ".join(f"{row[c]:7.3f}" for c in columns)
        print(f"{label:<44} {row['iterations']:4.0f} {cells} {row['wall'] / row['linear']:8.2f} "
              f"{functions / row['wall']:8.0%}")  # fmt: skip


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
