"""A gait library: periodic walking steps over a grid of speeds, each with its feedback, in
one file a controller loads, and the lookup by commanded speed.

A :class:`GaitLibrary` holds, per speed of its grid (increasing), one planned periodic step
(:class:`LibraryGait`): its exported samples at ``rate_hz`` as written and verified (time,
psi, dpsi, ddpsi, hinge torques), the phase of each sample and the feedback's gains there
(K (K, n, 2n) on x = (psi, dpsi), the model file's law: the periodic LQR on point feet, the
joint PD on feet), the closed loop's Floquet multipliers (largest moduli first; on feet the
largest's modulus alone, measured from a push's decay, the others NaN), the IPOPT
iterations and the step's settings. A step on feet is several contact phases (flat foot,
heel rise, double support: ``segments``, their names and durations) and carries the columns
a point foot has not (``extras``: the front foot's ground force in the double support, the
feedback's branch ``double_support``).

:meth:`GaitLibrary.at` interpolates between the two gaits whose speeds bracket the command,
sample by sample in normalised time, each contact phase on its own: a sample at t in phase
p of durations T_p sits at p + (t - start_p) / T_p, each gait is resampled linearly onto the
common grid there, and the phases' durations are blended (blending the whole step in t / T
would mix one gait's heel rise with the other's double support where their phases end at
different fractions of the step). The blend comes back as a ``model.LinkageTrajectory`` with
its gains, the stance foot's ground force from Newton's law on the whole body (less the
front foot's blended force), which :func:`problems.verify_gait` checks like any plan: how far
from a solved step it is shows in its margins (examples/benchmarks/gait_library.py measures
them against the grid's spacing).

The file is NumPy's ``.npz`` (:meth:`GaitLibrary.save`, :meth:`GaitLibrary.load`): named
arrays a controller reads with ``numpy.load`` and nothing else (HDF5 or Parquet would add a
dependency for what a dozen arrays per gait are), plus one JSON string (``library.json``)
with the grid, the settings and the units; written whole or not at all.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from model.dynamics import Dynamics
from model.linkage import Linkage
from model.linkage_naming import centre_of_pressure_name, root_contact
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError, check_real
from planner.files import atomic_path
from planner.solution import uniform_times
from problems.control.feedback import with_gains
from problems.gait.problem import centre_of_pressure
from problems.walking.footed import footed_step_at, step_at_speed
from problems.walking.step import walking_step

FORMAT = "anthropoid-planner gait library"
#: 2: the contact phases (``segments``), the extra columns and the law of steps on feet; a
#: version 1 file (point feet only) still loads
VERSION = 2
#: the arrays each gait keeps, with their units
ARRAYS = {"time": "s", "psi": "rad", "dpsi": "rad/s", "ddpsi": "rad/s^2", "torques": "N m",
          "phase": "1", "gains": "N m/rad | N m s/rad"}  # fmt: skip


@dataclass(frozen=True)
class LibraryGait:
    """One gait of a library (see the module): ``speed`` m/s, ``step_length`` m,
    ``step_time`` s; the exported samples (K,) / (K, n); ``gains`` (K, n, 2n);
    ``multipliers`` (2n,) complex, largest modulus first (NaN: not computed); ``iterations``
    of IPOPT (every solve); ``settings`` the step's (``metadata["gait"]``); ``segments``
    ((name, duration s), ...) its contact phases in order (empty: one, the whole step);
    ``extras`` {name: (K,)} the columns beyond the states and torques a controller reads
    (the front foot's force ``F_<contact>_x``/``_y`` N, ``double_support``); ``law`` the
    feedback's description (the file's ``metadata["feedback"]`` without its arrays)."""

    speed: float
    step_length: float
    step_time: float
    time: np.ndarray
    psi: np.ndarray
    dpsi: np.ndarray
    ddpsi: np.ndarray
    torques: np.ndarray
    phase: np.ndarray
    gains: np.ndarray
    multipliers: np.ndarray
    iterations: int
    settings: dict = field(default_factory=dict)
    segments: tuple[tuple[str, float], ...] = ()
    extras: dict = field(default_factory=dict)
    law: dict = field(default_factory=dict)

    @property
    def durations(self) -> np.ndarray:
        """Each contact phase's duration, s (one: the step time, for a step of one phase)."""
        if not self.segments:
            return np.array([self.step_time])
        return np.array([duration for _, duration in self.segments], dtype=float)

    def phase_coordinate(self) -> tuple[np.ndarray, np.ndarray]:
        """(coordinate (K,), phase index (K,)) of each sample: p + (t - start_p) / T_p, p the
        contact phase it lies in (the later phase's first sample where two meet, as exported;
        the step's last sample is the last phase's end, at coordinate P)."""
        durations = self.durations
        starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]])
        index = np.searchsorted(starts, self.time + 1e-9 * self.step_time, side="right") - 1
        index = np.clip(index, 0, durations.size - 1)
        return index + (self.time - starts[index]) / durations[index], index

    def on_grid(self, tau: np.ndarray, names: tuple[str, ...] | None = None) -> dict:
        """Every array (or those ``names`` of ``psi``, ``dpsi``, ``ddpsi``, ``torques``,
        ``gains``, ``phase``) at phase coordinates ``tau`` (M,) (:meth:`phase_coordinate`:
        t / T in [0, 1] for a step of one phase), linear between the samples of the same
        contact phase and never across an impact: a phase's end takes what
        ``settings["before_events"]`` holds there (the state, and on feet its accelerations
        and torques) and its other arrays on along their last slope; ``extras`` {name: (M,)}
        too when every array is asked for."""
        own, index = self.phase_coordinate()
        target = np.clip(np.floor(tau).astype(int), 0, self.durations.size - 1)
        events = self.settings.get("before_events") or []
        asked = names or ("psi", "dpsi", "ddpsi", "torques", "gains", "phase")
        arrays = {name: getattr(self, name) for name in asked}
        if names is None:
            arrays.update({f"extra:{key}": column for key, column in self.extras.items()})
        out = {name: np.empty((tau.size, *values.shape[1:])) for name, values in arrays.items()}
        for p in np.unique(target):
            rows, into = index == p, target == p
            event = events[p] if p < len(events) else None
            for name, values in arrays.items():
                x, flat = _to_phase_end(own[rows], values[rows].reshape(int(rows.sum()), -1),
                                        event, name, p)  # fmt: skip
                columns = [np.interp(tau[into], x, flat[:, j]) for j in range(flat.shape[1])]
                out[name][into] = np.stack(columns, axis=1).reshape(
                    (int(into.sum()), *values.shape[1:])
                )
        if names is None:
            out["extras"] = {key: out.pop(f"extra:{key}") for key in self.extras}
        return out


