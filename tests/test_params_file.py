"""``--params FILE`` of ``hydro identify greybox`` and ``hydro diagnose``
(:mod:`identification.params_file`): a preset for every plant, the plant's data sheet where its
contract reads one; values converted once, errors naming the field."""

from __future__ import annotations

import argparse
import dataclasses
import json

import pytest

from hydro_envs import registry
from hydro_envs.cli import main as hydro_main
from hydro_envs.plants.differential_cylinder.datasheet import load_rig
from identification.params_file import is_preset_file, load_params_file
from identification.ranges import RangesError, preset_mapping, write_preset

SERVO = registry.get("servo_cylinder").params_cls


def _servo_preset(tmp_path, **changes):
    p = dataclasses.replace(SERVO(), **changes)
    path = tmp_path / "servo.yaml"
    write_preset(path, preset_mapping(p, "test rig", "test"))
    return path


def test_a_preset_file_gives_its_values_for_a_plant_without_a_data_sheet(tmp_path):
    path = _servo_preset(tmp_path, mass=2.5 * SERVO().mass, piston_area=1.1e-3)
    assert is_preset_file(path)
    p = load_params_file("servo_cylinder", path, require=SERVO.geometry)
    assert p.mass == 2.5 * SERVO().mass and p.piston_area == 1.1e-3 and p.stroke == SERVO().stroke


def test_a_preset_without_the_geometry_is_refused_by_field(tmp_path):
    path = tmp_path / "servo.yaml"
    path.write_text("plant: servo_cylinder\nparameters:\n  mass: {value: 20, unit: kg, source: test}\n")
    with pytest.raises(RangesError, match="piston_area"):
        load_params_file("servo_cylinder", path, require=SERVO.geometry)


def test_the_data_sheet_of_a_plant_that_reads_one(tmp_path):
    assert registry.get("differential_cylinder").contract.load_params is load_rig
    rig = tmp_path / "rig.yaml"
    rig.write_text("bore: 50 mm\nrod: 28 mm\nstroke: 200 mm\nmass: 25 kg\n")
    assert not is_preset_file(rig)
    p = load_params_file("differential_cylinder", rig)
    assert (p.bore, p.rod, p.stroke, p.mass) == pytest.approx((0.05, 0.028, 0.2, 25.0))
    rig.write_text("bore: 50 m\nrod: 28 mm\nstroke: 200 mm\n")  # a bore of 50 m: out of bounds, named
    with pytest.raises(ValueError, match="bore"):
        load_params_file("differential_cylinder", rig)


def test_a_data_sheet_for_a_plant_without_a_reader_is_refused(tmp_path):
    rig = tmp_path / "rig.yaml"
    rig.write_text("bore: 50 mm\n")
    with pytest.raises(RangesError, match="servo_cylinder"):
        load_params_file("servo_cylinder", rig)


def test_diagnose_base_from_params_and_not_both(tmp_path):
    from identification.diagnosis.cli import _load_base

    path = _servo_preset(tmp_path, mass=3.0 * SERVO().mass)
    args = argparse.Namespace(plant="servo_cylinder", params=str(path), base=None, nominal_geometry=False)
    assert _load_base(args).mass == 3.0 * SERVO().mass
    with pytest.raises(ValueError, match="--base .* or --params .*not both"):
        _load_base(argparse.Namespace(plant="servo_cylinder", params=str(path), base=str(path), nominal_geometry=False))


def test_greybox_preset_and_params_together_are_a_usage_error(tmp_path, capsys):
    path = _servo_preset(tmp_path)
    rec = tmp_path / "rec.csv"
    rec.write_text("t [s],u [1],x [m],p1 [Pa],p2 [Pa]\n0,0,0.1,1e6,1e6\n0.001,0,0.1,1e6,1e6\n")
    code = hydro_main(["identify", "greybox", "--plant", "shaking_table", "--data", str(rec), "--fit", "mass_body",
                       "--preset", "nominal", "--params", str(path)])
    assert code == 2 and "not both" in capsys.readouterr().err


def test_greybox_starts_from_a_data_sheet(tmp_path, capsys):
    # the record's rig (a data sheet with 300 N Coulomb friction and 25 kg) is the start of the fit
    # of the mass only, from 20 % off: with the file's friction the mass comes back within 2 %
    rig = tmp_path / "rig.yaml"
    rig.write_text("bore: 50 mm\nrod: 28 mm\nstroke: 200 mm\nmass: 25 kg\nfriction: {coulomb: 300 N, static: 330 N}\n")
    rec = tmp_path / "rec.csv"
    env = registry.get("differential_cylinder").env_ids[0]
    assert hydro_main(["simulate", env, "--params", str(rig), "--nominal", "--steps", "1500", "--policy", "prbs",
                       "--amplitude", "0.3", "--out", str(rec)]) == 0
    capsys.readouterr()
    argv = ["identify", "greybox", "--plant", "differential_cylinder", "--data", str(rec), "--json", "--fit", "mass",
            "--params", str(rig), "--set", "mass=30.0"]
    assert hydro_main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["parameters"]["mass"] == pytest.approx(25.0, rel=0.02)
    assert f"parameters {rig}" in out["model"]
