"""Tests of ``hydro_envs/ServoCylinderPosition-v0`` (single env) and its native vector env.

The env's module docstring is the spec: action/observation layout, reward, reset options and
info. Every test checks behaviour against something computed independently of the env's own
code: the YAML ranges, the nominal dataclass, the reference array the test supplied, a
single env stepped alongside a vector env, or plain physics (full valve opening drives the
piston to a stop).
"""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import hydro_envs  # noqa: F401  (registers the env)
from hydro_envs.envs.servo_cylinder import ServoCylinderPositionEnv
from hydro_envs.params import ParameterError
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.plants.servo_cylinder.model import no_load_velocity
from hydro_envs.randomization import load_randomization
from env_helpers import action as _a
from env_helpers import padded as _padded
from env_helpers import random_actions as _random_actions
from env_helpers import rollout as _rollout


ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
NOMINAL = ServoCylinderParams()
L = NOMINAL.stroke
HALF = 0.5 * L
STATE_KEYS = ("x", "v", "p1", "p2", "xv", "vv", "z")
PARAM_NAMES = ServoCylinderParams.names()
OBS_DIM = 11


def _bang_bang(n, rng):
    """+-1 actions switching every 20-100 steps (drives the piston into the stops)."""
    out = np.empty((n, 1), dtype=np.float32)
    a, k = float(rng.choice([-1.0, 1.0])), 0
    while k < n:
        hold = int(rng.integers(20, 101))
        out[k : k + hold] = a
        a, k = -a, k + hold
    return out


@pytest.fixture(scope="module")
def spec():
    return load_randomization("servo_cylinder", ServoCylinderParams)


# ----------------------------------------------------------------------------- API checks
def test_gym_make_passive_checker_reset_and_step_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(ENV_ID)
        obs, info = env.reset(seed=0)
        for a in (env.action_space.sample(), _a(1.0), _a(-1.0), _a(0.0)):
            obs, reward, terminated, truncated, info = env.step(a)
        assert isinstance(reward, float)
        assert terminated is False and truncated is False
    assert env.spec.max_episode_steps == 2000


def test_spaces():
    env = gym.make(ENV_ID)
    a = env.action_space
    assert isinstance(a, gym.spaces.Box)
    assert a.shape == (1,) and a.dtype == np.float32
    np.testing.assert_array_equal(a.low, [-1.0])
    np.testing.assert_array_equal(a.high, [1.0])
    o = env.observation_space
    assert isinstance(o, gym.spaces.Box)
    assert o.shape == (OBS_DIM,) and o.dtype == np.float32
    # documented finite bounds: normalised reference + preview in [-1, 1], pressures >= 0,
    # last action in [-1, 1]
    np.testing.assert_array_equal(o.low[1:7], -1.0)
    np.testing.assert_array_equal(o.high[1:7], 1.0)
    np.testing.assert_array_equal(o.low[8:10], 0.0)
    assert (o.low[10], o.high[10]) == (-1.0, 1.0)


@pytest.mark.parametrize("kind", ["steps", "smooth", "sine", "chirp", "mixed"])
def test_observations_are_float32_and_inside_declared_bounds(kind):
    env = gym.make(ENV_ID, reference=kind).unwrapped
    space = env.observation_space
    finite_low = np.isfinite(space.low)
    finite_high = np.isfinite(space.high)
    obs_all, _, _ = _rollout(env, 7, _random_actions(400, seed=8))
    obs, _ = env.reset(seed=7)
    assert obs.dtype == np.float32 and obs.shape == (OBS_DIM,)
    assert np.all(np.isfinite(obs_all))
    assert np.all(obs_all[:, finite_low] >= space.low[finite_low])
    assert np.all(obs_all[:, finite_high] <= space.high[finite_high])
    for o in obs_all:
        assert space.contains(o.astype(np.float32))


# ----------------------------------------------------------------------------- determinism
def test_different_seeds_give_different_episodes():
    env = gym.make(ENV_ID)
    o1, i1 = env.reset(seed=1)
    o2, i2 = env.reset(seed=2)
    assert i1["params"] != i2["params"]
    assert not np.array_equal(o1[1:7], o2[1:7])  # reference (and its preview) differs
    assert i1["state"]["x"] != i2["state"]["x"]  # initial position differs


