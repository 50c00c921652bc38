"""problems.human.stride and .comparison: a planned step's stride and the metrics.

Oracles: the stride read back against the step's own samples of each leg (the pieces of the
cycle are the stance leg's and the swing leg's values shifted by the strike time), its
continuity where the pieces meet (the periodicity: a leg taken from the wrong side would jump
by tens of degrees), the stance fraction from the phases' durations, no ground force in the
swing; the metrics on hand-made curves with known RMS, r and peaks.
"""

import numpy as np
import pytest

from problems import walking_step
from problems.human import GaitRecording, compare_gait, step_stride
from problems.human.comparison import humps
from problems.human.joints import body_of, leg_angles


@pytest.fixture(scope="module")
def footed_stride(footed_gait):
    trajectory = footed_gait.to_trajectory(1000.0)
    return footed_gait, trajectory, step_stride(trajectory)


def test_stride_of_a_footed_step_is_its_legs_shifted(footed_stride):
    gait, trajectory, stride = footed_stride
    T = gait.duration
    flat, heel, _ = gait.durations()
    t_s = flat + heel
    assert stride.stance_fraction == pytest.approx((2 * T - t_s) / (2 * T), rel=1e-12)
    assert stride.stride_time == pytest.approx(2 * T)
    assert stride.body_mass == pytest.approx(sum(link.mass for link in gait.problem.linkage.links))
    body = body_of(gait.problem.linkage, gait.problem.neutral_ankles)
    names = trajectory.link_names
    psi = {name: trajectory.psi[:, i] for i, name in enumerate(names)}
    stance = leg_angles(body, body.stance, psi)
    swing = leg_angles(body, body.swing, psi)
    time = trajectory.time
    for k in (40, 150, 300):  # inside the single support: the stance piece
        percent = 100 * (time[k] + T - t_s) / (2 * T)
        assert stride.at("knee", percent) == pytest.approx(stance["knee"][k], abs=0.05)
        assert stride.at("ankle", percent) == pytest.approx(stance["ankle"][k], abs=0.05)
        percent = 100 * (time[k] + 2 * T - t_s) / (2 * T)  # the swing before the strike
        if time[k] < t_s:
            assert stride.at("hip", percent) == pytest.approx(swing["hip"][k], abs=0.05)
    k = int(np.searchsorted(time, t_s + 0.05))  # the double support: the front leg
    percent = 100 * (time[k] - t_s) / (2 * T)
    assert stride.at("thigh", percent) == pytest.approx(swing["thigh"][k], abs=0.05)


def _extrapolated(stride, name, percent, side):
    """``name`` at ``percent`` extrapolated linearly from one side (-1 before, +1 after)."""
    near, far = stride.at(name, percent + 0.1 * side), stride.at(name, percent + 0.3 * side)
    return near + (near - far) / 2.0


def test_stride_is_continuous_where_its_pieces_meet(footed_stride):
    _, _, stride = footed_stride
    # the other foot's toe-off (the step's start) and this foot's toe-off
    for percent in (100 * (stride.stance_fraction - 0.5), 100 * stride.stance_fraction):
        for name in ("thigh", "hip", "knee", "ankle"):
            before = _extrapolated(stride, name, percent, -1)
            after = _extrapolated(stride, name, percent, +1)
            assert abs(after - before) < 0.3, (name, percent, before, after)


def test_no_ground_force_on_the_swinging_foot(footed_stride):
    _, _, stride = footed_stride
    swing = (stride.percent > 100 * stride.stance_fraction + 0.2) & (stride.percent < 99.8)
    assert np.all(stride.channels["force_y"][swing] == 0.0)
    stance = (stride.percent > 1.0) & (stride.percent < 100 * stride.stance_fraction - 1.0)
    assert np.all(stride.channels["force_y"][stance] > 0.0)


def test_stride_of_a_point_foot_step():
    gait = walking_step().solve()
    stride = step_stride(gait.to_trajectory(1000.0))
    assert stride.stance_fraction == pytest.approx(0.5)
    assert stride.has("knee") and stride.has("hip_moment")
    stance = stride.percent < 49.5
    assert np.all(np.isfinite(stride.channels["ankle"][stance]))
    assert np.all(np.isnan(stride.channels["ankle"][stride.percent > 50.5]))
    for name in ("thigh", "knee"):  # the strike: angles continuous through the leg swap
        before, after = (_extrapolated(stride, name, 50.0, side) for side in (-1, 1))
        assert abs(after - before) < 0.3, name


def test_a_trajectory_without_its_settings_is_refused(footed_gait):
    trajectory = footed_gait.to_trajectory(1000.0)
    bare = trajectory.with_metadata(gait=None)
    with pytest.raises(ValueError, match=r"sidecar|walking step"):
        step_stride(bare)


# ---- the metrics --------------------------------------------------------------------------------
def _curve(values, stance=0.6):
    percent = np.linspace(0.0, 100.0, 2001)
    return GaitRecording(percent, {name: f(percent) for name, f in values.items()}, stance)


def test_rms_and_correlation_of_known_curves():
    wave = lambda p: 20 * np.sin(2 * np.pi * p / 100)  # noqa: E731
    shifted = _curve(
        {"knee": lambda p: wave(p) + 3.0, "hip": lambda p: 20 * np.cos(2 * np.pi * p / 100)}
    )
    data = _curve({"knee": wave, "hip": wave})
    result = compare_gait(shifted, data)
    assert result.channels["knee"].rms == pytest.approx(3.0, rel=1e-9)
    assert result.channels["knee"].r == pytest.approx(1.0, abs=1e-12)
    assert result.channels["hip"].r == pytest.approx(0.0, abs=2e-3)  # a quarter period apart
    assert result.channels["hip"].rms == pytest.approx(20.0, rel=2e-3)  # sqrt(2) x 20/sqrt(2)
    assert result.channels["knee"].model == pytest.approx((-17.0, 23.0), abs=1e-3)


def test_force_humps_over_the_stance():
    x = np.linspace(0.0, 100.0, 1001)
    force = 1.1 * np.exp(-(((x - 20) / 8) ** 2)) + 1.2 * np.exp(-(((x - 78) / 9) ** 2)) + 0.5
    (p1, at1), (valley, at_v), (p2, at2) = humps(force)
    assert (at1, at2) == pytest.approx((20.0, 78.0), abs=0.2)
    assert p1 == pytest.approx(1.6, abs=0.01) and p2 == pytest.approx(1.7, abs=0.01)
    assert valley == pytest.approx(force[np.argmin(np.where((x > 20) & (x < 78), force, 9))])
    assert 40 < at_v < 60


def test_compare_refuses_recordings_without_shared_channels():
    with pytest.raises(ValueError, match="shares no channel"):
        compare_gait(_curve({"knee": np.sin}), _curve({"hip": np.sin}))
