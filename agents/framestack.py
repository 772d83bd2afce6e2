r"""Frame stacking of observations for memoryless policies (rl_zoo3's ``frame_stack`` key).

A policy that sees the last ``n`` observations side by side, ``[o_{k-n+1}, ..., o_k]`` (oldest
first, zeros before the episode's first observation), can difference them: a velocity from
two positions, a pressure rate from two pressures. Training stacks with SB3's
``VecFrameStack`` (:func:`agents.train.make_envs`); :class:`FrameStackPolicy` applies the same
stacking at evaluation, copy by copy, so a trained policy sees the observations it was trained
on. The stacking follows SB3's ``StackedObservations`` for 1-D observations: on an episode start
the row is zeroed and the new observation written into the last slot; otherwise the row moves
one observation to the left first.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["FrameStackPolicy", "check_frame_stack"]


def check_frame_stack(value: Any, where: str = "frame_stack") -> int | None:
    """``None`` (no stacking) or an integer >= 1; otherwise ``ValueError`` naming the field."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or int(value) != value or not 1 <= int(value) <= 64:
        raise ValueError(f"{where} = {value!r}; must be null or an integer in [1, 64]")
    return int(value)


class FrameStackPolicy:
    """A policy trained on ``n``-frame stacks, fed single observations: ``predict(obs, state,
    episode_start, deterministic)`` for ``(obs_dim,)`` or ``(n_copies, obs_dim)``. Without
    ``episode_start`` the first call (and the first after :meth:`reset` or a change of batch
    size) starts every copy's episode."""

    def __init__(self, policy: Any, n_stack: int, obs_dim: int) -> None:
        self.policy = policy
        self.n_stack = check_frame_stack(n_stack, "n_stack") or 1
        if not (isinstance(obs_dim, (int, np.integer)) and obs_dim >= 1):
            raise ValueError(f"obs_dim must be an integer >= 1, got {obs_dim!r}")
        self.obs_dim = int(obs_dim)
        self._stack: np.ndarray | None = None

    def __getattr__(self, name: str) -> Any:  # env_id, config, run_dir, ... of the wrapped policy
        if name == "policy":
            raise AttributeError(name)
        return getattr(self.policy, name)

    @property
    def observation_space(self) -> Any:
        from gymnasium import spaces

        sp = self.policy.observation_space
        d = self.obs_dim
        return spaces.Box(sp.low[-d:], sp.high[-d:], dtype=sp.dtype)

    def reset(self) -> None:
        self._stack = None

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        o = np.asarray(obs, dtype=np.float32)
        single = o.ndim == 1
        o2 = o[None, :] if single else o
        if o2.ndim != 2 or o2.shape[1] != self.obs_dim:
            raise ValueError(f"obs must have shape ({self.obs_dim},) or (n, {self.obs_dim}), got {o.shape}")
        n = o2.shape[0]
        if self._stack is None or self._stack.shape[0] != n:
            self._stack = np.zeros((n, self.n_stack * self.obs_dim), dtype=np.float32)
            start = np.ones(n, dtype=bool)
        else:
            start = np.zeros(n, dtype=bool) if episode_start is None else \
                np.asarray(episode_start, dtype=bool).reshape(n).copy()
        self._stack = np.roll(self._stack, -self.obs_dim, axis=1)
        self._stack[start] = 0.0
        self._stack[:, -self.obs_dim:] = o2
        a, st = self.policy.predict(self._stack.copy(), state=state, episode_start=episode_start,
                                    deterministic=deterministic)
        return (a[0] if single else a), st
