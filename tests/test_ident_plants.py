"""Identification on the project's plants: the seeds' experiments run on
our simulators, and fit results turned into randomisation specs and presets.

* 004 sec. 4.2: closed-loop direct identification of the rodless cylinder, ARX(3, 3, 1)
  (eq (32)): the identified model has the integrator (a pole within 0.01 of z = 1).
* 001 sec. 4.5: ARX(10, 8, 3) (eq (6)) of the force actuator, piston locked, PRBS at 5 kHz.
* 000 methods 1 and 2: viscous coefficient c from virtual-rig Bode data within 5 %.
* identification.ranges: fit -> randomisation spec that the loader and the env accept.
"""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
import yaml

from hydro_envs.data.sensors import SensorModel

from hydro_envs.plants.force_actuator.experiments import prbs_locked

from hydro_envs.plants.ls_compensator.bode_fit import fit_compensator_viscous

from hydro_envs.plants.rodless_cylinder.experiments import closed_loop_m_sequence

from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
from identification import ranges
from identification.arx import SEED_004_EQ32, fit_arx

A6 = np.r_[1.0, -0.4223, -0.3765, -0.2802, -0.1959, 0.1930, 0.2234, -0.0532, -0.0051, -0.0903, 0.0394]


def test_closed_loop_m_sequence_arx3_has_the_integrator_of_004_eq32():
    d = closed_loop_m_sequence(position_noise_std=5e-6, seed=0)  # 2046 samples, 10 ms
    assert int(d["clamps"]) == 0
    assert np.all((d["u"] > 0.0) & (d["u"] < 10.0))  # the loop never saturated the valve
    y_mm = (d["y"] - d["y"].mean()) * 1e3
    m = fit_arx(y_mm, d["u"] - 5.0, SEED_004_EQ32["na"], SEED_004_EQ32["nb"], SEED_004_EQ32["nk"], dt=0.01)
    near = m.poles[np.argmin(np.abs(m.poles - 1.0))]
    assert abs(near - 1.0) < 0.01, m.poles  # eq (32): 0.9965
    assert abs(np.roots(SEED_004_EQ32["a"]) - 1.0).min() < 0.01  # the seed's own model too
    # the other poles are well inside the unit circle (the damped pneumatic mode)
    others = np.delete(m.poles, np.argmin(np.abs(m.poles - 1.0)))
    assert np.all(np.abs(others) < 0.9)
    # integrator gain = the plant's mid-stroke velocity gain K_T k_v (004 eqs (22), (28))
    from hydro_envs.plants.rodless_cylinder import model as rc

    lin = rc.linearize_mid_stroke(rc.RodlessCylinderParams())
    b1 = np.sum(m.b) / np.real(np.prod(1.0 - others))  # mm per V per sample
    gain = b1 / 0.01 * 1e-3  # m/s per V
    assert 0.3 * lin.k_t * lin.k_v < gain < 1.1 * lin.k_t * lin.k_v, (gain, lin.k_t * lin.k_v)
    assert m.fit_one_step > 95.0


def test_force_actuator_locked_prbs_arx10_as_001_eq6():
    d = prbs_locked(duration=2.0, amplitude=0.1, force_noise_std=0.5, seed=3)
    assert int(d["clamps"]) == 0
    n = int(0.7 * d["f"].size)
    y = d["f"] - d["f"][:n].mean()
    u = (d["i"] - d["i"][:n].mean()) * 1e3  # mA, as eq (6)'s N/mA gain suggests
    m = fit_arx(y[:n], u[:n], 10, 8, 3, dt=2e-4)
    v = m.validate(y[n:], u[n:])
    # threshold 85 %: hysteresis (5 % of rated current, 2x the PRBS amplitude's branch
    # slope change) and friction make the plant nonlinear; measured 91.7 %
    assert v["fit_free_run"] > 85.0, v
    # dominant (slowest) pole: the valve's slow stage, eq (7) pole 0.9762 (eq (6): 0.9762)
    slow = m.poles[np.argmax(np.abs(m.poles))]
    assert abs(slow.imag) < 1e-9 and abs(slow.real - 0.9762) < 0.015
    assert max(abs(np.roots(A6))) == pytest.approx(0.9762, abs=1e-3)


def test_viscous_coefficient_from_both_rig_methods_within_5_percent():
    from hydro_envs.plants.ls_compensator import model as lc
    from hydro_envs.plants.ls_compensator import experiments as rig

    p = lc.LSCompensatorParams()
    c_true = lc.derived(p)["viscous"]
    r1 = rig.run_method1(p, np.geomspace(30.0, 120.0, 5), amplitude=1e5, duration=0.6, settle=0.25)
    c1 = fit_compensator_viscous(r1)
    assert c1 == pytest.approx(c_true, rel=0.05)
    assert c1 == pytest.approx(rig.fit_viscous_coefficient(r1), rel=0.01)  # the rig's own fit
    speeds = 60.0 / rig.TEETH * np.array([200.0, 280.0, 300.0, 320.0, 400.0])
    r2 = rig.run_method2(p, speeds, duration=0.4, settle=0.15)
    c2 = fit_compensator_viscous(r2)
    c2_true = lc.derived(r2.params[0])["viscous"]
    assert c2 == pytest.approx(c2_true, rel=0.05)


