"""Friction-critical tasks: slow sines through reversals and micro-positioning."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs.envs.references import generate_friction_reference

IDS = ("hydro_envs/ServoCylinderSlowSine-v0", "hydro_envs/RodlessCylinderSlowSine-v0",
       "hydro_envs/ServoCylinderMicroPosition-v0", "hydro_envs/RodlessCylinderMicroPosition-v0")


@pytest.mark.parametrize("kind", ["slow_sine", "slow_triangle"])
def test_slow_references_reverse_at_low_speed(kind):
    dt, n, low, high = 1e-3, 4000, 0.007, 0.063  # the servo band (10-90 % of 69.6 mm)
    for seed in range(20):
        r = generate_friction_reference(kind, np.random.default_rng(seed), n, dt, low, high, 3e-5)
        v = np.diff(r) / dt
        assert low <= r.min() and r.max() <= high
        assert r[0] == pytest.approx(0.5 * (r.max() + r.min()), abs=0.02 * (high - low))  # starts at its centre
        assert 1e-3 < np.max(np.abs(v)) < 0.05  # mm/s to a few cm/s: the Stribeck region
        reversals = np.sum(np.diff(np.sign(v[np.abs(v) > 1e-6])) != 0)
        assert reversals >= 1  # at least one velocity reversal in 4 s (f >= 0.2 Hz)
        if kind == "slow_triangle":
            moving = np.abs(v) > 0.2 * np.max(np.abs(v))
            assert np.std(np.abs(v[moving])) < 0.05 * np.max(np.abs(v))  # constant speed legs


def test_micro_steps_are_a_few_sensor_resolutions():
    res = 5e-6
    r = generate_friction_reference("micro_steps", np.random.default_rng(3), 3000, 1e-3, 0.011, 0.099, res)
    steps = np.diff(r)[np.diff(r) != 0]
    assert steps.size >= 3
    assert np.all(np.abs(steps) >= 3 * res - 1e-12) and np.all(np.abs(steps) <= 30 * res + 1e-12)


def test_unknown_kind_is_an_error():
    with pytest.raises(ValueError, match="micro_steps"):
        generate_friction_reference("fast", np.random.default_rng(0), 10, 1e-3, 0.0, 1.0, 1e-6)
    with pytest.raises(ValueError, match="reference"):
        gym.make(IDS[0], reference="sine")


@pytest.mark.parametrize("env_id", IDS)
def test_episode_starts_at_rest_on_the_reference_and_is_seeded(env_id):
    env = gym.make(env_id)
    o1, info = env.reset(seed=5)
    batch = env.unwrapped._batch
    pos = next(iter(info["state"].values()))
    assert pos == pytest.approx(batch.REF[0, 0], abs=1e-12)
    assert abs(o1[0]) * batch.error_scale <= batch.quant + 1e-12  # only the sensor's quantisation
    o2, _ = gym.make(env_id).reset(seed=5)
    np.testing.assert_array_equal(o1, o2)
    if "Servo" in env_id:
        assert env.spec.max_episode_steps == 8000 and batch.quant == 1e-6  # the precision axis
    else:
        assert env.spec.max_episode_steps == (4000 if "SlowSine" in env_id else 3000)
    env.close()


def test_servo_friction_references_creep_below_the_stribeck_velocity_and_break_away():
    """Servo tasks: the slow references stay below the seals' Stribeck velocity (creep through
    the dip) with several reversals per episode; every micro step is larger than the seals'
    pre-sliding displacement (the seals must break away) and is held >= 2 s (hunting shows)."""
    from hydro_envs.envs.servo_cylinder import FRICTION_REFERENCE as R
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

    p = ServoCylinderParams()
    pre = p.static_friction / p.bristle_stiffness
    dt, n = 1e-3, 8000
    for seed in range(20):
        rng = np.random.default_rng(seed)
        r = generate_friction_reference("slow", rng, n, dt, 0.1 * p.stroke, 0.9 * p.stroke, 1e-6, R)
        v = np.diff(r) / dt
        assert np.max(np.abs(v)) < p.stribeck_velocity
        assert np.sum(np.diff(np.sign(v[np.abs(v) > 1e-7])) != 0) >= 2
        m = generate_friction_reference("micro_steps", rng, n, dt, 0.1 * p.stroke, 0.9 * p.stroke, 1e-6, R)
        jumps = np.flatnonzero(np.diff(m))
        assert np.all(np.abs(np.diff(m)[jumps]) >= 1.5 * pre)
        assert np.all(np.diff(np.r_[0, jumps + 1]) >= 2000)


# ------------------------------------------------------------------ friction awareness pays
def _paired_ratio(env_id: str, name: str, base: str, n: int = 6) -> float:
    from agents.benchmark import draw_parameters, rollout
    from agents.controllers import make_controller

    draws = draw_parameters(env_id, "in", n, 0)
    rmse = {}
    for c in (name, base):
        ro = rollout(env_id, make_controller(env_id, c), draws, seed=0)
        rmse[c] = np.sqrt(np.mean((ro.y - ro.ref) ** 2, axis=0))
    return float(np.mean(rmse[name] / rmse[base]))


def test_rodless_slow_sine_friction_model_pays():
    """The pressure-difference loop with the identified friction beats the PID by > 30 % and
    the same loop without friction (the model, not the structure, makes the gain)."""
    env = "hydro_envs/RodlessCylinderSlowSine-v0"
    assert _paired_ratio(env, "pid_dp_stribeck", "pid") < 0.7
    assert _paired_ratio(env, "pid_dp_stribeck", "pid_dp") < 0.85



def test_rodless_micro_steps_stiction_compensation_pays():
    """Micro steps from rest: the identified breakaway level in the pressure target (by the
    error's sign while the reference holds) beats the PID and the same loop without it."""
    env = "hydro_envs/RodlessCylinderMicroPosition-v0"
    assert _paired_ratio(env, "pid_dp_stiction", "pid") < 0.5
    assert _paired_ratio(env, "pid_dp_stiction", "pid_dp") < 0.6


def test_rodless_disturbance_observer_learns_each_draws_friction_online():
    """The observer of pid_dp_dob starts with no friction model: after one slow-sine episode its
    level lies between the draw's Coulomb friction and the Stribeck curve at the reference's mean
    speed (a different level per draw), and it beats the same loop blind to friction."""
    from agents.benchmark import rollout
    from agents.controllers import make_controller
    from hydro_envs.plants.rodless_cylinder.model import steady_friction
    from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams

    env = "hydro_envs/RodlessCylinderSlowSine-v0"
    ps = [RodlessCylinderParams(coulomb_friction=11.0, static_friction=25.0),
          RodlessCylinderParams(coulomb_friction=19.0, static_friction=40.0)]
    draws = [{"coulomb_friction": p.coulomb_friction, "static_friction": p.static_friction} for p in ps]
    ctrl = make_controller(env, "pid_dp_dob")
    ro = rollout(env, ctrl, draws, seed=0)
    v_mean = np.abs(np.diff(ro.ref, axis=0)).mean(axis=0) / 1e-3
    for p, level, v in zip(ps, ctrl.level, v_mean):
        assert 0.95 * p.coulomb_friction <= level <= 1.1 * float(steady_friction(p, v)), (level, v)
    assert _paired_ratio(env, "pid_dp_dob", "pid_dp") < 0.9

def test_servo_slow_sine_friction_model_pays():
    """Creep through reversals on the 1 um scale: the velocity feed-forward removes the PID's
    lag, and the identified Stribeck law in the pressure target removes most of what is left,
    the lost motion of building the breakaway pressure at each reversal."""
    env = "hydro_envs/ServoCylinderSlowSine-v0"
    assert _paired_ratio(env, "pid_vff_stribeck", "pid") < 0.4
    assert _paired_ratio(env, "pid_vff_stribeck", "pid_vff") < 0.6


def test_friction_identified_on_each_draw_recovers_its_coulomb_level():
    """The per-draw calibration runs the virtual 004 sec. 3 test on each parameter set and
    recovers that set's Coulomb level (not the nominal one)."""
    from agents.controllers.friction_models import identify_on_draws
    from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams

    ps = [RodlessCylinderParams(coulomb_friction=11.0, static_friction=25.0),
          RodlessCylinderParams(coulomb_friction=19.0, static_friction=40.0)]
    m = identify_on_draws("rodless_cylinder", ps)
    for p, fit in zip(ps, m.models):
        assert fit.parameters["F_c"] == pytest.approx(p.coulomb_friction, rel=0.03)
    f = m.predict(np.array([0.02, -0.02]))
    assert f[0] > 0 > f[1] and abs(f[1]) > f[0]


@pytest.mark.parametrize("plant", ["servo_cylinder", "rodless_cylinder"])
def test_presliding_test_recovers_the_bristle_stiffness(plant):
    """The virtual pre-sliding test (the seals loaded slowly from rest) and the closed-form fit
    of the LuGre loading branch return the rig's bristle stiffness within 8 %."""
    from agents.controllers.friction_models import identified_presliding
    from hydro_envs import registry

    sigma0, f_b = identified_presliding(plant)
    p = registry.get(plant).params_cls()
    assert sigma0 == pytest.approx(p.bristle_stiffness, rel=0.08)
    assert p.coulomb_friction < f_b <= 1.02 * p.static_friction


def test_servo_lugre_feedforward_pays_over_the_static_law():
    """The dynamic (LuGre) feed-forward, its pre-sliding identified on the rig, beats its blind
    twin and the static Stribeck feed-forward on the creep task."""
    env = "hydro_envs/ServoCylinderSlowSine-v0"
    assert _paired_ratio(env, "pid_vff_lugre", "pid_vff") < 0.4
    assert _paired_ratio(env, "pid_vff_lugre", "pid_vff_stribeck") < 0.9


def test_servo_lugre_observer_pays_over_the_feedforward():
    """The observer correction of the bristle estimate by the position error beats the same
    LuGre feed-forward without it (k_obs = 0) and its blind twin on the creep task."""
    env = "hydro_envs/ServoCylinderSlowSine-v0"
    assert _paired_ratio(env, "pid_vff_lugre_observer", "pid_vff_lugre") < 0.8


def test_lugre_observer_without_gain_is_the_feedforward_and_a_lag_loads_the_bristle():
    from agents.controllers import make_controller

    env = "hydro_envs/ServoCylinderSlowSine-v0"
    ff, ob = make_controller(env, "pid_vff_lugre"), make_controller(env, "pid_vff_lugre_observer")
    ob.k_obs = 0.0
    rng = np.random.default_rng(0)
    obs = np.clip(rng.normal(0.0, 0.01, (3, 11)), -1, 1)
    ff.reset(3), ob.reset(3)
    for _ in range(5):
        assert np.array_equal(ff.predict(obs)[0], ob.predict(obs)[0])
    # a piston standing 2 um behind a held reference: the estimate grows towards F_s, then holds
    ob = make_controller(env, "pid_vff_lugre_observer")
    ob.reset(1)
    hold = np.zeros((1, 11))
    hold[0, 1:7] = 0.0
    hold[0, 7] = -2e-6 / ob.half
    f = [float(ob.friction_target(np.zeros(1), np.zeros(1), hold)[0]) for _ in range(2000)]
    assert 0.0 < f[10] < f[50] <= f[-1] == f[-2]
    assert ob._z[0] == pytest.approx(max(ob.f_s, ob.f_c) / ob.sigma0)  # the bristle's largest deflection
