"""The command line, in process through problems.__main__.main(argv), plus one real subprocess."""

import functools
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from privileges import needs_permissions
from privileges import run as run_unprivileged

import problems.gait.accuracy as problems_accuracy
from model import Dynamics, LinkageTrajectory, equations, presets
from planner.trajectory import FORMATS as TRAJECTORY_FORMATS
from planner.trajectory import Trajectory
from problems import ACCURACY_PRESETS, GaitLaw, torques_along, verify_gait
from problems.__main__ import main

PROG = "anthropoid-planner"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    return code, captured.out, captured.err


def assert_one_line_error(capsys, message, *argv, code=2):
    status, _out, err = run(capsys, *argv)
    lines = err.strip().splitlines()
    assert status == code, (status, err)
    assert len(lines) == 1, err
    assert lines[0].startswith(PROG), lines[0]
    assert re.search(message, lines[0]), lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def profile_files(tmp_path_factory):
    """A 0.3 s, 1 kHz torque profile of "paper22" written by the `torques` command."""
    folder = tmp_path_factory.mktemp("torques")
    code = main(
        [
            "torques",
            "-q",
            "--duration-s",
            "0.3",
            "--rate-hz",
            "1000",
            "--output-dir",
            str(folder),
            "--no-plots",
            "--formats",
            "csv,json,npz",
        ]
    )
    assert code == 0
    return folder


