"""The OCP definition: a validated value (printable, copyable, immutable), names, points,
guesses, scales, and a clear error for every definition mistake."""

from __future__ import annotations

import copy
import dataclasses

import casadi as ca
import numpy as np
import pytest

from model import AnthropoidError, DefinitionError, Dynamics, presets
from planner import OCP, Point, Transcription
from planner.errors import DefinitionTypeError

CHAIN = Dynamics(presets.n_link_chain(2))


def double_integrator():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])


def di(**kwargs):
    options = {"T": 1.0, "N": 4, "state_names": ("q", "v"), "control_names": ("a",)}
    options.update(kwargs)
    return OCP(double_integrator(), **options)


def chain(**kwargs):
    options = {"T": 1.0, "N": 4}
    options.update(kwargs)
    return OCP(CHAIN, **options)


# ---- value semantics ------------------------------------------------------------------


def test_builders_return_new_values_and_leave_the_original_alone():
    base = chain()
    bounded = base.bound("M", -10, 10)
    assert base.bounds == () and len(bounded.bounds) == 2
    assert bounded is not base
    with pytest.raises(dataclasses.FrozenInstanceError):
        bounded.N = 5  # type: ignore[misc]
    copied = copy.copy(bounded)
    assert copied.bounds == bounded.bounds
    finer = dataclasses.replace(bounded, N=8)
    assert finer.N == 8 and bounded.N == 4 and finer.bounds == bounded.bounds
    assert bounded.refine(transcription="radau").degree == 3
    assert bounded.refine(transcription="radau", degree=5).refine(N=2).degree == 5


def test_ocp_prints_its_definition():
    ocp = (
        chain(transcription="radau", degree=4)
        .bound("psi_link1", -2, 2)
        .constrain("tilt", lambda p: p.psi_link1 - p.psi_link2, lower=-1, upper=1)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(M=0.0)
    )
    text = str(ocp)
    for expected in (
        "implicit dynamics",
        "nx=4 nu=2 nz=2",
        "T = 1 s",
        "N=4",
        "radau(degree 4)",
        "psi_link1 in [-2, 2]",
        "path[tilt] in [-1, 1]",
        "periodic: x(0) = x(T)",
        "minimize: integral",
        "constant(M_link1, M_link2)",
    ):
        assert expected in text, expected
    assert repr(ocp) == text


def test_linkage_naming_and_groups():
    ocp = chain()
    system = ocp.system
    assert system.state_names == ("psi_link1", "psi_link2", "dpsi_link1", "dpsi_link2")
    assert system.control_names == ("M_link1", "M_link2")
    assert system.aux_names == ("ddpsi_link1", "ddpsi_link2")
    assert system.state_units == ("rad", "rad", "rad/s", "rad/s")
    assert system.control_units == ("N m", "N m")
    assert ocp.resolve("dpsi") == ("dpsi_link1", "dpsi_link2")
    assert ocp.resolve("M_link2") == ("M_link2",)
    assert chain(formulation="explicit").system.aux_names == ()


def test_point_exposes_fields_by_name_and_group():
    ocp = chain()
    x, u, z = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("z", 2)
    point = Point(ocp.system, x, u, z, ca.SX.sym("t"), ca.SX.sym("T"))
    assert ca.is_equal(point.psi_link2, x[1])
    assert ca.is_equal(point["M_link1"], u[0])
    assert point.dpsi.shape == (2, 1) and point.ddpsi.shape == (2, 1)
    with pytest.raises(AttributeError, match="Point has no field 'foo'"):
        _ = point.foo
    with pytest.raises(AttributeError, match="read-only"):
        point.x = x


def test_function_expressions_pick_point_fields_by_input_name():
    psi = ca.SX.sym("psi", 2)
    t = ca.SX.sym("t")
    height = ca.Function(
        "height", [psi, t], [ca.sin(psi[0]) + ca.sin(psi[1]) + 0 * t], ["psi", "t"], ["y"]
    )
    ocp = chain().constrain("height", height, lower=-2.0)
    assert Transcription(ocp).n_g > 0
    bad = ca.Function("bad", [psi], [psi[0]], ["angles"], ["y"])
    with pytest.raises(
        DefinitionError, match=r"`path\[h\]`: Function input 'angles' is not a field"
    ):
        chain().constrain("h", bad, lower=0)


