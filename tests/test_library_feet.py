"""problems.library on feet: periodic steps on feet over speed (flat foot, heel rise, double
support) with their joint PD gains in one file, and the lookup that blends them phase by phase.

Oracles: the model's inverse dynamics (a pinned-root tree: the single support's equations of
motion need no contact force) against the blended samples, zero to round-off at a grid speed
and falling at second order with the grid's spacing, where blending the whole step in t / T
(mixing one gait's heel rise with the other's double support) misses by two orders more; the
impact's instant of the blend where its contact phases say; every stored gait verified from its
samples by the numpy verification; the step solved from the blend verified.
"""

import json
from dataclasses import replace

import numpy as np
import pytest

from planner.errors import DefinitionError
from problems import verify_gait
from problems.library import GaitLibrary


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The command's library at 0.9, 1.0, 1.1 m/s, read back from its file; its table."""
    import contextlib
    import io

    from problems.__main__ import main

    folder = tmp_path_factory.mktemp("feet") / "library"
    printed, errors = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(errors):
        code = main(["library", "--feet", "--speeds-mps", "0.9,1.0,1.1", "--output-dir",
                     str(folder)])  # fmt: skip
    assert code == 0, errors.getvalue()
    assert "the gait at 1.1 m/s: no |lambda_1| on feet: `gait`: its walk under the law falls" in (
        errors.getvalue()
    )
    return GaitLibrary.load(folder / "library.npz"), printed.getvalue(), folder / "library.npz"


@pytest.fixture(scope="module")
def library(built):
    return built[0]


def _single_support_residual(library: GaitLibrary, speed: float) -> float:
    """max |M - ID(psi, dpsi, ddpsi)| over the blend's single-support samples, N m."""
    blend = library.at(speed)
    rows = np.asarray(blend.extras["double_support"][0]) < 0.5
    psi, dpsi, ddpsi = (np.asarray(getattr(blend, k))[rows] for k in ("psi", "dpsi", "ddpsi"))
    expected = library.dynamics.inverse_dynamics(psi, dpsi, ddpsi)
    return float(np.max(np.abs(np.asarray(blend.torques)[rows] - expected)))


def test_the_command_prints_each_gaits_contact_phases(built):
    _, printed, _ = built
    assert ("| speed m/s | step m in s | IPOPT iterations | peak abs M N m | contact phases s | "
            "abs lambda_1 |") in printed  # fmt: skip
    row = next(line for line in printed.splitlines() if line.startswith("| 1.000 |"))
    assert "| 1.000 | 0.500 in 0.500 |" in row and "flat " in row and "double " in row
    assert 0.5 < float(row.split("|")[-2]) < 1.0  # the push's decay per step


def test_every_gait_keeps_its_phases_forces_and_gains(library):
    n = library.linkage.n
    assert library.feet and library.settings["feet"] == "feet"
    for gait in library.gaits:
        assert [name for name, _ in gait.segments] == ["flat", "heel rise", "double"]
        assert float(np.sum(gait.durations)) == pytest.approx(gait.step_time, rel=1e-9)
        assert set(gait.extras) == {"F_swing_heel_x", "F_swing_heel_y", "double_support"}
        # the double support's branch from the heel strike's instant on, the front heel's
        # force only there
        strike = float(np.sum(gait.durations[:2]))
        double = gait.extras["double_support"] > 0.5
        np.testing.assert_array_equal(double, gait.time >= strike - 1e-9)
        assert np.all(gait.extras["F_swing_heel_y"][~double] == 0.0)
        assert np.all(gait.extras["F_swing_heel_y"][double][1:] > 0.0)
        assert gait.gains.shape == (gait.time.size, n, 2 * n)
        assert np.all(gait.gains[:, 0] == 0.0)  # the ground's torque on the stance foot
        # on feet |lambda_1| alone (a push's decay per step), the others not computed: NaN;
        # the 1.1 m/s step, unbounded in joint speed, falls unpushed on the estimate's 8 kHz
        # clock in its eighth step: NaN, warned (measured)
        if gait.speed <= 1.0:
            assert 0.5 < gait.multipliers[0].real < 1.0 and gait.multipliers[0].imag == 0.0
        assert np.all(np.isnan(gait.multipliers[1:]))
        assert "joint PD" in gait.law["design"]
        assert verify_gait(library.at(gait.speed), library.linkage).ok


def test_a_grid_speed_is_its_own_gait(library):
    gait = library.gaits[1]
    blended = library.at(gait.speed)
    np.testing.assert_allclose(blended.time, gait.time, atol=1e-12)
    np.testing.assert_allclose(blended.psi, gait.psi, atol=1e-9)
    np.testing.assert_allclose(blended.torques, gait.torques, atol=1e-6)
    assert _single_support_residual(library, gait.speed) < 1e-8


