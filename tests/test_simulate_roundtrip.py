"""A record written by `hydro simulate` identifies back to the parameters that made it: the
sample-and-hold convention of the record (u[k] held over [t_k, t_k+1), sensors at t_k) is the
one the grey-box fit assumes, and the header's ``# param.NAME: VALUE [UNIT]`` lines are the truth.

One round trip per plant with an env: simulate at the nominal parameters, start the fit from
parameters 20-50 % off, recover them within 3 % -- under PRBS in the default suite, under
multisine and chirp in the slow one. Each plant's parameters are ones its sensors and
excitation make identifiable (the reasons are beside each case). The LS flow compensator has
no env to record from; its rig identification round trip is in test_ls_compensator.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hydro_envs import registry
from hydro_envs.cli import main as hydro
from hydro_envs.data import load_measured
from identification import greybox as gb

TOL = 0.03


def _record(tmp_path, capsys, env_id: str, steps: int, policy: str = "prbs", *extra: str):
    """``hydro simulate ENV_ID --nominal`` to a CSV; the loaded record and its file."""
    out = tmp_path / "record.csv"
    assert hydro(["simulate", env_id, "--steps", str(steps), "--policy", policy, "--nominal",
                  "--out", str(out), *extra]) == 0
    capsys.readouterr()
    plant = registry.spec_for_env(env_id).name
    return load_measured(out, required=registry.get(plant).inputs), out


def _truth(data, names) -> dict[str, float]:
    """Parameter values from the record's header (``VALUE [UNIT]``)."""
    return {k: float(data.metadata[f"param.{k}"].split()[0]) for k in names}


def _fit(plant: str, data, start: dict[str, float], **kw) -> gb.GreyboxResult:
    """Grey-box fit of the ``start`` parameters on the plant's default output channels."""
    setup = gb.plant_setup(plant)
    base = setup["params"].from_mapping(start)
    outs = list(setup["fit_outputs"])
    exp = gb.experiment_from_measured(data, plant, base, outs)
    return gb.fit_greybox(base, list(start), [exp], [setup["channels"][c] for c in outs], **kw)


def _check(res: gb.GreyboxResult, true: dict[str, float]) -> None:
    for name, value in true.items():
        assert res.values[name] == pytest.approx(value, rel=TOL), (name, res.values[name], value)
    assert res.identifiable, res.notes


# noise-free records: one solve (no noise-level reweighting), forward-difference Jacobian
FAST = {"reweight": False, "jacobian": "forward"}


def test_nominal_servo_record_gives_back_its_friction(tmp_path, capsys):
    # PRBS strokes at many speeds: Coulomb (sign-dependent) and viscous (speed-proportional)
    # friction act differently on x, p1, p2
    data, _ = _record(tmp_path, capsys, "hydro_envs/ServoCylinderPosition-v0", 4000)
    true = _truth(data, ("coulomb_friction", "viscous_friction"))
    res = _fit("servo_cylinder", data, {"coulomb_friction": 1.5 * true["coulomb_friction"],
                                         "viscous_friction": 1.2 * true["viscous_friction"]})
    for name, value in true.items():
        assert getattr(res.params, name) == pytest.approx(value, rel=TOL), name


def test_shaking_table_record_identifies_through_the_cli(tmp_path, capsys):
    # the whole path a lab would use: hydro simulate -> file -> hydro identify greybox --json.
    # Position and accelerometer under PRBS valve steps: the reversals at many speeds separate
    # the Coulomb level from the viscous slope of the table friction; the acceleration
    # transients after each step (oil column against 850 kg) set the bulk modulus
    data, path = _record(tmp_path, capsys, "hydro_envs/ShakingTable-v0", 2000)
    true = _truth(data, ("coulomb_friction", "viscous_friction", "e0"))
    start = {"coulomb_friction": 1.3 * true["coulomb_friction"], "viscous_friction": 0.8 * true["viscous_friction"],
             "e0": 1.2 * true["e0"]}
    argv = ["identify", "greybox", "--plant", "shaking_table", "--data", str(path), "--json",
            "--fit", ",".join(start)] + [a for k, v in start.items() for a in ("--set", f"{k}={v!r}")]
    assert hydro(argv) == 0
    out = json.loads(capsys.readouterr().out)
    for name, value in true.items():
        assert out["parameters"][name] == pytest.approx(value, rel=TOL), name
        assert out["parameters"][name] != pytest.approx(start[name], rel=TOL)


def test_rodless_cylinder_record_gives_back_friction_and_mass(tmp_path, capsys):
    # pneumatic slider under PRBS valve steps (80 % of the command range): the accelerations
    # after each switch weigh the slider (mass), the spread of speeds reached between switches
    # separates the Coulomb level from the viscous slope of the seal friction (at 50 % the
    # speeds cluster and the two correlate beyond 0.95); y and both pressures measured
    data, _ = _record(tmp_path, capsys, "hydro_envs/RodlessCylinder-v0", 1500, "prbs", "--amplitude", "0.8")
    true = _truth(data, ("coulomb_friction", "viscous_friction", "mass"))
    res = _fit("rodless_cylinder", data, {"coulomb_friction": 1.3 * true["coulomb_friction"],
                                           "viscous_friction": 0.8 * true["viscous_friction"],
                                           "mass": 1.2 * true["mass"]}, **FAST)
    _check(res, true)


