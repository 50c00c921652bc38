"""The extremes matrix (numerical stability at the edges of the range): every case with its
tolerance and its expected outcome, as data that ``tests/test_extremes.py`` reads.

A case either agrees with an independent reference to the tolerance stated here (relative
error per state, Euclidean over the state's components, Frobenius for matrices; where the
mass matrix's or the impact system's condition number is what limits the accuracy, the
tolerance is that number times the value given, and the case says so), or raises the
library's error class with a message matching the pattern given. A result that is NaN or
inf fails every check.

References (none shares code with the library): ``reference.newton_euler`` (recursive
Newton-Euler in numpy: mass matrices, inverse and forward dynamics, the floating base, point
Jacobians), a dense KKT solve of the impact in numpy, and closed-form optima of free-time
problems (the planner's cases).

``python tests/extremes.py`` prints the table that tests/extremes.md shows
(tests/test_extremes.py checks that the guide holds exactly this table);
``python -m pytest tests/test_extremes.py`` runs the fast cases, ``-m slow`` the long matrix.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

if __package__ in (None, ""):  # run as a script: the oracle package sits beside this file
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from reference import newton_euler as ne

from model import DefinitionError, Dynamics, Link, Linkage, LinkageTrajectory, presets
from planner import SolverError
from problems import GaitVerificationError


# ---- outcomes ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Tol:
    """Relative error <= value (times the per-state condition number ``scaled_by`` when
    given: "cond(M)", "cond(M_e)" the floating-base mass matrix, "cond(KKT)" the impact's
    saddle-point matrix)."""

    value: float
    scaled_by: str | None = None

    def __str__(self) -> str:
        return f"{self.value:.0e}" + (f" x {self.scaled_by}" if self.scaled_by else "")


@dataclass(frozen=True)
class Raises:
    """The computation raises ``error`` with a message matching ``match``."""

    error: type
    match: str

    def __str__(self) -> str:
        return f"raises {self.error.__name__}"


# ---- model cases ---------------------------------------------------------------------------
#: What a model case checks, and against what:
#: M     mass matrix                      vs Newton-Euler columns (numpy)
#: ID    inverse dynamics                 vs recursive Newton-Euler
#: FD    forward dynamics                 vs numpy.linalg.solve on the oracle's M
#: FD-r  the oracle's inverse dynamics of the model's accelerations vs the torques given
#:       (backward error: meaningful however large cond(M) is)
#: M_e   floating-base mass matrix        vs floating Newton-Euler
#: imp   impact map, base free            vs a dense KKT solve with the oracle's M_e and J
#: imp0  impact map, base held            vs a dense KKT solve with the oracle's M and J
QUANTITIES = ("M", "ID", "FD", "FD-r", "M_e", "imp", "imp0")


@dataclass(frozen=True)
class ModelCase:
    name: str
    linkage: Callable[[], Linkage | list[Linkage]]  # one tree, or several alike
    states: Callable[[Linkage], tuple]  # (psi, dpsi, ddpsi, torques), each (K, n)
    checks: dict[str, Tol | Raises]
    note: str = ""
    point: str | None = None  # link whose end lands, for imp / imp0 (default: the last)
    slow: bool = False


def random_states(count: int, seed: int, speed: float = 2.0):
    """States for a linkage: psi uniform in [-pi, pi), dpsi normal (std ``speed`` rad/s),
    ddpsi normal (std 10 rad/s^2), torques of another random motion (the scene's scale)."""

    def make(linkage: Linkage):
        rng = np.random.default_rng(seed)
        n = linkage.n
        psi = rng.uniform(-np.pi, np.pi, (count, n))
        dpsi = rng.normal(0.0, speed, (count, n))
        ddpsi = rng.normal(0.0, 10.0, (count, n))
        torques = ne.inverse_dynamics(linkage, psi, dpsi, rng.normal(0.0, 10.0, (count, n)))
        return psi, dpsi, ddpsi, torques

    return make


def fast_states(count: int, seed: int, top: float):
    """Angular velocities uniform in [-top, top] rad/s."""

    def make(linkage: Linkage):
        psi, _, ddpsi, _ = random_states(count, seed)(linkage)
        rng = np.random.default_rng(seed + 1)
        dpsi = rng.uniform(-top, top, psi.shape)
        torques = ne.inverse_dynamics(linkage, psi, dpsi, rng.normal(0.0, 10.0, psi.shape))
        return psi, dpsi, ddpsi, torques

    return make


def posed_states(count: int, seed: int, pose: Callable[[int], np.ndarray], spread: float):
    """Angles ``pose(n)`` plus normal noise of std ``spread`` rad (0: exactly the pose)."""

    def make(linkage: Linkage):
        _, dpsi, ddpsi, _ = random_states(count, seed)(linkage)
        rng = np.random.default_rng(seed + 2)
        psi = pose(linkage.n) + rng.normal(0.0, 1.0, dpsi.shape) * spread
        torques = ne.inverse_dynamics(linkage, psi, dpsi, rng.normal(0.0, 10.0, psi.shape))
        return psi, dpsi, ddpsi, torques

    return make


def aligned(n: int) -> np.ndarray:
    """Every link along one line (0.3 rad from +x)."""
    return np.full(n, 0.3)


def folded(n: int) -> np.ndarray:
    """A zig-zag: each link turned back onto its parent (pi apart)."""
    return 0.3 + np.pi * (np.arange(n) % 2)


def six_folded(n: int) -> np.ndarray:
    """The six-link scene folded flat: both legs on one line, torso and head back down."""
    return 1.3 + np.array([0.0, np.pi, 0.0, np.pi, np.pi, 0.0])


def span_tree(seed: int, n_links: int, general: bool = False) -> Callable[[], Linkage]:
    """A random tree with lengths, masses and inertias log-uniform over 1e-3..1e3."""
    return lambda: ne.random_tree(
        np.random.default_rng(seed), n_links, span=(1e-3, 1e3), general=general
    )


def chain_of(values) -> Callable[[], Linkage]:
    """A chain whose link i has length and mass values[i] (m, kg), a uniform rod's J."""
    values = tuple(float(v) for v in values)
    return lambda: Linkage(
        [Link(f"L{i}", None if i == 0 else f"L{i - 1}", v, v) for i, v in enumerate(values)]
    )


def star(values) -> Callable[[], Linkage]:
    """A 1 m, 1 kg hub with one child per value (length and mass), all on the hub's end."""
    values = tuple(float(v) for v in values)
    return lambda: Linkage(
        [Link("hub", None, 1.0, 1.0)] + [Link(f"c{i}", "hub", v, v) for i, v in enumerate(values)]
    )


def point_mass_chain(n: int, com: float) -> Callable[[], Linkage]:
    return lambda: presets.n_link_chain(n, inertia=0.0, com=com)


def hinge_point_mass() -> Linkage:
    """A root whose mass sits on its start hinge (com = 0, J = 0): only its child, hanging
    from its end, gives its angle dynamics."""
    return Linkage(
        [
            Link("arm", None, 1.0, 1.0, com=0.0, inertia=0.0),
            Link("bob", "arm", 1.0, 1.0, com=1.0, inertia=0.0),
        ]
    )


def ten_child_star() -> Linkage:
    return Linkage(
        [Link("hub", None, 1.0, 2.0)]
        + [Link(f"c{i}", "hub", 0.5 + 0.1 * i, 1.0 + i) for i in range(10)]
    )


def stretched_pair() -> Linkage:
    return presets.n_link_chain(2)


#: The tolerances every regular case meets: 10-100 times the worst errors measured over the
#: matrix (M 8e-16, ID 1.1e-13 where a hinge's torque is a small difference of large terms in
#: a six-decade tree, else 4e-15; FD-r 5e-15, M_e 8e-16; FD 2e-16 x cond(M), imp and imp0
#: 1.3e-16 x cond(KKT)).
EXACT = {"M": Tol(1e-14), "ID": Tol(1e-12), "FD-r": Tol(1e-13), "M_e": Tol(1e-14)}
#: Forward dynamics and the impact lose accuracy with the condition number of what they solve.
SOLVES = {
    "FD": Tol(1e-14, "cond(M)"),
    "imp": Tol(1e-14, "cond(KKT)"),
    "imp0": Tol(1e-14, "cond(KKT)"),
}
ALL = {**EXACT, **SOLVES}

MODEL_CASES: list[ModelCase] = [
    *[
        ModelCase(
            f"span 1e-3..1e3: random 12-link tree {seed}",
            span_tree(seed, 12),
            random_states(16, seed),
            ALL,
            "lengths, masses, inertias log-uniform over six decades; cond(M) up to 5e10",
        )
        for seed in range(3)
    ],
    ModelCase(
        "span 1e-3..1e3: 20 more random 12-link trees",
        lambda: [span_tree(seed, 12)() for seed in range(3, 23)],
        random_states(64, 3),
        ALL,
        "the same, more trees and states",
        slow=True,
    ),
    ModelCase(
        "span 1e-3..1e3: random 10-link general tree",
        span_tree(10, 10, general=True),
        random_states(16, 10),
        ALL,
        "off-axis centres of mass and displaced hinges (locked bodies)",
    ),
    ModelCase(
        "span: chain 1e3 m, kg down to 1e-3 (7 links)",
        chain_of(np.logspace(3, -3, 7)),
        random_states(16, 1),
        ALL,
        "cond(M) ~ 1e18: FD's tolerance exceeds 1 and says nothing; its residual FD-r holds",
    ),
    ModelCase(
        "span: chain 1e-3 up to 1e3 (7 links)",
        chain_of(np.logspace(-3, 3, 7)),
        random_states(16, 2),
        ALL,
        "heavy tip: cond(M) ~ 1e17, as above",
    ),
    ModelCase(
        "span: chain alternating 1e3 and 1e-3 (6 links)",
        chain_of([1e3, 1e-3] * 3),
        random_states(16, 3),
        ALL,
        "cond(M) ~ 1e19, as above",
    ),
    ModelCase(
        "span: star, children 1e-3..1e3 on one hub",
        star(np.logspace(-3, 3, 7)),
        random_states(16, 4),
        ALL,
        "cond(M) ~ 1e18, as above",
    ),
    ModelCase(
        "J = 0: chain of 5 point masses at mid-link",
        point_mass_chain(5, 0.5),
        random_states(16, 5),
        ALL,
    ),
    ModelCase(
        "J = 0, com = 1: chain of 5 masses on the end hinges",
        point_mass_chain(5, 1.0),
        random_states(16, 6),
        {
            **ALL,
            "imp": Raises(DefinitionError, r"the impact is singular.*mass matrix is singular"),
        },
        "no mass at H0: with the base free, H0 moves carrying nothing (M_e singular in every "
        "pose), the impact is refused",
    ),
    ModelCase(
        "J = 0, com = 0: root's mass on its hinge, child at its end",
        hinge_point_mass,
        random_states(16, 7),
        ALL,
        "the root's angle moves only the child",
    ),
    ModelCase(
        "com = 0: chain of 5 (J > 0)",
        lambda: presets.n_link_chain(5, com=0.0),
        random_states(16, 8),
        ALL,
    ),
    ModelCase(
        "com = 1: chain of 5 (J > 0)",
        lambda: presets.n_link_chain(5, com=1.0),
        random_states(16, 9),
        ALL,
    ),
    ModelCase(
        "six-link nearly aligned (1e-9 rad)",
        presets.six_link_anthropoid,
        posed_states(16, 10, aligned, 1e-9),
        {
            **EXACT,
            "FD": SOLVES["FD"],
            "imp": SOLVES["imp"],
            "imp0": Raises(DefinitionError, r"the impact is singular.*Jacobian loses rank"),
        },
        "every link on one line through H0: the held-base impact is singular (the landing "
        "point cannot move along the line) and says so",
        point="swing_shank",
    ),
    ModelCase(
        "six-link folded flat (1e-9 rad)",
        presets.six_link_anthropoid,
        posed_states(16, 11, six_folded, 1e-9),
        {
            **EXACT,
            "FD": SOLVES["FD"],
            "imp": SOLVES["imp"],
            "imp0": Raises(DefinitionError, r"the impact is singular.*Jacobian loses rank"),
        },
        "legs folded onto each other: as above",
        point="swing_shank",
    ),
    ModelCase(
        "J = 0: chain of 10 point masses nearly aligned (1e-3 rad)",
        point_mass_chain(10, 0.5),
        posed_states(16, 12, aligned, 1e-3),
        {**EXACT, "FD": SOLVES["FD"], "imp": Tol(1e-18, "cond(M_e)"), "imp0": SOLVES["imp0"]},
        "floating point masses near one line: M_e nearly singular (cond ~1e8), the impact's "
        "accuracy follows cond(M_e) (1e-20 measured)",
    ),
    ModelCase(
        "J = 0: chain of 10 point masses aligned exactly",
        point_mass_chain(10, 0.5),
        posed_states(4, 13, aligned, 0.0),
        {
            **EXACT,
            "FD": SOLVES["FD"],
            "imp": Raises(DefinitionError, r"the impact is singular.*mass matrix is singular"),
            "imp0": Raises(DefinitionError, r"the impact is singular.*Jacobian loses rank"),
        },
        "M_e singular (a motion that moves no mass) and J rank 1: both impacts refused",
    ),
    ModelCase(
        "J = 0: chain of 10 point masses folded (1e-9 rad)",
        point_mass_chain(10, 0.5),
        posed_states(16, 14, folded, 1e-9),
        {**EXACT, "FD": SOLVES["FD"]},
    ),
    ModelCase(
        "two links stretched through the landing point, base held",
        stretched_pair,
        posed_states(4, 15, aligned, 0.0),
        {**EXACT, "FD": SOLVES["FD"], "imp0": Raises(DefinitionError, "Jacobian loses rank")},
        "J M^-1 J^T singular: refused, where the range-space solve returned wrong numbers",
    ),
    ModelCase(
        "six-link at up to 100 rad/s",
        presets.six_link_anthropoid,
        fast_states(32, 16, 100.0),
        {**ALL, "FD": Tol(1e-12, "cond(M)")},
        "velocity terms ~1e4 rad^2/s^2 cancel against torques of that size in FD",
        point="swing_shank",
    ),
    ModelCase(
        "six-link at up to 100 rad/s",
        presets.six_link_anthropoid,
        fast_states(256, 116, 100.0),
        {**ALL, "FD": Tol(1e-12, "cond(M)")},
        "more states",
        point="swing_shank",
        slow=True,
    ),
    ModelCase(
        "chain of 40 links: floating base and impacts",
        lambda: presets.n_link_chain(40),
        random_states(8, 17),
        {"M_e": EXACT["M_e"], "imp": SOLVES["imp"], "imp0": SOLVES["imp0"]},
        "M, ID, FD of this chain: tests/test_dynamics.py (CASES)",
    ),
    ModelCase(
        "chain of 80 links",
        lambda: presets.n_link_chain(80),
        random_states(8, 18),
        ALL,
        slow=True,
    ),
    ModelCase(
        "star: 10 children on one link",
        ten_child_star,
        random_states(16, 19),
        ALL,
        point="c9",
    ),
]


# ---- planner cases -------------------------------------------------------------------------
@dataclass(frozen=True)
class PlannerCase:
    """A free-time rest-to-rest problem with a known optimum: min integral (1 + u^2) dt over
    a distance d, u = the acceleration (``double integrator``) or the torque of a rod turning
    without gravity (``rod``, I = 0.6 kg m^2: u = I ddpsi); T* = sqrt(6 I d) and the cost
    4 T*/3. Hermite-Simpson is exact on it (cubic motion, linear control) for any N, so the
    errors measure the NLP and the solver only. ``duration`` is T*, s (d follows)."""

    family: str
    name: str
    problem: str  # "double integrator" or "rod"
    N: int
    duration: float
    tol: float
    expect: Tol  # relative error of T and of the cost
    formulation: str = "implicit"
    slow: bool = False


def _planner(family, problem, N, duration, tol, expect, **kw):
    label = f"{problem}, N = {N}, T* = {duration:g} s, tol {tol:.0e}"
    if kw.get("formulation") == "explicit":
        label += ", explicit"
    return PlannerCase(family, label, problem, N, duration, tol, expect, **kw)


_N = "N from 2 to 1000 (T* = 1 s, tol 1e-8)"
_T = "T* from 0.05 to 20 s (N = 20, tol 1e-8)"
_TOL = "IPOPT tol from 1e-3 to 1e-10 (N = 20, T* = 1 s)"
PLANNER_CASES: list[PlannerCase] = [
    *[_planner(_N, "double integrator", N, 1.0, 1e-8, Tol(1e-7)) for N in (2, 10, 100, 1000)],
    *[_planner(_N, "rod", N, 1.0, 1e-8, Tol(1e-7)) for N in (2, 1000)],
    _planner(_N, "rod", 1000, 1.0, 1e-8, Tol(1e-7), formulation="explicit"),
    _planner(_N, "double integrator", 300, 1.0, 1e-8, Tol(1e-7), slow=True),
    *[
        _planner(_T, problem, 20, T, 1e-8, Tol(1e-6))
        for problem in ("double integrator", "rod")
        for T in (0.05, 0.2, 1.0, 5.0, 20.0)
    ],
    *[
        _planner(_TOL, problem, 20, 1.0, tol, Tol(max(10.0 * tol, 1e-8)))
        for problem in ("double integrator", "rod")
        for tol in (1e-3, 1e-4, 1e-6, 1e-8, 1e-10)
    ],
    *[
        _planner(
            "N = 1000 at both ends of T*, tol 1e-10", "rod", 1000, T, 1e-10, Tol(1e-8), slow=True
        )
        for T in (0.05, 20.0)
    ],
]


@dataclass(frozen=True)
class GaitCase:
    """A walking step or the fixed-base gait at an extreme of the planner's range: solved
    and verified in numpy (``verify_gait``), or compared with a reference solve, or the
    documented failure."""

    name: str
    kind: str  # "walk" or "gait"
    options: dict = field(default_factory=dict)  # walking_step / periodic_gait keywords
    ipopt: dict = field(default_factory=dict)
    expect: Tol | Raises | str = "verified"  # Tol: cost against tol 1e-10's
    slow: bool = True


GAIT_CASES: list[GaitCase] = [
    GaitCase("walking step, 0.5 m in 0.2 s", "walk", {"step_time": 0.2}),
    # 20 s at N = 30: intervals of 0.67 s, longer than the legs' swing time scales, so the
    # plan swings freely between its points; the hold cuts the mesh where it misses by much
    # and backs off the rest in the same rounds: 30 -> 108 intervals in 9 re-solves (18 s
    # here), verified (it ran out of its 20 rounds while a cut round backed off nothing; the
    # accuracy check warns: the open-loop re-integration of so slow a step drifts). At N = 100
    # it holds too (12 rounds, 28 s). A hold that runs out says so: test_sampled_limits.py.
    GaitCase("walking step, 0.5 m in 20 s, N = 30", "walk", {"step_time": 20.0}),
    GaitCase("walking step, 0.5 m in 20 s, N = 100", "walk", {"step_time": 20.0, "N": 100}),
    GaitCase(
        "walking step, 0.5 m in 0.05 s (10 m/s)",
        "walk",
        {"step_time": 0.05},
        {"max_iter": 150},
        Raises(SolverError, r"IPOPT failed with status \w+"),
    ),
    GaitCase("walking step, N = 2", "walk", {"N": 2}),
    GaitCase("walking step, N = 200", "walk", {"N": 200}),
    *[
        GaitCase(f"walking step, tol {t:.0e}", "walk", {}, {"tol": t}, Tol(10 * t))
        for t in (1e-3, 1e-6)
    ],
    *[
        GaitCase(f"fixed-base gait, tol {t:.0e}", "gait", {}, {"tol": t}, Tol(10 * t))
        for t in (1e-3, 1e-6)
    ],
    # 93 % of the legs' span (2 x 0.86 m): no plan lands the foot there with the body above
    # the ground and the ankle torque within its sole (without those rows it solves, with the
    # stance knee 0.157 m under the ground and the centre of pressure up to 107 m behind the
    # ankle); 1.4 m solves and verifies; infeasible at 1.0 s too, 1.4 mm short
    # (examples/benchmarks/similarity.py).
    GaitCase(
        "walking step, 1.6 m in 0.5 s",
        "walk",
        {"step_length": 1.6},
        expect=Raises(SolverError, r"IPOPT failed with status \w+ .*end\[landing\]"),
    ),
    # Plans that converge but fail their own check are not handed out as successes (before,
    # solve() returned both with Solve_Succeeded and only verify() said so). The heavy torso's
    # last swing moves between two 1 kHz samples more than they show (it verifies at 2 kHz);
    # the slow step on feet lets its front heel drift in the double support (a finer mesh).
    GaitCase(
        "walking step, a 340 kg torso",
        "walk",
        {"linkage_overrides": {"torso_mass": 340.0}},
        expect=Raises(
            GaitVerificationError, r"fails its own verification at 1000 Hz: kinematics misses"
        ),
    ),
    GaitCase(
        "step on feet at 0.1 m/s",
        "feet",
        {"speed": 0.1},
        expect=Raises(
            GaitVerificationError, r"fails its own verification at 1000 Hz: heel at rest misses"
        ),
    ),
]


@dataclass(frozen=True)
class ScaledCase:
    """The walking step of a walker scaled by ``size`` (every length; masses unchanged) and
    ``gravity`` (g), given its step in its own units (0.5 leg lengths of the six-link's in
    0.5 s times sqrt(size / gravity)) and drives scaled as m g L (150 N m x size x gravity),
    the rest left to the defaults (clearance, touchdown speed, approach window: dynamic
    similarity, ``problems.gait.similarity``): the six-link's dimensionless optimum (cost /
    ((size gravity)^2 sqrt(size / gravity))) to ``expect``, verified in numpy."""

    name: str
    size: float
    gravity: float
    expect: Tol = Tol(1e-6)
    slow: bool = False
    kind: str = "walk"  # or "feet": the step on feet (Winter's body), its optimum 636.6


SCALED_CASES: list[ScaledCase] = [
    *[ScaledCase(f"walking step, a walker {f:g} times the size", f, 1.0) for f in (1e-3, 1e3)],
    *[ScaledCase(f"walking step, a walker under {f:g} g", 1.0, f) for f in (1e-3, 1e3)],
    # its first solve takes 133 iterations against 80 (a scale of the step on feet that does
    # not follow the walker yet) and lands 2.3e-5 from the six-link-feet optimum
    ScaledCase("step on feet, a walker 0.001 times the size", 1e-3, 1.0, Tol(1e-4), True, "feet"),
    ScaledCase("step on feet, a walker under 0.001 g", 1.0, 1e-3, Tol(1e-6), True, "feet"),
]


@dataclass(frozen=True)
class UnitsCase:
    """The same problem in millimetres and grams (lengths mm, masses g, J g mm^2, g 9810
    mm/s^2, torques g mm^2/s^2 = 1e-9 N m) and in SI: the same physical answer (angles in rad,
    rates and torques relative to their largest, cost) and iterations within ``iterations``
    (a fraction of SI's)."""

    name: str
    kind: str  # "walk" or "gait"
    options: dict = field(default_factory=dict)
    expect: Tol = Tol(1e-6)
    iterations: float = 0.2
    slow: bool = False
    tol: float = 1e-8  # IPOPT's


UNITS_CASES: list[UnitsCase] = [
    UnitsCase("walking step in mm and g", "walk"),
    UnitsCase(
        "walking step with a double support, in mm and g (tol 1e-10)",
        "walk",
        {"double_support": 0.1, "N": 20},
        slow=True,
        tol=1e-10,  # its optimum is flat: at 1e-8 two solves end up to 5e-6 apart in torque
    ),
    UnitsCase("fixed-base gait in mm and g", "gait", slow=True),
]


# ---- bad input -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Exits:
    """The command line exits with ``status``, one error line matching ``match`` on stderr,
    and no output folder left behind."""

    status: int
    match: str

    def __str__(self) -> str:
        return f"exit {self.status}, nothing on disk"


@dataclass(frozen=True)
class InputCase:
    """A mistake at the public API: ``call(tmp_path)`` raises ``expect`` at once (nothing
    solved or written), or for the command line returns (argv, output folder) and the run
    ends as ``expect`` says. ``covered_by`` ("<test file>: <text>"): an existing test checks
    this message already; the matrix records it and tests/test_extremes.py checks that the
    file holds the text."""

    name: str
    expect: Raises | Exits
    call: Callable | None = None
    covered_by: str = ""


def _six_dynamics():
    return Dynamics(presets.six_link_anthropoid())


def _law(n: int):
    from problems import GaitLaw

    return GaitLaw(1.0, [0.1] * n, [0.0] * n, name=f"law{n}")


def _nan_guess(kind: str):
    from planner import OCP

    ocp = OCP(_six_dynamics(), T=1.0, N=10)
    t = np.linspace(0.0, 1.0, 11)
    law = _law(6)
    psi = law.psi(t)
    psi[3, 2] = np.nan
    if kind == "function":
        return ocp.guess(lambda times: (np.full((np.size(times), 6), np.nan),))

    names = presets.six_link_anthropoid().names
    return ocp.guess(LinkageTrajectory.from_linkage(t, psi, law.dpsi(t), np.zeros((11, 6)), names))


def _nan_guess_vector():
    from planner import OCP, Transcription, solve

    transcription = Transcription(OCP(_six_dynamics(), T=1.0, N=4))
    guess = transcription.initial_guess()
    guess[5] = np.nan
    return solve(transcription, guess=guess, progress=False)


def _missing_column(tmp_path):
    from problems import simulate

    names = presets.six_link_anthropoid().names
    t = np.linspace(0.0, 0.3, 7)
    law = _law(6)
    full = LinkageTrajectory.from_linkage(t, law.psi(t), law.dpsi(t), np.zeros((7, 6)), names)
    path = full.save(tmp_path / "full.csv")
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    keep = [i for i, c in enumerate(header) if not c.startswith("M_torso ")]
    rows = [line for line in lines if not line.startswith("#")]
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join(",".join(row.split(",")[i] for i in keep) for row in rows) + "\n")
    profile = LinkageTrajectory.load(cut)
    return simulate(_six_dynamics(), profile, np.zeros(12), (0.0, 0.3))


