"""Stable-Baselines3 adapter: train SB3 algorithms directly on a native batched vector env.

SB3 (2.x) does not accept Gymnasium vector envs: its ``VecEnv`` API resets a finished copy in
the *same* step and returns the last observation in ``infos[i]["terminal_observation"]``,
with ``infos[i]["TimeLimit.truncated"]`` marking time-limit ends. :class:`SB3VecEnv` wraps a
hydro-envs vector env created with ``autoreset_mode=SAME_STEP`` and translates, so all copies
are still advanced by one compiled kernel call per step (no Python loop over envs as in
SB3's ``DummyVecEnv``)::

    from hydro_envs.envs.sb3 import make_sb3_vec_env
    venv = make_sb3_vec_env("hydro_envs/ServoCylinderPosition-v0", n_envs=16, seed=0)
    model = stable_baselines3.PPO("MlpPolicy", venv).learn(10_000)

Seeding and options follow SB3: ``venv.seed(s)`` makes the next ``reset()`` seed copy ``i``
with ``s + i``; ``venv.set_options(...)`` passes reset options (``params``, ``state``,
``reference``) to the next ``reset()`` only.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "hydro_envs.envs.sb3 needs stable-baselines3: pip install 'hydro-envs[rl]'"
    ) from exc

import hydro_envs  # noqa: F401  (registers the envs)

__all__ = ["SB3VecEnv", "make_sb3_vec_env"]


class SB3VecEnv(VecEnv):
    """SB3 ``VecEnv`` view of a hydro-envs native vector env (SAME_STEP autoreset)."""

    def __init__(self, vector_env: gym.vector.VectorEnv) -> None:
        if getattr(vector_env, "autoreset_mode", None) != AutoresetMode.SAME_STEP:
            raise ValueError("SB3VecEnv needs a vector env created with autoreset_mode=SAME_STEP")
        self.venv = vector_env
        super().__init__(
            vector_env.num_envs, vector_env.single_observation_space, vector_env.single_action_space
        )
        self._actions: np.ndarray | None = None

    # -------------------------------------------------------------- VecEnv API
    def reset(self) -> np.ndarray:
        """Reset all copies with the seeds of :meth:`seed` and the options of
        :meth:`set_options` (SB3's contract: both apply to this reset only)."""
        seeds = list(self._seeds)
        groups: dict[str, list[int]] = {}
        for i, opt in enumerate(self._options):
            groups.setdefault(repr(sorted(opt.items())) if opt else "", []).append(i)
        obs = None
        for members in groups.values():
            opt = dict(self._options[members[0]])
            if len(groups) > 1:  # copies with different options: reset them group by group
                mask = np.zeros(self.num_envs, dtype=bool)
                mask[members] = True
                opt["reset_mask"] = mask
            obs, _ = self.venv.reset(seed=seeds, options=opt or None)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("step_async must be called before step_wait")
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            final = info["final_obs"]
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = final[i]
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]

    def _get_indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)


def make_sb3_vec_env(env_id: str, n_envs: int = 1, seed: int | None = None, **env_kwargs: Any) -> SB3VecEnv:
    """Create the native vector env of ``env_id`` (SAME_STEP autoreset) wrapped for SB3."""
    vec = gym.make_vec(
        env_id,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        **env_kwargs,
    )
    venv = SB3VecEnv(vec)
    if seed is not None:
        venv.seed(seed)
    return venv
