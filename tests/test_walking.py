"""The hybrid walking step (problems.walking.step) checked with code written another way.

Every property of the solved gaits is recomputed in numpy from the exported node trajectory
through ``reference.newton_euler`` and ``reference.gait_oracle`` (a dense KKT impact, the
leg swap written from the link names), never through the planner's constraint functions:
periodicity under impact and relabelling, the landing foot at rest, lift-off, the impulse and
the stance reaction in the friction cone, clearance, knee and posture limits, torque bounds,
and the exported torques against the oracle's inverse dynamics. The six-link preset, the
five-link biped without a head, two legs with no upper body and a branched upper body (torso,
head, two arms; these two at N = 12); mesh refinement; the law's cost as the benchmark.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from reference import gait_oracle as go
from reference import newton_euler as ne

import planner.phase_transcription as pt
from model import DefinitionError, DefinitionTypeError, Link, Linkage, LinkageTrajectory, presets
from planner import OCP, Transcription
from planner.sampled_limits import PASSIVE
from problems import (
    Biped,
    GaitVerificationError,
    WalkingGait,
    verify_gait,
    walking_step,
)

SIX = presets.six_link_anthropoid()
FIVE = presets.five_link_biped()
#: Two two-link legs meeting at the hip, nothing above it.
LEGS = SIX.drop("torso")
#: A branched upper body: the torso carries a head and two arms at the shoulder.
BRANCHED = Linkage(
    [
        *SIX.links,
        Link("left_arm", "torso", 0.6, 3.5, 0.45),
        Link("right_arm", "torso", 0.6, 3.5, 0.45),
    ]
)
LINKAGES = {"six": SIX, "five": FIVE, "legs": LEGS, "branched": BRANCHED}
#: The other upper bodies on a small mesh: the checks are the same, the solves cost less.
SMALL_N = {"legs": 12, "branched": 12}
BIPEDS = list(LINKAGES)


@functools.cache
def gait(linkage_name: str = "six", hold_limits: bool = True, **options) -> WalkingGait:
    """The step solved, its limits held at the samples and verified there; or, without
    ``hold_limits``, the transcription's own optimum (not verified: its samples may miss)."""
    if linkage_name in SMALL_N:
        options = {"N": SMALL_N[linkage_name], **options}
    step = walking_step(LINKAGES[linkage_name], **options)
    return step.solve(progress=False, hold_limits=hold_limits, verify=hold_limits)


def node_data(result: WalkingGait):
    trajectory = result.to_trajectory()
    return trajectory, trajectory.psi, trajectory.dpsi, trajectory.ddpsi, trajectory.torques


@pytest.mark.parametrize("name", BIPEDS)
def test_the_gait_is_periodic_through_impact_and_leg_swap(name):
    result = gait(name)
    linkage = result.problem.linkage
    _, psi, dpsi, _, _ = node_data(result)
    dpsi_plus, impulse, base = go.heel_strike(linkage, psi[-1], dpsi[-1])
    next_psi, next_dpsi = go.relabel(linkage, psi[-1], dpsi_plus)
    np.testing.assert_allclose(go.wrap(psi[0] - next_psi), 0.0, atol=1e-8)
    np.testing.assert_allclose(dpsi[0], next_dpsi, atol=1e-7)
    # The foot landed where it should, moving down; the old stance foot lifts off; the
    # impulse points into the ground inside the friction cone.
    foot = go.swing_foot(linkage, psi[-1])
    assert abs(foot - complex(result.problem.step_length, 0.0)) < 1e-8
    foot_velocity = ne.hinge_velocities(linkage, psi[-1], dpsi[-1])[
        linkage.index("swing_shank") + 1
    ]
    assert foot_velocity.imag <= 1e-8
    assert base.imag >= -1e-8
    mu = result.problem.mu
    assert impulse.imag > 0 and abs(impulse.real) <= mu * impulse.imag + 1e-8
    # The landing foot at rest after impact (floating base: H0 moves with `base`).
    i = linkage.index("swing_shank")
    _, after, _ = ne.point_kinematics(
        linkage, i, complex(linkage.links[i].length), psi[-1], dpsi_plus, np.zeros(linkage.n)
    )
    assert abs(after + base) < 1e-10


