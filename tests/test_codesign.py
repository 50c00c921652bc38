"""problems.drives.codesign: gear ratios designed with the gait (issue #36, part 5).

Oracles: the search against a cost whose minimum is known (a bowl in log N, its plans stood in
for), within its bounds and past designs no plan can walk (infinite cost); with real plans
(slow): every design's steps verified, the best design's cost its plans' exact energy, and no
worse than the start.
"""

import math

import pytest

import problems.drives.codesign as codesign
from model.presets import six_link_anthropoid
from planner.errors import AnthropoidError, DefinitionError
from problems.drives.catalogue import Drive, Gearbox, Motor
from problems.drives.loop import drives_in_the_loop

RPM = math.pi / 30.0
DRIVE = Drive(
    Motor("m", 0.07, 0.3, 2e-5, 0.6, 2.0, 48.0, 6000 * RPM, 0.5),
    Gearbox("g", 80.0, 0.8, 2e-6, 60.0, 160.0, 8000 * RPM, 0.4),
)
DRIVES = dict.fromkeys(("hip", "knee", "ankle", "neck"), DRIVE)
OPTIMUM = {"hip": 150.0, "knee": 45.0, "ankle": 100.0}


class _Plan:
    """A stand-in for a verified plan: its energy a bowl in log N around OPTIMUM, infinite
    (no plan) for a knee ratio below 40."""

    def __init__(self, drives, speed):
        self.ratios = {j: drives[j].gearbox.ratio for j in OPTIMUM}
        self.speed = speed


@pytest.fixture
def bowl(monkeypatch):
    calls = []

    def plan(linkage, drives, speed, *, regeneration=False, warm=None, **options):
        calls.append(warm is not None)
        if drives["knee"].gearbox.ratio < 40.0:
            raise AnthropoidError("no plan: the knee's motor cannot hold the stance")
        return _Plan(drives, speed), None

    def energy(gait, walker, regeneration):
        bowl = sum(math.log(gait.ratios[j] / OPTIMUM[j]) ** 2 for j in OPTIMUM)
        return gait.speed * (10.0 + 100.0 * bowl)

    monkeypatch.setattr(codesign, "plan_with_drives", plan)
    monkeypatch.setattr(codesign, "step_energy", energy)
    return calls


def test_the_search_finds_a_known_minimum_in_log_n(bowl):
    result = codesign.codesign_ratios(six_link_anthropoid(), DRIVES, (1.0, 2.0), tolerance=1.01)
    for joint, ratio in OPTIMUM.items():
        assert math.log(result.best.ratios[joint] / ratio) == pytest.approx(0.0, abs=0.05)
    assert result.best.energy < result.start.energy
    assert result.best.energy == pytest.approx(sum(result.best.per_speed))
    assert result.start.ratios == {"hip": 80.0, "knee": 80.0, "ankle": 80.0}
    # every design after the first starts its plans from the best so far
    assert bowl[: len(result.speeds)] == [False, False] and all(bowl[len(result.speeds) :])
    assert "co-designed" in result.table()


def test_the_search_stays_in_its_bounds_and_steps_past_designs_no_plan_walks(bowl):
    result = codesign.codesign_ratios(six_link_anthropoid(), DRIVES, (1.0,), bounds=(42.0, 120.0),
                                      tolerance=1.01)  # fmt: skip
    assert all(42.0 <= r <= 120.0 for ratios, _ in result.history for r in ratios.values())
    assert result.best.ratios["hip"] == pytest.approx(120.0)  # the bowl's 150 lies beyond
    infeasible = [(r, e) for r, e in result.history if r["knee"] < 40.0]
    assert not infeasible  # the bound at 42 keeps the knee where plans exist
    unbounded = codesign.codesign_ratios(six_link_anthropoid(), DRIVES, (1.0,), factor=3.0,
                                         tolerance=1.01)  # fmt: skip
    assert any(math.isinf(e) for r, e in unbounded.history if r["knee"] < 40.0)
    assert unbounded.best.ratios["knee"] >= 40.0


def test_bad_designs_are_refused_by_name(bowl):
    linkage = six_link_anthropoid()
    with pytest.raises(DefinitionError, match=r"no drive given for \['wrist'\]"):
        codesign.codesign_ratios(linkage, DRIVES, (1.0,), joints=("wrist",))
    with pytest.raises(DefinitionError, match="`bounds`"):
        codesign.codesign_ratios(linkage, DRIVES, (1.0,), bounds=(50.0, 20.0))
    with pytest.raises(DefinitionError, match="factor > tolerance > 1"):
        codesign.codesign_ratios(linkage, DRIVES, (1.0,), factor=1.01, tolerance=1.05)
    weak = Gearbox("g", 30.0, 0.8, 0.0, 60.0, 160.0, 900.0, 0.4)
    low = {**DRIVES, "knee": Drive(DRIVE.motor, weak)}
    with pytest.raises(AnthropoidError, match="the given drives walk no speed"):
        codesign.codesign_ratios(linkage, low, (1.0,))


@pytest.mark.slow
def test_a_real_design_is_made_of_verified_plans_and_improves_on_its_start():
    result = codesign.codesign_ratios(six_link_anthropoid(), DRIVES, (1.0,), joints=("hip",),
                                      factor=1.5, tolerance=1.4, N=16)  # fmt: skip
    assert result.best.energy <= result.start.energy
    for point in (result.start, result.best):
        assert all(gait.verified for gait in point.gaits)
    # the cost is the plans' exact energy, recomputed here from their files
    hip = codesign._with_ratio(DRIVE, result.best.ratios["hip"])
    walker = drives_in_the_loop(six_link_anthropoid(), {**DRIVES, "hip": hip})
    assert codesign.step_energy(result.best.gaits[0], walker, False) == pytest.approx(
        result.best.per_speed[0], rel=1e-12
    )
