"""Plots: figure structure (axes, lines, labels), stick-figure geometry, GIF output."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from model import Dynamics, LinkageTrajectory, drawing, presets
from planner import plots
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory, TrajectoryFileError, TrajectoryFileNotFoundError


@pytest.fixture(scope="module")
def dynamics():
    return Dynamics(presets.six_link_anthropoid())


@pytest.fixture(scope="module")
def walk(dynamics):
    """The scene's law (22) "paper22" sampled at 21 times over one period T = 1 s."""
    t = np.linspace(0.0, 1.0, 21)
    zeta = np.array([0.20, 0.30, 0.40, 0.30, 0.10, 0.05])
    varpi = np.array([0.00, 0.50, 1.00, 1.50, 0.20, 0.40])
    phase = varpi - (1 - np.cos(2 * np.pi * t[:, None])) * np.pi / 2
    psi = np.pi / 2 + zeta * np.sin(phase)
    dphase = -(np.pi**2) * np.sin(2 * np.pi * t[:, None])
    dpsi = zeta * np.cos(phase) * dphase
    return LinkageTrajectory.from_linkage(
        t,
        psi,
        dpsi,
        np.zeros_like(psi),
        dynamics.names,
        ddpsi=np.zeros_like(psi),
        ground_reaction=np.full(21, 700j),
        metadata={"source": "paper22"},
    )


def test_plot_trajectory_panels_per_group_and_unit(walk):
    figure = plots.plot_trajectory(walk)
    assert isinstance(figure, Figure)
    assert [ax.get_ylabel() for ax in figure.axes] == ["psi [rad]", "dpsi [rad/s]", "M [N m]"]
    assert [len(ax.lines) for ax in figure.axes] == [6, 6, 6]
    assert figure.axes[-1].get_xlabel() == "t [s]"
    assert [t.get_text() for t in figure.axes[0].get_legend().get_texts()][:2] == [
        "stance_shank",
        "stance_thigh",
    ]
    np.testing.assert_array_equal(figure.axes[1].lines[2].get_ydata(), walk.dpsi[:, 2])
    assert figure.get_suptitle() == "paper22"
    with_extras = walk.plot(extras=True)
    labels = [ax.get_ylabel() for ax in with_extras.axes]
    assert labels[3:] == ["ddpsi [rad/s^2]", "F [N]"]
    assert [len(ax.lines) for ax in with_extras.axes] == [6, 6, 6, 6, 2]


def test_plot_of_a_generic_trajectory_groups_by_unit():
    t = np.linspace(0.0, 1.0, 5)
    traj = Trajectory(
        t, np.c_[t, t, t], np.c_[t], ("x", "y", "v"), ("m", "m", "m/s"), ("u",), ("N",)
    )
    figure = traj.plot(title="generic")
    assert [ax.get_ylabel() for ax in figure.axes] == ["x, y [m]", "v [m/s]", "u [N]"]
    assert [len(ax.lines) for ax in figure.axes] == [2, 1, 1]
    with pytest.raises(DefinitionTypeError, match=r"`trajectory`: must be a planner"):
        plots.plot_trajectory(np.zeros(3))
    empty = Trajectory(t, np.zeros((5, 0)), np.zeros((5, 0)), (), (), (), ())
    with pytest.raises(DefinitionError, match=r"has no channels to plot"):
        plots.plot_trajectory(empty)


def test_stick_figure_strip_draws_each_link_between_its_hinges(dynamics, walk):
    figure = drawing.stick_figure_strip(dynamics, walk, n_frames=4)
    (ax,) = figure.axes
    n = dynamics.n
    assert len(ax.lines) == 4 * n + 1
    # independent geometry: pose 2 at t = 2/3 s, link "torso" (parent stance_thigh) runs from
    # the hip H2 to H5, recomputed from the angles with the scene's lengths
    lengths = {"stance_shank": 0.43, "stance_thigh": 0.43, "torso": 0.50}
    psi = walk.at(2.0 / 3.0)[0][:n]
    names = dynamics.names
    hip = sum(lengths[k] * np.exp(1j * psi[names.index(k)]) for k in names[:2])
    top = hip + lengths["torso"] * np.exp(1j * psi[names.index("torso")])
    shift = ax.lines[2 * n].get_xdata()[0]  # pose 2's root starts at H0 = 0 + 2 * spacing
    assert shift > 0 and f"by k x {shift / 2:.3g} m" in ax.get_xlabel()
    line = ax.lines[2 * n + names.index("torso")]
    np.testing.assert_allclose(line.get_xdata(), [hip.real + shift, top.real + shift], atol=1e-12)
    np.testing.assert_allclose(line.get_ydata(), [hip.imag, top.imag], atol=1e-12)
    assert [t.get_text() for t in ax.texts] == ["0 s", "0.333 s", "0.667 s", "1 s"]


