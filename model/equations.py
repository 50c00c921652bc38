"""The equations of motion printed in the seed paper's symbols, and operation counts.

Two tools live here, both about *how* the equations are written rather than about using them:

1. **Symbolic printing** (paper equations (14)-(21), corrected per ``shared/errata.md``).
   For a tree of paper-form links (:attr:`model.Linkage.is_paper_form`), with
   a_ik = l_k for k a strict ancestor of i and a_ii = n_i l_i, Lagrange's equations read
       sum_m B_km cos(psi_k - psi_m) ddpsi_m + sum_{m != k} B_km sin(psi_k - psi_m) dpsi_m^2
           + g cos(psi_k) sum_i m_i a_ik = M_k - sum_{children c of k} M_c,
   B_kk = I_k + (mass of k's strict descendants) l_k^2 with the paper's I_k about the start
   hinge (errata 1: I_k = J_k + m_k (n_k l_k)^2), and for k an ancestor of m
   B_km = (m_m n_m + mass of m's strict descendants) l_k l_m; links on different branches do
   not couple. :func:`equations_of_motion` builds this as data (:class:`Term` objects whose
   coefficients are sums of mass symbols times length symbols), :func:`equations_text` and
   :func:`equations_latex` render it, and :class:`EquationsOfMotion` evaluates every term
   numerically so that tests can check each one against an independent oracle.

2. **Operation counts** of generated CasADi Functions (:func:`operation_counts`), and two
   plain automatic-differentiation (AD) Lagrange derivations to compare against
   (:func:`ad_function`, :func:`derivation_comparison`): T and Pi written from complex
   positions w_i (real/imaginary pairs) or from trigonometric projections
   x_i = sum l cos psi, y_i = sum l sin psi, then ``casadi.gradient``/``jtimes`` for
   d/dt dT/d(dpsi) - dT/dpsi + dPi/dpsi = Q. With numeric parameters in all three, they
   compute the same numbers as :class:`model.Dynamics` and serve as an independent check.

Nothing here prints: every renderer returns a string.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np

from model.complex_sx import Cx, expj
from model.dynamics import FUNCTIONS, Dynamics
from model.linkage import Linkage
from model.presets import PRESETS, SIX_LINK_TABLE
from planner.errors import DefinitionError, DefinitionTypeError, check_states

__all__ = [
    "AD_FUNCTIONS",
    "COUNT_KINDS",
    "DERIVATIONS",
    "Coefficient",
    "Equation",
    "EquationsOfMotion",
    "MassSum",
    "Parameters",
    "Rate",
    "Term",
    "Trig",
    "ad_function",
    "derivation_comparison",
    "equations_for_preset",
    "equations_latex",
    "equations_of_motion",
    "equations_text",
    "format_comparison",
    "operation_counts",
]


# ---- structured representation -----------------------------------------------------------
# Link indices are 0-based in the data (the order of Linkage.links); symbols print 1-based
# (l_1 is links[0]), as the paper numbers its links.


@dataclass(frozen=True)
class MassSum:
    """A sum of mass symbols: m_w n_w (if ``weighted`` is set) + sum of m_i for i in ``plain``.

    E.g. (m_2 n_2 + m_3 + m_4): ``MassSum(weighted=1, plain=(2, 3))``. Value in kg.
    """

    weighted: int | None
    plain: tuple[int, ...]

    def value(self, p: Parameters) -> float:
        own = 0.0 if self.weighted is None else p.mass[self.weighted] * p.com[self.weighted]
        return own + math.fsum(p.mass[i] for i in self.plain)


@dataclass(frozen=True)
class Coefficient:
    """factor * ( I_inertia + masses * prod(l_k for k in lengths) * (g if gravity) ).

    ``inertia``: link whose I (about the start hinge) is added, or None. ``lengths`` may
    repeat an index (l_1 l_1 prints as l_1^2). Units: kg m^2 (times m/s^2 with g).
    """

    factor: int = 1
    inertia: int | None = None
    masses: MassSum | None = None
    lengths: tuple[int, ...] = ()
    gravity: bool = False

    def value(self, p: Parameters) -> float:
        total = 0.0 if self.inertia is None else p.inertia_start[self.inertia]
        if self.masses is not None:
            product = self.masses.value(p) * math.prod(p.length[k] for k in self.lengths)
            total += product * (p.gravity if self.gravity else 1.0)
        return self.factor * total


@dataclass(frozen=True)
class Trig:
    """cos or sin of (psi_first - psi_second), or of psi_first alone when second is None."""

    function: str  # "cos" | "sin"
    first: int
    second: int | None = None

    def value(self, psi: np.ndarray) -> np.ndarray:
        angle = psi[..., self.first]
        if self.second is not None:
            angle = angle - psi[..., self.second]
        return np.cos(angle) if self.function == "cos" else np.sin(angle)


@dataclass(frozen=True)
class Rate:
    """dpsi_link (order 1, rad/s) or ddpsi_link (order 2, rad/s^2)."""

    link: int
    order: int


@dataclass(frozen=True)
class Term:
    """sign * coefficient * trig * product of rates: one summand of an equation or energy."""

    sign: int
    coefficient: Coefficient
    trig: Trig | None = None
    rates: tuple[Rate, ...] = ()

    def value(self, p: Parameters, psi, dpsi=None, ddpsi=None) -> np.ndarray:
        """Numeric value for angles psi (..., n) rad and rates (..., n); shape (...)."""
        psi = np.asarray(psi, dtype=float)
        out = self.sign * self.coefficient.value(p) * np.ones(psi.shape[:-1])
        if self.trig is not None:
            out = out * self.trig.value(psi)
        for rate in self.rates:
            source = dpsi if rate.order == 1 else ddpsi
            out = out * np.asarray(source, dtype=float)[..., rate.link]
        return out


@dataclass(frozen=True)
class Equation:
    """Lagrange's equation of psi_link: sum(terms) = M_link - sum_{c in children} M_c."""

    link: int
    terms: tuple[Term, ...]
    children: tuple[int, ...]


