"""The project's one sampled-trajectory / torque-profile type.

CONTRACT (fixed; the implementation is filled in by the trajectory work, used by
planner.Solution and by problems.torques_along / problems.simulate):

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

Linkage naming convention (used by planner for a model.Dynamics and by problems):
    states   psi_<link> [rad] for every link, then dpsi_<link> [rad/s]
    controls M_<link>   [N m]  (hinge torques)
    extras   ddpsi_<link> [rad/s^2], Fx [N], Fy [N] (ground reaction at H0) when known

    Trajectory.from_linkage(time, psi, dpsi, torques, names, ddpsi=None,
                            ground_reaction=None, metadata=None)   -> Trajectory
    .psi, .dpsi, .torques, .ddpsi (K, n) and .link_names   (raise if not a linkage trajectory)
    .at(t) -> (states (len(t), nx), controls (len(t), nu))   piecewise-cubic interpolation
            (states: cubic Hermite using the derivative channels when present, else not-a-knot
            cubic spline; controls: not-a-knot cubic spline), numpy only
    .control_function(kind="cubic"|"linear") -> callable t -> (nu,) or (K, nu)
    .resample(rate_hz=None, times=None) -> Trajectory
    .save(path, rate_hz=None)   format by suffix: .csv, .json, .npz; full precision; atomic
                                write (temporary file + os.replace): nothing half-written
    Trajectory.load(path) -> Trajectory   (each format reads back what save wrote)
    .plot(...) -> matplotlib Figure (states and controls against time); stick figures and
                  GIF animations for linkages live in planner.plots and take a model.Dynamics

Implementation notes
--------------------
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
* Files (format by suffix):
    - ``.csv``: a header ``t [s],psi_stance_shank [rad],...``, then the comment lines
      ``# format: ...``, ``# version: 1``, ``# groups: {"state": [...], "control": [...],
      "extra": [...]}`` and ``# metadata: {json}``, then one row per sample, floats written
      with ``repr`` (shortest text that reads back bit for bit). Plain readers take it:
      ``numpy.genfromtxt(path, delimiter=",", names=True, comments="#")`` (fields named
      ``t_s``, ``psi_stance_shank_rad``, ...) and ``pandas.read_csv(path, comment="#")``
      (columns ``t [s]``, ...). Files of earlier versions, with the comments before the
      header, read back too. Without a ``# groups`` line (a file made by hand) columns named
      ``M_*`` are controls, ``ddpsi_*``/``Fx``/``Fy`` extras and the rest states. The reader
      also takes the file back after a spreadsheet saved it again (a byte-order mark, CRLF
      line ends, rows padded with empty cells, quoted comment lines, columns reordered).
    - ``.json``: ``{"format", "version", "metadata", "columns": [{"name", "unit", "group"}],
      "data": {name: [values]}}``, the time column being ``t`` [s] with group ``time``.
    - ``.npz``: arrays ``time``, ``states``, ``controls``, ``extras`` (K, n_extras), the
      names/units as string arrays, ``metadata`` as a JSON string; read without pickle.
"""

from __future__ import annotations

import bisect
import csv
import errno as errno_module
import json
import math
import os
import re
import zipfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from numbers import Real
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from model.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner import interpolation
from planner.files import atomic_path

if TYPE_CHECKING:  # matplotlib is imported lazily: the planner core must not pay for it
    from matplotlib.figure import Figure

#: The ``format`` field written into every file, and the version this code writes and reads.
FORMAT_NAME = "anthropoid-planner trajectory"
FORMAT_VERSION = 1
#: File suffixes understood by ``save`` and ``load``.
FORMATS = (".csv", ".json", ".npz")

#: Characters a channel name or unit may not hold: they would break the CSV header
#: ``name [unit]`` (comma, quote, brackets), the comment convention (#) or a line.
_FORBIDDEN = set(',"[]#\n\r')
_GROUPS = ("state", "control", "extra")
_HEADER_CELL = re.compile(r"^(?P<name>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]*)\]$")


class TrajectoryError(AnthropoidError, ValueError):
    """A query a trajectory cannot answer: a time outside its range, or a linkage channel
    (psi, torques, ...) asked of a trajectory that does not follow the linkage convention."""


class TrajectoryFileError(TrajectoryError):
    """A trajectory file that cannot be written or read: the message names the file, the
    line or column when there is one, and the fix."""


class TrajectoryFileNotFoundError(TrajectoryFileError, FileNotFoundError):
    """The file to load, or the folder to save into, does not exist."""


class TrajectoryWriteError(TrajectoryFileError, OSError):
    """The system refused to write a trajectory file (no write permission, a full disk, a
    file-size limit). The message names the file; ``errno``, ``strerror`` and ``filename``
    (the destination, never the temporary file) are the system's."""

    def __init__(self, message: str, errno=None, strerror=None, filename=None) -> None:
        OSError.__init__(self, errno, strerror, filename)
        self.args = (message,)
        self._message = message

    def __str__(self) -> str:
        return self._message


