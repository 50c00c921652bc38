"""Convergence orders of every transcription on a problem with a known optimum.

The problem: x' = u, x(0) = 1, minimise the integral of x^2 + u^2 over [0, T], T = 2 s. The
Riccati equation P' = P^2 - 1, P(T) = 0 gives P(t) = tanh(T - t), so the optimal cost is
tanh(T). Each transcription is solved at a few N (IPOPT tol 1e-13); printed: the cost errors,
the slope of log(error) against log(N) fitted by least squares, and the scheme's nominal order
for the cost (trapezoid 2, Hermite-Simpson 4, Radau degree d 2d - 1, Legendre degree d 2d).
The N are chosen so that the errors stay above round-off (a fit on round-off is meaningless).

    python examples/benchmarks/convergence_orders.py
    python examples/benchmarks/convergence_orders.py --quick   # three schemes only
"""

from __future__ import annotations

import argparse
import sys

import casadi as ca
import numpy as np

from planner import OCP

T = 2.0
TIGHT = {"tol": 1e-13}
#: (transcription, degree, nominal cost order, N values)
CASES = (
    ("trapezoid", None, 2, (4, 8, 16, 32)),
    ("hermite-simpson", None, 4, (2, 4, 8, 16)),
    ("radau", 1, 1, (4, 8, 16, 32)),
    ("radau", 2, 3, (2, 4, 8, 16)),
    ("radau", 3, 5, (2, 4, 8)),
    ("legendre", 2, 4, (2, 4, 8, 16)),
    ("legendre", 3, 6, (1, 2, 4)),
)


def scalar_lq(N: int, transcription: str, degree: int | None) -> OCP:
    """The scalar LQ problem above on N intervals of the given transcription."""
    x, u = ca.SX.sym("x"), ca.SX.sym("u")
    ode = ca.Function("f", [x, u], [u], ["x", "u"], ["xdot"])
    return (
        OCP(ode, T=T, N=N, transcription=transcription, degree=degree)
        .initial(x=1.0)
        .minimize(integral=lambda p: p.x**2 + p.u**2)
    )


def fitted_slope(Ns, errors) -> float:
    """Least-squares slope of -log(error) against log(N)."""
    return float(-np.polyfit(np.log(Ns), np.log(errors), 1)[0])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: three schemes")
    args = parser.parse_args(argv)
    cases = CASES[:3] if args.quick else CASES
    exact = np.tanh(T)
    print(f"scalar LQ, optimal cost tanh({T:g}) = {exact:.15f}; |cost - optimum| per N")
    print(f"{'transcription':<16} {'order':>5} {'slope':>6}   errors (N: error)")
    for name, degree, order, Ns in cases:
        errors = [
            abs(scalar_lq(N, name, degree).solve(progress=False, options=TIGHT).cost - exact)
            for N in Ns
        ]
        label = name if degree is None else f"{name}({degree})"
        cells = "  ".join(f"{N}: {e:.2e}" for N, e in zip(Ns, errors, strict=True))
        print(f"{label:<16} {order:>5} {fitted_slope(Ns, errors):>6.2f}   {cells}")


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
