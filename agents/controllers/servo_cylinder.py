r"""Classical baseline controllers for ``hydro_envs/ServoCylinderPosition-v0``.

PID, PID + friction feedforward and the model-based :class:`ServoFlowController`; all act on the env observation (layout: :mod:`hydro_envs.envs.servo_cylinder`)
and expose the SB3-style ``predict(obs, state=None, episode_start=None, deterministic=True)
-> (action, state)`` for a single observation ``(11,)`` or a batch ``(n, 11)``.

Tuning rule (from the plant's linearisation)
--------------------------------------------
The valve-controlled cylinder is, below its hydraulic resonance, an integrator
``x(s)/a(s) = K_q / s`` with the velocity gain ``K_q = v_nl`` per unit action
(:func:`~hydro_envs.plants.servo_cylinder.no_load_velocity`; nominal 0.669 m/s), in series with
a lightly damped oil-spring resonance ``omega_h`` (:func:`hydraulic_natural_frequency` at
mid-stroke; nominal 664 rad/s). The classical stability limit of the proportional loop is
``K_v = K_q K_p < 2 zeta_h omega_h``. We assume ``zeta_h = 0.075`` (``ZETA_H``; below the
textbook 0.1 because the seed's viscous coefficient alone gives only 0.015 and the critically
lapped valve adds little flow-pressure damping at null; with 0.1 and ``T_d = 0.25/omega_c`` the
closed loop of the nominal env sustained a ~1.9 mm oscillation at omega_h after a saturated step)
and place the crossover at half that limit (6 dB gain margin):

    omega_c = zeta_h omega_h                       (nominal 49.8 rad/s)
    K_p     = omega_c / K_q   [action per metre]   (nominal 74.4 1/m)
    T_i     = 4 / omega_c                          (nominal 80.4 ms; PI zero a factor 4 below omega_c)
    T_d     = 0.1 / omega_c                        (nominal 2.0 ms; small: the integrator plant
                                                     already gives 90 deg of phase, and D raises the
                                                     loop gain at omega_h)
    T_f     = 1 / (0.2 omega_h)                    (nominal 7.5 ms; the derivative filter rolls off
                                                     well below the resonance)
    T_t     = T_i                                  (back-calculation tracking time)

The P controller (:class:`ProportionalPositionController`) uses ``K_v = 40 1/s`` and no integral action.

Discrete law (``dt = 1 ms``, backward Euler), ``e = r - x_meas`` in metres::

    P_k = K_p e_k
    D_k = T_f/(T_f+dt) D_{k-1} - K_p T_d/(T_f+dt) (x_k - x_{k-1})   (derivative on the measurement,
                                                                  no kick on reference steps)
    v_k = P_k + I_k + D_k + ff_k ,   a_k = clip(v_k, -1, 1)
    I_{k+1} = I_k + K_p dt/T_i e_k + dt/T_t (a_k - v_k)            ("back_calculation")
    I_{k+1} = I_k + K_p dt/T_i e_k   unless a_k != v_k and e_k pushes further into the limit
                                                                  ("conditional")
    I_{k+1} = I_k + K_p dt/T_i e_k                                 ("none": windup)

Internal states (``I``, ``D``, ``x_{k-1}``) are kept per copy; rows with ``episode_start``
true are reset before the step (and the derivative is zero on a copy's first step).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.core import BaseController
from agents.controllers.tracking import TrackingPID

from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.plants.servo_cylinder.model import hydraulic_natural_frequency, no_load_velocity

__all__ = [
    "DT",
    "ZETA_H",
    "PIDController",
    "PIDFrictionFeedforwardController",
    "PIDModelFeedforwardController",
    "zero_friction",
    "ServoFlowController",
    "nominal_stribeck",
    "pid_tuning",
]

ZETA_H = 0.075  # assumed hydraulic damping ratio of the valve-cylinder resonance
DT = 1e-3  # s, control period of the servo env
PREVIEW_DT = 0.01  # s, obs[2] is the reference at +10 ms


def pid_tuning(params: ServoCylinderParams, zeta_h: float = ZETA_H) -> dict[str, float]:
    """The module docstring's rule: ``K_q, omega_h, omega_c, K_p, T_i, T_d, T_f`` (SI)."""
    if not (math.isfinite(zeta_h) and zeta_h > 0):
        raise ValueError(f"zeta_h must be > 0, got {zeta_h}")
    k_q = no_load_velocity(params)
    omega_h = hydraulic_natural_frequency(params, 0.5 * params.stroke)
    omega_c = zeta_h * omega_h
    return {
        "k_q": k_q,
        "omega_h": omega_h,
        "omega_c": omega_c,
        "kp": omega_c / k_q,
        "ti": 4.0 / omega_c,
        "td": 0.1 / omega_c,
        "tf": 1.0 / (0.2 * omega_h),
    }