def test_unseeded_reset_continues_the_seeded_stream():
    e1, e2 = gym.make(ENV_ID).unwrapped, gym.make(ENV_ID).unwrapped
    first1, _ = e1.reset(seed=5)
    e2.reset(seed=5)
    actions = _random_actions(50, seed=2)
    for a in actions:
        e1.step(a)
        e2.step(a)
    o1, i1 = e1.reset()
    o2, i2 = e2.reset()
    np.testing.assert_array_equal(o1, o2)
    assert i1 == i2
    assert not np.array_equal(o1, first1)  # a new episode, not a replay of the seeded one
    oo1, rr1, ss1 = [], [], []
    for a in actions:
        r = e1.step(a)
        oo1.append(r[0]), rr1.append(r[1]), ss1.append(r[4]["state"])
    for k, a in enumerate(actions):
        r = e2.step(a)
        np.testing.assert_array_equal(r[0], oo1[k])
        assert r[1] == rr1[k] and r[4]["state"] == ss1[k]


# ----------------------------------------------------------------------------- vector env
def _make_vec(n=4, **kwargs):
    return gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)


def _vec_rollout(venv, seed, actions):
    obs, info = venv.reset(seed=seed)
    O, R, X = [obs], [], [info["state"]["x"]]
    for a in actions:
        obs, r, term, trunc, info = venv.step(a)
        O.append(obs), R.append(r), X.append(info["state"]["x"])
    return np.array(O), np.array(R), np.array(X)


def test_vector_env_spaces_and_type():
    venv = _make_vec()
    assert type(venv.unwrapped).__name__ == "ServoCylinderPositionVectorEnv"
    assert venv.num_envs == 4
    assert venv.observation_space.shape == (4, OBS_DIM)
    assert venv.action_space.shape == (4, 1)
    obs, info = venv.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == (4, OBS_DIM)
    assert set(info["state"]) == set(STATE_KEYS)
    assert set(info["params"]) == set(PARAM_NAMES)
    assert info["params"]["mass"].shape == (4,)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP


def test_vector_env_same_seed_identical():
    actions = _random_actions(100, seed=4, shape=(4, 1))
    a = _vec_rollout(_make_vec(), 3, actions)
    b = _vec_rollout(_make_vec(), 3, actions)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_vector_next_step_autoreset():
    n, seed, T = 4, 3, 5
    venv = _make_vec(n, max_episode_steps=T)
    obs0, _ = venv.reset(seed=seed)
    act = np.full((n, 1), 0.5, dtype=np.float32)
    for k in range(1, T + 1):
        obs, reward, term, trunc, info = venv.step(act)
        assert not term.any()
        assert trunc.all() == (k == T) and trunc.any() == (k == T)
    last_obs_before = obs
    # step T+1: every copy resets; reward 0, not truncated, the fresh first observation
    obs, reward, term, trunc, info = venv.step(act)
    np.testing.assert_array_equal(reward, 0.0)
    assert not trunc.any() and not term.any()
    np.testing.assert_array_equal(obs[:, 10], 0.0)
    assert not np.array_equal(obs, last_obs_before)
    # that observation is what a single env of the same copy gives when reset after T steps
    for i in range(n):
        env = gym.make(ENV_ID, episode_steps=T, max_episode_steps=T)
        o, inf = env.reset(seed=seed + i)
        np.testing.assert_array_equal(o, obs0[i])
        for _ in range(T):
            env.step(act[i])
        o, inf = env.reset()
        np.testing.assert_array_equal(o, obs[i])
        assert inf["state"]["x"] == info["state"]["x"][i]
        assert inf["params"]["mass"] == info["params"]["mass"][i]
    # the step counter restarted: truncation again exactly T steps after the reset step
    for k in range(1, T + 1):
        obs, reward, term, trunc, info = venv.step(act)
        assert trunc.all() == (k == T) and trunc.any() == (k == T)
        assert np.all(reward != 0.0)


