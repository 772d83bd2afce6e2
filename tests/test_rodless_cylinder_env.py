"""``hydro_envs/RodlessCylinder-v0`` (seed 004): spaces, actions, info and reset options, the
reward, observation semantics and the env's step kernels.

Every check compares against something independent of the code under test: the YAML ranges,
the reward recomputed from ``info["state"]``, eq (1)'s friction at constant speed, and the
general step kernel against the specialised ones. The contract every env keeps (``check_env``,
seeding, vector copies, non-finite actions): ``test_env_contract.py``; plant physics and
numerics: ``test_rodless_cylinder.py``.
"""

from __future__ import annotations


import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the env)
from hydro_envs.params import ParameterError
from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.randomization import load_randomization
from env_helpers import action as _a
from env_helpers import padded as _padded
from env_helpers import random_actions as _random_actions
from env_helpers import rollout as _rollout


ENV_ID = "hydro_envs/RodlessCylinder-v0"
NOMINAL = RodlessCylinderParams()
L = NOMINAL.stroke
HALF = 0.5 * L
A = rc.piston_area(NOMINAL)
DT = 1e-3
STATE_KEYS = rc.STATE_NAMES
PARAM_NAMES = RodlessCylinderParams.names()
OBS_DIM = 11


@pytest.fixture(scope="module")
def spec():
    return load_randomization("rodless_cylinder", RodlessCylinderParams)


# ============================================================================ env: API
def test_spaces_and_observation_bounds():
    assert gym.make(ENV_ID).spec.max_episode_steps == 2000
    env = gym.make(ENV_ID).unwrapped
    assert env.action_space.shape == (1,) and env.action_space.dtype == np.float32
    o = env.observation_space
    assert o.shape == (OBS_DIM,) and o.dtype == np.float32 and np.all(np.isfinite(o.low))
    obs_all, _, _ = _rollout(env, 7, _random_actions(400, seed=8))
    assert obs_all.dtype == np.float32
    for ob in obs_all:
        assert o.contains(ob)


def test_wrong_shape_raises_and_out_of_range_is_clipped():
    e1, e2 = gym.make(ENV_ID).unwrapped, gym.make(ENV_ID).unwrapped
    e1.reset(seed=11)
    e2.reset(seed=11)
    with pytest.raises(ValueError, match="shape"):
        e1.step(np.zeros(2, dtype=np.float32))
    o1, r1, _, _, i1 = e1.step(_a(7.0))
    o2, r2, _, _, i2 = e2.step(_a(1.0))
    assert i1["state"] == i2["state"] and r1 == r2 and o1[10] == 1.0


def test_action_maps_to_0_10_volts_with_5_volt_centre():
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    assert env.channel_values()["u"] == 0.0  # before the first action: nothing applied yet
    for a, volts in ((-1.0, 0.0), (0.0, 5.0), (1.0, 10.0), (0.25, 6.25)):
        env.step(_a(a))
        ch = env.channel_values()
        assert set(ch) == {"u", "y", "pa", "pb"}
        assert ch["u"] == pytest.approx(volts, abs=1e-12)


# ============================================================================ env: info, reset
def test_info_state_and_params():
    env = gym.make(ENV_ID).unwrapped
    obs, info = env.reset(seed=4)
    p = info["params"]
    assert set(info["state"]) == set(STATE_KEYS) and set(p) == set(PARAM_NAMES)
    s = info["state"]
    assert 0.25 * p["stroke"] <= s["y"] <= 0.75 * p["stroke"]
    params = RodlessCylinderParams(**p)
    p0 = rc.centre_pressure(params)
    assert s["pa"] == s["pb"] == pytest.approx(p0, rel=1e-12)
    ta, tb = rc.chamber_temperatures(np.array([s[k] for k in STATE_KEYS]), params)
    assert ta[0] == pytest.approx(p["supply_temperature"]) and tb[0] == pytest.approx(p["supply_temperature"])
    for a in _random_actions(50, seed=5):
        _, _, _, _, info = env.step(a)
        assert info["params"] == p and all(type(v) is float for v in info["state"].values())


