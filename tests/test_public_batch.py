"""The agents read an env's plant batch through the public ``batch`` property (issue 57 item 2)."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np

import hydro_envs  # noqa: F401

ROOT = Path(__file__).resolve().parents[1]


def test_batch_is_the_plant_batch_of_single_and_vector_envs():
    env = gym.make("hydro_envs/ServoCylinderPosition-v0")
    env.reset(seed=0)
    b = env.unwrapped.batch
    assert b.Y.shape[0] == 1 and b.base_params is not None
    np.testing.assert_array_equal(b.Y[0], env.unwrapped.batch.Y[0])
    venv = gym.make_vec("hydro_envs/ServoCylinderPosition-v0", num_envs=3, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    assert venv.batch.Y.shape[0] == 3 and venv.batch.dt == venv.dt


def test_agents_and_bench_do_not_reach_into_the_private_batch():
    offenders = [str(p.relative_to(ROOT)) for d in ("agents", "bench") for p in (ROOT / d).rglob("*.py")
                 if re.search(r"\._batch\b", p.read_text(encoding="utf-8"))]
    assert not offenders, offenders