def test_default_scales_come_from_bounds_and_can_be_overridden():
    ocp = chain().bound("M", -50, 20).bound("psi_link1", 0.5, 1.5)
    assert ocp.variable_scale("M_link1") == 50.0
    assert ocp.variable_scale("psi_link1") == 1.5
    assert ocp.variable_scale("dpsi_link1") == 1.0
    assert ocp.scale(M=5.0).variable_scale("M_link2") == 5.0
    constrained = ocp.constrain("tilt", lambda p: p.psi_link1, lower=-3, upper=0.5)
    assert constrained.constraint_scale(constrained.constraints[0])[0] == 3.0
    assert constrained.scale(tilt=0.1).constraint_scale(constrained.constraints[0])[0] == 0.1
    # the NLP works with scaled variables and scaled defects
    transcription = Transcription(ocp.scale(M=5.0))
    assert transcription.control_scale.tolist() == [5.0, 5.0]
    assert transcription.phases[0].residual_scale.tolist() == [5.0, 5.0]


# ---- guesses -------------------------------------------------------------------------------


def guess_values(ocp):
    transcription = Transcription(ocp)
    return transcription, transcription.unpack(transcription.initial_guess())


def test_guess_from_constants_grids_and_callables():
    ocp = di(transcription="trapezoid").bound("a", -1.0, 3.0)
    _, values = guess_values(ocp)
    np.testing.assert_array_equal(values["U"], 1.0)  # the middle of the bounds
    np.testing.assert_array_equal(values["X"], 0.0)  # unbounded: 0
    _, values = guess_values(ocp.guess(q=0.5, a=2.0))
    np.testing.assert_array_equal(values["X"][:, 0], 0.5)
    np.testing.assert_array_equal(values["U"], 2.0)
    _, values = guess_values(ocp.guess(t=[0.0, 1.0], q=[0.0, 2.0]))
    np.testing.assert_allclose(values["X"][:, 0], 2.0 * np.linspace(0, 1, 5))
    _, values = guess_values(ocp.guess(lambda t: {"q": t**2, "a": np.cos(t)}))
    np.testing.assert_allclose(values["X"][:, 0], np.linspace(0, 1, 5) ** 2)
    # later layers override earlier ones variable by variable
    _, values = guess_values(ocp.guess(q=1.0, v=2.0).guess(v=3.0))
    np.testing.assert_array_equal(values["X"], np.tile([1.0, 3.0], (5, 1)))


def test_linkage_guess_torques_by_inverse_dynamics():
    def law(t):
        psi = np.column_stack([np.sin(t), np.cos(t)])
        dpsi = np.column_stack([np.cos(t), -np.sin(t)])
        ddpsi = np.column_stack([-np.sin(t), -np.cos(t)])
        return psi, dpsi, ddpsi

    for formulation in ("implicit", "explicit"):
        transcription, values = guess_values(chain(formulation=formulation).guess(law))
        t = transcription.mesh.s_dyn
        psi, dpsi, ddpsi = law(t)
        np.testing.assert_allclose(values["U"], CHAIN.inverse_dynamics(psi, dpsi, ddpsi))
        if formulation == "implicit":
            np.testing.assert_allclose(values["Z"], ddpsi)


# ---- definition errors: every path, with its message ------------------------------------


