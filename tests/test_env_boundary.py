"""The env boundary: every bad constructor argument or reset option is a clear error, every
accepted one keeps the simulation finite (a fuzz over every registered env id)."""

from __future__ import annotations

import math
import warnings
import zlib

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs import registry

SERVO = "hydro_envs/ServoCylinderPosition-v0"
ENV_IDS = [e.id for _, e in registry.env_entries()]


def _make(env_id=SERVO, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make(env_id, disable_env_checker=True, **kw).unwrapped


def _vec(n=3, env_id=SERVO, **kw):
    return gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)


# ---------------------------------------------------------------- reset options
@pytest.mark.parametrize(
    "state, exc, words",
    [
        ({"v": 1000.0}, ValueError, ["'v'", "1000", "no-load velocity"]),
        ({"xv": 10.0}, ValueError, ["'xv'", "spool_stroke"]),
        ({"p1": 1e9}, ValueError, ["'p1'", "supply_pressure"]),
        ({"p2": -5.0}, ValueError, ["'p2'"]),
        ({"x": 1.0}, ValueError, ["'x'", "stroke"]),
        ({"x": "0.03"}, TypeError, ["'x'", "real number"]),
        ({"x": True}, TypeError, ["'x'"]),
        ({"x": float("nan")}, ValueError, ["'x'", "finite"]),
        ({"x": [0.01]}, TypeError, ["'x'"]),
        ({"w": 0.0}, ValueError, ["'w'", "allowed"]),
    ],
)
def test_bad_state_options_name_field_value_and_range(state, exc, words):
    env = _make()
    env.reset(seed=0)
    with pytest.raises(exc) as err:
        env.reset(seed=1, options={"state": state})
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_bad_option_containers():
    env = _make()
    with pytest.raises(TypeError, match="options"):
        env.reset(options="yes")
    with pytest.raises(TypeError, match=r"options\['state'\]"):
        env.reset(options={"state": [0.01]})
    with pytest.raises(TypeError, match=r"options\['params'\]"):
        env.reset(options={"params": "mass"})
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"stat": {}})


def test_state_limits_follow_the_drawn_parameters():
    env = _make(randomize=False)
    env.reset(seed=0)
    b = env._batch
    p = env.params
    lim = b.state_limits(p)
    assert lim["p1"][:2] == (0.0, 2.0 * p.supply_pressure)
    assert lim["xv"][:2] == (-p.spool_stroke, p.spool_stroke)
    # a value just inside is accepted and set, just outside refused
    hi = lim["v"][1]
    _, info = env.reset(seed=0, options={"state": {"v": 0.99 * hi}})
    assert info["state"]["v"] == pytest.approx(0.99 * hi)
    with pytest.raises(ValueError, match="'v'"):
        env.reset(seed=0, options={"state": {"v": 1.01 * hi}})


def test_failed_reset_leaves_the_episode_unchanged():
    env = _make()
    env.reset(seed=3)
    for _ in range(5):
        env.step(np.array([0.3], np.float32))
    before = env._batch.Y.copy(), env._batch.K.copy(), env.params
    with pytest.raises(ValueError):
        env.reset(options={"state": {"x": 0.03, "v": 1e3}})
    assert np.array_equal(env._batch.Y, before[0]) and np.array_equal(env._batch.K, before[1])
    assert env.params == before[2]
    env.step(np.array([0.3], np.float32))


def test_force_actuator_filter_states_cannot_be_set():
    env = _make("hydro_envs/ForceActuator-v0")
    with pytest.raises(ValueError, match="internal filter state"):
        env.reset(options={"state": {"r1": 1.0}})


# ---------------------------------------------------------------- constructor arguments
@pytest.mark.parametrize("value", ["no", 0, 1, None, "False"])
def test_randomize_must_be_a_bool(value):
    with pytest.raises(TypeError, match="randomize"):
        _make(randomize=value)


def test_given_params_are_held_fixed_with_a_warning():
    with pytest.warns(UserWarning, match=r"mass=20.*held fixed"):
        env = gym.make(SERVO, params={"mass": 20.0}, disable_env_checker=True).unwrapped
    masses, moduli = set(), set()
    for s in range(5):
        env.reset(seed=s)
        masses.add(env.params.mass)
        moduli.add(env.params.bulk_modulus)
    assert masses == {20.0}
    assert len(moduli) == 5  # the rest is still drawn
    # the same through the vector env
    with pytest.warns(UserWarning, match="held fixed"):
        venv = _vec(2, params={"mass": 20.0})
    _, info = venv.reset(seed=0)
    assert np.all(info["params"]["mass"] == 20.0)
    # no warning when nothing drawn is given, or without randomisation
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym.make(SERVO, params={"tank_pressure": 2e5}, disable_env_checker=True)
        gym.make(SERVO, params={"mass": 20.0}, randomize=False, disable_env_checker=True)


def test_given_params_inconsistent_with_drawn_ranges_are_an_error():
    # static friction must stay >= Coulomb friction: a given static level below the drawn
    # Coulomb range cannot be held
    with pytest.raises(ValueError, match="static_friction"):
        _make(params={"static_friction": 1.0})


@pytest.mark.parametrize("value, exc", [(-1, ValueError), (0, ValueError), (2.5, TypeError), ("10", TypeError), (True, TypeError)])
def test_vector_max_episode_steps_positive_int(value, exc):
    with pytest.raises(exc, match="max_episode_steps"):
        _vec(2, max_episode_steps=value)