#: What to say about a write failure, by errno.
_WRITE_HINTS = {
    getattr(errno_module, name): hint
    for name, hint in (
        ("EACCES", "the folder is not writable; save elsewhere or change its permissions"),
        ("EPERM", "the folder is not writable; save elsewhere or change its permissions"),
        ("EROFS", "the file system is read-only; save elsewhere"),
        ("ENOSPC", "the disk is full; free space or save elsewhere"),
        ("EDQUOT", "the disk quota is exceeded; free space or save elsewhere"),
        ("EFBIG", "the file exceeds the size limit; write fewer samples"),
    )
    if hasattr(errno_module, name)
}


# ---- validation helpers -------------------------------------------------------------------
def _float_array(
    where: str,
    value: object,
    ndim: int,
    columns: Sequence[str] | None = None,
    finite: bool = True,
) -> np.ndarray:
    """Return ``value`` as a read-only float64 copy with ``ndim`` dimensions, all finite.

    ``columns`` names the columns of a 2-D array, so that a non-finite entry is reported by
    channel name.
    """
    if isinstance(value, (str, bytes)):
        raise DefinitionTypeError(
            f"`{where}`: must be an array of real numbers, got the string {value!r}"
        )
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as error:  # ragged nested lists
        raise DefinitionError(
            f"`{where}`: cannot be read as an array ({error}); give a rectangular array"
        ) from None
    if array.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers"}.get(array.dtype.kind, str(array.dtype))
        raise DefinitionTypeError(
            f"`{where}`: must hold real numbers, got an array of {kind}; "
            "convert it with numpy.asarray(..., dtype=float)"
        )
    if array.ndim != ndim:
        shape = "(K,)" if ndim == 1 else "(K, n)"
        fix = "; use .reshape(-1, 1) for a single channel" if ndim == 2 and array.ndim == 1 else ""
        raise DefinitionError(
            f"`{where}`: must be a {ndim}-D array of shape {shape}, got shape {array.shape}{fix}"
        )
    array = np.array(array, dtype=np.float64)
    if finite:
        _check_finite(where, array, columns)
    array.setflags(write=False)
    return array


def _check_finite(where: str, array: np.ndarray, columns: Sequence[str] | None = None) -> None:
    """Raise naming the first non-finite entry (by channel name when ``columns`` are given)."""
    bad = np.argwhere(~np.isfinite(array))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        if array.ndim == 2 and columns is not None and index[1] < len(columns):
            place = f"at sample {index[0]}, column {index[1]} (`{columns[index[1]]}`)"
        else:
            place = f"at index {index if array.ndim > 1 else index[0]}"
        raise DefinitionError(
            f"`{where}`: must be finite, got {float(array[index])!r} {place} "
            f"({len(bad)} non-finite value(s) in all); remove or fill those samples"
        )


def _check_label(where: str, value: object, what: str) -> str:
    """A channel name or unit: a non-empty string without CSV/comment-breaking characters."""
    if not isinstance(value, str):
        raise DefinitionTypeError(f"`{where}`: must be a string ({what}), got {value!r}")
    if not value.strip() or value != value.strip():
        raise DefinitionError(
            f"`{where}`: must be a non-empty {what} without leading or trailing spaces, "
            f"got {value!r}" + ("; use '1' for a dimensionless quantity" if what == "unit" else "")
        )
    bad = sorted(_FORBIDDEN.intersection(value))
    if bad:
        raise DefinitionError(
            f"`{where}`: {what} {value!r} contains {''.join(bad)!r}; the characters "
            f"{''.join(sorted(_FORBIDDEN))!r} would break the CSV header, remove them"
        )
    return value