def test_randomize_false_gives_nominal_and_true_draws_inside_yaml_ranges(spec):
    env = gym.make(ENV_ID, randomize=False)
    _, info = env.reset(seed=0)
    assert info["params"] == NOMINAL.as_dict()
    assert env.unwrapped.n_substeps == 2
    ranges = {row["name"]: row["value_range"] for row in spec.table()}
    assert set(ranges) == {"static_friction", "coulomb_friction", "stribeck_velocity", "viscous_friction",
                           "mass", "supply_pressure", "wall_heat_transfer_coefficient"}
    assert ranges["static_friction"] == pytest.approx((0.7 * 35.48, 1.3 * 35.48))
    assert ranges["supply_pressure"] == pytest.approx((0.4e6 + 101325, 0.7e6 + 101325))
    env = gym.make(ENV_ID)
    drawn = {k: [] for k in ranges}
    for seed in range(10):
        _, info = env.reset(seed=seed)
        for name in PARAM_NAMES:
            if name in ranges:
                lo, hi = ranges[name]
                assert lo <= info["params"][name] <= hi
                drawn[name].append(info["params"][name])
            else:
                assert info["params"][name] == getattr(NOMINAL, name)
    for values in drawn.values():
        assert len(set(values)) == len(values)


def test_reset_options():
    env = gym.make(ENV_ID, randomize=False)
    _, info = env.reset(seed=0, options={"params": {"mass": 1.5}, "state": {"y": 0.02, "pa": 3e5}})
    assert info["params"]["mass"] == 1.5 and info["state"]["y"] == 0.02 and info["state"]["pa"] == 3e5
    # masses follow for T_s at the given pressure and position
    ta, _ = rc.chamber_temperatures(np.array([info["state"][k] for k in STATE_KEYS]), NOMINAL)
    assert ta[0] == pytest.approx(NOMINAL.supply_temperature, rel=1e-12)
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"state": {"y": L + 0.01}})
    with pytest.raises(ValueError, match="floor"):
        env.reset(seed=0, options={"state": {"pb": 0.0}})
    with pytest.raises(ValueError, match="bogus"):
        env.reset(seed=0, options={"state": {"bogus": 1.0}})
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(seed=0, options={"initial_state": {}})
    with pytest.raises(ParameterError, match="mass"):
        env.reset(seed=0, options={"params": {"mass": -1.0}})
    ref = np.linspace(0.03, 0.07, 100)
    obs, _ = env.reset(seed=0, options={"reference": _padded(ref)})
    assert obs[1] == np.float32((ref[0] - HALF) / HALF)
    assert obs[2] == np.float32((ref[10] - HALF) / HALF)
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"reference": [0.05, L + 0.1]})


@pytest.mark.parametrize("task", ["positioning", "tracking"])
def test_tasks_draw_their_reference_kind(task):
    env = gym.make(ENV_ID, task=task, randomize=False).unwrapped
    for seed in range(4):
        env.reset(seed=seed)
        ref = env._batch.REF[0]
        assert ref.min() >= 0.1 * L - 1e-12 and ref.max() <= 0.9 * L + 1e-12
        rate = np.abs(np.diff(ref)) / DT
        if task == "positioning":
            assert np.count_nonzero(rate) <= 12  # piecewise-constant set points
        else:
            assert rate.max() <= 0.15 + 1e-9 and np.count_nonzero(rate) > 1000


def test_constructor_validation():
    for kw, name in (({"task": "juggling"}, "task"), ({"error_scale": 0.0}, "error_scale"),
                     ({"pressure_noise_std": -1.0}, "pressure_noise_std")):
        with pytest.raises(ValueError, match=name):
            gym.make(ENV_ID, **kw)


# ============================================================================ env: physics, reward, render
def test_reward_formula():
    env = gym.make(ENV_ID).unwrapped
    ref = 0.05 + 0.02 * np.sin(np.linspace(0.0, 6.0, 300))
    env.reset(seed=2, options={"reference": _padded(ref)})
    prev = 0.0
    for k, a in enumerate(_random_actions(100, seed=6), start=1):
        _, reward, _, _, info = env.step(a)
        e = ref[k] - info["state"]["y"]
        assert reward == pytest.approx(-((e / 0.01) ** 2) - 0.01 * (float(a[0]) - prev) ** 2, abs=1e-9, rel=0)
        prev = float(a[0])


def test_constant_action_gives_constant_speed_and_eq1_friction():
    """The env allows the 004 sec. 3 experiment: hold the valve, read A (pa - pb) = F_f(v)."""
    env = gym.make(ENV_ID, randomize=False).unwrapped
    env.reset(seed=0, options={"state": {"y": 0.005}})
    Y, F = [], []
    for _ in range(800):
        _, _, _, _, info = env.step(_a(0.3))  # 6.5 V
        s = info["state"]
        Y.append(s["y"]), F.append(A * (s["pa"] - s["pb"]))
    Y, F = np.array(Y), np.array(F)
    win = (Y > 0.3 * L) & (Y < 0.7 * L)
    v = np.gradient(Y, DT)[win]
    assert np.std(v) < 0.05 * np.mean(v) and np.mean(v) > 0.05  # nearly constant speed
    # inertia is negligible: M dv/dt is < 0.5 % of the friction force
    assert NOMINAL.mass * np.max(np.abs(np.gradient(v, DT))) < 0.005 * np.mean(F[win])
    assert np.mean(F[win]) == pytest.approx(float(rc.steady_friction(NOMINAL, np.mean(v))), rel=0.01)