def test_the_blend_goes_phase_by_phase_and_converges_at_second_order(library):
    """Halving the spacing (0.2 to 0.1 m/s) cuts the single support's residual about 4 times;
    a blend of the whole step in t / T misses the equations of motion 100 times more."""
    wide = GaitLibrary(library.gaits[::2], library.linkage, library.rate_hz)
    slow = GaitLibrary(library.gaits[:2], library.linkage, library.rate_hz)
    fast = GaitLibrary(library.gaits[1:], library.linkage, library.rate_hz)
    coarse = _single_support_residual(wide, 1.0)
    fine = max(_single_support_residual(slow, 0.95), _single_support_residual(fast, 1.05))
    assert 2.5 < coarse / fine < 6.0, (coarse, fine)
    whole_step = GaitLibrary(tuple(replace(g, segments=()) for g in slow.gaits),
                             library.linkage, library.rate_hz)  # fmt: skip
    assert _single_support_residual(whole_step, 0.95) > 50.0 * fine
    # the blend's heel strike: where its blended durations put it, the state before it the
    # blend of the two gaits' states before theirs
    blend = slow.at(0.95)
    durations = 0.5 * (slow.gaits[0].durations + slow.gaits[1].durations)
    event = blend.metadata["gait"]["before_events"][1]
    assert event["t"] == pytest.approx(float(np.sum(durations[:2])), abs=1e-12)
    first_double = int(np.argmax(np.asarray(blend.extras["double_support"][0]) > 0.5))
    assert blend.time[first_double] == pytest.approx(event["t"], abs=1e-12)
    np.testing.assert_allclose(
        event["x"], 0.5 * np.add(*(np.asarray(g.settings["before_events"][1]["x"])
                                   for g in slow.gaits)), atol=1e-12)  # fmt: skip


def test_solve_at_starts_each_phase_from_the_blend(library):
    blended = library.at(0.95)
    solved = library.solve_at(0.95)
    assert solved.verification.ok
    assert np.sum(solved.durations()) == pytest.approx(0.5 * np.sqrt(0.95) / 0.95, rel=1e-9)
    reference = solved.to_trajectory(library.rate_hz)
    drives = np.asarray(reference.torques)[:, 1:]
    # the blend is a few per cent of the drives' peaks away from the step solved there
    tau = np.linspace(0.0, 1.0, 401)

    def on(trajectory, values):
        own = np.asarray(trajectory.time) / trajectory.time[-1]
        return np.stack([np.interp(tau, own, values[:, j]) for j in range(values.shape[1])], 1)

    gap = on(blended, np.asarray(blended.torques)[:, 1:]) - on(reference, drives)
    assert np.sqrt(np.mean(gap**2)) < 0.1 * np.max(np.abs(drives))


def test_a_walk_takes_a_library_on_feet_only_on_feet(built, capsys):
    from problems.__main__ import main
    from problems.library import plan_sequence

    library, _, path = built
    with pytest.raises(DefinitionError, match="its gaits walk on feet; plan the walk on feet"):
        plan_sequence([0.0, 1.0, 0.0], library=library)
    code = main(["walk", "--speeds", "0,1.0,0", "--library", str(path)])
    assert code == 2
    assert "give --preset six-link-feet" in capsys.readouterr().err


@pytest.mark.slow
def test_a_walk_on_feet_from_the_library_walks_its_gaits(built, tmp_path, capsys):
    """`walk --preset six-link-feet --speeds 1.1,0.9 --library ...`: each speed's gait the
    library's own (its samples), the change between them, the file verified read back."""
    from model.linkage_trajectory import LinkageTrajectory
    from planner.trajectory import Trajectory
    from problems.__main__ import main

    library, _, path = built
    folder = tmp_path / "walk"
    code = main(["walk", "--preset", "six-link-feet", "--speeds", "1.1,0.9", "--library",
                 str(path), "--steps-at-speed", "1", "--no-plots",
                 "--output-dir", str(folder)])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert "steps verified: all checks passed" in out
    back = LinkageTrajectory.of(Trajectory.load(folder / "sequence.csv"))
    steps = back.metadata["sequence"]["steps"]
    assert steps[0]["kind"] == "gait" and steps[-1]["kind"] == "gait"
    # the first step is the library's gait at 1.1 m/s, sample for sample
    own = library.gaits[2]
    rows = np.flatnonzero(np.asarray(back.extras["step"][0]) == 0)
    time = np.asarray(back.time)[rows]
    for j in range(own.psi.shape[1]):
        np.testing.assert_allclose(np.asarray(back.psi)[rows, j],
                                   np.interp(time, own.time, own.psi[:, j]), atol=1e-4)  # fmt: skip


def test_a_version_1_file_still_loads(built, tmp_path):
    """A library written before the contact phases (point feet, version 1) loads as one."""
    _, _, path = built
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files if "_extra_" not in name}
    description = json.loads(str(arrays["library_json"]))
    description["version"] = 1
    for entry in description["gaits"]:
        for key in ("segments", "extras", "law"):
            entry.pop(key)
    arrays["library_json"] = np.array(json.dumps(description))
    old = tmp_path / "old.npz"
    np.savez(old, **arrays)
    loaded = GaitLibrary.load(old)
    assert not loaded.feet and loaded.gaits[0].segments == () and loaded.gaits[0].extras == {}


def test_bad_library_inputs_are_refused_naming_the_field(library):
    from problems.library import build_library

    with pytest.raises(DefinitionError, match=r"`feet`: True \(steps on feet\) or False"):
        build_library([1.0], feet="yes")
    a, b = library.gaits[:2]
    renamed = replace(b, segments=tuple(("toe", t) for _, t in b.segments))
    mixed = GaitLibrary((a, renamed), library.linkage, library.rate_hz)
    with pytest.raises(DefinitionError, match="walk other contact phases"):
        mixed.at(0.95)
    with pytest.raises(DefinitionError, match="`step_options`: the step walks"):
        library.solve_at(0.95, phases="flat-footed")
