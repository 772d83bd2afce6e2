"""agents/benchmark.py: frozen draws, metrics against hand-computed values, outputs, CLI."""

import csv
import math

import numpy as np
import pytest

import hydro_envs  # noqa: F401
from agents import benchmark as bm
from agents import benchmark_cli as bcli
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
    # Wilson score interval, z = 1.95996: 0/20 -> [0, z^2 / (n + z^2)] = [0, 0.16113]
    p, lo, hi = bm.wilson_ci(0, 20)
    assert p == 0.0 and lo == 0.0 and hi == pytest.approx(1.95996**2 / (20 + 1.95996**2), rel=1e-5)
    # 5/20: centre (p + z^2/2n) / (1 + z^2/n), half width z sqrt(p q / n + z^2 / 4n^2) / (1 + z^2/n)
    z = 1.959963985
    c = (0.25 + z * z / 40) / (1 + z * z / 20)
    h = z * math.sqrt(0.25 * 0.75 / 20 + z * z / 1600) / (1 + z * z / 20)
    p, lo, hi = bm.wilson_ci(5, 20)
    assert p == 0.25 and lo == pytest.approx(c - h, rel=1e-9) and hi == pytest.approx(c + h, rel=1e-9)
    s, lo, hi = bm.bootstrap_ci(v, bm.cvar, seed=0)
    assert lo <= s <= hi


def test_draw_bootstrap_is_nonnegative_seeded_and_about_the_standard_error():
    # zero-inflated counts: the Student-t interval of these goes below zero, the bootstrap not
    v = np.r_[np.zeros(18), 30.0, 50.0]
    m, lo, hi, k = bm.draw_bootstrap_ci(v, seed=3)
    assert (m, k) == (4.0, 20) and lo >= 0.0 and hi > m
    assert bm.draw_bootstrap_ci(v, seed=3) == (m, lo, hi, k)  # deterministic
    # normal data: half width ~ 1.96 s / sqrt(n) (s = 1, n = 400: 0.098)
    x = np.random.default_rng(0).normal(5.0, 1.0, 400)
    m, lo, hi, _ = bm.draw_bootstrap_ci(x, seed=0)
    assert m == pytest.approx(np.mean(x))
    assert (hi - lo) / 2 == pytest.approx(1.96 * np.std(x, ddof=1) / 20, rel=0.1)
    assert bm.draw_bootstrap_ci(x, seed=1) != (m, lo, hi, 400)  # the seed drives the resamples
    # constant data and one draw: zero width; NaNs are skipped; no finite value: NaN
    assert bm.draw_bootstrap_ci([2.0, 2.0, 2.0])[:3] == (2.0, 2.0, 2.0)
    assert bm.draw_bootstrap_ci([1.0, np.nan, 3.0], seed=0)[0] == 2.0
    assert math.isnan(bm.draw_bootstrap_ci([np.nan])[0])
    with pytest.raises(ValueError, match=r"n_draws = 3; must divide the 4 episodes"):
        bm.draw_bootstrap_ci(np.ones(4), 3)


def test_paired_ratio_interval_resamples_whole_draws():
    # two training seeds on 4 draws: episode j belongs to draw j % 4. The ratio of draw 0 is
    # 1 for both seeds and of draws 1..3 is 0.5: any resample's mean lies in [0.5, 1].
    ratio = np.r_[1.0, 0.5, 0.5, 0.5, 1.0, 0.5, 0.5, 0.5]
    m, lo, hi, _ = bm.draw_bootstrap_ci(ratio, 4, seed=0)
    assert m == pytest.approx(0.625) and 0.5 <= lo < m < hi <= 1.0
    # resampling whole draws: a resample mean is a multiple of 1/8 (k draws of 1 among 4),
    # resampling single episodes would also give multiples of 1/16
    boots_lo_hi = np.array([lo, hi])
    assert np.allclose(np.round(boots_lo_hi * 8) / 8, boots_lo_hi)


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

    files = sorted((Path(__file__).resolve().parents[1] / "configs" / "benchmarks").glob("*.yaml"))
    assert len(files) == 14  # + force_actuator_small_force, shaking_table_low_frequency, differential_cylinder x 3
    envs = set()
    for f in files:
        c = bcli.load_config(f)
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
        assert bcli.load_config(name)["env"].startswith("hydro_envs/")
    assert bcli._policy_path("agents/pretrained/servo_cylinder/ppo_s0").startswith(str(bcli.Path(bcli.__file__).resolve().parents[1]))
    with pytest.raises(FileNotFoundError, match="shipped: differential_cylinder, .*force_actuator"):
        bcli.load_config("no_such_config")


