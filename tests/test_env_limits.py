"""Bounded and finite steps (hydro_envs.envs.base): the sub-step cap and the non-finite state error."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs.envs.base import FINITE_CHECK_EVERY, MAX_SUBSTEPS, NonFiniteStateError, SubstepLimitError

SERVO = "hydro_envs/ServoCylinderPosition-v0"
RODLESS = "hydro_envs/RodlessCylinder-v0"
#: servo parameters each inside its range that together need more sub-steps than the cap
STIFF = {"mass": 0.05, "piston_area": 0.5}


def test_a_parameter_set_needing_too_many_substeps_is_refused_at_make():
    # each value at its range end steps (tests/test_range_ends.py), together they are too stiff:
    # a 50 g piston on a 0.5 m^2 area needs ~1.2e5 sub-steps per 1 ms step (its end stop)
    with pytest.raises(SubstepLimitError, match=rf"servo_cylinder: parameters mass=0.05, piston_area=0.5 need \d+ RK4 "
                       rf"sub-steps per env "
                       rf"step .*allowed at most {MAX_SUBSTEPS}"):
        gym.make(SERVO, randomize=False, params=STIFF)
    assert gym.make(SERVO, randomize=False, params={"mass": 1.0}).unwrapped.n_substeps <= MAX_SUBSTEPS


def test_the_local_refinement_counts_in_the_cap_and_a_reset_names_the_copy():
    # stiff bristles on a large bore are refined locally in the stick mode; sub-steps times
    # that refinement exceed the cap
    with pytest.raises(SubstepLimitError, match=r"rodless_cylinder: parameters bore=0.04, bristle_stiffness=3e\+07 need up "
                       r"to \d+ RK4 sub-steps per env step \(\d+ sub-steps, each refined up to \d+ x"):
        gym.make(RODLESS, randomize=False, params={"bore": 0.04, "bristle_stiffness": 3e7})
    venv = gym.make_vec(SERVO, num_envs=2, vectorization_mode="vector_entry_point", randomize=False)
    venv.reset(seed=0)
    mask = np.array([False, True])
    with pytest.raises(SubstepLimitError, match=r"^copy 1: servo_cylinder: parameters mass=0.05"):
        venv.reset(options={"reset_mask": mask, "params": STIFF})
    venv.reset(options={"reset_mask": mask, "params": {"mass": 2.0}})  # the env is still usable
    venv.close()


def test_a_non_finite_state_raises_naming_copy_state_and_parameters():
    env = gym.make(SERVO, randomize=False)
    env.reset(seed=0)
    b = env.unwrapped._batch
    b.Y[0, 2] = np.nan
    with pytest.raises(NonFiniteStateError, match=r"servo_cylinder copy 0: state .*= nan after step 1 with the nominal "
                       "parameters"):
        env.step(np.zeros(1, dtype=np.float32))
    venv = gym.make_vec(SERVO, num_envs=3, vectorization_mode="vector_entry_point", randomize=False)
    venv.reset(seed=0)
    venv.unwrapped._batch.Y[1, 0] = -np.inf
    with pytest.raises(NonFiniteStateError, match=r"copy 1: state "):
        venv.step(np.zeros((3, 1)))
    venv.reset(seed=0)
    vb = venv.unwrapped._batch
    vb.check_finite = False  # a caller that scores non-finite copies itself (benchmark, soak)
    vb.Y[1, 0] = np.nan
    venv.step(np.zeros((3, 1)))
    assert not np.all(np.isfinite(vb.Y[1]))
    venv.close()


def test_every_state_is_checked_within_the_check_interval():
    env = gym.make(SERVO, randomize=False)
    env.reset(seed=0)
    b = env.unwrapped._batch
    b.assert_finite()  # finite: nothing raised
    y = b.Y.copy()
    b.Y[0, -1] = np.inf
    with pytest.raises(NonFiniteStateError, match=r"state vv = inf|state .* = inf"):
        b.assert_finite()
    b.Y[:] = y
    for _ in range(FINITE_CHECK_EVERY + 1):  # the periodic full check passes on finite states
        env.step(np.zeros(1, dtype=np.float32))


def test_benchmark_and_soak_draws_skip_sets_beyond_the_cap():
    from hydro_envs.params import ParameterError

    env = gym.make(SERVO, randomize=False)
    b = env.unwrapped._batch
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = b.params_cls.from_mapping(STIFF)
    with pytest.raises(ValueError):  # SubstepLimitError is a ValueError: draw loops redraw on it
        b.substeps_for(p)
    assert issubclass(SubstepLimitError, ValueError) and not issubclass(SubstepLimitError, ParameterError)
    assert NonFiniteStateError.exit_code == 1
