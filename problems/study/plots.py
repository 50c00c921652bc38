"""Pictures of a walking study: cost of transport and peak torques against speed, and a heat
map of the cost over the grid with the failed points marked.

Curves run along the study's first axis, one per value of the other axes (for a study over
step length x step time: one curve per step time, the speed growing with the step length).
Figures are built directly (``matplotlib.figure.Figure``, no pyplot state) and written
atomically (``problems.walking.plots.save_figure``).
"""

from __future__ import annotations

import itertools
import math
import os
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from problems.study.result import StudyResult
from problems.walking.plots import save_figure

#: File names of :func:`save_plots`.
FILES = ("cost_of_transport.png", "peak_torque.png", "cost_map.png")
UNITS = {
    "step_length": "m",
    "step_time": "s",
    "mu": "",
    "torque_limit": "N m",
    "clearance": "m",
    "double_support": "s",
}


def _label(name: str) -> str:
    """An axis label: "step length (m)"."""
    unit = UNITS.get(name, "")
    return name.replace("_", " ") + (f" ({unit})" if unit else "")


def _value(name: str, value) -> str:
    unit = UNITS.get(name, "")
    text = f"{value:.4g}" if isinstance(value, float) else str(value)
    return f"{name} = {text}{' ' + unit if unit else ''}"


def _curves(result: StudyResult):
    """(label, rows along axis 0 as indices into the grid) for each combination of the other
    axes' values."""
    names = list(result.axes)
    others = [range(len(result.axes[n])) for n in names[1:]]
    for rest in itertools.product(*others):
        label = ", ".join(
            _value(n, result.axes[n][i]) for n, i in zip(names[1:], rest, strict=True)
        )
        indices = [(i, *rest) for i in range(len(result.axes[names[0]]))]
        yield label or "all points", indices


def _x(result: StudyResult) -> tuple[np.ndarray, str]:
    if "speed" in result.columns:
        return result.grid("speed"), "speed (m/s)"
    first = next(iter(result.axes))
    values = np.asarray(result.axes[first], dtype=float)
    shape = result.shape
    grid = np.broadcast_to(values.reshape((-1,) + (1,) * (len(shape) - 1)), shape)
    return np.array(grid), _label(first)


def _colours(count: int):
    cmap = colormaps["viridis"]
    return [cmap(0.9 * k / max(count - 1, 1)) for k in range(count)]


def cost_of_transport_figure(result: StudyResult) -> Figure:
    """Cost of transport (positive work per weight and distance) against speed, one curve
    per value of the other axes; failed points leave gaps."""
    figure = Figure(figsize=(7.0, 4.5), layout="constrained")
    axes = figure.add_subplot()
    x, xlabel = _x(result)
    column = "cost_of_transport" if "cost_of_transport" in result.columns else "cost"
    y = result.grid(column) if column in result.columns else np.full(result.shape, math.nan)
    curves = list(_curves(result))
    for (label, indices), colour in zip(curves, _colours(len(curves)), strict=True):
        axes.plot(
            [x[i] for i in indices], [y[i] for i in indices], "o-", color=colour, label=label, ms=4
        )
    axes.set_xlabel(xlabel)
    axes.set_ylabel("cost of transport (-)" if column == "cost_of_transport" else "cost")
    axes.set_title("cost of transport against speed")
    axes.grid(True, alpha=0.3)
    if len(curves) > 1:
        axes.legend(fontsize="small", loc="best")
    return figure


def peak_torque_figure(result: StudyResult) -> Figure:
    """The largest |M_i| of each hinge against speed, one panel per hinge, one curve per
    value of the other axes."""
    hinges = [
        c.removeprefix("peak_torque_") for c in result.columns if c.startswith("peak_torque_")
    ]
    count = max(len(hinges), 1)
    columns = min(3, count)
    rows = math.ceil(count / columns)
    figure = Figure(figsize=(4.0 * columns, 3.0 * rows), layout="constrained")
    x, xlabel = _x(result)
    curves = list(_curves(result))
    colours = _colours(len(curves))
    for k, hinge in enumerate(hinges):
        axes = figure.add_subplot(rows, columns, k + 1)
        y = result.grid(f"peak_torque_{hinge}")
        for (label, indices), colour in zip(curves, colours, strict=True):
            axes.plot([x[i] for i in indices], [y[i] for i in indices], "o-", color=colour,
                      label=label, ms=3)  # fmt: skip
        axes.set_title(f"M at {hinge}", fontsize="medium")
        axes.set_xlabel(xlabel)
        axes.set_ylabel("peak |M| (N m)")
        axes.grid(True, alpha=0.3)
        if k == 0 and len(curves) > 1:
            axes.legend(fontsize="x-small", loc="best")
    if not hinges:
        figure.add_subplot().text(0.5, 0.5, "no peak torques recorded", ha="center")
    figure.suptitle("peak hinge torque against speed")
    return figure