@dataclass(frozen=True)
class Parameters:
    """Numeric values of the symbols l_i (m), m_i (kg), n_i, I_i (kg m^2), g (m/s^2)."""

    length: tuple[float, ...]
    mass: tuple[float, ...]
    com: tuple[float, ...]
    inertia_start: tuple[float, ...]
    gravity: float

    @classmethod
    def from_linkage(cls, linkage: Linkage) -> Parameters:
        """The symbol values of a linkage; I_i = J_i + m_i (n_i l_i)^2 (errata 1)."""
        links = linkage.links
        return cls(
            length=tuple(link.length for link in links),
            mass=tuple(link.mass for link in links),
            com=tuple(link.com for link in links),
            inertia_start=tuple(link.inertia_about_start for link in links),
            gravity=linkage.gravity,
        )


@dataclass(frozen=True)
class EquationsOfMotion:
    """A paper-form tree's equations of motion, kinetic energy (as 2T) and potential energy,
    as symbolic terms with the tree's numeric parameters attached.

    Angles psi (n,) or (K, n) rad; dpsi rad/s; ddpsi rad/s^2.
    """

    linkage: Linkage
    equations: tuple[Equation, ...]
    kinetic_doubled: tuple[Term, ...]  # terms of 2T (14), J
    potential: tuple[Term, ...]  # terms of Pi (15), J

    @property
    def parameters(self) -> Parameters:
        """Values of the symbols for :attr:`linkage` (what the evaluators below use)."""
        return Parameters.from_linkage(self.linkage)

    def _state(self, **arrays) -> list[np.ndarray]:
        """Validate state arrays: numeric, finite, last axis n."""
        return [check_states(name, value, self.linkage.n) for name, value in arrays.items()]

    def term_values(self, psi, dpsi, ddpsi) -> list[np.ndarray]:
        """Per equation, the value of each term: list of n arrays of shape (..., n_terms), N m."""
        psi, dpsi, ddpsi = self._state(psi=psi, dpsi=dpsi, ddpsi=ddpsi)
        p = self.parameters
        return [
            np.stack([t.value(p, psi, dpsi, ddpsi) for t in eq.terms], axis=-1)
            for eq in self.equations
        ]

    def generalized_forces(self, psi, dpsi, ddpsi) -> np.ndarray:
        """Left-hand sides Q_k = M_k - sum_children M_c, N m: (n,) or (K, n)."""
        return np.stack([v.sum(axis=-1) for v in self.term_values(psi, dpsi, ddpsi)], axis=-1)

    def hinge_torques(self, psi, dpsi, ddpsi) -> np.ndarray:
        """Hinge torques M, N m, from the right-hand sides: M_k = Q_k + sum_children M_c."""
        q = self.generalized_forces(psi, dpsi, ddpsi)
        torque = np.array(q, copy=True)
        for eq in reversed(self.equations):  # children come after their parents
            for c in eq.children:
                torque[..., eq.link] += torque[..., c]
        return torque

    def kinetic_energy(self, psi, dpsi) -> np.ndarray:
        """T, J: half the sum of the 2T terms."""
        psi, dpsi = self._state(psi=psi, dpsi=dpsi)
        p = self.parameters
        return 0.5 * sum(t.value(p, psi, dpsi) for t in self.kinetic_doubled)

    def potential_energy(self, psi) -> np.ndarray:
        """Pi, J (zero at the height of H0)."""
        (psi,) = self._state(psi=psi)
        p = self.parameters
        return sum(t.value(p, psi) for t in self.potential)


