"""The result of a solve: grids, interpolants, drives, accuracy estimates, export.

A :class:`Solution` keeps the NLP's values where they live (states at the state points,
controls, auxiliary variables and rates at the dynamics points) and interpolates with exactly the
polynomials of its transcription (:class:`planner.schemes.Scheme`): trapezoid, linear
controls and quadratic states; Hermite-Simpson, quadratic controls and cubic states;
collocation, the Lagrange polynomials of each interval. Between intervals the interpolant is
right-continuous (intervals [t_k, t_k+1), the last one closed at T), except for Radau, which
is left-continuous (intervals (t_k, t_k+1], the first one closed at 0: a Radau interval owns
the controls at its end node); controls of a collocation scheme may jump at the nodes.

Accuracy estimates (all in the states' physical units):

* :meth:`Solution.integration_error`: each interval re-integrated from its start node with the
  interpolated controls at tight tolerance (CVODES; IDAS on the DAE x' = z, r(x, z, u, t) = 0
  for dynamics given as a generic implicit residual), compared with its end node (the
  project's one interval simulator, :class:`planner.simulation.Simulator`);
* :meth:`Solution.residual_error`: the integral over each interval of |f(x, u, t) - dx/dt|
  along the interpolant (the error OptimTraj reports; for a generic implicit residual, f is
  the root of r(x, f, u, t) = 0 by Newton's method from dx/dt);
* :meth:`Solution.replay`: the whole horizon integrated open loop from x(0). This is a
  stability probe, not an accuracy measure: an unstable motion (a six-link gait has a
  one-period sensitivity near 1e9) diverges whatever the transcription's accuracy.
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np

from planner.collocation import gauss_legendre
from planner.errors import AnthropoidError, DefinitionError, check_positive
from planner.simulation import (
    SimulationError,
    Simulator,
    check_tolerance,
    monomial_coefficients,
)

#: Gauss-Legendre points per interval for residual_error. The integrand |f - dx/dt| has kinks
#: where f - dx/dt changes sign, so the rule is not exact (its degree 2 * 12 - 1 exactness
#: holds for smooth polynomials only): an estimate, whose error is not bounded by that degree.
RESIDUAL_QUADRATURE_POINTS = 12
#: What :meth:`Solution.to_trajectory` samples: the consistent motion or the transcription's
#: own polynomials.
MOTIONS = ("consistent", "transcription")


def uniform_times(duration: float, rate_hz: float) -> np.ndarray:
    """The export grid of a motion lasting ``duration`` s: 0, 1/rate_hz, 2/rate_hz, ... and
    ``duration`` itself at the end when it is not on that grid (s, (K,))."""
    rate = check_positive("rate_hz", rate_hz, "Hz")
    count = int(np.floor(duration * rate + 1e-9))
    times = np.arange(count + 1) / rate
    if duration - times[-1] > 1e-9 * duration:
        times = np.append(times, duration)
    return times


@dataclass(frozen=True)
class IntegrationError:
    """Per-interval error estimates.

    per_interval : (N, nx) absolute error of each state on each interval, state units.
    max : the largest entry; worst_interval, worst_state: where it is.
    """

    per_interval: np.ndarray
    state_names: tuple[str, ...]

    @property
    def max(self) -> float:
        return float(np.max(self.per_interval)) if self.per_interval.size else 0.0

    @property
    def per_state(self) -> np.ndarray:
        """(nx,) worst over intervals."""
        return np.max(self.per_interval, axis=0)

    @property
    def worst_interval(self) -> int:
        return int(np.unravel_index(np.argmax(self.per_interval), self.per_interval.shape)[0])

    @property
    def worst_state(self) -> str:
        index = np.unravel_index(np.argmax(self.per_interval), self.per_interval.shape)[1]
        return self.state_names[int(index)]

    def __repr__(self) -> str:
        return (
            f"IntegrationError(max={self.max:.3e} in {self.worst_state} on interval "
            f"{self.worst_interval})"
        )


@dataclass(frozen=True)
class Replay:
    """Open-loop replay of the horizon from x(0): a stability probe, not an accuracy measure.

    time (N+1,) s; states (N+1, nx) integrated; deviation (N+1, nx) = integrated - solution.
    """

    time: np.ndarray
    states: np.ndarray
    deviation: np.ndarray

    @property
    def max_deviation(self) -> float:
        return float(np.max(np.abs(self.deviation)))


class Solution:
    """Values, interpolants, status and stats of a solved (or failed) transcription.

    Attributes
    ----------
    cost : objective value (physical units of the objective).
    status : IPOPT's return status; success : whether it counts as converged.
    stats : timings and counts (see :func:`planner.solver.solve`).
    T : duration, s. N : intervals. transcription_name, degree, formulation.
    time, states, controls, drives, accelerations : values at the N+1 mesh nodes (see properties).
    state_time, state_values : every state point (nX,), (nX, nx).
    point_time, control_values, aux_values, rate_values : every dynamics point (nC,), ...
    w : the scaled decision vector (n_w,) of the NLP (:attr:`transcription`, the whole
        problem's: a phase of several has the values of every phase).
    lam_x, lam_g : IPOPT's multipliers of the variable bounds (n_w,) and of the constraint
        rows (n_g,) of the scaled NLP (CasADi's signs: > 0 at an active upper bound), or None;
        they belong to the NLP layout :attr:`nlp_signature`. A guess from this Solution on an
        OCP with the same layout also warm-starts IPOPT's multipliers (see
        :func:`planner.solver.solve`, ``warm_start``).
    phase : the index of this phase in the NLP (0 for a single OCP).
    """

    def __init__(
        self,
        transcription,
        w: np.ndarray,
        cost: float,
        status: str,
        success: bool,
        stats: dict[str, Any],
        lam_g: np.ndarray | None = None,
        lam_x: np.ndarray | None = None,
        phase: int = 0,
    ) -> None:
        self.transcription = transcription
        self.phase = phase
        #: This phase's transcription (planner.phase_transcription.PhaseTranscription).
        self.block = block = transcription.phases[phase]
        self.ocp = block.ocp
        values = transcription.unpack(w, phase)
        # The dynamics with the static parameters they read fixed at the solution's values:
        # the interpolants, accuracy estimates and replays integrate that system.
        self.system = block.system.bind(values["P"])
        self.scheme = block.scheme
        self.mesh = block.mesh
        self.w = np.asarray(w, dtype=float).copy()
        self.cost = float(cost)
        self.status = status
        self.success = bool(success)
        self.stats = stats
        self.lam_g = None if lam_g is None else np.asarray(lam_g, dtype=float).reshape(-1).copy()
        self.lam_x = None if lam_x is None else np.asarray(lam_x, dtype=float).reshape(-1).copy()
        self.T = float(values["T"])
        self.state_values = values["X"]
        self.control_values = values["U"]
        self.aux_values = values["Z"]
        #: The static parameters' values, name -> value (``OCP.param``).
        self.params = values["P"]
        self.state_time = self.mesh.s_state * self.T
        self.point_time = self.mesh.s_dyn * self.T
        self.rate_values = self._rates()
        #: Interval integrators by (rtol, atol), built on first use.
        self._integrators: dict[tuple[float, float], Simulator] = {}

    @cached_property
    def cost_terms(self) -> dict[str, float]:
        """Each objective term's value at the solution, name -> value (``OCP.minimize``'s
        ``name``); they add up to ``cost`` (a phase of several: this phase's terms)."""
        terms = self.transcription.cost_terms(self.w)
        if len(self.transcription.phases) == 1:
            return terms
        prefix = f"{self.transcription.problem.names[self.phase]}: "
        return {k[len(prefix) :]: v for k, v in terms.items() if k.startswith(prefix)}

    # ---- basic views -----------------------------------------------------------------
    @property
    def N(self) -> int:
        return self.ocp.N

    @property
    def duration(self) -> float:
        """The horizon T, s (what a guess from this solution spans)."""
        return float(self.T)

    @property
    def h(self) -> float:
        """The interval length of a uniform mesh, T / N, s (see :attr:`interval_lengths`)."""
        if not self.mesh.uniform:
            raise DefinitionError(
                "`h`: the mesh is not uniform; read interval_lengths (N,) instead"
            )
        return self.T / self.N

    @property
    def interval_lengths(self) -> np.ndarray:
        """(N,) interval lengths h_k, s (T / N each on a uniform mesh)."""
        return (self.T / self.N) * self.mesh.relative

    @property
    def nlp_signature(self) -> str:
        """The structure of the NLP that ``w``, ``lam_x`` and ``lam_g`` belong to
        (:attr:`planner.transcription.Transcription.signature`)."""
        return self.transcription.signature

    @property
    def iterations(self) -> int:
        return int(self.stats.get("iterations", 0))

    @property
    def transcription_name(self) -> str:
        return self.scheme.name

    @property
    def degree(self) -> int | None:
        return self.scheme.degree

    @property
    def formulation(self) -> str:
        return self.system.formulation

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.system.state_names

    @property
    def control_names(self) -> tuple[str, ...]:
        return self.system.control_names

    @property
    def time(self) -> np.ndarray:
        """(N+1,) node times, s."""
        if self.mesh.uniform:
            return np.arange(self.N + 1) * (self.T / self.N)
        return self.mesh.breaks * self.T

    @property
    def states(self) -> np.ndarray:
        """(N+1, nx) states at the nodes (NLP variables)."""
        return self.state_values[self.mesh.node_state_cols]

    @property
    def controls(self) -> np.ndarray:
        """(N+1, nu) controls at the nodes, from the interpolant (right-continuous; for Radau
        left-continuous, so a node's control is the NLP variable of the interval ending there)."""
        return self.control(self.time)

    @property
    def drives(self) -> np.ndarray:
        """(N+1, n) the drives at the nodes (the system's ``drives`` group of controls: a
        linkage's hinge torques, N m, without the contact forces that may follow them)."""
        self._require_role("drives", "drives")
        columns = [self.system.control_names.index(n) for n in self.system.role_names("drives")]
        return self.controls[:, columns]

    @property
    def accelerations(self) -> np.ndarray | None:
        """(N+1, n) second derivatives of the positions at the nodes (the system's
        ``accelerations``: a linkage's angular accelerations, rad/s^2), or None."""
        if self.system.accelerations is None:
            return None
        return self.acceleration(self.time)

    def _require_role(self, role: str, what: str) -> None:
        if getattr(self.system, role) is None:
            raise DefinitionError(
                f"`{what}`: defined for a system with the role {role!r} only (a linkage's "
                "hinge torques); this system has none"
            )

    def _rates(self) -> np.ndarray:
        """(nC, nx) f(x, z, u, t) at the dynamics points, through the NLP's own point Function."""
        mapped = self.block.point_function.map(self.mesh.n_dyn_points)
        x = self.state_values[self.mesh.dyn_state_cols].T
        u = self.control_values.T
        z = self.aux_values.T if self.system.nz else np.zeros((0, x.shape[1]))
        times = self.point_time[None, :]
        # By name: the control-rate input, when there is one, does not change the rates.
        params = np.array([self.params[p.name] for p in self.ocp.params]).reshape(-1, 1)
        rate = mapped(
            x=x,
            u=u,
            z=z,
            t=times,
            T=np.full_like(times, self.T),
            params=np.repeat(params, times.size, axis=1),
        )["f"]
        return np.asarray(rate).T

    # ---- interpolation ---------------------------------------------------------------
    def _locate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if np.any(~np.isfinite(t)):
            raise DefinitionError("`t`: must be finite times in s")
        span = 1e-9 * max(self.T, 1.0)
        if np.any(t < -span) or np.any(t > self.T + span):
            raise DefinitionError(
                f"`t`: times must lie in [0, T] = [0, {self.T:g}] s, got [{t.min():g}, {t.max():g}]"
            )
        k, tau = self.mesh.locate(np.clip(t / self.T, 0.0, 1.0))
        return t, k, tau

    def state(self, t, derivative: int = 0) -> np.ndarray:
        """States (or their ``derivative``-th time derivative) at times t: (K, nx).

        Uses exactly the transcription's state polynomial of the interval containing t.
        """
        _, k, tau = self._locate(t)
        h = self._lengths(k)
        wx, wf = self.scheme.state_weights(tau, derivative)
        value = self._weighted(wx, self.state_values, self.mesh.state_cols[k])
        value += h * self._weighted(wf, self.rate_values, self.mesh.dyn_cols[k])
        return value / h**derivative

    def _lengths(self, k: np.ndarray) -> np.ndarray:
        """(K, 1) lengths h_k, s, of the intervals ``k`` (K,)."""
        return (self.T / self.N * self.mesh.relative[k])[:, None]

    @staticmethod
    def _weighted(weights: np.ndarray, values: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """(K, n): sum_j weights[i, j] values[columns[i, j]] for every sample i: each sample's
        interval polynomial at once (weights (K, J), values (points, n), columns (K, J))."""
        return np.einsum("kj,kjn->kn", weights, values[columns])

    def _point_values(self, values: np.ndarray, t, derivative: int = 0) -> np.ndarray:
        _, k, tau = self._locate(t)
        weights = self.scheme.control_weights(tau, derivative)
        return (
            self._weighted(weights, values, self.mesh.dyn_cols[k]) / self._lengths(k) ** derivative
        )

    def control(self, t) -> np.ndarray:
        """Controls at times t, (K, nu): the transcription's control polynomial."""
        return self._point_values(self.control_values, t)

    def control_rate(self, t) -> np.ndarray:
        """Control rates du/dt at times t, (K, nu), control units per second: the time
        derivative of the transcription's control polynomial of the interval holding t (the
        value ``p.du`` of a constraint or cost had there; one-sided at nodes, see
        :meth:`planner.ocp.OCP.constrain`)."""
        return self._point_values(self.control_values, t, derivative=1)

    def aux(self, t) -> np.ndarray:
        """Auxiliary variables z (implicit: ddpsi) at times t, (K, nz)."""
        return self._point_values(self.aux_values, t)

    def acceleration(self, t) -> np.ndarray:
        """The system's ``accelerations`` at times t, (K, n) (a linkage's ddpsi, rad/s^2): the
        NLP's polynomial of those variables (implicit), or the derived field evaluated on
        the interpolated states and controls (explicit: a linkage's forward dynamics, with
        the moments of contact forces when there are any)."""
        self._require_role("accelerations", "acceleration")
        return self._field(self.system.accelerations, t)

    def _field(self, group: str, t) -> np.ndarray:
        """(K, m) values of a group of auxiliary variables or of a derived field at times t."""
        s = self.system
        members = s.group(group)
        if members is not None and all(name in s.aux_names for name in members):
            return self.aux(t)[:, [s.aux_names.index(name) for name in members]]
        derived = s.derived_field(group)
        times = np.atleast_1d(np.asarray(t, dtype=float))
        x, u = self.state(times), self.control(times)
        z = self.aux(times) if s.nz else np.zeros((times.size, 0))
        values = derived.function.map(times.size)(x.T, z.T, u.T, times[None, :])
        return np.asarray(values).T

    def motion(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The solution as a consistent motion at times t: (x (K, nx), xdot (K, nx), u (K, nu)).

        For a system with ``positions``, ``velocities`` and ``drives_for_motion`` (a linkage):

        * velocities v(t): the transcription's own polynomial of the velocity states (on the
          trapezoid a quartic through the same values and slopes, whose integral is the
          trapezoid's position defect: ``Scheme.motion_weights``);
        * accelerations a(t) = dv/dt, its derivative (at the dynamics points: the NLP's
          accelerations; between them the polynomial's own slope);
        * positions q(t) = q_k + integral of v from the interval's start node t_k: the
          antiderivative of the velocity polynomial, restarted at every node. It meets the
          next node's position to the solver's tolerance on the position defects (each
          scheme's position defect is the exact integral of this velocity polynomial);
        * drives (u's ``drives`` group) = ``drives_for_motion``(x, a, u): the torques that
          make exactly this motion with the other controls (contact forces) of the
          transcription's control polynomial.

        So dq/dt = v, dv/dt = a and the equations of motion hold at every t to round-off, not
        only at the collocation points; positions differ from the transcription's own state
        polynomial by the collocation error, drives from its control polynomial likewise
        (``Solution.state``, ``Solution.control`` keep the transcription's polynomials).
        xdot holds (v, a) in the rows of (positions, velocities) and the state polynomial's
        derivative in the rows of any other state. Raises DefinitionError for a system
        without these roles.
        """
        s = self.system
        if not s.has_motion:
            raise DefinitionError(
                "`motion`: the system has no positions, velocities and drives_for_motion "
                "(a linkage's psi, dpsi and inverse dynamics); use state(t) and control(t)"
            )
        times, k, tau = self._locate(t)
        x = self.state(times)
        xdot = self.state(times, derivative=1)
        u = self.control(times)
        positions = [s.state_names.index(name) for name in s.group(s.positions)]
        velocities = [s.state_names.index(name) for name in s.group(s.velocities)]
        mesh = self.mesh
        nodes = self.state_values[mesh.node_state_cols]
        h = self._lengths(k)
        v = self.state_values[:, velocities]
        a = self.rate_values[:, velocities]
        end = tau[:, None] == 1.0
        for derivative, target, columns, factor in (
            (-1, x, positions, h),  # q = q_k + h (integral of v over [0, tau])
            (0, x, velocities, 1.0),
            (1, xdot, velocities, 1.0 / h),  # a = dv/dtau / h
        ):
            wx, wf = self.scheme.motion_weights(tau, derivative)
            value = self._weighted(wx, v, mesh.state_cols[k])
            value = factor * (value + h * self._weighted(wf, a, mesh.dyn_cols[k]))
            if derivative == -1:
                value = value + nodes[k][:, positions]
            if derivative < 1:
                # The node's own value at the interval's end (the polynomials meet it to
                # the defect tolerance): node samples are the NLP's states bit for bit.
                value = np.where(end, nodes[k + 1][:, columns], value)
            target[:, columns] = value
        xdot[:, positions] = x[:, velocities]
        drives = [s.control_names.index(name) for name in s.role_names("drives")]
        values = s.drives_for_motion.map(times.size)(x.T, xdot[:, velocities].T, u.T)
        u[:, drives] = np.asarray(values).T
        return x, xdot, u

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(states (K, nx), controls (K, nu)) at times t through the transcription's polynomials."""
        return self.state(t), self.control(t)

    def value(self, name: str, t) -> np.ndarray:
        """One variable by name at times t, (K,)."""
        s = self.system
        if name in s.state_names:
            return self.state(t)[:, s.state_names.index(name)]
        if name in s.control_names:
            return self.control(t)[:, s.control_names.index(name)]
        if name in s.aux_names:
            return self.aux(t)[:, s.aux_names.index(name)]
        raise DefinitionError(f"`name`: unknown variable {name!r}; known: {s.variable_names}")

    def interpolate_guess(self, s: np.ndarray) -> dict[str, np.ndarray]:
        """Every variable at normalised times s = t / T (a warm start for another mesh)."""
        t = np.asarray(s, dtype=float) * self.T
        out = {}
        states, controls = self(t)
        out.update({n: states[:, i] for i, n in enumerate(self.system.state_names)})
        out.update({n: controls[:, i] for i, n in enumerate(self.system.control_names)})
        out.update(self._extras(t))
        return out

    def _extras(self, t) -> dict[str, np.ndarray]:
        """name -> (K,) at times t: the auxiliary variables and the derived
        ``accelerations`` (explicit), the channels a trajectory stores besides the states
        and the drives (and what a guess on another mesh or formulation needs)."""
        s = self.system
        out = {}
        if s.nz:
            aux = self.aux(t)
            out.update({n: aux[:, i] for i, n in enumerate(s.aux_names)})
        if s.accelerations is not None and s.group(s.accelerations) is None:
            values = self._field(s.accelerations, t)
            out.update({n: values[:, i] for i, n in enumerate(s.role_names("accelerations"))})
        return out

    # ---- accuracy ----------------------------------------------------------------------
    @property
    def _implicit_only(self) -> bool:
        """The dynamics are a residual r(x, xdot, u, t) = 0 with no explicit ODE (generic)."""
        return self.system.ode is None

    @cached_property
    def _rate_rank(self) -> int:
        """Structural rank of dr/dxdot of a generic implicit residual."""
        s = self.system
        z = ca.SX.sym("z", s.nz)
        x, u, t = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("t")
        return ca.sprank(ca.jacobian(s.residual(x, z, u, t), z))

    def _require_rate(self, what: str) -> None:
        """A generic implicit residual must determine xdot: dr/dxdot structurally regular."""
        if not self._implicit_only:
            return
        rank, nz = self._rate_rank, self.system.nz
        if rank < nz:
            raise DefinitionError(
                f"`{what}`: the implicit residual r(x, xdot, u, t) does not determine xdot "
                f"(dr/dxdot has structural rank {rank} < {nz}), so the dynamics cannot be "
                "re-integrated or solved for xdot; give an ODE f(x, u[, t]) or an index-1 "
                "residual"
            )

    def _interval_integrator(self, rtol, atol, what: str) -> Simulator:
        """The :class:`planner.simulation.Simulator` of one mesh interval with the
        transcription's control polynomial, built once per tolerance pair.

        An explicit ODE integrates with CVODES. A generic implicit residual r(x, xdot, u, t)
        integrates as the semi-explicit index-1 DAE dx/dt = z, 0 = r(x, z, u, t) with IDAS
        (z = xdot algebraic, made consistent at each interval's start from a guess); r must
        determine xdot (dr/dxdot nonsingular), as it must for the OCP to be well posed.
        """
        key = (check_tolerance("rtol", rtol), check_tolerance("atol", atol))
        self._require_rate(what)
        if key in self._integrators:
            return self._integrators[key]
        s = self.system
        degree = self.scheme.ndc - 1  # the polynomial through the interval's dynamics points
        if self._implicit_only:
            simulator = Simulator(
                s.rate, s.residual, degree=degree, method="idas", rtol=key[0], atol=key[1]
            )
        else:
            x, z, u, t = (
                ca.SX.sym("x", s.nx),
                ca.SX.sym("z", 0),
                ca.SX.sym("u", s.nu),
                ca.SX.sym("t"),
            )
            ode = ca.Function("ode", [x, z, u, t], [s.ode(x, u, t)], ["x", "z", "u", "t"], ["xdot"])
            simulator = Simulator(ode, degree=degree, method="cvodes", rtol=key[0], atol=key[1])
        self._integrators[key] = simulator
        return simulator

    def _reintegration_failure(self, error: SimulationError, where: str) -> SimulationError:
        """The simulator's error in the words of a re-integration of this solution."""
        flag = error.flag or str(error)
        if self._implicit_only:
            message = (
                f"re-integration of the implicit residual failed (IDAS, {flag}) {where}: "
                "the residual r(x, xdot, u, t) must determine xdot (dr/dxdot nonsingular "
                "along the solution)"
            )
        else:
            message = (
                f"re-integration of the ODE failed (CVODES, {flag}) {where}: the interpolated "
                "motion diverges or is too stiff for rtol/atol; loosen them, or check the "
                "solution (its status, a finer mesh)"
            )
        return SimulationError(
            message,
            method=error.method,
            interval=error.interval,
            flag=error.flag,
            details=error.details,
            index=error.index,
        )

    def _interval_start_rates(self) -> np.ndarray:
        """(nz, N) guesses of xdot at each interval's start: its own aux polynomial at tau = 0
        (the DAE integrator makes them consistent)."""
        weights = self.scheme.control_weights([0.0])[0]  # (ndc,)
        return np.einsum("c,kcn->nk", weights, self.aux_values[self.mesh.dyn_cols])

    @cached_property
    def _newton(self) -> ca.Function:
        """xdot from r(x, xdot, u, t) = 0 by Newton's method: (guess, [x; u; t]) -> xdot."""
        s = self.system
        xs, us, ts = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("t")
        z = ca.SX.sym("z", s.nz)
        parameters = ca.vertcat(xs, us, ts)
        residual = ca.Function("r", [z, parameters], [s.residual(xs, z, us, ts)])
        return ca.rootfinder("xdot", "newton", residual, {"abstol": 1e-13, "max_iter": 100})

    def _rates_at(self, x: np.ndarray, u: np.ndarray, t: np.ndarray, guess: np.ndarray):
        """(K, nx) xdot = f(x, u, t) at K points: the ODE, or for a generic implicit residual
        the root of r(x, xdot, u, t) = 0 by Newton's method from ``guess`` (K, nx)."""
        s = self.system
        K = t.size
        if not self._implicit_only:
            return np.asarray(s.ode.map(K)(x.T, u.T, t[None, :])).T
        self._require_rate("residual_error")
        failed = (
            "solving the implicit residual r(x, xdot, u, t) = 0 for xdot failed (Newton from "
            "the interpolant's slope)"
        )
        advice = "the residual must determine xdot (dr/dxdot nonsingular along the solution)"
        try:
            z_root = np.asarray(self._newton.map(K)(guess.T, np.vstack([x.T, u.T, t[None, :]])))
        except RuntimeError as exc:
            raise AnthropoidError(f"{failed}: {advice}; {exc}") from exc
        bad = np.flatnonzero(~np.all(np.isfinite(z_root), axis=0))
        if bad.size:  # Newton reports success on a NaN iterate (casadi 3.8): check the root
            raise AnthropoidError(
                f"{failed}: the root is NaN or inf at t = {t[bad[0]]:.6g} s ({bad.size} of {K} "
                f"points); {advice}"
            )
        rate = s.rate.map(K)(x.T, z_root, u.T, t[None, :])
        return np.asarray(rate).T

    def _interval_coefficients(self) -> np.ndarray:
        """(N, nu, ndc) monomial coefficients in tau of each interval's control polynomial."""
        values = self.control_values[self.mesh.dyn_cols]  # (N, ndc, nu)
        return monomial_coefficients(self.scheme.interval_dyn_tau, values)

    def integration_error(self, rtol: float = 1e-12, atol: float = 1e-12) -> IntegrationError:
        """Re-integrate every interval from its start node with the interpolated controls.

        Returns the (N, nx) absolute difference from the end nodes (state units).
        """
        simulator = self._interval_integrator(rtol, atol, "integration_error")
        nodes = self.states
        z0 = self._interval_start_rates().T if self._implicit_only else None
        parameters = simulator.parameters(
            self.time[:-1], self.interval_lengths, self._interval_coefficients()
        )
        try:
            run = simulator.across(nodes[:-1], parameters, z0)
        except SimulationError as error:
            where = f"on one of the {self.N} intervals"
            if error.index is not None:
                k = error.index
                where += f" (first: {k}, t = {self.time[k]:.6g} .. {self.time[k + 1]:.6g} s)"
            raise self._reintegration_failure(error, where) from error
        return IntegrationError(np.abs(run.states - nodes[1:]), self.system.state_names)

    def residual_error(self, points: int = RESIDUAL_QUADRATURE_POINTS) -> IntegrationError:
        """Integral over each interval of |f(x(t), u(t), t) - dx/dt(t)| along the interpolant.

        (N, nx), state units; Gauss-Legendre quadrature with ``points`` points per interval.
        """
        tau, weights = gauss_legendre(points)
        h = self.interval_lengths
        t = (self.time[:-1, None] + tau[None, :] * h[:, None]).reshape(-1)
        # Points never hit a node, so the interval of each is unambiguous.
        x = self.state(t)
        dx = self.state(t, derivative=1)
        u = self.control(t)
        f = self._rates_at(x, u, t, dx)
        gap = np.abs(f - dx).reshape(self.N, points, -1)
        return IntegrationError(
            h[:, None] * np.einsum("p,kpn->kn", weights, gap), self.system.state_names
        )

    def replay(self, rtol: float = 1e-10, atol: float = 1e-10, x0=None) -> Replay:
        """Integrate the whole horizon open loop from x(0) (or ``x0`` (nx,), e.g. the state
        another phase ended in) with the interpolated controls.

        A stability probe, not an accuracy measure: the deviation grows with the motion's
        own instability (for an unstable gait it is large however accurate the solution).
        """
        simulator = self._interval_integrator(rtol, atol, "replay")
        z0 = self._interval_start_rates().T if self._implicit_only else None
        try:
            # Restarted at every node, as the per-interval re-integration: the replay's first
            # interval is the first re-integration.
            start = self.states[0] if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
            if start.shape != (self.system.nx,):
                raise DefinitionError(
                    f"`x0`: must be a state of {self.system.nx} entries, got shape {start.shape}"
                )
            run = simulator.along(start, self.time, self._interval_coefficients(), z0, restart=True)
        except SimulationError as error:
            k = error.index
            where = (
                "on one of the intervals"
                if k is None
                else f"on interval {k} (t = {self.time[k]:.6g} .. {self.time[k + 1]:.6g} s)"
            )
            raise self._reintegration_failure(error, where) from error
        return Replay(self.time, run.states, run.states - self.states)

    # ---- export ------------------------------------------------------------------------
    @property
    def metadata(self) -> dict[str, Any]:
        """JSON-serialisable description: model, mesh, status, cost, package versions."""

        def version(package: str) -> str:
            try:
                return importlib.metadata.version(package)
            except importlib.metadata.PackageNotFoundError:
                return "unknown"

        system = self.system
        return {
            "source": "planner",
            "model": None if system.model is None else dict(system.model),
            "transcription": self.scheme.name,
            "degree": self.scheme.degree,
            "N": self.N,
            "T": self.T,
            "formulation": system.formulation,
            "status": self.status,
            "success": self.success,
            "cost": self.cost,
            "iterations": self.iterations,
            "versions": {
                "casadi": ca.__version__,
                "numpy": np.__version__,
                "anthropoid-planner": version("anthropoid-planner"),
            },
        }

    def sample_times(self, rate_hz: float | None = None) -> np.ndarray:
        """The nodes (rate_hz None) or :func:`uniform_times` of the duration T."""
        if rate_hz is None:
            return self.time
        return uniform_times(self.T, rate_hz)

    def to_trajectory(self, rate_hz: float | None = None, motion: str | None = None):
        """The solution as a :class:`planner.trajectory.Trajectory`.

        At the nodes (``rate_hz`` None) or sampled at ``rate_hz``, in the system's names: its
        drives as the controls, the other controls, the auxiliary variables and the
        accelerations as extras (a linkage: psi_, dpsi_ states, M_ controls, ddpsi_ and
        contact-force extras).

        ``motion``: ``"consistent"`` (the default when the system offers it, a linkage: the
        samples of :meth:`motion`, whose positions, velocities, accelerations and drives obey
        the kinematics and the equations of motion at every sample to round-off; what a
        drive controller needs) or ``"transcription"`` (the transcription's own polynomials,
        :meth:`state`, :meth:`control`, :meth:`acceleration`: consistent at the collocation
        points only; the default for other systems). ``metadata["motion"]`` says which.
        """
        s = self.system
        if motion is None:
            motion = "consistent" if s.has_motion else "transcription"
        if motion not in MOTIONS:
            raise DefinitionError(f"`motion`: must be one of {MOTIONS}, got {motion!r}")
        times = self.sample_times(rate_hz)
        if motion == "consistent":
            states, rates, controls = self.motion(times)
        else:
            states, controls = self(times)
        # The drives are the trajectory's controls; the other controls (a linkage's contact
        # forces) and the auxiliary and derived channels are its extras.
        drives = s.role_names("drives") if s.drives is not None else s.control_names
        columns = [s.control_names.index(name) for name in drives]
        units = dict(zip(s.control_names, s.control_units, strict=True))
        units.update(zip(s.aux_names, s.aux_units, strict=True))
        for derived in s.derived:
            units.update(zip(derived.names, derived.units, strict=True))
        values = self._extras(times)
        values.update({n: controls[:, i] for i, n in enumerate(s.control_names) if n not in drives})
        if motion == "consistent":  # the accelerations are the velocity polynomial's slope
            velocities = [s.state_names.index(name) for name in s.group(s.velocities)]
            for name, column in zip(s.role_names("accelerations"), velocities, strict=True):
                values[name] = rates[:, column]
        return s.trajectory_type(
            times,
            states,
            controls[:, columns],
            s.state_names,
            s.state_units,
            tuple(drives),
            tuple(units[n] for n in drives),
            {name: (value, units[name]) for name, value in values.items()},
            {**self.metadata, "motion": motion},
        )

    def save(self, path, rate_hz: float | None = None, motion: str | None = None):
        """``to_trajectory(rate_hz, motion).save(path)``: format by suffix (.csv, .json,
        .npz). Returns the path written."""
        return self.to_trajectory(rate_hz, motion).save(path)

    def __repr__(self) -> str:
        return (
            f"Solution({self.scheme.label}, N={self.N}, T={self.T:g} s, {self.system.formulation}, "
            f"status={self.status}, cost={self.cost:.6g}, iterations={self.iterations})"
        )
