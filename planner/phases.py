"""Multi-phase optimal control: a sequence of phases joined by events.

A walking step with a double-support phase, a heel-toe roll, running with a flight phase, or a
gait of two different steps is a sequence of phases, each an ordinary single-phase
:class:`planner.OCP` (its own dynamics, duration fixed or free, mesh, transcription, bounds,
constraints and objective terms), joined by events:

* a join from phase k to phase k+1: x_{k+1}(0) = mapping(x_k(T_k)) (an impact map, a
  relabelling of legs, a contact switch), or plain continuity x_{k+1}(0) = x_k(T_k) when no
  mapping is given (the two phases must then have the same states: the node at the join is
  one NLP variable). Controls may jump at a join; ``controls="continuous"`` makes a
  continuity join behave like an interior node of one phase (on schemes with controls at the
  nodes, trapezoid and Hermite-Simpson, the controls there are one set too), so that a
  problem cut into phases is exactly the uncut one, with the same NLP;
* event constraints at a join, lower <= g(e) <= upper, on an :class:`EventPoint` ``e`` with
  both sides of the event (``e.x_before``, ``e.x_after``, ``e.T_before``, ``e.T_after`` and
  the static parameters): an impulse inside the friction cone, a lift-off velocity;
* periodicity, the join from the last phase back to the first: x_1(0) = mapping(x_K(T_K)).

The objective is the sum of the phases' objective terms; static parameters
(``Phases.param`` adds one to every phase, or a phase's own ``OCP.param``) are shared by name
across phases. Time restarts at 0 in each phase (a Point's ``t``); the Solution puts the
phases on one time axis, phase k starting at T_1 + ... + T_{k-1}.

A single-phase OCP is a problem of one phase: :class:`planner.transcription.Transcription`
transcribes both (each phase a :class:`planner.phase_transcription.PhaseTranscription` on its
share of the variables, the joins and events rows between them), and a one-phase solve
returns the phase's :class:`planner.Solution` directly.

>>> problem = (Phases.sequence(("single", single_support), ("double", double_support))
...            .periodic(leg_swap)
...            .constrain_event("single", "impulse cone", cone, lower=0))
>>> solution = problem.solve()        # PhasesSolution: .phase("single"), .to_trajectory()
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.ocp import (
    OCPDefinition,
    Param,
    _as_bounds,
    _check_constants,
    _free_symbols,
    _positive_array,
    evaluate_mapping,
)
from planner.phases_solution import PhasesSolution

if TYPE_CHECKING:
    from typing import Self

#: How controls pass a continuity join: they may jump (each phase has its own), or continue
#: as across an interior node of one phase.
JOIN_CONTROLS = ("jump", "continuous")


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
    (``mappings[k]``: phase k -> k+1, None for continuity; ``controls[k]``: "jump" or
    "continuous", see the module docstring), event constraints, periodicity.

    Build it with :meth:`sequence` and the builders (each returns a new value).
    :class:`planner.Phases` is this class with ``solve()`` (:mod:`planner.problem`).
    """

    phases: tuple[tuple[str, OCPDefinition], ...]
    mappings: tuple[Any, ...] = ()
    events: tuple[EventConstraint, ...] = ()
    periodicity: tuple[Any, ...] | None = None
    warm: Any = None  # a PhasesSolution to warm-start IPOPT's multipliers from
    controls: tuple[str, ...] = ()
    #: True when this is a single OCP seen as one phase (its periodicity is the OCP's own).
    single: bool = False

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
            if ocp.periodicity is not None and not self.single:
                raise DefinitionError(
                    f"`phases[{i}]` ({name!r}): the phase is periodic on its own; periodicity "
                    "closes the whole sequence: call periodic(...) on the Phases instead"
                )
            names.append(name)
        mappings = tuple(self.mappings) + (None,) * (len(self.phases) - 1 - len(self.mappings))
        if len(mappings) != len(self.phases) - 1:
            raise DefinitionError(
                f"`mappings`: {len(self.phases)} phases have {len(self.phases) - 1} joins, got "
                f"{len(self.mappings)} mappings"
            )
        object.__setattr__(self, "mappings", mappings)
        controls = tuple(self.controls) + ("jump",) * (len(mappings) - len(self.controls))
        if len(controls) != len(mappings):
            raise DefinitionError(
                f"`controls`: {len(self.phases)} phases have {len(mappings)} joins, got "
                f"{len(self.controls)} settings"
            )
        object.__setattr__(self, "controls", controls)
        for k, how in enumerate(controls):
            self._check_controls(k, how, names)
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

    def then(self, name: str, ocp: OCPDefinition, mapping=None, controls: str = "jump") -> Self:
        """Append a phase, joined to the last one by ``mapping`` (None: continuity; see
        :meth:`join` for ``controls``)."""
        return dataclasses.replace(
            self,
            phases=(*self.phases, (name, ocp)),
            mappings=(*self.mappings, mapping),
            controls=(*self.controls, controls),
        )

    def join(self, before: str, mapping=None, controls: str = "jump") -> Self:
        """The join after phase ``before``: x_next(0) = mapping(x_before(T)) (a callable of
        the SX state or a casadi.Function (nx_before,) -> (nx_after,)); None: continuity,
        the node at the join one variable of both phases. ``controls``: "jump" (default; each
        phase has its own controls at the join) or "continuous" (a continuity join only: the
        controls continue as across an interior node of one phase; with controls at the nodes
        (trapezoid, Hermite-Simpson on both sides) the dynamics point at the join is one point
        of both phases, holding the rows of the phase before only)."""
        k = self.index(before)
        if k == len(self.phases) - 1:
            raise DefinitionError(
                f"`before`: {before!r} is the last phase; its join to the first is periodic(...)"
            )
        mappings = list(self.mappings)
        mappings[k] = mapping
        controls_list = list(self.controls)
        controls_list[k] = controls
        return dataclasses.replace(self, mappings=tuple(mappings), controls=tuple(controls_list))

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
        value = event_value(label, expression, self._event_point(k))
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

    def _check_controls(self, k: int, how, names: list[str]) -> None:
        label = f"`controls` of the join after {names[k]!r}"
        if how not in JOIN_CONTROLS:
            raise DefinitionError(f"{label}: unknown {how!r}; use one of {JOIN_CONTROLS}")
        if how == "jump":
            return
        if self.mappings[k] is not None:
            raise DefinitionError(
                f"{label}: continuous controls need a continuity join (no mapping); a mapping "
                "is an event, across which the controls may jump"
            )
        before, after = self._sides(k)
        a, b = before.system, after.system
        if (a.control_names, a.aux_names) != (b.control_names, b.aux_names):
            raise DefinitionError(
                f"{label}: continuous controls need the same controls and auxiliary variables "
                f"on both sides, got {a.control_names + a.aux_names} and "
                f"{b.control_names + b.aux_names}"
            )

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


def event_value(label: str, expression, point: EventPoint) -> ca.SX:
    """An event constraint's rows at ``point``, an SX column of its symbols, checked."""
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


__all__ = ["EventConstraint", "EventPoint", "PhasesDefinition", "event_value"]