# ---- building the structure ---------------------------------------------------------------
def _check_paper_form(linkage: Linkage) -> None:
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    for i, link in enumerate(linkage.links):
        if link.com_lateral != 0.0:
            why = (
                f"its centre of mass lies off its axis (com_lateral={link.com_lateral!r}, as "
                "after Linkage.lock at a non-zero angle)"
            )
        elif link.origin is not None:
            where = (
                "H0 is not at the origin"
                if linkage.parents[i] < 0
                else (
                    "it does not start at its parent's end hinge (a child re-hung by Linkage.lock)"
                )
            )
            why = f"{where}: origin={link.origin!r}"
        else:
            continue
        raise DefinitionError(
            f"`links[{i}]` ({link.name!r}): {why}. The paper's symbolic form (16)-(21) needs "
            "every centre of mass on its link's axis and every link starting at its parent's "
            "end hinge (root at H0 = 0); model.Dynamics handles this tree numerically"
        )


def _strict_descendants(linkage: Linkage, k: int) -> tuple[int, ...]:
    return tuple(i for i in linkage.subtree(k) if i != k)


def _coupling(linkage: Linkage, k: int, m: int) -> Coefficient | None:
    """B_km as symbols (None when k and m lie on different branches: no coupling)."""
    if k == m:
        below = _strict_descendants(linkage, k)
        masses = MassSum(None, below) if below else None
        return Coefficient(inertia=k, masses=masses, lengths=(k, k) if below else ())
    upper, lower = (k, m) if k in linkage.ancestors(m) else (m, k)
    if upper not in linkage.ancestors(lower):
        return None
    masses = MassSum(lower, _strict_descendants(linkage, lower))
    return Coefficient(masses=masses, lengths=(upper, lower))


def _ordered_trig(function: str, k: int, m: int) -> tuple[int, Trig]:
    """f(psi_k - psi_m) written with the lower index first, as the paper does; the sign
    absorbs the swap for sin (odd) and not for cos (even)."""
    if k < m:
        return 1, Trig(function, k, m)
    return (-1 if function == "sin" else 1), Trig(function, m, k)


def equations_of_motion(linkage: Linkage) -> EquationsOfMotion:
    """The symbolic equations of motion, 2T and Pi of a paper-form tree.

    Term order follows the paper: in each equation the ddpsi terms in link order, then the
    dpsi^2 terms, then gravity; in 2T the squares first, then the cross terms ordered by
    their second index.

    Raises
    ------
    DefinitionError
        When a link is not of the paper's form, naming the link and why.
    """
    _check_paper_form(linkage)
    n = linkage.n
    coupling = {(k, m): _coupling(linkage, k, m) for k in range(n) for m in range(n)}
    equations = []
    for k in range(n):
        terms = []
        for m in range(n):
            b = coupling[k, m]
            if b is None:
                continue
            if k == m:
                terms.append(Term(1, b, None, (Rate(m, 2),)))
            else:
                sign, trig = _ordered_trig("cos", k, m)
                terms.append(Term(sign, b, trig, (Rate(m, 2),)))
        for m in range(n):
            b = coupling[k, m]
            if b is None or k == m:
                continue
            # Lagrange: d/dt dT/d(dpsi_k) - dT/dpsi_k leaves B_km sin(psi_k - psi_m) dpsi_m^2
            # (errata 3: the square of the *other* link's rate).
            sign, trig = _ordered_trig("sin", k, m)
            terms.append(Term(sign, b, trig, (Rate(m, 1), Rate(m, 1))))
        weight = Coefficient(
            masses=MassSum(k, _strict_descendants(linkage, k)), lengths=(k,), gravity=True
        )
        terms.append(Term(1, weight, Trig("cos", k)))
        equations.append(Equation(k, tuple(terms), linkage.children[k]))

    kinetic = [Term(1, coupling[k, k], None, (Rate(k, 1), Rate(k, 1))) for k in range(n)]
    for m in range(n):
        for k in range(m):
            b = coupling[k, m]
            if b is None:
                continue
            # 2T counts each cross pair twice (errata 2: (14) as printed lacks this 2).
            doubled = Coefficient(factor=2, masses=b.masses, lengths=b.lengths)
            kinetic.append(Term(1, doubled, Trig("cos", k, m), (Rate(k, 1), Rate(m, 1))))
    potential = tuple(
        Term(
            1,
            Coefficient(
                masses=MassSum(k, _strict_descendants(linkage, k)), lengths=(k,), gravity=True
            ),
            Trig("sin", k),
        )
        for k in range(n)
    )
    return EquationsOfMotion(linkage, tuple(equations), tuple(kinetic), potential)