def test_observation_semantics_and_noise():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    ref = np.full(100, HALF + 0.004)
    obs, info = env.reset(seed=0, options={"state": {"y": HALF}, "reference": _padded(ref)})
    p0 = rc.centre_pressure(NOMINAL)
    assert obs[0] == pytest.approx(0.4, abs=1e-5) and obs[7] == pytest.approx(0.0, abs=1e-4)
    assert obs[8] == pytest.approx(p0 / NOMINAL.supply_pressure, rel=1e-6) and obs[10] == 0.0
    kw = dict(position_noise_std=1e-4, pressure_noise_std=3e3, randomize=False)
    a = _rollout(gym.make(ENV_ID, **kw).unwrapped, 21, _random_actions(200))
    b = _rollout(gym.make(ENV_ID, **kw).unwrapped, 21, _random_actions(200))
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    env = gym.make(ENV_ID, **kw).unwrapped
    env.reset(seed=21)
    dy = []
    for act in _random_actions(400):
        _, _, _, _, info = env.step(act)
        dy.append(env.channel_values()["y"] - info["state"]["y"])
    assert 0.8e-4 < np.std(dy) < 1.2e-4


def test_render_rgb_array():
    env = gym.make(ENV_ID, render_mode="rgb_array", randomize=False)
    env.reset(seed=0, options={"state": {"y": 0.01}})
    f0 = env.render()
    assert isinstance(f0, np.ndarray) and f0.dtype == np.uint8 and f0.ndim == 3 and f0.shape[2] == 3
    for _ in range(200):
        env.step(_a(1.0))
    f1 = env.render()
    assert f1.shape == f0.shape and np.count_nonzero(np.any(f0 != f1, axis=2)) > 50
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    assert env.render() is None


def test_env_step_kernels_follow_the_supply_droop_and_agree_bit_for_bit():
    """Without droop the envs step with the stiff-supply kernels (no droop solve to compile), with
    a bristle state in every copy with the refinement test compiled without the static curve: the
    same numbers as the general kernels; a copy with droop or with the static curve switches every
    copy over. The vector env steps and observes in one kernel bound to the stiff-supply LuGre step
    for the default sets and to the general step otherwise: compared with the general parallel step
    and a separate observation."""
    import gymnasium as gym

    from hydro_envs.envs.base import PlantBatch
    from hydro_envs.plants.rodless_cylinder import kernels as K

    def run(force_full: bool, **params) -> tuple[np.ndarray, object]:
        venv = gym.make_vec("hydro_envs/RodlessCylinder-v0", num_envs=4, vectorization_mode="vector_entry_point")
        venv.reset(seed=5, options={"params": params} if params else None)
        b = venv.unwrapped._batch
        acts = np.random.default_rng(0).uniform(-1, 1, (150, 4, 1)).astype(np.float32)
        venv.step(acts[0])
        chosen = b.step_kernel
        if force_full:
            b.step_kernel = K.step_parallel
            b.step_and_observe = lambda: PlantBatch.step_then_observe(b)
        else:
            fused = b.step_observe
            assert fused.py_func.__name__ == ("_step_observe_parallel_default" if not params
                                              else "_step_observe_parallel")
        for a in acts[1:]:
            venv.step(a)
        return b.Y.copy(), chosen

    y_stiff, kernel = run(False)
    assert kernel is K._KERNELS[False, False].step_parallel  # no droop, a bristle state in every copy
    y_full, _ = run(True)
    assert np.array_equal(y_stiff, y_full)
    y_droop, kernel = run(False, supply_line_resistance=5e8)
    assert kernel is K._KERNELS[True, False].step_parallel
    assert np.array_equal(y_droop, run(True, supply_line_resistance=5e8)[0])
    assert not np.allclose(y_droop, y_stiff)
    y_static, kernel = run(False, bristle_stiffness=0.0)
    assert kernel is K._KERNELS[False, True].step_parallel
    assert np.array_equal(y_static, run(True, bristle_stiffness=0.0)[0])
    _, kernel = run(False, bristle_stiffness=0.0, supply_line_resistance=5e8)
    assert kernel is K.step_parallel
    assert not np.allclose(y_droop, y_stiff)
    y_static, kernel = run(False, bristle_stiffness=0.0)
    assert kernel is K._KERNELS[False, True].step_parallel
    assert np.array_equal(y_static, run(True, bristle_stiffness=0.0)[0])
