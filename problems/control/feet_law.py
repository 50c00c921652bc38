"""The drives' law of the step on feet (:class:`problems.walking.footed.FootedGait`), as a
drive runs it from the torque file: each of the seven hinge drives (the stance foot's ground
torque is no drive: the ground gives it) applies

    M = clip(M_ff(s) + kp (q_ref(s) - q) + kd (dq_ref(s) - dq), -limit, limit),

with q each hinge's angle relative to its parent (what its encoder reads) and s the hip's
progress over the stance ball (:class:`problems.control.tracking.GaitReference`), so that an
early or late heel strike re-indexes the plan instead of running out of step. The plan has
two branches, the single support (its phases joined: flat foot and heel rise in the human
cycle, up to the strike) and the double support, both indexed by the whole step's s: the law
switches to the second when the swing foot's striking point (its heel; its ball in toe
walking) touches the ground past half the step, and the legs swap (the plan's labels follow
the new stance foot) when s reaches 1, where the plan's rear foot leaves.

A stop at quiet standing (``step.stop``: one flat phase, the swing foot set down beside the
stance foot at rest) has one branch and no phase (its hip sways back and settles): the law
follows it by the time since it began, blends its gains over its last :data:`STAND_RAMP` s
into standing's (:func:`standing_gains`: the stance ankle also damps the whole body's sway),
and after its end holds its last sample, both feet on the ground.

In the file (:meth:`FeetLaw.channels`) the law is the point-foot feedback's form,
M = clip(M_ff(s) + K(s) (x_ref(s) - x)): K = [kp R, kd R] (n, 2n) with R the relative angles
of the absolute ones (q = R psi), one K per branch, in the columns ``K_<hinge>__<state>``.

Why joint PD and not the point-foot step's periodic LQR: a foot lying flat makes the body
fully actuated through most of the step (seven drives for seven angles), so joint feedback
holds it on the plan; the LQR's linearisation through the feet's four contact modes is open
work. The gains over which the step walks in MuJoCo are measured, not assumed
(``examples/benchmarks/feet_mujoco.py``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError, check_positive, check_real
from planner.trajectory import Trajectory
from problems.control.feedback import LAW, limit_metadata, with_gains
from problems.control.mujoco import TOUCHDOWN_FORCE
from problems.control.tracking import GaitReference, PhasePD

#: the hinge drives' PD gains, N m/rad and N m s/rad, and the bandwidth, rad/s, that caps them
#: on light links (:func:`hinge_gains`): chosen from the sweep of
#: examples/benchmarks/feet_mujoco.py (the default step on feet in MuJoCo)
FEET_KP = 1000.0
FEET_KD = 30.0
FEET_BANDWIDTH = 50.0
#: (kp, kd, bandwidth) per contact sequence where they differ from the above: toe walking
#: falls in its seventh step at 1000 / 30 / 50 and walks 50 at 1000 / 50 / 70 (the toe
#: walker's sweep in examples/benchmarks/feet_mujoco.py: its light feet and 30 ms double
#: support want more damping)
SEQUENCE_GAINS = {"toe-walking": (1000.0, 50.0, 70.0)}
#: standing after a stop, the stance ankle damps the whole body's sway at this ratio of
#: critical (:func:`standing_gains`): a sweep over 0-1 in MuJoCo (4 steps at 0.6 m/s, then
#: the stop; pushes of +-2.5, 5 and 10 N s in the first step or in the stop) stood 11 of 12
#: at 0.5 (not a 10 N s push back in the stop), 10 at 0.35, 9 at 0.7 and 1, 7 at 0
#: (examples/benchmarks/stops.py, table 5)
STAND_DAMPING = 0.5
#: s: a stop's law blends the walk's gains into standing's over its last this long, while the
#: swing foot comes down onto the ground under its floor's flat end
#: (:data:`problems.walking.step.LAND_TIME` 0.05 s) and the body comes to rest
STAND_RAMP = 0.1
#: the law's rate, Hz (the torque file's)
CONTROL_RATE_HZ = 1000.0


def feet_references(gait, rate_hz: float = CONTROL_RATE_HZ,
                    by_time: bool = False) -> tuple[GaitReference, ...]:  # fmt: skip
    """(single support, double support) of a solved step on feet, each the consistent
    motion sampled at ``rate_hz`` from its start (the single support the flat foot then the
    heel rise: one motion, its torques continuous where the heel rises; its last sample the
    state before the heel strike), both indexed by the whole step's phase: s = 0 at the
    step's start, 1 where the rear foot leaves (``by_time``: a law follows a branch by the
    time since it began while its hip stalls or sways back, then by the phase;
    :class:`GaitReference`). A stop at quiet standing (``step.stop``: one flat phase, no
    strike) has one branch, (stop,): followed by the time since it began throughout, its last
    sample (standing at rest) held after its end (``GaitReference(to_rest=True)``)."""
    step = gait.problem
    *singles, last = (part.to_trajectory(rate_hz) for part, _ in gait.segments())
    if step.stop:  # one flat phase to rest: by the time throughout, its end held
        stop = dataclasses.replace(last, extras={}, metadata={})
        return (GaitReference(stop, step.dynamics, step.biped.stance_thigh, to_rest=True),)
    single = dataclasses.replace(singles[0], extras={}, metadata={})
    for second in singles[1:]:
        # the heel rise's first sample is the flat foot's last (the same instant): kept once
        single = dataclasses.replace(
            single,
            time=np.r_[single.time, second.time[1:] - second.time[0] + single.time[-1]],
            states=np.vstack([single.states, second.states[1:]]),
            controls=np.vstack([single.controls, second.controls[1:]]),
        )
    hip = step.dynamics.point(step.biped.stance_thigh)
    ends = (complex(hip.position(single.psi[0])).real, complex(hip.position(last.psi[-1])).real)
    return tuple(
        GaitReference(part, step.dynamics, step.biped.stance_thigh, hip_range=ends, by_time=by_time)
        for part in (single, last)
    )


def hinge_inertias(dynamics, psi) -> np.ndarray:
    """The inertia each hinge's drive moves, kg m^2 (n,): the diagonal of the mass matrix in
    the hinges' relative angles (A^T M(psi) A, psi = A q), averaged over the postures psi
    (K, n) of a plan. The stance ankle's is the whole body's about it (~70 kg m^2 on the
    scene), the swing foot's its own about the ankle (~0.013 kg m^2)."""
    ancestry = dynamics.linkage.ancestry()
    diagonals = [np.diag(ancestry.T @ dynamics.mass_matrix(angles) @ ancestry)
                 for angles in np.atleast_2d(psi)]  # fmt: skip
    return np.mean(diagonals, axis=0)


