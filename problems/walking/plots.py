"""Pictures of a walking gait: angles, torques, ground reaction and friction use, the swing
foot's path, several steps drawn in world coordinates, and a GIF of them.

Figures are built directly (``matplotlib.figure.Figure``, no pyplot state); files are written
atomically (``planner.files.atomic_path``). The legs keep their colour across steps: a body
is named after the link it is in the first step, whatever its label after the leg swaps.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from planner.errors import DefinitionError, check_positive
from planner.files import atomic_path
from planner.gif import GifFrames
from problems.walking.step import WalkingGait, WorldMotion

#: matplotlib's tab10, one colour per body.
COLOURS = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)  # fmt: skip


def _sampled(gait: WalkingGait, samples: int):
    """Times (K,), states (K, 2n), torques (K, n), the rear (stance) foot's and the front
    foot's ground forces (K,) complex, N, through each phase's interpolant."""
    n = gait.problem.linkage.n
    parts = []
    for solution, t0 in gait.segments():
        count = max(2, round(samples * solution.T / gait.duration))
        local = np.linspace(0.0, solution.T, count)
        states, controls = solution(local)
        total = gait.problem.dynamics.ground_reaction(
            states[:, :n], states[:, n:], solution.acceleration(local)
        )
        front = np.zeros(count, dtype=complex)
        if controls.shape[1] > n:  # a double support: the front foot's force is a control
            front = controls[:, n] + 1j * controls[:, n + 1]
        parts.append((local + t0, states, controls[:, :n], total - front, front))
    return tuple(np.concatenate(column) for column in zip(*parts, strict=True))


def _angles_and_torques(angles, moments, t, states, torques, names, drives, size) -> None:
    """Every link's angle on the axes ``angles``, the torques of the hinges ``drives`` (link
    names) on ``moments``, over times t (K,); legends in font size ``size``."""
    for i, name in enumerate(names):
        colour = COLOURS[i % len(COLOURS)]
        angles.plot(t, states[:, i], color=colour, label=name)
        if name in drives:
            moments.plot(t, torques[:, i], color=colour, label=f"M_{name}")
    angles.set(xlabel="t [s]", ylabel="psi [rad]", title="link angles (absolute, from +x)")
    title = "hinge torques" if len(drives) == len(names) else "drive torques"
    moments.set(xlabel="t [s]", ylabel="M [N m]", title=title)
    for ax in (angles, moments):
        ax.legend(fontsize=size, ncol=2)


def gait_figure(gait: WalkingGait, samples: int = 501) -> Figure:
    """Four panels over one step: angles psi (rad), hinge torques M (N m), the feet's ground
    reactions (N) with the friction use |Fx| / (mu Fy), and the swing foot's path (m) with
    the clearance profile. A double support's phases follow each other on one time axis."""
    problem = gait.problem
    names = problem.linkage.names
    n = len(names)
    t, states, torques, force, front = _sampled(gait, samples)
    foot = problem.foot.position(states[:, :n])
    single = t <= problem.single_support_time + 1e-12
    figure = Figure(figsize=(11.0, 7.5))
    # Fixed margins: matplotlib's constrained layout measured every tick label and took 0.55
    # of the figure's 0.93 s to draw (examples/benchmarks/pictures.py).
    figure.subplots_adjust(left=0.065, right=0.975, bottom=0.07, top=0.91, wspace=0.3, hspace=0.3)
    axes = figure.subplots(2, 2)
    _angles_and_torques(axes[0, 0], axes[0, 1], t, states, torques, names, names, "small")
    ax = axes[1, 0]
    ax.plot(t, force.real, label="Fx stance foot")
    ax.plot(t, force.imag, label="Fy stance foot")
    use = ax.twinx()
    rear_foot, front_foot = problem.stance_contact, problem.swing_contact
    use.plot(t, rear_foot.friction_use(force.real, force.imag), color="0.3", linestyle="--")
    if np.any(front != 0):
        held = ~single
        ax.plot(t[held], front.real[held], label="Fx front foot")
        ax.plot(t[held], front.imag[held], label="Fy front foot")
        use.plot(t[held], front_foot.friction_use(front.real[held], front.imag[held]),
                 color="0.6", linestyle="--")  # fmt: skip
    ax.set(xlabel="t [s]", ylabel="F [N]", title="ground reactions")
    use.set_ylabel(f"friction use |Fx| / (mu Fy), mu = {rear_foot.friction:g}")
    use.set_ylim(0.0, 1.05)
    ax.legend(loc="upper left", fontsize="small")
    ax = axes[1, 1]
    ax.plot(foot.real, foot.imag, label="swing foot")
    profile = problem.clearance_at(t[single] / problem.single_support_time)
    ax.plot(foot.real[single], profile, color="0.5", linestyle=":", label="clearance profile")
    ax.plot([0.0], [0.0], "kv", label="stance foot")
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.set(xlabel="x [m]", ylabel="y [m]", title="swing foot path")
    ax.legend(fontsize="small")
    double = f", double support {problem.double_support:g} s" if problem.double_support else ""
    figure.suptitle(
        f"walking step: {problem.step_length:g} m in {problem.step_time:g} s{double}, cost "
        f"{gait.cost:.4g} (law {gait.law_cost:.4g}), cost of transport "
        f"{gait.cost_of_transport:.3f}"
    )
    return figure


