"""The contract every registered env keeps, checked once per env id from the registry.

For every id in :func:`hydro_envs.registry.env_entries`: Gymnasium's ``check_env`` passes with
no warning, and steps at either bound of the action space return a float reward and plain bool
flags; the registered episode length is the registry entry's; ``reset(seed)`` fixes the whole
trajectory (observations, rewards and ``info["state"]``, over a rollout long enough that the
state moves) and a different seed draws other parameters and another start; observations stay
inside ``observation_space``; copy ``i`` of the native vector env (the entry's vector class,
``info`` keyed by the plant's state and parameter names) reset with seed ``s`` equals a single
env reset with ``s + i``, observation, reward and state at every step; a pickled or deep-copied
env continues exactly as the original; a NaN/inf action raises ``ValueError`` naming the action,
in the single and the vector env, as an array, a list or a plain number. For one env per plant
(:data:`hydro_envs.soak.SOAK_ENVS`) a short soak finds no energy created, and per plant the vector
env's threaded step kernel advances uneven blocks of copies exactly as the serial loop does. A
fresh process that makes, resets and steps every env id has imported neither ``scipy.signal`` nor
``scipy.stats``. Action shapes, clipping and rejected actions leaving no trace: ``test_properties.py``.
"""

from __future__ import annotations

import copy
import os
import pickle
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs import registry, soak

ENTRIES = {entry.id: (spec, entry) for spec, entry in registry.env_entries()}
ENV_IDS = list(ENTRIES)
#: single-env rollout for determinism and the observation bounds; vector-env rollout
STEPS = 300
VEC_STEPS = 150
N_VEC = 3


def _actions(space, steps, seed, batch=()):
    """Seeded actions for ``space`` (a Box or Discrete single-env space)."""
    rng = np.random.default_rng(seed)
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(space.start, space.start + space.n, (steps,) + batch)
    a = rng.uniform(space.low, space.high, (steps,) + batch + space.shape)
    return a.astype(space.dtype)


def _rollout(env, seed, actions):
    """Observations, rewards and ``info["state"]`` rows of ``actions`` from ``reset(seed)``,
    resetting (unseeded) at episode ends."""
    obs, info = env.reset(seed=seed)
    O, R, S = [obs], [], [list(info["state"].values())]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        O.append(obs), R.append(r), S.append(list(info["state"].values()))
        if term or trunc:
            obs, info = env.reset()
            O.append(obs), S.append(list(info["state"].values()))
    return np.array(O), np.array(R), np.array(S)


def test_stepping_every_env_leaves_the_slow_scipy_modules_unimported():
    """Making, resetting and stepping every env id imports neither scipy.signal nor scipy.stats
    (about 0.7 s of a process's start) nor scipy.optimize (0.47 s); the modules that need them
    import them where used."""
    code = (
        "import sys, gymnasium as gym, hydro_envs\n"
        f"for env_id in {ENV_IDS!r}:\n"
        "    env = gym.make(env_id); env.reset(seed=0); env.step(env.action_space.sample())\n"
        "print(sorted(m for m in ('scipy.signal', 'scipy.stats', 'scipy.optimize') if m in sys.modules))\n"
    )
    repo = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=repo + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]", res.stdout


def test_registry_lists_every_registered_env():
    hydro = sorted(k for k in gym.registry if k.startswith("hydro_envs/"))
    assert sorted(ENV_IDS) == hydro and len(ENV_IDS) == len(set(ENV_IDS))


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_env_contract(env_id):
    plant, entry = ENTRIES[env_id]
    env = gym.make(env_id)
    space = env.action_space

    # Gymnasium's API checker and steps at the action bounds: no error and no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id).unwrapped)
        env.reset(seed=0)
        for a in (_actions(space, 1, seed=0)[0], space.low, space.high):
            _, reward, terminated, truncated, _ = env.step(a)
            assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert env.spec.max_episode_steps == entry.max_episode_steps

    # reset(seed) fixes the trajectory; another seed draws another episode
    acts = _actions(space, STEPS, seed=1)
    O1, R1, S1 = _rollout(env, 5, acts)
    O2, R2, S2 = _rollout(gym.make(env_id), 5, acts)
    np.testing.assert_array_equal(O1, O2)
    np.testing.assert_array_equal(R1, R2)
    np.testing.assert_array_equal(S1, S2)
    assert np.ptp(S1, axis=0).max() > 0.0, f"{env_id}: the state did not move in {STEPS} random steps"
    o5, i5 = gym.make(env_id).reset(seed=5)
    o6, i6 = gym.make(env_id).reset(seed=6)
    assert not np.array_equal(o5, o6), "seeds 5 and 6 gave the same initial observation"
    assert i5["params"] != i6["params"], "seeds 5 and 6 drew the same parameters"

    # observations inside the observation space over a random rollout
    for k, obs in enumerate(O1):
        assert env.observation_space.contains(obs), f"{env_id}: observation {k} outside the space: {obs}"
    assert O1.dtype == np.float32 and np.all(np.isfinite(R1))

    # copy i of the native vector env == a single env reset with seed s + i
    vacts = _actions(space, VEC_STEPS, seed=2, batch=(N_VEC,))
    venv = gym.make_vec(env_id, num_envs=N_VEC, vectorization_mode="vector_entry_point")
    module, name = entry.vector_entry_point.split(":")
    assert type(venv.unwrapped).__module__ == module and type(venv.unwrapped).__name__ == name
    vobs, info = venv.reset(seed=10)
    assert list(info["state"]) == list(plant.state_names)
    assert set(info["params"]) == set(plant.params_cls.names())
    VO, VR, VS, VD = [vobs], [], [np.array(list(info["state"].values()))], []
    for a in vacts:
        vobs, r, term, trunc, info = venv.step(a)
        VO.append(vobs), VR.append(r), VD.append(term | trunc)
        VS.append(np.array(list(info["state"].values())))
    VO, VR, VS = np.array(VO), np.array(VR), np.array(VS)
    assert not np.any(VD), "rollout too long for the row-by-row comparison (an episode ended)"
    for i in range(N_VEC):
        Oi, Ri, Si = _rollout(gym.make(env_id), 10 + i, vacts[:, i])
        np.testing.assert_array_equal(Oi, VO[:, i], err_msg=f"{env_id}: vector copy {i}")
        np.testing.assert_array_equal(Ri, VR[:, i], err_msg=f"{env_id}: vector copy {i}")
        np.testing.assert_array_equal(Si, VS[:, :, i], err_msg=f"{env_id}: vector copy {i} state")

    # pickle and deepcopy mid-episode continue identically
    env = gym.make(env_id)
    env.reset(seed=3)
    for a in acts[:10]:
        env.step(a)
    clones = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    ref = [env.step(a)[:2] for a in acts[10:20]]
    for clone in clones:
        got = [clone.step(a)[:2] for a in acts[10:20]]
        for (o, r), (o2, r2) in zip(ref, got):
            np.testing.assert_array_equal(o, o2)
            assert r == r2

    # non-finite actions raise ValueError naming the action, in the single and the vector env
    if isinstance(space, gym.spaces.Box):
        for bad in (np.nan, np.inf, -np.inf):
            forms = [np.full(space.shape, bad, dtype=space.dtype), np.full(space.shape, bad).tolist()]
            if space.shape == (1,):
                forms.append(float(bad))  # a plain number for a one-dimensional action
            for a in forms:
                with pytest.raises(ValueError, match="action must be finite"):
                    env.step(a)
        batch = np.zeros((N_VEC,) + space.shape, dtype=space.dtype)
        batch[-1, -1] = np.nan
        with pytest.raises(ValueError, match="finite"):
            venv.step(batch)