def hinge_gains(inertias, kp: float, kd: float, bandwidth: float):
    """(kp_i, kd_i) (n,) each: ``kp`` and ``kd`` on every hinge, capped at bandwidth^2 I_i and
    2 bandwidth I_i on a hinge that moves little inertia I_i. Why: a drive sampled every dt
    with kd dt / I > 2 overshoots its own damping and oscillates; uniform gains of 600 and
    30 on the swing foot (kd dt / I = 2.4 at 1 kHz) drove it against the torque limit every
    sample and shook the stance foot off the ground (measured). Capped, kd dt / I <=
    2 bandwidth dt (0.1 at the defaults)."""
    inertias = np.asarray(inertias, dtype=float)
    check_positive("kp", kp, "N m/rad")
    check_positive("kd", kd, "N m s/rad")
    if not isinstance(bandwidth, (int, float)) or not bandwidth > 0:  # inf: no cap
        raise DefinitionError(f"`bandwidth`: rad/s > 0 (inf: no cap), got {bandwidth!r}")
    return (np.minimum(kp, bandwidth**2 * inertias), np.minimum(kd, 2.0 * bandwidth * inertias))


def standing_gains(
    gain: np.ndarray, inertias, ankle: int, damping: float = STAND_DAMPING
) -> np.ndarray:
    """K (n, 2n) of standing held: the walk's joint PD ``gain`` (n, 2n) on x = (psi, dpsi)
    with the stance ankle's row (hinge ``ankle``, whose child link is the stance shank, of the
    same index) also damping the stance shank's absolute rate (column n + ``ankle``) at
    2 damping sqrt(kp_ankle I_ankle), the ratio ``damping``
    of critical for the whole body swaying on that ankle (I_ankle :func:`hinge_inertias`,
    about 70 kg m^2 on the scene). The other rows are the walk's: the swing ankle's capped
    gains too (uncapped, as in the double support, a walker pushed 10 N s in the stop that
    stood with them toppled: measured).

    Why: standing, the whole body sways on the stance ankle against kp = 1000 N m/rad less
    its weight's toppling 600 N m/rad, and the walk's kd = 30 N m s/rad damps that at 0.09 of
    critical: pushed 10 N s in the stop, the body rocked on its soles with a 2.7 s period and
    toppled within 3 s (measured). Why on the shank's absolute rate and not the ankle's
    relative one: a relative damping that large reads the stance foot's own rocking on its
    soft contact (kd dt / I_foot ~ 40 at 1 kHz) and shook the walker off its feet (measured:
    every hinge damped at 0.7 of critical toppled even the undisturbed stop)."""
    if not damping >= 0:
        raise DefinitionError(f"`stand_damping`: a ratio of critical >= 0 (0: the walk's PD "
                              f"alone), got {damping!r}")  # fmt: skip
    gain = np.array(gain, dtype=float)
    n = gain.shape[0]
    inertias = np.asarray(inertias, dtype=float)
    kp_ankle = gain[ankle, ankle]  # kp on the ankle's angle (R's +1 entry: the shank's)
    gain[ankle, n + ankle] += 2.0 * damping * np.sqrt(max(kp_ankle, 0.0) * inertias[ankle])
    return gain


