"""The gait library (issue #35, first part): building it over speed, and how far a blended
gait is from a solved one at the grid's spacing, on point feet and on feet.

    python examples/benchmarks/gait_library.py [--write]  # about 3 min
    python examples/benchmarks/gait_library.py --quick    # tables 2 and 4 only

Table 1: the point-foot library of 20 speeds from 0.4 to 1.8 m/s (``build_library``), with
each closed loop's Floquet multipliers (the phase-indexed law's return map at its fixed point,
``problems.control.linearisation.fixed_point``) and without; seconds, the middle gait's IPOPT
iterations from the gait law against its neighbours' from the warm start (median), the
largest |multiplier| over the library; interpreted (``ANTHROPOID_COMPILE=never``) and with
the compiled cache warm (the step's NLP and the hybrid simulation's period Jacobian compiled
into the cache first, timed apart: ``build_library(compiled=True)`` does the same).
Targets of issue #35: <= 15 s with the gains interpreted, <= 8 s with the cache.

Table 2: blends midway between two gaits 0.2, 0.1 and 0.05 m/s apart around 1 m/s
(``GaitLibrary.at``) against the step solved at that speed: the blend's distance from the
equations of motion (the independent verification's dynamics residual, N m), its landing and
impact-momentum misses, the torques' RMS and largest difference and the angles' largest
difference from the solved step, and the iterations of ``solve_at`` (the step re-solved
from the blend); ratios to the 0.05 m/s row measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from planner import native_nlp
from problems import verify_gait, walking_step
from problems.control.simulation import Plant
from problems.library import build_library
from problems.library.build import _feet_gait
from problems.walking.footed import footed_step_at, step_at_speed


def build_table() -> None:
    print("Table 1: a point-foot library of 20 speeds, 0.4 to 1.8 m/s\n")
    print("| NLP functions | multipliers | seconds | s per gait | iterations: middle (law) | "
          "warm (median) | largest abs multiplier | target s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    speeds = np.round(np.linspace(0.4, 1.8, 20), 6)
    mode = os.environ.get(native_nlp.MODE_ENV)
    # the compiled cache warm: the step's structure (one for every speed: the step's length
    # and time are parameters of the NLP) and the simulation's period Jacobian (one for the
    # linkage) compiled once into the cache, timed apart
    step_length, step_time = step_at_speed(1.0)
    clock = time.perf_counter()
    step = walking_step(None, step_length, step_time)
    step.solve(compiled=True, progress=False)
    nlp_seconds = time.perf_counter() - clock
    clock = time.perf_counter()
    Plant(step.linkage, mu=None).compile()
    plant_seconds = time.perf_counter() - clock
    try:
        for functions, target in (("interpreted", 15), ("compiled cache warm", 8)):
            # interpreted: the automatic mode off, so no library of the cache is used
            os.environ[native_nlp.MODE_ENV] = "never" if functions == "interpreted" else "auto"
            for with_multipliers in (True, False):
                start = time.perf_counter()
                library = build_library(speeds, multipliers=with_multipliers)
                seconds = time.perf_counter() - start
                iterations = [g.iterations for g in library.gaits]
                middle = iterations[len(iterations) // 2]
                warm = statistics.median(iterations[: len(iterations) // 2]
                                         + iterations[len(iterations) // 2 + 1:])  # fmt: skip
                largest = (
                    f"{max(float(np.max(np.abs(g.multipliers))) for g in library.gaits):.3f}"
                    if with_multipliers else "-"
                )  # fmt: skip
                print(f"| {functions} | {'return map' if with_multipliers else 'none'} | "
                      f"{seconds:.1f} | {seconds / 20:.2f} | {middle} | {warm:g} | {largest} | "
                      f"{target if with_multipliers else '-'} |")  # fmt: skip
    finally:
        if mode is None:
            os.environ.pop(native_nlp.MODE_ENV, None)
        else:
            os.environ[native_nlp.MODE_ENV] = mode
    print(f"\nfilling the cache before the compiled rows (not in their seconds; nothing to "
          f"compile when the cache held it already): the step's NLP {nlp_seconds:.1f} s, the "
          f"period Jacobian {plant_seconds:.1f} s\n")  # fmt: skip


def blend_table() -> None:
    print("Table 2: blends midway between gaits, against the step solved there\n")
    print(
        "| spacing m/s | speed | dynamics residual N m | ratio | landing miss mm | "
        "impact momentum miss | torque RMS / max N m | angles max rad | solve_at iterations |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for spacing in (0.2, 0.1, 0.05):
        low, high = 1.0 - spacing / 2, 1.0 + spacing / 2
        library = build_library([low, high], multipliers=False)
        blended = library.at(1.0)
        report = verify_gait(blended, library.linkage)
        solved = library.solve_at(1.0)
        reference = solved.to_trajectory(library.rate_hz)
        tau = np.linspace(0.0, 1.0, 401)

        def on(trajectory, values, tau=tau):
            own = trajectory.time / trajectory.time[-1]
            return np.stack([np.interp(tau, own, values[:, j]) for j in range(values.shape[1])],
                            axis=1)  # fmt: skip

        torque = on(blended, blended.torques) - on(reference, reference.torques)
        angles = on(blended, blended.psi) - on(reference, reference.psi)
        rows.append((spacing, -report["dynamics"].margin, -report["landing"].margin,
                     -report["impact momentum"].margin, float(np.sqrt(np.mean(torque**2))),
                     float(np.abs(torque).max()), float(np.abs(angles).max()),
                     solved.to_trajectory(1000.0).metadata.get("iterations")))  # fmt: skip
    finest = rows[-1][1]
    for spacing, residual, landing, momentum, rms, peak, angle, iterations in rows:
        print(f"| {spacing:g} | 1.0 | {residual:.3f} | {residual / finest:.1f} | "
              f"{1000 * landing:.3f} | {momentum:.2e} | {rms:.3f} / {peak:.3f} | {angle:.4f} | "
              f"{iterations} |")  # fmt: skip
    print()


def feet_build_table() -> None:
    print("Table 3: a library on feet of 11 speeds, 0.6 to 1.6 m/s\n")
    print("| seconds | s per gait | iterations: middle (law) | warm (median) | warm (max) |")
    print("|---|---|---|---|---|")
    speeds = np.round(np.linspace(0.6, 1.6, 11), 6)
    start = time.perf_counter()
    library = build_library(speeds, feet=True)
    seconds = time.perf_counter() - start
    iterations = [g.iterations for g in library.gaits]
    middle = iterations[len(iterations) // 2]
    warm = iterations[: len(iterations) // 2] + iterations[len(iterations) // 2 + 1 :]
    print(f"| {seconds:.1f} | {seconds / speeds.size:.2f} | {middle} | "
          f"{statistics.median(warm):g} | {max(warm)} |\n")  # fmt: skip


def _single_support_residual(library, trajectory) -> float:
    rows = np.asarray(trajectory.extras["double_support"][0]) < 0.5
    psi, dpsi, ddpsi = (np.asarray(getattr(trajectory, k))[rows] for k in ("psi", "dpsi",
                                                                          "ddpsi"))  # fmt: skip
    expected = library.dynamics.inverse_dynamics(psi, dpsi, ddpsi)
    return float(np.max(np.abs(np.asarray(trajectory.torques)[rows] - expected)))


def feet_blend_table() -> None:
    print("Table 4: blends on feet midway between gaits, against the step solved there\n")
    print("| spacing m/s | speed | single support residual N m | ratio | whole step residual "
          "N m | drive torque RMS / max N m | solve_at iterations | from the law |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    cold = footed_step_at(1.0).solve()
    law_iterations = cold.to_trajectory(1000.0).metadata.get("iterations")
    rows = []
    for spacing in (0.2, 0.1, 0.05):
        library = build_library([1.0 - spacing / 2, 1.0 + spacing / 2], feet=True)
        blended = library.at(1.0)
        report = verify_gait(blended, library.linkage)
        solved = library.solve_at(1.0)
        a, b = library.gaits
        tau = np.linspace(0.0, 3.0, 1201)
        blend = 0.5 * (a.on_grid(tau)["torques"] + b.on_grid(tau)["torques"])
        reference = _feet_gait(solved, 1.0, False).on_grid(tau)["torques"]
        gap = (blend - reference)[:, 1:]  # the drives (the root's is the ground's torque)
        rows.append((spacing, _single_support_residual(library, blended),
                     -report["dynamics"].margin, float(np.sqrt(np.mean(gap**2))),
                     float(np.abs(gap).max()),
                     solved.to_trajectory(1000.0).metadata.get("iterations")))  # fmt: skip
    finest = rows[-1][1]
    for spacing, single, whole, rms, peak, iterations in rows:
        print(f"| {spacing:g} | 1.0 | {single:.3f} | {single / finest:.1f} | {whole:.2f} | "
              f"{rms:.3f} / {peak:.3f} | {iterations} | {law_iterations} |")  # fmt: skip
    # where the largest gap comes from: the phases' durations are not linear in speed
    flat = [name for name, _ in a.segments].index("flat")
    durations = [a.durations[flat], 0.5 * (a.durations[flat] + b.durations[flat]),
                 float(solved.durations()[flat]), b.durations[flat]]  # fmt: skip
    print(f"\nthe flat phase at 0.05 m/s spacing, s: {a.speed:g} m/s {durations[0]:.4f}, the "
          f"blend at 1 m/s {durations[1]:.4f}, solved at 1 m/s {durations[2]:.4f}, {b.speed:g} "
          f"m/s {durations[3]:.4f} (the blend {1000 * (durations[1] - durations[2]):+.1f} ms "
          "from the solved step)\n")  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tables 2 and 4 only")
    args = parser.parse_args(argv)
    if not args.quick:
        build_table()
    blend_table()
    if not args.quick:
        feet_build_table()
    feet_blend_table()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
