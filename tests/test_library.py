"""problems.library: periodic steps over speed with their feedback in one file, and the
lookup by commanded speed.

Oracles: the file read back array by array; a grid speed's lookup against that gait's own
samples; the blend between two gaits against the equations of motion (the independent
verification's dynamics residual of the blended samples) and against a step solved at the
blended speed, the residual falling with the grid's spacing at second order (linear blending
of gaits smooth in speed: the error of a chord); every stored gait verified, its closed
loop's Floquet multipliers inside the unit circle; warm starts along the grid.
"""

import numpy as np
import pytest

from planner.errors import AnthropoidError
from problems import verify_gait
from problems.library import GaitLibrary, build_library


@pytest.fixture(scope="module")
def library():
    return build_library([0.9, 1.0, 1.1])


def test_the_file_holds_every_array(library, tmp_path):
    path = library.save(tmp_path / "library.npz")
    back = GaitLibrary.load(path)
    assert back.rate_hz == library.rate_hz and back.linkage.names == library.linkage.names
    for ours, theirs in zip(back.gaits, library.gaits, strict=True):
        assert (ours.speed, ours.step_length, ours.step_time) == (
            theirs.speed, theirs.step_length, theirs.step_time)  # fmt: skip
        for name in ("time", "psi", "dpsi", "ddpsi", "torques", "phase", "gains"):
            np.testing.assert_array_equal(getattr(ours, name), getattr(theirs, name))
        np.testing.assert_array_equal(ours.multipliers, theirs.multipliers)
    raw = np.load(path)
    assert "gait1_gains" in raw.files and raw["gait1_gains"].ndim == 3  # numpy alone reads it


def test_every_gait_is_verified_and_its_closed_loop_stable(library):
    for gait in library.gaits:
        assert np.max(np.abs(gait.multipliers)) < 1.0
        assert gait.gains.shape == (gait.time.size, library.linkage.n, 2 * library.linkage.n)
        assert gait.phase[0] == pytest.approx(0.0) and gait.phase[-1] == pytest.approx(1.0)
    # warm starts along the grid: the neighbours of the first (middle) gait take fewer
    # iterations than it did from the gait law
    middle = library.gaits[1].iterations
    assert all(g.iterations < middle for g in (library.gaits[0], library.gaits[2]))


def test_a_grid_speed_is_its_own_gait(library):
    gait = library.gaits[2]
    blended = library.at(gait.speed)
    np.testing.assert_allclose(blended.time, gait.time, atol=1e-12)
    np.testing.assert_allclose(blended.psi, gait.psi, atol=1e-12)
    np.testing.assert_allclose(blended.torques, gait.torques, atol=1e-9)
    assert verify_gait(blended, library.linkage).ok


def _dynamics_residual(library, speed):
    check = verify_gait(library.at(speed), library.linkage)["dynamics"]
    return -check.margin


def test_the_blend_converges_at_second_order_in_the_spacing(library):
    """Midway between gaits 0.2 m/s apart and 0.1 m/s apart: the blended samples' distance
    from the equations of motion falls about 4 times (2^2) when the spacing halves."""
    wide = GaitLibrary((library.gaits[0], library.gaits[2]), library.linkage, library.rate_hz)
    narrow = GaitLibrary(library.gaits[:2], library.linkage, library.rate_hz)
    coarse, fine = _dynamics_residual(wide, 1.0), _dynamics_residual(narrow, 0.95)
    assert 2.5 < coarse / fine < 6.0, (coarse, fine)
    assert fine < 1.5  # N m, at 0.1 m/s spacing


def test_the_blend_is_close_to_the_step_solved_there_and_solve_at_makes_it_exact(library):
    blended = library.at(0.95)
    solved = library.solve_at(0.95)
    reference = solved.to_trajectory(library.rate_hz)
    tau = np.linspace(0.0, 1.0, 201)

    def on(trajectory, values):
        own = trajectory.time / trajectory.time[-1]
        return np.stack([np.interp(tau, own, values[:, j]) for j in range(values.shape[1])], 1)

    torque = on(blended, blended.torques) - on(reference, reference.torques)
    assert np.sqrt(np.mean(torque**2)) < 0.5  # N m RMS over the step
    assert np.abs(on(blended, blended.psi) - on(reference, reference.psi)).max() < 0.03  # rad
    assert solved.verification.ok


def test_a_speed_outside_is_refused(library):
    with pytest.raises(ValueError, match=r"`speed`: 1.3 m/s is outside the library's 0.9..1.1"):
        library.at(1.3)
    with pytest.raises(ValueError, match="strictly increasing"):
        build_library([1.0, 0.9])


def test_a_step_that_fails_stops_the_build_naming_its_speed():
    """1 N m drives cannot walk: IPOPT's failure surfaces, with the library's speed."""
    with pytest.raises(AnthropoidError, match=r"the library's step at 1 m/s: IPOPT failed"):
        build_library([1.0], torque_limit=1.0)


def test_the_command_writes_the_library_a_controller_loads(tmp_path, capsys):
    from problems.__main__ import main

    out = tmp_path / "lib"
    code = main(["library", "--speeds-mps", "0.95,1.05", "--no-multipliers", "--output-dir",
                 str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert "| 0.950 | 0.487 in 0.513 |" in printed
    loaded = GaitLibrary.load(out / "library.npz")
    assert loaded.speeds.tolist() == [0.95, 1.05]
    assert np.all(np.isnan(loaded.gaits[0].multipliers))  # not computed, and said so: "-"
    code = main(["library", "--speeds-mps", "1.0", "--output-dir", str(tmp_path / "one")])
    assert code == 2
    assert "--speeds-mps: two or more speeds" in capsys.readouterr().err


def test_a_blend_is_a_joint_space_file_a_controller_runs(library):
    """The blend at 0.95 m/s written in the robot's terms (problems.robot.joint_space): its
    gains per physical drive, its phase rising through each step, its ground force (the
    whole body's, Newton) pressing and within the friction cone."""
    from problems.robot import joint_space

    view = joint_space(library.at(0.95))
    spec = view.metadata["controller"]
    assert spec["gains"] is not None and spec["rate_hz"] == 1000.0
    columns = view.columns
    assert all(f"K_{d}__{x}" in columns for d in spec["drives"] for x in spec["state"])
    first = columns["step"] == 0
    assert np.all(np.diff(columns["phase"][first]) > 0)
    # the stance foot pressed on the ground all step, within the blend's friction cone
    force_y = columns["ground_force_right_y_N"][first]
    force_x = columns["ground_force_right_x_N"][first]
    assert np.all(force_y > 0.0)
    assert np.all(np.abs(force_x) <= library.gaits[0].settings["mu"] * force_y)
