"""A trajectory of a linkage: its channels read as link angles, rates, torques.

A trajectory follows the linkage convention (:mod:`model.linkage_naming`, the planner's
System of a ``model.Dynamics``) when its channels are

    states   psi_<link> [rad] for every link, then dpsi_<link> [rad/s]
    controls M_<link>   [N m]  (hinge torques)
    extras   ddpsi_<link> [rad/s^2], Fx [N], Fy [N] (ground reaction at H0) when known

:class:`LinkageTrajectory` is a :class:`planner.trajectory.Trajectory` (the planner's generic
samples, which know no linkage) with the constructor ``from_linkage`` and the (K, n) views
``psi``, ``dpsi``, ``torques``, ``ddpsi``, ``ground_reaction`` and ``link_names``, which raise
:class:`planner.trajectory.TrajectoryError` on a trajectory that does not follow the
convention. A linkage's Solution returns one (``System.trajectory_type``); read a linkage's
file with ``LinkageTrajectory.load``, which also infers the groups of a file made by hand
from the convention's names (:func:`model.linkage_naming.infer_group`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from functools import cached_property

import numpy as np

from model import linkage_naming as naming
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory, TrajectoryError
from planner.trajectory.checks import check_label, float_array


@dataclass(frozen=True, eq=False, repr=False)
class LinkageTrajectory(Trajectory):
    """A :class:`planner.trajectory.Trajectory` read in the linkage convention (the fields and
    validation are the Trajectory's; this class adds the linkage's constructor and views)."""

    @staticmethod
    def infer_group(name: str) -> str:
        """The group of a column of a file made by hand (no groups line), by the convention."""
        return naming.infer_group(name)

    # ---- construction ----------------------------------------------------------------------
    @classmethod
    def of(cls, trajectory: Trajectory) -> LinkageTrajectory:
        """``trajectory`` (any :class:`planner.trajectory.Trajectory`: read from a file with
        ``Trajectory.load``, built by hand) with the linkage's views: the same samples, names,
        units and metadata; itself when it is one already."""
        if isinstance(trajectory, cls):
            return trajectory
        if not isinstance(trajectory, Trajectory):
            raise DefinitionTypeError(
                f"`trajectory`: must be a planner.Trajectory, got {type(trajectory).__name__}"
            )
        return cls(**{f.name: getattr(trajectory, f.name) for f in fields(Trajectory)})

    @classmethod
    def from_linkage(
        cls,
        time,
        psi,
        dpsi,
        torques,
        names: Sequence[str],
        ddpsi=None,
        ground_reaction=None,
        metadata: Mapping | None = None,
    ) -> LinkageTrajectory:
        """A trajectory in the linkage convention.

        Parameters
        ----------
        time : (K,) s.
        psi : (K, n) rad, absolute link angles.
        dpsi : (K, n) rad/s.
        torques : (K, n) N m, hinge torques M.
        names : n link names (``model.Linkage.names``).
        ddpsi : optional (K, n) rad/s^2; stored as extras ``ddpsi_<link>`` and then used as
            the derivative of dpsi by the interpolation.
        ground_reaction : optional force of the ground at H0, N: complex (K,) Fx + j Fy, or
            real (K, 2) columns Fx, Fy; stored as extras ``F_<root>_start_x`` and ``_y``
            (the contact at H0 named after its point, the root link's start).
        metadata : optional JSON-serialisable dict.
        """
        if isinstance(names, str) or not isinstance(names, Sequence):
            raise DefinitionTypeError(f"`names`: must be a sequence of link names, got {names!r}")
        links = tuple(check_label(f"names[{i}]", v, "name") for i, v in enumerate(names))
        n = len(links)
        if n == 0:
            raise DefinitionError("`names`: a linkage trajectory needs at least one link")
        time = float_array("time", time, 1)
        K = time.shape[0]

        def block(where: str, value) -> np.ndarray:
            array = float_array(where, value, 2, links)
            if array.shape != (K, n):
                raise DefinitionError(
                    f"`{where}`: must have shape (K, n) = ({K}, {n}) for {K} samples and "
                    f"{n} links, got {array.shape}"
                )
            return array

        psi = block("psi", psi)
        dpsi = block("dpsi", dpsi)
        torques = block("torques", torques)
        extras: dict[str, tuple[np.ndarray, str]] = {}
        if ddpsi is not None:
            ddpsi = block("ddpsi", ddpsi)
            for i, name in enumerate(naming.acceleration_names(links)):
                extras[name] = (ddpsi[:, i], naming.ACCELERATION_UNIT)
        if ground_reaction is not None:
            force = np.asarray(ground_reaction)
            if force.dtype.kind == "c":
                if force.shape != (K,):
                    raise DefinitionError(
                        f"`ground_reaction`: a complex Fx + j Fy must have shape ({K},), got "
                        f"{force.shape}"
                    )
                pair = np.stack([force.real, force.imag], axis=1)
            else:
                pair = force
            pair = float_array("ground_reaction", pair, 2, ("Fx", "Fy"))
            if pair.shape != (K, 2):
                raise DefinitionError(
                    f"`ground_reaction`: must be complex ({K},) Fx + j Fy or real ({K}, 2) "
                    f"columns Fx, Fy, got shape {pair.shape}"
                )
            names = naming.contact_force_names(naming.root_contact(links))
            for i, name in enumerate(names):
                extras[name] = (pair[:, i], naming.FORCE_UNIT)
        return cls(
            time=time,
            states=np.hstack([psi, dpsi]),
            controls=torques,
            state_names=naming.angle_names(links) + naming.rate_names(links),
            state_units=(naming.ANGLE_UNIT,) * n + (naming.RATE_UNIT,) * n,
            control_names=naming.torque_names(links),
            control_units=(naming.TORQUE_UNIT,) * n,
            extras=extras,
            metadata={} if metadata is None else metadata,
        )

    # ---- the linkage convention -------------------------------------------------------------
    @cached_property
    def _links(self) -> tuple[str, ...] | None:
        return naming.links_of(self.state_names, self.state_units)

    def _not_linkage(self, what: str) -> TrajectoryError:
        others = (f"{naming.TORQUES}_", f"{naming.ACCELERATIONS}_")
        if not self.metadata and any(n.startswith(others) for n in self.state_names):
            # Torques and accelerations among the states: a CSV file read by a reader that
            # took every column for a state, because the sidecar that says which is which
            # was not beside it.
            return TrajectoryError(
                f"`{what}`: every column of this trajectory was read as a state (torques "
                f"{naming.TORQUES}_<link> and accelerations among them) and it has no "
                "metadata: a CSV file read without its sidecar <file>.csv.meta.json, which "
                "holds the column groups and the gait's settings; put the sidecar back beside "
                "the CSV file (or read the file with model.LinkageTrajectory.load, which knows "
                "the linkage's column names)"
            )
        return TrajectoryError(
            f"`{what}`: this trajectory does not follow the linkage convention "
            f"({naming.CONVENTION}); its states are {list(self.state_names)}; build it with "
            "LinkageTrajectory.from_linkage or read the columns by name with .column(name)"
        )

    @property
    def is_linkage(self) -> bool:
        """True when the states follow the linkage convention (psi_<link>, dpsi_<link>)."""
        return self._links is not None

    @property
    def link_names(self) -> tuple[str, ...]:
        """Link names of a linkage trajectory, in the order of its columns."""
        if self._links is None:
            raise self._not_linkage("link_names")
        return self._links

    @property
    def psi(self) -> np.ndarray:
        """(K, n) link angles, rad."""
        if self._links is None:
            raise self._not_linkage("psi")
        return self.states[:, : len(self._links)]

    @property
    def dpsi(self) -> np.ndarray:
        """(K, n) angular velocities, rad/s."""
        if self._links is None:
            raise self._not_linkage("dpsi")
        return self.states[:, len(self._links) :]

    @property
    def torques(self) -> np.ndarray:
        """(K, n) hinge torques M, N m."""
        links = self._links
        if links is None:
            raise self._not_linkage("torques")
        expected = naming.torque_names(links)
        if self.control_names != expected or set(self.control_units) - {naming.TORQUE_UNIT}:
            raise TrajectoryError(
                f"`torques`: the controls must be {list(expected)} [{naming.TORQUE_UNIT}] for "
                "the links "
                f"{list(links)}, got {list(self.control_names)} {list(self.control_units)}; "
                "read them by name with .column(name)"
            )
        return self.controls

    @property
    def ddpsi(self) -> np.ndarray:
        """(K, n) angular accelerations, rad/s^2 (from the extras ``ddpsi_<link>``)."""
        if self._links is None:
            raise self._not_linkage("ddpsi")
        names = naming.acceleration_names(self._links)
        missing = [name for name in names if name not in self.extras]
        if missing:
            raise TrajectoryError(
                f"`ddpsi`: this trajectory stores no angular accelerations (missing extras "
                f"{missing}); pass ddpsi= to LinkageTrajectory.from_linkage"
            )
        return np.stack([self.extras[name][0] for name in names], axis=1)

    @property
    def ground_reaction(self) -> np.ndarray:
        """(K,) complex force of the ground at H0, Fx + j Fy, N (extras
        ``F_<root>_start_x``, ``_y``; ``Fx``, ``Fy`` in files written before those names)."""
        if self._links is None:
            raise self._not_linkage("ground_reaction")
        for fx, fy in (
            naming.contact_force_names(naming.root_contact(self._links)),
            naming.GROUND_REACTION,
        ):
            if fx in self.extras and fy in self.extras:
                return self.extras[fx][0] + 1j * self.extras[fy][0]
        fx, fy = naming.contact_force_names(naming.root_contact(self._links))
        raise TrajectoryError(
            f"`ground_reaction`: this trajectory stores no ground reaction (extras {fx}, {fy}); "
            "pass ground_reaction= to LinkageTrajectory.from_linkage"
        )


__all__ = ["LinkageTrajectory"]