def _labels(where: str, value: object, count: int, what: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise DefinitionTypeError(
            f"`{where}`: must be a tuple of {count} strings ({what}s), got {value!r}"
        )
    if len(value) != count:
        raise DefinitionError(
            f"`{where}`: must have one {what} per column ({count}), got {len(value)}: "
            f"{tuple(value)!r}"
        )
    return tuple(_check_label(f"{where}[{i}]", v, what) for i, v in enumerate(value))


def _jsonable(value: Any, where: str) -> Any:
    """A copy of ``value`` made of JSON types only (numpy scalars and arrays converted).

    Non-finite floats are kept: Python's json module writes and reads them (NaN, Infinity),
    and a failed solve's cost may be NaN.
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    if isinstance(value, np.generic):
        return _jsonable(value.item(), where)
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist(), where)
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise DefinitionTypeError(
                    f"`{where}`: keys must be strings (JSON objects), got {key!r}; use str(key)"
                )
            out[key] = _jsonable(item, f"{where}[{key!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [_jsonable(item, f"{where}[{i}]") for i, item in enumerate(value)]
    raise DefinitionTypeError(
        f"`{where}`: must be JSON-serialisable (dict, list, str, number, bool or None), got "
        f"{value!r} of type {type(value).__name__}; convert it first, e.g. with str()"
    )


def _derivative_unit(unit: str) -> tuple[str, ...]:
    """Units a channel must carry to be the time derivative of a channel in ``unit``."""
    units = [f"{unit}/s"]
    if unit.endswith("/s"):
        units.append(f"{unit}^2")
    return tuple(units)


def _check_positive(where: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise DefinitionTypeError(f"`{where}`: must be a real number, got {value!r}")
    number = float(value)
    if not math.isfinite(number) or number <= 0:
        raise DefinitionError(f"`{where}`: must be a finite number > 0, got {number!r}")
    return number


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
        time = _float_array("time", self.time, 1)
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
            values = _float_array(group, self.__dict__[group], 2, finite=False)
            names = _labels(names_field, self.__dict__[names_field], values.shape[1], "name")
            units = _labels(units_field, self.__dict__[units_field], values.shape[1], "unit")
            _check_finite(group, values, names)
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
            _check_label(f"extras key {name!r}", name, "name")
            if not isinstance(entry, (tuple, list)) or len(entry) != 2:
                raise DefinitionTypeError(
                    f"`extras[{name!r}]`: must be a pair (values (K,), unit str), got {entry!r}"
                )
            values = _float_array(f"extras[{name!r}]", entry[0], 1)
            if values.shape[0] != K:
                raise DefinitionError(
                    f"`extras[{name!r}]`: must have one value per time sample ({K}), got "
                    f"shape {values.shape}"
                )
            extras[name] = (values, _check_label(f"extras[{name!r}] unit", entry[1], "unit"))
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
        object.__setattr__(self, "metadata", _jsonable(self.metadata, "metadata"))

    # ---- construction ----------------------------------------------------------------------
    @classmethod
    def from_linkage(
        cls,
        time,
        psi,
        dpsi,
        torques,
        names: Sequence[str],
        ddpsi=None,
        ground_reaction=None,
        metadata: Mapping | None = None,
    ) -> Trajectory:
        """A trajectory in the linkage convention.

        Parameters
        ----------
        time : (K,) s.
        psi : (K, n) rad, absolute link angles.
        dpsi : (K, n) rad/s.
        torques : (K, n) N m, hinge torques M.
        names : n link names (``model.Linkage.names``).
        ddpsi : optional (K, n) rad/s^2; stored as extras ``ddpsi_<link>`` and then used as
            the derivative of dpsi by the interpolation.
        ground_reaction : optional force of the ground at H0, N: complex (K,) Fx + j Fy, or
            real (K, 2) columns Fx, Fy; stored as extras ``Fx``, ``Fy``.
        metadata : optional JSON-serialisable dict.
        """
        if isinstance(names, str) or not isinstance(names, Sequence):
            raise DefinitionTypeError(f"`names`: must be a sequence of link names, got {names!r}")
        links = tuple(_check_label(f"names[{i}]", v, "name") for i, v in enumerate(names))
        n = len(links)
        if n == 0:
            raise DefinitionError("`names`: a linkage trajectory needs at least one link")
        time = _float_array("time", time, 1)
        K = time.shape[0]

        def block(where: str, value) -> np.ndarray:
            array = _float_array(where, value, 2, links)
            if array.shape != (K, n):
                raise DefinitionError(
                    f"`{where}`: must have shape (K, n) = ({K}, {n}) for {K} samples and "
                    f"{n} links, got {array.shape}"
                )
            return array

        psi = block("psi", psi)
        dpsi = block("dpsi", dpsi)
        torques = block("torques", torques)
        extras: dict[str, tuple[np.ndarray, str]] = {}
        if ddpsi is not None:
            ddpsi = block("ddpsi", ddpsi)
            for i, link in enumerate(links):
                extras[f"ddpsi_{link}"] = (ddpsi[:, i], "rad/s^2")
        if ground_reaction is not None:
            force = np.asarray(ground_reaction)
            if force.dtype.kind == "c":
                if force.shape != (K,):
                    raise DefinitionError(
                        f"`ground_reaction`: a complex Fx + j Fy must have shape ({K},), got "
                        f"{force.shape}"
                    )
                pair = np.stack([force.real, force.imag], axis=1)
            else:
                pair = force
            pair = _float_array("ground_reaction", pair, 2, ("Fx", "Fy"))
            if pair.shape != (K, 2):
                raise DefinitionError(
                    f"`ground_reaction`: must be complex ({K},) Fx + j Fy or real ({K}, 2) "
                    f"columns Fx, Fy, got shape {pair.shape}"
                )
            extras["Fx"] = (pair[:, 0], "N")
            extras["Fy"] = (pair[:, 1], "N")
        return cls(
            time=time,
            states=np.hstack([psi, dpsi]),
            controls=torques,
            state_names=tuple(f"psi_{v}" for v in links) + tuple(f"dpsi_{v}" for v in links),
            state_units=("rad",) * n + ("rad/s",) * n,
            control_names=tuple(f"M_{v}" for v in links),
            control_units=("N m",) * n,
            extras=extras,
            metadata={} if metadata is None else metadata,
        )

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

    # ---- the linkage convention -------------------------------------------------------------
    @cached_property
    def _links(self) -> tuple[str, ...] | None:
        names = self.state_names
        if not names or len(names) % 2:
            return None
        n = len(names) // 2
        if not all(s.startswith("psi_") for s in names[:n]):
            return None
        links = tuple(s[4:] for s in names[:n])
        if names[n:] != tuple(f"dpsi_{v}" for v in links):
            return None
        if self.state_units != ("rad",) * n + ("rad/s",) * n:
            return None
        return links

    def _not_linkage(self, what: str) -> TrajectoryError:
        return TrajectoryError(
            f"`{what}`: this trajectory does not follow the linkage convention (states "
            f"psi_<link> [rad] then dpsi_<link> [rad/s]); its states are "
            f"{list(self.state_names)}; build it with Trajectory.from_linkage or read the "
            "columns by name with .column(name)"
        )

    @property
    def is_linkage(self) -> bool:
        """True when the states follow the linkage convention (psi_<link>, dpsi_<link>)."""
        return self._links is not None

    @property
    def link_names(self) -> tuple[str, ...]:
        """Link names of a linkage trajectory, in the order of its columns."""
        if self._links is None:
            raise self._not_linkage("link_names")
        return self._links

    @property
    def psi(self) -> np.ndarray:
        """(K, n) link angles, rad."""
        if self._links is None:
            raise self._not_linkage("psi")
        return self.states[:, : len(self._links)]

    @property
    def dpsi(self) -> np.ndarray:
        """(K, n) angular velocities, rad/s."""
        if self._links is None:
            raise self._not_linkage("dpsi")
        return self.states[:, len(self._links) :]

    @property
    def torques(self) -> np.ndarray:
        """(K, n) hinge torques M, N m."""
        links = self._links
        if links is None:
            raise self._not_linkage("torques")
        expected = tuple(f"M_{v}" for v in links)
        if self.control_names != expected or set(self.control_units) - {"N m"}:
            raise TrajectoryError(
                f"`torques`: the controls must be {list(expected)} [N m] for the links "
                f"{list(links)}, got {list(self.control_names)} {list(self.control_units)}; "
                "read them by name with .column(name)"
            )
        return self.controls

    @property
    def ddpsi(self) -> np.ndarray:
        """(K, n) angular accelerations, rad/s^2 (from the extras ``ddpsi_<link>``)."""
        if self._links is None:
            raise self._not_linkage("ddpsi")
        missing = [f"ddpsi_{v}" for v in self._links if f"ddpsi_{v}" not in self.extras]
        if missing:
            raise TrajectoryError(
                f"`ddpsi`: this trajectory stores no angular accelerations (missing extras "
                f"{missing}); pass ddpsi= to Trajectory.from_linkage"
            )
        return np.stack([self.extras[f"ddpsi_{v}"][0] for v in self._links], axis=1)

    @property
    def ground_reaction(self) -> np.ndarray:
        """(K,) complex force of the ground at H0, Fx + j Fy, N."""
        if self._links is None:
            raise self._not_linkage("ground_reaction")
        if "Fx" not in self.extras or "Fy" not in self.extras:
            raise TrajectoryError(
                "`ground_reaction`: this trajectory stores no ground reaction (extras Fx, Fy); "
                "pass ground_reaction= to Trajectory.from_linkage"
            )
        return self.extras["Fx"][0] + 1j * self.extras["Fy"][0]

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
    def _extra_values(self) -> np.ndarray:
        if not self.extras:
            return np.zeros((self.n_samples, 0))
        return np.stack([values for values, _ in self.extras.values()], axis=1)

    @cached_property
    def _extra_slopes(self) -> np.ndarray:
        if not self.extras:
            return self._extra_values
        return interpolation.spline_slopes(self.time, self._extra_values)

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
        values = interpolation.hermite(self.time, self._extra_values, self._extra_slopes, times)
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
            rate = _check_positive("rate_hz", rate_hz)
            # One more than needed; the filter below drops what lands at or past the end.
            count = math.floor(self.duration * rate) + 2
            grid = self.t0 + np.arange(count) / rate
            grid = grid[grid < self.tf - self.range_tolerance]
            # The end is always a sample (a gait's last state matters for periodicity), as in
            # planner.Solution.sample_times: the last interval is shorter when the duration is
            # not a whole number of periods.
            grid = np.append(grid, self.tf)
        else:
            grid = _float_array("times", times, 1)
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
        return Trajectory(
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

        ``.csv``, ``.json`` or ``.npz`` (see the module notes); at the samples, or resampled
        at ``rate_hz`` through the interpolant (``resample``). Floats are written at full
        precision (they read back bit for bit). The write is atomic: the data go to a
        temporary file in the same folder, renamed over ``path`` only when complete, so a
        failure leaves any previous file untouched and no partial one; the system's refusal (a
        folder without write permission, a full disk) raises :class:`TrajectoryWriteError`
        naming ``path``. Returns the path.
        """
        path = _as_path(path)
        suffix = _suffix(path)
        if not path.parent.is_dir():
            raise TrajectoryFileNotFoundError(
                f"{path}: cannot save, the folder {str(path.parent)!r} does not exist; create "
                "it first (e.g. os.makedirs)"
            )
        if path.is_dir():
            raise TrajectoryFileError(f"{path}: cannot save, this is a folder; give a file name")
        trajectory = self if rate_hz is None else self.resample(rate_hz=rate_hz)
        writer, binary = _WRITERS[suffix]
        try:
            _atomic_write(path, lambda handle: writer(trajectory, handle), binary)
        except OSError as error:
            strerror = error.strerror or str(error)
            hint = _WRITE_HINTS.get(error.errno)
            raise TrajectoryWriteError(
                f"{path}: cannot save: {strerror}" + (f"; {hint}" if hint else ""),
                error.errno,
                strerror,
                str(path),
            ) from error
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> Trajectory:
        """Read a file written by ``save`` (or a hand-made CSV with a ``t [s]`` column).

        Raises :class:`TrajectoryFileNotFoundError` when the file does not exist and
        :class:`TrajectoryFileError` for anything malformed, naming the file, the line or
        column, and the fix.
        """
        path = _as_path(path)
        suffix = _suffix(path)
        if not path.exists():
            raise TrajectoryFileNotFoundError(
                f"{path}: no such file (working folder {os.getcwd()!r}); check the path"
            )
        if path.is_dir():
            raise TrajectoryFileError(f"{path}: is a folder, not a trajectory file")
        fields = _READERS[suffix](path)
        try:
            return cls(**fields)
        except (DefinitionError, DefinitionTypeError) as error:
            raise TrajectoryFileError(f"{path}: {error}") from None

    # ---- plotting ------------------------------------------------------------------------
    def plot(self, **options: Any) -> Figure:
        """States and controls against time, one panel per group and unit; see
        :func:`planner.plots.plot_trajectory` for the options."""
        from planner.plots import plot_trajectory

        return plot_trajectory(self, **options)

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
    return Trajectory(**fields)


# ---- file helpers ---------------------------------------------------------------------------
def _as_path(path: object) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise DefinitionTypeError(
            f"`path`: must be a file path (str or pathlib.Path), got {path!r}"
        )
    return Path(path)


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise TrajectoryFileError(
            f"{path}: unknown trajectory format {path.suffix or '(no suffix)'!r}; the formats are "
            f"{', '.join(FORMATS)} (chosen by the file name's suffix)"
        )
    return suffix


def _atomic_write(path: Path, write: Callable[[Any], None], binary: bool) -> None:
    """Run ``write(handle)`` on a temporary file beside ``path``, then rename it over ``path``
    (:func:`planner.files.atomic_path`); the data reach the disk before the rename."""
    with atomic_path(path) as temporary:
        with (
            open(temporary, "wb") if binary else open(temporary, "w", encoding="utf-8", newline="")
        ) as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())


