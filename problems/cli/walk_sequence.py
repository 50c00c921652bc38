"""'walk --speeds': plan a walk through commanded speeds (start, speed changes, stop) as one
verified file of every step, with its pictures."""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path
from typing import TextIO

from planner.accuracy_check import AccuracyWarning
from planner.errors import AnthropoidError
from planner.trajectory import Trajectory
from problems.cli.common import (
    CommandFailed,
    Reporter,
    UsageError,
    new_folder,
    output_set,
    preset_linkage,
    save_joint_view,
    with_robot,
)
from problems.cli.walk_feet import FEET_SEQUENCE_SPEED_LIMIT, footed_options
from problems.control.mujoco_feet import STAND as FEET_STAND_S
from problems.library.closed_loop import STAND as STAND_S
from problems.library.transition import RETRIED
from problems.walking.footed import FootedStep
from problems.walking.step import WALKING_DEFAULTS


def _check(args, checked_options):
    """(the mesh, the sole) of the options (``checked_options``: walk's own check), each
    option a sequence cannot take refused by name; on feet (None, None)."""
    if args.preset not in ("six-link", "five-link", "six-link-feet"):
        raise UsageError(
            f"--speeds: plans point-foot steps (--preset six-link or five-link) or steps on feet "
            f"(six-link-feet); got --preset {args.preset}"
        )
    walker = getattr(args, "walker", None)
    if walker is not None and walker.feet:
        raise UsageError(
            "--speeds with --urdf of a robot with feet: its walk on feet through speeds is not "
            "built yet; plan its single step (drop --speeds), or a point-foot robot's walk"
        )
    if walker is not None and args.library is not None:
        raise UsageError("--speeds with --urdf and --library: the library's gaits are of its "
                         "own walker; drop one")  # fmt: skip
    if args.double_support_s > 0:
        raise UsageError("--speeds with --double-support-s: transitions join single supports; "
                         "drop --double-support-s")  # fmt: skip
    for option, field, default in (("--step-length-m", "step_length_m", "step_length"),
                                   ("--step-time-s", "step_time_s", "step_time")):  # fmt: skip
        if getattr(args, field) != WALKING_DEFAULTS[default]:
            raise UsageError(f"--speeds with {option}: each step's length and time follow its "
                             f"speed; drop {option}")  # fmt: skip
    if args.preset == "six-link-feet":
        return None, None
    mesh, _, target, sole = checked_options(args)
    if target is not None:
        raise UsageError("--speeds with --accuracy NUMBER: give a preset or -N")
    return mesh, sole


def _feet_options(args, speeds) -> dict:
    """plan_sequence's options of a walk on feet: the step on feet's (``walk_feet``), its
    joint speeds bounded at :data:`FEET_SEQUENCE_SPEED_LIMIT` unless told."""
    options = footed_options(args)
    if args.joint_speed_limit is None:
        options["speed_limit"] = FEET_SEQUENCE_SPEED_LIMIT
    return {**options, "feet": True}


