"""Pictures of a walk sequence: its speed over time, its torques, its steps."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from model.linkage_trajectory import LinkageTrajectory
from problems.walking.step import WorldMotion

COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
           "tab:pink", "tab:gray")  # fmt: skip
KIND_COLOURS = {"start": "tab:green", "gait": "0.85", "change": "tab:orange", "stop": "tab:red"}


def hip_speed(motion: WorldMotion, hip_link: str) -> tuple[np.ndarray, np.ndarray]:
    """(time (K,) s, the hip's forward speed (K,) m/s): the world x of ``hip_link``'s start
    (the trunk's: the hip) differentiated by central differences within each step (the
    speed jumps at a heel strike: no difference across one)."""
    x = motion.segments[hip_link][:, 0].real
    speed = np.full(x.shape, np.nan)
    for j in np.unique(motion.step):
        rows = np.flatnonzero(motion.step == j)
        if rows.size >= 2:
            speed[rows] = np.gradient(x[rows], motion.time[rows])
    return motion.time, speed


def sequence_figure(trajectory, motion: WorldMotion, hip_link: str, limit: float | None) -> Figure:
    """Three panels over the walk's time: the hip's forward speed with each step's own speed
    (length / time) and the commanded speeds, the kinds of steps shaded (start, gait,
    change, stop); every drive's torque with the limit (on feet not the ground's on the
    stance foot); each step's length."""
    trajectory = LinkageTrajectory.of(trajectory)
    meta = trajectory.metadata["sequence"]
    steps = meta["steps"]
    figure = Figure(figsize=(11.0, 9.0), layout="constrained")
    speed_ax, torque_ax, length_ax = figure.subplots(3, 1)
    for step in steps:
        start, end = step["start_s"], step["start_s"] + step["step_time_s"]
        for ax in (speed_ax, torque_ax):
            ax.axvspan(start, end, color=KIND_COLOURS[step["kind"]], alpha=0.25, linewidth=0)
    time, speed = hip_speed(motion, hip_link)
    speed_ax.plot(time, speed, color="tab:blue", linewidth=1.0, label="hip's forward speed")
    edges = [s["start_s"] for s in steps] + [steps[-1]["start_s"] + steps[-1]["step_time_s"]]
    own = [s["speed_m_s"] for s in steps]
    speed_ax.stairs(own, edges, color="k", linewidth=1.5, label="each step's length / time")
    speed_ax.set(ylabel="speed [m/s]", xlim=(edges[0], edges[-1]),
                 title="commanded " + " -> ".join(f"{v:g}" for v in meta["commanded_speeds_m_s"])
                 + " m/s; shaded: start (green), change (orange), stop (red) steps")  # fmt: skip
    speed_ax.legend(loc="upper right", fontsize="small")
    torques = np.asarray(trajectory.torques)
    # on feet the root's torque is the ground's on the stance foot (no drive, no limit)
    drives = meta["steps"][0]["settings"].get("drives") or trajectory.link_names
    for i, name in enumerate(trajectory.link_names):
        if name not in drives:
            continue
        torque_ax.plot(trajectory.time, torques[:, i], color=COLOURS[i % len(COLOURS)],
                       linewidth=0.8, label=f"M_{name}")  # fmt: skip
    if limit is not None:
        for sign in (-1, 1):
            torque_ax.axhline(sign * limit, color="k", linestyle="--", linewidth=0.8)
    torque_ax.set(
        ylabel="hinge torque [N m]",
        xlim=(edges[0], edges[-1]),
        title="torques in the model's labels (stance_* is each step's stance leg)"
        + ("" if len(drives) == len(trajectory.link_names) else "; the drives' only"),
    )
    torque_ax.legend(loc="upper right", fontsize="x-small", ncol=3)
    index = np.arange(len(steps))
    colours = [KIND_COLOURS[s["kind"]] for s in steps]
    length_ax.bar(index, [s["step_length_m"] for s in steps], color=colours, edgecolor="0.3")
    length_ax.set(xlabel="step", ylabel="step length [m]", title="step lengths (a stop's last "
                  "step lands beside the stance foot: 0)")  # fmt: skip
    torque_ax.set_xlabel("t [s]")
    return figure


__all__ = ["hip_speed", "sequence_figure"]
