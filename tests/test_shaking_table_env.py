"""Shaking table env (seed 003): references, spaces and channels, vector resets, info, reward, guards.

Every check compares against something independent of the code under test: the reference
generators' feasibility limits (stroke, flow, force), the Kanai-Tajimi spectrum, single envs
beside a vector env after a masked reset, the YAML ranges, the reward formula recomputed from
``info["state"]``, and long random rollouts at the randomisation corners. The contract every env
keeps (``check_env``, seeding, vector copies, non-finite actions): ``test_env_contract.py``;
plant physics and numerics: ``test_shaking_table.py``.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from scipy import signal

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs.data.channels import channels_for
from hydro_envs.envs.shaking_table import ACCELEROMETER_RANGE, EPISODE_STEPS, ShakingTableEnv
from hydro_envs.envs.shaking_table.references import (
    KANAI_TAJIMI,
    TABLE_REFERENCE_KINDS,
    generate_table_reference,
    reference_limits,
)
from hydro_envs.params import ParameterError
from hydro_envs.plants.shaking_table import model as st
from hydro_envs.plants.shaking_table.params import ShakingTableParams
from hydro_envs.randomization import load_randomization
from env_helpers import action as _a
from env_helpers import padded as _padded
from env_helpers import random_actions as _random_actions
from env_helpers import rollout as _rollout


ENV_ID = "hydro_envs/ShakingTable-v0"
DT = 1e-3
NOMINAL = ShakingTableParams()
HALF = 0.5 * NOMINAL.stroke
STATE_KEYS = ("x", "v", "pa", "pb", "xv", "vv", "z")
PARAM_NAMES = ShakingTableParams.names()
OBS_DIM = 13


@pytest.fixture(scope="module")
def spec():
    return load_randomization("shaking_table", ShakingTableParams)


# =========================================================================== references
@pytest.mark.parametrize("kind", TABLE_REFERENCE_KINDS)
@pytest.mark.parametrize("specimen", ["none", "500kg"])
def test_references_are_feasible_and_start_from_rest(kind, specimen):
    p = ShakingTableParams.preset("modified_ifas", specimen)
    lim = reference_limits(p)
    rng = np.random.default_rng(11)
    for _ in range(5):
        a, d = generate_table_reference(kind, rng, 6051, DT, lim)
        # the reference is the acceleration of d: integrate it twice from rest
        v = np.concatenate([[0.0], np.cumsum(a) * DT])
        x = np.concatenate([[0.0], np.cumsum(v[:-1]) * DT])
        np.testing.assert_allclose(x[1:], d, atol=1e-9 + 1e-6 * np.abs(d).max())
        assert np.abs(d).max() <= lim.displacement * (1 + 1e-9)
        assert np.abs(np.diff(d)).max() / DT <= lim.velocity * (1 + 1e-9)
        assert np.abs(a).max() <= lim.acceleration * (1 + 1e-9)
        assert np.abs(a).max() > 0.02 * lim.acceleration  # not trivially small
        assert abs(a[0]) < 0.2 * np.abs(a).max()  # starts gently


def test_pulse_reference_equals_its_moves_summed_over_the_whole_record():
    """The pulse reference evaluates each move's raised-cosine ramp only on the move's samples
    (one more on either side) and adds the step after it: the same numbers, to the bit, as the
    ramp ``tau - sin(2 pi tau) / (2 pi)`` of ``tau = clip((t - start) / dur, 0, 1)`` summed over
    the whole record for every move, with the same draws."""
    from hydro_envs.envs.shaking_table.references import _pulse_shape

    def whole_record(rng, t):
        d = np.zeros_like(t)
        level, start = 0.0, rng.uniform(0.05, 0.4)
        while start < t[-1]:
            dur, new = rng.uniform(0.1, 0.5), rng.uniform(-1.0, 1.0)
            tau = np.clip((t - start) / dur, 0.0, 1.0)
            d += (new - level) * (tau - np.sin(2.0 * math.pi * tau) / (2.0 * math.pi))
            level = new
            start += dur + rng.uniform(0.2, 0.8)
        return d

    for seed in range(40):
        t = DT * np.arange(-1, 6051 + 1)
        np.testing.assert_array_equal(_pulse_shape(np.random.default_rng(seed), t),
                                      whole_record(np.random.default_rng(seed), t))


def test_reference_limits_follow_stroke_flow_and_force():
    lim = reference_limits(NOMINAL)
    assert lim.displacement == pytest.approx(0.4 * HALF)
    assert lim.velocity == pytest.approx(0.5 * st.no_load_velocity(NOMINAL))
    assert lim.acceleration == pytest.approx(0.4 * (NOMINAL.piston_area * 206e5 - NOMINAL.static_friction) / 850.0)
    # at 0.5 Hz the stroke limits a sine to D w^2 = 0.052 (pi)^2 m/s^2
    assert lim.displacement * math.pi**2 == pytest.approx(0.513, abs=1e-3)
    assert KANAI_TAJIMI["omega_g"] == pytest.approx(5 * math.pi) and KANAI_TAJIMI["zeta_g"] == 0.6


def test_transition_reference_doubles_or_halves_the_amplitude():
    rng = np.random.default_rng(3)
    for _ in range(6):
        a, _ = generate_table_reference("transition", rng, 6051, DT, reference_limits(NOMINAL))
        first, last = np.abs(a[1200:2400]).max(), np.abs(a[5000:6000]).max()
        assert last / first == pytest.approx(2.0, rel=0.05) or last / first == pytest.approx(0.5, rel=0.05)


def test_earthquake_spectrum_peaks_near_the_kanai_tajimi_frequency():
    rng = np.random.default_rng(4)
    psd = 0.0
    for _ in range(20):
        a, _ = generate_table_reference("earthquake", rng, 8192, DT, reference_limits(NOMINAL))
        f, pxx = signal.welch(a / np.abs(a).max(), fs=1000.0, nperseg=2048)
        psd = psd + pxx
    f_peak = f[np.argmax(psd)]
    assert 1.0 < f_peak < 4.5  # omega_g = 5 pi rad/s = 2.5 Hz, broadened by zeta_g = 0.6
    assert psd[f > 30].max() < 1e-2 * psd.max()


# =========================================================================== env API
def test_spaces_and_channels():
    env = gym.make(ENV_ID)
    assert env.action_space.shape == (1,) and env.action_space.dtype == np.float32
    o = env.observation_space
    assert o.shape == (OBS_DIM,) and o.dtype == np.float32 and np.all(np.isfinite(o.low))
    assert (o.low[7], o.high[7]) == (np.float32(-1.2), np.float32(1.2))
    assert o.high[8] == np.float32(ACCELEROMETER_RANGE / 10.0)
    assert [(c.name, c.unit) for c in channels_for("shaking_table")] == [
        ("u", "V"), ("x", "m"), ("a", "m/s^2"), ("pa", "Pa"), ("pb", "Pa")]
    env.reset(seed=0)
    ch = env.unwrapped.channel_values()
    assert list(ch) == ["u", "x", "a"] and ch["u"] == 0.0
    env.step(_a(0.37))
    assert env.unwrapped.channel_values()["u"] == pytest.approx(float(np.float32(0.37)) * 10.0)
    obs, *_ = env.step(_a(7.0))  # clipped to full stroke, and observed as such
    assert obs[10] == 1.0 and env.unwrapped.channel_values()["u"] == 10.0
    assert env.spec.max_episode_steps == EPISODE_STEPS == 6000  # the 6 s record of eq (23)


@pytest.mark.parametrize("kind", list(TABLE_REFERENCE_KINDS) + ["mixed"])
def test_observations_inside_declared_bounds(kind):
    env = gym.make(ENV_ID, reference=kind).unwrapped
    obs_all, _, _ = _rollout(env, 7, _random_actions(400, seed=8))
    assert obs_all.dtype == np.float32 and np.all(np.isfinite(obs_all))
    for o in obs_all:
        assert env.observation_space.contains(o)


def _make_vec(n=4, **kw):
    return gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)


def test_vector_masked_reset_does_not_disturb_the_other_copies_sensors():
    """Re-observing every copy after a masked reset must not advance their velocity filters."""
    n, seed = 3, 20
    actions = _random_actions(80, seed=4, shape=(n, 1))
    venv = _make_vec(n)
    venv.reset(seed=seed)
    for k in range(40):
        venv.step(actions[k])
    venv.reset(options={"reset_mask": np.array([True, False, False])})
    for k in range(40, 80):
        obs, *_ = venv.step(actions[k])
    for i in (1, 2):
        o, _, _ = _rollout(gym.make(ENV_ID).unwrapped, seed + i, actions[:, i])
        np.testing.assert_array_equal(o[-1], obs[i])


def test_vector_autoreset_next_step_and_same_step():
    n, T = 3, 5
    act = np.full((n, 1), 0.5, dtype=np.float32)
    venv = _make_vec(n, max_episode_steps=T)
    venv.reset(seed=3)
    for k in range(1, T + 1):
        _, _, term, trunc, _ = venv.step(act)
        assert not term.any() and trunc.all() == (k == T)
    obs, reward, _, trunc, _ = venv.step(act)
    np.testing.assert_array_equal(reward, 0.0)
    assert not trunc.any()
    np.testing.assert_array_equal(obs[:, 10], 0.0)
    venv2 = _make_vec(n, max_episode_steps=T, autoreset_mode=AutoresetMode.SAME_STEP)
    venv2.reset(seed=3)
    for _ in range(T):
        obs2, _, _, trunc2, info2 = venv2.step(act)
    assert trunc2.all() and info2["_final_obs"].all()
    np.testing.assert_array_equal(obs2, obs)


def test_info_state_and_params():
    env = gym.make(ENV_ID).unwrapped
    obs, info = env.reset(seed=4)
    p = info["params"]
    assert set(p) == set(PARAM_NAMES) and set(info["state"]) == set(STATE_KEYS)
    assert abs(info["state"]["x"]) <= 0.1 * 0.5 * p["stroke"] + 1e-12
    assert info["state"]["pa"] == info["state"]["pb"] == pytest.approx(st.null_pressure(ShakingTableParams(**p)))
    for a in _random_actions(50, seed=5):
        _, _, _, _, info2 = env.step(a)
        assert info2["params"] == p and info2["params"] is not p
        assert all(type(v) is float and math.isfinite(v) for v in info2["state"].values())


def test_randomisation_draws_inside_yaml_ranges_and_kwargs(spec):
    ranges = {row["name"]: row["value_range"] for row in spec.table()}
    assert ranges["specimen_mass"] == (0.0, 500.0)
    assert all(e.mode == "absolute" for e in spec.entries)
    env = gym.make(ENV_ID)
    drawn = {name: [] for name in ranges}
    for seed in range(10):
        _, info = env.reset(seed=seed)
        p = info["params"]
        ShakingTableParams(**p)
        for name in PARAM_NAMES:
            if name in ranges:
                assert ranges[name][0] <= p[name] <= ranges[name][1], name
                drawn[name].append(p[name])
            else:
                assert p[name] == getattr(NOMINAL, name), name
    for name, values in drawn.items():
        assert len(set(values)) == len(values), name
    # nominal plant, presets and a fixed specimen
    _, info = gym.make(ENV_ID, randomize=False).reset(seed=0)
    assert info["params"] == NOMINAL.as_dict()
    _, info = gym.make(ENV_ID, randomize=False, preset="ifas", specimen_mass="500kg").reset(seed=0)
    assert info["params"] == ShakingTableParams.preset("ifas", "500kg").as_dict()
    env = gym.make(ENV_ID, preset="constant", specimen_mass=350.0)
    for seed in range(3):
        _, info = env.reset(seed=seed)
        assert info["params"]["specimen_mass"] == 350.0 and info["params"]["bulk_modulus_model"] == 0.0
    with pytest.raises(ValueError, match="specimen_mass"):
        gym.make(ENV_ID, specimen_mass="1t")


def test_reset_options():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    _, info = env.reset(seed=0, options={"params": {"specimen_mass": 0.0}, "state": {"x": 0.05}})
    assert info["params"]["specimen_mass"] == 0.0 and info["state"]["x"] == 0.05
    with pytest.raises(ValueError, match="stroke"):
        env.reset(seed=0, options={"state": {"x": 0.2}})
    with pytest.raises(ValueError, match="floor"):
        env.reset(seed=0, options={"state": {"pa": 10.0}})
    with pytest.raises(ParameterError, match="lambda_2"):
        env.reset(seed=0, options={"params": {"lambda_2": 0.64}})
    with pytest.raises(ValueError, match="zigzag"):
        env.reset(seed=0, options={"reference": "zigzag"})
    with pytest.raises(ValueError, match="accelerometer"):
        env.reset(seed=0, options={"reference": [0.0, 60.0]})
    ref = np.linspace(0.0, 2.0, 300)
    obs, _ = env.reset(seed=0, options={"reference": _padded(ref)})
    assert obs[1] == 0.0 and obs[2] == np.float32(ref[10] / 10.0) and obs[6] == np.float32(ref[50] / 10.0)
    obs, *_ = env.step(_a(0.0))
    assert obs[1] == np.float32(ref[1] / 10.0)
    for kind in TABLE_REFERENCE_KINDS:
        obs, _ = env.reset(seed=1, options={"reference": kind})
        assert env.observation_space.contains(obs)


def test_reward_formula():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    ref = 2.0 * np.sin(np.linspace(0.0, 12.0, 400))
    _, info = env.reset(seed=2, options={"reference": _padded(ref)})
    prev = 0.0
    for k, a in enumerate(_random_actions(200, seed=6), start=1):
        _, reward, _, _, info = env.step(a)
        y = np.array([info["state"][s] for s in STATE_KEYS])
        e = ref[k] - st.table_acceleration(y, env.params.to_array())
        expected = -(e**2) - 0.01 * (float(a[0]) - prev) ** 2 - 0.25 * (y[0] / HALF) ** 2
        assert reward == pytest.approx(expected, abs=1e-9, rel=0)
        prev = float(a[0])


def test_reward_ignores_sensor_noise_and_noise_is_seeded():
    ref = np.full(100, 1.0)
    rewards = []
    for kw in ({}, {"position_noise_std": 1e-4, "acceleration_noise_std": 0.1}):
        env = gym.make(ENV_ID, randomize=False, **kw).unwrapped
        env.reset(seed=1, options={"reference": _padded(ref)})
        rewards.append([env.step(_a(0.2))[1] for _ in range(30)])
    np.testing.assert_array_equal(rewards[0], rewards[1])
    kw = {"acceleration_noise_std": 0.1, "randomize": False}
    a = _rollout(gym.make(ENV_ID, **kw).unwrapped, 3, _random_actions(100))
    b = _rollout(gym.make(ENV_ID, **kw).unwrapped, 3, _random_actions(100))
    np.testing.assert_array_equal(a[0], b[0])
    env = gym.make(ENV_ID, **kw).unwrapped
    env.reset(seed=3)
    d = []
    for act in _random_actions(400):
        _, _, _, _, info = env.step(act)
        y = np.array([info["state"][s] for s in STATE_KEYS])
        d.append(env.channel_values()["a"] - st.table_acceleration(y, env.params.to_array()))
    assert 0.08 < np.std(d) < 0.12


@pytest.mark.parametrize("kwargs, name", [
    ({"error_scale": 0.0}, "error_scale"), ({"accel_scale": -1.0}, "accel_scale"),
    ({"acceleration_noise_std": -0.1}, "acceleration_noise_std"), ({"reference": "chirp"}, "reference"),
    ({"position_penalty": float("nan")}, "position_penalty"), ({"preset": "tabulated"}, "preset"),
])
def test_constructor_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


def test_render_rgb_array():
    env = gym.make(ENV_ID, render_mode="rgb_array", randomize=False)
    env.reset(seed=0)
    f0 = env.render()
    assert f0.dtype == np.uint8 and f0.ndim == 3 and f0.shape[2] == 3
    for _ in range(200):
        env.step(_a(1.0))
    assert np.count_nonzero(np.any(env.render() != f0, axis=2)) > 50
    with pytest.raises(ValueError, match="render_mode"):
        ShakingTableEnv(render_mode="human")


# =========================================================================== guards
def _bang_bang(n, rng):
    out, a, k = np.empty((n, 1), dtype=np.float32), float(rng.choice([-1.0, 1.0])), 0
    while k < n:
        hold = int(rng.integers(100, 600))
        out[k:k + hold] = a
        a, k = -a, k + hold
    return out


@pytest.mark.parametrize("preset", ["modified_ifas", "ifas"])
def test_guards_over_long_rollouts_at_the_randomisation_corners(spec, preset):
    rng = np.random.default_rng(2024)
    n = len(spec.entries)
    base = ShakingTableParams.preset(preset)
    corners = [spec.corner(False, base), spec.corner(True, base)]
    corners += [spec.corner(list(rng.integers(0, 2, n).astype(bool)), base) for _ in range(2)]
    env = gym.make(ENV_ID, randomize=False, preset=preset).unwrapped
    for c in corners:
        p = c.as_dict()
        for actions in (_bang_bang(3000, rng), _random_actions(3000, seed=int(rng.integers(1000)))):
            obs, info = env.reset(seed=int(rng.integers(1000)), options={"params": p})
            assert info["params"] == p
            X, Pmin = [], np.inf
            for a in actions:
                obs, r, _, _, info = env.step(a)
                s = info["state"]
                X.append(s["x"])
                Pmin = min(Pmin, s["pa"], s["pb"])
                assert math.isfinite(r) and env.observation_space.contains(obs)
                assert all(math.isfinite(v) for v in s.values())
            X = np.array(X)
            assert Pmin >= c.pressure_floor
            # impact of up to 1150 kg at 0.45 m/s on the 1e8 N/m stop: k d^2 / 2 = M v^2 / 2 -> d <= 1.5 mm
            assert np.abs(X).max() <= 0.5 * c.stroke + 2e-3
        assert np.ptp(X) > 0.01


def test_observation_carries_the_reference_motion():
    """obs[11] and obs[12] are the reference velocity and position: the integrals of the
    reference acceleration from rest at the start position."""
    env = gym.make("hydro_envs/ShakingTable-v0", randomize=False)
    obs, _ = env.reset(seed=3, options={"reference": "sine"})
    b = env.unwrapped._batch
    ref = b.REF[0].copy()
    from hydro_envs.plants.shaking_table import model as plant

    half = 0.5 * b.P[0, plant.I_L]
    x0 = float(b.Y[0, plant.X])
    assert obs[11] == pytest.approx(0.0, abs=1e-7)
    v, x = 0.0, x0
    for k in range(1, 400):
        x += v * 1e-3
        v += ref[k - 1] * 1e-3
        obs, *_ = env.step(np.zeros(1, dtype=np.float32))
        if k % 97 == 0:
            assert obs[11] * 0.5 == pytest.approx(v, rel=1e-4, abs=1e-7)
            assert obs[12] * half == pytest.approx(x, rel=1e-4, abs=1e-7)
    env.close()


def test_earthquake_filter_without_scipy_signal_equals_scipy_bit_for_bit():
    """The tabulated Kanai-Tajimi design and the compiled lfilter reproduce scipy exactly, so
    earthquake references are the same as with scipy.signal (which a reset no longer imports)."""
    from hydro_envs.envs.shaking_table import references as R
    from hydro_envs.laws.filters import lfilter_from_rest

    b, a = R.kanai_tajimi_digital(1e-3)
    kt = R.KANAI_TAJIMI
    wg, zg, wf, zf = kt["omega_g"], kt["zeta_g"], kt["omega_f"], kt["zeta_f"]
    num = np.polymul([2.0 * zg * wg, wg * wg], [1.0, 0.0, 0.0])
    den = np.polymul([1.0, 2.0 * zg * wg, wg * wg], [1.0, 2.0 * zf * wf, wf * wf])
    bz, az = signal.bilinear(num, den, fs=1.0 / 1e-3)
    assert np.array_equal(b, bz) and np.array_equal(a, az)
    x = np.random.default_rng(3).standard_normal(5000)
    assert np.array_equal(lfilter_from_rest(b, a, x), signal.lfilter(bz, az, x))
    bb, aa = signal.butter(3, 0.1)
    assert np.array_equal(lfilter_from_rest(2.0 * bb, 2.0 * aa, x), signal.lfilter(2.0 * bb, 2.0 * aa, x))
    with pytest.raises(ValueError, match="equal length"):
        lfilter_from_rest(np.ones(3), np.ones(2), x)
