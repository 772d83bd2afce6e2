"""Calibration end to end: an identify result -> a randomisation spec -> gym.make(env, randomization=FILE).

For every plant with an env a fit result is turned into a spec (identification.ranges), written,
loaded by the env, and the env's draws are checked against the written ranges; ranges beyond
a parameter's physical bounds are clipped; the ``--emit-ranges`` flag works (or refuses with a
clear message) on every identify method.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs import registry
from identification import cli, ranges
from identification.friction import FrictionPoints, fit_friction

DATA = Path(__file__).parent / "data"
SEAL_FILE = DATA / "pneumatic_seal_friction" / "X-ring257_5bar.csv"


def _friction_points(F_c, F_v, seed=0):
    """Coulomb + viscous friction at 24 speeds in both directions, 1 % force noise."""
    rng = np.random.default_rng(seed)
    v = np.concatenate([np.geomspace(0.005, 0.2, 12), -np.geomspace(0.005, 0.2, 12)])
    f = np.sign(v) * F_c + F_v * v
    return FrictionPoints(v, f * (1.0 + 0.01 * rng.standard_normal(v.size)))


def _friction_result(plant, scale=1.1, extra_fields=("coulomb_friction", "viscous_friction")):
    """A coulomb_viscous fit of a rig whose friction is ``scale`` x the plant's nominal."""
    nom = registry.get(plant).params_cls()
    F_c = scale * getattr(nom, extra_fields[0])
    F_v = scale * getattr(nom, extra_fields[1])
    fit = fit_friction(_friction_points(F_c, F_v), model="coulomb_viscous")
    return {"method": "friction", "parameters": fit.parameters, "std_errors": fit.std_errors,
            "units": fit.units}, (F_c, F_v)


def _env_draws_inside(env_id, path, n=4):
    spec = yaml.safe_load(Path(path).read_text())
    env = gym.make(env_id, randomization=str(path))
    for seed in range(n):
        obs, info = env.reset(seed=seed)
        assert np.all(np.isfinite(obs))
        for name, e in spec["parameters"].items():
            lo, hi = e["range"]
            assert lo <= info["params"][name] <= hi, (name, info["params"][name], lo, hi)
        obs, r, term, trunc, _ = env.step(env.action_space.sample() * 0.0)
        assert np.all(np.isfinite(obs)) and math.isfinite(float(r))
    env.close()
    return spec


def _env_of(plant):
    return registry.get(plant).envs[0].id


@pytest.mark.parametrize("plant", ["servo_cylinder", "rodless_cylinder", "shaking_table"])
def test_friction_fit_calibrates_each_cylinder_env(tmp_path, plant):
    res, (F_c, F_v) = _friction_result(plant)
    path = ranges.write_spec_from_result(tmp_path / "spec.yaml", res, plant, data_file="rig.csv",
                                         fit_description="test fit")
    spec = _env_draws_inside(_env_of(plant), path)
    assert set(spec["parameters"]) == {"coulomb_friction", "viscous_friction"}
    assert spec["plant"] == plant
    for field, truth in (("coulomb_friction", F_c), ("viscous_friction", F_v)):
        lo, hi = spec["parameters"][field]["range"]
        assert lo <= truth <= hi  # the rig's value is inside its calibrated range
        assert "rig.csv" in spec["parameters"][field]["source"]


def test_force_actuator_with_an_explicit_field_map(tmp_path):
    res, (F_c, F_v) = _friction_result("force_actuator", extra_fields=("coulomb_friction", "damping_linear"))
    with pytest.raises(ranges.RangesError):  # F_v has no default field here: only F_c maps ...
        ranges.spec_from_result(res, "force_actuator", field_map={"F_v": "no_such_field"})
    path = ranges.write_spec_from_result(tmp_path / "fa.yaml", res, "force_actuator",
                                         field_map={"F_v": "damping_linear"})
    spec = _env_draws_inside(_env_of("force_actuator"), path)
    assert set(spec["parameters"]) == {"coulomb_friction", "damping_linear"}
    lo, hi = spec["parameters"]["damping_linear"]["range"]
    assert lo <= F_v <= hi


