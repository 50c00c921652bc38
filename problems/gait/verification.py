"""Gait verification: the physics of a gait, checked again in numpy on its samples.

:func:`verify_gait` checks a gait from what a file holds (psi, dpsi, ddpsi, M and contact
forces of a :class:`planner.Trajectory`, e.g. read back from ``torques.csv``) and the
linkage, with kinematics and dynamics written here in plain numpy (complex sums over the
tree; hinge torques as the moments about each hinge of the inertia and weight of the part
beyond it), not with the planner's constraint functions or the model's SX expressions. It
checks the physics on every sample whatever rows the OCP had; the limits come from the
gait's settings (``metadata["gait"]``). The leg relabelling is the model's
(``model.swap_legs``): it defines what the next step's labels mean.

Checks (each reports its worst margin, > 0 inside, where it is reached and how many values
it checked; a failure names the sample, its time and by how much the gait misses):

every gait, at every sample
  * ``duration``: the samples span the step (or period) the settings state, s;
  * ``kinematics``: psi and dpsi agree (psi_k+1 - psi_k against the corrected trapezoid of
    dpsi and ddpsi, with an allowance for the acceleration's own change), rad;
    ``rates``: dpsi and ddpsi agree (the trapezoid of ddpsi, with an allowance of
    2.5 h^3 max|d2 ddpsi/dt2| estimated from the samples), rad/s; both skip the instants of
    an impact;
  * ``dynamics``: each hinge torque M_i equals the inverse dynamics of the sampled motion
    (and of the held foot's ground force in a double support): the moment about hinge i of
    sum m_k (a_k + j g) and J_k ddpsi_k over the part beyond it, N m;
  * ``passive joints``: a passive hinge (``passive``) carries at most ``passive_tolerance``
    of the torque limit: what the motion needs of a joint that has no drive, N m;
  * ``torque bounds``; ``ground``: every link end but the swing foot (``ground_points``) at
    or above ``ground_margin``, m; ``friction cone``: mu Fy - |Fx| >= 0, N;
    ``centre of pressure``: the ankle torque's centre of pressure M / Fy on the sole
    (``foot``: -heel Fy <= M <= toe Fy), N m, and its range as a fact of the report;
    ``knees`` and ``posture``, rad;
walking step (``metadata["gait"]["problem"] == "walking_step"``)
  * ``periodic angles``: psi(0) = the leg swap of psi(T) (mod 2 pi), rad; a step of a
    sequence (``next_state``: the next step's first state) checks ``join angles`` instead,
    and its impact against that state (so a sequence's joins are verified step by step);
    a step that starts from quiet standing (``start`` "standing") checks ``standing feet``
    (the swing foot at the stance foot at t = 0, m) and ``standing at rest`` (dpsi(0), rad/s);
  * ``landing``: the swing foot at (step_length, 0) at T, m; ``heel strike``: it comes down
    at ``touchdown_speed`` or faster, m/s;
  * ``impact momentum``: across heel strike, from x(T) before and x(0) (relabelled back)
    after, the angular momentum about the landing foot of the whole tree and about every
    hinge of the part beyond it without the landing foot is conserved, kg m^2/s
    (Westervelt-Grizzle: no impulse acts on those parts but at the landing foot or hinge);
  * ``foot at rest``: the landing foot's velocity after impact, m/s;
  * ``impulse cone``: the impulse Lambda = m (v_com+ - v_com-) with mu Ly - |Lx| >= 0, N s;
  * ``lift off``: the old stance foot's vertical velocity after impact >= 0, m/s;
  * ``clearance``: swing-foot height - the clearance profile >= 0, m (the default profile
    from ``clearance``, ``touchdown_speed`` and ``approach_time``; a callable one travels as
    the sampled table ``clearance_profile``);
  * with a double support: the impact with both feet held, the front foot held at rest,
    both feet's ground forces in their cones, the rear foot's centre of pressure;
fixed-base periodic gait (``"periodic_gait"``)
  * ``periodic state``: x(0) = x(T); ``clearance`` above the law's minimum minus the margin
    (the keypoints between samples are the planner's interpolant's business).

What it cannot check: anything between the samples it is given (a file at 1 kHz says
nothing of the motion between its rows), the model itself (it uses the linkage it is given:
a wrong mass is a wrong plan verified consistently), and that the motion is the optimum
the plan claims (the cost).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Real
from typing import Any

import numpy as np

from model import LinkageTrajectory
from model.contact import Contact
from model.linkage import Linkage
from model.linkage_naming import FORCES, GROUND_REACTION, contact_force_names, root_contact
from model.points import LinkPoint
from model.rerooting import swap_legs
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems.gait.biped import Biped
from problems.gait.similarity import WalkerScales

HALF_PI = 0.5 * math.pi
#: The gaits :func:`verify_gait` knows (``metadata["gait"]["problem"]``).
GAITS = ("walking_step", "footed_step", "periodic_gait")
#: The problems that are one step of walking (a leg swap at the end).
STEPS = ("walking_step", "footed_step")


class GaitVerificationError(AnthropoidError):
    """A gait failed :func:`verify_gait` (raised by :meth:`GaitReport.raise_if_failed`, and
    by a gait problem's ``solve()`` for a plan that converged but fails its own check:
    ``gait`` is that plan, for inspection, ``report`` its :class:`GaitReport`)."""

    def __init__(self, message: str, gait: Any = None, report: GaitReport | None = None):
        super().__init__(message)
        self.gait = gait
        self.report = report


class GaitVerificationWarning(UserWarning):
    """A gait problem's ``solve(raise_on_failure=False)`` returns a plan that fails its own
    verification (``gait.verified`` is False; ``gait.verification`` says where)."""


@dataclass(frozen=True)
class Check:
    """One verified property: its worst margin (> 0 satisfied, in ``unit``), where it is
    reached, and whether it passed within the tolerance."""

    name: str
    margin: float
    unit: str
    where: str
    tolerance: float
    samples: int

    @property
    def passed(self) -> bool:
        return bool(self.margin >= -self.tolerance)

    def __str__(self) -> str:
        verdict = "ok  " if self.passed else "FAIL"
        return (
            f"{verdict} {self.name:<18} worst margin {self.margin + 0.0:+.3e} {self.unit:<8} at "
            f"{self.where} ({self.samples} checked, tolerance {self.tolerance:.0e})"
        )


@dataclass(frozen=True)
class GaitReport:
    """The result of :func:`verify_gait`: ``checks`` in order, ``ok`` when all passed;
    ``facts``: what it measured besides (samples, duration s, the largest |M - inverse
    dynamics| N m, the centre of pressure's range (min, max) m from the ankle)."""

    checks: tuple[Check, ...]
    settings: dict[str, Any] = field(default_factory=dict)
    facts: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    def __getitem__(self, name: str) -> Check:
        for check in self.checks:
            if check.name == name:
                return check
        raise KeyError(f"no check called {name!r}; checks: {[c.name for c in self.checks]}")

    def raise_if_failed(self) -> None:
        if not self.ok:
            raise GaitVerificationError(
                "gait verification failed: "
                + "; ".join(
                    f"{c.name} misses by {-c.margin:.3g} {c.unit} at {c.where}"
                    for c in self.failures
                )
            )

    def __str__(self) -> str:
        head = "gait verified: all checks passed" if self.ok else "gait verification FAILED"
        return "\n".join([head, *(f"  {c}" for c in self.checks)])


# ---- numpy kinematics of the tree (complex sums, written again) ---------------------------
class _Kinematics:
    """Positions, velocities and accelerations of points of a linkage, in numpy.

    Link i's start hinge is the sum over the path of o_k e^{j psi_parent(k)}; a point at c in
    its frame is start_i + c e^{j psi_i}; rates differentiate each exponential.
    """

    def __init__(self, linkage: Linkage, rotors: Sequence[Mapping] = ()) -> None:
        self.linkage = linkage
        self.n = linkage.n
        # Geared motors' rotors (a gait planned with its drives: settings["rotors"]): the
        # rate vector b of each (omega_r = b . dpsi) and its inertia J.
        names = list(linkage.names)
        self.rotors = []
        for rotor in rotors:
            b = np.zeros(self.n)
            for link, weight in ((rotor["driven"], rotor["ratio"]),
                                 (rotor["stator"], 1.0 - rotor["ratio"])):  # fmt: skip
                if link is not None:
                    b[names.index(link)] += weight
            self.rotors.append((float(rotor["inertia"]), b, float(rotor["stator"] is not None)))
        self.origins = [linkage.origin_in_parent(i) for i in range(self.n)]
        self.com = np.array([link.com_offset for link in linkage.links])
        self.mass = np.array([link.mass for link in linkage.links])
        self.inertia = np.array([link.inertia for link in linkage.links])

    def ground_moment(self, ddpsi) -> np.ndarray | float:
        """What the rotors add to the root's torque to make the moment the ground takes (K,),
        N m: Euler's law for the whole body counts a rotor riding on it once (stator a link),
        one on the ground not at all, where the generalised root torque weights each by its
        rate vector's sum (:meth:`inverse_dynamics`)."""
        total = 0.0
        for inertia, b, on_body in self.rotors:
            total = total + inertia * (np.atleast_2d(ddpsi) @ b) * (on_body - np.sum(b))
        return total

    def starts(self, psi, dpsi=None, ddpsi=None):
        """(position, velocity, acceleration) of every start hinge, complex (K, n) each."""
        psi = np.atleast_2d(psi)
        e = np.exp(1j * psi)
        k = psi.shape[0]
        position = np.zeros((k, self.n), dtype=complex)
        velocity = np.zeros_like(position)
        acceleration = np.zeros_like(position)
        for i, p in enumerate(self.linkage.parents):
            if p < 0:
                position[:, i] = self.origins[i]
                continue
            lever = self.origins[i] * e[:, p]
            position[:, i] = position[:, p] + lever
            if dpsi is not None:
                velocity[:, i] = velocity[:, p] + 1j * dpsi[:, p] * lever
            if ddpsi is not None:
                acceleration[:, i] = (
                    acceleration[:, p] + (1j * ddpsi[:, p] - dpsi[:, p] ** 2) * lever
                )
        return position, velocity, acceleration

    def point(self, i: int, offset: complex, psi, dpsi=None, ddpsi=None):
        """(position, velocity, acceleration) of the point ``offset`` on link i, (K,) each."""
        psi = np.atleast_2d(psi)
        start, v, a = self.starts(psi, dpsi, ddpsi)
        lever = offset * np.exp(1j * psi[:, i])
        position = start[:, i] + lever
        velocity = v[:, i] + (0 if dpsi is None else 1j * dpsi[:, i] * lever)
        acceleration = a[:, i] + (
            0 if ddpsi is None else (1j * ddpsi[:, i] - dpsi[:, i] ** 2) * lever
        )
        return position, velocity, acceleration

    def coms(self, psi, dpsi=None, ddpsi=None):
        psi = np.atleast_2d(psi)
        start, v, a = self.starts(psi, dpsi, ddpsi)
        lever = self.com[None, :] * np.exp(1j * psi)
        velocity = v + (0 if dpsi is None else 1j * dpsi * lever)
        acceleration = a + (0 if ddpsi is None else (1j * ddpsi - dpsi**2) * lever)
        return start + lever, velocity, acceleration

    def ground_reaction(self, psi, dpsi, ddpsi) -> np.ndarray:
        """Force of the ground on the root, complex (K,), N: sum m_i (a_i + j g)."""
        _, _, acceleration = self.coms(psi, dpsi, ddpsi)
        return (acceleration + 1j * self.linkage.gravity) @ self.mass

    def inverse_dynamics(self, psi, dpsi, ddpsi, contacts=()) -> np.ndarray:
        """Hinge torques (K, n), N m: M_i = sum over the links k beyond hinge i (its subtree)
        of (w_k - h_i) x m_k (a_k + j g) + J_k ddpsi_k, less the moments about h_i of the
        ground forces ``contacts`` (link, offset, force (K,) complex) on that part: Euler's
        law for the part beyond hinge i about the point where the hinge is (written here
        independently of the model's Lagrange equations)."""
        psi, dpsi, ddpsi = (np.atleast_2d(a) for a in (psi, dpsi, ddpsi))
        starts, _, _ = self.starts(psi)
        position, _, acceleration = self.coms(psi, dpsi, ddpsi)
        force = self.mass[None, :] * (acceleration + 1j * self.linkage.gravity)
        torques = np.empty(psi.shape)
        applied = [(i, self.point(i, offset, psi)[0], f) for i, offset, f in contacts]
        for i in range(self.n):
            part = list(self.linkage.subtree(i))
            lever = position[:, part] - starts[:, i : i + 1]
            moment = np.sum((np.conj(lever) * force[:, part]).imag, axis=1)
            moment += ddpsi[:, part] @ self.inertia[part]
            for inertia, b, _ in self.rotors:
                # A rotor's angular momentum J omega_r counts whole when its stator and its
                # driven link are both in the part; geared across the cut, the ideal gear
                # passes N (driven side) or 1 - N (stator side) of its rate of change: b's
                # entries summed over the part.
                moment += inertia * (ddpsi @ b) * np.sum(b[part])
            for link, point, f in applied:
                if link in part:
                    moment -= (np.conj(point - starts[:, i]) * f).imag
            torques[:, i] = moment
        return torques

    def angular_momentum(self, psi, dpsi, base_velocity, about, links) -> float:
        """sum over ``links`` of (w_i - about) x m_i v_i + J_i dpsi_i, the base moving with
        ``base_velocity`` (complex), about the fixed point ``about`` (complex); each rotor's
        J omega_r weighted by its rate vector's entries over ``links`` (as in
        :meth:`inverse_dynamics`: whole when stator and driven are both in, N or 1 - N of it
        across the gear)."""
        position, velocity, _ = self.coms(psi[None], dpsi[None])
        r = position[0] - about
        v = velocity[0] + base_velocity
        cross = (np.conj(r) * v).imag
        links = list(links)
        rotors = sum(j * (dpsi @ b) * np.sum(b[links]) for j, b, _ in self.rotors)  # as above
        return float(np.sum((self.mass * cross + self.inertia * dpsi)[links]) + rotors)


def _worst(margins: np.ndarray, times: np.ndarray) -> tuple[float, str]:
    """Smallest margin over samples (rows) and its place "node k (t = ... s)"."""
    flat = margins.reshape(margins.shape[0], -1).min(axis=1)
    k = int(np.argmin(flat))
    return float(flat[k]), f"sample {k} (t = {times[k]:.4g} s)"


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def verify_gait(
    trajectory: Trajectory,
    linkage: Linkage,
    *,
    settings: Mapping[str, Any] | None = None,
    tolerance: float = 1e-6,
    hold_tolerance: float = 1e-3,
    passive_tolerance: float = 0.01,
) -> GaitReport:
    """Verify a gait from its samples (see the module docstring).

    Parameters
    ----------
    trajectory : a linkage Trajectory with ddpsi (``WalkingGait.to_trajectory(rate_hz)``,
        ``LinkageTrajectory.load(...)`` of a file it wrote, or any at the nodes of a solution).
    linkage : the linkage it was made for.
    settings : the gait's parameters (the keys of ``metadata["gait"]``: problem, step_length,
        mu, clearance, torque_limit, knee_range, posture, upright, foot, passive, ...); default
        the trajectory's ``metadata["gait"]``; given keys override it.
    tolerance : relative tolerance of every check: margins are in physical units and a check
        passes when margin >= -tolerance * its scale (1 for angles; 1 m, 1 m/s and 1 s for
        the six-link walker's 0.86 m legs under 9.81 m/s^2, and for another walker (the
        ``leg_length`` its settings state) its length, speed and time in those units by
        dynamic similarity (:class:`problems.gait.similarity.WalkerScales`): a walker 1000 times
        larger is held to 1000 times a metre's tolerance, one of a millimetre to a
        micrometre's; the weight m g for forces; m * 1 m/s (scaled alike) for impulses; the
        largest torque limit for torques, or the weight times the leg length without
        limits).
    hold_tolerance : m and m/s: how far the front foot of a double support may drift from
        its foothold and from rest. The planner holds it through its acceleration (the
        closed chain as a constraint on ddpsi), so position and velocity drift with the
        collocation error (0.1 mm and 0.7 mm/s on the default mesh, fourth order in h).
    passive_tolerance : the largest torque a passive hinge may show, as a fraction of the
        largest torque limit: the motion of an underactuated linkage is consistent at such
        a joint to the collocation error only (the planner refines its mesh until the
        motion needs at most 1 % of the torque scale there).
    """
    if not isinstance(trajectory, Trajectory):
        raise DefinitionTypeError(
            f"`trajectory`: must be a planner.Trajectory, got {type(trajectory).__name__}"
        )
    trajectory = LinkageTrajectory.of(trajectory)
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    if not trajectory.is_linkage or tuple(trajectory.link_names) != linkage.names:
        raise DefinitionError(
            f"`trajectory`: its links {getattr(trajectory, 'link_names', None)} are not the "
            f"linkage's {list(linkage.names)}"
        )
    merged = dict(trajectory.metadata.get("gait") or {})
    merged.update(settings or {})
    if merged.get("torque_limit") is not None:
        merged["torque_limit"] = _torque_limits(merged, linkage)
    problem = _gait_problem(merged, trajectory)
    for name, value in (
        ("tolerance", tolerance),
        ("hold_tolerance", hold_tolerance),
        ("passive_tolerance", passive_tolerance),
    ):
        if isinstance(value, bool) or not (isinstance(value, float | int) and 0 < value < 1):
            raise DefinitionError(f"`{name}`: must be a number in (0, 1), got {value!r}")
    kin = _Kinematics(linkage, merged.get("rotors") or ())
    times = trajectory.time
    weight = float(np.sum(kin.mass)) * linkage.gravity
    checks: list[Check] = []
    similar = _similarity_factors(merged, linkage)

    def add(name, margins, unit, scale=1.0, where=None):
        scale = scale * similar.get(unit, 1.0)
        margins = np.atleast_1d(np.asarray(margins, dtype=float))
        if where is None:
            if margins.ndim == 1 and margins.size != times.size:
                value, where = float(margins.min()), f"index {int(np.argmin(margins))}"
            else:
                value, where = _worst(margins, times)
        else:
            value = float(margins.min())
        checks.append(Check(name, value, unit, where, tolerance * scale, margins.size))

    facts: dict[str, Any] = {"samples": int(times.size), "duration": float(times[-1] - times[0])}
    double = problem == "walking_step" and float(merged.get("double_support") or 0.0) > 0.0
    footed = problem == "footed_step"
    contacts = _contacts(kin, merged, trajectory) if double or footed else []
    _verify_physics(add, kin, merged, trajectory, contacts, weight, passive_tolerance, facts)
    if footed:
        _verify_footed(add, kin, merged, trajectory, weight, hold_tolerance / tolerance,
                       passive_tolerance)  # fmt: skip
    elif double:
        _verify_double_support(add, kin, merged, trajectory, weight, hold_tolerance / tolerance)
    elif problem == "walking_step":
        _verify_walking(add, kin, merged, trajectory, weight)
    else:
        state = np.hstack([trajectory.psi, trajectory.dpsi])
        add(
            "periodic state",
            -np.abs(state[0] - state[-1]),
            "rad(/s)",
            where=f"t = 0 and t = {times[-1]:.4g} s",
        )
        minimum = merged.get("foot_minimum")
        if minimum is not None:
            foot = _foot(kin, merged)
            height = kin.point(*foot, trajectory.psi)[0].imag
            add("clearance", height - float(minimum), "m")
    return GaitReport(tuple(checks), merged, facts)


def _contacts(kin: _Kinematics, settings, trajectory) -> list[tuple[int, complex, np.ndarray]]:
    """The held feet's ground forces of a double support: (link, offset, force (K,)) from the
    extras ``F_<point>_x`` / ``_y`` of points other than the root's (its reaction is what
    the dynamics leave): a contact named in ``settings["contacts"]`` at its point, any other
    at the swing foot (the front foot)."""
    named = _named_contacts(kin, settings)
    root_x, _ = contact_force_names(root_contact(kin.linkage.names))
    names = [k for k in trajectory.extras if k.startswith(f"{FORCES}_") and k.endswith("_x")]
    found = []
    for name in names:
        if name in (root_x, GROUND_REACTION[0]):
            continue
        contact = name[len(FORCES) + 1 : -2]
        link, offset = named[contact] if contact in named else _foot(kin, settings)
        force = trajectory.extras[name][0] + 1j * trajectory.extras[name[:-1] + "y"][0]
        found.append((link, offset, np.asarray(force)))
    return found


def _named_contacts(kin: _Kinematics, settings) -> dict[str, tuple[int, complex]]:
    """``settings["contacts"]`` ({name: [link, along, lateral]}) as {name: (link index,
    offset in the link's frame, m)}."""
    named = {}
    for name, (link, along, lateral) in (settings.get("contacts") or {}).items():
        i = kin.linkage.index(link)
        named[name] = (i, kin.linkage.links[i].length * complex(float(along), float(lateral)))
    return named


def _gait_problem(settings, trajectory: Trajectory) -> str:
    """Which gait the settings say this is (one of :data:`GAITS`), or a DefinitionError
    saying how to tell it (and that a CSV file without its sidecar says nothing)."""
    problem = settings.get("problem")
    if problem in GAITS:
        return problem
    missing = (
        "; a torques.csv read without its sidecar torques.csv.meta.json has none: put the "
        "sidecar back beside the CSV file, it holds the gait's settings"
        if not trajectory.metadata
        else ""
    )
    raise DefinitionError(
        "`settings`: say which gait this is: settings={'problem': 'walking_step', "
        "'footed_step' or 'periodic_gait', ...} (the trajectory's metadata has none), got "
        f"{problem!r}{missing}"
    )


def _torque_limits(settings, linkage: Linkage) -> dict[str, float]:
    """``settings["torque_limit"]`` as {link: |M| bound, N m}: a mapping as the gait files
    hold it, or one number for every drive (``settings["drives"]`` when it lists them: a
    footed walker's root torque is the ground's) or every hinge."""
    limits = settings["torque_limit"]
    if isinstance(limits, Mapping):
        unknown = [name for name in limits if name not in linkage.names]
        if unknown:
            raise DefinitionError(
                f"`settings['torque_limit']`: no links {unknown} in the linkage "
                f"{list(linkage.names)}; give {{link: N m}} or one number for every drive"
            )
        values = dict(limits)
    else:
        values = dict.fromkeys(settings.get("drives") or linkage.names, limits)
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, Real) or not 0 < value < math.inf:
            raise DefinitionError(
                f"`settings['torque_limit']`: must be one number > 0 (N m, every drive) or "
                f"{{link: N m}}, got {value!r} for {name!r}"
            )
    return {name: float(value) for name, value in values.items()}


