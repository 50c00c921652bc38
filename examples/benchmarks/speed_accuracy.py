"""Speed against accuracy: every transcription on the two walking problems, measured against
a fine reference of the same local optimum.

    python examples/benchmarks/speed_accuracy.py           # the grid, refinement, presets
    python examples/benchmarks/speed_accuracy.py --quick   # smoke run (CI): seconds
    python examples/benchmarks/speed_accuracy.py --replot results.json   # summaries, figure

Problems: the six-link walking step (``problems.walking_step``, 0.5 m in 0.5 s) and the
fixed-base periodic gait (``problems.pinned.gait``, the "walking" law, period 1 s).
Grid: trapezoid, Hermite-Simpson, Radau degree 3 and 5, Legendre degree 3; N = 10 .. 320
(doubling); implicit and explicit dynamics; IPOPT tol 1e-4 and 1e-8. A run whose NLP has more
than ``--max-variables`` variables is skipped (listed at the end).

Per run (a solver built each time, ``cache=False``; medians of ``--repeat`` solves when one
takes under 1 s, else one): NLP variables, build and solve time, IPOPT iterations, cost;
against the reference of its local optimum: the cost's relative error, the torque profile's
error (max and RMS over every hinge, N m) on a common 1 kHz grid through each solution's own
interpolant, and the largest per-interval re-integration error per nominal state scale (the
units of ``OCP.solve(accuracy=...)``: 1 rad for angles, 3 rad/s for rates).

References, one per local optimum (basin): every run is re-solved on a probe mesh
(Hermite-Simpson N = 40, tol 1e-9) warm-started from it; a probe whose cost lies within
``BASIN_COST`` (relative) of a known basin's probe and whose torques within ``BASIN_TORQUE`` of
its peak torque lands in that basin; otherwise the reference is solved from the probe (Radau
degree 5 on N = 640 intervals at tol 1e-10): if it matches a known reference (``REFERENCE_COST``)
the probe joins that basin, else it opens a new one. A new basin's resolution is the largest
torque difference to a second solve from the probe on half the mesh (N = 320): it bounds the
reference's own error, the discretisation's and that of the nearby discrete optima that state
constraints enforced at points make. Torque errors within twice it are marked ``~``.

Then: which transcription is fastest for each band of torque error; mesh refinement to a
target (``OCP.solve(accuracy=...)``) against the uniform meshes of the grid (time to the same
torque error); the accuracy presets of ``problems.ACCURACY_PRESETS`` on both problems and on
two walking steps they were not chosen on (six-link, 0.4 m; five-link, 0.5 m), each against
its stated torque error. The Pareto plot (solve time against torque max error, log-log, one
curve per transcription, implicit, both tolerances) goes to ``--plot``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import statistics
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from model import presets
from problems import ACCURACY_PRESETS, periodic_gait, walking_step

SCHEMES = (
    ("trapezoid", None),
    ("hermite-simpson", None),
    ("radau", 3),
    ("radau", 5),
    ("legendre", 3),
)
NS = (10, 20, 40, 80, 160, 320)
FORMULATIONS = ("implicit", "explicit")
TOLERANCES = (1e-4, 1e-8)
#: (transcription, degree, N, tol) of the probe, the reference and its half-mesh check.
PROBE = ("hermite-simpson", None, 40, 1e-9)
REFERENCE = ("radau", 5, 640, 1e-10)
HALF = ("radau", 5, 320, 1e-10)
#: A probe lands in a known basin within these: cost (relative), torques (fraction of peak);
#: a reference matches a known one within REFERENCE_COST and BASIN_TORQUE. State constraints
#: enforced at points make nearby discrete optima on one mesh (six-link step, Radau(5) N = 160:
#: two optima 5e-7 apart in cost, 0.045 N m in torque), hence not 1e-7.
BASIN_COST = 1e-5
REFERENCE_COST = 1e-6
BASIN_TORQUE = 0.01
#: Repeat a solve (for a median) only when one takes less than this, s.
REPEAT_BELOW = 1.0
RATE_HZ = 1000.0
PROBLEMS = ("walking step", "fixed-base gait")
#: Problems the presets were not chosen on: a six-link step of 0.4 m, a five-link step.
UNTUNED = ("0.4 m step", "five-link step")
#: Refinement runs: (transcription, degree, first mesh in intervals per second, targets). A
#: first mesh of 10 intervals per second leaves the torques unresolved where the dynamics'
#: error is small, which the estimate does not see (README); 40 per second resolves them.
REFINEMENTS = (
    ("hermite-simpson", None, 10, (1e-3, 1e-5)),
    ("hermite-simpson", None, 40, (1e-4, 1e-6)),
    ("radau", 3, 40, (1e-5, 1e-7)),
)

QUICK = {
    "schemes": (("trapezoid", None), ("hermite-simpson", None)),
    "Ns": (10, 20),
    "formulations": ("implicit",),
    "tolerances": (1e-8,),
    "probe": ("hermite-simpson", None, 20, 1e-8),
    "reference": ("radau", 3, 40, 1e-9),
    "half": ("radau", 3, 20, 1e-9),
    "refinements": (("hermite-simpson", None, 20, (1e-2,)),),
    "presets": ("draft",),
    "preset_problems": PROBLEMS,
}


def define(problem: str, formulation: str = "implicit", **mesh):
    """The walking step or the fixed-base gait (six-link, the defaults), or one of the
    problems the presets were not chosen on (:data:`UNTUNED`)."""
    if problem == "walking step":
        return walking_step(formulation=formulation, **mesh)
    if problem == "0.4 m step":
        return walking_step(step_length=0.4, formulation=formulation, **mesh)
    if problem == "five-link step":
        return walking_step(presets.five_link_biped(), formulation=formulation, **mesh)
    return periodic_gait(formulation=formulation, **mesh)


def label(name: str, degree: int | None) -> str:
    return name if degree is None else f"{name}({degree})"


def torque_grid(solution) -> np.ndarray:
    """(K, n) drive torques on the common 1 kHz grid over [0, T], N m."""
    times = solution.sample_times(RATE_HZ)
    drives = solution.system.role_names("drives")
    columns = [solution.control_names.index(name) for name in drives]
    return solution.control(times)[:, columns]


def scaled_error(solution) -> float:
    """Largest per-interval re-integration error per nominal state scale."""
    ocp = solution.ocp
    scales = np.array([ocp.variable_scale(name) for name in solution.state_names])
    return float(np.max(solution.integration_error().per_interval / scales))


@dataclass
class Basin:
    """A local optimum: the probes that land in it (cost, torques), its reference (cost,
    torques, resolution)."""

    problem: str
    probes: list[tuple[float, np.ndarray]] = field(repr=False)
    cost: float
    torques: np.ndarray = field(repr=False)
    resolution: float
    rms_resolution: float
    seconds: float
    runs: int = 0

    def holds(
        self, problem: str, cost: float, torques: np.ndarray, tolerance: float, reference: bool
    ) -> bool:
        """A probe (``reference`` False) or a reference of this basin: the cost within
        ``tolerance`` (relative) and the torques within BASIN_TORQUE of their peak."""
        if problem != self.problem:
            return False
        peak = float(np.max(np.abs(torques)))
        pairs = [(self.cost, self.torques)] if reference else self.probes
        return any(
            abs(cost - c) <= tolerance * abs(c)
            and np.max(np.abs(torques - t)) <= BASIN_TORQUE * peak
            for c, t in pairs
        )


class References:
    """The basins met so far, per problem, and the probe/reference meshes."""

    def __init__(self, probe, reference, half) -> None:
        self.probe, self.reference, self.half = probe, reference, half
        self.basins: list[Basin] = []
        self.seconds = 0.0

    def _solve(self, problem: str, mesh, start):
        name, degree, N, tol = mesh
        ocp = define(problem).ocp.refine(N=N, transcription=name, degree=degree).guess(start)
        return ocp.solve(options={"tol": tol}, progress=False)

    def basin(self, problem: str, solution) -> tuple[int, Basin]:
        """The basin a run lands in: its probe's, or, for a probe not met before, its
        reference's (a known reference again: the probe joins that basin; a new one: a new
        basin, with the resolution check)."""
        begin = time.perf_counter()
        probe = self._solve(problem, self.probe, solution)
        torques = torque_grid(probe)
        found = self._find(problem, probe.cost, torques, BASIN_COST, reference=False)
        if found is None:
            start = time.perf_counter()
            reference = self._solve(problem, self.reference, probe)
            fine = torque_grid(reference)
            found = self._find(problem, reference.cost, fine, REFERENCE_COST, reference=True)
            if found is None:
                half = torque_grid(self._solve(problem, self.half, probe))
                gap = np.abs(fine - half)
                self.basins.append(
                    Basin(
                        problem,
                        [],
                        reference.cost,
                        fine,
                        float(gap.max()),
                        float(np.sqrt(np.mean(gap**2))),
                        0.0,
                    )
                )
                found = len(self.basins) - 1
            self.basins[found].seconds += time.perf_counter() - start
            self.basins[found].probes.append((probe.cost, torques))
        self.basins[found].runs += 1
        self.seconds += time.perf_counter() - begin
        return found, self.basins[found]

    def _find(self, problem, cost, torques, tolerance, reference) -> int | None:
        for index, basin in enumerate(self.basins):
            if basin.holds(problem, cost, torques, tolerance, reference):
                return index
        return None


@dataclass
class Row:
    problem: str
    scheme: str
    N: int
    formulation: str
    tol: float
    variables: int
    status: str = ""
    repeats: int = 0
    iterations: int = 0
    build: float = math.nan
    solve: float = math.nan
    cost: float = math.nan
    basin: int = -1
    cost_error: float = math.nan
    torque_max: float = math.nan
    torque_rms: float = math.nan
    resolved: bool = True
    integration: float = math.nan


def measure(problem, scheme, N, formulation, tol, references, repeat, max_variables):
    """One grid run; None when over the variable cap (counted as skipped)."""
    name, degree = scheme
    ocp = define(problem, formulation).ocp.refine(N=N, transcription=name, degree=degree)
    variables = ocp.transcribe().n_w
    row = Row(problem, label(name, degree), N, formulation, tol, variables)
    if variables > max_variables:
        return row, False
    builds, solves, solution = [], [], None
    for k in range(repeat):
        solution = ocp.solve(
            options={"tol": tol}, progress=False, cache=False, raise_on_failure=False
        )
        builds.append(solution.stats["build_seconds"])
        solves.append(solution.stats["solve_seconds"])
        if not solution.success or (k == 0 and solves[0] >= REPEAT_BELOW):
            break
    row.status, row.repeats = solution.status, len(solves)
    row.iterations, row.cost = solution.iterations, solution.cost
    row.build, row.solve = statistics.median(builds), statistics.median(solves)
    if not solution.success:
        return row, True
    row.integration = scaled_error(solution)
    row.basin, basin = references.basin(problem, solution)
    gap = np.abs(torque_grid(solution) - basin.torques)
    row.cost_error = abs(solution.cost - basin.cost) / abs(basin.cost)
    row.torque_max = float(gap.max())
    row.torque_rms = float(np.sqrt(np.mean(gap**2)))
    row.resolved = row.torque_max > 2.0 * basin.resolution
    return row, True


# ---- printing --------------------------------------------------------------------------------
HEADER = (
    f"{'problem':<16}{'transcription':<17}{'N':>4} {'form':<9}{'tol':>6}{'vars':>7}{'rep':>4}"
    f"{'iter':>5}{'build s':>9}{'solve s':>9}{'cost':>12}{'basin':>6}{'cost err':>10}"
    f"{'M max':>10}{'M rms':>10}{'reint.':>9}"
)


def format_row(r: Row) -> str:
    head = (
        f"{r.problem:<16}{r.scheme:<17}{r.N:>4} {r.formulation:<9}{r.tol:>6.0e}{r.variables:>7}"
        f"{r.repeats:>4}{r.iterations:>5}{r.build:>9.3f}{r.solve:>9.3f}{r.cost:>12.6g}"
    )
    if r.basin < 0:
        return head + f"   {r.status}"
    mark = " " if r.resolved else "~"
    return (
        head + f"{r.basin:>6}{r.cost_error:>10.1e}{mark}{r.torque_max:>9.2e}"
        f"{r.torque_rms:>10.2e}{r.integration:>9.1e}"
    )


def dominance(rows: list[Row], problem: str) -> list[str]:
    """Per band of torque max error: the fastest run (any scheme, form, tol) reaching it."""
    lines = [
        f"{problem}: fastest run reaching each torque max error (solve time; the fastest run "
        "of each other transcription in brackets as a ratio)"
    ]
    usable = [r for r in rows if r.problem == problem and r.basin >= 0]
    for bound in (10.0, 3.0, 1.0, 0.3, 0.1, 0.03):
        within = [r for r in usable if r.torque_max <= bound]
        if not within:
            lines.append(f"  <= {bound:>5g} N m: none")
            continue
        best = min(within, key=lambda r: r.solve)
        others = []
        for scheme in sorted({r.scheme for r in within} - {best.scheme}):
            fastest = min((r for r in within if r.scheme == scheme), key=lambda r: r.solve)
            others.append(f"{scheme} {fastest.solve / best.solve:.1f}x")
        lines.append(
            f"  <= {bound:>5g} N m: {best.scheme} N={best.N} {best.formulation} tol "
            f"{best.tol:.0e}: {best.solve:.3f} s, error {best.torque_max:.2g} N m"
            + (f"  [{', '.join(others)}]" if others else "")
        )
    return lines


def knobs(rows: list[Row], problem: str) -> list[str]:
    """The two knobs other than the mesh, each as same-run ratios over the grid's pairs that
    differ in that knob only: explicit against implicit dynamics (solve time, torque error)
    and tol 1e-4 against 1e-8 (solve time, iterations, torque error)."""
    usable = {
        (r.scheme, r.N, r.formulation, r.tol): r
        for r in rows
        if r.problem == problem and r.basin >= 0
    }

    def ratios(changed: str, a, b, field: str) -> list[float]:
        out = []
        for (scheme, N, formulation, tol), r in usable.items():
            key = (scheme, N, a, tol) if changed == "formulation" else (scheme, N, formulation, a)
            if (formulation if changed == "formulation" else tol) != b or key not in usable:
                continue
            out.append(getattr(usable[key], field) / getattr(r, field))
        return out

    def spread(values: list[float]) -> str:
        if not values:
            return "no pairs"
        return f"median {np.median(values):.2f} ({min(values):.2f}..{max(values):.2f})"

    lines = [f"{problem}: the other knobs, same-run ratios over pairs differing in it only"]
    pairs = ratios("formulation", "explicit", "implicit", "solve")
    lines.append(
        f"  explicit / implicit dynamics ({len(pairs)} pairs): solve time "
        f"{spread(pairs)}, torque max error "
        f"{spread(ratios('formulation', 'explicit', 'implicit', 'torque_max'))}"
    )
    pairs = ratios("tol", 1e-4, 1e-8, "solve")
    lines.append(
        f"  tol 1e-4 / tol 1e-8 ({len(pairs)} pairs): solve time {spread(pairs)}, iterations "
        f"{spread(ratios('tol', 1e-4, 1e-8, 'iterations'))}, torque max error "
        f"{spread(ratios('tol', 1e-4, 1e-8, 'torque_max'))}"
    )
    return lines


# ---- refinement against uniform meshes --------------------------------------------------------
def uniform_curve(rows: list[Row], problem: str, scheme: str | None) -> list[Row]:
    """The grid's uniform runs of ``scheme`` (None: every scheme), implicit, tol 1e-8."""
    return sorted(
        (
            r
            for r in rows
            if r.problem == problem
            and (scheme is None or r.scheme == scheme)
            and r.formulation == "implicit"
            and r.tol == 1e-8
            and r.basin >= 0
        ),
        key=lambda r: r.N,
    )


