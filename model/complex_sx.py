"""A complex number carried as a pair of CasADi SX scalars.

CasADi's SX has no complex type, and the seed paper's method lives on complex exponentials.
``Cx`` keeps the paper's algebra readable in the generator (``expj(psi)``, ``z.times_j()``,
``times_constants(z, lengths)``) while emitting only real SX operations. Multiplication by
real constants (every paper link) skips the products with exact zeros, so the complex form
costs no more than the real-valued trigonometric form would.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class Cx:
    """z = re + j im with SX parts (scalars or vectors, elementwise)."""

    re: ca.SX
    im: ca.SX

    def __add__(self, other: Cx | complex) -> Cx:
        if isinstance(other, Cx):
            return Cx(self.re + other.re, self.im + other.im)
        other = complex(other)  # a constant offset, e.g. the root's fixed start hinge
        return Cx(self.re + other.real, self.im + other.imag)

    def __mul__(self, constant: complex) -> Cx:
        """Multiply by a complex constant, skipping the products with exact zeros."""
        c = complex(constant)
        if c.imag == 0.0:  # real constant: two products, not four
            return Cx(c.real * self.re, c.real * self.im)
        if c.real == 0.0:  # purely imaginary constant: j b (x + j y) = -b y + j b x
            return Cx(-c.imag * self.im, c.imag * self.re)
        return Cx(c.real * self.re - c.imag * self.im, c.real * self.im + c.imag * self.re)

    def scale(self, real: ca.SX) -> Cx:
        """Multiply by a real (possibly symbolic, elementwise) factor."""
        return Cx(real * self.re, real * self.im)

    def times_j(self) -> Cx:
        """Multiply by the imaginary unit j (a quarter turn): free, no operations."""
        return Cx(-self.im, self.re)

    def abs2(self) -> ca.SX:
        """|z|^2."""
        return self.re * self.re + self.im * self.im


def expj(angle: ca.SX) -> Cx:
    """e^{j angle} = cos(angle) + j sin(angle)."""
    return Cx(ca.cos(angle), ca.sin(angle))


class Constants:
    """A vector of complex constants held as CasADi DM parts, converted once."""

    def __init__(self, values) -> None:
        c = np.asarray(values, dtype=complex).reshape(-1)
        self.values = c
        self.is_real = not np.any(c.imag)
        self.re = ca.DM(c.real)
        self.im = None if self.is_real else ca.DM(c.imag)  # never read for real constants

    def conj(self) -> Constants:
        return self if self.is_real else Constants(np.conj(self.values))


def times_constants(z: Cx, constants: Constants) -> Cx:
    """Elementwise z * c for a vector z and a vector of complex constants c.

    Real constants (every paper link) cost two products per element, not four.
    """
    re, im = constants.re, constants.im
    if constants.is_real:
        return Cx(re * z.re, re * z.im)
    return Cx(re * z.re - im * z.im, re * z.im + im * z.re)


def apply(operator: ca.DM, z: Cx) -> Cx:
    """A real constant matrix (a tree operator) applied to both parts of z."""
    return Cx(ca.mtimes(operator, z.re), ca.mtimes(operator, z.im))


def imag_of_conj_product(a: Cx, b: Cx) -> ca.SX:
    """Im(conj(a) * b) = a.re b.im - a.im b.re."""
    return a.re * b.im - a.im * b.re
