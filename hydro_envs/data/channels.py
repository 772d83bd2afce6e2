"""Measured channels of each plant, as the registry declares them.

Every plant's spec (:mod:`hydro_envs.registry`) lists its sensor and actuator channels with
their SI units; the measured-data format (:mod:`hydro_envs.data.measured`), the ``hydro
channels`` command and the environments' ``channel_values()`` use these names. The time
column ``t`` [s] is common to every plant and is not part of any plant's channel tuple
(:data:`TIME_CHANNEL`).
"""

from __future__ import annotations

from hydro_envs.registry import UnknownPlantError, get, names
from hydro_envs.spec import TIME_CHANNEL, Channel

__all__ = ["Channel", "TIME_CHANNEL", "UnknownPlantError", "channels_for", "known_plants"]


def channels_for(plant: str) -> tuple[Channel, ...]:
    """The channels of ``plant`` (time excluded), in column order.

    Raises :class:`UnknownPlantError` (a ``KeyError`` and ``ValueError``) listing the known
    plants if ``plant`` is not in the registry.
    """
    return get(plant).channels


def known_plants() -> tuple[str, ...]:
    """Sorted names of all plants."""
    return tuple(sorted(names()))
