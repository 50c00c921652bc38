"""Speed changes on feet (issue #35, parts 2-4 on feet): the steps between two periodic
steps on feet, planned, verified and walked in MuJoCo.

    python examples/benchmarks/feet_transitions.py [--changes 1.0:0.6,0.6:1.0,1.0:1.4,1.4:1.0]
        [--speed-limit 10] [--write]

The gaits are the human cycle on feet (``footed_step_at``, 150 N m limits) with every drive's
joint speed bounded (``speed_limit``, default 10 rad/s; 0: none): unbounded, the swing foot
whips at 40-60 rad/s before its heel strikes, and the joint PD law, whose reference goes on
along its last slope when the heel lands late, spins that foot round (traced at 1.2 m/s).

Table 1: each speed's gait planned without and with the bound (each solved warm from its
nearest solved neighbour), its largest joint speed, and each walked alone 20 steps in MuJoCo
under its joint PD law (``FeetLaw``, the default gains).

Table 2: each speed change of the bounded gaits (``plan_transition`` on feet; its steps keep
the bound): the step counts tried (the fewest that solve within the limits and verify is
taken; a try is capped at 300 IPOPT iterations a solve), the count taken, IPOPT's iterations
of the taken count (the limits' hold rounds included), the search's seconds (below the
table: why each smaller count failed), the worst join of its steps (each step's verification
against the next step's first state: the leg swap's angles and rates), and its largest drive
torque against the periodic gaits' it joins (ratio measured in the same run). A count that
fails in the limits' hold rounds can take many minutes before it does.

Table 3: the walk through the changes from the first on, while each solved and starts where
the one before ended, ``--steps-at-speed`` periodic steps at each speed and each change's
steps between, every step walked once in MuJoCo under its own plan's joint PD law
(``run_feet_steps_in_mujoco``): as planned, the body 10 % heavier and lighter, a 10 N s push
forward and back in the middle of the first change's first step, and forward in the
second's. Needs ``pip install ".[mujoco]"``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

from planner.errors import AnthropoidError
from problems.gait.problem import joint_rates
from problems.library import plan_transition
from problems.walking.footed import footed_step_at

#: the speed changes measured by default, (from, to) m/s: the issue's speeds on feet, in the
#: order the walk of Table 3 takes them (with the bound, 1.4 -> 0.6 and 1.4 -> 1.0 found no
#: plan in a run: the walk slows before it speeds up; the guide says what failed)
CHANGES = ((1.0, 0.6), (0.6, 1.0), (1.0, 1.4), (1.4, 1.0))
#: the gaits walked alone in MuJoCo besides the changes' speeds
ALONE = (0.8, 1.2)


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


def _gaits(speeds, speed_limit: float | None) -> dict[float, object]:
    """Each speed's step on feet, outward from 1 m/s, each warm from its nearest solved one."""
    gaits = {}
    for speed in sorted(speeds, key=lambda v: abs(v - 1.0)):
        step = footed_step_at(speed, speed_limit=speed_limit)
        if not gaits:
            gaits[speed] = step.solve()
            continue
        nearest = gaits[min(gaits, key=lambda v: abs(v - speed))]
        gaits[speed] = step.solve(step.phases.guess(nearest.solution))
    return gaits


def _joint_speed(gait) -> float:
    """The largest |joint speed| of a step's drives over its exported samples, rad/s."""
    samples = gait.exported()
    return float(np.max(np.abs(joint_rates(gait.problem.linkage, samples.dpsi)[:, 1:])))


def _mujoco():
    try:
        from problems.control.mujoco import import_mujoco
        from problems.control.mujoco_feet import run_feet_in_mujoco, run_feet_steps_in_mujoco

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
    parser.add_argument("--speed-limit", type=float, default=10.0,
                        help="the drives' joint speed bound, rad/s (0: none)")  # fmt: skip
    parser.add_argument("--steps-at-speed", type=int, default=8)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")  # the accuracy warnings: the verification below holds
    limit = args.speed_limit or None
    speeds = sorted({v for pair in args.changes for v in pair} | set(ALONE))
    clock = time.perf_counter()
    free = _gaits(speeds, None)
    gaits = free if limit is None else _gaits(speeds, limit)
    solved = time.perf_counter() - clock
    alone, stepped = _mujoco()
    print(f"Table 1: the periodic steps on feet ({len(speeds)} speeds, without and with the "
          f"joint speed bound {args.speed_limit:g} rad/s, solved in {solved:.1f} s), each walked "
          "alone 20 steps in MuJoCo under its joint PD law\n")  # fmt: skip
    print("| v m/s | phases s (flat / heel rise / double) | peak drive M N m | peak joint speed "
          "rad/s | MuJoCo |")  # fmt: skip
    print("|---|---|---|---|---|")
    plans = [("", free)] if limit is None else [("unbounded: ", free), ("bounded: ", gaits)]
    for speed in speeds:
        for label, plan in plans:
            gait = plan[speed]
            phases = " / ".join(f"{d:.3f}" for d in gait.durations())
            walked = "not installed" if alone is None else _outcome(alone(gait, steps=20))
            print(f"| {label}{speed:g} | {phases} | {_peak(gait):.1f} | {_joint_speed(gait):.1f} "
                  f"| {walked} |")  # fmt: skip
    print()
    transitions = changes_table(gaits, args.changes)
    route = _route(args.changes, transitions)
    if not route or stepped is None:
        print("Table 3: not run (the first change failed, or MuJoCo is not installed)\n")
        return 0
    walk_table(stepped, gaits, transitions, route, args.steps_at_speed)
    return 0


def _route(changes, transitions) -> list[tuple[float, float]]:
    """The changes from the first on while each solved and starts where the one before
    ended: the walk of Table 3."""
    route = []
    for change in changes:
        if change not in transitions or (route and route[-1][1] != change[0]):
            break
        route.append(change)
    return route


def changes_table(gaits, changes) -> dict:
    """Table 2: each change planned and measured; returns the transitions that solved."""
    print("Table 2: the speed changes on feet\n")
    print("| change | counts tried | steps | iterations | search s | worst join rad, rad/s | "
          "peak drive M N m | gaits' peak N m | ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    transitions = {}
    for a, b in changes:
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
    return transitions


def walk_table(stepped, gaits, transitions, changes, repeats: int) -> None:
    """Table 3: the walk through the chained changes, every step once in MuJoCo."""
    from problems.control.simulation import Disturbances

    speeds = [changes[0][0], *(b for _, b in changes)]
    steps = [gaits[speeds[0]]] * repeats
    starts = []
    for a, b in changes:
        starts.append(len(steps))
        steps += list(transitions[(a, b)].gaits) + [gaits[b]] * repeats
    first, second = (starts + starts)[:2]
    route = " -> ".join(f"{v:g}" for v in speeds)
    print(f"Table 3: the walk {route} m/s on feet in MuJoCo ({len(steps)} steps: {repeats} at "
          f"each speed, the changes from steps {', '.join(map(str, starts))})\n")  # fmt: skip
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