def nominal_stribeck(params: ServoCylinderParams | None = None):
    """The plant's Stribeck law (002 eq (1)) as an :class:`identification.friction.FrictionFit`
    built from the parameter set (no fit: the "identified" model with zero error)."""
    from identification.friction import FrictionFit

    p = params if params is not None else ServoCylinderParams()
    return FrictionFit(
        model="stribeck",
        parameters={"F_c": p.coulomb_friction, "F_s": p.static_friction,
                     "v_s": p.stribeck_velocity, "F_v": p.viscous_friction},
        std_errors={},
        covariance=np.zeros((4, 4)),
        metrics={},
        residuals=np.zeros(0),
        sign_velocity=p.friction_sign_velocity,
    )


class PIDController(TrackingPID):
    """:class:`~agents.controllers.tracking.TrackingPID` tuned for this plant (module docstring)."""

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None, *, zeta_h: float = ZETA_H,
                    error_scale: float = 0.01, **kwargs: Any) -> PIDController:
        """Tuned by :func:`pid_tuning` for ``params`` (default: nominal)."""
        p = params if params is not None else ServoCylinderParams()
        t = pid_tuning(p, zeta_h)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], stroke=p.stroke, error_scale=error_scale, **kwargs)


class PIDFrictionFeedforwardController(PIDController):
    """:class:`PIDController` plus a friction feedforward at the reference velocity.

    ``v_ref = (r(t + 10 ms) - r(t)) / 0.01 s`` from the observation's preview; the increment
    ``FrictionCompensator(model, params).action(v_ref)`` (:mod:`hydro_envs.plants.servo_cylinder.compensation`:
    the valve command that delivers ``v_ref`` against the model's friction minus the one that
    delivers it against none, as a fraction of ``command_max``) is added before saturation, so
    the anti-windup sees the total command. ``model``: any ``F = model(v)`` [N] or object with
    ``.predict(v)`` (a :class:`~identification.friction.FrictionFit`, a neural model); default
    the nominal Stribeck law (:func:`nominal_stribeck`).
    """

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float,
                 model: Any = None, params: ServoCylinderParams | None = None, **kwargs: Any) -> None:
        from hydro_envs.plants.servo_cylinder.compensation import FrictionCompensator

        super().__init__(kp, ti, td, tf, stroke=stroke, **kwargs)
        p = params if params is not None else ServoCylinderParams()
        self.compensator = FrictionCompensator(model if model is not None else nominal_stribeck(p), p)

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None, *, zeta_h: float = ZETA_H,
                    error_scale: float = 0.01, model: Any = None, **kwargs: Any) -> PIDFrictionFeedforwardController:
        p = params if params is not None else ServoCylinderParams()
        t = pid_tuning(p, zeta_h)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], stroke=p.stroke, error_scale=error_scale,
                   model=model, params=p, **kwargs)

    def reference_velocity(self, obs: np.ndarray) -> np.ndarray:
        """``(r(+10 ms) - r) / 0.01 s`` [m/s] from obs[2] and obs[1]."""
        return self.half * (obs[:, 2] - obs[:, 1]) / PREVIEW_DT

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(self.compensator.action(self.reference_velocity(obs)), dtype=float)


