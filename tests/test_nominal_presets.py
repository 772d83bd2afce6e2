"""Every plant ships its nominal parameter set as a preset with units and sources
(``configs/plants/<plant>/presets/nominal.yaml``, issue 54 item 3): the file a user copies to
describe their own rig, read by ``hydro identify greybox --params`` / ``hydro diagnose --params``.

Staleness check: the file must equal what :func:`identification.ranges.nominal_preset` writes for
today's defaults and sources (regenerate with the snippet in the message)."""

from __future__ import annotations

import pytest
import yaml

from hydro_envs import registry
from hydro_envs.config_files import config_file
from identification.ranges import load_preset, nominal_preset

PLANTS = [s for s in registry.specs() if getattr(s, "params_class", None)]


@pytest.mark.parametrize("spec", PLANTS, ids=lambda s: s.name)
def test_nominal_preset_is_shipped_current_and_sourced(spec):
    cls = spec.params_cls
    path = config_file("plants", spec.name, "presets", "nominal.yaml")
    assert path.is_file(), f"{spec.name}: no {path}"
    raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    regen = ("python -c \"from identification.ranges import nominal_preset, write_preset; ...\" "
             f"(write_preset('{path}', nominal_preset({cls.__name__})))")
    assert raw["parameters"] == nominal_preset(cls)["parameters"], f"{path} is stale: {regen}"
    assert all(v["source"] and v["unit"] for v in raw["parameters"].values())
    assert load_preset(path, cls) == cls()