class BlendedPD:
    """Two PD laws around one reference, blended by the time t s since the step began:
    M = (1 - w) M_first + w M_second, w = 0 up to ``start``, 3 u^2 - 2 u^3 (u = (t - start)
    / (end - start)) up to ``end``, 1 after: the same as one PD whose gains blend so (the
    feedforward is the reference's in both). A stop's law (:class:`FeetLaw`): the walk's
    :class:`PhasePD` into standing's :class:`TimedGainLaw` (:func:`standing_gains`) over its
    last :data:`STAND_RAMP` s."""

    def __init__(self, first, second, start: float, end: float) -> None:
        if not end > start:
            raise DefinitionError(f"`end`: after `start` ({start!r} s), got {end!r} s")
        self.first, self.second = first, second
        self.start, self.end = float(start), float(end)
        self.reference = first.reference

    def weight(self, t) -> np.ndarray:
        """w at the times t s (any shape): the second law's share."""
        u = np.clip((np.asarray(t, dtype=float) - self.start) / (self.end - self.start), 0, 1)
        return u * u * (3.0 - 2.0 * u)

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        w = float(self.weight(t))
        return (1.0 - w) * self.first.torques(t, x) + w * self.second.torques(t, x)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """dM/dx (n, 2n) of :meth:`torques`."""
        w = float(self.weight(t))
        return (1.0 - w) * self.first.jacobian(t, x) + w * self.second.jacobian(t, x)


class TimedGainLaw:
    """M = active (M_ff(t) + K (x_ref(t) - x)) with one gain K (n, 2n) on x = (psi, dpsi),
    the reference by the time t s since the step began (clamped to the plan: its last sample
    held after its end); ``passive``: hinges with no drive (their torque 0)."""

    def __init__(self, reference, gain: np.ndarray, passive=()) -> None:
        self.reference = reference
        self.gain = np.array(gain, dtype=float)
        self._active = np.ones(self.gain.shape[0])
        self._active[list(passive)] = 0.0

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        state, feedforward = self.reference.at_time(t)
        return self._active * (feedforward + self.gain @ (state - x))

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        return -self._active[:, None] * self.gain