def test_load_sensing_from_a_greybox_result(tmp_path):
    # the grey-box result schema: parameters named by the plant's fields
    nom = registry.get("load_sensing").params_cls()
    res = {"method": "greybox",
           "parameters": {"viscous_friction_40c": 1.2 * nom.viscous_friction_40c, "spring_preload": nom.spring_preload},
           "std_errors": {"viscous_friction_40c": 0.1 * nom.viscous_friction_40c, "spring_preload": 0.5},
           "units": {"viscous_friction_40c": "N s/m", "spring_preload": "N"}}
    path = ranges.write_spec_from_result(tmp_path / "ls.yaml", res, "load_sensing")
    spec = _env_draws_inside(_env_of("load_sensing"), path, n=2)
    lo, hi = spec["parameters"]["viscous_friction_40c"]["range"]
    assert lo == pytest.approx(nom.viscous_friction_40c)  # widened down to the nominal (1.2 - 2 x 0.1 = 1.0)
    assert hi == pytest.approx(1.4 * nom.viscous_friction_40c)
    assert spec["parameters"]["spring_preload"]["range"] == pytest.approx([nom.spring_preload - 1.0,
                                                                          nom.spring_preload + 1.0])


def test_ranges_beyond_the_physical_bounds_are_clipped(tmp_path):
    # viscous friction 50 +- 100 N s/m: 2 SE below is -150, clipped to the allowed 0;
    # Stribeck velocity 0.5 +- 1 m/s: clipped to the allowed [1e-5, 1] m/s
    res = {"method": "greybox", "parameters": {"viscous_friction": 50.0, "stribeck_velocity": 0.5},
           "std_errors": {"viscous_friction": 100.0, "stribeck_velocity": 1.0},
           "units": {"viscous_friction": "N s/m", "stribeck_velocity": "m/s"}}
    spec, cls = ranges.spec_from_result(res, "servo_cylinder")
    vf = spec["parameters"]["viscous_friction"]
    assert vf["range"] == [0.0, 250.0]
    assert "clipped to the allowed [0, 100000]" in vf["source"]
    vs = spec["parameters"]["stribeck_velocity"]
    assert vs["range"] == [1e-5, 1.0]
    path = ranges.write_ranges(tmp_path / "clip.yaml", spec, cls)
    _env_draws_inside(_env_of("servo_cylinder"), path, n=3)


def test_unit_mismatch_and_unmapped_results_are_refused():
    res = {"method": "greybox", "parameters": {"mass": 12.0}, "std_errors": {"mass": 1.0}, "units": {"mass": "g"}}
    with pytest.raises(ranges.RangesError, match="unit 'g'"):
        ranges.spec_from_result(res, "servo_cylinder")
    arx = {"method": "arx", "parameters": {"a1": -0.9}, "std_errors": {"a1": 0.01}}
    with pytest.raises(ranges.RangesError, match="not parameters of a plant"):
        ranges.spec_from_result(arx, "servo_cylinder")
    with pytest.raises(ranges.RangesError, match="no parameter class"):
        ranges.spec_from_result({"method": "friction", "parameters": {"F_c": 1.0}, "std_errors": {"F_c": 0.1}},
                                "seal_friction")