@pytest.mark.parametrize("name", BIPEDS)
def test_path_constraints_hold_node_by_node(name):
    result = gait(name)
    problem = result.problem
    linkage = problem.linkage
    trajectory, psi, dpsi, ddpsi, torques = node_data(result)
    weight = sum(link.mass for link in linkage.links) * linkage.gravity
    force = ne.ground_reaction(linkage, psi, dpsi, ddpsi)
    assert np.all(problem.mu * force.imag - np.abs(force.real) >= -1e-6 * weight)
    assert np.all(force.imag > 0)
    s = trajectory.time / trajectory.time[-1]
    profile = problem.clearance * np.sin(np.pi * s) ** 2
    assert np.all(go.swing_foot(linkage, psi).imag - profile >= -1e-8)
    names = linkage.names
    knees = np.column_stack(
        [
            psi[:, names.index("stance_thigh")] - psi[:, names.index("stance_shank")],
            psi[:, names.index("swing_thigh")] - psi[:, names.index("swing_shank")],
        ]
    )
    # IPOPT meets each scaled row to 1e-8 (tol); the knee rows are scaled by 2.5 rad.
    assert np.all(knees >= problem.knee_range[0] - 1e-7)
    assert np.all(knees <= problem.knee_range[1] + 1e-7)
    upright = [names.index(n) for n in problem.upright]
    assert len(upright) == linkage.n - 4  # default: every upper-body link (none for "legs")
    assert np.all(np.abs(psi[:, upright] - math.pi / 2) <= problem.posture + 1e-7)
    assert np.all(np.abs(torques) <= 150.0 + 1e-6)


@pytest.mark.parametrize("name", BIPEDS)
def test_exported_torques_are_the_oracle_inverse_dynamics(name):
    result = gait(name)
    linkage = result.problem.linkage
    _, psi, dpsi, ddpsi, torques = node_data(result)
    oracle = ne.inverse_dynamics(linkage, psi, dpsi, ddpsi)
    scale = np.max(np.abs(oracle))
    assert np.max(np.abs(torques - oracle)) <= 1e-8 * scale


def test_the_optimum_beats_the_law_and_the_law_is_its_guess():
    result = gait("six")
    assert result.success and result.solution.status == "Solve_Succeeded"
    assert result.cost < result.law_cost
    # The law's cost recomputed here: inverse dynamics along the law at the Hermite-Simpson
    # points of the mesh, Simpson's rule on each interval.
    problem = result.problem
    N, T = problem.ocp.N, problem.step_time
    h = T / N
    nodes = np.arange(N + 1) * h
    middles = nodes[:-1] + h / 2
    law = problem.law

    def effort(t):
        return np.sum(ne.inverse_dynamics(SIX, *law(t)) ** 2, axis=1)

    simpson = h / 6 * np.sum(effort(nodes[:-1]) + 4 * effort(middles) + effort(nodes[1:]))
    assert result.law_cost == pytest.approx(simpson, rel=1e-10)
    # The fitted law satisfies the step's periodicity exactly (zero rates at both ends).
    psi0, dpsi0, _ = law(0.0)
    psiT, dpsiT, _ = law(T)
    start, _ = go.relabel(SIX, psiT, dpsiT)
    np.testing.assert_allclose(go.wrap(psi0 - start), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.r_[dpsi0, dpsiT], 0.0, atol=1e-12)
    assert abs(go.swing_foot(SIX, psiT) - complex(problem.step_length, 0.0)) < 1e-12


def test_mesh_refinement_agrees_within_one_percent():
    costs = [gait("six", N=N).cost for N in (30, 60, 120)]
    assert max(costs) / min(costs) - 1.0 < 0.01, costs


@pytest.mark.parametrize(
    ("transcription", "degree", "formulation"),
    [
        ("trapezoid", None, "implicit"),
        ("radau", 3, "implicit"),
        ("hermite-simpson", None, "explicit"),
    ],
)
def test_other_transcriptions_and_the_explicit_formulation(transcription, degree, formulation):
    # The same optimum on the same mesh, or near it on another (the transcriptions' own
    # problems, without the limits held between the points: those differ with the motion)
    result = gait("six", False, transcription=transcription, degree=degree,
                  formulation=formulation)  # fmt: skip
    reference = gait("six", False)
    tolerance = 1e-6 if formulation == "explicit" else 0.01
    assert result.cost == pytest.approx(reference.cost, rel=tolerance)
    result = gait("six", transcription=transcription, degree=degree, formulation=formulation)
    assert result.verify().ok


def test_passive_ankle_and_other_objectives():
    passive = gait("six", passive=("stance_shank",))
    _, _, _, _, torques = node_data(passive)
    # At the nodes the motion's ankle torque is the NLP's 0 (to its dynamics tolerance);
    # between them what the motion needs of the unactuated ankle stays under PASSIVE of
    # the torque scale (the mesh is refined where it does not)
    np.testing.assert_allclose(torques[:, 0], 0.0, atol=1e-6)
    fine = passive.to_trajectory(rate_hz=2000.0).torques[:, 0]
    assert np.abs(fine).max() <= PASSIVE * passive.solution.ocp.variable_scale("M_stance_shank")
    assert passive.solution.N > 30  # it was: 3.1 N m at N = 30
    assert passive.cost > gait("six").cost  # a constraint more can only cost more
    assert passive.verify().ok
    rate = gait("six", objective="torque-rate")
    assert rate.verify().ok

    # Smoother commands: the torque profile's rates are smaller than the effort optimum's.
    def peak_rate(result):
        times, _, torques = result.fine()
        return np.max(np.abs(np.diff(torques, axis=0) / np.diff(times)[:, None]))

    assert peak_rate(rate) < 0.5 * peak_rate(gait("six"))