@pytest.mark.parametrize(
    "kwargs,error,match",
    [
        ({"N": 0}, DefinitionError, r"`N`: must be >= 1, got 0"),
        ({"N": 2.5}, DefinitionTypeError, r"`N`: must be an integer"),
        ({"transcription": "euler"}, DefinitionError, r"`transcription`: unknown 'euler'"),
        ({"transcription": "radau", "degree": 0}, DefinitionError, r"`degree`: must be in 1..9"),
        ({"transcription": "legendre", "degree": 10}, DefinitionError, r"must be in 1..9.*10"),
        ({"degree": 3}, DefinitionError, r"`degree`: applies to 'radau' and 'legendre' only"),
        ({"T": 0.0}, DefinitionError, r"`T`: must be a finite duration > 0 s"),
        ({"T": float("nan")}, DefinitionError, r"`T`: must be a finite duration"),
        ({"T": (2.0, 1.0)}, DefinitionError, r"`T`: lower bound 2 > upper bound 1"),
        ({"T": (0.0, 1.0)}, DefinitionError, r"`T`: free duration bounds must be finite and > 0"),
        ({"T": "1"}, DefinitionTypeError, r"`T`: must be a duration"),
        ({"formulation": "semi"}, DefinitionError, r"`formulation`: unknown 'semi'"),
        (
            {"state_names": ("a", "b", "c", "d")},
            DefinitionError,
            r"`state_names`: a Dynamics names its own",
        ),
    ],
)
def test_constructor_errors(kwargs, error, match):
    with pytest.raises(error, match=match):
        chain(**kwargs)


def test_dynamics_type_and_signature_errors():
    with pytest.raises(DefinitionTypeError, match=r"`dynamics`: must be a model"):
        OCP("pendulum", T=1.0, N=3)
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    wrong_out = ca.Function("f", [x, u], [x[0]])
    with pytest.raises(DefinitionError, match=r"the output must have shape \(2, 1\) like x"):
        OCP(wrong_out, T=1.0, N=3)
    one_input = ca.Function("f", [x], [x])
    with pytest.raises(DefinitionError, match=r"must be f\(x, u\[, t\]\) with one output"):
        OCP(one_input, T=1.0, N=3)
    with pytest.raises(DefinitionError, match=r"`state_names`: the dynamics has 2 of them, got 3"):
        di(state_names=("a", "b", "c"))
    with pytest.raises(DefinitionError, match=r"`control_names`: names must be unique"):
        OCP(ca.Function("f", [x, ca.SX.sym("u", 2)], [x]), T=1, N=2, control_names=("a", "a"))


def test_bound_errors():
    ocp = chain()
    with pytest.raises(DefinitionError, match=r"`bound`: unknown name 'M_knee'; use a variable"):
        ocp.bound("M_knee", -1, 1)
    with pytest.raises(DefinitionError, match=r"`bound\[M\]`: lower bound 1 > upper bound -1"):
        ocp.bound("M", 1, -1)
    with pytest.raises(DefinitionError, match=r"`bound\[psi\]`: lower bound contains NaN"):
        ocp.bound("psi", np.nan, 1)
    with pytest.raises(DefinitionError, match=r"`bound\[psi\]`: upper bound has shape \(3,\)"):
        ocp.bound("psi", -1, [1, 2, 3])
    with pytest.raises(DefinitionError, match=r"lower bound of \+inf or upper of -inf"):
        ocp.bound("psi", np.inf, np.inf)


def test_constraint_errors():
    ocp = chain()
    with pytest.raises(DefinitionError, match=r"`path\[c\]`: Point has no field 'psi_knee'"):
        ocp.constrain("c", lambda p: p.psi_knee, lower=0)
    with pytest.raises(DefinitionError, match=r"`path\[c\]`: give lower and/or upper"):
        ocp.constrain("c", lambda p: p.psi_link1)
    with pytest.raises(DefinitionError, match=r"`path\[c\]`: lower bound has shape \(3,\)"):
        ocp.constrain("c", lambda p: p.psi, lower=[0, 0, 0])
    with pytest.raises(DefinitionTypeError, match=r"`path\[c\]`: must be a callable of a Point"):
        ocp.constrain("c", 3.0, lower=0)
    with pytest.raises(DefinitionTypeError, match=r"`path\[c\]`: must return a CasADi SX"):
        ocp.constrain("c", lambda p: "high", lower=0)
    once = ocp.constrain("c", lambda p: p.psi_link1, lower=0)
    with pytest.raises(DefinitionError, match=r"a constraint named 'c' exists already"):
        once.constrain("c", lambda p: p.psi_link2, lower=0)
    with pytest.raises(DefinitionError, match=r"`at`: must be 'start' or 'end', got 'middle'"):
        ocp.boundary("b", lambda p: p.psi_link1, "middle", lower=0)
    with pytest.raises(DefinitionError, match=r"`initial`: 'M_link1' is not a state"):
        ocp.initial(M_link1=0.0)
    with pytest.raises(DefinitionError, match=r"`initial`: give at least one state=value"):
        ocp.initial()
    with pytest.raises(DefinitionError, match=r"`start\[initial psi\]`: lower bound has shape"):
        ocp.initial(psi=[0.0, 0.0, 0.0])