def _float_text(values: np.ndarray) -> list[str]:
    # repr of a Python float is the shortest text that parses back to the same double.
    return [repr(v) for v in values.tolist()]


def _groups(trajectory: Trajectory) -> dict[str, list[str]]:
    return {
        "state": list(trajectory.state_names),
        "control": list(trajectory.control_names),
        "extra": list(trajectory.extras),
    }


def _write_csv(trajectory: Trajectory, handle) -> None:
    columns = trajectory.columns
    # The header comes first and the comments after it: numpy.genfromtxt(names=True) takes
    # the first line for the names, comment or not; pandas and csv readers skip "#" lines.
    handle.write(",".join(f"{name} [{unit}]" for name, unit, _ in columns) + "\n")
    handle.write(f"# format: {json.dumps(FORMAT_NAME)}\n")
    handle.write(f"# version: {FORMAT_VERSION}\n")
    handle.write(f"# groups: {json.dumps(_groups(trajectory))}\n")
    handle.write(f"# metadata: {json.dumps(trajectory.metadata)}\n")
    table = np.column_stack(
        [trajectory.time, trajectory.states, trajectory.controls, trajectory._extra_values]
    )
    for row in table.tolist():
        handle.write(",".join(map(repr, row)) + "\n")


def _write_json(trajectory: Trajectory, handle) -> None:
    # One line per column of data keeps the file readable without one line per number.
    parts = [
        "{",
        f'  "format": {json.dumps(FORMAT_NAME)},',
        f'  "version": {FORMAT_VERSION},',
        f'  "metadata": {json.dumps(trajectory.metadata)},',
        '  "columns": [',
        ",\n".join(
            f"    {json.dumps({'name': n, 'unit': u, 'group': g})}"
            for n, u, g in trajectory.columns
        ),
        "  ],",
        '  "data": {',
        ",\n".join(
            f"    {json.dumps(name)}: [{', '.join(_float_text(trajectory.column(name)))}]"
            for name, _, _ in trajectory.columns
        ),
        "  }",
        "}",
    ]
    handle.write("\n".join(parts) + "\n")


