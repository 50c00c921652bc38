"""problems.human.tracking and 'track-gait': the periodic step closest to a recording.

Oracles: the Fourier series against a trigonometric polynomial it must reproduce exactly (and
its CasADi form against its numpy form); a recording that is itself a planned gait (the
default point-foot step's stride) tracked back to within the Fourier fit's residual, the
untracked channels (the ankle, the moments, the ground force) following because the motion
is the same; Winter's stride tracked on feet, every exported sample verified (slow).
"""

import json
import math

import casadi as ca
import numpy as np
import pytest

from problems import walking_step
from problems.__main__ import main
from problems.human import GaitRecording, read_winter, step_stride
from problems.human.tracking import FourierSeries, track_gait, tracking_of


def test_fourier_series_reproduces_a_trigonometric_polynomial():
    p = np.linspace(0.0, 100.0, 71)
    exact = 3.0 + 2.0 * np.cos(2 * np.pi * p / 100) - 1.5 * np.sin(6 * np.pi * p / 100)
    series = FourierSeries.fit(p, exact, harmonics=4)
    assert series.mean == pytest.approx(3.0, abs=1e-12)
    assert series.cosines == pytest.approx((2.0, 0.0, 0.0, 0.0), abs=1e-12)
    assert series.sines == pytest.approx((0.0, 0.0, -1.5, 0.0), abs=1e-12)
    x = ca.SX.sym("x")
    symbolic = ca.Function("f", [x], [series(x)])
    for value in (0.0, 17.3, 99.0, 130.0, -20.0):
        assert float(symbolic(value)) == pytest.approx(float(series(np.array(value))), abs=1e-12)
    assert series(np.array(130.0)) == pytest.approx(series(np.array(30.0)))  # periodic


def test_fourier_series_needs_enough_samples():
    with pytest.raises(ValueError, match="harmonics"):
        FourierSeries.fit(np.linspace(0, 100, 10), np.ones(10), harmonics=12)


@pytest.fixture(scope="module")
def planned_stride():
    gait = walking_step().solve()
    return step_stride(gait.to_trajectory(1000.0))


def test_a_planned_gait_tracked_back_on_point_feet(planned_stride):
    result = track_gait(planned_stride, feet=False, weights={"thigh": 1, "knee": 1, "hip": 1},
                        solve_options={"progress": False})  # fmt: skip
    assert result.gait.verified
    channels = result.comparison.channels
    for name in ("thigh", "hip", "knee"):
        assert channels[name].rms < 0.3, name  # the 12 harmonics' residual at the strike
    # not tracked, but the same motion: the stance ankle, the moments and the force follow
    assert channels["ankle"].rms < 0.3
    assert channels["knee_moment"].rms < 0.1 and channels["force_y"].rms < 0.15
    assert set(result.gait.solution.cost_terms) == {"objective", "tracking"}


@pytest.mark.parametrize(
    "weights, message",
    [
        ({"elbow": 1.0}, "unknown channel 'elbow'"),
        ({"knee": -1.0}, r"weights\['knee'\]"),
        ({"knee": 0.0}, "at least one channel"),
        ({"hip_moment": 1.0}, "unknown channel"),
    ],
)
def test_bad_weights_are_refused(planned_stride, weights, message):
    with pytest.raises(ValueError, match=message):
        tracking_of(planned_stride, weights)


def test_a_channel_the_recording_lacks_is_refused():
    percent = np.linspace(0, 100, 40)
    angles_only = GaitRecording(percent, {"knee": np.sin(percent / 10)}, 0.6, 1.0, 1.4)
    with pytest.raises(ValueError, match="does not measure force_y"):
        tracking_of(angles_only, {"knee": 1.0, "force_y": 10.0})
    assert set(tracking_of(angles_only, {"knee": 1.0}).weights) == {"knee"}
    with pytest.raises(ValueError, match="does not measure thigh"):
        tracking_of(angles_only)  # the default tracks thigh, knee and ankle


def test_track_gait_command_on_point_feet(capsys, tmp_path, winter_xlsx):
    folder = tmp_path / "track"
    code = main(["track-gait", "--data", str(winter_xlsx), "--point-feet", "--output-dir",
                 str(folder), "--no-plots", "-q"])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert "checks passed" in out and "NOT all" not in out
    assert sorted(p.name for p in folder.iterdir()) == [
        "comparison.json", "comparison.md", "manifest.json", "stride.csv", "torques.csv",
        "torques.csv.meta.json",
    ]  # fmt: skip
    result = json.loads((folder / "comparison.json").read_text())
    assert result["weights"] == {"thigh": 1.0, "knee": 1.0, "force_x": 100.0, "force_y": 100.0}
    assert result["channels"]["knee"]["rms"] < 3.0 and result["channels"]["thigh"]["rms"] < 3.0


@pytest.mark.slow
def test_winter_tracked_on_feet(winter_xlsx):
    """The measured result (examples/benchmarks/human_tracking.py): thigh 1.7, knee 2.2,
    ankle 3.0 deg RMS, every exported sample verified."""
    result = track_gait(read_winter(winter_xlsx), solve_options={"progress": False})
    assert result.gait.verified
    channels, features = result.comparison.channels, result.comparison.features
    assert channels["thigh"].rms < 2.0 and channels["knee"].rms < 2.5
    assert channels["ankle"].rms < 3.5
    assert channels["force_y"].r > 0.5
    assert math.isclose(features["knee_loading"].model, features["knee_loading"].data, abs_tol=2)
    assert math.isclose(features["knee_swing"].model, features["knee_swing"].data, abs_tol=2)
