"""The closed loop of a stop at quiet standing on feet (problems.control.feet_law.FeetLaw of a
stop, problems.control.mujoco_feet's stand, problems.library.feet_closed_loop): the stop
followed by the time, its gains blended into standing's, its last sample held.

Oracles: the plan's own samples (on the plan the law gives the plan's torques, at every
instant and after the end), the whole body's inertia about the stance ankle from the mass
matrix with every link above the foot turned at one rate (the standing damping's size),
finite differences of the law (its Jacobian), the smoothstep's closed form, the file's K
rows against the law at perturbed states, and MuJoCo: the walk ends standing, a push the
standing damping carries is not carried without it, and a fall in the stop is named."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import DefinitionError
from problems.control.feet_law import HELD, STAND_DAMPING, STAND_RAMP, FeetLaw, standing_gains
from problems.library.transition import plan_transition
from problems.walking.footed import footed_step_at


@pytest.fixture(scope="module")
def slow_and_stop():
    """The periodic step on feet at 0.6 m/s (joints bounded at 10 rad/s, as the walk command
    plans it) and its stop at quiet standing (one step)."""
    gait = footed_step_at(0.6, speed_limit=10.0).solve()
    transition = plan_transition(gait, "standing", steps=1)
    return gait, transition.gaits[0]


def test_a_stops_law_is_the_plan_by_the_time_and_holds_standing_after_it(slow_and_stop):
    """On the plan the law gives the plan's torques at every instant (no phase read: the
    stop's hip sways back and settles), and after the end the last sample's: standing held;
    one branch, indexed "time, then held"."""
    _, stop = slow_and_stop
    law = FeetLaw(stop)
    assert law.indexed_by == HELD and len(law.references) == len(law.branches) == 1
    samples = stop.to_trajectory(1000.0)
    times = samples.time - samples.time[0]
    for k in (0, 200, samples.time.size // 2, -60, -2, -1):
        x = np.r_[samples.psi[k], samples.dpsi[k]]
        np.testing.assert_allclose(law.torques(0, x, times[k])[1:], samples.torques[k][1:],
                                   rtol=0, atol=1e-9)  # fmt: skip
    last = np.r_[samples.psi[-1], samples.dpsi[-1]]
    for after in (0.01, 0.5, 3.0):
        np.testing.assert_allclose(law.torques(0, last, times[-1] + after)[1:],
                                   samples.torques[-1][1:], rtol=0, atol=1e-12)  # fmt: skip


def test_standing_damps_the_whole_bodys_sway_on_the_stance_ankle(slow_and_stop):
    """After the stop the stance ankle answers a rate of the stance shank (the body swaying
    on it) with 2 zeta sqrt(kp I) more than the walk's kd, I the whole body's inertia about
    that ankle: the mass matrix turned with every link but the stance foot at one rate; the
    other drives answer as the walk's PD; before the blend only the walk's PD acts."""
    _, stop = slow_and_stop
    problem = stop.problem
    law = FeetLaw(stop)
    names = problem.linkage.names
    n = len(names)
    ankle = names.index(problem.biped.stance_leg[1])
    samples = stop.to_trajectory(1000.0)
    T = samples.time[-1] - samples.time[0]
    x = np.r_[samples.psi[-1], samples.dpsi[-1]]
    body = np.ones(n)
    body[names.index(problem.biped.stance_leg[0])] = 0.0  # the foot stays, the rest turns
    inertia = np.mean([body @ problem.dynamics.mass_matrix(psi) @ body
                       for psi in law.references[0].states[:, :n]])  # fmt: skip
    kp, kd = law.gains[0][0][ankle], law.gains[0][1][ankle]
    assert kp == 1000.0 and inertia == pytest.approx(70.0, rel=0.1)  # the scene's body
    extra = 2.0 * STAND_DAMPING * np.sqrt(kp * inertia)
    delta = 1e-3
    turned = x.copy()
    turned[n + ankle] += delta  # the shank turns: its absolute rate and the ankle's relative
    change = (law.torques(0, turned, T + 0.2) - law.torques(0, x, T + 0.2)) / delta
    assert change[ankle] == pytest.approx(-(kd + extra), rel=1e-9)
    walk = law.torques(0, turned, T - 2 * STAND_RAMP) - law.torques(0, x, T - 2 * STAND_RAMP)
    assert walk[ankle] / delta == pytest.approx(-kd, rel=1e-9)
    # the knee's relative angle falls as the shank turns: its drive answers as the walk's PD
    knee = ankle + 1
    assert names[knee] == problem.biped.stance_leg[2]
    assert change[knee] == pytest.approx(law.gains[0][1][knee], rel=1e-9)
    # none of it: the walk's PD alone
    plain = FeetLaw(stop, stand_damping=0.0)
    none = (plain.torques(0, turned, T + 0.2) - plain.torques(0, x, T + 0.2)) / delta
    assert none[ankle] == pytest.approx(-kd, rel=1e-9)
    with pytest.raises(DefinitionError, match="stand_damping"):
        FeetLaw(stop, stand_damping=-0.1)


def test_the_blend_into_standing_is_a_smoothstep_and_its_jacobian_is_the_laws(slow_and_stop):
    """w(t) = 3 u^2 - 2 u^3 over the stop's last STAND_RAMP s (0 before, 1 after); the law's
    Jacobian against central differences at states off the plan, before, inside and after
    the blend."""
    _, stop = slow_and_stop
    law = FeetLaw(stop)
    (branch,) = law.branches
    samples = stop.to_trajectory(1000.0)
    T = samples.time[-1] - samples.time[0]
    u = np.array([0.0, 0.25, 0.5, 0.9, 1.0])
    t = T - STAND_RAMP + u * STAND_RAMP
    np.testing.assert_allclose(branch.weight(t), 3 * u**2 - 2 * u**3, rtol=0, atol=1e-12)
    assert branch.weight(T - 2 * STAND_RAMP) == 0.0 and branch.weight(T + 1.0) == 1.0
    rng = np.random.default_rng(3)
    n = stop.problem.linkage.n
    for when in (0.3 * T, T - 0.5 * STAND_RAMP, T + 0.3):
        k = min(round(when * 1000.0), samples.time.size - 1)
        x = np.r_[samples.psi[k], samples.dpsi[k]] + rng.normal(scale=0.02, size=2 * n)
        h = 1e-6
        numeric = np.column_stack([
            (branch.torques(when, x + h * e) - branch.torques(when, x - h * e)) / (2 * h)
            for e in np.eye(2 * n)
        ])  # fmt: skip
        np.testing.assert_allclose(branch.jacobian(when, x), numeric, rtol=1e-7, atol=1e-6)


def test_standing_gains_refuse_a_negative_damping():
    with pytest.raises(DefinitionError, match=r"stand_damping.*-1"):
        standing_gains(np.zeros((2, 4)), np.ones(2), 1, -1.0)


def test_the_walks_file_carries_the_stops_law_row_by_row(tmp_path):
    """plan_sequence([0.6, 0], feet=True) with its laws: the stop's rows are one branch
    (double_support 0), their phase column t / T, their K the law's (the file's torque at a
    perturbed state, M_ff - K dx, equals the law's), the last row's K standing's; the step's
    law in the sidecar says so (indexed "time, then held", held after the stop's duration);
    the file verifies read back."""
    from model.linkage_trajectory import LinkageTrajectory
    from planner.trajectory import Trajectory
    from problems.library import plan_sequence, verify_sequence
    from problems.library.feet_closed_loop import sequence_laws, with_feet_laws

    walk = plan_sequence([0.6, 0], feet=True, steps_at_speed=1, speed_limit=10.0)
    laws = sequence_laws(walk)
    assert [law.indexed_by for law in laws] == ["phase", HELD]
    path = tmp_path / "sequence.csv"
    with_feet_laws(walk, laws).save(path)
    back = LinkageTrajectory.of(Trajectory.load(path))
    assert verify_sequence(back, walk.linkage).ok
    entry = back.metadata["sequence"]["steps"][1]
    assert entry["law"]["indexed_by"] == HELD and "standing held" in entry["law"]["standing"]
    stop = walk.steps[1].gait
    assert entry["law"]["held_after_s"] == pytest.approx(laws[1].references[0].duration)
    assert "then held" in back.metadata["feedback"]["indexed_by"]
    names = walk.linkage.names
    n = len(names)
    states = [f"psi_{a}" for a in names] + [f"dpsi_{a}" for a in names]
    rows = np.flatnonzero(np.asarray(back.extras["step"][0]) == 1)
    assert not np.any(np.asarray(back.extras["double_support"][0])[rows])
    times = back.time[rows] - back.time[rows[0]]
    np.testing.assert_allclose(np.asarray(back.extras["phase"][0])[rows], times / times[-1],
                               atol=1e-9)  # fmt: skip
    rng = np.random.default_rng(11)
    for row in rows[[5, len(rows) // 2, -40, -1]]:
        gain = np.array([[back.extras[f"K_{a}__{s}"][0][row] for s in states] for a in names])
        x = np.r_[back.psi[row], back.dpsi[row]]
        off = rng.normal(scale=0.02, size=2 * n)
        t = back.time[row] - back.time[rows[0]]
        mine = back.torques[row] - gain @ off
        theirs = laws[1].torques(0, x + off, t)
        np.testing.assert_allclose(mine[1:], theirs[1:], rtol=1e-6, atol=1e-5)
    last = np.array([[back.extras[f"K_{a}__{s}"][0][rows[-1]] for s in states] for a in names])
    np.testing.assert_allclose(last[1:], laws[1].standing_gain[1:], rtol=1e-9, atol=1e-9)
    assert stop.problem.stop


def test_a_stop_on_feet_ends_standing_in_mujoco_and_a_fall_in_it_is_named(slow_and_stop):
    """Two steps of the 0.6 m/s gait then the stop, in MuJoCo: all three walked, the swing ball
    set down within 5 cm of the stance ball, the hip at rest after a second's stand; pushed
    10 N s forward in the stop it stands with the standing damping and is still swaying
    without it; pushed 10 N s back in the stop it falls, and the run says so, in the stop."""
    pytest.importorskip("mujoco")
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco

    run = _walks_the_stop(run_feet_steps_in_mujoco, *slow_and_stop)
    assert run.time[-1] == pytest.approx(sum(s.duration for s in run.steps), abs=2e-3)


def _walks_the_stop(walk, gait, stop):
    """The checks of a stop's walk both simulations pass (``walk``: MuJoCo's
    ``run_feet_steps_in_mujoco`` or ``simulate_feet_steps``): two steps of ``gait`` and the
    ``stop`` walked and stood, its swing ball beside the stance ball, its record spanning the
    stop and a second's stand; pushed 10 N s forward in the stop it stands with the standing
    damping and still sways without it; pushed 10 N s back it does not stand, in the stop.
    Returns the undisturbed run."""
    from problems.control.mujoco_feet import STAND_GAP
    from problems.control.simulation import Disturbances

    gaits = [gait, gait, stop]
    run = walk(gaits)
    assert (run.walked, run.fell) == (3, None)
    assert abs(run.steps[-1].length) < STAND_GAP
    # the stop's record spans the stop and a second's stand after it
    assert run.steps[-1].duration == pytest.approx(stop.duration + 1.0, abs=2e-3)
    forward = Disturbances(push=10.0, push_step=2)
    pushed = walk(gaits, disturbances=forward)
    assert pushed.fell is None, pushed.fell
    plain = [FeetLaw(gait), FeetLaw(gait), FeetLaw(stop, stand_damping=0.0)]
    undamped = walk(gaits, disturbances=forward, laws=plain)
    assert undamped.fell is not None and "still moving" in undamped.fell
    back = walk(gaits, disturbances=Disturbances(push=-10.0, push_step=2))
    assert back.fell is not None and back.fell.startswith("step 2")
    return run


def test_a_stop_ends_a_walk_in_mujoco(footed_gait):
    """A stop anywhere but last is refused by name, as is a stand that is not positive."""
    pytest.importorskip("mujoco")
    from dataclasses import replace

    from problems.control.mujoco_feet import run_feet_steps_in_mujoco
    from problems.walking.footed import FootedGait

    gait = footed_gait
    stop = FootedGait(replace(gait.problem, stop=True), gait.solution, 0.0)
    with pytest.raises(DefinitionError, match="step 0 of 2"):
        run_feet_steps_in_mujoco([stop, gait])
    with pytest.raises(DefinitionError, match="stand"):
        run_feet_steps_in_mujoco([gait], stand=0.0)


def test_a_stop_on_feet_ends_standing_in_the_products_simulation(slow_and_stop):
    """The same walk (two steps at 0.6 m/s, the stop) in the product's simulation on feet, as
    in MuJoCo: all three walked, the swing ball set down beside the stance ball, the hip at
    rest after the second's stand, the stop's record spanning the stop and the stand; pushed
    10 N s forward in the stop it stands with the standing damping and is still swaying
    without it; pushed 10 N s back in the stop it does not stand, and the run says so."""
    from problems.control.feet_simulation import simulate_feet_steps

    _walks_the_stop(simulate_feet_steps, *slow_and_stop)