# ------------------------------------------------------------------ friction metrics, JSON, figures
def test_friction_metrics_of_rollouts():
    # tracking: a triangle with one reversal at sample 101; the output lags one sample and sits
    # 0.3 m off within 0.2 s after the reversal. Step episode: one hold level of 300 samples.
    dt, steps = 1e-3, 300
    k = np.arange(steps)
    r = np.minimum(k, 200 - k).astype(float)[:, None] * 1e-3
    y = r.copy()
    y[150] += 0.3
    y[:50] = 0.0  # at rest while the reference moves: samples 1..49 (50 has the jump back)
    acts = np.zeros((steps, 1, 1))
    z = np.zeros(1)
    track = bm.Rollout(y, r, acts, z, z, np.zeros(1, dtype=bool), np.zeros((1, 3)), dt)
    hold_r = np.full((steps, 1), 2.0)
    hold_y = hold_r.copy()
    hold_y[120:] += 1e-4 * np.array([1.0, -1.0] * 90)[:, None]  # +-1e-4 hunting in the hold window
    # (the last half of the hold less the 60 ms preview guard: samples 120..239)
    step = bm.Rollout(hold_y, hold_r, acts, z, z, np.zeros(1, dtype=bool), np.zeros((1, 3)), dt)
    m = bm.friction_metrics(track, step)
    assert m["reversal_error"][0] == pytest.approx(0.3)
    assert m["stick_time"][0] == pytest.approx(49 / 299)  # moving samples 1..299 (all but the reversal's zero speed)
    assert m["steady_state_error"][0] == pytest.approx(1e-4)
    assert m["limit_cycle"][0] == pytest.approx(2e-4)
    # without a step episode the holds come from the tracking episode (a triangle has none)
    assert np.isnan(bm.friction_metrics(track, None)["steady_state_error"][0])


@pytest.mark.parametrize("env_id", ["hydro_envs/ServoCylinderSlowSine-v0",
                                    "hydro_envs/RodlessCylinderMicroPosition-v0"])
def test_friction_tasks_report_their_metrics(env_id, tmp_path):
    import json

    res = bm.run_benchmark(env_id, ["pid"], params="in", n=2, seed=0, episode_steps=1500, out_dir=tmp_path,
                           figures=False)
    s = res.summary["pid"]
    if "SlowSine" in env_id:  # 0.2-0.5 Hz: at least one reversal in 1.5 s
        assert np.all(np.isfinite(res.episodes["pid"]["reversal_error"]))
        assert 0 <= s["stick_time"][1] <= s["stick_time"][0] <= s["stick_time"][2] <= 1
        assert np.isnan(s["steady_state_error"][0])
    else:  # micro steps: holds, no reversal
        assert np.all(np.isfinite(res.episodes["pid"]["steady_state_error"]))
        assert np.isnan(s["reversal_error"][0])
    doc = json.loads(next(p for p in res.files if p.suffix == ".json").read_text())
    assert doc["env"] == env_id and doc["n_draws"] == 2
    assert doc["controllers"]["pid"]["rmse"]["value"] == pytest.approx(s["rmse"][0])
    assert doc["metrics"]["reversal_error"]["unit"] == "m" and doc["metrics"]["stick_time"]["unit"] == "-"
    assert "reversal error" in res.markdown()


def _png_size(path):
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def test_figures_are_wide_with_large_fonts_few_lines_and_units(tmp_path):
    import matplotlib.text

    from agents import benchmark_figures as bf

    rng = np.random.default_rng(0)
    names = ["zero", "p", "pid", "pid_ff", "flow", "sac", "ppo"]  # 7 controllers: two trace rows
    t = 1e-3 * np.arange(500)
    ref = 0.01 * np.sin(2 * np.pi * t)
    episodes = {c: {k: rng.uniform(0.1, 1.0, 4) for k, _ in bm.METRICS if k != "cvar10_rmse"} for c in names}
    summary = {c: bm.summarize(episodes[c], 0, 4) for c in names}
    res = bm.BenchmarkResult(SERVO, "in", 4, 0, [{}] * 4, episodes, summary, {c: 1 for c in names}, {},
                             {c: (ref * (1 - 0.1 * i), ref) for i, c in enumerate(names)}, 1e-3)
    files = bm.write_outputs(res, tmp_path, figures=True)
    pngs = [p for p in files if p.suffix == ".png"]
    assert {p.name for p in pngs} == {"servo_cylinder_in_box.png", "servo_cylinder_in_traces.png"}
    for p in pngs:
        assert _png_size(p)[0] >= 1200, p.name
    keys = [(k, lab) for k, lab in bm.METRICS if k not in ("cvar10_rmse", "failed")]
    for fig in (bf.box_figure(res, keys, "m"), bf.trace_figure(res, "position", "m")):
        axes = [ax for ax in fig.axes if ax.axison]
        for ax in axes:
            assert "[" in ax.get_ylabel() and ax.get_xlabel(), ax.get_title()
        sizes = [tx.get_fontsize() for tx in fig.findobj(matplotlib.text.Text) if tx.get_text().strip()]
        assert min(sizes) >= 9
    trace = bf.trace_figure(res, "position", "m")
    assert len(trace.axes) == 4  # 2 rows x (output, error)
    assert max(len(ax.lines) for ax in trace.axes) <= bf.MAX_LINES
    plotted = [ln.get_label() for ax in trace.axes[0::2] for ln in ax.lines]
    assert set(names) <= set(plotted)  # every controller is drawn somewhere
    box = bf.box_figure(res, keys, "m")
    assert sum(ax.axison for ax in box.axes) == len(keys)
    ylabels = {ax.get_title(): ax.get_ylabel() for ax in box.axes if ax.axison}
    assert ylabels["reversal error"] == "reversal error [m]" and ylabels["overshoot"] == "overshoot [%]"


