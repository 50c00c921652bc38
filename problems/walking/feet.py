"""The feet of a walker, as the walking step and the hybrid plant both read them.

A mixin for a class that has ``biped`` (a :class:`problems.gait.biped.Biped`), ``dynamics``
(its ``model.Dynamics``) and ``mu`` (the ground's friction coefficient): the stance foot is
H0, pinned; the swing foot is the end of the swing leg, which lands at heel strike (and is
held through a double support). Both are ``model.Contact`` values (``Biped.feet``), so that
cones, impulses and the verification read one description.
"""

from __future__ import annotations

from functools import cached_property

from model.contact import Contact


class WalkerFeet:
    """(stance, swing) contacts and the swing foot's kinematics of a walker; see the module."""

    @cached_property
    def feet(self) -> tuple[Contact, Contact]:
        """(stance foot, swing foot): the biped's feet (``Biped.feet``) with the ground's
        friction ``mu``."""
        return self.biped.feet(self.mu)

    @property
    def stance_contact(self) -> Contact:
        return self.feet[0]

    @property
    def swing_contact(self) -> Contact:
        return self.feet[1]

    @cached_property
    def foot(self):
        """The swing foot's kinematics (``model.PointKinematics`` of :attr:`swing_contact`)."""
        return self.dynamics.point(self.swing_contact.point)