@pytest.mark.parametrize("value, exc", [(0, ValueError), (2.0, TypeError), ("3", TypeError)])
def test_num_envs_and_episode_steps_positive_int(value, exc):
    with pytest.raises(exc, match="num_envs"):
        _vec(value)
    with pytest.raises(exc, match="episode_steps"):
        _make(episode_steps=value)


# ---------------------------------------------------------------- reset_mask
@pytest.mark.parametrize(
    "mask, exc",
    [
        (np.array([True, False]), ValueError),  # too short
        (np.array([True, False, True, True]), ValueError),  # too long
        ("yes", TypeError),
        (np.array([1, 0, 1]), TypeError),
        (np.zeros(3, bool), ValueError),
        (True, TypeError),
    ],
)
def test_reset_mask_checked_before_any_copy_is_reset(mask, exc):
    venv = _vec(3)
    venv.reset(seed=0)
    for _ in range(4):
        venv.step(np.zeros((3, 1), np.float32))
    b = venv.unwrapped._batch if hasattr(venv, "unwrapped") else venv._batch
    y, k = b.Y.copy(), b.K.copy()
    with pytest.raises(exc, match="reset_mask"):
        venv.reset(seed=5, options={"reset_mask": mask})
    assert np.array_equal(b.Y, y) and np.array_equal(b.K, k)


def test_reset_mask_resets_only_the_masked_copies():
    venv = _vec(3)
    venv.reset(seed=0)
    for _ in range(4):
        venv.step(np.zeros((3, 1), np.float32))
    b = venv._batch
    venv.reset(options={"reset_mask": [False, True, False]})
    assert list(b.K) == [4, 0, 4]


def test_first_reset_cannot_leave_copies_out():
    venv = _vec(3)
    with pytest.raises(ValueError, match="never reset"):
        venv.reset(seed=0, options={"reset_mask": np.array([True, False, True])})


# ---------------------------------------------------------------- fuzz over every env id
def _adversarial_value(rng, lo, hi):
    lo = lo if math.isfinite(lo) else -1e6
    hi = hi if math.isfinite(hi) else 1e6
    span = hi - lo
    choices = [lo, hi, 0.0, rng.uniform(lo, hi), 0.5 * (lo + hi),
               hi + 0.5 * span + 1.0, lo - 0.5 * span - 1.0, 1e300, -1e300, float("nan"), float("inf"), "1", None, True]
    return choices[int(rng.integers(len(choices)))]


def _action(rng, shape, k):
    kind = k % 4
    if kind == 0:
        return rng.uniform(-1, 1, shape).astype(np.float32)
    if kind == 1:
        return np.full(shape, (-1.0) ** (k // 4), np.float32)  # bang-bang
    if kind == 2:
        return (rng.uniform(-1, 1, shape) * 1e6).astype(np.float64)  # clipped
    return np.zeros(shape, np.float32)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_fuzz_reset_and_step_no_nan_no_undocumented_error(env_id):
    rng = np.random.default_rng(zlib.crc32(env_id.encode()))  # str hash() differs per process
    env = _make(env_id)
    env.reset(seed=0)
    b = env._batch
    names = [n for n in b.plant.STATE_NAMES if n not in b.fixed_states]
    accepted = refused = 0
    for trial in range(6 if "LoadSensing" in env_id else 16):  # its reset settles the pump (slow)
        env.reset(seed=trial)  # this episode's parameters: limits around them
        lim = b.state_limits(env.params)
        pick = rng.random(len(names)) < 0.4
        if trial % 2:  # in-range values, often at the limits
            state = {n: float(rng.choice([lim[n][0], lim[n][1], rng.uniform(*lim[n][:2])]))
                     for n, m in zip(names, pick) if m and math.isfinite(lim[n][0]) and math.isfinite(lim[n][1])}
        else:
            state = {n: _adversarial_value(rng, *lim[n][:2]) for n, m in zip(names, pick) if m}
            if trial == 0:  # at least one value every env must refuse
                state[names[0]] = float("nan")
        try:
            obs, _ = env.reset(seed=trial, options={"state": state})
        except (ValueError, TypeError) as exc:
            assert "options" in str(exc)
            refused += 1
            continue
        accepted += 1
        assert np.all(np.isfinite(obs)), (env_id, state)
        for k in range(40):
            obs, r, *_ = env.step(_action(rng, env.action_space.shape, k))
            assert np.all(np.isfinite(obs)) and math.isfinite(r), (env_id, state, k)
        for bad in (np.array([np.nan] * env.action_space.shape[0]), "a", None, np.zeros(7)):
            with pytest.raises(ValueError, match="action"):
                env.step(bad)
    assert accepted > 0 and refused > 0, (accepted, refused)


@pytest.mark.parametrize("env_id,value", [
    ("hydro_envs/ServoCylinderPosition-v0", 0.03),
    ("hydro_envs/RodlessCylinder-v0", 0.05),
    ("hydro_envs/ForceActuator-v0", 10.0),
    ("hydro_envs/LoadSensing-v0", 0.05),
    ("hydro_envs/ShakingTable-v0", 0.0),
])
def test_reference_array_shorter_than_the_episode_is_refused(env_id, value):
    """A user's reference must cover the episode; it is never silently held at its last value."""
    import gymnasium as gym
    import numpy as np

    env = gym.make(env_id, randomize=False)
    with pytest.raises(ValueError, match=r"options\['reference'\] has 10 samples"):
        env.reset(seed=0, options={"reference": np.full(10, value)})
    env.reset(seed=0, options={"reference": np.full(env.spec.max_episode_steps, value)})  # a full one is taken
    env.close()
