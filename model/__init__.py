"""Complex-variable Lagrange models of planar link trees, generated as CasADi SX.

>>> from model import Dynamics, presets
>>> dyn = Dynamics(presets.six_link_anthropoid())
>>> dyn.inverse_dynamics(psi, dpsi, ddpsi)        # hinge torques, N m
>>> foot = dyn.point("swing_shank")               # the end hinge of the swing shank
>>> dyn.floating.mass_matrix(psi)                 # q = (x0, y0, psi): (n + 2, n + 2)
>>> dyn.impact(foot)(psi, dpsi)                   # heel strike: dpsi+, impulse, base velocity
>>> swap = swap_legs(dyn.linkage)                 # re-rooted at the swing foot, legs renamed
"""

from model import presets
from model.contact import Contact, Ground
from model.dynamics import FUNCTIONS, Dynamics
from model.floating import FLOATING_FUNCTIONS, FloatingBase
from model.impact import ImpactMap
from model.linkage import Link, Linkage
from model.linkage_system import linkage_system
from model.linkage_trajectory import LinkageTrajectory
from model.mjcf import MjcfModel, to_mjcf
from model.points import POINT_FUNCTIONS, LinkPoint, PointKinematics
from model.rerooting import Rerooting, reroot, swap_legs
from model.rotors import Rotor
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError

__all__ = [
    "FLOATING_FUNCTIONS",
    "FUNCTIONS",
    "POINT_FUNCTIONS",
    "AnthropoidError",
    "Contact",
    "DefinitionError",
    "DefinitionTypeError",
    "Dynamics",
    "FloatingBase",
    "Ground",
    "ImpactMap",
    "Link",
    "LinkPoint",
    "Linkage",
    "LinkageTrajectory",
    "MjcfModel",
    "PointKinematics",
    "Rerooting",
    "Rotor",
    "linkage_system",
    "presets",
    "reroot",
    "swap_legs",
    "to_mjcf",
]
