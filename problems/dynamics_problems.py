"""The seed paper's first and second problems of dynamics (Discussion, after law (22)).

* First problem (:func:`torques_along`): given a law of motion psi(t), find the drive torques
  by inverse dynamics, and the ground reaction at H0.
* Second problem (:func:`simulate`): given the torques, integrate the twelfth-order system
  (for six links) with a CasADi integrator and return the motion.
* :func:`replay_law` puts the two together: the law's own torques replayed from the law's
  initial state must reproduce the law, until the instability of the upright linkage
  amplifies the integration error; it measures the deviation, the horizon under a threshold
  and the growth rate.

Every result is a :class:`planner.trajectory.Trajectory`, the project's one torque-profile
type, so a result exports and plots exactly like a planner Solution.
"""

from __future__ import annotations

import inspect
import itertools
import logging
import math
import platform
import time as _time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata as _metadata

import casadi as ca
import numpy as np

from model import LinkageTrajectory
from model.dynamics import Dynamics
from model.linkage import Linkage
from planner.errors import (
    DefinitionError,
    DefinitionTypeError,
    as_float_array,
    check_finite,
    check_integer,
    check_positive,
    check_real,
)
from planner.simulation import (
    METHODS,
    MIN_TOLERANCE,
    SimulationError,
    Simulator,
    check_tolerance,
    monomial_coefficients,
)
from planner.trajectory import Trajectory
from planner.units import QUANTITIES, accepted, si_unit, to_si
from problems.gait.law import GaitLaw

__all__ = [
    "FIT_WINDOW",
    "MAX_OUTPUT_SAMPLES",
    "METHODS",
    "MIN_TOLERANCE",
    "ReplayReport",
    "SimulationError",
    "fit_growth_rate",
    "law_torque_function",
    "linkage_profile",
    "replay_law",
    "simulate",
    "torques_along",
    "upright_instability_rate",
    "versions",
]

logger = logging.getLogger(__name__)

#: Default fitting window of :func:`fit_growth_rate`, rad. Its low end sits well above the
#: integration noise: a cvodes replay at rtol = atol = 1e-10 wanders 1e-9 to 1.5e-8 rad off
#: the law in its first 0.2 s before the instability takes over (a 1e-9 start fitted 23.0 /s
#: there against 24.6 /s from 1e-7); its high end below the nonlinear saturation.
FIT_WINDOW = (1e-7, 1e-3)

#: Most output samples :func:`simulate` makes from ``rate_hz`` (memory: (2n + ...) floats each).
MAX_OUTPUT_SAMPLES = 10_000_000

#: Progress reporter: called with (fraction done in [0, 1], short message).
Progress = Callable[[float, str], None]


