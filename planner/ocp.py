"""The optimal control problem as a value: dynamics, horizon, mesh, bounds, constraints, cost.

An :class:`OCP` is a frozen dataclass. Builder methods (``bound``, ``constrain``,
``constrain_at``, ``boundary``, ``initial``, ``final``, ``periodic``, ``minimize``, ``scale``,
``guess``) return a new OCP and never change the old one, so a definition can be printed,
copied (``dataclasses.replace``, ``copy.copy``), refined (``ocp.refine(N=80)``) and solved any
number of times. Every argument is validated when it is given: a mistake raises
:class:`planner.errors.DefinitionError` (or ``DefinitionTypeError``) naming the field, the value
and the fix, never a CasADi stack trace at solve time.

>>> ocp = (OCP(dynamics, T=1.0, N=50)                   # model.Dynamics: psi, dpsi; M
...        .bound("M", -150, 150)                        # a group, or one name: "M_torso"
...        .periodic()                                   # x(0) = x(T)
...        .minimize(integral=lambda p: ca.sumsqr(p.M))  # p: a Point, see below
...        .guess(gait_law))                             # t -> (psi, dpsi, ddpsi)
>>> solution = ocp.solve()

Expressions (path, keypoint and boundary constraints, objective terms) are Python callables
of a :class:`Point`, or CasADi Functions whose input names pick the Point's fields (``x``,
``u``, ``z``, ``t``, ``T``, a group such as ``psi`` or ``M``, or a variable name); a Function
with several outputs gives a constraint one row block, rows named after the outputs. Besides
the variables, a Point offers fields computed from them: a linkage's ``ddpsi`` in both
formulations and control rates (``du``; a linkage's ``dM``, ``dM_<link>``).

Variables. The OCP knows its model only through a :class:`planner.system.System`, which names
them: states x (nx,), controls u (nu,) and, in the implicit formulation, auxiliary variables
z (nz,) that stand for the state derivatives the residual needs, with their groups and units.
A model that knows how to be one offers ``as_system`` (:class:`planner.system.SystemSource`):
a ``model.Dynamics`` through the linkage adapter (:mod:`model.linkage_system`, the linkage
naming convention, which the planner never spells): x = [psi;
dpsi] (states ``psi_<link>`` rad, ``dpsi_<link>`` rad/s), u = M (``M_<link>``, N m) and,
implicit only, z = ddpsi (``ddpsi_<link>``, rad/s^2); groups ``psi``, ``dpsi``, ``ddpsi``,
``M``. A CasADi ODE Function f(x, u[, t]) -> xdot becomes one with groups ``x`` and ``u``;
with ``formulation="implicit"`` the Function is a residual r(x, xdot, u[, t]) (nx,) and
z = xdot. A System from any other adapter is taken as it is.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from planner import schemes
from planner.errors import (
    DefinitionError,
    DefinitionTypeError,
    as_float_array,
    check_finite,
    check_integer,
)
from planner.guesses import GuessLayer, SampledGuess, evaluate_guess_layer
from planner.schemes import DEFAULT_TRANSCRIPTION, TRANSCRIPTIONS
from planner.system import System, SystemSource

if TYPE_CHECKING:
    from typing import Self

FORMULATIONS = ("implicit", "explicit")
#: The name of an objective term given without one (``OCP.minimize``).
DEFAULT_TERM = "objective"


# ---- the Point: what expressions see -----------------------------------------------------
class Point:
    """Symbolic values at one point of the horizon, handed to user expressions.

    Fields: ``x`` (nx,), ``u`` (nu,), ``z`` (nz,), ``t`` (time, s), ``T`` (duration, s), every
    group (``p.psi``, ``p.M``, ...) as a column and every variable by name (``p.psi_torso``
    or ``p["psi_torso"]``), all CasADi SX, in physical units (scaling is the planner's).
    At a boundary (``boundary``, ``terminal``), ``x`` is the state at t0 or tf and ``x0``,
    ``xf`` both ends.

    Fields that are expressions, not variables, named by the :class:`System`:

    * derived groups (a linkage's ``ddpsi`` / ``ddpsi_<link>`` in the explicit formulation:
      forward dynamics of x and u; implicit, ddpsi is the variable z), built on first use;
    * control rates du/dt (``du``, a linkage's ``dM`` / ``dM_<link>``, a Function system's
      ``d<control>``), in control units per second, when ``du`` (nu,) is given: the time
      derivative of the transcription's control polynomial (see :meth:`OCP.constrain`). A
      rate name that is also a variable's name stays the variable; ``du`` always works.
    """

    def __init__(
        self,
        system: System,
        x,
        u,
        z,
        t,
        T,
        extra: Mapping[str, Any] | None = None,
        du=None,
    ):
        values: dict[str, Any] = {"x": x, "u": u, "z": z, "t": t, "T": T}
        for i, name in enumerate(system.state_names):
            values[name] = x[i]
        for i, name in enumerate(system.control_names):
            values[name] = u[i]
        for i, name in enumerate(system.aux_names):
            values[name] = z[i]
        for group, members in system.groups:
            if group not in values:
                values[group] = ca.vertcat(*[values[m] for m in members])
        if du is not None:
            for group in system.control_rate_groups:
                if isinstance(group, str):
                    values.setdefault(group, du)
                else:
                    values.setdefault(group[0], du[: group[1]])
            for i, name in enumerate(system.control_rate_names):
                values.setdefault(name, du[i])
        values.update(extra or {})
        # Derived fields cost an expression (forward dynamics: a mass-matrix solve) that most
        # problems never use: evaluated when first asked for.
        lazy: dict[str, tuple[int, int | None]] = {}
        for index, derived in enumerate(system.derived):
            if derived.group not in values:
                lazy[derived.group] = (index, None)
            for row, name in enumerate(derived.names):
                if name not in values:
                    lazy[name] = (index, row)
        object.__setattr__(self, "_system", system)
        object.__setattr__(self, "_values", values)
        object.__setattr__(self, "_lazy", lazy)
        object.__setattr__(self, "_derived", {})
        # Every field is an expression of x, u, z, t, T, du and the extras: their symbols are
        # all the symbols an expression of the point may use (found once, when first asked).
        sources = (x, u, z, t, T, *(() if du is None else (du,)), *(extra or {}).values())
        object.__setattr__(self, "_sources", sources)
        object.__setattr__(self, "_symbols", None)

    def _field(self, name: str):
        values = object.__getattribute__(self, "_values")
        if name in values:
            return values[name]
        lazy = object.__getattribute__(self, "_lazy")
        if name in lazy:
            index, row = lazy[name]
            cache = object.__getattribute__(self, "_derived")
            if index not in cache:
                derived = self._system.derived[index]
                v = values
                cache[index] = derived.function(v["x"], v["z"], v["u"], v["t"])
            return cache[index] if row is None else cache[index][row]
        raise KeyError(name)

    def __getattr__(self, name: str):
        try:
            return self._field(name)
        except KeyError:
            raise AttributeError(
                f"Point has no field {name!r}; fields: {sorted(self.fields)}"
            ) from None

    def __getitem__(self, name: str):
        try:
            return self._field(name)
        except KeyError:
            raise KeyError(f"Point has no field {name!r}; fields: {sorted(self.fields)}") from None

    def __setattr__(self, name, value):
        raise AttributeError("Point is read-only")

    @property
    def fields(self) -> tuple[str, ...]:
        return (*self._values, *self._lazy)

    @property
    def uses_derived(self) -> bool:
        """Whether an expression has asked for a derived field (e.g. explicit ddpsi)."""
        return bool(self._derived)

    def _symbol_hashes(self) -> frozenset[int]:
        """Element hashes of the SX symbols the point's fields are built from."""
        if self._symbols is None:
            hashes = {
                s.element_hash()
                for source in self._sources
                if isinstance(source, ca.SX)
                for s in ca.symvar(source)
            }
            object.__setattr__(self, "_symbols", frozenset(hashes))
        return self._symbols


def parameter_fields(names: tuple[str, ...], values) -> dict[str, Any]:
    """The Point fields of static parameters: each by name, and ``params`` (np,), from
    ``values`` (np,) (symbols or expressions) in the order of ``names``; none without
    parameters."""
    if not names:
        return {}
    fields = {name: values[i] for i, name in enumerate(names)}
    fields["params"] = values
    return fields


def evaluate_expression(label: str, expression, point: Point) -> ca.SX:
    """Evaluate a user expression (callable of a Point, or CasADi Function) to an SX column."""
    if isinstance(expression, ca.Function):
        args = []
        for name in expression.name_in():
            if name not in point.fields:
                raise DefinitionError(
                    f"`{label}`: Function input {name!r} is not a field of the point; "
                    f"name the inputs after fields such as {sorted(point.fields)[:12]}"
                )
            args.append(point[name])
        try:
            outputs = expression.call(args)
        except RuntimeError as exc:
            raise DefinitionError(f"`{label}`: calling the Function failed: {exc}") from exc
        if not outputs:
            raise DefinitionError(f"`{label}`: the Function has no output")
        # Several outputs stack into one column, output by output (each vectorised
        # column-major): rows named after the outputs (see expression_rows).
        result = outputs[0] if len(outputs) == 1 else ca.vertcat(*[ca.vec(o) for o in outputs])
    elif callable(expression):
        try:
            result = expression(point)
        except (AttributeError, KeyError) as exc:
            raise DefinitionError(f"`{label}`: {exc}") from exc
        except Exception as exc:  # a user's callable may fail in any way; say where
            raise DefinitionError(
                f"`{label}`: evaluating the expression failed: {type(exc).__name__}: {exc}; "
                "check shapes (p.x is (nx, 1)) and types of the Point's fields"
            ) from exc
    else:
        raise DefinitionTypeError(
            f"`{label}`: must be a callable of a Point or a casadi.Function, "
            f"got {type(expression).__name__}"
        )
    if isinstance(result, list | tuple):
        result = ca.vertcat(*result)
    if isinstance(result, int | float | np.ndarray | np.floating | ca.DM):
        result = ca.SX(ca.DM(result))
    if isinstance(result, ca.MX):
        raise DefinitionTypeError(
            f"`{label}`: returned an MX expression; build expressions from the Point's SX "
            "fields (use SX Functions)"
        )
    if not isinstance(result, ca.SX):
        raise DefinitionTypeError(
            f"`{label}`: must return a CasADi SX expression or numbers, got {type(result).__name__}"
        )
    if result.size2() != 1:
        if result.size1() == 1:
            result = result.T
        else:
            raise DefinitionError(f"`{label}`: must return a column vector, got {result.shape}")
    _check_symbols(label, result, point)
    return result


def expression_rows(expression, size: int) -> tuple[str, ...]:
    """Suffixes naming the ``size`` rows of an expression's value.

    A Function with several outputs: ``[<output>]`` for a one-element output and
    ``[<output>][i]`` for the elements of a longer one (column-major); otherwise ``""`` for a
    scalar and ``[i]`` for the rows of a vector.
    """
    if isinstance(expression, ca.Function) and expression.n_out() > 1:
        rows: list[str] = []
        for i in range(expression.n_out()):
            name, count = expression.name_out(i), expression.numel_out(i)
            rows.extend([f"[{name}]"] if count == 1 else [f"[{name}][{j}]" for j in range(count)])
        if len(rows) == size:
            return tuple(rows)
    return ("",) if size == 1 else tuple(f"[{i}]" for i in range(size))


def _check_symbols(label: str, result: ca.SX, point: Point) -> None:
    """Reject free symbols (not the Point's) and NaN/inf constants in ``result``."""
    free = _free_symbols(result, point._symbol_hashes())
    if free:
        raise DefinitionError(
            f"`{label}`: the expression uses free symbols {free} that are not fields of the "
            "point; build it from the Point's fields only"
        )
    _check_constants(label, result, "the expression")


def evaluate_mapping(label: str, mapping, x: ca.SX):
    """``mapping(x)`` (a callable of the SX state or a casadi.Function) as a column, checked:
    no free symbols but x's, no NaN or inf constants; raises DefinitionError naming
    ``label``."""
    try:
        value = mapping(x)
    except Exception as exc:  # a user's callable may fail in any way; say where
        raise DefinitionError(f"`{label}`: calling the mapping failed: {exc}") from exc
    if isinstance(value, list | tuple):
        value = ca.vertcat(*value)
    if isinstance(value, ca.SX):
        free = _free_symbols(value, {s.element_hash() for s in ca.symvar(x)})
        if free:
            raise DefinitionError(
                f"`{label}`: the mapping uses free symbols {free}; build it from the state "
                "argument only"
            )
        _check_constants(label, value, "the mapping")
    if not isinstance(value, ca.SX | ca.MX):
        raise DefinitionError(
            f"`{label}`: the mapping must return a state, got {type(value).__name__}"
        )
    return value


def _free_symbols(result: ca.SX, known: frozenset[int] | set[int]) -> list[str]:
    """Names of the symbols of ``result`` whose element hashes are not ``known``, sorted."""
    return sorted(str(s) for s in ca.symvar(result) if s.element_hash() not in known)


def _check_constants(label: str, result: ca.SX, subject: str) -> None:
    """Reject NaN/inf constants in the expression graph of ``result`` (``subject`` names it).

    The check inspects the constants of the graph, not a value at some test point, so an
    expression that is merely singular somewhere (1/x at x = 0) passes.
    """
    function = ca.Function("check", ca.symvar(result), [result])
    for k in range(function.n_instructions()):
        if function.instruction_id(k) == ca.OP_CONST:
            constant = function.instruction_constant(k)
            if not math.isfinite(constant):
                raise DefinitionError(
                    f"`{label}`: {subject} contains the constant {constant}; "
                    "NaN or inf in an NLP expression makes IPOPT stop (Invalid_Number_Detected)"
                )


# ---- validated pieces of a definition ---------------------------------------------------
@dataclass(frozen=True, eq=False)
class Constraint:
    """A named constraint lower <= g <= upper; ``where`` is "path", "start", "end" or "at".

    ``rows``: suffixes naming the rows of g (see :func:`expression_rows`). For ``where`` =
    "at", ``instants`` (K,) are the times (s) or, ``fraction`` True, the fractions of T where
    g holds, ``on`` the interpolant the point is read from ("transcription" or "motion",
    see :meth:`OCP.constrain_at`), and ``lower``, ``upper`` are (K, rows); otherwise they
    are (rows,).
    """

    name: str
    expression: Any
    lower: np.ndarray
    upper: np.ndarray
    where: str
    scale: np.ndarray | None = None
    rows: tuple[str, ...] = ()
    instants: tuple[float, ...] = ()
    fraction: bool = False
    on: str = "transcription"

    @property
    def size(self) -> int:
        """Rows of g at one point (one instant)."""
        return self.lower.shape[-1]

    def row_names(self) -> tuple[str, ...]:
        """``where[name]<row>`` for each row of g at one point."""
        rows = self.rows or expression_rows(None, self.size)
        return tuple(f"{self.where}[{self.name}]{row}" for row in rows)

    def instant_label(self, i: int) -> str:
        """Instant i as a row name shows it: "t=0.25 s" or "t=0.5 T"."""
        return f"t={self.instants[i]:.9g} " + ("T" if self.fraction else "s")

    def __repr__(self) -> str:
        bounds = _format_interval(self.lower, self.upper)
        if self.where == "at":
            times = ", ".join(f"{v:.9g}" for v in self.instants)
            unit = "T" if self.fraction else "s"
            return f"at[{self.name}] t = ({times}) {unit} in {bounds}"
        return f"{self.where}[{self.name}] in {bounds}"


@dataclass(frozen=True, eq=False)
class ObjectiveTerm:
    """A named term of the objective: the integral of ``integral(p)`` plus ``terminal(p)``
    at T (either may be None)."""

    name: str
    integral: Any = None
    terminal: Any = None

    def __repr__(self) -> str:
        parts = " + ".join(
            label for label in ("integral", "terminal") if getattr(self, label) is not None
        )
        return parts if self.name == DEFAULT_TERM else f"{self.name}: {parts}"


@dataclass(frozen=True, eq=False)
class Param:
    """A static parameter: bounds, guess (None: default) and nominal scale (None: default)."""

    name: str
    lower: float
    upper: float
    guess: float | None = None
    scale: float | None = None

    @property
    def initial(self) -> float:
        """The guess, or the middle of finite bounds, or the bound nearest 0, or 0."""
        if self.guess is not None:
            return self.guess
        if math.isfinite(self.lower) and math.isfinite(self.upper):
            return 0.5 * (self.lower + self.upper)
        return float(np.clip(0.0, self.lower, self.upper))

    @property
    def nominal(self) -> float:
        if self.scale is not None:
            return self.scale
        return float(default_scale(np.array([self.lower]), np.array([self.upper]))[0])


def _fractions(mesh, N: int) -> tuple[float, ...]:
    """Relative interval lengths as fractions of T (sum 1), checked against N."""
    array = as_float_array("mesh", mesh, "a sequence of N positive interval lengths")
    if array.ndim != 1 or array.size != N:
        raise DefinitionError(
            f"`mesh`: give N = {N} relative interval lengths, got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise DefinitionError(f"`mesh`: interval lengths must be finite and > 0, got {array}")
    fractions = array / np.sum(array)
    return tuple(float(f) for f in fractions)


def _format_interval(lower, upper) -> str:
    lo, hi = np.atleast_1d(lower), np.atleast_1d(upper)
    if lo.size == 1:
        return f"[{lo.flat[0]:g}, {hi.flat[0]:g}]"
    return f"[{lo.size} rows]"


def _numeric_bound(label: str, side: str, value) -> np.ndarray:
    """``value`` as a float array, or DefinitionTypeError naming the bound's side."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        message = f"`{label}`: {side} bound must be numeric, got {value!r}"
        raise DefinitionTypeError(message) from exc


def _as_bounds(label: str, lower, upper, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate and broadcast bounds to (size,) arrays; None means unbounded."""
    out = []
    for side, value, default in (("lower", lower, -np.inf), ("upper", upper, np.inf)):
        if value is None:
            out.append(np.full(size, default))
            continue
        array = _numeric_bound(label, side, value)
        if array.ndim == 0:
            array = np.full(size, float(array))
        array = array.reshape(-1) if array.ndim == 2 and 1 in array.shape else array
        if array.shape != (size,):
            raise DefinitionError(
                f"`{label}`: {side} bound has shape {np.shape(value)}, expected a scalar or "
                f"({size},)"
            )
        if np.any(np.isnan(array)):
            raise DefinitionError(f"`{label}`: {side} bound contains NaN; use +-inf for none")
        out.append(array.astype(float))
    lo, hi = out
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        i = int(bad[0])
        raise DefinitionError(
            f"`{label}`: lower bound {lo[i]:g} > upper bound {hi[i]:g}"
            + (f" (row {i})" if size > 1 else "")
            + "; swap them or widen the interval"
        )
    if np.any(lo == np.inf) or np.any(hi == -np.inf):
        raise DefinitionError(f"`{label}`: a lower bound of +inf or upper of -inf is infeasible")
    return lo, hi


def _per_output(label: str, side: str, expression, value):
    """A bound given per output of a multi-output Function ({"Fy": 0.0}) as a flat row
    array (outputs not named: unbounded); any other bound unchanged."""
    if not isinstance(value, Mapping):
        return value
    if not (isinstance(expression, ca.Function) and expression.n_out() > 1):
        raise DefinitionTypeError(
            f"`{label}`: a {side} bound by output name needs a casadi.Function with several "
            f"outputs; give a number or an array, got {value!r}"
        )
    outputs = expression.name_out()
    unknown = sorted(set(value) - set(outputs))
    if unknown:
        raise DefinitionError(
            f"`{label}`: {side} bound names unknown outputs {unknown}; the Function's outputs "
            f"are {outputs}"
        )
    default = -np.inf if side == "lower" else np.inf
    parts = []
    for i, output in enumerate(outputs):
        count = expression.numel_out(i)
        given = value.get(output)
        if given is None:
            parts.append(np.full(count, default))
            continue
        bound_lo, bound_hi = (given, None) if side == "lower" else (None, given)
        lo, hi = _as_bounds(f"{label}[{output}]", bound_lo, bound_hi, count)
        parts.append(lo if side == "lower" else hi)
    return np.concatenate(parts)


def _instant_bounds(
    label: str, lower, upper, rows: int, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of a constraint at ``count`` instants as (count, rows) arrays.

    Each side: None (unbounded), a scalar, (rows,) (every instant alike), (count, rows) (per
    instant), or (count,) for a scalar constraint (rows = 1)."""
    out = []
    for side, value in (("lower", lower), ("upper", upper)):
        if value is None:
            out.append(None)
            continue
        array = _numeric_bound(label, side, value)
        if array.ndim == 0 or array.shape == (rows,):
            array = np.broadcast_to(array, (count, rows))
        elif rows == 1 and array.shape == (count,):
            array = array[:, None]
        if array.shape != (count, rows):
            raise DefinitionError(
                f"`{label}`: {side} bound has shape {np.shape(value)}; expected a scalar, "
                f"({rows},) for every instant alike, or ({count}, {rows}) per instant "
                f"({count} instants, {rows} rows)"
            )
        out.append(array.reshape(-1))
    lo, hi = _as_bounds(label, out[0], out[1], count * rows)
    return lo.reshape(count, rows), hi.reshape(count, rows)


def default_scale(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Nominal magnitude from bounds: the largest finite |bound|, or 1 when there is none."""
    stacked = np.abs(np.vstack([lower, upper]))
    stacked[~np.isfinite(stacked)] = 0.0
    scale = stacked.max(axis=0)
    scale[scale == 0.0] = 1.0
    return scale


# ---- the OCP ------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class OCPDefinition:
    """An optimal control problem on a fixed or free horizon [0, T], transcribed on N intervals.

    The definition, as a value; :class:`planner.OCP` is this class with ``transcribe()`` and
    ``solve()`` (:mod:`planner.problem`), which need the layers built on it.

    Parameters
    ----------
    dynamics : a model that is a :class:`planner.system.SystemSource` (``model.Dynamics``), a
        ``planner.System``, or a casadi.Function f(x, u[, t]) -> xdot (``formulation``
        "explicit", the default for Functions) or r(x, xdot, u[, t]) -> (nx,) ("implicit").
    T : duration, s: a number (fixed) or a pair (lower, upper) (free; guess with ``guess(T=)``).
    N : number of mesh intervals, >= 1 (uniform, h = T / N, unless ``mesh`` is given).
    transcription : a name of the registry :mod:`planner.schemes`: "trapezoid",
        "hermite-simpson" (separated form, midpoint controls are variables), "radau" or
        "legendre" (orthogonal collocation of ``degree`` 1..9, default 3; controls and,
        implicit, ddpsi at the collocation points).
    formulation : "implicit" (default for a Dynamics: ddpsi are variables, dynamics_residual = 0
        at every dynamics point, no mass-matrix solve) or "explicit" (forward dynamics).
    state_names, control_names, state_units, control_units : for a Function only.
    mesh : relative lengths of the N intervals (a sequence of N positive numbers, scaled to sum
        to 1: the fractions of T), for a non-uniform mesh; None (default): uniform.
    contacts : points of a linkage held by the ground (link names for their end hinges, or
        ``model.LinkPoint``): their ground forces become controls ``F_<point>_x/_y`` (group
        ``F``, N) acting on the tree (the model's ``as_system`` places them); a model only.
    dynamics_params : names of static parameters the dynamics Function reads: its last
        inputs, one scalar each, in this order (f(x, u[, t], p_1, ..., p_m)); declare each
        with :meth:`param` (bounds, guess, scale) so that it is designed with the motion
        (a pendulum's length, a gear ratio). A casadi.Function only.

    The remaining fields are filled by the builder methods; treat them as read-only.
    """

    dynamics: Any
    T: float | tuple[float, float]
    N: int
    transcription: str = DEFAULT_TRANSCRIPTION
    degree: int | None = None
    formulation: str | None = None
    state_names: tuple[str, ...] | None = None
    control_names: tuple[str, ...] | None = None
    state_units: tuple[str, ...] | None = None
    control_units: tuple[str, ...] | None = None
    bounds: tuple[tuple[str, float, float], ...] = ()
    constraints: tuple[Constraint, ...] = ()
    periodicity: tuple[Any, ...] | None = None  # (mapping or None,) when periodic
    objective: tuple[ObjectiveTerm, ...] = ()
    scales: tuple[tuple[str, float], ...] = ()
    guesses: tuple[GuessLayer, ...] = ()
    T_guess: float | None = None
    mesh: tuple[float, ...] | None = None
    params: tuple[Param, ...] = ()
    contacts: tuple[Any, ...] = ()
    dynamics_params: tuple[str, ...] = ()
    margins: tuple[tuple[str, np.ndarray, np.ndarray, bool], ...] = ()

    def __post_init__(self) -> None:
        dynamics = self.dynamics
        # A model that knows how to be a System (model.Dynamics: the linkage adapter) offers
        # ``as_system``; the planner reads nothing else of it.
        source = isinstance(dynamics, SystemSource)
        if not isinstance(dynamics, ca.Function | System) and not source:
            raise DefinitionTypeError(
                "`dynamics`: must be a model (e.g. model.Dynamics: anything with "
                "as_system(formulation, contacts) -> planner.System), a planner.System or a "
                f"casadi.Function f(x, u[, t]) -> xdot, got {type(dynamics).__name__}"
            )
        given = isinstance(dynamics, System)
        default = (
            dynamics.formulation
            if given
            else dynamics.default_formulation
            if source
            else "explicit"
        )
        formulation = self.formulation or default
        if formulation not in FORMULATIONS:
            raise DefinitionError(
                f"`formulation`: unknown {formulation!r}; use one of {FORMULATIONS}"
            )
        if given and formulation != dynamics.formulation:
            raise DefinitionError(
                f"`formulation`: the System given is {dynamics.formulation}, got "
                f"{formulation!r}; build the System in the formulation wanted"
            )
        if self.contacts and not source:
            raise DefinitionError(
                "`contacts`: contact forces need a model that places them (a model.Dynamics: "
                "points of a linkage); a casadi.Function takes its forces as controls of its own"
            )
        if not isinstance(self.contacts, tuple):
            object.__setattr__(self, "contacts", tuple(self.contacts))
        if isinstance(self.dynamics_params, str):
            raise DefinitionTypeError(
                f"`dynamics_params`: give a sequence of names, got {self.dynamics_params!r}"
            )
        object.__setattr__(self, "dynamics_params", tuple(self.dynamics_params))
        if self.dynamics_params and (source or given):
            raise DefinitionError(
                "`dynamics_params`: a model holds its own parameters, and a System declares "
                "its own (System.params); give parameters to a casadi.Function's last inputs"
            )
        if source or given:
            owner = f"a {type(dynamics).__name__}" if source else "a System"
            for name in ("state_names", "control_names", "state_units", "control_units"):
                if getattr(self, name) is not None:
                    raise DefinitionError(
                        f"`{name}`: {owner} names its own variables; give names only with a "
                        "casadi.Function"
                    )
        if given:
            system = dynamics
        elif source:
            system = dynamics.as_system(formulation, self.contacts)
            if not isinstance(system, System):
                raise DefinitionTypeError(
                    f"`dynamics`: {type(dynamics).__name__}.as_system must return a "
                    f"planner.System, got {type(system).__name__}"
                )
        else:
            system = System.from_function(
                dynamics,
                formulation,
                self.state_names,
                self.control_names,
                self.state_units,
                self.control_units,
                self.dynamics_params,
            )
        object.__setattr__(self, "formulation", formulation)
        object.__setattr__(self, "system", system)
        object.__setattr__(self, "N", check_integer("N", self.N, 1))
        if self.mesh is not None:
            object.__setattr__(self, "mesh", _fractions(self.mesh, self.N))
        # The registry of transcriptions knows the names, degree ranges and defaults.
        object.__setattr__(self, "degree", schemes.check_degree(self.transcription, self.degree))
        T = self.T
        if isinstance(T, tuple | list):
            if len(T) != 2:
                raise DefinitionError(f"`T`: a free duration is a pair (lower, upper), got {T!r}")
            lo, hi = _as_bounds("T", T[0], T[1], 1)
            if not (np.isfinite(lo[0]) and np.isfinite(hi[0])) or lo[0] <= 0:
                raise DefinitionError(
                    f"`T`: free duration bounds must be finite and > 0 s, got {tuple(T)}"
                )
            object.__setattr__(self, "T", (float(lo[0]), float(hi[0])))
            if self.T_guess is not None and not lo[0] <= self.T_guess <= hi[0]:
                raise DefinitionError(f"`T` guess {self.T_guess} outside the bounds {tuple(T)}")
        else:
            if isinstance(T, bool) or not isinstance(T, int | float | np.number):
                raise DefinitionTypeError(
                    f"`T`: must be a duration in s or a pair (lower, upper), got {T!r}"
                )
            if not math.isfinite(T) or T <= 0:
                raise DefinitionError(f"`T`: must be a finite duration > 0 s, got {T}")
            object.__setattr__(self, "T", float(T))

    # ---- naming ------------------------------------------------------------------------
    @property
    def free_time(self) -> bool:
        return isinstance(self.T, tuple)

    @property
    def duration_guess(self) -> float:
        """The duration used for guesses: T if fixed, the guess or the middle of its bounds."""
        if not self.free_time:
            return self.T
        return self.T_guess if self.T_guess is not None else 0.5 * (self.T[0] + self.T[1])

    def resolve(self, name: str, what: str = "variable") -> tuple[str, ...]:
        """Variable names behind ``name``: itself, or the members of a group (``psi``, ``M``)."""
        if not isinstance(name, str):
            raise DefinitionTypeError(f"`{what}`: names are strings, got {name!r}")
        system = self.system
        if name in system.variable_names:
            return (name,)
        group = system.group(name)
        if group is not None:
            return group
        if name in system.point_only_fields:
            raise DefinitionError(
                f"`{what}`: {name!r} is a Point field computed from the variables (a control "
                f"rate or a derived quantity), not a variable; write a constraint instead, "
                f"e.g. constrain('{name} limit', lambda p: p.{name}, lower=..., upper=...)"
            )
        groups = [g for g, _ in system.groups]
        raise DefinitionError(
            f"`{what}`: unknown name {name!r}; use a variable ({', '.join(system.variable_names)})"
            f" or a group ({', '.join(groups)})"
        )

    def _constraint_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.constraints)

    def _point(self, where: str = "path") -> Point:
        s = self.system
        x, u, z = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
        t, T = ca.SX.sym("t"), ca.SX.sym("T")
        extra = self.param_fields(ca.SX.sym("params", len(self.params)))
        if where in ("start", "end"):
            extra.update({"x0": ca.SX.sym("x0", s.nx), "xf": ca.SX.sym("xf", s.nx)})
        return Point(s, x, u, z, t, T, extra, du=ca.SX.sym("du", s.nu))

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    def param_fields(self, values) -> dict[str, Any]:
        """The Point fields of the static parameters (:func:`parameter_fields`)."""
        return parameter_fields(self.param_names, values)

    # ---- builders ----------------------------------------------------------------------
    def bound(self, name: str, lower=None, upper=None) -> Self:
        """Bounds lower <= v <= upper on a variable or group at every point where it lives.

        ``name``: a variable (``"M_torso"``) or a group (``"M"``, ``"psi"``); the duration
        ``"T"`` is not bounded here (give ``T=(lo, hi)`` to the OCP). Bounds: scalars or arrays
        over the group; None = none.
        A later bound on the same variable replaces the earlier one.
        """
        names = self.resolve(name, "bound")
        lo, hi = _as_bounds(f"bound[{name}]", lower, upper, len(names))
        kept = tuple(b for b in self.bounds if b[0] not in names)
        added = tuple((n, float(lo[i]), float(hi[i])) for i, n in enumerate(names))
        return dataclasses.replace(self, bounds=kept + added)

    def variable_bounds(self, name: str) -> tuple[float, float]:
        for n, lo, hi in self.bounds:
            if n == name:
                return lo, hi
        return -np.inf, np.inf

    def _add_constraint(
        self,
        name,
        expression,
        lower,
        upper,
        where,
        scale,
        instants=(),
        fraction=False,
        on="transcription",
    ) -> Self:
        if not isinstance(name, str) or not name:
            raise DefinitionTypeError(f"`name`: a constraint needs a non-empty name, got {name!r}")
        if name in self._constraint_names():
            raise DefinitionError(
                f"`name`: a constraint named {name!r} exists already; names must be unique"
            )
        label = f"{where}[{name}]"
        value = evaluate_expression(label, expression, self._point(where))
        if lower is None and upper is None:
            raise DefinitionError(f"`{label}`: give lower and/or upper (equal: lower=upper)")
        rows = expression_rows(expression, value.size1())
        lower = _per_output(label, "lower", expression, lower)
        upper = _per_output(label, "upper", expression, upper)
        if where == "at":
            lo, hi = _instant_bounds(label, lower, upper, value.size1(), len(instants))
        else:
            lo, hi = _as_bounds(label, lower, upper, value.size1())
        scale_array = None
        if scale is not None:
            scale_array = _positive_array(f"{label} scale", scale, value.size1())
        constraint = Constraint(
            name, expression, lo, hi, where, scale_array, rows, tuple(instants), fraction, on
        )
        return dataclasses.replace(self, constraints=(*self.constraints, constraint))

    def constrain(self, name: str, expression, lower=None, upper=None, scale=None) -> Self:
        """A path constraint lower <= g(point) <= upper at every dynamics point.

        Dynamics points: the nodes (trapezoid), nodes and midpoints (Hermite-Simpson), the
        collocation points (radau, legendre). ``expression``: callable of a :class:`Point` or a
        Function of Point fields, scalar or vector; a Function with several outputs stacks
        them into one block of rows named after the outputs (``path[grf][Fy] node 3``), and
        its bounds may then be given per output (``lower={"Fy": 0.0}``: outputs not named are
        unbounded). Bounds: scalars or (rows,); ``scale``: nominal magnitude (default from the
        finite bounds, else 1).

        Control rates (``p.du``, a linkage's ``p.dM``) at a dynamics point are the time
        derivative of the control polynomial of the interval that owns the point, the one the
        Solution interpolates with there (:meth:`planner.solution.Solution.control_rate`):
        intervals [t_k, t_k+1), the last one also owning T; Radau (t_k, t_k+1], its end node
        included. A node shared by two intervals (trapezoid, Hermite-Simpson) has a slope on
        each side: the point carries the slope of the interval starting there, and path rows
        and integrands that read a rate are evaluated once more at each interior node with the
        slope of the interval ending there (rows "path[c] node 3 (end of interval 2)"; on the
        trapezoid, whose rate is constant per interval, not for rows that read only rates and T:
        they would repeat a row). So a rate bound holds on both sides of every node, and the
        integral of a rate term is every interval's own quadrature. Collocation controls are
        separate polynomials per interval that may jump at the nodes, where no rate sees them:
        when anything reads a rate, the transcription makes them continuous (rows
        "continuity[u] node k"); degree 1 (piecewise-constant controls) is refused.
        A rate term converges at order 2 p for controls of degree p (capped by the scheme's
        order): 2 on the trapezoid and degree-2 collocation, 4 on Hermite-Simpson and degree 3.

        A constraint of the state, ``t`` and ``T`` only (no control, no z) also holds where
        no dynamics point lies: t = 0 for ``radau`` (its points are the interval ends) and the
        mesh nodes for ``legendre`` (interior points only). A constraint that involves a
        control or z is not enforced there (controls are no variables at those points): add a
        ``boundary`` constraint for t = 0 or T, or use trapezoid/Hermite-Simpson when it must
        hold exactly at the nodes.
        """
        return self._add_constraint(name, expression, lower, upper, "path", scale)

    def constrain_at(
        self,
        name: str,
        expression,
        *,
        t=None,
        fraction=None,
        lower=None,
        upper=None,
        scale=None,
        on: str = "transcription",
    ) -> Self:
        """A constraint lower <= g(point) <= upper at given instants (keypoints).

        ``t``: a time, s, or a sequence of them, in [0, T] (fixed T only); ``fraction``: a
        fraction of the duration (or a sequence), in [0, 1]: t = fraction * T, also for a
        free T. Give exactly one. An absolute t with a free duration is refused: the mesh
        interval that contains it would change with T, a jump the NLP cannot follow.

        The point is evaluated on the transcription's own interpolant of the interval that
        contains the instant (the polynomials the Solution interpolates with, same interval
        rule at nodes: see :meth:`constrain`), so an instant need not be a node: ``x``, ``u``,
        ``z``, ``t``, ``T``, every group and variable, derived fields (explicit ``ddpsi``:
        forward dynamics of the interpolated x and u) and control rates (the derivative of the
        interval's control polynomial there).

        Bounds: a scalar or (rows,) for every instant alike, or (K, rows) per instant (K
        instants; (K,) for a scalar g). Rows are named "at[name] t=0.25 s (interval 12)"
        (with ``fraction``: "t=0.5 T"). ``expression`` and ``scale`` as in :meth:`constrain`.

        ``on="motion"`` reads the point from the consistent motion instead
        (:meth:`planner.solution.Solution.motion`, what the solution's files sample: positions
        integrated from the velocity polynomial, accelerations its slope, drives by
        ``drives_for_motion``): so that a bound holds on exactly the exported samples
        (:func:`planner.hold_at_samples`). It needs a system with that role (a linkage) and
        an expression that reads no control rate.

        >>> ocp.constrain_at("foot", foot_xy, fraction=[0.25, 0.5], lower=targets, upper=targets)
        """
        label = f"at[{name}]"
        if (t is None) == (fraction is None):
            raise DefinitionError(
                f"`{label}`: give exactly one of t (s, fixed T) and fraction (of T), got "
                f"t={t!r}, fraction={fraction!r}"
            )
        if t is not None and self.free_time:
            raise DefinitionError(
                f"`{label}`: t={t!r} is an absolute time but the duration is free "
                f"(T in [{self.T[0]:g}, {self.T[1]:g}] s): the mesh interval holding it would "
                "change with T; give fraction=t/T instead (e.g. fraction=0.5 for T/2)"
            )
        key, value = ("t", t) if t is not None else ("fraction", fraction)
        instants = _instants(label, key, value, self.T if t is not None else 1.0)
        if on not in ("transcription", "motion"):
            raise DefinitionError(f"`{label}`: on must be 'transcription' or 'motion', got {on!r}")
        if on == "motion" and not self.system.has_motion:
            raise DefinitionError(
                f"`{label}`: on='motion' needs a system with positions, velocities and "
                "drives_for_motion (a linkage); this one has none: use on='transcription'"
            )
        return self._add_constraint(
            name, expression, lower, upper, "at", scale, instants, fraction is not None, on
        )

    def boundary(self, name: str, expression, at: str, lower=None, upper=None, scale=None) -> Self:
        """A boundary constraint lower <= g(point) <= upper at ``at`` = "start" or "end".

        The point's ``x`` is the state there (``x0`` and ``xf`` give both ends), ``u`` the
        control (the interpolant's value for collocation), ``T`` the duration.
        """
        if at not in ("start", "end"):
            raise DefinitionError(f"`at`: must be 'start' or 'end', got {at!r}")
        return self._add_constraint(name, expression, lower, upper, at, scale)

    def initial(self, **values) -> Self:
        """Fix states (or groups) at t = 0: ``initial(q=0.0, v=0.0)`` or ``initial(psi=[...])``."""
        return self._fix("start", "initial", values)

    def final(self, **values) -> Self:
        """Fix states (or groups) at t = T: ``final(q=1.0)``."""
        return self._fix("end", "final", values)

    def _fix(self, at: str, prefix: str, values: Mapping[str, Any]) -> Self:
        if not values:
            raise DefinitionError(f"`{prefix}`: give at least one state=value")
        ocp = self
        for key, value in values.items():
            names = self.resolve(key, prefix)
            for n in names:
                if n not in self.system.state_names:
                    raise DefinitionError(
                        f"`{prefix}`: {n!r} is not a state; boundary values fix states "
                        f"({', '.join(self.system.state_names)})"
                    )
            idx = [self.system.state_names.index(n) for n in names]

            def select(p, idx=tuple(idx)):
                return ca.vertcat(*[p.x[i] for i in idx])

            ocp = ocp._add_constraint(f"{prefix} {key}", select, value, value, at, None)
        return ocp

    def periodic(self, mapping=None) -> Self:
        """Periodicity x(0) = mapping(x(T)); identity by default.

        ``mapping``: a callable of the SX state (nx,) returning (nx,), or a casadi.Function
        (nx,) -> (nx,): an impact map and a relabelling of legs enter here.
        """
        if mapping is not None:
            value = evaluate_mapping("periodic", mapping, ca.SX.sym("x", self.system.nx))
            if value.shape != (self.system.nx, 1):
                raise DefinitionError(
                    f"`periodic`: the mapping must return a ({self.system.nx}, 1) state, "
                    f"got {value.shape}"
                )
        return dataclasses.replace(self, periodicity=(mapping,))

    def minimize(self, integral=None, terminal=None, name: str = DEFAULT_TERM) -> Self:
        """An objective term: the integral of ``integral(p)`` over [0, T] (the transcription's
        quadrature) + ``terminal(p)`` at t = T (``p.x`` = x(T), ``p.x0``, ``p.T``); both
        scalar expressions of a :class:`Point`.

        The objective is the sum of the terms. ``name`` identifies a term: a term of the same
        name is replaced (so ``minimize(integral=...)`` twice keeps the last, as the default
        name is the same), a new name adds a term; the Solution reports each term's value
        (``Solution.cost_terms``).
        """
        if not isinstance(name, str) or not name:
            raise DefinitionTypeError(f"`name`: an objective term needs a name, got {name!r}")
        if integral is None and terminal is None:
            raise DefinitionError("`minimize`: give an integral and/or a terminal term")
        for label, term, where in (("integral", integral, "path"), ("terminal", terminal, "end")):
            if term is not None:
                value = evaluate_expression(label, term, self._point(where))
                if value.shape != (1, 1):
                    raise DefinitionError(f"`{label}`: must be scalar, got shape {value.shape}")
        term = ObjectiveTerm(name, integral, terminal)
        kept = tuple(t for t in self.objective if t.name != name)
        if len(kept) == len(self.objective):
            return dataclasses.replace(self, objective=(*self.objective, term))
        terms = tuple(term if t.name == name else t for t in self.objective)
        return dataclasses.replace(self, objective=terms)

    def param(self, name: str, lower=None, upper=None, guess=None, scale=None) -> Self:
        """A static parameter: one decision variable for the whole horizon (a free step
        length, a design quantity), a Point field ``p.<name>`` (and ``p.params``, all of
        them) in every expression: constraints, objective terms, the periodicity map.

        ``lower``/``upper``: bounds (None: none); ``guess``: its initial value (default: the
        middle of finite bounds, else the bound nearest 0, else 0); ``scale``: its nominal
        magnitude (default from the bounds). A parameter of the same name is replaced.
        Parameters do not enter the dynamics (a model's parameters are numbers).
        """
        if not isinstance(name, str) or not name.isidentifier():
            raise DefinitionError(
                f"`param`: a parameter's name must be an identifier (a Point field), got {name!r}"
            )
        if name in self._point().fields and name not in self.param_names:
            raise DefinitionError(
                f"`param`: {name!r} is already a field of the Point (a variable, group or "
                "built-in field); choose another name"
            )
        lo, hi = _as_bounds(f"param[{name}]", lower, upper, 1)
        value = None
        if guess is not None:
            value = float(as_float_array(f"param[{name}] guess", guess, "a number"))
            if not math.isfinite(value) or not lo[0] <= value <= hi[0]:
                raise DefinitionError(
                    f"`param[{name}]`: the guess {value!r} must be finite and within the bounds "
                    f"[{lo[0]:g}, {hi[0]:g}]"
                )
        nominal = None
        if scale is not None:
            nominal = float(_positive_array(f"param[{name}] scale", scale, 1)[0])
        parameter = Param(name, float(lo[0]), float(hi[0]), value, nominal)
        kept = tuple(p for p in self.params if p.name != name)
        if len(kept) == len(self.params):
            return dataclasses.replace(self, params=(*self.params, parameter))
        params = tuple(parameter if p.name == name else p for p in self.params)
        return dataclasses.replace(self, params=params)

    def back_off(self, name: str, lower=None, upper=None, at_ends: bool = True) -> Self:
        """Tighten a path constraint or a variable's bounds by margins per mesh interval: at
        the points of interval k the rows hold lower + lower_margin[k] <= g <= upper -
        upper_margin[k] (a point shared by two intervals takes the larger margin).
        ``at_ends`` False keeps the plain bounds at the first and last node (where a
        boundary condition may pin the row: a landing foot at height 0 and a clearance).

        ``name``: a path constraint's name or a variable's; ``lower``, ``upper``: margins
        >= 0 in the row's units, (N,) or (N, rows), or None for none. What the dynamics
        points cannot see (a bound the exported motion passes between them) is held this
        way without changing the NLP's structure (:func:`planner.hold_at_samples`). The
        margins belong to this mesh: :meth:`refine` drops them. Giving a name again replaces
        its margins.
        """
        label = f"back_off[{name}]"
        paths = {c.name: c for c in self.constraints if c.where == "path"}
        if name in paths:
            rows = paths[name].size
        elif name in self.system.variable_names:
            rows = 1
        else:
            raise DefinitionError(
                f"`{label}`: no path constraint or variable called {name!r}; path constraints: "
                f"{list(paths)}"
            )
        arrays = []
        for side, value in (("lower", lower), ("upper", upper)):
            if value is None:
                arrays.append(np.zeros((self.N, rows)))
                continue
            array = as_float_array(f"{label} {side}", value, f"margins of shape ({self.N}, {rows})")
            if array.ndim == 1 and rows == 1:
                array = array[:, None]
            if array.shape != (self.N, rows):
                raise DefinitionError(
                    f"`{label}`: {side} margins must have shape ({self.N}, {rows}) (one per mesh "
                    f"interval and row), got {array.shape}"
                )
            check_finite(f"{label} {side}", array, "margins")
            if np.any(array < 0):
                raise DefinitionError(f"`{label}`: {side} margins must be >= 0, got {array.min()}")
            arrays.append(array.copy())
        if name in paths:
            equal = paths[name].lower == paths[name].upper
            if np.any(equal & np.any((arrays[0] > 0) | (arrays[1] > 0), axis=0)):
                raise DefinitionError(
                    f"`{label}`: rows {np.flatnonzero(equal).tolist()} are equalities; an "
                    "equality cannot be backed off (give 0 margins there)"
                )
        if not isinstance(at_ends, bool):
            raise DefinitionTypeError(f"`{label}`: at_ends must be True or False, got {at_ends!r}")
        kept = tuple(m for m in self.margins if m[0] != name)
        return dataclasses.replace(self, margins=(*kept, (name, *arrays, at_ends)))

    def margin(self, name: str) -> tuple[np.ndarray, np.ndarray, bool] | None:
        """(lower (N, rows), upper (N, rows), at_ends) of :meth:`back_off` for ``name``, or
        None."""
        for key, lower, upper, at_ends in self.margins:
            if key == name:
                return lower, upper, at_ends
        return None

    def scale(self, **scales) -> Self:
        """Nominal magnitudes of variables, groups or constraints: ``scale(M=100, clearance=0.05)``.

        The NLP works with v / scale; defects are divided by their state's scale and the
        dynamics residual by the scale of the torques (states for a generic implicit DAE).
        ``objective=`` gives the objective's nominal magnitude, in its own units (default:
        from the objective and its gradient at the initial guess, see
        :func:`planner.solver.objective_scale`).
        """
        items = list(self.scales)
        constraint_names = self._constraint_names()
        for key, value in scales.items():
            if key == "objective":
                array = _positive_array("scale[objective]", value, 1)
                items.append(("objective", float(array[0])))
                continue
            if key in constraint_names:
                size = next(c.size for c in self.constraints if c.name == key)
                _positive_array(f"scale[{key}]", value, size)
                items.append((key, value))
                continue
            names = self.resolve(key, "scale")
            array = _positive_array(f"scale[{key}]", value, len(names))
            items.extend((n, float(array[i])) for i, n in enumerate(names))
        return dataclasses.replace(self, scales=tuple(items))

    @property
    def objective_scale(self) -> float | None:
        """The objective's nominal magnitude given by ``scale(objective=...)``, or None."""
        given = [v for key, v in self.scales if key == "objective"]
        return float(given[-1]) if given else None

    def variable_scale(self, name: str) -> float:
        """A variable's nominal magnitude: given by :meth:`scale`, else its largest finite
        bound, else the system's natural magnitude (``System.nominal``: a linkage's weight
        times its mean link length for torques, ...), else 1."""
        value = None
        for key, v in self.scales:
            if key == name:
                value = v
        if value is not None:
            return float(value)
        lo, hi = self.variable_bounds(name)
        if not (np.isfinite(lo) and lo != 0.0) and not (np.isfinite(hi) and hi != 0.0):
            nominal = self.system.nominal or {}
            if name in nominal:
                return float(nominal[name])
        return float(default_scale(np.array([lo]), np.array([hi]))[0])

    def constraint_scale(self, constraint: Constraint) -> np.ndarray:
        for key, v in reversed(self.scales):
            if key == constraint.name:
                return _positive_array(key, v, constraint.size)
        if constraint.scale is not None:
            return constraint.scale
        return default_scale(constraint.lower, constraint.upper)

    def guess(self, source=None, *, t=None, T=None, **values) -> Self:
        """Add an initial guess; later guesses override earlier ones variable by variable.

        ``source``: a callable of time t (K,) s returning a dict (names or groups -> (K,) or
        (K, size)) or a tuple ((psi, dpsi[, ddpsi[, M]]) for a linkage, (x[, u[, z]])
        otherwise), or an earlier Solution (or planner Trajectory), re-gridded through its
        interpolant in normalised time t / T (coarse-to-fine warm start). With a free
        duration, a Solution's (Trajectory's) duration also becomes the guess of T, clipped
        into the bounds; the re-gridding in normalised time keeps the guess on the new mesh
        when the two durations differ. When a converged Solution is the last guess and this
        OCP has the same NLP layout (same mesh and transcription, variables and constraints;
        e.g. a changed bound or cost weight), :func:`planner.solver.solve` also starts IPOPT
        from its multipliers (``solve(..., warm_start=False)`` turns that off).
        ``values``: constants (``M=0``, ``psi=[...]``) or, with ``t`` (K,), arrays (K,) /
        (K, size) interpolated linearly onto the mesh. ``T``: guess of a free duration (wins
        over a source's duration given in the same call).
        For a linkage, torques that no guess gives are computed by inverse dynamics from the
        guessed psi, dpsi, ddpsi.
        """
        layers = list(self.guesses)
        T_guess = self.T_guess
        if T is not None:
            if not self.free_time:
                raise DefinitionError("`T`: the duration is fixed; a T guess needs T=(lo, hi)")
            T_val = float(T)
            if not self.T[0] <= T_val <= self.T[1]:
                raise DefinitionError(f"`T`: guess {T_val} outside the bounds {self.T}")
            T_guess = T_val
        if source is not None:
            layer = self._guess_source(source)
            layers.append(layer)
            if layer.kind == "solution" and self.free_time and T is None:
                T_guess = float(np.clip(layer.source.duration, *self.T))
        if values:
            layers.append(self._guess_values(values, t))
        elif t is not None:
            raise DefinitionError("`t`: a time grid needs arrays, e.g. guess(t=times, psi=...)")
        if source is None and not values and T is None:
            raise DefinitionError("`guess`: give a source, values or T")
        return dataclasses.replace(self, guesses=tuple(layers), T_guess=T_guess)

    def _guess_source(self, source) -> GuessLayer:
        if isinstance(source, SampledGuess):  # a Solution, a Trajectory
            return GuessLayer("solution", source=source)
        if callable(source):
            layer = GuessLayer("callable", source=source)
            # Evaluate once now so that a wrong shape or NaN fails at definition time.
            probe = np.linspace(0.0, self.duration_guess, 5)
            evaluate_guess_layer(self.system, self.duration_guess, self.resolve, layer, probe)
            return layer
        if isinstance(source, Mapping):
            return self._guess_values(dict(source), None)
        raise DefinitionTypeError(
            "`guess`: source must be a callable of t, a Solution, a Trajectory or a dict, got "
            f"{type(source).__name__}"
        )

    def _guess_values(self, values: Mapping[str, Any], t) -> GuessLayer:
        times = None
        if t is not None:
            times = np.asarray(t, dtype=float).reshape(-1)
            if times.size < 1 or not np.all(np.isfinite(times)):
                raise DefinitionError("`t`: the guess time grid must be finite and non-empty")
            if times.size > 1 and np.any(np.diff(times) <= 0):
                raise DefinitionError("`t`: the guess time grid must be strictly increasing")
        resolved: dict[str, np.ndarray] = {}
        for key, value in values.items():
            names = self.resolve(key, "guess")
            array = as_float_array(f"guess[{key}]", value, "numeric")
            check_finite(f"guess[{key}]", array)
            m = len(names)
            if times is None:
                if array.ndim == 0:
                    array = np.full(m, float(array))
                if array.shape != (m,):
                    raise DefinitionError(
                        f"`guess[{key}]`: constant guess has shape {array.shape}, expected a "
                        f"scalar or ({m},); for arrays over time pass t=..."
                    )
                for i, n in enumerate(names):
                    resolved[n] = np.array(array[i])
            else:
                K = times.size
                if array.ndim == 0:
                    array = np.full((K, m), float(array))
                elif array.ndim == 1 and m == 1 and array.size == K:
                    array = array[:, None]
                elif array.ndim == 1 and array.size == m:
                    array = np.tile(array, (K, 1))
                if array.shape != (K, m):
                    raise DefinitionError(
                        f"`guess[{key}]`: expected shape ({K}, {m}) on the {K}-point grid t, "
                        f"got {np.shape(value)}"
                    )
                for i, n in enumerate(names):
                    resolved[n] = array[:, i].copy()
        return GuessLayer("grid" if times is not None else "constant", resolved, times)

    # ---- mesh, solving ------------------------------------------------------------------
    def refine(
        self, N: int | None = None, transcription: str | None = None, degree=None, mesh=None
    ) -> Self:
        """The same problem on another mesh (N, transcription, degree; ``mesh``: relative
        interval lengths, see :class:`OCP`; a new N without a ``mesh`` is uniform)."""
        changes: dict[str, Any] = {}
        if mesh is not None:
            changes["mesh"] = tuple(np.asarray(mesh, dtype=float).reshape(-1))
            changes["N"] = len(changes["mesh"]) if N is None else N
        elif N is not None:
            changes["N"] = N
            changes["mesh"] = None
        if transcription is not None:
            changes["transcription"] = transcription
            if transcription not in schemes.WITH_DEGREE and degree is None:
                changes["degree"] = None
        if degree is not None:
            changes["degree"] = degree
        if changes:
            changes["margins"] = ()  # per interval of the old mesh
        return dataclasses.replace(self, **changes)

    # ---- printing ----------------------------------------------------------------------
    def __str__(self) -> str:
        s = self.system
        T = f"T in [{self.T[0]:g}, {self.T[1]:g}] s" if self.free_time else f"T = {self.T:g} s"
        mesh = self.transcription + (f"(degree {self.degree})" if self.degree else "")
        lines = [
            f"OCP: {s.formulation} dynamics, nx={s.nx} nu={s.nu} nz={s.nz}, {T}, N={self.N}, "
            f"{mesh}",
            f"  states:   {', '.join(s.state_names)}",
            f"  controls: {', '.join(s.control_names)}",
        ]
        if self.bounds:
            lines.append(
                "  bounds:   " + ", ".join(f"{n} in [{lo:g}, {hi:g}]" for n, lo, hi in self.bounds)
            )
        for c in self.constraints:
            lines.append(f"  {c!r}")
        if self.periodicity is not None:
            mapping = self.periodicity[0]
            lines.append("  periodic: x(0) = " + ("x(T)" if mapping is None else "Delta(x(T))"))
        if self.params:
            lines.append(
                "  params:   "
                + ", ".join(f"{p.name} in [{p.lower:g}, {p.upper:g}]" for p in self.params)
            )
        objective = [repr(term) for term in self.objective]
        lines.append(f"  minimize: {' + '.join(objective) or 'nothing (feasibility)'}")
        if self.guesses:
            lines.append(f"  guesses:  {', '.join(repr(g) for g in self.guesses)}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return str(self)


def _instants(label: str, key: str, value, end: float) -> tuple[float, ...]:
    """Validated instants in [0, ``end``] (T in s, or 1 for fractions), distinct."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DefinitionTypeError(
            f"`{label}`: {key} must be a number or a sequence of numbers, got {value!r}"
        ) from exc
    if array.ndim > 1 or array.size == 0 or isinstance(value, bool):
        raise DefinitionError(
            f"`{label}`: {key} must be a number or a non-empty sequence of numbers, got {value!r}"
        )
    array = array.reshape(-1)
    unit = " s" if key == "t" else ""
    bad = ~np.isfinite(array) | (array < 0) | (array > end)
    if np.any(bad):
        what = f"[0, T] = [0, {end:g}] s" if key == "t" else "[0, 1]"
        raise DefinitionError(
            f"`{label}`: {key}={float(array[bad][0])!r}{unit} lies outside {what}; an instant "
            "must lie in the horizon"
        )
    shown = [f"{v:.9g}" for v in array]
    if len(set(shown)) != len(shown):
        repeated = next(v for v in shown if shown.count(v) > 1)
        raise DefinitionError(
            f"`{label}`: {key}={repeated}{unit} is given twice; each instant once (a repeated "
            "row makes the constraint Jacobian rank-deficient)"
        )
    return tuple(float(v) for v in array)


def _positive_array(label: str, value, size: int) -> np.ndarray:
    array = as_float_array(label, value, "numeric")
    if array.ndim == 0:
        array = np.full(size, float(array))
    if array.shape != (size,):
        raise DefinitionError(f"`{label}`: expected a scalar or ({size},), got {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise DefinitionError(f"`{label}`: scales must be finite and > 0, got {array}")
    return array


__all__ = [
    "FORMULATIONS",
    "TRANSCRIPTIONS",
    "Constraint",
    "OCPDefinition",
    "ObjectiveTerm",
    "Param",
    "Point",
    "System",
]