def uniform_time_at(rows: list[Row], problem: str, scheme: str | None, error: float):
    """(the cheapest uniform run within ``error`` (build + solve), the log-log interpolation of
    ``scheme``'s uniform curve to ``error``, s) or None for either."""
    curve = uniform_curve(rows, problem, scheme)
    within = [r for r in curve if r.torque_max <= error]
    cheapest = min(within, key=lambda r: r.build + r.solve) if within else None
    interpolated = None
    if scheme is not None:
        for a, b in itertools.pairwise(curve):
            if a.torque_max > error >= b.torque_max:
                w = math.log(a.torque_max / error) / math.log(a.torque_max / b.torque_max)
                ta, tb = a.build + a.solve, b.build + b.solve
                interpolated = math.exp((1 - w) * math.log(ta) + w * math.log(tb))
                break
    return cheapest, interpolated


def refinement_section(rows, references, refinements, out) -> list[dict]:
    results = []
    print(
        "\nmesh refinement to a target (OCP.solve(accuracy=...), tol 1e-8) against the grid's "
        "uniform meshes (implicit, tol 1e-8), time to the same torque max error: build + "
        "solve (+ the estimates, for the refinement; all passes)",
        file=out,
    )
    print(
        f"{'problem':<16}{'transcription':<17}{'target':>7}{'N':>12}{'reint.':>9}{'iter':>5}"
        f"{'solve s':>8}{'total s':>8}{'M max':>10}{'M rms':>10}  uniform, same scheme | "
        "uniform, any scheme | uniform, same scheme, within the target's re-integration error",
        file=out,
    )
    for problem in PROBLEMS:
        for name, degree, density, targets in refinements:
            scheme = label(name, degree)
            for target in targets:
                ocp = define(problem).ocp
                start = max(8, math.ceil(density * ocp.T - 1e-9))
                ocp = ocp.refine(N=start, transcription=name, degree=degree)
                solution = ocp.solve(
                    accuracy=target,
                    options={"tol": 1e-8},
                    progress=False,
                    cache=False,
                    raise_on_failure=False,
                )
                history = solution.stats["refinement"]
                _, basin = references.basin(problem, solution)
                gap = np.abs(torque_grid(solution) - basin.torques)
                error = float(gap.max())
                seconds = history.seconds
                same, interpolated = uniform_time_at(rows, problem, scheme, error)
                best, _ = uniform_time_at(rows, problem, None, error)
                cells = []
                for run in (same, best):
                    if run is None:
                        cells.append("none reached it")
                        continue
                    cost = run.build + run.solve
                    cells.append(
                        f"{'' if run is same else run.scheme + ' '}N={run.N} {cost:.2f} s "
                        f"({cost / seconds:.2f}x, {run.torque_max:.2g} N m)"
                    )
                if interpolated is not None:
                    cells[0] += f", interpolated {interpolated:.2f} s"
                consistent = [
                    r for r in uniform_curve(rows, problem, scheme) if r.integration <= target
                ]
                if consistent:
                    run = min(consistent, key=lambda r: r.build + r.solve)
                    cost = run.build + run.solve
                    cells.append(f"N={run.N} {cost:.2f} s ({cost / seconds:.2f}x)")
                else:
                    cells.append("none reached it")
                mark = " " if error > 2.0 * basin.resolution else "~"
                rms = float(np.sqrt(np.mean(gap**2)))
                meshes = f"{start}->{solution.N}"
                print(
                    f"{problem:<16}{scheme:<17}{target:>7.0e}{meshes:>12}"
                    f"{history.errors[-1]:>9.1e}{history.iterations:>5}"
                    f"{history.solve_seconds:>8.2f}{seconds:>8.2f}{mark}{error:>9.2e}{rms:>10.2e}"
                    f"  {cells[0]} | {cells[1]} | {cells[2]}"
                    + ("" if history.reached else f"  [{history.reason}]"),
                    file=out,
                )
                results.append(
                    {
                        "problem": problem,
                        "scheme": scheme,
                        "target": target,
                        "sizes": history.sizes,
                        "errors": history.errors,
                        "seconds": seconds,
                        "solve_seconds": history.solve_seconds,
                        "torque_max": error,
                        "reached": history.reached,
                        "uniform_seconds": None if same is None else same.build + same.solve,
                        "interpolated_seconds": interpolated,
                        "best_uniform_seconds": None if best is None else best.build + best.solve,
                        "same_integration": cells[2],
                    }
                )
    return results


