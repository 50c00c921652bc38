"""planner.check_accuracy_of / AccuracyWarning: a converged plan that does not obey its
dynamics between the mesh points says so.

Oracle: the converged optimum of the same problem on a fine mesh (the coarse plan is another,
worse one), and scipy's integration of the Newton-Euler dynamics for the error itself.
"""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler as ne
from scipy.integrate import solve_ivp

from model import DefinitionError, Dynamics, presets
from planner import ACCURACY_WARNING, OCP, AccuracyWarning, check_accuracy_of

CHAIN = presets.n_link_chain(2)
DOWN = -np.pi / 2


def swing_up(N: int) -> OCP:
    """The two-link chain from hanging to upright in 3 s, |M| <= 5 N m, min sum M^2."""
    up = [DOWN + np.pi, DOWN + np.pi]
    return (
        OCP(Dynamics(CHAIN), T=3.0, N=N)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=up, dpsi=0.0)
        .bound("M", -5.0, 5.0)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(t=[0.0, 3.0], psi=[[DOWN, DOWN], up])
    )


def test_a_coarse_swing_up_that_succeeds_warns_naming_the_fix():
    with pytest.warns(AccuracyWarning, match=r"refine the mesh: a larger N") as caught:
        coarse = swing_up(40).solve(progress=False)
    assert coarse.success and len(caught) == 1
    measured = coarse.stats["accuracy"]
    assert measured["warned"] and measured["error"] > 0.1 > ACCURACY_WARNING
    # the oracle: the worst interval integrated with scipy on the Newton-Euler dynamics
    k = measured["interval"]
    t0, t1 = coarse.time[k], coarse.time[k + 1]

    def rhs(t, x):
        inside = min(max(t, t0 + 1e-12), t1 - 1e-12)
        torques = coarse.control([inside])[0]
        return np.concatenate([x[2:], ne.forward_dynamics(CHAIN, x[:2], x[2:], torques)])

    end = solve_ivp(rhs, (t0, t1), coarse.states[k], "DOP853", rtol=1e-11, atol=1e-11).y[:, -1]
    assert np.max(np.abs(end - coarse.states[k + 1])) == pytest.approx(measured["error"], rel=1e-4)
    # it is not the optimum: the converged one costs less (37.4 against 41.3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        fine = swing_up(160).guess(coarse).solve(progress=False)
    assert fine.cost < 0.95 * coarse.cost
    assert fine.stats["accuracy"]["error"] < ACCURACY_WARNING


def test_the_threshold_is_configurable_and_the_check_can_be_off():
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        quiet = swing_up(40).solve(progress=False, accuracy_warning=1.0)
        assert not quiet.stats["accuracy"]["warned"]
        off = swing_up(40).solve(progress=False, accuracy_warning=None)
        assert "accuracy" not in off.stats
    assert check_accuracy_of(off, None)["error"] == pytest.approx(
        quiet.stats["accuracy"]["error"], rel=1e-9
    )
    with pytest.raises(DefinitionError, match=r"`accuracy_warning`: must be > 0"):
        check_accuracy_of(off, -1.0)
