"""The project's one sampled-trajectory / torque-profile type: :class:`Trajectory`.

    Trajectory(
        time:      (K,) float, s, strictly increasing
        states:    (K, nx) float
        controls:  (K, nu) float
        state_names, state_units:     tuple[str, ...] of length nx
        control_names, control_units: tuple[str, ...] of length nu
        extras:    dict[str, (values (K,), unit str)]   derived channels (ddpsi_*, Fx, Fy, ...)
        metadata:  dict, JSON-serialisable (source, model parameters, transcription, N,
                   status, cost, package versions, ...)
    )

    .at(t) -> (states (len(t), nx), controls (len(t), nu))   piecewise-cubic interpolation
            (states: cubic Hermite using the derivative channels when present, else not-a-knot
            cubic spline; controls: not-a-knot cubic spline), numpy only
    .control_function(kind="cubic"|"linear") -> callable t -> (nu,) or (K, nu)
    .resample(rate_hz=None, times=None) -> Trajectory
    .save(path, rate_hz=None), Trajectory.load(path)   (planner.trajectory.formats)
    .plot(...) -> matplotlib Figure (states and controls against time)

The trajectory knows no linkage: ``model.LinkageTrajectory`` is the subclass that reads the
channels as link angles, rates and torques (``.psi``, ``.torques``, ...), and the linkage's
stick figures and GIFs live in ``model.drawing``.

Interpolation (the kernels are :mod:`planner.interpolation`)
-----------------------------------------------------------
* Derivative channels: the state ``X`` [u] is interpolated by cubic Hermite when a state or
  extra named ``dX`` with unit ``u/s`` (or ``v/s^2`` when u = ``v/s``) exists: psi_<link> uses
  dpsi_<link>, and dpsi_<link> uses ddpsi_<link> when that extra is stored. Every other state,
  every control and every extra uses the not-a-knot cubic spline through the samples (third
  derivative continuous at the second and second-to-last samples, as MATLAB's ``spline`` and
  scipy's ``CubicSpline``): O(h^4) up to the ends, where a natural spline's zero end curvature
  would be wrong for a torque profile (``interpolation.spline_slopes``).
* Queries outside [time[0], time[-1]] raise :class:`TrajectoryError`; a query within
  ``range_tolerance`` of an end (1e-9 of the duration, at least a few ulp) is clamped to it,
  because integrators and grids built by arithmetic land a rounding error past the end.
"""

from __future__ import annotations

import bisect
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from planner import interpolation
from planner.errors import DefinitionError, DefinitionTypeError, check_positive
from planner.trajectory import formats, plot
from planner.trajectory.checks import (
    check_finite_array,
    check_label,
    float_array,
    jsonable,
    labels,
)
from planner.trajectory.errors import TrajectoryError

if TYPE_CHECKING:  # matplotlib is imported lazily: the planner core must not pay for it
    from matplotlib.figure import Figure


def _derivative_unit(unit: str) -> tuple[str, ...]:
    """Units a channel must carry to be the time derivative of a channel in ``unit``."""
    units = [f"{unit}/s"]
    if unit.endswith("/s"):
        units.append(f"{unit}^2")
    return tuple(units)


