"""``walk --preset six-link-feet``: the walking step on feet (``problems.walking.footed``).

The same job as the point-foot ``walk`` (plan, files, their verification read back from disk,
pictures), for a biped whose legs end in a foot with heel and ball: the human cycle of flat
foot, heel rise, heel strike and a double support rolling the front foot down, with free
phase durations. The options of the point-foot step that have no meaning here (its mesh,
sole, passive ankle, double support, the objectives other than torque and human, the LQR's
simulated ground) are refused by
name. ``--feedback`` writes the drives' joint PD law around the plan into torques.csv
(:class:`problems.control.feet_law.FeetLaw`) and walks it in MuJoCo.
"""

from __future__ import annotations

import sys
import time
import warnings
from typing import TextIO

from planner.accuracy_check import AccuracyWarning
from planner.sampled_limits import SampleLimitError
from problems.cli.common import (
    CommandFailed,
    Reporter,
    UsageError,
    check_clearance,
    new_folder,
    output_set,
    phase_starts,
    print_mujoco_runs,
    print_verification,
    sample_grid,
    write_joint_space,
    write_step_files,
    write_walk_pictures,
)
from problems.walking.footed import footed_step
from problems.walking.step import WALKING_DEFAULTS

#: Options of ``walk`` that the step on feet does not take: (attribute, option, its default).
NOT_WITH_FEET = (
    ("transcription", "--transcription", None),
    ("intervals", "-N", None),
    ("degree", "--degree", None),
    ("accuracy", "--accuracy", None),
    ("formulation", "--formulation", WALKING_DEFAULTS["formulation"]),
    ("passive_ankle", "--passive-ankle", False),
    ("foot_heel_m", "--foot-heel-m", None),
    ("foot_toe_m", "--foot-toe-m", None),
    ("ground_margin_m", "--ground-margin-m", WALKING_DEFAULTS["ground_margin"]),
    ("double_support_s", "--double-support-s", WALKING_DEFAULTS["double_support"]),
    ("ground_friction", "--ground-friction", 1.0),
    ("landing_speed_mps", "--landing-speed-mps", None),
)

#: What the cost is, per --objective.
COST_WORDS = {
    "torque": "integral of the drives' sum M_i^2, N^2 m^2 s",
    "human": "integral of the joints' strength-normalised effort with passive moments, (N m)^2 s",
}
#: Every driven joint's speed bound, rad/s, of a walk through --speeds on feet unless
#: --joint-speed-limit says otherwise: unbounded, the swing foot whips at 43-60 rad/s and the
#: gaits at 1.2 and 1.4 m/s fall in MuJoCo; at 10 every gait from 0.6 to 1.4 m/s walks 20 steps
#: (examples/benchmarks/feet_transitions.py, Table 1)
FEET_SEQUENCE_SPEED_LIMIT = 10.0
#: The mesh of ``--quick`` per ``--feet-phases`` (intervals of each phase).
QUICK_MESH = {"human": (10, 6, 14), "flat-footed": (20, 20), "toe-walking": (20, 8)}


def run_feet(args, out: TextIO, report: Reporter) -> int:
    """Plan, write, verify and draw a step on feet."""
    step = _footed_step(args)
    output = output_set(str(args.output_dir or new_folder("walk")), "walk")
    gait, seconds, caught = _solve(step, args, report)
    _print_plan(gait, args, seconds, out)
    for warning in caught:
        if issubclass(warning.category, AccuracyWarning):
            # the planner's advice names -N and --accuracy, which the step on feet does not
            # take: the fix here is its default mesh
            what = str(warning.message).split("; refine")[0]
            report.warn(what + ("; drop --quick for the default mesh" if args.quick else ""))
    law = None
    if args.feedback:
        from problems.control.feet_law import FeetLaw

        law = FeetLaw(gait, rate_hz=args.rate_hz)
    with output:
        _write_files(gait, law, output, args, report, out)
        if not args.no_plots:
            from problems.walking.plots import footed_figure

            write_walk_pictures(footed_figure(gait), gait, output, args, report)
        if law is not None:
            _print_law(gait, law, out)
            _feet_in_simulation(gait, law, report, out)
            engine = _feet_in_mujoco(gait, law, report, out)
            if engine is not None and not args.no_plots:
                _draw_mujoco_walk(engine.runs["closed loop"], gait, output, report)
        paths = output.commit({"argv": list(sys.argv[1:]), "verification": "passed"})
    for path in paths:
        print(f"wrote {path}", file=out)
    return 0


