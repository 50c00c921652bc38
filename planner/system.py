"""The System: dynamics in the planner's form, carrying its own naming.

The generic planner (the OCP, its transcription, the Solution, the guesses) knows a model
only through a :class:`System`: its states, controls and auxiliary variables with their
names and units, the groups that name several at once, the residual rows and their scale,
the Point fields that are expressions rather than variables (:class:`DerivedField`, control
rates), how a guess function's tuple reads, how guesses the user gave complete the others,
and which groups play two mechanical roles the Solution offers views of (the drive torques,
the second derivatives of the states). A model becomes a System through an adapter:

* :meth:`System.from_function`: a CasADi Function, an ODE f(x, u[, t]) or an implicit
  residual r(x, xdot, u[, t]) (names and units given by the user, or x_0.., u_0..);
* a model's own ``as_system`` (:class:`SystemSource`): ``model.Dynamics`` through the linkage
  adapter :mod:`model.linkage_system` (the linkage naming convention lives there, on the
  model's side: the planner imports nothing of the model);

and a new kind of model (a floating base, contact forces as algebraic variables) is a new
adapter returning a System, which ``OCP`` also takes directly.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol, runtime_checkable

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory

#: A guess completion: values the guesses give at some points, name -> (K,), to values of
#: more variables (e.g. the torques of inverse dynamics), name -> (K,).
GuessCompletion = Callable[[Mapping[str, np.ndarray]], Mapping[str, np.ndarray]]


@dataclass(frozen=True, eq=False)
class DerivedField:
    """A group of Point fields that are expressions of the variables, not variables.

    ``function``: SX Function (x (nx,), z (nz,), u (nu,), t (1,)) -> (m,); the Point offers
    the column as ``group`` and its rows by ``names`` (units ``units``).
    """

    group: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    function: ca.Function


@dataclass(frozen=True, eq=False)
class System:
    """Dynamics in the planner's form: xdot = rate(x, z, u, t) and 0 = residual(x, z, u, t).

    ``rate`` and ``residual`` are SX Functions with inputs (x (nx,), z (nz,), u (nu,), t (1,))
    and, when the dynamics read static parameters (``params``: their names, declared on the
    OCP with ``OCP.param``), a last input p (len(params),); ``residual`` is None (nz = 0) for
    explicit dynamics. ``ode`` (x, u, t[, p]) -> xdot, when known, serves re-simulation.
    :meth:`bind` fixes the parameters' values (what a Solution integrates with).
    ``groups`` maps group names (for a linkage ``psi``, ``M``; always ``x``, ``u`` and, with
    auxiliary variables, ``z``) to variable names;
    ``residual_scale_group`` names the group whose nominal scales scale the residual rows
    (torques for a linkage: the residual is in N m), ``residual_names`` the rows of the
    residual at one point ("dynamics[<name>]").

    Point fields that are no NLP variables, named by the system (see :class:`planner.ocp.Point`):
    ``derived`` groups of expressions of (x, z, u, t) (a linkage's accelerations in the
    explicit formulation: its forward dynamics), and the control rates du/dt, one name per
    control (``control_rate_names``) gathered in the groups ``control_rate_groups``; a group
    given as (name, count) holds the first ``count`` rates only.

    Guesses: a guess function's tuple fills the groups ``guess_order`` in order (``x``, ``u``,
    ``z`` by default); a derived group's values in a guess are kept under its names, for
    ``complete_guess``, which maps the values the guesses give at the dynamics points to
    values of controls no guess gives (a linkage's torques by inverse dynamics), or is None.

    Roles the Solution offers views of: ``drives``, the control group of drive torques
    (``Solution.drives``; a trajectory exports these as its controls and the other controls
    as derived channels), and ``accelerations``, the group (variables or derived) of the
    second time derivatives of the states (``Solution.acceleration``, ``Solution.accelerations``);
    None when the system has none. ``model``: a JSON-serialisable description of the model
    for exported metadata, or None.

    ``nominal``: a variable's natural magnitude from the model (name -> positive number, in
    its units), the scale of a variable that has neither a scale nor a finite bound in the
    OCP (a linkage's torques: its weight times its mean link length), so that the same
    problem in other units (millimetres and grams) is the same scaled NLP; None: 1.

    A motion and the drives it needs (what :meth:`planner.solution.Solution.motion` and the
    exported files use; all three or none): ``positions`` and ``velocities``, two state
    groups of equal length whose rates are each other's (d position_i/dt = velocity_i,
    checked on ``rate``: a linkage's psi and dpsi), and ``drives_for_motion``, an SX Function
    (x (nx,), a (nv,), u (nu,)) -> drives: the values of the ``drives`` group that give the
    velocities the rates a at state x with the other controls of u (a linkage's inverse
    dynamics less the hinge moments of its contact forces). With them a sampled motion is
    consistent by construction: positions, velocities, accelerations and drives obey the
    kinematics and the dynamics at every instant, not only at the collocation points.

    ``trajectory_type``: the :class:`planner.trajectory.Trajectory` subclass a Solution's
    samples come in (a linkage's ``model.LinkageTrajectory``, whose views read the channels
    as angles and torques); the generic Trajectory by default.
    """

    rate: ca.Function
    residual: ca.Function | None
    ode: ca.Function | None
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    control_names: tuple[str, ...]
    control_units: tuple[str, ...]
    aux_names: tuple[str, ...]
    aux_units: tuple[str, ...]
    groups: tuple[tuple[str, tuple[str, ...]], ...]
    residual_scale_group: str
    formulation: str
    derived: tuple[DerivedField, ...] = ()
    control_rate_names: tuple[str, ...] = ()
    control_rate_groups: tuple[str | tuple[str, int], ...] = ()
    residual_names: tuple[str, ...] = ()
    guess_order: tuple[str, ...] = ("x", "u", "z")
    complete_guess: GuessCompletion | None = None
    drives: str | None = None
    accelerations: str | None = None
    model: Mapping | None = None
    params: tuple[str, ...] = ()
    positions: str | None = None
    velocities: str | None = None
    drives_for_motion: ca.Function | None = None
    nominal: Mapping[str, float] | None = None
    trajectory_type: type[Trajectory] = Trajectory

    def __post_init__(self) -> None:
        if self.residual is not None and len(self.residual_names) != self.residual.size1_out(0):
            raise DefinitionError(
                f"`residual_names`: the residual has {self.residual.size1_out(0)} rows, got "
                f"{len(self.residual_names)} names; name every row"
            )
        for role in ("drives", "accelerations"):
            group = getattr(self, role)
            if (
                group is not None
                and self.group(group) is None
                and self.derived_field(group) is None
            ):
                raise DefinitionError(
                    f"`{role}`: {group!r} is neither a group nor a derived field of the system; "
                    f"groups: {[key for key, _ in self.groups]}"
                )
        self._check_motion_roles()

    def _check_motion_roles(self) -> None:
        """positions, velocities and drives_for_motion: all or none, the rates of the
        positions exactly the velocity states, the Function's shapes right."""
        given = [self.positions is not None, self.velocities is not None]
        given.append(self.drives_for_motion is not None)
        if not any(given):
            return
        if not all(given) or self.drives is None or self.accelerations is None:
            raise DefinitionError(
                "`positions`, `velocities`, `drives_for_motion`: give all three (with the "
                "`drives` and `accelerations` roles) or none"
            )
        positions, velocities = self.group(self.positions), self.group(self.velocities)
        for role, members in (("positions", positions), ("velocities", velocities)):
            if members is None or any(m not in self.state_names for m in members):
                raise DefinitionError(
                    f"`{role}`: {getattr(self, role)!r} must be a group of states"
                )
        if len(positions) != len(velocities):
            raise DefinitionError(
                f"`velocities`: {len(velocities)} velocities for {len(positions)} positions; "
                "give one velocity per position"
            )
        x = ca.SX.sym("x", self.nx)
        inputs = [x, ca.SX.sym("z", self.nz), ca.SX.sym("u", self.nu), ca.SX.sym("t")]
        inputs += [ca.SX.sym("p", len(self.params))] if self.params else []
        rate = self.rate.call(inputs)[0]
        for p, v in zip(positions, velocities, strict=True):
            i, j = self.state_names.index(p), self.state_names.index(v)
            if not ca.is_equal(rate[i], x[j], 1):
                raise DefinitionError(
                    f"`positions`: the rate of {p!r} is not the state {v!r} ({rate[i]}); "
                    "positions and velocities must be each other's integral and derivative"
                )
        function = self.drives_for_motion
        n_drives = len(self.role_names("drives"))
        shapes = [(self.nx, 1), (len(velocities), 1), (self.nu, 1)]
        if (
            function.n_in() != 3
            or [function.size_in(k) for k in range(3)] != shapes
            or function.n_out() != 1
            or function.size_out(0) != (n_drives, 1)
        ):
            raise DefinitionError(
                f"`drives_for_motion`: must map (x ({self.nx},), a ({len(velocities)},), u "
                f"({self.nu},)) to the {n_drives} drives, got {function}"
            )

    @property
    def has_motion(self) -> bool:
        """Whether the system offers consistent motions (``positions``, ``velocities``,
        ``drives_for_motion``)."""
        return self.drives_for_motion is not None

    def bind(self, values: Mapping[str, float]) -> System:
        """This system with its static parameters fixed at ``values`` (name -> value): the
        functions take (x, z, u, t) again. Itself when it reads no parameter."""
        if not self.params:
            return self
        missing = [name for name in self.params if name not in values]
        if missing:
            raise DefinitionError(f"`params`: no values for the dynamics' parameters {missing}")
        fixed = ca.DM([float(values[name]) for name in self.params])

        def close(function: ca.Function | None, inputs: int) -> ca.Function | None:
            if function is None:
                return None
            symbols = [
                ca.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(inputs)
            ]
            return ca.Function(
                function.name(),
                symbols,
                function.call([*symbols, fixed]),
                function.name_in()[:inputs],
                function.name_out(),
            )

        return replace(
            self,
            rate=close(self.rate, 4),
            residual=close(self.residual, 4),
            ode=close(self.ode, 3),
            params=(),
        )

    def parameter_input(self, fields: Mapping[str, Any]) -> list:
        """The extra input of the functions from the Point's fields: [vertcat of the values
        of ``params``], or [] when the dynamics read none."""
        if not self.params:
            return []
        missing = [name for name in self.params if name not in fields]
        if missing:
            name = missing[0]
            raise DefinitionError(
                f"`dynamics`: reads the static parameter {name!r}, which the OCP does not "
                f"declare; add .param({name!r}, lower=..., upper=..., guess=...)"
            )
        return [ca.vertcat(*[fields[name] for name in self.params])]

    @property
    def nx(self) -> int:
        return len(self.state_names)

    @property
    def nu(self) -> int:
        return len(self.control_names)

    @property
    def nz(self) -> int:
        return len(self.aux_names)

    @property
    def variable_names(self) -> tuple[str, ...]:
        return self.state_names + self.control_names + self.aux_names

    def unit(self, name: str) -> str:
        names = self.variable_names
        units = self.state_units + self.control_units + self.aux_units
        return units[names.index(name)]

    def group(self, name: str) -> tuple[str, ...] | None:
        for key, members in self.groups:
            if key == name:
                return members
        return None

    def derived_field(self, name: str) -> DerivedField | None:
        """The derived field whose group is ``name``, or None."""
        for derived in self.derived:
            if derived.group == name:
                return derived
        return None

    def role_names(self, role: str) -> tuple[str, ...]:
        """The names of the variables or derived rows of a role (``drives``,
        ``accelerations``): empty when the system has no such group."""
        group = getattr(self, role)
        if group is None:
            return ()
        members = self.group(group)
        return members if members is not None else self.derived_field(group).names

    @property
    def point_only_fields(self) -> tuple[str, ...]:
        """Names of the Point fields that are expressions, not NLP variables: derived groups
        and their rows, control-rate groups and names."""
        names: list[str] = []
        for derived in self.derived:
            names.extend((derived.group, *derived.names))
        groups = [g if isinstance(g, str) else g[0] for g in self.control_rate_groups]
        names.extend((*groups, *self.control_rate_names))
        return tuple(names)

    @staticmethod
    def from_function(
        function: ca.Function,
        formulation: str,
        state_names: Sequence[str] | None,
        control_names: Sequence[str] | None,
        state_units: Sequence[str] | None,
        control_units: Sequence[str] | None,
        param_names: Sequence[str] = (),
    ) -> System:
        """A system from an ODE f(x, u[, t][, p_1, ..., p_m]) -> xdot or an implicit
        r(x, xdot, u[, t][, p_1, ..., p_m]) -> (nx,); the last m = len(param_names) inputs
        are scalar static parameters, read by name (``OCP.param``)."""
        implicit = formulation == "implicit"
        param_names = _names("dynamics_params", param_names, len(param_names), "p")
        m = len(param_names)
        n_in = function.n_in() - m
        expected = "r(x, xdot, u[, t]" if implicit else "f(x, u[, t]"
        expected += ", " + ", ".join(param_names) + ")" if m else ")"
        if n_in not in ((3, 4) if implicit else (2, 3)) or function.n_out() != 1:
            raise DefinitionError(
                f"`dynamics`: a {formulation} dynamics Function must be {expected} with one "
                f"output; got {function.n_in()} inputs {function.name_in()} and "
                f"{function.n_out()} outputs"
            )
        for i in range(n_in, n_in + m):
            if function.size_in(i) != (1, 1):
                raise DefinitionError(
                    f"`dynamics`: the parameter input {function.name_in(i)!r} (for "
                    f"{param_names[i - n_in]!r}) must be scalar, got {function.size_in(i)}"
                )
        for i in range(n_in):
            if function.size2_in(i) != 1:
                raise DefinitionError(
                    f"`dynamics`: input {function.name_in(i)!r} must be a column vector, got "
                    f"shape {function.size_in(i)}"
                )
        nx = function.size1_in(0)
        nu = function.size1_in(2 if implicit else 1)
        if implicit and function.size1_in(1) != nx:
            raise DefinitionError(
                f"`dynamics`: the xdot input must have nx = {nx} rows, got {function.size1_in(1)}"
            )
        if function.size_out(0) != (nx, 1):
            raise DefinitionError(
                f"`dynamics`: the output must have shape ({nx}, 1) like x, "
                f"got {function.size_out(0)}"
            )
        if n_in == (4 if implicit else 3) and function.size_in(n_in - 1) != (1, 1):
            raise DefinitionError(
                f"`dynamics`: the time input must be scalar, got {function.size_in(n_in - 1)}"
            )
        states = _names("state_names", state_names, nx, "x")
        controls = _names("control_names", control_names, nu, "u")
        s_units = _names("state_units", state_units, nx, None) if state_units else ("-",) * nx
        c_units = _names("control_units", control_units, nu, None) if control_units else ("-",) * nu
        x = ca.SX.sym("x", nx)
        u = ca.SX.sym("u", nu)
        t = ca.SX.sym("t")
        # The parameters: one vector input p, as every System's functions take them.
        p = [ca.SX.sym("p", m)] if m else []
        given = [p[0][i] for i in range(m)]
        names_p = ["p"] if m else []
        if implicit:
            z = ca.SX.sym("z", nx)
            args = [x, z, u] + ([t] if n_in == 4 else []) + given
            residual = ca.Function(
                "residual",
                [x, z, u, t, *p],
                [function(*args)],
                ["x", "z", "u", "t", *names_p],
                ["residual"],
            )
            rate = z
            ode = None
            aux = tuple(f"d{name}" for name in states)
        else:
            z = ca.SX.sym("z", 0)
            args = [x, u] + ([t] if n_in == 3 else []) + given
            rate = function(*args)
            ode = ca.Function("ode", [x, u, t, *p], [rate], ["x", "u", "t", *names_p], ["xdot"])
            residual = None
            aux = ()
        rate_f = ca.Function(
            "rate", [x, z, u, t, *p], [rate], ["x", "z", "u", "t", *names_p], ["xdot"]
        )
        groups = (("x", states), ("u", controls)) + ((("z", aux),) if aux else ())
        return System(
            rate=rate_f,
            residual=residual,
            ode=ode,
            state_names=states,
            state_units=s_units,
            control_names=controls,
            control_units=c_units,
            aux_names=aux,
            aux_units=tuple(f"{unit}/s" for unit in s_units) if aux else (),
            groups=groups,
            residual_scale_group="x",
            formulation=formulation,
            control_rate_names=tuple(f"d{name}" for name in controls),
            control_rate_groups=("du",),
            residual_names=states if implicit else (),
            params=param_names,
        )


@runtime_checkable
class SystemSource(Protocol):
    """A model that turns itself into a :class:`System` (``model.Dynamics`` is one): what
    ``OCP(dynamics=...)`` accepts besides a System and a CasADi Function, so that the planner
    needs to import no model.

    ``default_formulation``: "implicit" or "explicit", used when the OCP names none;
    ``as_system(formulation, contacts)``: the System, with ``contacts`` (the model's own
    descriptions of points held by the ground, () for none) placed as the model places them.
    """

    default_formulation: str

    def as_system(self, formulation: str, contacts: Sequence = ()) -> System:
        """The model as a System in ``formulation``, with ``contacts`` held."""
        ...


def _names(field_name: str, names, size: int, prefix: str | None) -> tuple[str, ...]:
    if names is None:
        return tuple(f"{prefix}_{i}" for i in range(size))
    if isinstance(names, str) or not all(isinstance(n, str) for n in names):
        raise DefinitionTypeError(f"`{field_name}`: must be a sequence of strings, got {names!r}")
    names = tuple(names)
    if len(names) != size:
        raise DefinitionError(
            f"`{field_name}`: the dynamics has {size} of them, got {len(names)} names {names}"
        )
    if prefix is not None and len(set(names)) != size:
        raise DefinitionError(f"`{field_name}`: names must be unique, got {names}")
    return names


__all__ = [
    "DerivedField",
    "GuessCompletion",
    "System",
    "SystemSource",
]