def _cli(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


def test_every_identify_method_has_the_flag():
    for name in cli.METHODS:
        code, out, _ = _cli([name, "--help"])
        assert code == 0 and "--emit-ranges" in out and "--ranges-plant" in out, name


def test_seal_friction_cli_needs_a_target_plant_then_calibrates_it(tmp_path):
    base = ["friction", "--plant", "seal_friction", "--data", str(SEAL_FILE), "--bore", "0.0257",
            "--drop-rows", "5", "--model", "coulomb", "--emit-ranges", str(tmp_path / "s.yaml")]
    code, _, err = _cli(base)
    assert code == 2 and "--ranges-plant" in err and "no env" in err
    code, out, err = _cli(base + ["--ranges-plant", "rodless_cylinder", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["ranges_plant"] == "rodless_cylinder"
    spec = _env_draws_inside(_env_of("rodless_cylinder"), res["ranges_file"], n=2)
    lo, hi = spec["parameters"]["coulomb_friction"]["range"]
    assert lo <= res["parameters"]["F_c"] <= hi


def test_arx_flag_refuses_with_a_reason(tmp_path):
    t = np.arange(600) * 1e-3
    rng = np.random.default_rng(0)
    u = rng.standard_normal(t.size)
    y = np.convolve(u, [0.0, 1e-3, 5e-4])[: t.size]
    p = tmp_path / "r.csv"
    p.write_text("# plant: servo_cylinder\nt [s],u [V],x [m]\n"
                 + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist())))
    code, _, err = _cli(["arx", "--plant", "servo_cylinder", "--data", str(p), "--input", "u", "--output", "x",
                         "--orders", "1", "2", "1", "--emit-ranges", str(tmp_path / "a.yaml")])
    assert code == 2 and "not parameters of a plant" in err
    assert not (tmp_path / "a.yaml").exists()


def test_slider_friction_maps_to_the_named_cylinder_but_not_its_mass(tmp_path):
    nom = registry.get("servo_cylinder").params_cls()
    res = {"method": "slider",
           "parameters": {"mass": 95.0, "coulomb_friction": 1.05 * nom.coulomb_friction,
                          "viscous_friction": 0.95 * nom.viscous_friction, "force_offset": -3.0},
           "std_errors": {"mass": 0.5, "coulomb_friction": 1.0, "viscous_friction": 5.0, "force_offset": 0.2},
           "units": {"mass": "kg", "coulomb_friction": "N", "viscous_friction": "N s/m", "force_offset": "N"}}
    spec, _ = ranges.spec_from_result(res, "servo_cylinder")
    assert set(spec["parameters"]) == {"coulomb_friction", "viscous_friction"}
    spec, _ = ranges.spec_from_result(res, "servo_cylinder", field_map={"mass": "mass"})
    e = spec["parameters"]["mass"]
    assert e["range"] == [94.0, 96.0] and e["nominal"] == 95.0  # 95 +- 1, centred on the estimate


def test_greybox_cli_record_to_spec_to_env(tmp_path):
    """hydro simulate (nominal servo) -> hydro identify greybox --emit-ranges -> gym.make."""
    from hydro_envs.cli import main as hydro

    rec = tmp_path / "servo.csv"
    with contextlib.redirect_stdout(io.StringIO()):
        assert hydro(["simulate", "hydro_envs/ServoCylinderPosition-v0", "--steps", "1500", "--policy", "multisine",
                      "--nominal", "--seed", "1", "--out", str(rec)]) == 0
    out = tmp_path / "gb.yaml"
    code, text, err = _cli(["greybox", "--plant", "servo_cylinder", "--data", str(rec), "--fit",
                            "coulomb_friction,viscous_friction", "--emit-ranges", str(out), "--json"])
    assert code == 0, err
    res = json.loads(text)
    assert res["quality"]["ok"] is True
    nom = registry.get("servo_cylinder").params_cls()
    assert res["parameters"]["coulomb_friction"] == pytest.approx(nom.coulomb_friction, rel=0.03)
    spec = _env_draws_inside("hydro_envs/ServoCylinderPosition-v0", out, n=2)
    assert set(spec["parameters"]) == {"coulomb_friction", "viscous_friction"}


def test_frf_needs_an_explicit_map_then_calibrates(tmp_path):
    from scipy import signal

    fs, m, c, k = 1000.0, 700.0, 3.0e4, 4.0e6  # a table-like mass-spring-damper, force input
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    sysd = signal.cont2discrete((A, np.array([[0.0], [1.0 / m]]), np.array([[1.0, 0.0]]), np.array([[0.0]])),
                                1.0 / fs, method="zoh")
    u = 1e3 * np.random.default_rng(0).standard_normal(6000)
    _, y, _ = signal.dlsim((*sysd[:4], 1.0 / fs), u)
    p = tmp_path / "msd.csv"
    t = np.arange(u.size) / fs
    # a force input [N]: the slider's channel f (a servo valve's u [V] of +-4 kV is refused as implausible)
    p.write_text("# plant: slider\nt [s],f [N],x [m]\n"
                 + "".join(f"{a!r},{b!r},{c_!r}\n" for a, b, c_ in zip(t.tolist(), u.tolist(), y.ravel().tolist())))
    base = ["frf", "--plant", "slider", "--data", str(p), "--input", "f", "--output", "x",
            "--emit-ranges", str(tmp_path / "f.yaml"), "--ranges-plant", "shaking_table"]
    code, _, err = _cli(base)
    assert code == 2 and "not parameters of a plant" in err
    code, text, err = _cli(base + ["--ranges-map", "mass=platform_mass", "--json"])
    assert code == 0, err
    res = json.loads(text)
    assert res["parameters"]["mass"] == pytest.approx(m, rel=0.02)
    spec = _env_draws_inside("hydro_envs/ShakingTable-v0", tmp_path / "f.yaml", n=2)
    lo, hi = spec["parameters"]["platform_mass"]["range"]
    assert lo <= res["parameters"]["mass"] <= hi
    assert spec["parameters"]["platform_mass"].get("nominal", 650.0) == pytest.approx(
        min(max(res["parameters"]["mass"], lo), hi))
