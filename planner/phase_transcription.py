"""One phase of a transcription: an :class:`planner.ocp.OCP` on its mesh, as NLP pieces.

The horizon [0, T] is cut into N intervals of lengths h_k = T f_k (uniform: f_k = 1 / N; a
non-uniform mesh gives the fractions f_k); in each, tau = (t - t_k) / h_k. The transcription's
:class:`planner.schemes.Scheme` (from the registry :mod:`planner.schemes`, which lists the
schemes) fixes, for one interval, where the states live and where the dynamics are enforced
(the "dynamics points", where the controls and auxiliary variables live too), the defects
X_k A^T - h F_k B^T = 0, the quadrature of the integral objective and the interpolant
x(tau) = X_k Wx(tau)^T + h F_k Wf(tau)^T, u(tau) = U_k Wu(tau)^T.

A :class:`PhaseTranscription` is given the physical values of its variables, its duration
and the static parameters as expressions by the NLP that holds it
(:class:`planner.transcription.Transcription`, the one NLP of a problem of one or more
phases) and returns its constraint rows, objective terms and boundary states. It is built
from one SX Function per dynamics point (rate, residual, path constraints, integrand), mapped
over all points with ``Function.map``, so that construction cost does not grow with the
expression size times N; defects are sparse constant matrices applied to the stacked
variables. Path constraints hold at the dynamics points; those of the state, t and T only
hold also at the state points with no dynamics point (Radau: t = 0; Legendre: the nodes).
Every constraint row keeps a name ("defect[psi_torso] interval 12", "path[clearance] node 3").

Keypoint constraints (``OCP.constrain_at``) evaluate the point on the interpolant of the
interval holding each instant: sparse constant matrices of the weights Wx, Wf, Wu (and Wu'
for control rates) applied to X, F and U. Control rates at the dynamics points are U_k
Wu'(tau)^T / h of the owning interval; reading them adds, on schemes sharing nodes, the other
side's slope at interior nodes, and on collocation, control continuity rows (see
``OCP.constrain``).
"""

from __future__ import annotations

import copy as _copy
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.guesses import evaluate_guess_layer
from planner.ocp import OCPDefinition, Point, evaluate_expression
from planner.resolved_definition import ResolvedDefinition
from planner.schemes import TRANSCRIPTIONS, Scheme

#: Merge common subexpressions in the function of a dynamics point: rows that read the same
#: quantity (the ground reaction of the friction cone and of the centre of pressure) otherwise
#: repeat it; measured on the walking step, 40 % less function time per IPOPT iteration
#: (``examples/benchmarks/gait_bench.py``).
MERGE_POINT_EXPRESSIONS = True


