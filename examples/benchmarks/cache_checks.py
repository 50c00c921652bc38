"""What checking a compiled NLP library before it loads costs, against the solve it serves.

    python examples/benchmarks/cache_checks.py              # medians of 5
    python examples/benchmarks/cache_checks.py --repeat 3

A library in the compiled cache (``planner.native_cache``) is loaded only when it matches the
size and SHA-256 recorded when it was published: a truncated one loaded by ``dlopen`` kills the
process with SIGBUS. For the default walking step (point feet) and the default step on feet,
in one run: the library's size, the check (SHA-256 of the file, what ``checked`` does once per
process and file), the other way to be safe that was considered (loading the library in a
child process first: a Python start, CasADi's import and the ``nlpsol`` build from the
library), and the compiled solve the check precedes (``step.solve(compiled=True)``, its
library already on disk). Compiles each structure into the cache first when it is not there
(minutes for the step on feet; ``ANTHROPOID_CACHE`` picks the folder).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

from planner import AccuracyWarning, Transcription, native_cache, native_nlp
from planner.solver import nlp_oracle
from problems import footed_step, walking_step

STEPS = {"point feet (walking_step)": walking_step, "feet (footed_step)": footed_step}

#: The child that loads a library, as a check before loading it here would run.
CHILD = (
    "import sys, casadi; "
    "casadi.nlpsol('probe', 'ipopt', sys.argv[1], {'print_time': False, 'ipopt.sb': 'yes', "
    "'ipopt.print_level': 0})"
)


def library_of(make) -> Path:
    """The published library of the step's NLP structure (compiled now when missing)."""
    step = make()
    problem = getattr(step, "phases", None) or step.ocp
    transcription = Transcription(problem)
    found = native_nlp.compile_library(
        nlp_oracle(transcription), transcription.structure_key, wait=True
    )
    if found is None:
        raise SystemExit("the compiled cache cannot take libraries here (see the warning)")
    return found


def median_seconds(action, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per median (default 5)")
    args = parser.parse_args(argv)
    print(f"Checking a compiled library before it loads (medians of {args.repeat}), ms")
    head = (
        f"{'step':<28} {'MB':>6} {'SHA-256':>8} {'child load':>10} {'solve':>8} "
        f"{'check/solve':>11} {'child/check':>11}"
    )
    print(head)
    print("-" * len(head))
    for label, make in STEPS.items():
        library = library_of(make)
        size = library.stat().st_size / 1e6
        check = median_seconds(lambda library=library: native_cache.digest(library), args.repeat)
        child = median_seconds(
            lambda library=library: subprocess.run(
                [sys.executable, "-c", CHILD, str(library)], check=True, capture_output=True
            ),
            args.repeat,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            solve = median_seconds(
                lambda make=make: make().solve(progress=False, compiled=True), args.repeat
            )
        print(
            f"{label:<28} {size:6.2f} {1e3 * check:8.2f} {1e3 * child:10.1f} {1e3 * solve:8.1f} "
            f"{check / solve:11.4f} {child / check:11.0f}"
        )
    print("(the check runs once per process and library; a re-solve reuses its verdict)")
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
