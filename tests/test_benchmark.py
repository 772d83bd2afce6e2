"""agents/benchmark.py: frozen draws, metrics against hand-computed values, outputs, CLI."""

import csv
import math

import numpy as np
import pytest

import hydro_envs  # noqa: F401
from agents import benchmark as bm
from hydro_envs.cli import main as hydro_main
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.randomization import load_randomization

SERVO = "hydro_envs/ServoCylinderPosition-v0"


# ------------------------------------------------------------------ metrics on synthetic traces
def test_step_metrics_hand_computed():
    dt = 0.01
    r = np.r_[np.zeros(10), np.ones(40)]  # one jump 0 -> 1 at index 10
    y = np.zeros(50)
    # rise, overshoot to 1.2 at index 14, then within the 2 % band from index 25 on
    y[10:15] = [0.3, 0.7, 1.0, 1.15, 1.2]
    y[15:25] = np.linspace(1.1, 1.03, 10)  # still outside +-0.02
    y[25:] = 1.01
    over, settle, jumps = bm.step_metrics(y, r, dt)
    assert jumps == 1
    assert over == pytest.approx(20.0)  # (1.2 - 1) / 1 * 100
    # last sample outside the band is index 24 -> settled at (24 + 1 - 10) samples = 0.15 s
    assert settle == pytest.approx(0.15)
    # a downward step that never overshoots and settles immediately
    r2 = np.r_[np.ones(5), np.zeros(5)]
    y2 = np.r_[np.ones(5), np.zeros(5)]
    assert bm.step_metrics(y2, r2, dt)[:2] == (0.0, 0.0)
    # no jump: NaN
    o, s, k = bm.step_metrics(np.zeros(5), np.zeros(5), dt)
    assert k == 0 and math.isnan(o) and math.isnan(s)


def test_cvar_and_confidence_intervals():
    v = np.arange(1.0, 21.0)  # 20 values: the worst 10 % are 20 and 19
    assert bm.cvar(v, 0.1) == pytest.approx(19.5)
    assert bm.cvar(np.arange(1.0, 11.0), 0.1) == pytest.approx(10.0)
    assert bm.cvar([3.0, np.nan, 1.0], 0.1) == pytest.approx(3.0)
    m, lo, hi = bm.mean_ci([1.0, 2.0, 3.0, 4.0])
    # t(0.975, 3) = 3.1824, s = 1.2910: half width 3.1824 * 1.2910 / 2 = 2.0542
    assert m == pytest.approx(2.5)
    assert hi - m == pytest.approx(2.0542, abs=1e-3) and m - lo == pytest.approx(2.0542, abs=1e-3)
    p, lo, hi = bm.wilson_ci(0, 20)
    assert p == 0.0 and lo == 0.0 and 0.1 < hi < 0.2  # Wilson: 0.161
    p, lo, hi = bm.wilson_ci(5, 20)
    assert lo < p < hi
    s, lo, hi = bm.bootstrap_ci(v, bm.cvar, seed=0)
    assert lo <= s <= hi


def test_episode_metrics_on_synthetic_rollout():
    steps, n = 100, 2
    t = np.arange(steps)
    ref = np.stack([np.ones(steps), 2.0 * np.ones(steps)], axis=1)
    y = np.stack([1.0 - 0.5 * (t < 20), np.zeros(steps)], axis=1)  # copy 1 never moves
    acts = np.zeros((steps, n, 1))
    acts[:, 0, 0] = 0.5
    ro = bm.Rollout(y, ref, acts, np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.zeros((n, 3)), 1e-3)
    m = bm.episode_metrics(ro, None, bm.ADAPTERS[SERVO])
    assert m["rmse"][0] == pytest.approx(math.sqrt(20 * 0.25 / 100))
    assert m["max_error"][0] == pytest.approx(0.5)
    assert m["effort"][0] == pytest.approx(0.5) and m["effort"][1] == 0.0
    # copy 1 holds still: RMSE equals the hold-still RMSE -> failure
    assert m["failed"].tolist() == [0.0, 1.0]