def test_vector_same_step_autoreset():
    n, seed, T = 4, 3, 5
    act = np.full((n, 1), 0.5, dtype=np.float32)
    ref_venv = _make_vec(n, max_episode_steps=T)  # NEXT_STEP, for the last obs of the episode
    ref_venv.reset(seed=seed)
    venv = _make_vec(n, max_episode_steps=T, autoreset_mode=AutoresetMode.SAME_STEP)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    venv.reset(seed=seed)
    for k in range(1, T + 1):
        obs, reward, term, trunc, info = venv.step(act)
        ref_obs, ref_reward, _, ref_trunc, _ = ref_venv.step(act)
        np.testing.assert_array_equal(reward, ref_reward)
        np.testing.assert_array_equal(trunc, ref_trunc)
        if k < T:
            assert "final_obs" not in info and "_final_obs" not in info
            np.testing.assert_array_equal(obs, ref_obs)
    assert trunc.all()
    assert "final_obs" in info and "_final_obs" in info
    np.testing.assert_array_equal(info["_final_obs"], np.ones(n, dtype=bool))
    np.testing.assert_array_equal(np.stack(list(info["final_obs"])), ref_obs)
    # the returned obs is the reset obs (same as NEXT_STEP's reset step)
    np.testing.assert_array_equal(obs[:, 10], 0.0)
    reset_obs, *_ = ref_venv.step(act)
    np.testing.assert_array_equal(obs, reset_obs)
    # and the next step is not an end
    obs, reward, term, trunc, info = venv.step(act)
    assert not trunc.any() and "final_obs" not in info


def test_vector_reset_mask_resets_only_masked_copies():
    n, T = 4, 5
    venv = _make_vec(n, max_episode_steps=T)
    venv.reset(seed=1)
    act = np.full((n, 1), 0.2, dtype=np.float32)
    for _ in range(3):
        obs, *_ = venv.step(act)
    before = obs.copy()
    obs, info = venv.reset(options={"reset_mask": np.array([True, False, False, False])})
    assert obs[0, 10] == 0.0
    np.testing.assert_array_equal(obs[1:], before[1:])
    ends = []
    for k in range(1, T + 1):
        _, _, _, trunc, _ = venv.step(act)
        ends.append(trunc.copy())
    ends = np.array(ends)
    assert ends[1, 1:].all() and not ends[1, 0]  # copies 1-3: 5th step of their episode
    assert ends[4, 0] and not ends[4, 1:].any()  # copy 0 restarted 3 steps later


def test_vector_step_infos_are_new_objects():
    venv = _make_vec(2)
    venv.reset(seed=0)
    act = np.zeros((2, 1), dtype=np.float32)
    _, _, _, _, info1 = venv.step(act)
    mass = info1["params"]["mass"].copy()
    # the per-episode parameter arrays are shared until the next reset, so they are
    # read-only: writing to them fails loudly instead of leaking into later infos
    with pytest.raises(ValueError):
        info1["params"]["mass"][:] = -1.0
    info1["params"]["extra"] = 1
    _, _, _, _, info2 = venv.step(act)
    assert "extra" not in info2["params"]
    assert info2["params"] is not info1["params"]
    np.testing.assert_array_equal(info2["params"]["mass"], mass)


# ----------------------------------------------------------------------------- actions
def test_rejected_action_leaves_state_untouched():
    e1, e2 = gym.make(ENV_ID).unwrapped, gym.make(ENV_ID).unwrapped
    e1.reset(seed=9)
    e2.reset(seed=9)
    with pytest.raises(ValueError):
        e1.step(_a(np.nan))
    with pytest.raises(ValueError):
        e1.step(np.zeros(2, dtype=np.float32))
    r1 = e1.step(_a(0.3))
    r2 = e2.step(_a(0.3))
    np.testing.assert_array_equal(r1[0], r2[0])
    assert r1[1] == r2[1] and r1[4]["state"] == r2[4]["state"]


@pytest.mark.parametrize("shape", [(2,), (1, 1, 1), (3, 1), (0,)])
def test_wrong_action_shape_raises(shape):
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(shape, dtype=np.float32))