def test_draws_come_from_a_given_randomisation_spec(tmp_path):
    """``--randomization FILE``: the 'in' draws follow the calibrated spec, not the training ranges."""
    spec = tmp_path / "calibrated.yaml"
    spec.write_text(
        "plant: rodless_cylinder\nparameters:\n  coulomb_friction:\n    distribution: uniform\n"
        "    mode: absolute\n    range: [5.0, 6.0]\n    unit: N\n    nominal: 5.5\n"
        "    source: 'fit of a seal record (test)'\n")
    from agents.benchmark import draw_parameters

    draws = draw_parameters("hydro_envs/RodlessCylinder-v0", "in", 6, seed=0,
                            env_kwargs={"randomization": str(spec)})
    assert all(set(d) == {"coulomb_friction"} and 5.0 <= d["coulomb_friction"] <= 6.0 for d in draws)
    default = draw_parameters("hydro_envs/RodlessCylinder-v0", "in", 6, seed=0)
    assert len(default[0]) > 1


def test_a_second_run_into_one_out_is_refused_unless_force(tmp_path, capsys):
    out = tmp_path / "out"
    args = ["benchmark", "--env", SERVO, "--controllers", "pid", "--n", "2", "--steps", "20", "--no-figures",
            "--out", str(out)]
    assert hydro_main(args) == 0
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    assert hydro_main(args[:-2] + ["--seed", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "--force" in err and "pid ..." not in err  # refused before any controller ran
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first
    assert hydro_main(args[:-2] + ["--seed", "1", "--out", str(out), "--force"]) == 0
    assert {p.name: p.read_bytes() for p in out.iterdir()} != first


def test_a_full_disk_leaves_no_complete_looking_result(tmp_path, monkeypatch):
    import errno

    import hydro_envs.outputs as outs

    names = ["pid", "zero"]
    rng = np.random.default_rng(0)
    episodes = {c: {k: rng.uniform(0.1, 1.0, 4) for k, _ in bm.METRICS if k != "cvar10_rmse"} for c in names}
    summary = {c: bm.summarize(episodes[c], 0, 4) for c in names}
    t = 1e-3 * np.arange(100)
    res = bm.BenchmarkResult(SERVO, "in", 4, 0, [{}] * 4, episodes, summary, {c: 1 for c in names}, {},
                             {c: (np.sin(t), np.sin(t)) for c in names}, 1e-3)
    real = outs._commit
    calls = []

    def commit(tmp, target):  # the disk fills while the third file (the summary CSV) is committed
        calls.append(target.name)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(tmp, target)

    monkeypatch.setattr(outs, "_commit", commit)
    (tmp_path / "servo_cylinder_in.md").write_text("an earlier result\n")
    with pytest.raises(OSError, match=r"cannot write .*servo_cylinder_in\.csv: No space left on device"):
        bm.write_outputs(res, tmp_path, figures=False)
    # no temp file, no 0-byte CSV, no new .md or .json beside a missing CSV: the earlier file is back
    assert sorted(p.name for p in tmp_path.iterdir()) == ["servo_cylinder_in.md"]
    assert (tmp_path / "servo_cylinder_in.md").read_text() == "an earlier result\n"
    monkeypatch.undo()

    def full_write(self, name, data, *, encoding="utf-8"):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(outs.Staged, "write", full_write)
    out = tmp_path / "second"
    with pytest.raises(OSError, match="No space left"):
        bm.write_outputs(res, out, figures=False)
    assert list(out.iterdir()) == []