# ------------------------------------------------------------------ draws
def test_draws_in_inside_out_outside_and_reproducible():
    spec = load_randomization("servo_cylinder", ServoCylinderParams)
    nominal = ServoCylinderParams()
    d_in = bm.draw_parameters(SERVO, "in", 30, seed=3)
    d_out = bm.draw_parameters(SERVO, "out", 30, seed=3)
    assert d_in == bm.draw_parameters(SERVO, "in", 30, seed=3)
    assert d_in != bm.draw_parameters(SERVO, "in", 30, seed=4)
    assert bm.draw_parameters(SERVO, "nominal", 3) == [{}, {}, {}]
    for e in spec.entries:
        lo, hi = e.value_range(getattr(nominal, e.name))
        wlo, whi = e.widened(bm.OUT_FACTOR).value_range(getattr(nominal, e.name))
        vin = np.array([d[e.name] for d in d_in])
        vout = np.array([d[e.name] for d in d_out])
        assert np.all((vin >= lo) & (vin <= hi)), e.name
        assert np.all((vout < lo) | (vout > hi)), e.name
        assert np.all((vout >= wlo - 1e-12 * abs(wlo)) & (vout <= whi + 1e-12 * abs(whi))), e.name
    for d in d_out:  # every out draw is a valid parameter set
        ServoCylinderParams.from_mapping(d)


def test_bad_names_raise_naming_field_and_allowed():
    with pytest.raises(ValueError, match=r"params.*'bogus'.*nominal.*in.*out"):
        bm.draw_parameters(SERVO, "bogus", 2)
    with pytest.raises(ValueError, match=r"params.*nominal"):
        bm.run_benchmark(SERVO, ["pid"], params="inside", n=2)
    with pytest.raises(ValueError, match=r"controllers: unknown controller 'pdi'.*pid_ff_stribeck.*sb3:RUN_DIR"):
        bm.run_benchmark(SERVO, ["pdi"], n=2)
    with pytest.raises(ValueError, match=r"env.*supports"):
        bm.run_benchmark("hydro_envs/Nope-v0", ["pid"], n=2)
    with pytest.raises(ValueError, match=r"n must be an integer >= 1"):
        bm.draw_parameters(SERVO, "in", 0)
    other = _StandIn(0.1)
    other.env_id = "hydro_envs/RodlessCylinder-v0"
    with pytest.raises(ValueError, match=r"sb3:runs/x_s0 was trained on hydro_envs/RodlessCylinder-v0"):
        bm.run_benchmark(SERVO, ["sb3:runs/x_s0"], n=1, episode_steps=5, policy_loader=lambda run: other)


# ------------------------------------------------------------------ benchmark runs
class _StandIn:
    """A stand-in for agents.policies.load_trained(run_dir): P control with a seed-dependent gain."""

    def __init__(self, gain):
        self.gain = gain

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs)
        return np.clip(self.gain * obs[..., :1], -1, 1).astype(np.float32), state


def test_same_draws_for_all_controllers_outputs_and_seed_pooling(tmp_path):
    loaded = []

    def loader(run):
        loaded.append(run)
        return _StandIn(0.1 if run.endswith("s0") else 0.2)

    res = bm.run_benchmark(SERVO, ["zero", "pid", "sb3:runs/sac_servo_s0", "sb3:runs/sac_servo_s1"],
                           params="in", n=3, seed=5, out_dir=tmp_path, episode_steps=60,
                           policy_loader=loader, figures=True)
    assert loaded == ["runs/sac_servo_s0", "runs/sac_servo_s1"]
    assert list(res.summary) == ["zero", "pid", "sac_servo"]
    assert res.members == {"zero": 1, "pid": 1, "sac_servo": 2}
    assert res.episodes["sac_servo"]["rmse"].size == 6  # 3 draws x 2 training seeds
    # identical parameter arrays for every controller, equal to the frozen draws
    arrays = list(res.param_arrays.values())
    for a in arrays[1:]:
        np.testing.assert_array_equal(a, arrays[0])
    names = ServoCylinderParams.names()
    for i, d in enumerate(res.draws):
        for k, v in d.items():
            assert arrays[0][i, names.index(k)] == v
    # paired ratio to the PID on the same draw (the stand-in's 2 seeds both map onto draws 0..2)
    np.testing.assert_array_equal(res.episodes["pid"]["rmse_rel_pid"], 1.0)
    pid = res.episodes["pid"]["rmse"]
    np.testing.assert_allclose(res.episodes["sac_servo"]["rmse_rel_pid"],
                               res.episodes["sac_servo"]["rmse"] / np.r_[pid, pid])
    # CI contains the mean; CVaR >= mean RMSE
    for c, s in res.summary.items():
        for key, (m, lo, hi, k) in s.items():
            if np.isfinite(m):
                assert lo <= m <= hi, (c, key)
        assert s["cvar10_rmse"][0] >= s["rmse"][0] - 1e-15
    # files: markdown, CSV summary (parsable, one row per controller and metric), figures
    stems = {p.name for p in res.files}
    assert {"servo_cylinder_in.md", "servo_cylinder_in.csv", "servo_cylinder_in_episodes.csv",
            "servo_cylinder_in_draws.csv", "servo_cylinder_in_box.png", "servo_cylinder_in_traces.png"} <= stems
    rows = list(csv.DictReader((tmp_path / "servo_cylinder_in.csv").open()))
    assert len(rows) == 3 * len(bm.METRICS)
    r = next(x for x in rows if x["controller"] == "pid" and x["metric"] == "rmse")
    assert float(r["value"]) == pytest.approx(res.summary["pid"]["rmse"][0])
    md = (tmp_path / "servo_cylinder_in.md").read_text()
    assert "| pid |" in md and "sac_servo (2 seeds)" in md
    ep = list(csv.DictReader((tmp_path / "servo_cylinder_in_episodes.csv").open()))
    assert len(ep) == 3 + 3 + 6


