"""Helpers the env tests share: one action, seeded random actions, a rollout of a single env and a
padded test reference.

Imported by the test modules as ``from env_helpers import ...`` (pytest puts ``tests/`` on the
import path)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np


def action(value: float) -> np.ndarray:
    """The one-dimensional action ``[value]`` as float32, as the env's action space holds it."""
    return np.array([value], dtype=np.float32)


def random_actions(n: int, seed: int = 123, shape: tuple[int, ...] = (1,)) -> np.ndarray:
    """``n`` actions drawn uniformly in [-1, 1] from ``seed`` (float32, ``(n, *shape)``)."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (n, *shape)).astype(np.float32)


def rollout(env: Any, seed: int, actions: Iterable[np.ndarray], options: Mapping[str, Any] | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reset ``env`` with ``seed`` (and ``options``) and apply ``actions``: the observations
    (reset's first), the rewards and the rows of ``info["state"]`` in the plant's state order."""
    obs, info = env.reset(seed=seed, options=options)
    observations, rewards, states = [obs], [], [list(info["state"].values())]
    for a in actions:
        obs, reward, _, _, info = env.step(a)
        observations.append(obs)
        rewards.append(reward)
        states.append(list(info["state"].values()))
    return np.array(observations), np.array(rewards), np.array(states)


def padded(ref: Any, length: int = 10_000) -> np.ndarray:
    """A short test reference held at its last value to ``length`` samples, to cover any episode
    (an env refuses a reference shorter than its episode)."""
    ref = np.asarray(ref, dtype=float)
    return np.pad(ref, (0, max(0, length - ref.size)), mode="edge")