class FeetLaw:
    """The drives' law on the step on feet (module docstring): joint PD around the plan,
    indexed by the hip's progress, with the single and double support's branches.

    Parameters
    ----------
    gait : FootedGait
        The solved step.
    kp, kd : float
        N m/rad, N m s/rad of every hinge drive; in the single support capped on light links
        at ``bandwidth`` rad/s (:func:`hinge_gains`). The root's (the ground's torque on the
        stance foot) is no drive: its gain is unused. None (each): the sequence's default,
        :data:`SEQUENCE_GAINS` or (:data:`FEET_KP`, :data:`FEET_KD`, :data:`FEET_BANDWIDTH`).
    rate_hz : float
        The reference's sample rate (the file's), Hz.
    stand_damping : float
        A stop's standing held after it: the stance ankle's damping of the whole body's sway,
        as a ratio of critical (:func:`standing_gains`; 0: the walk's joint PD alone).

    Attributes: ``references`` (single, double) :class:`GaitReference`, or (stop,) for a
    stop at quiet standing; ``gains`` per branch, (kp (n,), kd (n,)); ``indexed_by``:
    "phase", or "time" for a step whose hip does not always advance (the first step of a
    start from rest: followed by the time since the step began until its hip advances for
    good, then by the phase; ``GaitReference.by_time``), or :data:`HELD` for a stop (by the
    time since it began, its last sample, standing at rest, held after its end).
    """

    def __init__(
        self,
        gait,
        kp: float | None = None,
        kd: float | None = None,
        bandwidth: float | None = None,
        rate_hz: float = CONTROL_RATE_HZ,
        stand_damping: float = STAND_DAMPING,
    ) -> None:
        step = gait.problem
        self.step = step
        defaults = SEQUENCE_GAINS.get(step.sequence_name, (FEET_KP, FEET_KD, FEET_BANDWIDTH))
        kp = defaults[0] if kp is None else kp
        kd = defaults[1] if kd is None else kd
        bandwidth = defaults[2] if bandwidth is None else bandwidth
        self.rate_hz = check_positive("rate_hz", rate_hz, "Hz")
        self.bandwidth = bandwidth
        # a step whose hip does not always advance (a start from rest) has no phase to
        # follow its plan by: its law goes by the time since each branch began; a stop's
        # hip sways back and settles: by the time throughout, standing held after its end
        if step.stop:
            self.references, self.indexed_by = feet_references(gait, self.rate_hz), HELD
        else:
            try:
                self.references, self.indexed_by = feet_references(gait, self.rate_hz), "phase"
            except DefinitionError:  # the phase refused it: the hip stalls or sways back
                self.references = feet_references(gait, self.rate_hz, by_time=True)
                self.indexed_by = "time"
        n = step.linkage.n
        inertias = hinge_inertias(step.dynamics, self.references[0].states[:, :n])
        # In the double support both feet are on the ground: every drive moves the closed
        # chain, none a light link alone, and the front ankle needs the full gains to press
        # its foot flat by the leg swap (capped there, the foot landed late and the steps
        # drifted until the hip stalled, at step 24: measured)
        self.gains = (hinge_gains(inertias, kp, kd, bandwidth),
                      (np.full(n, float(kp)), np.full(n, float(kd))))  # fmt: skip
        branch_gains = self.gains[: len(self.references)]  # a stop's one: the walk's
        self.branches = tuple(
            PhasePD(reference, step.linkage.parents, *gains, passive=(0,))
            for reference, gains in zip(self.references, branch_gains, strict=True)
        )
        #: R (n, n): the hinges' relative angles of the absolute ones, q = R psi
        self.relative_matrix = self.branches[0].relative_matrix
        if step.stop:  # one branch: the walk's gains, blended into standing's at its end
            self.gains = self.gains[:1]
            self.branches = (self._stop_branch(inertias, stand_damping),)

    def _stop_branch(self, inertias, stand_damping: float) -> BlendedPD:
        """A stop's law: the walk's PD around it, blended over its last :data:`STAND_RAMP` s
        into standing's (:func:`standing_gains`, kept as :attr:`standing_gain` K (n, 2n))."""
        step = self.step
        walk = self.branches[0]
        ankle = step.linkage.names.index(step.biped.stance_leg[1])  # the stance shank's hinge
        self.standing_gain = standing_gains(self._gain_matrix(*self.gains[0]), inertias, ankle,
                                            check_real("stand_damping", stand_damping))  # fmt: skip
        stop = walk.reference
        return BlendedPD(walk, TimedGainLaw(stop, self.standing_gain, (0,)),
                         stop.duration - STAND_RAMP, stop.duration)  # fmt: skip

    def _gain_matrix(self, kp, kd) -> np.ndarray:
        """K = [kp R, kd R] (n, 2n) of per-hinge gains kp, kd (n,) on x = (psi, dpsi), R the
        relative angles' matrix (q = R psi); row 0 (the ground's torque on the stance foot:
        no drive) zero."""
        relative = self.relative_matrix
        gain = np.hstack([np.asarray(kp)[:, None] * relative, np.asarray(kd)[:, None] * relative])
        gain[0] = 0.0
        return gain

    def phase(self, psi) -> float:
        """The step's phase s of the angles psi (n,) in the plan's labels."""
        return self.references[0].phase(psi)

    def torques(self, branch: int, x: np.ndarray, t: float = 0.0) -> np.ndarray:
        """Hinge torques (n,) N m in the plan's labels (the root's 0) for the state x (2n,)
        and the branch (0: single support, 1: double); ``t``: s since the branch began, read
        only by a law by the time (:attr:`indexed_by` "time": a start from rest)."""
        return self.branches[branch].torques(t, x)

    def channels(self, trajectory: Trajectory) -> Trajectory:
        """``trajectory`` (the step's exported samples, ``gait.to_trajectory(rate_hz)``) with
        the phase s of each sample, its branch (``double_support``: 1 from the heel strike's
        instant on) and the branch's gains as columns ``K_<hinge>__<state>``, and the law in
        ``metadata["feedback"]`` (:func:`problems.control.feedback.with_gains`)."""
        step = self.step
        n = step.linkage.n
        if trajectory.psi.shape[1] != n:
            raise DefinitionError(
                f"`trajectory`: {trajectory.psi.shape[1]} angles, the step on feet has {n}"
            )
        times = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
        if step.stop:  # by the time: the phase column is the law's index, t / T
            phases = times / times[-1]
        else:
            phases = np.array([self.phase(psi) for psi in trajectory.psi])
        # the joined file keeps the state after the impact at the strike's instant (a stop
        # has no strike: one branch)
        double = times >= self.references[0].duration - 1e-9
        if len(self.references) == 1:
            double = np.zeros(times.size, dtype=bool)
        rows = [self._gain_matrix(kp, kd) for kp, kd in self.gains]
        if step.stop:  # the walk's gains blended into standing's by the time
            w = self.branches[0].weight(times)[:, None, None]
            gains = (1.0 - w) * rows[0] + w * self.standing_gain
        else:
            gains = np.where(double[:, None, None], rows[-1], rows[0])
        limits = [np.inf] + [step.limits[name] for name in step.linkage.names[1:]]
        # the gains as the file's K rows hold them: none for the ground's torque on the root
        kp = [np.r_[0.0, gains[1:]].tolist() for gains, _ in self.gains]
        kd = [np.r_[0.0, gains[1:]].tolist() for _, gains in self.gains]
        if step.stop:
            branches, indexed_by = STOP_BRANCH, HELD_TEXT
            kp_entry = {"stop": kp[0], "unit": KP_UNIT}
            kd_entry = {"stop": kd[0], "unit": "N m s/rad"}
        else:
            single = " + ".join(step.sequence[:-1])
            branches = FEET_BRANCHES.format(single=single, point=step.striking_point)
            indexed_by = self.indexed_by if self.indexed_by == "phase" else BY_TIME
            kp_entry = {"single": kp[0], "double": kp[1], "unit": KP_UNIT}
            kd_entry = {"single": kd[0], "double": kd[1], "unit": "N m s/rad"}
        return with_gains(
            trajectory.with_extra("double_support", double.astype(float), "1"),
            step.linkage.names,
            phases,
            gains,
            {
                "law": LAW,
                "phase": FEET_PHASE.format(hip=step.biped.stance_thigh),
                "indexed_by": indexed_by,
                "branches": branches,
                "limit_N_m": limit_metadata(limits),
                "control_rate_hz": self.rate_hz,
                "design": "joint PD around the plan on the hinges' relative angles, K = "
                "[kp R, kd R]; in the single support capped on light links at "
                f"{self.bandwidth:g} rad/s (problems.control.feet_law.hinge_gains)",
                "kp": kp_entry,
                "kd": kd_entry,
                # how a stop goes over into standing, beside its gains
                **({"standing": STAND_BLEND} if step.stop else {}),
            },
        )


