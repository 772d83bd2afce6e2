"""The main job (agents/demo.py) and the pre-trained baselines (agents/pretrain.py).

What is checked is the truth of each stage, not that it ran: the virtual constant-velocity test
recovers the rig's friction within its noise, the identified feedforward lowers the PID's
tracking error on the same frozen draws, the compact policy format reproduces the SB3 model's
actions bit for bit, and the shipped servo baseline tracks better than the PID it is compared
with in the docs.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("rich")

import gymnasium as gym  # noqa: E402

import hydro_envs  # noqa: E402,F401
from agents import demo  # noqa: E402
from agents.policies import OBS_NORM_FILE, POLICY_FILE, export_compact, load_trained  # noqa: E402
from agents.pretrain import PLANTS, PRETRAINED_ROOT, pretrained_dir  # noqa: E402


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    from agents.train import train

    out = tmp_path_factory.mktemp("runs")
    return train(demo.ENV_ID, "ppo", timesteps=2048, seed=3, out=out, name="tiny", n_envs=8,
                 hyperparams={"n_steps": 256, "batch_size": 256, "n_epochs": 1}, progress_bar=False,
                 eval_freq=0, n_eval_episodes=0, torch_threads=1)


def test_compact_export_gives_bit_identical_actions(tiny_run, tmp_path):
    compact = export_compact(tiny_run, tmp_path / "compact")
    assert (compact / POLICY_FILE).is_file() and (compact / OBS_NORM_FILE).is_file()
    assert not list(compact.glob("*.pkl")) and not list(compact.glob("*.zip"))
    size = sum(f.stat().st_size for f in compact.iterdir())
    assert size < 100_000, size
    full, small = load_trained(tiny_run), load_trained(compact)
    obs = np.random.default_rng(0).normal(0.0, 3.0, (500, 11)).astype(np.float32)
    a_full, _ = full.predict(obs)
    a_small, _ = small.predict(obs)
    assert np.array_equal(a_full, a_small)
    assert small.env_id == demo.ENV_ID and small.algo == "ppo"


def test_compact_folder_errors_name_the_missing_file(tmp_path):
    (tmp_path / POLICY_FILE).write_bytes(b"")
    with pytest.raises(FileNotFoundError, match="args.json"):
        load_trained(tmp_path)


#: plants with envs and controllers but no pre-trained PPO baseline yet (each a decision, named)
NO_BASELINE = {"differential_cylinder": "new plant (issue 54): no PPO baseline trained yet",
               "load_sensing": "no learned policy beat the pump's own regulation by 5 % (agents.pretrain.NOT_SHIPPED)"}


def test_every_plant_without_a_baseline_is_named():
    missing = {p for p in PLANTS if not sorted((PRETRAINED_ROOT / p).glob("ppo_*s*"))}
    assert missing == set(NO_BASELINE), (missing, NO_BASELINE)


@pytest.mark.parametrize("plant", sorted(set(PLANTS) - set(NO_BASELINE)))
def test_shipped_baselines_load_and_act(plant):
    env_id = PLANTS[plant]
    folders = sorted((PRETRAINED_ROOT / plant).glob("ppo_*s*"))
    assert folders, f"no pre-trained baseline for {plant} in {PRETRAINED_ROOT}"
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    for f in folders:
        assert sum(p.stat().st_size for p in f.iterdir()) < 100_000
        pol = load_trained(f)
        assert pol.env_id == env_id
        a, _ = pol.predict(obs)
        assert a.shape == env.action_space.shape and np.all(np.isfinite(a))
        assert env.action_space.contains(a.astype(env.action_space.dtype))
    env.close()


def test_pretrained_dir_names_the_regeneration_command(tmp_path):
    with pytest.raises(FileNotFoundError, match="python -m agents.pretrain"):
        pretrained_dir("hydro_envs/ServoCylinderPosition-v0", seed=99, root=tmp_path)
    with pytest.raises(ValueError, match="pre-trained baselines exist"):
        pretrained_dir("CartPole-v1")


def test_shipped_servo_baseline_beats_pid_on_the_nominal_plant():
    """The docs table's claim (learned < PID on the nominal servo), on 6 frozen episodes."""
    from agents.benchmark import run_benchmark

    env_id = "hydro_envs/ServoCylinderPosition-v0"
    res = run_benchmark(env_id, ["pid", f"ppo=sb3:{pretrained_dir(env_id)}"], params="nominal", n=6,
                        seed=0, step_reference=None, figures=False)
    assert res.summary["ppo"]["rmse_rel_pid"][0] < 0.9, res.summary["ppo"]["rmse_rel_pid"]


def test_demo_end_to_end_quick(tmp_path, tiny_run):
    """All four stages on a pre-made tiny agent (training itself is tested in test_train)."""
    out = tmp_path / "demo"
    res = demo.run(out, timesteps=1, n=4, params=("in",), progress_bar=False, agent_run=tiny_run)
    fit = res["fit"]
    # stage 1: the 002 sec. 4 test through realistic sensors recovers the rig's Coulomb and
    # viscous friction (the well-excited parameters) within 2 % and 3 %
    assert fit.parameters["F_c"] == pytest.approx(40.0, rel=0.02)
    assert fit.parameters["F_v"] == pytest.approx(250.0, rel=0.03)
    assert fit.parameters["F_s"] > fit.parameters["F_c"]
    # stage 4: the controllers on the same frozen draws of the friction task; dry friction makes
    # most of the PID's error, and the identified friction beats the same loop blind to it
    (bench,) = res["results"]
    assert list(bench.summary) == ["pid", demo.BLIND_TWIN, demo.FF_NAME, "ppo"]
    assert bench.summary["pid"]["friction_share"][0] > 0.5
    assert bench.summary[demo.FF_NAME]["rmse"][0] < 0.8 * bench.summary[demo.BLIND_TWIN]["rmse"][0]
    stem = "ServoCylinderSlowSine_v0_in"
    for name in ("friction_fit.png", f"{stem}.md", f"{stem}.csv", f"{stem}_box.png", f"{stem}_traces.png"):
        assert (out / name).is_file(), name
    assert res["total_s"] > 0