# ---- the type -----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class Trajectory:
    """Samples of states, controls and derived channels on a strictly increasing time grid.

    Parameters
    ----------
    time : (K,) float, s, strictly increasing, K >= 2.
    states : (K, nx) float, in ``state_units``.
    controls : (K, nu) float, in ``control_units`` (nu may be 0).
    state_names, state_units : tuple of nx str.
    control_names, control_units : tuple of nu str.
    extras : mapping name -> (values (K,), unit): derived channels (ddpsi_*, Fx, Fy, ...);
        None means none.
    metadata : JSON-serialisable dict (numpy scalars and arrays are converted on the way in,
        tuples become lists); None means empty.

    All arrays are stored as read-only float64 copies (``extras`` as a read-only mapping);
    names are unique over states, controls and extras (and differ from ``t``, the time column
    of the files). Construction validates
    everything and raises :class:`model.DefinitionError` / :class:`model.DefinitionTypeError`
    naming the field, the value and the fix. Two trajectories are equal when every array is
    equal element by element and names, units and metadata match.
    """

    time: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    control_names: tuple[str, ...]
    control_units: tuple[str, ...]
    extras: Mapping[str, tuple[np.ndarray, str]] = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        time = float_array("time", self.time, 1)
        if time.shape[0] < 2:
            raise DefinitionError(
                f"`time`: a trajectory needs at least 2 samples, got {time.shape[0]}"
            )
        steps = np.diff(time)
        if np.any(steps <= 0):
            k = int(np.argmax(steps <= 0)) + 1
            raise DefinitionError(
                f"`time`: must be strictly increasing, got time[{k}] = {float(time[k])!r} s after "
                f"time[{k - 1}] = {float(time[k - 1])!r} s; sort the samples and drop duplicates"
            )
        K = time.shape[0]
        arrays = {}
        for group, names_field, units_field in (
            ("states", "state_names", "state_units"),
            ("controls", "control_names", "control_units"),
        ):
            values = float_array(group, self.__dict__[group], 2, finite=False)
            names = labels(names_field, self.__dict__[names_field], values.shape[1], "name")
            units = labels(units_field, self.__dict__[units_field], values.shape[1], "unit")
            check_finite_array(group, values, names)
            if values.shape[0] != K:
                raise DefinitionError(
                    f"`{group}`: must have one row per time sample ({K}), got shape {values.shape}"
                )
            arrays[group] = values
            object.__setattr__(self, names_field, names)
            object.__setattr__(self, units_field, units)
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "states", arrays["states"])
        object.__setattr__(self, "controls", arrays["controls"])

        if self.extras is None:  # callers forwarding an optional value
            object.__setattr__(self, "extras", {})
        if not isinstance(self.extras, Mapping):
            raise DefinitionTypeError(
                f"`extras`: must be a dict name -> (values (K,), unit), got "
                f"{type(self.extras).__name__}"
            )
        extras: dict[str, tuple[np.ndarray, str]] = {}
        for name, entry in self.extras.items():
            check_label(f"extras key {name!r}", name, "name")
            if not isinstance(entry, (tuple, list)) or len(entry) != 2:
                raise DefinitionTypeError(
                    f"`extras[{name!r}]`: must be a pair (values (K,), unit str), got {entry!r}"
                )
            values = float_array(f"extras[{name!r}]", entry[0], 1)
            if values.shape[0] != K:
                raise DefinitionError(
                    f"`extras[{name!r}]`: must have one value per time sample ({K}), got "
                    f"shape {values.shape}"
                )
            extras[name] = (values, check_label(f"extras[{name!r}] unit", entry[1], "unit"))
        # Read-only view: the interpolants cached from the extras must stay valid.
        object.__setattr__(self, "extras", MappingProxyType(extras))

        seen: dict[str, str] = {"t": "the time column"}
        for where, names in (
            ("state_names", self.state_names),
            ("control_names", self.control_names),
            ("extras", tuple(extras)),
        ):
            for name in names:
                if name in seen:
                    raise DefinitionError(
                        f"`{where}`: name {name!r} is used twice (already {seen[name]}); "
                        "every channel needs a unique name"
                    )
                seen[name] = f"in {where}"

        if self.metadata is None:
            object.__setattr__(self, "metadata", {})
        if not isinstance(self.metadata, Mapping):
            raise DefinitionTypeError(
                f"`metadata`: must be a dict, got {type(self.metadata).__name__}"
            )
        object.__setattr__(self, "metadata", jsonable(self.metadata, "metadata"))

    # ---- basic facts -----------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """K, the number of samples."""
        return self.time.shape[0]

    @property
    def t0(self) -> float:
        """First sample time, s."""
        return float(self.time[0])

    @property
    def tf(self) -> float:
        """Last sample time, s."""
        return float(self.time[-1])

    @property
    def duration(self) -> float:
        """tf - t0, s."""
        return self.tf - self.t0

    @property
    def range_tolerance(self) -> float:
        """How far past either end (s) a query is still accepted and clamped to the end."""
        scale = max(abs(self.t0), abs(self.tf))
        return max(1e-9 * self.duration, 8.0 * float(np.spacing(scale)))

    @property
    def columns(self) -> tuple[tuple[str, str, str], ...]:
        """(name, unit, group) of every column in file order: t, states, controls, extras."""
        return (
            ("t", "s", "time"),
            *((n, u, "state") for n, u in zip(self.state_names, self.state_units, strict=True)),
            *(
                (n, u, "control")
                for n, u in zip(self.control_names, self.control_units, strict=True)
            ),
            *((name, unit, "extra") for name, (_, unit) in self.extras.items()),
        )

    def column(self, name: str) -> np.ndarray:
        """The (K,) samples of one channel by name (``t`` for time)."""
        if name == "t":
            return self.time
        if name in self.state_names:
            return self.states[:, self.state_names.index(name)]
        if name in self.control_names:
            return self.controls[:, self.control_names.index(name)]
        if name in self.extras:
            return self.extras[name][0]
        raise TrajectoryError(
            f"no channel named {name!r}; the channels are {[c[0] for c in self.columns]}"
        )

    def with_metadata(self, **items: Any) -> Trajectory:
        """A copy with ``items`` added to (or replacing keys of) the metadata."""
        return _replace(self, metadata={**self.metadata, **items})

    def with_extra(self, name: str, values, unit: str) -> Trajectory:
        """A copy with one derived channel ``name`` (values (K,), ``unit``) added or replaced."""
        return _replace(self, extras={**self.extras, name: (values, unit)})

    # ---- interpolation -----------------------------------------------------------------------
    def _query(self, t, where: str = "t") -> tuple[np.ndarray, bool]:
        """Query times as a (q,) float array clamped to the range, and whether t was scalar."""
        scalar = np.ndim(t) == 0
        array = np.atleast_1d(np.asarray(t))
        if array.dtype.kind not in "iuf" or array.ndim != 1:
            raise DefinitionError(
                f"`{where}`: must be a real number or a 1-D array of times (s), got "
                f"{np.asarray(t).dtype} array of shape {np.shape(t)}"
            )
        array = array.astype(np.float64)
        if not np.all(np.isfinite(array)):
            bad = float(array[~np.isfinite(array)][0])
            raise DefinitionError(f"`{where}`: times must be finite, got {bad!r}")
        t0, tf, tol = self.t0, self.tf, self.range_tolerance
        outside = (array < t0 - tol) | (array > tf + tol)
        if np.any(outside):
            bad = float(array[outside][0])
            raise TrajectoryError(
                f"`{where}`: {bad!r} s is outside the trajectory's time range [{t0!r}, {tf!r}] s "
                f"({int(outside.sum())} of {array.size} queries); query inside the range, it "
                "does not extrapolate"
            )
        return np.clip(array, t0, tf), scalar

    @cached_property
    def _state_slopes(self) -> np.ndarray:
        """(K, nx) dx/dt at the samples: derivative channels where present, else the
        not-a-knot spline's slopes."""
        if not self.state_names:
            return np.zeros_like(self.states)
        channels = {
            name: (self.states[:, j], unit)
            for j, (name, unit) in enumerate(zip(self.state_names, self.state_units, strict=True))
        }
        channels.update(self.extras)
        slopes = interpolation.spline_slopes(self.time, self.states)
        for j, (name, unit) in enumerate(zip(self.state_names, self.state_units, strict=True)):
            derivative = channels.get(f"d{name}")
            if derivative is not None and derivative[1] in _derivative_unit(unit):
                slopes[:, j] = derivative[0]
        slopes.setflags(write=False)
        return slopes

    @cached_property
    def _control_slopes(self) -> np.ndarray:
        if not self.control_names:
            return np.zeros_like(self.controls)
        return interpolation.spline_slopes(self.time, self.controls)

    @cached_property
    def extra_values(self) -> np.ndarray:
        """(K, number of extras) the extras' samples, in the order of ``extras``."""
        if not self.extras:
            return np.zeros((self.n_samples, 0))
        return np.stack([values for values, _ in self.extras.values()], axis=1)

    @cached_property
    def _extra_slopes(self) -> np.ndarray:
        if not self.extras:
            return self.extra_values
        return interpolation.spline_slopes(self.time, self.extra_values)

    @property
    def hermite_states(self) -> tuple[str, ...]:
        """Names of the states interpolated with a derivative channel (the others use the
        not-a-knot cubic spline)."""
        channels = dict(zip(self.state_names, self.state_units, strict=True))
        channels.update({name: unit for name, (_, unit) in self.extras.items()})
        return tuple(
            name
            for name, unit in zip(self.state_names, self.state_units, strict=True)
            if channels.get(f"d{name}") in _derivative_unit(unit)
        )

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """States and controls at time(s) ``t`` (s).

        Returns ``(states, controls)``: (q, nx) and (q, nu) for a 1-D ``t`` of q times, (nx,)
        and (nu,) for a scalar. States: cubic Hermite with the derivative channels where
        present (see ``hermite_states``), not-a-knot cubic spline otherwise; controls:
        not-a-knot cubic spline. Exact at the samples; raises :class:`TrajectoryError` outside
        the range.
        """
        times, scalar = self._query(t)
        states = interpolation.hermite(self.time, self.states, self._state_slopes, times)
        controls = interpolation.hermite(self.time, self.controls, self._control_slopes, times)
        if scalar:
            return states[0], controls[0]
        return states, controls

    def extras_at(self, t) -> dict[str, np.ndarray]:
        """Extras at time(s) ``t`` by not-a-knot cubic spline: name -> (q,) or scalar float."""
        times, scalar = self._query(t)
        values = interpolation.hermite(self.time, self.extra_values, self._extra_slopes, times)
        return {
            name: (values[0, j] if scalar else values[:, j]) for j, name in enumerate(self.extras)
        }

    def control_function(self, kind: str = "cubic") -> ControlFunction:
        """The controls as a callable of time, for replaying torques in a simulation.

        ``kind="cubic"``: the not-a-knot cubic spline of ``at``; ``kind="linear"``: piecewise
        linear. The callable maps a scalar t (s) to (nu,) and a (q,) array to (q, nu),
        vectorised (one searchsorted per call); it raises outside the time range.
        """
        if kind not in ("cubic", "linear"):
            raise DefinitionError(f"`kind`: must be 'cubic' or 'linear', got {kind!r}")
        return ControlFunction(self, kind)

    def resample(self, rate_hz: float | None = None, times=None) -> Trajectory:
        """The trajectory sampled through its interpolant at new times.

        Give exactly one of ``rate_hz`` (samples at t0 + k / rate_hz, k = 0, 1, ..., plus tf
        itself, which replaces the last one when it falls within the range tolerance of it) or
        ``times`` ((q,) s, strictly increasing, inside the range). States and controls come
        from ``at``, extras from their not-a-knot cubic spline. The metadata gains
        ``resampled``: {"rate_hz", "source_samples"}.
        """
        if (rate_hz is None) == (times is None):
            raise DefinitionError(
                "`resample`: give exactly one of rate_hz (samples per second) or times (s), got "
                f"rate_hz={rate_hz!r} and times={'None' if times is None else 'an array'}"
            )
        if rate_hz is not None:
            rate = check_positive("rate_hz", rate_hz, "Hz")
            # One more than needed; the filter below drops what lands at or past the end.
            count = math.floor(self.duration * rate) + 2
            grid = self.t0 + np.arange(count) / rate
            grid = grid[grid < self.tf - self.range_tolerance]
            # The end is always a sample (a gait's last state matters for periodicity), as in
            # planner.Solution.sample_times: the last interval is shorter when the duration is
            # not a whole number of periods.
            grid = np.append(grid, self.tf)
        else:
            grid = float_array("times", times, 1)
            if grid.shape[0] < 2 or np.any(np.diff(grid) <= 0):
                raise DefinitionError(
                    "`times`: must be at least 2 strictly increasing times (s), got "
                    f"{grid.shape[0]} value(s)"
                    + ("" if grid.shape[0] < 2 else " that are not increasing")
                )
            grid, _ = self._query(grid, "times")
            rate = None
        states, controls = self.at(grid)
        extras_values = self.extras_at(grid)
        metadata = {
            **self.metadata,
            "resampled": {"rate_hz": rate, "source_samples": self.n_samples},
        }
        return type(self)(
            time=grid,
            states=states,
            controls=controls,
            state_names=self.state_names,
            state_units=self.state_units,
            control_names=self.control_names,
            control_units=self.control_units,
            extras={name: (extras_values[name], unit) for name, (_, unit) in self.extras.items()},
            metadata=metadata,
        )

    # ---- files ---------------------------------------------------------------------------
    def save(self, path: str | os.PathLike, rate_hz: float | None = None) -> Path:
        """Write the trajectory to ``path`` in the format given by its suffix.

        ``.csv``, ``.json`` or ``.npz`` (:mod:`planner.trajectory.formats`); at the samples,
        or resampled at ``rate_hz`` through the interpolant (``resample``). Floats are written
        at full precision (they read back bit for bit). The write is atomic: the data go to a
        temporary file in the same folder, renamed over ``path`` only when complete, so a
        failure leaves any previous file untouched and no partial one; the system's refusal (a
        folder without write permission, a full disk) raises :class:`TrajectoryWriteError`
        naming ``path``. Returns the path.
        """
        return formats.save(self, path, rate_hz)

    @staticmethod
    def infer_group(name: str) -> str:
        """The group ("state", "control" or "extra") of a column of a file made by hand, which
        has no groups line: a generic trajectory reads every column as a state (a subclass that
        knows a naming convention, e.g. ``model.LinkageTrajectory``, reads the names)."""
        return "state"

    @classmethod
    def load(cls, path: str | os.PathLike) -> Trajectory:
        """Read a file written by ``save`` (or a hand-made CSV with a ``t [s]`` column).

        Raises :class:`TrajectoryFileNotFoundError` when the file does not exist and
        :class:`TrajectoryFileError` for anything malformed, naming the file, the line or
        column, and the fix.
        """
        return formats.load(path, cls, cls.infer_group)

    # ---- a guess for another problem -------------------------------------------------------
    def interpolate_guess(self, s: np.ndarray) -> dict[str, np.ndarray]:
        """Every channel at normalised times s = (t - t0) / duration, name -> (K,): states and
        controls through the interpolant, extras linearly (a warm start for an OCP,
        ``OCP.guess(trajectory)``)."""
        t = self.t0 + np.asarray(s, dtype=float) * self.duration
        states, controls = self.at(t)
        out = {n: states[:, i] for i, n in enumerate(self.state_names)}
        out.update({n: controls[:, i] for i, n in enumerate(self.control_names)})
        for name, (values, _unit) in self.extras.items():
            out[name] = np.interp(t, self.time, values)
        return out

    # ---- plotting ------------------------------------------------------------------------
    def plot(self, **options: Any) -> Figure:
        """States and controls against time, one panel per group and unit; see
        :func:`planner.trajectory.plot.draw` (``extras``, ``figsize``, ``title``)."""
        return plot.draw(self, **options)

    # ---- dunder --------------------------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trajectory):
            return NotImplemented
        return (
            self.columns == other.columns
            and np.array_equal(self.time, other.time)
            and np.array_equal(self.states, other.states)
            and np.array_equal(self.controls, other.controls)
            and all(np.array_equal(v, other.extras[k][0]) for k, (v, _) in self.extras.items())
            and self.metadata == other.metadata
        )

    __hash__ = None  # type: ignore[assignment]  # holds arrays; equality is by value

    def __repr__(self) -> str:
        def short(names: Sequence[str]) -> str:
            shown = ", ".join(names[:4])
            return f"[{shown}{', ...' if len(names) > 4 else ''}] ({len(names)})"

        return (
            f"Trajectory({self.n_samples} samples, t = {self.t0!r} .. {self.tf!r} s, "
            f"states {short(self.state_names)}, controls {short(self.control_names)}, "
            f"extras {short(tuple(self.extras))}, metadata keys {sorted(self.metadata)})"
        )