def test_periodic_objective_and_scale_errors():
    ocp = chain()
    with pytest.raises(DefinitionError, match=r"`periodic`: the mapping must return a \(4, 1\)"):
        ocp.periodic(lambda x: x[:2])
    with pytest.raises(DefinitionError, match=r"`periodic`: calling the mapping failed"):
        ocp.periodic(lambda x: x.no_such_method())
    with pytest.raises(DefinitionError, match=r"`minimize`: give an integral and/or a terminal"):
        ocp.minimize()
    with pytest.raises(DefinitionError, match=r"`integral`: must be scalar, got shape \(2, 1\)"):
        ocp.minimize(integral=lambda p: p.M)
    with pytest.raises(DefinitionError, match=r"`scale\[M\]`: scales must be finite and > 0"):
        ocp.scale(M=0.0)
    with pytest.raises(DefinitionError, match=r"`scale`: unknown name 'torque'"):
        ocp.scale(torque=1.0)


def test_guess_errors():
    ocp = chain()
    with pytest.raises(DefinitionError, match=r"`guess\[psi\]`: contains NaN or inf"):
        ocp.guess(psi=[np.nan, 0.0])
    with pytest.raises(DefinitionError, match=r"`guess\[M\]`: constant guess has shape \(3,\)"):
        ocp.guess(M=[1.0, 2.0, 3.0])
    with pytest.raises(DefinitionError, match=r"`guess\[psi\]`: expected shape \(3, 2\)"):
        ocp.guess(t=[0.0, 0.5, 1.0], psi=np.zeros((2, 2)))
    with pytest.raises(DefinitionError, match=r"`t`: the guess time grid must be strictly"):
        ocp.guess(t=[0.0, 0.0], psi=np.zeros((2, 2)))
    with pytest.raises(DefinitionError, match=r"`t`: a time grid needs arrays"):
        ocp.guess(t=[0.0, 1.0])
    with pytest.raises(DefinitionError, match=r"`guess`: unknown name 'theta'"):
        ocp.guess(theta=1.0)
    with pytest.raises(DefinitionError, match=r"`guess\[psi\]`: the function returned shape"):
        ocp.guess(lambda t: (np.zeros((t.size, 3)), np.zeros((t.size, 2))))
    with pytest.raises(DefinitionError, match=r"`guess\[dpsi\]`: the function returned NaN"):
        ocp.guess(lambda t: (np.zeros((t.size, 2)), np.full((t.size, 2), np.nan)))
    with pytest.raises(DefinitionTypeError, match=r"`guess\[psi\]`: must be numeric, got 'up'"):
        ocp.guess(lambda t: ("up", np.zeros((t.size, 2))))
    with pytest.raises(DefinitionError, match=r"`guess`: calling the guess function failed"):
        ocp.guess(lambda t: 1 / 0)
    with pytest.raises(DefinitionTypeError, match=r"`guess`: source must be a callable of t"):
        ocp.guess(42)
    with pytest.raises(DefinitionError, match=r"`T`: the duration is fixed"):
        ocp.guess(T=2.0)
    with pytest.raises(DefinitionError, match=r"`T`: guess 9.0 outside the bounds"):
        chain(T=(0.5, 2.0)).guess(T=9.0)
    with pytest.raises(DefinitionError, match=r"`guess`: give a source, values or T"):
        ocp.guess()


