"""Planner benchmark: build and solve times of every transcription on a six-link periodic gait.

The problem: the six-link scene of shared/scene.md, period T = 1 s fixed, periodicity
x(0) = x(T), minimise the integral of sum_i M_i^2, every absolute angle within +-0.1 rad of the
"paper22" gait law (22) (``problems.GaitLaw.preset("paper22")``)

    psi_j(t) = pi/2 + zeta_j sin(varpi_j - (1 - cos(2 pi t / T)) pi/2),
    zeta = [0.20, 0.30, 0.40, 0.30, 0.10, 0.05], varpi = [0.00, 0.50, 1.00, 1.50, 0.20, 0.40],

initial guess: the law, its derivatives, and the torques of inverse dynamics along it.

Printed, all measured in this one run (medians over ``--repeat`` runs; the machine is shared,
so compare the ratios of a run, not runs):

1. per transcription and N: NLP size, build time (transcription + IPOPT setup with its
   derivative functions, a fresh solver each time), solve time, iterations, ms per iteration,
   time in NLP function evaluations, cost, re-integration error; and the exponent a of
   solve time ~ N^a (and of ms per iteration) fitted over N = 20..160;
2. before/after: today's defaults against the previous ones (IPOPT's monotone barrier update
   and MUMPS's automatic ordering, objective unscaled, a solver built per solve), on the
   same OCPs, with the solve-time ratio and the cost difference, and the exponent of each;
3. the headline case (Hermite-Simpson, N = 50): implicit vs explicit dynamics, MX vs
   SX-expanded NLP;
4. the solver cache: a re-solve's build with a cached solver, and when the SX expansion pays
   (its extra build divided by what it saves per solve);
5. warm starts on the headline case: cold, re-solves from its own Solution with primal values
   only and with the multipliers, and a continuation step (band 0.10 -> 0.11 rad).
6. what the planner's walking pieces cost on the headline case: keypoints (every angle
   within 0.05 rad of the law at t = T/8, 3T/8, 5T/8, 7T/8, between nodes), the ground
   reaction as a two-output Function (Fy >= 0), a torque-rate penalty (1e-4 integral of sum
   dM_i^2), and all three, with ratios to the plain problem measured in the same run.

    python examples/benchmarks/planner_bench.py            # N = 10, 20, 40, 80, 160
    python examples/benchmarks/planner_bench.py --quick    # smoke run (N = 10, 20, 40; once)
"""

from __future__ import annotations

import argparse
import json
import logging
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from model import Dynamics, presets
from planner import OCP, Phases
from planner.solver_cache import SOLVERS
from problems import GaitLaw

logger = logging.getLogger("planner_bench")

LAW = GaitLaw.preset("paper22")
PERIOD = LAW.period
BAND = 0.1  # rad: allowed distance of every angle from the law


def paper22_gait(
    N: int = 50,
    transcription: str = "hermite-simpson",
    degree: int | None = None,
    formulation: str = "implicit",
    dynamics=None,
    band: float = BAND,
) -> OCP:
    """The six-link periodic gait OCP of this benchmark (angles within +-``band`` rad)."""
    dynamics = dynamics or Dynamics(presets.six_link_anthropoid())
    return (
        OCP(
            dynamics,
            T=PERIOD,
            N=N,
            transcription=transcription,
            degree=degree,
            formulation=formulation,
        )
        .constrain("near_law", lambda p: p.psi - LAW.psi(p.t), lower=-band, upper=band)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(LAW)
    )


