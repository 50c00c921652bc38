"""Controllers of a planned walking step: the plan as a reference indexed by a phase measured
on the body, open-loop replay, and joint PD feedback around the plan.

A time-indexed reference falls out of step as soon as a heel strike comes early or late (the
issue's MuJoCo measurement: a PD indexed by the time since touchdown walks at most 3 steps),
so the reference here is indexed by the *phase* s, the hip's progress over the stance foot:

    s(psi) = (x_hip(psi) - x_hip(0)) / (x_hip(T) - x_hip(0)),

0 at the step's start and 1 at its planned heel strike, read off the plan's samples, which
must make it strictly increasing (a hip that stops or goes back has no phase). A heel strike
that comes early cuts the reference (the next step starts at s = 0); one that comes late
extends it: for s > 1 the reference state goes on along the plan's last slope dx/ds (the
swing foot keeps coming down to a ground that is lower than planned) and the feedforward
torques hold their last value.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from model.dynamics import Dynamics
from planner.errors import DefinitionError, check_real
from planner.trajectory import Trajectory
from problems.control.buffered import BufferedCalls

#: rad/s: a step that ends at rest (``GaitReference(to_rest=True)``) ends with every rate
#: within this (the stop's plan holds dpsi = 0 at its end to round-off)
REST_RATE = 1e-9


class TimedReference:
    """A plan as tables over time: time (K,) s from 0, states (K, 2n) (psi, dpsi), torques
    (K, n) N m, blended linearly between samples.

    Parameters
    ----------
    trajectory : Trajectory
        The plan's samples (``gait.to_trajectory(rate_hz)``: the consistent motion, whose
        torques are its own inverse dynamics).
    """

    def __init__(self, trajectory: Trajectory) -> None:
        self.time = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
        self.states = np.hstack([trajectory.psi, trajectory.dpsi])
        self.torques = np.asarray(trajectory.torques, dtype=float)
        self.n = self.torques.shape[1]

    @property
    def duration(self) -> float:
        return float(self.time[-1])

    def at_time(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(x_ref (2n,), M_ff (n,)) at t s since the start (clamped to the plan)."""
        return self._blend(self.time, t)

    def _blend(self, grid: np.ndarray, value: float):
        value = min(max(float(value), grid[0]), grid[-1])
        # the interval holding value (plain ints: called several times every control period)
        k = min(max(int(np.searchsorted(grid, value, side="right")) - 1, 0), grid.size - 2)
        w = (value - grid[k]) / (grid[k + 1] - grid[k])
        states = (1.0 - w) * self.states[k] + w * self.states[k + 1]
        torques = (1.0 - w) * self.torques[k] + w * self.torques[k + 1]
        return states, torques