def versions() -> dict[str, str]:
    """Versions of the packages that produced a result (for exported metadata)."""
    try:
        own = _metadata.version("anthropoid-planner")
    except _metadata.PackageNotFoundError:  # running from a source tree without install
        own = "unknown"
    return {
        "anthropoid-planner": own,
        "casadi": ca.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


def _as_dynamics(dynamics: Dynamics | Linkage) -> Dynamics:
    if isinstance(dynamics, Linkage):
        return Dynamics(dynamics)
    if not isinstance(dynamics, Dynamics):
        raise DefinitionTypeError(
            f"`dynamics`: must be a model.Dynamics (or a model.Linkage), "
            f"got {type(dynamics).__name__}"
        )
    return dynamics


def _check_law(dynamics: Dynamics, law: GaitLaw) -> None:
    if not isinstance(law, GaitLaw):
        raise DefinitionTypeError(f"`law`: must be a problems.GaitLaw, got {type(law).__name__}")
    law.check_links(dynamics.names)


def _time_grid(name: str, t, minimum: int = 1) -> np.ndarray:
    """A strictly increasing finite 1-D array of times, s."""
    times = np.atleast_1d(as_float_array(name, t, "a 1-D array of times in s"))
    if times.ndim != 1 or times.size < minimum:
        raise DefinitionError(
            f"`{name}`: must be a 1-D array of at least {minimum} time(s) in s, "
            f"got shape {times.shape}"
        )
    check_finite(name, times, "times in s")
    if times.size > 1 and np.any(np.diff(times) <= 0):
        k = int(np.argmax(np.diff(times) <= 0))
        raise DefinitionError(
            f"`{name}`: times must increase strictly; t[{k + 1}] = {times[k + 1]!r} s "
            f"follows t[{k}] = {times[k]!r} s"
        )
    return times


# ---- first problem ------------------------------------------------------------------------
def torques_along(
    dynamics: Dynamics | Linkage,
    law: GaitLaw,
    t,
    metadata: dict | None = None,
) -> Trajectory:
    """First problem of dynamics: the hinge torques that make the linkage follow ``law``.

    Parameters
    ----------
    dynamics : model.Dynamics or model.Linkage
        The linkage's model (n links).
    law : GaitLaw
        A law for n links.
    t : array_like (K,)
        Strictly increasing times, s, K >= 2.
    metadata : dict, optional
        Extra entries merged into the result's metadata.

    Returns
    -------
    Trajectory
        time (K,), psi/dpsi (K, n) from the law (rad, rad/s), torques M (K, n) N m by inverse
        dynamics (one batched evaluation), extras ddpsi_<link> (rad/s^2) and Fx, Fy (N, the
        force of the ground on the root at H0), metadata: law parameters, model parameters,
        package versions.
    """
    dynamics = _as_dynamics(dynamics)
    _check_law(dynamics, law)
    # A Trajectory has at least 2 samples; one state's torques: dynamics.inverse_dynamics.
    times = _time_grid("t", t, minimum=2)
    psi, dpsi, ddpsi = law(times)
    try:
        torques = dynamics.inverse_dynamics(psi, dpsi, ddpsi)
        ground = dynamics.ground_reaction(psi, dpsi, ddpsi)
    except DefinitionError as exc:  # finite motion, torques beyond double precision
        raise DefinitionError(
            f"`law`: the torques along {law.name!r} overflow double precision (period "
            f"{law.period:g} s, angular accelerations up to {np.max(np.abs(ddpsi)):.3g} "
            f"rad/s^2); give a longer period or smaller amplitudes ({exc})"
        ) from exc
    info = {
        "source": "problems.torques_along",
        "problem": "first problem of dynamics: torques by inverse dynamics along a law",
        "law": law.to_dict(),
        "model": dynamics.linkage.parameters(),
        "versions": versions(),
    }
    info.update(metadata or {})
    return LinkageTrajectory.from_linkage(
        times,
        psi,
        dpsi,
        np.asarray(torques).reshape(times.size, dynamics.n),
        dynamics.names,
        ddpsi=ddpsi,
        ground_reaction=np.asarray(ground).reshape(times.size),
        metadata=info,
    )


def law_torque_function(dynamics: Dynamics | Linkage, law: GaitLaw) -> Callable:
    """The law's exact torques as a callable of time: t (K,) s -> M (K, n) N m.

    Evaluated by inverse dynamics at the requested times (no interpolation), which is what a
    replay needs to stay on the law for as long as the instability allows.
    """
    dynamics = _as_dynamics(dynamics)
    _check_law(dynamics, law)

    def torque(t):
        psi, dpsi, ddpsi = law(np.atleast_1d(np.asarray(t, dtype=float)))
        return np.asarray(dynamics.inverse_dynamics(psi, dpsi, ddpsi)).reshape(-1, dynamics.n)

    return torque


# ---- torque sources -------------------------------------------------------------------------
@dataclass(frozen=True)
class _TorqueSource:
    """A torque profile normalised for integration.

    ``evaluate`` maps times (K,) s to torques (K, n) N m; ``knots`` are the times where the
    profile's polynomial pieces join (empty for a smooth callable); ``span`` the time range
    it is defined on; ``description`` goes into metadata.
    """

    evaluate: Callable[[np.ndarray], np.ndarray]
    knots: np.ndarray
    span: tuple[float, float]
    description: dict
    trajectory: Trajectory | None


def _unit_problem(where: str, name: str, unit: str, si: str) -> str | None:
    """Why column ``name`` in ``unit`` cannot stand for a quantity in ``si``, or None."""
    known = si_unit(unit)
    quantity = QUANTITIES[si]
    if known is None:
        return (
            f"`{where}`: column `{name}` is in {unit!r}, a unit this library does not read as "
            f"{quantity}; give it in {si} (or one of {accepted(si)})"
        )
    if known[0] != si:
        return (
            f"`{where}`: column `{name}` is in {unit!r}, {QUANTITIES[known[0]]}, but it must "
            f"be {quantity}: {si} (or one of {accepted(si)})"
        )
    return None


def linkage_profile(
    profile: Trajectory, names, states: bool = True, where: str = "torques"
) -> Trajectory:
    """``profile`` in the linkage convention of the links ``names``, in SI units.

    Reads the columns by name: M_<link> (torques), and with ``states`` psi_<link> and
    dpsi_<link> (the initial state), whatever their order in the file; converts the units
    the library knows (deg -> rad, kN m -> N m, ..., :mod:`planner.units`). A profile whose
    controls are not named M_<link> but are as many as the links, all in torque units, is
    read in order. Raises DefinitionError naming the missing column, or the column and its
    unit when the unit is not one of the quantity's (a torque in 'rad', an angle in 'N m'),
    or unknown (a file in 'kN/m' is refused, not integrated as N m).
    """
    if not isinstance(profile, Trajectory):
        raise DefinitionTypeError(
            f"`{where}`: must be a planner Trajectory, got {type(profile).__name__}"
        )
    names = tuple(names)
    n = len(names)
    channels = {name: unit for name, unit, _ in profile.columns}
    wanted = [(f"M_{link}", "N m") for link in names]
    if states:
        wanted = (
            [(f"psi_{link}", "rad") for link in names]
            + [(f"dpsi_{link}", "rad/s") for link in names]
            + wanted
        )
    links = list(
        dict.fromkeys(c.split("_", 1)[1] for c in channels if c.startswith(("psi_", "dpsi_", "M_")))
    )
    torque_channels = len(profile.control_names)
    if set(links) - set(names):
        raise DefinitionError(
            f"`{where}`: the profile is for links {links}: the profile has {torque_channels} "
            f"torque channels but the linkage has {n} links {list(names)}; use a profile "
            "written for this linkage"
        )
    positional = not any(c.startswith("M_") for c in profile.control_names)
    if positional and torque_channels != n:
        raise DefinitionError(
            f"`{where}`: the profile has {torque_channels} torque channels but the linkage "
            f"has {n} links; use a profile written for this linkage"
        )
    # Controls under other names (a generic trajectory): read in order, units checked.
    renamed = (
        dict(zip(profile.control_names, (f"M_{link}" for link in names), strict=True))
        if positional
        else {}
    )
    missing = [
        f"{name} [{si}]"
        for name, si in wanted
        if name not in channels and name not in renamed.values()
    ]
    if missing:
        raise DefinitionError(
            f"`{where}`: the profile lacks the column(s) {', '.join(missing)}; a linkage "
            "profile needs psi_<link> [rad], dpsi_<link> [rad/s] (for the initial state) and "
            "M_<link> [N m] for every link of the linkage"
        )
    converted = to_si(profile)
    columns = {}
    for name, si in wanted:
        source = next((k for k, v in renamed.items() if v == name), name)
        problem = _unit_problem(where, source, channels[source], si)
        if problem is not None:
            raise DefinitionError(problem)
        columns[name] = converted.column(source)
    torques = np.column_stack([columns[f"M_{link}"] for link in names])
    metadata = dict(converted.metadata)
    if not states:
        return Trajectory(
            time=converted.time,
            states=np.zeros((converted.n_samples, 0)),
            controls=torques,
            state_names=(),
            state_units=(),
            control_names=tuple(f"M_{link}" for link in names),
            control_units=("N m",) * n,
            metadata=metadata,
        )
    ddpsi = None
    accelerations = [f"ddpsi_{link}" for link in names]
    if all(a in converted.extras and converted.extras[a][1] == "rad/s^2" for a in accelerations):
        ddpsi = np.column_stack([converted.extras[a][0] for a in accelerations])
    return LinkageTrajectory.from_linkage(
        converted.time,
        np.column_stack([columns[f"psi_{link}"] for link in names]),
        np.column_stack([columns[f"dpsi_{link}"] for link in names]),
        torques,
        names,
        ddpsi=ddpsi,
        metadata=metadata,
    )


def _torque_source(
    torques,
    names: tuple[str, ...],
    interpolation: str,
    solution_rate_hz: float,
    states: bool = True,
) -> _TorqueSource:
    n = len(names)
    if hasattr(torques, "to_trajectory") and not isinstance(torques, Trajectory):
        # A planner Solution samples what its files hold (its consistent motion, the
        # torques the inverse dynamics of that motion) at a rate: the nodes alone would
        # lose what happens between them.
        try:
            accepts_rate = "rate_hz" in inspect.signature(torques.to_trajectory).parameters
        except (TypeError, ValueError):  # a callable without an introspectable signature
            accepts_rate = False
        if accepts_rate:
            torques = torques.to_trajectory(rate_hz=solution_rate_hz)
        else:
            torques = torques.to_trajectory()
    if isinstance(torques, Trajectory):
        torques = linkage_profile(torques, names, states=states)
        function = torques.control_function(interpolation)
        time = np.asarray(torques.time, dtype=float)  # at least 2 samples, as any Trajectory

        def evaluate(t: np.ndarray) -> np.ndarray:
            return np.asarray(function(t), dtype=float).reshape(-1, n)

        description = {
            "kind": f"Trajectory, {interpolation} interpolation of {time.size} samples",
            "source_metadata": dict(torques.metadata),
        }
        return _TorqueSource(evaluate, time, (time[0], time[-1]), description, torques)
    if callable(torques):

        def evaluate(t: np.ndarray) -> np.ndarray:
            try:
                values = np.asarray(torques(t), dtype=float)
                if values.shape == (t.size, n):
                    return values
            except (TypeError, ValueError, IndexError):
                logger.debug("torque callable is not vectorised; calling it per time")
            values = np.array([np.asarray(torques(float(s)), dtype=float).reshape(-1) for s in t])
            if values.shape != (t.size, n):
                raise DefinitionError(
                    f"`torques`: the callable must return {n} torques (N m) per time, "
                    f"got shape {values.shape[1:]}"
                )
            return values

        name = getattr(torques, "__qualname__", type(torques).__name__)
        return _TorqueSource(
            evaluate, np.empty(0), (-math.inf, math.inf), {"kind": f"callable {name}"}, None
        )
    raise DefinitionTypeError(
        "`torques`: must be a Trajectory, an object with to_trajectory() (a planner "
        f"Solution) or a callable t -> (n,) torques in N m, got {type(torques).__name__}"
    )


# ---- second problem -------------------------------------------------------------------------
def _chebyshev_nodes(degree: int) -> np.ndarray:
    """Chebyshev points of the first kind on [0, 1], degree + 1 of them, increasing."""
    k = np.arange(degree + 1)
    return 0.5 - 0.5 * np.cos((2 * k + 1) * math.pi / (2 * degree + 2))


# Simulators per model (weakly keyed: a model that goes away takes them along), each built
# on first use and reused by every later simulate() with the same options.
_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _simulator(
    dynamics: Dynamics, method: str, degree: int, rtol: float, atol: float, steps: int
) -> Simulator:
    """The :class:`planner.simulation.Simulator` of the linkage's ODE x' = f(x, M) with the
    power of the hinge torques as quadrature, for these options."""
    cache = _CACHE.setdefault(dynamics, {})
    key = (method, degree, rtol, atol, steps)
    if key not in cache:
        n = dynamics.n
        x, z, u, t = ca.SX.sym("x", 2 * n), ca.SX.sym("z", 0), ca.SX.sym("u", n), ca.SX.sym("t")
        inputs, names = [x, z, u, t], ["x", "z", "u", "t"]
        rate = ca.Function("ode", inputs, [dynamics.function("ode")(x, u)], names, ["xdot"])
        power = ca.Function(
            "power", inputs, [ca.dot(u, _hinge_rates(dynamics, x[n:]))], names, ["power"]
        )
        cache[key] = Simulator(
            rate, None, power, degree=degree, method=method, rtol=rtol, atol=atol, steps=steps
        )
    return cache[key]


def _hinge_rates(dynamics: Dynamics, dpsi: ca.SX) -> ca.SX:
    """(n,) relative angular velocities of the hinges, dpsi_i - dpsi_parent(i) (rad/s; the
    root's hinge is to the ground): the rates that multiply M_i in the torques' power."""
    n = dynamics.n
    parent = np.zeros((n, n))
    for i, p in enumerate(dynamics.linkage.parents):
        if p >= 0:
            parent[i, p] = 1.0
    return dpsi - ca.mtimes(ca.DM(parent), dpsi)


def _round_off(times: np.ndarray) -> float:
    """Distance below which two times of this span count as the same instant, s."""
    return 1e-12 * max(1.0, float(np.max(np.abs(times))))


def _output_grid(t0: float, tf: float, t_eval: np.ndarray) -> np.ndarray:
    """t_eval with t0 and tf added, points within round-off of another dropped (tf kept)."""
    times = np.union1d(np.clip(t_eval, t0, tf), [t0, tf])
    tol = _round_off(times)
    keep = np.concatenate([np.diff(times) > tol, [True]])  # of a close pair keep the later
    keep[0] = True
    times = times[keep]
    if times.size > 2 and times[1] - times[0] <= tol:  # t0 and its neighbour both kept
        times = np.delete(times, 1)
    return times


def _integration_grid(output: np.ndarray, knots: np.ndarray, max_interval: float) -> np.ndarray:
    """Output times, profile knots inside the span, and subdivisions of long intervals.

    Every output time is a grid point exactly (the simulation reports the state there); a
    knot within round-off of an output time is dropped rather than merged, because a merge
    could move the output time by an ulp and :func:`simulate` then maps it to the wrong
    interval end.
    """
    tol = _round_off(output)
    inside = knots[(knots > output[0] + tol) & (knots < output[-1] - tol)]
    if inside.size:
        position = np.clip(np.searchsorted(output, inside), 1, output.size - 1)
        nearest = np.minimum(
            np.abs(inside - output[position - 1]), np.abs(output[position] - inside)
        )
        inside = inside[nearest > tol]
    grid = np.union1d(output, inside)
    pieces = [grid[:1]]
    for a, b in itertools.pairwise(grid):
        count = max(1, math.ceil((b - a) / max_interval - 1e-9))
        pieces.append(np.linspace(a, b, count + 1)[1:])
        pieces[-1][-1] = b  # linspace may land an ulp off b
    return np.concatenate(pieces)


def simulate(
    dynamics: Dynamics | Linkage,
    torques,
    x0=None,
    t_span=None,
    t_eval=None,
    *,
    rate_hz: float = 100.0,
    method: str = "cvodes",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    steps: int = 8,
    degree: int = 5,
    max_interval: float = 0.01,
    interpolation: str = "cubic",
    solution_rate_hz: float = 1000.0,
    progress: Progress | None = None,
) -> Trajectory:
    """Second problem of dynamics: integrate the motion under given hinge torques.

    Parameters
    ----------
    dynamics : model.Dynamics or model.Linkage
        The linkage's model (n links).
    torques : Trajectory, object with ``to_trajectory()``, or callable
        The torque profile. A Trajectory (or a planner Solution) is read by column name
        (M_<link>, and psi_<link>, dpsi_<link> for the default x0) with its units converted
        to SI (deg, kN m, ...: :func:`linkage_profile`; a unit that is not one of the
        quantity's is refused, naming the column) and interpolated with its
        ``control_function(interpolation)``; a callable maps t (s, scalar or (K,)) to torques
        (N m, (n,) or (K, n)).
    x0 : array_like (2n,), optional
        Initial state [psi (rad); dpsi (rad/s)] at ``t_span[0]``. Default: the profile's own
        state there (a Trajectory source only).
    t_span : (t0, tf), optional
        Time interval, s, tf > t0. Default: the profile's time range (a Trajectory only).
    t_eval : array_like (K,), optional
        Output times, s, strictly increasing, within t_span (its ends are added). Default: a
        uniform grid at ``rate_hz``.
    rate_hz : float
        Output rate when ``t_eval`` is not given, Hz (> 0; at most MAX_OUTPUT_SAMPLES
        samples over t_span).
    method : {"cvodes", "idas", "rk", "collocation"}
        CasADi integrator plugin. cvodes (BDF/Adams) and idas honour ``rtol``/``atol``; rk
        (fixed-step Runge-Kutta 4) and collocation (Radau, fixed steps) use ``steps``
        finite elements per integration interval and ignore the tolerances.
    rtol, atol : float
        Relative and absolute tolerances of cvodes/idas (absolute in rad and rad/s), in
        [MIN_TOLERANCE = 1e-14, 1).
    steps : int
        Finite elements per integration interval for rk and collocation (>= 1).
    degree : int
        Degree of the polynomial in time that represents the torque on each integration
        interval (interpolated at Chebyshev points); >= 3 reproduces a cubic-spline profile
        exactly, because the intervals split at the profile's knots.
    max_interval : float
        Longest integration interval, s: a smooth callable profile is represented to about
        (max_interval / 4)^(degree + 1) relative accuracy.
    interpolation : {"cubic", "linear"}
        How a Trajectory's torque samples are interpolated.
    solution_rate_hz : float
        Rate, Hz, at which an object with ``to_trajectory(rate_hz=...)`` (a planner Solution)
        is sampled through its own interpolant before the cubic spline is laid through the
        samples (measured on a Hermite-Simpson solution with N = 20: 1 kHz replays its
        open-loop motion to 9e-5 rad, its nodes alone to 0.2 rad).
    progress : callable (fraction, message), optional
        Progress reporter, called after each chunk of intervals.

    Returns
    -------
    Trajectory
        time = the output grid (K,), psi/dpsi (K, n), torques (K, n) as applied, extras
        ddpsi_<link> (forward dynamics), Fx, Fy (N, ground reaction at H0) and ``work`` (J,
        integrated work of the hinge torques since t0, from the integrator's quadrature);
        metadata: method, tolerances, torque source, model parameters, versions, timing.

    Raises
    ------
    DefinitionError, DefinitionTypeError
        Bad input (shapes, ranges, unknown method, t_span outside the profile).
    SimulationError
        The integrator failed or the state became non-finite: one line naming the interval
        and the solver's flag. Nothing reaches the terminal from SUNDIALS or CasADi: their
        output is caught at file-descriptor level and kept in the error's ``details``.
    """
    start = _time.perf_counter()
    dynamics = _as_dynamics(dynamics)
    n = dynamics.n
    if method not in METHODS:
        raise DefinitionError(f"`method`: unknown integrator {method!r}; choose one of {METHODS}")
    if interpolation not in ("cubic", "linear"):
        raise DefinitionError(
            f"`interpolation`: must be 'cubic' or 'linear', got {interpolation!r}"
        )
    rtol = check_tolerance("rtol", rtol)
    atol = check_tolerance("atol", atol)
    steps = check_integer("steps", steps, 1)
    degree = check_integer("degree", degree, 1)
    max_interval = check_positive("max_interval", max_interval, "s")
    solution_rate_hz = check_positive("solution_rate_hz", solution_rate_hz, "Hz")
    source = _torque_source(
        torques, dynamics.names, interpolation, solution_rate_hz, states=x0 is None
    )

    # Time span and output grid.
    if t_span is None:
        if source.trajectory is None:
            raise DefinitionError("`t_span`: required when `torques` is a callable; give (t0, tf)")
        t_span = source.span
    try:
        t0, tf = (float(v) for v in t_span)
    except (TypeError, ValueError) as exc:
        raise DefinitionTypeError(f"`t_span`: must be (t0, tf) in s, got {t_span!r}") from exc
    if not (math.isfinite(t0) and math.isfinite(tf)) or tf <= t0:
        raise DefinitionError(f"`t_span`: needs finite t0 < tf (s), got ({t0!r}, {tf!r})")
    low, high = source.span
    slack = 1e-9 * max(1.0, abs(high - low))
    if t0 < low - slack or tf > high + slack:
        raise DefinitionError(
            f"`t_span`: ({t0:g}, {tf:g}) s leaves the torque profile's time range "
            f"[{low:g}, {high:g}] s; shorten t_span (a profile is not extrapolated)"
        )
    if t_eval is None:
        rate_hz = check_positive("rate_hz", rate_hz, "Hz")
        count = max(1, math.ceil((tf - t0) * rate_hz - 1e-9))
        if count + 1 > MAX_OUTPUT_SAMPLES:
            raise DefinitionError(
                f"`rate_hz`: {rate_hz:g} Hz over {tf - t0:g} s asks for {count + 1} output "
                f"samples, more than {MAX_OUTPUT_SAMPLES}; lower rate_hz or shorten t_span"
            )
        output = np.linspace(t0, tf, count + 1)
    else:
        output = _time_grid("t_eval", t_eval)
        if output[0] < t0 - slack or output[-1] > tf + slack:
            raise DefinitionError(
                f"`t_eval`: must lie within t_span [{t0:g}, {tf:g}] s, "
                f"got [{output[0]:g}, {output[-1]:g}] s"
            )
    output = _output_grid(t0, tf, output)

    # Initial state.
    if x0 is None:
        if source.trajectory is None:
            raise DefinitionError(
                "`x0`: required when `torques` is a callable; give [psi (rad); dpsi (rad/s)]"
            )
        states, _ = source.trajectory.at(np.array([t0]))
        x0 = np.asarray(states, dtype=float).reshape(-1)[: 2 * n]
    x_start = as_float_array("x0", x0, f"2n = {2 * n} numbers").reshape(-1)
    if x_start.shape != (2 * n,):
        raise DefinitionError(
            f"`x0`: must have 2n = {2 * n} entries [psi (rad); dpsi (rad/s)], got {x_start.size}"
        )
    check_finite("x0", x_start, "angles and rates")

    # Integration intervals and torque polynomials on each (one batched torque evaluation).
    grid = _integration_grid(output, source.knots, max_interval)
    h = np.diff(grid)
    nodes = _chebyshev_nodes(degree)
    sample_times = (grid[:-1, None] + h[:, None] * nodes[None, :]).reshape(-1)
    # The ends of the span may sit a round-off outside the profile: clamp to its range.
    sample_times = np.clip(sample_times, low, high)
    values = source.evaluate(sample_times)
    if not np.all(np.isfinite(values)):
        raise DefinitionError("`torques`: the profile gives NaN or inf torques in t_span")
    coefficients = monomial_coefficients(nodes, values.reshape(h.size, degree + 1, n))

    # One run of cvodes/idas per block of intervals, a chain of one-step intervals for rk and
    # collocation (planner.simulation.Simulator.along); a progress report after each block.
    simulator = _simulator(dynamics, method, int(degree), rtol, atol, int(steps))

    def report(fraction: float, reached: float) -> None:
        progress(fraction, f"simulate: t = {reached:.3f} s of {tf:g} s")

    run = simulator.along(
        x_start, grid, coefficients, progress=None if progress is None else report
    )
    full, work = run.states, run.quadrature[:, 0]
    cumulative = np.concatenate([[0.0], np.cumsum(work)])
    index = np.searchsorted(grid, output)
    if np.any(grid[np.minimum(index, grid.size - 1)] != output):  # a bug, not a user error
        raise AssertionError("simulate: an output time is not on the integration grid")
    psi, dpsi = full[index, :n], full[index, n:]
    applied = source.evaluate(np.clip(output, low, high))
    ddpsi = np.asarray(dynamics.forward_dynamics(psi, dpsi, applied)).reshape(-1, n)
    ground = np.asarray(dynamics.ground_reaction(psi, dpsi, ddpsi)).reshape(-1)
    info = {
        "source": "problems.simulate",
        "problem": "second problem of dynamics: motion under given torques",
        "method": method,
        "rtol": rtol if method in ("cvodes", "idas") else None,
        "atol": atol if method in ("cvodes", "idas") else None,
        "steps_per_interval": int(steps) if method in ("rk", "collocation") else None,
        "torque_degree": int(degree),
        "integration_intervals": int(h.size),
        "t_span": [t0, tf],
        "x0": x_start.tolist(),
        "torques": source.description,
        "model": dynamics.linkage.parameters(),
        "versions": versions(),
        "wall_seconds": _time.perf_counter() - start,
    }
    trajectory = LinkageTrajectory.from_linkage(
        output,
        psi,
        dpsi,
        applied,
        dynamics.names,
        ddpsi=ddpsi,
        ground_reaction=ground,
        metadata=info,
    )
    return trajectory.with_extra("work", cumulative[index], "J")


# ---- replay of a law ------------------------------------------------------------------------
@dataclass(frozen=True)
class ReplayReport:
    """How long a simulation under a law's own torques stays on the law.

    Attributes
    ----------
    time : (K,) s
    deviation : (K,) rad
        max over links of |psi_simulated - psi_law|.
    threshold : float, rad
    horizon : float, s
        Time from the start until the deviation first exceeds ``threshold`` (the whole span
        when it never does).
    growth_rate : float, 1/s
        Exponential rate lambda fitted to log(running max of the deviation) where it lies in
        ``fit_window`` (NaN with fewer than 5 points there).
    fit_window : (low, high), rad
    simulation : Trajectory
    """

    time: np.ndarray
    deviation: np.ndarray
    threshold: float
    horizon: float
    growth_rate: float
    fit_window: tuple[float, float]
    simulation: Trajectory

    def table(self, rows: int = 11) -> list[tuple[float, float]]:
        """(t s, deviation rad) at ``rows`` evenly spaced output samples."""
        index = np.unique(np.linspace(0, self.time.size - 1, rows).round().astype(int))
        return [(float(self.time[i]), float(self.deviation[i])) for i in index]


def fit_growth_rate(time, deviation, window: tuple[float, float] = FIT_WINDOW) -> float:
    """Exponential growth rate of a deviation, 1/s.

    Fits log(running max of ``deviation``) = a + lambda t by least squares over the samples
    whose running max lies in ``window`` (rad): above the integration noise, below the
    nonlinear saturation (default :data:`FIT_WINDOW`, 1e-7 to 1e-3 rad; a window reaching
    down into the noise flattens the fit and underestimates the rate). The running max makes
    the fit robust to the oscillation of a deviation about the growing envelope. Returns NaN
    with fewer than 5 samples in the window.

    Parameters
    ----------
    time : (K,) s
    deviation : (K,) rad, >= 0
    window : (low, high) rad
    """
    time = np.asarray(time, dtype=float).reshape(-1)
    deviation = np.asarray(deviation, dtype=float).reshape(-1)
    if time.shape != deviation.shape:
        raise DefinitionError(
            f"`deviation`: shape {deviation.shape} differs from `time` {time.shape}"
        )
    low, high = (check_real("window", v) for v in window)
    if not 0 < low < high:
        raise DefinitionError(f"`window`: needs 0 < low < high (rad), got {window!r}")
    envelope = np.maximum.accumulate(deviation)
    mask = (envelope >= low) & (envelope <= high)
    if np.count_nonzero(mask) < 5:
        return math.nan
    slope, _ = np.polyfit(time[mask], np.log(envelope[mask]), 1)
    return float(slope)


def replay_law(
    dynamics: Dynamics | Linkage,
    law: GaitLaw,
    t_end: float,
    *,
    torques=None,
    t0: float = 0.0,
    rate_hz: float = 200.0,
    threshold: float = 1e-6,
    fit_window: tuple[float, float] = FIT_WINDOW,
    **simulate_options,
) -> ReplayReport:
    """Replay the law's own torques from the law's state at ``t0`` and compare with the law.

    ``torques`` defaults to the exact law torques (:func:`law_torque_function`); pass a
    Trajectory (e.g. a file written by :func:`torques_along`) to include the interpolation
    of sampled torques. Options of :func:`simulate` pass through (method, rtol, atol, ...).
    """
    dynamics = _as_dynamics(dynamics)
    _check_law(dynamics, law)
    t0 = check_real("t0", t0)
    t_end = check_real("t_end", t_end)
    if t_end <= t0:
        raise DefinitionError(f"`t_end`: must be > t0 = {t0:g} s, got {t_end!r}")
    threshold = check_real("threshold", threshold)
    source = law_torque_function(dynamics, law) if torques is None else torques
    simulation = simulate(
        dynamics, source, law.state(t0), (t0, t_end), rate_hz=rate_hz, **simulate_options
    )
    time = np.asarray(simulation.time)
    deviation = np.max(np.abs(np.asarray(simulation.psi) - law.psi(time)), axis=1)
    above = np.nonzero(deviation > threshold)[0]
    horizon = (time[above[0]] if above.size else time[-1]) - t0
    rate = fit_growth_rate(time, deviation, fit_window)
    return ReplayReport(time, deviation, threshold, float(horizon), rate, fit_window, simulation)


def upright_instability_rate(dynamics: Dynamics | Linkage, psi) -> float:
    """Largest real part of the eigenvalues of the linearised motion at rest at ``psi``, 1/s.

    The hinge torques are held at the gravity torques of the pose, so psi is an equilibrium;
    a positive value is the exponential rate at which a small deviation grows (a reference
    for the rate measured in a replay, which moves about this pose).
    """
    dynamics = _as_dynamics(dynamics)
    n = dynamics.n
    pose = as_float_array("psi", psi, f"{n} finite angles in rad").reshape(-1)
    if pose.shape != (n,) or not np.all(np.isfinite(pose)):
        raise DefinitionError(f"`psi`: must be {n} finite angles in rad, got {psi!r}")
    x = ca.SX.sym("x", 2 * n)
    u = ca.DM(dynamics.gravity_torques(pose))
    jacobian = ca.Function("A", [x], [ca.jacobian(dynamics.function("ode")(x, u), x)])
    a = np.asarray(jacobian(np.concatenate([pose, np.zeros(n)])))
    return float(np.max(np.linalg.eigvals(a).real))
