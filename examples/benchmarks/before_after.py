"""Before and after a change, in one run: the headline cases of planner_bench.py and
gait_bench.py built and solved by the code of an earlier git revision and by this tree.

    python examples/benchmarks/before_after.py --before 0715383          # about 4 minutes
    python examples/benchmarks/before_after.py --before HEAD~3 --repeat 7

The earlier revision is checked out into a temporary git worktree. Every measurement runs in
a fresh subprocess (imports and code generation included in nothing but the build), the two
trees alternating, so that the shared machine's noise falls on both alike. Printed: per case,
the medians of build (s), solve (s) and iterations for each tree, the ratios after/before,
and the costs (which must agree: the same optimum).

Cases (what both trees can state with the same code):

* planner headline: planner_bench.py's six-link periodic gait, Hermite-Simpson N = 50;
* walking step: ``walking_step()`` of gait_bench.py (six-link, Hermite-Simpson N = 30, with
  its holds of the limits at the samples);
* fixed-base gait: ``periodic_gait()`` of gait_bench.py (Hermite-Simpson N = 50).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CASES = {
    "planner headline": (
        "import planner_bench as b\n"
        "s = b.paper22_gait(50).solve(progress=False)\n"
        "out = (s.stats['build_seconds'], s.stats['solve_seconds'], s.stats['iterations'], s.cost)"
    ),
    "walking step": (
        "import time, warnings\n"
        "warnings.simplefilter('ignore')\n"
        "from problems import walking_step\n"
        "t0 = time.perf_counter(); step = walking_step(); t1 = time.perf_counter()\n"
        "g = step.solve(progress=False); t2 = time.perf_counter()\n"
        "out = (t1 - t0, t2 - t1, g.solution.iterations, g.solution.cost)"
    ),
    "fixed-base gait": (
        "import time, warnings\n"
        "warnings.simplefilter('ignore')\n"
        "from problems import periodic_gait\n"
        "t0 = time.perf_counter(); gait = periodic_gait(); t1 = time.perf_counter()\n"
        "g = gait.solve(progress=False); t2 = time.perf_counter()\n"
        "out = (t1 - t0, t2 - t1, g.solution.iterations, g.solution.cost)"
    ),
}


def measure(tree: Path, case: str) -> tuple[float, float, int, float]:
    """(build s, solve s, iterations, cost) of ``case`` by the code of ``tree``, in a fresh
    subprocess."""
    script = (
        "import json, sys\n"
        f"sys.path[:0] = [{str(tree)!r}, {str(tree / 'examples' / 'benchmarks')!r}]\n"
        + CASES[case]
        + "\nprint(json.dumps(out))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    if done.returncode != 0:
        raise RuntimeError(f"{case} in {tree}: {done.stderr.strip().splitlines()[-1:]}")
    build, solve, iterations, cost = json.loads(done.stdout.strip().splitlines()[-1])
    return build, solve, int(iterations), cost


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default="0715383", metavar="REV", help="the earlier revision")
    parser.add_argument("--repeat", type=int, default=5, help="runs per case and tree (median)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        before = Path(folder) / "before"
        added = subprocess.run(
            ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(before), args.before],
            capture_output=True,
            text=True,
        )
        if added.returncode != 0:
            print(f"cannot check out {args.before}: {added.stderr.strip()}")
            return 1
        try:
            print(f"before: git {args.before}; after: this tree ({ROOT}); medians of {args.repeat}")
            print(
                f"{'case':<18} {'build before':>12} {'after':>8} {'ratio':>6}   "
                f"{'solve before':>12} {'after':>8} {'ratio':>6}   {'iterations':>10}   "
                f"{'cost before':>14} {'cost after':>14}"
            )
            for case in CASES:
                runs = {"before": [], "after": []}
                for _ in range(max(1, args.repeat)):
                    runs["before"].append(measure(before, case))
                    runs["after"].append(measure(ROOT, case))
                m = {
                    key: [statistics.median(column) for column in zip(*values, strict=True)]
                    for key, values in runs.items()
                }
                b, a = m["before"], m["after"]
                print(
                    f"{case:<18} {b[0]:>12.3f} {a[0]:>8.3f} {a[0] / b[0]:>6.2f}   "
                    f"{b[1]:>12.3f} {a[1]:>8.3f} {a[1] / b[1]:>6.2f}   "
                    f"{int(b[2]):>4} {int(a[2]):>5}   {b[3]:>14.10g} {a[3]:>14.10g}"
                )
        finally:
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(before)],
                capture_output=True,
            )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