def test_vector_env_action_validation():
    venv = _make_vec(4)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.array([[0.0], [np.nan], [0.0], [0.0]], dtype=np.float32))
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((3, 1), dtype=np.float32))
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((4, 2), dtype=np.float32))
    obs, *_ = venv.step(np.array([[5.0], [-5.0], [0.25], [1.0]], dtype=np.float32))
    np.testing.assert_array_equal(obs[:, 10], np.array([1.0, -1.0, 0.25, 1.0], dtype=np.float32))


@pytest.mark.parametrize("big, clipped", [(5.0, 1.0), (-7.5, -1.0), (1e30, 1.0)])
def test_out_of_range_actions_are_clipped(big, clipped):
    e1, e2 = gym.make(ENV_ID).unwrapped, gym.make(ENV_ID).unwrapped
    e1.reset(seed=11)
    e2.reset(seed=11)
    for _ in range(5):
        o1, r1, _, _, i1 = e1.step(_a(big))
        o2, r2, _, _, i2 = e2.step(_a(clipped))
        assert i1["state"] == i2["state"]
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2
        assert o1[10] == clipped
    # list/float actions go through the same clipping
    o3, *_ = e1.step([big])
    o4, *_ = e2.step(clipped)
    np.testing.assert_array_equal(o3, o4)


def test_step_before_reset_raises():
    env = gym.make(ENV_ID).unwrapped
    with pytest.raises(gym.error.ResetNeeded):
        env.step(_a(0.0))


# ----------------------------------------------------------------------------- info
def _check_state_info(state, params):
    assert set(state) == set(STATE_KEYS)
    for k in STATE_KEYS:
        assert type(state[k]) is float and math.isfinite(state[k])
    assert -5e-4 <= state["x"] <= params["stroke"] + 5e-4
    for k in ("p1", "p2"):  # absolute Pa: between the floor and ~20 MPa
        assert params["pressure_floor"] <= state[k] <= 3e7


def test_info_contents_at_reset_and_every_step():
    env = gym.make(ENV_ID).unwrapped
    obs, info = env.reset(seed=4)
    assert set(info) >= {"state", "params"}
    assert set(info["params"]) == set(PARAM_NAMES)
    _check_state_info(info["state"], info["params"])
    # rest state at reset: piston in the middle half, chambers at (ps + pR) / 2
    p = info["params"]
    assert 0.25 * p["stroke"] <= info["state"]["x"] <= 0.75 * p["stroke"]
    pn = 0.5 * (p["supply_pressure"] + p["tank_pressure"])
    assert info["state"]["p1"] == pytest.approx(pn, rel=1e-12)
    assert info["state"]["p2"] == pytest.approx(pn, rel=1e-12)
    assert 5e6 < pn < 1e7  # MPa range, absolute
    prev = info
    for a in _random_actions(100, seed=5):
        obs, r, term, trunc, info = env.step(a)
        _check_state_info(info["state"], info["params"])
        assert info["params"] == p
        assert info is not prev and info["state"] is not prev["state"]
        assert info["params"] is not prev["params"]
        prev = info


def test_mutating_info_does_not_leak():
    env = gym.make(ENV_ID).unwrapped
    _, info0 = env.reset(seed=4)
    mass = info0["params"]["mass"]
    info0["params"]["mass"] = 1e3
    info0["state"]["x"] = -1.0
    _, _, _, _, info1 = env.step(_a(0.0))
    assert info1["params"]["mass"] == mass
    assert env.params.mass == mass
    assert info1["state"]["x"] > 0.0
    info1["params"]["mass"] = 2e3
    info1["state"]["p1"] = 0.0
    _, _, _, _, info2 = env.step(_a(0.0))
    assert info2["params"]["mass"] == mass
    assert info2["state"]["p1"] > 1e6


def test_randomize_false_gives_nominal_params():
    env = gym.make(ENV_ID, randomize=False)
    for seed in (0, 1, 2):
        _, info = env.reset(seed=seed)
        assert info["params"] == NOMINAL.as_dict()
        _, _, _, _, info = env.step(_a(0.1))
        assert info["params"] == NOMINAL.as_dict()
    assert env.unwrapped.n_substeps == 2  # documented for the nominal plant