# ---- help -----------------------------------------------------------------------------------
def test_help_lists_commands(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    for command in ("equations", "torques", "simulate", "demo"):
        assert command in out


def test_the_command_line_offers_the_trajectory_formats(capsys, tmp_path):
    """--formats takes every format of planner.trajectory (and writes files that read back),
    and the help of `torques` and `simulate` lists them."""
    listed = ",".join(suffix.lstrip(".") for suffix in TRAJECTORY_FORMATS)
    code, _out, err = run(
        capsys,
        "torques",
        "-q",
        "--duration-s",
        "0.05",
        "--rate-hz",
        "100",
        "--output-dir",
        tmp_path,
        "--no-plots",
        "--formats",
        listed,
    )
    assert code == 0, err
    # every format, the CSV's sidecar, and the manifest of the set the run wrote
    names = sorted(p.name for p in tmp_path.iterdir())
    expected = [f"torques{suffix}" for suffix in TRAJECTORY_FORMATS]
    assert names == sorted([*expected, "torques.csv.meta.json", "manifest.json"])
    for suffix in TRAJECTORY_FORMATS:
        assert LinkageTrajectory.load(tmp_path / f"torques{suffix}").n_samples == 6
    for command in ("torques", "simulate"):
        code, out, _ = run(capsys, command, "--help")
        assert code == 0
        flat = " ".join(out.split())
        for suffix in TRAJECTORY_FORMATS:
            assert suffix.lstrip(".") in flat, (command, suffix)


@pytest.mark.parametrize(
    ("command", "expected"),
    [
        ("equations", ["--preset", "--latex", "--output", "kg m^2", "N m"]),
        (
            "torques",
            [
                "--law",
                "--period-s",
                "--zeta-rad",
                "--varpi-rad",
                "--center-rad",
                "--duration-s",
                "--rate-hz",
                "--output-dir",
                "--formats",
                "--no-plots",
                "--gif",
                "Hz",
                "N m",
            ],
        ),
        (
            "simulate",
            [
                "TORQUE_FILE",
                "--method",
                "--rtol",
                "--atol",
                "--substeps",
                "--t-end-s",
                "--rate-hz",
                "--interpolation",
                "--output-dir",
                "--formats",
                "rad/s",
                "cvodes",
                "collocation",
            ],
        ),
        ("demo", ["--rows", "--no-equations", "N m"]),
        (
            "compare-gait",
            [
                "PLAN",
                "--data",
                "--data-body-mass-kg",
                "--body-mass-kg",
                "--output-dir",
                "--no-plots",
                "N m/kg",
                "body weights",
            ],
        ),
        (
            "track-gait",
            [
                "--data",
                "--point-feet",
                "--weights",
                "--effort",
                "--rate-hz",
                "1/deg^2",
                "1/BW^2",
                "--output-dir",
            ],
        ),
    ],
)
def test_every_subcommand_explains_its_options(capsys, command, expected):
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    text = " ".join(out.split())  # argparse wraps lines
    for item in [*expected, "--quiet"]:
        assert item in text, item


def test_python_dash_m_help_in_a_subprocess():
    env = dict(os.environ, MPLBACKEND="Agg")
    result = subprocess.run(
        [sys.executable, "-m", "problems", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "simulate" in result.stdout and "usage: anthropoid-planner" in result.stdout


# ---- equations and demo ----------------------------------------------------------------------
def test_equations_text_latex_and_file(capsys, tmp_path):
    linkage = presets.six_link_anthropoid()
    code, out, _ = run(capsys, "equations")
    assert code == 0 and out.strip() == equations.equations_text(linkage).strip()
    code, out, _ = run(capsys, "equations", "--latex", "--preset", "six-link")
    assert code == 0 and out.strip() == equations.equations_latex(linkage).strip()
    target = tmp_path / "eq.tex"
    code, out, _ = run(capsys, "equations", "--latex", "--output", target)
    assert code == 0 and target.read_text().strip() == equations.equations_latex(linkage).strip()
    code, out, _ = run(capsys, "equations", "--preset", "exoskeleton-leg")
    assert code == 0
    assert out.strip() == equations.equations_text(presets.exoskeleton_leg()).strip()


def test_demo_prints_equations_and_the_torque_table(capsys):
    code, out, _ = run(capsys, "demo")
    assert code == 0
    assert equations.equations_text(presets.six_link_anthropoid()).strip() in out
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s+\d\.\d{3}\s", line)]
    assert len(rows) == 11
    law = GaitLaw.preset("paper22")
    dynamics = Dynamics(presets.six_link_anthropoid())
    expected = torques_along(dynamics, law, np.linspace(0.0, 1.0, 11)).torques
    np.testing.assert_allclose(np.array(rows, dtype=float)[:, 1:], expected, atol=0.006)
    peak = next(line for line in out.splitlines() if line.strip().startswith("max|M|"))
    fine = torques_along(dynamics, law, np.linspace(0.0, 1.0, 1001)).torques
    values = np.array(peak.split()[1:7], dtype=float)
    np.testing.assert_allclose(values, np.max(np.abs(fine), axis=0), atol=0.006)


def test_demo_table_only(capsys):
    code, out, _ = run(capsys, "demo", "--no-equations", "--rows", "3")
    assert code == 0
    assert len([line for line in out.splitlines() if re.match(r"^\s+\d\.\d{3}\s", line)]) == 3


# ---- torques and simulate --------------------------------------------------------------------
def test_torques_writes_profiles_that_read_back(profile_files):
    law = GaitLaw.preset("paper22")
    dynamics = Dynamics(presets.six_link_anthropoid())
    t = np.linspace(0.0, 0.3, 301)
    expected = torques_along(dynamics, law, t)
    for suffix in ("csv", "json", "npz"):
        profile = LinkageTrajectory.load(profile_files / f"torques.{suffix}")
        np.testing.assert_allclose(profile.time, t, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(profile.torques, expected.torques)  # full precision
        np.testing.assert_array_equal(profile.psi, expected.psi)


def test_torques_with_plots_and_modified_law(capsys, tmp_path):
    code, out, err = run(
        capsys,
        "torques",
        "--law",
        "walking",
        "--period-s",
        "1.2",
        "--zeta-rad",
        "0.1,0.2,0.3,0.2,0.1,0.05",
        "--duration-s",
        "0.6",
        "--rate-hz",
        "50",
        "--output-dir",
        tmp_path,
    )
    assert code == 0, err
    for name in ("torques.csv", "torques.json", "torques.png", "stick_figure.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert "max |M_i| (N m)" in out and "T = 1.2 s" in out
    assert "plotting" in err  # progress on stderr
    profile = LinkageTrajectory.load(tmp_path / "torques.csv")
    assert profile.time.size == 31
    law = GaitLaw(
        1.2,
        [0.1, 0.2, 0.3, 0.2, 0.1, 0.05],
        GaitLaw.preset("walking").varpi,
        GaitLaw.preset("walking").center,
    )
    np.testing.assert_allclose(profile.psi, law.psi(profile.time), atol=1e-15)


def test_round_trip_torques_then_simulate_reproduces_the_law(capsys, tmp_path, profile_files):
    # Stated tolerance: 1e-6 rad over 0.2 s. Measured 2.1e-7 rad (1 kHz cubic-spline torques;
    # the deviation grows ~exp(25 t) from the upright instability).
    code, out, err = run(
        capsys,
        "simulate",
        profile_files / "torques.csv",
        "--t-end-s",
        "0.2",
        "--rate-hz",
        "200",
        "--rtol",
        "1e-12",
        "--atol",
        "1e-12",
        "--output-dir",
        tmp_path,
        "--formats",
        "csv,json",
    )
    assert code == 0, err
    assert "simulating with cvodes" in err
    motion = LinkageTrajectory.load(tmp_path / "simulated.csv")
    law = GaitLaw.preset("paper22")
    assert motion.time[-1] == pytest.approx(0.2)
    deviation = np.max(np.abs(motion.psi - law.psi(motion.time)))
    assert deviation < 1e-6
    assert "max |psi - psi_file|" in out and "stays below 1e-6 rad" in out
    assert (tmp_path / "simulated.png").exists() and (tmp_path / "simulated.json").exists()
    # the same from the JSON export, quietly, without plots, with another integrator
    code, out, err = run(
        capsys,
        "simulate",
        "-q",
        profile_files / "torques.json",
        "--t-end-s",
        "0.2",
        "--method",
        "collocation",
        "--output-dir",
        tmp_path / "json",
        "--no-plots",
    )
    assert code == 0 and err == ""
    again = LinkageTrajectory.load(tmp_path / "json" / "simulated.csv")
    assert np.max(np.abs(again.psi - law.psi(again.time))) < 1e-6


def test_simulate_says_it_still_runs_between_progress_reports(monkeypatch, tmp_path, profile_files):
    # A long integration block is silent: the command's heartbeat fills the silence. The
    # integration here waits until the heartbeat has spoken (an event, not a clock), then runs.
    import functools
    import io
    import time

    stream = io.StringIO()
    monkeypatch.setattr(sys, "stderr", stream)
    monkeypatch.setattr(sys, "stdout", io.StringIO())
    from problems.cli import program
    from problems.cli import simulate as simulate_command

    monkeypatch.setattr(program, "Reporter", functools.partial(program.Reporter, heartbeat_s=0.05))
    real = simulate_command.simulate
    fractions = []

    def slow_simulate(*args, progress, **options):
        deadline = time.monotonic() + 60.0  # a bound against hanging, not a timing assertion
        while "still simulating" not in stream.getvalue() and time.monotonic() < deadline:
            time.sleep(0.01)

        def recorded(fraction, message):
            fractions.append(fraction)
            progress(fraction, message)

        return real(*args, progress=recorded, **options)

    monkeypatch.setattr(simulate_command, "simulate", slow_simulate)
    code = main(["simulate", str(profile_files / "torques.csv"), "--method", "rk", "--substeps",
                 "400", "--no-plots", "--output-dir", str(tmp_path)])  # fmt: skip
    lines = stream.getvalue().splitlines()
    assert code == 0, lines
    assert lines[0].endswith("] simulating with rk over [0, 0.3] s")
    assert re.search(r"\] still simulating with rk over \[0, 0.3\] s: [0-9.]+ s so far$", lines[1])
    assert "simulate: t = 0.300 s of 0.3 s (100%)" in stream.getvalue()
    # 400 steps per interval: blocks of 4 intervals, so the fractions come often (about
    # 0.3 s / 10 ms = 30 intervals plus the output times: several blocks, not one).
    assert len(fractions) >= 5 and fractions[-1] == 1.0
    assert np.all(np.diff(fractions) > 0)


# ---- bad input ------------------------------------------------------------------------------
def test_simulate_bad_files(capsys, tmp_path, profile_files):
    out_dir = ["--output-dir", tmp_path / "out"]
    assert_one_line_error(
        capsys, r"torque file '.*nope\.csv' does not exist", "simulate", tmp_path / "nope.csv"
    )
    garbage = tmp_path / "garbage.csv"
    garbage.write_text("hello,world\n1,2\nnot a number,\x00\n")
    assert_one_line_error(capsys, r"torque file '.*garbage\.csv' is malformed", "simulate", garbage)
    columns = tmp_path / "columns.csv"
    columns.write_text("t [s],a [m],b [m]\n0,1,2\n1,2,3\n")
    assert_one_line_error(
        capsys,
        r"torque file '.*columns\.csv' (is malformed|has no linkage columns)",
        "simulate",
        columns,
    )
    text = tmp_path / "torques.txt"
    text.write_text("0 1 2\n")
    assert_one_line_error(capsys, r"unknown format '\.txt'", "simulate", text)
    assert_one_line_error(capsys, r"is a folder", "simulate", tmp_path)
    good = profile_files / "torques.csv"
    assert_one_line_error(
        capsys, r"is for links .* preset 'five-link' has", "simulate", good, "--preset", "five-link"
    )
    assert_one_line_error(
        capsys,
        r"unknown --method 'euler'; choose one of: cvodes, idas, rk, collocation",
        "simulate",
        good,
        "--method",
        "euler",
        *out_dir,
    )
    for option, value, message in (
        ("--rtol", "2", r"--rtol: must lie in \[1e-14, 1\), got 2.0; give a tolerance such as"),
        ("--rtol", "1e-16", r"--rtol: must lie in \[1e-14, 1\), got 1e-16; below 1e-14 cvodes"),
        ("--atol", "0", r"--atol: must lie in \[1e-14, 1\), got 0.0; a tolerance is a small"),
        ("--atol=-1e-8", None, r"--atol: must lie in \[1e-14, 1\), got -1e-08"),
        ("--rtol", "nan", r"--rtol: must be a finite number such as 1e-10, got 'nan'"),
        ("--atol", "x", r"--atol: expected a number such as 1e-10, got 'x'"),
        ("--rate-hz", "2e6", r"--rate-hz: must be at most 1,000,000 Hz, got '2e6'"),
        ("--rate-hz", "-5", r"--rate-hz: must be a finite number > 0 Hz, got '-5'"),
    ):
        value = () if value is None else (value,)
        assert_one_line_error(capsys, message, "simulate", good, option, *value, *out_dir)
    assert_one_line_error(
        capsys,
        r"--t-end-s 5 s is outside the file's time range \(0, 0.3\] s",
        "simulate",
        good,
        "--t-end-s",
        "5",
        *out_dir,
    )
    assert_one_line_error(capsys, r"--substeps: must be >= 1", "simulate", good, "--substeps", "0")
    assert_one_line_error(
        capsys, r"unknown preset 'nope'", "simulate", good, "--preset", "nope", *out_dir
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--preset", "nope"], r"unknown preset 'nope'; choose one of: six-link"),
        (["--law", "paper23"], r"unknown gait law 'paper23'; choose one of: paper22, walking"),
        (["--period-s", "-1"], r"--period-s: must be a finite number > 0 s, got '-1'"),
        (["--period-s", "1e-300"], r"--period-s: 1e-300 s is too short: the law's angular"),
        (["--duration-s", "abc"], r"--duration-s: expected a number in s, got 'abc'"),
        (["--rate-hz", "0"], r"--rate-hz: must be a finite number > 0 Hz"),
        (
            ["--zeta-rad", "0.1,0.2"],
            r"--zeta-rad: expected 6 values \(one per link of preset 'six-link'\), got 2",
        ),
        (["--zeta-rad", "a,b"], r"--zeta-rad: expected comma-separated numbers in rad"),
        (
            ["--zeta-rad=0.2,-0.1,0,0,0,0"],
            r"--zeta-rad: value 2 is -0.1 rad, but an amplitude must be >= 0 rad; give 0.1 and "
            r"add pi to value 2 of --varpi-rad instead",
        ),
        (["--center-rad", "nan,0,0,0,0,0"], r"--center-rad: must be finite numbers in rad"),
        (["--formats", "csv,xls"], r"--formats: unknown format\(s\) \['xls'\]"),
        (
            ["--preset", "five-link"],
            r"gait law 'paper22' drives 6 links but preset 'five-link' has 5",
        ),
        (
            ["--rate-hz", "1e6", "--duration-s", "10"],
            r"asks for 10,000,001 samples, more than the 2,000,000 any command makes",
        ),
        (
            ["--rate-hz", "1e6", "--duration-s", "2"],
            r"--rate-hz 1e\+06 Hz x --duration-s 2 s asks for 2,000,001 samples, more than the",
        ),
        (
            ["--rate-hz", "1e5", "--duration-s", "2"],
            r"asks for 200,001 samples \(files of about 212 MB\), more than 200,000; lower "
            r"--rate-hz or --duration-s, or add --force to go ahead",
        ),
        (["--rate-hz", "1e9"], r"--rate-hz: must be at most 1,000,000 Hz, got '1e9'"),
        (["--bogus"], r"unrecognized arguments: --bogus"),
    ],
)
def test_torques_bad_input(capsys, tmp_path, argv, message):
    assert_one_line_error(capsys, message, "torques", "--output-dir", tmp_path, "--no-plots", *argv)


def test_other_bad_input(capsys, tmp_path):
    assert_one_line_error(capsys, r"unknown preset 'nope'", "equations", "--preset", "nope")
    assert_one_line_error(capsys, r"required: <command>")
    assert_one_line_error(capsys, r"invalid choice: 'fly'", "fly")
    assert_one_line_error(capsys, r"--rows: must be >= 1", "demo", "--rows", "0")
    assert_one_line_error(
        capsys, r"--rows: expected an integer, got '2.5'", "demo", "--rows", "2.5"
    )
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert_one_line_error(
        capsys,
        r"--output-dir: '.*file' exists and is not a folder",
        "torques",
        "--output-dir",
        a_file,
    )
    assert_one_line_error(
        capsys,
        r"--output-dir: cannot create '.*file/sub': Not a directory",
        "torques",
        "--output-dir",
        a_file / "sub",
    )
    assert_one_line_error(  # a file that cannot be written: status 1, as documented
        capsys,
        r"--output: cannot write '.*file/eq\.txt': Not a directory",
        "equations",
        "--output",
        a_file / "eq.txt",
        code=1,
    )


def test_equations_output_is_atomic_under_a_file_size_limit(tmp_path):
    # A real failure of the system (EFBIG) in a child process limited to 1 kB of file size:
    # exit status 1, the file named, and the old file untouched (no truncated file).
    target = tmp_path / "equations.txt"
    target.write_text("old\n")
    script = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))\n"
        "from problems.__main__ import main\n"
        f"sys.exit(main(['equations', '--output', {str(target)!r}]))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip() == (
        f"{PROG} equations: error: --output: cannot write {str(target)!r}: File too large"
    )
    assert result.stdout == ""
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["equations.txt"]


def test_simulate_unreadable_file_and_too_many_samples(capsys, tmp_path, monkeypatch):
    assert (
        main(
            [
                "torques",
                "-q",
                "--duration-s",
                "3",
                "--rate-hz",
                "10",
                "--no-plots",
                "--output-dir",
                str(tmp_path),
            ]
        )
        == 0
    )
    profile = tmp_path / "torques.csv"
    assert_one_line_error(
        capsys,
        r"--rate-hz 1e\+06 Hz over 3 s asks for 3,000,001 samples, more than the 2,000,000 "
        r"any command makes; lower --rate-hz or --t-end-s",
        "simulate",
        profile,
        "--rate-hz",
        "1e6",
        "--output-dir",
        tmp_path,
    )

    def unreadable(cls, path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(Trajectory, "load", classmethod(unreadable))
    assert_one_line_error(
        capsys,
        r"torque file '.*torques\.csv' cannot be read: Permission denied",
        "simulate",
        profile,
        "--output-dir",
        tmp_path,
    )


def test_torques_gif_and_npz(capsys, tmp_path):
    code, _out, err = run(
        capsys,
        "torques",
        "--duration-s",
        "0.1",
        "--rate-hz",
        "50",
        "--gif",
        "--formats",
        "npz",
        "--output-dir",
        tmp_path,
    )
    assert code == 0, err
    assert (tmp_path / "animation.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert LinkageTrajectory.load(tmp_path / "torques.npz").time.size == 6
    assert "writing animation.gif (4 frames)" in err  # 0.1 s at 30 frames per second


# ---- failures, warnings and progress ----------------------------------------------------------
def test_simulate_integration_failure_is_one_line(capfd, tmp_path):
    # Torques of 1e9 N m make cvodes give up (100000 steps in one interval). SUNDIALS and
    # CasADi write about 70 lines straight to stderr on such a failure; the command prints
    # its progress line and one error line, in the options' words, and exits with 1.
    law = GaitLaw.preset("paper22")
    t = np.linspace(0.0, 0.3, 31)
    names = presets.six_link_anthropoid().names
    huge = LinkageTrajectory.from_linkage(t, law.psi(t), law.dpsi(t), np.full((31, 6), 1e9), names)
    path = huge.save(tmp_path / "huge.csv")
    code = main(["simulate", str(path), "--no-plots", "--output-dir", str(tmp_path / "out")])
    captured = capfd.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 1, captured.err
    # Progress lines ("[  1.02 s] still simulating ...": the heartbeat while cvodes works)
    # and the error line; none of SUNDIALS' or CasADi's.
    others = [line for line in lines if not re.match(r"\[ *[0-9.]+ s\] ", line)]
    assert len(others) == 1, captured.err[:2000]
    assert "Traceback" not in captured.err and "Input 0" not in captured.err
    assert re.fullmatch(
        rf"{PROG} simulate: error: integrator 'cvodes' failed between t = 0 s and t = 0.01 s: "
        r"CV_TOO_MUCH_WORK \(more than 100000 steps inside one interval\); .* lower "
        r"--t-end-s or loosen --rtol/--atol",
        lines[-1],
    ), lines[-1]
    assert not (tmp_path / "out" / "simulated.csv").exists()


@pytest.mark.parametrize("method", ["rk", "collocation"])
def test_simulate_fixed_step_failure_is_one_line(capfd, tmp_path, method):
    # rk's NaN state (CasADi warns once per step) and collocation's failed Newton iteration:
    # one error line with the advice in the options' words, status 1.
    law = GaitLaw.preset("paper22")
    t = np.linspace(0.0, 0.3, 31)
    names = presets.six_link_anthropoid().names
    huge = LinkageTrajectory.from_linkage(t, law.psi(t), law.dpsi(t), np.full((31, 6), 1e9), names)
    path = huge.save(tmp_path / "huge.csv")
    out = ["--no-plots", "--output-dir", str(tmp_path / "out"), "-q"]
    code = main(["simulate", str(path), "--method", method, *out])
    captured = capfd.readouterr()
    assert code == 1, captured.err
    assert re.fullmatch(
        rf"{PROG} simulate: error: integrator '{method}' failed between t = 0 s and t = 0.01 s: "
        r"[^\n]*; lower --t-end-s or raise --substeps\n",
        captured.err,
    ), captured.err[:2000]


@pytest.fixture(scope="module")
def planner_files(tmp_path_factory):
    """A planner solution for the exoskeleton leg, saved at its nodes and at 1 kHz."""
    import casadi as ca

    from planner import OCP

    folder = tmp_path_factory.mktemp("planner")
    down = -np.pi / 2
    solution = (
        OCP(Dynamics(presets.exoskeleton_leg()), T=0.5, N=10)
        .bound("M", -200, 200)
        .initial(psi=[down] * 3, dpsi=[0.0] * 3)
        .final(psi=[down + 0.4, down + 0.2, down + 0.6], dpsi=[0.0] * 3)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .solve()
    )
    solution.save(folder / "nodes.csv")
    solution.save(folder / "fine.csv", rate_hz=1000)
    # the nodes resampled through a spline: as coarse as the nodes, however many samples
    LinkageTrajectory.load(folder / "nodes.csv").save(folder / "resampled.csv", rate_hz=1000)
    return folder


def test_simulate_warns_about_a_planner_solution_saved_at_its_nodes(capsys, planner_files):
    common = ["--preset", "exoskeleton-leg", "--no-plots", "-q"]
    out_dir = planner_files / "out"  # a folder of its own: the inputs' is not simulate's
    code, _out, err = run(
        capsys, "simulate", planner_files / "nodes.csv", *common, "--output-dir", out_dir
    )
    assert code == 0
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # the warning shows through --quiet, on one line
    assert re.fullmatch(
        rf"{PROG} simulate: warning: torque file '.*nodes\.csv' holds 11 samples of a planner "
        r"solution with N = 10 intervals \(hermite-simpson\), its nodes only: between them the "
        r"torques are a not-a-knot cubic spline, .* Solution.save\(path, rate_hz=1000\) .*",
        lines[0],
    ), lines[0]
    code, _out, err = run(
        capsys, "simulate", planner_files / "resampled.csv", *common, "--output-dir", out_dir
    )
    assert code == 0
    assert re.fullmatch(
        rf"{PROG} simulate: warning: torque file '.*resampled\.csv' was resampled from 11 "
        r"samples of a planner solution with N = 10 intervals \(hermite-simpson\), its nodes "
        r"only: .*",
        err.strip(),
    ), err
    # the same solution through its own interpolant at 1 kHz: no warning
    code, _out, err = run(
        capsys, "simulate", planner_files / "fine.csv", *common, "--output-dir", out_dir
    )
    assert code == 0 and err == ""
    code, out, _ = run(capsys, "simulate", "--help")
    assert "nodes only" in " ".join(out.split()) and "warning" in out


def test_reporter_heartbeat_while_a_silent_stage_runs():
    import io
    import time

    from problems.cli.common import Reporter

    stream = io.StringIO()
    report = Reporter(stream, heartbeat_s=0.01)
    with report.working("writing animation.gif (4 frames)"):
        deadline = time.monotonic() + 30.0  # a generous bound, not a timing assertion
        while "still" not in stream.getvalue() and time.monotonic() < deadline:
            time.sleep(0.005)
    lines = stream.getvalue().splitlines()
    assert lines[0].endswith("] writing animation.gif (4 frames)")
    assert re.search(r"\] still writing animation.gif \(4 frames\): [0-9.]+ s so far$", lines[1])
    assert re.search(r"\] done writing animation.gif \(4 frames\) in [0-9.]+ s$", lines[-1])
    quiet = io.StringIO()
    with Reporter(quiet, enabled=False, heartbeat_s=0.01).working("x"):
        pass
    assert quiet.getvalue() == ""


def test_programming_errors_keep_their_traceback(capsys, monkeypatch):
    from problems import SimulationError, cli

    def fails_with(error):
        def command(args, out, report):
            raise error

        return command

    # A bug is not bad input: a plain ValueError, TypeError or KeyError propagates.
    for bug in (ValueError("a bug"), TypeError("a bug"), KeyError("a bug")):
        monkeypatch.setitem(cli.COMMANDS, "demo", fails_with(bug))
        with pytest.raises(type(bug), match="a bug"):
            main(["demo"])
    # The library's own failures and OSError: one line, status 1.
    for error, message in (
        (SimulationError("integrator 'rk' failed"), "integrator 'rk' failed"),
        (PermissionError(13, "Permission denied", "out/torques.png"), "'out/torques.png': Perm"),
    ):
        monkeypatch.setitem(cli.COMMANDS, "demo", fails_with(error))
        assert_one_line_error(capsys, re.escape(message), "demo", code=1)


def test_library_parameter_names_become_option_names():
    from problems.cli import common
    from problems.cli.simulate import SIMULATE_OPTIONS

    assert (
        common.in_option_words("`rate_hz`: must be > 0 Hz; `x0`: too", SIMULATE_OPTIONS)
        == "--rate-hz: must be > 0 Hz; `x0`: too"
    )
    assert common.in_option_words(
        "`GaitLaw.center`: has 5 values but `zeta` has 6", common.LAW_OPTIONS
    ) == ("--center-rad: has 5 values but --zeta-rad has 6")
    assert common.in_option_words("`GaitLaw.varpi[2]`: must be finite", common.LAW_OPTIONS) == (
        "--varpi-rad value 3: must be finite"
    )


# ---- units of the torque file -----------------------------------------------------------------
def _relabelled(source, target, replace):
    """A copy of CSV ``source`` with its header rewritten by ``replace`` (a function of the
    header cells, returning the new cells) and the data column by column as it returns."""
    lines = source.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    cells = lines[header].split(",")
    rows = [line.split(",") for line in lines[header + 1 :] if not line.startswith("#")]
    keep, cells, scale = replace(cells)
    out = [",".join(cells)]
    out += [line for line in lines if line.startswith("#") and not line.startswith("# groups")]
    for row in rows:
        out.append(",".join(repr(float(row[i]) / scale[j]) for j, i in enumerate(keep)))
    target.write_text("\n".join(out) + "\n")
    return target


def test_simulate_converts_a_file_in_degrees_and_kilonewton_metres(capsys, tmp_path, profile_files):
    source = profile_files / "torques.csv"

    def to_kilo(cells):
        keep = list(range(len(cells)))
        scale = [1e3 if "[N m]" in c else (np.pi / 180 if "[rad" in c else 1.0) for c in cells]
        cells = [
            c.replace("[N m]", "[kN m]")
            .replace("[rad/s^2]", "[deg/s^2]")
            .replace("[rad/s]", "[deg/s]")
            .replace("[rad]", "[deg]")
            for c in cells
        ]
        return keep, cells, scale

    kilo = _relabelled(source, tmp_path / "kilo.csv", to_kilo)
    assert "psi_torso [deg]" in kilo.read_text() and "M_head [kN m]" in kilo.read_text()
    common = ("--t-end-s", "0.2", "--no-plots")
    code, out_si, _ = run(capsys, "simulate", source, "--output-dir", tmp_path / "si", *common)
    assert code == 0
    code, out_kilo, err = run(capsys, "simulate", kilo, "--output-dir", tmp_path / "k", *common)
    assert code == 0
    assert "converted the columns of" in err and "kN m -> N m" in err and "deg -> rad" in err
    deviation = [line for line in out_kilo.splitlines() if line.startswith("max |psi")]
    assert deviation == [line for line in out_si.splitlines() if line.startswith("max |psi")]
    a = LinkageTrajectory.load(tmp_path / "si" / "simulated.csv")
    b = LinkageTrajectory.load(tmp_path / "k" / "simulated.csv")
    np.testing.assert_allclose(b.psi, a.psi, atol=1e-10)


def test_simulate_refuses_an_unknown_unit_or_a_missing_column_by_name(
    capsys, tmp_path, profile_files
):
    source = profile_files / "torques.csv"

    def unknown(cells):
        cells = [c.replace("M_torso [N m]", "M_torso [kN/m]") for c in cells]
        return list(range(len(cells))), cells, [1.0] * len(cells)

    bad = _relabelled(source, tmp_path / "unknown.csv", unknown)
    assert_one_line_error(
        capsys,
        r"torque file '.*unknown\.csv': column `M_torso` is in 'kN/m', a unit this library "
        r"does not read as a torque; give it in N m",
        "simulate",
        bad,
    )

    def without_head_angle(cells):
        keep = [i for i, c in enumerate(cells) if not c.startswith("psi_head ")]
        return keep, [cells[i] for i in keep], [1.0] * len(keep)

    lacking = _relabelled(source, tmp_path / "lacking.csv", without_head_angle)
    assert_one_line_error(
        capsys,
        r"torque file '.*lacking\.csv': the profile lacks the column\(s\) psi_head \[rad\]",
        "simulate",
        lacking,
    )


# ---- bounded work -----------------------------------------------------------------------------
def test_long_runs_need_force_and_the_largest_are_refused(capsys, tmp_path, profile_files):
    assert_one_line_error(
        capsys,
        r"--rows 100000000 asks for 100,000,000 samples, more than the 2,000,000 any command "
        r"makes; give fewer --rows",
        "demo",
        "--rows",
        "100000000",
    )
    assert_one_line_error(
        capsys,
        r"--rows 200001 asks for 200,001 samples \(a table\), more than 200,000; give fewer "
        r"--rows, or add --force to go ahead",
        "demo",
        "--rows",
        "200001",
    )
    profile = profile_files / "torques.csv"  # 0.3 s at 1 kHz: 300 intervals and more
    line = assert_one_line_error(
        capsys,
        r"--substeps 1000000000 with --method rk over up to 362 integration intervals is "
        r"362,000,000,000 finite elements, about 2,172,000 s here \(more than 60 s\); give "
        r"fewer --substeps or a shorter --t-end-s, or add --force to run it",
        "simulate",
        profile,
        "--method",
        "rk",
        "--substeps",
        "1000000000",
    )
    assert "collocation" not in line
    assert_one_line_error(
        capsys,
        r"--substeps 2000 with --method collocation .* about 145 s here",
        "simulate",
        profile,
        "--method",
        "collocation",
        "--substeps",
        "2000",
    )
    assert_one_line_error(
        capsys,
        r"--rate-hz 1e\+06 Hz over 0.3 s asks for 300,001 samples \(output files to match\), "
        r"more than 200,000; lower --rate-hz or --t-end-s, or add --force",
        "simulate",
        profile,
        "--rate-hz",
        "1e6",
    )
    # --force goes past the soft limits
    code, out, _ = run(capsys, "demo", "--no-equations", "--rows", "200001", "--force")
    rows = [line for line in out.splitlines() if re.match(r"\s*\d+\.\d{3}\s", line)]
    assert code == 0 and len(rows) == 200001


def test_planner_progress_is_shown_on_stderr_unless_quiet(capsys, monkeypatch):
    import casadi as ca

    from planner import OCP
    from problems import cli

    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    f = ca.Function("f", [x, u], [ca.vertcat(x[1], u)])
    ocp = (
        OCP(f, T=1.0, N=5, state_names=("q", "v"), control_names=("a",))
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
    )
    solved = []

    def plan(args, out, report):
        solved.append(ocp.solve())  # progress=True, the default
        return 0

    monkeypatch.setitem(cli.COMMANDS, "demo", plan)
    code, out, err = run(capsys, "demo")
    iterations = [line for line in err.splitlines() if "iter" in line and "objective" in line]
    assert code == 0 and out == ""
    assert len(iterations) == solved[-1].iterations + 1, err
    assert re.search(r"\] iter\s+0\s+objective [-+.\de]+\s+max violation [.\de+-]+\s+[\d.]+ s", err)
    code, out, err = run(capsys, "demo", "--quiet")
    assert code == 0 and err == ""
    # outside the command line nothing is configured: nothing on the streams
    ocp.solve()
    assert capsys.readouterr() == ("", "")


# ---- walk: the main job -------------------------------------------------------------------
@pytest.fixture(scope="module")
def walk_run(tmp_path_factory):
    """`walk --quick` once for the module: its exit status, printed summary and folder."""
    folder = tmp_path_factory.mktemp("walk") / "out"
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["walk", "--quick", "--output-dir", str(folder)])
    return code, out.getvalue(), err.getvalue(), folder


def test_walk_writes_the_robots_view_beside_the_models(walk_run):
    """joints.csv: one stride of the file read back, the printed peaks the file's."""
    code, out, err, folder = walk_run
    assert code == 0, err
    table = np.genfromtxt(folder / "joints.csv", delimiter=",", names=True)
    meta = json.loads((folder / "joints.csv.meta.json").read_text())
    assert meta["format"] == "anthropoid-planner joint space" and meta["sides"] == ["right", "left"]
    assert table["t_s"][-1] == pytest.approx(1.0)  # two steps of 0.5 s
    printed = re.search(r"peak \|tau\| \(N m\): right_hip ([\d.]+)", out)
    assert float(printed.group(1)) == pytest.approx(np.max(np.abs(table["tau_right_hip_N_m"])),
                                                    abs=0.051)  # fmt: skip
    assert "joints.csv" in json.loads((folder / "manifest.json").read_text())["files"]


def test_walk_legs_option_is_checked(capsys):
    assert_one_line_error(capsys, r"--legs: .*two different leg names", "walk", "--legs", "a,a")


def test_walk_on_feet_takes_the_torque_or_the_human_objective_only(capsys):
    assert_one_line_error(capsys, r"--objective work: the step on feet takes torque or human",
                          "walk", "--preset", "six-link-feet", "--objective", "work")  # fmt: skip


def test_walk_quick_writes_the_torques_the_solution_and_the_pictures(walk_run):
    code, out, err, folder = walk_run
    assert code == 0, err
    assert "Traceback" not in out + err
    for name in ("torques.csv", "torques.json", "solution.npz", "gait.png", "walk.png", "walk.gif"):
        assert (folder / name).stat().st_size > 0, name
    assert re.search(r"IPOPT: Solve_Succeeded in \d+ iterations; build [\d.]+ s, solve", out)
    law = re.search(r"same mesh: ([\d.e+]+) \(", out)
    cost = re.search(r"cost \(integral of sum M_i\^2, N\^2 m\^2 s\): ([\d.e+]+);", out)
    assert float(cost.group(1)) < float(law.group(1))
    # the file read back is what is verified, check by check
    assert re.search(
        r"verification of torques.csv \(501 samples, numpy, independent of the planner\): all "
        r"\d+ checks passed",
        out,
    )
    for check in ("dynamics", "kinematics", "rates", "ground", "centre of pressure", "clearance"):
        assert re.search(rf"\n  ok   {check} +[-+]\d", out), check
    assert re.search(r"its torques are the inverse dynamics of its own motion to \d", out)
    assert re.search(r"accuracy: largest per-interval re-integration error", out)
    # --quick's 12 intervals obey the dynamics to 2 % of a rate's scale: a warning names the fix
    assert re.search(r"warning: the plan obeys its dynamics only to .* -N", err)
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["command"] == "walk" and "torques.csv" in manifest["files"]
    # Progress lines on stderr for the stages, the GIF among them.
    assert "solving with IPOPT" in err and "writing walk.gif" in err
    # The torque file is a 1 kHz profile of one step with the gait's settings, readable by
    # numpy alone.
    profile = LinkageTrajectory.load(folder / "torques.csv")
    assert profile.metadata["gait"]["problem"] == "walking_step"
    np.testing.assert_allclose(np.diff(profile.time), 1e-3, atol=1e-12)
    assert profile.time[-1] == pytest.approx(0.5)
    solution = LinkageTrajectory.load(folder / "solution.npz")
    assert solution.n_samples == 13  # the 12 intervals' nodes
    # The GIF shows two steps: frames for 2 x 0.5 s at 15 frames per second, three footholds
    # 0.5 m apart, and the body advanced by two step lengths from the first frame to the last.
    count, (first, last) = gif_end_frames(folder / "walk.gif")
    assert count - 1 >= 2 * 0.5 * 15
    footholds, advance = footholds_and_advance(first, last)
    assert len(footholds) == 3, footholds
    step_pixels = np.diff(footholds)
    assert np.ptp(step_pixels) <= 2, footholds  # evenly spaced
    assert advance / step_pixels.mean() == pytest.approx(2.0, abs=0.05)


def gif_end_frames(path):
    """The frame count and the first and last frames (RGB, int arrays) of a GIF."""
    from PIL import Image

    with Image.open(path) as gif:
        ends = []
        for k in (0, gif.n_frames - 1):
            gif.seek(k)
            ends.append(np.asarray(gif.convert("RGB"), dtype=int))
        return gif.n_frames, ends


def footholds_and_advance(first, last):
    """Read a walk's picture back: the pixel columns of the black foothold markers on the
    grey ground line (between the axes' black frame lines), and how far (pixels) the
    coloured bodies moved from the first frame to the last (centroid of the pixels coloured in
    one frame only: the legend and the markers cancel)."""
    grey = np.abs(first - 128).max(axis=2) < 20
    ground = int(np.argmax(grey.sum(axis=1)))
    black = (first.max(axis=2) < 60) | (last.max(axis=2) < 60)  # bodies hide some markers
    frame_lines = np.flatnonzero(black.sum(axis=0) > 100)
    inside = np.zeros(black.shape[1], dtype=bool)
    inside[frame_lines.min() + 1 : frame_lines.max()] = True
    columns = np.flatnonzero(black[ground - 10 : ground + 3].any(axis=0) & inside)
    runs = np.split(columns, np.flatnonzero(np.diff(columns) > 1) + 1)
    footholds = [float(run.mean()) for run in runs if run.size]
    coloured_first, coloured_last = np.ptp(first, axis=2) > 60, np.ptp(last, axis=2) > 60
    before = np.nonzero(coloured_first & ~coloured_last)[1].mean()
    after = np.nonzero(coloured_last & ~coloured_first)[1].mean()
    return footholds, float(after - before)


def test_walk_on_feet_writes_verified_files_and_pictures(tmp_path):
    """`walk --preset six-link-feet --quick`: the step on feet planned, written, read back and
    verified phase by phase, drawn (the GIF's feet are outlines: two steps, three footholds)."""
    import contextlib
    import io

    folder = tmp_path / "feet"
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["walk", "--preset", "six-link-feet", "--quick", "--output-dir", str(folder)])
    out, err = out.getvalue(), err.getvalue()
    assert code == 0, err
    assert re.search(r"\(human\): .* flat [\d.]+ s, heel rise [\d.]+ s, double [\d.]+ s", out)
    assert re.search(r"verification of torques.csv \(\d+ samples.*\): all \d+ checks passed", out)
    for check in ("stance foot flat", "ball passive", "heel held", "front ball up", "ankles"):
        assert re.search(rf"\n  ok   {check} +[-+]\d", out), check
    assert re.search(r"ankle push-off up to \d+ W", out)
    profile = LinkageTrajectory.load(folder / "torques.csv")
    assert profile.metadata["gait"]["problem"] == "footed_step"
    assert {"F_swing_heel_x", "F_swing_heel_y", "CoP_stance_foot_start_x"} <= set(profile.extras)
    for name in ("gait.png", "walk.png", "walk.gif", "solution.npz", "manifest.json"):
        assert (folder / name).stat().st_size > 0, name
    count, (first, last) = gif_end_frames(folder / "walk.gif")
    assert count - 1 >= 2 * 0.5 * 15  # two steps of 0.5 s at 15 frames per second
    footholds, advance = footholds_and_advance(first, last)
    assert len(footholds) == 3, footholds
    assert advance / np.diff(footholds).mean() == pytest.approx(2.0, abs=0.1)


@pytest.mark.slow
def test_walk_on_feet_with_feedback_writes_its_law_and_walks_it_in_mujoco(tmp_path):
    """`walk --preset six-link-feet --feedback`: the joint PD law in torques.csv (the gains'
    columns, the branch of each row, the law in the sidecar) and its walks in MuJoCo."""
    pytest.importorskip("mujoco")
    import contextlib
    import io

    folder = tmp_path / "feet"
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["walk", "--preset", "six-link-feet", "--feedback", "--no-gif",
                     "--output-dir", str(folder)])  # fmt: skip
    out, err = out.getvalue(), err.getvalue()
    assert code == 0, err
    assert re.search(r"feedback: joint PD around the plan at 1000 Hz", out)
    assert re.search(r"\n  closed loop +20/20 ", out), out  # MuJoCo's
    simulation = out.split("the product's simulation on feet")[1].split("MuJoCo (")[0]
    assert re.search(r"\n  closed loop +10/10 ", simulation), out
    assert re.search(r"\n  mass \+10 % +10/10 ", simulation), out
    assert re.search(r"\n  open loop +[01]/20 .*fell: step", out), out
    assert re.search(r"largest push survived in MuJoCo: forward [\d.]+ N s", out)
    profile = LinkageTrajectory.load(folder / "torques.csv")
    assert {"phase", "double_support", "K_stance_shank__psi_stance_foot"} <= set(profile.extras)
    assert profile.metadata["feedback"]["kp"]["double"][1] == 1000.0
    assert (folder / "mujoco_walk.png").stat().st_size > 0