def footed_figure(gait, samples: int = 801) -> Figure:
    """A step on feet (:class:`problems.walking.footed.FootedGait`) in six panels: link
    angles; the drives' torques; one leg's ground reaction through its stance, heel strike
    to toe-off, in body weights, the phases shaded (the double hump, or not); where the
    ground pushes under that foot (the centre of pressure from the ball: on the heel while
    the foot rolls down, along the sole while it lies flat, at the ball after the heel
    rises); the stance ankle's power (push-off); the swing foot's heel and ball through the
    single support."""
    problem = gait.problem
    names = problem.linkage.names
    n = len(names)
    weight = problem.weight
    figure = Figure(figsize=(13.0, 7.5))
    figure.subplots_adjust(left=0.055, right=0.985, bottom=0.07, top=0.91, wspace=0.3, hspace=0.32)
    axes = figure.subplots(2, 3)
    times, states, torques = gait.fine(samples)
    _angles_and_torques(axes[0, 0], axes[0, 1], times, states, torques, names, problem.drives,
                        "x-small")  # fmt: skip
    stance = gait.stance(samples)
    since = f"t from {problem.striking_point} strike [s]"
    t, force = stance["time"], stance["force"]
    durations = gait.durations()
    # the stance: as the front foot (the double support), its single support's phases, as
    # the rear foot
    edges = np.cumsum([0.0, durations[-1], *durations[:-1], durations[-1]])
    labels = {"flat": "flat foot", "heel rise": "heel rise" if "flat" in problem.sequence
              else "on the ball"}  # fmt: skip
    shades = ("loading (front foot)", *(labels[name] for name in problem.sequence[:-1]),
              "push-off (rear foot)")  # fmt: skip
    for ax in (axes[0, 2], axes[1, 0], axes[1, 1]):  # the stance's phases, shaded
        for k in range(len(shades)):
            ax.axvspan(edges[k], edges[k + 1], color=str(0.95 - 0.05 * (k % 2)), zorder=0)
    ax = axes[0, 2]
    for k, label in enumerate(shades):
        ax.text(0.5 * (edges[k] + edges[k + 1]), 0.02, label, rotation=90, fontsize="x-small",
                ha="center", va="bottom", transform=ax.get_xaxis_transform())  # fmt: skip
    ax.plot(t, force.imag / weight, label="Fy / m g")
    ax.plot(t, force.real / weight, label="Fx / m g")
    ax.set(xlabel=since, ylabel="ground force [body weights]",
           title="one foot through its stance")  # fmt: skip
    ax.legend(fontsize="x-small", loc="upper right")
    ax = axes[1, 0]
    ax.plot(t, 100 * stance["pressure"], label="centre of pressure")
    ax.axhline(0.0, color="0.4", linestyle=":", label="ball")
    ax.axhline(-100 * problem.sole, color="0.4", linestyle="--", label="heel")
    ax.set(xlabel=since, ylabel="from the ball [cm]",
           title="where the ground pushes under the foot")  # fmt: skip
    ax.legend(fontsize="x-small")
    ax = axes[1, 1]
    ax.plot(t, stance["ankle_power"], color="C3")
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.set(xlabel=since, ylabel="P [W]",
           title="the ankle's power through the stance (> 0: push-off)")  # fmt: skip
    ax = axes[1, 2]
    single = times <= sum(durations[:-1]) + 1e-12
    psi = states[single][:, :n]
    for role, style in (("swing_heel", "-"), ("swing_toe", "--")):
        where = problem.point(role).position(psi)
        ax.plot(where.real, where.imag, style, label=role.replace("_", " ").replace("toe", "ball"))
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.plot([0.0, -problem.sole], [0.0, 0.0], "k-", linewidth=3, label="stance foot's sole")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="the swing foot (single support)")
    ax.legend(fontsize="x-small")
    phases = ", ".join(f"{name} {d:.3f} s" for name, d in zip(problem.sequence, durations,
                                                              strict=True))  # fmt: skip
    figure.suptitle(
        f"walking step on feet: {problem.step_length:g} m in {problem.step_time:g} s "
        f"({phases}), cost {gait.cost:.4g} (law {gait.law_cost:.4g}), cost of transport "
        f"{gait.cost_of_transport:.3f}"
    )
    return figure