# ---- the mesh -----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Mesh:
    """Index bookkeeping of a scheme on N intervals (times normalised by T).

    ``fractions`` (N,): each interval's length as a fraction of T (None: uniform 1/N); interval
    k spans [breaks[k], breaks[k+1]] of the normalised time and has length h_k = T f_k.
    """

    scheme: Scheme
    N: int
    fractions: tuple[float, ...] | None = None

    @cached_property
    def widths(self) -> np.ndarray:
        """(N,) interval lengths as fractions of T (sum 1)."""
        if self.fractions is None:
            return np.full(self.N, 1.0 / self.N)
        return np.asarray(self.fractions, dtype=float)

    @cached_property
    def uniform(self) -> bool:
        return self.fractions is None

    @cached_property
    def relative(self) -> np.ndarray:
        """(N,) interval lengths in units of the mean length h = T / N: h_k = h r_k (exactly
        ones on a uniform mesh, so its NLP is the same to the last bit)."""
        if self.uniform:
            return np.ones(self.N)
        return self.widths * self.N

    @cached_property
    def breaks(self) -> np.ndarray:
        """(N+1,) normalised times of the nodes, 0 = breaks[0] < ... < breaks[N] = 1."""
        if self.uniform:
            return np.arange(self.N + 1) / self.N
        breaks = np.concatenate([[0.0], np.cumsum(self.widths)])
        breaks[-1] = 1.0
        return breaks

    def _times(self, taus: np.ndarray) -> np.ndarray:
        """(N, len(taus)) normalised times of the points at ``taus`` of every interval."""
        if self.uniform:  # (k + tau) / N, bit for bit as before non-uniform meshes
            return (np.arange(self.N)[:, None] + taus[None, :]) / self.N
        return self.breaks[:-1, None] + taus[None, :] * self.widths[:, None]

    @cached_property
    def n_state_points(self) -> int:
        return self.N * self.scheme.ms + 1

    @cached_property
    def n_dyn_points(self) -> int:
        return self.N * self.scheme.mc + int(self.scheme.shares_end)

    @cached_property
    def state_cols(self) -> np.ndarray:
        """(N, ms+1) state-point columns of each interval."""
        ms = self.scheme.ms
        return np.arange(self.N)[:, None] * ms + np.arange(ms + 1)[None, :]

    @cached_property
    def dyn_cols(self) -> np.ndarray:
        """(N, ndc) dynamics-point columns of each interval."""
        mc = self.scheme.mc
        return np.arange(self.N)[:, None] * mc + np.arange(self.scheme.ndc)[None, :]

    @cached_property
    def node_state_cols(self) -> np.ndarray:
        """(N+1,) state columns of the mesh nodes."""
        return np.arange(self.N + 1) * self.scheme.ms

    @cached_property
    def s_state(self) -> np.ndarray:
        """(n_state_points,) normalised times t / T of the state points."""
        return np.append(self._times(self.scheme.state_tau).reshape(-1), 1.0)

    @cached_property
    def s_dyn(self) -> np.ndarray:
        """(n_dyn_points,) normalised times of the dynamics points."""
        s = self._times(self.scheme.dyn_tau).reshape(-1)
        return np.append(s, 1.0) if self.scheme.shares_end else s

    @cached_property
    def dyn_state_cols(self) -> np.ndarray:
        """(n_dyn_points,) state column at each dynamics point (every one is a state point)."""
        taus = self.scheme.interval_state_tau
        local = [int(np.argmin(np.abs(taus - tau))) for tau in self.scheme.dyn_tau]
        cols = (np.arange(self.N)[:, None] * self.scheme.ms + np.array(local)[None, :]).reshape(-1)
        return np.append(cols, self.n_state_points - 1) if self.scheme.shares_end else cols

    @cached_property
    def free_state_cols(self) -> np.ndarray:
        """State columns where no dynamics point lies: t = 0 for Radau, every node for
        Legendre, none for trapezoid and Hermite-Simpson."""
        return np.setdiff1d(np.arange(self.n_state_points), self.dyn_state_cols)

    @cached_property
    def quadrature(self) -> np.ndarray:
        """(n_dyn_points,) weights q with integral ~= h sum q_c L_c, h = T / N (each interval's
        weights times its relative length r_k)."""
        q = np.zeros(self.n_dyn_points)
        weights = self.scheme.quadrature[None, :] * self.relative[:, None]
        np.add.at(q, self.dyn_cols.reshape(-1), weights.reshape(-1))
        return q

    def defect_matrices(self) -> tuple[ca.DM, ca.DM]:
        """Sparse (n_state_points, N r) and (n_dyn_points, N r): D = X A_big - h F B_big with
        h = T / N, the rate weights of interval k times its relative length r_k (h_k = h r_k)."""
        r = self.scheme.A.shape[0]
        rows_a, cols_a, vals_a, rows_b, cols_b, vals_b = [], [], [], [], [], []
        for k in range(self.N):
            for j in range(r):
                col = k * r + j
                for i, value in enumerate(self.scheme.A[j]):
                    if value != 0.0:
                        rows_a.append(int(self.state_cols[k, i]))
                        cols_a.append(col)
                        vals_a.append(float(value))
                for i, value in enumerate(self.scheme.B[j]):
                    if value != 0.0:
                        rows_b.append(int(self.dyn_cols[k, i]))
                        cols_b.append(col)
                        vals_b.append(float(value) * float(self.relative[k]))
        a = ca.DM(ca.Sparsity.triplet(self.n_state_points, self.N * r, rows_a, cols_a), vals_a)
        b = ca.DM(ca.Sparsity.triplet(self.n_dyn_points, self.N * r, rows_b, cols_b), vals_b)
        return a, b

    def dyn_label(self, c: int) -> str:
        """A readable place for dynamics point c: "node 3", "interval 2 midpoint" or
        "interval 2 point 1" (the scheme's :meth:`~planner.schemes.Scheme.point_name`)."""
        scheme = self.scheme
        k, j = divmod(c, scheme.mc)
        if scheme.shares_end:
            return f"node {k}" if j == 0 else f"interval {k} {scheme.point_name(j)}"
        if j == scheme.mc - 1 and scheme.owns_end:
            return f"node {k + 1}"
        return f"interval {k} {scheme.point_name(j + 1)}"

    def state_label(self, col: int) -> str:
        """A readable place for state point ``col``: "node 3" or "interval 2 point 1"."""
        k, j = divmod(col, self.scheme.ms)
        if j == 0:
            return f"node {k}"
        return f"interval {k} {self.scheme.point_name(j)}"

    @cached_property
    def dyn_owner(self) -> tuple[np.ndarray, np.ndarray]:
        """(interval (n_dyn_points,), tau (n_dyn_points,)): each dynamics point in the interval
        that owns it, the one :meth:`locate` gives for its time: a node shared by two
        intervals (trapezoid, Hermite-Simpson) belongs to the interval starting there, T to
        the last interval; a Radau end node to the interval it ends."""
        c = np.arange(self.n_dyn_points)
        k = np.minimum(c // self.scheme.mc, self.N - 1)
        return k, self.scheme.interval_dyn_tau[c - k * self.scheme.mc]

    def interval_matrix(self, k, weights, state: bool, power: int = 0) -> ca.DM:
        """Sparse (n_state_points or n_dyn_points, K): column i holds ``weights[i]`` (K, m) on
        the state (``state``, m = ms + 1) or dynamics (m = ndc) columns of interval ``k[i]``,
        so that V @ matrix evaluates the interval polynomials of values V at K places.
        ``power``: the weights of column i are multiplied by r_k^power (r_k the interval's
        length relative to h = T / N): 1 for the h F terms of a state, -1 for a derivative
        d/dt = d/dtau / h_k.
        """
        cols = self.state_cols if state else self.dyn_cols
        k = np.asarray(k, dtype=int).reshape(-1)
        weights = np.asarray(weights, dtype=float).reshape(k.size, cols.shape[1])
        if power and not self.uniform:
            weights = weights * self.relative[k, None] ** power
        rows = cols[k].reshape(-1)
        columns = np.repeat(np.arange(k.size), cols.shape[1])
        keep = weights.reshape(-1) != 0.0
        size = self.n_state_points if state else self.n_dyn_points
        sparsity = ca.Sparsity.triplet(size, k.size, rows[keep].tolist(), columns[keep].tolist())
        # Triplets in column order; one interval never repeats a column, so no duplicates.
        return ca.DM(sparsity, weights.reshape(-1)[keep][np.lexsort((rows[keep], columns[keep]))])

    def locate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interval index and tau of normalised times s = t / T.

        Intervals are [t_k, t_k+1) (the last one closed), except for Radau, whose intervals
        are (t_k, t_k+1] (the first one closed): a Radau interval owns the controls at its end
        node, so that a node's value is an NLP variable, not an extrapolation.
        """
        s = np.asarray(s, dtype=float)
        if self.uniform:
            scaled = s * self.N
        else:
            # The interval's index plus the fraction of it, as on a uniform mesh.
            j = np.clip(np.searchsorted(self.breaks, s, side="right") - 1, 0, self.N - 1)
            scaled = j + (s - self.breaks[j]) / self.widths[j]
        # A node time t_k = k h divided by T and multiplied by N can land a few ulps off the
        # integer k; snap it, or the node would be assigned to the neighbouring interval and
        # read from an extrapolated polynomial instead of its own NLP variable.
        nearest = np.rint(scaled)
        tolerance = 16 * np.finfo(float).eps * max(1, self.N)  # a few ulps of the largest value
        scaled = np.where(np.abs(scaled - nearest) <= tolerance, nearest, scaled)
        if self.scheme.owns_end:
            k = np.clip(np.ceil(scaled).astype(int) - 1, 0, self.N - 1)
        else:
            k = np.clip(np.floor(scaled).astype(int), 0, self.N - 1)
        return k, scaled - k


# ---- the NLP ------------------------------------------------------------------------------
def _drop_first(values, keep: list[int] | None, sym):
    """vec(values) of an (m, n) matrix with only the rows ``keep`` of its first column
    (None: every row)."""
    if keep is None or values.size2() == 0:
        return ca.vec(values)
    first = values[keep, 0] if keep else sym(0, 1)
    return ca.vertcat(first, ca.vec(values[:, 1:]))


def _reads(expression: ca.SX, symbols: ca.SX) -> bool:
    """Whether ``expression`` depends on any of ``symbols`` (False for no symbols)."""
    return symbols.numel() > 0 and expression.numel() > 0 and ca.depends_on(expression, symbols)


@dataclass(frozen=True)
class SharedStart:
    """What a phase shares with the phase before it across a continuity join: its first state
    node (always), its first dynamics point's controls and auxiliary variables (``controls``,
    when the join keeps the controls continuous and both schemes have a point there), and
    the rows there that the phase before already holds (``point_rows``: the residual and the
    path constraints, by name, of the shared dynamics point; ``state_paths``: the state-only
    path constraints, by name, at the shared node)."""

    controls: bool = False
    residual: bool = False
    point_paths: frozenset[str] = frozenset()
    state_paths: frozenset[str] = frozenset()


class PhaseTranscription:
    """One phase's NLP pieces: layout, rows, objective terms, bounds, row names, guess.

    Layout of the phase's own decision vector (scaled, v / scale): [vec(Xs) (nx * nX);
    vec(Us) (nu * nC); vec(Zs) (nz * nC); Ts (free T only)], with X at the nX state points
    and U, Z at the nC dynamics points, columns in time order. The static parameters belong
    to the whole NLP.

    ``provide``: a callable of this phase (its layout known) returning {"v": the physical
    values of its variables (n_w,), "T": a fixed duration (0 or 1 entries), "params": the
    static parameters in ``ocp.params`` order, "sym": the symbol class (MX or SX), "shared":
    a :class:`SharedStart` or None}, expressions of the NLP's symbols.
    """

    def __init__(self, ocp: OCPDefinition, provide) -> None:
        if not isinstance(ocp, OCPDefinition):
            raise DefinitionTypeError(f"`ocp`: must be a planner.OCP, got {type(ocp).__name__}")
        #: The definition, as given (solutions keep it).
        self.ocp = ocp
        #: What this transcription reads of it, read once (scales, bounds, rows, margins).
        self.definition = definition = ResolvedDefinition.of(ocp)
        self._provide = provide
        self.system = definition.system
        self.scheme = definition.scheme
        self.mesh = Mesh(self.scheme, definition.N, definition.mesh)
        self.state_scale = definition.state_scale
        self.control_scale = definition.control_scale
        self.aux_scale = definition.aux_scale
        self.residual_scale = definition.residual_scale
        self.T_scale = definition.T_scale
        self._build()

    def with_definition(self, ocp: OCPDefinition) -> PhaseTranscription:
        """A copy of this phase's transcription for ``ocp``, which differs from this one's
        only in margins and guesses (:meth:`planner.transcription.Transcription.for_problem`
        checks that): the rows and functions shared, the bounds read again."""
        copy = _copy.copy(self)
        copy.ocp = ocp
        copy.definition = ResolvedDefinition.of(ocp)
        copy._bounds_and_names()
        return copy

    # ---- sizes and layout ----------------------------------------------------------------
    @property
    def n_w(self) -> int:
        return self._n_w

    @property
    def n_g(self) -> int:
        return len(self.g_names)

    @property
    def label(self) -> str:
        """The mesh in words, for logs."""
        return f"{self.scheme.label} N={self.definition.N}"

    def slice_of(self, key: str) -> slice:
        """Where the block ``key`` ("X", "U", "Z", "T") lies in this phase's layout."""
        return self._slices[key]

    @property
    def starts_at_a_point(self) -> bool:
        """Whether a dynamics point lies at t = 0 (controls at the first node)."""
        return bool(self.mesh.s_dyn[0] == 0.0)

    @property
    def ends_at_a_point(self) -> bool:
        """Whether a dynamics point lies at t = T (controls at the last node)."""
        return bool(self.mesh.s_dyn[-1] == 1.0)

    def _layout(self) -> None:
        s, mesh = self.system, self.mesh
        nX, nC = mesh.n_state_points, mesh.n_dyn_points
        self._slices = {}
        offset = 0
        for key, size in (("X", s.nx * nX), ("U", s.nu * nC), ("Z", s.nz * nC)):
            self._slices[key] = slice(offset, offset + size)
            offset += size
        free = 1 if self.definition.free_time else 0
        self._slices["T"] = slice(offset, offset + free)
        offset += free
        self._n_w = offset

    # ---- symbolic construction --------------------------------------------------------
    def _path_constraints(self):
        return list(self.definition.path)

    def _boundary_constraints(self):
        return list(self.definition.boundary)

    def _instant_constraints(self):
        return list(self.definition.instant)

    @cached_property
    def state_paths(self) -> tuple:
        """Path constraints that depend on the state, t and T only (no control, no z): they
        are also enforced at the state points where no dynamics point lies
        (``mesh.free_state_cols``), where controls are not variables."""
        s = self.system
        x, u, z = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
        du = ca.SX.sym("du", s.nu)
        params = self.definition.param_fields(ca.SX.sym("params", self.definition.n_params))
        point = Point(s, x, u, z, ca.SX.sym("t"), ca.SX.sym("T"), params, du=du)
        others = ca.vertcat(u, z, du)
        kept = []
        for c in self._path_constraints():
            value = evaluate_expression(f"path[{c.name}]", c.expression, point)
            if others.numel() == 0 or not ca.depends_on(value, others):
                kept.append(c)
        return tuple(kept)

    def _state_path_function(self) -> ca.Function:
        """(x, t, T, params) -> the state-only path constraints at one state point, physical
        units."""
        s = self.system
        x, t, T = ca.SX.sym("x", s.nx), ca.SX.sym("t"), ca.SX.sym("T")
        P = ca.SX.sym("params", self.definition.n_params)
        # The constraints do not depend on u, z and du; zeros keep their shapes.
        zeros = ca.SX.zeros(s.nu)
        fields = self.definition.param_fields(P)
        point = Point(s, x, zeros, ca.SX.zeros(s.nz), t, T, fields, du=zeros)
        rows = [
            evaluate_expression(f"path[{c.name}]", c.expression, point) for c in self.state_paths
        ]
        return ca.Function(
            "state_path",
            [x, t, T, P],
            [ca.vertcat(*rows) if rows else ca.SX(0, 1)],
            ["x", "t", "T", "params"],
            ["path"],
        )

    def _point_function(self) -> ca.Function:
        """SX Function at one dynamics point, in physical units (the scaling is applied around
        it, by the NLP parameters: see :meth:`_build`).

        (x, u, z, t, T, params[, du]) -> (f (nx,), residual (nz,), path (np,), integrand
        (n_terms,): one per objective term with an integral); du: control rates, an input only
        when path constraints or the integrand read them.

        Also sets ``node_side_function`` when path constraints or the integrand read the
        control rate on a scheme whose nodes two intervals share (trapezoid, Hermite-Simpson):
        (x, u, z, t, T, params, du) -> (those path rows, integrand) for the node's other side.
        """
        s, definition = self.system, self.definition
        xs, us, zs = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
        t, T, dus = ca.SX.sym("t"), ca.SX.sym("T"), ca.SX.sym("du", s.nu)
        P = ca.SX.sym("params", definition.n_params)
        fields = definition.param_fields(P)
        p = s.parameter_input(fields)
        rate = s.rate(xs, zs, us, t, *p)
        residual = s.residual(xs, zs, us, t, *p) if s.residual is not None else ca.SX(0, 1)
        point = Point(s, xs, us, zs, t, T, fields, du=dus)
        paths = [
            evaluate_expression(f"path[{c.name}]", c.expression, point)
            for c in self._path_constraints()
        ]
        path = ca.vertcat(*paths) if paths else ca.SX(0, 1)
        integrands = [
            evaluate_expression(f"integral[{term.name}]", term.integral, point)
            for term in self.integral_terms
        ]
        integrand = ca.vertcat(*integrands) if integrands else ca.SX(0, 1)
        # A derived field (explicit ddpsi) repeats the rate's forward dynamics, and rows that
        # read the same quantity (a ground reaction for the friction cone and the centre of
        # pressure) repeat each other's expressions: merge them.
        options = {"cse": True} if MERGE_POINT_EXPRESSIONS or point.uses_derived else {}
        reads = [_reads(value, dus) for value in paths]
        self._integrand_reads_rate = _reads(integrand, dus)
        self._point_reads_rate = any(reads) or self._integrand_reads_rate
        if self.scheme.ndc == 2:
            # Linear controls (trapezoid): the rate is constant on an interval, so a row that
            # reads nothing but the rate (and T) at the node ending an interval would repeat
            # the row of the node starting it: only rows that also read the point get a side.
            point_values = ca.vertcat(xs, us, zs, t)
            sides = [
                r and _reads(value, point_values) for value, r in zip(paths, reads, strict=True)
            ]
        else:
            sides = reads
        constraints = self._path_constraints()
        self._rate_paths = tuple(c for c, r in zip(constraints, sides, strict=True) if r)
        self.node_side_function = None
        if self.scheme.shares_end and (self._rate_paths or self._integrand_reads_rate):
            side_paths = [value for value, r in zip(paths, sides, strict=True) if r]
            self.node_side_function = ca.Function(
                "node_side",
                [xs, us, zs, t, T, P, dus],
                [
                    ca.vertcat(*side_paths) if side_paths else ca.SX(0, 1),
                    integrand if self._integrand_reads_rate else ca.SX.zeros(integrand.size1()),
                ],
                ["x", "u", "z", "t", "T", "params", "du"],
                ["path", "integrand"],
                options,
            )
        # The rate input only when read: an unused input still costs IPOPT's setup time
        # (derivative functions of the mapped call).
        inputs = [xs, us, zs, t, T, P] + ([dus] if self._point_reads_rate else [])
        return ca.Function(
            "point",
            inputs,
            [rate, residual, path, integrand],
            ["x", "u", "z", "t", "T", "params", "du"][: len(inputs)],
            ["f", "residual", "path", "integrand"],
            options,
        )

    @property
    def integral_terms(self) -> tuple:
        """The objective terms with an integral, in order (rows of the point's integrand)."""
        return self.definition.integral_terms

    @property
    def terminal_terms(self) -> tuple:
        """The objective terms with a terminal part, in order."""
        return self.definition.terminal_terms

    def _boundary_function(self) -> ca.Function:
        """(x0, xf, u0, uf, z0, zf, T, params[, du0, duf]) -> (boundary rows, terminal parts
        of the objective terms (n_terminal,)), physical units; the control rates at both ends
        only when read. (Periodicity is a join of the whole NLP: planner.transcription.)"""
        s, definition = self.system, self.definition
        x0s, xfs = ca.SX.sym("x0", s.nx), ca.SX.sym("xf", s.nx)
        u0s, ufs = ca.SX.sym("u0", s.nu), ca.SX.sym("uf", s.nu)
        z0s, zfs = ca.SX.sym("z0", s.nz), ca.SX.sym("zf", s.nz)
        du0s, dufs = ca.SX.sym("du0", s.nu), ca.SX.sym("duf", s.nu)
        T = ca.SX.sym("T")
        P = ca.SX.sym("params", definition.n_params)
        x0, xf = x0s, xfs
        extra = {"x0": x0, "xf": xf, **definition.param_fields(P)}
        start = Point(s, x0, u0s, z0s, ca.SX(0), T, extra, du=du0s)
        end = Point(s, xf, ufs, zfs, T, T, extra, du=dufs)
        rows = []
        for c in self._boundary_constraints():
            point = start if c.where == "start" else end
            rows.append(evaluate_expression(f"{c.where}[{c.name}]", c.expression, point))
        terminals = [
            evaluate_expression(f"terminal[{term.name}]", term.terminal, end)
            for term in self.terminal_terms
        ]
        mayer = ca.vertcat(*terminals) if terminals else ca.SX(0, 1)
        self._boundary_reads_rate = _reads(ca.vertcat(*rows, mayer), ca.vertcat(du0s, dufs))
        rates = [du0s, dufs] if self._boundary_reads_rate else []
        return ca.Function(
            "boundary",
            [x0s, xfs, u0s, ufs, z0s, zfs, T, P, *rates],
            [ca.vertcat(*rows) if rows else ca.SX(0, 1), mayer],
            {"cse": True} if start.uses_derived or end.uses_derived else {},
        )

    def _build(self) -> None:
        """This phase's rows, objective terms and boundary states as expressions of the
        physical values the NLP provides (the functions inside work in physical units; the
        NLP applies the nominal scales around them: :mod:`planner.transcription`)."""
        s, definition, mesh, scheme = self.system, self.definition, self.mesh, self.scheme
        self._layout()
        nX, nC, N = mesh.n_state_points, mesh.n_dyn_points, definition.N
        given = self._provide(self)
        sym, v, p_T, params = given["sym"], given["v"], given["T"], given["params"]
        #: What this phase shares with the one before (planner.transcription.SharedStart).
        self.shared = shared = given.get("shared") or SharedStart()
        # Physical values (the names Xs, Us, Zs stay from the scaled version of this code).
        Xs = ca.reshape(v[self._slices["X"]], s.nx, nX)
        Us = ca.reshape(v[self._slices["U"]], s.nu, nC)
        Zs = ca.reshape(v[self._slices["Z"]], s.nz, nC)
        T = v[self._slices["T"]] if definition.free_time else p_T
        h = T / N  # the mean interval length; interval k has h r_k (mesh.relative)
        point_f = self._point_function()
        self.point_function = point_f
        mapped = point_f.map(nC)
        times = T * ca.DM(mesh.s_dyn).T
        Xd = Xs[:, mesh.dyn_state_cols.tolist()]
        rate_input = []
        if self._point_reads_rate:
            # du/dt at each dynamics point from the polynomial of the interval owning it.
            owner, tau = mesh.dyn_owner
            rates = mesh.interval_matrix(
                owner, scheme.control_weights(tau, 1), state=False, power=-1
            )
            rate_input = [ca.mtimes(Us, rates) / h]
        Fs, Rs, Ps, Ls = mapped(
            Xd, Us, Zs, times, ca.repmat(T, 1, nC), ca.repmat(params, 1, nC), *rate_input
        )
        A_big, B_big = mesh.defect_matrices()
        defects = ca.mtimes(Xs, A_big) - h * ca.mtimes(Fs, B_big)
        # Boundary values of controls and aux come from the first/last interval's polynomial.
        w0 = scheme.control_weights([0.0])[0]
        w1 = scheme.control_weights([1.0])[0]
        first, last = mesh.dyn_cols[0].tolist(), mesh.dyn_cols[-1].tolist()
        u0 = ca.mtimes(Us[:, first], ca.DM(w0))
        uf = ca.mtimes(Us[:, last], ca.DM(w1))
        z0 = ca.mtimes(Zs[:, first], ca.DM(w0)) if s.nz else Zs[:, :0]
        zf = ca.mtimes(Zs[:, last], ca.DM(w1)) if s.nz else Zs[:, :0]
        boundary_f = self._boundary_function()
        self.boundary_function = boundary_f
        rate_input = []
        if self._boundary_reads_rate:
            relative = mesh.relative
            rate_input = [
                ca.mtimes(Us[:, first], ca.DM(scheme.control_weights([0.0], 1)[0] / relative[0]))
                / h,
                ca.mtimes(Us[:, last], ca.DM(scheme.control_weights([1.0], 1)[0] / relative[-1]))
                / h,
            ]
        gb, mayer = boundary_f(Xs[:, 0], Xs[:, -1], u0, uf, z0, zf, T, params, *rate_input)
        at_functions = [self._instant_function(c) for c in self._instant_constraints()]
        self.reads_control_rate = (
            self._point_reads_rate
            or self._boundary_reads_rate
            or any(reads for _, reads in at_functions)
        )
        quadrature, side_cost, Pside, continuity = self._control_rate_terms(
            Xd, Us, Zs, times, T, h, params, sym
        )
        integrals = h * ca.mtimes(Ls, ca.DM(quadrature)) + side_cost
        # Each objective term's value: its integral part plus its terminal part.
        integral_rows = {term.name: i for i, term in enumerate(self.integral_terms)}
        terminal_rows = {term.name: i for i, term in enumerate(self.terminal_terms)}
        terms = []
        for term in definition.objective:
            value = 0
            if term.name in integral_rows:
                value = value + integrals[integral_rows[term.name]]
            if term.name in terminal_rows:
                value = value + mayer[terminal_rows[term.name]]
            terms.append(value)
        #: Each objective term's value (n_terms,), physical units, in ``ocp.objective`` order.
        self.term_values = ca.vertcat(*terms) if terms else sym(0, 1)
        objective = ca.sum1(self.term_values) if terms else sym(0)
        # State-only path constraints also where no dynamics point lies (Radau t = 0,
        # Legendre nodes): there the state is a variable, the control is not.
        free = mesh.free_state_cols
        if free.size and self.state_paths:
            state_path = self._state_path_function().map(free.size)
            Pfree = state_path(
                Xs[:, free.tolist()],
                T * ca.DM(mesh.s_state[free]).T,
                ca.repmat(T, 1, free.size),
                ca.repmat(params, 1, free.size),
            )
        else:
            Pfree = sym(0, 1)
        g_at = [
            self._instant_rows(c, f, Xs, Us, Zs, Fs, T, h, params)
            for c, (f, _) in zip(self._instant_constraints(), at_functions, strict=True)
        ]
        # Rows the phase before already holds at a shared start (the same residual and the
        # same time-free path constraints at the same values) are left out: repeated
        # equality rows would make the constraint Jacobian rank deficient.
        self._point_keep = self._kept_rows(self._path_constraints(), shared.point_paths)
        self._free_keep = self._kept_rows(self.state_paths, shared.state_paths)
        g = ca.vertcat(
            ca.vec(defects),
            _drop_first(Rs, [] if shared.residual else None, sym),
            _drop_first(Ps, self._point_keep, sym),
            _drop_first(Pfree, self._free_keep if self._free_starts else None, sym),
            ca.vec(Pside),
            gb,
            *g_at,
            ca.vec(continuity),
        )
        #: Physical constraint rows, objective, boundary states and duration: what the NLP
        #: assembles (planner.transcription).
        self.rows, self._objective = g, objective
        self.x0, self.xf, self.duration = Xs[:, 0], Xs[:, -1], T
        self._bounds_and_names()

    @property
    def _free_starts(self) -> bool:
        """Whether the first state node is a state point without a dynamics point."""
        free = self.mesh.free_state_cols
        return bool(free.size and free[0] == 0)

    @staticmethod
    def _kept_rows(constraints, dropped: frozenset[str]) -> list[int] | None:
        """The rows kept at the first point when the rows of the constraints named in
        ``dropped`` are left out there; None: every row is kept."""
        if not dropped:
            return None
        kept, row = [], 0
        for c in constraints:
            if c.name not in dropped:
                kept.extend(range(row, row + c.size))
            row += c.size
        return kept

    def _control_rate_terms(self, Xd, Us, Zs, times, T, h, params, sym):
        """What reading control rates adds to the NLP.

        Returns (quadrature (nC,), side cost (per integral term), side path rows
        (m, N - 1), continuity rows).
        A node that two intervals share (trapezoid, Hermite-Simpson) has a rate on each side;
        the dynamics point carries the slope of the interval starting there, and the side
        terms add the slope of the interval ending there (interior nodes 1..N-1): the path
        rows that read rates hold on both sides, and the integral takes each interval's share
        of the node with that interval's own slope (the quadrature of every interval's own
        polynomial, as for collocation). Collocation controls are independent polynomials per
        interval that may jump at the nodes, which a rate would not see: when anything reads
        a rate, they are made continuous (u_k(1) = u_k+1(0), rows "continuity[u] node k").
        """
        s, mesh, scheme, N = self.system, self.mesh, self.scheme, self.definition.N
        quadrature = mesh.quadrature
        side_cost, Pside, continuity = 0, sym(0, max(N - 1, 0)), sym(0, 1)
        if not self.reads_control_rate:
            return quadrature, side_cost, Pside, continuity
        if scheme.ndc == 1:
            others = ", ".join(name for name in TRANSCRIPTIONS if name != scheme.name)
            raise DefinitionError(
                f"`transcription`: {scheme.name} of degree {scheme.degree} has "
                "piecewise-constant controls, so control rates (p.du) are zero inside the "
                f"intervals and infinite at the nodes; use a higher degree, or one of {others}"
            )
        nodes = np.arange(1, N)
        if N > 1 and self.node_side_function is not None:
            cols = (nodes * scheme.mc).tolist()
            weights = np.tile(scheme.control_weights([1.0], 1), (N - 1, 1))
            left = ca.mtimes(Us, mesh.interval_matrix(nodes - 1, weights, False, power=-1)) / h
            Pside, Lside = self.node_side_function.map(N - 1)(
                Xd[:, cols],
                Us[:, cols],
                Zs[:, cols],
                times[:, cols],
                ca.repmat(T, 1, N - 1),
                ca.repmat(params, 1, N - 1),
                left,
            )
            if self._integrand_reads_rate:
                # The node's share of the interval ending there (weight times its width).
                ending = float(scheme.quadrature[-1]) * mesh.relative[nodes - 1]
                quadrature = quadrature.copy()
                quadrature[cols] -= ending
                side_cost = h * ca.mtimes(Lside, ca.DM(ending))
        if N > 1 and not scheme.shares_end and s.nu:
            ends = np.tile(scheme.control_weights([1.0]), (N - 1, 1))
            starts = np.tile(scheme.control_weights([0.0]), (N - 1, 1))
            continuity = ca.mtimes(Us, mesh.interval_matrix(nodes - 1, ends, state=False))
            continuity -= ca.mtimes(Us, mesh.interval_matrix(nodes, starts, state=False))
        return quadrature, side_cost, Pside, continuity

    def _instant_places(self, constraint) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s (K,), interval (K,), tau (K,)): the normalised times t / T of an "at"
        constraint's instants and where they lie on the mesh (:meth:`Mesh.locate`)."""
        instants = np.array(constraint.instants)
        if constraint.fraction:
            s = instants
        else:
            T = self.definition.T
            if np.any(instants > T):
                raise DefinitionError(
                    f"`at[{constraint.name}]`: t={instants.max():g} s lies after the end of the "
                    f"horizon T = {T:g} s; give instants in [0, T] or fractions of T"
                )
            s = instants / T
        k, tau = self.mesh.locate(s)
        return s, k, tau

    def _instant_function(self, constraint) -> tuple[ca.Function, bool]:
        """(x, u, z, t, T, params, du) -> the constraint's rows at one instant (SX, physical
        units), and whether they read the control rate."""
        s = self.system
        xs, us, zs = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
        t, T, dus = ca.SX.sym("t"), ca.SX.sym("T"), ca.SX.sym("du", s.nu)
        P = ca.SX.sym("params", self.definition.n_params)
        point = Point(s, xs, us, zs, t, T, self.definition.param_fields(P), du=dus)
        label = f"at[{constraint.name}]"
        value = evaluate_expression(label, constraint.expression, point)
        if constraint.on == "motion" and _reads(value, dus):
            raise DefinitionError(
                f"`{label}`: reads a control rate, which the consistent motion does not offer "
                "(its drives come from the inverse dynamics); constrain it on='transcription'"
            )
        function = ca.Function(
            "at",
            [xs, us, zs, t, T, P, dus],
            [value],
            ["x", "u", "z", "t", "T", "params", "du"],
            ["rows"],
            {"cse": True} if point.uses_derived else {},
        )
        return function, _reads(value, dus)

    def _instant_rows(self, constraint, function, Xs, Us, Zs, Fs, T, h, params):
        """Rows of an "at" constraint at its K instants, (K rows,) instant by instant: the
        point on the interpolant of the interval holding each instant (physical values:
        x = X_k Wx^T + h_k F_k Wf^T with F the rates, u = U_k Wu^T, du = U_k Wu'^T / h_k,
        h_k = h r_k the length of interval k)."""
        mesh, scheme = self.mesh, self.scheme
        s, k, tau = self._instant_places(constraint)
        wx, wf = scheme.state_weights(tau)
        x = ca.mtimes(Xs, mesh.interval_matrix(k, wx, state=True))
        if np.any(wf != 0.0):
            x = x + h * ca.mtimes(Fs, mesh.interval_matrix(k, wf, state=False, power=1))
        u_matrix = mesh.interval_matrix(k, scheme.control_weights(tau), state=False)
        u = ca.mtimes(Us, u_matrix)
        z = ca.mtimes(Zs, u_matrix)
        du = ca.mtimes(
            Us, mesh.interval_matrix(k, scheme.control_weights(tau, 1), state=False, power=-1)
        )
        K = k.size
        if constraint.on == "motion":
            x, u, z = self._motion_at(k, tau, x, u, z, Xs, Fs, h, function)
        rows = function.map(K)(
            x, u, z, T * ca.DM(s).T, ca.repmat(T, 1, K), ca.repmat(params, 1, K), du / h
        )
        return ca.vec(rows)

    def _motion_at(self, k, tau, x, u, z, Xs, Fs, h, function):
        """(x, u, z) at K instants of intervals k, local times tau, on the consistent motion
        (what ``Solution.motion`` samples): positions q_k + h_k (integral of the velocity
        polynomial), velocities that polynomial, accelerations its slope (z, when z holds
        them), the drives from ``drives_for_motion`` (only when ``function``, the rows, read
        a control or z: the inverse dynamics is the costly part); the rest as ``x``, ``u``,
        ``z`` (the transcription's interpolant, (n, K) each)."""
        s, mesh, scheme = self.system, self.mesh, self.scheme
        index = {name: i for i, name in enumerate(s.state_names)}
        positions = [index[name] for name in s.group(s.positions)]
        velocities = [index[name] for name in s.group(s.velocities)]
        V, A = Xs[velocities, :], Fs[velocities, :]

        def velocity_polynomial(derivative: int, power: int):
            # v's polynomial (derivative 0), its integral (-1, times h_k) or slope (1, / h_k):
            # V Wx r^power + h A Wf r^(power + 1), r_k the interval's relative length.
            wx, wf = scheme.motion_weights(tau, derivative)
            value = ca.mtimes(V, mesh.interval_matrix(k, wx, state=True, power=power))
            if np.any(wf != 0.0):
                weights = mesh.interval_matrix(k, wf, state=False, power=power + 1)
                value = value + h * ca.mtimes(A, weights)
            return value

        # At an interval's end (tau = 1) the next node's own values, as Solution.motion.
        end = np.asarray(tau) == 1.0
        unit = np.eye(scheme.ms + 1)
        start_weights = np.where(end[:, None], 0.0, unit[0])
        end_weights = np.where(end[:, None], unit[scheme.ms], 0.0)
        start = mesh.interval_matrix(k, start_weights, state=True)
        q = ca.mtimes(Xs[positions, :], start) + h * velocity_polynomial(-1, 1)
        v = velocity_polynomial(0, 0)
        if np.any(end):
            inside = ca.diag(ca.DM((~end).astype(float)))
            finish = mesh.interval_matrix(k, end_weights, state=True)
            q = ca.mtimes(q, inside) + ca.mtimes(Xs[positions, :], finish)
            v = ca.mtimes(v, inside) + ca.mtimes(Xs[velocities, :], finish)
        a = velocity_polynomial(1, -1) / h
        rows = [x[i, :] for i in range(s.nx)]
        for j, (p, w) in enumerate(zip(positions, velocities, strict=True)):
            rows[p], rows[w] = q[j, :], v[j, :]
        x = ca.vertcat(*rows)
        if s.nz and s.group(s.accelerations) == s.aux_names:
            z = a
        reads = function.sparsity_jac("u", "rows").nnz() + function.sparsity_jac("z", "rows").nnz()
        if not reads:  # positions and velocities only: the drives are not needed
            return x, u, z
        drives = [s.control_names.index(name) for name in s.role_names("drives")]
        values = s.drives_for_motion.map(k.size)(x, a, u)
        controls = [u[i, :] for i in range(s.nu)]
        for j, i in enumerate(drives):
            controls[i] = values[j, :]
        return x, ca.vertcat(*controls), z

    def _bounds_and_names(self) -> None:
        s, definition, mesh = self.system, self.definition, self.mesh
        nX, nC, N = mesh.n_state_points, mesh.n_dyn_points, definition.N
        # variable bounds (scaled) and names
        lbx = np.full(self.n_w, -np.inf)
        ubx = np.full(self.n_w, np.inf)
        names: list[str] = []
        for key, var_names, scale, count, label in (
            ("X", s.state_names, self.state_scale, nX, mesh.state_label),
            ("U", s.control_names, self.control_scale, nC, mesh.dyn_label),
            ("Z", s.aux_names, self.aux_scale, nC, mesh.dyn_label),
        ):
            if not var_names:
                continue
            lo, hi = definition.bounds_of(var_names)
            lo, hi = lo / scale, hi / scale
            sl = self._slices[key]
            lbx[sl] = np.tile(lo, count)
            ubx[sl] = np.tile(hi, count)
            times = mesh.s_state if key == "X" else mesh.s_dyn
            for j, n in enumerate(var_names):
                margin = self._point_margins(n, times)
                if margin is not None:
                    lbx[sl][j :: len(var_names)] += margin[0][:, 0] / scale[j]
                    ubx[sl][j :: len(var_names)] -= margin[1][:, 0] / scale[j]
            names.extend(f"bound[{n}] {label(c)}" for c in range(count) for n in var_names)
        if definition.free_time:
            index = self._slices["T"].start
            lbx[index] = definition.T[0] / self.T_scale
            ubx[index] = definition.T[1] / self.T_scale
            names.append("bound[T]")
        self.lbx, self.ubx, self.w_names = lbx, ubx, tuple(names)
        w_scale = [
            np.tile(sc, count)
            for sc, count in (
                (self.state_scale, nX),
                (self.control_scale, nC),
                (self.aux_scale, nC),
            )
        ]
        self.w_scale = np.concatenate([*w_scale, [self.T_scale] if definition.free_time else []])
        # constraint rows
        g_names: list[str] = []
        lbg: list[np.ndarray] = []
        ubg: list[np.ndarray] = []
        r = self.scheme.A.shape[0]
        for k in range(N):
            for j in range(r):
                suffix = self.scheme.defect_labels[j]
                g_names.extend(f"defect[{n}] interval {k}{suffix}" for n in s.state_names)
        n_defects = N * r * s.nx
        lbg.append(np.zeros(n_defects))
        ubg.append(np.zeros(n_defects))
        g_scale = [np.tile(self.state_scale, N * r)]
        if s.nz:
            # Not at a dynamics point shared with the phase before (it holds those rows).
            first = 1 if self.shared.residual else 0
            for c in range(first, nC):
                g_names.extend(f"dynamics[{n}] {mesh.dyn_label(c)}" for n in s.residual_names)
            lbg.append(np.zeros(s.nz * (nC - first)))
            ubg.append(np.zeros(s.nz * (nC - first)))
            g_scale.append(np.tile(self.residual_scale, nC - first))
        # Path constraints at every dynamics point, the state-only ones also at the state
        # points with no dynamics point (Radau t = 0, Legendre nodes); at a shared start only
        # the rows the phase before does not hold (``_point_keep``, ``_free_keep``).
        free = mesh.free_state_cols
        for constraints, columns, label, keep in (
            (self._path_constraints(), range(nC), mesh.dyn_label, self._point_keep),
            (
                self.state_paths if free.size else (),
                free,
                mesh.state_label,
                self._free_keep if self._free_starts else None,
            ),
        ):
            if constraints:
                row_names, lo, hi, scale = self._constraint_rows(constraints)
                times = (mesh.s_dyn if label == mesh.dyn_label else mesh.s_state)[list(columns)]
                lows, highs = self._row_margins(constraints, times, scale)
                for i, col in enumerate(columns):
                    rows = keep if i == 0 and keep is not None else range(len(row_names))
                    g_names.extend(f"{row_names[r]} {label(int(col))}" for r in rows)
                    lbg.append((lo + lows[i])[list(rows)])
                    ubg.append((hi - highs[i])[list(rows)])
                    g_scale.append(scale[list(rows)])
        if self.node_side_function is not None and self._rate_paths and N > 1:
            # The rate-reading path rows again at each interior node, with the slope of the
            # interval ending there.
            row_names, lo, hi, scale = self._constraint_rows(self._rate_paths)
            for k in range(1, N):
                g_names.extend(f"{n} node {k} (end of interval {k - 1})" for n in row_names)
            lbg.append(np.tile(lo, N - 1))
            ubg.append(np.tile(hi, N - 1))
            g_scale.append(np.tile(scale, N - 1))
        boundary = self._boundary_constraints()
        if boundary:
            row_names, lo, hi, scale = self._constraint_rows(boundary)
            g_names.extend(row_names)
            lbg.append(lo)
            ubg.append(hi)
            g_scale.append(scale)
        for c in self._instant_constraints():
            _, intervals, _ = self._instant_places(c)
            scale = definition.constraint_scales[c.name]
            for i, k in enumerate(intervals):
                place = f"{c.instant_label(i)} (interval {k})"
                g_names.extend(f"{row} {place}" for row in c.row_names())
            lbg.append((c.lower / scale).reshape(-1))
            ubg.append((c.upper / scale).reshape(-1))
            g_scale.append(np.tile(scale, len(intervals)))
        if self.reads_control_rate and not self.scheme.shares_end and N > 1 and s.nu:
            for k in range(1, N):
                g_names.extend(f"continuity[{n}] node {k}" for n in s.control_names)
            lbg.append(np.zeros(s.nu * (N - 1)))
            ubg.append(np.zeros(s.nu * (N - 1)))
            g_scale.append(np.tile(self.control_scale, N - 1))
        self.g_names = tuple(g_names)
        self.g_scale = np.concatenate(g_scale)
        self.lbg = np.concatenate(lbg) if lbg else np.zeros(0)
        self.ubg = np.concatenate(ubg) if ubg else np.zeros(0)
        if self.lbg.size != self.rows.size1():
            raise RuntimeError(
                f"internal: {self.lbg.size} constraint bounds for {self.rows.size1()} rows"
            )

    def _point_margins(self, name: str, times: np.ndarray):
        """(lower (K, rows), upper (K, rows)) margins of ``name`` (``OCP.back_off``) at the
        normalised times of K points, each the largest of the intervals that hold the point
        (a node shared by two intervals takes both into account; none at the phase's ends
        unless ``at_ends``); None without margins."""
        margins = self.definition.margins.get(name)
        if margins is None:
            return None
        breaks = self.mesh.breaks
        tolerance = 1e-12
        first = np.clip(np.searchsorted(breaks, times - tolerance, side="right") - 1, 0, None)
        last = np.clip(np.searchsorted(breaks, times + tolerance, side="left") - 1, None, None)
        N = self.definition.N
        first = np.minimum(first, N - 1)
        last = np.clip(np.maximum(last, first), 0, N - 1)
        ends = ((times <= tolerance) | (times >= 1.0 - tolerance)) & (not margins[2])
        out = []
        for array in margins[:2]:
            out.append(np.where(ends[:, None], 0.0, np.maximum(array[first], array[last])))
        return out[0], out[1]

    def _row_margins(self, constraints, times: np.ndarray, scale: np.ndarray):
        """Scaled (lower, upper) margins (K, rows of ``constraints`` stacked) at K points."""
        lows, highs = [], []
        for c in constraints:
            margins = self._point_margins(c.name, times)
            if margins is None:
                margins = (np.zeros((times.size, c.size)), np.zeros((times.size, c.size)))
            lows.append(margins[0])
            highs.append(margins[1])
        return np.hstack(lows) / scale, np.hstack(highs) / scale

    def _constraint_rows(self, constraints) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
        """Row names ("path[c]", "start[b][1]"), scaled lower and upper bounds and nominal
        scales of ``constraints`` at one point, stacked in order."""
        scales = [self.definition.constraint_scales[c.name] for c in constraints]
        names = [row for c in constraints for row in c.row_names()]
        lower = np.concatenate([c.lower / s for c, s in zip(constraints, scales, strict=True)])
        upper = np.concatenate([c.upper / s for c, s in zip(constraints, scales, strict=True)])
        return names, lower, upper, np.concatenate(scales)

    # ---- numeric helpers ----------------------------------------------------------------
    def unpack(self, w: np.ndarray) -> dict[str, Any]:
        """Physical values from this phase's scaled decision vector (its own layout, n_w).

        Returns dict with X (nX, nx), U (nC, nu), Z (nC, nz), T (s).
        """
        s, mesh = self.system, self.mesh
        w = np.asarray(w, dtype=float).reshape(-1)
        X = w[self._slices["X"]].reshape(mesh.n_state_points, s.nx) * self.state_scale
        U = w[self._slices["U"]].reshape(mesh.n_dyn_points, s.nu) * self.control_scale
        Z = w[self._slices["Z"]].reshape(mesh.n_dyn_points, s.nz) * self.aux_scale
        definition = self.definition
        T = float(w[self._slices["T"]][0] * self.T_scale) if definition.free_time else definition.T
        return {"X": X, "U": U, "Z": Z, "T": T}

    def pack(self, X: np.ndarray, U: np.ndarray, Z: np.ndarray, T: float) -> np.ndarray:
        """This phase's scaled decision vector from physical X (nX, nx), U (nC, nu), Z (nC,
        nz) and T."""
        w = np.zeros(self.n_w)
        w[self._slices["X"]] = (np.asarray(X) / self.state_scale).reshape(-1)
        w[self._slices["U"]] = (np.asarray(U) / self.control_scale).reshape(-1)
        w[self._slices["Z"]] = (np.asarray(Z) / self.aux_scale).reshape(-1)
        if self.definition.free_time:
            w[self._slices["T"]] = T / self.T_scale
        return w

    def initial_guess(self) -> np.ndarray:
        """This phase's scaled decision vector from the OCP's guesses (defaults: bound
        midpoints, or 0)."""
        definition, s, mesh = self.definition, self.system, self.mesh
        T = definition.duration_guess
        t_state = mesh.s_state * T
        t_dyn = mesh.s_dyn * T
        at_state: dict[str, np.ndarray] = {}
        at_dyn: dict[str, np.ndarray] = {}
        context = (s, T, definition.resolve)
        for layer in definition.guesses:
            at_state.update(evaluate_guess_layer(*context, layer, t_state))
            at_dyn.update(evaluate_guess_layer(*context, layer, t_dyn))

        def default(name: str, count: int) -> np.ndarray:
            lo, hi = definition.bounds[name]
            if np.isfinite(lo) and np.isfinite(hi):
                value = 0.5 * (lo + hi)
            else:
                value = float(np.clip(0.0, lo, hi))
            return np.full(count, value)

        nX, nC = mesh.n_state_points, mesh.n_dyn_points

        def stack(names, source, count):
            columns = [source.get(n, default(n, count)) for n in names]
            return np.column_stack(columns) if columns else np.zeros((count, 0))

        X = stack(s.state_names, at_state, nX)
        Z = stack(s.aux_names, at_dyn, nC)
        U = stack(s.control_names, at_dyn, nC)
        missing = [n for n in s.control_names if n not in at_dyn]
        if s.complete_guess is not None and missing and definition.guesses:
            # Controls that no guess gives, from the guessed motion by the system's own rule
            # (a linkage's torques by inverse dynamics, so that a gait law starts the solver
            # on a dynamically consistent point).
            completed = s.complete_guess(at_dyn)
            for name in missing:
                if name in completed:
                    U[:, s.control_names.index(name)] = completed[name]
        return self.pack(X, U, Z, T)