class ControlFunction:
    """Controls of a :class:`Trajectory` as a fast callable of time.

    ``f(t)`` -> (nu,) for a scalar t (s), (q, nu) for a (q,) array; N m for hinge torques.
    ``kind`` is ``"cubic"`` (not-a-knot cubic spline, the same as ``Trajectory.at``) or
    ``"linear"``. ``names`` and ``units`` describe the columns.
    """

    def __init__(self, trajectory: Trajectory, kind: str) -> None:
        self._trajectory = trajectory
        self.kind = kind
        self.names = trajectory.control_names
        self.units = trajectory.control_units
        self._time = trajectory.time
        self._values = trajectory.controls
        # Computing the spline slopes once here keeps every call a searchsorted and a few
        # vector operations.
        self._slopes = trajectory._control_slopes if kind == "cubic" else None
        # A scalar call (an integrator asking for u(t)) skips numpy's array machinery: the
        # knots as a Python list for bisect, and the accepted range with its tolerance.
        self._knots = trajectory.time.tolist()
        tolerance = trajectory.range_tolerance
        self._low, self._high = trajectory.t0 - tolerance, trajectory.tf + tolerance

    def __call__(self, t) -> np.ndarray:
        if isinstance(t, (float, int, np.floating, np.integer)) and not isinstance(t, bool):
            time = float(t)
            if self._low <= time <= self._high:  # NaN fails too and takes the checked path
                return self._scalar(time)
        times, scalar = self._trajectory._query(t)
        if self._slopes is None:
            values = interpolation.linear(self._time, self._values, times)
        else:
            values = interpolation.hermite(self._time, self._values, self._slopes, times)
        return values[0] if scalar else values

    def _scalar(self, time: float) -> np.ndarray:
        """One evaluation, operation for operation the same arithmetic as the vectorised
        ``interpolation.hermite``/``linear`` (so both agree bit for bit)."""
        knots = self._knots
        time = min(max(time, knots[0]), knots[-1])
        i = min(max(bisect.bisect_right(knots, time) - 1, 0), len(knots) - 2)
        left = knots[i]
        h = knots[i + 1] - left
        tau = (time - left) / h
        values = self._values
        if self._slopes is None:
            return (1.0 - tau) * values[i] + tau * values[i + 1]
        h00, h01, h10, h11 = interpolation.hermite_basis(tau)
        slopes = self._slopes
        return values[i] * h00 + values[i + 1] * h01 + h * (slopes[i] * h10 + slopes[i + 1] * h11)

    def __repr__(self) -> str:
        return (
            f"ControlFunction({self.kind}, {len(self.names)} controls {list(self.names)}, "
            f"t in [{self._trajectory.t0!r}, {self._trajectory.tf!r}] s)"
        )


def _replace(trajectory: Trajectory, **changes: Any) -> Trajectory:
    fields = {
        "time": trajectory.time,
        "states": trajectory.states,
        "controls": trajectory.controls,
        "state_names": trajectory.state_names,
        "state_units": trajectory.state_units,
        "control_names": trajectory.control_names,
        "control_units": trajectory.control_units,
        "extras": trajectory.extras,
        "metadata": trajectory.metadata,
    }
    fields.update(changes)
    return type(trajectory)(**fields)


__all__ = ["ControlFunction", "Trajectory"]
