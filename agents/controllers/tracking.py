"""Position PID for the cylinder-tracking observation layout (:mod:`hydro_envs.envs.cylinder_tracking`).

Error ``stroke/2 (obs[1] - obs[7])`` (reference less measured position, both normalised by the
half stroke: independent of the env's ``error_scale``, which only scales obs[0] for learned
policies), measured position ``stroke/2 (obs[7] + 1)``; derivative on the
measurement through a first-order filter ``tf``; integral with back-calculation (time constant
``tt``) or conditional anti-windup. Each plant's controller module tunes it
(``from_params``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.core import ANTI_WINDUP, BaseController, PIDCore, bristle_step_at_frozen_velocity

__all__ = ["TrackingPID", "PressureLoopPID", "FrictionObserver", "LuGreFeedforward", "LuGreObserver", "ANTI_WINDUP", "DT",
           "PREVIEW_DT"]

DT = 1e-3  # s, control period of the cylinder-tracking envs
#: the observation's preview offsets [steps] after the current reference (obs[1])
PREVIEW_STEPS_OBS = (0, 10, 20, 30, 40, 50)


class TrackingPID(BaseController):
    """PID on the position error with filtered derivative and anti-windup.

    ``kp`` [action/m], ``ti, td, tf, tt`` [s] (``ti = inf``: no integral); ``stroke`` [m] and ``error_scale`` [m] undo the
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
        for name, val, lo in (("kp", kp, 0.0), ("stroke", stroke, 0.0), ("error_scale", error_scale, 0.0),
                              ("dt", dt, 0.0)):
            if not (math.isfinite(val) and val > lo):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        for name, val in (("ti", ti), ("tt", tt)):  # inf: no integral action
            if not (val > 0.0 and not math.isnan(val)):
                raise ValueError(f"{name} must be > 0 (inf: no integral), got {val}")
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

    def position_error(self, obs: np.ndarray) -> np.ndarray:
        """``r - x_meas`` [m] from the observation's reference and measured position."""
        return self.half * (obs[:, 1] - obs[:, 7])

    def _act(self, obs: np.ndarray) -> np.ndarray:
        e = self.position_error(obs)
        x = self.half * (obs[:, 7] + 1.0)
        return self.pid.step(e, x, self.feedforward(obs))


#: seconds between the observation's reference previews (obs[1] = r(t), obs[2..6] = r(t + 10 k ms))
PREVIEW_DT = 0.01
#: reference speed [m/s] below which :class:`PressureLoopPID` takes the reference as holding
HOLD_SPEED = 1e-4


