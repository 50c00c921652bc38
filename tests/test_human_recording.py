"""problems.human.workbook, .recording and .winter: reading recorded gait.

Oracles: a workbook written here with the standard library (shared and inline strings,
numbers, a formula's cached value) read back; the CSV layout written and read back and read
by numpy.genfromtxt; Winter's table values (cited numbers of Appendix A: the ankle's peak
plantarflexor moment -89.8 N m at frame 61, the heel contacts at frames 28 and 97) and his
angle definitions recomputed from his own markers.
"""

import math
import zipfile

import numpy as np
import pytest

from problems.human import GaitRecording, read_csv, read_recording, read_winter, write_csv
from problems.human.winter import marker_angles
from problems.human.workbook import column_number, read_workbook

_MAIN = "http://schemas.openxmlformats.org/spreadsheetml/2006/main"
_REL = "http://schemas.openxmlformats.org/officeDocument/2006/relationships"


def _write_workbook(path):
    sheet = (
        f'<worksheet xmlns="{_MAIN}"><sheetData>'
        '<row r="1"><c r="A1" t="s"><v>0</v></c><c r="AB1" t="inlineStr"><is><t> inline </t>'
        "</is></c></row>"
        '<row r="2"><c r="A2"><v>1.5E-2</v></c><c r="B2" t="s"><v>1</v></c>'
        '<c r="C2"><f>A2*2</f><v>0.03</v></c><c r="D2"/></row>'
        "</sheetData></worksheet>"
    )
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr(
            "xl/workbook.xml",
            f'<workbook xmlns="{_MAIN}" xmlns:r="{_REL}"><sheets>'
            '<sheet name="First" sheetId="1" r:id="rId7"/></sheets></workbook>',
        )
        archive.writestr(
            "xl/_rels/workbook.xml.rels",
            '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/'
            'relationships"><Relationship Id="rId7" Target="worksheets/s.xml" '
            'Type="x"/></Relationships>',
        )
        archive.writestr(
            "xl/sharedStrings.xml",
            f'<sst xmlns="{_MAIN}"><si><t>TITLE</t></si><si><r><t>\u2212</t></r>'
            "<r><t>4.5</t></r></si></sst>",
        )
        archive.writestr("xl/worksheets/s.xml", sheet)


def test_workbook_cells_read_back(tmp_path):
    path = tmp_path / "book.xlsx"
    _write_workbook(path)
    cells = read_workbook(path)["First"]
    assert cells == {(1, 1): "TITLE", (1, 28): "inline", (2, 1): 0.015, (2, 2): -4.5, (2, 3): 0.03}
    assert [column_number(c) for c in ("A", "Z", "AA", "AZ", "BA")] == [1, 26, 27, 52, 53]


def test_a_file_that_is_no_workbook_is_refused_by_name(tmp_path):
    path = tmp_path / "not.xlsx"
    path.write_text("a,b\n")
    with pytest.raises(ValueError, match=r"not\.xlsx.*not a readable \.xlsx"):
        read_workbook(path)


def _recording():
    percent = np.linspace(0.0, 100.0, 11)
    return GaitRecording(
        percent,
        {
            "knee": 30 * np.sin(percent / 15.0),
            "force_y": np.where(percent < 60, 1.0, 0.0),
            "ankle": np.full(11, np.nan),
        },
        stance_fraction=0.6,
        stride_time=1.0,
        stride_length=1.4,
        body_mass=70.0,
        source="hand, made",
    )


def test_csv_round_trip_and_numpy_reads_it(tmp_path):
    recording = _recording()
    path = write_csv(recording, tmp_path / "stride.csv")
    back = read_csv(path)
    np.testing.assert_allclose(back.percent, recording.percent)
    for name in ("knee", "force_y"):
        np.testing.assert_allclose(back.channels[name], recording.channels[name], rtol=1e-5)
    assert np.all(np.isnan(back.channels["ankle"])) and not back.has("ankle")
    assert (back.stance_fraction, back.stride_time, back.body_mass) == (0.6, 1.0, 70.0)
    assert back.source == "hand, made" and back.speed == pytest.approx(1.4)
    table = np.genfromtxt(path, delimiter=",", names=True)
    np.testing.assert_allclose(table["knee_flexion_deg"], recording.channels["knee"], rtol=1e-5)
    assert list(tmp_path.iterdir()) == [path]  # nothing staged left