def _to_phase_end(x: np.ndarray, flat: np.ndarray, event: dict | None, name: str, p: int):
    """(coordinates, values) of one array's samples in contact phase ``p`` (``x`` (K,),
    ``flat`` (K, columns)), carried to the phase's end p + 1 where an ``event`` (its
    ``before_events`` entry) ends it: with the entry's value there (:func:`_at_event`), or on
    along the last slope (held at the last value, the blend just before a heel strike
    missed the equations of motion by 25 N m at 0.1 m/s spacing); as they are without one."""
    if event is None:
        return x, flat
    end = _at_event(event, name)
    if end is None:
        if x.size < 2:
            return x, flat
        slope = (flat[-1] - flat[-2]) / (x[-1] - x[-2])
        end = flat[-1] + slope * (p + 1.0 - x[-1])
    return np.append(x, p + 1.0), np.vstack([flat, end])


@dataclass(frozen=True)
class GaitLibrary:
    """Gaits over speed (see the module): ``gaits`` by increasing speed, the ``linkage``
    they were planned for, ``rate_hz`` of their samples, ``settings`` of the build."""

    gaits: tuple[LibraryGait, ...]
    linkage: Linkage
    rate_hz: float
    settings: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        speeds = [g.speed for g in self.gaits]
        if len(speeds) < 1 or any(b <= a for a, b in itertools.pairwise(speeds)):
            raise DefinitionError(f"`gaits`: one or more, by strictly increasing speed, got "
                                  f"{speeds}")  # fmt: skip

    @cached_property
    def dynamics(self) -> Dynamics:
        """The linkage's model (built once)."""
        return Dynamics(self.linkage)

    @property
    def speeds(self) -> np.ndarray:
        return np.array([g.speed for g in self.gaits])

    def bracket(self, speed: float) -> tuple[int, int, float]:
        """(i, j, w): the gaits around ``speed`` and the weight of j (0 at i's speed)."""
        speed = check_real("speed", speed)
        speeds = self.speeds
        if not speeds[0] - 1e-12 <= speed <= speeds[-1] + 1e-12:
            raise DefinitionError(
                f"`speed`: {speed!r} m/s is outside the library's {speeds[0]:g}..{speeds[-1]:g} "
                "m/s: extend the library (build_library) or command a speed within it"
            )
        j = int(np.clip(np.searchsorted(speeds, speed), 1, max(1, speeds.size - 1)))
        i = j - 1 if speeds.size > 1 else 0
        if speeds.size == 1:
            return 0, 0, 0.0
        w = (speed - speeds[i]) / (speeds[j] - speeds[i])
        return i, j, float(min(max(w, 0.0), 1.0))

    def at(self, speed: float) -> LinkageTrajectory:
        """The step at ``speed`` m/s: a gait of the grid, or the blend of its two neighbours
        (see the module), as a trajectory with its gains (``K_<hinge>__<state>``) and
        settings (``metadata["gait"]``, its step length, time and the state before each
        impact blended; ``library``: which gaits and weight)."""
        a, b, w, durations = self._bracketed(speed)
        times, tau = _phase_grid(durations, self.rate_hz)
        left, right = a.on_grid(tau), b.on_grid(tau)
        blend = {name: (1.0 - w) * left[name] + w * right[name] for name in left
                 if name != "extras"}  # fmt: skip
        extras = {key: (1.0 - w) * left["extras"][key] + w * right["extras"][key]
                  for key in a.extras}  # fmt: skip
        settings = dict(a.settings)
        settings["step_length"] = (1.0 - w) * a.step_length + w * b.step_length
        settings["step_time"] = float(np.sum(durations))
        if a.segments:
            starts = np.cumsum(durations)[:-1]
            settings["before_events"] = [
                {"t": float(t), **{key: ((1.0 - w) * np.asarray(ea[key])
                                         + w * np.asarray(eb[key])).tolist()
                                   for key in ("x", "ddpsi", "torques") if key in ea}}
                for t, ea, eb in zip(starts, a.settings["before_events"],
                                     b.settings["before_events"], strict=True)
            ]  # fmt: skip
        trajectory = LinkageTrajectory.from_linkage(
            times, blend["psi"], blend["dpsi"], blend["torques"], self.linkage.names,
            ddpsi=blend["ddpsi"], ground_reaction=self._stance_force(blend, extras),
            metadata={"gait": settings, "model": self.linkage.parameters(),
                      "library": {"speed": float(speed), "between": [a.speed, b.speed],
                                  "weight": w}},
        )  # fmt: skip
        for key, column in extras.items():
            trajectory = trajectory.with_extra(key, column, "N" if key.startswith("F_") else "1")
        if a.segments:  # on feet: where the stance sole pushes, as the step's own file has it
            root = root_contact(self.linkage.names)
            pressure = centre_of_pressure(blend["torques"][:, 0], trajectory.ground_reaction)
            trajectory = trajectory.with_extra(centre_of_pressure_name(root), pressure, "m")
        law = {**(a.law or {"law": "M = clip(M_ff(s) + K(s) (x_ref(s) - x), -limit, limit)"}),
               "library": "blended between the gaits at the bracketing speeds"}  # fmt: skip
        return LinkageTrajectory.of(
            with_gains(trajectory, self.linkage.names, blend["phase"], blend["gains"], law)
        )

    def _bracketed(self, speed: float) -> tuple[LibraryGait, LibraryGait, float, np.ndarray]:
        """(a, b, w, durations): the gaits around ``speed`` (:meth:`bracket`), the weight of
        b and the blended contact phases' durations (P,) s; refused where a and b walk other
        contact phases."""
        i, j, w = self.bracket(speed)
        a, b = self.gaits[i], self.gaits[j]
        names = [name for name, _ in a.segments]
        if names != [name for name, _ in b.segments]:
            raise DefinitionError(
                f"`speed`: the gaits at {a.speed:g} and {b.speed:g} m/s walk other contact "
                f"phases ({names} against {[n for n, _ in b.segments]}); they do not blend"
            )
        return a, b, w, (1.0 - w) * a.durations + w * b.durations

    def _stance_force(self, blend: dict, extras: dict) -> np.ndarray:
        """The ground's force on the stance foot (K,) complex, N, of the blended motion:
        Newton's law on the whole body less the other contacts' blended forces (what a
        joint-space file and the verification read)."""
        force = self.dynamics.ground_reaction(blend["psi"], blend["dpsi"], blend["ddpsi"])
        for key, column in extras.items():
            if key.startswith("F_"):
                force = force - (column if key.endswith("_x") else 1j * column)
        return np.asarray(force)

    @property
    def feet(self) -> bool:
        """Whether the gaits walk on feet (several contact phases)."""
        return bool(self.gaits[0].segments)

    def solve_at(self, speed: float, **step_options):
        """The step at ``speed`` m/s solved (``problems.walking_step``, or on feet
        ``problems.footed_step``, with the library's linkage, ``step_options`` as there),
        warm-started from :meth:`at`'s blend: a verified plan where the blend is only close
        to one. On feet each contact phase starts from its piece of the blend and its
        duration (and the duration parameters) from the blended durations."""
        if not self.feet:
            length, duration = step_at_speed(speed)
            step = walking_step(self.linkage, length, duration, **step_options)
            return step.solve(step.ocp.guess(self.at(speed)), progress=False)
        step = footed_step_at(speed, linkage=self.linkage, **step_options)
        a, b, w, durations = self._bracketed(speed)
        if tuple(step.sequence) != tuple(name for name, _ in a.segments):
            raise DefinitionError(
                f"`step_options`: the step walks {list(step.sequence)}, the library's gaits "
                f"{[name for name, _ in a.segments]}; give the library's phases="
            )

        def piece(p: int):
            def source(t):
                tau = p + np.clip(np.asarray(t, dtype=float) / durations[p], 0.0, 1.0)
                names = ("psi", "dpsi", "ddpsi", "torques")  # what a guess reads, not the gains
                left, right = a.on_grid(tau, names), b.on_grid(tau, names)
                return tuple((1.0 - w) * left[name] + w * right[name] for name in names)

            return source

        return step.solve(_guessed(step.problem, piece, durations), progress=False)

    # ---- the file ---------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """``path`` (.npz, see the module), written whole or not at all."""
        path = Path(path)
        arrays: dict[str, np.ndarray] = {}
        for k, gait in enumerate(self.gaits):
            for name in ARRAYS:
                arrays[f"gait{k}_{name}"] = np.asarray(getattr(gait, name), dtype=float)
            arrays[f"gait{k}_multipliers"] = np.asarray(gait.multipliers, dtype=complex)
            for key, column in gait.extras.items():
                arrays[f"gait{k}_extra_{key}"] = np.asarray(column, dtype=float)
        description = {
            "format": FORMAT,
            "version": VERSION,
            "speeds_m_s": self.speeds.tolist(),
            "rate_hz": self.rate_hz,
            "units": ARRAYS,
            "gains": "gait<k>_gains[s, i, j]: row i (hinge, the model's order) of K on column j "
            "of x = (psi, dpsi); the law M = clip(M_ff(s) + K(s) (x_ref(s) - x)), s the "
            "phase (the hip's progress over the stance foot); each gait's own law in "
            "gaits[k].law",
            "extras": "gait<k>_extra_<name>: the columns gaits[k].extras names (N for F_*)",
            "model": self.linkage.parameters(),
            "settings": self.settings,
            "gaits": [
                {"speed": g.speed, "step_length": g.step_length, "step_time": g.step_time,
                 "iterations": g.iterations, "settings": g.settings,
                 "segments": [[name, float(t)] for name, t in g.segments],
                 "extras": list(g.extras), "law": g.law}
                for g in self.gaits
            ],
        }  # fmt: skip
        arrays["library_json"] = np.array(json.dumps(description, allow_nan=False))
        if path.suffix != ".npz":
            raise DefinitionError(f"`path`: a gait library is an .npz file, got {str(path)!r}")
        with atomic_path(path, suffix=".npz") as temporary:
            np.savez_compressed(temporary, **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> GaitLibrary:
        """The library written by :meth:`save` at ``path``."""
        path = Path(path)
        try:
            data = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as error:
            raise DefinitionError(
                f"`path`: {str(path)!r} is not a gait library ({error})"
            ) from None
        with data:
            if "library_json" not in data.files:
                raise DefinitionError(f"`path`: {str(path)!r} has no library_json: not a gait "
                                      "library")  # fmt: skip
            description: dict[str, Any] = json.loads(str(data["library_json"]))
            if description.get("format") != FORMAT or description.get("version") not in (1, 2):
                raise DefinitionError(
                    f"`path`: {str(path)!r} is {description.get('format')!r} version "
                    f"{description.get('version')!r}, not {FORMAT!r} version 1 or {VERSION}"
                )
            gaits = []
            for k, entry in enumerate(description["gaits"]):
                arrays = {name: np.asarray(data[f"gait{k}_{name}"]) for name in ARRAYS}
                gaits.append(LibraryGait(
                    speed=entry["speed"], step_length=entry["step_length"],
                    step_time=entry["step_time"], multipliers=data[f"gait{k}_multipliers"],
                    iterations=entry["iterations"], settings=entry["settings"], **arrays,
                    segments=tuple((name, float(t)) for name, t in entry.get("segments", ())),
                    extras={key: np.asarray(data[f"gait{k}_extra_{key}"])
                            for key in entry.get("extras", ())},
                    law=entry.get("law", {}),
                ))  # fmt: skip
        return cls(tuple(gaits), Linkage.from_parameters(description["model"]),
                   float(description["rate_hz"]), description["settings"])  # fmt: skip


def _at_event(event: dict, name: str) -> np.ndarray | None:
    """``name``'s value at a phase's end from its ``before_events`` entry, or None."""
    if name in ("psi", "dpsi"):
        x = np.asarray(event["x"], dtype=float)  # (psi, dpsi)
        return x[: x.size // 2] if name == "psi" else x[x.size // 2 :]
    if name in ("ddpsi", "torques") and name in event:
        return np.asarray(event[name], dtype=float)
    return None


def _guessed(problem, piece, durations: np.ndarray):
    """``problem`` (the step on feet's phases) guessed phase by phase: phase p from
    ``piece(p)`` (a callable of its time t (K,) s giving (psi, dpsi, ddpsi, torques), or a
    solved phase, taken in normalised time), its
    duration ``durations[p]`` s and the duration parameters (each phase's but the last, in
    the problem's own order and names, :func:`problems.walking.footed.footed_step`) from
    theirs (clipped into their bounds)."""
    names = [parameter.name for parameter in problem.params]
    values = dict(zip(names, durations[:-1], strict=True))
    phases = []
    for p, (name, ocp) in enumerate(problem.phases):
        ocp = ocp.guess(piece(p), T=float(np.clip(durations[p], *ocp.T)))
        for parameter in ocp.params:
            if parameter.name in values:
                value = float(np.clip(values[parameter.name], parameter.lower, parameter.upper))
                ocp = ocp.param(parameter.name, parameter.lower, parameter.upper, guess=value,
                                scale=parameter.scale)  # fmt: skip
        phases.append((name, ocp))
    return replace(problem, phases=tuple(phases))


def _phase_grid(durations: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(times (M,) s, phase coordinates (M,)) of a step of contact phases of ``durations``
    (P,): each phase on its own export grid from its start (``uniform_times``), its last
    sample left to the next phase's first where two meet."""
    times, tau = [], []
    start = 0.0
    for p, duration in enumerate(durations):
        local = uniform_times(float(duration), rate_hz)
        if p < durations.size - 1:
            local = local[local < duration * (1.0 - 1e-9)]
        times.append(start + local)
        tau.append(p + local / duration)
        start += float(duration)
    return np.concatenate(times), np.concatenate(tau)


__all__ = ["FORMAT", "VERSION", "GaitLibrary", "LibraryGait"]
