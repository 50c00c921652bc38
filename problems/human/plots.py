"""The picture a biomechanist expects: a planned gait against recorded data over the cycle.

Nine panels, time in % of the cycle from heel strike, each one's toe-off a dashed line: hip,
knee and ankle angles; their moments (extensor / plantarflexor positive, N m/kg); the thigh's
inclination and the ground force's forward and vertical components in body weights.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from problems.human.comparison import GaitComparison
from problems.human.recording import CHANNELS

#: The panels, row by row.
PANELS = (
    ("hip", "knee", "ankle"),
    ("hip_moment", "knee_moment", "ankle_moment"),
    ("thigh", "force_x", "force_y"),
)
MODEL_COLOUR, DATA_COLOUR = "#d62728", "#444444"


def comparison_figure(comparison: GaitComparison, title: str | None = None) -> Figure:
    """The figure of :data:`PANELS` (model red, data grey), RMS and r in each title."""
    figure = Figure(figsize=(12.0, 9.5), layout="constrained")
    axes = figure.subplots(3, 3, sharex=True)
    cycle = np.linspace(0.0, 100.0, 1001)
    model, data = comparison.model, comparison.data
    for row, names in zip(axes, PANELS, strict=True):
        for ax, name in zip(row, names, strict=True):
            _, unit, label = CHANNELS[name]
            drawn = False
            for recording, colour, who in (
                (data, DATA_COLOUR, "human"),
                (model, MODEL_COLOUR, "model"),
            ):
                if recording.has(name):
                    ax.plot(cycle, recording.at(name, cycle), color=colour, lw=1.8, label=who)
                    ax.axvline(100 * recording.stance_fraction, color=colour, ls="--", lw=0.8)
                    drawn = True
            metrics = comparison.channels.get(name)
            extra = "" if metrics is None else f"\nRMS {metrics.rms:.2f}, r {metrics.r:.2f}"
            if metrics is not None and metrics.over == "stance":
                extra += " (stance)"
            ax.set_title(f"{label}{extra}", fontsize=9)
            ax.set_ylabel(unit)
            ax.axhline(0.0, color="#bbbbbb", lw=0.6)
            ax.grid(alpha=0.3)
            if not drawn:
                ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center")
    for ax in axes[-1]:
        ax.set_xlabel("% of the gait cycle (heel strike to heel strike)")
        ax.set_xlim(0.0, 100.0)
    axes[0][0].legend(loc="best", fontsize=8)
    figure.suptitle(
        title or f"{model.source}\nagainst {data.source} (dashed: toe-off)", fontsize=10
    )
    return figure
