"""Measured data: the plants' channels and the measured-data file format.

See :mod:`hydro_envs.data.measured` for the file format and the loader,
:mod:`hydro_envs.data.foreign` for other layouts and the column map,
:mod:`hydro_envs.data.friction_reading` for the static friction level read off a record,
:mod:`hydro_envs.data.units` for unit conversion, :mod:`hydro_envs.data.checks` for the
plausibility checks and :mod:`hydro_envs.data.channels` for the channels of each plant.
"""

from hydro_envs.data.channels import TIME_CHANNEL, Channel, UnknownPlantError, channels_for, known_plants
from hydro_envs.data.measured import MeasuredData, MeasuredDataError, load_measured, write_measured

__all__ = [
    "Channel",
    "TIME_CHANNEL",
    "UnknownPlantError",
    "channels_for",
    "known_plants",
    "MeasuredData",
    "MeasuredDataError",
    "load_measured",
    "write_measured",
]
