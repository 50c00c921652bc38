"""model.linkage_trajectory: a trajectory read in the linkage convention (``from_linkage``,
the views psi, dpsi, torques, ddpsi, ground_reaction), and its refusal of a trajectory that
does not follow it. The generic Trajectory's own tests are tests/test_trajectory.py, whose
builders these use."""

from __future__ import annotations

import numpy as np
import pytest
from test_trajectory import LINKS, T4, generic_trajectory, linkage_trajectory

from model import LinkageTrajectory
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import TrajectoryError


def test_from_linkage_builds_the_convention():
    traj = linkage_trajectory()
    n = len(LINKS)
    assert traj.state_names == tuple(f"psi_{v}" for v in LINKS) + tuple(f"dpsi_{v}" for v in LINKS)
    assert traj.state_units == ("rad",) * n + ("rad/s",) * n
    assert traj.control_names == tuple(f"M_{v}" for v in LINKS)
    assert traj.control_units == ("N m",) * n
    assert [(name, unit) for name, (_, unit) in traj.extras.items()] == [
        *((f"ddpsi_{v}", "rad/s^2") for v in LINKS),
        (f"F_{LINKS[0]}_start_x", "N"),  # the contact at H0: the root's start
        (f"F_{LINKS[0]}_start_y", "N"),
    ]
    assert traj.is_linkage and traj.link_names == LINKS
    assert traj.psi.shape == traj.dpsi.shape == traj.torques.shape == traj.ddpsi.shape == (41, n)
    np.testing.assert_array_equal(traj.dpsi, traj.states[:, n:])
    assert traj.ground_reaction.dtype.kind == "c"
    np.testing.assert_array_equal(traj.ground_reaction.imag, traj.extras["F_shank_start_y"][0])
    # numpy scalars and tuples in the metadata become JSON types on the way in
    assert traj.metadata == {"source": "test", "N": 40, "cost": 0.1, "v": [1, 2]}
    assert type(traj.metadata["N"]) is int
    assert traj.hermite_states == traj.state_names
    assert "41 samples" in repr(traj)


def test_ground_reaction_as_real_columns_and_arrays_read_only():
    t = np.linspace(0.0, 1.0, 5)
    one = np.ones((5, 1))
    traj = LinkageTrajectory.from_linkage(t, one, one, one, ["a"], ground_reaction=np.c_[t, 2 * t])
    np.testing.assert_array_equal(traj.ground_reaction, t + 2j * t)
    with pytest.raises(ValueError, match="read-only"):
        traj.states[0, 0] = 1.0
    with pytest.raises(AttributeError):
        traj.time = t  # frozen
    assert not traj.time.flags.writeable and not traj.extras["F_a_start_x"][0].flags.writeable


def test_linkage_properties_refuse_a_generic_trajectory():
    generic = generic_trajectory()
    # the planner's trajectory knows no linkage; the model's view of it reads the convention
    assert not any(hasattr(generic, name) for name in ("psi", "torques", "is_linkage"))
    traj = LinkageTrajectory.of(generic)
    assert not traj.is_linkage and traj == generic
    for name in ("psi", "dpsi", "torques", "ddpsi", "link_names", "ground_reaction"):
        with pytest.raises(TrajectoryError, match=rf"`{name}`: this trajectory does not follow"):
            getattr(traj, name)


def test_missing_linkage_extras_are_named():
    traj = linkage_trajectory(extras=False)
    with pytest.raises(TrajectoryError, match=r"`ddpsi`: .*missing extras \['ddpsi_shank'"):
        _ = traj.ddpsi
    with pytest.raises(TrajectoryError, match=r"`ground_reaction`: .*pass ground_reaction="):
        _ = traj.ground_reaction
    renamed = LinkageTrajectory(
        traj.time,
        traj.states,
        traj.controls,
        traj.state_names,
        traj.state_units,
        ("T1", "T2", "T3"),
        ("N m",) * 3,
    )
    assert renamed.link_names == LINKS
    with pytest.raises(TrajectoryError, match=r"`torques`: the controls must be \['M_shank'"):
        _ = renamed.torques


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"names": "abc"}, DefinitionTypeError, r"`names`: must be a sequence of link names"),
        ({"names": []}, DefinitionError, r"`names`: a linkage trajectory needs at least one"),
        ({"psi": np.zeros((4, 3))}, DefinitionError, r"`psi`: must have shape \(K, n\) = \(4, 2\)"),
        ({"torques": np.zeros((5, 2))}, DefinitionError, r"`torques`: must have shape \(K, n\)"),
        ({"ddpsi": np.zeros((4, 1))}, DefinitionError, r"`ddpsi`: must have shape"),
        (
            {"dpsi": np.array([[0, 0], [0, 0], [np.nan, 0], [0, 0]])},
            DefinitionError,
            r"`dpsi`: must be finite, got nan at sample 2, column 0 \(`a`\)",
        ),
        ({"ground_reaction": np.zeros(4, complex)[:3]}, DefinitionError, r"complex Fx \+ j Fy"),
        ({"ground_reaction": np.zeros((4, 3))}, DefinitionError, r"`ground_reaction`: must be"),
        ({"metadata": {"f": lambda: 0}}, DefinitionTypeError, r"`metadata\['f'\]`"),
    ],
)
def test_from_linkage_validation(change, error, match):
    arguments = {
        "time": T4,
        "psi": np.zeros((4, 2)),
        "dpsi": np.zeros((4, 2)),
        "torques": np.zeros((4, 2)),
        "names": ("a", "b"),
    }
    with pytest.raises(error, match=match):
        LinkageTrajectory.from_linkage(**{**arguments, **change})


def test_of_takes_trajectories_only_and_keeps_a_linkage_trajectory():
    linkage = linkage_trajectory()
    assert LinkageTrajectory.of(linkage) is linkage
    with pytest.raises(DefinitionTypeError, match=r"`trajectory`: must be a planner.Trajectory, "):
        LinkageTrajectory.of({"time": [0, 1]})