def test_all_definition_errors_share_the_library_base():
    with pytest.raises(AnthropoidError):
        chain(N=-1)
    with pytest.raises(ValueError):
        chain().bound("M", 2, 1)


def test_more_definition_errors():
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    row = ca.SX.sym("r", 1, 2)
    with pytest.raises(DefinitionError, match=r"input 'i0' must be a column vector"):
        OCP(ca.Function("f", [row, u], [row.T]), T=1, N=2)
    xdot3 = ca.SX.sym("xdot", 3)
    with pytest.raises(DefinitionError, match=r"the xdot input must have nx = 2 rows, got 3"):
        OCP(ca.Function("r", [x, xdot3, u], [x]), T=1, N=2, formulation="implicit")
    t2 = ca.SX.sym("t", 2)
    with pytest.raises(DefinitionError, match=r"the time input must be scalar"):
        OCP(ca.Function("f", [x, u, t2], [x]), T=1, N=2)
    f = ca.Function("f", [x, u], [x])
    with pytest.raises(DefinitionError, match=r"`formulation`: unknown 'semi'"):
        OCP(f, T=1, N=2, formulation="semi")
    with pytest.raises(DefinitionTypeError, match=r"`state_names`: must be a sequence of strings"):
        OCP(f, T=1, N=2, state_names="qv")
    with pytest.raises(DefinitionTypeError, match=r"`degree`: must be an integer in 1..9"):
        OCP(f, T=1, N=2, transcription="radau", degree=2.0)
    with pytest.raises(DefinitionError, match=r"`T`: a free duration is a pair"):
        OCP(f, T=(1.0, 2.0, 3.0), N=2)
    with pytest.raises(DefinitionError, match=r"`T` guess 5.0 outside the bounds"):
        OCP(f, T=(1.0, 2.0), N=2, T_guess=5.0)


def test_expression_errors():
    ocp = chain()
    psi = ca.SX.sym("psi", 2)
    two_out = ca.Function("two", [psi], [psi[0], psi[1]], ["psi"], ["a", "b"])
    # Several outputs stack into rows (a constraint), so an objective term must be scalar.
    with pytest.raises(DefinitionError, match=r"`integral`: must be scalar, got shape \(2, 1\)"):
        ocp.minimize(integral=two_out)
    wrong = ca.Function("wrong", [ca.SX.sym("psi", 3)], [0], ["psi"], ["a"])
    with pytest.raises(DefinitionError, match=r"`path\[c\]`: calling the Function failed"):
        ocp.constrain("c", wrong, lower=0)
    mx = ca.MX.sym("m")
    with pytest.raises(DefinitionTypeError, match=r"returned an MX expression"):
        ocp.constrain("c", lambda p: mx, lower=0)
    with pytest.raises(DefinitionError, match=r"must return a column vector, got \(2, 2\)"):
        ocp.constrain("c", lambda p: ca.repmat(p.psi, 1, 2), lower=0)
    with pytest.raises(DefinitionTypeError, match=r"`name`: a constraint needs a non-empty name"):
        ocp.constrain("", lambda p: p.psi_link1, lower=0)
    with pytest.raises(DefinitionTypeError, match=r"`bound\[M\]`: lower bound must be numeric"):
        ocp.bound("M", "low", 1)
    with pytest.raises(DefinitionTypeError, match=r"`bound`: names are strings, got 3"):
        ocp.bound(3, 0, 1)
    with pytest.raises(DefinitionTypeError, match=r"`scale\[M\]`: must be numeric"):
        ocp.scale(M="big")
    with pytest.raises(DefinitionError, match=r"`scale\[M\]`: expected a scalar or \(2,\)"):
        ocp.scale(M=[1.0, 2.0, 3.0])
    with pytest.raises(DefinitionError, match=r"`t`: the guess time grid must be finite"):
        ocp.guess(t=[], psi=np.zeros((0, 2)))
    with pytest.raises(DefinitionTypeError, match=r"`guess\[psi\]`: must be numeric"):
        ocp.guess(psi="up")
    with pytest.raises(DefinitionError, match=r"the function returned 5 arrays; expected up to 4"):
        ocp.guess(lambda t: (0,) * 5)
    with pytest.raises(DefinitionTypeError, match=r"must return a dict or a tuple"):
        ocp.guess(lambda t: np.zeros((t.size, 2)))


