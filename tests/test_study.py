"""Walking studies (problems.study.study): the table against one-by-one solves on the process pool
and on a real Dask LocalCluster, resume after an injected exception and after a killed worker
(no point solved twice, none missing, no half-written file), failed points recorded with their
status, the continuation schedule, the study folder's checks, the command line and the plots.

Grids are small and coarse (N = 10): the 7 x 7 grid at N = 30 is the benchmark's
(examples/benchmarks/study_bench.py).
"""

from __future__ import annotations

import csv
import io
import logging
import math
import os
import subprocess
import sys
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import reference.newton_euler as ne
from privileges import permissions_hold
from privileges import run as run_unprivileged

from model import LinkageTrajectory
from model.presets import six_link_anthropoid
from planner import ACCURACY_WARNING, AccuracyWarning, Trajectory
from planner.errors import DefinitionError, DefinitionTypeError
from problems import Study, StudyProgress, StudyResult, cli, run_study, verify_gait, walking_step
from problems.cli.study import ProgressBar, value_list
from problems.study.backends import (
    CLUSTER_INSTALL,
    DaskBackend,
    available_cores,
    check_workers,
    make_backend,
)
from problems.study.plots import FILES, cost_map_figure, save_plots
from problems.study.point import (
    DEFINITION_FAILED,
    WORKER_LOST,
    PointSpec,
    check_outputs,
    guess_from,
    trajectory_bytes,
    warm_record,
)
from problems.study.runner import MAX_LOSSES
from problems.study.schedule import Schedule, choose_ordering
from problems.study.store import (
    StudyFileError,
    StudyFolder,
    StudyFolderError,
    read_definition,
    read_rows,
)

N = 10
AXES = {"step_length": [0.4, 0.5, 0.6], "step_time": [0.45, 0.5]}
#: IPOPT's failure statuses a failed point may carry.
IPOPT_FAILURES = {
    "Infeasible_Problem_Detected",
    "Maximum_Iterations_Exceeded",
    "Restoration_Failed",
    "Error_In_Step_Computation",
    "Search_Direction_Becomes_Too_Small",
    "Solved_To_Acceptable_Level",
    "Diverging_Iterates",
    "Invalid_Number_Detected",
}


def _one_by_one(step_length: float, step_time: float) -> float:
    """The same OCP solved alone, cold from the gait law."""
    return (
        walking_step(step_length=step_length, step_time=step_time, N=N).solve(progress=False).cost
    )


def _files(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.is_file()]


def _assert_complete_files(folder: Path) -> None:
    """No temporary (half-written) file, every record and solution loads, the table holds
    exactly the settled points."""
    hidden = [p for p in _files(folder) if p.name.startswith(".")]
    assert hidden == [], hidden
    rows = read_rows(folder)
    for point_id, row in rows.items():
        if row["success"]:
            LinkageTrajectory.load(folder / "solutions" / f"{point_id}.npz")
    with open(folder / "results.csv", newline="") as handle:
        table = list(csv.DictReader(handle))
    assert sorted(r["point"] for r in table) == sorted(rows)


