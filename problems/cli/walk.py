"""'walk': plan a walking step (the main job): torques for the drives, files, plots, feedback."""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path
from typing import TextIO

from planner.accuracy_check import AccuracyWarning
from planner.sampled_limits import SampleLimitError
from planner.schemes import DEFAULT_TRANSCRIPTION, TRANSCRIPTIONS, WITH_DEGREE
from problems.cli.common import (
    MAX_DRAWN_STEPS,
    MAX_INTERVALS,
    CommandFailed,
    Reporter,
    UsageError,
    accuracy_option,
    check_clearance,
    check_samples,
    counts_option,
    legs_option,
    new_folder,
    non_negative,
    one_of,
    output_set,
    phase_starts,
    positive,
    preset_linkage,
    print_mujoco_runs,
    print_runs,
    print_verification,
    sample_grid,
    speeds_option,
    write_joint_space,
    write_step_files,
    write_walk_pictures,
)
from problems.cli.study import (
    DEFAULT_DEGREES,
    DEGREES,
    count_at_most,
    non_negative_count,
    positive_count,
)
from problems.cli.walk_feet import FEET_SEQUENCE_SPEED_LIMIT, run_feet
from problems.gait.accuracy import ACCURACY_PRESETS
from problems.gait.problem import WORK_REGULARISATION
from problems.library.transition import RETRY_ITERATIONS, SEARCH_ITERATIONS, SEARCH_SECONDS
from problems.walking.footed import SEQUENCES
from problems.walking.step import WALKING_DEFAULTS, walking_step


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'walk' command's parser."""
    walk = commands.add_parser(
        "walk",
        parents=[common, limits],
        help="plan a periodic walking step: drive torques, files, plots (the main job)",
        description=(
            "Plan one periodic walking step of a biped by direct collocation on IPOPT: single "
            "support on the stance foot, the swing foot from (-s, 0) behind to (s, 0), heel "
            "strike (inelastic impact) and leg swap, periodic across steps; ground reaction "
            "and impulse inside the friction cone, swing-foot clearance, knee and posture "
            "limits, torque bounds; minimum integral of sum M_i^2. The gait law (22) fitted "
            "to the step is the initial guess and the benchmark. Prints a summary (cost "
            "against the law's, iterations, times, accuracy, an independent verification) and "
            "writes to --output-dir: torques.csv and torques.json at --rate-hz (one step, N m, "
            "for a drive controller; the next step repeats it with the legs exchanged), "
            "solution.npz (the nodes at full precision, to warm-start from), gait.png "
            "(angles, torques, ground reaction and friction use, foot path), walk.png and "
            "walk.gif (--steps steps in world coordinates). Exit status 1 when IPOPT fails or "
            "the verification fails."
        ),
    )
    _add_body_options(walk)
    _add_step_options(walk)
    _add_sequence_options(walk)
    _add_mesh_options(walk)
    _add_output_options(walk)


def _add_body_options(walk: argparse.ArgumentParser) -> None:
    """walk's options of the walker: a preset or a robot's URDF/MJCF, its feet's contact phases."""
    walk.add_argument("--preset", default="six-link", metavar="NAME",
                      help="biped preset: six-link or five-link (point feet), or six-link-feet "
                      "(feet with heel and ball: flat foot, heel rise, heel strike, double "
                      "support; its own mesh and phases) (default: six-link)")  # fmt: skip
    walk.add_argument("--feet-phases", default="human", choices=sorted(SEQUENCES),
                      help="with --preset six-link-feet, the contact phases of the step: "
                      "human (flat foot, heel rise, double support), flat-footed (no heel "
                      "rise: the stance foot flat until toe-off), toe-walking (on the balls of "
                      "the feet, the swing ball striking) (default: human)")  # fmt: skip
    walk.add_argument(
        "--urdf",
        type=Path,
        metavar="PATH",
        help="plan the robot of this URDF instead of a preset: its sagittal legs and trunk "
        "(hinges about y; the legs hang from one link and are named right/left or r_/l_), "
        "on feet when its legs have feet with heel and toe frames, else on point feet; "
        "joints.csv names each drive's URDF joint and its encoder's sign and zero",
    )
    walk.add_argument(
        "--lock",
        type=lambda text: tuple(j.strip() for j in text.split(",") if j.strip()),
        default=(),
        metavar="J1,J2",
        help="with --urdf, joints held at their zero and merged (a hip's roll and yaw, a "
        "waist, the arms)",
    )
    walk.add_argument(
        "--sole",
        type=lambda text: tuple(float(v) for v in text.split(",")),
        metavar="HEEL_X,TOE_X,Z",
        help="with --urdf, the feet's heel and toe, m from the ankle in the robot's zero pose "
        "(x forward, z up), for feet without heel and toe frames (read off the sole's "
        "collision box)",
    )