def footed_options(args) -> dict:
    """footed_step's keyword arguments from the options (all but the step's length and time
    and a robot's walker), the options it does not take refused first."""
    given = [option for name, option, default in NOT_WITH_FEET if getattr(args, name) != default]
    if given:
        raise UsageError(
            f"{', '.join(given)}: not for --preset six-link-feet (the step on feet has its own "
            "mesh, feet and phases); drop them"
        )
    check_clearance(args.clearance_m)
    if args.objective not in ("torque", "human"):
        raise UsageError(
            f"--objective {args.objective}: the step on feet takes torque or human; drop it"
        )
    options = {"objective": args.objective, "mu": args.mu, "torque_limit": args.torque_limit_nm,
               "phases": args.feet_phases}  # fmt: skip
    if args.touchdown_speed_mps is not None:
        options["touchdown_speed"] = args.touchdown_speed_mps
    if args.clearance_m is not None:
        options["clearance"] = args.clearance_m
    if args.quick:
        options["N"] = QUICK_MESH[args.feet_phases]
    if args.joint_speed_limit:
        options["speed_limit"] = args.joint_speed_limit
    return options


def _footed_step(args):
    """The step on feet the options ask for, the options it does not take refused first."""
    extra = footed_options(args)
    walker = getattr(args, "walker", None)
    if walker is not None:
        extra.update(linkage=walker.linkage, points=walker.points, hip_limit=walker.hip_limit())

    def step(**ranges):
        return footed_step(step_length=args.step_length_m, step_time=args.step_time_s, **extra,
                           **ranges)  # fmt: skip

    planned = step()
    if walker is None:
        return planned
    # the robot's knees and ankles within their URDF limits (the ankle's from the neutral
    # stance the step's feet define)
    return step(
        knee_range=walker.joint_range("knee", planned.knee_range),
        ankle_range=walker.joint_range("ankle", planned.ankle_range, planned.neutral_ankles),
    )


def _solve(step, args, report):
    """(gait, seconds, the warnings caught): the step solved, its limits held at the samples;
    a solve that fails raises CommandFailed (nothing is written)."""
    report.step(f"defining the walking step on feet of {_walker_name(args)} (8 links)")
    start = time.perf_counter()
    with report.working(f"solving with IPOPT ({len(step.sequence)} phases, N = {step.mesh})"), \
            warnings.catch_warnings(record=True) as caught:  # fmt: skip
        warnings.simplefilter("always", AccuracyWarning)
        try:
            # verify=False: the file itself is verified, read back from disk, below
            gait = step.solve(rate_hz=args.rate_hz, raise_on_failure=False, verify=False,
                              compiled=True if args.compiled else None)  # fmt: skip
        except SampleLimitError as error:
            raise CommandFailed(
                f"the plan's limits could not be held at every sample: {error}; nothing written"
            ) from None
    if not gait.solution.success:
        raise CommandFailed(f"IPOPT did not converge: {gait.solution.status}; nothing written")
    return gait, time.perf_counter() - start, caught


def _print_plan(gait, args, seconds: float, out: TextIO) -> None:
    """The plan in lines: the step and its phases, IPOPT, the cost, the peaks of the samples
    at --rate-hz (the file's), one foot's stance."""
    step = gait.problem
    summary = gait.summary(args.rate_hz)
    phases = ", ".join(f"{name} {d:.3f} s" for name, d in zip(step.sequence, gait.durations(),
                                                              strict=True))  # fmt: skip
    print(
        f"walking step on feet of {_walker_name(args)} ({args.feet_phases}): "
        f"{step.step_length:g} m "
        f"(ball to ball) in {step.step_time:g} s ({step.speed:.3g} m/s); {phases} (free "
        "within their bounds)",
        file=out,
    )
    print(
        f"IPOPT: {gait.solution.status}; {summary['iterations']} iterations in "
        f"{summary['solves']} solves (the limits held at the samples), {seconds:.2f} s",
        file=out,
    )
    print(
        f"cost ({COST_WORDS[args.objective]}): {gait.cost:.6g}; the gait law "
        f"(22) with flat feet, same mesh: {gait.law_cost:.6g}",
        file=out,
    )
    drives = ", ".join(f"{name} {summary['peak_torque'][name]:.1f}" for name in step.drives)
    print(
        f"cost of transport {summary['cost_of_transport']:.4f} (positive work "
        f"{summary['positive_work']:.2f} J per step); peak |M| (N m): {drives}",
        file=out,
    )
    push = summary["push_off"]
    print(
        f"one foot through its stance ({gait.duration + gait.durations()[-1]:.3f} s, strike to "
        f"toe-off): vertical ground force up to {summary['peak_vertical_force']:.2f} body "
        f"weights; ankle push-off up to {push['power']:.0f} W at {100 * push['at']:.0f} % of "
        "the stance",
        file=out,
    )


