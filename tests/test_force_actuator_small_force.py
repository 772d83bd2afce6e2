"""The force actuator's friction-critical task ``hydro_envs/ForceActuatorSmallForce-v0``: its
references (small forces through zero, smoothed small steps), its rig (the free piston against
the environment spring) and that the seals' stiction, not the loop, makes the PID's error."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs.envs.force_actuator import SMALL_FORCE_RIG
from hydro_envs.envs.friction_tasks import SmallForceReference, generate_small_force_reference

ENV_ID = "hydro_envs/ForceActuatorSmallForce-v0"
DT = 2e-4


@pytest.mark.parametrize("kind", ["small_sine", "small_triangle", "small_steps"])
def test_small_force_references_start_at_rest_and_stay_small(kind):
    for seed in range(20):
        r = generate_small_force_reference(kind, np.random.default_rng(seed), 5000, DT)
        assert r[0] == pytest.approx(0.0, abs=1e-9)
        assert np.max(np.abs(r)) <= 60.0 + 1e-9 and np.max(np.abs(r)) >= 10.0 - 1e-9
        if kind != "small_steps":
            assert np.sum(np.diff(np.sign(r[1:])) != 0) >= 1  # the force changes sign: the piston reverses
        else:
            assert np.max(np.abs(np.diff(r))) <= math.pi / 2 * 120.0 / (0.1 / DT) + 1e-9  # the 100 ms rise


def test_bad_ranges_and_kinds_raise():
    with pytest.raises(ValueError):
        SmallForceReference(amplitude=(0.0, 10.0))
    with pytest.raises(ValueError):
        SmallForceReference(rise=0.5)
    with pytest.raises(ValueError):
        generate_small_force_reference("square", np.random.default_rng(0), 10, DT)
    with pytest.raises(ValueError):
        gym.make(ENV_ID, reference="square")


def test_task_runs_on_the_free_piston_rig_and_its_params_override():
    env = gym.make(ENV_ID).unwrapped
    obs, _ = env.reset(seed=0)
    assert env.params.piston_locked == 0.0 and env.params.load_stiffness == SMALL_FORCE_RIG["load_stiffness"]
    assert np.all(np.isfinite(obs)) and env._batch.episode_steps == 5000
    env.reset(seed=1, options={"params": {"load_stiffness": 1e5}, "reference": "small_sine"})
    assert env.params.load_stiffness == 1e5
    for _ in range(50):
        obs, r, term, trunc, _ = env.step(np.zeros(1, np.float32))
        assert np.isfinite(r)


def test_stiction_decides_the_pid_error():
    """The PID on the same draws and episodes with and without dry friction: friction makes most
    of its squared error (the benchmark's friction_share >= 0.5)."""
    from agents.benchmark import draw_parameters, dry_friction_free, rollout
    from agents.controllers.force_actuator import ForcePIDController

    draws = draw_parameters(ENV_ID, "in", 6, 0)
    a = rollout(ENV_ID, ForcePIDController.from_params(), draws, seed=0)
    b = rollout(ENV_ID, ForcePIDController.from_params(), dry_friction_free(ENV_ID, draws), seed=0)
    share = 1.0 - np.mean((b.y - b.ref) ** 2) / np.mean((a.y - a.ref) ** 2)
    assert share >= 0.5, share


def test_virtual_friction_test_identifies_the_seals():
    """The closed-form Dahl loading branch gives back the plant's static levels and bristle
    stiffness; the slide gives its Coulomb level; the test shows Table 2's breakaway."""
    from agents.controllers.force_actuator import identify_seal_friction, valve_force_gain
    from hydro_envs.plants.force_actuator.params import ForceActuatorParams

    p = ForceActuatorParams()
    ident = identify_seal_friction(p)
    assert ident["g_push"] == pytest.approx(p.stiction_retract, rel=0.01)
    assert ident["g_pull"] == pytest.approx(p.stiction_extend, rel=0.01)
    assert ident["sigma0"] == pytest.approx(p.friction_stiffness, rel=0.02)
    # the slide's end: eq (5)'s damping holds the free piston near the valve's knee (7-10 mm/s,
    # 1.5-2 v_s), where the Stribeck term still adds 1-4 N to F_c
    assert p.coulomb_friction <= ident["f_c"] <= 1.15 * p.coulomb_friction
    assert 0.5 * p.stribeck_velocity < ident["v_s"] < 2.0 * p.stribeck_velocity
    assert ident["break_push"] == pytest.approx(99.0, abs=0.5) and ident["break_pull"] == pytest.approx(54.0, abs=0.5)
    # 58 N/mA small-signal gain at null (the params' rated-current note), per action unit of 45 mA
    assert valve_force_gain(p) / (p.current_max * 1e3) == pytest.approx(58.0, rel=0.02)


def test_dahl_feedforward_pays_against_its_blind_twin():
    """pid_dahl vs pid (its blind twin) on the same draws and episodes: well below the PID's error."""
    from agents.benchmark import draw_parameters, rollout
    from agents.controllers import force_actuator
    from agents.controllers.force_actuator import ForcePIDController

    draws = draw_parameters(ENV_ID, "in", 6, 0)
    base = rollout(ENV_ID, ForcePIDController.from_params(), draws, seed=0)
    dahl = rollout(ENV_ID, force_actuator.controllers()["pid_dahl"](), draws, seed=0)
    ratio = math.sqrt(np.mean((dahl.y - dahl.ref) ** 2) / np.mean((base.y - base.ref) ** 2))
    assert ratio < 0.6, ratio