def _torque_scale(kin: _Kinematics, settings) -> float:
    limits = settings.get("torque_limit")
    if limits:
        return float(max(float(v) for v in limits.values()))
    leg = kin.linkage.links[0].length
    return float(np.sum(kin.mass)) * kin.linkage.gravity * leg


def _similarity_factors(settings, linkage: Linkage) -> dict[str, float]:
    """By unit, the factor of a check's scale for the walker of ``settings["leg_length"]``
    under the linkage's gravity against the six-link walker (all 1 without a leg length:
    files of earlier versions, the fixed-base gait)."""
    leg = settings.get("leg_length")
    if not isinstance(leg, float | int) or isinstance(leg, bool) or not leg > 0:
        return {}
    relative = WalkerScales(float(leg), linkage.gravity).relative
    length, speed, time = relative["length"], relative["speed"], relative["time"]
    return {"m": length, "m/s": speed, "s": time, "rad/s": 1.0 / time,
            "rad(/s)": max(1.0, 1.0 / time), "N s": speed, "kg m^2/s": speed}  # fmt: skip


def _impact_instants(settings, trajectory) -> np.ndarray:
    """Times (s) where the state jumps between two samples (the impact at a double
    support's start): the kinematic checks skip the pair that holds one."""
    events = settings.get("before_events") or []
    return np.array([float(e["t"]) for e in events])


