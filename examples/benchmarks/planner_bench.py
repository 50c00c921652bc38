"""Planner benchmark: build and solve times of every transcription on a six-link periodic gait.

The problem: the six-link scene of shared/scene.md, period T = 1 s fixed, periodicity
x(0) = x(T), minimise the integral of sum_i M_i^2, every absolute angle within +-0.1 rad of the
"paper22" gait law (22) (``problems.GaitLaw.preset("paper22")``)

    psi_j(t) = pi/2 + zeta_j sin(varpi_j - (1 - cos(2 pi t / T)) pi/2),
    zeta = [0.20, 0.30, 0.40, 0.30, 0.10, 0.05], varpi = [0.00, 0.50, 1.00, 1.50, 0.20, 0.40],

initial guess: the law, its derivatives, and the torques of inverse dynamics along it.

Printed: per transcription and N, the NLP size, build time (transcription + IPOPT setup,
including the derivative functions), solve time, iterations, ms per iteration, time in NLP
function evaluations, cost; medians over ``--repeat`` runs. Then the headline case
(Hermite-Simpson, N = 50): implicit vs explicit dynamics, and the MX (default) vs SX-expanded
NLP, with ratios measured in the same run. Last, warm starts on that case: the cold solve vs
re-solving from its own Solution with the primal values only (``warm_start=False``) and with
IPOPT's multipliers too (the default on the same NLP layout), and the same two after a
continuation step (the band widened from 0.10 to 0.11 rad) next to that problem's cold solve.
Last, what the planner's walking pieces cost on the headline case: keypoints (every angle
within 0.05 rad of the law at t = T/8, 3T/8, 5T/8, 7T/8, between nodes), the ground reaction as
a two-output Function (Fy >= 0), a torque-rate penalty (1e-4 integral of sum dM_i^2), and all
three, with ratios to the plain problem measured in the same run.

    python examples/benchmarks/planner_bench.py            # N = 10, 20, 40, 80, 160
    python examples/benchmarks/planner_bench.py --quick    # smoke run (N = 10, 20; once)
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys

import casadi as ca
import numpy as np

from model import presets
from planner import OCP
from problems import GaitLaw

logger = logging.getLogger("planner_bench")

LAW = GaitLaw.preset("paper22")
PERIOD = LAW.period
BAND = 0.1  # rad: allowed distance of every angle from the law


def paper22_sx(t):
    """The law's angles as a CasADi expression of the symbolic time t, (6, 1)."""
    phase = ca.DM(LAW.varpi) - (1 - ca.cos(2 * np.pi * t / LAW.period)) * np.pi / 2
    return ca.DM(LAW.center) + ca.DM(LAW.zeta) * ca.sin(phase)


def paper22_gait(
    N: int = 50,
    transcription: str = "hermite-simpson",
    degree: int | None = None,
    formulation: str = "implicit",
    dynamics=None,
    band: float = BAND,
) -> OCP:
    """The six-link periodic gait OCP of this benchmark (angles within +-``band`` rad)."""
    dynamics = dynamics or presets.six_link_anthropoid().dynamics()
    return (
        OCP(
            dynamics,
            T=PERIOD,
            N=N,
            transcription=transcription,
            degree=degree,
            formulation=formulation,
        )
        .constrain("near_law", lambda p: p.psi - paper22_sx(p.t), lower=-band, upper=band)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(LAW)
    )


def walking_pieces(N: int, dynamics) -> dict[str, OCP]:
    """The headline gait with the planner's walking pieces added one by one, then together."""
    base = paper22_gait(N, "hermite-simpson", None, dynamics=dynamics)
    fractions = np.array([0.125, 0.375, 0.625, 0.875])
    posture = LAW.psi(fractions * PERIOD)

    def keypoints(ocp: OCP) -> OCP:
        return ocp.constrain_at(
            "posture",
            lambda p: p.psi,
            fraction=fractions,
            lower=posture - 0.05,
            upper=posture + 0.05,
        )

    def ground(ocp: OCP) -> OCP:
        return ocp.constrain("grf", dynamics.function("ground_reaction"), lower={"Fy": 0.0})

    def rates(ocp: OCP) -> OCP:
        return ocp.minimize(integral=lambda p: ca.sumsqr(p.M) + 1e-4 * ca.sumsqr(p.dM))

    return {
        "plain": base,
        "+ keypoints": keypoints(base),
        "+ ground Fy>=0": ground(base),
        "+ torque rates": rates(base),
        "+ all three": rates(ground(keypoints(base))),
    }