def test_cli_with_config(tmp_path, capsys):
    cfg = tmp_path / "b.yaml"
    cfg.write_text(
        "env: hydro_envs/ServoCylinderPosition-v0\ncontrollers: [zero, pid]\nparams: [nominal]\n"
        "n: 2\nseed: 0\nepisode_steps: 40\n"
    )
    rc = hydro_main(["benchmark", "--config", str(cfg), "--out", str(tmp_path / "out"), "--no-figures"])
    assert rc == 0
    assert (tmp_path / "out" / "servo_cylinder_nominal.csv").exists()
    assert "| pid |" in capsys.readouterr().out
    rc = hydro_main(["benchmark", "--env", SERVO, "--controllers", "pid", "--params", "sideways", "--n", "2"])
    assert rc == 2
    assert "nominal, in, out" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("env: hydro_envs/ServoCylinderPosition-v0\nepisodes: 3\n")
    assert hydro_main(["benchmark", "--config", str(bad)]) == 2
    assert "unknown key(s) ['episodes']" in capsys.readouterr().err


def test_shipped_configs_are_valid():
    from pathlib import Path

    from agents.controllers import controller_names

    files = sorted((Path(__file__).resolve().parents[1] / "agents" / "configs" / "benchmarks").glob("*.yaml"))
    assert len(files) == 9
    envs = set()
    for f in files:
        c = bm.load_config(f)
        envs.add(c["env"])
        assert set(c["controllers"]) <= set(controller_names(c["env"]))
        assert set(c["params"]) == set(bm.PARAM_SETS)
        assert c["n"] == 20
    assert envs == set(bm.ADAPTERS)


@pytest.mark.parametrize("env_id", sorted(bm.ADAPTERS))
def test_every_env_runs_with_same_draws(env_id):
    names = ["zero", "pid"] if env_id != "hydro_envs/LoadSensing-v0" else ["passive", "pid"]
    # >= 100 steps: LoadSensing's generate_demand fails for episodes shorter than its 0.1-0.3 s rest
    res = bm.run_benchmark(env_id, names, params="out", n=2, seed=1, episode_steps=150)
    a, b = res.param_arrays.values()
    np.testing.assert_array_equal(a, b)
    for c in names:
        assert np.all(np.isfinite(res.episodes[c]["rmse"]))
        assert np.all(np.isfinite(res.episodes[c]["effort"]))
    if bm.ADAPTERS[env_id].step_reference is None:  # the shaking table: overshoot/settling n/a
        assert np.all(np.isnan(res.episodes["pid"]["overshoot"]))
    if bm.ADAPTERS[env_id].pressures is None:  # the force actuator: no chamber pressures
        assert np.all(np.isnan(res.episodes["pid"]["pressure_violations"]))


def test_configs_resolve_by_name_from_any_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("servo_cylinder", "rodless_cylinder_slow_sine.yaml"):
        assert bm.load_config(name)["env"].startswith("hydro_envs/")
    assert bm._policy_path("agents/pretrained/servo_cylinder/ppo_s0").startswith(str(bm.Path(bm.__file__).resolve().parents[1]))
    with pytest.raises(FileNotFoundError, match="shipped: force_actuator"):
        bm.load_config("no_such_config")
