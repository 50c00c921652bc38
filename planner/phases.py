"""Multi-phase optimal control: a sequence of phases joined by events.

A walking step with a double-support phase, a heel-toe roll, running with a flight phase, or a
gait of two different steps is a sequence of phases, each an ordinary single-phase
:class:`planner.OCP` (its own dynamics, duration fixed or free, mesh, transcription, bounds,
constraints and objective terms), joined by events:

* a join from phase k to phase k+1: x_{k+1}(0) = mapping(x_k(T_k)) (an impact map, a
  relabelling of legs, a contact switch), or plain continuity x_{k+1}(0) = x_k(T_k) when no
  mapping is given (the two phases must then have the same states);
* event constraints at a join, lower <= g(e) <= upper, on an :class:`EventPoint` ``e`` with
  both sides of the event (``e.x_before``, ``e.x_after``, ``e.T_before``, ``e.T_after`` and
  the static parameters): an impulse inside the friction cone, a lift-off velocity;
* periodicity, the join from the last phase back to the first: x_1(0) = mapping(x_K(T_K)).

The objective is the sum of the phases' objective terms; static parameters
(``Phases.param`` adds one to every phase, or a phase's own ``OCP.param``) are shared by name
across phases. Time restarts at 0 in each phase (a Point's ``t``); the Solution puts the
phases on one time axis, phase k starting at T_1 + ... + T_{k-1}.

A single-phase OCP is transcribed by the same code (:class:`planner.transcription.
Transcription`); here each phase is such a transcription built on its share of the variables,
and the events are rows added between them.

>>> problem = (Phases.sequence(("single", single_support), ("double", double_support))
...            .periodic(leg_swap)
...            .constrain_event("single", "impulse cone", cone, lower=0))
>>> solution = problem.solve()        # PhasesSolution: .phase("single"), .to_trajectory()
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from model.errors import DefinitionError, DefinitionTypeError
from planner.ocp import (
    OCPDefinition,
    Param,
    _as_bounds,
    _check_constants,
    _free_symbols,
    _positive_array,
    evaluate_mapping,
)
from planner.solution import IntegrationError, Solution
from planner.trajectory import Trajectory
from planner.transcription import Transcription

if TYPE_CHECKING:
    from typing import Self


class EventPoint:
    """Both sides of an event, for event constraints: ``x_before`` (the state at the end of
    the phase before, (nx,)), ``x_after`` (the state at the start of the phase after),
    ``T_before``, ``T_after`` (their durations, s) and every static parameter by name; all
    CasADi SX in physical units."""

    def __init__(self, fields: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_fields", dict(fields))

    def __getattr__(self, name: str):
        fields = object.__getattribute__(self, "_fields")
        if name in fields:
            return fields[name]
        raise AttributeError(f"EventPoint has no field {name!r}; fields: {sorted(fields)}")

    def __getitem__(self, name: str):
        return self.__getattr__(name)

    def __setattr__(self, name, value):
        raise AttributeError("EventPoint is read-only")

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(self._fields)


@dataclass(frozen=True, eq=False)
class EventConstraint:
    """lower <= expression(EventPoint) <= upper at the join after phase ``after_phase``."""

    name: str
    after_phase: int
    expression: Any
    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray | None


@dataclass(frozen=True, eq=False)
class PhasesDefinition:
    """A multi-phase problem, as a value: phases (name, OCP) in order, the joins between them
    (``mappings[k]``: phase k -> k+1, None for continuity), event constraints, periodicity.

    Build it with :meth:`sequence` and the builders (each returns a new value).
    :class:`planner.Phases` is this class with ``solve()`` (:mod:`planner.problem`).
    """

    phases: tuple[tuple[str, OCPDefinition], ...]
    mappings: tuple[Any, ...] = ()
    events: tuple[EventConstraint, ...] = ()
    periodicity: tuple[Any, ...] | None = None
    warm: Any = None  # a PhasesSolution to warm-start IPOPT's multipliers from

    def __post_init__(self) -> None:
        if not isinstance(self.phases, tuple) or not self.phases:
            raise DefinitionError("`phases`: give at least one (name, OCP) phase")
        names = []
        for i, item in enumerate(self.phases):
            if not (isinstance(item, tuple) and len(item) == 2):
                raise DefinitionTypeError(
                    f"`phases[{i}]`: must be a (name, OCP) pair, got {item!r}"
                )
            name, ocp = item
            if not isinstance(name, str) or not name:
                raise DefinitionTypeError(f"`phases[{i}]`: a phase needs a name, got {name!r}")
            if name in names:
                raise DefinitionError(f"`phases[{i}]`: two phases are called {name!r}")
            if not isinstance(ocp, OCPDefinition):
                raise DefinitionTypeError(
                    f"`phases[{i}]` ({name!r}): must be a planner.OCP, got {type(ocp).__name__}"
                )
            names.append(name)
        mappings = tuple(self.mappings) + (None,) * (len(self.phases) - 1 - len(self.mappings))
        if len(mappings) != len(self.phases) - 1:
            raise DefinitionError(
                f"`mappings`: {len(self.phases)} phases have {len(self.phases) - 1} joins, got "
                f"{len(self.mappings)} mappings"
            )
        object.__setattr__(self, "mappings", mappings)
        for k, mapping in enumerate(mappings):
            self._check_mapping(k, (k + 1) % len(self.phases), mapping, f"join after {names[k]!r}")
        if self.periodicity is not None:
            self._check_mapping(len(names) - 1, 0, self.periodicity[0], "periodic")
        self.params  # noqa: B018 (checks that shared parameters agree)

    # ---- building -----------------------------------------------------------------------
    @classmethod
    def sequence(cls, *phases: tuple[str, OCPDefinition]) -> Self:
        """Phases in order, joined by continuity (change a join with :meth:`join`)."""
        return cls(tuple(phases))

    def then(self, name: str, ocp: OCPDefinition, mapping=None) -> Self:
        """Append a phase, joined to the last one by ``mapping`` (None: continuity)."""
        return dataclasses.replace(
            self, phases=(*self.phases, (name, ocp)), mappings=(*self.mappings, mapping)
        )

    def join(self, before: str, mapping=None) -> Self:
        """The join after phase ``before``: x_next(0) = mapping(x_before(T)) (a callable of
        the SX state or a casadi.Function (nx_before,) -> (nx_after,)); None: continuity."""
        k = self.index(before)
        if k == len(self.phases) - 1:
            raise DefinitionError(
                f"`before`: {before!r} is the last phase; its join to the first is periodic(...)"
            )
        mappings = list(self.mappings)
        mappings[k] = mapping
        return dataclasses.replace(self, mappings=tuple(mappings))

    def periodic(self, mapping=None) -> Self:
        """Close the sequence: x_first(0) = mapping(x_last(T_last)) (None: the identity)."""
        return dataclasses.replace(self, periodicity=(mapping,))

    def constrain_event(
        self, after: str, name: str, expression, lower=None, upper=None, scale=None
    ) -> Self:
        """An event constraint at the join after phase ``after`` (the periodic join after the
        last phase when the problem is periodic): lower <= expression(e) <= upper, ``e`` an
        :class:`EventPoint`."""
        k = self.index(after)
        if k == len(self.phases) - 1 and self.periodicity is None:
            raise DefinitionError(
                f"`after`: {after!r} is the last phase and the problem is not periodic: there "
                "is no event after it; call periodic(...) first"
            )
        if not isinstance(name, str) or not name:
            raise DefinitionTypeError(f"`name`: an event constraint needs a name, got {name!r}")
        if any(e.name == name for e in self.events):
            raise DefinitionError(f"`name`: an event constraint named {name!r} exists already")
        label = f"event[{name}]"
        value = _event_value(label, expression, self._event_point(k))
        if lower is None and upper is None:
            raise DefinitionError(f"`{label}`: give lower and/or upper (equal: lower=upper)")
        lo, hi = _as_bounds(label, lower, upper, value.size1())
        scale_array = None if scale is None else _positive_array(f"{label} scale", scale, lo.size)
        event = EventConstraint(name, k, expression, lo, hi, scale_array)
        return dataclasses.replace(self, events=(*self.events, event))

    def param(self, name: str, lower=None, upper=None, guess=None, scale=None) -> Self:
        """A static parameter of the whole problem (added to every phase: ``OCP.param``)."""
        phases = tuple(
            (phase, ocp.param(name, lower, upper, guess, scale)) for phase, ocp in self.phases
        )
        return dataclasses.replace(self, phases=phases)

    def guess(self, solution: PhasesSolution) -> Self:
        """Every phase guessed from ``solution``'s phase of the same name (re-gridded when the
        meshes differ); IPOPT's multipliers too when the NLP layouts are the same."""
        if not isinstance(solution, PhasesSolution):
            raise DefinitionTypeError(
                f"`solution`: must be a planner.PhasesSolution, got {type(solution).__name__}"
            )
        phases = tuple(
            (name, ocp.guess(solution.phase(name)) if name in solution.names else ocp)
            for name, ocp in self.phases
        )
        return dataclasses.replace(self, phases=phases, warm=solution)

    # ---- reading ------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.phases)

    def index(self, name: str) -> int:
        if name not in self.names:
            raise DefinitionError(f"`phase`: no phase called {name!r}; phases: {list(self.names)}")
        return self.names.index(name)

    def phase(self, name: str) -> OCPDefinition:
        return self.phases[self.index(name)][1]

    @property
    def params(self) -> tuple[Param, ...]:
        """The static parameters of all phases, shared by name (bounds must agree)."""
        found: dict[str, Param] = {}
        for phase, ocp in self.phases:
            for p in ocp.params:
                known = found.get(p.name)
                if known is None:
                    found[p.name] = p
                elif (known.lower, known.upper) != (p.lower, p.upper):
                    raise DefinitionError(
                        f"`param`: {p.name!r} has bounds [{known.lower:g}, {known.upper:g}] in "
                        f"one phase and [{p.lower:g}, {p.upper:g}] in {phase!r}; a shared "
                        "parameter has one set of bounds"
                    )
        return tuple(found.values())

    def _sides(self, k: int) -> tuple[OCPDefinition, OCPDefinition]:
        return self.phases[k][1], self.phases[(k + 1) % len(self.phases)][1]

    def _event_point(self, k: int, values=None) -> EventPoint:
        before, after = self._sides(k)
        if values is None:
            values = {
                "x_before": ca.SX.sym("x_before", before.system.nx),
                "x_after": ca.SX.sym("x_after", after.system.nx),
                "T_before": ca.SX.sym("T_before"),
                "T_after": ca.SX.sym("T_after"),
            }
            params = ca.SX.sym("params", len(self.params))
            values.update({p.name: params[i] for i, p in enumerate(self.params)})
        return EventPoint(values)

    def _check_mapping(self, k: int, after_index: int, mapping, label: str) -> None:
        before = self.phases[k][1].system
        after = self.phases[after_index][1].system
        if mapping is None:
            if before.state_names != after.state_names:
                raise DefinitionError(
                    f"`{label}`: continuity needs the same states on both sides, got "
                    f"{before.state_names} and {after.state_names}; give a mapping"
                )
            return
        x = ca.SX.sym("x", before.nx)
        value = evaluate_mapping(label, mapping, x)
        if value.shape != (after.nx, 1):
            raise DefinitionError(
                f"`{label}`: the mapping must return the next phase's state ({after.nx}, 1), "
                f"got {value.shape}"
            )

    # ---- solving ------------------------------------------------------------------------
    def transcribe(self) -> PhasesTranscription:
        return PhasesTranscription(self)

    def __str__(self) -> str:
        lines = [f"Phases: {' -> '.join(self.names)}"]
        for k, mapping in enumerate(self.mappings):
            kind = "continuity" if mapping is None else "mapping"
            lines.append(f"  join {self.names[k]} -> {self.names[k + 1]}: {kind}")
        if self.periodicity is not None:
            kind = "identity" if self.periodicity[0] is None else "mapping"
            lines.append(f"  periodic {self.names[-1]} -> {self.names[0]}: {kind}")
        for e in self.events:
            lines.append(f"  event[{e.name}] after {self.names[e.after_phase]}")
        for name, ocp in self.phases:
            lines.append(f"  phase {name}:")
            lines.extend("    " + line for line in str(ocp).splitlines())
        return "\n".join(lines)

    def __repr__(self) -> str:
        return str(self)