def run_sequence(args, out: TextIO, report: Reporter, checked_options, step_options) -> int:
    """Plan, verify from the file read back, draw, write as a set (``checked_options``,
    ``step_options``: walk's, which reads its options into walking_step's arguments)."""
    from problems.library.sequence import (
        checked_speeds,
        checked_transition_counts,
        plan_sequence,
        verify_sequence,
    )

    mesh, sole = _check(args, checked_options)
    try:
        speeds = checked_speeds(args.speeds)
    except AnthropoidError as error:
        raise UsageError(f"--speeds: {error}") from None
    try:
        checked_transition_counts(args.transition_steps, len(speeds) - 1)
    except AnthropoidError as error:
        raise UsageError(f"--transition-steps: {error}") from None
    feet = args.preset == "six-link-feet"
    library = _library(args.library, feet)
    if library is not None:
        low, high = float(library.speeds[0]), float(library.speeds[-1])
        outside = [v for v in speeds if v > 0 and not low - 1e-12 <= v <= high + 1e-12]
        if outside:
            raise UsageError(
                f"--speeds: {outside[0]:g} m/s is outside the library's {low:g}..{high:g} m/s "
                "(--library); command speeds within it or build a wider library"
            )
    if feet:
        linkage, options = None, _feet_options(args, speeds)
    else:
        linkage = preset_linkage(args.preset) if library is None else library.linkage
        if args.walker is not None:  # the robot of --urdf, its limits in the options
            linkage = args.walker.linkage
        options = step_options(args, linkage, mesh, sole)
        options.pop("double_support", None)
    if library is not None:  # the library's walker and its own build options
        options = {"feet": True} if feet else {}
    output = output_set(str(args.output_dir or new_folder("walk")), "walk")
    clock = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AccuracyWarning)
        try:
            sequence = plan_sequence(speeds, None if library else linkage,
                                     steps_at_speed=args.steps_at_speed,
                                     max_steps=args.max_transition_steps, library=library,
                                     transition_iterations=args.transition_iterations,
                                     retry_iterations=args.retry_iterations or None,
                                     transition_steps=args.transition_steps,
                                     progress=report.step, **options)  # fmt: skip
        except AnthropoidError as error:
            raise CommandFailed(f"the walk through {args.speeds}: {error}") from error
    seconds = time.perf_counter() - clock
    _print_plan(sequence, seconds, caught, args.rate_hz, out)
    feedback = _feedback(sequence, args, report, feet) if args.feedback else None
    with output:
        path = output.path("sequence.csv")
        with_robot(_with_law(sequence, feedback, args.rate_hz, feet), args).save(path)
        trajectory = Trajectory.load(path)
        check = verify_sequence(trajectory, sequence.linkage)
        print(f"verification of sequence.csv read back (numpy, every step, each step's end "
              f"against the next step's first row): {check}", file=out)  # fmt: skip
        if not check.ok:
            raise CommandFailed("sequence.csv failed its verification; nothing written")
        _write_joints(trajectory, output, args.legs, out)
        mujoco_run = None
        if feedback is not None:
            walk = _feet_closed_loop if feet else _closed_loop
            mujoco_run = walk(feedback, sequence, args, report, out)
        if not args.no_plots:
            _pictures(sequence, trajectory, output, args, report)
            if mujoco_run is not None and mujoco_run.time.size:
                _draw_mujoco_walk(mujoco_run, sequence.steps[0].gait.problem, output, report)
        paths = output.commit({"argv": list(sys.argv[1:]), "verification": "passed"})
    for written in paths:
        print(f"wrote {written}", file=out)
    return 0


def _write_joints(trajectory, output, legs, out) -> None:
    """joints.csv: the walk (``sequence.csv`` read back) as the robot's drives see it
    (``problems.robot.sequence_joints``), staged in ``output``, and what it holds in a line."""
    from problems.robot.sequence_joints import sequence_joint_space

    view = sequence_joint_space(trajectory, sides=tuple(legs))
    save_joint_view(view, output, out, f"the whole walk ({view.time.size} rows, sequence.csv's; "
                    f"the {legs[0]} leg in stance in the first step)")  # fmt: skip


def _feedback(sequence, args, report, feet: bool):
    """The walk's law: each step's joint PD on feet (``FeetLaw`` per step), else the
    finite-horizon LQR along the whole walk."""
    if feet:
        from problems.library.feet_closed_loop import sequence_laws

        with report.working("the drives' law of each step (joint PD around its plan)"):
            return sequence_laws(sequence, rate_hz=args.rate_hz)
    from problems.library.closed_loop import design_sequence_feedback

    with report.working("designing the walk's feedback (a finite-horizon LQR along it)"):
        return design_sequence_feedback(sequence, control_rate_hz=args.rate_hz)


def _with_law(sequence, feedback, rate_hz: float, feet: bool):
    """The walk's samples at ``rate_hz`` with its law's channels when it has one."""
    if feedback is None:
        return sequence.trajectory(rate_hz)
    if feet:
        from problems.library.feet_closed_loop import with_feet_laws

        return with_feet_laws(sequence, feedback, rate_hz)
    from problems.library.closed_loop import with_sequence_gains

    return with_sequence_gains(feedback, sequence.trajectory(rate_hz))


def _draw_mujoco_walk(run, problem, output, report) -> None:
    """mujoco_walk.png: MuJoCo's walk as planned, in world coordinates."""
    from problems.walking import plots as walking_plots

    motion = run.world(problem.dynamics, rate_hz=30.0, corners=problem.corners)
    with report.working("plotting mujoco_walk.png"):
        strip = walking_plots.world_strip(motion, frames_per_step=2,
                                          title="the walk in MuJoCo, closed loop")  # fmt: skip
        walking_plots.save_figure(strip, output.path("mujoco_walk.png"))


