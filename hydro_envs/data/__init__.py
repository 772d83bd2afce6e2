"""Measured data: channel registry and the measured-data file format.

See :mod:`hydro_envs.data.measured` for the file format and
:mod:`hydro_envs.data.channels` for the per-plant channel registry.
"""

from hydro_envs.data.channels import (
    PLANT_CHANNELS,
    TIME_CHANNEL,
    Channel,
    UnknownPlantError,
    channels_for,
    known_plants,
    register_plant_channels,
)
from hydro_envs.data.measured import (
    MeasuredData,
    MeasuredDataError,
    load_measured,
    write_measured,
)

__all__ = [
    "Channel",
    "TIME_CHANNEL",
    "PLANT_CHANNELS",
    "UnknownPlantError",
    "register_plant_channels",
    "channels_for",
    "known_plants",
    "MeasuredData",
    "MeasuredDataError",
    "load_measured",
    "write_measured",
]