# ---- rendering ------------------------------------------------------------------------------
class _Style:
    """Symbol spellings for one output format."""

    def __init__(self, latex: bool) -> None:
        self.latex = latex

    def sub(self, base: str, index: int) -> str:
        label = str(index + 1)
        if self.latex and len(label) > 1:
            label = "{" + label + "}"
        return f"{base}_{label}"

    def psi(self, k: int) -> str:
        return self.sub(r"\psi" if self.latex else "psi", k)

    def rate(self, k: int, order: int) -> str:
        if self.latex:
            accent = r"\dot" if order == 1 else r"\ddot"
            return accent + "{" + r"\psi" + "}" + self.sub("", k)
        return self.sub("d" * order + "psi", k)

    def trig(self, t: Trig) -> str:
        name = "\\" + t.function if self.latex else t.function
        if t.second is None:
            return f"{name} {self.psi(t.first)}"
        return f"{name}({self.psi(t.first)} - {self.psi(t.second)})"

    def masses(self, s: MassSum) -> str:
        items = []
        if s.weighted is not None:
            items.append(f"{self.sub('m', s.weighted)} {self.sub('n', s.weighted)}")
        items += [self.sub("m", i) for i in s.plain]
        text = " + ".join(items)
        return f"({text})" if len(items) > 1 else text

    def lengths(self, ks: Sequence[int]) -> str:
        parts = []
        for k in dict.fromkeys(ks):  # keeps first-seen order
            power = ks.count(k)
            parts.append(self.sub("l", k) + (f"^{power}" if power > 1 else ""))
        return " ".join(parts)

    def rates(self, rates: Sequence[Rate]) -> str:
        parts = []
        for r in dict.fromkeys(rates):
            power = rates.count(r)
            parts.append(self.rate(r.link, r.order) + (f"^{power}" if power > 1 else ""))
        return " ".join(parts)

    def torque(self, k: int) -> str:
        return self.sub("M", k)

    def inertia(self, k: int) -> str:
        return self.sub("I", k)

    @property
    def potential_symbol(self) -> str:
        return r"\Pi" if self.latex else "Pi"


def _render_term(term: Term, style: _Style, trig_before_lengths: bool) -> str:
    """The magnitude of a term (its sign is rendered by the caller), in the paper's order:
    equations of motion write "(masses) cos(psi_1 - psi_2) l_1 l_2 ddpsi_2" (16)-(21), the
    energies "(masses) l_1 l_2 cos(psi_1 - psi_2) ..." and "(masses) g l_1 sin psi_1"
    (14)-(15)."""
    c = term.coefficient
    parts = [] if c.factor == 1 else [str(c.factor)]
    if c.inertia is not None:
        if c.masses is None:
            parts.append(style.inertia(c.inertia))
        else:
            # [I_1 + (m_2 + ... + m_6) l_1^2]: the bracket of (14) and (16)
            mass = f"{style.masses(c.masses)} {style.lengths(c.lengths)}"
            parts.append(f"[{style.inertia(c.inertia)} + {mass}]")
    else:
        parts.append(style.masses(c.masses))
        if c.gravity:
            parts.append("g")
        two_angle = term.trig is not None and term.trig.second is not None
        if two_angle and trig_before_lengths:
            parts += [style.trig(term.trig), style.lengths(c.lengths)]
        else:
            parts.append(style.lengths(c.lengths))
            if term.trig is not None:
                parts.append(style.trig(term.trig))
    if term.rates:
        parts.append(style.rates(term.rates))
    return " ".join(parts)


def _render_sum(terms: Iterable[Term], style: _Style, trig_before_lengths: bool) -> list[str]:
    """Terms as lines "+ ..." / "- ..." (the first without a leading plus)."""
    lines = []
    for i, term in enumerate(terms):
        body = _render_term(term, style, trig_before_lengths)
        if term.sign < 0:
            lines.append(f"- {body}")
        else:
            lines.append(body if i == 0 else f"+ {body}")
    return lines


def _right_hand_side(eq: Equation, style: _Style) -> str:
    return " - ".join([style.torque(eq.link)] + [style.torque(c) for c in eq.children])


