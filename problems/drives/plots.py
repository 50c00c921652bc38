"""The torque-speed plane of each drive: the operating points of every plan of a duty cycle,
its RMS point and its peaks (:func:`requirements_figure`)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from problems.drives.catalogue import Drive
from problems.drives.requirements import DriveRequirements


def drive_envelope(drive: Drive, points: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """(output speed (M,) rad/s >= 0, the largest output torque there (M,) N m) of ``drive``
    driving: the gearbox's peak, the motor's peak through the gearbox, and the supply's line
    N eta k_t (V - k_t N w) / R, up to the lower of the motor's and gearbox's speeds."""
    motor, gearbox = drive.motor, drive.gearbox
    top = min(motor.max_speed, gearbox.max_input_speed) / gearbox.ratio
    speed = np.linspace(0.0, top, points)
    scale = gearbox.ratio * gearbox.efficiency
    line = (
        scale
        * motor.torque_constant
        * (motor.voltage - motor.torque_constant * gearbox.ratio * speed)
        / motor.resistance
    )
    torque = np.minimum(np.minimum(gearbox.peak_torque, scale * motor.peak_torque), line)
    return speed, np.maximum(torque, 0.0)


def requirements_figure(
    requirements: DriveRequirements, *, columns: int = 4, chosen: dict[str, Drive] | None = None
) -> Figure:
    """One panel per drive: torque (N m) over speed (rad/s) at every sample of every plan (a
    line per step in the order walked, coloured by plan, broken at the heel strikes), the
    quadrants where the drive brakes (tau dq < 0) shaded, the peaks as a dashed box and the
    RMS point (RMS speed, RMS torque: the thermal operating point a continuous rating must
    cover) as a star; with ``chosen`` {drive: Drive}, that drive's limits over it (red: the
    peak envelope where it drives, :func:`drive_envelope`; dotted: its continuous output
    torque; the output torque only: the drive's own inertia needs more at the motor)."""
    drives = requirements.names
    rows = math.ceil(len(drives) / columns)
    figure = Figure(figsize=(3.4 * columns, 3.0 * rows + 0.6), layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    colours = [f"C{k % 10}" for k in range(len(requirements.plans))]
    for ax, drive in zip(axes, drives, strict=False):
        need = requirements[drive]
        speed = 1.1 * max(need.peak_speed, 1e-9)
        torque = 1.1 * max(need.peak_torque, 1e-9)
        envelope = drive_envelope(chosen[drive]) if chosen and drive in chosen else None
        if envelope is not None:
            speed = max(speed, 1.05 * envelope[0][-1])
            torque = max(torque, 1.05 * float(envelope[1].max()))
        # braking: the second and fourth quadrants
        ax.fill_between([-speed, 0.0], 0.0, torque, color="0.92", lw=0)
        ax.fill_between([0.0, speed], -torque, 0.0, color="0.92", lw=0)
        for plan, colour in zip(requirements.plans, colours, strict=True):
            for k, step in enumerate(plan.steps):  # no line across a heel strike
                ax.plot(step.speeds[drive], step.torques[drive], color=colour, lw=0.8,
                        label=plan.name if k == 0 else None)  # fmt: skip
        box_x = [-need.peak_speed, need.peak_speed, need.peak_speed, -need.peak_speed,
                 -need.peak_speed]  # fmt: skip
        box_y = [-need.peak_torque, -need.peak_torque, need.peak_torque, need.peak_torque,
                 -need.peak_torque]  # fmt: skip
        ax.plot(box_x, box_y, "k--", lw=0.6)
        ax.plot([need.rms_speed], [need.rms_torque], "k*", ms=9, label="RMS")
        if envelope is not None:
            w, top = envelope
            ax.plot(np.r_[w, w[-1]], np.r_[top, 0.0], "r-", lw=1.0, label="drive peak")
            ax.plot(-np.r_[w, w[-1]], -np.r_[top, 0.0], "r-", lw=1.0)
            g, m = chosen[drive].gearbox, chosen[drive].motor
            rated = min(g.continuous_torque, g.ratio * g.efficiency * m.continuous_torque)
            ax.axhline(rated, color="r", ls=":", lw=0.8)
            ax.axhline(-rated, color="r", ls=":", lw=0.8)
        ax.set_xlim(-speed, speed)
        ax.set_ylim(-torque, torque)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.axvline(0.0, color="0.6", lw=0.5)
        ax.set_title(f"{drive.replace('_', ' ')}: peak {need.peak_torque:.0f} N m, "
                     f"RMS {need.rms_torque:.0f}", fontsize=9)  # fmt: skip
        ax.set_xlabel("speed dq, rad/s", fontsize=8)
        ax.set_ylabel("torque tau, N m", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes[len(drives) :]:
        ax.set_visible(False)
    axes[0].legend(fontsize=7, loc="upper left")
    names = ", ".join(f"{p.name} {100 * p.share:.0f} %" for p in requirements.plans)
    figure.suptitle(f"Each drive's torque over its speed (shaded: braking; dashed: peaks; "
                    f"star: RMS); duty cycle {names}", fontsize=10)  # fmt: skip
    return figure


__all__ = ["requirements_figure"]