def test_cost_of_transport_speed_and_world_motion():
    result = gait("six")
    problem = result.problem
    assert result.speed == pytest.approx(problem.step_length / problem.step_time)
    # Positive work recomputed from the node trajectory, by hand (coarser grid).
    times, states, torques = result.fine(4001)
    n = SIX.n
    rates = states[:, n:].copy()
    for i, p in enumerate(SIX.parents):
        if p >= 0:
            rates[:, i] -= states[:, n + p]
    work = np.trapezoid(np.maximum(torques * rates, 0).sum(axis=1), times)
    assert result.positive_work == pytest.approx(work, rel=1e-3)
    weight = sum(link.mass for link in SIX.links) * SIX.gravity
    assert result.cost_of_transport == pytest.approx(
        result.positive_work / (weight * problem.step_length)
    )
    motion = result.world(steps=3, rate_hz=50)
    assert motion.time[0] == 0.0 and motion.time[-1] == pytest.approx(3 * problem.step_time)
    assert np.all(np.diff(motion.time) > 0)
    np.testing.assert_allclose(motion.footholds.real, [0.0, 0.5, 1.0, 1.5])
    # Each body is in one place at the junction of two steps: the same physical leg, seen
    # from both sides of a heel strike.
    for name, segment in motion.segments.items():
        jumps = np.abs(np.diff(segment, axis=0)).max(axis=1)
        assert np.max(jumps) < 0.1, name
    # The stance foot of step k stands at k s: step 1's stance leg is the first swing leg.
    second = motion.step == 1
    foot_of = motion.segments["swing_shank"][second]
    ends = np.concatenate([foot_of[:, 0], foot_of[:, 1]])
    assert np.min(np.abs(ends - 0.5)) < 1e-12


def test_verify_gait_finds_what_is_wrong_node_by_node():
    result = gait("six")
    trajectory = result.to_trajectory()
    assert verify_gait(trajectory, SIX).ok
    # Torques over the limit at node 7, by 5 N m.
    torques = trajectory.torques.copy()
    torques[7, 2] = 155.0
    broken = LinkageTrajectory.from_linkage(
        trajectory.time,
        trajectory.psi,
        trajectory.dpsi,
        torques,
        SIX.names,
        ddpsi=trajectory.ddpsi,
        metadata=trajectory.metadata,
    )
    report = verify_gait(broken, SIX)
    # the torque no longer matches the motion either
    assert not report.ok and [c.name for c in report.failures] == ["dynamics", "torque bounds"]
    check = report["torque bounds"]
    assert check.where == f"sample 7 (t = {trajectory.time[7]:.4g} s)"
    assert check.margin == pytest.approx(-5.0)
    with pytest.raises(GaitVerificationError, match=r"torque bounds misses by 5 N m at sample 7"):
        report.raise_if_failed()
    # A start that does not follow from the heel strike: the momentum check fails too.
    dpsi = trajectory.dpsi.copy()
    dpsi[0, 3] += 0.5
    shifted = LinkageTrajectory.from_linkage(
        trajectory.time, trajectory.psi, dpsi, trajectory.torques, SIX.names,
        ddpsi=trajectory.ddpsi, metadata=trajectory.metadata,
    )  # fmt: skip
    failed = {c.name for c in verify_gait(shifted, SIX).failures}
    assert "impact momentum" in failed
    # A file read back verifies the same.
    path = result.to_trajectory().save(pytest.importorskip("pathlib").Path("gait_check.npz"))
    try:
        assert verify_gait(LinkageTrajectory.load(path), SIX).ok
    finally:
        path.unlink()


def raised_profile(s):
    """A clearance profile other than the default (numpy or SX): 7 cm at mid-swing, flat at
    both ends, m."""
    return 1.12 * s**2 * (1.0 - s) ** 2


def with_settings(trajectory, **gait):
    metadata = {**trajectory.metadata, "gait": {**trajectory.metadata["gait"], **gait}}
    return LinkageTrajectory.from_linkage(
        trajectory.time, trajectory.psi, trajectory.dpsi, trajectory.torques,
        trajectory.link_names, ddpsi=trajectory.ddpsi, metadata=metadata,
    )  # fmt: skip