#: Parent indices of the six-link tree of scene.md, whose equations the paper numbers (16)-(21).
_PAPER_PARENTS = tuple(
    -1 if parent is None else [row[0] for row in SIX_LINK_TABLE].index(parent)
    for _, parent, *_ in SIX_LINK_TABLE
)


def _first_number(linkage: Linkage, first_number: int | None) -> int:
    if first_number is None:
        return 16 if linkage.parents == _PAPER_PARENTS else 1
    if isinstance(first_number, bool) or not isinstance(first_number, int):
        raise DefinitionTypeError(f"`first_number`: must be an int or None, got {first_number!r}")
    return first_number


def _legend(linkage: Linkage) -> list[str]:
    rows = []
    for i, link in enumerate(linkage.links):
        parent = "ground (H0)" if link.parent is None else f"link {linkage.parents[i] + 1}"
        rows.append(f"  {i + 1}: {link.name}, on {parent}")
    return rows


def equations_text(
    linkage: Linkage, first_number: int | None = None, include_energy: bool = True
) -> str:
    """The equations of motion of a paper-form tree as plain text, in the paper's symbols.

    For the six-link scene this is the corrected (16)-(21) (``shared/errata.md``).
    ``first_number``: label of the first equation; None: 16 for a tree shaped like the
    paper's six-link mechanism (so the labels match the paper), else 1. With
    ``include_energy`` the text also gives 2T (14, corrected) and Pi (15).

    Raises DefinitionError for a tree that is not of the paper's form.
    """
    system = equations_of_motion(linkage)
    style = _Style(latex=False)
    number = _first_number(linkage, first_number)
    out = [
        f"Equations of motion of a {linkage.n}-link planar tree "
        "(Lagrange's equations of the second kind).",
        "Links (i: name, start hinge):",
        *_legend(linkage),
        "Symbols: l_i length (m), m_i mass (kg),",
        "  n_i centre-of-mass position from the start hinge as a fraction of l_i,",
        "  I_i = J_i + m_i (n_i l_i)^2 moment of inertia about the start hinge (kg m^2),",
        "  g gravity (m/s^2, along -y), psi_i absolute angle from +x (rad),",
        "  dpsi_i = d psi_i/dt, ddpsi_i = d^2 psi_i/dt^2,",
        "  M_i hinge torque on link i from its parent (from the ground for the root), N m.",
        "",
    ]
    for offset, eq in enumerate(system.equations):
        label = f"({number + offset})"
        lines = _render_sum(eq.terms, style, trig_before_lengths=True)
        pad = " " * (len(label) + 1)
        out.append(f"{label} {lines[0]}")
        out += [pad + line for line in lines[1:]]
        out.append(f"{pad}= {_right_hand_side(eq, style)}")
        out.append("")
    if include_energy:
        paper = linkage.parents == _PAPER_PARENTS
        for title, symbol, terms in (
            ("Kinetic energy" + (" (14)" if paper else "") + ":", "2T", system.kinetic_doubled),
            ("Potential energy" + (" (15)" if paper else "") + ":", "Pi", system.potential),
        ):
            lines = _render_sum(terms, style, trig_before_lengths=False)
            out.append(title)
            out.append(f"{symbol} = {lines[0]}")
            out += [" " * (len(symbol) + 3) + line for line in lines[1:]]
            out.append("")
    return "\n".join(out).rstrip() + "\n"


def equations_latex(
    linkage: Linkage, first_number: int | None = None, include_energy: bool = True
) -> str:
    """The same equations as :func:`equations_text`, as LaTeX (amsmath ``aligned`` blocks
    tagged with their numbers), one term per line as in the paper.

    Raises DefinitionError for a tree that is not of the paper's form.
    """
    system = equations_of_motion(linkage)
    style = _Style(latex=True)
    number = _first_number(linkage, first_number)
    blocks = []

    def block(lines: list[str], tail: str, tag: str | None) -> str:
        body = " \\\\\n".join(f"  & {line}" for line in lines)
        body += f" {tail}" if tail else ""
        head = "\\begin{equation}\n\\begin{aligned}\n"
        end = "\n\\end{aligned}" + (f"\n\\tag{{{tag}}}" if tag else "") + "\n\\end{equation}"
        return head + body + end

    for offset, eq in enumerate(system.equations):
        lines = _render_sum(eq.terms, style, trig_before_lengths=True)
        blocks.append(block(lines, f"= {_right_hand_side(eq, style)}", str(number + offset)))
    if include_energy:
        paper = linkage.parents == _PAPER_PARENTS
        for symbol, terms, tag in (
            ("2T", system.kinetic_doubled, "14"),
            (style.potential_symbol, system.potential, "15"),
        ):
            lines = _render_sum(terms, style, trig_before_lengths=False)
            lines[0] = f"{symbol} = {lines[0]}"
            blocks.append(block(lines, "", tag if paper else None))
    return "\n\n".join(blocks) + "\n"


