"""Position PID for the cylinder-tracking observation layout (:mod:`hydro_envs.envs.cylinder_tracking`).

Error ``obs[0] * error_scale``, measured position ``stroke/2 (obs[7] + 1)``; derivative on the
measurement through a first-order filter ``tf``; integral with back-calculation (time constant
``tt``) or conditional anti-windup. Each plant's controller module tunes it
(``from_params``).
"""

from __future__ import annotations

import math

import numpy as np

from agents.controllers.core import ANTI_WINDUP, BaseController, PIDCore

__all__ = ["TrackingPID", "ANTI_WINDUP", "DT"]

DT = 1e-3  # s, control period of the cylinder-tracking envs


class TrackingPID(BaseController):
    """PID on the position error with filtered derivative and anti-windup.

    ``kp`` [action/m], ``ti, td, tf, tt`` [s]; ``stroke`` [m] and ``error_scale`` [m] undo the
    observation's normalisation; ``anti_windup`` in ``("back_calculation", "conditional",
    "none")``. ``tt`` defaults to ``ti``. The law is :class:`~agents.controllers.core.PIDCore`'s
    on the error ``obs[0] * error_scale`` and the measured position; subclasses add
    :meth:`feedforward`.
    """

    obs_dim = 11

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float,
                 error_scale: float = 0.01, dt: float = DT, anti_windup: str = "back_calculation",
                 tt: float | None = None) -> None:
        super().__init__()
        tt = ti if tt is None else tt
        for name, val, lo in (("kp", kp, 0.0), ("ti", ti, 0.0), ("tt", tt, 0.0), ("stroke", stroke, 0.0),
                              ("error_scale", error_scale, 0.0), ("dt", dt, 0.0)):
            if not (math.isfinite(val) and val > lo):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        for name, val in (("td", td), ("tf", tf)):
            if not (math.isfinite(val) and val >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {val}")
        self.kp, self.ti, self.td, self.tf, self.tt = float(kp), float(ti), float(td), float(tf), float(tt)
        self.half = 0.5 * float(stroke)
        self.error_scale = float(error_scale)
        self.dt = float(dt)
        self.anti_windup = anti_windup
        self.pid = PIDCore(self.kp, self.ti, self.td, self.tf, self.dt, tt=self.tt, anti_windup=anti_windup)
        self.reset()

    @property
    def integral(self) -> np.ndarray:
        """The integrator state of every copy [action]."""
        return self.pid.integral

    def _allocate(self, n: int) -> None:
        self.pid.allocate(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.pid.reset_rows(mask)

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        """Additive action before saturation (none here; see the subclasses)."""
        return np.zeros(obs.shape[0])

    def _act(self, obs: np.ndarray) -> np.ndarray:
        e = obs[:, 0] * self.error_scale
        x = self.half * (obs[:, 7] + 1.0)
        return self.pid.step(e, x, self.feedforward(obs))