def _walker_name(args) -> str:
    """The preset's name, or the URDF file's."""
    return "six-link-feet" if getattr(args, "walker", None) is None else str(args.urdf)


def _write_files(gait, law, output, args, report, out: TextIO) -> None:
    """torques.csv and .json (with the law's channels), solution.npz, the file read back and
    verified (raises when it fails), joints.csv."""
    step = gait.problem
    channels = None if law is None else law.channels
    profile, check, torques_csv = write_step_files(gait, channels, output, args, report)
    write_joint_space(torques_csv, output, args.legs, out)
    root = step.linkage.names[0]
    print(
        f"torques.csv: {sample_grid(profile.time, args.rate_hz, phase_starts(profile))}; "
        f"M_{root} is the ground's torque on the stance foot (no drive: its centre of pressure "
        f"is CoP_{root}_start_x, m from the ball), F_{step.strike_role}_x/_y the front "
        f"{step.striking_point}'s force in the double support",
        file=out,
    )
    print_verification(check, profile.n_samples, out)


def _draw_mujoco_walk(run, gait, output, report) -> None:
    """mujoco_walk.png: the closed loop's walk in MuJoCo, its bodies in world coordinates."""
    from problems.walking import plots as walking_plots

    step = gait.problem
    motion = run.world(step.dynamics, rate_hz=60.0, corners=step.corners)
    title = (f"MuJoCo, the file's law: {run.walked} steps on heel and ball spheres "
             "(later poses darker)")  # fmt: skip
    with report.working("plotting mujoco_walk.png"):
        figure = walking_plots.world_strip(motion, frames_per_step=3, title=title)
        walking_plots.save_figure(figure, output.path("mujoco_walk.png"))


#: steps a case in the product's simulation on feet (``--feedback``; MuJoCo's check walks 20)
SIMULATION_STEPS = 10


def _feet_in_simulation(gait, law, report, out) -> None:
    """The file's law in the product's own simulation on feet (``--feedback``): the plan,
    the disturbances on level ground, :data:`SIMULATION_STEPS` steps each."""
    from problems.control.feet_simulation import simulate_feet
    from problems.control.simulation import disturbances_for

    step = gait.problem
    cases = {("closed loop" if label == "plan" else label): d
             for label, d in disturbances_for(step.linkage.n, step.torque_limit).items()
             if "ground" not in label}  # fmt: skip
    with report.working("walking in the product's simulation on feet (compliant heels and balls)"):
        runs = {label: simulate_feet(gait, steps=SIMULATION_STEPS, disturbances=d, law=law)
                for label, d in cases.items()}  # fmt: skip
    print("the product's simulation on feet (the plan's equations on a floating base, heels "
          "and balls on a compliant ground, problems.control.feet_simulation; the file's law):",
          file=out)  # fmt: skip
    print_mujoco_runs(out, runs, SIMULATION_STEPS, False)


def _print_law(gait, law, out) -> None:
    """The law written in torques.csv (``--feedback``)."""
    n = gait.problem.linkage.n
    kp, kd = law.gains[1]  # the double support's: uncapped, the same on every hinge
    print(
        f"feedback: joint PD around the plan at {law.rate_hz:g} Hz (kp {kp.max():g} "
        f"N m/rad, kd {kd.max():g} N m s/rad, capped on light links in the single "
        f"support at {law.bandwidth:g} rad/s), indexed by the hip's progress; torques.csv "
        f"carries it ({n * 2 * n} columns K_<hinge>__<state>, phase, double_support; the law "
        "in torques.csv.meta.json)",
        file=out,
    )


def _feet_in_mujoco(gait, law, report, out):
    """The law's walks in MuJoCo (``--feedback``); returns the MuJoCo check, or None without
    MuJoCo."""
    try:
        import mujoco  # noqa: F401 - only whether the extra is there
    except ImportError:
        print('MuJoCo: not installed (pip install ".[mujoco]"): no run in MuJoCo', file=out)
        return None
    from problems.control.mujoco_feet import feet_mujoco_check

    with report.working("walking in MuJoCo (heel and ball spheres, soft contacts)"):
        engine = feet_mujoco_check(gait, law=law)
    print(
        f"MuJoCo (the same eight links, heel and ball spheres, soft contacts, friction "
        f"{gait.problem.mu:g}; the file's law):",
        file=out,
    )
    print_mujoco_runs(out, engine.runs, engine.steps, engine.pushes)
    return engine