# ---- presets ----------------------------------------------------------------------------------
def presets_section(references, names, problems, repeat, out) -> list[dict]:
    print(
        "\naccuracy presets (problems.ACCURACY_PRESETS) on the problems they were chosen on "
        f"and on {' and '.join(p for p in problems if p not in PROBLEMS) or 'no other'}",
        file=out,
    )
    print(
        f"{'problem':<16}{'preset':<10}{'mesh':<24}{'tol':>6}{'rep':>4}{'iter':>5}"
        f"{'build s':>9}{'solve s':>9}{'M max':>10}{'M rms':>10}{'peak M':>8}{'stated':>9}"
        "  holds",
        file=out,
    )
    results = []
    for problem in problems:
        for name in names:
            preset = ACCURACY_PRESETS[name]
            builds, solves, gait = [], [], None
            for k in range(repeat):
                # the preset's own accuracy: the limits between the points are not held
                # (their back-offs move the optimum by the margins: a problem of its own)
                gait = define(problem, accuracy=name).solve(
                    progress=False, cache=False, hold_limits=False, verify=False
                )
                builds.append(gait.solution.stats["build_seconds"])
                solves.append(gait.solution.stats["solve_seconds"])
                if k == 0 and solves[0] >= REPEAT_BELOW:
                    break
            solution = gait.solution
            _, basin = references.basin(problem, solution)
            gap = np.abs(torque_grid(solution) - basin.torques)
            mesh = f"{label(preset.transcription, preset.degree)} N={solution.N}"
            peak = float(np.max(np.abs(basin.torques)))
            print(
                f"{problem:<16}{name:<10}{mesh:<24}{preset.tol:>6.0e}{len(solves):>4}"
                f"{solution.iterations:>5}{statistics.median(builds):>9.3f}"
                f"{statistics.median(solves):>9.3f}{gap.max():>10.2e}"
                f"{np.sqrt(np.mean(gap**2)):>10.2e}{peak:>8.1f}{preset.torque_error:>9.2g}"
                f"  {'yes' if gap.max() <= preset.torque_error else 'NO'}",
                file=out,
            )
            results.append(
                {
                    "problem": problem,
                    "preset": name,
                    "N": solution.N,
                    "build": statistics.median(builds),
                    "solve": statistics.median(solves),
                    "torque_max": float(gap.max()),
                }
            )
    return results