def test_a_callable_clearance_profile_travels_with_the_gait_and_is_verified(tmp_path):
    result = walking_step(N=16, clearance=raised_profile).solve(progress=False)
    trajectory = result.to_trajectory()
    s = trajectory.time / trajectory.time[-1]
    # The oracle: the swing foot above the profile at every node (the planner's rows).
    height = go.swing_foot(SIX, trajectory.psi).imag
    margin = height - raised_profile(s)
    assert np.all(margin >= -1e-8), margin
    # The profile travels as data at the exported samples, written from the callable.
    table = trajectory.metadata["gait"]["clearance_profile"]
    np.testing.assert_allclose(table["s"], s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(table["height"], raised_profile(s), rtol=0, atol=1e-15)
    report = verify_gait(trajectory, SIX)
    assert report.ok, str(report)
    assert report["clearance"].margin == pytest.approx(margin.min(), abs=1e-12)
    # A profile the gait misses at one node: reported there, by the amount it misses.
    node = 5
    bumped = raised_profile(s)
    bumped[node] = height[node] + 0.01
    report = verify_gait(with_settings(trajectory, clearance_profile={"s": s.tolist(),
                                                                     "height": bumped.tolist()}),
                         SIX)  # fmt: skip
    assert [c.name for c in report.failures] == ["clearance"]
    assert report["clearance"].where == f"sample {node} (t = {trajectory.time[node]:.4g} s)"
    assert report["clearance"].margin == pytest.approx(-0.01, abs=1e-12)
    with pytest.raises(
        GaitVerificationError, match=rf"clearance misses by 0.01 m at sample {node}"
    ):
        report.raise_if_failed()
    # Twice as high: the worst node is where the oracle says, not where height >= 0 would.
    doubled = {"s": s.tolist(), "height": (2.0 * raised_profile(s)).tolist()}
    report = verify_gait(trajectory, SIX, settings={"clearance_profile": doubled})
    worst = int(np.argmin(height - 2.0 * raised_profile(s)))
    assert report["clearance"].where.startswith(f"sample {worst} ")
    assert report["clearance"].margin == pytest.approx(
        np.min(height - 2.0 * raised_profile(s)), abs=1e-12
    )
    # At another rate the table is sampled there (path rows hold at the dynamics points
    # only, so between nodes the foot may dip below the profile by the collocation error:
    # the check then reports the oracle's margin at those samples).
    fine = result.to_trajectory(rate_hz=200)
    s_fine = fine.time / fine.time[-1]
    np.testing.assert_allclose(
        fine.metadata["gait"]["clearance_profile"]["height"], raised_profile(s_fine), atol=1e-15
    )
    oracle = go.swing_foot(SIX, fine.psi).imag - raised_profile(s_fine)
    assert verify_gait(fine, SIX)["clearance"].margin == pytest.approx(oracle.min(), abs=1e-12)
    # A file read back carries the profile.
    for suffix in ("json", "csv", "npz"):
        loaded = LinkageTrajectory.load(trajectory.save(tmp_path / f"profile.{suffix}"))
        assert loaded.metadata["gait"]["clearance_profile"] == table, suffix
        assert verify_gait(loaded, SIX).ok, suffix
    assert result.problem.settings()["clearance"] is None
    # A malformed or too short table is refused, naming the field.
    with pytest.raises(DefinitionError, match=r"`settings\['clearance_profile'\]`: 's' and"):
        verify_gait(trajectory, SIX, settings={"clearance_profile": {"s": [0, 1], "height": [0]}})
    with pytest.raises(DefinitionError, match=r"it covers s in \[0, 0.5\]"):
        verify_gait(
            trajectory, SIX, settings={"clearance_profile": {"s": [0, 0.5], "height": [0, 0]}}
        )


def test_the_ocp_is_a_value_the_user_can_change():
    step = walking_step(N=20)
    tighter = step.ocp.bound("M", -40.0, 40.0)
    assert isinstance(tighter, OCP) and step.ocp.N == 20
    result = step.solve(tighter, progress=False)
    _, _, _, _, torques = node_data(result)
    assert np.max(np.abs(torques)) <= 40.0 + 1e-6
    assert result.cost >= step.solve(progress=False).cost - 1e-9
    finer = step.solve(step.ocp.refine(N=40).guess(result.solution), progress=False)
    assert finer.solution.N == 40 and finer.verify().ok


def test_biped_detection_and_the_law_fit():
    biped = Biped.of(SIX)
    assert (biped.stance_shank, biped.stance_thigh, biped.swing_thigh, biped.swing_shank) == (
        "stance_shank",
        "stance_thigh",
        "swing_thigh",
        "swing_shank",
    )
    assert biped.upper_body == ("torso", "head")
    assert Biped.of(LEGS).upper_body == ()
    assert Biped.of(BRANCHED).upper_body == ("torso", "head", "left_arm", "right_arm")
    # Inverse kinematics: the feet where asked, knees ahead of the legs.
    psi = biped.posture(complex(0.2, 0.8), complex(0.45, 0.0))
    hinges = ne.hinge_positions(SIX, psi)
    assert abs(hinges[2] - complex(0.2, 0.8)) < 1e-12
    assert abs(hinges[4] - complex(0.45, 0.0)) < 1e-12
    assert psi[1] - psi[0] > 0 and psi[2] - psi[3] > 0


def test_bad_walking_input_is_refused():
    with pytest.raises(DefinitionError, match=r"swap_legs needs a biped"):
        walking_step(presets.exoskeleton_leg())
    with pytest.raises(DefinitionError, match=r"`step_length`: 2 m is too long for legs of 0.86 m"):
        walking_step(step_length=2.0)
    with pytest.raises(DefinitionError, match=r"`step_time`: must be > 0 s, got -0.5"):
        walking_step(step_time=-0.5)
    with pytest.raises(DefinitionError, match=r"`mu`: the friction coefficient must be > 0"):
        walking_step(mu=0.0)
    with pytest.raises(DefinitionError, match=r"`objective`: unknown 'speed'"):
        walking_step(objective="speed")
    with pytest.raises(DefinitionError, match=r"`passive`: no link called 'ankle'"):
        walking_step(passive=("ankle",))
    with pytest.raises(DefinitionError, match=r"`torque_limit`: give a limit for every link"):
        walking_step(torque_limit={"torso": 100.0})
    with pytest.raises(DefinitionError, match=r"`torque_limit`: must be > 0 N m, got -1.0"):
        walking_step(torque_limit=-1.0)
    with pytest.raises(DefinitionError, match=r"`knee_range`: lower must be < upper"):
        walking_step(knee_range=(1.0, 0.5))
    with pytest.raises(DefinitionError, match=r"`clearance`: must be >= 0 m"):
        walking_step(clearance=-0.01)
    with pytest.raises(DefinitionError, match=r"`along`|`step_length`: must be finite"):
        walking_step(step_length=float("nan"))
    with pytest.raises(DefinitionTypeError, match=r"`ocp`: must be a planner.OCP"):
        walking_step(N=4).solve("ocp")
    lopsided = presets.six_link_anthropoid(swing_thigh_length=0.5)
    with pytest.raises(DefinitionError, match=r"swing_thigh\.length = 0\.5 m differs"):
        walking_step(lopsided)
    # a shank and a thigh read as a compass walker whose one-link legs differ
    one_leg = Linkage([Link("shank", None, 0.4, 3.0), Link("thigh", "shank", 0.4, 7.0)])
    with pytest.raises(DefinitionError, match=r"the legs are not mirror images"):
        walking_step(one_leg)
    with pytest.raises(DefinitionError, match=r"swap_legs needs a biped: .* has 0 children"):
        walking_step(Linkage([Link("pole", None, 1.0, 5.0)]))


# ---- a double support between the steps (planner.Phases) ---------------------------------------
@functools.cache
def double(N_double: int | None = None) -> WalkingGait:
    """The step with a 0.1 s double support; on a mesh given here (a convergence study)
    not verified: the coarsest lets the front foot drift past the check's 1 mm/s."""
    step = walking_step(double_support=0.1, N_double=N_double)
    return step.solve(progress=False, verify=N_double is None)


def test_double_support_is_periodic_through_the_held_impact_and_the_swap():
    result = double()
    single, both = result.solution.phases
    assert result.success and result.cost < result.law_cost
    assert single.T == pytest.approx(0.4) and both.T == pytest.approx(0.1)
    n = SIX.n
    # The impact with both feet held: the fixed-base dense KKT of the oracle.
    psi, dpsi = single.states[-1, :n], single.states[-1, n:]
    i = SIX.index("swing_shank")
    mass = ne.mass_matrix(SIX, psi)
    jacobian = ne.point_jacobian(SIX, i, complex(SIX.links[i].length), psi)[:, 2:]
    kkt = np.block([[mass, -jacobian.T], [jacobian, np.zeros((2, 2))]])
    after = np.linalg.solve(kkt, np.r_[mass @ dpsi, 0.0, 0.0])
    np.testing.assert_allclose(both.states[0, :n], psi, atol=1e-9)
    np.testing.assert_allclose(both.states[0, n:], after[:n], atol=1e-7)
    # The rear foot can only push: its impulse (what the momentum change leaves) in its cone.
    masses = np.array([link.mass for link in SIX.links])
    change = (ne.com_velocities(SIX, psi, after[:n]) - ne.com_velocities(SIX, psi, dpsi)) @ masses
    rear = change - complex(*after[n:])
    # (IPOPT meets the impulse rows, scaled by m * 1 m/s = 60 N s, to 1e-8: 6e-7 N s.)
    assert rear.imag >= -1e-6 and abs(rear.real) <= 0.8 * rear.imag + 1e-6
    # The legs swap when the double support ends, without an impact.
    next_psi, next_dpsi = go.relabel(SIX, both.states[-1, :n], both.states[-1, n:])
    np.testing.assert_allclose(go.wrap(single.states[0, :n] - next_psi), 0.0, atol=1e-8)
    np.testing.assert_allclose(single.states[0, n:], next_dpsi, atol=1e-7)


def test_double_support_dynamics_forces_and_cones_with_the_oracle():
    result = double()
    both = result.solution.phase("double")
    trajectory = both.to_trajectory()
    n = SIX.n
    psi, dpsi, ddpsi, torques = (
        trajectory.psi,
        trajectory.dpsi,
        trajectory.ddpsi,
        trajectory.torques,
    )
    force = (
        trajectory.extras["F_swing_shank_end_x"][0]
        + 1j * trajectory.extras["F_swing_shank_end_y"][0]
    )
    # The oracle's generalised forces with the foot's ground force: (I - C)(ID - M) = J^T F.
    i = SIX.index("swing_shank")
    jacobian = ne.point_jacobian(SIX, i, complex(SIX.links[i].length), psi)[:, :, 2:]
    gap = ne.inverse_dynamics(SIX, psi, dpsi, ddpsi) - torques
    children = np.zeros((n, n))
    for c, p in enumerate(SIX.parents):
        if p >= 0:
            children[p, c] = 1.0
    generalized = gap @ (np.eye(n) - children).T
    applied = np.einsum("kij,ki->kj", jacobian, np.column_stack([force.real, force.imag]))
    np.testing.assert_allclose(generalized, applied, atol=1e-7 * np.max(np.abs(applied)))
    rear = ne.ground_reaction(SIX, psi, dpsi, ddpsi) - force
    weight = sum(link.mass for link in SIX.links) * SIX.gravity
    for f in (rear, force):
        assert np.all(0.8 * f.imag - np.abs(f.real) >= -1e-6 * weight)


def test_double_support_foot_drift_converges_at_fourth_order():
    # The front foot is held through its acceleration: its position drifts with the
    # collocation error only.
    meshes = (8, 16, 24)  # 32 costs 66 s of hold rounds on this step, 24 four
    drift = []
    for N_double in meshes:
        result = double(N_double)
        both = result.solution.phase("double")
        foot = go.swing_foot(SIX, both.state(np.linspace(0.0, both.T, 101))[:, : SIX.n])
        drift.append(np.max(np.abs(foot - 0.5)))
    order = -np.polyfit(np.log(meshes), np.log(drift), 1)[0]
    assert drift[0] < 2e-4 and order > 3.3, (drift, order)


def test_double_support_gait_verifies_and_exports_one_step():
    result = double()
    report = result.verify()
    assert report.ok, str(report)
    assert {"periodic rates", "impact pose", "impulse cones", "foot held"} <= {
        c.name for c in report.checks
    }
    trajectory = result.to_trajectory(rate_hz=1000)
    assert trajectory.time[-1] == pytest.approx(0.5)
    events = trajectory.metadata["gait"]["before_events"]
    assert events[0]["t"] == pytest.approx(0.4)
    # In single support the front foot bears nothing.
    front = trajectory.extras["F_swing_shank_end_y"][0]
    assert np.all(front[trajectory.time < 0.4 - 1e-9] == 0.0)
    assert np.min(front[trajectory.time > 0.4 + 1e-9]) > 0.0
    with pytest.raises(DefinitionError, match=r"`double_support`: must lie in \[0, step_time\)"):
        walking_step(double_support=0.5)


# ---- a plan a robot can execute: the body above the ground, a sole, a decisive touchdown --
def _samples(result, rate_hz=2000.0):
    return result.to_trajectory(rate_hz)


def test_every_point_of_the_body_stays_above_the_ground_at_every_sample():
    # the oracle: every hinge and link end from the Newton-Euler oracle's hinge positions
    for length in (0.5, 1.0):  # the default, and the step whose knees went under the ground
        result = gait("six", step_length=length)
        trajectory = _samples(result)
        hinges = ne.hinge_positions(SIX, trajectory.psi)  # (K, n + 1): H0 then each end
        swing_foot = 1 + SIX.index("swing_shank")
        heights = np.delete(hinges.imag, [0, swing_foot], axis=1)
        assert heights.min() >= -1e-6, (length, heights.min())
    # the points and a margin are the user's to choose
    raised = gait("six", ground_margin=0.3)
    heights = ne.hinge_positions(SIX, _samples(raised).psi).imag
    knees = [1 + SIX.index("stance_shank"), 1 + SIX.index("swing_thigh")]
    assert heights[:, knees].min() >= 0.3 - 1e-6
    step = walking_step(ground_points=("head",))
    assert step.ground_points == ("head",)
    with pytest.raises(DefinitionError, match=r"`ground_points`: 'swing_shank' ends in the swing"):
        walking_step(ground_points=("swing_shank",))
    with pytest.raises(DefinitionError, match=r"`ground_margin`: must be >= 0 m"):
        walking_step(ground_margin=-0.1)


def test_the_default_step_is_not_changed_by_the_ground_rows():
    # the ground rows are inactive on the default step: the same optimum without them
    unheld = {"progress": False, "hold_limits": False, "verify": False}
    without = walking_step(ground_points=()).solve(**unheld)
    with_rows = walking_step().solve(**unheld)
    assert with_rows.cost == pytest.approx(without.cost, rel=1e-7)


def test_the_ankle_torque_keeps_its_centre_of_pressure_on_the_sole():
    result = gait("six")
    trajectory = _samples(result)
    force = ne.ground_reaction(SIX, trajectory.psi, trajectory.dpsi, trajectory.ddpsi)
    pressure = trajectory.torques[:, 0] / force.imag  # M / Fy from the ankle
    heel, toe = result.problem.foot_sole
    assert (heel, toe) == pytest.approx((0.05, 0.15))  # 0.86 m legs
    assert pressure.min() >= -heel - 1e-6 and pressure.max() <= toe + 1e-6
    # the file states it per sample
    np.testing.assert_allclose(trajectory.extras["CoP_stance_shank_start_x"][0], pressure,
                               rtol=1e-10, atol=1e-12)  # fmt: skip
    low, high = result.centre_of_pressure(2000.0)
    assert (low, high) == pytest.approx((pressure.min(), pressure.max()), abs=1e-9)
    # a shorter sole: the plan keeps its pressure on it
    short = gait("six", foot=(0.02, 0.05))
    short_pressure = short.centre_of_pressure(2000.0)
    assert -0.02 - 1e-6 <= short_pressure[0] and short_pressure[1] <= 0.05 + 1e-6
    assert short.cost > result.cost
    with pytest.raises(DefinitionError, match=r"`foot`: heel and toe must be >= 0 m"):
        walking_step(foot=(-0.1, 0.1))
    with pytest.raises(DefinitionError, match=r"`foot`: give \(heel, toe\)"):
        walking_step(foot=(0.1,))


def test_the_landing_foot_comes_down_decisively():
    # The grazing step: at most 1 mm up for the last 20 ms, coming down at 0.05-0.10 m/s, so
    # that a millimetre of error moved the touchdown by 10-30 ms. Now: at least 0.3 m/s at
    # heel strike, and above the line coming down at 0.3 m/s in the last instants.
    grazing = gait("six", touchdown_speed=0.0)
    result = gait("six")
    for plan, decisive in ((grazing, False), (result, True)):
        trajectory = _samples(plan, 5000.0)
        foot = go.swing_foot(SIX, trajectory.psi)
        left = trajectory.time[-1] - trajectory.time
        velocity = plan.touchdown_velocity
        if decisive:
            assert velocity.imag <= -0.3 + 1e-6
            window = left <= 0.02
            assert np.all(
                foot.imag[window]
                >= 0.3 * left[window] * np.exp(-((left[window] / 0.03) ** 4)) - 1e-6
            )
            # a foot 1 mm low touches down within a few ms of T
            early = left[np.flatnonzero(foot.imag >= 1e-3)[-1]]
            assert early <= 0.004
        else:
            assert -0.15 < velocity.imag < 0.0
            assert foot.imag[left <= 0.02].max() < 1.5e-3
    # the touchdown's cost: a few percent
    assert result.cost < 1.05 * grazing.cost
    with pytest.raises(DefinitionError, match=r"`touchdown_speed`: the landing foot's downward"):
        walking_step(touchdown_speed=-0.1)


def test_the_defaults_follow_the_legs_in_any_units():
    mm = walking_step(SIX.in_units(length=1e3, mass=1e3), 500.0, 0.5, clearance=50.0,
                      torque_limit=150e9)  # fmt: skip
    assert mm.touchdown_speed == pytest.approx(300.0)
    assert mm.foot_sole == pytest.approx((50.0, 150.0))


def test_contact_forces_are_named_after_their_contact():
    single = gait("six").to_trajectory()
    assert {"F_stance_shank_start_x", "F_stance_shank_start_y"} <= set(single.extras)
    assert not any(name in single.extras for name in ("Fx", "Fy"))
    double = walking_step(double_support=0.1, N=20).solve(progress=False).to_trajectory()
    assert {"F_stance_shank_start_x", "F_swing_shank_end_x", "F_swing_shank_end_y"} <= set(
        double.extras
    )


def test_rows_that_read_the_same_reaction_share_its_evaluation(monkeypatch):
    """The friction cone and the centre of pressure both read the stance foot's ground
    reaction (the whole tree's dynamics): the point function merges them, with the same
    values at a random point, in fewer operations than the rows built apart."""
    ocp = walking_step(N=4).ocp
    functions = {}
    for merge in (False, True):
        monkeypatch.setattr(pt, "MERGE_POINT_EXPRESSIONS", merge)
        functions[merge] = Transcription(ocp).phases[0].point_function
    rng = np.random.default_rng(7)
    inputs = [
        rng.uniform(-1.0, 1.0, functions[True].size_in(i)) for i in range(functions[True].n_in())
    ]
    for apart, merged in zip(functions[False](*inputs), functions[True](*inputs), strict=True):
        np.testing.assert_allclose(np.asarray(merged), np.asarray(apart), rtol=1e-12, atol=1e-12)
    assert functions[True].n_instructions() < 0.8 * functions[False].n_instructions()


def test_steps_of_other_lengths_and_times_share_one_nlp_structure():
    """The step's length and duration enter its NLP as bounds and parameters only, so that a
    study over lengths and speeds solves one structure (one cached solver, one compiled
    library): the clearance's approach term reads the OCP's duration symbol, not a number."""
    keys = {
        Transcription(walking_step(step_length=length, step_time=time).ocp).structure_key
        for length, time in ((0.5, 0.5), (0.35, 0.5), (0.5, 0.65), (0.62, 0.42))
    }
    assert len(keys) == 1
    # ... and the key does see what is structure: another clearance height is a constant
    # inside an expression
    other = Transcription(walking_step(clearance=0.08).ocp).structure_key
    assert other not in keys


def test_a_lifted_clearance_floor_starts_flat_and_joins_the_plain_one():
    """clearance_profile(..., lift): its second derivative at t = 0 is 0 (central differences
    of the numpy and CasADi forms), where the plain floor's is 2 h pi^2 / T^2 (closed form);
    past a few lift times it is the plain floor; the verification's floor is the same."""
    import casadi as ca

    from problems.gait.verification import _clearance_profile
    from problems.walking.step import clearance_profile

    T, h, lift = 0.4, 0.05, 0.05
    plain = functools.partial(clearance_profile, T=T, height=h, touchdown_speed=0.0, window=0.03)
    lifted = functools.partial(plain, lift=lift)
    dt = 1e-4

    def curvature(floor):  # f'' at 0 by a one-sided second difference (f(0) = 0 = f'(0))
        return float(2.0 * (floor(np.array(dt / T)) - floor(np.array(0.0))) / dt**2)

    assert curvature(plain) == pytest.approx(2.0 * h * math.pi**2 / T**2, rel=1e-3)
    assert abs(curvature(lifted)) < 1e-3 * 2.0 * h * math.pi**2 / T**2
    s = np.linspace(0.0, 1.0, 41)
    symbol = ca.SX.sym("s")
    as_sx = ca.Function("floor", [symbol], [lifted(symbol)])
    np.testing.assert_allclose(np.ravel(as_sx(s)), lifted(s), rtol=0, atol=1e-15)
    late = s * T > 4.0 * lift
    np.testing.assert_allclose(lifted(s)[late], plain(s)[late], rtol=0, atol=h * np.exp(-16))
    settings = {"clearance": h, "step_time": T, "lift_time": lift}
    np.testing.assert_allclose(_clearance_profile(settings, s), lifted(s), rtol=0, atol=1e-15)
    with pytest.raises(DefinitionError, match="'lift_time' needs the single support's duration"):
        _clearance_profile({"clearance": h, "lift_time": lift}, s)


def test_a_landed_clearance_floor_ends_flat_and_mirrors_the_lifted_one():
    """clearance_profile(..., land): the lifted floor mirrored in time (h sin^2 is symmetric
    about s = 1/2, so land at s is lift at 1 - s, without the approach term); its second
    derivative at t = T is 0 where the plain floor's is 2 h pi^2 / T^2; both together; the
    verification's floor reads ``land_time``."""
    import casadi as ca

    from problems.gait.verification import _clearance_profile
    from problems.walking.step import clearance_profile

    T, h, land = 0.4, 0.05, 0.05
    plain = functools.partial(clearance_profile, T=T, height=h, touchdown_speed=0.0, window=0.03)
    s = np.linspace(0.0, 1.0, 41)
    np.testing.assert_allclose(plain(s, land=land), plain(1.0 - s, lift=land), rtol=0,
                               atol=1e-15)  # fmt: skip
    dt = 1e-4

    def curvature(floor):  # f'' at T by a one-sided second difference (f(T) = 0 = f'(T))
        return float(2.0 * (floor(np.array(1.0 - dt / T)) - floor(np.array(1.0))) / dt**2)

    assert curvature(plain) == pytest.approx(2.0 * h * math.pi**2 / T**2, rel=1e-3)
    assert abs(curvature(functools.partial(plain, land=land))) < 1e-3 * 2.0 * h * math.pi**2 / T**2
    both = plain(s, lift=land, land=land)
    np.testing.assert_allclose(both, plain(s) * (1 - np.exp(-((s * T / land) ** 2)))
                               * (1 - np.exp(-(((1 - s) * T / land) ** 2))), rtol=0,
                               atol=1e-15)  # fmt: skip
    symbol = ca.SX.sym("s")
    as_sx = ca.Function("floor", [symbol], [plain(symbol, lift=land, land=land)])
    np.testing.assert_allclose(np.ravel(as_sx(s)), both, rtol=0, atol=1e-15)
    settings = {"clearance": h, "step_time": T, "lift_time": land, "land_time": land}
    np.testing.assert_allclose(_clearance_profile(settings, s), both, rtol=0, atol=1e-15)
    with pytest.raises(DefinitionError, match="'land_time' needs the single support's duration"):
        _clearance_profile({"clearance": h, "land_time": land}, s)
    with pytest.raises(DefinitionError, match="`land_time`: must be >= 0 s"):
        walking_step(land_time=-0.01)