def _verify_drives(add, linkage, settings, torques, passive_links, allowed: float,
                   scale: float) -> None:  # fmt: skip
    """Passive joints (``passive_links``, within ``allowed`` N m: what the motion may need of
    a joint without a drive), the hinges' torque bounds and the physical stance hip's."""
    limits = settings.get("torque_limit")
    if passive_links:
        add("passive joints", allowed - np.abs(torques[:, passive_links]), "N m", scale)
    if limits:
        # a hinge without a limit (a footed walker's root: the ground's torque) is unbounded
        limit = np.array([float(limits.get(name, np.inf)) for name in linkage.names])
        add("torque bounds", limit[None, :] - np.abs(torques), "N m", scale)
    if settings.get("hip_limit") is not None:
        # the physical stance hip: the drive between the trunk and the stance thigh, the
        # trunk's hinge and every other hinge at the stance thigh's end (the swing thigh)
        thigh = linkage.index(Biped.of(linkage).stance_leg[-1])
        at_hip = [i for i, parent in enumerate(linkage.parents) if parent == thigh]
        hip = np.sum(torques[:, at_hip], axis=1)
        add("stance hip", float(settings["hip_limit"]) - np.abs(hip), "N m", scale)


def _verify_joint_speeds(add, linkage: Linkage, settings, dpsi: np.ndarray) -> None:
    """``joint speeds``: with a ``speed_limit`` (rad/s), each driven joint's rate within it:
    a driven link turning on its parent (the ground for the root), a swing thigh on the
    trunk (the robot's hip drive); the driven links are the settings' ``drives`` or every
    link not ``passive``."""
    limit = settings.get("speed_limit")
    if limit is None:
        return
    names = list(linkage.names)
    driven = settings.get("drives") or [n for n in names if n not in (settings.get("passive")
                                                                       or ())]  # fmt: skip
    legs = Biped.of(linkage)
    at_hip = [
        names[i]
        for i, parent in enumerate(linkage.parents)
        if parent == names.index(legs.stance_leg[-1]) and names[i] != legs.swing_leg[0]
    ]
    stators = {name: (names[linkage.parents[k]] if linkage.parents[k] >= 0 else None)
               for k, name in enumerate(names)}  # fmt: skip
    if len(at_hip) == 1:
        stators[legs.swing_leg[0]] = at_hip[0]
    rates = np.column_stack(
        [
            dpsi[:, names.index(name)]
            - (0.0 if stators[name] is None else dpsi[:, names.index(stators[name])])
            for name in driven
        ]
    )
    add("joint speeds", float(limit) - np.abs(rates), "rad/s", float(limit))