class PIDModelFeedforwardController(PIDFrictionFeedforwardController):
    """:class:`PIDController` plus the whole steady-state valve command for the reference
    velocity: ``FrictionCompensator(model, params).command(v_ref) / command_max``, the inverse
    orifice law (002 eqs (3)-(7)) at the load pressure of the model's friction, rather than only
    the friction increment of :class:`PIDFrictionFeedforwardController`. With ``model`` the zero
    law (:func:`zero_friction`, controller ``pid_vff``) it is the friction-blind velocity
    feed-forward, so ``pid_vff`` against ``pid_vff_stribeck`` isolates what the friction model
    adds."""

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        v = self.reference_velocity(obs)
        return np.asarray(self.compensator.command(v), dtype=float) / self.compensator.params.command_max


def zero_friction(v: Any) -> np.ndarray:
    """The friction-free law ``F(v) = 0`` [N]."""
    return np.zeros_like(np.asarray(v, dtype=float))


class ServoFlowController(BaseController):
    r"""Model-based nonlinear controller: velocity feedforward through the inverse orifice law
    with measured load-pressure feedback (flow feedback linearisation, 002 eqs (3)-(7)).

    Desired piston velocity (outer PI loop on the position error, same crossover as the PID)::

        v_d = v_ref + omega_c e + I,   I_{k+1} = I_k + dt omega_c / T_i e_k   (frozen in saturation)
        v_ref = (r(t + 10 ms) - r(t)) / 10 ms          (reference preview, obs[1..2])

    Inner loop: the valve opening that delivers ``v_d`` at the *measured* load pressure
    ``p_L = p1 - p2`` (obs[8..9] times the nominal supply), i.e. the steady-state orifice law of
    :func:`hydro_envs.plants.servo_cylinder.compensation.valve_command` with the friction force replaced by the
    measured ``A p_L`` -- this linearises the pressure dependence of the flow gain (002 eq (3):
    ``Q = C_v w x_v sqrt(2 dp / rho)``) whatever the friction or load is::

        u = v_d A / (k_v C_v w sqrt((p_s - p_R - sgn(v_d) p_L) / rho)),   a = u / u_max

    The edge drop is floored at 5 % of ``p_s - p_R`` (near stall the inverse gain would blow up).
    Designed on the nominal parameters (``params``); nominal ``omega_c = 49.8 1/s``,
    ``T_i = 80 ms`` (:func:`pid_tuning`).
    """

    obs_dim = 11
    action_dim = 1

    def __init__(self, params: ServoCylinderParams | None = None, *, zeta_h: float = ZETA_H,
                 error_scale: float = 0.01, dt: float = DT) -> None:
        super().__init__()
        p = params if params is not None else ServoCylinderParams()
        t = pid_tuning(p, zeta_h)
        self.params = p
        self.omega_c = t["omega_c"]
        self.ti = t["ti"]
        self.error_scale = float(error_scale)
        self.dt = float(dt)
        self.half = 0.5 * p.stroke
        self._gain = p.spool_gain * p.discharge_coefficient * p.area_gradient * math.sqrt(2.0 / p.oil_density)
        self.reset()

    def _allocate(self, n: int) -> None:
        self.integral = np.zeros(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.integral[mask] = 0.0

    def _act(self, o: np.ndarray) -> np.ndarray:
        p = self.params
        e = o[:, 0] * self.error_scale
        v_ref = self.half * (o[:, 2] - o[:, 1]) / PREVIEW_DT
        v_d = v_ref + self.omega_c * e + self.integral
        p_l = (o[:, 8] - o[:, 9]) * p.supply_pressure
        drop = np.maximum(p.supply_pressure - p.tank_pressure - np.sign(v_d) * p_l,
                          0.05 * (p.supply_pressure - p.tank_pressure))
        u = v_d * p.piston_area / (self._gain * np.sqrt(0.5 * drop))
        v_cmd = u / p.command_max
        a = np.clip(v_cmd, -1.0, 1.0)
        grow = (a == v_cmd) | (np.sign(e) != np.sign(v_cmd))
        self.integral = self.integral + np.where(grow, self.dt * self.omega_c / self.ti * e, 0.0)
        return a


#: bandwidth of :class:`ProportionalPositionController`'s loop [1/s]
LOOP_BANDWIDTH = 40.0


class ProportionalPositionController:
    """``a = K_p (r - x)`` on the env observation (SB3-style ``predict``).

    The classical loop for a valve-controlled cylinder: the plant is an integrator with
    velocity gain ``K_q = v_noload`` per unit action (orifice law, 002 eqs (3)-(5)), so
    ``a = K_p e`` closes a first-order loop with bandwidth ``K_q K_p``, placed at
    :data:`LOOP_BANDWIDTH` = 40 1/s, well below the usual stability limit ``2 zeta_h omega_h``
    of a valve-controlled cylinder (omega_h = 680 rad/s at the stroke end, zeta_h ~ 0.1 gives
    136 1/s)."""

    def __init__(self, nominal: ServoCylinderParams | None = None, error_scale: float = 0.01,
                 bandwidth: float = LOOP_BANDWIDTH) -> None:
        nominal = nominal or ServoCylinderParams()
        self.kp = bandwidth / no_load_velocity(nominal)  # action per metre of error
        self.error_scale = error_scale

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs)
        error = obs[..., 0:1] * self.error_scale  # obs[0] = e / error_scale
        return np.clip(self.kp * error, -1.0, 1.0).astype(np.float32), state


