"""A complex number carried as a pair of CasADi SX scalars.

CasADi's SX has no complex type, and the seed paper's method lives on complex exponentials.
``Cx`` keeps the paper's algebra readable in the generator (``l * expj(psi)``, ``z * j``,
``conj(z) * w``) while emitting only real SX operations. Multiplication by a Python constant
skips the products with exact zeros, so a paper link (real lengths) costs no more than the
real-valued trigonometric form would.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

Number = float | complex


@dataclass(frozen=True)
class Cx:
    """z = re + j im with SX (or float) parts."""

    re: ca.SX | float
    im: ca.SX | float

    def __add__(self, other: Cx | Number) -> Cx:
        if isinstance(other, Cx):
            return Cx(self.re + other.re, self.im + other.im)
        other = complex(other)
        return Cx(self.re + other.real, self.im + other.imag)

    __radd__ = __add__

    def __sub__(self, other: Cx | Number) -> Cx:
        if isinstance(other, Cx):
            return Cx(self.re - other.re, self.im - other.im)
        other = complex(other)
        return Cx(self.re - other.real, self.im - other.imag)

    def __neg__(self) -> Cx:
        return Cx(-self.re, -self.im)

    def __mul__(self, other: Cx | Number) -> Cx:
        if isinstance(other, Cx):
            return Cx(
                self.re * other.re - self.im * other.im,
                self.re * other.im + self.im * other.re,
            )
        c = complex(other)
        if c.imag == 0.0:  # real constant: two products, not four
            return Cx(c.real * self.re, c.real * self.im)
        if c.real == 0.0:  # purely imaginary constant: j b (x + j y) = -b y + j b x
            return Cx(-c.imag * self.im, c.imag * self.re)
        return Cx(c.real * self.re - c.imag * self.im, c.real * self.im + c.imag * self.re)

    __rmul__ = __mul__

    def scale(self, real: ca.SX | float) -> Cx:
        """Multiply by a real (possibly symbolic) scalar."""
        return Cx(real * self.re, real * self.im)

    def times_j(self) -> Cx:
        """Multiply by the imaginary unit j (a quarter turn): free, no operations."""
        return Cx(-self.im, self.re)

    def conj(self) -> Cx:
        return Cx(self.re, -self.im)

    def abs2(self) -> ca.SX:
        """|z|^2."""
        return self.re * self.re + self.im * self.im


def expj(angle: ca.SX) -> Cx:
    """e^{j angle} = cos(angle) + j sin(angle)."""
    return Cx(ca.cos(angle), ca.sin(angle))


ZERO = Cx(0.0, 0.0)


class Constants:
    """A vector of complex constants held as CasADi DM parts, converted once."""

    def __init__(self, values) -> None:
        c = np.asarray(values, dtype=complex).reshape(-1)
        self.values = c
        self.re = ca.DM(c.real)
        self.im = ca.DM(c.imag)
        self.is_real = not np.any(c.imag)

    def conj(self) -> Constants:
        return Constants(np.conj(self.values))


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


def real_of_product(constant: complex, z: Cx) -> ca.SX:
    """Re(constant * z) without forming the imaginary part."""
    c = complex(constant)
    if c.imag == 0.0:
        return c.real * z.re
    return c.real * z.re - c.imag * z.im


def imag_of_conj_product(a: Cx, b: Cx) -> ca.SX:
    """Im(conj(a) * b) = a.re b.im - a.im b.re."""
    return a.re * b.im - a.im * b.re
