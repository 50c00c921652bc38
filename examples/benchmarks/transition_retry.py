"""The transition search's second pass on feet (issue #35): a speed change between two
periodic steps on feet, searched over 1..max_steps counts at 300 IPOPT iterations a try and,
when none solves, the counts that stopped on that cap again at 1000
(``plan_transition(retry_iterations=...)``).

    python examples/benchmarks/transition_retry.py [--change 1.4:0.6] [--max-steps 2]
        [--retry-iterations 1000] [--write]

Prints each try as it ends (count, pass, outcome, seconds since the search began), then a
table: the count taken, the tries, IPOPT's iterations of the taken count (hold rounds
included), the search's seconds and the largest drive torque. The gaits are
``footed_step_at(v, speed_limit=10)``, as a walk on feet plans them. A failed try can take
minutes (each is capped at 600 s of wall time, its hold rounds included); the README's
numbers (1.4 -> 0.6 m/s: 1073 s; 1.4 -> 1.2 and 1.4 -> 1.0 m/s with --max-steps 3 and 2)
were measured with this script's code run from a scratch copy beside another job.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

from planner.errors import AnthropoidError
from problems.library import plan_transition
from problems.library.transition import RETRIED
from problems.walking.footed import footed_step_at


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--change", default="1.4:0.6", help="from:to, m/s (default 1.4:0.6)")
    parser.add_argument("--max-steps", type=int, default=2)
    parser.add_argument("--retry-iterations", type=int, default=1000, help="0: no second pass")
    args = parser.parse_args()
    v_a, v_b = (float(v) for v in args.change.split(":"))
    warnings.simplefilter("ignore")
    clock = time.perf_counter()
    a = footed_step_at(v_a, speed_limit=10.0).solve(progress=False)
    b = footed_step_at(v_b, speed_limit=10.0).solve(progress=False)
    print(f"gaits at {v_a:g} and {v_b:g} m/s on feet: {time.perf_counter() - clock:.0f} s")
    start = time.perf_counter()

    def stamp(line: str) -> None:
        print(f"[{time.perf_counter() - start:7.0f} s] {line}", flush=True)

    try:
        transition = plan_transition(a, b, max_steps=args.max_steps, progress=stamp,
                                     retry_iterations=args.retry_iterations or None)  # fmt: skip
    except AnthropoidError as error:
        print(f"no transition in {time.perf_counter() - start:.0f} s: {str(error)[:400]}")
        return 1
    seconds = time.perf_counter() - start
    marks = [(k, "+" if why.startswith(RETRIED) else "") for k, why in transition.attempts]
    tried = ", ".join(f"{k}{mark}" for k, mark in marks)
    print()
    print("| change m/s | steps | tries (+: second pass) | iterations | search s | peak N m |")
    print("|---|---|---|---|---|---|")
    print(f"| {v_a:g} -> {v_b:g} | {transition.steps} | {tried} | {transition.iterations} | "
          f"{seconds:.0f} | {max(transition.peak_torques().values()):.1f} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    from _tables import run

    sys.exit(run(main, __file__))