def _write_npz(trajectory: Trajectory, handle) -> None:
    def strings(values: Sequence[str]) -> np.ndarray:
        return np.array(list(values), dtype=str) if values else np.zeros(0, dtype="<U1")

    np.savez(
        handle,
        format=np.array(FORMAT_NAME),
        version=np.array(FORMAT_VERSION),
        time=trajectory.time,
        states=trajectory.states,
        controls=trajectory.controls,
        extras=trajectory._extra_values,
        state_names=strings(trajectory.state_names),
        state_units=strings(trajectory.state_units),
        control_names=strings(trajectory.control_names),
        control_units=strings(trajectory.control_units),
        extra_names=strings(tuple(trajectory.extras)),
        extra_units=strings(tuple(unit for _, unit in trajectory.extras.values())),
        metadata=np.array(json.dumps(trajectory.metadata)),
    )


def _check_format(path: Path, where: str, name: object, version: object) -> None:
    if name != FORMAT_NAME:
        raise TrajectoryFileError(
            f"{path}: {where}: format is {name!r}, expected {FORMAT_NAME!r}; this is not a "
            "trajectory file written by Trajectory.save"
        )
    if isinstance(version, bool) or not isinstance(version, int):
        raise TrajectoryFileError(f"{path}: {where}: version must be an integer, got {version!r}")
    if version > FORMAT_VERSION:
        raise TrajectoryFileError(
            f"{path}: {where}: format version {version} is newer than this library reads "
            f"({FORMAT_VERSION}); upgrade anthropoid-planner"
        )
    if version < 1:
        raise TrajectoryFileError(f"{path}: {where}: unknown format version {version!r}")