def equations_for_preset(name: str = "six-link", latex: bool = False) -> str:
    """The printed equations of a ready linkage of ``model.presets.PRESETS`` (text or LaTeX),
    for the command line: ``equations_for_preset("six-link")`` is the corrected (16)-(21)."""
    if name not in PRESETS:
        raise DefinitionError(f"`name`: unknown preset {name!r}; available: {sorted(PRESETS)}")
    linkage = PRESETS[name]()
    return equations_latex(linkage) if latex else equations_text(linkage)


# ---- operation counts --------------------------------------------------------------------
_ADD_SUB = {ca.OP_ADD, ca.OP_SUB}
_MUL = {ca.OP_MUL}
_DIV = {ca.OP_DIV, ca.OP_INV}
_TRIG = {
    ca.OP_SIN,
    ca.OP_COS,
    ca.OP_TAN,
    ca.OP_ASIN,
    ca.OP_ACOS,
    ca.OP_ATAN,
    ca.OP_ATAN2,
    ca.OP_SINH,
    ca.OP_COSH,
    ca.OP_TANH,
}
_IO = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_PARAMETER}

#: Keys of :func:`operation_counts`, in table order.
COUNT_KINDS = ("add_sub", "mul", "div", "trig", "other", "arithmetic", "total")


def operation_counts(function: ca.Function) -> dict[str, int]:
    """Instructions of an SX Function by kind.

    Returns a dict with ``add_sub`` (OP_ADD, OP_SUB), ``mul`` (OP_MUL), ``div`` (OP_DIV,
    OP_INV), ``trig`` (sin, cos, tan and their inverses/hyperbolic forms), ``other`` (every
    other computing instruction: negation, OP_SQ, OP_TWICE, sqrt, assignments, ...),
    ``arithmetic`` (the sum of those five: what runs per evaluation) and ``total``
    (``Function.n_instructions()``, which also counts reading inputs, writing outputs and
    loading constants). The figures of ``shared/errata.md`` (7) are totals.
    """
    if not isinstance(function, ca.Function):
        raise DefinitionTypeError(
            f"`function`: must be a casadi.Function, got {type(function).__name__}"
        )
    if not function.is_a("SXFunction"):
        raise DefinitionError(
            f"`function`: {function.name()!r} is not an SX Function (it is "
            f"{function.class_name()}); instruction counts are defined for SX only"
        )
    counts = dict.fromkeys(COUNT_KINDS, 0)
    total = function.n_instructions()
    for k in range(total):
        op = function.instruction_id(k)
        if op in _IO:
            continue
        if op in _ADD_SUB:
            counts["add_sub"] += 1
        elif op in _MUL:
            counts["mul"] += 1
        elif op in _DIV:
            counts["div"] += 1
        elif op in _TRIG:
            counts["trig"] += 1
        else:
            counts["other"] += 1
        counts["arithmetic"] += 1
    counts["total"] = total
    return counts


# ---- automatic-differentiation derivations (comparison and cross-check) ---------------------
#: Functions an AD derivation provides, with the same inputs and outputs as model.FUNCTIONS.
AD_FUNCTIONS = (
    "com_positions",
    "energy",
    "mass_matrix",
    "gravity_torques",
    "inverse_dynamics",
    "forward_dynamics",
)

_FORMS = ("complex", "trig")
_TIME_DERIVATIVES = ("jtimes", "jacobian")


