"""Tests of the Stable-Baselines3 adapter (hydro_envs.envs.sb3).

The adapter must turn the native SAME_STEP vector env into SB3's VecEnv contract: finished
copies are reset in the same step, the last observation goes to
``infos[i]["terminal_observation"]`` and time-limit ends are flagged with
``infos[i]["TimeLimit.truncated"]``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from gymnasium.vector import AutoresetMode  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecEnv  # noqa: E402

import hydro_envs  # noqa: E402,F401
from hydro_envs.envs.sb3 import SB3VecEnv, make_sb3_vec_env  # noqa: E402

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
N = 4
T = 10


def _actions(steps, seed=0):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, N, 1)).astype(np.float32)


def _sb3_rollout(venv, actions):
    obs = venv.reset()
    O, R, D, I = [obs], [], [], []
    for a in actions:
        obs, r, d, infos = venv.step(a)
        O.append(obs), R.append(r), D.append(d), I.append(infos)
    return np.array(O), np.array(R), np.array(D), I


def test_adapter_is_an_sb3_vec_env_with_the_single_spaces():
    venv = make_sb3_vec_env(ENV_ID, n_envs=N, seed=0, max_episode_steps=T)
    assert isinstance(venv, VecEnv)
    assert venv.num_envs == N
    assert venv.observation_space.shape == (11,) and venv.observation_space.dtype == np.float32
    assert venv.action_space.shape == (1,)
    assert venv.venv.unwrapped.autoreset_mode == AutoresetMode.SAME_STEP
    assert venv.get_attr("max_episode_steps") == [T] * N
    assert venv.env_is_wrapped(gym.Wrapper) == [False] * N


def test_time_limit_ends_and_terminal_observation():
    venv = make_sb3_vec_env(ENV_ID, n_envs=N, seed=0, max_episode_steps=T)
    obs = venv.reset()
    assert obs.shape == (N, 11) and obs.dtype == np.float32
    act = np.full((N, 1), 0.5, dtype=np.float32)
    for k in range(1, T + 1):
        obs, reward, dones, infos = venv.step(act)
        assert reward.shape == (N,) and reward.dtype == np.float32
        assert dones.shape == (N,) and dones.dtype == bool
        assert isinstance(infos, list) and len(infos) == N
        if k < T:
            assert not dones.any()
            assert all("terminal_observation" not in i for i in infos)
            np.testing.assert_array_equal(obs[:, 10], 0.5)
    assert dones.all()
    for i, info in enumerate(infos):
        term = info["terminal_observation"]
        assert term.shape == (11,) and term.dtype == np.float32
        assert term[10] == np.float32(0.5)  # the last obs of the episode carries its action
        assert info["TimeLimit.truncated"] is True
        assert not np.array_equal(term, obs[i])
    # the returned obs after done is a reset obs
    np.testing.assert_array_equal(obs[:, 10], 0.0)
    obs, reward, dones, infos = venv.step(act)
    assert not dones.any()


def test_terminal_observation_equals_native_same_step_final_obs():
    actions = _actions(2 * T + 3, seed=1)
    venv = make_sb3_vec_env(ENV_ID, n_envs=N, seed=5, max_episode_steps=T)
    O, R, D, I = _sb3_rollout(venv, actions)
    native = gym.make_vec(
        ENV_ID,
        num_envs=N,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        max_episode_steps=T,
    )
    obs, _ = native.reset(seed=5)
    np.testing.assert_array_equal(obs, O[0])
    n_ends = 0
    for k, a in enumerate(actions):
        obs, r, term, trunc, info = native.step(a)
        np.testing.assert_array_equal(obs, O[k + 1])
        np.testing.assert_array_equal(r.astype(np.float32), R[k])
        np.testing.assert_array_equal(term | trunc, D[k])
        if D[k].any():
            for i in np.flatnonzero(D[k]):
                np.testing.assert_array_equal(I[k][i]["terminal_observation"], info["final_obs"][i])
                n_ends += 1
    assert n_ends == 2 * N  # two episode ends per copy in 23 steps of T = 10


def test_seed_semantics_and_reproducible_rollouts():
    actions = _actions(25, seed=2)
    a = _sb3_rollout(make_sb3_vec_env(ENV_ID, n_envs=N, seed=3, max_episode_steps=T), actions)
    b = _sb3_rollout(make_sb3_vec_env(ENV_ID, n_envs=N, seed=3, max_episode_steps=T), actions)
    for x, y in zip(a[:3], b[:3]):
        np.testing.assert_array_equal(x, y)
    for ia, ib in zip(a[3], b[3]):
        for da, db in zip(ia, ib):
            assert da.keys() == db.keys()
            if "terminal_observation" in da:
                np.testing.assert_array_equal(da["terminal_observation"], db["terminal_observation"])
    c = _sb3_rollout(make_sb3_vec_env(ENV_ID, n_envs=N, seed=4, max_episode_steps=T), actions)
    assert not np.array_equal(a[0], c[0])
    # venv.seed(s): copy i is seeded s + i on the next reset (as a single env with seed s + i)
    venv = make_sb3_vec_env(ENV_ID, n_envs=N, max_episode_steps=T)
    assert venv.seed(3) == [3, 4, 5, 6]
    obs = venv.reset()
    np.testing.assert_array_equal(obs, a[0][0])
    for i in range(N):
        single, _ = gym.make(ENV_ID, episode_steps=T).reset(seed=3 + i)
        np.testing.assert_array_equal(obs[i], single)
    # the seed is used once: a later reset continues the streams (a new episode)
    obs2 = venv.reset()
    assert not np.array_equal(obs2, obs)


def test_ppo_learns_without_error():
    venv = make_sb3_vec_env(ENV_ID, n_envs=N, seed=0, max_episode_steps=50)
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu", verbose=0)
    model.learn(256)
    assert model.num_timesteps >= 256
    action, _ = model.predict(venv.reset(), deterministic=True)
    assert action.shape == (N, 1) and np.all(np.abs(action) <= 1.0)


def test_next_step_vector_env_is_rejected():
    native = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="SAME_STEP"):
        SB3VecEnv(native)
    native_same = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", autoreset_mode=AutoresetMode.SAME_STEP
    )
    assert SB3VecEnv(native_same).num_envs == 2


def test_step_wait_without_step_async_raises():
    venv = make_sb3_vec_env(ENV_ID, n_envs=2, seed=0)
    venv.reset()
    with pytest.raises(RuntimeError):
        venv.step_wait()


def test_set_options_reach_the_next_reset():
    venv = make_sb3_vec_env(ENV_ID, n_envs=2, seed=0, max_episode_steps=T)
    venv.set_options({"reference": np.full(100, 0.03)})
    obs = venv.reset()
    half = 0.5 * 0.0696
    np.testing.assert_allclose(obs[:, 1], (0.03 - half) / half, atol=1e-6)