def test_force_actuator_record_gives_back_supply_pressure_and_sensor(tmp_path, capsys):
    # blocked-force set-up, only the sensed force measured: PRBS current steps reach 60 % of
    # the jet deflection, whose static force scales with the supply pressure (001 sec. 3.1);
    # every step rings the force sensor's ~410 Hz mode, whose frequency is its stiffness (the
    # 0.56 kg sensor mass fixed) and whose decay its damping (001 eq (2))
    data, _ = _record(tmp_path, capsys, "hydro_envs/ForceActuator-v0", 2000)
    true = _truth(data, ("supply_pressure", "sensor_damping", "sensor_stiffness"))
    res = _fit("force_actuator", data, {"supply_pressure": 1.2 * true["supply_pressure"],
                                         "sensor_damping": 0.8 * true["sensor_damping"],
                                         "sensor_stiffness": 1.2 * true["sensor_stiffness"]}, **FAST)
    _check(res, true)


@pytest.mark.parametrize("mass_start", [1.2, 1.15])
def test_load_sensing_record_gives_back_load_and_compensator_damping(tmp_path, capsys, mass_start):
    # PRBS on both inputs (solenoid force on the FC spool, CV opening), pressures, actuator
    # position and velocity measured: the load's oil-spring oscillation sets the load mass and
    # its decay the actuator's viscous friction; the pressure transients of the compensator
    # its viscous coefficient (000 Fig. 14: the parameter deciding LS stability). From a 1.15x
    # load the first solver run stops on its step size (xtol) with the gradient far from zero
    # (a trial point of a light load raised its sub-steps for the rest of it); the second run
    # from there, with the sub-steps that point needs, reaches the parameters that made the record
    data, _ = _record(tmp_path, capsys, "hydro_envs/LoadSensing-v0", 1000)
    true = _truth(data, ("load_mass", "actuator_viscous", "viscous_friction_40c"))
    res = _fit("load_sensing", data, {"load_mass": mass_start * true["load_mass"],
                                       "actuator_viscous": 0.8 * true["actuator_viscous"],
                                       "viscous_friction_40c": 1.3 * true["viscous_friction_40c"]}, **FAST)
    _check(res, true)
    if mass_start == 1.15:
        assert any(n.startswith("restarted from the first stop") for n in res.notes), res.notes


def test_record_with_the_input_one_row_late_does_not_identify(tmp_path, capsys):
    # the check above can fail: the same rodless record with u recorded one sample late (the
    # convention error a logger can make) misses the friction by far more than the tolerance
    data, _ = _record(tmp_path, capsys, "hydro_envs/RodlessCylinder-v0", 1500, "prbs", "--amplitude", "0.8")
    true = _truth(data, ("coulomb_friction", "viscous_friction", "mass"))
    u = data["u"]
    data.channels["u"] = np.concatenate([u[:1], u[:-1]])
    res = _fit("rodless_cylinder", data, {k: v for k, v in true.items()}, **FAST)
    assert max(abs(res.values[k] / v - 1.0) for k, v in true.items()) > 3 * TOL


# the same parameter sets under the broadband policies: (env, steps, extra flags, start / truth)
BROADBAND = {
    "servo_cylinder": ("hydro_envs/ServoCylinderPosition-v0", 4000, (),
                       {"coulomb_friction": 1.5, "viscous_friction": 1.2}),
    "shaking_table": ("hydro_envs/ShakingTable-v0", 4000, (),
                      {"coulomb_friction": 1.3, "viscous_friction": 0.8, "e0": 1.2}),
    "rodless_cylinder": ("hydro_envs/RodlessCylinder-v0", 4000, ("--amplitude", "0.8"),
                         {"coulomb_friction": 1.3, "viscous_friction": 0.8, "mass": 1.2}),
    "force_actuator": ("hydro_envs/ForceActuator-v0", 5000, (),
                       {"supply_pressure": 1.2, "sensor_damping": 0.8, "sensor_stiffness": 1.2}),
    "load_sensing": ("hydro_envs/LoadSensing-v0", 3000, (),
                     {"load_mass": 1.2, "actuator_viscous": 0.8, "viscous_friction_40c": 1.3}),
}


@pytest.mark.slow
@pytest.mark.parametrize("policy", ["multisine", "chirp"])
@pytest.mark.parametrize("plant", sorted(BROADBAND))
def test_broadband_record_gives_back_its_parameters(tmp_path, capsys, plant, policy):
    # multisine (flat spectrum, random phases) and log chirp from 2 cycles per record to a tenth
    # of the sample rate; the full fit (noise-level reweighting, central differences). The
    # friction pairs may correlate beyond 0.95 under a sweep (few distinct speeds at a time):
    # the values are checked, not the identifiability flag
    env_id, steps, extra, factors = BROADBAND[plant]
    data, _ = _record(tmp_path, capsys, env_id, steps, policy, *extra)
    true = _truth(data, factors)
    res = _fit(plant, data, {k: f * true[k] for k, f in factors.items()})
    for name, value in true.items():
        assert res.values[name] == pytest.approx(value, rel=TOL), (name, res.values[name], value)