def _ad_energies(linkage: Linkage, form: str, psi: ca.SX, dpsi: ca.SX) -> tuple[ca.SX, ...]:
    """T and Pi (J), and the centres of mass x, y (m, (n,) each), of any tree, written from
    positions the plain way.

    ``complex``: w_i = sum o_k e^{j psi_parent} + c_i e^{j psi_i} as real/imaginary pairs,
    each phasor e^{j psi_k} formed once; velocities by the paper's rule d/dt e^{j psi} =
    j dpsi e^{j psi} (7)-(12). ``trig``: the textbook projections x_i = sum l cos psi,
    y_i = sum l sin psi and their time derivatives, each coordinate written as its own sum
    (so cos psi_k and sin psi_k are evaluated in every coordinate that uses them, which is
    exactly what separates the two forms in CasADi's instruction count).
    General links (off-axis centres of mass, moved hinges) are handled through the complex
    constants o_k and c_i of Linkage.
    """
    links = linkage.links
    origins = [linkage.origin_in_parent(i) for i in range(linkage.n)]
    kinetic: ca.SX = ca.SX(0)
    potential: ca.SX = ca.SX(0)
    phasor = [expj(psi[k]) for k in range(linkage.n)] if form == "complex" else None
    com_x, com_y = [], []
    for i, link in enumerate(links):
        # (angle index, complex lever in that link's frame): w_i = const + sum lever e^{j psi}
        chain = []
        for k in (*linkage.ancestors(i), i):
            p = linkage.parents[k]
            if p >= 0:
                chain.append((p, origins[k]))
        chain.append((i, link.com_offset))
        base = origins[0]  # H0's fixed position in the world
        if form == "complex":
            w = Cx(base.real, base.imag)
            v = Cx(0.0, 0.0)
            for k, lever in chain:
                w = w + phasor[k] * lever
                v = v + phasor[k].times_j().scale(dpsi[k]) * lever
            x, y, vx, vy = w.re, w.im, v.re, v.im
        else:
            # Re/Im of lever e^{j psi} written with cos and sin of the angle directly.
            x = base.real + sum(
                lever.real * ca.cos(psi[k]) - lever.imag * ca.sin(psi[k]) for k, lever in chain
            )
            y = base.imag + sum(
                lever.real * ca.sin(psi[k]) + lever.imag * ca.cos(psi[k]) for k, lever in chain
            )
            vx = sum(
                -(lever.real * ca.sin(psi[k]) + lever.imag * ca.cos(psi[k])) * dpsi[k]
                for k, lever in chain
            )
            vy = sum(
                (lever.real * ca.cos(psi[k]) - lever.imag * ca.sin(psi[k])) * dpsi[k]
                for k, lever in chain
            )
        kinetic = kinetic + 0.5 * link.mass * (vx * vx + vy * vy)
        kinetic = kinetic + 0.5 * link.inertia * dpsi[i] * dpsi[i]
        potential = potential + linkage.gravity * link.mass * y
        com_x.append(x)
        com_y.append(y)
    return kinetic, potential, ca.vertcat(*com_x), ca.vertcat(*com_y)


def _subtree_sums(linkage: Linkage, q: ca.SX) -> ca.SX:
    """Hinge torques from generalised forces: M_k = sum of Q over the subtree of k."""
    return ca.vertcat(*[sum(q[i] for i in linkage.subtree(k)) for k in range(linkage.n)])


def _generalized_from_torques(linkage: Linkage, torque: ca.SX) -> ca.SX:
    """Q_k = M_k - sum_{children c} M_c."""
    return ca.vertcat(
        *[torque[k] - sum(torque[c] for c in linkage.children[k]) for k in range(linkage.n)]
    )


