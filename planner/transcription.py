"""The NLP of an optimal control problem of one or more phases, built on construction.

A problem is a sequence of phases (:class:`planner.phases.Phases`) joined by events; a
single-phase :class:`planner.OCP` is the sequence of one phase, transcribed by this same code
(its periodicity is the join from its only phase back to itself). Each phase is a
:class:`planner.phase_transcription.PhaseTranscription` (its mesh, defects, path, boundary
and keypoint rows, objective terms) built on its share of the variables; this module holds
what the phases share:

* the decision vector, scaled (v / scale): [phase 1's own variables; ...; phase K's own
  variables; the static parameters]. Across a continuity join the next phase's first state
  node *is* the last node of the phase before (one variable, no rows), and with continuous
  controls the dynamics point there too (the rows the phase before holds at it are left
  out): a problem cut into phases has the NLP of the uncut problem (``Phases.join``);
* the rows: each phase's rows, then per join with a mapping the rows x_next(0) -
  mapping(x_prev(T_prev)) ("join[a->b][x]", "periodic[x]"), then the event constraints;
* the parameters p of the NLP: everything that is a number of the problem rather than its
  structure, [each phase's variable scales; the static parameters' scales; each fixed
  duration; 1 / row scales; 1 / objective scale]. So two problems that differ only in
  bounds, scales, fixed durations or guesses have the same NLP function
  (:attr:`Transcription.structure_key`) and :func:`planner.solver.solve` reuses one IPOPT
  solver for both;
* names of variables and rows ("bound[psi_torso] node 3", "defect[x] interval 12"), prefixed
  with "<phase>: " when there are several phases.

MX with the phases' SX point Functions mapped over their meshes (the default) builds ~5-10x
faster than a fully expanded SX NLP and solves ~1.5x slower (planner_bench.py): the better
total for a one-off solve; ``expand=True`` builds the whole NLP in SX.
"""

from __future__ import annotations

import copy as _copy
import dataclasses
import hashlib
import itertools
import logging
import threading
import time
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.ocp import OCPDefinition, Point, evaluate_expression
from planner.phase_transcription import PhaseTranscription, SharedStart
from planner.phases import EventPoint, PhasesDefinition, event_value
from planner.phases_solution import PhasesSolution
from planner.solution import Solution

logger = logging.getLogger(__name__)


#: The fields of an OCP that do not enter its NLP's symbols, names or scales, only its
#: bounds and starting point (:meth:`Transcription.for_problem`).
_NUMBERS_ONLY = ("margins", "guesses", "T_guess")


def _same_fields(old, new, skipped) -> bool:
    """Whether two definitions (frozen dataclasses) of one type hold the same values in
    every field but ``skipped``: the same objects, or equal ones."""
    if type(old) is not type(new):
        return False
    for field in dataclasses.fields(old):
        if field.name in skipped:
            continue
        a, b = getattr(old, field.name), getattr(new, field.name)
        if a is b:
            continue
        try:
            if not bool(a == b):
                return False
        except Exception:  # arrays or symbols inside: not provably equal
            return False
    return True


def _same_but_margins(old: OCPDefinition, new: OCPDefinition) -> bool:
    return _same_fields(old, new, _NUMBERS_ONLY)


def _single_phase(name: str, what: str) -> property:
    """A property of :class:`Transcription` that reads ``name`` of its only phase's block."""

    def read(self):
        return getattr(self._only(name), name)

    return property(read, doc=f"{what} of the single phase (a Phases NLP raises)")


