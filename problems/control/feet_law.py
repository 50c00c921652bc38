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

from planner.errors import DefinitionError, check_positive
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
#: the law's rate, Hz (the torque file's)
CONTROL_RATE_HZ = 1000.0


def feet_references(gait, rate_hz: float = CONTROL_RATE_HZ,
                    by_time: bool = False) -> tuple[GaitReference, GaitReference]:  # fmt: skip
    """(single support, double support) of a solved step on feet, each the consistent
    motion sampled at ``rate_hz`` from its start (the single support the flat foot then the
    heel rise: one motion, its torques continuous where the heel rises; its last sample the
    state before the heel strike), both indexed by the whole step's phase: s = 0 at the
    step's start, 1 where the rear foot leaves (``by_time``: a law follows a branch by the
    time since it began while its hip stalls or sways back, then by the phase;
    :class:`GaitReference`)."""
    step = gait.problem
    *singles, last = (part.to_trajectory(rate_hz) for part, _ in gait.segments())
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

    Attributes: ``references`` (single, double) :class:`GaitReference`; ``gains`` per branch,
    (kp (n,), kd (n,)); ``indexed_by``: "phase", or "time" for a step whose hip does not
    always advance (the first step of a start from rest: followed by the time since the step
    began until its hip advances for good, then by the phase; ``GaitReference.by_time``).
    """

    def __init__(
        self,
        gait,
        kp: float | None = None,
        kd: float | None = None,
        bandwidth: float | None = None,
        rate_hz: float = CONTROL_RATE_HZ,
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
        # follow its plan by: its law goes by the time since each branch began
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
        self.branches = tuple(
            PhasePD(reference, step.linkage.parents, *gains, passive=(0,))
            for reference, gains in zip(self.references, self.gains, strict=True)
        )

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
        phases = np.array([self.phase(psi) for psi in trajectory.psi])
        times = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
        # the joined file keeps the state after the impact at the strike's instant
        double = times >= self.references[0].duration - 1e-9
        relative = self.branches[0].relative_matrix  # q = R psi
        rows = []
        for kp, kd in self.gains:
            gain = np.hstack([kp[:, None] * relative, kd[:, None] * relative])
            gain[0] = 0.0  # the ground's torque on the stance foot: no drive
            rows.append(gain)
        gains = np.where(double[:, None, None], rows[1], rows[0])
        limits = [np.inf] + [step.limits[name] for name in step.linkage.names[1:]]
        # the gains as the file's K rows hold them: none for the ground's torque on the root
        kp = [np.r_[0.0, gains[1:]].tolist() for gains, _ in self.gains]
        kd = [np.r_[0.0, gains[1:]].tolist() for _, gains in self.gains]
        single = " + ".join(step.sequence[:-1])
        point = step.striking_point
        return with_gains(
            trajectory.with_extra("double_support", double.astype(float), "1"),
            step.linkage.names,
            phases,
            gains,
            {
                "law": LAW,
                "phase": FEET_PHASE.format(hip=step.biped.stance_thigh),
                "indexed_by": self.indexed_by if self.indexed_by == "phase" else BY_TIME,
                "branches": FEET_BRANCHES.format(single=single, point=point),
                "limit_N_m": limit_metadata(limits),
                "control_rate_hz": self.rate_hz,
                "design": "joint PD around the plan on the hinges' relative angles, K = "
                "[kp R, kd R]; in the single support capped on light links at "
                f"{self.bandwidth:g} rad/s (problems.control.feet_law.hinge_gains)",
                "kp": {
                    "single": kp[0],
                    "double": kp[1],
                    "unit": "N m/rad, per hinge (the root's 0: the ground's torque, no drive)",
                },
                "kd": {"single": kd[0], "double": kd[1], "unit": "N m s/rad"},
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
#: the branches and their switches, as the file's metadata says them
FEET_BRANCHES = (
    "rows with double_support = 0: the single support ({single}) up to the strike; 1: the "
    "double support after it. The law takes the double support's rows when the swing "
    f"{{point}}'s normal force passes {TOUCHDOWN_FORCE:g} N past s = 0.5, and swaps the legs "
    "at s = 1; past a branch's last row x_ref goes on along its last slope dx/ds"
)


__all__ = [
    "FEET_BANDWIDTH",
    "FEET_KD",
    "FEET_KP",
    "SEQUENCE_GAINS",
    "FeetLaw",
    "feet_references",
    "hinge_gains",
    "hinge_inertias",
]