def _event_value(label: str, expression, point: EventPoint) -> ca.SX:
    try:
        value = expression(point)
    except Exception as exc:  # a user's callable may fail in any way; say where
        raise DefinitionError(f"`{label}`: evaluating the expression failed: {exc}") from exc
    if isinstance(value, list | tuple):
        value = ca.vertcat(*value)
    if isinstance(value, int | float | np.ndarray | ca.DM):
        value = ca.SX(ca.DM(value))
    if not isinstance(value, ca.SX) or value.size2() != 1:
        raise DefinitionError(f"`{label}`: must return an SX column, got {value!r}")
    known = {s.element_hash() for v in point._fields.values() for s in ca.symvar(ca.SX(v))}
    free = _free_symbols(value, known)
    if free:
        raise DefinitionError(f"`{label}`: the expression uses free symbols {free}")
    _check_constants(label, value, "the expression")
    return value


# ---- the NLP ------------------------------------------------------------------------------
class PhasesTranscription:
    """The NLP of a :class:`Phases` problem: every phase transcribed on its share of the
    variables (:class:`Transcription`, the single-phase code), the shared static parameters,
    and the join, event and periodicity rows.

    Decision vector (scaled): [w_phase1; ...; w_phaseK; parameters]. Rows: each phase's
    rows, then per join the state rows ("join[a->b][x_name]"), the event constraints, and the
    periodicity rows. Names of a phase's variables and rows start with "<phase>: ".
    """

    def __init__(self, problem: PhasesDefinition) -> None:
        if not isinstance(problem, PhasesDefinition):
            raise DefinitionTypeError(
                f"`problem`: must be a planner.Phases, got {type(problem).__name__}"
            )
        start = time.perf_counter()
        self.problem = problem
        self.params = problem.params
        n_params = len(self.params)
        w_params = ca.MX.sym("w_params", n_params)
        p_params = ca.MX.sym("p_w_params", n_params)
        physical_params = w_params * p_params
        self._symbols: list[tuple[ca.MX, ca.MX, ca.MX]] = []

        def provider(ocp: OCPDefinition):
            indices = [[p.name for p in self.params].index(p.name) for p in ocp.params]

            def provide(transcription: Transcription) -> dict:
                k = len(self._symbols)
                w = ca.MX.sym(f"w_{k}", transcription.n_w)
                p_w = ca.MX.sym(f"p_w_{k}", transcription.n_w)
                p_T = ca.MX.sym(f"p_T_{k}", 0 if ocp.free_time else 1)
                self._symbols.append((w, p_w, p_T))
                return {"v": w * p_w, "T": p_T, "params": physical_params[indices]}

            return provide

        self.blocks = [Transcription(ocp, phase_symbols=provider(ocp)) for _, ocp in problem.phases]
        joins, join_scales, join_names = self._joins(physical_params)
        events, event_bounds, event_names = self._events(physical_params)
        g = ca.vertcat(*[b.rows for b in self.blocks], *joins, *events)
        objective = sum((b._objective for b in self.blocks), ca.MX(0))
        w = ca.vertcat(*[s[0] for s in self._symbols], w_params)
        p_g = ca.MX.sym("p_g", g.size1())
        p_f = ca.MX.sym("p_f")
        p = ca.vertcat(
            *[s[1] for s in self._symbols], p_params, *[s[2] for s in self._symbols], p_g, p_f
        )
        self.parametric_nlp = {"x": w, "p": p, "f": objective * p_f, "g": g * p_g}
        self._objective = objective
        self.term_values = ca.vertcat(*[b.term_values for b in self.blocks])
        self._assemble(join_scales, join_names, event_bounds, event_names)
        self.build_seconds = time.perf_counter() - start

    # ---- rows between the phases ----------------------------------------------------------
    def _join_pairs(self):
        """(k, k_next, mapping, label) for every join (the periodic one last)."""
        names = self.problem.names
        K = len(names)
        out = [
            (k, k + 1, mapping, f"join[{names[k]}->{names[k + 1]}]")
            for k, mapping in enumerate(self.problem.mappings)
        ]
        if self.problem.periodicity is not None:
            out.append((K - 1, 0, self.problem.periodicity[0], "periodic"))
        return out

    def _joins(self, params):
        rows, scales, names = [], [], []
        for k, k_next, mapping, label in self._join_pairs():
            before, after = self.blocks[k], self.blocks[k_next]
            image = before.xf if mapping is None else _map_mx(mapping, before.xf)
            rows.append(after.x0 - image)
            scales.append(after.state_scale)
            names.extend(f"{label}[{n}]" for n in after.system.state_names)
        return rows, scales, names

    def _events(self, params):
        rows, bounds, names = [], [], []
        pairs = {k: (k, k_next) for k, k_next, _, _ in self._join_pairs()}
        for event in self.problem.events:
            k, k_next = pairs[event.after_phase]
            before, after = self.blocks[k], self.blocks[k_next]
            symbols = self.problem._event_point(event.after_phase)._fields
            function = ca.Function(
                "event",
                [
                    symbols["x_before"],
                    symbols["x_after"],
                    symbols["T_before"],
                    symbols["T_after"],
                    ca.vertcat(*[symbols[p.name] for p in self.params])
                    if self.params
                    else ca.SX(0, 1),
                ],
                [_event_value(f"event[{event.name}]", event.expression, EventPoint(symbols))],
            )
            rows.append(function(before.xf, after.x0, before.duration, after.duration, params))
            scale = event.scale if event.scale is not None else _default(event)
            bounds.append((event.lower / scale, event.upper / scale, scale))
            size = event.lower.size
            names.extend(
                f"event[{event.name}]" + (f"[{i}]" if size > 1 else "") for i in range(size)
            )
        return rows, bounds, names

    def _assemble(self, join_scales, join_names, event_bounds, event_names) -> None:
        """Bounds, names and scales of the whole vector and all rows."""
        prefix = len(self.blocks) > 1
        names = self.problem.names

        def tag(k, items):
            return [f"{names[k]}: {item}" for item in items] if prefix else list(items)

        self.lbx = np.concatenate(
            [*[b.lbx for b in self.blocks], [p.lower / p.nominal for p in self.params]]
        )
        self.ubx = np.concatenate(
            [*[b.ubx for b in self.blocks], [p.upper / p.nominal for p in self.params]]
        )
        self.w_scale = np.concatenate(
            [*[b.w_scale for b in self.blocks], [p.nominal for p in self.params]]
        )
        self.w_names = tuple(
            [n for k, b in enumerate(self.blocks) for n in tag(k, b.w_names)]
            + [f"bound[{p.name}]" for p in self.params]
        )
        zeros = [np.zeros(scale.size) for scale in join_scales]
        self.lbg = np.concatenate(
            [*[b.lbg for b in self.blocks], *zeros, *[lo for lo, _, _ in event_bounds]]
        )
        self.ubg = np.concatenate(
            [*[b.ubg for b in self.blocks], *zeros, *[hi for _, hi, _ in event_bounds]]
        )
        self.g_scale = np.concatenate(
            [*[b.g_scale for b in self.blocks], *join_scales, *[s for _, _, s in event_bounds]]
        )
        self.g_names = tuple(
            [n for k, b in enumerate(self.blocks) for n in tag(k, b.g_names)]
            + join_names
            + event_names
        )
        offsets = np.cumsum([0] + [b.n_w for b in self.blocks])
        self._w_slices = [slice(offsets[k], offsets[k + 1]) for k in range(len(self.blocks))]
        row_offsets = np.cumsum([0] + [b.n_g for b in self.blocks])
        self._g_slices = [
            slice(row_offsets[k], row_offsets[k + 1]) for k in range(len(self.blocks))
        ]
        if self.lbg.size != self.parametric_nlp["g"].size1():
            raise RuntimeError(
                f"internal: {self.lbg.size} row bounds for {self.parametric_nlp['g'].size1()} rows"
            )

    # ---- the interface the solver reads ----------------------------------------------------
    @property
    def n_w(self) -> int:
        return self.lbx.size

    @property
    def n_g(self) -> int:
        return self.lbg.size

    @property
    def label(self) -> str:
        return " -> ".join(
            f"{name} {b.scheme.name} N={b.ocp.N}"
            for name, b in zip(self.problem.names, self.blocks, strict=True)
        )

    def parameter_values(self, objective_scale: float = 1.0) -> np.ndarray:
        """[each phase's variable scales; the parameters' scales; each fixed T; 1 / row
        scales; 1 / objective scale]."""
        fixed_T = [[] if b.ocp.free_time else [b.ocp.T] for b in self.blocks]
        return np.concatenate(
            [
                *[b.w_scale for b in self.blocks],
                [p.nominal for p in self.params],
                *fixed_T,
                1.0 / self.g_scale,
                [1.0 / float(objective_scale)],
            ]
        )

    @cached_property
    def signature(self) -> str:
        digest = hashlib.sha256()
        for names in (self.w_names, self.g_names):
            digest.update("\n".join(names).encode())
            digest.update(b"\0")
        sizes = f"{self.n_w} variables, {self.n_g} constraints"
        return f"phases {self.label}: {sizes}, {digest.hexdigest()}"

    @cached_property
    def nlp_function(self) -> ca.Function:
        nlp = self.parametric_nlp
        return ca.Function(
            "nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]], ["x", "p"], ["f", "g"]
        )

    @cached_property
    def structure_key(self) -> str:
        return f"MX-phases-{hashlib.sha256(self.nlp_function.serialize().encode()).hexdigest()}"

    @cached_property
    def terms_function(self) -> ca.Function:
        nlp = self.parametric_nlp
        return ca.Function("terms", [nlp["x"], nlp["p"]], [self.term_values], ["x", "p"], ["terms"])

    @property
    def given_objective_scale(self) -> float | None:
        scales = {b.ocp.objective_scale for b in self.blocks} - {None}
        return scales.pop() if len(scales) == 1 else None

    def guess_solution(self):
        """The PhasesSolution warm starts come from (``Phases.guess``), or None."""
        return self.problem.warm

    def initial_guess(self) -> np.ndarray:
        """Each phase's own guess, then the parameters' (a guessed-from solution's values,
        else their guesses)."""
        values = dict(getattr(self.problem.warm, "params", None) or {})
        params = [values.get(p.name, p.initial) / p.nominal for p in self.params]
        return np.concatenate([*[b.initial_guess() for b in self.blocks], params])

    def solution(self, w, cost, status, success, stats, lam_g, lam_x) -> PhasesSolution:
        return PhasesSolution(self, w, cost, status, success, stats, lam_g, lam_x)


