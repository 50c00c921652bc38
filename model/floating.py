"""The floating base: the same tree with its root hinge free in the plane.

Generalised coordinates q = (x0, y0, psi_1..psi_n): the root hinge H0 moves by z0 = x0 + j y0
from where the fixed-base model pins it (the origin, or the root's ``origin``) and every point
of the tree moves with it, w_i -> z0 + w_i. With the fixed-base model's
subtree first moments K_m (``Dynamics.subtree_moments``: sum_i m_i dw_i/dt =
sum_m j dpsi_m K_m e^{j psi_m}) the kinetic energy is

    T = 1/2 m |dz0|^2 + Re( conj(dz0) sum_m j dpsi_m K_m e^{j psi_m} ) + T_fixed(psi, dpsi),

so the mass matrix is the fixed-base one bordered by the total mass m and the coupling columns
j K_m e^{j psi_m} (as (Re, Im) rows):

    M_e = [[m I_2, B], [B^T, M(psi)]],   B[:, m] = (Re, Im) of j K_m e^{j psi_m},

and Pi = Pi_fixed + m g y0. Nothing is derived again: the psi-psi block, the exponentials and
the energy are the fixed-base model's own expressions (:class:`model.Dynamics`).

The floating base's tree sparsity: the base is an ancestor of every link, so M_e keeps the
tree pattern (the base rows are full, the psi-psi block is zero between branches) and a sparse
L D L^T that eliminates leaves first has no fill-in (``model.impact`` uses it).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from model.complex_sx import Constants, times_constants
from planner.errors import DefinitionError

#: The owner a part calls back into: the ``model.Dynamics`` that built it. Named, not
#: imported: dynamics.py imports this module, and an import back would close a circle.
Dynamics = Any

#: name -> (input names, output names, description)
FLOATING_FUNCTIONS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str]] = {
    "floating_mass_matrix": (
        ("psi",),
        ("mass_matrix",),
        "mass matrix of q = (x0, y0, psi), (n + 2, n + 2): kg, kg m, kg m^2",
    ),
    "floating_energy": (("q", "dq"), ("kinetic", "potential"), "T and Pi with the base, J"),
    "linear_momentum": (("psi", "dq"), ("px", "py"), "m v_com of the whole tree, kg m/s"),
}


class FloatingBase:
    """The floating-base twin of a :class:`model.Dynamics` (``dyn.floating``).

    q = (x0, y0, psi) (n + 2,) m and rad; dq (n + 2,) m/s and rad/s. (x0, y0) displaces the
    root hinge H0 from where the fixed-base model pins it (the root's ``origin``, the world
    origin by default), so H0 is at z0 = x0 + j y0 for a paper-form tree.
    Functions (``FLOATING_FUNCTIONS``) are generated on first use and cached in the Dynamics.
    """

    def __init__(self, dynamics: Dynamics) -> None:
        self._dynamics = dynamics
        self._base = ca.SX.sym("base", 2)
        self._dbase = ca.SX.sym("dbase", 2)
        self._cache: dict[str, object] = {}

    @property
    def dynamics(self) -> Dynamics:
        return self._dynamics

    @property
    def n(self) -> int:
        """Number of generalised coordinates, n + 2."""
        return self._dynamics.n + 2

    @property
    def symbols(self) -> dict[str, ca.SX]:
        """q, dq (n + 2,) and the fixed-base model's symbols (psi, dpsi, ...)."""
        own = self._dynamics.symbols
        return {
            **own,
            "q": ca.vertcat(self._base, own["psi"]),
            "dq": ca.vertcat(self._dbase, own["dpsi"]),
        }

    @property
    def total_mass(self) -> float:
        """kg."""
        return self._dynamics.subtree_moments()[0][0]

    def function(self, name: str) -> ca.Function:
        """The named SX Function (see ``FLOATING_FUNCTIONS``), generated on first use."""
        if name not in FLOATING_FUNCTIONS:
            raise DefinitionError(
                f"`name`: unknown floating-base function {name!r}; "
                f"available: {sorted(FLOATING_FUNCTIONS)}"
            )
        inputs, outputs, _ = FLOATING_FUNCTIONS[name]
        symbols = self.symbols
        return self._dynamics.cached_function(
            name,
            inputs,
            [symbols[k] for k in inputs],
            outputs,
            getattr(self, "_build_" + name),
        )

    # ---- expressions ---------------------------------------------------------------------
    def coupling(self) -> ca.SX:
        """B (2, n): d(sum_i m_i dw_i/dt)/d(dpsi), the columns j K_m e^{j psi_m}, kg m."""
        if "coupling" not in self._cache:
            dyn = self._dynamics
            _, frames = dyn.link_kinematics(0)
            moments = Constants(dyn.subtree_moments()[1])
            column = times_constants(frames, moments).times_j()
            self._cache["coupling"] = ca.vertcat(column.re.T, column.im.T)
        return self._cache["coupling"]

    def mass_matrix_expression(self) -> ca.SX:
        """M_e(psi) (n + 2, n + 2), symmetric, with the tree's structural zeros."""
        if "mass_matrix" not in self._cache:
            m = self.total_mass
            coupling = self.coupling()
            self._cache["mass_matrix"] = ca.blockcat(
                [
                    [m * ca.SX.eye(2), coupling],
                    [coupling.T, self._dynamics.mass_matrix_expression()],
                ]
            )
        return self._cache["mass_matrix"]

    def _build_floating_mass_matrix(self) -> list[ca.SX]:
        return [self.mass_matrix_expression()]

    def _build_floating_energy(self) -> list[ca.SX]:
        dyn = self._dynamics
        psi, dpsi = dyn.symbols["psi"], dyn.symbols["dpsi"]
        kinetic, potential = dyn.function("energy").call([psi, dpsi])
        relative = ca.mtimes(self.coupling(), dpsi)  # momentum of the motion relative to H0
        m = self.total_mass
        kinetic = (
            kinetic + ca.dot(self._dbase, relative) + 0.5 * m * ca.dot(self._dbase, self._dbase)
        )
        # The fixed model's Pi has H0 at the root's origin; the base moves it by (x0, y0).
        potential = potential + dyn.linkage.gravity * m * self._base[1]
        return [kinetic, potential]

    def _build_linear_momentum(self) -> list[ca.SX]:
        momentum = self.total_mass * self._dbase + ca.mtimes(
            self.coupling(), self._dynamics.symbols["dpsi"]
        )
        return [momentum[0], momentum[1]]

    # ---- numeric -------------------------------------------------------------------------
    def _evaluate(self, name: str, *arrays) -> list:
        self.function(name)
        return self._dynamics.evaluate(name, *arrays)

    def mass_matrix(self, psi) -> np.ndarray:
        """M_e, (n + 2, n + 2) or (K, n + 2, n + 2)."""
        return self._evaluate("floating_mass_matrix", psi)[0]

    def energy(self, q, dq) -> tuple:
        """(kinetic, potential) energy with the base moving, J: scalars or (K,)."""
        kinetic, potential = self._evaluate("floating_energy", q, dq)
        return kinetic, potential

    def momentum(self, psi, dq) -> np.ndarray | complex:
        """Linear momentum of the tree, px + j py, kg m/s: complex scalar or (K,)."""
        px, py = self._evaluate("linear_momentum", psi, dq)
        return px + 1j * py

    def __repr__(self) -> str:
        return f"FloatingBase({self._dynamics.linkage!r})"