@pytest.mark.slow
def test_walk_on_feet_toe_walking_writes_verified_files(tmp_path):
    """`walk --preset six-link-feet --feet-phases toe-walking --quick`: on the balls of the
    feet, planned, written, read back and verified with the front ball's checks."""
    import contextlib
    import io

    folder = tmp_path / "toes"
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["walk", "--preset", "six-link-feet", "--feet-phases", "toe-walking",
                     "--quick", "--no-gif", "--output-dir", str(folder)])  # fmt: skip
    out, err = out.getvalue(), err.getvalue()
    assert code == 0, err
    assert re.search(r"\(toe-walking\): .* heel rise [\d.]+ s, double [\d.]+ s", out)
    assert re.search(r"verification of torques.csv \(\d+ samples.*\): all \d+ checks passed", out)
    for check in ("ball held", "front heel up", "ball passive", "stance heel up"):
        assert re.search(rf"\n  ok   {check} +[-+]\d", out), check
    profile = LinkageTrajectory.load(folder / "torques.csv")
    assert profile.metadata["gait"]["phases"] == ["heel rise", "double"]
    assert {"F_swing_toe_x", "F_swing_toe_y"} <= set(profile.extras)
    assert "F_swing_toe_x/_y the front ball's force in the double support" in out


def test_walk_refuses_a_landing_speed_that_is_not_positive(capsys):
    for value in ("0", "-1"):
        assert_one_line_error(
            capsys, rf"--landing-speed-mps: must be a finite number > 0 m/s, got '{value}'",
            "walk", f"--landing-speed-mps={value}",
        )  # fmt: skip