def _map_mx(mapping, x: ca.MX) -> ca.MX:
    """A mapping (callable of SX or Function) applied to an MX state through an SX Function."""
    symbol = ca.SX.sym("x", x.size1())
    value = mapping(symbol)
    if isinstance(value, list | tuple):
        value = ca.vertcat(*value)
    return ca.Function("mapping", [symbol], [value])(x)


def _default(event: EventConstraint) -> np.ndarray:
    stacked = np.abs(np.vstack([event.lower, event.upper]))
    stacked[~np.isfinite(stacked)] = 0.0
    scale = stacked.max(axis=0)
    scale[scale == 0.0] = 1.0
    return scale


# ---- the solution -------------------------------------------------------------------------
class PhasesSolution:
    """A solved :class:`Phases` problem: each phase's :class:`Solution` (``phase(name)``),
    the whole on one time axis (``time``, ``states``, ``to_trajectory``), status and stats,
    the static parameters and each objective term.
    """

    def __init__(
        self, transcription: PhasesTranscription, w, cost, status, success, stats, lam_g, lam_x
    ):
        self.transcription = transcription
        self.problem = transcription.problem
        self.w = np.asarray(w, dtype=float).reshape(-1)
        self.cost = float(cost)
        self.status = status
        self.success = bool(success)
        self.stats = stats
        self.lam_g = None if lam_g is None else np.asarray(lam_g, dtype=float).reshape(-1)
        self.lam_x = None if lam_x is None else np.asarray(lam_x, dtype=float).reshape(-1)
        count = len(transcription.params)
        values = self.w[self.w.size - count :] * np.array([p.nominal for p in transcription.params])
        #: The static parameters' values, name -> value.
        self.params = {p.name: float(v) for p, v in zip(transcription.params, values, strict=True)}
        self.phases: list[Solution] = []
        for k, block in enumerate(transcription.blocks):
            w_k = self.w[transcription._w_slices[k]]
            solution = Solution(
                block,
                w_k,
                cost=float("nan"),
                status=status,
                success=success,
                stats=stats,
                lam_g=None if lam_g is None else self.lam_g[transcription._g_slices[k]],
                lam_x=None if lam_x is None else self.lam_x[transcription._w_slices[k]],
            )
            solution.params = {p.name: self.params[p.name] for p in block.ocp.params}
            self.phases.append(solution)

    @property
    def names(self) -> tuple[str, ...]:
        return self.problem.names

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
        values = np.asarray(
            self.transcription.terms_function(self.w, self.transcription.parameter_values())
        ).reshape(-1)
        names = [
            f"{phase}: {term.name}" for phase, ocp in self.problem.phases for term in ocp.objective
        ]
        return dict(zip(names, values.tolist(), strict=True))

    @property
    def time(self) -> np.ndarray:
        """Every phase's node times on the common axis, (sum N_k + K,) s: a phase's end and
        the next one's start are both kept (the state may jump there)."""
        return np.concatenate([s.time + t0 for s, t0 in zip(self.phases, self.starts, strict=True)])

    @property
    def states(self) -> np.ndarray:
        return np.vstack([s.states for s in self.phases])

    def integration_error(self, rtol: float = 1e-12, atol: float = 1e-12) -> IntegrationError:
        """Every phase's intervals re-integrated (``Solution.integration_error``), stacked in
        phase order, (sum N_k, nx); the phases must have the same states."""
        errors = [s.integration_error(rtol, atol) for s in self.phases]
        names = errors[0].state_names
        if any(e.state_names != names for e in errors):
            raise DefinitionError(
                "`integration_error`: the phases have different states; read each phase's "
                "(phase(name).integration_error())"
            )
        return IntegrationError(np.vstack([e.per_interval for e in errors]), names)

    def to_trajectory(self, rate_hz: float | None = None) -> Trajectory:
        """The phases one after another on one time axis, sampled like
        ``Solution.to_trajectory`` (each phase at its nodes or at ``rate_hz``). Every phase
        must have the same variables. At a join the end of one phase and the start of the
        next are one instant: the start of the next is kept (a jump, e.g. an impact, shows
        as the next phase's value)."""
        first = self.phases[0].system
        for name, s in zip(self.names, self.phases, strict=True):
            if (s.system.state_names, s.system.control_names) != (
                first.state_names,
                first.control_names,
            ):
                raise DefinitionError(
                    f"`to_trajectory`: phase {name!r} has other variables than "
                    f"{self.names[0]!r}; export the phases one by one (phase(name))"
                )
        parts = [s.to_trajectory(rate_hz) for s in self.phases]
        times, states, controls, extras = [], [], [], {}
        for k, (part, t0) in enumerate(zip(parts, self.starts, strict=True)):
            keep = slice(None) if k == len(parts) - 1 else slice(None, -1)
            times.append(part.time[keep] + t0)
            states.append(part.states[keep])
            controls.append(part.controls[keep])
            for name, (values, unit) in part.extras.items():
                extras.setdefault(name, ([], unit))[0].append(np.asarray(values)[keep])
        metadata = {
            **parts[0].metadata,
            "phases": [
                {"name": n, "start": float(t0), "T": float(s.T), "N": s.N}
                for n, s, t0 in zip(self.names, self.phases, self.starts, strict=True)
            ],
            "T": self.T,
            "cost": self.cost,
            "status": self.status,
        }
        return Trajectory(
            np.concatenate(times),
            np.vstack(states),
            np.vstack(controls),
            first.state_names,
            first.state_units,
            first.control_names,
            first.control_units,
            {name: (np.concatenate(v), unit) for name, (v, unit) in extras.items()},
            metadata,
        )

    def __repr__(self) -> str:
        return (
            f"PhasesSolution({' -> '.join(self.names)}, T={self.T:g} s, status={self.status}, "
            f"cost={self.cost:.6g}, iterations={self.iterations})"
        )


__all__ = [
    "EventConstraint",
    "EventPoint",
    "PhasesDefinition",
    "PhasesSolution",
    "PhasesTranscription",
]
