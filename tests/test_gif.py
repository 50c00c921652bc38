"""planner.gif.GifFrames: each frame is the figure as a full render would draw it (the oracle:
a fresh figure in the same state, drawn whole by Agg), no trails of earlier frames, one
palette, the timing and the atomic write."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from model import DefinitionError
from planner.gif import GifFrames

STATES = [(0.1, 0.2), (0.5, 0.8), (0.9, 0.3)]


def _figure(x: float, y: float, title: bool = True):
    figure = Figure(figsize=(2.0, 2.0), layout="constrained")
    ax = figure.add_subplot()
    ax.set(xlim=(0, 1), ylim=(0, 1))
    ax.plot([0, 1], [0.5, 0.5], color="0.5")
    (line,) = ax.plot([0.0, x], [0.0, y], color="tab:red", linewidth=3)
    clock = ax.set_title(f"x = {x:.1f}" if title else "")
    return figure, ax, line, clock


def _render(x: float, y: float, dpi: float) -> np.ndarray:
    figure, *_ = _figure(x, y)
    figure.set_dpi(dpi)
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].astype(int)


@pytest.mark.parametrize("full", [False, True])
def test_each_frame_is_the_full_render_of_its_state(tmp_path, full):
    figure, ax, line, clock = _figure(*STATES[-1])  # the layout sized for the longest title
    with GifFrames(figure, [line, clock], fps=10, dpi=50, full=full) as gif:
        for x, y in STATES:
            line.set_data([0.0, x], [0.0, y])
            clock.set_text(f"x = {x:.1f}")
            if full:
                ax.set_xlim(0, 1)  # a view that moves: here it stays, the frames must agree
            gif.grab()
        path = gif.save(tmp_path / "moving.gif")
    with Image.open(path) as image:
        assert image.n_frames == len(STATES)
        assert image.info["duration"] == 100  # ms per frame at 10 fps
        for k, (x, y) in enumerate(STATES):
            image.seek(k)
            frame = np.asarray(image.convert("RGB")).astype(int)
            expected = _render(x, y, 50)
            assert frame.shape == expected.shape
            # one palette for all frames: colours within its rounding; every pixel drawn
            # where the full render draws it (a trail of an earlier line would differ by far)
            difference = np.abs(frame - expected).max(axis=2)
            assert np.mean(difference > 40) < 0.002, (k, np.mean(difference > 40))


def test_nothing_grabbed_or_a_bad_rate_is_refused(tmp_path):
    figure, _, line, _ = _figure(0.5, 0.5)
    with pytest.raises(DefinitionError, match=r"`fps`: must be > 0"):
        GifFrames(figure, [line], fps=0)
    gif = GifFrames(figure, [line], fps=5)
    with pytest.raises(DefinitionError, match="no frame was grabbed"):
        gif.save(tmp_path / "empty.gif")
    assert list(tmp_path.iterdir()) == []