def test_walk_on_feet_refuses_the_point_foot_options_by_name(capsys):
    for option in (["-N", "12"], ["--double-support-s", "0.05"], ["--passive-ankle"],
                   ["--ground-friction", "1.5"], ["--landing-speed-mps", "1"]):  # fmt: skip
        assert_one_line_error(
            capsys, rf"{option[0]}: not for --preset six-link-feet", "walk", "--preset",
            "six-link-feet", *option,
        )  # fmt: skip
    assert_one_line_error(
        capsys, r"--clearance-m: must be a finite number >= 0 m, got -1.0", "walk", "--preset",
        "six-link-feet", "--clearance-m", "-1",
    )  # fmt: skip
    assert_one_line_error(
        capsys, r"--feet-phases flat-footed: only with --preset six-link-feet", "walk",
        "--feet-phases", "flat-footed",
    )  # fmt: skip


def test_walk_refuses_a_tree_that_is_not_a_biped(capsys):
    assert_one_line_error(
        capsys, r"--preset: 'exoskeleton-leg' is not a biped", "walk", "--preset", "exoskeleton-leg"
    )
    assert_one_line_error(
        capsys, r"argument --step-length-m: must be at most 2 m", "walk", "--step-length-m", "3"
    )
    assert_one_line_error(
        capsys, r"--degree: applies to --transcription radau or legendre", "walk", "--degree", "3"
    )