def split_gait(N: int, dynamics, controls: str = "continuous") -> Phases:
    """The headline gait cut at T/2 into two phases joined by continuity, periodic over both:
    the same problem written with planner.Phases (each phase's time restarts at 0, so the
    second phase reads the law at t + T/2). ``controls``: "continuous" (the cut is an
    interior node: the NLP of the one-phase problem) or "jump" (the torques may jump at T/2:
    a point more)."""
    half = PERIOD / 2

    def phase(offset: float) -> OCP:
        return (
            OCP(dynamics, T=half, N=N // 2)
            .constrain(
                "near_law",
                lambda p: p.psi - LAW.psi(p.t + offset),
                lower=-BAND,
                upper=BAND,
            )
            .minimize(integral=lambda p: ca.sumsqr(p.M))
            .guess(lambda t: LAW(t + offset))
        )

    return (
        Phases.sequence(("first", phase(0.0)))
        .then("second", phase(half), controls=controls)
        .periodic()
    )


def baseline_headline(revision: str, N: int, repeat: int) -> dict | None:
    """The headline (Hermite-Simpson gait of this benchmark) built and solved by the code of
    git ``revision`` of this repository, in a subprocess, medians of ``repeat``; None when
    git or the revision is not available. The "before" of a change, measured in this run."""
    root = Path(__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory() as folder:
        tree = Path(folder) / "tree"
        added = subprocess.run(
            ["git", "-C", str(root), "worktree", "add", "--detach", str(tree), revision],
            capture_output=True,
            text=True,
        )
        if added.returncode != 0:
            return None
        try:
            script = (
                "import json, statistics, sys\n"
                f"sys.path[:0] = [{str(tree)!r}, {str(tree / 'examples' / 'benchmarks')!r}]\n"
                "import planner_bench as b\n"
                "runs = []\n"
                f"for _ in range({repeat}):\n"
                f"    s = b.paper22_gait({N}).solve(progress=False)\n"
                "    runs.append((s.stats['build_seconds'], s.stats['solve_seconds'],"
                " s.stats['iterations'], s.cost))\n"
                "print(json.dumps([statistics.median(c) for c in zip(*runs)]))\n"
            )
            done = subprocess.run(
                [sys.executable, "-c", script], capture_output=True, text=True, cwd=folder
            )
            if done.returncode != 0:
                return None
            build, solve, iterations, cost = json.loads(done.stdout.strip().splitlines()[-1])
            return {"build": build, "solve": solve, "iterations": iterations, "cost": cost}
        finally:
            subprocess.run(
                ["git", "-C", str(root), "worktree", "remove", "--force", str(tree)],
                capture_output=True,
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


#: The previous defaults, for the before/after table: IPOPT's monotone barrier update and
#: MUMPS's automatic ordering (METIS from N ~ 100 on here); the objective is left unscaled by
#: ``unscaled`` below, and every solve builds its solver (``cache=False``).
BEFORE_IPOPT = {"mu_strategy": "monotone", "mumps_pivot_order": 7}


def unscaled(ocp: OCP) -> OCP:
    """The OCP with the objective scale 1, as before objective scaling."""
    return ocp.scale(objective=1.0)


def measure(
    ocp: OCP,
    repeat: int,
    expand: bool | None = None,
    warm_start: bool = True,
    options: dict | None = None,
    cache: bool = False,
) -> dict:
    """Median build/solve times (s), iterations, function time of ``repeat`` solves (each
    with a freshly built solver unless ``cache``)."""
    runs = []
    for _ in range(repeat):
        solution = ocp.solve(
            progress=False,
            expand=expand,
            raise_on_failure=False,
            warm_start=warm_start,
            options=options,
            cache=cache,
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
        "cached": solution.stats["solver_cached"],
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


def exponent(Ns, values) -> float:
    """a of values ~ N^a, least squares in log-log over N >= 20 (below, fixed costs rule)."""
    points = [(N, v) for N, v in zip(Ns, values, strict=True) if N >= 20 and v > 0]
    if len(points) < 2:
        return float("nan")
    x, y = zip(*points, strict=True)
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def exponent_line(label: str, Ns, results) -> str:
    solve = exponent(Ns, [m["solve"] for m in results])
    per_iteration = exponent(Ns, [m["solve"] / max(m["iterations"], 1) for m in results])
    return f"  {label:<26} solve time ~ N^{solve:.2f}, time per iteration ~ N^{per_iteration:.2f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: N = 10, 20, 40, once")
    parser.add_argument("--repeat", type=int, default=3, help="runs per case (median)")
    parser.add_argument(
        "--baseline",
        metavar="REV",
        help="also build and solve the headline with the code of git revision REV (a "
        "subprocess on a temporary worktree): the before of a change, in this run",
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stdout)
    # --quick fits its exponents over N = 20, 40 only: two points, rough, but every line and
    # table of the full run is printed.
    Ns = (10, 20, 40) if args.quick else (10, 20, 40, 80, 160)
    fitted = f"N = 20..{Ns[-1]}"
    repeat = 1 if args.quick else max(1, args.repeat)
    dynamics = Dynamics(presets.six_link_anthropoid())
    schemes = (
        ("trapezoid", None),
        ("hermite-simpson", None),
        ("radau", 3),
        ("legendre", 3),
    )
    out = [
        f"six-link periodic gait (paper22 law +-{BAND} rad, min int sum M^2), implicit dynamics, "
        f"exact Hessian, MX + mapped SX functions, default options; medians of {repeat} "
        "run(s), a fresh solver per run; err rad: largest per-interval re-integration error "
        "of the angles (Solution.integration_error)",
        HEADER,
    ]
    exponents = []
    by_scheme = {}
    for name, degree in schemes:
        label = name + (f"({degree})" if degree else "")
        results = []
        for N in Ns:
            ocp = paper22_gait(N, name, degree, dynamics=dynamics)
            results.append(measure(ocp, repeat))
            out.append(row(label, N, results[-1]))
        by_scheme[label] = results
        exponents.append(exponent_line(label, Ns, results))
    out.append(
        f"fitted over {fitted} (log-log least squares"
        + ("; --quick: two points, rough):" if args.quick else "):")
    )
    out.extend(exponents)
    logger.info("\n".join(out))

    # ---- before/after: the previous defaults on the same OCPs, in this run -------------
    N = 20 if args.quick else 50
    cases = [("hermite-simpson", None, N)]
    if not args.quick:
        cases += [
            ("hermite-simpson", None, 160),
            ("radau", 3, 80),
            ("legendre", 3, 80),
            ("trapezoid", None, 40),
        ]
    lines = [
        "\nbefore/after: before = mu_strategy monotone, MUMPS automatic ordering, objective "
        "unscaled; after = the defaults (mu_strategy adaptive, mumps_pivot_order 2 = AMF, "
        "objective scaled); both a fresh solver per solve",
        f"{'case':<22} {'iters':>13} {'solve ms':>17} {'after/before':>12} {'cost':>14} "
        f"{'|d cost|':>9}",
    ]
    for name, degree, n in cases:
        label = f"{name}{f'({degree})' if degree else ''} N={n}"
        ocp = paper22_gait(n, name, degree, dynamics=dynamics)
        before = measure(unscaled(ocp), repeat, options=BEFORE_IPOPT)
        after = by_scheme.get(label.split(" N=")[0], [])
        after = next((m for m, k in zip(after, Ns, strict=True) if k == n), None)
        after = after or measure(ocp, repeat)
        lines.append(
            f"{label:<22} {before['iterations']:>5.0f} -> {after['iterations']:>4.0f} "
            f"{1e3 * before['solve']:>7.0f} -> {1e3 * after['solve']:>6.0f} "
            f"{after['solve'] / before['solve']:>11.2f}x {after['cost']:>14.6f} "
            f"{abs(after['cost'] - before['cost']):>9.1e}"
            + ("" if after["status"] == before["status"] == "Solve_Succeeded" else "  FAILED")
        )
    if not args.quick:
        # Robustness: variants of the gait (narrower and wider bands, coarse meshes), each
        # solved once with the previous and with today's defaults.
        bands = (0.08, 0.09, 0.1, 0.11, 0.12, 0.15, 0.2, 0.25)
        variants = [(band, n) for band in bands for n in (10, 15, 20, 30, 40)]
        counts = {"before": [0, []], "after": [0, []]}
        failed = []
        for band, n in variants:
            ocp = paper22_gait(n, band=band, dynamics=dynamics)
            for key, problem, options in (
                ("before", unscaled(ocp), BEFORE_IPOPT),
                ("after", ocp, None),
            ):
                solution = problem.solve(
                    progress=False, options=options, raise_on_failure=False, cache=False
                )
                counts[key][0] += solution.success
                counts[key][1].append(solution.iterations)
                if not solution.success:
                    failed.append(f"{key} band {band} N={n}: {solution.status}")
        ratios = [a / b for a, b in zip(counts["after"][1], counts["before"][1], strict=True)]
        lines.append(
            f"robustness, {len(variants)} variants (band 0.08..0.25 rad x N = 10..40): "
            f"converged before {counts['before'][0]}, after {counts['after'][0]}; "
            f"iterations after/before: median {statistics.median(ratios):.2f}, "
            f"range {min(ratios):.2f}..{max(ratios):.2f}"
        )
        lines.extend(f"  not converged: {item}" for item in failed)
    # The exponents before and after, on the meshes of the fit only (N >= 20).
    fit = [n for n in Ns if n >= 20]
    before_hs = [
        measure(unscaled(paper22_gait(n, dynamics=dynamics)), repeat, options=BEFORE_IPOPT)
        for n in fit
    ]
    after_hs = [m for m, n in zip(by_scheme["hermite-simpson"], Ns, strict=True) if n >= 20]
    lines.append(f"hermite-simpson, fitted over {fitted}:")
    lines.append(exponent_line("before", fit, before_hs))
    lines.append(exponent_line("after", fit, after_hs))
    logger.info("\n".join(lines))

    # ---- headline: formulations and SX expansion -------------------------------------
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

    # ---- the solver cache, and when the SX expansion pays ------------------------------
    SOLVERS.clear()
    sizes = [("hermite-simpson", None, n) for n in ((20,) if args.quick else (20, 50, 160))]
    if not args.quick:
        sizes.append(("radau", 3, 80))
    lines = [
        "\nsolver cache: build = transcription + solver (fresh), or transcription + structure "
        "key + lookup (cached); solves with a cached solver, same guess; SX pays after "
        "(SX build - MX build) / (MX solve - SX solve) solves of one structure",
        f"{'case':<22} {'MX build':>9} {'cached':>7} {'SX build':>9} {'cached':>7} "
        f"{'MX solve':>9} {'SX solve':>9} {'SX/MX':>6} {'SX pays after':>14}",
    ]
    for name, degree, n in sizes:
        label = f"{name}{f'({degree})' if degree else ''} N={n}"
        ocp = paper22_gait(n, name, degree, dynamics=dynamics)
        runs = 1 if args.quick else max(repeat, 5)
        mx_fresh = measure(ocp, 1, cache=True)  # builds and keeps the solver
        mx = measure(ocp, runs, cache=True)
        sx_fresh = measure(ocp, 1, expand=True, cache=True)
        sx = measure(ocp, runs, expand=True, cache=True)
        assert mx["cached"] and sx["cached"] and not mx_fresh["cached"]
        gain = mx["solve"] - sx["solve"]
        extra = sx_fresh["build"] - mx_fresh["build"]
        pays = f"{extra / gain:.1f} solves" if gain > 0 else "never"
        lines.append(
            f"{label:<22} {1e3 * mx_fresh['build']:>7.0f}ms {1e3 * mx['build']:>5.0f}ms "
            f"{1e3 * sx_fresh['build']:>7.0f}ms {1e3 * sx['build']:>5.0f}ms "
            f"{1e3 * mx['solve']:>7.0f}ms {1e3 * sx['solve']:>7.0f}ms "
            f"{sx['solve'] / mx['solve']:>6.2f} {pays:>14}"
        )
    logger.info("\n".join(lines))

    # ---- warm starts: the same NLP layout, so the multipliers of the cold solution are reused
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
            warm_cases[label] = measure(ocp, repeat_warm, cache=True)
        else:
            guessed = ocp.guess(cold_solution)
            warm_cases[label] = measure(guessed, repeat_warm, warm_start=warm_start, cache=True)
    lines = [
        f"\nwarm start: hermite-simpson N={N}, guess = the cold solution; primal: values "
        "only (warm_start=False); +mult: with its multipliers (warm_start=True); cached "
        "solvers except 'cold'",
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

    # ---- phases: the headline cut in two (continuity at T/2, periodic over both) --------
    one = measure(paper22_gait(N, dynamics=dynamics), repeat_warm)
    two = measure(split_gait(N, dynamics), repeat_warm)
    jump = measure(split_gait(N, dynamics, controls="jump"), repeat_warm)
    lines = [
        f"\nphases: the headline (hermite-simpson N={N}) as one phase and cut at T/2 into two "
        "(planner.Phases: each half N/2 intervals, continuity, periodic)",
        f"{'case':<17}" + HEADER[17:] + "  build x  solve x",
        row("one phase", N, one),
        row("two, continuous", N, two)
        + f"  {two['build'] / one['build']:>7.2f} {two['solve'] / one['solve']:>8.2f}",
        row("two, jump", N, jump)
        + f"  {jump['build'] / one['build']:>7.2f} {jump['solve'] / one['solve']:>8.2f}",
        f"costs: one phase {one['cost']:.6f}, two with continuous controls {two['cost']:.6f} "
        f"(relative difference {abs(two['cost'] / one['cost'] - 1):.1e}; "
        f"{two['n_w'] - one['n_w']} variables more: the same NLP), two with a torque jump "
        f"allowed at T/2 {jump['cost']:.6f} ({jump['n_w'] - one['n_w']} variables more: the "
        "dynamics point at the cut twice)",
    ]
    if args.baseline:
        before = baseline_headline(args.baseline, N, repeat_warm)
        if before is None:
            lines.append(f"baseline {args.baseline}: not available (git or the revision)")
        else:
            lines.append(
                f"headline before (git {args.baseline}) / now: build "
                f"{1e3 * before['build']:.1f} / {1e3 * one['build']:.1f} ms "
                f"({one['build'] / before['build']:.2f}x), solve {1e3 * before['solve']:.1f} / "
                f"{1e3 * one['solve']:.1f} ms ({one['solve'] / before['solve']:.2f}x), "
                f"iterations {before['iterations']:.0f} / {one['iterations']:.0f}, cost "
                f"{before['cost']:.6f} / {one['cost']:.6f}"
            )
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
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