def _add_mesh_options(walk: argparse.ArgumentParser) -> None:
    """walk's options of the transcription and its mesh."""
    walk.add_argument(
        "--transcription",
        default=None,
        choices=TRANSCRIPTIONS,
        help=f"collocation scheme (default: {DEFAULT_TRANSCRIPTION})",
    )
    walk.add_argument("-N", "--intervals", type=count_at_most(MAX_INTERVALS, "intervals",
                      "refine with --accuracy TARGET instead"), default=None, metavar="N",
                      help=f"mesh intervals (default: {WALKING_DEFAULTS['N']}, 12 with --quick; "
                           f"at most "
                           f"{MAX_INTERVALS:,})")  # fmt: skip
    walk.add_argument("--degree", type=positive_count, default=None, metavar="D",
                      help=f"degree of {DEGREES} (default: {DEFAULT_DEGREES})")  # fmt: skip
    presets = "; ".join(f"{p.name}: {p.summary}" for p in ACCURACY_PRESETS.values())
    walk.add_argument(
        "--accuracy",
        type=accuracy_option,
        default=None,
        metavar="PRESET|TARGET",
        help=f"a preset instead of -N/--transcription/--degree ({presets}), or a number: "
        "refine the mesh (from -N/--transcription) until the per-interval re-integration error "
        "per nominal state scale (1 rad, 3 rad/s) is within it, e.g. 1e-5",
    )
    walk.add_argument(
        "--formulation",
        default=WALKING_DEFAULTS["formulation"],
        choices=("implicit", "explicit"),
        help="implicit: accelerations are variables (default); explicit: forward dynamics",
    )
    walk.add_argument(
        "--compiled",
        action="store_true",
        help="compile the NLP's functions to native code with the system's C compiler (about "
        "10 s per structure the first time; kept in a disk cache, so later runs of the same "
        "step solve faster: see planner.native_nlp); without it a compiled structure is "
        "used when the cache holds it",
    )


def _add_sequence_options(walk: argparse.ArgumentParser) -> None:
    """walk's options of a walk through speeds (--speeds and what goes with it)."""
    walk.add_argument(
        "--speeds",
        type=speeds_option,
        default=None,
        metavar="V0,V1,..",
        help="plan a walk through these speeds, m/s (0: quiet standing, first or last; on "
        "feet a stop plans from 0.6 m/s, not yet from 1 m/s; e.g. 0,1.0,1.4,0.6,0): each "
        "speed's periodic step, "
        "the steps between them (as many as the limits need), one file sequence.csv of every "
        "step, verified step by step, and "
        "sequence.png, walk.png, walk.gif; each step's length and time follow its speed "
        "(0.5 sqrt(v) m in 0.5 sqrt(v) / v s)",
    )
    walk.add_argument(
        "--library",
        default=None,
        metavar="PATH",
        help="with --speeds: a gait library (python -m problems library) whose walker and "
        "build options the walk takes (the step options here are not used), each speed's "
        "gait solved from the library's blend there (the speeds within its grid)",
    )
    walk.add_argument(
        "--steps-at-speed",
        type=positive_count,
        default=8,
        metavar="K",
        help="with --speeds: periodic steps walked at each speed between its transitions "
        "(default: 8)",
    )
    walk.add_argument(
        "--max-transition-steps",
        type=positive_count,
        default=6,
        metavar="K",
        help="with --speeds: the most steps a transition may take (default: 6); the fewest "
        "that solve within the limits and verify are taken",
    )
    walk.add_argument(
        "--transition-steps",
        type=counts_option,
        default=None,
        metavar="K1,K2,..",
        help="with --speeds: each transition's step count, in order (0: searched as "
        "--max-transition-steps says); a count given has one try, at --retry-iterations' "
        "cap: a walk planned again with the counts its last run printed skips the failed tries",
    )
    walk.add_argument(
        "--transition-iterations",
        type=positive_count,
        default=SEARCH_ITERATIONS,
        metavar="K",
        help="with --speeds: IPOPT's iterations for each count a transition tries (default: "
        f"{SEARCH_ITERATIONS}; each try is also capped at {SEARCH_SECONDS:g} s of wall time)",
    )
    walk.add_argument(
        "--retry-iterations",
        type=non_negative_count,
        default=RETRY_ITERATIONS,
        metavar="K",
        help="with --speeds: when no count of a transition solves, the counts that stopped on "
        f"--transition-iterations are tried again with K (default: {RETRY_ITERATIONS}; 0: no "
        "second pass); on feet slowing from 1.4 m/s needs it",
    )