#: the plant these controllers are for (its registry name)
PLANT = "servo_cylinder"

# ------------------------------------------------------------------ registry hooks
#: the benchmark's step reference per env id of this plant (None: no step episodes)
_STEP_REFERENCE = {
    "hydro_envs/ServoCylinderPosition-v0": "steps",
    "hydro_envs/ServoCylinderSlowSine-v0": None,
    "hydro_envs/ServoCylinderMicroPosition-v0": "micro_steps",
}


def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory."""
    from agents.controllers.core import ZeroController
    from agents.controllers.friction_models import identified_friction

    return {
        "zero": lambda: ZeroController(1),
        "p": ProportionalPositionController,
        "pid": PIDController.from_params,
        "pid_ff_stribeck": lambda: PIDFrictionFeedforwardController.from_params(
            model=identified_friction(PLANT, "stribeck")),
        "pid_ff_neural": lambda: PIDFrictionFeedforwardController.from_params(
            model=identified_friction(PLANT, "neural")),
        "pid_vff": lambda: PIDModelFeedforwardController.from_params(model=zero_friction),
        "pid_vff_stribeck": lambda: PIDModelFeedforwardController.from_params(
            model=identified_friction(PLANT, "stribeck")),
        "pid_vff_neural": lambda: PIDModelFeedforwardController.from_params(
            model=identified_friction(PLANT, "neural")),
        "pid_vff_rbf": lambda: PIDModelFeedforwardController.from_params(
            model=identified_friction(PLANT, "rbf")),
        "flow": ServoFlowController,
    }


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (position tracking, encoder-level settling band)."""
    from agents.adapters import EnvAdapter, cyl_output, cyl_pressures, cyl_stroke

    return EnvAdapter(env_id, "position", "m", _STEP_REFERENCE.get(env_id), 1e-4, cyl_output, cyl_pressures,
                      cyl_stroke)


def friction_points():
    from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
    from identification.constant_velocity import friction_points_from_square_wave

    exp = run_friction_experiment(period_max=3.0)
    return friction_points_from_square_wave(exp.data), exp.params.friction_sign_velocity, "stribeck"