def test_stick_figure_strip_into_given_axes_and_errors(dynamics, walk):
    figure = Figure()
    ax = figure.add_subplot()
    assert drawing.stick_figure_strip(dynamics, walk, n_frames=1, ax=ax, spacing=0.5) is figure
    assert len(ax.lines) == dynamics.n + 1
    t = walk.time
    generic = Trajectory(t, np.c_[t], np.zeros((21, 0)), ("x",), ("m",), (), ())
    with pytest.raises(DefinitionError, match=r"needs a linkage trajectory"):
        drawing.stick_figure_strip(dynamics, generic)
    other = Dynamics(presets.five_link_biped())
    with pytest.raises(DefinitionError, match=r"its links \['stance_shank'.* differ from"):
        drawing.stick_figure_strip(other, walk)
    with pytest.raises(DefinitionError, match=r"`n_frames`: must be >= 1, got 0"):
        drawing.stick_figure_strip(dynamics, walk, n_frames=0)
    with pytest.raises(DefinitionTypeError, match=r"`n_frames`: must be an integer"):
        drawing.stick_figure_strip(dynamics, walk, n_frames=2.5)
    with pytest.raises(DefinitionTypeError, match=r"`dynamics`: must be a model.Dynamics"):
        drawing.stick_figure_strip(object(), walk)
    with pytest.raises(DefinitionTypeError, match=r"`ax`: must be matplotlib Axes"):
        drawing.stick_figure_strip(dynamics, walk, ax="axes")
    with pytest.raises(DefinitionError, match=r"`spacing`: must be >= 0 m, got -1"):
        drawing.stick_figure_strip(dynamics, walk, spacing=-1)
    with pytest.raises(DefinitionError, match=r"`spacing`: must be finite, got nan"):
        drawing.stick_figure_strip(dynamics, walk, spacing=float("nan"))
    with pytest.raises(DefinitionTypeError, match=r"`spacing`: must be a real number"):
        drawing.stick_figure_strip(dynamics, walk, spacing="wide")


def test_animate_writes_a_gif_with_the_frames_asked_for(dynamics, walk, tmp_path):
    path = drawing.animate(
        dynamics, walk, tmp_path / "walk.gif", fps=10, n_frames=5, dpi=30, figsize=(2, 2)
    )
    assert path == tmp_path / "walk.gif"
    with Image.open(path) as image:
        assert image.format == "GIF"
        assert image.n_frames == 5
        assert image.size == (60, 60)
    assert [p.name for p in tmp_path.iterdir()] == ["walk.gif"]


def test_animate_default_frame_count_is_real_time(dynamics, walk, tmp_path):
    short = LinkageTrajectory.from_linkage(
        walk.time * 0.1, walk.psi, walk.dpsi * 10, walk.torques, dynamics.names
    )
    path = drawing.animate(dynamics, short, str(tmp_path / "short.gif"), fps=30, dpi=20)
    with Image.open(path) as image:
        assert image.n_frames == 4  # 0.1 s at 30 fps: frames at 0, 1/30, 2/30, 0.1 s


def test_animate_errors_and_atomic_write(dynamics, walk, tmp_path, monkeypatch):
    with pytest.raises(TrajectoryFileError, match=r"written as GIF; give a file name ending"):
        drawing.animate(dynamics, walk, tmp_path / "walk.mp4")
    with pytest.raises(TrajectoryFileNotFoundError, match=r"folder .* does not exist"):
        drawing.animate(dynamics, walk, tmp_path / "no" / "walk.gif")
    with pytest.raises(DefinitionError, match=r"`fps`: must be > 0"):
        drawing.animate(dynamics, walk, tmp_path / "walk.gif", fps=0)
    with pytest.raises(DefinitionError, match=r"`fps`: must be finite, got inf"):
        drawing.animate(dynamics, walk, tmp_path / "walk.gif", fps=float("inf"))
    with pytest.raises(DefinitionTypeError, match=r"`fps`: must be a real number, got 'fast'"):
        drawing.animate(dynamics, walk, tmp_path / "walk.gif", fps="fast")
    with pytest.raises(DefinitionError, match=r"`n_frames`: must be >= 2"):
        drawing.animate(dynamics, walk, tmp_path / "walk.gif", n_frames=1)

    def refuse(source, target):
        raise OSError("no space left")

    monkeypatch.setattr(drawing.os, "replace", refuse)
    with pytest.raises(OSError, match="no space left"):
        drawing.animate(dynamics, walk, tmp_path / "walk.gif", n_frames=2, dpi=20)
    assert list(tmp_path.iterdir()) == []