def _limits(motion: WorldMotion) -> tuple[float, float, float, float]:
    points = np.concatenate([v.reshape(-1) for v in motion.segments.values()])
    x0, x1 = points.real.min(), points.real.max()
    y1 = points.imag.max()
    pad = 0.08 * max(x1 - x0, y1)
    return x0 - pad, x1 + pad, -pad, y1 + pad


def world_strip(motion: WorldMotion, frames_per_step: int = 6, title: str | None = None) -> Figure:
    """Poses of several steps drawn where they happen (world x), the footholds marked;
    ``title`` replaces the default one."""
    x0, x1, y0, y1 = _limits(motion)
    # equal axes 3 inches high, the legend beside them
    figure = Figure(figsize=(min(2.8 + 3.0 * (x1 - x0) / (y1 - y0), 16.0), 4.0),
                    layout="constrained")  # fmt: skip
    draw_world(figure.add_subplot(), motion, frames_per_step, title)
    return figure


def draw_world(ax, motion: WorldMotion, frames_per_step: int = 6, title: str | None = None) -> None:
    """:func:`world_strip`'s drawing on a given matplotlib Axes ``ax`` (to combine it with
    other panels in one figure)."""
    steps = int(motion.step.max()) + 1
    count = max(2, frames_per_step * steps)
    picks = np.unique(np.linspace(0, motion.time.size - 1, count).round().astype(int))
    x0, x1, y0, y1 = _limits(motion)
    for j, (name, segment) in enumerate(motion.segments.items()):
        for k, index in enumerate(picks):
            ax.plot(segment[index].real, segment[index].imag, color=COLOURS[j % len(COLOURS)],
                    linewidth=1.8, marker="o", markersize=2.5, alpha=0.35 + 0.65 * k / len(picks),
                    label=name if k == len(picks) - 1 else None)  # fmt: skip
    ax.plot([x0, x1], [0.0, 0.0], color="0.5", linewidth=0.8, zorder=0)
    ax.plot(motion.footholds.real, motion.footholds.imag, "kv", label="footholds")
    ax.set(xlim=(x0, x1), ylim=(y0, y1), xlabel="x [m]", ylabel="y [m]", aspect="equal")
    ax.set_title(title or f"{steps} steps in world coordinates (later poses darker)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="small", frameon=False,
              title="bodies, named\nas in step 0", title_fontsize="small")  # fmt: skip


