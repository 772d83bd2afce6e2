"""Registry of the measured channels of each plant.

Every plant in ``hydro_envs`` exposes a fixed set of sensor / actuator channels. The
registry below is the single source of truth for their names and SI units: the
measured-data format (:mod:`hydro_envs.data.measured`), the ``hydro channels`` command
and the environments' ``channel_values()`` all use these names.

The time column ``t`` [s] is common to every plant and is not part of any plant's
channel tuple; it is exposed as :data:`TIME_CHANNEL`.

New plants register their channels from their own module::

    from hydro_envs.data.channels import Channel, register_plant_channels

    register_plant_channels("shaking_table", (
        Channel("u", "V", "valve command"),
        Channel("x", "m", "table position"),
        Channel("a", "m/s^2", "table acceleration"),
    ))

This module is dependency-free (no numpy) so that it is cheap to import.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

__all__ = [
    "Channel",
    "TIME_CHANNEL",
    "PLANT_CHANNELS",
    "UnknownPlantError",
    "register_plant_channels",
    "channels_for",
    "known_plants",
]


@dataclass(frozen=True)
class Channel:
    """One measured signal: its column name, SI unit and a one-line meaning."""

    name: str
    unit: str
    meaning: str


#: The time column, first column of every measured-data file.
TIME_CHANNEL = Channel("t", "s", "time since start of record")

#: plant name -> its channels, in canonical column order (time excluded).
PLANT_CHANNELS: dict[str, tuple[Channel, ...]] = {}

# Channel names must be usable as CSV header cells and Python-ish identifiers: no commas,
# brackets, quotes or whitespace.
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# Units: anything printable without brackets, commas or line breaks ("" = dimensionless).
_UNIT_RE = re.compile(r"[^\[\],\r\n]*")


class UnknownPlantError(KeyError, ValueError):
    """Raised for a plant name that has no registered channels.

    Subclasses both ``KeyError`` (it is a failed registry lookup) and ``ValueError``
    (it is a bad argument value), so either can be caught.
    """

    def __init__(self, plant: str) -> None:
        known = ", ".join(sorted(PLANT_CHANNELS)) or "(none registered)"
        self.plant = plant
        self.known = tuple(sorted(PLANT_CHANNELS))
        super().__init__(f"unknown plant {plant!r}; known plants: {known}")

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0])


def register_plant_channels(
    plant: str, channels: Iterable[Channel], *, replace: bool = False
) -> tuple[Channel, ...]:
    """Register the channels of ``plant`` (time excluded) and return them as a tuple.

    Re-registering identical channels is a no-op. Registering different channels under an
    existing name raises ``ValueError`` unless ``replace=True``.
    """
    if not isinstance(plant, str) or not _NAME_RE.fullmatch(plant):
        raise ValueError(
            f"plant name {plant!r} is invalid: use letters, digits and '_' "
            "(not starting with a digit)"
        )
    chans = tuple(channels)
    if not chans:
        raise ValueError(f"plant {plant!r}: at least one channel is required")
    seen: set[str] = set()
    for ch in chans:
        if not isinstance(ch, Channel):
            raise TypeError(f"plant {plant!r}: expected Channel, got {type(ch).__name__}")
        if not _NAME_RE.fullmatch(ch.name):
            raise ValueError(
                f"plant {plant!r}: channel name {ch.name!r} is invalid: use letters, "
                "digits and '_' (not starting with a digit)"
            )
        if ch.name == TIME_CHANNEL.name:
            raise ValueError(
                f"plant {plant!r}: channel name 't' is reserved for the time column"
            )
        if ch.name in seen:
            raise ValueError(f"plant {plant!r}: duplicate channel name {ch.name!r}")
        seen.add(ch.name)
        if not isinstance(ch.unit, str) or not _UNIT_RE.fullmatch(ch.unit):
            raise ValueError(
                f"plant {plant!r}, channel {ch.name!r}: unit {ch.unit!r} must not contain "
                "brackets, commas or line breaks"
            )
    old = PLANT_CHANNELS.get(plant)
    if old is not None and old != chans and not replace:
        raise ValueError(
            f"plant {plant!r} is already registered with different channels "
            f"({', '.join(c.name for c in old)}); pass replace=True to override"
        )
    PLANT_CHANNELS[plant] = chans
    return chans


def channels_for(plant: str) -> tuple[Channel, ...]:
    """The registered channels of ``plant`` (time excluded), in column order.

    Raises :class:`UnknownPlantError` (a ``KeyError`` and ``ValueError``) listing the
    known plants if ``plant`` is not registered.
    """
    try:
        return PLANT_CHANNELS[plant]
    except (KeyError, TypeError):
        raise UnknownPlantError(plant) from None


def known_plants() -> tuple[str, ...]:
    """Sorted names of all registered plants."""
    return tuple(sorted(PLANT_CHANNELS))


# --- plants registered here ------------------------------------------------------------

# Seed 002: valve-controlled double-rod servo cylinder.
register_plant_channels(
    "servo_cylinder",
    (
        Channel("u", "V", "servo-valve command (+-10 V = full spool stroke)"),
        Channel("x", "m", "piston position from the chamber-1 end of stroke (0..stroke)"),
        Channel("p1", "Pa", "absolute pressure in chamber 1"),
        Channel("p2", "Pa", "absolute pressure in chamber 2"),
    ),
)
