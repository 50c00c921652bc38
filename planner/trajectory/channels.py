"""What the trajectory's file formats and its plot read of a trajectory: :class:`Channels`.

The writers (:mod:`planner.trajectory.formats`) and the plot (:mod:`planner.trajectory.plot`)
work on these attributes, not on :class:`planner.trajectory.Trajectory` itself, so the
trajectory type can call them without the modules importing one another in a circle.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np


class Channels(Protocol):
    """Named, unit-carrying samples on a time grid (a Trajectory satisfies it).

    ``time`` (K,) s; ``states`` (K, nx), ``controls`` (K, nu) with their names and units;
    ``extras`` name -> (values (K,), unit); ``metadata`` a JSON-serialisable dict.
    """

    time: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    control_names: tuple[str, ...]
    control_units: tuple[str, ...]
    extras: Mapping[str, tuple[np.ndarray, str]]
    metadata: dict

    @property
    def columns(self) -> tuple[tuple[str, str, str], ...]:
        """(name, unit, group) of every column in file order: t, states, controls, extras."""
        ...

    @property
    def extra_values(self) -> np.ndarray:
        """(K, number of extras) the extras' samples, in the order of ``extras``."""
        ...

    def column(self, name: str) -> np.ndarray:
        """The samples of the channel ``name``, (K,)."""
        ...

    def resample(self, rate_hz: float | None = None, times=None) -> Channels:
        """The channels at other times."""
        ...


__all__ = ["Channels"]