def _add_step_options(walk: argparse.ArgumentParser) -> None:
    """walk's options of the step: its length and time, friction, limits, feet, objective."""
    walk.add_argument(
        "--step-length-m",
        type=positive("m", 2.0),
        default=WALKING_DEFAULTS["step_length"],
        metavar="S",
        help="distance between the feet at heel strike, m (default: "
        f"{WALKING_DEFAULTS['step_length']:g})",
    )
    walk.add_argument(
        "--step-time-s",
        type=positive("s", 10.0),
        default=WALKING_DEFAULTS["step_time"],
        metavar="T",
        help=f"duration of one step, s (default: {WALKING_DEFAULTS['step_time']:g})",
    )
    walk.add_argument("--mu", type=positive("(friction coefficient)", 10.0),
                      default=WALKING_DEFAULTS["mu"],
                      help=f"friction coefficient of the ground (default: "
                           f"{WALKING_DEFAULTS['mu']:g})")  # fmt: skip
    walk.add_argument(
        "--torque-limit-nm",
        type=positive("N m", 1e5),
        default=WALKING_DEFAULTS["torque_limit"],
        metavar="M",
        help="bound on every hinge torque |M_i|, N m (default: "
        f"{WALKING_DEFAULTS['torque_limit']:g})",
    )
    walk.add_argument(
        "--passive-ankle",
        action="store_true",
        help="no torque at the stance foot (a point foot's passive ankle)",
    )
    walk.add_argument(
        "--foot-heel-m",
        type=non_negative("m"),
        default=None,
        metavar="H",
        help="the sole reaches H m behind the ankle: the ankle torque's centre of pressure "
        "M / Fy stays on the sole (default 0.05 m for 0.86 m legs, scaled with the legs)",
    )
    walk.add_argument(
        "--foot-toe-m",
        type=non_negative("m"),
        default=None,
        metavar="T",
        help="the sole reaches T m ahead of the ankle (default 0.15 m for 0.86 m legs)",
    )
    walk.add_argument(
        "--touchdown-speed-mps",
        type=non_negative("m/s"),
        default=None,
        metavar="V",
        help="least downward speed of the landing foot at heel strike, m/s, and the slope of "
        "the clearance's approach line (default 0.3 m/s for 0.86 m legs under 9.81 m/s^2, "
        "scaled as sqrt(g L); 0 lets it graze in)",
    )
    walk.add_argument(
        "--landing-speed-mps",
        type=positive("m/s"),
        default=None,
        metavar="V",
        help="largest horizontal speed of the landing foot at heel strike, m/s (default: free; "
        "with a double support the optimum swings the foot in at about 7 m/s, which a real "
        "floor does not stop: 1 m/s walks in MuJoCo on a lower ground too)",
    )
    walk.add_argument(
        "--ground-margin-m",
        type=non_negative("m"),
        default=WALKING_DEFAULTS["ground_margin"],
        metavar="G",
        help="every point of the body but the feet (knees, hips, neck, head) stays G m above "
        f"the ground (default: {WALKING_DEFAULTS['ground_margin']:g})",
    )
    walk.add_argument(
        "--double-support-s",
        type=float,
        default=WALKING_DEFAULTS["double_support"],
        metavar="D",
        help="a double support of D s after heel strike, within the step time (two phases; "
        "default: 0, the legs swap at heel strike)",
    )
    walk.add_argument(
        "--clearance-m",
        type=float,
        default=None,
        metavar="H",
        help="mid-swing foot clearance h of the profile h sin^2(pi t/T), m (default: 0.05 m "
        "for 0.86 m legs, scaled with the leg)",
    )
    walk.add_argument(
        "--joint-speed-limit",
        type=non_negative("rad/s"),
        default=None,
        metavar="W",
        help="bound every driven joint's speed at W rad/s at every node (0: none; default: "
        f"none, but {FEET_SEQUENCE_SPEED_LIMIT:g} rad/s for a walk through --speeds on feet, "
        "whose unbounded swing foot whips at 43-60 rad/s and falls in MuJoCo at 1.2 and 1.4 "
        "m/s)",
    )
    walk.add_argument(
        "--objective",
        default=WALKING_DEFAULTS["objective"],
        choices=("torque", "torque-rate", "work", "human"),
        help="integral of sum M^2 (default), of sum dM^2, positive work, or 'human': the "
        "joints' strength-normalised effort with passive moments (problems.human.effort; "
        "with --preset six-link-feet: torque or human)",
    )


