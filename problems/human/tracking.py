"""Tracking a recorded gait: the periodic step whose motion is closest to a recording, with
its torques (the dynamically consistent version of a measured gait, as OpenSim Moco's
MocoTrack gives it).

The step on feet (:func:`problems.walking.footed.footed_step`) or on point feet
(:func:`problems.walking_step`) at the recording's own step (half its stride, in half its
stride time), every constraint of the step kept (ground, friction, limits, periodicity with
the leg swap, the heel strike), and the objective replaced by

    integral over the step of  sum_c w_c (q_c(t) - r_c(cycle(t)))^2  +  effort sum_i (M_i / M_max)^2

over both legs (deg for angles, body weights for the ground force): q_c the model's channel
in the conventions of :mod:`problems.human.joints`, r_c the recording's as a Fourier series
of :data:`HARMONICS` harmonics over its cycle (smooth and periodic, so the objective has
exact derivatives), cycle(t) each leg's % of its cycle: the swing foot strikes at t_s
(the double support's start, a sum of the free phase durations, or the step's end), so the
swing leg is at 100 (t - t_s) / 2T % and the stance leg half a cycle ahead. The effort term
regularises the torques (the drives' |M| <= M_max bound is the scale). The two terms are
named ``tracking`` and ``effort`` in ``Solution.cost_terms``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, check_positive
from problems.gait.problem import RATE_HZ
from problems.human.comparison import GaitComparison, compare_gait
from problems.human.joints import Body, body_of, joint_radians
from problems.human.recording import ANGLES, FORCES, GaitRecording
from problems.human.stride import step_stride

#: Harmonics of the recording's Fourier series (Winter's 70 frames a cycle: 12 harmonics
#: leave 0.3 deg RMS on his knee, the sharpest angle).
HARMONICS = 12
#: Default weights, 1/deg^2 (angles) and 1/BW^2 (forces): the thigh, knee and ankle; the
#: hip off (a recorded hip measures the thigh against a HAT line that tilts with the pelvis,
#: no model trunk does); the ground force, when the recording has it, so that 0.1 BW counts
#: as 1 deg (on Winter's stride: the vertical force 0.26 BW RMS off instead of 0.48 with
#: angles alone, for 0.2-0.4 deg on the knee and ankle; examples/benchmarks/
#: human_prediction.py).
DEFAULT_WEIGHTS = {"thigh": 1.0, "knee": 1.0, "ankle": 1.0, "force_x": 100.0, "force_y": 100.0}
#: Default weight of the effort term sum (M_i / M_max)^2 (per s): much lower and the
#: drives' torques chatter between the mesh points (plans that fail their verification);
#: at 50 with the rate terms below they are smooth and the angles within 2-3 deg.
DEFAULT_EFFORT = 50.0
#: Intervals of the footed step's phases when tracking (flat, heel rise, double): a tracked
#: heel rise lasts about 60 % of the step, three times the predicted one.
TRACKING_MESH = (30, 30, 15)
#: Weight of the centre of pressure's speed on a flat foot, (dM_0 T / (sole m g))^2 per s,
#: in the effort term: without it a tracked flat foot holds its pressure on the heel and
#: throws it to the ball within the last mesh interval before the heel rises (a jump the
#: plan's interpolant misses between its samples); with it the pressure rolls forward.
PRESSURE_RATE = 1.0
#: Weight of the drives' torque rates, sum (dM_i T / M_max)^2 per s, in the effort term.
TORQUE_RATE = 0.01


@dataclass(frozen=True)
class FourierSeries:
    """A periodic function of the cycle's % (period 100): ``mean`` + sum_k ``cosines[k-1]``
    cos(2 pi k p / 100) + ``sines[k-1]`` sin(2 pi k p / 100)."""

    mean: float
    cosines: tuple[float, ...]
    sines: tuple[float, ...]

    @classmethod
    def fit(cls, percent: np.ndarray, values: np.ndarray, harmonics: int) -> FourierSeries:
        """Least squares on the finite samples, one cycle (a last sample at 100 % repeats the
        first cycle's start and is left out)."""
        keep = np.isfinite(values) & (percent < 100.0 - 1e-9)
        p, v = percent[keep], values[keep]
        if p.size < 2 * harmonics + 1:
            raise DefinitionError(
                f"`harmonics`: {harmonics} need at least {2 * harmonics + 1} samples of the "
                f"channel, the recording has {p.size}"
            )
        angle = 2 * np.pi * np.outer(p, np.arange(1, harmonics + 1)) / 100.0
        basis = np.hstack([np.ones((p.size, 1)), np.cos(angle), np.sin(angle)])
        coefficients = np.linalg.lstsq(basis, v, rcond=None)[0]
        return cls(float(coefficients[0]), tuple(coefficients[1 : harmonics + 1].tolist()),
                   tuple(coefficients[harmonics + 1 :].tolist()))  # fmt: skip

    def __call__(self, percent):
        """The series at ``percent`` (numpy array or CasADi expression)."""
        symbolic = isinstance(percent, ca.SX | ca.MX | ca.DM)
        cos, sin = (ca.cos, ca.sin) if symbolic else (np.cos, np.sin)
        value = self.mean
        for k, (a, b) in enumerate(zip(self.cosines, self.sines, strict=True), start=1):
            angle = 2 * math.pi * k * percent / 100.0
            value = value + a * cos(angle) + b * sin(angle)
        return value


@dataclass(frozen=True)
class Tracking:
    """What to track: the recording's channels (:data:`ANGLES`, :data:`FORCES`) by weight,
    as Fourier series, and the effort weight. Build with :func:`tracking_of`."""

    recording: GaitRecording
    weights: Mapping[str, float]
    effort: float
    references: Mapping[str, FourierSeries]

    def integrand(self, body: Body, legs_percent, psi, forces, torques, torque_limit: float):
        """(tracking, effort) integrands at one point: ``legs_percent`` (stance leg's %,
        swing leg's %), ``psi`` {link: angle}, ``forces`` (stance foot's, swing foot's)
        (Fx, Fy) in body weights or None where the foot is in the air, ``torques`` the
        drives' (list of expressions)."""
        terms = []
        for leg, percent, force in zip((body.stance, body.swing), legs_percent, forces,
                                       strict=True):  # fmt: skip
            angles = joint_radians(body, leg, psi)
            for name, weight in self.weights.items():
                if name in ANGLES:
                    value = angles[name]
                    if value is None:  # a point foot's swing ankle: nothing to track
                        continue
                    value = value * (180.0 / math.pi)
                else:
                    value = 0.0 if force is None else force[FORCES.index(name)]
                terms.append(weight * (value - self.references[name](percent)) ** 2)
        tracking = sum(terms[1:], terms[0])
        effort = self.effort * ca.sumsqr(ca.vertcat(*torques) / torque_limit)
        return tracking, effort


def tracking_of(
    recording: GaitRecording,
    weights: Mapping[str, float] | None = None,
    effort: float = DEFAULT_EFFORT,
    harmonics: int = HARMONICS,
    feet: bool = True,
) -> Tracking:
    """A :class:`Tracking` of ``recording`` (weights {channel: w}, default
    :data:`DEFAULT_WEIGHTS` less the forces the recording lacks, and less the ankle for a
    walker on point feet (``feet`` False); channels the recording lacks are refused)."""
    if weights is None:
        weights = {n: w for n, w in DEFAULT_WEIGHTS.items() if n in ANGLES or recording.has(n)}
        if not feet:  # a point foot has no ankle: its shank's tilt on a flat sole is no match
            weights.pop("ankle")
    weights = dict(weights)
    for name, weight in weights.items():
        if name not in ANGLES + FORCES:
            raise DefinitionError(f"`weights`: unknown channel {name!r}; use {ANGLES + FORCES}")
        if not (isinstance(weight, int | float) and math.isfinite(weight) and weight >= 0):
            raise DefinitionError(f"`weights[{name!r}]`: a number >= 0, got {weight!r}")
        if weight > 0 and not recording.has(name):
            raise DefinitionError(
                f"`weights[{name!r}]`: the recording ({recording.source}) does not measure "
                f"{name}; give it weight 0 or leave it out"
            )
    weights = {name: float(w) for name, w in weights.items() if w > 0}
    if not weights:
        raise DefinitionError("`weights`: give at least one channel a weight > 0")
    effort = float(check_positive("effort", effort, "(weight of sum (M/M_max)^2)"))
    references = {name: FourierSeries.fit(recording.percent, recording.channels[name],
                                          harmonics) for name in weights}  # fmt: skip
    return Tracking(recording, weights, effort, references)


@dataclass(frozen=True)
class TrackedGait:
    """:func:`track_gait`'s result: the solved, verified ``gait``, its stride
    (:func:`problems.human.step_stride` of its exported samples) and the ``comparison``
    with the recording."""

    gait: Any
    tracking: Tracking
    stride: GaitRecording
    comparison: GaitComparison


def _recorded_step(recording: GaitRecording) -> tuple[float, float]:
    if not (math.isfinite(recording.stride_length) and math.isfinite(recording.stride_time)):
        raise DefinitionError(
            "`recording`: its stride length and time are needed for the step (a CSV "
            "recording's '# stride_length_m:' and '# stride_time_s:' lines)"
        )
    return recording.stride_length / 2.0, recording.stride_time / 2.0


def tracking_step(tracking: Tracking, feet: bool = True, **options):
    """The step to solve: ``footed_step`` (``feet``) or ``walking_step`` at the recording's
    step (``options`` go to them) with the tracking objective in every phase."""
    from problems.walking.footed import footed_step
    from problems.walking.step import walking_step

    length, duration = _recorded_step(tracking.recording)
    if feet:
        options.setdefault("N", TRACKING_MESH)
        step = footed_step(step_length=length, step_time=duration, **options)
        return replace(step, phases=_footed_phases(step, tracking))
    step = walking_step(step_length=length, step_time=duration, **options)
    if step.phases is not None:
        raise DefinitionError("`double_support`: tracking on point feet takes the single "
                              "support only")  # fmt: skip
    return replace(step, ocp=_point_foot_ocp(step, tracking))


def _footed_phases(step, tracking: Tracking):
    from problems.walking.footed import _offset, _parameters, _summed

    body = body_of(step.linkage, step.neutral_ankles)
    names = step.linkage.names
    drives = [names.index(name) for name in step.drives]
    reaction = step.dynamics.function("ground_reaction")
    weight = step.weight
    phases = []
    for k, (name, ocp) in enumerate(step.phases.phases):

        def terms(p, k=k, name=name):
            strike = _summed(p, _parameters(step))  # the double support starts
            t = p.t + _offset(step, k, p)
            swing_percent = 100.0 * (t - strike) / (2.0 * step.step_time)
            psi = {n: p.psi[i] for i, n in enumerate(names)}
            fx, fy = reaction(p.psi, p.dpsi, p.ddpsi)
            if name == "double":
                front = (p.F[0] / weight, p.F[1] / weight)
                rear = ((fx - p.F[0]) / weight, (fy - p.F[1]) / weight)
            else:
                front, rear = None, (fx / weight, fy / weight)
            tracked, effort = tracking.integrand(
                body, (swing_percent + 50.0, swing_percent), psi, (rear, front),
                [p.M[i] for i in drives], step.torque_limit,
            )  # fmt: skip
            rolling = p.dM[0] * step.step_time / (step.sole * weight)
            rates = ca.vertcat(*[p.dM[i] for i in drives]) * (step.step_time / step.torque_limit)
            smooth = PRESSURE_RATE * rolling**2 + TORQUE_RATE * ca.sumsqr(rates)
            return tracked, effort + smooth

        ocp = ocp.minimize(integral=lambda p, terms=terms: terms(p)[1])  # the default term
        ocp = ocp.minimize(integral=lambda p, terms=terms: terms(p)[0], name="tracking")
        phases.append((name, ocp))
    return replace(step.phases, phases=tuple(phases))


def _point_foot_ocp(step, tracking: Tracking):
    body = body_of(step.linkage)
    names = step.linkage.names
    reaction = step.dynamics.function("ground_reaction")
    weight = step.biped.total_mass * step.linkage.gravity
    limit = max(step.torque_limit.values())
    drives = [names.index(n) for n in names if n not in step.passive]

    def terms(p):
        stance_percent = 100.0 * p.t / (2.0 * step.step_time)  # it struck at the start
        psi = {n: p.psi[i] for i, n in enumerate(names)}
        fx, fy = reaction(p.psi, p.dpsi, p.ddpsi)
        tracked, effort = tracking.integrand(
            body, (stance_percent, stance_percent + 50.0), psi,
            ((fx / weight, fy / weight), None), [p.M[i] for i in drives], limit,
        )  # fmt: skip
        rates = ca.vertcat(*[p.dM[i] for i in drives]) * (step.step_time / limit)
        return tracked, effort + TORQUE_RATE * ca.sumsqr(rates)

    ocp = step.ocp.minimize(integral=lambda p: terms(p)[1])
    return ocp.minimize(integral=lambda p: terms(p)[0], name="tracking")


def track_gait(
    recording: GaitRecording,
    *,
    feet: bool = True,
    weights: Mapping[str, float] | None = None,
    effort: float = DEFAULT_EFFORT,
    harmonics: int = HARMONICS,
    rate_hz: float = RATE_HZ,
    solve_options: Mapping[str, Any] | None = None,
    **step_options,
) -> TrackedGait:
    """The periodic step closest to ``recording`` (see the module), solved, its limits held
    and every exported sample verified at ``rate_hz`` (a plan that fails raises
    :class:`problems.GaitVerificationError`), its stride compared with the recording.

    Parameters
    ----------
    recording : the recorded cycle (:func:`problems.human.read_recording`) with its stride
        length and time.
    feet : the step on feet (default) or on point feet.
    weights : {channel: weight} over :data:`ANGLES` (1/deg^2) and :data:`FORCES`
        (1/BW^2); default :data:`DEFAULT_WEIGHTS`.
    effort : the weight of sum_i (M_i / M_max)^2.
    step_options : to ``footed_step`` / ``walking_step`` (linkage, mu, torque_limit, ...).
    """
    tracking = tracking_of(recording, weights, effort, harmonics, feet)
    step = tracking_step(tracking, feet, **step_options)
    gait = step.solve(rate_hz=rate_hz, **dict(solve_options or {}))
    stride = step_stride(gait.to_trajectory(rate_hz))
    return TrackedGait(gait, tracking, stride, compare_gait(stride, recording))
