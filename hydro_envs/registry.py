"""The plant registry: one :class:`~hydro_envs.spec.PlantSpec` per plant, read by every command.

The envs registered with Gymnasium, the measured-data channels and loader, validation, the
soak test, the ``hydro`` command line, identification, diagnosis and the agents all look a
plant up here. The list below is explicit: a fresh process that imports only this module knows
every plant, and nothing registers itself as a side effect of some other import.

Adding a plant: its folder ``hydro_envs/plants/<name>/`` (see :mod:`hydro_envs.spec`) and its
name in :data:`PLANT_NAMES`.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator

from hydro_envs.spec import EnvEntry, PlantSpec

__all__ = ["PLANT_NAMES", "UnknownPlantError", "get", "specs", "names", "env_entries", "spec_for_env"]

#: every plant, in the order commands list them
PLANT_NAMES: tuple[str, ...] = (
    "servo_cylinder",
    "shaking_table",
    "force_actuator",
    "ls_compensator",
    "load_sensing",
    "rodless_cylinder",
    "slider",
    "seal_friction",
    "differential_cylinder",
)

_SPECS: dict[str, PlantSpec] = {}


class UnknownPlantError(KeyError, ValueError):
    """A plant name the registry does not know (a ``KeyError`` and a ``ValueError``)."""

    def __init__(self, plant: object) -> None:
        self.plant = plant
        self.known = PLANT_NAMES
        super().__init__(f"unknown plant {plant!r}; known plants: {', '.join(PLANT_NAMES)}")

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0])


def get(name: str) -> PlantSpec:
    """The spec of plant ``name`` (raises :class:`UnknownPlantError` listing the known ones)."""
    spec = _SPECS.get(name) if isinstance(name, str) else None
    if spec is None:
        if not isinstance(name, str) or name not in PLANT_NAMES:
            raise UnknownPlantError(name)
        spec = importlib.import_module(f"hydro_envs.plants.{name}.spec").SPEC
        if spec.name != name:
            raise RuntimeError(f"hydro_envs.plants.{name}.spec.SPEC is named {spec.name!r}")
        _SPECS[name] = spec
    return spec


def specs(*, with_model: bool | None = None) -> list[PlantSpec]:
    """Every spec in registry order (``with_model``: only those with / without a model)."""
    out = [get(n) for n in PLANT_NAMES]
    if with_model is not None:
        out = [s for s in out if s.has_model == with_model]
    return out


def names() -> tuple[str, ...]:
    return PLANT_NAMES


def env_entries() -> Iterator[tuple[PlantSpec, EnvEntry]]:
    """(plant spec, env entry) of every registered env id."""
    for spec in specs():
        for entry in spec.envs:
            yield spec, entry


def spec_for_env(env_id: str) -> PlantSpec:
    """The plant an env id runs on."""
    for spec, entry in env_entries():
        if entry.id == env_id:
            return spec
    known = [e.id for _, e in env_entries()]
    raise KeyError(f"unknown env id {env_id!r}; hydro_envs env ids: {', '.join(known)}")