# ---- the figure -------------------------------------------------------------------------------
def plot(data: dict, path: Path) -> Path:
    """Two panels (one per problem): solve time against torque max error, log-log, one curve
    per transcription (implicit, tol 1e-8; tol 1e-4 as open markers), the refinement runs as
    stars, the references' resolution shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import ticker

    rows = [Row(**r) for r in data["rows"]]
    colours = dict(
        zip(
            [label(n, d) for n, d in SCHEMES],
            ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e"],
            strict=True,
        )
    )
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), constrained_layout=True)
    for ax, problem in zip(axes, PROBLEMS, strict=True):
        mine = [r for r in rows if r.problem == problem and r.basin >= 0]
        for scheme, colour in colours.items():
            for tol, filled in ((1e-8, True), (1e-4, False)):
                curve = sorted(
                    (
                        r
                        for r in mine
                        if r.scheme == scheme and r.formulation == "implicit" and r.tol == tol
                    ),
                    key=lambda r: r.N,
                )
                if not curve:
                    continue
                ax.plot(
                    [r.solve for r in curve],
                    [r.torque_max for r in curve],
                    linestyle="-" if filled else "none",
                    marker="o",
                    color=colour,
                    markerfacecolor=colour if filled else "white",
                    markersize=6 if filled else 5,
                    label=scheme if filled else None,
                    linewidth=1.8,
                )
                if filled:
                    last = curve[-1]
                    ax.annotate(
                        f"N={last.N}",
                        (last.solve, last.torque_max),
                        textcoords="offset points",
                        xytext=(5, 3),
                        fontsize=7,
                        color=colour,
                    )
        refined = [r for r in data.get("refinement", []) if r["problem"] == problem]
        for r in refined:
            r.setdefault("solve_seconds", r["seconds"])  # files written before it was stored
            ax.plot(
                r["solve_seconds"],
                r["torque_max"],
                "*",
                color=colours.get(r["scheme"], "black"),
                markeredgecolor="black",
                markersize=13,
                linestyle="none",
            )
            ax.annotate(
                f"{r['target']:.0e}",
                (r["solve_seconds"], r["torque_max"]),
                textcoords="offset points",
                xytext=(6, -9),
                fontsize=7,
            )
        floor = max(
            (b["resolution"] for b in data["basins"] if b["problem"] == problem), default=None
        )
        if floor:
            ax.axhspan(1e-9, 2 * floor, color="0.85", zorder=0)
            ax.text(
                0.01,
                2 * floor,
                " twice the reference's resolution",
                transform=ax.get_yaxis_transform(),
                ha="left",
                va="bottom",
                fontsize=8,
                color="0.35",
            )
        values = [r.torque_max for r in mine] + [r["torque_max"] for r in refined]
        if values:
            ax.set_ylim(min(values) / 2, max(values) * 2)
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain = ticker.FuncFormatter(lambda v, _: f"{v:g}")
        ax.xaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(plain)
            axis.set_minor_formatter(ticker.NullFormatter())
        ax.set_xlabel("solve time, s (IPOPT, median)")
        ax.set_ylabel("torque profile error, max over hinges and 1 kHz grid, N m")
        ax.set_title(
            f"{problem} (six-link), implicit dynamics\nN = 10, 20, 40, ..., 320 along each curve",
            fontsize=10,
        )
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    labels = [f"{name}, tol 1e-08" for name in labels]
    handles.append(
        plt.Line2D([], [], linestyle="none", marker="o", color="0.3", markerfacecolor="white")
    )
    labels.append("the same, tol 1e-04")
    handles.append(
        plt.Line2D(
            [], [], linestyle="none", marker="*", markersize=12, color="0.6", markeredgecolor="k"
        )
    )
    labels.append(
        "refined to the target written\n(colour: transcription;\nsolve time of all passes)"
    )
    fig.legend(handles, labels, loc="outside right center", fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ---- main -------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: seconds")
    parser.add_argument("--repeat", type=int, default=3, help="solves per run for medians")
    parser.add_argument(
        "--max-variables",
        type=int,
        default=40000,
        help="skip a run whose NLP has more variables (default 40000: the whole grid; 20000 "
        "drops N = 320 of Radau and Legendre, a third of the grid's time)",
    )
    parser.add_argument("--problems", default=",".join(PROBLEMS), help="comma-separated")
    parser.add_argument(
        "--plot",
        default=None,
        help="PNG of the Pareto plot (default examples/pictures/speed_accuracy.png; "
        "none with --quick unless given)",
    )
    parser.add_argument("--json", default=None, help="write the measurements here")
    parser.add_argument(
        "--replot",
        default=None,
        help="print the summaries and draw the figure again from a --json file",
    )
    parser.add_argument(
        "--skip",
        default="",
        help="comma-separated sections to skip: grid (and with it refinement), refinement, presets",
    )
    args = parser.parse_args(argv)
    root = Path(__file__).resolve().parents[1]
    if args.replot:  # the summaries and the figure again, from the measurements
        data = json.loads(Path(args.replot).read_text())
        rows = [Row(**r) for r in data["rows"]]
        for problem in dict.fromkeys(r.problem for r in rows):
            for line in dominance(rows, problem) + knobs(rows, problem):
                print(line)
        print(f"wrote {plot(data, Path(args.plot or root / 'pictures' / 'speed_accuracy.png'))}")
        return 0
    quick = args.quick
    settings = QUICK if quick else {}
    schemes = settings.get("schemes", SCHEMES)
    Ns = settings.get("Ns", NS)
    formulations = settings.get("formulations", FORMULATIONS)
    tolerances = settings.get("tolerances", TOLERANCES)
    references = References(
        settings.get("probe", PROBE),
        settings.get("reference", REFERENCE),
        settings.get("half", HALF),
    )
    repeat = 1 if quick else max(1, args.repeat)
    problems = [p.strip() for p in args.problems.split(",") if p.strip()]
    unknown = [p for p in problems if p not in PROBLEMS]
    if unknown:
        parser.error(f"--problems: unknown {unknown}; use {', '.join(PROBLEMS)}")
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}
    if skip - {"grid", "refinement", "presets"}:
        parser.error(f"--skip: unknown {sorted(skip - {'grid', 'refinement', 'presets'})}")
    out = sys.stdout
    begin = time.perf_counter()
    print(
        f"speed against accuracy{' (--quick)' if quick else ''}: {os.cpu_count()} cores, load "
        f"average {os.getloadavg()[0]:.2f} at the start; reference "
        f"{label(*references.reference[:2])} N={references.reference[2]} tol "
        f"{references.reference[3]:.0e}, probe {label(*references.probe[:2])} "
        f"N={references.probe[2]} tol {references.probe[3]:.0e}; times: median of up to "
        f"{repeat} solves",
        file=out,
    )
    rows, skipped = [], []
    if "grid" not in skip:
        print(HEADER, file=out, flush=True)
    for problem in problems if "grid" not in skip else ():
        for formulation in formulations:
            for tol in tolerances:
                for scheme in schemes:
                    for N in Ns:
                        row, done = measure(
                            problem, scheme, N, formulation, tol, references, repeat,
                            args.max_variables,
                        )  # fmt: skip
                        if not done:
                            skipped.append(row)
                            continue
                        rows.append(row)
                        print(format_row(row), file=out, flush=True)
    grid_seconds = time.perf_counter() - begin
    if rows:
        print(
            "\n(~: torque error within twice the reference's resolution, not resolved; "
            "M max/rms in N m; cost err relative; reint.: per-interval re-integration error "
            "per nominal state scale)",
            file=out,
        )
    if skipped:
        print(
            f"skipped (over --max-variables {args.max_variables}): "
            + ", ".join(
                f"{r.problem} {r.scheme} N={r.N} {r.formulation} tol {r.tol:.0e} "
                f"({r.variables} vars)"
                for r in skipped
            ),
            file=out,
        )
    print("", file=out)
    for problem in problems if rows else ():
        for line in dominance(rows, problem) + knobs(rows, problem):
            print(line, file=out)
    refinement = []
    if not skip & {"refinement", "grid"}:  # against the grid's uniform meshes
        refinement = refinement_section(
            rows, references, settings.get("refinements", REFINEMENTS), out
        )
    preset_rows = []
    if "presets" not in skip:
        preset_rows = presets_section(
            references,
            settings.get("presets", tuple(ACCURACY_PRESETS)),
            settings.get("preset_problems", PROBLEMS + UNTUNED),
            repeat,
            out,
        )
    print("\nreferences (one per local optimum met)", file=out)
    for index, basin in enumerate(references.basins):
        print(
            f"  basin {index}: {basin.problem}, cost {basin.cost:.9g} (probes "
            f"{', '.join(f'{c:.9g}' for c, _ in basin.probes)}: {basin.runs} runs), resolution "
            f"{basin.resolution:.2e} N m max, "
            f"{basin.rms_resolution:.2e} rms "
            f"(against N={references.half[2]}), references solved in "
            f"{basin.seconds:.1f} s",
            file=out,
        )
    total = time.perf_counter() - begin
    print(
        f"\ntotal {total / 60:.1f} min (grid {grid_seconds / 60:.1f} min; probes and "
        f"references, all sections: {references.seconds / 60:.1f} min); load average "
        f"{os.getloadavg()[0]:.2f} at the end",
        file=out,
    )
    data = {
        "rows": [asdict(r) for r in rows],
        "skipped": [asdict(r) for r in skipped],
        "basins": [
            {
                "problem": b.problem,
                "cost": b.cost,
                "probe_costs": [c for c, _ in b.probes],
                "resolution": b.resolution,
                "rms_resolution": b.rms_resolution,
                "runs": b.runs,
            }
            for b in references.basins
        ],
        "refinement": refinement,
        "presets": preset_rows,
        "seconds": total,
    }
    if args.json:
        Path(args.json).write_text(json.dumps(data, indent=1))
        print(f"wrote {args.json}", file=out)
    target = args.plot or (None if quick else root / "pictures" / "speed_accuracy.png")
    if target:
        print(f"wrote {plot(data, Path(target))}", file=out)
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
