"""The plot of a trajectory's channels against time.

Every function builds a :class:`matplotlib.figure.Figure` directly (not through pyplot), so the
library leaves no figure registered in pyplot's global state, needs no interactive backend
(``MPLBACKEND=Agg`` works) and never calls ``plt.show``; the caller saves or shows what it
gets back. A figure passed in through ``ax`` is drawn into and returned.

The drawings of a linkage moving (stick figures, GIFs) are the linkage's side:
:mod:`model.drawing`.
"""

from __future__ import annotations

from matplotlib.figure import Figure

from planner.errors import (
    DefinitionTypeError,
)
from planner.trajectory import (
    Trajectory,
)
from planner.trajectory.plot import draw


def plot_trajectory(
    trajectory: Trajectory,
    *,
    extras: bool = False,
    figsize: tuple[float, float] | None = None,
    title: str | None = None,
) -> Figure:
    """States and controls (and optionally the extras) against time, one panel per group
    and unit: :func:`planner.trajectory.plot.draw` (the plot of ``Trajectory.plot``) for a
    checked ``trajectory``. Returns a matplotlib Figure not registered with pyplot."""
    if not isinstance(trajectory, Trajectory):
        raise DefinitionTypeError(
            f"`trajectory`: must be a planner.trajectory.Trajectory, got "
            f"{type(trajectory).__name__}"
        )
    return draw(trajectory, extras=extras, figsize=figsize, title=title)


__all__ = ["plot_trajectory"]
