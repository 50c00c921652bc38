"""Speed changes on feet (issue #35, parts 2-4 on feet): the steps between two periodic
steps on feet, planned, verified and walked in MuJoCo.

    python examples/benchmarks/feet_transitions.py [--changes 1.0:0.6,0.6:1.0] [--write]

Table 1: the periodic steps on feet (the human cycle, ``footed_step_at``, 150 N m limits)
at the speeds the changes join, each solved warm from the one before, and each walked alone
20 steps in MuJoCo under its joint PD law (``FeetLaw``, the default gains): where that law
carries a gait on feet and where it does not.

Table 2: each speed change (``plan_transition`` on feet): the step counts tried (the fewest
that solve within the limits and verify is taken; a try is capped at 300 IPOPT iterations a
solve), the count taken, IPOPT's iterations of the taken count (the limits' hold rounds
included), the search's seconds (below the table: why each smaller count failed), the worst
join of its steps (each step's verification against the next step's first state: the leg
swap's angles and rates), and its largest drive torque against the periodic gaits' it joins
(ratio measured in the same run). The four default changes take about half an hour: a count
that fails in the limits' hold rounds can take many minutes before it does.

Table 3: the walk a (x S) -> b (x S) -> a (x S) with its two changes (the first two changes
given), every step walked once in MuJoCo, each under its own plan's joint PD law
(``run_feet_steps_in_mujoco``): as planned, the body 10 % heavier and lighter, a 10 N s push
forward and back in the middle of the first change's first step, and forward in the
second's. Needs ``pip install ".[mujoco]"``.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
import warnings

import numpy as np

from planner.errors import AnthropoidError
from problems.library import plan_transition
from problems.walking.footed import footed_step_at

#: the speed changes measured by default, (from, to) m/s: the issue's sequence on feet
#: (1.0 -> 1.4 -> 0.6) and back from 0.6 to 1.0
CHANGES = ((1.0, 0.6), (0.6, 1.0), (1.0, 1.4), (1.4, 0.6))
#: the gaits walked alone in MuJoCo besides the changes' speeds
ALONE = (0.8, 1.1, 1.2)


def _changes(text: str) -> tuple[tuple[float, float], ...]:
    pairs = []
    for item in text.split(","):
        a, b = (float(v) for v in item.split(":"))
        pairs.append((a, b))
    return tuple(pairs)


def _peak(gait) -> float:
    """The largest drive torque of a step's exported samples, N m (the root's is the
    ground's)."""
    torques = np.asarray(gait.exported().torques)[:, 1:]
    return float(np.max(np.abs(torques)))


def _gaits(speeds) -> dict[float, object]:
    """Each speed's step on feet, outward from 1 m/s, each warm from its nearest solved one."""
    gaits = {}
    for speed in sorted(speeds, key=lambda v: abs(v - 1.0)):
        step = footed_step_at(speed)
        if not gaits:
            gaits[speed] = step.solve()
            continue
        nearest = gaits[min(gaits, key=lambda v: abs(v - speed))]
        gaits[speed] = step.solve(step.phases.guess(nearest.solution))
    return gaits


def _mujoco():
    try:
        from problems.walking.mujoco import import_mujoco
        from problems.walking.mujoco_feet import run_feet_in_mujoco, run_feet_steps_in_mujoco

        import_mujoco()
    except AnthropoidError:  # the extra is optional: the tables say so
        return None, None
    return run_feet_in_mujoco, run_feet_steps_in_mujoco


