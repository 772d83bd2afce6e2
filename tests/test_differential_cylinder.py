"""Differential cylinder (issue 54): data-sheet arithmetic, analytic results, the parameter file
with units, the env from a file, the controllers."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs import registry
from hydro_envs.params import ParameterError
from hydro_envs.plants.differential_cylinder import model as dc
from hydro_envs.plants.differential_cylinder.datasheet import load_rig, shipped_files
from hydro_envs.plants.differential_cylinder.params import (
    DifferentialCylinderParams, bandwidth_to_natural_frequency, edge_flow_coefficient,
)
from hydro_envs.sim.simulate import simulate

ENV = "hydro_envs/DifferentialCylinderPosition-v0"
#: the shipped example parameter file (configs/ of the repository)
RIG_FILE = str(Path(__file__).resolve().parents[1] / "configs" / "datasheets" / "differential_cylinder_63_36_300.yaml")
SPEC = registry.get("differential_cylinder")
NOMINAL = DifferentialCylinderParams()


def test_areas_and_valve_from_the_data_sheet():
    # 63/36 mm: A1 = 31.17 cm^2, A2 = 20.99 cm^2 (hand calculation pi/4 d^2)
    assert NOMINAL.piston_area == pytest.approx(31.172e-4, rel=1e-4)
    assert NOMINAL.annulus_area == pytest.approx(20.994e-4, rel=1e-4)
    # 40 L/min at 35 bar per edge: K = 6.667e-4 / sqrt(3.5e6)
    assert edge_flow_coefficient(NOMINAL.rated_flow, NOMINAL.rated_pressure_drop) == pytest.approx(
        6.6667e-4 / 1870.83, rel=1e-4)
    # the -3 dB frequency of the spool the natural frequency implies is the data sheet's 60 Hz
    for zeta in (0.3, 0.7, 1.2):
        wn = bandwidth_to_natural_frequency(60.0, zeta)
        w = 2 * math.pi * 60.0
        gain = wn**2 / abs(complex(wn**2 - w**2, 2 * zeta * wn * w))
        assert gain == pytest.approx(1 / math.sqrt(2), rel=1e-9)


def test_rated_flow_through_the_valve_at_the_rated_drop():
    # a fully open valve with p_s - p1 = 35 bar into a chamber: the flow is Q_N (laminar core aside)
    row = NOMINAL.to_array()
    ps, pt = NOMINAL.supply_pressure, NOMINAL.tank_pressure
    q1, q2 = dc.valve_flows(1.0, ps - 35e5, pt + 35e5, row)
    assert q1 == pytest.approx(NOMINAL.rated_flow, rel=2e-3)
    assert -q2 == pytest.approx(NOMINAL.rated_flow, rel=2e-3)


def test_minimum_natural_frequency_location_is_the_minimum():
    xs = np.linspace(0.0, NOMINAL.stroke, 3001)
    w = [dc.hydraulic_natural_frequency(NOMINAL, x) for x in xs]
    assert dc.minimum_natural_frequency(NOMINAL) == pytest.approx(min(w), rel=1e-6)
    assert dc.minimum_natural_frequency_position(NOMINAL) == pytest.approx(xs[int(np.argmin(w))], abs=2e-4)


def test_substeps_and_stiffness_modes_bound_the_jacobian():
    y = dc.rest_state(NOMINAL, 0.0)
    y[dc.V] = 0.0
    row = NOMINAL.to_array()
    u = np.zeros(1)

    def f(s):
        d = np.zeros(dc.N_STATES)
        dc.differential_cylinder_rhs(s, u, row, d)
        return d

    jac = np.zeros((dc.N_STATES, dc.N_STATES))
    for j in range(dc.N_STATES):
        h = 1e-7 * max(1.0, abs(y[j]))
        a, b = y.copy(), y.copy()
        a[j] += h
        b[j] -= h
        jac[:, j] = (f(a) - f(b)) / (2 * h)
    assert np.abs(np.linalg.eigvals(jac)).max() <= max(dc.stiffness_modes(NOMINAL).values())


def test_parameter_file_loads_and_equals_the_nominal_rig():
    assert load_rig(RIG_FILE) == NOMINAL
    assert load_rig("differential_cylinder_63_36_300") == NOMINAL  # shipped as package data
    shipped = shipped_files()["differential_cylinder_63_36_300"].read_text()
    with open(RIG_FILE) as fh:
        assert fh.read() == shipped


def test_units_convert_once():
    assert load_rig({"bore": "63 mm"}).bore == load_rig({"bore": 0.063}).bore == 0.063
    assert load_rig({"bore": "6.3 cm"}).bore == 0.063
    p = load_rig({"valve": {"rated_flow": "60 L/min", "bandwidth": "0.1 kHz"}, "mass": "250 kg"})
    assert p.rated_flow == pytest.approx(1e-3, rel=1e-12) and p.valve_bandwidth == 100.0 and p.mass == 250.0
    # pressure levels are gauge unless marked absolute; differences are not shifted
    assert load_rig({"supply_pressure": "200 bar"}).supply_pressure == 200e5 + 101325.0
    assert load_rig({"supply_pressure": "200 bar(a)"}).supply_pressure == 200e5
    assert load_rig({"valve": {"rated_pressure_drop": "10 bar"}}).rated_pressure_drop == 10e5


@pytest.mark.parametrize("mapping, words", [
    ({"bore": "63 kg"}, ("bore", "63 kg", "[m]")),
    ({"valve": {"rated_flow": "40 bar"}}, ("rated_flow", "bar", "m^3/s")),
    ({"stroke": "-300 mm"}, ("stroke", "-300 mm", "allowed")),
    ({"mass": "0 kg"}, ("mass", "0 kg", "allowed")),
    ({"rod": "70 mm"}, ("rod", "bore")),
    ({"valve": {"flow": "40 L/min"}}, ("valve.flow",)),
    ({"bore": "sixty mm"}, ("bore", "sixty")),
])
def test_a_wrong_unit_or_impossible_value_is_refused_by_name(mapping, words):
    with pytest.raises(ParameterError) as exc:
        load_rig(mapping)
    for w in words:
        assert w in str(exc.value)


def test_env_made_from_a_file_is_that_rig_and_randomised_around_it(tmp_path):
    f = tmp_path / "rig.yaml"
    f.write_text("bore: 80 mm\nrod: 45 mm\nstroke: 500 mm\nsupply_pressure: 200 bar\n"
                 "valve: {rated_flow: 60 L/min, rated_pressure_drop: 70 bar, bandwidth: 40 Hz}\n")
    env = gym.make(ENV, params=str(f), randomize=False)
    env.reset(seed=0)
    p = env.unwrapped.params
    assert (p.bore, p.rod, p.stroke, p.valve_bandwidth) == (0.08, 0.045, 0.5, 40.0)
    env = gym.make(ENV, params=str(f))
    masses = []
    for s in range(20):
        env.reset(seed=s)
        q = env.unwrapped.params
        assert q.bore == 0.08  # geometry is not drawn
        masses.append(q.mass / NOMINAL.mass)
        assert 0.9 * 60 / 60e3 <= q.rated_flow <= 1.1 * 60 / 60e3
    assert 1.0 <= min(masses) < max(masses) <= 2.0
    obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert np.all(np.isfinite(obs))
    # a rig without stiction data (F_S = F_C) is randomised too: F_S >= F_C at every corner
    env = gym.make(ENV, params={"friction": {"coulomb": "100 N", "static": "100 N"}})
    env.reset(seed=3)
    assert env.unwrapped.params.static_friction >= env.unwrapped.params.coulomb_friction


def _run(params, command, duration=0.4, x0=0.01):
    dt = 1e-4
    y0 = dc.rest_state(params, x0)
    return simulate(SPEC, params, np.full((int(round(duration / dt)), 1), command), y0, dt)


def test_speed_ratio_of_a_constant_command_run():
    # no friction: the analytic no-load speeds of the orifice law with the force balance
    p = dataclasses.replace(NOMINAL, coulomb_friction=0.0, static_friction=0.0, viscous_friction=0.0)
    v_out = _run(p, p.command_max, x0=0.01)[-1, dc.V]
    v_in = _run(p, -p.command_max, x0=p.stroke - 0.01)[-1, dc.V]
    assert v_out == pytest.approx(dc.no_load_velocity(p, 1), rel=2e-3)
    assert -v_in == pytest.approx(dc.no_load_velocity(p, -1), rel=2e-3)
    assert v_out / -v_in == pytest.approx(1 / math.sqrt(p.area_ratio), rel=3e-3)


def test_validation_rows_pass():
    rows = SPEC.validation_rows()
    assert len(rows) == 3 and all(r.kind == "consistency" for r in rows)
    for r in rows:
        assert r.passed, (r.name, r.published, r.reproduced)


def test_rest_state_is_at_rest_under_load():
    p = dataclasses.replace(NOMINAL, load_force=5e3, coulomb_friction=0.0, static_friction=0.0)
    y = dc.rest_state(p, 0.1)
    d = np.zeros(dc.N_STATES)
    dc.differential_cylinder_rhs(y, np.zeros(1), p.to_array(), d)
    assert abs(d[dc.V]) < 1e-9 and d[dc.P1] == 0.0 and d[dc.P2] == 0.0
    # gauge balance: A1 (p1 - p_amb) = A2 (p2 - p_amb) + F_L
    amb = p.ambient_pressure
    assert p.piston_area * (y[dc.P1] - amb) == pytest.approx(p.annulus_area * (y[dc.P2] - amb) + 5e3, rel=1e-12)


def test_controllers_track_and_the_compensation_evens_the_directions():
    from agents.controllers import make_controller

    env = gym.make(ENV, randomize=False)
    rmse = {}
    for name in ("pid", "pid_vff_arc", "pid_vff_arc_stribeck"):
        errs = []
        for seed in (0, 1):
            ctrl = make_controller(ENV, name)
            obs, _ = env.reset(seed=seed, options={"reference": "sine"})
            e = []
            for _ in range(1500):
                a, _ = ctrl.predict(obs)
                obs, *_ = env.step(a)
                e.append(obs[0] * 0.01)
            errs.append(np.sqrt(np.mean(np.square(e[300:]))))
        rmse[name] = float(np.mean(errs))
    assert rmse["pid"] < 5e-3
    assert rmse["pid_vff_arc"] < 0.7 * rmse["pid"]


def test_cli_simulate_and_benchmark_take_a_parameter_file(tmp_path, capsys):
    from hydro_envs.cli import main as hydro_main
    from hydro_envs.data.measured import load_measured

    rig = tmp_path / "rig.yaml"
    rig.write_text("bore: 80 mm\nrod: 45 mm\nstroke: 400 mm\nmass: 60 kg\n")
    out = tmp_path / "rec.csv"
    assert hydro_main(["simulate", ENV, "--params", str(rig), "--nominal", "--steps", "50", "--policy", "prbs",
                       "--out", str(out)]) == 0
    meta = load_measured(out).metadata
    assert meta["param.bore"].startswith("0.08 ") and meta["param.stroke"].startswith("0.4 ")
    bad = tmp_path / "bad.yaml"
    bad.write_text("bore: 80 kg\n")
    assert hydro_main(["simulate", ENV, "--params", str(bad), "--steps", "5", "--out", str(tmp_path / "b.csv")]) == 2
    assert "bore" in capsys.readouterr().err
    assert hydro_main(["benchmark", "--env", ENV, "--controllers", "pid,pid_vff_arc_stribeck", "--params",
                       f"{rig},nominal", "--n", "2", "--steps", "300", "--no-figures"]) == 0
    assert "| pid_vff_arc_stribeck |" in capsys.readouterr().out
    assert hydro_main(["benchmark", "--env", ENV, "--params", "sideways", "--n", "2"]) == 2
    assert "nominal, in, out" in capsys.readouterr().err


def test_identify_friction_recovers_coulomb_and_viscous_with_both_areas(tmp_path, capsys):
    import json

    from hydro_envs.cli import main as hydro_main
    from hydro_envs.data.measured import write_measured
    from hydro_envs.plants.differential_cylinder.friction_test import friction_record
    from identification.constant_velocity import friction_points_from_square_wave
    from identification.friction import fit_friction

    truth = dataclasses.replace(NOMINAL, coulomb_friction=150.0, static_friction=200.0, viscous_friction=900.0,
                                stribeck_velocity=0.008)
    record = friction_record(truth)
    path = write_measured(tmp_path / "fr.csv", record)
    assert hydro_main(["identify", "friction", "--plant", "differential_cylinder", "--data", str(path),
                       "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)["parameters"]
    assert fit["F_c"] == pytest.approx(150.0, rel=0.05) and fit["F_v"] == pytest.approx(900.0, rel=0.05)
    # from the parameter file's geometry too
    assert hydro_main(["identify", "friction", "--plant", "differential_cylinder", "--data", str(path), "--json",
                       "--params", RIG_FILE]) == 0
    assert json.loads(capsys.readouterr().out)["parameters"]["F_c"] == pytest.approx(150.0, rel=0.05)
    # the equal-area formula F = A1 (p1 - p2) does not: the rod side's 20 % smaller area is a force
    # of the annulus pressure, not friction
    # (a 10 kN pressure force whose sign follows the motion: the fit is refused as unidentifiable)
    from identification.friction.data import UnidentifiableError

    try:
        wrong = fit_friction(friction_points_from_square_wave(record, truth.piston_area),
                             model="coulomb_viscous").parameters
    except UnidentifiableError:
        pass
    else:
        assert abs(wrong["F_c"] / 150.0 - 1.0) > 0.05 or abs(wrong["F_v"] / 900.0 - 1.0) > 0.05
    assert hydro_main(["identify", "friction", "--plant", "differential_cylinder", "--data", str(path),
                       "--area", "0.003"]) == 2
    assert "two areas" in capsys.readouterr().err


def _linear_plant(p, x):
    from agents.controllers.differential_cylinder_tuning import linear_rig

    return linear_rig(p, x)


def _loops(nominal):
    """The rule's loops tuned on ``nominal`` (agents.controllers.differential_cylinder)."""
    from agents.controllers.differential_cylinder import CROSSOVER_RATIO, K_DP, P_CROSSOVER_RATIO, P_K_DP, pid_tuning
    from agents.controllers.differential_cylinder_tuning import loop_set

    p_bandwidth = P_CROSSOVER_RATIO * pid_tuning(nominal)["omega_h"]
    return loop_set(nominal, CROSSOVER_RATIO, K_DP, p_bandwidth, P_K_DP)