def test_randomize_true_draws_inside_yaml_ranges(spec):
    env = gym.make(ENV_ID)
    ranges = {row["name"]: row["value_range"] for row in spec.table()}
    assert ranges["bulk_modulus"] == (5e8, 1e9)
    assert ranges["mass"] == pytest.approx((12.3, 24.6))
    drawn = {name: [] for name in ranges}
    for seed in range(12):
        _, info = env.reset(seed=seed)
        p = info["params"]
        ServoCylinderParams(**p)  # a valid parameter set
        for name in PARAM_NAMES:
            if name in ranges:
                lo, hi = ranges[name]
                assert lo <= p[name] <= hi, (name, p[name], lo, hi)
                drawn[name].append(p[name])
            else:
                assert p[name] == getattr(NOMINAL, name), name
    for name, values in drawn.items():  # really drawn, not left nominal
        assert len(set(values)) == len(values), name
    assert 5e8 <= min(drawn["bulk_modulus"]) and max(drawn["bulk_modulus"]) <= 1e9
    assert 12.3 <= min(drawn["mass"]) and max(drawn["mass"]) <= 24.6


# ----------------------------------------------------------------------------- reset options
def test_reset_params_override():
    env = gym.make(ENV_ID)
    _, info = env.reset(seed=0, options={"params": {"mass": 20.0, "load_force": 100.0}})
    assert info["params"]["mass"] == 20.0
    assert info["params"]["load_force"] == 100.0
    assert env.unwrapped.params.mass == 20.0
    _, _, _, _, info = env.step(_a(0.0))
    assert info["params"]["mass"] == 20.0
    # override applies after the draw: the other drawn parameters are unaffected
    _, plain = env.reset(seed=0)
    _, over = env.reset(seed=0, options={"params": {"mass": 20.0}})
    assert {k: v for k, v in plain["params"].items() if k != "mass"} == {
        k: v for k, v in over["params"].items() if k != "mass"
    }


def test_reset_params_override_errors():
    env = gym.make(ENV_ID)
    with pytest.raises(ParameterError, match="no_such_param"):
        env.reset(seed=0, options={"params": {"no_such_param": 1.0}})
    with pytest.raises(ParameterError, match=r"mass.*\[0.05, 10000\] kg"):
        env.reset(seed=0, options={"params": {"mass": -1.0}})
    with pytest.raises(ParameterError, match="bulk_modulus"):
        env.reset(seed=0, options={"params": {"bulk_modulus": float("nan")}})


def test_reset_state_override():
    env = gym.make(ENV_ID)
    _, info = env.reset(seed=0, options={"state": {"x": 0.01}})
    assert info["state"]["x"] == 0.01
    _, info = env.reset(seed=0, options={"state": {"x": 0.02, "p1": 2e6, "p2": 3e6, "v": 0.0}})
    assert (info["state"]["x"], info["state"]["p1"], info["state"]["p2"]) == (0.02, 2e6, 3e6)
    with pytest.raises(ValueError, match="bogus"):
        env.reset(seed=0, options={"state": {"bogus": 1.0}})
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"state": {"x": NOMINAL.stroke + 1e-3}, "params": {"stroke": NOMINAL.stroke}})
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"state": {"x": -1e-4}})
    with pytest.raises(ValueError, match="floor"):
        env.reset(seed=0, options={"state": {"p1": 500.0}})
    with pytest.raises(ValueError, match="floor"):
        env.reset(seed=0, options={"state": {"p2": 0.0}})
    with pytest.raises(ValueError, match="finite"):
        env.reset(seed=0, options={"state": {"v": float("nan")}})


