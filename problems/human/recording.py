"""A gait cycle of one leg in the biomechanist's conventions, and its plain CSV layout.

Recorded walking (a lab's, Winter's appendix) and a planned gait are compared as the same
value: :class:`GaitRecording`, one leg's cycle from its heel strike (0 %) to the next
(100 %), with any of the channels of :data:`CHANNELS`:

============  ==========================  =====================================================
channel       CSV column                  meaning (0 standing upright; walking to +x)
============  ==========================  =====================================================
thigh         thigh_flexion_deg           thigh from the vertical, the knee ahead positive
hip           hip_flexion_deg             thigh relative to the trunk, flexion positive
knee          knee_flexion_deg            thigh minus shank, flexion positive
ankle         ankle_dorsiflexion_deg      0 with the shank perpendicular to the heel-ball line,
                                          dorsiflexion (toes up) positive
hip_moment    hip_moment_N_m_per_kg       internal moment, extensor positive, per body mass
knee_moment   knee_moment_N_m_per_kg      internal moment, extensor positive
ankle_moment  ankle_moment_N_m_per_kg     internal moment, plantarflexor positive
force_x       ground_force_x_BW           ground's force on the foot, forward, body weights
force_y       ground_force_y_BW           ground's force on the foot, up, body weights
============  ==========================  =====================================================

The CSV file (:func:`write_csv`, :func:`read_csv`): one header row, comment lines
``# key: value`` (``stance_fraction`` required: toe-off as a fraction of the cycle;
``stride_time_s``, ``stride_length_m``, ``body_mass_kg``, ``source`` optional; the reader
takes them anywhere), and one row per sample: ``cycle_percent`` (0-100, increasing) and
any of the columns above, comma separated, empty or ``nan`` where a channel is not
measured. The names hold no spaces, so ``numpy.genfromtxt(path, delimiter=",",
names=True)`` reads it as well.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.errors import DefinitionError
from planner.files import write_text_atomically

#: channel -> (CSV column, unit, label for tables and pictures).
CHANNELS: dict[str, tuple[str, str, str]] = {
    "thigh": ("thigh_flexion_deg", "deg", "thigh flexion from the vertical"),
    "hip": ("hip_flexion_deg", "deg", "hip flexion"),
    "knee": ("knee_flexion_deg", "deg", "knee flexion"),
    "ankle": ("ankle_dorsiflexion_deg", "deg", "ankle dorsiflexion"),
    "hip_moment": ("hip_moment_N_m_per_kg", "N m/kg", "hip moment (extensor +)"),
    "knee_moment": ("knee_moment_N_m_per_kg", "N m/kg", "knee moment (extensor +)"),
    "ankle_moment": ("ankle_moment_N_m_per_kg", "N m/kg", "ankle moment (plantarflexor +)"),
    "force_x": ("ground_force_x_BW", "BW", "ground force, forward"),
    "force_y": ("ground_force_y_BW", "BW", "ground force, vertical"),
}
#: The joint angles among :data:`CHANNELS`.
ANGLES = ("thigh", "hip", "knee", "ankle")
#: The joint moments among :data:`CHANNELS`.
MOMENTS = ("hip_moment", "knee_moment", "ankle_moment")
#: The ground force among :data:`CHANNELS`.
FORCES = ("force_x", "force_y")
PERCENT_COLUMN = "cycle_percent"
_META = {
    "stance_fraction": "stance_fraction",
    "stride_time_s": "stride_time",
    "stride_length_m": "stride_length",
    "body_mass_kg": "body_mass",
}


@dataclass(frozen=True)
class GaitRecording:
    """One leg's gait cycle from heel strike (see the module).

    Attributes
    ----------
    percent : (K,) % of the cycle, increasing, within [0, 100].
    channels : {channel of :data:`CHANNELS`: (K,) values in its unit; NaN where unmeasured}.
    stance_fraction : toe-off, as a fraction of the cycle (0-1).
    stride_time : s, or NaN. ``stride_length``: m, or NaN. ``body_mass``: kg, or NaN.
    source : where it comes from, in words.
    """

    percent: np.ndarray
    channels: Mapping[str, np.ndarray]
    stance_fraction: float
    stride_time: float = math.nan
    stride_length: float = math.nan
    body_mass: float = math.nan
    source: str = ""

    def __post_init__(self) -> None:
        percent = np.asarray(self.percent, dtype=float)
        if percent.ndim != 1 or percent.size < 4 or not np.all(np.isfinite(percent)):
            raise DefinitionError(
                f"`percent`: give at least 4 finite % of the cycle, got shape {percent.shape}"
            )
        if np.any(np.diff(percent) <= 0):
            raise DefinitionError("`percent`: the % of the cycle must increase sample by sample")
        if percent[0] < 0 or percent[-1] > 100:
            raise DefinitionError(
                f"`percent`: must lie within [0, 100], got {percent[0]:g}..{percent[-1]:g}"
            )
        channels = {}
        for name, values in self.channels.items():
            if name not in CHANNELS:
                raise DefinitionError(f"`channels`: unknown {name!r}; use {list(CHANNELS)}")
            values = np.asarray(values, dtype=float)
            if values.shape != percent.shape:
                raise DefinitionError(
                    f"`channels[{name!r}]`: {values.shape} values for {percent.size} samples"
                )
            channels[name] = values
        if not any(np.any(np.isfinite(v)) for v in channels.values()):
            raise DefinitionError(f"`channels`: give at least one of {list(CHANNELS)}")
        if not 0 < self.stance_fraction < 1:
            raise DefinitionError(
                f"`stance_fraction`: toe-off as a fraction of the cycle in (0, 1), got "
                f"{self.stance_fraction!r}"
            )
        object.__setattr__(self, "percent", percent)
        object.__setattr__(self, "channels", channels)

    @property
    def speed(self) -> float:
        """stride_length / stride_time, m/s (NaN when either is unknown)."""
        return self.stride_length / self.stride_time

    def has(self, channel: str) -> bool:
        """True when ``channel`` has any finite sample."""
        values = self.channels.get(channel)
        return values is not None and bool(np.any(np.isfinite(values)))

    def at(self, channel: str, percent) -> np.ndarray:
        """``channel`` at ``percent`` (% of the cycle, any shape), linear between samples and
        across the cycle's end (the cycle repeats); NaN where the channel is unmeasured."""
        values = self.channels.get(channel)
        percent = np.asarray(percent, dtype=float)
        if values is None:
            return np.full(percent.shape, np.nan)
        x, y = self.percent, values
        if x[0] > 0 or x[-1] < 100:  # close the cycle: the sample after the last is the first
            x = np.concatenate([x[-1:] - 100.0, x, x[:1] + 100.0])
            y = np.concatenate([y[-1:], y, y[:1]])
        return np.interp(np.mod(percent, 100.0), x, y)