def test_walk_reports_a_failed_solve_with_status_1(capsys, tmp_path):
    # 1 N m per hinge cannot hold the body up: IPOPT fails (infeasible or out of iterations).
    status, out, err = run(
        capsys, "walk", "--quick", "--no-plots", "--torque-limit-nm", "1",
        "--output-dir", tmp_path / "failed",
    )  # fmt: skip
    assert status == 1
    assert re.search(r"error: IPOPT did not converge: \w+", err)
    assert "IPOPT:" in out  # the summary is still printed, with the status


def test_walk_accuracy_refines_to_a_target_and_prints_its_passes(capsys, tmp_path):
    status, out, err = run(
        capsys, "walk", "-q", "-N", "10", "--accuracy", "1e-2", "--no-plots",
        "--output-dir", tmp_path / "refined",
    )  # fmt: skip
    assert status == 0, err
    assert "refinement to 1.0e-02 (per-interval re-integration error / nominal scale): " in out
    assert ": reached (" in out
    N = int(re.search(r"hermite-simpson N = (\d+) \(refined mesh\)", out).group(1))
    passes = re.findall(r"^\s+(\d+)\s+(\d+)\s+([\d.e+-]+) ", out, flags=re.MULTILINE)
    assert passes[0][1] == "10" and int(passes[-1][1]) == N > 10
    assert float(passes[-1][2]) <= 1e-2
    # the accuracy line in the same units: the error over its state's nominal scale
    line = re.search(r"accuracy: .* error ([\d.e+-]+) (rad/s|rad) \(.*; ([\d.e+-]+) of its", out)
    scale = 3.0 if line.group(2) == "rad/s" else 1.0
    assert float(line.group(3)) == pytest.approx(float(line.group(1)) / scale, rel=0.01)
    assert float(line.group(3)) <= 1e-2
    profile = LinkageTrajectory.load(tmp_path / "refined" / "solution.npz")
    final = profile.metadata["N"]  # the refined mesh, cut further where a limit needed it
    assert profile.n_samples == final + 1 and final >= N
    cut = re.search(r"intervals cut in two \(N = (\d+)\)", out)
    assert final == (int(cut.group(1)) if cut else N)


