"""GIF animations of a matplotlib figure, fast: lay out and draw the figure once, redraw only
what moves.

matplotlib's ``PillowWriter`` renders the whole figure for every frame (twice, with a
constrained layout solved each time) and lets Pillow find a palette per frame: about 0.1 s a
frame for a stick figure, most of a quick plan's run time. Here the figure is laid out and
drawn once; each frame restores that background and draws the moving artists on it
(blitting), or, when the view itself moves (``full=True``: the axes follow the body), draws
the whole figure with the layout frozen. Every frame is quantised to the first frame's
palette (the colours of a stick figure do not change), without dithering.

>>> with GifFrames(figure, moving=lines + [title], fps=30) as gif:
...     for k in range(frames):
...         update(k)
...         gif.grab()
...     gif.save(path)            # atomic (planner.files.atomic_path)
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from planner.errors import DefinitionError, check_positive
from planner.files import atomic_path


class GifFrames:
    """Frames of ``figure`` (dots per inch ``dpi``) for a GIF at ``fps`` frames per second.

    moving : the artists that change from frame to frame (lines, texts); drawn over the
        background by :meth:`grab`.
    full : draw the whole figure for every frame (the axes' limits change: a view that
        follows the motion); the layout is still solved once.
    """

    def __init__(self, figure: Figure, moving, fps: float, dpi: float = 80.0, full=False) -> None:
        self.fps = check_positive("fps", fps, "frames per second")
        self.figure = figure
        self.moving = list(moving)
        self.full = bool(full)
        figure.set_dpi(check_positive("dpi", dpi, "dots per inch"))
        self.canvas = FigureCanvasAgg(figure)
        for artist in self.moving:
            artist.set_animated(True)  # left out of the background
        self.canvas.draw()  # the layout, once
        figure.set_layout_engine("none")
        self.background = self.canvas.copy_from_bbox(figure.bbox)
        self.frames: list[Image.Image] = []

    def __enter__(self) -> GifFrames:
        return self

    def __exit__(self, *exc) -> None:
        self.frames.clear()

    def grab(self) -> None:
        """Add the figure as it is now as a frame."""
        if self.full:
            self.canvas.draw()
        else:
            self.canvas.restore_region(self.background)
        for artist in self.moving:
            if artist.axes is not None:
                artist.axes.draw_artist(artist)
            else:
                self.figure.draw_artist(artist)
        rgb = np.asarray(self.canvas.buffer_rgba())[..., :3]
        image = Image.fromarray(np.ascontiguousarray(rgb))
        if not self.frames:
            self.frames.append(image.quantize(colors=255, method=Image.Quantize.MEDIANCUT))
        else:
            self.frames.append(image.quantize(palette=self.frames[0], dither=Image.Dither.NONE))

    def save(self, path: str | os.PathLike) -> Path:
        """Write the frames as an endless GIF, atomically; returns the path."""
        path = Path(os.fspath(path))
        if not self.frames:
            raise DefinitionError("GifFrames.save: no frame was grabbed; call grab() first")
        with atomic_path(path, suffix=".gif") as temporary:
            self.frames[0].save(
                temporary,
                format="GIF",
                save_all=True,
                append_images=self.frames[1:],
                duration=round(1000.0 / self.fps),
                loop=0,
            )
        return path


__all__ = ["GifFrames"]
