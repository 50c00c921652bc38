"""A planned gait against a recorded one: the metrics a biomechanist reads.

Both are :class:`GaitRecording` values (one leg's cycle from heel strike). Joint angles and
moments are compared over the cycle, the ground force over each one's own stance (time in %
of the stance: a model whose toe-off comes earlier is not charged for the shift twice), on
uniform grids of :data:`GRID` points, each linear between its samples:

* per channel: each one's range, the RMS of the difference, Pearson's r (over the samples
  where both are finite);
* the knee's loading-response flexion (its largest in the first 25 % of the cycle) and its
  swing peak (largest after toe-off) with when it comes (% of the cycle);
* the vertical force's two humps and the valley between them (the largest in the first and
  last halves of the stance, the least between, body weights, when: % of the stance);
* the peak extensor (plantarflexor) moment of each joint, N m/kg, and when (% of the cycle);
* the stance fraction (toe-off, % of the cycle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from problems.human.recording import CHANNELS, FORCES, MOMENTS, GaitRecording

#: Samples of the comparison grids (over the cycle and over the stance), 0.1 % apart.
GRID = 1001
#: The loading response: the first 25 % of the cycle (Perry: 0-10 %; the knee's flexion
#: peaks at about 15 % in Winter's data, so the window takes it whole).
LOADING_RESPONSE = 25.0


@dataclass(frozen=True)
class ChannelMetrics:
    """One channel: ``model`` and ``data`` ranges (min, max), ``rms`` of the difference,
    Pearson's ``r`` (NaN when either is constant), over the cycle or, for forces, the stance
    (``over``)."""

    channel: str
    model: tuple[float, float]
    data: tuple[float, float]
    rms: float
    r: float
    over: str


@dataclass(frozen=True)
class Feature:
    """A named value of both gaits: ``model`` and ``data`` (unit ``unit``), and when they
    happen (``model_at``, ``data_at``, % of the cycle or the stance as ``at_unit`` says, NaN
    when not a peak)."""

    name: str
    unit: str
    model: float
    data: float
    model_at: float = math.nan
    data_at: float = math.nan
    at_unit: str = ""


@dataclass(frozen=True)
class GaitComparison:
    """:func:`compare_gait`'s result: ``channels`` (:class:`ChannelMetrics` by channel),
    ``features`` (:class:`Feature` by name), the two recordings."""

    model: GaitRecording
    data: GaitRecording
    channels: dict[str, ChannelMetrics]
    features: dict[str, Feature]

    def table(self) -> str:
        """The comparison as a Markdown table (the command prints it)."""
        lines = [
            "| quantity | model | human | RMS diff | r |",
            "|---|---|---|---|---|",
        ]
        for name, metrics in self.channels.items():
            _, unit, label = CHANNELS[name]
            over = " (over the stance)" if metrics.over == "stance" else ""
            lines.append(
                f"| {label}, {unit}{over} | {_range(metrics.model)} | {_range(metrics.data)} "
                f"| {metrics.rms:.2f} | {metrics.r:.2f} |"
            )
        for feature in self.features.values():
            at = ""
            if math.isfinite(feature.model_at):
                at = f" (at {feature.model_at:.0f} / {feature.data_at:.0f} % {feature.at_unit})"
            lines.append(
                f"| {feature.name}, {feature.unit}{at} | {_number(feature.model)} | "
                f"{_number(feature.data)} | | |"
            )
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """Plain data (JSON): the channels' and the features' numbers."""
        return {
            "model": self.model.source,
            "data": self.data.source,
            "channels": {
                name: {
                    "model": list(m.model),
                    "data": list(m.data),
                    "rms": m.rms,
                    "r": m.r,
                    "over": m.over,
                }
                for name, m in self.channels.items()
            },
            "features": {
                name: {
                    "unit": f.unit,
                    "model": f.model,
                    "data": f.data,
                    "model_at": f.model_at,
                    "data_at": f.data_at,
                    "at": f.at_unit,
                }
                for name, f in self.features.items()
            },
        }


def _measured(recording: GaitRecording) -> list[str]:
    return [name for name in CHANNELS if recording.has(name)]


def _number(value: float) -> str:
    return f"{value:.3g}" if abs(value) < 10 else f"{value:.1f}"


def _range(pair: tuple[float, float]) -> str:
    return f"{_number(pair[0])}..{_number(pair[1])}"


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    norm = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / norm if norm > 0 else math.nan


def _metrics(channel: str, a: np.ndarray, b: np.ndarray, over: str) -> ChannelMetrics:
    both = np.isfinite(a) & np.isfinite(b)
    if both.sum() < 4:
        raise DefinitionError(f"`{channel}`: fewer than 4 samples measured in both gaits")
    a, b = a[both], b[both]
    return ChannelMetrics(
        channel,
        (float(a.min()), float(a.max())),
        (float(b.min()), float(b.max())),
        float(np.sqrt(np.mean((a - b) ** 2))),
        _pearson(a, b),
        over,
    )


def stance_grid(recording: GaitRecording, channel: str, count: int = GRID) -> np.ndarray:
    """``channel`` over the recording's stance at ``count`` points from heel strike (0 %) to
    toe-off (100 % of the stance)."""
    cycle = np.linspace(0.0, 100.0 * recording.stance_fraction, count)
    return recording.at(channel, cycle)


def humps(
    force: np.ndarray,
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """((first peak, at), (valley, at), (second peak, at)) of a vertical force over the stance
    (``force`` (K,) on a uniform grid; at: % of the stance): the largest in each half and the
    least between them."""
    k = force.size
    percent = np.linspace(0.0, 100.0, k)
    half = k // 2
    first = int(np.argmax(force[:half]))
    second = half + int(np.argmax(force[half:]))
    valley = first + int(np.argmin(force[first : second + 1]))
    return tuple((float(force[i]), float(percent[i])) for i in (first, valley, second))


def compare_gait(model: GaitRecording, data: GaitRecording) -> GaitComparison:
    """The metrics of ``model`` against ``data`` (see the module); raises DefinitionError
    when they share no channel."""
    for name, value in (("model", model), ("data", data)):
        if not isinstance(value, GaitRecording):
            raise DefinitionTypeError(
                f"`{name}`: must be a problems.human.GaitRecording, got {type(value).__name__}"
            )
    shared = [name for name in CHANNELS if model.has(name) and data.has(name)]
    if not shared:
        raise DefinitionError(
            f"`data`: shares no channel with the model (model: {_measured(model)}, data: "
            f"{_measured(data)})"
        )
    cycle = np.linspace(0.0, 100.0, GRID)
    channels = {}
    for name in shared:
        if name in FORCES:
            channels[name] = _metrics(
                name, stance_grid(model, name), stance_grid(data, name), "stance"
            )
        else:
            channels[name] = _metrics(name, model.at(name, cycle), data.at(name, cycle), "cycle")
    features = {
        "stance": Feature(
            "stance (toe-off)",
            "% of the cycle",
            100 * model.stance_fraction,
            100 * data.stance_fraction,
        ),
    }
    if "knee" in shared:
        features.update(_knee_features(model, data, cycle))
    if "force_y" in shared:
        a, b = humps(stance_grid(model, "force_y")), humps(stance_grid(data, "force_y"))
        for (name, label), (ma, mt), (da, dt) in zip(
            (
                ("force_peak_1", "vertical force, first peak"),
                ("force_valley", "... valley"),
                ("force_peak_2", "... second peak"),
            ),
            a,
            b,
            strict=True,
        ):
            features[name] = Feature(label, "BW", ma, da, mt, dt, "of the stance")
    for name in MOMENTS:
        if name in shared:
            kind = "plantarflexor" if name == "ankle_moment" else "extensor"
            everywhere = np.ones(cycle.shape, bool)
            features[f"{name}_peak"] = _peak(
                f"{name.split('_')[0]} {kind} peak", "N m/kg", model.at(name, cycle),
                data.at(name, cycle), (everywhere, everywhere), cycle,
            )  # fmt: skip
    return GaitComparison(model, data, channels, features)


def _peak(label: str, unit: str, a: np.ndarray, b: np.ndarray, windows, cycle) -> Feature:
    """The largest of ``a`` (model) and ``b`` (data) within their ``windows`` (masks), and
    when (% of the cycle)."""
    i = int(np.nanargmax(np.where(windows[0], a, -np.inf)))
    j = int(np.nanargmax(np.where(windows[1], b, -np.inf)))
    return Feature(label, unit, float(a[i]), float(b[j]), float(cycle[i]), float(cycle[j]),
                   "of the cycle")  # fmt: skip


def _knee_features(model: GaitRecording, data: GaitRecording, cycle: np.ndarray):
    a, b = model.at("knee", cycle), data.at("knee", cycle)
    early = cycle <= LOADING_RESPONSE
    swings = (cycle >= 100 * model.stance_fraction, cycle >= 100 * data.stance_fraction)
    return {
        "knee_loading": _peak("knee flexion in loading response (0-25 %)", "deg", a, b,
                              (early, early), cycle),
        "knee_swing": _peak("knee flexion, swing peak", "deg", a, b, swings, cycle),
    }  # fmt: skip


__all__ = ["GaitComparison", "compare_gait", "humps", "stance_grid"]
