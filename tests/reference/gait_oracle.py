"""Independent checks of gaits for the tests: numpy only, through the Newton-Euler oracle.

Nothing here calls the planner's constraint functions, the model's SX Functions or the
library's verify_gait: the impact is a dense KKT solve with the oracle's floating-base mass
matrix and point Jacobian, the leg relabelling is written from the link names, the ground
reaction and foot positions are the oracle's.
"""

from __future__ import annotations

import math

import numpy as np

from reference import newton_euler as ne

LEG_SWAP = {
    "stance_shank": "swing_shank",
    "stance_thigh": "swing_thigh",
    "swing_thigh": "stance_thigh",
    "swing_shank": "stance_shank",
}


def relabel(linkage, psi, dpsi):
    """The next step's (psi, dpsi) after the legs swap (names of the six/five-link presets):
    the new stance leg is the old swing leg turned up (+pi), the new swing leg the old stance
    leg turned down (-pi); the upper body keeps its angles."""
    names = linkage.names
    new_psi, new_dpsi = np.empty_like(psi), np.empty_like(dpsi)
    for i, name in enumerate(names):
        source = names.index(LEG_SWAP.get(name, name))
        turn = 0.0 if name not in LEG_SWAP else (math.pi if name.startswith("stance") else -math.pi)
        new_psi[i] = psi[source] + turn
        new_dpsi[i] = dpsi[source]
    return new_psi, new_dpsi


def heel_strike(linkage, psi, dpsi):
    """Dense KKT impact of the swing foot (end of swing_shank) with H0 at rest before:
    (dpsi_plus (n,), impulse complex, base velocity after, complex)."""
    n = linkage.n
    foot = linkage.index("swing_shank")
    offset = complex(linkage.links[foot].length)
    mass = ne.floating_mass_matrix(linkage, psi)
    jacobian = ne.point_jacobian(linkage, foot, offset, psi)
    kkt = np.block([[mass, -jacobian.T], [jacobian, np.zeros((2, 2))]])
    dq_minus = np.r_[0.0, 0.0, dpsi]
    solution = np.linalg.solve(kkt, np.r_[mass @ dq_minus, 0.0, 0.0])
    return (
        solution[2 : n + 2],
        complex(solution[n + 2], solution[n + 3]),
        complex(solution[0], solution[1]),
    )


def wrap(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def swing_foot(linkage, psi) -> np.ndarray:
    """Swing-foot positions (complex, m) for angles (K, n)."""
    return ne.hinge_positions(linkage, psi)[..., linkage.index("swing_shank") + 1]