class PressureLoopPID(TrackingPID):
    r"""Position PID with a load-pressure loop and optional velocity and friction feed-forward,
    for the cylinder-tracking observation (obs[8..9] = chamber pressures over ``p_s``)::

        a = PID(e) + vff v_ref / K_q + k_dp (F^(v_ref) / A - (p_1 - p_2)) / p_s

    * the pressure feedback ``-k_dp (p_1 - p_2) / p_s`` damps the oil (or air) spring mode of the
      axis, which limits a position loop without it to ``K_v < 2 zeta_h omega_h``;
    * ``v_ref`` is the reference velocity between the previews ``preview`` and ``preview + 1``
      (10 ms apart), ``K_q`` the velocity gain per unit action (``vff = True``: the velocity
      feed-forward);
    * ``F^(v)`` [N] is a friction model (``model``: callable or ``.predict``; ``None``: no
      friction in the target). At a velocity reversal of the reference it swings the target
      pressure by ``2 F^ / A`` ahead of the motion, the pressure the axis otherwise has to build
      while it stands still. A subclass can override :meth:`friction_target` (an observer).
    * ``hold_band`` [m] > 0: while the reference holds (``|v_ref| <`` :data:`HOLD_SPEED`) the target
      is the model's breakaway level ``F^(0+)`` in the direction of the position error,
      ``F^(0+) tanh(e / hold_band)``: a step from rest builds the breakaway pressure at once
      instead of through the integral, and the target fades inside the band, so the axis is not
      pushed back and forth about the level (the stiction compensation of micro-positioning).
    """

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float, k_q: float, area: float,
                 supply_pressure: float, k_dp: float, vff: bool = False, model: Any = None, preview: int = 1,
                 hold_band: float = 0.0, **kwargs: Any) -> None:
        super().__init__(kp, ti, td, tf, stroke=stroke, **kwargs)
        for name, val in (("k_q", k_q), ("area", area), ("supply_pressure", supply_pressure)):
            if not (np.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        if not (np.isfinite(k_dp) and k_dp >= 0):
            raise ValueError(f"k_dp must be finite and >= 0, got {k_dp}")
        if preview not in range(len(PREVIEW_STEPS_OBS) - 1):
            raise ValueError(f"preview = {preview!r}; allowed 0..{len(PREVIEW_STEPS_OBS) - 2}")
        self.k_q, self.area, self.ps, self.k_dp = float(k_q), float(area), float(supply_pressure), float(k_dp)
        if not (np.isfinite(hold_band) and hold_band >= 0):
            raise ValueError(f"hold_band must be finite and >= 0 m, got {hold_band}")
        if hold_band > 0 and model is None:
            raise ValueError("hold_band > 0 needs a friction model (its breakaway level)")
        self.vff, self.preview, self.hold_band = bool(vff), int(preview), float(hold_band)
        #: factor on the friction target (1: the model as identified; 0: the blind twin), for ablations
        self.friction_scale = 1.0
        self._f = None if model is None else (model.predict if hasattr(model, "predict") else model)

    def preview_velocity(self, j: int, obs: np.ndarray) -> np.ndarray:
        """Reference velocity [m/s] between previews ``j`` and ``j + 1`` (obs[1 + j], obs[2 + j])."""
        return self.half * (obs[:, 2 + j] - obs[:, 1 + j]) / PREVIEW_DT

    def friction_target(self, v: np.ndarray, dp: np.ndarray, obs: np.ndarray) -> np.ndarray | float:
        """Friction force [N] the pressure difference should carry at reference velocity ``v``
        (and, with ``hold_band``, at the position error of a hold)."""
        if self._f is None:
            return 0.0
        f = np.asarray(self._f(v), dtype=float)
        if self.hold_band > 0.0:
            e = self.position_error(obs)
            up = np.asarray(self._f(np.full_like(v, HOLD_SPEED * 1e-6)), dtype=float)
            down = -np.asarray(self._f(np.full_like(v, -HOLD_SPEED * 1e-6)), dtype=float)
            breakaway = np.where(e >= 0.0, up, down) * np.tanh(e / self.hold_band)
            f = np.where(np.abs(v) < HOLD_SPEED, breakaway, f)
        return f

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        v = self.preview_velocity(self.preview, obs)
        out = v / self.k_q if self.vff else np.zeros(obs.shape[0])
        if self.k_dp > 0.0:
            dp = (obs[:, 8] - obs[:, 9]) * self.ps
            target = self.friction_scale * np.asarray(self.friction_target(v, dp, obs), dtype=float)
            out = out + self.k_dp * (target / self.area - dp) / self.ps
        return out


class FrictionObserver:
    """Mixin for :class:`PressureLoopPID`: the friction target from a disturbance observer on the
    axis' force balance instead of an identified model (an on-line, adaptive compensator).

    While the reference slides (``|v_ref| > v_slide``) the force the fluid carries beyond the
    inertia, ``F^_d = A (p_1 - p_2) - M a_ref``, is the friction at ``v_ref``; the observer
    low-passes ``F^_d sgn(v_ref)`` (time constant ``tau``) into a level ``F^_c`` per copy that
    starts at 0 (no prior: it learns the sliding friction on the first stroke) and holds between
    slides. The target is ``F^_c tanh(v_ref / v_slide)``. ``a_ref`` is the preview's second
    difference, ``mass`` [kg] the nominal moving mass."""

    def __init__(self, *args: Any, mass: float, tau: float = 0.3, v_slide: float = 1e-3, **kwargs: Any) -> None:
        for name, val in (("mass", mass), ("tau", tau), ("v_slide", v_slide)):
            if not (np.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        self.mass, self.tau, self.v_slide = float(mass), float(tau), float(v_slide)
        kwargs.pop("model", None)  # the observer is the friction model
        super().__init__(*args, model=None, **kwargs)

    @property
    def level(self) -> np.ndarray:
        """The observed sliding friction of every copy [N]."""
        return self._fc

    def _allocate(self, n: int) -> None:
        super()._allocate(n)  # type: ignore[misc]
        self._fc = np.zeros(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        super()._reset_rows(mask)  # type: ignore[misc]
        self._fc[mask] = 0.0

    def friction_target(self, v: np.ndarray, dp: np.ndarray, obs: np.ndarray) -> np.ndarray:
        sliding = np.abs(v) > self.v_slide
        if sliding.any():
            pv = self.preview_velocity  # type: ignore[attr-defined]
            a = (pv(2, obs) - pv(0, obs)) / (2.0 * PREVIEW_DT)
            f_d = self.area * dp[sliding] - self.mass * a[sliding]  # type: ignore[attr-defined]
            self._fc[sliding] += (self.dt / self.tau) * (np.sign(v[sliding]) * f_d - self._fc[sliding])  # type: ignore[attr-defined]
        return self._fc * np.tanh(v / self.v_slide)


class LuGreFeedforward:
    """Mixin for :class:`PressureLoopPID`: the friction target from a LuGre model driven by the
    reference velocity instead of the static law -- a dynamic friction feed-forward.

    ``stribeck``: the static fit (parameters ``F_c, F_s, v_s, F_v`` of 002 eq (1)) as the
    model's steady state; ``sigma0`` [N/m] its bristle stiffness (identified on a pre-sliding
    test); ``sigma1`` [N s/m] its micro-damping (fading over ``v_s``). Per copy the bristle state
    ``z`` follows ``dz/dt = v - sigma0 |v| z / g(v)`` at the reference velocity (the exact update
    over one control period at frozen ``v``), and the target is
    ``sigma0 z + sigma1(v) dz/dt + F_v v``: at a reversal the target passes through zero over the
    pre-sliding distance instead of flipping at once, and a reversal after a short stroke starts
    from a partly loaded bristle."""

    def __init__(self, *args: Any, stribeck: Any, sigma0: float, sigma1: float = 0.0, **kwargs: Any) -> None:
        par = stribeck.parameters if hasattr(stribeck, "parameters") else dict(stribeck)
        self.f_c, self.f_s, self.v_s = float(par["F_c"]), float(par["F_s"]), float(par["v_s"])
        self.f_v = float(par.get("F_v", 0.0))
        for name, val in (("sigma0", sigma0), ("F_c", self.f_c), ("v_s", self.v_s)):
            if not (np.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be finite and > 0, got {val}")
        self.sigma0, self.sigma1 = float(sigma0), float(sigma1)
        kwargs.pop("model", None)
        super().__init__(*args, model=lambda v: np.zeros_like(v), **kwargs)

    def _allocate(self, n: int) -> None:
        super()._allocate(n)  # type: ignore[misc]
        self._z = np.zeros(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        super()._reset_rows(mask)  # type: ignore[misc]
        self._z[mask] = 0.0

    def bristle_correction(self, obs: np.ndarray) -> np.ndarray | float:
        """Extra bristle rate [m/s] added to ``dz/dt`` (none here: a pure feed-forward)."""
        return 0.0

    def friction_target(self, v: np.ndarray, dp: np.ndarray, obs: np.ndarray) -> np.ndarray:
        g = self.f_c + (self.f_s - self.f_c) * np.exp(-np.abs(v) / self.v_s)
        a = self.sigma0 * np.abs(v) / g
        corr = self.bristle_correction(obs)
        self._z = bristle_step_at_frozen_velocity(self._z, v, g, self.sigma0, self.dt) + corr * self.dt  # type: ignore[attr-defined]
        z_max = max(self.f_s, self.f_c) / self.sigma0
        self._z = np.clip(self._z, -z_max, z_max)
        dz = v - a * self._z + corr
        s1 = self.sigma1 * np.exp(-((v / self.v_s) ** 2))
        return self.sigma0 * self._z + s1 * dz + self.f_v * v


class LuGreObserver(LuGreFeedforward):
    """Mixin for :class:`PressureLoopPID`: :class:`LuGreFeedforward` with the observer correction
    of Canudas de Wit, Olsson, Astrom and Lischinsky (IEEE TAC 40(3), 1995, sec. IV): the
    bristle estimate follows ``dz^/dt = v - sigma0 |v| z^ / g(v) + k_obs e`` with ``e = r - x``
    the measured position error, so a piston that lags (or sticks) loads the estimated bristle
    further and the friction target grows until it moves; ``|z^|`` is held within the bristle's
    largest deflection ``F_s / sigma0``. ``k_obs`` [1/s] the observer gain (0: the feed-forward)."""

    def __init__(self, *args: Any, k_obs: float, **kwargs: Any) -> None:
        if not (np.isfinite(k_obs) and k_obs >= 0):
            raise ValueError(f"k_obs must be finite and >= 0 1/s, got {k_obs}")
        self.k_obs = float(k_obs)
        super().__init__(*args, **kwargs)

    def bristle_correction(self, obs: np.ndarray) -> np.ndarray:
        return self.k_obs * self.position_error(obs)  # type: ignore[attr-defined]
