"""The trajectory's own plot: its channels against time (``Trajectory.plot``).

matplotlib is optional and heavy: it is imported when a figure is drawn, not when the
trajectory package is (the planner core must not pay for it). The figure is built directly
(not through pyplot), so nothing is registered in pyplot's global state and no interactive
backend is needed. :func:`planner.plots.plot_trajectory` is the same plot for any trajectory
argument (checked), beside the linkage drawings.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from planner.errors import DefinitionError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from planner.trajectory.channels import Channels

#: Colours of the links, cycled: matplotlib's tab10, so a link keeps its colour in every plot.
COLOURS = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)  # fmt: skip


def _panels(trajectory: Channels, extras: bool) -> list[tuple[str, str, list[str]]]:
    """(label, unit, channel names) per panel: each group split by unit, in column order."""
    panels: list[tuple[str, str, list[str]]] = []
    for name, unit, group in trajectory.columns[1:]:
        if group == "extra" and not extras:
            continue
        for label, panel_unit, names in panels:
            if label == group and panel_unit == unit:
                names.append(name)
                break
        else:
            panels.append((group, unit, [name]))
    return panels


def _common_prefix(names: Sequence[str]) -> str:
    """``psi`` for psi_a, psi_b: the part before the first underscore when all names share it."""
    heads = {name.split("_", 1)[0] for name in names}
    if len(heads) == 1 and all("_" in name for name in names):
        return heads.pop()
    return ""


def draw(
    trajectory: Channels,
    *,
    extras: bool = False,
    figsize: tuple[float, float] | None = None,
    title: str | None = None,
) -> Figure:
    """States and controls (and optionally the extras) against time.

    One panel per group (state, control, extra) and unit, stacked with a shared time axis:
    for a linkage trajectory psi [rad], dpsi [rad/s] and M [N m] (plus ddpsi [rad/s^2] and
    the contact forces F_<contact>_x, _y [N] with ``extras=True``). One line per channel,
    labelled by name; the vertical axis carries the channels' common prefix (or names) and
    the unit.

    Parameters
    ----------
    trajectory : the samples to draw (lines through the samples, no interpolation).
    extras : also draw the derived channels.
    figsize : inches; default 8 wide and 2.2 per panel.
    title : figure title; default the metadata's ``source`` when there is one.

    Returns
    -------
    matplotlib.figure.Figure, not registered with pyplot (save it with ``savefig``).
    """
    panels = _panels(trajectory, extras)
    if not panels:
        raise DefinitionError("`trajectory`: has no channels to plot")
    from matplotlib.figure import Figure  # optional and heavy: imported when drawing

    figure = Figure(figsize=figsize or (8.0, 0.8 + 2.2 * len(panels)), layout="constrained")
    axes = figure.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    time = trajectory.time
    for ax, (group, unit, names) in zip(axes, panels, strict=True):
        prefix = _common_prefix(names)
        for j, name in enumerate(names):
            label = name[len(prefix) + 1 :] if prefix else name
            ax.plot(time, trajectory.column(name), color=COLOURS[j % len(COLOURS)], label=label)
        # psi, dpsi, M for a linkage; otherwise the channel names when few, else the group
        label = prefix or (", ".join(names) if len(names) <= 3 else group)
        ax.set_ylabel(f"{label} [{unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="small", frameon=False)
    axes[-1].set_xlabel("t [s]")
    axes[-1].set_xlim(time[0], time[-1])
    heading = title if title is not None else trajectory.metadata.get("source")
    if heading:
        figure.suptitle(str(heading))
    return figure


__all__ = ["COLOURS", "draw"]
