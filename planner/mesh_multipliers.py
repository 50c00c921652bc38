"""IPOPT's multipliers carried onto a mesh whose intervals were cut in halves.

A re-solve after :func:`planner.hold_at_samples` cuts intervals has new variables and rows, so
:func:`planner.solver.warm_start_multipliers` could not reuse the last solve's multipliers
and IPOPT restarted them cold (measured on the step on feet: 24 and 29 iterations after the
two cuts against 7 and 10 after the back-offs that kept the mesh). Here each entry of the
new NLP finds its source in the old one by its name: the same row or variable at the same
place of the unchanged intervals, the cut interval's own entry for its halves, the cut
interval's midpoint for the node between them.

The multipliers approximate the continuous ones times the quadrature weight of their point:
a defect's multiplier (the costate) is kept, a path row's, a dynamics row's or a bound's is
scaled by its point's new weight over the old (a half interval's midpoint weighs half the
whole interval's; the node that was a midpoint a quarter). The start is approximate by
design: IPOPT only needs it near the new optimum.
"""

from __future__ import annotations

import math
import re

import numpy as np

#: "node 3", "interval 2": the places of a name on its phase's mesh.
_PLACE = re.compile(r"\b(node|interval) (\d+)")
#: Rows whose multiplier is a costate, not a weighted density: kept as they are.
_COSTATE_ROWS = ("defect[", "continuity[")


def _intervals(old: tuple[float, ...], new: tuple[float, ...]):
    """For each new interval (old interval, half: None whole, 0 first, 1 second), or None when
    ``new`` is not ``old`` with some intervals cut in two halves (fractions of the horizon)."""
    source, i, j = [], 0, 0
    while i < len(old) and j < len(new):
        if math.isclose(new[j], old[i], rel_tol=1e-9):
            source.append((i, None))
            j += 1
        elif (
            j + 1 < len(new)
            and math.isclose(new[j], old[i] / 2, rel_tol=1e-9)
            and math.isclose(new[j + 1], old[i] / 2, rel_tol=1e-9)
        ):
            source.extend([(i, 0), (i, 1)])
            j += 2
        else:
            return None
        i += 1
    return source if i == len(old) and j == len(new) else None


def _source(name: str, intervals) -> tuple[str, float] | None:
    """The old name of ``name``'s entry and its multiplier's factor, on a phase whose new
    intervals come from the old as ``intervals`` says; None without one."""
    factor = 1.0
    costate = name.startswith(_COSTATE_ROWS) or any(f": {r}" in name for r in _COSTATE_ROWS)
    count = len(intervals)
    missing = False

    def place(match: re.Match) -> str:
        nonlocal factor, missing
        kind, k = match.group(1), int(match.group(2))
        if kind == "interval":
            if k >= count:
                missing = True
                return match.group(0)
            i, half = intervals[k]
            if half is not None and not costate:
                factor *= 0.5  # a midpoint or a point inside half the interval
            return f"interval {i}"
        if k == count:  # the last node
            return f"node {intervals[-1][0] + 1}"
        if k > count:
            missing = True
            return match.group(0)
        i, half = intervals[k]
        if half == 1:  # the node between the halves: the old interval's midpoint
            if not costate:
                factor *= 0.25  # Simpson: (h/2 + h/2) / 6 against 4 h / 6
            return f"interval {i} midpoint"
        return f"node {i}"

    old = _PLACE.sub(place, name)
    return None if missing else (old, factor)


def carried_entries(old, new) -> tuple[tuple[np.ndarray, np.ndarray], ...] | None:
    """For the variables (``w_names``), then the rows (``g_names``) of the
    :class:`planner.transcription.Transcription` ``new``: (the index of each one's source
    in ``old``'s, -1 for none; the factor of its multiplier), when ``new``'s phases are
    ``old``'s with some intervals cut in halves (the same phase names, every other interval
    unchanged); None otherwise."""
    names = old.problem.names
    if tuple(new.problem.names) != tuple(names):
        return None
    maps = {}
    for name, before, after in zip(names, old.phases, new.phases, strict=True):
        intervals = _intervals(tuple(before.mesh.widths), tuple(after.mesh.widths))
        if intervals is None:
            return None
        maps[name] = intervals
    if all(len(m) == len({i for i, _ in m}) for m in maps.values()):
        return None  # nothing was cut: not this function's case
    return tuple(
        _sources(old_names, new_names, maps)
        for old_names, new_names in ((old.w_names, new.w_names), (old.g_names, new.g_names))
    )


def _sources(old_names, new_names, maps) -> tuple[np.ndarray, np.ndarray]:
    """(index of each new name's source among ``old_names`` or -1, its factor), the phases'
    interval maps ``maps`` ({phase name: :func:`_intervals`})."""
    index = {name: k for k, name in enumerate(old_names)}
    rows = np.full(len(new_names), -1, dtype=int)
    factors = np.zeros(len(new_names))
    single = len(maps) == 1
    for k, name in enumerate(new_names):
        phase, _, rest = name.partition(": ")
        if phase in maps and rest:
            intervals, prefix = maps[phase], f"{phase}: "
        elif single:
            intervals, prefix, rest = next(iter(maps.values())), "", name
        else:  # a join, a periodicity, a parameter: no place on a mesh
            if name in index:
                rows[k], factors[k] = index[name], 1.0
            continue
        found = _source(rest, intervals)
        if found is None:
            continue
        old, factor = found
        at = index.get(prefix + old)
        if at is not None:
            rows[k], factors[k] = at, factor
    return rows, factors
