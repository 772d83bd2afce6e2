"""A record written by `hydro simulate` identifies back to the parameters that made it: the
sample-and-hold convention of the record is the one the identification methods assume."""

from __future__ import annotations

import pytest

from hydro_envs.cli import main as hydro
from hydro_envs.data import load_measured
from identification import greybox as gb


def test_nominal_servo_record_gives_back_its_friction(tmp_path, capsys):
    out = tmp_path / "servo.csv"
    assert hydro(["simulate", "hydro_envs/ServoCylinderPosition-v0", "--steps", "4000", "--policy", "prbs",
                  "--nominal", "--out", str(out)]) == 0
    capsys.readouterr()
    data = load_measured(out)
    true = {k: float(data.metadata[f"param.{k}"].split()[0]) for k in ("coulomb_friction", "viscous_friction")}
    setup = gb.plant_setup("servo_cylinder")
    base = setup["params"].from_mapping({"coulomb_friction": 1.5 * true["coulomb_friction"],
                                         "viscous_friction": 1.2 * true["viscous_friction"]})
    outs = list(setup["fit_outputs"])
    exp = gb.experiment_from_measured(data, "servo_cylinder", base, outs)
    res = gb.fit_greybox(base, list(true), [exp], [setup["channels"][c] for c in outs])
    for name, value in true.items():
        assert getattr(res.params, name) == pytest.approx(value, rel=0.03), name
