"""The shipped ``--base`` examples (configs/base/): one per diagnosis plant, each loads as
``hydro diagnose`` loads a ``--base`` file (geometry required), is the plant's effect-free
base model and is not stale against the parameter defaults."""

from __future__ import annotations

from pathlib import Path

import pytest

from identification.diagnosis.base_examples import base_example
from identification.diagnosis.models import null_base
from identification.diagnosis.plants import PLANTS, diagnosis_plant
from identification.ranges import load_preset
from hydro_envs.yamlio import load_yaml

BASE_DIR = Path(__file__).resolve().parents[1] / "configs" / "base"
REGENERATE = "python -m identification.diagnosis.base_examples --out configs/base"


@pytest.mark.parametrize("plant", PLANTS)
def test_shipped_base_example_loads_and_is_the_effect_free_base(plant):
    path = BASE_DIR / f"{plant}.yaml"
    assert path.is_file(), f"{path} missing: {REGENERATE}"
    spec = diagnosis_plant(plant)
    cls = spec.params_cls
    p = load_preset(path, cls, require=cls.geometry)
    want = null_base(spec)
    diff = {f: (float(getattr(p, f)), float(getattr(want, f))) for f in cls.names()
            if float(getattr(p, f)) != float(getattr(want, f))}
    assert not diff, f"{path} is stale ({diff}): {REGENERATE}"
    assert load_yaml(path, what="preset") == base_example(plant), f"{path} is stale: {REGENERATE}"