def test_solver_and_solution_argument_errors():
    from planner import solve

    ocp = di().initial(q=0.0, v=0.0).final(q=1.0, v=0.0).minimize(integral=lambda p: p.a**2)
    with pytest.raises(DefinitionTypeError, match=r"`problem`: must be a planner.OCP"):
        Transcription("ocp")
    transcription = Transcription(ocp)
    with pytest.raises(DefinitionError, match=r"`expand`: applies when solving an OCP"):
        solve(transcription, expand=True)
    with pytest.raises(DefinitionError, match=r"`guess`: expected a decision vector of shape"):
        solve(transcription, guess=np.zeros(3), progress=False)
    solution = solve(transcription, progress=False)
    with pytest.raises(DefinitionError, match=r"`drives`: defined for a system with the role"):
        _ = solution.drives
    with pytest.raises(DefinitionError, match=r"`t`: must be finite times in s"):
        solution.state([np.nan])
    with pytest.raises(DefinitionError, match=r"`rate_hz`: must be > 0 Hz"):
        solution.to_trajectory(rate_hz=0.0)


def test_collocation_argument_errors():
    from planner.collocation import collocation_roots

    with pytest.raises(DefinitionError, match=r"`family`: unknown collocation family 'lobatto'"):
        collocation_roots("lobatto", 3)
    with pytest.raises(DefinitionError, match=r"`degree`: must be an integer in 1..9"):
        collocation_roots("radau", 2.5)
    with pytest.raises(DefinitionError, match=r"`degree`: must be in 1..9 for radau"):
        collocation_roots("radau", 12)
    from planner import make_scheme

    with pytest.raises(DefinitionError, match=r"`degree`: radau collocation needs a degree"):
        make_scheme("radau")
    with pytest.raises(DefinitionError, match=r"`transcription`: unknown 'euler'"):
        make_scheme("euler")
    point = chain()._point()
    with pytest.raises(KeyError, match=r"Point has no field 'foo'"):
        point["foo"]


# ---- user mistakes in expressions fail at definition, naming the expression --------------
def _expression_ocp():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    f = ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])
    return OCP(f, T=1.0, N=4, state_names=("q", "v"), control_names=("a",))


@pytest.mark.parametrize(
    "expression,match",
    [
        (lambda p: p.x @ p.x, r"`path\[c\]`: evaluating the expression failed: RuntimeError"),
        (
            lambda p: p.x + ca.SX.sym("w", 3),
            r"`path\[c\]`: evaluating the expression failed: RuntimeError.*[Dd]imension",
        ),
        (lambda p: p.q + "a", r"`path\[c\]`: evaluating the expression failed: TypeError"),
        (lambda p: 1 / 0, r"`path\[c\]`: evaluating the expression failed: ZeroDivisionError"),
        (lambda p: p.q + ca.SX.sym("k"), r"`path\[c\]`: .*free symbols \['k'\]"),
        (lambda p: p.q * np.nan, r"`path\[c\]`: the expression contains the constant nan"),
        (lambda p: p.q + np.inf, r"`path\[c\]`: the expression contains the constant inf"),
    ],
)
def test_bad_path_expression_is_a_definition_error(expression, match):
    with pytest.raises(DefinitionError, match=match) as info:
        _expression_ocp().constrain("c", expression, upper=1.0)
    if "failed" in match:
        assert info.value.__cause__ is not None


