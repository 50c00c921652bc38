"""The paper's setting as an optimal control problem: a periodic gait on a pinned stance foot.

Hinge H0 stays pinned for the whole period T of a gait law (22); the state is periodic,
x(0) = x(T); the hinge torques are the controls. The law gives the task and the first guess:

* ``keypoints``: at the given fractions of T the swing foot passes through the law's foot
  positions (``OCP.constrain_at`` on the transcription's interpolant: a keypoint need not be
  a node);
* ``clearance``: the swing foot's height stays above the law's lowest foot height minus
  ``margin`` at every dynamics point;
* ``posture``: the upright links (default the upper body of a biped, or none) within
  ``posture`` rad of the vertical pi/2;
* torque bounds |M_i| <= ``torque_limit``; the objective (``"torque"``, ``"torque-rate"``,
  ``"work"``; :mod:`problems.gait.problem`).

The law's own cost on the same mesh (its angles, rates and accelerations at the mesh points,
torques by inverse dynamics) is the benchmark (``PeriodicGait.law_cost``).

Local optima: the problem is not convex and the defaults start from the law. With the
six-link scene and the "walking" law (period 1 s, Hermite-Simpson N = 50, keypoints at 1/4,
1/2, 3/4) ``examples/benchmarks/gait_bench.py`` finds three optima by start: from the law
(the default) cost 724.78, from the law shifted by half a period or the standing pose 692.13,
from the "paper22" law 849.42. Which one a start reaches depends on IPOPT's barrier strategy
too (with the monotone update the law reached 692.13): for the best of several, solve from
several guesses and keep the lowest.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np

from model.dynamics import Dynamics
from model.linkage import Linkage
from model.presets import six_link_anthropoid
from planner.errors import DefinitionError, DefinitionTypeError, check_positive, check_real
from planner.problem import OCP
from planner.transcription import Transcription
from problems.gait.accuracy import resolve_mesh, solve_plan
from problems.gait.biped import Biped
from problems.gait.law import GaitLaw
from problems.gait.problem import (
    RATE_HZ,
    Gait,
    check_links,
    check_objective,
    finish_gait_ocp,
    gait_ocp,
    keep_upright,
    objective_at_guess,
    refine_and_hold,
    solve_and_hold,
    torque_limits,
    verified,
)

#: Fractions of the period at which the swing foot follows the law by default.
KEYPOINTS = (0.25, 0.5, 0.75)
#: Scale of the clearance rows as a fraction of the foot's reach (the lengths from H0 to the
#: foot: 0.043 m for the six-link swing foot, 1.72 m away), and the least scale of the
#: keypoint rows, twice that. Derived from the linkage, not metres, so that the same gait in
#: other units (millimetres and grams) is the same scaled NLP for IPOPT.
CLEARANCE_SCALE = 0.025


@dataclass(frozen=True, eq=False)
class PeriodicGaitProblem:
    """The fixed-base periodic gait as a problem: ``ocp`` (a planner OCP value to inspect or
    change) and the law, foot and task around it. ``solve(ocp=None, accuracy=None,
    **options)`` returns a :class:`PeriodicGait`; ``accuracy`` is the preset the problem was
    built with (``periodic_gait(accuracy=...)``), whose IPOPT tolerance ``solve`` uses."""

    linkage: Linkage
    dynamics: Dynamics
    law: GaitLaw
    foot_link: str
    keypoints: tuple[float, ...]
    foot_targets: np.ndarray
    foot_minimum: float
    margin: float
    torque_limit: dict[str, float]
    posture: float
    upright: tuple[str, ...]
    objective: str
    ocp: OCP | None
    accuracy: str | None = None

    @property
    def foot(self):
        """The swing foot: the end of ``foot_link`` (``model.PointKinematics``)."""
        return self.dynamics.point(self.foot_link)

    @property
    def foot_reach(self) -> float:
        """The largest distance of the foot from H0, m: the lengths (and displaced hinges) of
        the links from the root to the foot."""
        linkage = self.linkage
        i = linkage.index(self.foot_link)
        path = (*linkage.ancestors(i), i)
        hinges = sum(abs(linkage.origin_in_parent(k)) for k in path[1:])
        return hinges + linkage.links[i].length + abs(linkage.origin_in_parent(path[0]))

    def law_cost(self, ocp: OCP | None = None) -> float:
        """The law's objective on ``ocp``'s mesh (default this problem's)."""
        return objective_at_guess(Transcription(self.ocp if ocp is None else ocp))

    def solve(
        self,
        ocp: OCP | None = None,
        accuracy: str | float | None = None,
        *,
        rate_hz: float | None = RATE_HZ,
        hold_limits: bool = True,
        verify: bool = True,
        **options,
    ) -> PeriodicGait:
        """Solve ``ocp`` (default this problem's); ``options`` go to :func:`planner.solve`.

        ``accuracy``: a preset name (:data:`problems.ACCURACY_PRESETS`: ``ocp`` re-meshed
        with the preset's transcription and density, solved at its tolerance), or a number:
        the mesh refined until the per-interval re-integration error per nominal state scale
        is within it (:func:`planner.refine_to`, which takes ``max_passes`` and
        ``max_intervals``; ``gait.solution.stats["refinement"]`` is the history). Without
        it, the tolerance of the preset the problem was built with applies.
        ``options={"tol": ...}`` overrides a preset's tolerance. ``rate_hz``,
        ``hold_limits``: the limits also hold on the exported motion at that rate, as in
        :meth:`problems.walking.step.WalkingStep.solve`; ``verify``: the plan checked on
        those samples, never handed out as a plain success when it fails (as there).
        """
        ocp = self.ocp if ocp is None else ocp
        if not isinstance(ocp, OCP):
            raise DefinitionTypeError(f"`ocp`: must be a planner.OCP, got {type(ocp).__name__}")
        remesh, target, options = solve_plan(accuracy, self.accuracy, options)
        if target is not None:
            solution, final = refine_and_hold(ocp, target, options, hold_limits, rate_hz)
            gait = PeriodicGait(self, solution, self.law_cost(final))
        else:
            if remesh is not None:
                ocp = ocp.refine(**remesh.mesh(self.law.period))
            transcription = Transcription(ocp)
            law = objective_at_guess(transcription)
            solution = solve_and_hold(transcription, options, hold_limits, rate_hz)
            gait = PeriodicGait(self, solution, law)
        return verified(gait, rate_hz, verify, options)

    def settings(self, times=None) -> dict[str, Any]:
        """The problem's parameters as plain data (exported with the gait's files).
        ``times`` (the exported samples, s) is not needed here: the foot's minimum height is
        one number."""
        return {
            "problem": "periodic_gait",
            "period": self.law.period,
            "swing_foot": self.foot_link,
            "keypoints": list(self.keypoints),
            "foot_targets": self.foot_targets.tolist(),
            "foot_minimum": self.foot_minimum - self.margin,
            "torque_limit": dict(self.torque_limit),
            "posture": self.posture,
            "upright": list(self.upright),
            "objective": self.objective,
            "law": self.law.to_dict(),
        }


@dataclass(frozen=True, eq=False)
class PeriodicGait(Gait):
    """A solved fixed-base periodic gait (see :class:`problems.gait.problem.Gait`)."""


def periodic_gait(
    linkage: Linkage | None = None,
    law: GaitLaw | str = "walking",
    *,
    N: int | None = None,
    transcription: str | None = None,
    degree: int | None = None,
    formulation: str = "implicit",
    accuracy: str | None = None,
    foot: str | None = None,
    keypoints: Sequence[float] = KEYPOINTS,
    margin: float = 0.02,
    torque_limit: float | Mapping[str, float] = 300.0,
    posture: float = 0.2,
    upright: Sequence[str] | None = None,
    objective: str = "torque",
) -> PeriodicGaitProblem:
    """The paper's periodic gait on a pinned stance foot (see the module docstring).

    Parameters
    ----------
    linkage : default the six-link anthropoid.
    law : a :class:`GaitLaw` with one value per link, or a preset name ("walking": the swing
        leg about -pi/2; "paper22": every link about the upward vertical, as printed).
    N, transcription, degree, formulation : the mesh (``planner.OCP``; default
        Hermite-Simpson, N = 50).
    accuracy : instead of N, transcription and degree, a preset of
        :data:`problems.ACCURACY_PRESETS` ("draft", "balanced", "precise"): its transcription,
        its intervals per second of the period, and its IPOPT tolerance in
        :meth:`PeriodicGaitProblem.solve`.
    foot : the link whose end is the swing foot; default the biped's swing shank (or the
        last link of a tree that is not a biped).
    keypoints : fractions of the period in (0, 1) where the foot follows the law; () for none.
    margin : the foot may go this far below the law's lowest point, m (>= 0).
    torque_limit : |M_i| bound, N m, one number or one per link.
    posture : largest deviation of an upright link from the vertical, rad.
    upright : links kept near upright (default: the upper body of a biped, else none).
    objective : "torque", "torque-rate" or "work".
    """
    linkage = six_link_anthropoid() if linkage is None else linkage
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    if isinstance(law, str):
        law = GaitLaw.preset(law)
    if not isinstance(law, GaitLaw):
        raise DefinitionTypeError(f"`law`: must be a GaitLaw or a preset name, got {law!r}")
    law.check_links(linkage.names)
    try:
        biped = Biped.of(linkage)
    except DefinitionError:
        biped = None
    if foot is None:
        foot = biped.swing_shank if biped is not None else linkage.names[-1]
    check_links("foot", (foot,), linkage)
    fractions = tuple(check_real(f"keypoints[{i}]", f) for i, f in enumerate(keypoints))
    for f in fractions:
        if not 0.0 < f < 1.0:
            raise DefinitionError(
                f"`keypoints`: fractions of the period must lie in (0, 1), got {f!r} (t = 0 "
                "and T are one instant of a periodic gait)"
            )
    margin = check_real("margin", margin)
    if margin < 0:
        raise DefinitionError(f"`margin`: must be >= 0 m, got {margin!r}")
    posture = check_positive("posture", posture, "rad")
    if upright is None:
        upright = biped.upper_body if biped is not None else ()
    upright = check_links("upright", upright, linkage)
    check_objective(objective)
    mesh = resolve_mesh(accuracy, law.period, N, transcription, degree, default_N=50)
    dynamics = Dynamics(linkage)
    point = dynamics.point(foot)
    period = law.period
    targets = np.atleast_1d(point.position(law.psi(np.array(fractions) * period)))
    lowest = float(np.min(point.position(law.psi(np.linspace(0.0, period, 2001))).imag))
    problem = PeriodicGaitProblem(
        linkage=linkage,
        dynamics=dynamics,
        law=law,
        foot_link=foot,
        keypoints=fractions,
        foot_targets=np.column_stack([targets.real, targets.imag])
        if fractions
        else np.zeros((0, 2)),
        foot_minimum=lowest,
        margin=margin,
        torque_limit=torque_limits(linkage, torque_limit),
        posture=posture,
        upright=upright,
        objective=objective,
        ocp=None,  # built from the problem's pieces, below
        accuracy=accuracy,
    )
    N, transcription, degree = mesh["N"], mesh["transcription"], mesh["degree"]
    return replace(problem, ocp=_periodic_ocp(problem, N, transcription, degree, formulation))


def _periodic_ocp(problem: PeriodicGaitProblem, N, transcription, degree, formulation) -> OCP:
    linkage = problem.linkage
    position = problem.foot.function("position")
    mesh = {"N": N, "transcription": transcription, "degree": degree, "formulation": formulation}
    ocp = gait_ocp(problem.dynamics, problem.law.period, mesh, problem.torque_limit)
    scale = CLEARANCE_SCALE * problem.foot_reach
    ocp = ocp.constrain(
        "clearance",
        lambda p: position(p.psi)[1],
        lower=problem.foot_minimum - problem.margin,
        scale=scale,
    )
    if problem.keypoints:
        ocp = ocp.constrain_at(
            "foot",
            lambda p: ca.vertcat(*position(p.psi)),
            fraction=list(problem.keypoints),
            lower=problem.foot_targets,
            upper=problem.foot_targets,
            scale=max(float(np.max(np.abs(problem.foot_targets))), 2.0 * scale),
        )
    ocp = keep_upright(ocp, problem.upright, problem.posture).periodic()
    return finish_gait_ocp(ocp, linkage, problem.objective, problem.torque_limit, problem.law)


__all__ = ["CLEARANCE_SCALE", "KEYPOINTS", "PeriodicGait", "PeriodicGaitProblem", "periodic_gait"]