@pytest.mark.parametrize("env_id", soak.SOAK_ENVS)
def test_energy_balance(env_id):
    r = soak.soak_env(env_id, 2_000, num_envs=8, seed=11, episode_steps=125)
    assert r.steps >= 2_000
    assert r.counts.get("energy", 0) == 0 and r.counts.get("passivity", 0) == 0, (r.counts, r.examples)
    assert r.breaches == 0, (r.counts, r.examples)


@pytest.mark.parametrize("n", [3, 131])
@pytest.mark.parametrize("env_id", [entry.id for _, entry in {s.name: (s, e) for s, e in registry.env_entries()}.values()])
def test_vector_step_kernel_equals_the_serial_one_on_uneven_blocks(env_id, n):
    """The threaded step (blocks of copies, :func:`hydro_envs.sim.rk4.in_blocks`) advances every
    copy exactly as the serial loop does, also when the copies do not divide into equal blocks
    (131 copies: blocks of 2 and 3) and when there are fewer copies than blocks."""
    env = gym.make_vec(env_id, num_envs=n)
    env.reset(seed=3)
    env.step(_actions(env.single_action_space, 1, 4, (n,))[0])
    b = env.unwrapped._batch
    kernels = b.plant_spec.kernels
    serial = kernels.pick(b.P).step_serial
    assert b.step_kernel is not serial
    out = []
    for kernel in (serial, b.step_kernel):
        Y, W, c = b.Y.copy(), b.W.copy(), b.clamps.copy()
        for _ in range(50):
            kernel(Y, b.U, b.P, b.dt, b.NSUB, W, c)
        out.append((Y, c))
    assert np.all(np.isfinite(out[0][0]))
    assert not np.array_equal(out[0][0], b.Y)
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])


@pytest.mark.parametrize("n", [3, 131])
@pytest.mark.parametrize("env_id", [entry.id for _, entry in {s.name: (s, e) for s, e in registry.env_entries()}.values()])
def test_vector_step_and_observe_in_one_kernel_equals_stepping_then_observing(env_id, n):
    """The vector env steps and observes every copy in one parallel kernel (it never calls the
    step kernel or the observation kernel on their own), with the states, observations and
    rewards of stepping all copies and then observing them (``PlantBatch.step_then_observe``),
    also on uneven blocks and with fewer copies than blocks."""
    from hydro_envs.envs.base import PlantBatch

    env = gym.make_vec(env_id, num_envs=n)
    b = env.unwrapped._batch
    actions = _actions(env.single_action_space, 60, 2, (n,))

    def refuse(*args):
        raise AssertionError("the vector step called the step or the observation kernel on its own")

    runs = []
    for fused in (True, False):
        env.reset(seed=5)
        if fused:
            b.step_kernel = b.observe = refuse
        else:
            b.step_and_observe = lambda: PlantBatch.step_then_observe(b)
        for k in range(60):
            obs, reward, *_ = env.step(actions[k])
        if fused:
            del b.observe
            b.select_step_kernel()
        runs.append((b.Y.copy(), obs, reward, b.K.copy()))
    assert np.all(runs[1][3] == 60) and not np.array_equal(runs[1][0], runs[0][0] * 0.0)
    for got, want in zip(runs[0], runs[1]):
        assert np.array_equal(got, want)