def _add_output_options(walk: argparse.ArgumentParser) -> None:
    """walk's options of the files, pictures and feedback."""
    walk.add_argument(
        "--rate-hz",
        type=positive("Hz", 1e5),
        default=1000.0,
        metavar="HZ",
        help="samples per second of the torque files, Hz (default: 1000)",
    )
    walk.add_argument(
        "--legs",
        type=legs_option,
        default=("right", "left"),
        metavar="A,B",
        help="names of the legs in joints.csv, the one in stance in the planned step first "
        "(default: right,left)",
    )
    walk.add_argument("--steps", type=count_at_most(MAX_DRAWN_STEPS, "steps",
                      "the pictures repeat one step: a few show it"), default=2,
                      help=f"steps drawn in walk.png and walk.gif (default: 2, at most "
                           f"{MAX_DRAWN_STEPS})")  # fmt: skip
    walk.add_argument(
        "--output-dir",
        default=None,
        metavar="DIR",
        help="output folder (default: a new folder walk_<date>_<time> here); a folder of an "
        "earlier walk has its files replaced as a set, any other non-empty folder is refused",
    )
    walk.add_argument(
        "--feedback",
        action="store_true",
        help="design the feedback of the step (a periodic LQR through the heel strike, and "
        "the lift-off with --double-support-s, indexed by the hip's progress), write its gains "
        "into torques.csv (columns phase, K_<hinge>__<state>; the law in "
        "torques.csv.meta.json) and check the closed loop in the product's hybrid simulation "
        "and in MuJoCo: multipliers, open loop, 50 steps, mass +-10 %%, ground +-5 mm and "
        "+-1 cm, a start error, weaker drives, largest pushes (about two minutes; draws "
        "closed_loop.png and the pushed walk, closed_loop_walk.png and .gif). With "
        "--preset six-link-feet: joint PD gains around the plan in the same columns, checked "
        "in the product's simulation on feet (10 steps a case) and in MuJoCo (20; about two "
        "minutes; draws mujoco_walk.png)",
    )
    walk.add_argument(
        "--ground-friction",
        type=positive("", 100.0),
        default=1.0,
        metavar="MU",
        help="friction coefficient of the simulated ground of --feedback (default: 1.0; the "
        "plan runs along its own cone, --mu, right after heel strike, so the feedback needs a "
        "little more)",
    )
    walk.add_argument("--no-plots", action="store_true", help="write no PNG or GIF")
    walk.add_argument("--no-gif", action="store_true", help="write the PNGs but no GIF")
    walk.add_argument(
        "--quick",
        action="store_true",
        help="a coarse, fast run (N = 12, a short GIF): a smoke test of the whole job",
    )


def run(args, out: TextIO, report: Reporter) -> int:
    args.walker = _robot(args)
    if args.speeds is not None:
        from problems.cli.walk_sequence import run_sequence

        return run_sequence(args, out, report, _checked_options, step_options)
    if args.preset == "six-link-feet" or (args.walker is not None and args.walker.feet):
        return run_feet(args, out, report)
    mesh, preset, target, sole = _checked_options(args)
    linkage = preset_linkage(args.preset) if args.walker is None else args.walker.linkage
    output = output_set(str(args.output_dir or new_folder("walk")), "walk")
    report.step(f"defining the walking step of {args.urdf or args.preset} ({linkage.n} links)")
    step = _step(args, linkage, mesh, sole)
    gait, caught = _solve(step, args, target, report)
    _print_plan(gait, args, preset, target, caught, out, report)
    # Everything goes to a staging folder first and replaces the output folder as a set once
    # the file the drives read has been read back and verified.
    feedback = None
    if args.feedback:
        from problems.control.feedback import design_feedback

        with report.working("designing the feedback (a periodic LQR through the step's events)"):
            feedback = design_feedback(gait, ground_mu=args.ground_friction)
    with output:
        channels = None if feedback is None else feedback.channels
        profile, check, torques_csv = write_step_files(gait, channels, output, args, report)
        write_joint_space(torques_csv, output, args.legs, out)
        dynamics = check.facts.get("dynamics residual", math.nan)
        print(
            f"torques.csv: {sample_grid(profile.time, args.rate_hz, phase_starts(profile))} "
            "of the consistent "
            f"motion (positions integrate the velocities, accelerations are their slope); its "
            f"torques are the inverse dynamics of its own motion to {dynamics:.1e} N m",
            file=out,
        )
        print_verification(check, profile.n_samples, out)
        closed = None
        if feedback is not None:
            closed = _closed_loop(feedback, report, out)
        if not args.no_plots:
            from problems.walking import plots as walking_plots

            write_walk_pictures(walking_plots.gait_figure(gait), gait, output, args, report)
            if closed is not None:
                with report.working("plotting closed_loop.png"):
                    walking_plots.save_figure(walking_plots.closed_loop_figure(closed),
                                              output.path("closed_loop.png"))  # fmt: skip
                _draw_pushed_walk(closed, gait.problem.dynamics, output, args.no_gif, report)
        paths = output.commit({"argv": list(sys.argv[1:]), "verification": "passed"})
    for path in paths:
        print(f"wrote {path}", file=out)
    return 0


