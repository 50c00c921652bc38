"""Motors and gearboxes as a drive engineer's catalogue holds them, read from CSV files.

The layout (one row per product; a header row naming the columns, any order; SI-prefixed units
as in datasheets, converted here; a column may be left empty only where it says so):

motors.csv
    ``name``; ``torque_constant_mNm_A`` (k_t; the back-EMF constant is the same number in
    mV s/rad); ``resistance_ohm`` (terminal, phase to phase); ``rotor_inertia_gcm2``;
    ``continuous_torque_mNm`` (the nominal, thermally continuous torque); ``peak_torque_mNm``
    (the short-time torque the drive's current limit allows); ``voltage_V`` (the supply);
    ``max_speed_rpm``; ``mass_g``; ``source`` (where the numbers come from: datasheet and page).
gearboxes.csv
    ``name``; ``ratio`` (N, motor turns per output turn, >= 1); ``efficiency`` (eta in (0, 1],
    forward, at rated load); ``inertia_gcm2`` (at its input, the motor side);
    ``continuous_torque_Nm`` (rated output torque); ``peak_torque_Nm`` (repeated peak output
    torque); ``max_input_speed_rpm``; ``mass_g``; ``source``.

A drive is one motor with one gearbox (:class:`Drive`). At an output torque tau (N m, the
joint's, in the sense that grows its angle q) and speed dq (rad/s) with acceleration ddq, the
motor turns at N dq and gives

    tau_m = (J_m + J_g) N ddq + tau / (N eta)   when the motor drives (tau dq >= 0),
    tau_m = (J_m + J_g) N ddq + tau eta / N     when the load drives it back (tau dq < 0),

draws the current i = tau_m / k_t, needs the voltage u = R i + k_t N dq, and takes the electrical
power u i = R i^2 + tau_m N dq (copper losses plus the mechanical power at the motor; negative
when it regenerates). The rotor's and gearbox's inertia is the drive's own: reflected through
N^2 it adds to the joint's inertia (issue #36's part 4 puts it in the equations of motion); here
the motor supplies it on top of the plan's torque.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.errors import DefinitionError

#: motors.csv's columns: name -> (unit factor to SI, what it is)
MOTOR_COLUMNS = {
    "torque_constant_mNm_A": (1e-3, "torque constant k_t, mN m/A"),
    "resistance_ohm": (1.0, "terminal resistance, ohm"),
    "rotor_inertia_gcm2": (1e-7, "rotor inertia, g cm^2"),
    "continuous_torque_mNm": (1e-3, "continuous torque, mN m"),
    "peak_torque_mNm": (1e-3, "peak torque, mN m"),
    "voltage_V": (1.0, "supply voltage, V"),
    "max_speed_rpm": (math.pi / 30.0, "largest speed, rpm"),
    "mass_g": (1e-3, "mass, g"),
}
#: gearboxes.csv's columns: name -> (unit factor to SI, what it is)
GEARBOX_COLUMNS = {
    "ratio": (1.0, "reduction N, >= 1"),
    "efficiency": (1.0, "efficiency eta in (0, 1]"),
    "inertia_gcm2": (1e-7, "inertia at the input, g cm^2"),
    "continuous_torque_Nm": (1.0, "rated output torque, N m"),
    "peak_torque_Nm": (1.0, "repeated peak output torque, N m"),
    "max_input_speed_rpm": (math.pi / 30.0, "largest input speed, rpm"),
    "mass_g": (1e-3, "mass, g"),
}


@dataclass(frozen=True)
class Motor:
    """A motor in SI units: N m/A, ohm, kg m^2, N m, N m, V, rad/s, kg."""

    name: str
    torque_constant: float
    resistance: float
    rotor_inertia: float
    continuous_torque: float
    peak_torque: float
    voltage: float
    max_speed: float
    mass: float
    source: str = ""


@dataclass(frozen=True)
class Gearbox:
    """A gearbox in SI units: ratio, efficiency, kg m^2 (input side), N m, N m, rad/s, kg."""

    name: str
    ratio: float
    efficiency: float
    inertia: float
    continuous_torque: float
    peak_torque: float
    max_input_speed: float
    mass: float
    source: str = ""


@dataclass(frozen=True)
class Drive:
    """One motor with one gearbox (see the module)."""

    motor: Motor
    gearbox: Gearbox

    @property
    def name(self) -> str:
        return f"{self.motor.name} + {self.gearbox.name}"

    @property
    def mass(self) -> float:
        return self.motor.mass + self.gearbox.mass

    def at_motor(self, tau, dq, ddq) -> dict[str, np.ndarray]:
        """The motor's side at output torques ``tau`` N m, speeds ``dq`` rad/s and
        accelerations ``ddq`` rad/s^2 (arrays of one shape) of a plan made without the drive:
        the rotor turns at N ddq on top (see :meth:`motor_side`)."""
        ddq = np.asarray(ddq, dtype=float)
        return self.motor_side(tau, dq, self.gearbox.ratio * ddq)

    @property
    def inertia(self) -> float:
        """The rotor's and the gear input's inertia about the motor's axis, kg m^2."""
        return self.motor.rotor_inertia + self.gearbox.inertia

    def motor_torque(self, tau_out, rotor_acceleration, factor):
        """tau_m = J a_r + tau_out factor / N, N m: the rotor's inertia before the gear, the
        gear's losses on the torque it passes (``factor`` 1/eta when the motor drives, eta when
        the load drives it back). Arithmetic only: numpy arrays or CasADi expressions."""
        return self.inertia * rotor_acceleration + tau_out * factor / self.gearbox.ratio

    def electrical(self, tau_m, dq) -> dict:
        """At the motor's torque ``tau_m`` N m and the joint's speed ``dq`` rad/s: ``speed``
        rad/s (N dq), ``current`` A, ``voltage`` V (R i + k_t N dq), ``power`` W (u i: copper
        losses plus the mechanical power at the motor), ``copper`` W (R i^2). Arithmetic only:
        numpy arrays or CasADi expressions."""
        k, resistance, ratio = self.motor.torque_constant, self.motor.resistance, self.gearbox.ratio
        current = tau_m / k
        copper = resistance * current**2
        return {"speed": ratio * dq, "current": current,
                "voltage": resistance * tau_m / k + k * ratio * dq,
                "power": copper + tau_m * ratio * dq, "copper": copper}  # fmt: skip

    def motor_side(self, tau_out, dq, rotor_acceleration) -> dict[str, np.ndarray]:
        """The motor's side when the gear gives the links ``tau_out`` N m at the joint's
        speed ``dq`` rad/s while the rotor accelerates at ``rotor_acceleration`` rad/s^2 (in
        the joint's sense; arrays of one shape): ``torque`` tau_m N m and :meth:`electrical`'s
        ``speed``, ``current``, ``voltage``, ``power`` and ``copper``, the branch chosen by the
        power's direction (:meth:`motor_torque`: the motor drives when tau_out dq >= 0)."""
        tau, dq, acceleration = (
            np.asarray(v, dtype=float) for v in (tau_out, dq, rotor_acceleration)
        )
        eta = self.gearbox.efficiency
        factor = np.where(tau * dq >= 0.0, 1.0 / eta, eta)
        torque = self.motor_torque(tau, acceleration, factor)
        return {"torque": torque, **self.electrical(torque, dq)}