class LogSolve:
    """An output that appends the point's values to a file: one line per completed solve
    (outputs run after a point converged, in the worker)."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __call__(self, gait) -> float:
        with open(self.path, "a") as handle:
            handle.write(f"{gait.problem.step_length!r},{gait.problem.step_time!r}\n")
        return 1.0


def _solves(path: Path) -> Counter:
    return Counter(path.read_text().split()) if path.exists() else Counter()


def killing_step(step_length, step_time, N, marker, victim, driver):
    """walking_step, but the first call at ``victim`` in a worker process (not ``driver``,
    the test's own process, which describes the study) kills that worker."""
    if [step_length, step_time] == victim and os.getpid() != driver and not os.path.exists(marker):
        Path(marker).write_text("killed")
        os._exit(1)
    return walking_step(step_length=step_length, step_time=step_time, N=N)


# ---- the table against one-by-one solves ---------------------------------------------------
@pytest.fixture(scope="module")
def pool_study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pool") / "study"
    return Study(AXES, fixed={"N": N}).run(folder, workers=2)


def test_pool_table_equals_one_by_one_solves(pool_study):
    result = pool_study
    assert result.run["backend"] == "process pool, 2 workers"
    assert result.run["ordering"] == "lines"  # 3 lines for 2 workers
    assert len(result.solved) == 6 and result.failed == [] and result.missing == []
    for row in result.rows:
        reference = _one_by_one(row["step_length"], row["step_time"])
        assert abs(row["cost"] - reference) <= 1e-6 * reference, row["point"]
    # Continuation along the lines of the step time: heads from the law, the rest from their
    # predecessor.
    starts = {row["point"]: row["start"] for row in result.rows}
    assert starts == {"p0_0": "law", "p0_1": "p0_0", "p1_0": "law", "p1_1": "p1_0",
                      "p2_0": "law", "p2_1": "p2_0"}  # fmt: skip
    _assert_complete_files(result.folder)


def test_outputs_recomputed_from_the_exported_gaits(pool_study):
    """Each output against the point's exported node trajectory and code written another way
    (the Newton-Euler oracle's ground reaction, numpy verification)."""
    linkage = six_link_anthropoid()
    weight = sum(link.mass for link in linkage.links) * linkage.gravity
    for row in pool_study.solved:
        gait = pool_study.solution(row["point"])
        assert row["speed"] == pytest.approx(row["step_length"] / row["step_time"], rel=1e-14)
        assert row["cost_of_transport"] == pytest.approx(
            row["positive_work"] / (weight * row["step_length"]), rel=1e-12
        )
        force = ne.ground_reaction(linkage, gait.psi, gait.dpsi, gait.ddpsi)
        loaded = force.imag >= 1e-3 * weight  # an unloaded foot has no friction use
        use = np.max(np.abs(force.real[loaded]) / (0.8 * force.imag[loaded]))
        assert row["peak_friction_use"] == pytest.approx(use, rel=1e-8)
        assert row["verified"] is True and verify_gait(gait, linkage).ok
        # The peaks are the 1 kHz file's (the consistent motion between the nodes, not the
        # nodes'): solved again alone, the point's file holds the same peaks.
        if row is pool_study.solved[0]:
            alone = walking_step(step_length=row["step_length"], step_time=row["step_time"], N=N)
            exported = alone.solve().to_trajectory(1000.0)
            for i, name in enumerate(linkage.names):
                peak = np.max(np.abs(exported.torques[:, i]))
                assert row[f"peak_torque_{name}"] == pytest.approx(peak, rel=1e-4, abs=1e-6)
        assert gait.metadata["gait"]["step_length"] == row["step_length"]
        assert 0 < row["accuracy"] < 0.5 and row["iterations"] > 0


def test_study_on_a_dask_local_cluster_with_a_killed_worker(tmp_path):
    """A real scheduler and two worker processes; the worker solving p0_1 dies once (Dask
    reschedules it); the table equals one-by-one solves, every point solved once."""
    cloudpickle = pytest.importorskip("cloudpickle", reason="the cluster extra is not installed")
    pytest.importorskip("distributed", reason="the cluster extra is not installed")
    log = tmp_path / "solves.txt"
    marker = tmp_path / "killed"
    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)  # the workers cannot import this test module
    try:
        study = Study(
            {"step_length": [0.45], "step_time": [0.45, 0.5]},
            killing_step,
            fixed={"N": N, "marker": str(marker), "victim": [0.45, 0.5], "driver": os.getpid()},
            outputs=("cost", ("logged", LogSolve(str(log)))),
        )
        result = study.run(tmp_path / "study", scheduler="local", workers=2, ordering="lines")
    finally:
        cloudpickle.unregister_pickle_by_value(module)
    assert marker.exists()  # the worker was killed
    assert result.run["backend"] == "Dask LocalCluster, 2 workers"
    assert [r["point"] for r in result.solved] == ["p0_0", "p0_1"]
    assert result.rows[1]["start"] == "p0_0"  # warm-started across processes
    for row in result.rows:
        reference = _one_by_one(row["step_length"], row["step_time"])
        assert abs(row["cost"] - reference) <= 1e-6 * reference
    assert set(_solves(log).values()) == {1} and len(_solves(log)) == 2
    _assert_complete_files(result.folder)


def test_warm_start_transfer_equals_the_in_memory_solution():
    """A neighbour's record rebuilt in another step's transcription is the neighbour's guess
    in physical units, with its objective scale and multipliers."""
    first = walking_step(step_length=0.5, step_time=0.5, N=N)
    gait = first.solve(progress=False)
    record = {**warm_record(gait.solution), "trajectory": trajectory_bytes(gait.to_trajectory())}
    other = walking_step(step_length=0.55, step_time=0.45, N=N)
    guessed = guess_from(other, record)
    rebuilt = guessed.guesses[-1].source
    assert rebuilt.nlp_signature == gait.solution.nlp_signature
    np.testing.assert_allclose(rebuilt.state_values, gait.solution.state_values, rtol=1e-15)
    np.testing.assert_allclose(rebuilt.control_values, gait.solution.control_values, rtol=1e-15)
    assert rebuilt.stats["objective_scale"] == gait.solution.stats["objective_scale"]
    # Physical multipliers lam * f_scale / scale are the same in both scalings.
    scale = gait.solution.stats["objective_scale"]
    np.testing.assert_allclose(
        rebuilt.lam_g * scale / rebuilt.transcription.g_scale,
        gait.solution.lam_g * scale / gait.solution.transcription.g_scale,
        rtol=1e-14,
    )
    assert other.solve(guessed, progress=False).cost == pytest.approx(
        other.solve(other.ocp.guess(gait.solution), progress=False).cost, rel=1e-9
    )
    # Another mesh: the neighbour's trajectory is the guess instead.
    coarse = walking_step(step_length=0.5, step_time=0.5, N=8)
    assert isinstance(guess_from(coarse, record).guesses[-1].source, Trajectory)


def test_a_study_over_the_double_support(tmp_path):
    """Steps with and without a double support (phases): across the change of NLP layout a
    point starts from the law; each point equals its one-by-one solve."""
    study = Study({"double_support": [0.0, 0.05]}, fixed={"N": 8, "step_time": 0.5})
    result = study.run(tmp_path / "study", workers=1)
    assert len(result.solved) == 2
    phases = result.rows[1]
    assert phases["start"] == "law" and "another NLP layout" in phases["notes"]
    for row in result.rows:
        step = walking_step(step_time=0.5, N=8, double_support=row["double_support"])
        assert row["cost"] == pytest.approx(step.solve(progress=False).cost, rel=1e-6)
        assert row["verified"] is True
    assert len(result.solution("p1").time) > len(result.solution("p0").time)


