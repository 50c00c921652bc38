"""One set of parallel springs for a walker's drives over several speeds (issue #36, part 5).

Each speed's step designs its own springs in its NLP (:mod:`problems.drives.springs`: the
stiffness and rest angle static parameters of the plan, minimising the drives' electrical
energy): what springs retuned at every speed could save. A walker carries one set, so each
speed's design is then tried at every other speed, fixed there (each a plan with the drives in
the loop, warm-started from that speed's own design, verified), and the set with the least
energy summed over the speeds is the walker's (a design no plan walks at some speed costs
infinity). The steps with no spring (the same drives in the loop) are the reference.

The plans are local optima: another speed's springs, fixed, can walk a speed for less than its
own design did. That speed's design is then solved again from that plan (a better start), and
its own is the better of the two (tried in turn at the other speeds, a candidate for the one
set too): each speed's own is then no worse than the sets first tried there, what retuned
springs could save as far as these plans find it.

Each speed costs 2 + (S - 1) plans for S speeds (its step without springs, with its own, and
with each other speed's), and 1 + (S - 1) more when another's springs beat its own.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from model.linkage import Linkage
from planner.errors import AnthropoidError, DefinitionError
from problems.drives.catalogue import Drive
from problems.drives.codesign import plan_with_drives, step_energy
from problems.drives.springs import ParallelSpring, check_springs, designed, spring_values

#: a set of springs: {joint: (k N m/rad, q_0 rad)}
SpringValues = Mapping[str, tuple[float, float]]


@dataclass(frozen=True)
class SpringDesign:
    """The ``speeds`` (m/s); the energy per step of each speed (J, drawn or net with
    ``regeneration``) with no springs (``bare``), with its own springs (``own``, their values
    ``own_springs``) and with the walker's one set (``shared``, its values
    ``shared_springs``); every candidate set's energies (``tried``: (values, per speed)); the
    seconds."""

    springs: tuple[ParallelSpring, ...]
    speeds: tuple[float, ...]
    regeneration: bool
    bare: tuple[float, ...]
    own: tuple[float, ...]
    own_springs: tuple[dict[str, tuple[float, float]], ...]
    shared: tuple[float, ...]
    shared_springs: dict[str, tuple[float, float]]
    tried: tuple[tuple[dict[str, tuple[float, float]], tuple[float, ...]], ...]
    seconds: float

    def table(self) -> str:
        """Energy per step by speed for no springs, each speed's own and the one set, markdown."""
        head = "| springs | " + " | ".join(f"{v:g} m/s, J" for v in self.speeds)
        lines = [head + " | sum, J |", "|---" * (2 + len(self.speeds)) + "|"]
        rows = (
            ("none (the drives in the loop)", self.bare),
            ("each speed's own (designed in its NLP)", self.own),
            (f"one set: {designed(self.shared_springs)}", self.shared),
        )
        for label, energies in rows:
            cells = " | ".join(f"{e:.1f}" for e in energies)
            lines.append(f"| {label} | {cells} | {sum(energies):.1f} |")
        lines.append("")
        for speed, values in zip(self.speeds, self.own_springs, strict=True):
            lines.append(f"- designed at {speed:g} m/s: {designed(values)}")
        return "\n".join(lines)


def _fixed(springs: Sequence[ParallelSpring], values: SpringValues) -> tuple[ParallelSpring, ...]:
    return tuple(replace(s, stiffness=values[s.joint][0], rest=values[s.joint][1]) for s in springs)


def design_springs(
    linkage: Linkage,
    drives: Mapping[str, Drive],
    speeds: Sequence[float],
    springs: Sequence[ParallelSpring],
    *,
    regeneration: bool = False,
    **step_options,
) -> SpringDesign:
    """One set of ``springs`` (their free numbers designed; see the module) beside ``drives``
    for ``linkage``'s steps at ``speeds`` m/s (``problems.walking.footed.step_at_speed``'s
    lengths and times), the electrical energy drawn (net with ``regeneration``) the cost;
    ``step_options`` go to :func:`problems.walking_step` (N, ...). Raises
    :class:`planner.AnthropoidError` when some speed has no plan without springs or none with
    its own."""
    springs = check_springs(springs)
    if not springs:
        raise DefinitionError("`springs`: give at least one ParallelSpring to design")
    speeds = tuple(float(v) for v in speeds)
    if not speeds:
        raise DefinitionError("`speeds`: give at least one speed, m/s")
    clock = time.perf_counter()
    bare, own, own_springs, own_gaits = [], [], [], []
    for speed in speeds:
        gait, walker = plan_with_drives(linkage, drives, speed, regeneration=regeneration,
                                        **step_options)  # fmt: skip
        bare.append(step_energy(gait, walker, regeneration))
        gait, walker = plan_with_drives(linkage, drives, speed, regeneration=regeneration,
                                        warm=gait, springs=springs, **step_options)  # fmt: skip
        values = spring_values(gait.solution, springs)
        own.append(step_energy(gait, walker, regeneration, values))
        own_springs.append(values)
        own_gaits.append(gait)
    tried: list[tuple[dict, tuple[float, ...]]] = []

    def cross(k: int) -> dict[int, tuple[float, dict, object]]:
        """Speed k's own springs, fixed, at every other speed (into ``tried``); returns the
        speeds they walk for less than those speeds' own: {j: (energy, springs, gait)}."""
        values, fixed, energies, beats = own_springs[k], _fixed(springs, own_springs[k]), [], {}
        for j, speed in enumerate(speeds):
            if j == k:
                energies.append(own[j])
                continue
            try:
                gait, walker = plan_with_drives(linkage, drives, speed, regeneration=regeneration,
                                                warm=own_gaits[j], springs=fixed,
                                                **step_options)  # fmt: skip
            except AnthropoidError:
                energies.append(math.inf)
                continue
            energies.append(step_energy(gait, walker, regeneration, values))
            if energies[-1] < own[j]:
                beats[j] = (energies[-1], values, gait)
        tried.append((dict(values), tuple(energies)))
        return beats

    better: dict[int, tuple[float, dict, object]] = {}
    for k in range(len(speeds)):
        for j, found in cross(k).items():
            if found[0] < better.get(j, (math.inf,))[0]:
                better[j] = found
    for j, (energy, values, gait) in sorted(better.items()):
        # another speed's springs walked this one for less: design it again from that plan,
        # and try the new design at the other speeds as well (one round: what it beats there
        # is not designed again)
        own[j], own_springs[j], own_gaits[j] = energy, values, gait
        try:
            gait, walker = plan_with_drives(linkage, drives, speeds[j], regeneration=regeneration,
                                            warm=gait, springs=springs, **step_options)  # fmt: skip
        except AnthropoidError:
            continue
        again = spring_values(gait.solution, springs)
        energy = step_energy(gait, walker, regeneration, again)
        if energy < own[j]:
            own[j], own_springs[j], own_gaits[j] = energy, again, gait
            cross(j)
    shared_springs, shared = min(tried, key=lambda item: sum(item[1]))
    return SpringDesign(springs, speeds, regeneration, tuple(bare), tuple(own),
                        tuple(own_springs), shared, shared_springs, tuple(tried),
                        time.perf_counter() - clock)  # fmt: skip


__all__ = ["SpringDesign", "design_springs"]