def _infer_group(name: str) -> str:
    if name.startswith("M_"):
        return "control"
    if name.startswith("ddpsi_") or name in ("Fx", "Fy"):
        return "extra"
    return "state"


def _assemble(
    path: Path,
    where: str,
    time: np.ndarray,
    names: Sequence[str],
    units: Sequence[str],
    values: Sequence[np.ndarray],
    groups: Mapping[str, Sequence[str]] | None,
    metadata: Any,
) -> dict[str, Any]:
    """Constructor fields from named columns, ordered by ``groups`` (or by name rules)."""
    by_name = dict(zip(names, zip(values, units, strict=True), strict=True))
    if groups is None:
        ordered = {g: [n for n in names if _infer_group(n) == g] for g in _GROUPS}
    else:
        if (
            not isinstance(groups, Mapping)
            or set(groups) - set(_GROUPS)
            or not all(
                isinstance(v, list) and all(isinstance(s, str) for s in v) for v in groups.values()
            )
        ):
            raise TrajectoryFileError(
                f"{path}: {where}: groups must be an object {{'state': [names], 'control': "
                f"[names], 'extra': [names]}}, got {groups!r}"
            )
        ordered = {g: list(groups.get(g, [])) for g in _GROUPS}
        listed = [n for g in _GROUPS for n in ordered[g]]
        missing = [n for n in listed if n not in by_name]
        if missing:
            raise TrajectoryFileError(
                f"{path}: {where}: the columns {missing} listed in the groups are missing from "
                "the data; restore them, or delete the groups line to infer groups from names"
            )
        unlisted = [n for n in names if n not in listed]
        if unlisted:
            raise TrajectoryFileError(
                f"{path}: {where}: the columns {unlisted} are not listed in the groups; add "
                "them to the groups, or delete the groups line to infer groups from names"
            )

    def block(group: str) -> np.ndarray:
        chosen = ordered[group]
        if not chosen:
            return np.zeros((time.shape[0], 0))
        return np.stack([by_name[n][0] for n in chosen], axis=1)

    return {
        "time": time,
        "states": block("state"),
        "controls": block("control"),
        "state_names": tuple(ordered["state"]),
        "state_units": tuple(by_name[n][1] for n in ordered["state"]),
        "control_names": tuple(ordered["control"]),
        "control_units": tuple(by_name[n][1] for n in ordered["control"]),
        "extras": {n: by_name[n] for n in ordered["extra"]},
        "metadata": {} if metadata is None else metadata,
    }


def _read_text(path: Path) -> str:
    try:
        # utf-8-sig: spreadsheets save a byte-order mark in front of the header.
        return path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: not a UTF-8 text file (byte {error.start}); is it really a "
            f"{path.suffix} file?"
        ) from None
    except OSError as error:
        raise TrajectoryFileError(f"{path}: cannot be read: {error.strerror}") from None


