"""Complex-variable Lagrange models of planar link trees, generated as CasADi SX.

>>> from model import presets
>>> dyn = presets.six_link_anthropoid().dynamics()
>>> dyn.inverse_dynamics(psi, dpsi, ddpsi)        # hinge torques, N m
"""

from model import presets
from model.dynamics import FUNCTIONS, Dynamics
from model.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from model.linkage import Link, Linkage

__all__ = [
    "FUNCTIONS",
    "AnthropoidError",
    "DefinitionError",
    "DefinitionTypeError",
    "Dynamics",
    "Link",
    "Linkage",
    "presets",
]
