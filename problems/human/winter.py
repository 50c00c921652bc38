"""Winter's recorded stride (Biomechanics and Motor Control of Human Movement, 4th ed.,
Wiley 2009, Appendix A) from its workbook, as a :class:`GaitRecording`.

The workbook (tables A.1-A.7 as sheets; the copy in ``../shared/human_gait/`` and its
provenance) holds one right stride of one subject (56.7 kg, filmed at 69.9 Hz) with the
events in its STATE column: right heel contact (HCR) at frames 28 and 97, right toe-off (TOR)
at frame 70. Read from it, in the conventions of :mod:`problems.human.recording`:

* angles, table A.4 (ankle, knee, hip ``THETA``, deg) and A.3 (the thigh's absolute angle,
  the vector knee -> hip from +x, less 90 deg);
* the right foot's ground force, table A.5 (``RX``, ``RY`` on the foot, N, / m g) and the
  moments of force (N m on the distal segment, counter-clockwise positive, walking to +x:
  the plantarflexor's on the foot is clockwise, the knee extensor's on the leg
  counter-clockwise, the hip extensor's on the thigh clockwise; / m);
* the stride from the heel marker (A.2) at the two heel contacts.

Winter's definitions, checked on the markers by :func:`marker_angles` (the tests hold
them): hip = thigh - HAT line (trochanter to rib cage: it tilts with the pelvis and thigh,
which no model trunk does), knee = thigh - leg axis (malleolus to fibula head), ankle
= 90 deg - (leg axis - heel-to-metatarsal line).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from planner.errors import DefinitionError
from problems.human.recording import GaitRecording
from problems.human.workbook import Cells, read_workbook

#: The subject's mass, kg (Winter 2009, Appendix A).
WINTER_BODY_MASS = 56.7
GRAVITY = 9.81
_SHEETS = {
    "markers_raw": "A1",
    "markers": "A2",
    "segments": "A3",
    "joints": "A4",
    "kinetics": "A5",
}


def _sheet(book: dict[str, Cells], table: str, path: Path) -> Cells:
    for name, cells in book.items():
        if name.startswith(f"{table}."):
            return cells
    raise DefinitionError(
        f"`path`: {str(path)!r} has no sheet of Winter's table {table} (sheets: {list(book)})"
    )


def _frames(cells: Cells) -> dict[int, int]:
    """{frame number: its row}."""
    return {int(v): r for (r, c), v in cells.items() if c == 2 and isinstance(v, float)}


def _events(cells: Cells, path: Path) -> tuple[int, int, int]:
    """(heel contact, toe-off, next heel contact) frames of the right foot from the STATE
    column."""
    labels = sorted((r, v) for (r, c), v in cells.items() if c == 1 and v in ("HCR", "TOR"))
    frame = {r: int(v) for (r, c), v in cells.items() if c == 2 and isinstance(v, float)}
    contacts = [frame[r] for r, v in labels if v == "HCR"]
    if len(contacts) < 2:
        raise DefinitionError(
            f"`path`: {str(path)!r}: table A.4 marks fewer than two right "
            "heel contacts (HCR) in its STATE column"
        )
    first, second = contacts[0], contacts[1]
    offs = [frame[r] for r, v in labels if v == "TOR" and first < frame[r] < second]
    if not offs:
        raise DefinitionError(
            f"`path`: {str(path)!r}: no right toe-off (TOR) between the heel "
            f"contacts at frames {first} and {second}"
        )
    return first, offs[0], second


def _column(cells: Cells, headers: tuple[str, ...], path: Path, table: str) -> int:
    """The column whose header rows read ``headers`` top-down: the last label in the column
    itself, the others the nearest label at or to the left of it in their rows (the workbook
    writes a block's label once over its columns)."""
    first_data = min(r for (r, c), v in cells.items() if c == 2 and isinstance(v, float))
    labels = {
        (r, c): v.upper()
        for (r, c), v in cells.items()
        if r < first_data and c > 2 and isinstance(v, str)
    }
    rows = sorted({r for r, _ in labels})
    for column in sorted({c for _, c in labels}):
        found = []
        for row in rows:
            left = [c for (r, c) in labels if r == row and c <= column]
            if left:
                found.append((labels[(row, max(left))], max(left) == column))
        # headers in order among the labels, the last one written in this very column
        k = 0
        for label, own in found:
            if k < len(headers) and label == headers[k] and (k < len(headers) - 1 or own):
                k += 1
        if k == len(headers):
            return column
    raise DefinitionError(
        f"`path`: {str(path)!r}: no column {' / '.join(headers)} in table {table}"
    )


def _series(cells: Cells, column: int, frames: range) -> np.ndarray:
    rows = _frames(cells)
    return np.array([cells.get((rows[f], column), np.nan) for f in frames], dtype=float)


def read_winter(path: str | Path, body_mass: float = WINTER_BODY_MASS) -> GaitRecording:
    """The right stride of Winter's Appendix A from the workbook at ``path``, heel contact to
    heel contact (see the module); ``body_mass``: the subject's, kg."""
    path = Path(path)
    book = read_workbook(path)
    joints = _sheet(book, "A4", path)
    segments, kinetics = _sheet(book, "A3", path), _sheet(book, "A5", path)
    markers = _sheet(book, "A2", path)
    strike, toe_off, next_strike = _events(joints, path)
    frames = range(strike, next_strike + 1)
    time = _series(joints, 3, frames)
    stride_time = float(time[-1] - time[0])
    percent = 100.0 * (time - time[0]) / stride_time
    weight = body_mass * GRAVITY

    def read(sheet: Cells, table: str, *headers: str) -> np.ndarray:
        return _series(sheet, _column(sheet, headers, path, table), frames)

    channels = {
        "ankle": read(joints, "A.4", "ANKLE", "THETA"),
        "knee": read(joints, "A.4", "KNEE", "THETA"),
        "hip": read(joints, "A.4", "HIP", "THETA"),
        "thigh": read(segments, "A.3", "THIGH", "THETA") - 90.0,
        "force_x": read(kinetics, "A.5", "FOOT SEGMENT", "GROUND", "RX") / weight,
        "force_y": read(kinetics, "A.5", "FOOT SEGMENT", "GROUND", "RY") / weight,
        # the moments on the distal segment, counter-clockwise: to extensor positive
        "ankle_moment": -read(kinetics, "A.5", "FOOT SEGMENT", "ANKLE", "MOMENT") / body_mass,
        "knee_moment": read(kinetics, "A.5", "LEG SEGMENT", "KNEE", "MOMENT") / body_mass,
        "hip_moment": -read(kinetics, "A.5", "THIGH SEGMENT", "HIP", "MOMENT") / body_mass,
    }
    heel_x = read(markers, "A.2", "RIGHT HEEL", "X")
    stance = (_series(joints, 3, range(toe_off, toe_off + 1))[0] - time[0]) / stride_time
    return GaitRecording(
        percent,
        channels,
        stance_fraction=float(stance),
        stride_time=stride_time,
        stride_length=float(heel_x[-1] - heel_x[0]),
        body_mass=float(body_mass),
        source=f"Winter 2009, Appendix A (right stride, frames {strike}-{next_strike}; "
        f"{path.name})",
    )


def marker_angles(path: str | Path) -> dict[str, np.ndarray]:
    """Winter's joint angles recomputed from his markers, deg, over every frame (the check
    of the conventions): ``frame``; from the raw markers (table A.1, cm) ``knee_raw`` (thigh
    knee -> trochanter less leg malleolus -> fibula head) and ``ankle_raw`` (90 less the leg
    axis less the heel -> 5th metatarsal line); from the filtered markers (A.2) ``thigh``
    (knee -> trochanter from +x, less 90) and ``hip`` (that thigh less the HAT line
    trochanter -> rib cage); and table A.4's ``ankle``, ``knee``, ``hip`` and A.3's thigh
    (``thigh_table``) on the same frames."""
    path = Path(path)
    book = read_workbook(path)
    raw, markers = _sheet(book, "A1", path), _sheet(book, "A2", path)
    joints, segments = _sheet(book, "A4", path), _sheet(book, "A3", path)
    raw_rows = {int(v): r for (r, c), v in raw.items() if c == 1 and isinstance(v, float)}
    frames = range(1, min(max(raw_rows), max(_frames(joints))) + 1)

    def raw_point(name: str) -> np.ndarray:
        column = _column(raw, (name, "X"), path, "A.1")
        x = np.array([raw.get((raw_rows[f], column), np.nan) for f in frames])
        y = np.array([raw.get((raw_rows[f], column + 1), np.nan) for f in frames])
        return (x + 1j * y) / 100.0

    def point(name: str) -> np.ndarray:
        column = _column(markers, (name, "X"), path, "A.2")
        return _series(markers, column, frames) + 1j * _series(markers, column + 3, frames)

    def angle(vector: np.ndarray) -> np.ndarray:
        return np.degrees(np.angle(vector))

    heel, metatarsal = raw_point("RIGHT HEEL"), raw_point("RIGHT METAT.")
    ankle, fibula = raw_point("RIGHT ANKLE"), raw_point("RIGHT FIBULA")
    knee, hip = raw_point("RIGHT KNEE"), raw_point("RIGHT HIP")
    leg = angle(fibula - ankle)
    thigh = angle(
        point("GREATER TROCHANTER (HIP)") - point("RIGHT FEMORAL LATERAL EPICONDYLE (KNEE)")
    )
    hat = angle(point("BASE RIB CAGE") - point("GREATER TROCHANTER (HIP)"))
    return {
        "frame": np.array(frames, dtype=float),
        "knee_raw": angle(hip - knee) - leg,
        "ankle_raw": 90.0 - (leg - angle(metatarsal - heel)),
        "thigh": thigh - 90.0,
        "hip": thigh - hat,
        "ankle": _series(joints, _column(joints, ("ANKLE", "THETA"), path, "A.4"), frames),
        "knee": _series(joints, _column(joints, ("KNEE", "THETA"), path, "A.4"), frames),
        "hip_table": _series(joints, _column(joints, ("HIP", "THETA"), path, "A.4"), frames),
        "thigh_table": _series(segments, _column(segments, ("THIGH", "THETA"), path, "A.3"), frames)
        - 90.0,
    }


def stride_summary(recording: GaitRecording) -> str:
    """One line: stride, speed, stance."""
    return (
        f"{recording.stride_length:.3f} m in {recording.stride_time:.3f} s "
        f"({recording.speed:.2f} m/s), stance {100 * recording.stance_fraction:.1f} %"
        if math.isfinite(recording.speed)
        else f"stance {100 * recording.stance_fraction:.1f} %"
    )
