"""Human walking reproduced: the objective's elements one by one against Winter's stride, the
"human" setting at three speeds and for two bodies, and tracking the stride.

    python examples/benchmarks/human_prediction.py \
        --data ../shared/human_gait/Winter_Appendix_data.xlsx   # about 3 min
    python examples/benchmarks/human_prediction.py --data ... --quick    # table 1 only

Table 1: the step on feet at Winter's step (0.7075 m in 0.4935 s, the subject's 1.43 m/s) under
each objective, compared with the stride (``problems.human.compare_gait``: RMS and r over the
cycle for the angles, over the stance for the vertical force; the force's humps and valley in
body weights; the loading-response and swing knee flexion; the plantarflexor peak; the stance
fraction), every plan verified at its 1 kHz samples; then the point-foot step under the torque
and the human objective (its "ankle" the stance shank's tilt on a flat sole). The targets of
issue #34 in the last row. Table 2: the "human" setting at 0.9, 1.43 and 1.8 m/s (step length
0.7075 (v / 1.43)^(1/2) m times the height ratio, the step time length / v) for the scene's
body (1.75 m, 70 kg) and one of 1.60 m, 55 kg by the same anthropometric table
(``model.presets.scaled_body``): stance fraction, force humps, plantarflexor peak, knee swing
peak, against the data where it was measured (1.43 m/s). Table 3: tracking the stride on feet
and on point feet, angles only and angles with the ground force: RMS per channel, verified,
seconds.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from dataclasses import replace

from model import presets
from planner import AccuracyWarning
from problems import footed_step, walking_step
from problems.human import compare_gait, read_winter, step_stride
from problems.human.effort import HUMAN, HumanObjective
from problems.human.tracking import track_gait

WINTER_STEP = (0.7075, 0.4935)
WINTER_SPEED = WINTER_STEP[0] / WINTER_STEP[1]
#: (label, objective) of table 1: each element added on the one before, then variants.
ELEMENTS = (
    ("torque (today)", "torque"),
    ("joints", HumanObjective(passive=False)),
    ("+ passive", HumanObjective()),
    ("+ ankle 2x strong", HumanObjective(strengths={"ankle": 0.508})),
    ("+ accelerations 0.003 = human", HUMAN),
    ("human, exponent 3", replace(HUMAN, exponent=3.0)),
    ("human, accelerations 0.03", replace(HUMAN, accelerations=0.03)),
    ("human, collision 3/J", replace(HUMAN, collision=3.0)),
    ("human, hips 2x strong", replace(HUMAN, strengths={"ankle": 0.508, "hip": 0.508})),
)


def metrics(gait, data):
    comparison = compare_gait(step_stride(gait.to_trajectory(1000.0)), data)
    return comparison.channels, comparison.features


def row(label, channels, features, seconds, verified) -> str:
    c, f = channels, features

    def pair(name):
        return f"{c[name].rms:4.1f} {c[name].r:5.2f}"

    humps = "/".join(f"{f[k].model:.2f}" for k in ("force_peak_1", "force_valley",
                                                     "force_peak_2"))  # fmt: skip
    return (f"| {label} | {pair('thigh')} | {pair('knee')} | {pair('ankle')} | {humps} | "
            f"{c['force_y'].r:5.2f} | {f['knee_loading'].model:4.1f} | "
            f"{f['knee_swing'].model:4.1f} | {f['ankle_moment_peak'].model:4.2f} | "
            f"{f['stance'].model:4.1f} | {verified} | {seconds:4.1f} |")  # fmt: skip


HEADER = ("| objective | thigh RMS r | knee RMS r | ankle RMS r | Fy humps BW | Fy r | "
          "LR knee | swing knee | PF peak N m/kg | stance % | verified | s |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|")  # fmt: skip


def elements_table(data) -> None:
    print("Table 1: the objective's elements at Winter's step, against his stride\n")
    print(HEADER)
    for label, objective in ELEMENTS:
        start = time.perf_counter()
        try:
            gait = footed_step(None, *WINTER_STEP, objective=objective).solve()
        except Exception as error:  # a plan that fails its verification is a measurement
            print(f"| {label} | failed: {type(error).__name__}: {str(error)[:90]} |")
            continue
        seconds = time.perf_counter() - start
        channels, features = metrics(gait, data)
        print(row(label, channels, features, seconds, gait.verified))
    for objective in ("torque", "human"):  # the point-foot step: no ankle to push off with
        start = time.perf_counter()
        gait = walking_step(None, *WINTER_STEP, objective=objective).solve()
        channels, point_features = metrics(gait, data)
        print(row(f"point feet, {objective}", channels, point_features,
                  time.perf_counter() - start, gait.verified))  # fmt: skip
    f = features
    humps = "/".join(f"{f[k].data:.2f}" for k in ("force_peak_1", "force_valley",
                                                    "force_peak_2"))  # fmt: skip
    print(f"| Winter (data) | | | | {humps} | | {f['knee_loading'].data:.1f} | "
          f"{f['knee_swing'].data:.1f} | {f['ankle_moment_peak'].data:.2f} | "
          f"{f['stance'].data:.1f} | | |")  # fmt: skip
    print(
        "| targets | <= 4, >= 0.95 | <= 6, >= 0.9 | <= 6, >= 0.9 | +-0.15 | >= 0.85 | "
        ">= 10 | +-5 | +-20 % | | | |\n"
    )


def speeds_table(data) -> None:
    print("Table 2: the human setting at three speeds, two bodies\n")
    print(
        "| body | speed m/s | step m in s | stance % | Fy humps BW | PF peak N m/kg | "
        "knee swing | cost of transport | verified | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for height, mass in ((1.75, 70.0), (1.60, 55.0)):
        linkage = presets.scaled_body(presets.anthropoid_with_feet(), height, mass)
        for speed in (0.9, WINTER_SPEED, 1.8):
            length = WINTER_STEP[0] * math.sqrt(speed / WINTER_SPEED) * height / 1.75
            start = time.perf_counter()
            try:
                gait = footed_step(linkage, length, length / speed, objective="human").solve()
            except Exception as error:
                print(f"| {height} m {mass:g} kg | {speed:.2f} | failed: {str(error)[:90]} |")
                continue
            seconds = time.perf_counter() - start
            _, f = metrics(gait, data)
            humps = "/".join(f"{f[k].model:.2f}" for k in ("force_peak_1", "force_valley",
                                                             "force_peak_2"))  # fmt: skip
            print(f"| {height} m {mass:g} kg | {speed:.2f} | {length:.3f} in "
                  f"{length / speed:.3f} | {f['stance'].model:.1f} | {humps} | "
                  f"{f['ankle_moment_peak'].model:.2f} | {f['knee_swing'].model:.1f} | "
                  f"{gait.cost_of_transport:.3f} | {gait.verified} | {seconds:.1f} |")  # fmt: skip
    print("\n(against the data, only the 1.43 m/s rows: Winter walked at that speed)\n")


def tracking_table(data) -> None:
    print("Table 3: tracking Winter's stride (effort 50, the default weights)\n")
    print("| walker | tracked | thigh | hip* | knee | ankle | Fy RMS r | verified | s |\n"
          "|---|---|---|---|---|---|---|---|---|")  # fmt: skip
    angles = {"thigh": 1.0, "knee": 1.0, "ankle": 1.0}
    for feet in (True, False):
        for label, weights in (("angles", angles),
                               ("angles + force", {**angles, "force_x": 100.0,
                                                   "force_y": 100.0})):  # fmt: skip
            if not feet:
                weights = {k: v for k, v in weights.items() if k != "ankle"}
            start = time.perf_counter()
            try:
                result = track_gait(data, feet=feet, weights=weights,
                                    solve_options={"progress": False})  # fmt: skip
            except Exception as error:
                print(
                    f"| {'feet' if feet else 'point feet'} | {label} | failed: {str(error)[:90]} |"
                )
                continue
            seconds = time.perf_counter() - start
            c = result.comparison.channels
            print(f"| {'feet' if feet else 'point feet'} | {label} | {c['thigh'].rms:.2f} | "
                  f"{c['hip'].rms:.1f} | {c['knee'].rms:.2f} | {c['ankle'].rms:.2f} | "
                  f"{c['force_y'].rms:.2f} {c['force_y'].r:.2f} | {result.gait.verified} | "
                  f"{seconds:.1f} |")  # fmt: skip
    print(
        "\n*hip: Winter's hip is the thigh against a HAT line that tilts with the pelvis; a point"
        " foot's 'ankle' is its shank's tilt on a flat sole (not tracked)"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="Winter's appendix workbook (.xlsx)")
    parser.add_argument("--quick", action="store_true", help="table 1 only")
    args = parser.parse_args(argv)
    data = read_winter(args.data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        elements_table(data)
        if not args.quick:
            speeds_table(data)
            tracking_table(data)
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
