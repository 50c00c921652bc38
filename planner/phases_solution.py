"""The result of a multi-phase solve: each phase's Solution and the whole on one time axis."""

from __future__ import annotations

import copy
import dataclasses
import math
from functools import cached_property

import casadi as ca
import numpy as np

from planner.errors import DefinitionError
from planner.solution import IntegrationError, Replay, Solution
from planner.trajectory import Trajectory


class PhasesSolution:
    """A solved :class:`planner.Phases` problem: each phase's :class:`Solution`
    (``phase(name)``, ``phases``), the whole on one time axis (``time``, ``states``,
    ``to_trajectory``, ``save``), the accuracy estimates of every phase, status and stats, the
    static parameters and each objective term.

    ``w``, ``lam_x``, ``lam_g`` are the whole NLP's (:attr:`transcription`); every phase's
    Solution holds the same vectors and reads its own share.
    """

    def __init__(self, transcription, w, cost, status, success, stats, lam_g, lam_x):
        self.transcription = transcription
        self.problem = transcription.problem
        self.w = np.asarray(w, dtype=float).reshape(-1)
        self.cost = float(cost)
        self.status = status
        self.success = bool(success)
        self.stats = stats
        self.lam_g = None if lam_g is None else np.asarray(lam_g, dtype=float).reshape(-1)
        self.lam_x = None if lam_x is None else np.asarray(lam_x, dtype=float).reshape(-1)
        #: The static parameters' values, name -> value.
        self.params = transcription.param_values(self.w)
        terms = transcription.cost_terms(self.w)
        self.phases: list[Solution] = []
        for k, name in enumerate(self.problem.names):
            own = sum(v for key, v in terms.items() if key.startswith(f"{name}: "))
            solution = Solution(
                transcription, self.w, own, status, success, stats, self.lam_g, self.lam_x, k
            )
            # A phase sees the parameters it declares.
            solution.params = {p.name: self.params[p.name] for p in solution.ocp.params}
            self.phases.append(solution)

    @property
    def names(self) -> tuple[str, ...]:
        return self.problem.names

    def part(self, first: str, last: str) -> PhasesSolution:
        """The consecutive phases ``first`` .. ``last`` as a solution of their own (one step
        of several solved together): its phases the same :class:`Solution` objects, its
        problem those phases with the joins and events between them (no periodicity), its
        cost theirs, its parameters those they declare, its time axis from the first one's
        start; status, statistics and the NLP's vectors the whole solve's."""
        i, j = self.problem.index(first), self.problem.index(last)
        if j < i:
            raise DefinitionError(f"`last`: {last!r} comes before {first!r}; give them in order")
        whole = self.problem
        events = tuple(
            dataclasses.replace(e, after_phase=e.after_phase - i)
            for e in whole.events
            if i <= e.after_phase < j
        )
        problem = dataclasses.replace(
            whole,
            phases=whole.phases[i : j + 1],
            mappings=whole.mappings[i:j],
            controls=whole.controls[i:j],
            events=events,
            periodicity=None,
            warm=None,
        )
        part = copy.copy(self)
        part.__dict__.pop("cost_terms", None)
        part.problem = problem
        part.phases = self.phases[i : j + 1]
        part.cost = math.fsum(solution.cost for solution in part.phases)
        part.params = {p.name: self.params[p.name] for p in problem.params}
        return part

    def phase(self, name: str) -> Solution:
        return self.phases[self.problem.index(name)]

    @property
    def iterations(self) -> int:
        return int(self.stats.get("iterations", 0))

    @property
    def nlp_signature(self) -> str:
        return self.transcription.signature

    @property
    def durations(self) -> np.ndarray:
        """(K,) each phase's duration, s."""
        return np.array([s.T for s in self.phases])

    @property
    def T(self) -> float:
        return float(np.sum(self.durations))

    @property
    def starts(self) -> np.ndarray:
        """(K,) each phase's start on the common time axis, s."""
        return np.concatenate([[0.0], np.cumsum(self.durations)[:-1]])

    @cached_property
    def cost_terms(self) -> dict[str, float]:
        """Each objective term's value, "<phase>: <term>" -> value (they add up to cost)."""
        terms = self.transcription.cost_terms(self.w)
        prefixes = tuple(f"{name}: " for name in self.names)  # a part's phases only (part())
        return {key: value for key, value in terms.items() if key.startswith(prefixes)}

    @property
    def time(self) -> np.ndarray:
        """Every phase's node times on the common axis, (sum N_k + K,) s: a phase's end and
        the next one's start are both kept (the state may jump there)."""
        return np.concatenate([s.time + t0 for s, t0 in zip(self.phases, self.starts, strict=True)])

    @property
    def states(self) -> np.ndarray:
        """(sum N_k + K, nx) every phase's node states, as :attr:`time`."""
        self._same_states("states")
        return np.vstack([s.states for s in self.phases])

    def _same_states(self, what: str) -> tuple[str, ...]:
        names = self.phases[0].state_names
        for name, s in zip(self.names, self.phases, strict=True):
            if s.state_names != names:
                raise DefinitionError(
                    f"`{what}`: phase {name!r} has other states than {self.names[0]!r} "
                    f"({s.state_names} against {names}); read each phase (phase(name))"
                )
        return names

    # ---- accuracy -----------------------------------------------------------------------
    def integration_error(self, rtol: float = 1e-12, atol: float = 1e-12) -> IntegrationError:
        """Every phase's intervals re-integrated (``Solution.integration_error``), stacked in
        phase order, (sum N_k, nx); the phases must have the same states."""
        names = self._same_states("integration_error")
        errors = [s.integration_error(rtol, atol) for s in self.phases]
        return IntegrationError(np.vstack([e.per_interval for e in errors]), names)

    def residual_error(self, points: int | None = None) -> IntegrationError:
        """Every phase's ``Solution.residual_error`` (the integral of |f - dx/dt| over each
        interval), stacked in phase order, (sum N_k, nx); the phases must have the same
        states."""
        names = self._same_states("residual_error")
        errors = [s.residual_error(*([] if points is None else [points])) for s in self.phases]
        return IntegrationError(np.vstack([e.per_interval for e in errors]), names)

    def replay(self, rtol: float = 1e-10, atol: float = 1e-10) -> Replay:
        """The whole sequence integrated open loop from x(0) with the interpolated controls:
        each phase from the state the previous one ended in, through the join's mapping (a
        stability probe, see ``Solution.replay``). time (sum N_k + K,) as :attr:`time`;
        deviation against each phase's nodes."""
        self._same_states("replay")
        times, states, deviations = [], [], []
        x0 = None
        for k, (solution, t0) in enumerate(zip(self.phases, self.starts, strict=True)):
            if k:
                mapping = self.problem.mappings[k - 1]
                x0 = states[-1][-1] if mapping is None else _evaluate(mapping, states[-1][-1])
            run = solution.replay(rtol, atol, x0=x0)
            times.append(run.time + t0)
            states.append(run.states)
            deviations.append(run.deviation)
        return Replay(np.concatenate(times), np.vstack(states), np.vstack(deviations))

    # ---- export -------------------------------------------------------------------------
    def to_trajectory(self, rate_hz: float | None = None) -> Trajectory:
        """The phases one after another on one time axis, sampled like
        ``Solution.to_trajectory`` (each phase at its nodes or at ``rate_hz``). The phases
        must have the same states and drives; a channel that only some phases have (a
        contact force held in one phase) is 0 in the others, and ``metadata["phases"]``
        lists each phase's start, duration, mesh and channels. At a join the end of one
        phase and the start of the next are one instant: the start of the next is kept (a
        jump, e.g. an impact, shows as the next phase's value)."""
        self._same_states("to_trajectory")
        parts = [s.to_trajectory(rate_hz) for s in self.phases]
        first = parts[0]
        for name, part in zip(self.names, parts, strict=True):
            if part.control_names != first.control_names:
                raise DefinitionError(
                    f"`to_trajectory`: phase {name!r} drives {part.control_names}, phase "
                    f"{self.names[0]!r} {first.control_names}; export the phases one by one "
                    "(phase(name).to_trajectory())"
                )
        units: dict[str, str] = {}
        for part in parts:
            for name, (_, unit) in part.extras.items():
                units.setdefault(name, unit)
        times, states, controls = [], [], []
        extras: dict[str, list[np.ndarray]] = {name: [] for name in units}
        for k, (part, t0) in enumerate(zip(parts, self.starts, strict=True)):
            keep = slice(None) if k == len(parts) - 1 else slice(None, -1)
            times.append(part.time[keep] + t0)
            states.append(part.states[keep])
            controls.append(part.controls[keep])
            count = part.time[keep].size
            for name in units:
                values = part.extras[name][0] if name in part.extras else np.zeros(part.n_samples)
                extras[name].append(np.asarray(values, dtype=float)[keep][:count])
        metadata = {
            **first.metadata,
            "phases": [
                {
                    "name": n,
                    "start": float(t0),
                    "T": float(s.T),
                    "N": s.N,
                    "transcription": s.scheme.name,
                    "degree": s.scheme.degree,
                    "channels": sorted(part.extras),
                }
                for n, s, t0, part in zip(self.names, self.phases, self.starts, parts, strict=True)
            ],
            "T": self.T,
            "cost": self.cost,
            "status": self.status,
        }
        return type(first)(
            np.concatenate(times),
            np.vstack(states),
            np.vstack(controls),
            first.state_names,
            first.state_units,
            first.control_names,
            first.control_units,
            {name: (np.concatenate(values), units[name]) for name, values in extras.items()},
            metadata,
        )

    def save(self, path, rate_hz: float | None = None):
        """``to_trajectory(rate_hz).save(path)``: format by suffix (.csv, .json, .npz).

        Returns the path written."""
        return self.to_trajectory(rate_hz).save(path)

    def __repr__(self) -> str:
        return (
            f"PhasesSolution({' -> '.join(self.names)}, T={self.T:g} s, status={self.status}, "
            f"cost={self.cost:.6g}, iterations={self.iterations})"
        )


def _evaluate(mapping, x: np.ndarray) -> np.ndarray:
    """A join's mapping (callable of SX or casadi.Function) at a numeric state."""
    symbol = ca.SX.sym("x", x.size)
    value = mapping(symbol)
    if isinstance(value, list | tuple):
        value = ca.vertcat(*value)
    return np.asarray(ca.Function("mapping", [symbol], [value])(x)).reshape(-1)


__all__ = ["PhasesSolution"]
