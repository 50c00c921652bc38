"""One-state evaluation through CasADi's buffer (problems.control.buffered), as the hybrid
simulation and the return map use it every control period: the same numbers as the
Function's own call, bit for bit, also for a matrix argument (CasADi's column-major order),
the plant's and the reference's fast paths against the checked model evaluation, and the
refusals."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from model import presets
from planner.errors import DefinitionError
from problems.control.buffered import BufferedCall
from problems.control.simulation import Plant


def test_a_buffered_call_is_the_functions_own_call_bit_for_bit():
    rng = np.random.default_rng(5)
    plant = Plant(presets.six_link_anthropoid(), mu=1.0)
    call = BufferedCall(plant.advance)
    for _ in range(5):
        x, torques, h = rng.normal(size=12) * 0.3, rng.normal(size=6) * 20.0, 1e-3
        (ours,) = call(x, torques, h)
        np.testing.assert_array_equal(ours, np.asarray(plant.advance(x, torques, h)).ravel())
        np.testing.assert_array_equal(plant.advance_state(x, torques, h), ours)
        # the swing foot through its buffer against the checked model evaluation
        assert plant.swing_foot(x[:6]) == complex(plant.foot.position(x[:6]))
    # a matrix argument and a matrix result keep CasADi's column-major order
    a = ca.SX.sym("a", 2, 3)
    product = ca.Function("product", [a], [ca.mtimes(a, ca.DM([[1.0], [2.0], [3.0]])), a.T])
    value = np.arange(6.0).reshape(2, 3)
    column, transposed = BufferedCall(product)(value)
    np.testing.assert_array_equal(column, value @ [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(transposed.reshape(2, 3), value)  # (3, 2) stored by columns


def test_sparse_functions_and_wrong_arguments_are_refused():
    x = ca.SX.sym("x", 2)
    sparse = ca.Function("sparse", [x], [ca.SX(2, 2)])
    with pytest.raises(DefinitionError, match="'sparse' has a sparse output 0"):
        BufferedCall(sparse)
    call = BufferedCall(ca.Function("twice", [x], [2 * x]))
    with pytest.raises(DefinitionError, match="'twice' takes 1 arguments, got 2"):
        call(np.ones(2), np.ones(2))