def measure(ocp: OCP, repeat: int, expand: bool | None = None, warm_start: bool = True) -> dict:
    """Median build/solve times (s), iterations, function time of ``repeat`` fresh solves."""
    runs = []
    for _ in range(repeat):
        solution = ocp.solve(
            progress=False, expand=expand, raise_on_failure=False, warm_start=warm_start
        )
        stats = solution.stats
        runs.append(
            (
                stats["build_seconds"],
                stats["solve_seconds"],
                stats["iterations"],
                stats["function_seconds"],
            )
        )
    build, solve, iterations, functions = (
        statistics.median(column) for column in zip(*runs, strict=True)
    )
    # Accuracy of the last solution (not timed): each interval re-integrated from its start
    # node under the interpolated torques at tight tolerance, compared with its end node.
    accuracy = solution.integration_error()
    angles = [i for i, name in enumerate(accuracy.state_names) if name.startswith("psi_")]
    return {
        "error": float(accuracy.per_state[angles].max()),
        "build": build,
        "solve": solve,
        "iterations": iterations,
        "functions": functions,
        "n_w": solution.stats["n_variables"],
        "cost": solution.cost,
        "status": solution.status,
        "warm_start": solution.stats["warm_start"],
    }


def row(label: str, N: int, m: dict) -> str:
    per_iteration = 1e3 * m["solve"] / max(m["iterations"], 1)
    status = "" if m["status"] == "Solve_Succeeded" else f"  {m['status']}"
    return (
        f"{label:<17} {N:>4} {m['n_w']:>6} {1e3 * m['build']:>9.1f} {1e3 * m['solve']:>9.1f} "
        f"{m['iterations']:>6.0f} {per_iteration:>8.2f} {1e3 * m['functions']:>9.1f} "
        f"{m['cost']:>12.2f} {m['error']:>9.1e}{status}"
    )


