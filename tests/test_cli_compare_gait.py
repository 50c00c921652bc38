"""'compare-gait': the comparison of a planned step with recorded walking as a command.

The oracle of the numbers: the table the issue (#34) measured with other code on today's
default step on feet at Winter's step (0.7075 m in 0.4935 s): thigh 6.3 deg RMS, r 0.92; hip
10.9, 0.81; knee 13.4, 0.78; ankle 13.1, 0.65; vertical force 0.34 BW RMS, r 0.27 over the
stance, its humps 1.12 / 0.56 / 2.09 BW; the loading-response knee 5 deg against 16; moment
peaks 1.26 / 0.84 / 0.75 N m/kg against 0.96 / 0.66 / 1.58. Held within the noise of
sampling (the peaks of the moments jump at the heel strike: 10 %).
"""

import json
import re

import numpy as np
import pytest

from problems import footed_step
from problems.__main__ import main
from problems.human import read_csv


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    return code, captured.out, captured.err


@pytest.fixture(scope="module")
def winter_step_file(tmp_path_factory):
    """Today's default step on feet at Winter's step, its 1 kHz file with the sidecar."""
    gait = footed_step(step_length=0.7075, step_time=0.4935).solve()
    path = tmp_path_factory.mktemp("plan") / "torques.csv"
    gait.to_trajectory(1000.0).save(path)
    return path


def test_compare_gait_reproduces_the_issues_table(capsys, tmp_path, winter_step_file, winter_xlsx):
    out_dir = tmp_path / "cmp"
    code, out, err = run(
        capsys,
        "compare-gait",
        winter_step_file,
        "--data",
        winter_xlsx,
        "--output-dir",
        out_dir,
        "-q",
    )
    assert code == 0, err
    written = sorted(p.name for p in out_dir.iterdir())
    assert written == [
        "comparison.json",
        "comparison.md",
        "comparison.png",
        "manifest.json",
        "stride.csv",
    ]
    result = json.loads((out_dir / "comparison.json").read_text())
    channels, features = result["channels"], result["features"]
    expected = {
        "thigh": (6.3, 0.92),
        "hip": (10.9, 0.81),
        "knee": (13.4, 0.78),
        "ankle": (13.1, 0.65),
    }
    for name, (rms, r) in expected.items():
        assert channels[name]["rms"] == pytest.approx(rms, abs=0.5), name
        assert channels[name]["r"] == pytest.approx(r, abs=0.03), name
    assert channels["force_y"]["rms"] == pytest.approx(0.34, abs=0.03)
    assert channels["force_y"]["r"] == pytest.approx(0.27, abs=0.05)
    humps = [features[k]["model"] for k in ("force_peak_1", "force_valley", "force_peak_2")]
    assert humps == pytest.approx([1.12, 0.56, 2.09], abs=0.05)
    data_humps = [features[k]["data"] for k in ("force_peak_1", "force_valley", "force_peak_2")]
    assert data_humps == pytest.approx([1.09, 0.65, 1.10], abs=0.01)
    assert features["knee_loading"]["model"] == pytest.approx(5.0, abs=1.0)
    assert features["knee_loading"]["data"] == pytest.approx(16.0, abs=0.5)
    for joint, model, human in (("hip", 1.26, 0.96), ("knee", 0.84, 0.66), ("ankle", 0.75, 1.58)):
        feature = features[f"{joint}_moment_peak"]
        assert feature["model"] == pytest.approx(model, rel=0.1), joint
        assert feature["data"] == pytest.approx(human, abs=0.01), joint
    # the printed table is the file's, and the stride reads back in the recording layout
    assert "| knee flexion, deg |" in out
    assert (out_dir / "comparison.md").read_text().count("|") > 60
    stride = read_csv(out_dir / "stride.csv")
    assert stride.stance_fraction == pytest.approx(features["stance"]["model"] / 100)
    assert np.isfinite(stride.channels["knee"]).all()


def test_compare_gait_takes_a_lab_csv(capsys, tmp_path, winter_step_file):
    lab = tmp_path / "lab.csv"
    percent = np.linspace(0, 100, 51)
    rows = "\n".join(f"{p:g},{20 * np.sin(np.pi * p / 100):.4f}" for p in percent)
    lab.write_text(f"cycle_percent,knee_flexion_deg\n# stance_fraction: 0.6\n{rows}\n")
    code, out, err = run(
        capsys,
        "compare-gait",
        winter_step_file,
        "--data",
        lab,
        "--output-dir",
        tmp_path / "c",
        "--no-plots",
        "-q",
    )
    assert code == 0, err
    assert "knee flexion, deg" in out and "hip flexion" not in out


@pytest.mark.parametrize(
    "argv, message",
    [
        (["missing.csv", "--data", "lab.csv"], r"PLAN: no file 'missing.csv'"),
        (["plan.csv", "--data", "lab.csv"], r"PLAN: .*sidecar|PLAN: .*walking step"),
        (["{plan}", "--data", "bad.csv"], r"--data: .*first column"),
        (
            ["{plan}", "--data", "bad.csv", "--data-body-mass-kg", "60"],
            r"--data-body-mass-kg: only for a workbook",
        ),
    ],
)
def test_compare_gait_refuses_bad_input_in_one_line(
    capsys, tmp_path, monkeypatch, winter_step_file, argv, message
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "plan.csv").write_text(winter_step_file.read_text())  # without its sidecar
    (tmp_path / "lab.csv").write_text(
        "cycle_percent,knee_flexion_deg\n# stance_fraction: 0.6\n0,1\n30,2\n60,3\n90,2\n"
    )
    (tmp_path / "bad.csv").write_text("time,knee_flexion_deg\n# stance_fraction: 0.6\n0,1\n")
    argv = [a.format(plan=winter_step_file) for a in argv]
    code, _, err = run(capsys, "compare-gait", *argv)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), lines
    assert not (tmp_path / "compare").exists()  # nothing written