# ---- nothing lost --------------------------------------------------------------------------
def test_resume_after_an_injected_exception(tmp_path):
    """The progress callback raises after 2 points: the points in flight are still written,
    nothing is half-written; the same study again solves only the missing points."""
    log = tmp_path / "solves.txt"
    study = Study(AXES, fixed={"N": N}, outputs=("cost", ("logged", LogSolve(str(log)))))
    folder = tmp_path / "study"

    def stop_after_two(progress: StudyProgress) -> None:
        if progress.row is not None and progress.done_this_run == 2:
            raise RuntimeError("injected after 2 points")

    with pytest.raises(RuntimeError, match="injected after 2 points"):
        study.run(folder, workers=2, progress=stop_after_two)
    first = read_rows(folder)
    assert 2 <= len(first) < 6
    _assert_complete_files(folder)
    assert sum(_solves(log).values()) == len(first)
    # What a run killed between two writes leaves: a temporary file and a solution without
    # its record (the point is not settled: solved again, the file replaced).
    missing = next(p.id for p in study.points if p.id not in first)
    (folder / "points" / f".{missing}.npz.a1b2c3d4.npz").write_bytes(b"half")
    (folder / "solutions" / f"{missing}.npz").write_bytes(b"half a solution")

    result = study.run(folder, workers=2)
    assert result.run["solved"] == 6 - len(first)
    assert len(result.solved) == 6 and result.missing == []
    solves = _solves(log)
    assert len(solves) == 6 and set(solves.values()) == {1}  # none twice, none missing
    _assert_complete_files(folder)
    again = study.run(folder, workers=2)
    assert again.run["solved"] == 0 and sum(_solves(log).values()) == 6


def test_a_killed_pool_worker_loses_no_point(tmp_path):
    """A worker process dies in the middle of a point: the pool is replaced, the points in
    flight are queued again and the study completes in the same run, each point solved once."""
    log = tmp_path / "solves.txt"
    marker = tmp_path / "killed"
    study = Study(
        AXES,
        killing_step,
        fixed={"N": N, "marker": str(marker), "victim": [0.5, 0.5], "driver": os.getpid()},
        outputs=("cost", ("logged", LogSolve(str(log)))),
    )
    result = study.run(tmp_path / "study", workers=2)
    assert marker.exists()
    assert result.run["lost"] >= 1
    assert len(result.solved) == 6 and result.missing == []
    solves = _solves(log)
    assert len(solves) == 6 and set(solves.values()) == {1}
    _assert_complete_files(result.folder)


def test_failed_points_are_recorded_and_the_rest_completes(tmp_path):
    """With 40 N m drives a 1.2 m step is infeasible (IPOPT says so from the neighbour and
    from the law), 1.7 m is refused by walking_step (the legs cannot reach); 0.4 m solves."""
    study = Study(
        {"step_length": [0.4, 1.2, 1.7]},
        fixed={"N": 8, "step_time": 0.5, "torque_limit": 40.0},
    )
    result = study.run(tmp_path / "study", workers=1)
    rows = {row["point"]: row for row in result.rows}
    assert rows["p0"]["success"] is True
    infeasible = rows["p1"]
    assert infeasible["status"] == "Infeasible_Problem_Detected"
    assert infeasible["success"] is False and infeasible["status"] in IPOPT_FAILURES
    assert infeasible["attempts"] == 2
    assert "from p0:" in infeasible["notes"] and "from law:" in infeasible["notes"]
    refused = rows["p2"]
    assert refused["status"] == DEFINITION_FAILED and "too long for legs" in refused["notes"]
    assert [r["point"] for r in result.failed] == ["p1", "p2"]
    assert np.isnan(result.grid("cost")[1:]).all() and np.isfinite(result.grid("cost")[0])
    # The heat map marks exactly the failed points.
    figure = cost_map_figure(result)
    crosses = [
        (line.get_xdata()[0], line.get_ydata()[0])
        for line in figure.axes[0].get_lines()
        if line.get_marker() == "x"
    ]
    assert sorted(crosses) == [(0, 1), (0, 2)]
    assert [p.name for p in save_plots(result)] == list(FILES)


# ---- the schedule ----------------------------------------------------------------------------
def test_lines_schedule_breadth_first_with_predecessor_starts():
    schedule = Schedule((3, 4), "lines")
    assert schedule.next_ready() == (0, 0)
    order = []
    while (point := schedule.next_ready()) is not None:
        schedule.start(point)
        order.append(point)
    assert order == [(0, 0), (1, 0), (2, 0)]  # heads only: the rest wait for predecessors
    assert schedule.starts((0, 0)) == [None]
    schedule.settle((0, 0), True)
    schedule.settle((1, 0), False)
    assert schedule.next_ready() == (0, 1)
    assert schedule.starts((0, 1)) == [(0, 0), None]
    # p1_1's predecessor failed: it starts from the nearest solved points, then the law.
    assert schedule.starts((1, 1)) == [(0, 0), None]
    schedule.start((0, 1))
    schedule.settle((0, 1), True)
    assert schedule.starts((1, 1)) == [(0, 1), (0, 0), None]
    assert schedule.starts((0, 2)) == [(0, 1), (0, 0), None]
    schedule.requeue((2, 0))  # lost with its worker
    assert (2, 0) in schedule.pending and schedule.next_ready() in {(1, 1), (0, 2), (2, 0)}