class Transcription:
    """The NLP of a :class:`planner.OCP` (one phase) or a :class:`planner.Phases` problem.

    Attributes the solver reads: ``n_w``, ``n_g``, ``lbx``/``ubx`` (scaled variable bounds),
    ``lbg``/``ubg`` (scaled row bounds), ``w_scale``, ``g_scale``, ``w_names``, ``g_names``,
    ``parametric_nlp`` ({"x", "p", "f", "g"}), :meth:`parameter_values`,
    :meth:`initial_guess`, :attr:`signature`, :attr:`structure_key`, :meth:`solution`.
    ``phases`` holds each phase's :class:`PhaseTranscription`; for a single OCP the phase's
    own views (``ocp``, ``mesh``, ``scheme``, ``system``, the scales, ``point_function``,
    :meth:`unpack`, :meth:`pack`) are offered here too.
    """

    def __init__(self, problem: OCPDefinition | PhasesDefinition, expand: bool | None = None):
        start = time.perf_counter()
        if isinstance(problem, OCPDefinition):
            #: The single-phase OCP, or None for a Phases problem.
            self.single = problem
            self.problem = PhasesDefinition(
                (("phase", problem),), periodicity=problem.periodicity, single=True
            )
        elif isinstance(problem, PhasesDefinition):
            self.single = None
            self.problem = problem
        else:
            raise DefinitionTypeError(
                "`problem`: must be a planner.OCP or a planner.Phases, got "
                f"{type(problem).__name__}"
            )
        self.expand = False if expand is None else bool(expand)
        sym = ca.SX if self.expand else ca.MX
        self.params = self.problem.params
        n_params = len(self.params)
        w_params = sym.sym("w_params", n_params)
        p_params = sym.sym("p_w_params", n_params)
        physical_params = w_params * p_params
        names = [p.name for p in self.params]
        own_w, own_p, fixed_T = [], [], []
        #: Per phase: the NLP position of each entry of the phase's layout, and which
        #: entries the phase owns (the others it shares with the phase before).
        self._index: list[np.ndarray] = []
        self._own: list[np.ndarray] = []
        offset = 0
        physical: list[Any] = []

        def provider(k: int, ocp: OCPDefinition):
            indices = [names.index(p.name) for p in ocp.params]

            def provide(block: PhaseTranscription) -> dict:
                nonlocal offset
                shared, index, own, source = self._sharing(k, block)
                count = int(own.sum())
                w = sym.sym(f"w_{k}", count)
                p_w = sym.sym(f"p_w_{k}", count)
                p_T = sym.sym(f"p_T_{k}", 0 if ocp.free_time else 1)
                own_w.append(w)
                own_p.append(p_w)
                fixed_T.append(p_T)
                index[own] = offset + np.arange(count)
                offset += count
                self._index.append(index)
                self._own.append(own)
                v = _assemble(w * p_w, own, source, physical[k - 1] if k else None)
                physical.append(v)
                return {
                    "v": v,
                    "T": p_T,
                    "params": physical_params[indices],
                    "sym": sym,
                    "shared": shared,
                }

            return provide

        #: Each phase's transcription, in order.
        self.phases: list[PhaseTranscription] = []
        for k, (_, ocp) in enumerate(self.problem.phases):
            self.phases.append(PhaseTranscription(ocp, provider(k, ocp)))
        self._params_offset = offset
        joins, join_scales, join_names = self._joins()
        events, event_bounds, event_names = self._events(physical_params)
        g = ca.vertcat(*[b.rows for b in self.phases], *joins, *events)
        objective = sum((b._objective for b in self.phases), sym(0))
        w = ca.vertcat(*own_w, w_params)
        p_g = sym.sym("p_g", g.size1())  # 1 / nominal scale of each constraint row
        p_f = sym.sym("p_f")  # 1 / nominal scale of the objective
        p = ca.vertcat(*own_p, p_params, *fixed_T, p_g, p_f)
        #: The NLP IPOPT solves: scaled w, parameters p, scaled objective and rows.
        self.parametric_nlp = {"x": w, "p": p, "f": objective * p_f, "g": g * p_g}
        self._objective = objective
        #: Each objective term's value (n_terms,), physical units, phase by phase.
        self.term_values = ca.vertcat(*[b.term_values for b in self.phases])
        #: What the bounds of the rows between the phases are made of (kept for
        #: :meth:`for_problem`, which makes them again).
        self._between = (join_scales, join_names, event_bounds, event_names)
        self._assemble_bounds(*self._between)
        self.build_seconds = time.perf_counter() - start
        logger.debug(
            "transcribed %s: %d variables, %d constraints in %.3f s",
            self.label,
            self.n_w,
            self.n_g,
            self.build_seconds,
        )

    def for_problem(self, problem: OCPDefinition | PhasesDefinition) -> Transcription | None:
        """This transcription for ``problem`` when ``problem`` is this one's problem but for
        its phases' margins (:meth:`planner.OCP.back_off`) and guesses (``guess``, a warm
        start), which change no symbol, name or scale of the NLP: a copy that shares the NLP
        and reads the bounds and guesses again (a few milliseconds where a transcription
        takes tens: the rounds of :func:`planner.hold_at_samples`). None when ``problem``
        differs in anything else (then it needs its own transcription)."""
        start = time.perf_counter()
        if isinstance(problem, OCPDefinition):
            if self.single is None or not _same_but_margins(self.single, problem):
                return None
            wrapped = PhasesDefinition(
                (("phase", problem),), periodicity=problem.periodicity, single=True
            )
        elif isinstance(problem, PhasesDefinition) and self.single is None:
            if not _same_fields(self.problem, problem, ("phases", "warm")):
                return None
            if [name for name, _ in problem.phases] != list(self.problem.names) or not all(
                _same_but_margins(old, new)
                for (_, old), (_, new) in zip(self.problem.phases, problem.phases, strict=True)
            ):
                return None
            wrapped = problem
        else:
            return None
        copy = _copy.copy(self)
        copy.single = problem if self.single is not None else None
        copy.problem = wrapped
        copy.phases = [
            block.with_definition(ocp)
            for block, (_, ocp) in zip(self.phases, wrapped.phases, strict=True)
        ]
        copy._assemble_bounds(*self._between)
        copy.build_seconds = time.perf_counter() - start
        return copy

    # ---- sharing across continuity joins --------------------------------------------------
    def _sharing(self, k: int, block: PhaseTranscription):
        """What phase k (layout known, rows not built yet) shares with the phase before:
        (SharedStart or None, NLP index (n_w_k,) with the shared entries filled, own mask
        (n_w_k,), the shared entries' positions in the phase before's layout (n_w_k,))."""
        index = np.full(block.n_w, -1)
        own = np.ones(block.n_w, dtype=bool)
        source = np.full(block.n_w, -1)
        if k == 0 or self.problem.mappings[k - 1] is not None:
            return None, index, own, source
        before = self.phases[k - 1]
        s = block.system

        def share(here: int, there: int, count: int) -> None:
            own[here : here + count] = False
            source[here : here + count] = np.arange(there, there + count)
            index[here : here + count] = self._index[k - 1][there : there + count]

        # The first state node here, the last there (state columns are contiguous).
        share(block.slice_of("X").start, before.slice_of("X").stop - s.nx, s.nx)
        shared = {"controls": False, "residual": False}
        if self.problem.controls[k - 1] == "continuous" and (
            before.ends_at_a_point and block.starts_at_a_point
        ):
            # The dynamics point at the join: the controls and auxiliary variables there
            # are one set (the first column of U and Z here, the last there).
            for key, count in (("U", s.nu), ("Z", s.nz)):
                share(block.slice_of(key).start, before.slice_of(key).stop - count, count)
            shared.update(
                controls=True,
                residual=_same_dynamics(before.ocp, block.ocp),
                point_paths=_common(
                    before, block, before._path_constraints(), block._path_constraints()
                ),
            )
        # The phase before holds its state-only path rows at its last node, at a dynamics
        # point or a free state point: the same rows at a free state point here are left out.
        common_state = frozenset()
        if block._free_starts:
            common_state = _common(before, block, before.state_paths, block.state_paths)
        return SharedStart(state_paths=common_state, **shared), index, own, source

    # ---- rows between the phases ----------------------------------------------------------
    def _join_pairs(self):
        """(k, k_next, mapping, label) for every join that is a row block: the joins with a
        mapping and the periodic one (continuity joins share their variables)."""
        names = self.problem.names
        out = [
            (k, k + 1, mapping, f"join[{names[k]}->{names[k + 1]}]")
            for k, mapping in enumerate(self.problem.mappings)
            if mapping is not None
        ]
        if self.problem.periodicity is not None:
            out.append((len(names) - 1, 0, self.problem.periodicity[0], "periodic"))
        return out

    def _joins(self):
        rows, scales, names = [], [], []
        for k, k_next, mapping, label in self._join_pairs():
            before, after = self.phases[k], self.phases[k_next]
            image = before.xf if mapping is None else _apply(mapping, before.xf)
            rows.append(after.x0 - image)
            scales.append(after.state_scale)
            names.extend(f"{label}[{n}]" for n in after.system.state_names)
        return rows, scales, names

    def _events(self, params):
        rows, bounds, names = [], [], []
        count = len(self.phases)
        for event in self.problem.events:
            k = event.after_phase
            before, after = self.phases[k], self.phases[(k + 1) % count]
            symbols = self.problem._event_point(k)._fields
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
                [event_value(f"event[{event.name}]", event.expression, EventPoint(symbols))],
            )
            rows.append(function(before.xf, after.x0, before.duration, after.duration, params))
            scale = event.scale if event.scale is not None else _default_scale(event)
            bounds.append((event.lower / scale, event.upper / scale, scale))
            size = event.lower.size
            names.extend(
                f"event[{event.name}]" + (f"[{i}]" if size > 1 else "") for i in range(size)
            )
        return rows, bounds, names

    def _assemble_bounds(self, join_scales, join_names, event_bounds, event_names) -> None:
        """Bounds, names and scales of the whole vector and all rows. A shared variable has
        the scale and name of the phase that owns it and the bounds of both phases."""
        prefix = len(self.phases) > 1
        names = self.problem.names

        def tag(k, items):
            return [f"{names[k]}: {item}" for item in items] if prefix else list(items)

        n_w = self._params_offset + len(self.params)
        lbx, ubx = np.full(n_w, -np.inf), np.full(n_w, np.inf)
        w_scale = np.ones(n_w)
        w_names = [""] * n_w
        for k, block in enumerate(self.phases):
            own, index = self._own[k], self._index[k]
            w_scale[index[own]] = block.w_scale[own]
            labels = tag(k, block.w_names)
            for i in np.flatnonzero(own):
                w_names[index[i]] = labels[i]
            # Physical bounds of every entry, owned or shared, in the owner's scale.
            ratio = block.w_scale / w_scale[index]
            lbx[index] = np.maximum(lbx[index], block.lbx * ratio)
            ubx[index] = np.minimum(ubx[index], block.ubx * ratio)
        for i, param in enumerate(self.params):
            at = self._params_offset + i
            lbx[at], ubx[at] = param.lower / param.nominal, param.upper / param.nominal
            w_scale[at] = param.nominal
            w_names[at] = f"bound[{param.name}]"
        self.lbx, self.ubx, self.w_scale, self.w_names = lbx, ubx, w_scale, tuple(w_names)
        zeros = [np.zeros(scale.size) for scale in join_scales]
        self.lbg = np.concatenate(
            [*[b.lbg for b in self.phases], *zeros, *[lo for lo, _, _ in event_bounds]]
        )
        self.ubg = np.concatenate(
            [*[b.ubg for b in self.phases], *zeros, *[hi for _, hi, _ in event_bounds]]
        )
        self.g_scale = np.concatenate(
            [*[b.g_scale for b in self.phases], *join_scales, *[s for _, _, s in event_bounds]]
        )
        self.g_names = tuple(
            [n for k, b in enumerate(self.phases) for n in tag(k, b.g_names)]
            + join_names
            + event_names
        )
        row_offsets = np.cumsum([0] + [b.n_g for b in self.phases])
        self._g_slices = [
            slice(row_offsets[k], row_offsets[k + 1]) for k in range(len(self.phases))
        ]
        if self.lbg.size != self.parametric_nlp["g"].size1():
            raise RuntimeError(
                f"internal: {self.lbg.size} row bounds for {self.parametric_nlp['g'].size1()} rows"
            )

    # ---- sizes, names, signatures -----------------------------------------------------------
    @property
    def n_w(self) -> int:
        return self.lbx.size

    @property
    def n_g(self) -> int:
        return self.lbg.size

    @property
    def label(self) -> str:
        """The mesh in words, for logs."""
        if self.single is not None:
            return self.phases[0].label
        return " -> ".join(
            f"{name} {b.label}" for name, b in zip(self.problem.names, self.phases, strict=True)
        )

    @cached_property
    def signature(self) -> str:
        """The NLP's structure as a string: two transcriptions with equal signatures have the
        same decision variables and constraint rows, in the same order.

        "<mesh> <formulation>: <n_w> variables, <n_g> constraints, <digest>" (a Phases
        problem: "phases <meshes>: ..."), the digest (SHA-256) over every variable and row
        name (``w_names``, ``g_names``: what and where). Bounds, scales, expressions and T
        are not part of it: a problem that differs from another only in those (a parameter
        continuation, a changed bound or cost weight) has the same signature, so its
        multipliers can warm-start the other's solve (:func:`planner.solver.solve`).
        """
        digest = hashlib.sha256()
        for names in (self.w_names, self.g_names):
            digest.update("\n".join(names).encode())
            digest.update(b"\0")
        sizes = f"{self.n_w} variables, {self.n_g} constraints, {digest.hexdigest()}"
        if self.single is not None:
            return f"{self.label} {self.phases[0].system.formulation}: {sizes}"
        return f"phases {self.label}: {sizes}"

    def parameter_values(self, objective_scale: float = 1.0) -> np.ndarray:
        """The NLP parameters p of :attr:`parametric_nlp`: [each phase's own variable scales;
        the static parameters' scales; each fixed duration, s; 1 / row scales (n_g,);
        1 / ``objective_scale``]."""
        own_scales = [b.w_scale[own] for b, own in zip(self.phases, self._own, strict=True)]
        fixed_T = [[] if b.definition.free_time else [b.definition.T] for b in self.phases]
        return np.concatenate(
            [
                *own_scales,
                [p.nominal for p in self.params],
                *fixed_T,
                1.0 / self.g_scale,
                [1.0 / float(objective_scale)],
            ]
        )

    @cached_property
    def nlp_function(self) -> ca.Function:
        """(w (n_w,), p) -> (f, g): the scaled NLP of :attr:`parametric_nlp` as a Function."""
        nlp = self.parametric_nlp
        return ca.Function(
            "nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]], ["x", "p"], ["f", "g"]
        )

    @cached_property
    def nlp(self) -> dict[str, Any]:
        """The NLP in the decision vector alone: {"x": w, "f": the objective in its physical
        units (unscaled), "g": the scaled constraint rows}, the parameters replaced by
        :meth:`parameter_values`."""
        nlp = self.parametric_nlp
        physical = ca.Function("physical", [nlp["x"], nlp["p"]], [self._objective, nlp["g"]])
        f, g = physical(nlp["x"], ca.DM(self.parameter_values()))
        return {"x": nlp["x"], "f": f, "g": g}

    @cached_property
    def structure_key(self) -> str:
        """SHA-256 of the serialised NLP function (w, p) -> (f, g).

        Two transcriptions with equal keys compute the same f and g from the same (w, p):
        same meshes, transcriptions, dynamics, expressions and constants. Bounds, nominal
        scales, fixed durations and the guess are not part of it (they are arguments of the
        solver), so an IPOPT solver built for one serves the other
        (:mod:`planner.solver_cache`). Any constant inside an expression (a cost weight, a
        target angle written as a number) is part of it.
        """
        text = self.nlp_function.serialize()
        return f"{'SX' if self.expand else 'MX'}-{hashlib.sha256(text.encode()).hexdigest()}"

    @cached_property
    def terms_function(self) -> ca.Function:
        """(w, p) -> each objective term's value (n_terms,), physical units."""
        nlp = self.parametric_nlp
        return ca.Function("terms", [nlp["x"], nlp["p"]], [self.term_values], ["x", "p"], ["terms"])

    def term_names(self) -> list[str]:
        """The objective terms' names, in :attr:`term_values` order ("<phase>: <term>" when
        there are several phases)."""
        prefix = len(self.phases) > 1
        return [
            f"{name}: {term.name}" if prefix else term.name
            for name, ocp in self.problem.phases
            for term in ocp.objective
        ]

    def cost_terms(self, w: np.ndarray) -> dict[str, float]:
        """Each objective term's value at the scaled decision vector ``w``, by name."""
        values = np.asarray(self.terms_function(w, self.parameter_values())).reshape(-1)
        return dict(zip(self.term_names(), values.tolist(), strict=True))

    # ---- what the solver reads besides the NLP ------------------------------------------
    @property
    def given_objective_scale(self) -> float | None:
        """``scale(objective=...)`` of the phases, when they agree, or None."""
        scales = {b.definition.objective_scale for b in self.phases} - {None}
        return scales.pop() if len(scales) == 1 else None

    def guess_solution(self):
        """The Solution the last guess comes from (warm starts read its multipliers and
        objective scale), or None: a single OCP's last guess layer, or ``Phases.guess``."""
        if self.single is None:
            return self.problem.warm
        guesses = self.single.guesses
        if guesses and guesses[-1].kind == "solution":
            return guesses[-1].source
        return None

    def initial_guess(self) -> np.ndarray:
        """The scaled decision vector of the guesses: each phase's (a shared variable takes
        the value of the phase that owns it), then the static parameters (the values of a
        Solution guessed from, else their own guesses)."""
        w = np.zeros(self.n_w)
        for k, block in enumerate(self.phases):
            own, index = self._own[k], self._index[k]
            w[index[own]] = block.initial_guess()[own]
        values: dict[str, float] = {}
        for _, ocp in self.problem.phases:
            for layer in ocp.guesses:
                params = getattr(layer.source, "params", None)  # a Trajectory carries none
                if isinstance(params, dict):
                    values.update(params)
        values.update(getattr(self.problem.warm, "params", None) or {})
        for i, param in enumerate(self.params):
            w[self._params_offset + i] = values.get(param.name, param.initial) / param.nominal
        return w

    def solution(self, w, cost, status, success, stats, lam_g, lam_x):
        """The result of a solve of this NLP: the :class:`planner.solution.Solution` of a
        single OCP, or the :class:`planner.phases_solution.PhasesSolution` of phases."""
        if self.single is not None:
            return Solution(self, w, cost, status, success, stats, lam_g, lam_x)
        return PhasesSolution(self, w, cost, status, success, stats, lam_g, lam_x)

    # ---- values of one phase ----------------------------------------------------------
    def phase_vector(self, w: np.ndarray, k: int = 0) -> np.ndarray:
        """Phase k's scaled decision vector in its own layout (n_w_k,) from the NLP's w."""
        w = np.asarray(w, dtype=float).reshape(-1)
        index = self._index[k]
        return w[index] * self.w_scale[index] / self.phases[k].w_scale

    def param_values(self, w: np.ndarray) -> dict[str, float]:
        """The static parameters' physical values at the NLP's w, name -> value."""
        w = np.asarray(w, dtype=float).reshape(-1)
        at = self._params_offset
        return {p.name: float(w[at + i] * p.nominal) for i, p in enumerate(self.params)}

    def unpack(self, w: np.ndarray, phase: int = 0) -> dict[str, Any]:
        """Physical values of a phase (default the first: a single OCP's) at the NLP's scaled
        w: X (nX, nx), U (nC, nu), Z (nC, nz), T (s) and P (the static parameters, name ->
        value)."""
        values = self.phases[phase].unpack(self.phase_vector(w, phase))
        values["P"] = self.param_values(w)
        return values

    def pack(self, X: np.ndarray, U: np.ndarray, Z: np.ndarray, T: float, P=None) -> np.ndarray:
        """The scaled decision vector of a single OCP from physical X (nX, nx), U (nC, nu),
        Z (nC, nz), T and the static parameters P (name -> value; default their guesses)."""
        block = self._only("pack")
        w = np.zeros(self.n_w)
        w[self._index[0]] = block.pack(X, U, Z, T)
        P = P or {}
        for i, param in enumerate(self.params):
            w[self._params_offset + i] = P.get(param.name, param.initial) / param.nominal
        return w

    # ---- a single OCP's phase, offered here -----------------------------------------------
    def _only(self, what: str) -> PhaseTranscription:
        if len(self.phases) != 1:
            raise DefinitionError(
                f"`{what}`: this NLP has {len(self.phases)} phases; read phases[k].{what}"
            )
        return self.phases[0]

    # What one phase's block holds, read through the NLP of a single OCP (a Phases NLP
    # refuses: read phases[k].<name>).
    ocp = _single_phase("ocp", "the OCP definition (OCPDefinition)")
    system = _single_phase("system", "the System of its dynamics")
    scheme = _single_phase("scheme", "the transcription's Scheme")
    mesh = _single_phase("mesh", "the Mesh (interval lengths, node and point times)")
    state_scale = _single_phase("state_scale", "(nx,) nominal scales of the states")
    control_scale = _single_phase("control_scale", "(nu,) nominal scales of the controls")
    aux_scale = _single_phase("aux_scale", "(nz,) nominal scales of the auxiliaries")
    point_function = _single_phase("point_function", "the Function of one dynamics point")
    boundary_function = _single_phase("boundary_function", "the Function of the boundary rows")