def test_walk_accuracy_target_missed_fails_with_status_1_and_writes_nothing(
    capsys, tmp_path, monkeypatch
):
    # One pass allowed: a target far below N = 10's error cannot be reached.
    monkeypatch.setattr(
        problems_accuracy, "refine_to", functools.partial(problems_accuracy.refine_to, max_passes=1)
    )
    folder = tmp_path / "missed"
    status, out, err = run(
        capsys, "walk", "-q", "-N", "10", "--accuracy", "1e-7", "--no-plots",
        "--output-dir", folder,
    )  # fmt: skip
    assert status == 1
    assert re.search(
        r"error: the accuracy target 1e-07 was not reached: max_passes = 1 used, error "
        r"[\d.e+-]+; nothing written",
        err,
    )
    assert "NOT reached" in out  # the passes are still printed
    assert not folder.exists()


def test_walk_accuracy_preset_sets_the_mesh(capsys, tmp_path):
    draft = ACCURACY_PRESETS["draft"]
    status, out, err = run(
        capsys, "walk", "-q", "--accuracy", "draft", "--no-plots", "--output-dir", tmp_path / "d"
    )
    assert status == 0, err
    assert f"{draft.transcription} (accuracy draft: tol {draft.tol:g}" in out
    assert f") N = {draft.intervals(0.5)}, implicit" in out