def test_coarse_schedule_seeds_then_neighbours():
    schedule = Schedule((5, 3), "coarse")
    seeds = {p for p in schedule.pending if schedule.is_seed(p)}
    assert seeds == {(i, j) for i in (0, 2, 4) for j in (0, 2)}
    ready = []
    while (point := schedule.next_ready()) is not None:
        schedule.start(point)
        ready.append(point)
    assert set(ready) == seeds
    assert schedule.starts((0, 0)) == [None]
    schedule.settle((0, 0), True)
    assert schedule.next_ready() in {(0, 1), (1, 0)}
    assert schedule.starts((0, 1)) == [(0, 0), None]
    assert schedule.starts((1, 1)) == [(0, 0), None]
    cold = Schedule((2, 2), "cold", solved=[(0, 0)])
    assert cold.starts((0, 1)) == [None] and cold.next_ready() == (0, 1)


def test_ordering_choice_and_unblocking():
    assert choose_ordering("auto", (7, 7), 2) == "lines"
    assert choose_ordering("auto", (9,), 2) == "coarse"
    assert choose_ordering("auto", (3, 7), 4) == "coarse"
    assert choose_ordering("coarse", (7, 7), 2) == "coarse"
    # A resumed study: the only pending point is ready, from its solved neighbour.
    schedule = Schedule((1, 3), "lines", solved=[(0, 0), (0, 2)])
    assert schedule.next_ready() == (0, 1)
    assert schedule.starts((0, 1)) == [(0, 0), (0, 2), None]
    schedule = Schedule((1, 3), "coarse", solved=[(0, 0)], failed=[(0, 2)])
    assert schedule.next_ready() == (0, 1) and schedule.starts((0, 1)) == [(0, 0), None]
    # The safety net when nothing is ready: the first pending point in grid order.
    schedule = Schedule((1, 3), "lines")
    schedule.start((0, 0))
    assert schedule.next_ready() is None and schedule.unblock() == (0, 1)
    assert schedule.next_ready() == (0, 1)


# ---- the folder ------------------------------------------------------------------------------
def test_a_changed_study_is_refused_and_a_folder_is_held_by_one_run(tmp_path):
    definition = {"axes": {"step_length": [0.4, 0.5]}, "fixed": {"N": 30}}
    with StudyFolder(tmp_path / "s", definition):
        with pytest.raises(StudyFolderError, match="another run is using"):
            StudyFolder(tmp_path / "s", definition)
    StudyFolder(tmp_path / "s", definition).close()  # the same study: resumed
    changed = {"axes": {"step_length": [0.4, 0.5, 0.6]}, "fixed": {"N": 30}}
    with pytest.raises(
        StudyFolderError, match=r"holds another study \(axes.step_length: \[0.4, 0.5\] in the"
    ):
        StudyFolder(tmp_path / "s", changed)
    with pytest.raises(StudyFolderError, match=r"fixed.N: 30 in the folder, 20 now"):
        StudyFolder(tmp_path / "s", {**definition, "fixed": {"N": 20}})
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(StudyFolderError, match="not a study folder"):
        StudyFolder(tmp_path / "other", definition)
    (tmp_path / "file").write_text("x")
    with pytest.raises(StudyFolderError, match="exists and is not a folder"):
        StudyFolder(tmp_path / "file", definition)
    with pytest.raises(StudyFileError, match="no such file; is this a study folder"):
        read_definition(tmp_path / "other")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "study.json").write_text("{not json")
    with pytest.raises(StudyFileError, match="cannot be read as JSON"):
        read_definition(tmp_path / "bad")
    (tmp_path / "bad" / "study.json").write_text('{"format": "other"}')
    with pytest.raises(StudyFileError, match="not a study definition"):
        read_definition(tmp_path / "bad")


def test_a_changed_problem_in_a_study_folder_is_refused(tmp_path):
    study = Study({"step_length": [0.5]}, fixed={"N": 6})
    study.run(tmp_path / "s", workers=1)
    with pytest.raises(StudyFolderError, match=r"fixed\.mu: \(absent\) in the folder, 0\.7 now"):
        Study({"step_length": [0.5]}, fixed={"N": 6, "mu": 0.7}).run(tmp_path / "s", workers=1)

    def same_step(step_length, N):  # the same arguments, another function: another study
        return {"step_length": step_length, "N": N}

    with pytest.raises(StudyFolderError, match=r"holds another study \(problem: "):
        Study({"step_length": [0.5]}, same_step, fixed={"N": 6}).run(tmp_path / "s", workers=1)
    result = StudyResult.load(tmp_path / "s")
    assert len(result.solved) == 1 and result.total == 1
    with pytest.raises(DefinitionError, match="no column 'nothing'"):
        result.grid("nothing")
    with pytest.raises(DefinitionError, match="no column 'nothing'"):
        result.column("nothing")
    with pytest.raises(DefinitionError, match="no solution 'p9'"):
        result.solution("p9")