def test_bad_objective_and_boundary_expressions_are_definition_errors():
    ocp = _expression_ocp()
    k = ca.SX.sym("k")
    with pytest.raises(DefinitionError, match=r"`integral`: .*free symbols \['k'\]"):
        ocp.minimize(integral=lambda p: p.a**2 + k)
    with pytest.raises(DefinitionError, match=r"`integral`: the expression contains the constant"):
        ocp.minimize(integral=lambda p: ca.sumsqr(p.u) * np.nan)
    with pytest.raises(DefinitionError, match=r"`terminal`: evaluating the expression failed"):
        ocp.minimize(terminal=lambda p: 1 / 0)
    with pytest.raises(DefinitionError, match=r"`end\[b\]`: .*free symbols \['k'\]"):
        ocp.boundary("b", lambda p: p.q + k, at="end", upper=1.0)
    with pytest.raises(DefinitionError, match=r"`periodic`: the mapping uses free symbols \['k'\]"):
        ocp.periodic(lambda x: x + k)
    with pytest.raises(DefinitionError, match=r"`periodic`: the mapping contains the constant inf"):
        ocp.periodic(lambda x: x + np.inf)


def test_singular_but_finite_expressions_are_accepted():
    # 1/q is inf at q = 0, but it has no NaN/inf constant: it must not be rejected
    ocp = _expression_ocp().constrain("c", lambda p: 1 / (1 + p.q**2) + p.a / p.v, upper=1.0)
    assert ocp.constraints[-1].name == "c"


# ---- fields that are expressions; keypoints; several outputs --------------------------------


def test_points_offer_ddpsi_in_both_formulations_and_control_rates_by_name():
    for formulation in ("implicit", "explicit"):
        point = chain(formulation=formulation)._point()
        assert point.ddpsi.shape == (2, 1)
        assert "ddpsi_link2" in point.fields and "dM_link1" in point.fields
        assert ca.is_equal(point.dM, point.du) and ca.is_equal(point.dM_link2, point.du[1])
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 2)
    explicit = Point(chain(formulation="explicit").system, x, u, ca.SX(0, 1), 0, 1)
    # Explicit ddpsi is the forward dynamics of x and u: the oracle's at a random state.
    from reference import newton_euler

    rng = np.random.default_rng(3)
    xv, uv = rng.normal(size=4), rng.normal(size=2)
    value = ca.Function("a", [x, u], [explicit.ddpsi])(xv, uv)
    expected = newton_euler.forward_dynamics(presets.n_link_chain(2), xv[:2], xv[2:], uv)
    np.testing.assert_allclose(np.asarray(value).reshape(-1), expected, rtol=1e-10)
    with pytest.raises(AttributeError, match="Point has no field 'du'"):
        _ = explicit.du  # a Point built without control rates has none
    generic = di()._point()
    assert ca.is_equal(generic.da, generic.du[0]) and "ddpsi" not in generic.fields


def test_derived_and_rate_fields_are_not_variables():
    with pytest.raises(DefinitionError, match=r"`bound`: 'dM' is a Point field computed from"):
        chain().bound("dM", -1, 1)
    with pytest.raises(DefinitionError, match=r"`scale`: 'ddpsi_link1' is a Point field"):
        chain(formulation="explicit").scale(ddpsi_link1=10.0)
    with pytest.raises(DefinitionError, match=r"`guess`: 'da' is a Point field"):
        di().guess(da=1.0)


def test_keypoints_print_and_accept_bounds_per_instant():
    ocp = di().constrain_at("key", lambda p: p.q, t=[0.25, 0.5], lower=[1.0, 2.0], upper=3.0)
    (constraint,) = ocp.constraints
    assert constraint.lower.shape == (2, 1) and constraint.lower[1, 0] == 2.0
    assert "at[key] t = (0.25, 0.5) s in [2 rows]" in str(ocp)
    both = di().constrain_at("pair", lambda p: p.x, fraction=0.5, lower=[[0.0, -1.0]], upper=1)
    assert "at[pair] t = (0.5) T" in str(both)


