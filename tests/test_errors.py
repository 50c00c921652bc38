"""planner.errors: the error classes and the shared validators, message by message."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from planner.errors import (
    AnthropoidError,
    DefinitionError,
    DefinitionTypeError,
    as_float_array,
    check_finite,
    check_integer,
    check_positive,
    check_real,
    check_states,
)


def test_error_classes_derive_from_the_library_base_and_builtins():
    assert issubclass(DefinitionError, AnthropoidError) and issubclass(DefinitionError, ValueError)
    assert issubclass(DefinitionTypeError, AnthropoidError)
    assert issubclass(DefinitionTypeError, TypeError)


def test_check_real():
    assert check_real("mass", 2) == 2.0 and isinstance(check_real("mass", np.float32(2)), float)
    with pytest.raises(DefinitionTypeError, match="`mass`: must be a real number, got True"):
        check_real("mass", True)
    with pytest.raises(DefinitionTypeError, match="`mass`: must be a real number, got '1' of type"):
        check_real("mass", "1")
    with pytest.raises(DefinitionError, match="`mass`: must be finite, got inf; give a finite"):
        check_real("mass", math.inf)


def test_check_positive():
    assert check_positive("rate_hz", 2) == 2.0 and isinstance(check_positive("x", 1), float)
    with pytest.raises(DefinitionError, match=r"^`rate_hz`: must be > 0 Hz, got 0.0$"):
        check_positive("rate_hz", 0, "Hz")
    with pytest.raises(DefinitionError, match=r"^`gain`: must be > 0, got -1.5$"):
        check_positive("gain", -1.5)
    with pytest.raises(DefinitionError, match="`rate_hz`: must be finite, got inf"):
        check_positive("rate_hz", math.inf, "Hz")
    with pytest.raises(DefinitionTypeError, match="`rate_hz`: must be a real number, got True"):
        check_positive("rate_hz", True, "Hz")


def test_check_integer():
    assert check_integer("N", np.int64(3), 1) == 3 and type(check_integer("N", 3, 1)) is int
    assert check_integer("size", 0, 0) == 0
    with pytest.raises(DefinitionError, match=r"^`N`: must be >= 1, got 0$"):
        check_integer("N", 0, 1)
    with pytest.raises(DefinitionError, match=r"^`size`: must be >= 0 \(0 keeps"):
        check_integer("size", -1, 0, "(0 keeps none)")
    for bad in (2.5, True, "3", None):
        with pytest.raises(
            DefinitionTypeError, match=rf"^`N`: must be an integer >= 1, got {bad!r}"
        ):
            check_integer("N", bad, 1)


def test_as_float_array():
    array = as_float_array("x0", [1, 2], "2 numbers")
    assert array.dtype == float and array.tolist() == [1.0, 2.0]
    with pytest.raises(DefinitionTypeError, match=r"`x0`: must be 2 numbers, got 'ab'"):
        as_float_array("x0", "ab", "2 numbers")
    # numpy would drop the imaginary part (with only a warning) and read booleans as 0, 1
    for bad, what in (([1, 1j], "complex numbers"), (np.array([True, False]), "booleans")):
        with pytest.raises(DefinitionTypeError, match=rf"`x0`: must be 2 numbers, got {what}"):
            as_float_array("x0", bad, "2 numbers")


def test_check_finite():
    check_finite("t", np.array([0.0, 1.0]))
    check_finite("t", np.zeros(0))  # nothing to refuse
    with pytest.raises(DefinitionError, match="`t`: contains NaN or inf; give finite values"):
        check_finite("t", np.array([0.0, np.nan]))
    with pytest.raises(DefinitionError, match="`t`: contains NaN or inf; give finite times in s"):
        check_finite("t", np.array([-np.inf]), "times in s")


def test_check_states():
    assert check_states("psi", [0, 1, 2], 3).shape == (3,)
    assert check_states("psi", np.zeros((4, 3)), 3).shape == (4, 3)
    assert check_states("psi", np.zeros((0, 3)), 3).shape == (0, 3)  # an empty batch
    with pytest.raises(
        DefinitionTypeError, match=r"`psi`: must be numeric of shape \(3,\) or \(K, 3\), got 'a'"
    ):
        check_states("psi", "a", 3)
    for bad in (np.zeros(2), np.zeros((4, 2)), np.zeros((1, 1, 3)), 1.0):
        shape = re.escape(str(np.shape(bad)))
        with pytest.raises(
            DefinitionError, match=rf"`psi`: expected shape \(3,\) or \(K, 3\), got {shape}"
        ):
            check_states("psi", bad, 3)
    with pytest.raises(DefinitionError, match="`psi`: contains NaN or inf; give finite values"):
        check_states("psi", [0.0, np.inf, 0.0], 3)
    for bad, what in ((np.full(3, 1j), "complex numbers"), ([True, False, True], "booleans")):
        with pytest.raises(
            DefinitionTypeError,
            match=rf"`psi`: must be real numbers of shape \(3,\) or \(K, 3\), got {what}",
        ):
            check_states("psi", bad, 3)