HEADER = (
    f"{'transcription':<17} {'N':>4} {'vars':>6} {'build ms':>9} {'solve ms':>9} "
    f"{'iters':>6} {'ms/iter':>8} {'f-eval ms':>9} {'cost':>12} {'err rad':>9}"
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: N = 10, 20, once")
    parser.add_argument("--repeat", type=int, default=3, help="runs per case (median)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stdout)
    Ns = (10, 20) if args.quick else (10, 20, 40, 80, 160)
    repeat = 1 if args.quick else max(1, args.repeat)
    dynamics = presets.six_link_anthropoid().dynamics()
    schemes = (
        ("trapezoid", None),
        ("hermite-simpson", None),
        ("radau", 3),
        ("legendre", 3),
    )
    out = [
        f"six-link periodic gait (paper22 law +-{BAND} rad, min int sum M^2), implicit dynamics, "
        f"exact Hessian, MX + mapped SX functions; medians of {repeat} run(s); err rad: largest "
        "per-interval re-integration error of the angles (Solution.integration_error)",
        HEADER,
    ]
    for name, degree in schemes:
        label = name + (f"({degree})" if degree else "")
        for N in Ns:
            ocp = paper22_gait(N, name, degree, dynamics=dynamics)
            out.append(row(label, N, measure(ocp, repeat)))
    logger.info("\n".join(out))

    N = 20 if args.quick else 50
    headline = [
        f"\nheadline: hermite-simpson N={N} (target here: build ~500 ms, solve ~750 ms)",
        f"{'case':<17}" + HEADER[17:],
    ]
    cases = {}
    for label, formulation, expand in (
        ("implicit MX", "implicit", False),
        ("explicit MX", "explicit", False),
        ("implicit SX", "implicit", True),
        ("explicit SX", "explicit", True),
    ):
        ocp = paper22_gait(N, "hermite-simpson", None, formulation, dynamics=dynamics)
        cases[label] = measure(ocp, 1 if args.quick else max(repeat, 5), expand)
        headline.append(row(label, N, cases[label]))

    def total(m):
        return m["build"] + m["solve"]

    implicit, explicit = cases["implicit MX"], cases["explicit MX"]
    headline.append(
        f"explicit / implicit (MX): build {explicit['build'] / implicit['build']:.2f}x, "
        f"solve {explicit['solve'] / implicit['solve']:.2f}x, "
        f"build+solve {total(explicit) / total(implicit):.2f}x"
    )
    implicit_sx, explicit_sx = cases["implicit SX"], cases["explicit SX"]
    headline.append(
        f"explicit / implicit (SX): build {explicit_sx['build'] / implicit_sx['build']:.2f}x, "
        f"solve {explicit_sx['solve'] / implicit_sx['solve']:.2f}x"
    )
    headline.append(
        f"SX / MX (implicit): build {implicit_sx['build'] / implicit['build']:.2f}x, "
        f"solve {implicit_sx['solve'] / implicit['solve']:.2f}x, "
        f"build+solve {total(implicit_sx) / total(implicit):.2f}x"
    )
    logger.info("\n".join(headline))

    # Warm starts: the same NLP layout, so the multipliers of the cold solution are reused.
    cold_ocp = paper22_gait(N, "hermite-simpson", None, dynamics=dynamics)
    cold_solution = cold_ocp.solve(progress=False)
    wider = paper22_gait(N, "hermite-simpson", None, dynamics=dynamics, band=0.11)
    repeat_warm = 1 if args.quick else max(repeat, 5)
    warm_cases = {"cold": implicit}
    for label, ocp, warm_start in (
        ("same, primal", cold_ocp, False),
        ("same, +mult", cold_ocp, True),
        ("band .11, cold", wider, None),
        ("band .11, primal", wider, False),
        ("band .11, +mult", wider, True),
    ):
        if warm_start is None:  # keeps the law as its guess
            warm_cases[label] = measure(ocp, repeat_warm)
        else:
            guessed = ocp.guess(cold_solution)
            warm_cases[label] = measure(guessed, repeat_warm, warm_start=warm_start)
    lines = [
        f"\nwarm start: hermite-simpson N={N}, guess = the cold solution; primal: values "
        "only (warm_start=False); +mult: with its multipliers (warm_start=True)",
        f"{'case':<17}" + HEADER[17:],
    ]
    for label, m in warm_cases.items():
        lines.append(row(label, N, m))
    same, cold = warm_cases["same, +mult"], warm_cases["cold"]
    primal = warm_cases["same, primal"]
    lines.append(
        f"same-mesh warm start with multipliers: {same['iterations']:.0f} iterations "
        f"(primal only {primal['iterations']:.0f}, cold {cold['iterations']:.0f}); "
        f"solve cold / warm {cold['solve'] / same['solve']:.1f}x, "
        f"primal / warm {primal['solve'] / same['solve']:.1f}x"
    )
    wide, wide_primal = warm_cases["band .11, +mult"], warm_cases["band .11, primal"]
    wide_cold = warm_cases["band .11, cold"]
    lines.append(
        f"continuation (band 0.11): {wide['iterations']:.0f} iterations with multipliers "
        f"(primal only {wide_primal['iterations']:.0f}, cold {wide_cold['iterations']:.0f}); "
        f"solve cold / warm {wide_cold['solve'] / wide['solve']:.1f}x, "
        f"primal / warm {wide_primal['solve'] / wide['solve']:.1f}x"
    )
    if not (same["warm_start"] and wide["warm_start"]):
        lines.append("warning: the multipliers were not reused (stats['warm_start'] False)")
    logger.info("\n".join(lines))

    pieces = {
        label: measure(ocp, repeat_warm) for label, ocp in walking_pieces(N, dynamics).items()
    }
    plain = pieces["plain"]
    lines = [
        f"\nwalking pieces: hermite-simpson N={N}, implicit; ratios to the plain problem "
        "(the torque-rate penalty changes the optimum, so its iterations are another problem's)",
        f"{'case':<17}" + HEADER[17:] + "  build x  solve x",
    ]
    for label, m in pieces.items():
        lines.append(
            row(label, N, m)
            + f"  {m['build'] / plain['build']:>7.2f} {m['solve'] / plain['solve']:>8.2f}"
        )
    logger.info("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