def _outcome(run) -> str:
    if run.fell is not None:
        reason = run.fell.split(": ", 1)[-1].replace("|", "")  # no pipe in a table's cell
        return f"fell in step {run.walked}: {reason[:60]}"
    return f"{run.walked} steps"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--changes", type=_changes, default=CHANGES,
                        help="from:to,from:to m/s (default %(default)s)")  # fmt: skip
    parser.add_argument("--steps-at-speed", type=int, default=9)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")  # the accuracy warnings: the verification below holds
    speeds = sorted({v for pair in args.changes for v in pair})
    clock = time.perf_counter()
    gaits = _gaits(sorted({*speeds, *ALONE}))
    solved = time.perf_counter() - clock
    alone, stepped = _mujoco()
    print(f"Table 1: the periodic steps on feet ({len(gaits)} speeds solved in {solved:.1f} s), "
          "each walked alone 20 steps in MuJoCo under its joint PD law\n")  # fmt: skip
    print("| v m/s | phases s (flat / heel rise / double) | peak drive M N m | MuJoCo |")
    print("|---|---|---|---|")
    for speed, gait in sorted(gaits.items()):
        phases = " / ".join(f"{d:.3f}" for d in gait.durations())
        walked = "not installed" if alone is None else _outcome(alone(gait, steps=20))
        print(f"| {speed:g} | {phases} | {_peak(gait):.1f} | {walked} |")
    print()
    print("Table 2: the speed changes on feet\n")
    print("| change | counts tried | steps | iterations | search s | worst join rad, rad/s | "
          "peak drive M N m | gaits' peak N m | ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    transitions = {}
    for a, b in args.changes:
        clock = time.perf_counter()
        try:
            transition = plan_transition(gaits[a], gaits[b])
        except AnthropoidError as error:
            print(f"| {a:g} -> {b:g} m/s | failed: {str(error)[:150]} | | | "
                  f"{time.perf_counter() - clock:.1f} | | | | |")  # fmt: skip
            continue
        search = time.perf_counter() - clock
        transitions[(a, b)] = transition
        joins = [(c.name, c.margin) for report in transition.reports for c in report.checks
                 if c.name in ("join angles", "join rates")]  # fmt: skip
        angle = min(m for name, m in joins if name == "join angles")
        rate = min(m for name, m in joins if name == "join rates")
        peak = max(transition.peak_torques().values())
        joined = max(_peak(gaits[a]), _peak(gaits[b]))
        tried = ", ".join(f"{k}{'' if why == 'solved and verified' else ' (failed)'}"
                          for k, why in transition.attempts)  # fmt: skip
        print(f"| {a:g} -> {b:g} m/s | {tried} | {transition.steps} | {transition.iterations} | "
              f"{search:.1f} | {-angle:.1e}, {-rate:.1e} | {peak:.1f} | {joined:.1f} | "
              f"{peak / joined:.2f} |")  # fmt: skip
    print()
    for (a, b), transition in transitions.items():  # why each count before the taken one failed
        for k, why in transition.attempts[:-1]:
            print(f"- {a:g} -> {b:g} m/s, {k} step(s): {why[:160]}")
    print()
    if len(args.changes) < 2 or args.changes[0][::-1] != args.changes[1]:
        return 0
    (a, b), _ = args.changes[0], args.changes[1]
    if (a, b) not in transitions or (b, a) not in transitions or stepped is None:
        print("Table 3: not run (a change failed, or MuJoCo is not installed)\n")
        return 0
    walk_table(stepped, gaits, transitions, a, b, args.steps_at_speed)
    return 0


def walk_table(stepped, gaits, transitions, a: float, b: float, repeats: int) -> None:
    """Table 3: the walk a -> b -> a, every step once in MuJoCo."""
    from problems.walking.simulation import Disturbances

    steps = [gaits[a]] * repeats
    changes = []
    for start, end in itertools.pairwise((a, b, a)):
        changes.append(len(steps))
        steps += list(transitions[(start, end)].gaits) + [gaits[end]] * repeats
    first, second = changes
    title = f"the walk {a:g} -> {b:g} -> {a:g} m/s on feet in MuJoCo ({len(steps)} steps"
    print(f"Table 3: {title}: {repeats} at each speed, the changes from steps {first} and "
          f"{second})\n")  # fmt: skip
    print("| case | MuJoCo | s |")
    print("|---|---|---|")
    cases = {
        "as planned": Disturbances(),
        "mass +10 %": Disturbances(mass_scale=1.1),
        "mass -10 %": Disturbances(mass_scale=0.9),
        f"push +10 N s mid step {first}": Disturbances(push=10.0, push_step=first),
        f"push -10 N s mid step {first}": Disturbances(push=-10.0, push_step=first),
        f"push +10 N s mid step {second}": Disturbances(push=10.0, push_step=second),
    }
    for label, disturbances in cases.items():
        clock = time.perf_counter()
        run = stepped(steps, disturbances=disturbances)
        print(f"| {label} | {_outcome(run)} of {len(steps)} | {time.perf_counter() - clock:.1f} |")
    print()


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
