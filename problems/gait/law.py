"""The seed paper's walking law (22), generalised with a centre angle per link.

    psi_j(t) = center_j + zeta_j sin( varpi_j - (1 - cos(2 pi t / T)) pi/2 ),   j = 1..n

(paper: center_j = pi/2 for every link; zeta_j is an amplitude in radians although the paper
says seconds, errata item 6). With the phase phi_j(t) = varpi_j - (1 - cos(w t)) pi/2 and
w = 2 pi / T the derivatives are analytic:

    dphi/dt   = -(pi/2) w sin(w t)             d2phi/dt2 = -(pi/2) w^2 cos(w t)
    dpsi_j    = zeta_j cos(phi_j) dphi/dt
    ddpsi_j   = zeta_j ( cos(phi_j) d2phi/dt2 - sin(phi_j) (dphi/dt)^2 )

The law evaluates on numbers (numpy: a time or an array of times) and on CasADi expressions
(a scalar SX, MX or DM time: psi, dpsi, ddpsi as (n, 1) columns of the same formulas), so an
OCP's constraint or cost reads ``p.psi - law.psi(p.t)`` without writing the law again.

Every link shares the time function phi - varpi, so dpsi vanishes for all links at once at
t = 0 and t = T/2 (mod T). The motion is *static* there (ddpsi = 0 as well) only for the links
with cos(phi_j) = 0, i.e. varpi_j = pi/2 (mod pi) at t = 0, or varpi_j - pi = pi/2 (mod pi) at
T/2, which is the same condition; "paper22" has no static instant (its ddpsi(0) != 0), see
:meth:`GaitLaw.static_times`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from planner.errors import (
    DefinitionError,
    DefinitionTypeError,
    as_float_array,
    check_finite,
    check_positive,
    check_real,
)

__all__ = ["LAW_PRESETS", "GaitLaw"]

HALF_PI = 0.5 * math.pi

#: CasADi types a time may have for a symbolic evaluation.
SYMBOLIC = (ca.SX, ca.MX, ca.DM)


def _vector(field_name: str, values: object) -> tuple[float, ...]:
    """Validate a per-link parameter vector and return it as a tuple of floats."""
    if isinstance(values, (str, bytes)) or not isinstance(values, (Sequence, np.ndarray)):
        raise DefinitionTypeError(
            f"`GaitLaw.{field_name}`: must be a sequence of real numbers (one per link), "
            f"got {values!r}"
        )
    items = tuple(check_real(f"GaitLaw.{field_name}[{i}]", v) for i, v in enumerate(values))
    if not items:
        raise DefinitionError(f"`GaitLaw.{field_name}`: must have one value per link, got none")
    return items


@dataclass(frozen=True)
class GaitLaw:
    """Law (22) of the seed paper with a per-link centre angle.

    Parameters
    ----------
    period : float
        Walking period T, s (> 0).
    zeta : sequence of float, length n
        Amplitudes zeta_j, rad (>= 0; a negative amplitude is the phase varpi_j + pi).
    varpi : sequence of float, length n
        Phases varpi_j, rad.
    center : sequence of float, length n, or None
        Centre angles, rad, measured from +x counter-clockwise. ``None``: pi/2 for every link
        (the paper's upright law).
    name : str
        A label carried into exported metadata.

    A law is a value: frozen, comparable, printable; ``to_dict``/``from_dict`` round-trip it.
    """

    period: float
    zeta: tuple[float, ...]
    varpi: tuple[float, ...]
    center: tuple[float, ...] | None = None
    name: str = field(default="custom")

    def __post_init__(self) -> None:
        period = check_positive("GaitLaw.period", self.period, "s")
        zeta = _vector("zeta", self.zeta)
        varpi = _vector("varpi", self.varpi)
        center = (HALF_PI,) * len(zeta) if self.center is None else _vector("center", self.center)
        for field_name, values in (("varpi", varpi), ("center", center)):
            if len(values) != len(zeta):
                raise DefinitionError(
                    f"`GaitLaw.{field_name}`: has {len(values)} values but `zeta` has "
                    f"{len(zeta)}; give one value per link"
                )
        for i, z in enumerate(zeta):
            if z < 0:
                raise DefinitionError(
                    f"`GaitLaw.zeta[{i}]`: amplitude must be >= 0 rad, got {z!r}; "
                    "use the phase varpi + pi instead of a negative amplitude"
                )
        if not isinstance(self.name, str):
            raise DefinitionTypeError(f"`GaitLaw.name`: must be a string, got {self.name!r}")
        # |ddpsi_j| <= zeta_j ((pi/2) w^2 + (pi/2)^2 w^2) with w = 2 pi / T: a period so short
        # that this overflows gives inf and NaN accelerations (then torques) everywhere.
        w = 2.0 * math.pi / period
        peak = max(zeta) * (HALF_PI + HALF_PI * HALF_PI) * w * w
        if not math.isfinite(w) or not math.isfinite(peak):
            raise DefinitionError(
                f"`GaitLaw.period`: {period!r} s is too short: the law's angular accelerations "
                f"(~zeta (2 pi / T)^2 = {peak:.3g} rad/s^2) overflow double precision; give a "
                "period in seconds, e.g. 1.0"
            )
        object.__setattr__(self, "period", period)
        object.__setattr__(self, "zeta", zeta)
        object.__setattr__(self, "varpi", varpi)
        object.__setattr__(self, "center", center)

    # ---- presets and plain data -----------------------------------------------------------
    @classmethod
    def preset(cls, name: str) -> GaitLaw:
        """A named law: ``"paper22"`` (scene.md benchmark) or ``"walking"`` (see LAW_PRESETS)."""
        if name not in LAW_PRESETS:
            raise DefinitionError(
                f"`law`: unknown gait-law preset {name!r}; available: {sorted(LAW_PRESETS)}"
            )
        return cls(**LAW_PRESETS[name], name=name)

    def to_dict(self) -> dict:
        """Plain JSON-serialisable parameters (for exported metadata)."""
        return {
            "name": self.name,
            "period": self.period,
            "zeta": list(self.zeta),
            "varpi": list(self.varpi),
            "center": list(self.center),
            "formula": "psi_j(t) = center_j + zeta_j sin(varpi_j - (1 - cos(2 pi t / T)) pi/2)",
        }

    @classmethod
    def from_dict(cls, data: dict) -> GaitLaw:
        """Inverse of :meth:`to_dict` (extra keys such as ``formula`` are ignored)."""
        if not isinstance(data, dict):
            raise DefinitionTypeError(f"`data`: must be a dict of law parameters, got {data!r}")
        missing = [k for k in ("period", "zeta", "varpi") if k not in data]
        if missing:
            raise DefinitionError(f"`data`: gait-law parameters lack {missing}")
        return cls(
            period=data["period"],
            zeta=data["zeta"],
            varpi=data["varpi"],
            center=data.get("center"),
            name=data.get("name", "custom"),
        )

    @property
    def n(self) -> int:
        """Number of links the law drives."""
        return len(self.zeta)

    def check_links(self, names: Sequence[str]) -> GaitLaw:
        """This law, if it drives one link per name in ``names`` (a linkage's links); else a
        DefinitionError naming both counts and the links."""
        if self.n != len(names):
            raise DefinitionError(
                f"`law`: drives {self.n} links but the linkage has {len(names)} "
                f"({', '.join(names)}); give one zeta, varpi and center per link"
            )
        return self

    # ---- evaluation ---------------------------------------------------------------------------
    def _phase(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """phi (K, n), dphi/dt (K, 1), d2phi/dt2 (K, 1) and the arrays' scalar flag."""
        scalar = np.ndim(t) == 0
        times = np.atleast_1d(as_float_array("t", t, "a time or a 1-D array of times in s"))
        if times.ndim != 1:
            raise DefinitionError(
                f"`t`: must be a scalar or a 1-D array (K,), got shape {times.shape}"
            )
        check_finite("t", times, "times in s")
        w = 2.0 * math.pi / self.period
        wt = w * times[:, None]
        phi = np.asarray(self.varpi)[None, :] - (1.0 - np.cos(wt)) * HALF_PI
        dphi = -HALF_PI * w * np.sin(wt)
        ddphi = -HALF_PI * w * w * np.cos(wt)
        return phi, dphi, ddphi, np.asarray(self.zeta)[None, :], scalar

    @staticmethod
    def _shape(values: np.ndarray, scalar: bool) -> np.ndarray:
        return values[0] if scalar else values

    def symbolic(self, t) -> tuple:
        """(psi, dpsi, ddpsi) as (n, 1) CasADi expressions of the scalar time ``t`` (an SX or
        MX symbol or expression, or a DM), rad, rad/s, rad/s^2: the formulas of the module
        docstring, for constraints and costs of an OCP (``p.psi - law.psi(p.t)``)."""
        if t.numel() != 1:
            raise DefinitionError(
                f"`t`: a CasADi time must be a scalar, got shape {t.shape}; evaluate the law "
                "at one symbolic time (p.t) or give numbers"
            )
        w = 2.0 * math.pi / self.period
        wt = w * t
        sin_wt, cos_wt = ca.sin(wt), ca.cos(wt)
        phi = ca.DM(self.varpi) - (1 - cos_wt) * HALF_PI
        dphi = -HALF_PI * w * sin_wt
        ddphi = -HALF_PI * w * w * cos_wt
        zeta = ca.DM(self.zeta)
        sin, cos = ca.sin(phi), ca.cos(phi)
        psi = ca.DM(self.center) + zeta * sin
        dpsi = zeta * cos * dphi
        ddpsi = zeta * (cos * ddphi - sin * dphi * dphi)
        return psi, dpsi, ddpsi

    def psi(self, t):
        """Angles psi(t), rad: (n,) for a scalar t in s, (K, n) for t of shape (K,), an
        (n, 1) CasADi expression for a CasADi time (:meth:`symbolic`)."""
        if isinstance(t, SYMBOLIC):
            return self.symbolic(t)[0]
        phi, _, _, zeta, scalar = self._phase(t)
        return self._shape(np.asarray(self.center)[None, :] + zeta * np.sin(phi), scalar)

    def dpsi(self, t):
        """Angular velocities, rad/s: (n,) or (K, n), or (n, 1) for a CasADi time."""
        if isinstance(t, SYMBOLIC):
            return self.symbolic(t)[1]
        phi, dphi, _, zeta, scalar = self._phase(t)
        return self._shape(zeta * np.cos(phi) * dphi, scalar)

    def ddpsi(self, t):
        """Angular accelerations, rad/s^2: (n,) or (K, n), or (n, 1) for a CasADi time."""
        if isinstance(t, SYMBOLIC):
            return self.symbolic(t)[2]
        phi, dphi, ddphi, zeta, scalar = self._phase(t)
        return self._shape(zeta * (np.cos(phi) * ddphi - np.sin(phi) * dphi * dphi), scalar)

    def __call__(self, t) -> tuple:
        """(psi, dpsi, ddpsi) at t, each (n,) or (K, n) (or (n, 1) CasADi expressions for a
        CasADi time); rad, rad/s, rad/s^2."""
        if isinstance(t, SYMBOLIC):
            return self.symbolic(t)
        phi, dphi, ddphi, zeta, scalar = self._phase(t)
        sin, cos = np.sin(phi), np.cos(phi)
        psi = np.asarray(self.center)[None, :] + zeta * sin
        dpsi = zeta * cos * dphi
        ddpsi = zeta * (cos * ddphi - sin * dphi * dphi)
        return self._shape(psi, scalar), self._shape(dpsi, scalar), self._shape(ddpsi, scalar)

    def state(self, t):
        """The ODE state x = [psi; dpsi] at t: (2n,) or (K, 2n), or (2n, 1) for a CasADi
        time."""
        if isinstance(t, SYMBOLIC):
            psi, dpsi, _ = self.symbolic(t)
            return ca.vertcat(psi, dpsi)
        psi, dpsi, _ = self(t)
        return np.concatenate([psi, dpsi], axis=-1)

    def static_times(self, t_end: float | None = None, tol: float = 1e-12) -> np.ndarray:
        """Times in [0, t_end] (default one period) where dpsi = ddpsi = 0 for every link, s.

        dpsi = 0 for all links exactly at t = k T/2; there ddpsi_j = -zeta_j cos(phi_j)
        (pi/2) w^2 cos(w t) vanishes iff zeta_j cos(phi_j) = 0 with phi_j = varpi_j (k even)
        or varpi_j - pi (k odd); both give cos(varpi_j) = 0 up to sign. So either every
        link with zeta_j != 0 has cos(varpi_j) = 0 (within ``tol``), and every t = k T/2 is
        static, or the law has no static instant and the result is empty.
        """
        end = self.period if t_end is None else check_real("t_end", t_end)
        if end < 0:
            raise DefinitionError(f"`t_end`: must be >= 0 s, got {end!r}")
        static = all(
            z == 0.0 or abs(math.cos(v)) <= tol for z, v in zip(self.zeta, self.varpi, strict=True)
        )
        if not static:
            return np.empty(0)
        half = 0.5 * self.period
        return half * np.arange(math.floor(end / half + 1e-12) + 1)

    def __str__(self) -> str:
        def fmt(values):
            return "[" + ", ".join(f"{v:.4g}" for v in values) + "]"

        return (
            f"GaitLaw {self.name!r}: T = {self.period:g} s, zeta = {fmt(self.zeta)} rad, "
            f"varpi = {fmt(self.varpi)} rad, center = {fmt(self.center)} rad"
        )


#: Named laws for six-link scenes (link order of ``model.presets.six_link_anthropoid``).
#: "paper22": the scene.md benchmark (the paper's law, every link about the upward vertical).
#: "walking": the same amplitudes and phases, with the swing leg (links 3, 4) about the
#: downward vertical -pi/2 and the stance leg and trunk about +pi/2: a walking posture.
LAW_PRESETS: dict[str, dict] = {
    "paper22": {
        "period": 1.0,
        "zeta": (0.20, 0.30, 0.40, 0.30, 0.10, 0.05),
        "varpi": (0.00, 0.50, 1.00, 1.50, 0.20, 0.40),
        "center": (HALF_PI,) * 6,
    },
    "walking": {
        "period": 1.0,
        "zeta": (0.20, 0.30, 0.40, 0.30, 0.10, 0.05),
        "varpi": (0.00, 0.50, 1.00, 1.50, 0.20, 0.40),
        "center": (HALF_PI, HALF_PI, -HALF_PI, -HALF_PI, HALF_PI, HALF_PI),
    },
}
