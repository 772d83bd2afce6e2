"""Residual RL on a classical controller (agents/residual.py): with a zero correction the
residual policy and the residual training env are exactly the base controller; the config key
is validated; a residual run loads back as a ResidualPolicy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.controllers import make_controller
from agents.residual import ResidualPolicy, ResidualVecEnv, check_residual

ENV = "hydro_envs/ServoCylinderPosition-v0"
N, STEPS, EPISODE = 4, 200, 80  # short episodes so the rollout crosses two auto-resets
CONFIG = Path(__file__).resolve().parents[1] / "configs" / "agents" / "residual" / "ppo.yml"


def _venv(seed: int = 0):
    from hydro_envs.envs.sb3 import make_sb3_vec_env

    return make_sb3_vec_env(ENV, n_envs=N, seed=seed, max_episode_steps=EPISODE)


class ZeroPolicy:
    """A trained-policy stand-in whose correction is always zero."""

    def __init__(self, venv) -> None:
        self.observation_space = venv.observation_space
        self.action_space = venv.action_space

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        o = np.asarray(obs)
        shape = self.action_space.shape if o.ndim == 1 else (o.shape[0], *self.action_space.shape)
        return np.zeros(shape, dtype=np.float32), state


def _base_rollout(venv):
    """Rewards and actions of the base PID on ``venv`` (episode starts after reset and dones)."""
    ctrl = make_controller(ENV, "pid")
    obs = venv.reset()
    start = np.ones(N, dtype=bool)
    rewards, actions = [], []
    for _ in range(STEPS):
        a, _ = ctrl.predict(obs, episode_start=start)
        obs, r, dones, _ = venv.step(a)
        start = dones.copy()
        rewards.append(r.copy())
        actions.append(a.copy())
    return np.array(rewards), np.array(actions)


def test_zero_policy_gives_the_base_controller_actions():
    venv = _venv()
    base = make_controller(ENV, "pid")
    res = ResidualPolicy(ZeroPolicy(venv), ENV, "pid", 0.3)
    assert res.env_id == ENV and res.observation_space == venv.observation_space
    assert res.action_space == venv.action_space
    obs = venv.reset()
    start = np.ones(N, dtype=bool)
    resets = 0
    for _ in range(STEPS):
        a_base, _ = base.predict(obs, episode_start=start)
        a_res, _ = res.predict(obs, episode_start=start)
        assert a_res.dtype == np.float32 and a_res.shape == (N, 1)
        np.testing.assert_array_equal(a_res, a_base)
        obs, _, dones, _ = venv.step(a_base)
        start = dones.copy()
        resets += int(dones.any())
    assert resets == 2
    venv.close()
    # single observation, episode starts tracked by the policy itself
    one = ResidualPolicy(ZeroPolicy(venv), ENV, "pid", 1.0)
    ctrl = make_controller(ENV, "pid")
    o = obs[0]
    for k in range(3):
        a1, _ = one.predict(o)
        a2, _ = ctrl.predict(o, episode_start=k == 0)
        assert a1.shape == (1,)
        np.testing.assert_array_equal(a1, a2)


def test_residual_env_with_zero_actions_reproduces_the_base_rollout():
    want_r, want_a = _base_rollout(_venv(seed=3))
    env = ResidualVecEnv(_venv(seed=3), ENV, "pid", 0.3)
    env.reset()
    got = []
    for _ in range(STEPS):
        _, r, _, _ = env.step(np.zeros((N, 1), dtype=np.float32))
        got.append(r.copy())
    np.testing.assert_array_equal(np.array(got), want_r)
    assert np.abs(want_a).max() > 0.0  # the PID acts (not a trivially zero rollout)
    env.close()


def test_residual_law_clips_and_scales():
    env = ResidualVecEnv(_venv(), ENV, "zero", 0.5)
    sent = []
    inner = env.venv
    orig = inner.step_async
    inner.step_async = lambda a: (sent.append(np.array(a)), orig(a))[-1]
    env.reset()
    env.step(np.array([[0.4], [-2.0], [3.0], [0.0]], dtype=np.float32))
    np.testing.assert_allclose(sent[0][:, 0], [0.2, -0.5, 0.5, 0.0], rtol=1e-6)
    env.close()


@pytest.mark.parametrize("controller,scale,field", [
    ("pid", 0.0, "residual.scale"), ("pid", 1.5, "residual.scale"), ("pid", float("nan"), "residual.scale"),
    ("pid", "x", "residual.scale"), ("pid", True, "residual.scale"), ("nope", 0.3, "residual.controller"),
])
def test_bad_residual_arguments_raise(controller, scale, field):
    with pytest.raises(ValueError, match=field) as exc:
        check_residual(ENV, controller, scale)
    assert repr(scale) in str(exc.value) or repr(controller) in str(exc.value)
    with pytest.raises(ValueError, match=field):
        ResidualVecEnv(_venv(), ENV, controller, scale)
    with pytest.raises(ValueError, match=field):
        ResidualPolicy(object(), ENV, controller, scale)


def test_config_key_is_validated():
    from agents.train import ConfigError, load_agent_config, resolve_config

    entry = load_agent_config(CONFIG, "ppo", ENV)
    assert resolve_config(entry, "ppo", ENV)["residual"] == {"controller": "pid", "scale": 0.3}
    assert "residual" not in resolve_config(load_agent_config(None, "ppo", ENV), "ppo", ENV)
    for bad, field in (({"controller": "pid", "scale": 2}, "residual.scale"),
                       ({"controller": "foo", "scale": 0.3}, "residual.controller"),
                       ({"controller": "pid"}, "residual.scale"),
                       ({"controller": "pid", "scale": 0.3, "gain": 1}, "residual.gain"),
                       ("pid", "residual")):
        with pytest.raises(ConfigError, match=field) as exc:
            resolve_config(entry, "ppo", ENV, {"residual": bad})
        assert "residual/ppo.yml" in str(exc.value) and ENV in str(exc.value)


def test_tiny_residual_training_loads_as_residual_policy(tmp_path):
    import yaml

    from agents.policies import TrainedPolicy, load_trained
    from agents.train import train

    run = train(ENV, "ppo", config=CONFIG, timesteps=256, n_envs=4, n_eval_episodes=0, out=tmp_path,
                progress_bar=False, hyperparams={"batch_size": 64}, torch_threads=1)
    assert yaml.safe_load((run / "config.yml").read_text())[ENV]["residual"] == {"controller": "pid", "scale": 0.3}
    pol = load_trained(run)
    assert isinstance(pol, ResidualPolicy) and isinstance(pol.policy, TrainedPolicy)
    assert pol.env_id == ENV and pol.scale == 0.3 and pol.controller_name == "pid"
    assert pol.algo == "ppo" and pol.observation_space.shape == (11,)
    obs = _venv().reset()
    a, _ = pol.predict(obs, episode_start=np.ones(N, dtype=bool))
    assert a.shape == (N, 1) and a.dtype == np.float32 and np.all(np.abs(a) <= 1.0)
    base, _ = make_controller(ENV, "pid").predict(obs, episode_start=np.ones(N, dtype=bool))
    corr, _ = pol.policy.predict(obs)
    np.testing.assert_allclose(a, np.clip(base + 0.3 * np.clip(corr, -1, 1), -1, 1), rtol=1e-6, atol=1e-7)


# ------------------------------------------------------------------ frame stacking
class RecordingPolicy:
    """Returns zeros and keeps every observation it was given."""

    def __init__(self, space) -> None:
        self.observation_space = space
        self.seen: list[np.ndarray] = []

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        self.seen.append(np.array(obs, copy=True))
        return np.zeros((np.asarray(obs).shape[0], 1), dtype=np.float32), state


def test_frame_stack_policy_sees_what_vecframestack_trained_on():
    """Fed single observations and episode starts, FrameStackPolicy builds the same stacks as
    SB3's VecFrameStack over two auto-resets (zeros before an episode's first observation)."""
    from stable_baselines3.common.vec_env import VecFrameStack

    from agents.framestack import FrameStackPolicy

    venv = VecFrameStack(_venv(), 3)
    d = venv.observation_space.shape[0] // 3
    rec = RecordingPolicy(venv.observation_space)
    pol = FrameStackPolicy(rec, 3, d)
    stacked = venv.reset()
    start = np.ones(N, dtype=bool)
    rng = np.random.default_rng(0)
    for _ in range(STEPS):
        pol.predict(stacked[:, -d:], episode_start=start)
        np.testing.assert_array_equal(rec.seen[-1], stacked)
        stacked, _, dones, _ = venv.step(rng.uniform(-0.2, 0.2, (N, 1)).astype(np.float32))
        start = dones.copy()


@pytest.mark.parametrize("bad", [0, 2.5, -1, True, "3", 100])
def test_frame_stack_key_is_checked(bad):
    from agents.framestack import check_frame_stack

    with pytest.raises(ValueError, match="frame_stack"):
        check_frame_stack(bad)


def test_tiny_frame_stacked_residual_training_loads_and_predicts(tmp_path):
    from agents.framestack import FrameStackPolicy
    from agents.policies import load_trained
    from agents.train import train

    run = train(ENV, "ppo", config=CONFIG, timesteps=256, n_envs=4, n_eval_episodes=2, eval_freq=0,
                out=tmp_path, progress_bar=False, hyperparams={"batch_size": 64, "frame_stack": 3},
                torch_threads=1)
    pol = load_trained(run)
    assert isinstance(pol, ResidualPolicy) and isinstance(pol.policy, FrameStackPolicy)
    assert pol.observation_space.shape == (11,) and pol.policy.policy.observation_space.shape == (33,)
    obs = _venv().reset()
    a, _ = pol.predict(obs, episode_start=np.ones(N, dtype=bool))
    assert a.shape == (N, 1) and np.all(np.isfinite(a)) and np.all(np.abs(a) <= 1)


@pytest.mark.parametrize("folder", sorted(p.name + "/" + q.name for p in (Path(__file__).resolve().parents[1] / "agents" / "pretrained").iterdir()
                                          for q in p.glob("ppo_residual_s*")))
def test_shipped_residual_policies_load_and_act(folder):
    """Every shipped residual policy loads (safe layout) as a ResidualPolicy on its env, acts
    within [-1, 1], and kept its training curve."""
    import gymnasium as gym

    from agents.policies import load_trained

    run = Path(__file__).resolve().parents[1] / "agents" / "pretrained" / folder
    pol = load_trained(run)
    assert isinstance(pol, ResidualPolicy)
    env = gym.make(pol.env_id)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        a, _ = pol.predict(obs)
        assert a.shape == env.action_space.shape and np.all(np.abs(a) <= 1)
        obs, *_ = env.step(a)
    env.close()
    assert len((run / "evaluations.csv").read_text().splitlines()) >= 5
