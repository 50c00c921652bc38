"""A gait library: periodic walking steps over a grid of speeds, each with its feedback, in
one file a controller loads, and the lookup by commanded speed.

A :class:`GaitLibrary` holds, per speed of its grid (increasing), one planned periodic step
(:class:`LibraryGait`): its exported samples at ``rate_hz`` as written and verified (time,
psi, dpsi, ddpsi, hinge torques), the phase of each sample and the periodic LQR's gains there
(K (K, n, 2n) on x = (psi, dpsi), the model file's law), the closed loop's Floquet multipliers
(largest moduli first), the IPOPT iterations and the step's settings. :meth:`GaitLibrary.at`
interpolates between the two gaits whose speeds bracket the command, sample by sample in
normalised time t / T (each gait resampled linearly onto the common grid; the duration itself
blended), and returns the blended step as a ``model.LinkageTrajectory`` with its gains, which
:func:`problems.verify_gait` checks like any plan: how far from a solved step it is shows in
its margins (examples/benchmarks/gait_library.py measures them against the grid's spacing).

The file is NumPy's ``.npz`` (:meth:`GaitLibrary.save`, :meth:`GaitLibrary.load`): named
arrays a controller reads with ``numpy.load`` and nothing else (HDF5 or Parquet would add a
dependency for what a dozen arrays per gait are), plus one JSON string (``library.json``)
with the grid, the settings and the units; written whole or not at all.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from model.dynamics import Dynamics
from model.linkage import Linkage
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError, check_real
from planner.files import atomic_path
from planner.solution import uniform_times
from problems.walking.feedback import with_gains
from problems.walking.footed import step_at_speed
from problems.walking.step import walking_step

FORMAT = "anthropoid-planner gait library"
VERSION = 1
#: the arrays each gait keeps, with their units
ARRAYS = {"time": "s", "psi": "rad", "dpsi": "rad/s", "ddpsi": "rad/s^2", "torques": "N m",
          "phase": "1", "gains": "N m/rad | N m s/rad"}  # fmt: skip


@dataclass(frozen=True)
class LibraryGait:
    """One gait of a library (see the module): ``speed`` m/s, ``step_length`` m,
    ``step_time`` s; the exported samples (K,) / (K, n); ``gains`` (K, n, 2n);
    ``multipliers`` (2n,) complex, largest modulus first; ``iterations`` of IPOPT (every
    solve); ``settings`` the step's (``metadata["gait"]``)."""

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

    def on_grid(self, tau: np.ndarray) -> dict[str, np.ndarray]:
        """Every array at normalised times ``tau`` (M,) in [0, 1] (linear between samples)."""
        own = self.time / self.time[-1]
        out = {}
        for name in ("psi", "dpsi", "ddpsi", "torques", "gains"):
            values = getattr(self, name)
            flat = values.reshape(values.shape[0], -1)
            columns = [np.interp(tau, own, flat[:, j]) for j in range(flat.shape[1])]
            out[name] = np.stack(columns, axis=1).reshape((tau.size, *values.shape[1:]))
        out["phase"] = np.interp(tau, own, self.phase)
        return out


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
        settings (``metadata["gait"]``, its step length and time blended; ``library``:
        which gaits and weight)."""
        i, j, w = self.bracket(speed)
        a, b = self.gaits[i], self.gaits[j]
        T = (1.0 - w) * a.step_time + w * b.step_time
        times = uniform_times(T, self.rate_hz)  # the exported files' grid
        tau = times / T
        left, right = a.on_grid(tau), b.on_grid(tau)
        blend = {name: (1.0 - w) * left[name] + w * right[name] for name in left}
        settings = dict(a.settings)
        settings["step_length"] = (1.0 - w) * a.step_length + w * b.step_length
        settings["step_time"] = T
        # the ground's force on the stance foot, of the blended motion (Newton on the whole
        # body: what a joint-space file and the verification read)
        force = self.dynamics.ground_reaction(blend["psi"], blend["dpsi"], blend["ddpsi"])
        trajectory = LinkageTrajectory.from_linkage(
            times, blend["psi"], blend["dpsi"], blend["torques"], self.linkage.names,
            ddpsi=blend["ddpsi"], ground_reaction=np.asarray(force),
            metadata={"gait": settings, "model": self.linkage.parameters(),
                      "library": {"speed": float(speed), "between": [a.speed, b.speed],
                                  "weight": w}},
        )  # fmt: skip
        law = {"law": "M = clip(M_ff(s) + K(s) (x_ref(s) - x), -limit, limit)",
               "library": "blended between the gaits at the bracketing speeds"}  # fmt: skip
        return LinkageTrajectory.of(
            with_gains(trajectory, self.linkage.names, blend["phase"], blend["gains"], law)
        )

    def solve_at(self, speed: float, **step_options):
        """The step at ``speed`` m/s solved (``problems.walking_step`` with the library's
        linkage, ``step_options`` as there), warm-started from :meth:`at`'s blend: a verified
        plan where the blend is only close to one."""
        length, duration = step_at_speed(speed)
        step = walking_step(self.linkage, length, duration, **step_options)
        return step.solve(step.ocp.guess(self.at(speed)), progress=False)

    # ---- the file ---------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """``path`` (.npz, see the module), written whole or not at all."""
        path = Path(path)
        arrays: dict[str, np.ndarray] = {}
        for k, gait in enumerate(self.gaits):
            for name in ARRAYS:
                arrays[f"gait{k}_{name}"] = np.asarray(getattr(gait, name), dtype=float)
            arrays[f"gait{k}_multipliers"] = np.asarray(gait.multipliers, dtype=complex)
        description = {
            "format": FORMAT,
            "version": VERSION,
            "speeds_m_s": self.speeds.tolist(),
            "rate_hz": self.rate_hz,
            "units": ARRAYS,
            "gains": "gait<k>_gains[s, i, j]: row i (hinge, the model's order) of K on column j "
            "of x = (psi, dpsi); the law M = clip(M_ff(s) + K(s) (x_ref(s) - x)), s the "
            "phase (the hip's progress over the stance foot)",
            "model": self.linkage.parameters(),
            "settings": self.settings,
            "gaits": [
                {"speed": g.speed, "step_length": g.step_length, "step_time": g.step_time,
                 "iterations": g.iterations, "settings": g.settings}
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
            if description.get("format") != FORMAT or description.get("version") != VERSION:
                raise DefinitionError(
                    f"`path`: {str(path)!r} is {description.get('format')!r} version "
                    f"{description.get('version')!r}, not {FORMAT!r} version {VERSION}"
                )
            gaits = []
            for k, entry in enumerate(description["gaits"]):
                arrays = {name: np.asarray(data[f"gait{k}_{name}"]) for name in ARRAYS}
                gaits.append(LibraryGait(
                    speed=entry["speed"], step_length=entry["step_length"],
                    step_time=entry["step_time"], multipliers=data[f"gait{k}_multipliers"],
                    iterations=entry["iterations"], settings=entry["settings"], **arrays,
                ))  # fmt: skip
        return cls(tuple(gaits), Linkage.from_parameters(description["model"]),
                   float(description["rate_hz"]), description["settings"])  # fmt: skip


__all__ = ["FORMAT", "VERSION", "GaitLibrary", "LibraryGait"]