def _read_csv(path: Path) -> dict[str, Any]:
    text = _read_text(path)
    comments: dict[str, Any] = {}
    header: list[tuple[str, str]] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        cells = next(csv.reader([line]), [])
        # A spreadsheet that saves the file again pads short rows with empty cells and quotes
        # comment lines that hold commas or quotes: drop the padding, rebuild the comment.
        while cells and not cells[-1].strip():
            cells.pop()
        if not cells:
            continue
        if cells[0].lstrip().startswith("#"):
            if line.lstrip().startswith('"'):
                stripped = ",".join(cells).strip()
            else:  # a JSON value never ends in a comma: trailing ones are padding
                stripped = line.strip().rstrip(",").strip()
            key, colon, value = stripped[1:].partition(":")
            key = key.strip()
            # Before the header (files of earlier versions) or right after it (this one).
            if not rows and colon and key in ("format", "version", "groups", "metadata"):
                if key in comments:
                    raise TrajectoryFileError(
                        f"{path}: line {number}: a second `# {key}:` comment; keep one"
                    )
                try:
                    comments[key] = json.loads(value)
                except json.JSONDecodeError as error:
                    raise TrajectoryFileError(
                        f"{path}: line {number}: the `# {key}:` comment is not valid JSON "
                        f"({error.msg} at character {error.colno}); fix or delete the line"
                    ) from None
            continue
        if header is None:
            header_line = number
            header = []
            for column, cell in enumerate(cells, start=1):
                match = _HEADER_CELL.match(cell.strip())
                if not match or not match["name"] or not match["unit"].strip():
                    raise TrajectoryFileError(
                        f"{path}: line {number}, column {column}: header cell {cell!r} must "
                        "read `name [unit]`, e.g. `psi_torso [rad]`; add the unit in brackets"
                    )
                header.append((match["name"], match["unit"].strip()))
            if header[0] != ("t", "s"):
                raise TrajectoryFileError(
                    f"{path}: line {number}, column 1: the first column must be `t [s]` (time "
                    f"in seconds), got {cells[0].strip()!r}; rename it or move the time "
                    "column first"
                )
            duplicates = sorted({n for n, _ in header if [h[0] for h in header].count(n) > 1})
            if duplicates:
                raise TrajectoryFileError(
                    f"{path}: line {number}: the header names {duplicates} more than once; "
                    "every column needs a unique name"
                )
            continue
        rows.append((number, cells))
    if "format" in comments or "version" in comments:
        _check_format(
            path,
            "the `# format:`/`# version:` comments",
            comments.get("format"),
            comments.get("version"),
        )
    if header is None:
        raise TrajectoryFileError(
            f"{path}: no header row; the first line that is not a # comment must be "
            "`t [s],name [unit],...`"
        )
    if len(rows) < 2:
        raise TrajectoryFileError(
            f"{path}: {len(rows)} data row(s) after the header on line {header_line}; a "
            "trajectory needs at least 2 samples"
        )
    table = np.empty((len(rows), len(header)))
    for r, (number, cells) in enumerate(rows):
        if len(cells) != len(header):
            raise TrajectoryFileError(
                f"{path}: line {number}: {len(cells)} cells, but the header on line "
                f"{header_line} has {len(header)} columns; every row needs one value per column"
            )
        for c, cell in enumerate(cells):
            try:
                value = float(cell)
            except ValueError:
                raise TrajectoryFileError(
                    f"{path}: line {number}, column {c + 1} (`{header[c][0]}`): {cell!r} is not "
                    "a number; every data cell must be a decimal number"
                ) from None
            if not math.isfinite(value):
                raise TrajectoryFileError(
                    f"{path}: line {number}, column {c + 1} (`{header[c][0]}`): must be finite, "
                    f"got {cell.strip()!r}; fill or remove the sample"
                )
            table[r, c] = value
    steps = np.diff(table[:, 0])
    if np.any(steps <= 0):
        r = int(np.argmax(steps <= 0)) + 1
        raise TrajectoryFileError(
            f"{path}: line {rows[r][0]}: time {float(table[r, 0])!r} s does not come after "
            f"{float(table[r - 1, 0])!r} s on line {rows[r - 1][0]}; rows must be in strictly "
            "increasing time, without duplicates"
        )
    names = [n for n, _ in header[1:]]
    return _assemble(
        path,
        "the `# groups:` comment",
        table[:, 0],
        names,
        [u for _, u in header[1:]],
        [table[:, c] for c in range(1, len(header))],
        comments.get("groups"),
        comments.get("metadata"),
    )


def _read_json(path: Path) -> dict[str, Any]:
    text = _read_text(path)
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: line {error.lineno}, column {error.colno}: not valid JSON ({error.msg})"
        ) from None
    if not isinstance(document, dict):
        raise TrajectoryFileError(
            f"{path}: the top level must be an object with format, version, metadata, columns "
            f"and data, got {type(document).__name__}"
        )
    missing = [k for k in ("format", "version", "columns", "data") if k not in document]
    if missing:
        raise TrajectoryFileError(
            f"{path}: missing key(s) {missing}; a trajectory file holds format, version, "
            "metadata, columns and data (write it with Trajectory.save)"
        )
    _check_format(path, "top level", document["format"], document["version"])
    columns, data = document["columns"], document["data"]
    if not isinstance(columns, list) or not isinstance(data, dict):
        raise TrajectoryFileError(
            f"{path}: `columns` must be a list of {{name, unit, group}} and `data` an object "
            "name -> list of numbers"
        )
    names, units, groups = [], [], {g: [] for g in _GROUPS}
    for i, column in enumerate(columns):
        if (
            not isinstance(column, dict)
            or not all(isinstance(column.get(k), str) for k in ("name", "unit", "group"))
            or column["group"] not in ("time", *_GROUPS)
        ):
            raise TrajectoryFileError(
                f"{path}: columns[{i}] must be {{'name': str, 'unit': str, 'group': one of "
                f"time, state, control, extra}}, got {column!r}"
            )
        names.append(column["name"])
        units.append(column["unit"])
        if column["group"] != "time":
            groups[column["group"]].append(column["name"])
    if not names or (names[0], units[0], columns[0]["group"]) != ("t", "s", "time"):
        raise TrajectoryFileError(
            f"{path}: columns[0] must be {{'name': 't', 'unit': 's', 'group': 'time'}}, got "
            f"{columns[0] if columns else 'no columns'!r}"
        )
    if len(set(names)) != len(names):
        raise TrajectoryFileError(f"{path}: `columns` names a column twice: {names}")
    arrays = []
    for name in names:
        if name not in data:
            raise TrajectoryFileError(
                f"{path}: data[{name!r}] is missing; every column listed in `columns` needs "
                "its list of values in `data`"
            )
        values = data[name]
        if not isinstance(values, list):
            raise TrajectoryFileError(f"{path}: data[{name!r}] must be a list of numbers")
        for k, v in enumerate(values):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise TrajectoryFileError(
                    f"{path}: data[{name!r}][{k}] is {v!r}, not a number; every value must be "
                    "a number"
                )
            try:
                finite = math.isfinite(v)
            except OverflowError:  # an integer beyond the largest float
                finite = False
            if not finite:
                shown = (
                    f"an integer of {len(str(abs(v)))} digits" if isinstance(v, int) else repr(v)
                )
                raise TrajectoryFileError(
                    f"{path}: data[{name!r}][{k}] must be finite, got {shown}; fill "
                    "or remove the sample"
                )
        arrays.append(np.array(values, dtype=np.float64))
        if arrays[-1].shape != arrays[0].shape:
            raise TrajectoryFileError(
                f"{path}: data[{name!r}] has {arrays[-1].shape[0]} values but data['t'] has "
                f"{arrays[0].shape[0]}; every column needs one value per sample"
            )
    extra_keys = sorted(set(data) - set(names))
    if extra_keys:
        raise TrajectoryFileError(
            f"{path}: data holds {extra_keys} that `columns` does not describe; add them to "
            "`columns` or remove them"
        )
    return _assemble(
        path,
        "columns",
        arrays[0],
        names[1:],
        units[1:],
        arrays[1:],
        groups,
        document.get("metadata"),
    )