def test_walk_accuracy_bad_input(capsys):
    assert_one_line_error(
        capsys, r"--accuracy draft: the preset sets the mesh; drop -N, --transcription",
        "walk", "--accuracy", "draft", "-N", "20", "--transcription", "radau",
    )  # fmt: skip
    assert_one_line_error(
        capsys, r"argument --accuracy: expected a preset \(draft, balanced or precise\) or a "
        r"refinement target such as 1e-5, got 'fast'", "walk", "--accuracy", "fast",
    )  # fmt: skip
    assert_one_line_error(
        capsys, r"argument --accuracy: must lie in \[1e-09, 1\)", "walk", "--accuracy", "0",
    )  # fmt: skip
    assert_one_line_error(
        capsys, r"--accuracy: a refinement target needs a single support",
        "walk", "--accuracy", "1e-4", "--double-support-s", "0.1",
    )  # fmt: skip


# ---- files that keep their promises, sizes bounded up front, one spelling per option -------
def test_the_walk_file_reads_with_plain_readers_and_is_its_own_inverse_dynamics(walk_run):
    import csv

    _, _, _, folder = walk_run
    path = folder / "torques.csv"
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0][0] == "t [s]" and len(rows) == 1 + 501
    assert all(len(row) == len(rows[0]) for row in rows)
    named = np.genfromtxt(path, delimiter=",", names=True)
    assert named.shape == (501,) and "F_stance_shank_start_y_N" in named.dtype.names
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(path)
    assert frame.shape == (501, len(rows[0])) and "CoP_stance_shank_start_x [m]" in frame
    # the file's torques against the oracle's inverse dynamics of the file's motion (--quick:
    # its 12 intervals made the transcription's own torques 23 % off their motion)
    profile = LinkageTrajectory.load(path)
    oracle = ne_inverse_dynamics(profile)
    assert np.abs(profile.torques - oracle).max() < 1e-9 * np.abs(oracle).max()
    assert verify_gait(profile, presets.six_link_anthropoid()).ok


def ne_inverse_dynamics(profile):
    from reference import newton_euler

    return newton_euler.inverse_dynamics(
        presets.six_link_anthropoid(), profile.psi, profile.dpsi, profile.ddpsi
    )


def test_walk_refuses_sizes_it_cannot_make_before_it_starts(capsys, tmp_path):
    folder = tmp_path / "big"
    assert_one_line_error(capsys, r"--steps: at most 50 steps, got 1,000,000; the pictures",
                          "walk", "--steps", "1000000", "--output-dir", folder)  # fmt: skip
    assert_one_line_error(capsys, r"-N/--intervals: at most 2,000 intervals, got 100,000; refine",
                          "walk", "-N", "100000", "--output-dir", folder)  # fmt: skip
    assert_one_line_error(
        capsys,
        r"--rate-hz 100000 Hz x --step-time-s 10 s asks for 1,000,001 samples .*, more than "
        r"200,000; lower --rate-hz, or add --force",
        "walk", "--rate-hz", "1e5", "--step-time-s", "10", "--output-dir", folder,
    )  # fmt: skip
    assert not folder.exists()


def test_one_spelling_per_option_and_no_prefixes(capsys):
    # walk spells --step-length-m; its prefix --step-length is no option of walk
    assert_one_line_error(capsys, r"unrecognized arguments: --step-length 0.5", "walk",
                          "--step-length", "0.5")  # fmt: skip
    # the study spells it the same way
    assert_one_line_error(capsys, r"unrecognized arguments: --step-length 0.5", "study",
                          "--step-length", "0.5")  # fmt: skip
    code, out, _ = run(capsys, "study", "--help")
    assert "--step-length-m" in out and "--step-time-s" in out
    # simulate's finite elements per interval are --substeps (walk's --steps are steps drawn)
    code, out, _ = run(capsys, "simulate", "--help")
    assert code == 0
    assert "--substeps" in out and "--steps" not in out.replace("--substeps", "")


def test_walk_replaces_its_own_folder_as_a_set_and_refuses_others(capsys, tmp_path):
    folder = tmp_path / "walk"
    code, _, err = run(capsys, "walk", "--quick", "-q", "--no-gif", "--output-dir", folder)
    assert code == 0, err
    assert {"gait.png", "walk.png", "manifest.json"} <= {p.name for p in folder.iterdir()}
    # the same folder again without pictures: the earlier pictures do not stay beside
    code, _, err = run(capsys, "walk", "--quick", "-q", "--no-plots", "--output-dir", folder)
    assert code == 0, err
    names = sorted(p.name for p in folder.iterdir())
    assert names == ["joints.csv", "joints.csv.meta.json", "manifest.json", "solution.npz",
                     "torques.csv", "torques.csv.meta.json", "torques.json"]  # fmt: skip
    assert [p.name for p in tmp_path.iterdir()] == ["walk"]  # no staging folder left
    # a folder of other files is refused before the solve, and left as it was
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    message = r"--output-dir: .* is not empty \(notes.txt\) and is not an earlier 'walk' run"
    assert_one_line_error(capsys, message, "walk", "--quick", "--output-dir", foreign)
    assert [p.name for p in foreign.iterdir()] == ["notes.txt"]
    # a directory where a file of the set goes, in an earlier run's folder: refused too
    (folder / "torques.csv").unlink()
    (folder / "torques.csv").mkdir()
    assert_one_line_error(capsys, r"files it did not write|is not empty", "walk", "--quick",
                          "--output-dir", folder)  # fmt: skip


def test_a_failed_write_leaves_nothing_of_the_new_run(capsys, tmp_path, monkeypatch):
    from planner.trajectory import formats

    folder = tmp_path / "walk"
    code, _, err = run(capsys, "walk", "--quick", "-q", "--no-plots", "--output-dir", folder)
    assert code == 0, err
    before = {p.name: p.read_bytes() for p in folder.iterdir()}

    def full_disk(trajectory, handle):
        raise OSError(28, "No space left on device")

    monkeypatch.setitem(formats._WRITERS, ".json", (full_disk, False))
    code, _, err = run(capsys, "walk", "--quick", "-q", "--no-plots", "--output-dir", folder)
    # the file and the folder as given: not the hidden staging folder
    assert code == 1 and err.strip().splitlines()[-1] == (
        f"{PROG} walk: error: --output-dir: writing torques.json in {str(folder)!r} failed "
        "(No space left on device)")  # fmt: skip
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before  # the earlier run
    assert [p.name for p in tmp_path.iterdir()] == ["walk"]
    code, _, err = run(capsys, "walk", "--quick", "-q", "--no-plots", "--output-dir",
                       tmp_path / "new")  # fmt: skip
    assert code == 1 and not (tmp_path / "new").exists()