def _library(path, feet: bool):
    """The GaitLibrary of --library, or None; its gaits on feet exactly when the walk is."""
    if path is None:
        return None
    from problems.library import GaitLibrary

    try:
        library = GaitLibrary.load(path)
    except (OSError, AnthropoidError, ValueError, KeyError) as error:
        raise UsageError(f"--library {path}: cannot read a gait library there ({error})") from None
    if library.feet != feet:
        fix = ("give --preset six-link-feet" if library.feet else
               "build one with `python -m problems library --feet`")  # fmt: skip
        raise UsageError(
            f"--library {path}: its gaits walk on {'feet' if library.feet else 'point feet'}, "
            f"the walk on {'feet' if feet else 'point feet'}; {fix}"
        )
    return library


def _closed_loop(feedback, sequence, args, report, out):
    """The walk under its law in the product's simulation and in MuJoCo (when installed): as
    planned, the body 10 % heavier, a 10 N s forward push in the middle of the first
    transition step that changes speed (else of the first periodic step); a table; returns
    MuJoCo's run as planned (None without MuJoCo)."""
    from problems.library.closed_loop import SequenceDisturbances, simulate_sequence

    kinds = [step.kind for step in sequence.steps]
    push_step = kinds.index("change") if "change" in kinds else kinds.index("gait")
    pushed = SequenceDisturbances(push=10.0, push_step=push_step)
    cases = {"as planned": SequenceDisturbances(),
             "mass +10 %": SequenceDisturbances(mass_scale=1.1),
             f"push 10 N s, step {push_step}": pushed}  # fmt: skip
    try:
        from problems.control.mujoco import import_mujoco
        from problems.library.mujoco_sequence import run_sequence_in_mujoco

        import_mujoco()
    except AnthropoidError as error:
        run_sequence_in_mujoco = None
        print(f"MuJoCo: {error}", file=out)
    print(f"closed loop ({len(kinds)} steps, then {STAND_S:g} s standing when the walk ends at "
          "rest):", file=out)  # fmt: skip
    print(f"  {'case':<22} {'product simulation':<28} {'MuJoCo':<28}", file=out)
    planned_run = None
    for label, disturbances in cases.items():
        with report.working(f"walking it closed loop: {label}"):
            product = simulate_sequence(feedback, disturbances, ground_mu=args.ground_friction)
            mujoco = None
            if run_sequence_in_mujoco is not None:
                mujoco = run_sequence_in_mujoco(feedback, disturbances,
                                                ground_mu=args.ground_friction)  # fmt: skip
                planned_run = planned_run or mujoco
        print(f"  {label:<22} {_outcome(product):<28} "
              f"{'-' if mujoco is None else _outcome(mujoco):<28}", file=out)  # fmt: skip
        for name, run in (("product", product), ("MuJoCo", mujoco)):
            if run is not None and run.fell is not None:
                print(f"    {name}: {run.fell[:160]}", file=out)
    return None if planned_run is None else planned_run.run


