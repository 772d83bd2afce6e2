"""rl_zoo3 interop (:mod:`agents.zoo`): the native batch env inside a zoo run, zoo run folders.

The zoo's vector env is rebuilt here as rl_zoo3's ``ExperimentManager.create_envs`` builds it
(SB3's ``make_vec_env`` of ``spec.make`` copies, each in a ``Monitor``), so the fast tests need
no rl_zoo3; ``tests/test_zoo_configs.py`` runs rl_zoo3 itself (slow).
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import gymnasium as gym  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor  # noqa: E402

import hydro_envs  # noqa: E402,F401
from agents.zoo import native_vec_env, read_zoo_yaml  # noqa: E402
from hydro_envs.envs.sb3 import SB3VecEnv, make_sb3_vec_env  # noqa: E402

ENV = "hydro_envs/ServoCylinderPosition-v0"
CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "agents"


def _zoo_env(n, log, wrapper_class=None):
    spec = gym.spec(ENV)
    return make_vec_env(lambda **kw: spec.make(**kw), n_envs=n, seed=7, monitor_dir=str(log),
                        vec_env_cls=DummyVecEnv, wrapper_class=wrapper_class)


def test_native_vec_env_replaces_the_zoo_env_bit_identically(tmp_path):
    venv = native_vec_env(_zoo_env(3, tmp_path))
    assert isinstance(venv, VecMonitor) and isinstance(venv.venv, SB3VecEnv)
    assert venv.num_envs == 3
    ref = make_sb3_vec_env(ENV, n_envs=3, seed=7)  # the seeds the zoo's make_vec_env gave: 7 + i
    o1, o2 = venv.reset(), ref.reset()
    np.testing.assert_array_equal(o1, o2)
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, size=(3, 1)).astype(np.float32)
        s1, s2 = venv.step(a), ref.step(a)
        np.testing.assert_array_equal(s1[0], s2[0])
        np.testing.assert_array_equal(s1[1], s2[1])
    assert not list(tmp_path.glob("[0-9]*.monitor.csv")), "the closed copies' empty monitor files are left"
    assert (tmp_path / "native.monitor.csv").is_file()


def test_native_vec_env_refuses_per_copy_wrappers(tmp_path):
    class Scaled(gym.ActionWrapper):
        def action(self, action):
            return 0.5 * action

    with pytest.raises(ValueError, match="Scaled"):
        native_vec_env(_zoo_env(2, tmp_path, wrapper_class=Scaled))


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_every_shipped_entry_names_the_native_wrapper(algo):
    from agents.train import NATIVE_VEC_ENV_WRAPPER, load_agent_config, resolve_config

    data = yaml.safe_load((CONFIGS / f"{algo}.yml").read_text())
    for env_id, entry in data.items():
        assert entry.get("vec_env_wrapper") == NATIVE_VEC_ENV_WRAPPER, (algo, env_id)
    entry = load_agent_config(None, algo, ENV)
    resolve_config(entry, algo, ENV)  # the package's trainer accepts the key
    from agents.train import ConfigError

    with pytest.raises(ConfigError, match="vec_env_wrapper"):
        resolve_config({**entry, "vec_env_wrapper": "my.Wrapper"}, algo, ENV)


def test_zoo_yaml_reads_ordered_dicts_and_nothing_else(tmp_path):
    good = tmp_path / "args.yml"
    good.write_text(yaml.dump(OrderedDict([("algo", "ppo"), ("env", ENV), ("n", 3)])))  # as rl_zoo3 writes it
    assert good.read_text().startswith("!!python/object/apply:collections.OrderedDict")
    assert read_zoo_yaml(good) == {"algo": "ppo", "env": ENV, "n": 3}
    bad = tmp_path / "bad.yml"
    bad.write_text("!!python/object/apply:os.system\n- echo owned\n")
    with pytest.raises(ValueError, match="not a zoo YAML file"):
        read_zoo_yaml(bad)


def _write_zoo_run(run: Path):
    """A zoo run folder with rl_zoo3's layout and file formats, from a 64-step PPO."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    name = ENV.replace("/", "-")
    venv = VecNormalize(make_sb3_vec_env(ENV, n_envs=2, seed=0))
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, seed=0,
                policy_kwargs=dict(net_arch=[8]), device="cpu").learn(64)
    (run / name).mkdir(parents=True)
    model.save(run / f"{name}.zip")
    venv.save(str(run / name / "vecnormalize.pkl"))
    (run / name / "args.yml").write_text(yaml.dump(OrderedDict([("algo", "ppo"), ("env", ENV), ("seed", 0)])))
    (run / name / "config.yml").write_text(yaml.dump(OrderedDict(
        [("n_envs", 2), ("normalize", {"norm_obs": True, "norm_reward": True}), ("policy", "MlpPolicy"), ("policy_kwargs", "dict(net_arch=[8])")])))
    return model, venv


def test_load_trained_reads_a_zoo_run_folder(tmp_path):
    pytest.importorskip("torch")
    from agents.policies import UntrustedPickleError, export_compact, load_trained

    run = tmp_path / "ppo" / "run_1"
    model, venv = _write_zoo_run(run)
    with pytest.raises(UntrustedPickleError, match="rl_zoo3 run folder"):
        load_trained(run)
    pol = load_trained(run, trust_pickle=True)
    assert (pol.env_id, pol.algo, pol.config["n_envs"]) == (ENV, "ppo", 2)
    obs, _ = gym.make(ENV).reset(seed=3)
    expected, _ = model.predict(venv.normalize_obs(obs[None].astype(np.float32)), deterministic=True)
    got, _ = pol.predict(obs[None])
    np.testing.assert_array_equal(got, expected)
    compact = export_compact(run, tmp_path / "compact", trust_pickle=True)
    again, _ = load_trained(compact).predict(obs[None])
    np.testing.assert_array_equal(again, expected)