def test_walk_and_study_options_default_to_the_walking_steps_own_defaults():
    # one source: the command line reads walking_step's signature, it types no number again
    import inspect

    from planner.schemes import DEFAULT_TRANSCRIPTION
    from problems.cli import build_parser
    from problems.walking.step import DEFAULT_N, WALKING_DEFAULTS, walking_step

    signature = inspect.signature(walking_step).parameters
    assert WALKING_DEFAULTS["N"] == DEFAULT_N and signature["N"].default is None
    parser = build_parser()
    walk = parser.parse_args(["walk"])
    study = parser.parse_args(["study"])
    for option, argument in (
        ("step_length_m", "step_length"),
        ("step_time_s", "step_time"),
        ("mu", "mu"),
        ("torque_limit_nm", "torque_limit"),
        ("double_support_s", "double_support"),
        ("ground_margin_m", "ground_margin"),
        ("objective", "objective"),
        ("formulation", "formulation"),
    ):
        assert getattr(walk, option) == signature[argument].default, option
        if option in ("mu", "torque_limit_nm", "double_support_s"):
            assert getattr(study, option) == (signature[argument].default,), option
    # defaults scaled with the walker: the command line leaves them to walking_step
    for option, argument in (("clearance_m", "clearance"), ("touchdown_speed_mps",
                                                            "touchdown_speed")):  # fmt: skip
        assert getattr(walk, option) is None and signature[argument].default == "default"
    assert study.clearance_m is None
    assert study.transcription == DEFAULT_TRANSCRIPTION
    help_text = parser._subparsers._group_actions[0].choices["walk"].format_help()
    assert (
        f"default: {DEFAULT_N}," in help_text and f"(default: {DEFAULT_TRANSCRIPTION})" in help_text
    )


# ---- output folders stay the user's, every command that writes ---------------------------------
def _writer_argv(command, folder, profile_files):
    """A short run of each command that writes a folder, into ``folder``."""
    return {
        "torques": ["torques", "--duration-s", "0.05", "--rate-hz", "100", "--no-plots"],
        "simulate": ["simulate", profile_files / "torques.csv", "--t-end-s", "0.05", "--no-plots"],
        "walk": ["walk", "--quick", "--no-plots"],
    }[command] + ["--output-dir", folder]


WRITERS = ("torques", "simulate", "walk")


@pytest.mark.parametrize("command", WRITERS)
def test_an_existing_output_folder_keeps_its_inode_and_mode_and_a_link_is_followed(
    capsys, tmp_path, monkeypatch, profile_files, command
):
    folder = tmp_path / "mine"
    folder.mkdir()
    folder.chmod(0o700)
    before = folder.stat()
    for _ in range(2):  # into the empty folder, then over the first run
        code, _, err = run(capsys, *_writer_argv(command, folder, profile_files))
        assert code == 0, err
    after = folder.stat()
    assert (after.st_ino, after.st_mode & 0o7777) == (before.st_ino, 0o700)
    assert (folder / "manifest.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]  # no staging, nothing beside
    # a link to a folder: followed, and still a link
    target = tmp_path / "target"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target)
    code, out, err = run(capsys, *_writer_argv(command, link, profile_files))
    assert code == 0, err
    assert link.is_symlink() and (target / "manifest.json").is_file()
    assert f"wrote {link}" in out  # named as given
    # the working folder itself, empty
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    code, _, err = run(capsys, *_writer_argv(command, ".", profile_files))
    assert code == 0, err
    assert (here / "manifest.json").is_file() and not [p for p in here.iterdir()
                                                        if p.name.startswith(".")]  # fmt: skip


@needs_permissions
@pytest.mark.parametrize("command", WRITERS)
@pytest.mark.parametrize("where", ["the folder", "its parent"])
def test_a_folder_that_cannot_be_written_is_refused_before_the_command_computes(
    tmp_path, profile_files, command, where
):
    locked = tmp_path / "ro"
    locked.mkdir()
    folder = locked if where == "the folder" else locked / "new"
    locked.chmod(0o555)
    argv = [sys.executable, "-m", "problems", *map(str, _writer_argv(command, folder,
                                                                      profile_files))]  # fmt: skip
    try:
        done = run_unprivileged(argv, capture_output=True, text=True, timeout=300)
    finally:
        locked.chmod(0o755)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    # one line, before any progress line of the computation (the run was not started)
    assert len(lines) == 1, lines
    doing = "write into" if where == "the folder" else "create"
    assert f"--output-dir: cannot {doing} {str(folder)!r} (Permission denied)" in lines[0]
    assert ".partial" not in lines[0] and list(locked.iterdir()) == []


@pytest.mark.parametrize("command", WRITERS)
def test_stagings_that_killed_runs_left_are_removed_by_the_next_run(
    capsys, tmp_path, profile_files, command
):
    left = tmp_path / ".out.partial-abcd1234"  # what a run killed with SIGKILL left
    left.mkdir()
    (left / "torques.csv").write_bytes(bytes(1 << 20))
    earlier = tmp_path / ".out.old-abcd1234"  # what an earlier version's commit left
    earlier.mkdir()
    code, _, err = run(capsys, *_writer_argv(command, tmp_path / "out", profile_files))
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_run_stopped_by_sigterm_leaves_nothing(tmp_path):
    """SIGTERM while the files are staged (a 241-frame GIF takes seconds): exit 143, one line,
    no staging folder, no output folder. A 2 s run's GIF (61 frames) was written within the
    0.3 s this test used to wait on a fast CI machine, and the run ended with 0."""
    import signal
    import time

    folder = tmp_path / "out"
    argv = [sys.executable, "-m", "problems", "torques", "--duration-s", "8", "--gif",
            "--output-dir", str(folder)]  # fmt: skip
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not any(p.name.startswith(".out.partial-") for p in tmp_path.iterdir()):
        assert process.poll() is None and time.monotonic() < deadline, "it never staged"
        time.sleep(0.02)
    time.sleep(0.05)  # into the writing
    assert process.poll() is None, "the run ended before it could be stopped"
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err
    assert err.strip().splitlines()[-1].endswith("terminated (SIGTERM); nothing of this run "
                                                 "was written")  # fmt: skip
    assert list(tmp_path.iterdir()) == []


def test_a_huge_value_is_echoed_abridged_not_whole(capsys):
    """--steps with 5,000 digits was echoed whole (5,000 characters on one error line)."""
    cases = (
        (5000, r"expected an integer, got '9{40}\.\.\.' \(5,000 characters\)"),
        (4000, r"at most 50 steps, got [0-9,]{40}\.\.\. \(5,333 characters\)"),
    )
    for digits, said in cases:
        line = assert_one_line_error(capsys, said, "walk", "--steps", "9" * digits)
        assert len(line) < 300, len(line)


def test_the_commands_default_output_folders_are_ignored_by_git():
    """Run from a clone's root, the commands' default folders do not show up as files to
    commit."""
    from pathlib import Path

    from problems.cli import build_parser
    from problems.cli.common import new_folder
    from problems.cli.study import DEFAULT_FOLDER

    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        pytest.skip("not a git clone")
    parser = build_parser()
    defaults = {
        command: parser.parse_args([command, *extra]).output_dir
        for command, extra in (("torques", []), ("simulate", ["t.csv"]),
                               ("compare-gait", ["p.csv", "--data", "d.csv"]),
                               ("track-gait", ["--data", "d.csv"]))
    }  # fmt: skip
    folders = [*defaults.values(), DEFAULT_FOLDER, str(new_folder("walk"))]
    for folder in folders:
        result = subprocess.run(["git", "check-ignore", "-q", f"{folder}/torques.csv"],
                                cwd=root, capture_output=True)  # fmt: skip
        assert result.returncode == 0, f"{folder} is not ignored by git"
