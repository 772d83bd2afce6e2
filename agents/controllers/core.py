"""Shared plumbing of the classical controllers: SB3-style ``predict`` and a batched PID core.

Every controller of :mod:`agents.controllers` is a policy object with
``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``
for one observation ``(obs_dim,)`` (returns ``(action_dim,)``) or a batch ``(n, obs_dim)``
(returns ``(n, action_dim)``), float32 actions inside the env's ``Box(-1, 1)``. Internal states
are kept per copy; rows whose ``episode_start`` is true are reset before the step. A change of
the batch size resets every copy.

:class:`PIDCore` is the discrete PID law used by every env's PID (backward Euler, ``dt`` = the
env step)::

    D_k = T_f/(T_f+dt) D_{k-1} - K_p T_d/(T_f+dt) (y_k - y_{k-1})     derivative on the measurement
    v_k = K_p e_k + I_k + D_k + ff_k,     a_k = clip(v_k, lo, hi)
    I_{k+1} = I_k + K_p dt/T_i e_k + dt/T_t (a_k - v_k)                 back-calculation anti-windup

(``T_i = inf`` disables the integral; ``anti_windup="conditional"`` freezes ``I`` while the
output is saturated and the error pushes further into the limit; ``"none"`` winds up.)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "bristle_step_at_frozen_velocity","ANTI_WINDUP", "BaseController", "PIDCore", "check_positive"]

ANTI_WINDUP = ("back_calculation", "conditional", "none")


def check_positive(**values: float) -> None:
    """Raise ``ValueError`` naming the first value that is not finite and > 0."""
    for name, val in values.items():
        if not (math.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be finite and > 0, got {val}")


class BaseController:
    """``predict`` plumbing: shape checks, per-copy state sizing, ``episode_start`` resets.

    Subclasses set ``obs_dim`` and ``action_dim`` and implement ``_allocate(n)`` (fresh
    per-copy state for ``n`` copies), ``_reset_rows(mask)`` and ``_act(obs) -> (n, action_dim)``
    (float64, before the final clip to [-1, 1]).
    """

    obs_dim: int = 0
    action_dim: int = 1
    name: str = "controller"

    def __init__(self) -> None:
        self._n = -1

    def reset(self, n: int | None = None) -> None:
        """Forget all internal states (``n`` copies; ``None``: size them on the next call)."""
        self._n = -1 if n is None else int(n)
        self._allocate(max(self._n, 0))

    def _allocate(self, n: int) -> None:  # pragma: no cover - trivial default
        pass

    def _reset_rows(self, mask: np.ndarray) -> None:  # pragma: no cover - trivial default
        pass

    def _act(self, obs: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        o = obs[None, :] if single else obs
        if o.ndim != 2 or o.shape[1] != self.obs_dim:
            raise ValueError(
                f"obs must have shape ({self.obs_dim},) or (n, {self.obs_dim}) for {type(self).__name__}, "
                f"got {obs.shape}"
            )
        n = o.shape[0]
        if n != self._n:
            self.reset(n)
        if episode_start is not None:
            mask = np.broadcast_to(np.asarray(episode_start, dtype=bool).reshape(-1), (n,))
            if mask.any():
                self._reset_rows(mask)
        a = np.clip(self._act(o), -1.0, 1.0).astype(np.float32)
        a = a.reshape(n, self.action_dim)
        return (a[0] if single else a), state


class PIDCore:
    """Batched discrete PID (module docstring); gains may be scalars or per-copy arrays."""

    def __init__(self, kp: Any, ti: Any, td: Any, tf: Any, dt: float, *, tt: Any = None,
                 anti_windup: str = "back_calculation", lo: float = -1.0, hi: float = 1.0) -> None:
        if anti_windup not in ANTI_WINDUP:
            raise ValueError(f"anti_windup = {anti_windup!r}; allowed {ANTI_WINDUP}")
        check_positive(dt=dt)
        for name, val, allow_inf in (("kp", kp, False), ("ti", ti, True)):
            arr = np.asarray(val, dtype=float)
            if not np.all((arr > 0) & (np.isfinite(arr) | allow_inf)):
                raise ValueError(f"{name} must be > 0{'' if allow_inf else ' and finite'}, got {val}")
        for name, val in (("td", td), ("tf", tf)):
            arr = np.asarray(val, dtype=float)
            if not np.all(np.isfinite(arr) & (arr >= 0)):
                raise ValueError(f"{name} must be finite and >= 0, got {val}")
        if not lo < hi:
            raise ValueError(f"output limits must satisfy lo < hi, got [{lo}, {hi}]")
        self.kp, self.ti, self.td, self.tf = (np.asarray(x, dtype=float) for x in (kp, ti, td, tf))
        self.tt = self.ti if tt is None else np.asarray(tt, dtype=float)
        self.dt = float(dt)
        self.anti_windup = anti_windup
        self.lo, self.hi = float(lo), float(hi)
        self.allocate(0)

    def allocate(self, n: int) -> None:
        self.integral = np.zeros(n)
        self.deriv = np.zeros(n)
        self.y_prev = np.zeros(n)
        self.fresh = np.ones(n, dtype=bool)

    def reset_rows(self, mask: np.ndarray) -> None:
        self.integral[mask] = 0.0
        self.deriv[mask] = 0.0
        self.fresh[mask] = True

    def step(self, e: np.ndarray, y: np.ndarray, ff: Any = 0.0) -> np.ndarray:
        """One sample: error ``e``, measurement ``y`` (for the derivative), additive ``ff``;
        returns the saturated output ``a`` (per copy)."""
        dy = np.where(self.fresh, 0.0, y - self.y_prev)
        self.deriv = (self.tf * self.deriv - self.kp * self.td * dy) / (self.tf + self.dt)
        v = self.kp * e + self.integral + self.deriv + ff
        a = np.clip(v, self.lo, self.hi)
        with np.errstate(divide="ignore"):
            di = np.where(np.isfinite(self.ti), self.kp * self.dt / self.ti, 0.0) * e
            if self.anti_windup == "back_calculation":
                di = di + np.where(np.isfinite(self.tt), self.dt / self.tt, 0.0) * (a - v)
            elif self.anti_windup == "conditional":
                di = np.where((a != v) & (np.sign(e) == np.sign(v)), 0.0, di)
        self.integral = self.integral + di
        self.y_prev = np.array(y, dtype=float, copy=True)
        self.fresh[:] = False
        return a


class ZeroController:
    """Action 0 for every copy (``action_dim`` wide): the do-nothing reference."""

    def __init__(self, action_dim: int = 1) -> None:
        self.action_dim = int(action_dim)

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs)
        if obs.ndim == 1:
            return np.zeros(self.action_dim, dtype=np.float32), state
        return np.zeros((obs.shape[0], self.action_dim), dtype=np.float32), state


def bristle_step_at_frozen_velocity(z: np.ndarray, v: np.ndarray, g: np.ndarray, sigma0: float,
                                    t: float) -> np.ndarray:
    """LuGre bristle deflection [m] after ``t`` seconds at frozen velocity ``v`` [m/s]: the exact
    solution of ``dz/dt = v - sigma0 |v| z / g`` (level ``g`` [N], stiffness ``sigma0`` [N/m]),
    ``z_ss + (z - z_ss) exp(-sigma0 |v| t / g)`` with ``z_ss = sgn(v) g / sigma0``."""
    z_ss = np.sign(v) * g / sigma0
    return z_ss + (z - z_ss) * np.exp(-(sigma0 * np.abs(v) / g) * t)