def cost_map_figure(result: StudyResult, column: str = "cost") -> Figure:
    """A heat map of ``column`` over the first two axes (later axes at their first value),
    failed points marked with a red cross, missing ones hatched."""
    names = list(result.axes)
    status = result.status_grid()
    values = result.grid(column) if column in result.columns else np.full(result.shape, math.nan)
    if len(names) == 1:
        values, status = values[:, None], status[:, None]
        second, second_values = "", ("",)
    else:
        second, second_values = names[1], result.axes[names[1]]
        cut = (slice(None), slice(None)) + (0,) * (len(names) - 2)
        values, status = values[cut], status[cut]
    first, first_values = names[0], result.axes[names[0]]
    figure = Figure(figsize=(1.0 + 0.9 * max(len(second_values), 4), 1.2 + 0.6 * len(first_values)),
                    layout="constrained")  # fmt: skip
    axes = figure.add_subplot()
    finite = values[np.isfinite(values)]
    if finite.size and finite.min() > 0 and finite.max() / finite.min() > 10:
        norm = LogNorm(finite.min(), finite.max())
    elif finite.size:
        norm = Normalize(finite.min(), max(finite.max(), finite.min() + 1e-12))
    else:
        norm = Normalize(0.0, 1.0)
    image = axes.imshow(
        np.ma.masked_invalid(values), origin="lower", aspect="auto", cmap="viridis", norm=norm
    )
    scale = ", log scale" if isinstance(norm, LogNorm) else ""
    what = "cost: the objective at the optimum" if column == "cost" else column
    figure.colorbar(image, ax=axes, label=f"{what}{scale}")
    annotate = values.size <= 200
    for (i, j), state in np.ndenumerate(status):
        if state == "failed":
            axes.plot(j, i, marker="x", color="red", ms=14, mew=3)
        elif state == "missing":
            axes.add_patch(_hatch(j, i))
        elif annotate and np.isfinite(values[i, j]):
            shade = norm(values[i, j])
            axes.text(j, i, f"{values[i, j]:.4g}", ha="center", va="center", fontsize="x-small",
                      color="black" if shade > 0.5 else "white")  # fmt: skip
    axes.set_yticks(range(len(first_values)), [f"{v:.4g}" if isinstance(v, float) else str(v)
                                                for v in first_values])  # fmt: skip
    axes.set_ylabel(_label(first))
    axes.set_xticks(range(len(second_values)), [f"{v:.4g}" if isinstance(v, float) else str(v)
                                                 for v in second_values])  # fmt: skip
    if second:
        axes.set_xlabel(_label(second))
    failed = int(np.sum(status == "failed"))
    missing = int(np.sum(status == "missing"))
    notes = []
    if failed:
        notes.append(f"x: {failed} failed")
    if missing:
        notes.append(f"hatched: {missing} not solved yet")
    if len(names) > 2:
        notes.append(", ".join(_value(n, result.axes[n][0]) for n in names[2:]))
    axes.set_title(f"{column} over the grid" + (f" ({'; '.join(notes)})" if notes else ""),
                   fontsize="medium")  # fmt: skip
    return figure


def _hatch(x: float, y: float) -> Rectangle:
    return Rectangle((x - 0.5, y - 0.5), 1.0, 1.0, fill=False, hatch="//", color="0.6")


def save_plots(result: StudyResult, folder: str | os.PathLike | None = None) -> list[Path]:
    """Write :data:`FILES` to ``folder`` (default the study's own folder); returns the paths."""
    folder = result.folder if folder is None else Path(os.fspath(folder))
    figures = (cost_of_transport_figure, peak_torque_figure, cost_map_figure)
    return [
        save_figure(make(result), folder / name) for make, name in zip(figures, FILES, strict=True)
    ]


__all__ = [
    "FILES",
    "cost_map_figure",
    "cost_of_transport_figure",
    "peak_torque_figure",
    "save_plots",
]