# ---- definitions -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: Study([0.5]), DefinitionTypeError, "give a dict name -> values"),
        (lambda: Study({}), DefinitionTypeError, "at least one axis"),
        (lambda: Study({"step length": [0.5]}), DefinitionError, "must be an identifier"),
        (lambda: Study({"step_length": 0.5}), DefinitionTypeError, "give a sequence of values"),
        (lambda: Study({"step_length": []}), DefinitionError, "needs at least one value"),
        (lambda: Study({"step_length": [0.4, 0.4]}), DefinitionError, "0.4 is given twice"),
        (lambda: Study({"step_length": [math.nan]}), DefinitionError, r"\[0\]`: must be finite"),
        (lambda: Study({"step_length": [None]}), DefinitionTypeError, "number, a string or a bool"),
        (lambda: Study({"stride": [1.0]}), DefinitionError, "not parameters of walking_step"),
        (
            lambda: Study({"step_length": [0.5]}, fixed={"step_length": 0.4}),
            DefinitionError,
            "are axes too",
        ),
        (lambda: Study({"step_length": [0.5]}, fixed=3), DefinitionTypeError, "dict of keyword"),
        (lambda: Study({"step_length": [0.5]}, problem=3), DefinitionTypeError, "a function or"),
        (
            lambda: Study({"mass": [1.0]}, problem=lambda step_length: {}),
            DefinitionError,
            "cannot be called with the axes",
        ),
        (
            lambda: Study({"step_length": [0.5]}, fixed={"N": object()}),
            DefinitionTypeError,
            r"`fixed\['N'\]`: a object cannot be written",
        ),
        (lambda: Study({"step_length": [0.5]}, outputs="cost"), DefinitionTypeError, "string"),
        (
            lambda: Study({"step_length": [0.5]}, outputs=["price"]),
            DefinitionError,
            "unknown output",
        ),
        (
            lambda: Study({"step_length": [0.5]}, outputs=["cost", "cost"]),
            DefinitionError,
            "'cost' is given twice",
        ),
        (
            lambda: Study({"step_length": [0.5]}, outputs=[("a b", len)]),
            DefinitionTypeError,
            "neither an output name",
        ),
        (lambda: Study({"step_length": [0.5]}, ipopt=1), DefinitionTypeError, "IPOPT options"),
        (lambda: Study({"step_length": [0.5]}, multipliers=1), DefinitionTypeError, "True or"),
        (lambda: Schedule((2,), "auto"), DefinitionError, "resolve it with choose_ordering"),
        (lambda: Schedule((0,), "lines"), DefinitionError, "needs >= 1 point"),
        (lambda: Schedule((2,), "lines", line_axis=1), DefinitionError, "is not an axis"),
        (lambda: Schedule((2,), "lines", line_axis=0.5), DefinitionTypeError, "axis number"),
        (lambda: Schedule((2,), "coarse", stride=0), DefinitionError, "integer >= 1"),
        (lambda: Schedule((2,), "lines", solved=[(5,)]), DefinitionError, "not a point"),
        (lambda: choose_ordering("spiral", (2,), 1), DefinitionError, "unknown 'spiral'"),
        (lambda: check_workers(0), DefinitionError, "`workers`: must be an integer >= 1"),
        (lambda: check_outputs([3]), DefinitionTypeError, "neither an output name"),
    ],
)
def test_bad_definitions_are_refused(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_bad_run_options_are_refused(tmp_path):
    study = Study({"step_length": [0.5]}, fixed={"N": 6})
    with pytest.raises(DefinitionError, match="unknown 'spiral'"):
        study.run(tmp_path / "a", ordering="spiral")
    with pytest.raises(DefinitionTypeError, match="`retry_failed`: must be True or False"):
        study.run(tmp_path / "a", retry_failed="yes")
    with pytest.raises(DefinitionTypeError, match="`progress`: must be a function"):
        study.run(tmp_path / "a", progress=3)
    with pytest.raises(DefinitionTypeError, match="`scheduler`: give a scheduler address"):
        study.run(tmp_path / "a", scheduler=5)
    with pytest.raises(
        DefinitionTypeError, match=r"must return a WalkingStep, a FootedStep .* or a dict"
    ):
        Study({"step_length": [0.5]}, lambda step_length: 1.0).run(tmp_path / "b")
    with pytest.raises(
        DefinitionTypeError, match=r"must return a WalkingStep, a FootedStep .* or a dict"
    ):
        PointSpec(problem=lambda step_length: 1.0).step({"step_length": 0.5})


def test_without_dask_the_study_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # "import distributed" fails
    spec = PointSpec()
    with pytest.raises(DefinitionError, match=r'pip install "\.\[cluster\]"'):
        make_backend(spec, 2, "tcp://127.0.0.1:1")
    with pytest.raises(DefinitionError, match=r"needs dask\.distributed, which is not installed"):
        DaskBackend(spec, "local")
    assert 'pip install ".[cluster]"' in CLUSTER_INSTALL


def test_cores_and_a_serial_run(tmp_path):
    assert available_cores() == len(os.sched_getaffinity(0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_study(tmp_path / "s", {"step_time": [0.5]}, fixed={"N": 6}, workers=1)
    assert result.run["backend"] == "serial (this process)" and len(result.solved) == 1
    # N = 6 is too coarse for the step's dynamics: the row says so, the solve does not print
    # it (from a worker it would cut through the progress bar)
    (row,) = result.solved
    assert row["accuracy"] > ACCURACY_WARNING and row["accuracy_warning"]
    assert "accuracy warning" in row["notes"]
    assert not [w for w in caught if issubclass(w.category, AccuracyWarning)]


# ---- command line and progress ---------------------------------------------------------------
def test_command_line_study_runs_resumes_and_refuses_another(tmp_path, capsys):
    folder = tmp_path / "study"
    argv = ["study", "--quick", "--workers", "2", "--output-dir", str(folder)]
    assert cli.main(argv) == 0
    out, err = capsys.readouterr()
    assert "this run: 4 solved, 0 failed" in out
    assert "4 solved, 0 failed, 0 missing of 4" in out
    assert "verification: all solved points passed" in out
    assert "4/4 points, 0 failed" in err
    for name in ("results.csv", *FILES):
        assert (folder / name).stat().st_size > 0
    assert len(list((folder / "solutions").glob("p*.npz"))) == 4
    assert cli.main([*argv, "--no-plots"]) == 0
    assert "this run: nothing left to solve" in capsys.readouterr().out
    assert cli.main([*argv, "--step-time-s", "0.4,0.5"]) == 2
    assert "holds another study (axes.step_time" in capsys.readouterr().err
    assert cli.main(["study", "--step-length-m", "0.3:0.7"]) == 2
    assert "start:stop:count" in capsys.readouterr().err
    assert cli.main(["study", "--step-length-m", "0.3:0.7:2000"]) == 2
    assert "at most 1,000 values on an axis" in capsys.readouterr().err
    assert cli.main(["study", "--step-length-m", "0.3:0.7:200", "--step-time-s", "0.3:1:100"]) == 2
    assert "the grid has 20,000 points, more than 10,000" in capsys.readouterr().err
    assert cli.main(["study", "--workers", "100000"]) == 2
    assert "at most 256 workers" in capsys.readouterr().err


def test_command_line_study_takes_every_registered_transcription_and_a_degree(tmp_path, capsys):
    from planner.schemes import REGISTRY

    parser = cli.build_parser()
    for name in REGISTRY:  # the planner's registry, not a list of the command line's own
        assert parser.parse_args(["study", "--transcription", name]).transcription == name
    assert cli.main(["study", "--transcription", "simpson"]) == 2
    assert "--transcription: invalid choice: 'simpson'" in capsys.readouterr().err
    # --degree reaches the points: the study's point is the walking step solved one by one
    # with that degree, and its saved solution says so.
    folder = tmp_path / "radau2"
    argv = ["study", "--step-length-m", "0.5", "--step-time-s", "0.5", "-N", "8", "--workers", "1",
            "--transcription", "radau", "--degree", "2", "--no-plots",
            "--output-dir", folder]  # fmt: skip
    assert cli.main([str(a) for a in argv]) == 0
    out = capsys.readouterr().out
    assert "walking study of six-link (radau(2) N = 8)" in out
    row = StudyResult.load(folder).rows[0]
    alone = walking_step(N=8, transcription="radau", degree=2).solve(progress=False)
    assert row["cost"] == pytest.approx(alone.cost, rel=1e-6)
    default = walking_step(N=8, transcription="radau").solve(progress=False)  # degree 3
    assert abs(row["cost"] - default.cost) > 1e-3 * default.cost
    saved = LinkageTrajectory.load(next((folder / "solutions").glob("p*.npz")))
    assert (saved.metadata["transcription"], saved.metadata["degree"]) == ("radau", 2)
    # Bad degrees are refused before any point is defined, naming the option.
    for extra, message in (
        (["--degree", "3"], "--degree: applies to --transcription radau or legendre only"),
        (["--transcription", "legendre", "--degree", "10"],
         "--degree: must be in 1..9 for legendre collocation, got 10"),
    ):  # fmt: skip
        assert cli.main(["study", *extra, "--output-dir", str(tmp_path / "bad")]) == 2
        assert message in capsys.readouterr().err
        assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize(
    ("text", "values"),
    [("0.5", (0.5,)), ("0.4,0.5", (0.4, 0.5)), ("0.3:0.7:5", (0.3, 0.4, 0.5, 0.6, 0.7))],
)
def test_axis_values_on_the_command_line(text, values):
    np.testing.assert_allclose(value_list("m", 2.0)(text), values, rtol=1e-15)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("0.3:0.7", "start:stop:count"),
        ("a,b", "start:stop:count"),
        ("0.3:0.7:1", "count must be >= 2"),
        ("0,0.5", r"must lie in \(0, 2\] m"),
        ("3", r"must lie in \(0, 2\] m"),
        ("0.5,0.5", "given twice"),
    ],
)
def test_bad_axis_values_on_the_command_line(text, match):
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match=match):
        value_list("m", 2.0)(text)


