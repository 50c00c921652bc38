"""Drawings of a linkage moving: stick-figure strips and GIF animations.

Every function builds a :class:`matplotlib.figure.Figure` directly (not through pyplot), so the
library leaves no figure registered in pyplot's global state, needs no interactive backend
(``MPLBACKEND=Agg`` works) and never calls ``plt.show``; the caller saves or shows what it
gets back. A figure passed in through ``ax`` is drawn into and returned. matplotlib is
imported with this module, which ``model`` does not import: ``from model import drawing``.

The geometry comes from a :class:`model.Dynamics`: link i is drawn from its start hinge
H_{parent(i)} (H0 for the root) to its end hinge H_i, with the hinge positions of
``dynamics.hinge_positions`` (complex x + j y, m), along a linkage trajectory
(:class:`model.LinkageTrajectory`). The planner's generic plot of channels against time is
:func:`planner.plots.plot_trajectory`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from model.dynamics import Dynamics
from model.linkage_naming import CONVENTION
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import (
    DefinitionError,
    DefinitionTypeError,
    check_integer,
    check_positive,
    check_real,
)
from planner.gif import GifFrames
from planner.trajectory import Trajectory, TrajectoryFileError, TrajectoryFileNotFoundError
from planner.trajectory.plot import COLOURS


# ---- linkage geometry ---------------------------------------------------------------------
def _check_linkage(dynamics: Dynamics, trajectory: Trajectory) -> LinkageTrajectory:
    """``trajectory`` as a LinkageTrajectory of ``dynamics``' links, or raise naming it."""
    if not isinstance(dynamics, Dynamics):
        raise DefinitionTypeError(
            f"`dynamics`: must be a model.Dynamics, got {type(dynamics).__name__}"
        )
    if not isinstance(trajectory, Trajectory):
        raise DefinitionTypeError(
            f"`trajectory`: must be a planner.trajectory.Trajectory, got "
            f"{type(trajectory).__name__}"
        )
    trajectory = LinkageTrajectory.of(trajectory)
    if not trajectory.is_linkage:
        raise DefinitionError(
            f"`trajectory`: a stick figure needs a linkage trajectory ({CONVENTION}), got "
            f"states {list(trajectory.state_names)}"
        )
    if tuple(trajectory.link_names) != tuple(dynamics.linkage.names):
        raise DefinitionError(
            f"`trajectory`: its links {list(trajectory.link_names)} differ from the dynamics' "
            f"links {list(dynamics.linkage.names)}; draw it with the model it was made for"
        )
    return trajectory


def _poses(dynamics: Dynamics, trajectory: LinkageTrajectory, times: np.ndarray) -> np.ndarray:
    """(F, n+1) complex hinge positions H0..Hn, m, at ``times`` (s) through the interpolant."""
    n = len(trajectory.link_names)
    states, _ = trajectory.at(times)
    hinges = np.asarray(dynamics.hinge_positions(states[:, :n]))
    return hinges.reshape(len(times), n + 1)


def _segment_starts(dynamics: Dynamics) -> np.ndarray:
    """Index in the hinge array of each link's start hinge: H_{parent} is parent + 1, the
    root (parent -1) starts at H0."""
    return np.asarray(dynamics.linkage.parents, dtype=int) + 1


def _limits(points: np.ndarray, margin: float = 0.08) -> tuple[float, float, float, float]:
    """Equal-aspect-friendly box around complex ``points`` with a relative margin."""
    x0, x1 = float(points.real.min()), float(points.real.max())
    y0, y1 = float(min(points.imag.min(), 0.0)), float(points.imag.max())
    pad = margin * max(x1 - x0, y1 - y0, 1e-3)
    return x0 - pad, x1 + pad, y0 - pad, y1 + pad