SE = {"F_c": 0.27, "F_s": 0.47, "v_s": 7.5e-4, "F_v": 2.1}
EST = {"F_c": 39.5, "F_s": 60.5, "v_s": 0.0106, "F_v": 253.7}


def test_ranges_from_fit_load_and_env_draws_inside(tmp_path):
    import gymnasium as gym

    import hydro_envs  # noqa: F401  (registers the envs)
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.randomization import RandomizationSpec

    spec = ranges.ranges_from_fit(EST, SE, ServoCylinderParams, k=2.0, data_file="run.csv",
                                  fit_description="stribeck")
    path = ranges.write_ranges(tmp_path / "r.yaml", spec, ServoCylinderParams)
    loaded = RandomizationSpec.from_yaml(path, ServoCylinderParams)
    ent = {e.name: e for e in loaded.entries}
    assert ent["coulomb_friction"].low == pytest.approx(39.5 - 0.54)
    assert ent["viscous_friction"].high == pytest.approx(253.7 + 4.2)
    assert "run.csv" in ent["coulomb_friction"].source and ent["coulomb_friction"].mode == "absolute"
    # F_s = 60.5 +- 0.94 contains the nominal 60; v_s = 10.6 +- 1.5 mm/s contains 10 mm/s
    assert "widened" not in ent["static_friction"].source
    env = gym.make("hydro_envs/ServoCylinderPosition-v0", randomization=str(path))
    for seed in range(5):
        _, info = env.reset(seed=seed)
        for name, e in ent.items():
            assert e.low <= info["params"][name] <= e.high
    env.close()


def test_nominal_outside_the_confidence_region_is_declared_widened_or_raises(tmp_path):
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.randomization import RandomizationError, RandomizationSpec

    est = dict(EST, F_s=58.0)  # 58 +- 0.94 excludes the nominal 60 N
    spec = ranges.ranges_from_fit(est, SE, ServoCylinderParams)
    e = spec["parameters"]["static_friction"]
    assert e["range"][1] < 60.0 and e["nominal"] == 58.0 and "default 60 N lies outside" in e["source"]
    loaded = RandomizationSpec.from_mapping(spec, ServoCylinderParams)  # loads with its own nominal
    assert loaded.entries[[x.name for x in loaded.entries].index("static_friction")].nominal == 58.0
    bad = {**spec, "parameters": {**spec["parameters"], "static_friction": {**e, "nominal": 61.0}}}
    with pytest.raises(RandomizationError, match="static_friction.*61"):
        RandomizationSpec.from_mapping(bad, ServoCylinderParams)
    spec = ranges.ranges_from_fit(est, SE, ServoCylinderParams, on_nominal_outside="widen")
    e = spec["parameters"]["static_friction"]
    assert e["range"][1] == 60.0 and "widened to include the nominal 60" in e["source"]
    with pytest.raises(ranges.RangesError, match="static_friction"):
        ranges.ranges_from_fit(est, SE, ServoCylinderParams, on_nominal_outside="raise")


def test_cli_emit_ranges_from_a_virtual_friction_experiment(tmp_path):
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.randomization import RandomizationSpec
    from identification.cli import main

    data = tmp_path / "friction.csv"
    run_friction_experiment(sensors=SensorModel.realistic(), seed=0, path=data, duration=40.0,
                              amplitude_start=0.05, period_max=3.0)
    out = tmp_path / "ranges.yaml"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["friction", "--plant", "servo_cylinder", "--data", str(data), "--json",
                   "--emit-ranges", str(out)])
    assert rc == 0
    res = json.loads(buf.getvalue())
    assert res["ranges_file"] == str(out)
    spec = RandomizationSpec.from_yaml(out, ServoCylinderParams)
    assert set(spec.names) == {"coulomb_friction", "static_friction", "stribeck_velocity", "viscous_friction"}
    for e in spec.entries:
        assert "friction.csv" in e.source
    # the loader accepted it: each range holds its nominal -- the plant's default where the
    # confidence region contains it, else the estimate, declared with the default it departs from
    # (the constant-velocity method's stick-slip bias moves F_s and v_s of this plant)
    nominal = ServoCylinderParams()
    for e in spec.entries:
        default = getattr(nominal, e.name)
        if e.low <= default <= e.high:
            assert "lies outside" not in e.source
        else:
            assert "lies outside this range" in e.source and e.low <= e.nominal <= e.high


@pytest.mark.parametrize("name", ["servo_cylinder_nominal", "servo_cylinder_virtual_friction",
                                  "rodless_cylinder_nominal"])
def test_plant_presets_load_with_sources(name):
    from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.config_files import config_file

    plant, _, preset = name.partition("_cylinder_")
    path = config_file("plants", f"{plant}_cylinder", "presets", f"{preset}.yaml")
    cls = RodlessCylinderParams if name.startswith("rodless") else ServoCylinderParams
    p = ranges.load_preset(path, cls)
    raw = yaml.safe_load(path.read_text())
    assert raw["source"] and all(v["source"] for v in raw["parameters"].values())
    if name.endswith("nominal"):
        assert p == cls()
    else:  # calibrated friction within 10 % of the plant that made the data (F_s biased low
        # by the friction limit cycle, see hydro_envs/plants/servo_cylinder/friction_test.py)
        n = cls()
        for f in ("coulomb_friction", "static_friction", "stribeck_velocity", "viscous_friction"):
            assert getattr(p, f) == pytest.approx(getattr(n, f), rel=0.1)