#: The .npz arrays that hold names and units (1-D string arrays), and every array of the file.
_NPZ_STRING_KEYS = (
    "state_names",
    "state_units",
    "control_names",
    "control_units",
    "extra_names",
    "extra_units",
)
_NPZ_KEYS = (
    "format",
    "version",
    "time",
    "states",
    "controls",
    "extras",
    *_NPZ_STRING_KEYS,
    "metadata",
)


def _read_npz(path: Path) -> dict[str, Any]:
    try:
        with np.load(path, allow_pickle=False) as archive:
            missing = [k for k in _NPZ_KEYS if k not in archive.files]
            if missing:
                raise TrajectoryFileError(
                    f"{path}: missing array(s) {missing}; write the file with Trajectory.save"
                )
            arrays = {k: archive[k] for k in _NPZ_KEYS}
    except TrajectoryFileError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise TrajectoryFileError(
            f"{path}: not a readable .npz archive ({error}); write it with Trajectory.save"
        ) from None
    name, version = arrays["format"], arrays["version"]
    scalar = name.ndim == 0 and version.ndim == 0  # not arrays of several values
    _check_format(
        path,
        "arrays format/version",
        str(name) if scalar and name.dtype.kind == "U" else name,
        int(version) if scalar and version.dtype.kind in "iu" else version,
    )
    strings = {}
    for key in _NPZ_STRING_KEYS:
        value = arrays[key]
        if value.ndim != 1 or (value.size and value.dtype.kind != "U"):
            raise TrajectoryFileError(
                f"{path}: array {key!r} must be a 1-D array of strings, got {value.dtype} "
                f"{value.shape}"
            )
        strings[key] = tuple(str(s) for s in value)
    try:
        metadata = json.loads(str(arrays["metadata"]))
    except json.JSONDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: array 'metadata' is not valid JSON ({error.msg}); it must hold a JSON string"
        ) from None
    extras_table = arrays["extras"]
    if extras_table.ndim != 2 or extras_table.shape[1] != len(strings["extra_names"]):
        raise TrajectoryFileError(
            f"{path}: array 'extras' must have shape (K, {len(strings['extra_names'])}) for "
            f"the extra_names, got {extras_table.shape}"
        )
    if len(strings["extra_units"]) != len(strings["extra_names"]):
        raise TrajectoryFileError(
            f"{path}: arrays 'extra_names' and 'extra_units' differ in length"
        )
    return {
        "time": arrays["time"],
        "states": arrays["states"],
        "controls": arrays["controls"],
        "state_names": strings["state_names"],
        "state_units": strings["state_units"],
        "control_names": strings["control_names"],
        "control_units": strings["control_units"],
        "extras": {
            name: (extras_table[:, j], unit)
            for j, (name, unit) in enumerate(
                zip(strings["extra_names"], strings["extra_units"], strict=True)
            )
        },
        "metadata": metadata,
    }


_WRITERS: dict[str, tuple[Callable[[Trajectory, Any], None], bool]] = {
    ".csv": (_write_csv, False),
    ".json": (_write_json, False),
    ".npz": (_write_npz, True),
}
_READERS: dict[str, Callable[[Path], dict[str, Any]]] = {
    ".csv": _read_csv,
    ".json": _read_json,
    ".npz": _read_npz,
}

__all__ = [
    "FORMATS",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "ControlFunction",
    "Trajectory",
    "TrajectoryError",
    "TrajectoryFileError",
    "TrajectoryFileNotFoundError",
    "TrajectoryWriteError",
]