def test_a_rerun_of_the_demo_trains_beside_the_earlier_agent(tmp_path):
    """The demo's agent folder is ``ppo_seed0``; a rerun finds it full and takes the next free
    name instead of stopping (the earlier run is kept)."""
    assert demo.free_run_name(tmp_path, "ppo_seed0") == "ppo_seed0"
    (tmp_path / "ppo_seed0").mkdir()
    assert demo.free_run_name(tmp_path, "ppo_seed0") == "ppo_seed0"  # empty: reused
    (tmp_path / "ppo_seed0" / "model.zip").write_bytes(b"x")
    assert demo.free_run_name(tmp_path, "ppo_seed0") == "ppo_seed0_2"
    (tmp_path / "ppo_seed0_2").mkdir()
    (tmp_path / "ppo_seed0_2" / "model.zip").write_bytes(b"x")
    assert demo.free_run_name(tmp_path, "ppo_seed0") == "ppo_seed0_3"


def test_demo_rejects_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="algo"):
        demo.run(tmp_path, algo="dqn")
    with pytest.raises(ValueError, match="n must be"):
        demo.run(tmp_path, n=1)


def test_hydro_demo_rollouts_still_work(capsys):
    from hydro_envs.cli import main

    assert main(["demo", "--rollouts", "--episodes", "1"]) == 0
    assert "mean tracking RMSE" in capsys.readouterr().out


def test_benchmark_configs_list_existing_baselines_of_their_env():
    from agents.benchmark_cli import load_config

    root = Path(__file__).resolve().parents[1]
    files = sorted((root / "configs" / "benchmarks").glob("*.yaml"))
    assert len(files) >= 14
    main_envs = {env: plant for plant, env in PLANTS.items() if plant not in NO_BASELINE}
    for f in files:
        cfg = load_config(f)
        policies = cfg.get("policies", [])
        if cfg["env"] in main_envs:  # a plant's main task lists its shipped seeds (the friction tasks none)
            assert len(policies) >= 3, f
        for rel in policies:
            pol = load_trained(root / rel)
            assert pol.env_id == cfg["env"], (f, rel)


def test_the_first_vector_env_sets_the_openmp_spin_for_a_time_unless_the_user_chose():
    """The package's spin count is replaced, when the first vector env is made, by the count that
    spins ``SPIN_TIME_US`` at this CPU's ``pause`` latency (x86-64); a user's setting stays."""
    import platform
    import subprocess
    import sys

    from hydro_envs._openmp import SPIN_TIME_US, spin_count_for

    if platform.machine().lower() not in ("x86_64", "amd64"):
        pytest.skip("the spin is timed with the x86 pause instruction")
    code = ("import os, gymnasium as gym, hydro_envs; from hydro_envs._spin import pause_ns; "
            "before = os.environ.get('GOMP_SPINCOUNT'); "
            "gym.make_vec('hydro_envs/ServoCylinderPosition-v0', num_envs=2, vectorization_mode='vector_entry_point'); "
            "print(before, os.environ.get('GOMP_SPINCOUNT'), pause_ns())")
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")

    def run(**extra: str) -> list[str]:
        out = subprocess.run([sys.executable, "-c", code], env={**env, **extra}, capture_output=True, text=True,
                             check=True)
        return out.stdout.split()

    before, after, ns = run()
    assert before == "None" and after != before  # importing sets nothing
    assert 0.5 < int(after) * float(ns) / (SPIN_TIME_US * 1e3) < 2.0  # about 75 us of pauses
    assert run(GOMP_SPINCOUNT="0")[:2] == ["0", "0"]
    assert spin_count_for(10.0) == 7500 and spin_count_for(1e9) == 1
    with pytest.raises(ValueError, match="pause_ns must be > 0"):
        spin_count_for(0.0)


def test_a_pause_that_cannot_be_timed_gives_the_fixed_spin_count_and_warns(monkeypatch):
    import numba.np.ufunc.parallel as numba_parallel

    from hydro_envs import _openmp, _spin

    def broken(*args, **kwargs):
        raise RuntimeError("no pause intrinsic")

    monkeypatch.setattr(numba_parallel, "_is_initialized", False)
    monkeypatch.setattr(_openmp, "_done", False)
    monkeypatch.delenv("GOMP_SPINCOUNT", raising=False)
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    monkeypatch.setattr(_spin, "pause_ns", broken)
    with pytest.warns(RuntimeWarning, match="could not time the CPU's pause instruction"):
        assert _openmp.set_spin_time() == int(_openmp.SPIN_COUNT)
    assert os.environ["GOMP_SPINCOUNT"] == _openmp.SPIN_COUNT
    monkeypatch.setenv("GOMP_SPINCOUNT", "7")
    assert _openmp.set_spin_time() is None  # once per process
    assert os.environ["GOMP_SPINCOUNT"] == "7"
