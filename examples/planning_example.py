"""The planning guide's example ("Planning: optimal control by direct collocation"), solved
and drawn: the six-link walking step of the main job changed as a user changes any OCP
(drives bounded to 100 N m, the hip at least 0.8 m high, a torque-rate penalty).

    python examples/planning_example.py            # N = 30: examples/pictures/planning_example.png
    python examples/planning_example.py --quick --output-dir out   # N = 12 (the test suite)

Prints the cost and what makes the answer a walk (lowest hip, lowest swing foot, largest
torque) and draws one picture, planning_example.png: two steps in world coordinates with the
hip bound, the torques with their bounds, and the hip and swing-foot heights over the step.
``--trajectory PATH`` also saves the node trajectory (CSV, JSON or NPZ).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import casadi as ca
import numpy as np
from matplotlib.figure import Figure

from problems import walking_step
from problems.walking import plots as walking_plots

TORQUE_LIMIT = 100.0  # N m
HIP_MINIMUM = 0.8  # m


def readme_problem(N: int):
    """The guide's block: the walking step, its OCP changed (a planner.OCP is a value)."""
    step = walking_step(N=N)
    hip = step.dynamics.point("stance_thigh")  # the hip: end of the stance thigh
    ocp = (
        step.ocp.bound("M", -TORQUE_LIMIT, TORQUE_LIMIT)
        .constrain("hip height", lambda p: hip.expression("position", p.psi)[1], lower=HIP_MINIMUM)
        .minimize(integral=lambda p: ca.sumsqr(p.M) + 1e-2 * ca.sumsqr(p.dM))
    )
    return step, ocp, hip


def picture(gait, hip) -> Figure:
    problem = gait.problem
    n = problem.linkage.n
    times, states, torques = gait.fine(501)
    figure = Figure(figsize=(11.0, 7.0), layout="constrained")
    grid = figure.add_gridspec(2, 2, height_ratios=(1.2, 1.0))
    ax = figure.add_subplot(grid[0, :])
    walking_plots.draw_world(ax, gait.world(steps=2, rate_hz=100.0))
    ax.axhline(HIP_MINIMUM, color="0.4", linestyle="--", linewidth=0.8)
    label = {"facecolor": "white", "edgecolor": "none", "alpha": 0.85, "pad": 1.0}
    ax.text(ax.get_xlim()[0] + 0.02, HIP_MINIMUM + 0.02, f"hip >= {HIP_MINIMUM:g} m",
            fontsize="small", color="0.3", zorder=5, bbox=label)  # fmt: skip
    ax.set_title("two steps in world coordinates (later poses darker)")
    ax = figure.add_subplot(grid[1, 0])
    for i, name in enumerate(problem.linkage.names):
        ax.plot(times, torques[:, i], color=walking_plots.COLOURS[i], label=f"M_{name}")
    for bound in (-TORQUE_LIMIT, TORQUE_LIMIT):
        ax.axhline(bound, color="0.4", linestyle="--", linewidth=0.8)
    ax.set(xlabel="t [s]", ylabel="M [N m]", title=f"hinge torques, |M| <= {TORQUE_LIMIT:g} N m")
    ax.legend(fontsize="x-small", ncol=2)
    ax = figure.add_subplot(grid[1, 1])
    ax.plot(times, hip.position(states[:, :n]).imag, label="hip")
    ax.plot(times, problem.foot.position(states[:, :n]).imag, label="swing foot")
    ax.axhline(HIP_MINIMUM, color="0.4", linestyle="--", linewidth=0.8)
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.set(xlabel="t [s]", ylabel="y [m]", title="heights over one step")
    ax.legend(fontsize="small")
    figure.suptitle(
        f"README planning example: walking step {problem.step_length:g} m in "
        f"{problem.step_time:g} s, N = {gait.solution.N}, cost {gait.cost:.2f}"
    )
    return figure


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = Path(__file__).resolve().parent / "pictures"
    parser.add_argument("--output-dir", default=default, type=Path, help="output folder")
    parser.add_argument("--quick", action="store_true", help="N = 12 instead of 30")
    parser.add_argument("--trajectory", type=Path, help="also save the node trajectory here")
    args = parser.parse_args(argv)
    step, ocp, hip = readme_problem(12 if args.quick else 30)
    gait = step.solve(ocp, progress=False)  # the WalkingGait of ocp.solve(): world(), fine()
    _, states, torques = gait.fine(2001)
    n = step.linkage.n
    print(f"cost {gait.cost:.2f} in {gait.solution.iterations} iterations")
    print(f"lowest hip {hip.position(states[:, :n]).imag.min():.4f} m (bound {HIP_MINIMUM} m)")
    print(f"lowest swing foot {step.foot.position(states[:, :n]).imag.min():.2e} m")
    print(f"largest |M| {np.abs(torques).max():.2f} N m (bound {TORQUE_LIMIT:g} N m)")
    folder = args.output_dir
    folder.mkdir(parents=True, exist_ok=True)
    if args.trajectory is not None:
        print(f"wrote {gait.to_trajectory().save(args.trajectory)}")
    path = walking_plots.save_figure(picture(gait, hip), folder / "planning_example.png")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