@pytest.mark.parametrize("kind", ["steps", "sine", "chirp", "smooth"])
def test_reset_reference_kind(kind):
    env = gym.make(ENV_ID, randomize=False).unwrapped
    obs, info = env.reset(seed=3, options={"reference": kind})
    refs = [obs[1]]
    for _ in range(600):
        obs, *_ = env.step(_a(0.0))
        refs.append(obs[1])
    r = HALF + HALF * np.array(refs, dtype=np.float64)  # back to metres
    # references lie in the band [0.1 L, 0.9 L] (float32 rounding of the normalised value)
    assert r.min() >= 0.1 * L - 1e-8 and r.max() <= 0.9 * L + 1e-8
    assert np.ptp(r) > 1e-4  # not constant
    rate = np.abs(np.diff(r)) / 1e-3
    if kind == "steps":
        assert np.count_nonzero(rate > 1e-6) <= 4  # piecewise constant, held >= 0.2 s
    else:  # smooth kinds respect 0.6 x the no-load speed
        assert rate.max() <= 0.6 * no_load_velocity(NOMINAL) * 1.01 + 1e-3


def test_reset_reference_unknown_kind_raises():
    env = gym.make(ENV_ID)
    with pytest.raises(ValueError, match="zigzag"):
        env.reset(seed=0, options={"reference": "zigzag"})


def test_reset_reference_array():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    ref = np.linspace(0.02, 0.05, 2000)  # one sample per step of the 2000-step episode
    obs, _ = env.reset(seed=0, options={"reference": _padded(ref)})
    assert obs[1] == np.float32((ref[0] - HALF) / HALF)
    for m, d in enumerate((10, 20, 30, 40, 50)):  # preview at +10..+50 ms
        assert obs[2 + m] == np.float32((ref[d] - HALF) / HALF)
    for k in range(1, 4):
        obs, *_ = env.step(_a(0.0))
        assert obs[1] == np.float32((ref[k] - HALF) / HALF)
        assert obs[6] == np.float32((ref[k + 50] - HALF) / HALF)
    # an array shorter than the episode is refused (never silently held); past the episode's
    # last step the preview repeats the last sample
    with pytest.raises(ValueError, match="has 2 samples"):
        env.reset(seed=0, options={"reference": [0.03, 0.04]})
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"reference": [0.03, L + 0.01]})
    with pytest.raises(ValueError):
        env.reset(seed=0, options={"reference": [0.03, np.nan]})
    with pytest.raises(ValueError):
        env.reset(seed=0, options={"reference": np.full((3, 3), 0.03)})
    with pytest.raises(ValueError):
        env.reset(seed=0, options={"reference": []})


def test_reset_unknown_option_raises():
    env = gym.make(ENV_ID)
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(seed=0, options={"initial_state": {"x": 0.01}})


# ----------------------------------------------------------------------------- obs + reward
def test_observation_semantics_from_known_state():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    ref = np.full(50, HALF + 0.005)
    obs, info = env.reset(seed=0, options={"state": {"x": HALF}, "reference": _padded(ref)})
    assert info["state"]["x"] == HALF
    # error (r - x_meas)/0.01 with the encoder's 3e-5 m quantisation
    assert abs(obs[0] - 0.5) <= 3e-3 + 1e-6
    assert obs[1] == pytest.approx(0.005 / HALF, abs=1e-6)
    np.testing.assert_allclose(obs[2:7], 0.005 / HALF, atol=1e-6)
    assert abs(obs[7]) <= 1.5e-5 / HALF + 1e-7
    pn = 0.5 * (NOMINAL.supply_pressure + NOMINAL.tank_pressure)
    assert obs[8] == pytest.approx(pn / NOMINAL.supply_pressure, abs=1e-6)
    assert obs[9] == pytest.approx(pn / NOMINAL.supply_pressure, abs=1e-6)
    assert obs[10] == 0.0
    # after steps the pressure entries track the true state p / ps
    for _ in range(20):
        obs, _, _, _, info = env.step(_a(0.4))
    s = info["state"]
    assert obs[8] == pytest.approx(s["p1"] / NOMINAL.supply_pressure, abs=1e-6)
    assert obs[9] == pytest.approx(s["p2"] / NOMINAL.supply_pressure, abs=1e-6)
    assert obs[10] == np.float32(0.4)
    assert abs(obs[0] - (HALF + 0.005 - s["x"]) / 0.01) <= 1.5e-3 + 1e-6
    assert abs(obs[7] - (s["x"] - HALF) / HALF) <= 1.5e-5 / HALF + 1e-6