#: The transcriptions :func:`transcribe` made or was shown last, newest last.
_RECENT: list[Transcription] = []
#: How many it keeps (a hold's rounds need the one before; a study's threads a few).
RECENT_TRANSCRIPTIONS = 8
_RECENT_LOCK = threading.Lock()


def transcribe(problem: OCPDefinition | PhasesDefinition) -> Transcription:
    """``Transcription(problem)``, or the copy of a recent transcription whose problem
    differs from ``problem`` only in margins and guesses (:meth:`Transcription.for_problem`:
    the same NLP, the bounds and guesses read again): what :func:`planner.solve` transcribes
    with, so that re-solves with backed-off limits or another guess skip the symbolic work."""
    with _RECENT_LOCK:
        recent = list(reversed(_RECENT))
    for old in recent:
        if old.expand:  # an SX transcription given to solve(): not what is asked here
            continue
        made = old.for_problem(problem)
        if made is not None:
            remember(made, replacing=old)
            return made
    made = Transcription(problem)
    remember(made)
    return made


def remember(transcription: Transcription, replacing: Transcription | None = None) -> None:
    """Keep ``transcription`` among the recent ones :func:`transcribe` reuses (in place of
    ``replacing``, a transcription it was copied from)."""
    with _RECENT_LOCK:
        for kept in (replacing, transcription):
            if any(t is kept for t in _RECENT):
                _RECENT[:] = [t for t in _RECENT if t is not kept]
        _RECENT.append(transcription)
        del _RECENT[:-RECENT_TRANSCRIPTIONS]


