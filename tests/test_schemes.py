"""planner.schemes: the one registry of transcriptions, and that everything reads it.

Independent checks: a transcription added to the registry alone (backward Euler, written here
from its textbook formula) is accepted by the OCP, transcribed, named in the rows, solved,
interpolated and re-integrated, and gives the cost of Radau of degree 1 (which is backward
Euler) and the closed-form optimum's first-order error; the command line offers exactly the
registry's names; every degree check reads the registry's range.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_transcription import min_energy

from planner import TRANSCRIPTIONS, make_scheme, schemes
from planner.errors import DefinitionError, DefinitionTypeError
from planner.schemes import REGISTRY, WITH_DEGREE, Entry, Scheme, check_degree
from problems.cli import build_parser


def backward_euler(degree):
    """x1 = x0 + h f(t1): one dynamics point, at the interval's end node, which it owns."""
    return Scheme(
        "backward-euler",
        None,
        state_tau=np.array([0.0]),
        dyn_tau=np.array([1.0]),
        shares_end=False,
        A=np.array([[-1.0, 1.0]]),
        B=np.array([[1.0]]),
        defect_labels=("",),
        quadrature=np.array([1.0]),
        order=1,
        # x(tau) = x0 + h f1 tau, the line the defect implies
        state_basis=lambda tau, r: (
            np.column_stack([np.ones_like(tau) if r == 0 else np.zeros_like(tau), 0 * tau]),
            (tau if r == 0 else np.ones_like(tau) if r == 1 else np.zeros_like(tau))[:, None],
        ),
    )


def test_a_transcription_added_to_the_registry_alone_works_everywhere(monkeypatch):
    monkeypatch.setitem(REGISTRY, "backward-euler", Entry("backward-euler", backward_euler))
    ours = min_energy(16, "backward-euler")
    assert ours.degree is None
    transcription = ours.transcribe()
    assert transcription.scheme.owns_end  # its intervals own their end nodes, as Radau's
    assert "defect[q] interval 3" in transcription.g_names
    assert "bound[a] node 16" in transcription.w_names
    solution = ours.solve(progress=False, options={"tol": 1e-12})
    reference = min_energy(16, "radau", 1).solve(progress=False, options={"tol": 1e-12})
    assert solution.stats["n_variables"] == reference.stats["n_variables"]
    assert abs(solution.cost - reference.cost) < 1e-9 * reference.cost
    # the cost converges to the optimum 12 at least at the registered order (as every
    # scheme's convergence test in test_transcription asks: slope >= order - 0.3)
    finer = min_energy(32, "backward-euler").solve(progress=False, options={"tol": 1e-12})
    slope = np.log2(abs(solution.cost - 12.0) / abs(finer.cost - 12.0))
    assert slope >= transcription.scheme.order - 0.3, slope
    # the Solution interpolates and re-integrates with the registry's scheme: the state is
    # piecewise linear with the end-node rate, so re-integrating v' = a exactly matches it
    np.testing.assert_allclose(solution.state(solution.time)[:, 0], solution.states[:, 0])
    assert solution.integration_error().per_interval[:, 1].max() < 1e-9


def test_the_ocp_takes_every_registered_transcription_with_its_default_degree():
    for name, found in REGISTRY.items():
        ocp = min_energy(4, name)
        assert ocp.degree == found.default_degree
        assert ocp.transcribe().scheme.name == name
        if found.degrees:
            for degree in (found.degrees[0], found.degrees[-1]):
                assert min_energy(2, name, degree).degree == degree
            outside = found.degrees[-1] + 1
            with pytest.raises(DefinitionError, match=rf"`degree`: must be in 1..9 for {name}"):
                min_energy(2, name, outside)
            with pytest.raises(DefinitionTypeError, match=r"`degree`: must be an integer in 1"):
                min_energy(2, name, 2.0)
            with pytest.raises(DefinitionError, match=rf"`degree`: {name} collocation needs"):
                make_scheme(name)
        else:
            with pytest.raises(DefinitionError, match=r"`degree`: applies to 'radau' and"):
                min_energy(2, name, 3)
    # refine drops the degree when the new transcription takes none
    assert min_energy(4, "radau", 4).refine(transcription="trapezoid").degree is None
    assert min_energy(4, "radau", 4).refine(transcription="legendre").degree == 4
    with pytest.raises(DefinitionError, match=r"`transcription`: unknown 'euler'; use one of"):
        check_degree("euler", None)


def test_the_command_line_offers_the_registry():
    parser = build_parser()
    walk = next(
        action.choices["walk"]
        for action in parser._actions
        if getattr(action, "choices", None) and "walk" in action.choices
    )
    options = {option: action for action in walk._actions for option in action.option_strings}
    assert tuple(options["--transcription"].choices) == TRANSCRIPTIONS == tuple(REGISTRY)
    assert WITH_DEGREE == ("radau", "legendre")
    help_text = options["--degree"].help
    assert all(f"{name} 1..9" in help_text for name in WITH_DEGREE), help_text
    lines = schemes.help_text().splitlines()
    assert [line.split(":")[0] for line in lines] == list(REGISTRY)