#: the phase, as the file's metadata says it
FEET_PHASE = (
    "s = (x_hip - x_hip(0)) / (x_hip(T) - x_hip(0)): the hip (end of {hip}) ahead of the "
    "stance ball along x, 0 at the step's start (the rear foot's toe-off), 1 where the next "
    "rear foot leaves; psi absolute angles from +x, stance ball at H0"
)
#: how a law by the time follows its plan, as the file's metadata says it
BY_TIME = (
    "time, then phase: a branch's rows by the time since it began (the single support's "
    "since the step's start, the double support's since the strike) while its hip stalls or "
    "sways back (a start from rest), then by the phase from where the hip advances for good; "
    "the phase ends the step at s = 1"
)
#: how a stop's law follows its plan (FeetLaw.indexed_by), and as the file's metadata says it
HELD = "time, then held"
HELD_TEXT = (
    "time, then held: a stop at quiet standing (its hip sways back and settles) is followed "
    "by the time since it began; after its last row (both feet flat side by side, at rest) "
    "the law holds that row: x_ref, tau_ff and K of the last row"
)
#: how a stop's gains go over into standing's, as the file's metadata says it
STAND_BLEND = (
    "standing held: the stance ankle also damps the stance shank's absolute rate (its K "
    "column of that rate); the rows' K blend the stop's PD into standing's by the time since "
    f"the step began, w = 3 u^2 - 2 u^3, u = (t - (T - {STAND_RAMP:g} s)) / {STAND_RAMP:g} s "
    "within [0, 1], T the stop's duration: its last row's K are standing's, held after T"
)
#: a stop's one branch, as the file's metadata says it
STOP_BRANCH = (
    "one branch (double_support = 0 throughout): the stop's flat phase, the swing foot set "
    "down beside the stance foot at its end; no strike and no leg swap follow"
)
#: the unit of the file's kp, per hinge
KP_UNIT = "N m/rad, per hinge (the root's 0: the ground's torque, no drive)"
#: the branches and their switches, as the file's metadata says them
FEET_BRANCHES = (
    "rows with double_support = 0: the single support ({single}) up to the strike; 1: the "
    "double support after it. The law takes the double support's rows when the swing "
    f"{{point}}'s normal force passes {TOUCHDOWN_FORCE:g} N past s = 0.5, and swaps the legs "
    "at s = 1; past a branch's last row x_ref goes on along its last slope dx/ds"
)