def test_keypoint_errors():
    ocp = di()
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: give exactly one of t \(s, fixed T\)"):
        ocp.constrain_at("k", lambda p: p.q, lower=0)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: give exactly one of t"):
        ocp.constrain_at("k", lambda p: p.q, t=0.5, fraction=0.5, lower=0)
    with pytest.raises(
        DefinitionError, match=r"`at\[k\]`: t=0.5 is an absolute time but the duration is free"
    ):
        di(T=(1.0, 2.0)).constrain_at("k", lambda p: p.q, t=0.5, lower=0)
    with pytest.raises(
        DefinitionError, match=r"`at\[k\]`: t=1.5 s lies outside \[0, T\] = \[0, 1\] s"
    ):
        ocp.constrain_at("k", lambda p: p.q, t=[0.5, 1.5], lower=0)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: fraction=-0.1 lies outside \[0, 1\]"):
        ocp.constrain_at("k", lambda p: p.q, fraction=-0.1, lower=0)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: t=0.3 s is given twice"):
        ocp.constrain_at("k", lambda p: p.q, t=[0.3, 0.5, 0.3], lower=0)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: t must be a number or a non-empty"):
        ocp.constrain_at("k", lambda p: p.q, t=[], lower=0)
    with pytest.raises(DefinitionTypeError, match=r"`at\[k\]`: fraction must be a number"):
        ocp.constrain_at("k", lambda p: p.q, fraction="half", lower=0)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: lower bound has shape \(3,\); expected"):
        ocp.constrain_at("k", lambda p: p.q, t=[0.2, 0.4], lower=[0, 1, 2])
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: lower bound 2 > upper bound 1"):
        ocp.constrain_at("k", lambda p: p.q, t=[0.2, 0.4], lower=[0, 2], upper=1)
    # A fixed horizon shortened after the keypoint was given: refused when transcribed.
    short = dataclasses.replace(ocp.constrain_at("k", lambda p: p.q, t=0.8, lower=0), T=0.5)
    with pytest.raises(DefinitionError, match=r"`at\[k\]`: t=0.8 s lies after the end"):
        Transcription(short)


def test_bounds_by_output_name_errors():
    psi = ca.SX.sym("psi", 2)
    two = ca.Function("two", [psi], [psi[0], psi], ["psi"], ["a", "b"])
    with pytest.raises(DefinitionTypeError, match=r"`path\[c\]`: a lower bound by output name"):
        chain().constrain("c", lambda p: p.psi, lower={"a": 0.0})
    with pytest.raises(DefinitionError, match=r"`path\[c\]`: upper bound names unknown outputs"):
        chain().constrain("c", two, upper={"z": 0.0})
    with pytest.raises(DefinitionError, match=r"`path\[c\]\[b\]`: upper bound has shape \(3,\)"):
        chain().constrain("c", two, upper={"b": [1.0, 2.0, 3.0]})
    rows = chain().constrain("c", two, lower={"b": [0.0, 1.0]}).constraints[0]
    np.testing.assert_array_equal(rows.lower, [-np.inf, 0.0, 1.0])
    assert rows.row_names() == ("path[c][a]", "path[c][b][0]", "path[c][b][1]")


def test_builders_reuse_the_models_system_instead_of_building_it_again():
    """Each builder makes a new definition, which asks its model for its System again: the
    model keeps one per formulation and contacts (a walking step's OCP asks about 30 times)."""
    dynamics = Dynamics(presets.n_link_chain(2))
    ocp = OCP(dynamics, T=1.0, N=4)
    built = ocp.bound("M", -5, 5).constrain("tilt", lambda p: p.psi_link1, upper=1.0).scale(M=2)
    assert built.system is ocp.system
    assert OCP(dynamics, T=2.0, N=8).system is ocp.system
    assert OCP(dynamics, T=1.0, N=4, formulation="explicit").system is not ocp.system
    held = OCP(dynamics, T=1.0, N=4, contacts=("link2",))
    assert held.system is not ocp.system and held.system.control_names[-1] == "F_link2_end_y"