def _robot(args):
    """The robot of --urdf (problems.robot.UrdfWalker) or None, its options checked."""
    if args.urdf is None:
        if args.lock or args.sole:
            raise UsageError("--lock, --sole: only with --urdf (a robot's joints to hold, its "
                             "soles)")  # fmt: skip
        return None
    if args.preset != "six-link":
        raise UsageError(f"--preset {args.preset} and --urdf: the URDF is the robot; drop one")
    from problems.robot import read_urdf_walker

    walker = read_urdf_walker(args.urdf, lock=args.lock, sole=args.sole)
    if args.legs != ("right", "left") and tuple(args.legs) != walker.sides:
        raise UsageError(f"--legs: the URDF names its legs {','.join(walker.sides)}; drop --legs")
    args.legs = walker.sides
    # each hinge bounded by its joint's URDF effort (--torque-limit-nm where none is given)
    args.torque_limit_nm = walker.hinge_limits(args.torque_limit_nm)
    return walker


def _checked_options(args):
    """(mesh options of walking_step, the accuracy preset or None, the refinement target or
    None, the sole (heel, toe) m or (None, None)), every option checked against the others
    (UsageError naming them)."""
    if args.feet_phases != "human":
        raise UsageError(
            f"--feet-phases {args.feet_phases}: only with --preset six-link-feet (point feet "
            "have no heel or ball); drop it or plan on feet"
        )
    if args.preset not in ("six-link", "five-link"):
        raise UsageError(
            f"--preset: {args.preset!r} is not a biped; use six-link, five-link or six-link-feet"
        )
    check_clearance(args.clearance_m)
    if not math.isfinite(args.double_support_s) or not 0 <= args.double_support_s:
        raise UsageError(
            f"--double-support-s: must be a number >= 0 s, got {args.double_support_s}"
        )
    if args.degree is not None and args.transcription not in WITH_DEGREE:
        raise UsageError(f"--degree: applies to --transcription {one_of(WITH_DEGREE)} only")
    samples = math.ceil(args.step_time_s * args.rate_hz - 1e-9) + 1
    check_samples(
        samples,
        args.force,
        f"--rate-hz {args.rate_hz:g} Hz x --step-time-s {args.step_time_s:g} s",
        "lower --rate-hz",
        f"files of about {samples * 2 * 600 / 1e6:,.0f} MB",
    )
    preset = args.accuracy if isinstance(args.accuracy, str) else None
    target = args.accuracy if isinstance(args.accuracy, float) else None
    if preset is not None:
        given = [
            option
            for option, value in (
                ("-N", args.intervals),
                ("--transcription", args.transcription),
                ("--degree", args.degree),
            )
            if value is not None
        ]
        if given:
            raise UsageError(
                f"--accuracy {preset}: the preset sets the mesh; drop {', '.join(given)} (or "
                "give a number to --accuracy to refine from that mesh)"
            )
        mesh = {"accuracy": preset}
    else:
        mesh = {
            "N": args.intervals or (12 if args.quick else 30),
            "transcription": args.transcription or DEFAULT_TRANSCRIPTION,
            "degree": args.degree,
        }
    if target is not None and args.double_support_s > 0:
        raise UsageError(
            "--accuracy: a refinement target needs a single support; with --double-support-s "
            "give a preset or -N"
        )
    sole = (args.foot_heel_m, args.foot_toe_m)
    if (sole[0] is None) != (sole[1] is None):
        raise UsageError("--foot-heel-m, --foot-toe-m: give both (the sole behind and ahead of "
                         "the ankle) or neither")  # fmt: skip
    if sole[0] is not None and sole[0] + sole[1] <= 0:
        raise UsageError("--foot-heel-m, --foot-toe-m: the sole must be longer than 0 m; for a "
                         "point foot give --passive-ankle")  # fmt: skip
    return mesh, preset, target, sole