def _assemble(own_values, own: np.ndarray, source: np.ndarray, before):
    """A phase's physical values in its layout: its own entries (``own_values``, in order)
    where ``own`` is True, elsewhere the entries ``source`` of the phase before's physical
    values ``before`` (what the two phases share across a continuity join)."""
    if own.all():
        return own_values
    pieces, taken = [], 0
    for start, stop, owned in _runs(own):
        if owned:
            pieces.append(own_values[taken : taken + stop - start])
            taken += stop - start
        else:
            pieces.append(before[source[start:stop].tolist()])
    return ca.vertcat(*pieces)


def _runs(mask: np.ndarray):
    """(start, stop, value) of the runs of equal values in a boolean mask."""
    edges = np.flatnonzero(np.diff(mask.astype(int))) + 1
    bounds = [0, *edges.tolist(), mask.size]
    return [(a, b, bool(mask[a])) for a, b in itertools.pairwise(bounds) if b > a]


def _common(
    before: PhaseTranscription, block: PhaseTranscription, constraints, others
) -> frozenset[str]:
    """Names of the path constraints of two phases (``constraints`` of the phase before,
    ``others`` of the next) that give the same rows at a shared node whatever the phases'
    clocks: the same name, bounds and scale, an expression that reads neither t nor T, and
    the same expression (the same callable, or expressions equal on one symbolic point).
    Only constraints that agree in name, bounds and scale are evaluated."""
    s = before.system
    clock = ca.SX.sym("t"), ca.SX.sym("T")
    point = Point(
        s,
        ca.SX.sym("x", s.nx),
        ca.SX.sym("u", s.nu),
        ca.SX.sym("z", s.nz),
        *clock,
        before.definition.param_fields(ca.SX.sym("params", before.definition.n_params)),
        du=ca.SX.sym("du", s.nu),
    )
    by_name = {d.name: d for d in others}
    names = set()
    for c in constraints:
        d = by_name.get(c.name)
        if d is None or not (
            np.array_equal(c.lower, d.lower)
            and np.array_equal(c.upper, d.upper)
            and before.definition.constraint_scales[c.name].tolist()
            == block.definition.constraint_scales[d.name].tolist()
        ):
            continue
        rows = evaluate_expression(c.name, c.expression, point)
        if ca.depends_on(rows, ca.vertcat(*clock)):
            continue
        if c.expression is not d.expression:
            try:
                others_rows = evaluate_expression(d.name, d.expression, point)
            except DefinitionError:  # e.g. a parameter the phase before does not have
                continue
            if not ca.is_equal(rows, others_rows, 64):
                continue
        names.add(c.name)
    return frozenset(names)