def _number(path: Path, row: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DefinitionError(
            f"{path}: row {row}, column {column!r}: expected a number, got {text!r}"
        ) from None
    if not math.isfinite(value):
        raise DefinitionError(f"{path}: row {row}, column {column!r}: {text!r} is not finite")
    return value


def _rows(path: str | Path, columns: dict) -> list[dict]:
    """The CSV's rows as {name, source, column: SI value}, every column checked."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            header = reader.fieldnames or []
            missing = [c for c in ("name", *columns) if c not in header]
            if missing:
                raise DefinitionError(
                    f"{path}: missing the columns {missing} (the layout: problems.drives.catalogue)"
                )
            rows = []
            for k, raw in enumerate(reader, start=2):  # row 1 is the header
                entry = {"name": (raw["name"] or "").strip(),
                         "source": (raw.get("source") or "").strip()}  # fmt: skip
                if not entry["name"]:
                    raise DefinitionError(f"{path}: row {k}: no name")
                for column, (factor, what) in columns.items():
                    value = _number(path, k, column, (raw[column] or "").strip())
                    if value < 0 or (value == 0 and column not in ("inertia_gcm2",)):
                        raise DefinitionError(
                            f"{path}: row {k} ({entry['name']}), column {column!r}: {what} "
                            f"must be > 0, got {value:g}"
                        )
                    entry[column] = value * factor
                rows.append(entry)
    except OSError as error:
        raise DefinitionError(f"{path}: cannot read it ({error.strerror})") from None
    if not rows:
        raise DefinitionError(f"{path}: no rows")
    return rows


def read_motors(path: str | Path) -> tuple[Motor, ...]:
    """The motors of ``path`` (the layout: the module's docstring)."""
    return tuple(
        Motor(
            r["name"],
            r["torque_constant_mNm_A"],
            r["resistance_ohm"],
            r["rotor_inertia_gcm2"],
            r["continuous_torque_mNm"],
            r["peak_torque_mNm"],
            r["voltage_V"],
            r["max_speed_rpm"],
            r["mass_g"],
            r["source"],
        )
        for r in _rows(path, MOTOR_COLUMNS)
    )


def read_gearboxes(path: str | Path) -> tuple[Gearbox, ...]:
    """The gearboxes of ``path`` (the layout: the module's docstring)."""
    gearboxes = []
    for r in _rows(path, GEARBOX_COLUMNS):
        if r["ratio"] < 1.0 or r["efficiency"] > 1.0:
            raise DefinitionError(
                f"{path}: {r['name']}: the ratio must be >= 1 and the efficiency in (0, 1], got "
                f"{r['ratio']:g} and {r['efficiency']:g}"
            )
        gearboxes.append(
            Gearbox(
                r["name"],
                r["ratio"],
                r["efficiency"],
                r["inertia_gcm2"],
                r["continuous_torque_Nm"],
                r["peak_torque_Nm"],
                r["max_input_speed_rpm"],
                r["mass_g"],
                r["source"],
            )
        )
    return tuple(gearboxes)


__all__ = [
    "GEARBOX_COLUMNS",
    "MOTOR_COLUMNS",
    "Drive",
    "Gearbox",
    "Motor",
    "read_gearboxes",
    "read_motors",
]