def _step(args, linkage, mesh, sole):
    """The walking step the options ask for."""
    options = step_options(args, linkage, mesh, sole)
    return walking_step(linkage, args.step_length_m, args.step_time_s, **options)


def step_options(args, linkage, mesh, sole) -> dict:
    """walking_step's keyword arguments from the options (all but the step's length and
    time): the mesh, friction, limits, feet, objective, the robot's ranges."""
    extra = {}
    if sole[0] is not None:
        extra["foot"] = sole
    if args.touchdown_speed_mps is not None:
        extra["touchdown_speed"] = args.touchdown_speed_mps
    if args.landing_speed_mps is not None:
        extra["landing_speed"] = args.landing_speed_mps
    if args.clearance_m is not None:
        extra["clearance"] = args.clearance_m
    walker = getattr(args, "walker", None)
    if walker is not None:  # the robot's knees and stance hip within their URDF limits
        extra["knee_range"] = walker.joint_range("knee", WALKING_DEFAULTS["knee_range"])
        extra["hip_limit"] = walker.hip_limit()
    return dict(
        **mesh,
        formulation=args.formulation,
        mu=args.mu,
        torque_limit=args.torque_limit_nm,
        passive=(linkage.names[0],) if args.passive_ankle else (),
        objective=args.objective,
        double_support=args.double_support_s,
        ground_margin=args.ground_margin_m,
        speed_limit=args.joint_speed_limit or None,
        **extra,
    )


def _solve(step, args, target, report):
    """(gait, the warnings caught): the step solved with IPOPT (its iterations reported every
    second), its limits held at the samples; a failure to hold them raises CommandFailed."""
    last = [-math.inf]

    def iteration(row) -> None:
        now = time.perf_counter()
        if now - last[0] >= 1.0:
            last[0] = now
            report.step(
                f"  IPOPT iteration {row['iteration']}: objective {row['objective']:.6g}, "
                f"max violation {row['infeasibility']:.2e}"
            )

    scheme = step.ocp.transcription + (f"({step.ocp.degree})" if step.ocp.degree else "")
    doing = f"solving with IPOPT ({scheme}, N = {step.ocp.N}"
    doing += f", refining to {target:g})" if target is not None else ")"
    with report.working(doing), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AccuracyWarning)
        try:
            gait = step.solve(
                progress=iteration,
                raise_on_failure=False,
                accuracy=target,
                rate_hz=args.rate_hz,
                compiled=True if args.compiled else None,
                verify=False,  # the file itself is verified, read back from disk, below
            )
        except SampleLimitError as error:
            raise CommandFailed(
                f"the plan's limits could not be held at every sample: {error}; nothing written"
            ) from None
    return gait, caught


def _print_plan(gait, args, preset, target, caught, out, report) -> None:
    """The plan in lines (:func:`_print_solve`, :func:`_print_results`); raises
    CommandFailed when IPOPT did not converge or the accuracy target was not reached
    (nothing is written)."""
    _print_solve(gait, args, preset, out)
    _print_results(gait, args, target, caught, out, report)


def _print_solve(gait, args, preset, out) -> None:
    """The step and its mesh (the refinement's passes), IPOPT's first solve and the limits'
    hold rounds; raises CommandFailed when IPOPT did not converge."""
    step = gait.problem
    solution = gait.solution
    stats = solution.stats
    history = stats.get("refinement")
    phases = f", double support {step.double_support:g} s" if step.double_support > 0 else ""
    single = gait.segments()[0][0]
    scheme = single.scheme.label
    if preset is not None:
        chosen = ACCURACY_PRESETS[preset]
        scheme += f" (accuracy {preset}: tol {chosen.tol:g}, stated torque error <= "
        scheme += f"{chosen.torque_error:g} N m)"
    # The mesh solved first (the refinement's last, or the one asked for); the limits held
    # between the points may cut intervals of it (said below).
    planned = history.sizes[-1] if history is not None else step.ocp.N
    print(
        f"walking step of {args.urdf or args.preset}: {step.step_length:g} m in "
        f"{step.step_time:g} s "
        f"({step.speed:.3g} m/s){phases}, {scheme} N = {planned}"
        + (" (refined mesh)" if history is not None else "")
        + f", {args.formulation}",
        file=out,
    )
    if history is not None:
        for line in history.table().splitlines():
            print(f"  {line}", file=out)
    held = stats.get("sampled_limits")
    rounds = held["rounds"] if held is not None else []
    first = rounds[0] if rounds else {
        "iterations": solution.iterations,
        "build_seconds": stats["build_seconds"],
        "solve_seconds": stats["solve_seconds"],
    }  # fmt: skip
    print(
        f"IPOPT: {solution.status} in {first['iterations']} iterations; build "
        f"{first['build_seconds']:.3f} s, solve {first['solve_seconds']:.3f} s"
        + ("" if history is None else f" (last pass; all passes {history.seconds:.3f} s)"),
        file=out,
    )
    if not solution.success:
        raise CommandFailed(f"IPOPT did not converge: {solution.status}; nothing written")
    if held is not None:
        again = rounds[1:]
        split = sum(r.get("split", 0) for r in rounds)
        raised = sum(r.get("raised", 0) for r in rounds)
        words = (
            "they hold without a re-solve"
            if not again
            else f"{raised} interval bounds backed off"
            + (f", {split} intervals cut in two (N = {single.N})" if split else "")
            + f" in {len(again)} warm re-solve{'s' if len(again) > 1 else ''} "
            f"({sum(r['iterations'] for r in again)} iterations, "
            f"{sum(r['build_seconds'] + r['solve_seconds'] for r in again):.3f} s)"
        )
        print(
            f"limits on the exported motion at {args.rate_hz:g} Hz and between the samples: "
            f"{words}",
            file=out,
        )