def ad_function(
    linkage: Linkage, name: str, form: str = "complex", time_derivative: str = "jtimes"
) -> ca.Function:
    """One Function of a plain AD Lagrange derivation, named and shaped as in model.FUNCTIONS.

    Parameters
    ----------
    linkage : Linkage
        Any tree; numeric parameters are baked in.
    name : str
        One of :data:`AD_FUNCTIONS`.
    form : {"complex", "trig"}
        Positions as complex exponentials or as trigonometric projections (see
        :func:`_ad_energies`).
    time_derivative : {"jtimes", "jacobian"}
        How d/dt dT/d(dpsi) is formed: one forward directional derivative
        ``jtimes(p, [psi; dpsi], [dpsi; ddpsi])``, or the full Jacobians
        ``jacobian(p, psi) dpsi + jacobian(p, dpsi) ddpsi``.

    The Lagrange equations are d/dt dT/d(dpsi) - dT/dpsi + dPi/dpsi = Q; hinge torques are
    subtree sums of Q. The mass matrix is the Jacobian of dT/d(dpsi) in dpsi, forward
    dynamics solves it symbolically with ``casadi.solve`` (dense QR). ``com_positions`` is
    the plain position formula itself (no derivative), the quantity on which the two forms
    differ most simply.
    """
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    if name not in AD_FUNCTIONS:
        raise DefinitionError(f"`name`: {name!r} has no AD derivation; choose from {AD_FUNCTIONS}")
    if form not in _FORMS:
        raise DefinitionError(f"`form`: must be one of {_FORMS}, got {form!r}")
    if time_derivative not in _TIME_DERIVATIVES:
        raise DefinitionError(
            f"`time_derivative`: must be one of {_TIME_DERIVATIVES}, got {time_derivative!r}"
        )
    n = linkage.n
    psi, dpsi = ca.SX.sym("psi", n), ca.SX.sym("dpsi", n)
    ddpsi, torque = ca.SX.sym("ddpsi", n), ca.SX.sym("M", n)
    kinetic, potential, com_x, com_y = _ad_energies(linkage, form, psi, dpsi)
    momentum = ca.gradient(kinetic, dpsi)

    def lagrange(acceleration) -> ca.SX:
        if time_derivative == "jtimes":
            rate = ca.jtimes(momentum, ca.vertcat(psi, dpsi), ca.vertcat(dpsi, acceleration))
        else:
            rate = ca.mtimes(ca.jacobian(momentum, psi), dpsi) + ca.mtimes(
                ca.jacobian(momentum, dpsi), acceleration
            )
        return rate - ca.gradient(kinetic, psi) + ca.gradient(potential, psi)

    if name == "com_positions":
        symbols, outputs = [psi], [com_x, com_y]
    elif name == "energy":
        symbols, outputs = [psi, dpsi], [kinetic, potential]
    elif name == "mass_matrix":
        symbols, outputs = [psi], [ca.jacobian(momentum, dpsi)]
        # T is quadratic in dpsi: its Hessian does not depend on dpsi; substitute to drop it.
        outputs = [ca.substitute(outputs[0], dpsi, ca.DM.zeros(n))]
    elif name == "gravity_torques":
        symbols, outputs = [psi], [_subtree_sums(linkage, ca.gradient(potential, psi))]
    elif name == "inverse_dynamics":
        symbols, outputs = [psi, dpsi, ddpsi], [_subtree_sums(linkage, lagrange(ddpsi))]
    else:
        bias = lagrange(ca.DM.zeros(n))
        mass = ca.jacobian(momentum, dpsi)
        rhs = _generalized_from_torques(linkage, torque) - bias
        symbols, outputs = [psi, dpsi, torque], [ca.solve(mass, rhs)]
    inputs, output_names, _ = FUNCTIONS[name]
    return ca.Function(f"ad_{form}_{name}", symbols, outputs, list(inputs), list(output_names))


#: Derivations compared by :func:`derivation_comparison`: label -> (form, time_derivative).
DERIVATIONS = {
    "ours": None,
    "ad_complex": ("complex", "jtimes"),
    "ad_trig": ("trig", "jtimes"),
    "ad_complex_jacobian": ("complex", "jacobian"),
    "ad_trig_jacobian": ("trig", "jacobian"),
}


def derivation_comparison(
    linkage: Linkage,
    functions: Sequence[str] = (
        "com_positions",
        "energy",
        "mass_matrix",
        "gravity_torques",
        "inverse_dynamics",
    ),
    derivations: Sequence[str] = ("ours", "ad_complex", "ad_trig"),
) -> list[dict]:
    """Operation counts of each function under each derivation.

    Returns rows ``{"function", "derivation", **operation_counts}``, one per pair, in the
    order given. ``ours`` is :class:`model.Dynamics`; the AD labels are in
    :data:`DERIVATIONS` (``forward_dynamics`` may also be asked for; its AD form solves a
    dense symbolic system and grows quickly with n).
    """
    for name in functions:
        if name not in AD_FUNCTIONS:
            raise DefinitionError(
                f"`functions`: {name!r} has no AD derivation; choose from {AD_FUNCTIONS}"
            )
    for label in derivations:
        if label not in DERIVATIONS:
            raise DefinitionError(
                f"`derivations`: unknown {label!r}; choose from {list(DERIVATIONS)}"
            )
    dynamics = Dynamics(linkage)
    rows = []
    for name in functions:
        for label in derivations:
            if label == "ours":
                function = dynamics.function(name)
            else:
                form, time_derivative = DERIVATIONS[label]
                function = ad_function(linkage, name, form, time_derivative)
            rows.append({"function": name, "derivation": label, **operation_counts(function)})
    return rows


def format_comparison(rows: Sequence[dict]) -> str:
    """Rows of :func:`derivation_comparison` as an aligned plain-text table."""
    header = ("function", "derivation", *COUNT_KINDS)
    table = [header] + [tuple(str(row[key]) for key in header) for row in rows]
    widths = [max(len(r[c]) for r in table) for c in range(len(header))]
    lines = [
        "  ".join(
            cell.ljust(w) if c < 2 else cell.rjust(w)
            for c, (cell, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in table
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines) + "\n"