def test_reward_formula():
    env = gym.make(ENV_ID).unwrapped
    ref = 0.035 + 0.01 * np.sin(np.linspace(0.0, 6.0, 400))
    actions = _random_actions(200, seed=6)
    _, info = env.reset(seed=2, options={"reference": _padded(ref)})
    prev = 0.0
    for k, a in enumerate(actions, start=1):
        obs, reward, _, _, info = env.step(a)
        e = ref[k] - info["state"]["x"]
        a_k = float(a[0])
        expected = -((e / 0.01) ** 2) - 0.01 * (a_k - prev) ** 2
        assert reward == pytest.approx(expected, abs=1e-9, rel=0)
        prev = a_k
    # custom scales enter the same formula
    env = gym.make(ENV_ID, error_scale=0.002, action_rate_penalty=0.5).unwrapped
    _, info = env.reset(seed=2, options={"reference": _padded(ref)})
    _, r1, _, _, info = env.step(_a(0.8))
    e = ref[1] - info["state"]["x"]
    assert r1 == pytest.approx(-((e / 0.002) ** 2) - 0.5 * float(np.float32(0.8)) ** 2, abs=1e-9, rel=0)


# ----------------------------------------------------------------------------- physics
def _hold(env, x0, action, steps=300):
    env.reset(seed=0, options={"state": {"x": x0}})
    xs = []
    for _ in range(steps):
        _, _, _, _, info = env.step(_a(action))
        xs.append(info["state"]["x"])
    return np.array(xs), info


def test_full_opening_drives_to_the_stops():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    xs, info = _hold(env, 0.01, 1.0)
    assert abs(xs[-1] - L) <= 5e-4
    assert xs[20] > 0.01  # moves in +x right away
    assert info["state"]["p1"] > info["state"]["p2"]  # chamber 1 pressurised to push
    xs, info = _hold(env, L - 0.01, -1.0)
    assert abs(xs[-1]) <= 5e-4
    assert xs[20] < L - 0.01
    assert info["state"]["p2"] > info["state"]["p1"]


def test_closed_valve_holds_position():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    xs, info = _hold(env, 0.01, 0.0)
    assert np.max(np.abs(xs - 0.01)) <= 1e-4


def test_guards_at_randomisation_corners(spec):
    rng = np.random.default_rng(2024)
    n = len(spec.entries)
    corners = [spec.corner(False), spec.corner(True)]
    corners += [spec.corner(list(rng.integers(0, 2, n).astype(bool))) for _ in range(3)]
    env = gym.make(ENV_ID, randomize=False).unwrapped
    for c in corners:
        p = c.as_dict()
        obs, info = env.reset(seed=int(rng.integers(1000)), options={"params": p})
        assert info["params"] == p
        X, P = [], []
        for a in _bang_bang(2000, rng):
            obs, r, _, _, info = env.step(a)
            s = info["state"]
            X.append(s["x"]), P.append((s["p1"], s["p2"]))
            assert math.isfinite(r) and np.all(np.isfinite(obs))
            assert all(math.isfinite(v) for v in s.values())
        X, P = np.array(X), np.array(P)
        assert P.min() >= c.pressure_floor
        assert X.min() >= -5e-4 and X.max() <= c.stroke + 5e-4
        assert X.max() - X.min() > 0.5 * c.stroke  # bang-bang really travelled across


# ----------------------------------------------------------------------------- render
def test_render_rgb_array_changes_when_piston_moves():
    env = gym.make(ENV_ID, render_mode="rgb_array", randomize=False)
    env.reset(seed=0, options={"state": {"x": 0.01}})
    f0 = env.render()
    assert isinstance(f0, np.ndarray) and f0.dtype == np.uint8
    assert f0.ndim == 3 and f0.shape[2] == 3 and f0.shape[0] > 10 and f0.shape[1] > 10
    for _ in range(150):
        env.step(_a(1.0))
    f1 = env.render()
    assert f1.shape == f0.shape and f1.dtype == np.uint8
    assert np.count_nonzero(np.any(f0 != f1, axis=2)) > 50