def _print_results(gait, args, target, caught, out, report) -> None:
    """Cost, the peaks of the samples at --rate-hz (the file's), heel strike, centre of
    pressure, accuracy and its warning; raises CommandFailed when the accuracy target was not
    reached."""
    step = gait.problem
    stats = gait.solution.stats
    history = stats.get("refinement")
    accuracy = stats.get("accuracy")
    single = gait.segments()[0][0]
    limit = args.torque_limit_nm
    limit = max(limit.values()) if isinstance(limit, dict) else limit  # a URDF's: per hinge
    objective_words = {
        "torque": "integral of sum M_i^2, N^2 m^2 s",
        "torque-rate": "integral of sum dM_i^2 (+ 1e-3 sum M_i^2)",
        "work": f"positive work (+ {WORK_REGULARISATION / limit:.3g} sum M_i^2), J",
        "human": "integral of the joints' strength-normalised effort, (N m)^2 s",
    }[args.objective]
    print(
        f"cost ({objective_words}): {gait.cost:.6g}; the gait law (22) fitted to the step, "
        f"same mesh: {gait.law_cost:.6g} ({gait.law_cost / gait.cost:.3g}x the optimum)",
        file=out,
    )
    impact = gait.impact
    peaks = ", ".join(
        f"{name} {value:.1f}" for name, value in gait.summary(args.rate_hz)["peak_torque"].items()
    )
    print(
        f"cost of transport {gait.cost_of_transport:.4f} (positive work "
        f"{gait.positive_work:.2f} J per step); peak |M| (N m): {peaks}",
        file=out,
    )
    after = (
        "both feet stay on the ground"
        if step.double_support > 0
        else f"the old stance foot lifts off at ({impact['lift_off'][0]:.3f}, "
        f"{impact['lift_off'][1]:.3f}) m/s"
    )
    touchdown = gait.touchdown_velocity
    print(
        f"heel strike: the foot lands at ({touchdown.real:.3f}, {touchdown.imag:.3f}) m/s "
        f"(at least {step.touchdown_speed:g} m/s down), impulse ({impact['impulse'][0]:.3f}, "
        f"{impact['impulse'][1]:.3f}) N s, {after}",
        file=out,
    )
    low, high = gait.centre_of_pressure(args.rate_hz)
    if args.passive_ankle:
        sole_words = "a passive ankle (a point foot: no ankle torque)"
    elif step.foot_sole is None:
        sole_words = "no sole given"
    else:
        heel, toe = step.foot_sole
        sole_words = f"the sole from {-1000 * heel:.0f} to {1000 * toe:.0f} mm"
    print(
        f"centre of pressure of the stance foot (M / Fy from the ankle, every sample): "
        f"{1000 * low:.1f} .. {1000 * high:.1f} mm; {sole_words}",
        file=out,
    )
    if accuracy is not None:
        worst = accuracy["state"]
        nominal = single.ocp.variable_scale(worst) if worst in single.state_names else 1.0
        unit = (
            single.system.state_units[single.state_names.index(worst)]
            if worst in single.state_names
            else ""
        )
        print(
            f"accuracy: largest per-interval re-integration error "
            f"{accuracy['error'] * nominal:.2e} {unit} ({worst}, interval "
            f"{accuracy['interval']}; {accuracy['error']:.2e} of its nominal scale {nominal:g} "
            f"{unit}, the units of --accuracy)",
            file=out,
        )
    for warning in caught:
        if issubclass(warning.category, AccuracyWarning):
            report.warn(
                f"the plan obeys its dynamics only to {accuracy['error']:.2g} of a state's "
                "nominal scale between the mesh points (more than "
                f"{accuracy['threshold']:g}): refine the mesh with a larger -N, --accuracy "
                "balanced or --accuracy 1e-3"
            )
    if history is not None and not history.reached:
        raise CommandFailed(
            f"the accuracy target {target:g} was not reached: {history.reason}; nothing written"
        )