class GaitReference(BufferedCalls, TimedReference):
    """A planned step as tables over time and over the phase.

    Parameters
    ----------
    trajectory : Trajectory
        The step's samples (``gait.to_trajectory(rate_hz)``: the consistent motion, whose
        torques are its own inverse dynamics).
    dynamics : Dynamics
        The plan's model (for the hip's position).
    hip : str
        The link whose end is the hip (the stance thigh).
    hip_range : (float, float) or None
        The hip's x, m, where s = 0 and s = 1 (default: its first and last sample): a part of
        a step (one side of a double support's heel strike) indexed by the whole step's s.
    by_time : bool
        A law follows the plan by the time since the step began while its hip stalls or
        sways back (a start from rest: the hip is still at t = 0 and may sway back), and by
        the phase from where the hip advances for good (:attr:`time_indexed_until`, s); the
        phase table's rows before that point are read only by the time.
    to_rest : bool
        The step ends at rest (a stop at quiet standing): a law follows it by the time since
        it began throughout (its hip sways back and settles: it has no phase to follow;
        :attr:`time_indexed_until` is inf) and holds its last sample, at rest, after its end
        (:meth:`at_time` clamps to the plan). Its last sample must be at rest (every rate 0
        to 1e-9 rad/s), or the hold would be no equilibrium of the plan.
    """

    def __init__(
        self,
        trajectory: Trajectory,
        dynamics: Dynamics,
        hip: str,
        hip_range: tuple[float, float] | None = None,
        by_time: bool = False,
        to_rest: bool = False,
    ) -> None:
        super().__init__(trajectory)
        self.by_time = bool(by_time) or bool(to_rest)
        self.to_rest = bool(to_rest)
        self._hip = dynamics.point(hip)
        hips = np.asarray(self._hip.position(trajectory.psi)).real
        start, end = (hips[0], hips[-1]) if hip_range is None else hip_range
        self._start, self._span = float(start), float(end - start)
        self.phases = (hips - self._start) / self._span if self._span != 0 else hips * 0
        if self.to_rest:
            moving = float(np.abs(self.states[-1, self.n :]).max())
            if not moving <= REST_RATE:
                raise DefinitionError(
                    f"`trajectory`: a step that ends at rest (to_rest) ends with its rates "
                    f"within {REST_RATE:g} rad/s, this one's reach {moving:.3g} rad/s: give "
                    "the stop's samples, or index the step by its phase"
                )
            #: by the time throughout: the phase table is not read
            self.time_indexed_until = float("inf")
            return
        stalls = np.flatnonzero(np.diff(self.phases) <= 0.0)
        #: s since the start up to which a law by the time follows the plan by the time: where
        #: the hip moves forward for good (0 when it always does)
        self.time_indexed_until = 0.0
        if self.by_time and stalls.size and stalls[-1] + 1 < self.phases.size - 1:
            # by the time while the hip stalls or sways, by the phase once it advances for
            # good; the table's rows before that point get phases just below it (read only
            # by the time), so the phase table stays increasing
            switch = int(stalls[-1]) + 1
            self.time_indexed_until = float(self.time[switch])
            self.phases = self.phases.copy()
            below = np.arange(switch, 0, -1) * 1e-12 * max(1.0, abs(self.phases[switch]))
            self.phases[:switch] = self.phases[switch] - below
            stalls = stalls[:0]
        if self._span <= 0 or stalls.size:
            where = f"at t = {self.time[stalls[0]]:.3f} s" if stalls.size else "over the step"
            raise DefinitionError(
                f"`trajectory`: the hip does not move forward {where}; the phase (the hip's "
                "progress over the stance foot) indexes only a step whose hip always advances"
            )

    @classmethod
    def of(cls, gait, rate_hz: float = 1000.0) -> GaitReference:
        """The reference of a solved :class:`problems.walking.step.WalkingGait` at ``rate_hz``."""
        problem = gait.problem
        return cls(gait.to_trajectory(rate_hz), problem.dynamics, problem.biped.stance_thigh)

    @classmethod
    def branches(cls, gait, rate_hz: float = 1000.0) -> tuple[GaitReference, GaitReference]:
        """The two references of a step with a double support: the single support up to the
        heel strike (its last sample the state before the impact) and the double support
        after it, each from its own phase's consistent motion sampled at ``rate_hz`` from its
        start, both indexed by the whole step's phase (s = 1 where the rear foot lifts)."""
        problem = gait.problem
        (single, _), (double, _) = gait.segments()
        parts = [single.to_trajectory(rate_hz), double.to_trajectory(rate_hz)]
        hip = problem.dynamics.point(problem.biped.stance_thigh)
        ends = (complex(hip.position(parts[0].psi[0])).real,
                complex(hip.position(parts[1].psi[-1])).real)  # fmt: skip
        return tuple(
            cls(part, problem.dynamics, problem.biped.stance_thigh, hip_range=ends)
            for part in parts
        )

    @property
    def hip_range(self) -> tuple[float, float]:
        """The hip's x over the stance foot, m, where s = 0 and s = 1."""
        return self._start, self._start + self._span

    def phase(self, psi) -> float:
        """s of the angles psi (n,): the hip's progress, 0 at the start, 1 at heel strike
        (or where the rear foot lifts, after a double support)."""
        # through the position function's evaluation buffer: called every control period
        hip = self._buffered("hip", lambda: self._hip.function("position"))
        return float((hip(psi)[0][0] - self._start) / self._span)

    def at_phase(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(x_ref (2n,), M_ff (n,)) at the phase s: the plan for s in [0, 1], its start before
        0, its last slope after 1 (module docstring)."""
        if s > self.phases[-1]:
            states, torques = self._blend(self.phases, self.phases[-1])
            return states + (s - self.phases[-1]) * self._end_slope, torques
        return self._blend(self.phases, s)

    def phase_gradient(self, psi) -> np.ndarray:
        """ds/dpsi (n,): the hip's forward Jacobian over the step's span."""
        return self._buffered("hip_jacobian", self._hip_x_jacobian)(psi)[0] / self._span

    def _hip_x_jacobian(self) -> ca.Function:
        """psi -> d x_hip / dpsi (n,): the hip's x row over the angles (not the base's
        columns), dense for the evaluation buffer."""
        angles = ca.SX.sym("psi", self.n)
        row = ca.densify(self._hip.function("jacobian")(angles)[0, 2:])
        return ca.Function("hip_x_jacobian", [angles], [row])

    @property
    def _end_slope(self) -> np.ndarray:
        return (self.states[-1] - self.states[-2]) / (self.phases[-1] - self.phases[-2])

    def slopes_at_phase(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(dx_ref/ds (2n,), dM_ff/ds (n,)) of :meth:`at_phase` at s."""
        grid = self.phases
        if s >= grid[-1]:
            return self._end_slope, np.zeros(self.n)
        if s <= grid[0]:
            return np.zeros(2 * self.n), np.zeros(self.n)
        k = int(np.clip(np.searchsorted(grid, s, side="right") - 1, 0, grid.size - 2))
        width = grid[k + 1] - grid[k]
        return (
            (self.states[k + 1] - self.states[k]) / width,
            (self.torques[k + 1] - self.torques[k]) / width,
        )

    def tracking(self, x, t: float | None = None) -> float:
        """The largest |psi - psi_ref| at the phase of x, rad; at the time ``t`` s since the
        step began instead while a law follows it by the time (t below
        :attr:`time_indexed_until`: a start from rest, a stop to rest)."""
        psi = np.asarray(x[: self.n])
        if t is not None and t < self.time_indexed_until:
            reference, _ = self.at_time(t)
        else:
            reference, _ = self.at_phase(self.phase(psi))
        return float(np.abs(psi - reference[: self.n]).max())


