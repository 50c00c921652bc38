"""What the main job's pictures cost against its plan, and the GIF writer against matplotlib's.

    python examples/benchmarks/pictures.py            # medians of 3
    python examples/benchmarks/pictures.py --repeat 5

Times, in one run, for the default walking step (six-link, HS N = 30): the solve (holds
included), gait.png, walk.png and walk.gif (2 steps, 30 fps) as ``python -m problems walk``
writes them, and the same GIF through matplotlib's ``PillowWriter`` (the whole figure rendered
for every frame, a palette per frame: what the product used before ``planner.gif``; here on a
leaner figure, no legend or footholds, so if anything it flatters the old way). Ratios are to
the solve's median in the same run.

Then the main job as a user runs it, in fresh processes (imports, the solve, the export and
its verification; matplotlib's import counted with the pictures): ``python -m problems walk``
with ``--no-plots`` (the plan) and without (plan and pictures), alternating; the pictures'
cost is the difference of the medians. The product's settings (``ANTHROPOID_COMPILE``, its
cache) are the environment's, so the plan runs as a user's second run would.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from matplotlib.animation import PillowWriter

from problems import walking_step
from problems.walking import plots as walking_plots


def _median(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _pillow_writer_gif(motion, path: Path, fps: float = 30.0, dpi: float = 80.0) -> None:
    """The same frames as ``animate_walk`` through matplotlib's PillowWriter."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    duration = motion.time[-1] - motion.time[0]
    frames = np.linspace(motion.time[0], motion.time[-1], max(2, round(duration * fps) + 1))
    picks = np.searchsorted(motion.time, frames).clip(0, motion.time.size - 1)
    figure = Figure(figsize=(6.0, 7.0), dpi=dpi, layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    lines = [ax.plot([], [], linewidth=2.5, marker="o")[0] for _ in motion.segments]
    points = np.concatenate([v.reshape(-1) for v in motion.segments.values()])
    ax.set(xlim=(points.real.min(), points.real.max()), ylim=(0, points.imag.max()),
           aspect="equal")  # fmt: skip
    clock = ax.set_title("")
    writer = PillowWriter(fps=fps)
    with writer.saving(figure, path, dpi):
        for index in picks:
            for line, segment in zip(lines, motion.segments.values(), strict=True):
                line.set_data(segment[index].real, segment[index].imag)
            clock.set_text(f"t = {motion.time[index]:.3f} s")
            writer.grab_frame()


def _walk_seconds(arguments: list[str], repeat: int) -> list[float]:
    """Wall seconds of ``python -m problems walk`` in a new process, each run."""
    times = []
    root = Path(__file__).resolve().parents[2]
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(root), *filter(None, [os.environ.get("PYTHONPATH")])])}  # fmt: skip
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "problems", "walk", "-q", "--output-dir",
                            str(Path(folder) / "out"), *arguments], check=True,
                           stdout=subprocess.DEVNULL, env=environment)  # fmt: skip
            times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (median)")
    args = parser.parse_args()
    step = walking_step()
    rows = []
    gait = step.solve(progress=False)
    rows.append(("solve (HS N = 30, holds included)", _median(
        lambda: step.solve(progress=False), args.repeat)))  # fmt: skip
    motion = gait.world(steps=2, rate_hz=60.0)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        rows.append(("gait.png", _median(lambda: walking_plots.save_figure(
            walking_plots.gait_figure(gait), out / "gait.png"), args.repeat)))  # fmt: skip
        rows.append(("walk.png", _median(lambda: walking_plots.save_figure(
            walking_plots.world_strip(motion), out / "walk.png"), args.repeat)))  # fmt: skip
        rows.append(("walk.gif (planner.gif: drawn once, blitted)", _median(
            lambda: walking_plots.animate_walk(motion, out / "walk.gif", fps=30.0),
            args.repeat)))  # fmt: skip
        rows.append(("walk.gif through matplotlib's PillowWriter", _median(
            lambda: _pillow_writer_gif(motion, out / "pillow.gif"), args.repeat)))  # fmt: skip
    solve = rows[0][1]
    pictures = sum(seconds for _, seconds in rows[1:4])
    print("The main job's pictures against its plan (default six-link walking step)")
    print(f"(medians of {args.repeat}; the machine is shared: compare ratios in one run)")
    head = f"{'what':<46} {'median s':>9} {'/ solve':>8}"
    print(head)
    print("-" * len(head))
    for what, seconds in rows:
        print(f"{what:<46} {seconds:9.3f} {seconds / solve:8.2f}")
    print(f"{'the three pictures walk writes':<46} {pictures:9.3f} {pictures / solve:8.2f}")
    plan, whole = [], []
    for _ in range(args.repeat):  # alternating: the machine's noise falls on both alike
        plan += _walk_seconds(["--no-plots"], 1)
        whole += _walk_seconds([], 1)
    plan_s, whole_s = statistics.median(plan), statistics.median(whole)
    print()
    print(f"The main job in new processes, `python -m problems walk` (medians of {args.repeat})")
    head = f"{'what':<46} {'median s':>9} {'/ plan':>8}"
    print(head)
    print("-" * len(head))
    for what, seconds in (("plan (--no-plots): imports, solve, files, check", plan_s),
                          ("plan and pictures (the default job)", whole_s),
                          ("pictures (the difference)", whole_s - plan_s)):  # fmt: skip
        print(f"{what:<46} {seconds:9.3f} {seconds / plan_s:8.2f}")


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