def _closed_loop(feedback, report, out):
    """Run and print the closed-loop check of ``walk --feedback``; returns it."""
    from problems.control.feedback import closed_loop_check

    weights = feedback.gains.weights
    events = (
        "the heel strike"
        if feedback.double is None
        else "the held heel strike and the lift-off (a law for each support; torques.csv's "
        "double_support column says which)"
    )
    print(
        f"feedback: periodic LQR through {events} at {feedback.control_rate_hz:g} Hz "
        f"(Bryson weights: {weights.angle:g} rad, {weights.rate:g} rad/s, {weights.torque:g} "
        f"N m), designed in {feedback.design_seconds:.2f} s; torques.csv carries its gains "
        f"({len(feedback.names) * 2 * len(feedback.names)} columns K_<hinge>__<state>, N m/rad "
        "and N m s/rad) and the phase; the law is in torques.csv.meta.json",
        file=out,
    )
    with report.working("checking the closed loop (the product's hybrid simulation)"):
        check = closed_loop_check(feedback)
    multipliers = ", ".join(f"{abs(m):.3f}" for m in check.loop.multipliers[:3])
    print(
        f"closed loop, simulated (pinned stance foot, rigid impacts, ground friction "
        f"{feedback.plant.mu:g}): largest Floquet multipliers |lambda| {multipliers} "
        f"(stable below 1); open loop (the plan's torques alone): largest |lambda| "
        f"{abs(check.open_loop_multipliers[0]):.3g} linearised along the plan, and simulated: "
        f"{check.open_loop.fell or 'walked'}",
        file=out,
    )
    print_runs(out, check.runs, check.steps, [
        ("peak |M| N m", 12, lambda steps: f"{max(r.peak_torque for r in steps):.1f}"),
        ("tracking rad", 12, lambda steps: f"{max(r.tracking for r in steps):.2e}"),
    ])  # fmt: skip
    forward, back = check.pushes
    print(
        f"  largest push on the torso's centre of mass at mid-step that it walks 10 more steps "
        f"after: forward {forward:.1f} N s, back {back:.1f} N s (bisection to 0.5 N s)",
        file=out,
    )
    try:
        import mujoco  # noqa: F401 - only whether the extra is there
    except ImportError:
        print('MuJoCo: not installed (pip install ".[mujoco]"): no run in MuJoCo', file=out)
        return check
    from problems.control.mujoco import mujoco_check

    with report.working("walking in MuJoCo (feet with soles, soft contacts)"):
        engine = mujoco_check(feedback)
    print(
        f"MuJoCo (the same body and the file's law at {feedback.control_rate_hz:g} Hz; feet "
        "with soles, soft contacts; planned stance Fy at most "
        f"{engine.planned_normal:.0f} N):",
        file=out,
    )
    print_mujoco_runs(out, engine.runs, engine.steps, engine.pushes)
    return check


def _draw_pushed_walk(closed, dynamics, output, no_gif: bool, report) -> None:
    """closed_loop_walk.png (and .gif): the simulated closed-loop walk that survived the
    largest forward push, in world coordinates."""
    from problems.control.feedback import PUSH_STEPS
    from problems.walking import plots as walking_plots

    run = closed.push_runs[0]
    motion = run.world(dynamics, rate_hz=60.0)
    what = (
        f"closed loop, simulated: a forward push of {closed.pushes[0]:.1f} N s on the torso "
        f"in step 2 (the largest survived), {run.walked}/{PUSH_STEPS} steps"
    )
    with report.working("plotting closed_loop_walk.png"):
        figure = walking_plots.world_strip(motion, frames_per_step=3, title=what)
        walking_plots.save_figure(figure, output.path("closed_loop_walk.png"))
    if not no_gif:
        with report.working(f"writing closed_loop_walk.gif ({run.walked} steps)"):
            walking_plots.animate_walk(
                motion,
                output.path("closed_loop_walk.gif"),
                fps=20.0,
                caption=f"push {closed.pushes[0]:.1f} N s in step 2; ",
                window=2.5,
            )