def walk_laws(gaits, laws=None) -> tuple[tuple, tuple]:
    """(gaits, laws) of a walk on feet, checked: ``gaits`` solved steps on feet
    (:class:`problems.walking.footed.FootedGait`, one per step) of one walker, a stop at
    quiet standing only as the last; ``laws`` one per step (default ``FeetLaw(gaits[j])``,
    made once per distinct gait). The walks in MuJoCo and in the product's simulation take
    them so."""
    from problems.walking.footed import FootedGait

    gaits = tuple(gaits)
    if not gaits or not all(isinstance(gait, FootedGait) for gait in gaits):
        raise DefinitionTypeError(
            "`gaits`: solved steps on feet (FootedGait), at least one, got "
            f"{[type(gait).__name__ for gait in gaits]}"
        )
    stops = [j for j, gait in enumerate(gaits) if gait.problem.stop]
    if stops and stops != [len(gaits) - 1]:
        raise DefinitionError(
            f"`gaits`: a stop at quiet standing ends a walk; step {stops[0]} of {len(gaits)} "
            "is one: end the walk there"
        )
    names = gaits[0].problem.linkage.names
    if any(gait.problem.linkage.names != names for gait in gaits):
        raise DefinitionError("`gaits`: steps of one walker (the same links)")
    if laws is None:
        made: dict[int, FeetLaw] = {}
        laws = tuple(made.setdefault(id(gait), FeetLaw(gait)) for gait in gaits)
    laws = tuple(laws)
    if len(laws) != len(gaits):
        raise DefinitionError(f"`laws`: one per step, {len(gaits)}, got {len(laws)}")
    return gaits, laws


__all__ = [
    "FEET_BANDWIDTH",
    "FEET_KD",
    "FEET_KP",
    "HELD",
    "SEQUENCE_GAINS",
    "FeetLaw",
    "feet_references",
    "hinge_gains",
    "hinge_inertias",
    "standing_gains",
    "walk_laws",
]