def animate_walk(
    motion: WorldMotion,
    path: str | os.PathLike,
    fps: float = 30.0,
    dpi: float = 80.0,
    caption: str = "",
    window: float | None = None,
) -> Path:
    """A GIF of the steps of ``motion`` in world coordinates, one frame per 1/fps s of gait
    time (real time), written atomically; ``caption`` heads every frame's clock. ``window``
    m: the view follows the body over that width of the ground (default: all of the walk
    in view; a long walk would draw the body too small)."""
    path = Path(os.fspath(path))
    if path.suffix.lower() != ".gif":
        raise DefinitionError(f"`path`: an animation is a .gif file, got {str(path)!r}")
    fps = check_positive("fps", fps, "frames per second")
    duration = motion.time[-1] - motion.time[0]
    frames = np.linspace(motion.time[0], motion.time[-1], max(2, round(duration * fps) + 1))
    picks = np.searchsorted(motion.time, frames).clip(0, motion.time.size - 1)
    x0, x1, y0, y1 = _limits(motion)
    segments = list(motion.segments.values())
    centres = np.mean([segment.real.mean(axis=1) for segment in segments], axis=0)
    if window is not None:
        window = check_positive("window", window, "m")
    view = x1 - x0 if window is None or window >= x1 - x0 else window
    if view < x1 - x0:  # following: the ground's margin of the view, not of the whole walk
        top = y1 - 0.08 * max(x1 - x0, y1)
        pad = 0.08 * max(view, top)
        y0, y1 = -pad, top + pad
    width = 6.0
    figure = Figure(figsize=(width, width * (y1 - y0) / view + 0.6), dpi=dpi,
                    layout="constrained")  # fmt: skip
    ax = figure.add_subplot()
    ax.set(xlim=(x0, x1), ylim=(y0, y1), aspect="equal", xlabel="x [m]", ylabel="y [m]")
    ax.plot([x0, x1], [0.0, 0.0], color="0.5", linewidth=0.8, zorder=0)
    ax.plot(motion.footholds.real, motion.footholds.imag, "kv")
    lines = [
        ax.plot([], [], color=COLOURS[j % len(COLOURS)], linewidth=2.5, marker="o",
                markersize=3.0, solid_capstyle="round", label=name)[0]
        for j, name in enumerate(motion.segments)
    ]  # fmt: skip
    ax.legend(loc="upper right", fontsize="x-small", frameon=False, title="named as in step 0",
              title_fontsize="x-small")  # fmt: skip
    clock = ax.set_title(f"{caption}t = {motion.time[-1]:.3f} s, step 99")  # laid out once
    follow = view < x1 - x0
    with GifFrames(figure, [*lines, clock], fps=fps, dpi=dpi, full=follow) as gif:
        for index in picks:
            for line, segment in zip(lines, segments, strict=True):
                line.set_data(segment[index].real, segment[index].imag)
            if follow:  # the body in view, the view inside the walk's extent
                left = min(max(centres[index] - view / 2, x0), x1 - view)
                ax.set_xlim(left, left + view)
            clock.set_text(f"{caption}t = {motion.time[index]:.3f} s, step {motion.step[index]}")
            gif.grab()
        gif.save(path)
    return path


def save_figure(figure: Figure, path: str | os.PathLike, dpi: float = 100.0) -> Path:
    """Write ``figure`` as PNG atomically, drawn once (``savefig`` draws a figure with a
    layout engine twice: once to lay it out, once to print it)."""
    path = Path(os.fspath(path))
    figure.set_dpi(check_positive("dpi", dpi, "dots per inch"))
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    image = Image.fromarray(np.asarray(canvas.buffer_rgba()))
    with atomic_path(path, suffix=path.suffix) as temporary:
        image.save(temporary, format="PNG", dpi=(dpi, dpi))
    return path


__all__ = [
    "animate_walk",
    "draw_world",
    "footed_figure",
    "gait_figure",
    "save_figure",
    "world_strip",
]


def closed_loop_figure(check) -> Figure:
    """The closed-loop check (:class:`problems.control.feedback.ClosedLoopCheck`): the
    largest angle error from the plan at the same phase, per step and case, and the open-loop
    replay's error against time until it falls."""
    figure = Figure(figsize=(11.0, 4.2))
    FigureCanvasAgg(figure)
    errors, open_axis = figure.subplots(1, 2)
    for label, run in check.runs.items():
        if run.steps:
            tracking = [max(r.tracking, 1e-9) for r in run.steps]
            errors.semilogy(range(len(tracking)), tracking, marker=".", label=
                            f"{label} ({run.walked}/{check.steps})")  # fmt: skip
        else:
            errors.plot([], [], label=f"{label} (fell in step 0)")
    errors.set_xlabel("step (from 0, as the tables count)")
    errors.set_ylabel("largest |psi - psi_ref(s)| in the step, rad")
    errors.set_title(
        f"closed loop (periodic LQR): largest multiplier {check.loop.spectral_radius:.3f}"
    )
    errors.legend(fontsize="small")
    errors.grid(True, which="both", alpha=0.3)
    run = check.open_loop
    reference = check.reference
    n = reference.n
    deviation = [
        np.abs(x[:n] - reference.at_time(t)[0][:n]).max()
        for t, x in zip(run.time, run.states, strict=True)
    ]
    open_axis.semilogy(run.time, np.maximum(deviation, 1e-12), color="C3")
    open_axis.set_xlabel("t, s")
    open_axis.set_ylabel("largest |psi - psi_plan(t)|, rad")
    why = run.fell or "walked every step"
    open_axis.set_title("open loop (the plan's torques alone)", fontsize="medium")
    open_axis.text(0.02, 0.02, _wrap(why, 55), transform=open_axis.transAxes, fontsize="small")
    open_axis.grid(True, which="both", alpha=0.3)
    figure.tight_layout()
    return figure


def _wrap(text: str, width: int) -> str:
    words, lines, line = text.split(), [], ""
    for word in words:
        if len(line) + len(word) + 1 > width and line:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return "\n".join([*lines, line])