def _verify_physics(add, kin, settings, trajectory, contacts, weight, passive, facts) -> None:
    """What every gait must obey at every sample, whatever its OCP held: the duration, the
    kinematics, the equations of motion, passive joints, torque bounds, the ground, the
    friction cone and centre of pressure of the stance foot, knees and posture."""
    linkage = kin.linkage
    psi, dpsi, ddpsi, torques = (
        trajectory.psi,
        trajectory.dpsi,
        trajectory.ddpsi,
        trajectory.torques,
    )
    times = trajectory.time
    problem = settings.get("problem")
    duration = settings.get("step_time") if problem in STEPS else settings.get("period")
    if duration is not None:
        span = float(times[-1] - times[0])
        add(
            "duration",
            np.array([-abs(span - float(duration))]),
            "s",
            float(duration),
            where=f"{times.size} samples over {span:.6g} s",
        )
    # Kinematics: the corrected trapezoid of dpsi (exact for cubic rates) against psi; an
    # acceleration that jumps or kinks between two samples (a mesh node) costs up to
    # h^2 |da| / 12 of it, allowed. Rates against the trapezoid of ddpsi, allowed
    # 2.5 h^3 max |d2 ddpsi / dt2| (the rule's error with a safety for kinks at the nodes).
    h = np.diff(times)[:, None]
    keep = np.ones(h.shape[0], dtype=bool)
    for t in _impact_instants(settings, trajectory):
        keep &= ~((times[:-1] < t + 1e-12) & (times[1:] > t - 1e-12))
    change = ddpsi[1:] - ddpsi[:-1]
    residual = psi[1:] - psi[:-1] - h / 2 * (dpsi[1:] + dpsi[:-1]) + h**2 / 12 * change
    allowance = 2.0 * h**2 / 12 * np.abs(change)
    margins = np.full(residual.shape, np.inf)
    margins[keep] = (allowance - np.abs(residual))[keep]
    add("kinematics", _per_sample(margins), "rad")
    curvature = np.zeros_like(ddpsi)
    if times.size > 2:
        curvature[1:-1] = np.abs(ddpsi[2:] - 2 * ddpsi[1:-1] + ddpsi[:-2]) / (h[1:] * h[:-1])
    near = np.maximum(curvature[:-1], curvature[1:])
    near = np.maximum(near, np.vstack([near[1:], near[-1:]]))
    near = np.maximum(near, np.vstack([near[:1], near[:-1]]))
    residual = dpsi[1:] - dpsi[:-1] - h / 2 * (ddpsi[1:] + ddpsi[:-1])
    margins = np.full(residual.shape, np.inf)
    margins[keep] = (2.5 * h**3 * near - np.abs(residual))[keep]
    intervals = _mesh_intervals(trajectory.metadata)
    sparse, thin = _sparse_phases(trajectory.metadata, times)
    if thin and not np.all(sparse):
        # A phase sampled too thinly for its mesh (a short double support on a fine mesh):
        # the rates are checked in the other phases only.
        margins[sparse] = np.inf
        facts["rates"] = (
            f"not checked in {', '.join(thin)} (fewer than {RATES_DENSITY} samples per mesh "
            "interval)"
        )
        add("rates", _per_sample(margins), "rad/s")
    elif intervals is None or times.size - 1 >= RATES_DENSITY * intervals:
        add("rates", _per_sample(margins), "rad/s")
    else:
        # An acceleration polynomial bulges inside a mesh interval: samples at the nodes
        # alone cannot bound the trapezoid's error from the samples themselves.
        facts["rates"] = (
            f"not checked: {times.size} samples for {intervals} mesh intervals (at least "
            f"{RATES_DENSITY} per interval needed)"
        )
    # The equations of motion: the torques against the inverse dynamics of the motion.
    scale = _torque_scale(kin, settings)
    expected = kin.inverse_dynamics(psi, dpsi, ddpsi, contacts)
    gap = torques - expected
    facts["dynamics residual"] = float(np.max(np.abs(gap)))
    add("dynamics", -np.abs(gap), "N m", scale)
    passive_links = [linkage.index(name) for name in settings.get("passive") or ()]
    _verify_drives(add, linkage, settings, torques, passive_links, passive * scale, scale)
    _verify_joint_speeds(add, linkage, settings, dpsi)
    # The ground: every point of the body that is not a contact stays above it.
    margin = float(settings.get("ground_margin") or 0.0)
    foot_link = settings.get("swing_foot")
    points = settings.get("ground_points")
    if points is None:
        points = [name for name in linkage.names if name != foot_link]
    if points:
        heights = np.column_stack(
            [
                kin.point(
                    linkage.index(name), complex(linkage.links[linkage.index(name)].length), psi
                )[0].imag
                for name in points
            ]
        )
        add("ground", heights - margin, "m")
    # The stance foot: friction cone and centre of pressure (the front foot of a double
    # support is a point contact: its cone is checked with the double support).
    reaction = kin.ground_reaction(psi, dpsi, ddpsi)
    for _, _, force in contacts:
        reaction = reaction - force
    mu = settings.get("mu")
    if mu is not None:
        stance = Contact.at_root(kin.linkage, float(mu))
        add("friction cone", stance.cone_margin(reaction.real, reaction.imag), "N", weight)
    moment = torques[:, 0] + kin.ground_moment(ddpsi)
    loaded = reaction.imag > 0.05 * weight
    if np.any(loaded):
        pressure = moment[loaded] / reaction.imag[loaded]
        facts["centre of pressure"] = (float(pressure.min()), float(pressure.max()))
    foot = settings.get("foot")
    # (a step on feet: the sole carries the root's torque only while it lies flat; see
    # _verify_footed)
    if foot is not None and problem == "walking_step" and 0 not in passive_links:
        heel, toe = (float(v) for v in foot)
        rows = np.column_stack([moment + heel * reaction.imag, toe * reaction.imag - moment])
        add("centre of pressure", rows, "N m", weight * (heel + toe))
    if settings.get("knee_range") and problem in STEPS:
        lower, upper = settings["knee_range"]
        flexion = _knees(linkage, settings, psi)
        add("knees", np.minimum(flexion - lower, upper - flexion), "rad")
    if settings.get("upright"):
        columns = [linkage.index(name) for name in settings["upright"]]
        lean = np.abs(psi[:, columns] - HALF_PI)
        add("posture", float(settings["posture"]) - lean, "rad")