def stick_figure_strip(
    dynamics: Dynamics,
    trajectory: Trajectory,
    n_frames: int = 8,
    ax: Axes | None = None,
    *,
    spacing: float | None = None,
    figsize: tuple[float, float] | None = None,
) -> Figure:
    """Poses of a linkage at ``n_frames`` evenly spaced times, side by side.

    Pose k (time t0 + k (tf - t0) / (n_frames - 1), from the trajectory's interpolant) is
    shifted by k * ``spacing`` along x. Each link is one line from its start hinge to its end
    hinge, with the hinges marked, in the same colour in every pose; the ground (y = 0) is one
    more line, and each pose is labelled with its time. So the axes hold
    ``n_frames * n_links + 1`` lines.

    Parameters
    ----------
    dynamics : model.Dynamics of the linkage the trajectory was made for.
    trajectory : linkage trajectory (``LinkageTrajectory.is_linkage``).
    n_frames : number of poses, >= 1.
    ax : axes to draw into; default a new figure.
    spacing : shift between poses, m; default 1.15 x the x range of all poses together (at
        least a third of their height), so neighbouring poses do not overlap.
    figsize : inches, for a new figure.

    Returns
    -------
    The figure holding the axes.
    """
    trajectory = _check_linkage(dynamics, trajectory)
    frames = check_integer("n_frames", n_frames, 1)
    times = (
        np.array([trajectory.t0])
        if frames == 1
        else np.linspace(trajectory.t0, trajectory.tf, frames)
    )
    hinges = _poses(dynamics, trajectory, times)
    starts = _segment_starts(dynamics)
    # Poses are drawn relative to their own H0, so the x range of all poses together (not
    # the widest single pose) is what keeps neighbours apart.
    width = float(np.ptp(hinges.real))
    height = float(np.ptp(hinges.imag))
    if spacing is None:
        spacing = max(1.15 * width, height / 3.0, 1e-3)
    elif check_real("spacing", spacing) < 0:
        raise DefinitionError(f"`spacing`: must be >= 0 m, got {spacing!r}")
    shifted = hinges + spacing * np.arange(frames)[:, None]
    if ax is None:
        size = figsize or (min(2.0 + 1.3 * frames, 16.0), 3.5)
        figure = Figure(figsize=size, layout="constrained")
        ax = figure.add_subplot()
    elif not isinstance(ax, Axes):
        raise DefinitionTypeError(f"`ax`: must be matplotlib Axes or None, got {ax!r}")
    names = dynamics.linkage.names
    for k in range(frames):
        for i, name in enumerate(names):
            start, end = shifted[k, starts[i]], shifted[k, i + 1]
            ax.plot(
                [start.real, end.real],
                [start.imag, end.imag],
                color=COLOURS[i % len(COLOURS)],
                linewidth=2.0,
                marker="o",
                markersize=3.0,
                solid_capstyle="round",
                label=name if k == 0 else None,
            )
    x0, x1, y0, y1 = _limits(shifted)
    ax.plot([x0, x1], [0.0, 0.0], color="0.5", linewidth=0.8, zorder=0)
    for k, t in enumerate(times):
        ax.annotate(
            f"{t:.3g} s",
            (shifted[k, 0].real, y0),
            ha="center",
            va="bottom",
            fontsize="small",
        )
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0 - 0.05 * (y1 - y0), y1)
    ax.set_aspect("equal")
    ax.set_xlabel(f"x [m] (pose k shifted by k x {spacing:.3g} m)")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="small", frameon=False)
    return ax.figure


# ---- animation ----------------------------------------------------------------------------
def animate(
    dynamics: Dynamics,
    trajectory: Trajectory,
    path: str | os.PathLike,
    fps: float = 30,
    *,
    n_frames: int | None = None,
    dpi: float = 80,
    figsize: tuple[float, float] = (4.0, 4.0),
) -> Path:
    """Write a GIF of the linkage moving along the trajectory (:class:`planner.gif.GifFrames`:
    the figure drawn once, the links redrawn over it).

    Frames at ``n_frames`` evenly spaced times from t0 to tf; by default one per 1/fps of
    trajectory time (plus the end), so the GIF plays in real time. The write is atomic: the
    GIF is rendered into a temporary file in the same folder and renamed over ``path`` only
    when complete. Pillow merges consecutive identical frames, so a motionless stretch
    yields fewer frames than asked for.

    Parameters
    ----------
    dynamics : model.Dynamics of the linkage.
    trajectory : linkage trajectory.
    path : output file, suffix ``.gif``; its folder must exist.
    fps : frames per second of playback, > 0.
    n_frames : number of frames, >= 2; default round((tf - t0) fps) + 1.
    dpi, figsize : resolution (dots per inch) and size (inches) of each frame.

    Returns
    -------
    The path written.
    """
    trajectory = _check_linkage(dynamics, trajectory)
    path = Path(os.fspath(path))
    if path.suffix.lower() != ".gif":
        raise TrajectoryFileError(
            f"{path}: an animation is written as GIF; give a file name ending in .gif"
        )
    if not path.parent.is_dir():
        raise TrajectoryFileNotFoundError(
            f"{path}: cannot save, the folder {str(path.parent)!r} does not exist; create it first"
        )
    fps = check_positive("fps", fps, "frames per second")
    if n_frames is None:
        frames = max(2, round(trajectory.duration * fps) + 1)
    else:
        frames = check_integer("n_frames", n_frames, 2)
    times = np.linspace(trajectory.t0, trajectory.tf, frames)
    hinges = _poses(dynamics, trajectory, times)
    starts = _segment_starts(dynamics)
    names = dynamics.linkage.names

    figure = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = figure.add_subplot()
    x0, x1, y0, y1 = _limits(hinges)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.plot([x0, x1], [0.0, 0.0], color="0.5", linewidth=0.8, zorder=0)
    lines = [
        ax.plot([], [], color=COLOURS[i % len(COLOURS)], linewidth=2.5, marker="o",
                markersize=3.5, solid_capstyle="round", label=name)[0]
        for i, name in enumerate(names)
    ]  # fmt: skip
    clock = ax.set_title(f"t = {times[-1]:.3f} s")  # the layout makes room for it once
    ax.legend(loc="upper right", fontsize="x-small", frameon=False)

    with GifFrames(figure, [*lines, clock], fps=fps, dpi=dpi) as gif:
        for k, t in enumerate(times):
            for i, line in enumerate(lines):
                start, end = hinges[k, starts[i]], hinges[k, i + 1]
                line.set_data([start.real, end.real], [start.imag, end.imag])
            clock.set_text(f"t = {t:.3f} s")
            gif.grab()
        gif.save(path)
    return path


__all__ = ["animate", "stick_figure_strip"]