def _walking(**options):
    from problems import walking_step

    return walking_step(**options)


def _cli_walk_too_long(tmp_path):
    return ["walk", "--quick", "-q", "--step-length-m", "1.9", "--output-dir"], tmp_path / "out"


def _cli_walk_failed(tmp_path):
    # 1 N m per hinge cannot hold the body up: IPOPT fails
    argv = ["walk", "--quick", "-q", "--no-plots", "--torque-limit-nm", "1", "--output-dir"]
    return argv, tmp_path / "out"


def _cli_simulate_failed(tmp_path):

    law = _law(6)
    t = np.linspace(0.0, 0.3, 31)
    names = presets.six_link_anthropoid().names
    huge = LinkageTrajectory.from_linkage(t, law.psi(t), law.dpsi(t), np.full((31, 6), 1e9), names)
    path = huge.save(tmp_path / "huge.csv")
    return ["simulate", str(path), "-q", "--no-plots", "--output-dir"], tmp_path / "out"


INPUT_CASES: list[InputCase] = [
    InputCase(
        "NaN in a guess (values)",
        Raises(DefinitionError, r"`guess\[psi\]`: contains NaN or inf"),
        covered_by="test_ocp.py: contains NaN or inf",
    ),
    InputCase(
        "NaN from a guess function",
        Raises(DefinitionError, r"`guess\[psi\]`: the function returned NaN or inf"),
        lambda tmp: _nan_guess("function"),
    ),
    InputCase(
        "NaN in a guess Trajectory",
        Raises(DefinitionError, r"`psi`: must be finite, got nan at sample 3, column 2"),
        lambda tmp: _nan_guess("trajectory"),
    ),
    InputCase(
        "NaN in a guess vector given to solve",
        Raises(DefinitionError, r"`guess`: contains NaN or inf at 1 of \d+ entries"),
        lambda tmp: _nan_guess_vector(),
    ),
    InputCase(
        "a 5-link law as the guess of a 6-link OCP",
        Raises(DefinitionError, r"`guess\[psi\]`: .*: 5 values per time where `psi` has 6"),
        lambda tmp: __import__("planner").OCP(_six_dynamics(), T=1.0, N=10).guess(_law(5)),
    ),
    InputCase(
        "a 6-link law for periodic_gait on 5 links",
        Raises(DefinitionError, r"`law`: drives 6 links but the linkage has 5"),
        covered_by="test_periodic_gait.py: `law`: drives 6 links but the linkage has 5",
    ),
    InputCase(
        "a 6-link law for torques_along on 5 links",
        Raises(DefinitionError, r"`law`: drives 6 links but the linkage has 5"),
        covered_by="test_dynamics_problems.py: `law`: drives 6 links but the linkage has 5",
    ),
    InputCase(
        "a torque file without a torque column (simulate)",
        Raises(DefinitionError, r"`torques`: the profile lacks the column\(s\) M_torso \[N m\]"),
        _missing_column,
    ),
    InputCase(
        "a torque file without an angle column (CLI simulate)",
        Exits(2, r"lacks the column\(s\) psi_head"),
        covered_by="test_cli.py: the profile lacks the column",
    ),
    InputCase(
        "a negative duration: OCP(T=-1)",
        Raises(DefinitionError, r"`T`: must be a finite duration > 0 s"),
        covered_by="test_ocp.py: `T`: must be a finite duration > 0 s",
    ),
    InputCase(
        "a negative step time",
        Raises(DefinitionError, r"`step_time`: must be > 0 s, got -0.5"),
        covered_by="test_walking.py: `step_time`: must be > 0 s, got -0.5",
    ),
    InputCase(
        "a negative law period",
        Raises(DefinitionError, r"`GaitLaw.period`: must be > 0 s"),
        covered_by="test_gait_law.py: `GaitLaw.period`: must be > 0 s",
    ),
    InputCase(
        "a simulation span that runs backwards",
        Raises(DefinitionError, r"`t_span`: needs finite t0 < tf"),
        covered_by="test_dynamics_problems.py: `t_span`: needs finite t0 < tf",
    ),
    InputCase(
        "a free-duration bound <= 0",
        Raises(DefinitionError, r"`T`: free duration bounds must be finite and > 0"),
        covered_by="test_ocp.py: `T`: free duration bounds must be finite and > 0",
    ),
    InputCase(
        "a negative double support",
        Raises(DefinitionError, r"`double_support`: must lie in \[0, step_time\)"),
        covered_by="test_walking.py: `double_support`: must lie in",
    ),
    InputCase(
        "a clearance profile giving NaN",
        Raises(DefinitionError, r"`clearance`: a profile must map s = t / T \(K,\) to finite"),
        lambda tmp: _walking(clearance=lambda s: np.full(np.shape(s), np.nan)),
    ),
    InputCase(
        "a negative posture bound",
        Raises(DefinitionError, r"`posture`: must be > 0 rad, got -1.0"),
        lambda tmp: _walking(posture=-1.0),
    ),
    InputCase(
        "a walking step without gravity",
        Raises(DefinitionError, r"`linkage.gravity`: a walking step needs gravity > 0"),
        lambda tmp: _walking(linkage=presets.six_link_anthropoid(gravity=0.0)),
    ),
    InputCase(
        "CLI walk: a step too long for the legs",
        Exits(2, r"`step_length`: 1.9 m is too long for legs of 0.86 m"),
        _cli_walk_too_long,
    ),
    InputCase(
        "CLI walk: a solve that fails",
        Exits(1, r"IPOPT did not converge: \w+; nothing written"),
        _cli_walk_failed,
    ),
    InputCase(
        "CLI simulate: an integration that fails",
        Exits(1, r"integrator 'cvodes' failed"),
        _cli_simulate_failed,
    ),
]