def test_render_none_and_invalid_mode():
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    assert env.render() is None
    with warnings.catch_warnings(), pytest.raises(ValueError, match="render_mode"):
        warnings.simplefilter("ignore")  # gymnasium's own "not in render_modes" notice
        gym.make(ENV_ID, render_mode="ansi")
    with pytest.raises(ValueError, match="render_mode"):
        ServoCylinderPositionEnv(render_mode="human")
    with pytest.raises(ValueError, match="render"):
        _make_vec(2, render_mode="rgb_array")


# ----------------------------------------------------------------------------- constructor
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"position_noise_std": -1e-4}, "position_noise_std"),
        ({"pressure_noise_std": float("nan")}, "pressure_noise_std"),
        ({"error_scale": 0.0}, "error_scale"),
        ({"error_scale": -0.01}, "error_scale"),
        ({"reference": "zigzag"}, "reference"),
        ({"action_rate_penalty": -1.0}, "action_rate_penalty"),
    ],
)
def test_constructor_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


# ----------------------------------------------------------------------------- sensors
def test_noise_is_seeded_and_of_the_right_size():
    kw = dict(position_noise_std=1e-4, pressure_noise_std=1e4, randomize=False)
    actions = _random_actions(400, seed=12)
    a = _rollout(gym.make(ENV_ID, **kw).unwrapped, 21, actions)
    b = _rollout(gym.make(ENV_ID, **kw).unwrapped, 21, actions)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    env = gym.make(ENV_ID, **kw).unwrapped
    env.reset(seed=21, options={"state": {"x": HALF}})
    dx, dp1, dp2 = [], [], []
    for act in actions:
        _, _, _, _, info = env.step(act)
        ch = env.channel_values()
        dx.append(ch["x"] - info["state"]["x"])
        dp1.append(ch["p1"] - info["state"]["p1"])
        dp2.append(ch["p2"] - info["state"]["p2"])
    assert 0.8e-4 < np.std(dx) < 1.2e-4
    assert abs(np.mean(dx)) < 2e-5
    assert 8e3 < np.std(dp1) < 1.2e4 and 8e3 < np.std(dp2) < 1.2e4
    # noise-free env: measured x is the true x up to the 0.03 mm encoder quantisation
    env = gym.make(ENV_ID, randomize=False).unwrapped
    env.reset(seed=21)
    for act in actions[:100]:
        _, _, _, _, info = env.step(act)
        ch = env.channel_values()
        assert abs(ch["x"] - info["state"]["x"]) <= 1.5e-5 + 1e-12
        assert abs(round(ch["x"] / 3e-5) * 3e-5 - ch["x"]) < 1e-12
        assert ch["p1"] == info["state"]["p1"] and ch["p2"] == info["state"]["p2"]


def test_reward_ignores_sensor_noise():
    ref = np.full(100, HALF + 0.003)
    rewards = []
    for kw in ({}, {"position_noise_std": 1e-3, "pressure_noise_std": 1e5}):
        env = gym.make(ENV_ID, randomize=False, **kw).unwrapped
        env.reset(seed=1, options={"state": {"x": HALF}, "reference": _padded(ref)})
        rewards.append([env.step(_a(0.2))[1] for _ in range(30)])
    np.testing.assert_array_equal(rewards[0], rewards[1])


def test_noisy_pressure_observation_stays_in_space():
    env = gym.make(ENV_ID, randomize=False, pressure_noise_std=1e4).unwrapped
    floor = NOMINAL.pressure_floor
    obs, _ = env.reset(seed=0, options={"state": {"p1": floor, "p2": floor}})
    observations = [obs]
    for _ in range(20):
        observations.append(env.step(_a(0.0))[0])
    for o in observations:
        assert env.observation_space.contains(o)


def test_channel_values():
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    ch = env.channel_values()
    assert set(ch) == {"u", "x", "p1", "p2"}
    assert ch["u"] == 0.0
    for a in (0.37, -1.0, 0.0, 2.0):
        _, _, _, _, info = env.step(_a(a))
        ch = env.channel_values()
        assert all(type(v) is float for v in ch.values())
        expected_u = float(np.float32(min(a, 1.0))) * 10.0
        assert ch["u"] == pytest.approx(expected_u, abs=1e-12)
        assert ch["p1"] == info["state"]["p1"]
