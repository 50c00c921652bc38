"""Do the torques in the file make the motion in the file? Against the rate and the mesh.

    python examples/benchmarks/file_consistency.py            # N = 12, 30, 60, 120
    python examples/benchmarks/file_consistency.py --quick    # N = 12, 30

A drive controller reads a torque file sample by sample: feedforward torques and the motion
they should make. The walking step (six-link, 0.5 m in 0.5 s, Hermite-Simpson, its limits held
at 1 kHz) is exported two ways at several rates:

* ``transcription``: the transcription's own polynomials (cubic states, quadratic torques and
  accelerations), what the files held before: consistent at the collocation points only;
* ``consistent`` (the default now): positions integrated from the velocity polynomial,
  accelerations its slope, torques the inverse dynamics of that motion.

Printed per N and rate: the largest |M - inverse dynamics of the file's own motion| (N m and
% of the peak torque), the largest |dpsi - d psi/dt| between the file's own channels (rad/s;
d psi/dt by central differences of the file's psi samples, whose own truncation error,
h^2 |d3 psi / dt3| / 6, is what remains for the consistent file and shrinks with the rate),
and how far the consistent file's torques lie from the
transcription's torque polynomial (N m): the collocation error the file now shows in its
motion rather than hides in a mismatch. The inverse dynamics is the verification's own
(``problems.verify_gait``: numpy, moments about each hinge, written apart from the model);
tests/test_motion.py checks the same against the Newton-Euler oracle.
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from model import LinkageTrajectory
from planner import AccuracyWarning
from problems import verify_gait, walking_step

RATES = (250.0, 1000.0, 4000.0)


def measure(gait, rate_hz: float) -> dict[str, float]:
    """The two exports of ``gait`` at ``rate_hz`` against their own inverse dynamics."""
    solution = gait.solution
    linkage = gait.problem.linkage
    n = linkage.n
    times = solution.sample_times(rate_hz)
    out: dict[str, float] = {}
    for motion in ("transcription", "consistent"):
        trajectory = solution.to_trajectory(rate_hz, motion=motion)
        with_settings = LinkageTrajectory.from_linkage(
            trajectory.time,
            trajectory.psi,
            trajectory.dpsi,
            trajectory.torques,
            linkage.names,
            ddpsi=trajectory.ddpsi,
            metadata={"gait": gait.problem.settings(times)},
        )
        # the verification's own numpy inverse dynamics (moments about each hinge)
        gap = verify_gait(with_settings, linkage).facts["dynamics residual"]
        peak = np.abs(np.asarray(trajectory.torques)).max()
        # the file's own psi differentiated (central differences of its samples, exact to
        # h^2 |d3 psi / dt3| / 6) against its dpsi column
        psi, dpsi, t = np.asarray(trajectory.psi), np.asarray(trajectory.dpsi), trajectory.time
        slope = (psi[2:] - psi[:-2]) / (t[2:] - t[:-2])[:, None]
        out[f"{motion} torque gap"] = float(gap)
        out[f"{motion} torque gap %"] = float(100.0 * gap / peak)
        out[f"{motion} rate gap"] = float(np.abs(slope - dpsi[1:-1]).max())
    consistent = solution.to_trajectory(rate_hz).torques
    out["file vs polynomial"] = float(np.abs(consistent - solution.control(times)[:, :n]).max())
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 12 and 30 only")
    args = parser.parse_args(argv)
    meshes = (12, 30) if args.quick else (12, 30, 60, 120)
    print("Six-link walking step, 0.5 m in 0.5 s, Hermite-Simpson; per mesh N and export rate:")
    print("  transcription file: |M - ID(its motion)| (N m, % of peak), |dpsi - dpsi/dt| rad/s")
    print("  consistent file:    the same two; and |M_file - the NLP's torque polynomial| N m")
    head = (
        f"{'N':>4} {'rate Hz':>8} {'trans. M gap':>13} {'%':>6} {'rate gap':>9}   "
        f"{'consist. M gap':>14} {'%':>8} {'rate gap':>9}   {'file - poly':>11}"
    )
    print(head)
    print("-" * len(head))
    for N in meshes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            gait = walking_step(N=N).solve(progress=False)
        for rate in RATES:
            m = measure(gait, rate)
            print(
                f"{gait.solution.N:>4} {rate:>8.0f} {m['transcription torque gap']:>13.3e} "
                f"{m['transcription torque gap %']:>6.2f} {m['transcription rate gap']:>9.2e}   "
                f"{m['consistent torque gap']:>14.2e} {m['consistent torque gap %']:>8.1e} "
                f"{m['consistent rate gap']:>9.1e}   {m['file vs polynomial']:>11.3e}"
            )
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