def write_csv(recording: GaitRecording, path: str | Path) -> Path:
    """``recording`` as the CSV layout of the module, written whole or not at all."""
    path = Path(path)
    names = [name for name in CHANNELS if name in recording.channels]
    # the header first: numpy.genfromtxt(names=True) takes the first line for the names
    lines = [",".join([PERCENT_COLUMN] + [CHANNELS[name][0] for name in names])]
    lines.append(f"# source: {recording.source}" if recording.source else None)
    for key, attribute in _META.items():
        value = getattr(recording, attribute)
        if math.isfinite(value):
            lines.append(f"# {key}: {value:.10g}")
    for k, percent in enumerate(recording.percent):
        row = [f"{percent:.6g}"] + [f"{recording.channels[n][k]:.6g}" for n in names]
        lines.append(",".join(row))
    text = "\n".join(line for line in lines if line is not None) + "\n"
    return write_text_atomically(path, text)


def read_csv(path: str | Path) -> GaitRecording:
    """A recording in the CSV layout of the module; raises DefinitionError naming the file,
    the line and the fix."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise DefinitionError(f"`path`: cannot read {str(path)!r} ({error})") from error
    meta: dict[str, str] = {}
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            key, colon, value = line[1:].partition(":")
            if colon:
                meta[key.strip()] = value.strip()
            continue
        rows.append((number, [cell.strip() for cell in line.split(",")]))
    if not rows:
        raise DefinitionError(f"`path`: {str(path)!r} has no header row ({PERCENT_COLUMN}, ...)")
    header = rows[0][1]
    columns = {column: name for name, (column, _, _) in CHANNELS.items()}
    if header[0] != PERCENT_COLUMN:
        raise DefinitionError(
            f"`path`: {str(path)!r}: the first column must be {PERCENT_COLUMN!r}, got {header[0]!r}"
        )
    unknown = [column for column in header[1:] if column not in columns]
    if unknown:
        raise DefinitionError(
            f"`path`: {str(path)!r}: unknown columns {unknown}; use {PERCENT_COLUMN!r} and "
            f"any of {[c for c, _, _ in CHANNELS.values()]}"
        )
    values = np.full((len(rows) - 1, len(header)), np.nan)
    for k, (number, cells) in enumerate(rows[1:]):
        if len(cells) != len(header):
            raise DefinitionError(
                f"`path`: {str(path)!r} line {number}: {len(cells)} cells for {len(header)} columns"
            )
        for j, cell in enumerate(cells):
            try:
                values[k, j] = float(cell) if cell else math.nan
            except ValueError:
                raise DefinitionError(
                    f"`path`: {str(path)!r} line {number}: {header[j]} = {cell!r} is not a number"
                ) from None
    if "stance_fraction" not in meta:
        raise DefinitionError(
            f"`path`: {str(path)!r} says no '# stance_fraction: <toe-off / cycle>' line"
        )
    numbers = {}
    for key, attribute in _META.items():
        if key in meta:
            try:
                numbers[attribute] = float(meta[key])
            except ValueError:
                raise DefinitionError(
                    f"`path`: {str(path)!r}: '# {key}: {meta[key]}' is not a number"
                ) from None
    channels = {columns[column]: values[:, j + 1] for j, column in enumerate(header[1:])}
    try:
        return GaitRecording(
            values[:, 0], channels, source=meta.get("source", str(path)), **numbers
        )
    except DefinitionError as error:
        raise DefinitionError(f"{error} (in {str(path)!r})") from None
