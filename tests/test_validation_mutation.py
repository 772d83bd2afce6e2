"""Each plant's validation rows can fail: a 20 % change of one physical parameter of the nominal
model makes at least one of that plant's rows fail (the rows compare the model with something it
did not produce, or they would pass whatever the parameter)."""

import dataclasses
import importlib

import pytest

#: plant -> (its parameter class, the field changed, the factor)
MUTATIONS = {
    "servo_cylinder": ("ServoCylinderParams", "area_gradient", 0.8),  # 002 Table 1 w: 34 L/min row
    "force_actuator": ("ForceActuatorParams", "sensor_stiffness", 1.2),  # 001 Table 1 k_s: ring-down rows
    "ls_compensator": ("LSCompensatorParams", "spool_mass", 1.2),  # 000 Table 1 m: Table 1 and rig rows
    "load_sensing": ("LoadSensingParams", "spring_preload", 1.2),  # the 20 bar margin
    # eq (2)'s port radius: the valve's nominal-flow row against the MPYE-5-M5 data sheet
    "rodless_cylinder": ("RodlessCylinderParams", "port_radius", 1.2),
    # 003 Table 1 R: the valve's full-opening flow row against the 20 l/min catalogue
    "shaking_table": ("ShakingTableParams", "flow_coefficient", 0.8),
}
# No row can check the moving masses of 003 and 004 (platform_mass, mass): no number the seeds
# print depends on them through a route the model does not take as input (003 prints the
# platform's 650 kg and Table 3's errors against records not shipped; 004 neither the slide's
# mass nor eq (32)'s sample time, so eq (32)'s pole angle cannot be compared).


def _failing_rows(plant, monkeypatch):
    module = importlib.import_module(f"hydro_envs.plants.{plant}.validation")
    cls_name, field, factor = MUTATIONS[plant]
    cls = getattr(importlib.import_module(f"hydro_envs.plants.{plant}.params"), cls_name)
    base = cls()

    def mutated(*args, **kwargs):
        p = cls(*args, **kwargs)
        return dataclasses.replace(p, **{field: factor * getattr(base, field)})

    if plant == "shaking_table":  # its rows take presets
        preset = cls.preset.__func__
        monkeypatch.setattr(cls, "preset", classmethod(lambda c, *a, **k: dataclasses.replace(
            preset(c, *a, **k), **{field: factor * getattr(base, field)})))
    else:
        monkeypatch.setattr(module, cls_name, mutated)
    return [r.name for r in module.rows() if not r.passed]


@pytest.mark.slow
@pytest.mark.parametrize("plant", sorted(MUTATIONS))
def test_a_twenty_percent_change_fails_a_row(plant, monkeypatch):
    assert _failing_rows(plant, monkeypatch), f"{plant}: no row fails with {MUTATIONS[plant]}"
