"""``--params FILE`` of ``hydro identify greybox`` and ``hydro diagnose``: a plant's parameter set
from a file with units.

Two formats, told apart by the file itself:

* a **preset** (``plant:``, ``parameters:`` with ``{value, unit, source}`` per field, as
  :func:`identification.ranges.write_preset` writes them), read by
  :func:`identification.ranges.load_preset` for every plant;
* the plant's **data sheet** (``bore: 63 mm``, ``valve: {rated_flow: 40 L/min, ...}``), read by
  the reader its contract gives (:attr:`hydro_envs.contract.PlantModel.load_params`, e.g. the
  differential cylinder's :func:`~hydro_envs.plants.differential_cylinder.datasheet.load_rig`,
  which also takes the name of a shipped file).

Either way each value is converted once and checked against the field's bounds; an error is one
line naming the file, the field and the allowed range.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["load_params_file", "is_preset_file"]


def is_preset_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an existing YAML preset (a mapping with a ``parameters`` key)."""
    from hydro_envs.yamlio import load_yaml

    p = Path(path)
    if not p.is_file():
        return False
    data = load_yaml(p, what="parameter file")
    return isinstance(data, Mapping) and "parameters" in data


def load_params_file(plant: str, path: str | os.PathLike[str], require: Sequence[str] = ()) -> Any:
    """The parameter set of plant ``plant`` in file ``path``: a preset (every plant; the fields in
    ``require``, e.g. the rig's geometry, must be listed) or the plant's data sheet (a plant whose
    contract gives ``load_params``; a data sheet describes the whole rig)."""
    from hydro_envs import registry
    from identification.ranges import load_preset

    spec = registry.get(plant)
    reader = spec.contract.load_params if spec.has_model else None
    if reader is None or is_preset_file(path):
        return load_preset(path, spec.params_cls, require=require)
    return reader(path)