class OpenLoop:
    """The plan's torques by the time since the step's start: no feedback."""

    def __init__(self, reference: GaitReference) -> None:
        self.reference = reference

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        return self.reference.at_time(t)[1]

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """dM/dx (n, 2n): zero, the torques do not read the state."""
        return np.zeros((self.reference.n, 2 * self.reference.n))


class PhasePD:
    """Feedforward plus PD on the relative joint angles, all indexed by the phase:

        M = M_ff(s) + Kp (q_ref(s) - q) + Kd (dq_ref(s) - dq),   s = s(psi),

    (by the time t given to :meth:`torques` instead while t is below the reference's
    ``time_indexed_until``: a start from rest, ``GaitReference(by_time=True)``), with q the
    hinge's relative angle (psi_i - psi_parent(i); the stance ankle's is psi_1 from the
    ground), which each drive measures and on which its torque acts.

    kp N m/rad, kd N m s/rad: scalars or (n,) per hinge; ``passive``: hinge indices with no
    drive (their torque is 0).
    """

    def __init__(self, reference: GaitReference, parents, kp, kd, passive=()) -> None:
        self.reference = reference
        n = reference.n
        self.kp = _gains("kp", kp, n)
        self.kd = _gains("kd", kd, n)
        self._parents = np.asarray(parents)
        self._has_parent = self._parents >= 0
        self._active = np.ones(n)
        self._active[list(passive)] = 0.0
        # R: the relative angles of the absolute ones, q = R psi
        self._relative_matrix = np.eye(n)
        for i, p in enumerate(self._parents):
            if p >= 0:
                self._relative_matrix[i, p] -= 1.0

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    @property
    def relative_matrix(self) -> np.ndarray:
        """R (n, n): the hinges' relative angles of the absolute ones, q = R psi."""
        return self._relative_matrix.copy()

    def relative(self, angles: np.ndarray) -> np.ndarray:
        out = angles.copy()
        out[self._has_parent] -= angles[self._parents[self._has_parent]]
        return out

    def torques(self, t: float, x: np.ndarray, share: float = 1.0) -> np.ndarray:
        """M (n,) N m at state x; ``share``: the PD's part (1: the law; 0: the feedforward
        alone, see ``SwitchedLQR``'s settle)."""
        n = self.reference.n
        if t < self.reference.time_indexed_until:  # t: s since the step began
            state, feedforward = self.reference.at_time(t)
        else:
            state, feedforward = self.reference.at_phase(self.reference.phase(x[:n]))
        error = state - x
        feedback = self.kp * self.relative(error[:n]) + self.kd * self.relative(error[n:])
        return self._active * (feedforward + share * feedback)

    def jacobian(self, t: float, x: np.ndarray, share: float = 1.0) -> np.ndarray:
        """dM/dx (n, 2n) of :meth:`torques` (within a sample interval of the phase table)."""
        reference = self.reference
        n = reference.n
        relative = self._relative_matrix
        jacobian = -share * np.hstack([self.kp[:, None] * relative, self.kd[:, None] * relative])
        if t < reference.time_indexed_until:  # the reference does not read the state
            return self._active[:, None] * jacobian
        s = reference.phase(x[:n])
        state_slope, torque_slope = reference.slopes_at_phase(s)
        along = torque_slope + share * (
            self.kp * (relative @ state_slope[:n]) + self.kd * (relative @ state_slope[n:])
        )
        jacobian[:, :n] += np.outer(along, reference.phase_gradient(x[:n]))
        return self._active[:, None] * jacobian


def _gains(name: str, value, n: int) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    for i, v in enumerate(array):
        if check_real(f"{name}[{i}]", v) < 0:
            raise DefinitionError(f"`{name}`: gains must be >= 0, got {v!r} at hinge {i}")
    return array


__all__ = ["GaitReference", "OpenLoop", "PhasePD", "TimedReference"]