@pytest.mark.parametrize(
    "text, message",
    [
        ("cycle_percent,knee_flexion_deg\n0,1\n50,2\n60,1\n100,1\n", "stance_fraction"),
        ("# stance_fraction: 0.6\ntime,knee_flexion_deg\n0,1\n", "first column"),
        (
            "# stance_fraction: 0.6\ncycle_percent,knee_deg\n0,1\n",
            r"unknown columns \['knee_deg'\]",
        ),
        ("# stance_fraction: 0.6\ncycle_percent,knee_flexion_deg\n0,1\n50,x\n", "line 4.*'x'"),
        ("# stance_fraction: 0.6\ncycle_percent,knee_flexion_deg\n0,1\n50\n", "line 4: 1 cells"),
        (
            "# stance_fraction: 0.6\ncycle_percent,knee_flexion_deg\n0,1\n50,1\n40,1\n90,1\n",
            "increase",
        ),
        (
            "# stance_fraction: 1.6\ncycle_percent,knee_flexion_deg\n0,1\n50,1\n70,1\n90,1\n",
            "stance_fraction",
        ),
    ],
)
def test_a_bad_csv_is_refused_naming_the_line_and_the_fix(tmp_path, text, message):
    path = tmp_path / "lab.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_recording(path)


def test_at_interpolates_across_the_end_of_the_cycle():
    recording = GaitRecording(
        np.array([10.0, 40.0, 70.0, 90.0]), {"knee": np.array([0.0, 30.0, 60.0, 20.0])}, 0.6
    )
    # between 90 % and 110 % (= 10 % of the next cycle): 20 -> 0
    assert recording.at("knee", 100.0) == pytest.approx(10.0)
    assert recording.at("knee", 0.0) == pytest.approx(10.0)
    assert recording.at("knee", 55.0) == pytest.approx(45.0)


# ---- Winter's appendix ----------------------------------------------------------------------
def test_winter_stride_events_and_table_values(winter_xlsx):
    stride = read_winter(winter_xlsx)
    # heel contacts at frames 28 and 97 at 69.9 Hz: 69 frames = 0.987 s; toe-off at frame 70
    assert stride.stride_time == pytest.approx(0.987, abs=1e-3)
    assert stride.stance_fraction == pytest.approx(42 / 69, abs=2e-3)
    assert stride.stride_length == pytest.approx(1.415, abs=0.005)
    assert stride.percent.size == 70
    k = 61 - 28  # frame 61: the ankle moment on the foot -89.8 N m, clockwise
    assert stride.channels["ankle_moment"][k] == pytest.approx(89.8 / 56.7)
    # frame 28 (heel contact): hip moment on the thigh -54.4 N m (extensor), Ry 87.1 N
    assert stride.channels["hip_moment"][0] == pytest.approx(54.4 / 56.7)
    assert stride.channels["force_y"][0] == pytest.approx(87.1 / (56.7 * 9.81))
    # frame 37: knee moment on the leg +37.8 N m (extensor), A.4 knee 9.8 deg at frame 33
    assert stride.channels["knee_moment"][37 - 28] == pytest.approx(37.8 / 56.7)
    assert stride.channels["knee"][33 - 28] == pytest.approx(9.8)
    # the swing: no ground force between toe-off and the next contact
    swing = stride.percent > 100 * stride.stance_fraction + 1e-9
    assert np.all(stride.channels["force_y"][swing][:-1] == 0.0)
    heavier = read_winter(winter_xlsx, body_mass=70.0)
    assert heavier.channels["ankle_moment"][k] == pytest.approx(89.8 / 70.0)


def test_winter_angles_follow_his_definitions_on_his_markers(winter_xlsx):
    angles = marker_angles(winter_xlsx)

    def rms(a, b):
        d = angles[a] - angles[b]
        return math.sqrt(np.nanmean(d**2))

    # the filtered markers give the tables' thigh and hip to their rounding (0.1 deg)
    assert rms("thigh", "thigh_table") < 0.06 and rms("hip", "hip_table") < 0.06
    # the raw (unfiltered, 1 mm) markers give the knee and the ankle to their noise
    assert rms("knee_raw", "knee") < 1.0
    assert rms("ankle_raw", "ankle") < 2.0
    # ... and the opposite sign conventions would be tens of degrees off
    assert math.sqrt(np.nanmean((angles["ankle_raw"] + angles["ankle"]) ** 2)) > 5.0


def test_a_csv_recording_takes_no_workbook_options(tmp_path):
    path = write_csv(_recording(), tmp_path / "lab.csv")
    with pytest.raises(
        ValueError, match=r"`options`: a CSV recording takes none, got \['body_mass'\]"
    ):
        read_recording(path, body_mass=60.0)
