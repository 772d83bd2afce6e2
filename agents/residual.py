r"""Residual reinforcement learning on top of a classical controller.

The applied action is the base controller's action plus a scaled correction from the learned
policy::

    a_k = clip(u_base(o_k) + scale * clip(pi(o_k), -1, 1), -1, 1)

with ``u_base`` one of the classical controllers of :mod:`agents.controllers` (for example the
env's PID, which keeps its own per-copy state) and ``0 < scale <= 1``.

Why: a freshly initialised SB3 policy outputs actions close to zero (small last-layer weights,
a small ``log_std_init``), so the first rollouts already run the base controller and training
starts at its performance instead of at a random policy's; the policy only has to learn the
correction (unmodelled friction, the randomised plant parameters). ``scale`` bounds how far it
can move away from the base controller (an exploration and safety margin).

* :class:`ResidualVecEnv` applies the law during training. It must sit *inside*
  ``VecNormalize`` (``VecNormalize(ResidualVecEnv(venv, ...))``): the base controller needs the
  raw observations, the policy sees the normalised ones. It keeps the last raw observation of
  every copy and an episode-start flag per copy (all copies after :meth:`~ResidualVecEnv.reset`,
  and copies whose ``done`` was true in the last step: SB3 vector envs reset those
  automatically and return the new episode's first observation), so the base controller's
  internal states restart with every episode.
* :class:`ResidualPolicy` applies it at evaluation: a trained policy (anything with SB3-style
  ``predict``, e.g. :class:`agents.policies.TrainedPolicy`) plus the base controller, with the
  same ``predict`` contract. :func:`agents.policies.load_trained` returns one when the run's
  ``config.yml`` has a ``residual`` entry (:mod:`agents.train`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from agents.controllers import controller_names, make_controller

__all__ = ["RESIDUAL_KEYS", "check_residual", "ResidualVecEnv", "ResidualPolicy"]

#: keys of the ``residual`` entry of a training config (:mod:`agents.train`)
RESIDUAL_KEYS = ("controller", "scale")


def check_residual(env_id: str, controller: Any, scale: Any, where: str = "residual") -> tuple[str, float]:
    """``(controller, scale)`` validated: ``controller`` one of
    :func:`agents.controllers.controller_names` of ``env_id``, ``scale`` a finite number in
    ``(0, 1]``; otherwise ``ValueError`` naming ``<where>.controller`` / ``<where>.scale``, the
    value and what is allowed."""
    names = controller_names(env_id)
    if not isinstance(controller, str) or controller not in names:
        raise ValueError(f"{where}.controller = {controller!r} for {env_id}; allowed {list(names)}")
    s = scale
    if isinstance(s, bool) or not isinstance(s, (int, float)) or not math.isfinite(s) or not 0.0 < s <= 1.0:
        raise ValueError(f"{where}.scale = {scale!r}; must be a finite number in (0, 1]")
    return controller, float(s)


def _combine(base: Any, correction: Any, scale: float) -> np.ndarray:
    """``clip(base + scale * clip(correction, -1, 1), -1, 1)`` as float32."""
    b = np.asarray(base, dtype=np.float64)
    c = np.clip(np.asarray(correction, dtype=np.float64).reshape(b.shape), -1.0, 1.0)
    return np.clip(b + scale * c, -1.0, 1.0).astype(np.float32)


class ResidualVecEnv(VecEnvWrapper):
    """SB3 vector env whose actions are residuals on ``controller`` (module docstring).

    Place it inside ``VecNormalize``; the action space is the wrapped env's (``Box(-1, 1)``).
    """

    def __init__(self, venv: VecEnv, env_id: str, controller: str, scale: float) -> None:
        self.controller_name, self.scale = check_residual(env_id, controller, scale)
        super().__init__(venv)
        self.env_id = env_id
        self.controller = make_controller(env_id, self.controller_name)
        self._last_obs: np.ndarray | None = None
        self._starts = np.ones(self.num_envs, dtype=bool)

    def reset(self) -> VecEnvObs:
        obs = self.venv.reset()
        self._last_obs = np.array(obs, copy=True)
        self._starts[:] = True
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        if self._last_obs is None:
            raise RuntimeError("ResidualVecEnv: call reset() before step()")
        base, _ = self.controller.predict(self._last_obs, episode_start=self._starts.copy(), deterministic=True)
        self._starts[:] = False
        self.venv.step_async(_combine(base, actions, self.scale))

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        self._last_obs = np.array(obs, copy=True)
        self._starts = np.asarray(dones, dtype=bool).reshape(self.num_envs).copy()
        return obs, rewards, dones, infos


class ResidualPolicy:
    """A trained policy as the residual of a classical controller, with SB3-style ``predict``.

    ``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)`` for
    one raw observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``. The ``episode_start`` given
    by the caller goes to the base controller (and to the policy); without it, the first call
    after construction or :meth:`reset` (or after a change of the batch size) starts every
    copy's episode and later calls continue them. Other attributes (``model``,
    ``obs_normalizer``, ``algo``, ``config``, ``run_dir``, ...) are the wrapped policy's.
    """

    def __init__(self, policy: Any, env_id: str, controller: str, scale: float) -> None:
        self.controller_name, self.scale = check_residual(env_id, controller, scale)
        self.policy = policy
        self.env_id = env_id
        self.controller = make_controller(env_id, self.controller_name)
        self.observation_space = getattr(policy, "observation_space", None)
        self.action_space = getattr(policy, "action_space", None)
        self._fresh = True
        self._n = -1

    def reset(self) -> None:
        """Start a new episode on every copy at the next ``predict`` without ``episode_start``."""
        self._fresh = True

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "policy":
            raise AttributeError(name)
        return getattr(self.policy, name)

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        o = np.asarray(obs)
        n = 1 if o.ndim == 1 else o.shape[0]
        if episode_start is not None:
            starts = np.broadcast_to(np.asarray(episode_start, dtype=bool).reshape(-1), (n,)).copy()
        else:
            starts = np.full(n, self._fresh or n != self._n, dtype=bool)
        self._fresh, self._n = False, n
        correction, state = self.policy.predict(obs, state=state, episode_start=episode_start,
                                                deterministic=deterministic)
        base_start = starts[0] if o.ndim == 1 else starts
        base, _ = self.controller.predict(obs, episode_start=base_start, deterministic=True)
        return _combine(base, correction, self.scale), state

    def __repr__(self) -> str:
        return (f"ResidualPolicy({self.policy!r}, env_id={self.env_id!r}, controller={self.controller_name!r}, "
                f"scale={self.scale})")
