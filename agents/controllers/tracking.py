"""Position PID for the cylinder-tracking observation layout (:mod:`hydro_envs.envs.cylinder_tracking`).

Error ``obs[0] * error_scale``, measured position ``stroke/2 (obs[7] + 1)``; derivative on the
measurement through a first-order filter ``tf``; integral with back-calculation (time constant
``tt``) or conditional anti-windup. Each plant's controller module tunes it
(``from_params``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["TrackingPID", "ANTI_WINDUP", "DT"]

DT = 1e-3  # s, control period of the cylinder-tracking envs
ANTI_WINDUP = ("back_calculation", "conditional", "none")


class TrackingPID:
    """PID on the position error with filtered derivative and anti-windup.

    ``kp`` [action/m], ``ti, td, tf, tt`` [s]; ``stroke`` [m] and ``error_scale`` [m] undo the
    observation's normalisation; ``anti_windup`` in ``("back_calculation", "conditional",
    "none")``. ``tt`` defaults to ``ti``.
    """

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float,
                 error_scale: float = 0.01, dt: float = DT, anti_windup: str = "back_calculation",
                 tt: float | None = None) -> None:
        tt = ti if tt is None else tt
        for name, val, lo in (("kp", kp, 0.0), ("ti", ti, 0.0), ("tt", tt, 0.0), ("stroke", stroke, 0.0),
                              ("error_scale", error_scale, 0.0), ("dt", dt, 0.0)):
            if not (math.isfinite(val) and val > lo):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        for name, val in (("td", td), ("tf", tf)):
            if not (math.isfinite(val) and val >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {val}")
        if anti_windup not in ANTI_WINDUP:
            raise ValueError(f"anti_windup = {anti_windup!r}; allowed {ANTI_WINDUP}")
        self.kp, self.ti, self.td, self.tf, self.tt = float(kp), float(ti), float(td), float(tf), float(tt)
        self.half = 0.5 * float(stroke)
        self.error_scale = float(error_scale)
        self.dt = float(dt)
        self.anti_windup = anti_windup
        self._n = -1
        self.reset()

    def reset(self, n: int | None = None) -> None:
        """Forget all internal states (``n`` copies; ``None``: size them on the next call)."""
        self._n = -1 if n is None else int(n)
        m = max(self._n, 0)
        self.integral = np.zeros(m)
        self.deriv = np.zeros(m)
        self.x_prev = np.zeros(m)
        self.fresh = np.ones(m, dtype=bool)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.integral[mask] = 0.0
        self.deriv[mask] = 0.0
        self.fresh[mask] = True

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        """Additive action before saturation (none here; see the subclass)."""
        return np.zeros(obs.shape[0])

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        o = obs[None, :] if single else obs
        if o.ndim != 2 or o.shape[1] < 11:
            raise ValueError(f"obs must have shape (11,) or (n, 11), got {obs.shape}")
        n = o.shape[0]
        if n != self._n:
            self.reset(n)
        if episode_start is not None:
            mask = np.broadcast_to(np.asarray(episode_start, dtype=bool).reshape(-1), (n,))
            self._reset_rows(mask)
        e = o[:, 0] * self.error_scale
        x = self.half * (o[:, 7] + 1.0)
        dx = np.where(self.fresh, 0.0, x - self.x_prev)
        self.deriv = (self.tf * self.deriv - self.kp * self.td * dx) / (self.tf + self.dt)
        v = self.kp * e + self.integral + self.deriv + self.feedforward(o)
        a = np.clip(v, -1.0, 1.0)
        di = self.kp * self.dt / self.ti * e
        if self.anti_windup == "back_calculation":
            di = di + self.dt / self.tt * (a - v)
        elif self.anti_windup == "conditional":
            di = np.where((a != v) & (np.sign(e) == np.sign(v)), 0.0, di)
        self.integral = self.integral + di
        self.x_prev = x
        self.fresh[:] = False
        act = a.astype(np.float32)[:, None]
        return (act[0] if single else act), state