def _feet_closed_loop(laws, sequence, args, report, out):
    """The walk on feet under its laws in the product's simulation on feet and in MuJoCo
    (when installed): as planned, the body 10 % heavier, a 10 N s forward push in the middle
    of the first step that changes speed; a table; returns MuJoCo's run as planned (None
    without MuJoCo)."""
    from problems.library.feet_closed_loop import walk_in_mujoco, walk_in_simulation

    try:
        from problems.control.mujoco import import_mujoco

        import_mujoco()
        has_mujoco = True
    except AnthropoidError as error:
        print(f"MuJoCo: {error}", file=out)
        has_mujoco = False
    count = len(sequence.steps)
    with report.working(f"walking it in the product's simulation ({count} steps, 3 cases)"):
        product, push_step = walk_in_simulation(sequence, laws)
    mujoco = None
    if has_mujoco:
        with report.working(f"walking it in MuJoCo ({count} steps, 3 cases)"):
            mujoco, _ = walk_in_mujoco(sequence, laws)
    stops = sequence.speeds[-1] == 0
    standing = f", then {FEET_STAND_S:g} s standing after the stop" if stops else ""
    print(f"closed loop ({count} steps{standing}; each step's joint PD around its own plan, "
          "handed over at the leg swap; the product's simulation: the plan's equations on a "
          "floating base, compliant heels and balls; MuJoCo: heel and ball spheres, soft "
          "contacts):", file=out)  # fmt: skip
    print(f"  {'case':<26} {'product simulation':<28} {'MuJoCo':<28}", file=out)

    def outcome(run) -> str:
        if run is None:
            return "-"
        stood = ", stood" if stops and run.fell is None else ""
        return f"{run.walked}/{count} steps{stood}" + ("" if run.fell is None else " (fell)")

    for label, run in product.items():
        where = f", step {push_step}" if "push" in label else ""
        other = None if mujoco is None else mujoco[label]
        print(f"  {label + where:<26} {outcome(run):<28} {outcome(other):<28}", file=out)
        for name, each in (("product", run), ("MuJoCo", other)):
            if each is not None and each.fell is not None:
                print(f"    {name}: {each.fell[:160]}", file=out)
    return None if mujoco is None else mujoco["as planned"]


def _outcome(run) -> str:
    stood = ", stood" if run.stood else ""
    return f"{run.walked}/{run.planned} steps{stood}" + ("" if run.fell is None else " (fell)")


def _print_plan(sequence, seconds: float, caught, rate_hz: float, out) -> None:
    """The walk's steps and each transition's tries, iterations (every solve) and torque
    peak over the samples the file holds (at ``rate_hz``)."""
    kinds = [step.kind for step in sequence.steps]
    print(f"walk through {' -> '.join(f'{v:g}' for v in sequence.speeds)} m/s: "
          f"{len(kinds)} steps in {sequence.duration:.2f} s ({kinds.count('gait')} periodic, "
          f"{len(kinds) - kinds.count('gait')} in transitions), planned in {seconds:.1f} s",
          file=out)  # fmt: skip
    print(f"  {'transition':<16} {'steps':>5} {'tried':>12} {'iterations':>10}  peak |M| N m "
          "(hinge)", file=out)  # fmt: skip
    for t in sequence.transitions:
        peaks = t.peak_torques(rate_hz)
        worst = max(peaks, key=peaks.get)
        # a second pass's counts marked "+": tried again with more iterations
        tried = ",".join(f"{k}{'+' if why.startswith(RETRIED) else ''}" for k, why in t.attempts)
        label = f"{t.speeds[0]:g} -> {t.speeds[1]:g} m/s"
        print(f"  {label:<16} {t.steps:>5} {tried:>12} {t.iterations:>10}  "
              f"{peaks[worst]:.1f} ({worst})", file=out)  # fmt: skip
        for k, why in t.attempts[:-1]:
            print(f"    {k} step(s) failed: {why[:150]}", file=out)
    counts = ",".join(str(t.steps) for t in sequence.transitions)
    print(f"  planned again without the search: --transition-steps {counts}", file=out)
    for warning in caught:
        print(f"  warning: {str(warning.message)[:200]}", file=out)


def _pictures(sequence, trajectory, output, args, report) -> None:
    from problems.library.plots import sequence_figure
    from problems.walking import plots as walking_plots

    problem = sequence.steps[0].gait.problem
    hip = problem.biped.upper_body[0]
    motion = sequence.world(rate_hz=30.0 if args.quick else 60.0)
    with report.working("plotting sequence.png"):
        # the drives' bounds (on feet the root's torque is the ground's: no bound of its own)
        limits = problem.limits if isinstance(problem, FootedStep) else problem.torque_limit
        limit = max(limits.values())
        figure = sequence_figure(trajectory, sequence.world(rate_hz=200.0), hip, limit)
        walking_plots.save_figure(figure, output.path("sequence.png"))
    with report.working("plotting walk.png"):
        walking_plots.save_figure(walking_plots.world_strip(motion, frames_per_step=2),
                                  output.path("walk.png"))  # fmt: skip
    if not args.no_gif:
        with report.working(f"writing walk.gif ({len(sequence.steps)} steps)"):
            walking_plots.animate_walk(motion, Path(output.path("walk.gif")),
                                       fps=15.0 if args.quick else 25.0, window=3.0)  # fmt: skip