def _same_dynamics(a: OCPDefinition, b: OCPDefinition) -> bool:
    """Whether two phases have the same residual rows at the same values: residual
    functions equal on one set of symbols (the same names and sizes), neither reading the
    phase's clock t."""
    ra, rb = a.system.residual, b.system.residual
    if ra is None or rb is None:
        return ra is None and rb is None
    inputs = ra.n_in()
    if (
        a.system.residual_names != b.system.residual_names
        or a.system.params != b.system.params
        or inputs != rb.n_in()
        or any(ra.sparsity_in(i) != rb.sparsity_in(i) for i in range(inputs))
    ):
        return False
    symbols = [ca.SX.sym(ra.name_in(i), ra.sparsity_in(i)) for i in range(inputs)]
    left = ra(*symbols)
    if ca.depends_on(left, symbols[3]):
        return False
    same_model = (
        a.dynamics is b.dynamics
        and a.formulation == b.formulation
        and tuple(a.contacts) == tuple(b.contacts)
    )
    return same_model or ca.is_equal(left, rb(*symbols), 64)


def _apply(mapping, x):
    """A mapping (callable of SX or Function) applied to an MX or SX state through an SX
    Function."""
    symbol = ca.SX.sym("x", x.size1())
    value = mapping(symbol)
    if isinstance(value, list | tuple):
        value = ca.vertcat(*value)
    return ca.Function("mapping", [symbol], [value])(x)


def _default_scale(event) -> np.ndarray:
    stacked = np.abs(np.vstack([event.lower, event.upper]))
    stacked[~np.isfinite(stacked)] = 0.0
    scale = stacked.max(axis=0)
    scale[scale == 0.0] = 1.0
    return scale


__all__ = ["Transcription"]