def test_classical_loops_are_stable_without_dry_friction_over_the_randomisation():
    from agents.controllers.margins import loop_margins
    from hydro_envs.randomization import load_randomization

    spec = load_randomization("differential_cylinder", DifferentialCylinderParams)
    rng = np.random.default_rng(3)
    corners = [NOMINAL, spec.corner(False), spec.corner(True)] + [
        spec.corner(rng.integers(0, 2, len(spec.entries)).astype(bool)) for _ in range(6)]
    worst = {}
    for p in corners:
        for x in (dc.minimum_natural_frequency_position(p), 0.5 * p.stroke, 0.9 * p.stroke):
            Ad, Bd, C = _linear_plant(p, x)
            for name, ctrl in _loops(NOMINAL).items():
                m = loop_margins(Ad, Bd, C, ctrl, 1e-3)
                assert m.stable, (name, x, m)
                worst[name] = min(worst.get(name, np.inf), m.gain_margin_db)
    assert worst["p x1.00"] >= 15.0 and min(worst["pid x1.00"], worst["pid x1.22"]) >= 10.0, worst


def test_greybox_round_trip_through_the_cli_recovers_mass_bulk_modulus_and_viscous_friction(tmp_path, capsys):
    # hydro simulate (PRBS valve steps, a rig from a parameter file) -> file -> hydro identify
    # greybox from a start 20-30 % off; the geometry comes from the file's param.NAME metadata
    import json

    from hydro_envs.cli import main as hydro_main

    rig = tmp_path / "rig.yaml"
    rig.write_text("bore: 50 mm\nrod: 28 mm\nstroke: 200 mm\nmass: 25 kg\nbulk_modulus: 1.0 GPa\n"
                   "friction: {viscous: 800 N s/m}\n")
    rec = tmp_path / "rec.csv"
    assert hydro_main(["simulate", ENV, "--params", str(rig), "--nominal", "--steps", "1500", "--policy", "prbs",
                       "--amplitude", "0.3", "--out", str(rec)]) == 0
    true = {"mass": 25.0, "bulk_modulus": 1.0e9, "viscous_friction": 800.0}
    start = {k: v * f for (k, v), f in zip(true.items(), (1.3, 0.8, 1.2))}
    argv = ["identify", "greybox", "--plant", "differential_cylinder", "--data", str(rec), "--json",
            "--fit", ",".join(start)] + [a for k, v in start.items() for a in ("--set", f"{k}={v!r}")]
    capsys.readouterr()
    assert hydro_main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    for name, value in true.items():
        assert out["parameters"][name] == pytest.approx(value, rel=0.03), name


def test_the_plant_gives_what_the_registry_sim_envs_and_identification_ask():
    from hydro_envs.contract import conformance_problems

    model, params_cls = SPEC.contract, SPEC.params_cls
    assert conformance_problems(SPEC) == []  # the typed contract (tests/test_plant_contract.py for every plant)
    assert model.rest_state is not None and model.rest_state_from_measurement is not None
    assert model.fit_outputs == ("x", "p1", "p2") and model.load_params is load_rig
    assert set(params_cls.geometry) <= set(params_cls.names())
    assert set(SPEC.dry_friction_parameters) <= set(params_cls.names())
    # the kernel row's columns are the fields and the derived names, the indices generated from them
    from hydro_envs.plants.differential_cylinder import params as pm

    assert NOMINAL.to_array().shape == (pm.N_PARAMS,)
    for name, col in (("stroke", pm.I_L), ("supply_pressure", pm.I_PS), ("command_max", pm.I_UMAX)):
        assert NOMINAL.to_array()[col] == getattr(NOMINAL, name)
    assert NOMINAL.to_array()[pm.I_A1] == NOMINAL.piston_area and NOMINAL.to_array()[pm.I_A2] == NOMINAL.annulus_area