def test_progress_bar_lines_and_time_left():
    stream = io.StringIO()
    bar = ProgressBar(stream)
    for k in range(1, 21):
        bar(StudyProgress(20, k - (k > 10), int(k > 10), k, 2, 2.0 * k, 2.0 * (20 - k), {"p": k}))
    lines = stream.getvalue().splitlines()
    assert len(lines) == 10  # one per tenth of the points (not a TTY)
    assert lines[0].startswith("[###...........................] 2/20 points, 0 failed")
    assert "19 solved" not in lines[-1] and "20/20 points, 1 failed, 2 running" in lines[-1]
    assert "left 0:00" in lines[-1] and "elapsed 0:40" in lines[-1]
    assert "left 0:32" in lines[1]  # 4 points done, 16 left at 2 s each
    quiet = io.StringIO()
    ProgressBar(quiet, enabled=False)(StudyProgress(1, 1, 0, 1, 0, 1.0, 0.0, {}))
    assert quiet.getvalue() == ""


def test_the_walking_study_example_runs(tmp_path):
    example = Path(__file__).resolve().parents[1] / "examples" / "walking_study.py"
    env = dict(os.environ, MPLBACKEND="Agg")
    run = subprocess.run(
        [sys.executable, str(example), "--quick", "--output-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    assert "lowest cost of transport" in run.stdout
    assert "passive ankle, 0.400 m" in run.stdout and "actuated ankle, 0.400 m" in run.stdout
    speed = StudyResult.load(tmp_path / "speed")
    assert len(speed.solved) == 4
    ankle = StudyResult.load(tmp_path / "ankle")
    rows = {row["ankle"]: row for row in ankle.rows}
    # A passive ankle has no torque at H0: no ankle power, and a user-defined output column.
    # The peaks are the 1 kHz file's, the consistent motion's inverse dynamics: at a passive
    # hinge it needs no more than the verification's 1 % of the torque scale (150 N m).
    assert rows["passive"]["peak_torque_stance_shank"] <= 0.01 * 150.0
    assert (
        rows["passive"]["peak_torque_stance_shank"]
        < 0.1 * rows["actuated"]["peak_torque_stance_shank"]
    )
    assert rows["passive"]["peak_ankle_power"] <= 1e-5 < rows["actuated"]["peak_ankle_power"]
    for name in FILES:
        assert (tmp_path / "speed" / name).stat().st_size > 0


def test_the_axes_keep_their_order(tmp_path):
    """The grid's order (and so its point ids) survives the definition file, whose JSON
    objects have none; another order is another study."""
    study = Study({"step_time": [0.5], "step_length": [0.45, 0.5]}, fixed={"N": 6})
    result = study.run(tmp_path / "s", workers=1)
    assert list(result.axes) == ["step_time", "step_length"]
    assert [(r["point"], r["step_length"]) for r in result.rows] == [("p0_0", 0.45), ("p0_1", 0.5)]
    assert result.grid("cost").shape == (1, 2)
    swapped = Study({"step_length": [0.45, 0.5], "step_time": [0.5]}, fixed={"N": 6})
    with pytest.raises(
        StudyFolderError, match=r"axis_order.0: \"step_time\" in the folder, \"step_length\" now"
    ):
        swapped.run(tmp_path / "s", workers=1)


@pytest.mark.slow  # a benchmark's study configurations run
def test_the_study_benchmark_smoke_run():
    """study_bench.py --quick: every configuration runs; the same continuation on the pool
    gives the serial run's costs to the last bit (the warm-start transfer is exact)."""
    script = Path(__file__).resolve().parents[1] / "examples" / "benchmarks" / "study_bench.py"
    run = subprocess.run(
        [sys.executable, str(script), "--quick", "--no-dask"],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, MPLBACKEND="Agg"),
    )
    assert run.returncode == 0, run.stderr
    rows = {line[:28].strip(): line.split() for line in run.stdout.splitlines() if "  " in line}
    assert rows["pool 2 workers, lines"][-1] == "0.0e+00"
    assert rows["serial cold"][-2] == "0"  # no failed point
    assert "ordering on the pool: lines" in run.stdout


# ---- nothing lost: kill -9, a worker that always dies, damaged files, refused folders -------
def always_dying_step(step_length, step_time, N, victim, driver):
    """walking_step, but the point at ``victim`` kills its worker every time."""
    if [step_length, step_time] == victim and os.getpid() != driver:
        os._exit(1)
    return walking_step(step_length=step_length, step_time=step_time, N=N)


def test_a_point_whose_worker_always_dies_is_the_only_one_charged(tmp_path):
    log = tmp_path / "solves.txt"
    study = Study(
        AXES,
        always_dying_step,
        fixed={"N": N, "victim": [0.5, 0.5], "driver": os.getpid()},
        outputs=("cost", ("logged", LogSolve(str(log)))),
    )
    result = study.run(tmp_path / "study", workers=2)
    lost = [row for row in result.failed if row["status"] == WORKER_LOST]
    assert [row["point"] for row in lost] == ["p1_1"] and len(result.solved) == 5
    assert result.run["lost"] == MAX_LOSSES  # the victim's deaths, no innocent's
    solves = _solves(log)
    assert len(solves) == 5 and set(solves.values()) == {1}  # the others solved once each


def _children(pid: int) -> list[int]:
    """The live processes whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
def test_kill_9_of_a_study_leaves_no_worker_and_the_same_command_resumes(tmp_path):
    import signal
    import time

    folder = tmp_path / "study"
    argv = [sys.executable, "-m", "problems", "study", "--step-length-m", "0.4,0.5,0.6",
            "--step-time-s", "0.45,0.5", "-N", "10", "--workers", "2", "--no-plots", "-q",
            "--output-dir", str(folder)]  # fmt: skip
    environment = {**os.environ, "MPLBACKEND": "Agg"}
    process = subprocess.Popen(argv, env=environment, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE)  # fmt: skip
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline:  # until the workers run and a point is settled
        workers = _children(process.pid) or workers
        if list((folder / "points").glob("p*.npz")) and len(workers) >= 2:
            break
        time.sleep(0.05)
    assert len(workers) >= 2, "the study's workers never started"
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    deadline = time.monotonic() + 10
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(pid) for pid in workers), "a worker outlived the study's process"
    settled = len(read_rows(folder))
    assert 1 <= settled < 6
    # the same command, at once: no lock held, the missing points solved
    again = subprocess.run(argv, env=environment, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "another run" not in again.stderr
    assert f"this run: {6 - settled} solved" in again.stdout
    _assert_complete_files(folder)


def test_a_damaged_record_or_solution_is_reported_and_solved_again(tmp_path, caplog):
    study = Study(AXES, fixed={"N": N})
    folder = tmp_path / "study"
    study.run(folder, workers=1)
    record = folder / "points" / "p0_0.npz"
    record.write_bytes(record.read_bytes()[:100])  # a copy cut short
    solution = folder / "solutions" / "p1_1.npz"
    solution.write_bytes(b"not a zip")
    with caplog.at_level(logging.WARNING, logger="problems.study.study"):
        result = study.run(folder, workers=1)
    assert sorted(Path(p).name for p in result.run["damaged"]) == ["p0_0.npz", "p1_1.npz"]
    assert result.run["solved"] == 2 and len(result.solved) == 6
    messages = " ".join(r.getMessage() for r in caplog.records)
    assert str(record) in messages and "moved aside as p0_0.npz.damaged" in messages
    assert "its solution p1_1.npz" in messages
    assert (folder / "points" / "p0_0.npz.damaged").exists()
    assert (folder / "solutions" / "p1_1.npz.damaged").exists()
    _assert_complete_files(folder)


def _snapshot(folder: Path) -> dict:
    return {
        str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None, p.stat().st_mtime_ns)
        for p in sorted(folder.rglob("*"))
    }


def test_a_refused_folder_is_left_exactly_as_it_was(tmp_path):
    definition = {"axes": {"step_length": [0.4, 0.5]}, "fixed": {"N": 30}}
    StudyFolder(tmp_path / "s", definition).close()
    before = _snapshot(tmp_path / "s")
    changed = {"axes": {"step_length": [0.4, 0.6]}, "fixed": {"N": 30}}
    with pytest.raises(StudyFolderError, match="holds another study"):
        StudyFolder(tmp_path / "s", changed)
    assert _snapshot(tmp_path / "s") == before
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    before = _snapshot(other)
    with pytest.raises(StudyFolderError, match="not a study folder"):
        StudyFolder(other, definition)
    assert _snapshot(other) == before  # no lock file left in it
    # held by another run: refused, and nothing written either
    with StudyFolder(tmp_path / "s", definition):
        before = _snapshot(tmp_path / "s")
        with pytest.raises(StudyFolderError, match="another run is using"):
            StudyFolder(tmp_path / "s", definition)
        assert _snapshot(tmp_path / "s") == before


@pytest.mark.parametrize(
    "edit, value",
    [("an axis made NaN", [float("nan")]), ("an axis changed", [0.7])],
)
def test_an_edited_study_definition_is_refused_not_resumed(tmp_path, edit, value):
    """study.json edited by hand (its axes no longer those the records were solved for):
    refused when the study is resumed and when it is read, naming the file and the fix;
    before, only the fingerprint was compared and StudyResult reported the edited axes."""
    import json

    definition = {"axes": {"step_length": [0.4, 0.5]}, "fixed": {"N": 30}}
    StudyFolder(tmp_path / "s", definition).close()
    path = tmp_path / "s" / "study.json"
    content = json.loads(path.read_text())
    content["definition"]["axes"]["step_length"] = value
    path.write_text(json.dumps(content))
    message = r"study.json': its definition was changed after the study was written"
    with pytest.raises(StudyFileError, match=message):
        StudyFolder(tmp_path / "s", definition)
    with pytest.raises(StudyFileError, match=message):
        StudyResult.load(tmp_path / "s")


def test_a_study_folder_link_is_followed_and_an_unusable_folder_named(tmp_path, capsys):
    definition = {"axes": {"step_length": [0.4, 0.5]}, "fixed": {"N": 30}}
    target = tmp_path / "made" / "here"
    link = tmp_path / "link"
    link.symlink_to(target)  # dangling: its target is made, the link stays
    StudyFolder(link, definition).close()
    assert link.is_symlink() and (target / "study.json").is_file()
    (tmp_path / "file").write_text("x")
    with pytest.raises(StudyFolderError, match=r"`folder`: cannot use .*file/s' \(Not a directory"):
        StudyFolder(tmp_path / "file" / "s", definition)
    # the command line names its option, before solving anything
    code = cli.main(["study", "--quick", "--output-dir", str(tmp_path / "file" / "s")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("anthropoid-planner study: error: --output-dir: cannot use ")
    assert "(Not a directory" in err[-1] and "give a folder you can write" in err[-1]


@pytest.mark.skipif(not permissions_hold(), reason="file permissions cannot be made to hold")
def test_a_read_only_study_folder_is_refused_before_solving(tmp_path):
    locked = tmp_path / "ro"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        for folder in (locked, locked / "new"):
            done = run_unprivileged(
                [sys.executable, "-m", "problems", "study", "--quick", "-q",
                 "--output-dir", str(folder)],
                capture_output=True, text=True, timeout=300,
            )  # fmt: skip
            assert done.returncode == 2, done.stderr
            line = done.stderr.strip().splitlines()[-1]
            assert "error: --output-dir: cannot use" in line and "Permission denied" in line
    finally:
        locked.chmod(0o755)
    assert list(locked.iterdir()) == []