#: Samples per mesh interval the ``rates`` check needs (a file at 1 kHz has 16 on the
#: default step's 30 intervals of 16.7 ms).
RATES_DENSITY = 4


def _mesh_intervals(metadata) -> int | None:
    """The mesh intervals of the solution a trajectory was sampled from (its metadata's N,
    or the sum over its phases), or None when it does not say."""
    phases = metadata.get("phases")
    if phases:
        counts = [p.get("N") for p in phases]
        if all(isinstance(c, int) and not isinstance(c, bool) for c in counts):
            return int(sum(counts))
        return None
    count = metadata.get("N")
    return count if isinstance(count, int) and not isinstance(count, bool) else None


def _sparse_phases(metadata, times: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """(a mask of the sample pairs (K-1,) inside phases with fewer than
    :data:`RATES_DENSITY` samples per mesh interval, those phases' names), from the
    metadata's phases (start, T, N); nothing when it lists none."""
    sparse = np.zeros(times.size - 1, dtype=bool)
    thin = []
    for phase in metadata.get("phases") or ():
        try:
            start, span, count = float(phase["start"]), float(phase["T"]), int(phase["N"])
        except (KeyError, TypeError, ValueError):
            return np.zeros(times.size - 1, dtype=bool), []
        edge = 1e-9 * max(1.0, span)
        inside = (times[:-1] >= start - edge) & (times[1:] <= start + span + edge)
        if np.count_nonzero(inside) < RATES_DENSITY * count:
            sparse |= inside
            thin.append(str(phase.get("name", "?")))
    return sparse, thin


def _per_sample(margins: np.ndarray) -> np.ndarray:
    """Margins of sample pairs (K-1, c) as margins of samples (K, c): each sample takes the
    worse of the two pairs it belongs to (so that a failure names a sample)."""
    out = np.full((margins.shape[0] + 1, margins.shape[1]), np.inf)
    out[:-1] = margins
    out[1:] = np.minimum(out[1:], margins)
    return out


def _swing_foot(kin: _Kinematics, settings, mu: float) -> Contact:
    """The swing foot (the end of ``settings["swing_foot"]``) as a contact with friction."""
    return Contact(LinkPoint(kin.linkage.names[_foot(kin, settings)[0]]), friction=mu)


def _landing_speed(add, settings, velocity: complex, where: str) -> None:
    """The landing foot's horizontal speed at heel strike within the plan's
    ``landing_speed`` (m/s), when it has one; ``velocity``: the foot's before the impact."""
    bound = settings.get("landing_speed")
    if bound is not None:
        bound = float(bound)
        add("landing speed", np.array([bound - abs(velocity.real)]), "m/s",
            where=f"{where} (at most {bound:g} m/s along the ground)")  # fmt: skip


def _foot(kin: _Kinematics, settings) -> tuple[int, complex]:
    name = settings.get("swing_foot")
    if name is None:
        raise DefinitionError("`settings`: give 'swing_foot', the link whose end is the foot")
    i = kin.linkage.index(name)
    return i, complex(kin.linkage.links[i].length)


def _legs(linkage: Linkage) -> tuple[list[int], list[int]]:
    """(stance leg from the root up, swing leg from the hip down), link indices
    (:meth:`problems.gait.biped.Biped.of`: the links the leg swap turns up and down)."""
    biped = Biped.of(linkage)
    return [linkage.index(k) for k in biped.stance_leg], [linkage.index(k) for k in biped.swing_leg]


def _knees(linkage: Linkage, settings, psi) -> np.ndarray:
    """Knee flexion psi_thigh - psi_shank (K, 2) of both legs, rad: the stance leg's two
    links below the hip, the swing leg's two below the hip (a leg may end in a foot)."""
    stance, swing = _legs(linkage)
    return np.column_stack(
        [psi[:, stance[-1]] - psi[:, stance[-2]], psi[:, swing[0]] - psi[:, swing[1]]]
    )


def _clearance_profile(settings, s: np.ndarray, single: float | None = None):
    """The swing foot's minimum height (m) at fractions ``s`` of the single support (of
    ``single`` s; default the step time less the double support): a
    sampled profile (``settings["clearance_profile"]``, {"s": [...], "height": [...]}: the
    values at the exported samples themselves, linear in between), else the default
    h sin^2(pi s) + v_td (T - t) exp(-((T - t) / w)^4) with h = ``settings["clearance"]``
    (0 when None: height >= 0), v_td = ``touchdown_speed``, w = ``approach_time`` and T the
    single support's duration (the approach term only when all three are given); with
    ``lift_time`` > 0 the sine term times 1 - exp(-(s T / lift_time)^2) (a floor that starts
    flat: a start from standing on feet), with ``land_time`` > 0 times
    1 - exp(-((1 - s) T / land_time)^2) (a floor that ends flat: a stop at standing on feet)."""
    table = settings.get("clearance_profile")
    if table is None:
        clearance = settings.get("clearance")
        height = 0.0 if clearance is None else float(clearance) * np.sin(np.pi * s) ** 2
        speed, window = settings.get("touchdown_speed"), settings.get("approach_time")
        if single is None and settings.get("step_time"):
            single = float(settings["step_time"]) - float(settings.get("double_support") or 0)
        lift = float(settings.get("lift_time") or 0.0)
        land = float(settings.get("land_time") or 0.0)
        if (lift > 0 or land > 0) and not single:
            named = "lift_time" if lift > 0 else "land_time"
            raise DefinitionError(
                f"`settings`: a clearance floor with '{named}' needs the single support's "
                "duration ('step_time')"
            )
        if lift > 0:
            height = height * (1.0 - np.exp(-((s * single / lift) ** 2)))
        if land > 0:
            height = height * (1.0 - np.exp(-(((1.0 - s) * single / land) ** 2)))
        if speed and window and single:
            left = (1.0 - s) * single
            height = height + float(speed) * left * np.exp(-((left / float(window)) ** 4))
        return height
    field = "`settings['clearance_profile']`"
    try:
        grid = np.asarray(table["s"], dtype=float)
        heights = np.asarray(table["height"], dtype=float)
    except (KeyError, TypeError, ValueError) as exc:
        raise DefinitionError(
            f"{field}: give {{'s': fractions t / T, 'height': m}} as two lists of numbers, "
            f"got {str(table)[:80]!r}"
        ) from exc
    if (
        grid.ndim != 1
        or grid.shape != heights.shape
        or grid.size < 1
        or not np.all(np.isfinite(grid))
        or not np.all(np.isfinite(heights))
        or np.any(np.diff(grid) <= 0)
    ):
        raise DefinitionError(
            f"{field}: 's' and 'height' must be finite lists of the same length with 's' "
            f"increasing, got {grid.size} and {heights.size} entries"
        )
    reach = 1e-9 * max(1.0, float(np.max(np.abs(grid))))
    if s.size and (s.min() < grid[0] - reach or s.max() > grid[-1] + reach):
        raise DefinitionError(
            f"{field}: it covers s in [{grid[0]:.4g}, {grid[-1]:.4g}] but the trajectory's "
            f"samples reach [{s.min():.4g}, {s.max():.4g}]; sample the profile over the "
            "whole single support (WalkingStep.clearance_table(times))"
        )
    return np.interp(s, grid, heights)


def _verify_walking(add, kin: _Kinematics, settings, trajectory, weight) -> None:
    psi, dpsi, times = trajectory.psi, trajectory.dpsi, trajectory.time
    linkage = kin.linkage
    n = linkage.n
    swing = _swing_foot(kin, settings, float(settings["mu"]))
    step_length = float(settings["step_length"])
    swap = swap_legs(linkage)
    foot_link, foot_offset = _foot(kin, settings)
    source = list(swap.source)
    # The state after heel strike, in the next step's labels: this step's own x(0) when it
    # repeats (periodic), the next step's first state in a sequence (``next_state``).
    psi_next, dpsi_next, join = _next_state(settings, psi, dpsi)
    # Angles: the next step starts from the swapped pose of this step's end.
    swapped, _ = swap.map_state(psi[-1], dpsi[-1])
    where = "t = 0 vs swap(T)" if join == "periodic" else "the next step's t = 0 vs swap(T)"
    add(f"{join} angles", -np.abs(_wrap(psi_next - swapped)), "rad", where=where)
    landing, approach, _ = kin.point(foot_link, foot_offset, psi[-1:], dpsi[-1:])
    speed = float(settings.get("touchdown_speed") or 0.0)
    add(
        "heel strike",
        np.array([-approach[0].imag - speed]),
        "m/s",
        where=f"t = T (foot coming down at {speed:g} m/s or faster)",
    )
    _landing_speed(add, settings, approach[0], "t = T")
    add(
        "landing",
        -np.abs(np.array([landing[0].real - step_length, landing[0].imag])),
        "m",
        where="t = T",
    )
    # After heel strike, in this step's labels: rates relabelled back from x(0); the old
    # stance foot (H0) moves like the new swing foot does at t = 0.
    dpsi_plus = np.empty(n)
    dpsi_plus[source] = dpsi_next
    _, lift, _ = kin.point(foot_link, foot_offset, psi_next[None], dpsi_next[None])
    base = complex(lift[0])
    _, foot_after, _ = kin.point(foot_link, foot_offset, psi[-1:], dpsi_plus[None])
    add("foot at rest", -np.array([abs(foot_after[0] + base)]), "m/s", where="after impact")
    _, v_minus, _ = kin.coms(psi[-1:], dpsi[-1:])
    _, v_plus, _ = kin.coms(psi[-1:], dpsi_plus[None])
    impulse = complex(((v_plus[0] + base) - v_minus[0]) @ kin.mass)
    momentum_scale = float(np.sum(kin.mass))
    add(
        "impulse cone",
        np.array([swing.cone_margin(impulse.real, impulse.imag)]),
        "N s",
        momentum_scale,
        where="heel strike",
    )
    add("lift off", np.array([base.imag]), "m/s", where="after impact")
    about = complex(landing[0])
    parts = [("whole tree", about, range(n))]
    starts, _, _ = kin.starts(psi[-1:])
    for c in range(1, n):
        subtree = set(linkage.subtree(c))
        part = subtree if foot_link not in subtree else set(range(n)) - subtree
        parts.append((f"hinge of {linkage.names[c]}", complex(starts[0, c]), sorted(part)))
    worst, where = math.inf, ""
    scale = max(
        abs(kin.angular_momentum(psi[-1], dpsi[-1], 0j, about, range(n))),
        momentum_scale * 1.0 * kin.linkage.links[0].length,
    )
    for label, point, part in parts:
        before = kin.angular_momentum(psi[-1], dpsi[-1], 0j, point, part)
        after = kin.angular_momentum(psi[-1], dpsi_plus, base, point, part)
        margin = -abs(after - before)
        if margin < worst:
            worst, where = margin, f"about the {label}"
    add("impact momentum", np.array([worst]), "kg m^2/s", scale, where=where)
    height = kin.point(foot_link, foot_offset, psi)[0].imag
    s = (times - times[0]) / (times[-1] - times[0])
    add("clearance", height - _clearance_profile(settings, s), "m")
    if settings.get("start") == "standing":
        # Quiet standing at t = 0: both feet on the ground at one point, the body at rest.
        foot, _, _ = kin.point(foot_link, foot_offset, psi[:1], dpsi[:1])
        add("standing feet", -np.abs([foot[0].real, foot[0].imag]), "m", where="t = 0")
        add("standing at rest", -np.abs(dpsi[0]), "rad/s", where="t = 0")


def _next_state(settings, psi: np.ndarray, dpsi: np.ndarray):
    """(psi (n,), dpsi (n,), what they are) after this step's heel strike and leg swap: the
    step's own first state when it is periodic, ``settings["next_state"]`` (2n,) (the next
    step's first state in a sequence of steps) when that is given."""
    n = psi.shape[1]
    given = settings.get("next_state")
    if given is None:
        return psi[0], dpsi[0], "periodic"
    x = np.asarray(given, dtype=float).reshape(-1)
    if x.shape != (2 * n,) or not np.all(np.isfinite(x)):
        raise DefinitionError(
            f"`settings['next_state']`: the next step's first state (psi, dpsi), {2 * n} finite "
            f"numbers, got {x.size}"
        )
    return x[:n], x[n:], "join"


def _held_impact(
    kin: _Kinematics, psi, dpsi_minus, dpsi_plus, landing: complex, link: int, welded=False
):
    """An impact with the root's start (H0) held and a point of ``link`` at ``landing``
    landing: (momentum residual (n + 2,), rear impulse, front impulse, angular impulse), the
    impulses (complex, N s) at H0 and at the landing point found from the momentum balances
    by least squares (linear momentum; angular momentum of the whole tree about H0 and of
    the part beyond every hinge about it); with ``welded`` the root link is held in rotation
    too and takes an angular impulse about H0 (N m s; else 0); a consistent impact leaves no
    residual."""
    linkage = kin.linkage
    n = linkage.n
    _, v_minus, _ = kin.coms(psi[None], dpsi_minus[None])
    _, v_plus, _ = kin.coms(psi[None], dpsi_plus[None])
    starts, _, _ = kin.starts(psi[None])
    momentum = complex((v_plus[0] - v_minus[0]) @ kin.mass)
    lever = complex(landing - starts[0, 0])
    rows = [[1.0, 0.0, 1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, -lever.imag, lever.real, 1.0]]  # fmt: skip
    right = [momentum.real, momentum.imag]
    whole = kin.angular_momentum(psi, dpsi_plus, 0j, starts[0, 0], range(n)) - (
        kin.angular_momentum(psi, dpsi_minus, 0j, starts[0, 0], range(n))
    )
    right.append(whole)
    for c in range(1, n):
        part = linkage.subtree(c)
        about = complex(starts[0, c])
        change = kin.angular_momentum(psi, dpsi_plus, 0j, about, part) - (
            kin.angular_momentum(psi, dpsi_minus, 0j, about, part)
        )
        arm = complex(landing - about) if link in part else 0j
        rows.append([0.0, 0.0, -arm.imag, arm.real, 0.0])
        right.append(change)
    matrix = np.array(rows) if welded else np.array(rows)[:, :4]
    impulses, *_ = np.linalg.lstsq(matrix, np.array(right), rcond=None)
    residual = matrix @ impulses - np.array(right)
    angular = float(impulses[4]) if welded else 0.0
    return residual, complex(*impulses[:2]), complex(*impulses[2:4]), angular


def _verify_double_support(add, kin: _Kinematics, settings, trajectory, weight, hold) -> None:
    """A step with a double support: single support until T_s = step_time - double_support,
    the impact with both feet held (its pre-impact state in ``before_events``), both feet on
    the ground until T, the legs swap without an impact."""
    linkage = kin.linkage
    n = linkage.n
    mu = float(settings["mu"])
    rear_foot, front_foot = Contact.at_root(linkage, mu), _swing_foot(kin, settings, mu)
    step_length = float(settings["step_length"])
    psi, dpsi, times = trajectory.psi, trajectory.dpsi, trajectory.time
    swap = swap_legs(linkage)
    foot_link, foot_offset = _foot(kin, settings)
    events = settings.get("before_events") or []
    if not events:
        raise DefinitionError(
            "`settings`: a step with a double support needs the state before its impact "
            "(metadata['gait']['before_events'], written by WalkingGait.to_trajectory)"
        )
    strike_time = float(events[0]["t"])
    pre = np.asarray(events[0]["x"], dtype=float)
    j = int(np.argmin(np.abs(times - strike_time)))  # the double support's first sample
    double = times >= times[j]
    # Periodicity: the legs swap when the double support ends, the rates unchanged.
    swapped, swapped_rates = swap.map_state(psi[-1], dpsi[-1])
    add("periodic angles", -np.abs(_wrap(psi[0] - swapped)), "rad", where="t = 0 vs swap(T)")
    add("periodic rates", -np.abs(dpsi[0] - swapped_rates), "rad/s", where="t = 0 vs swap(T)")
    landing, approach, _ = kin.point(foot_link, foot_offset, pre[None, :n], pre[None, n:])
    add("heel strike", np.array([-approach[0].imag]), "m/s", where=f"t = {strike_time:.4g} s")
    _landing_speed(add, settings, approach[0], f"t = {strike_time:.4g} s")
    target = complex(step_length, 0.0)
    add("landing", -np.array([abs(landing[0] - target)]), "m", where=f"t = {strike_time:.4g} s")
    add("impact pose", -np.abs(psi[j] - pre[:n]), "rad", where=f"t = {strike_time:.4g} s")
    scale = float(np.sum(kin.mass)) * linkage.links[0].length
    residual, rear, front, _ = _held_impact(
        kin, psi[j], pre[n:], dpsi[j], complex(landing[0]), foot_link
    )
    add("impact momentum", -np.abs(residual), "kg m^2/s", scale, where="heel strike")
    add(
        "impulse cones",
        np.array(
            [
                front_foot.cone_margin(front.real, front.imag),
                rear_foot.cone_margin(rear.real, rear.imag),
            ]
        ),
        "N s",
        float(np.sum(kin.mass)),
        where="heel strike (front, rear)",
    )
    # The front foot held from the impact on: at (s, 0), at rest.
    held, moving, _ = kin.point(foot_link, foot_offset, psi[double], dpsi[double])
    add("foot held", -np.abs(held - target), "m", hold, where="double support")
    add("foot at rest", -np.abs(moving), "m/s", hold, where="double support")
    # Lift-off of the rear foot: the next step's swing foot starts upwards (or at rest).
    _, lift, _ = kin.point(foot_link, foot_offset, psi[:1], dpsi[:1])
    add("lift off", np.array([lift[0].imag]), "m/s", where="t = 0")
    # The front foot's ground force (a control) in its cone while it is held (the rear
    # foot's, the whole tree's reaction less it, is the stance foot's cone above).
    front_force = np.zeros(times.size, dtype=complex)
    for _, _, force in _contacts(kin, settings, trajectory):
        front_force += force
    cone = front_foot.cone_margin(front_force.real, front_force.imag)
    add("front foot cone", np.where(double, cone, np.inf), "N", weight)
    single = ~double
    height = kin.point(foot_link, foot_offset, psi[single])[0].imag
    s = times[single] / strike_time
    margins = np.full(times.size, np.inf)
    margins[single] = height - _clearance_profile(settings, s)
    add("clearance", margins, "m")


#: The contact phases of a step on feet when its settings name none (the human cycle).
FOOTED_PHASES = ("flat", "heel rise", "double")


def _verify_footed(add, kin: _Kinematics, settings, trajectory, weight, hold, passive) -> None:
    """A step on feet (``problems.walking.footed``), its contact phases as listed in
    ``settings["phases"]`` (default the human cycle: flat, heel rise, double): the stance foot
    flat and still while it lies flat (until the heel rises; through the whole step when it
    never rises), the centre of pressure of the ground's torque on it on the sole
    (``foot``: the root's torque M_0 and the ground's force at the ball less the front
    foot's, -sole Fy <= M_0 <= 0), its heel above the ground after and the ball a pivot
    that carries no torque (at most ``passive`` of the torque scale, as a passive joint); the
    swing foot's heel and ball over the clearance profile until its striking point
    (``settings["strike"]``: its heel, or its ball in toe walking) lands at
    (step_length - sole, 0) (the ball: (step_length, 0)); the impact with the stance ball
    held (and the stance foot held flat, its angular impulse on the sole, when it lies
    flat); the striking point held at rest and its force in the cone through the double
    support, the front foot's other point above the ground, the front foot flat and at rest
    at the end after a heel strike; ankles in their range; the legs swap at the end
    (periodic angles and rates; ``join angles`` and ``join rates`` against ``next_state``
    in a sequence of steps). A step that starts from quiet standing (``start`` "standing")
    checks ``standing feet`` (the swing ball at the stance ball at t = 0, m), ``standing
    flat`` (both soles flat at t = 0, rad) and ``standing at rest`` (dpsi(0), rad/s). A stop
    (``stop``: one flat phase, no strike) checks the clearance until its end and the same
    three at t = T instead of the strike and the double support."""
    linkage = kin.linkage
    named = _named_contacts(kin, settings)
    psi, dpsi, times = trajectory.psi, trajectory.dpsi, trajectory.time
    sequence = tuple(settings.get("phases") or FOOTED_PHASES)
    events = settings.get("before_events") or []
    if len(events) != len(sequence) - 1:
        raise DefinitionError(
            f"`settings`: a step on feet of phases {sequence} needs the states before its "
            f"{len(sequence) - 1} events (metadata['gait']['before_events'], written by "
            f"Gait.to_trajectory), got {len(events)}"
        )
    stop = bool(settings.get("stop"))
    # a stop's single support is the whole step: it ends at rest, with no strike
    strike = float(times[-1]) if stop else float(events[-1]["t"])
    stance, swing = _legs(linkage)
    flat_stance, flat_swing = (float(v) for v in settings["flat_angles"])
    root, foot = stance[0], swing[-1]
    swap = swap_legs(linkage)
    swapped, swapped_rates = swap.map_state(psi[-1], dpsi[-1])
    # the next step starts from the swapped state at toe-off: this step's own first state
    # when it repeats, the next step's in a sequence of steps (``next_state``)
    psi_next, dpsi_next, join = _next_state(settings, psi, dpsi)
    where = "t = 0 vs swap(T)" if join == "periodic" else "the next step's t = 0 vs swap(T)"
    add(f"{join} angles", -np.abs(_wrap(psi_next - swapped)), "rad", where=where)
    add(f"{join} rates", -np.abs(dpsi_next - swapped_rates), "rad/s", where=where)
    edge = 1e-9 * max(1.0, float(times[-1]))
    rear_flat = "heel rise" not in sequence
    if "flat" not in sequence:  # on the ball from the start
        flat = np.zeros(times.size, dtype=bool)
    elif rear_flat:  # flat until toe-off
        flat = np.ones(times.size, dtype=bool)
    else:  # flat until the heel rises
        flat = times <= float(events[0]["t"]) + edge
    add("stance foot flat", np.where(flat, -np.abs(_wrap(psi[:, root] - flat_stance)), np.inf),
        "rad")  # fmt: skip
    add("stance foot still", np.where(flat, -np.abs(dpsi[:, root]), np.inf), "rad/s")

    def height(name, rows=slice(None)):
        link, offset = named[name]
        return kin.point(link, offset, psi[rows])[0].imag

    add("stance heel up", np.where(~flat, height("stance_heel"), np.inf), "m")
    reaction = kin.ground_reaction(psi, trajectory.dpsi, trajectory.ddpsi)
    for _, _, force in _contacts(kin, settings, trajectory):
        reaction = reaction - force
    moment = trajectory.torques[:, root]
    heel, toe = (float(v) for v in settings["foot"])
    rows = np.column_stack([moment + heel * reaction.imag, toe * reaction.imag - moment])
    add("centre of pressure", np.where(flat[:, None], rows, np.inf), "N m", weight * (heel + toe))
    scale = _torque_scale(kin, settings)
    add("ball passive", np.where(flat, np.inf, passive * scale - np.abs(moment)), "N m", scale)
    single = times <= strike + edge if stop else times < strike - edge
    fraction = np.clip(times / strike, 0.0, 1.0)
    floor = _clearance_profile(settings, fraction, single=strike)
    swing_feet = np.column_stack([height("swing_heel") - floor, height("swing_toe") - floor])
    add("clearance", np.where(single[:, None], swing_feet, np.inf), "m")
    if stop:
        _standing_on_feet(add, kin, named, psi, dpsi, -1, f"t = {times[-1]:.4g} s",
                          (root, foot), (flat_stance, flat_swing))  # fmt: skip
    else:
        _footed_strike(add, kin, settings, trajectory, events[-1], weight, hold, strike)
    if settings.get("start") == "standing":
        # Quiet standing at t = 0: both feet flat side by side, the body at rest.
        _standing_on_feet(add, kin, named, psi, dpsi, 0, "t = 0", (root, foot),
                          (flat_stance, flat_swing))  # fmt: skip
    low, high = (float(v) for v in settings["ankle_range"])
    neutral = [float(v) for v in settings["neutral_ankles"]]
    ankles = np.column_stack([psi[:, stance[1]] - psi[:, root] - neutral[0],
                              psi[:, swing[1]] - psi[:, foot] - neutral[1]])  # fmt: skip
    add("ankles", np.minimum(ankles - low, high - ankles), "rad")


def _standing_on_feet(add, kin: _Kinematics, named, psi, dpsi, k: int, where: str, feet,
                      flat) -> None:  # fmt: skip
    """Quiet standing at sample ``k``: ``standing feet`` (the swing ball at the stance ball,
    m), ``standing flat`` (both soles flat, rad: ``feet`` (root, swing foot) link indices at
    their ``flat`` angles), ``standing at rest`` (dpsi, rad/s)."""
    ball, _, _ = kin.point(*named["swing_toe"], psi[k : k + 1 or None])
    base, _, _ = kin.point(*named["stance_toe"], psi[k : k + 1 or None])
    gap = ball[0] - base[0]
    add("standing feet", -np.abs([gap.real, gap.imag]), "m", where=where)
    angles = np.array([psi[k, feet[0]] - flat[0], psi[k, feet[1]] - flat[1]])
    add("standing flat", -np.abs(_wrap(angles)), "rad", where=where)
    add("standing at rest", -np.abs(dpsi[k]), "rad/s", where=where)


def _footed_strike(add, kin: _Kinematics, settings, trajectory, event, weight, hold,
                   strike: float) -> None:  # fmt: skip
    """The strike of a step on feet at ``strike`` s (``event``: the state just before it)
    and the double support after it (see :func:`_verify_footed`)."""
    linkage = kin.linkage
    n = linkage.n
    mu = float(settings["mu"])
    named = _named_contacts(kin, settings)
    psi, dpsi, times = trajectory.psi, trajectory.dpsi, trajectory.time
    sequence = tuple(settings.get("phases") or FOOTED_PHASES)
    strike_role = str(settings.get("strike") or "swing_heel")
    pre = np.asarray(event["x"], dtype=float)
    rear_flat = "heel rise" not in sequence
    foot = _legs(linkage)[1][-1]
    flat_swing = float(settings["flat_angles"][1])
    heel, toe = (float(v) for v in settings["foot"])

    def height(name):
        link, offset = named[name]
        return kin.point(link, offset, psi)[0].imag

    # The strike, from the state just before it.
    by_heel = strike_role == "swing_heel"
    point = "heel" if by_heel else "ball"
    strike_link, strike_offset = named[strike_role]
    landing, approach, _ = kin.point(strike_link, strike_offset, pre[None, :n], pre[None, n:])
    speed = float(settings.get("touchdown_speed") or 0.0)
    coming = f"the {point} coming down at {speed:g} m/s or faster"
    add("heel strike", np.array([-approach[0].imag - speed]), "m/s",
        where=f"t = {strike:.4g} s ({coming})")  # fmt: skip
    behind = float(settings["sole"]) if by_heel else 0.0
    target = complex(float(settings["step_length"]) - behind, 0.0)
    add("landing", -np.array([abs(landing[0] - target)]), "m", where=f"t = {strike:.4g} s")
    j = int(np.argmin(np.abs(times - strike)))  # the double support's first sample
    add("impact pose", -np.abs(psi[j] - pre[:n]), "rad", where=f"t = {strike:.4g} s")
    residual, rear, front, angular = _held_impact(
        kin, psi[j], pre[n:], dpsi[j], complex(landing[0]), strike_link, welded=rear_flat
    )
    mass = float(np.sum(kin.mass))
    scale = mass * linkage.links[1].length
    add("impact momentum", -np.abs(residual), "kg m^2/s", scale, where=f"{point} strike")
    strike_contact = Contact(LinkPoint(linkage.names[strike_link]), friction=mu)
    add("impulse cones", np.array([strike_contact.cone_margin(front.real, front.imag),
                                   strike_contact.cone_margin(rear.real, rear.imag)]),
        "N s", mass, where=f"{point} strike (front {point}, rear ball)")  # fmt: skip
    if rear_flat:  # the rear foot's angular impulse about its ball: the impulse on its sole
        add("impulse pressure", np.array([angular + heel * rear.imag, toe * rear.imag - angular]),
            "N m s", mass * (heel + toe), where=f"{point} strike (rear foot flat)")  # fmt: skip
    double = times >= times[j]
    held, moving, _ = kin.point(strike_link, strike_offset, psi[double], dpsi[double])
    add(f"{point} held", -np.abs(held - target), "m", hold, where="double support")
    add(f"{point} at rest", -np.abs(moving), "m/s", hold, where="double support")
    # The front foot's other point above the ground, up to the held point's own drift
    # (checked above with the hold tolerance): the foot turning down about its held heel
    # lays the ball on the ground where the heel is.
    other = "swing_toe" if by_heel else "swing_heel"
    up = height(other) - np.minimum(height(strike_role), 0.0)
    add(f"front {'ball' if by_heel else 'heel'} up", np.where(double, up, np.inf), "m")
    front_force = np.zeros(times.size, dtype=complex)
    for _, _, force in _contacts(kin, settings, trajectory):
        front_force += force
    cone = strike_contact.cone_margin(front_force.real, front_force.imag)
    add(f"front {point} cone", np.where(double, cone, np.inf), "N", weight)
    if by_heel:
        add("front foot flat", -np.array([abs(_wrap(psi[-1, foot] - flat_swing)),
                                          abs(dpsi[-1, foot])]),
            "rad(/s)", where=f"t = {times[-1]:.4g} s")  # fmt: skip


__all__ = [
    "Check",
    "GaitReport",
    "GaitVerificationError",
    "GaitVerificationWarning",
    "verify_gait",
]