# ---- the table ----------------------------------------------------------------------------
def _model_rows():
    for case in MODEL_CASES:
        outcome = ", ".join(f"{q} {case.checks[q]}" for q in QUANTITIES if q in case.checks)
        yield case.name + (" (slow)" if case.slow else ""), outcome, case.note


def _planner_rows():
    families: dict[str, list[PlannerCase]] = {}
    for case in PLANNER_CASES:
        families.setdefault(case.family, []).append(case)
    for family, cases in families.items():
        parts = []
        for problem in dict.fromkeys(c.problem for c in cases):
            mine = [c for c in cases if c.problem == problem]
            values = ", ".join(
                (
                    f"N {c.N}"
                    if family == _N
                    else f"{c.duration:g} s"
                    if family == _T
                    else f"{c.tol:.0e}"
                    if family == _TOL
                    else f"{c.duration:g} s"
                )
                + (" explicit" if c.formulation == "explicit" else "")
                + (" (slow)" if c.slow else "")
                + (f" to {c.expect}" if family == _TOL else "")
                for c in mine
            )
            parts.append(f"{problem}: {values}")
        tolerances = {str(c.expect) for c in cases}
        outcome = (
            "T and cost to " + tolerances.pop()
            if len(tolerances) == 1
            else "T and cost to 10 tol (>= 1e-8)"
        )
        yield f"free-time rest-to-rest, {family}", outcome, "; ".join(parts)
    for case in GAIT_CASES:
        if isinstance(case.expect, Tol):
            outcome = f"cost within {case.expect} of tol 1e-10's"
        elif isinstance(case.expect, Raises):
            why = {SolverError: " (IPOPT's status)", GaitVerificationError: " (the failed checks)"}
            outcome = f"raises {case.expect.error.__name__}" + why.get(
                case.expect.error, " (refine the mesh)"
            )
        else:
            outcome = "solves; verify_gait passes"
        yield case.name + (" (slow)" if case.slow else ""), outcome, ""
    for case in UNITS_CASES:
        yield (
            case.name + (" (slow)" if case.slow else ""),
            f"same answer to {case.expect}, iterations within {case.iterations:.0%}",
            "",
        )
    for case in SCALED_CASES:
        yield (
            case.name + (" (slow)" if case.slow else ""),
            f"the unscaled walker's dimensionless cost to {case.expect}; verify_gait passes",
            "defaults by dynamic similarity",
        )


def _input_rows():
    for case in INPUT_CASES:
        where = f"checked in {case.covered_by.split(':')[0]}" if case.covered_by else ""
        yield case.name, str(case.expect), where


def table() -> str:
    """The matrix as the Markdown table of tests/extremes.md."""
    lines = ["| case | tolerance / outcome | note |", "|---|---|---|"]
    for title, rows in (
        ("model", _model_rows()),
        ("planner", _planner_rows()),
        ("bad input", _input_rows()),
    ):
        lines.append(f"| **{title}** | | |")
        for name, outcome, note in rows:
            lines.append(f"| {name} | {outcome} | {note} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table())
