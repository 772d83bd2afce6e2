r"""Classical baseline controllers for ``hydro_envs/ServoCylinderPosition-v0`` and its friction tasks.

The PID position loop with load-pressure feedback, the same loop with velocity and friction
feed-forward, a P loop and the model-based :class:`ServoFlowController`; all act on the env
observation (layout: :mod:`hydro_envs.envs.servo_cylinder`) and expose the SB3-style
``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)`` for a
single observation ``(11,)`` or a batch ``(n, 11)``.

Tuning rule (from the plant's linearisation without dry friction)
-----------------------------------------------------------------
The valve-controlled cylinder is, below its hydraulic resonance, an integrator
``x(s)/a(s) = K_q / s`` with the velocity gain ``K_q = v_nl`` per unit action
(:func:`~hydro_envs.plants.servo_cylinder.no_load_velocity`; nominal 0.669 m/s), in series with
the oil-spring resonance ``omega_h`` (:func:`hydraulic_natural_frequency` at mid-stroke; nominal
664 rad/s). Its damping comes from the seed's viscous coefficient alone (the critically lapped,
leak-free valve of 002 eq (8) adds none at null): ``zeta_h = 0.015``, so a position loop alone
is limited to ``K_v = K_q K_p < 2 zeta_h omega_h = 20 1/s`` (6 dB gain margin at 10 1/s). The
loop's stability must not rest on friction (dry friction damps the axis only while it sticks),
so the loop closes a load-pressure feedback inside the position loop, the textbook remedy
(Merritt, *Hydraulic Control Systems*, 1967, ch. 8: pressure feedback raises the valve's
flow-pressure coefficient and with it the damping)::

    a = PID(e) - k_dp (p_1 - p_2) / p_s        (+ feed-forward, below)

    k_dp    = 0.09                                (K_DP; the P and flow loops: 0.06, P_K_DP)
    omega_c = 0.03 omega_h                        (nominal 20 1/s)
    K_p     = omega_c / K_q   [action per metre]   (nominal 30 1/m)
    T_i     = 4 / omega_c                          (nominal 0.2 s)
    T_d     = 0.1 / omega_c                        (nominal 5 ms)
    T_f     = 1 / (0.2 omega_h)                    (nominal 7.5 ms)

The gains are fixed on the nominal plant and must hold over the randomisation, whose oil spring
spans a factor of two in ``omega_h`` (mass 1-2x, bulk modulus 0.5-1 GPa) and whose damping is
lightest on the heavy, low-viscosity draws: too little pressure feedback leaves those undamped,
too much destabilises the pressure loop on the light, stiff-oil draws (their oil resonance near
130 Hz sits close to a 150 Hz valve and the 1 ms sample). On the plants linearised without dry
friction and sampled at 1 ms (:mod:`agents.controllers.margins`): nominal gain margin 25.9 dB,
phase margin 80 deg at 3.2 Hz crossover; at least 4.2 dB over the corners of the randomisation
(8.5 dB for the P and flow loops with their own ``k_dp = 0.06``, :data:`P_K_DP`; one gain 0.12 for
all three left the PID 0.17 dB and the P and flow loops unstable on the corner with the slowest,
least damped valve; ``tests/test_controller_margins.py``). The loop of before (crossover ``0.075 omega_h``, no
pressure feedback) has a gain margin of -2.2 dB there: it was stable only through the damping
of its regularised friction.

Feed-forward (:class:`~agents.controllers.tracking.PressureLoopPID`)::

    a += vff v_ref / K_q + k_dp F^(v_ref) / (A p_s)

``v_ref`` from the reference preview (10-20 ms ahead), ``F^`` an identified friction model: the
pressure target swings by ``2 F^ / A`` at a reference reversal, ahead of the motion, instead of
the loop building it while the piston sticks (the lost motion of about 2 x 22 um of oil
compression at the seed's volumes). Names: ``pid`` (no feed-forward), ``pid_vff`` (velocity
feed-forward, no friction), ``pid_ff_<model>`` / ``pid_vff_<model>`` the same with the friction
model ``<model>`` -- so ``pid`` / ``pid_vff`` are the friction-blind twins.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.core import BaseController
from agents.controllers.tracking import PREVIEW_DT, FrictionObserver, LuGreFeedforward, LuGreObserver, PressureLoopPID

from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.plants.servo_cylinder.model import hydraulic_natural_frequency, no_load_velocity

__all__ = [
    "DT",
    "K_DP",
    "P_K_DP",
    "CROSSOVER_RATIO",
    "ServoPIDController",
    "ServoObserverController",
    "ServoLuGreController",
    "ServoLuGreObserverController",
    "zero_friction",
    "ServoFlowController",
    "nominal_stribeck",
    "pid_tuning",
]

DT = 1e-3  # s, control period of the servo env
#: gain of the PID's load-pressure loop [action per supply pressure] (module docstring: on the
#: randomisation's corners 0.12 left the PID 0.17 dB, 0.08 2.8 dB, 0.09 4.2 dB, 0.1 2.7 dB, 0.06 unstable)
K_DP = 0.09
#: the same gain of the P and flow loops, which have no integral and a smaller phase lag (on the
#: corners 0.12 unstable, 0.09 2.6 dB, 0.06 8.5 dB, 0.04 4.2 dB; ``tests/test_controller_margins.py``)
P_K_DP = 0.06
#: loop crossover over the hydraulic natural frequency
CROSSOVER_RATIO = 0.03


def pid_tuning(params: ServoCylinderParams, crossover_ratio: float = CROSSOVER_RATIO) -> dict[str, float]:
    """The module docstring's rule: ``k_q, omega_h, omega_c, kp, ti, td, tf, k_dp`` (SI)."""
    if not (math.isfinite(crossover_ratio) and crossover_ratio > 0):
        raise ValueError(f"crossover_ratio must be > 0, got {crossover_ratio}")
    k_q = no_load_velocity(params)
    omega_h = hydraulic_natural_frequency(params, 0.5 * params.stroke)
    omega_c = crossover_ratio * omega_h
    return {
        "k_q": k_q,
        "omega_h": omega_h,
        "omega_c": omega_c,
        "kp": omega_c / k_q,
        "ti": 4.0 / omega_c,
        "td": 0.1 / omega_c,
        "tf": 1.0 / (0.2 * omega_h),
        "k_dp": K_DP,
    }


def nominal_stribeck(params: ServoCylinderParams | None = None):
    """The plant's Stribeck law (002 eq (1), the steady state of its LuGre seals) as an
    :class:`identification.friction.FrictionFit` built from the parameter set (no fit: the
    "identified" model with zero error)."""
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
        sign_velocity=0.0,
    )


class ServoPIDController(PressureLoopPID):
    """:class:`~agents.controllers.tracking.PressureLoopPID` tuned for this plant by
    :func:`pid_tuning` (module docstring): ``vff`` and ``model`` select the feed-forward."""

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None, *, crossover_ratio: float = CROSSOVER_RATIO,
                    error_scale: float = 0.01, vff: bool = False, model: Any = None,
                    **kwargs: Any) -> ServoPIDController:
        """Tuned by :func:`pid_tuning` for ``params`` (default: nominal)."""
        p = params if params is not None else ServoCylinderParams()
        t = pid_tuning(p, crossover_ratio)
        kwargs.setdefault("k_dp", t["k_dp"])
        return cls(t["kp"], t["ti"], t["td"], t["tf"], stroke=p.stroke, error_scale=error_scale, k_q=t["k_q"],
                   area=p.piston_area, supply_pressure=p.supply_pressure, vff=vff, model=model, **kwargs)


class ServoObserverController(FrictionObserver, ServoPIDController):
    """``pid_vff_dob``: :class:`ServoPIDController` with the velocity feed-forward and the friction
    target of the on-line disturbance observer :class:`~agents.controllers.tracking.FrictionObserver`
    (no identification run; the nominal moving mass; sliding above 0.1 mm/s, the friction
    tasks' creep speeds being 0.2-1.6 mm/s). Blind twin: ``pid_vff``."""

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None, **kwargs: Any) -> ServoObserverController:
        p = params if params is not None else ServoCylinderParams()
        kwargs.setdefault("v_slide", 1e-4)
        return super().from_params(p, vff=True, mass=p.mass, **kwargs)


class ServoLuGreController(LuGreFeedforward, ServoPIDController):
    """``pid_vff_lugre``: :class:`ServoPIDController` with the velocity feed-forward and a LuGre
    friction feed-forward (:class:`~agents.controllers.tracking.LuGreFeedforward`) identified on the
    rig: its steady state the Stribeck law of the square-wave test, its bristle stiffness from
    the pre-sliding test (:func:`~hydro_envs.plants.servo_cylinder.friction_test.presliding_test`,
    :func:`identification.friction.bristle_stiffness_from_loading`), its micro-damping critical for
    the nominal mass. Blind twin: ``pid_vff``."""

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None, **kwargs: Any) -> ServoLuGreController:
        from agents.controllers.friction_models import identified_friction, identified_presliding

        p = params if params is not None else ServoCylinderParams()
        sigma0, _ = identified_presliding(PLANT)
        return super().from_params(p, vff=True, stribeck=identified_friction(PLANT, "stribeck"), sigma0=sigma0,
                                   sigma1=2.0 * math.sqrt(sigma0 * p.mass), **kwargs)


class ServoLuGreObserverController(LuGreObserver, ServoLuGreController):
    """``pid_vff_lugre_observer``: :class:`ServoLuGreController` whose bristle estimate is corrected
    by the position error (:class:`~agents.controllers.tracking.LuGreObserver`, gain
    :data:`OBSERVER_GAIN`). Blind twin: ``pid_vff``."""

    @classmethod
    def from_params(cls, params: ServoCylinderParams | None = None,
                    **kwargs: Any) -> ServoLuGreObserverController:
        kwargs.setdefault("k_obs", OBSERVER_GAIN)
        return super().from_params(params, **kwargs)  # type: ignore[return-value]


#: LuGre observer gain [1/s] (assumed: 4 x below 2000 1/s, where loops on the slow-sine task's
#: ``out`` draws diverge; with sigma0 ~ 2e6 N/m a 10 um lag builds the target at ~1e4 N/s)
OBSERVER_GAIN = 500.0


def zero_friction(v: Any) -> np.ndarray:
    """The friction-free law ``F(v) = 0`` [N]."""
    return np.zeros_like(np.asarray(v, dtype=float))


class ServoFlowController(BaseController):
    r"""Model-based nonlinear controller: velocity feedforward through the inverse orifice law
    with measured load-pressure feedback (flow feedback linearisation, 002 eqs (3)-(7)), plus the
    load-pressure damping loop of the PID (module docstring).

    Desired piston velocity (outer PI loop on the position error, the PID's crossover)::

        v_d = v_ref + omega_c e + I,   I_{k+1} = I_k + dt omega_c / T_i e_k   (frozen in saturation)
        v_ref = (r(t + 10 ms) - r(t)) / 10 ms          (reference preview, obs[1..2])

    Inner loop: the valve opening that delivers ``v_d`` at the *measured* load pressure
    ``p_L = p1 - p2`` (obs[8..9] times the nominal supply), i.e. the steady-state orifice law of
    :func:`hydro_envs.plants.servo_cylinder.compensation.valve_command` with the friction force replaced by the
    measured ``A p_L`` -- this linearises the pressure dependence of the flow gain (002 eq (3):
    ``Q = C_v w x_v sqrt(2 dp / rho)``) whatever the friction or load is -- and the damping term
    ``-k_dp p_L / p_s`` (near null the inverse law alone adds no damping)::

        u = v_d A / (k_v C_v w sqrt((p_s - p_R - sgn(v_d) p_L) / rho)),   a = u / u_max - k_dp p_L / p_s

    The edge drop is floored at 5 % of ``p_s - p_R`` (near stall the inverse gain would blow up).
    Designed on the nominal parameters (``params``, :func:`pid_tuning`).
    """

    obs_dim = 11
    action_dim = 1

    def __init__(self, params: ServoCylinderParams | None = None, *, crossover_ratio: float = CROSSOVER_RATIO,
                 error_scale: float = 0.01, dt: float = DT) -> None:
        super().__init__()
        p = params if params is not None else ServoCylinderParams()
        t = pid_tuning(p, crossover_ratio)
        self.params = p
        self.omega_c = t["omega_c"]
        self.ti = t["ti"]
        self.k_dp = P_K_DP  # the P loop's pressure gain: near null this loop is a P loop with a slow integral
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
        e = self.half * (o[:, 1] - o[:, 7])  # r - x_meas, whatever the env's error_scale
        v_ref = self.half * (o[:, 2] - o[:, 1]) / PREVIEW_DT
        v_d = v_ref + self.omega_c * e + self.integral
        p_l = (o[:, 8] - o[:, 9]) * p.supply_pressure
        drop = np.maximum(p.supply_pressure - p.tank_pressure - np.sign(v_d) * p_l,
                          0.05 * (p.supply_pressure - p.tank_pressure))
        u = v_d * p.piston_area / (self._gain * np.sqrt(0.5 * drop))
        v_cmd = u / p.command_max - self.k_dp * p_l / p.supply_pressure
        a = np.clip(v_cmd, -1.0, 1.0)
        grow = (a == v_cmd) | (np.sign(e) != np.sign(v_cmd))
        self.integral = self.integral + np.where(grow, self.dt * self.omega_c / self.ti * e, 0.0)
        return a


#: bandwidth of :class:`ProportionalPositionController`'s loop [1/s]
LOOP_BANDWIDTH = 20.0


class ProportionalPositionController(PressureLoopPID):
    """``a = K_p (r - x) - k_dp (p_1 - p_2) / p_s`` on the env observation: the P loop of a
    valve-controlled cylinder (an integrator with velocity gain ``K_q = v_nl`` per unit action,
    so ``a = K_p e`` closes a first-order loop of bandwidth ``K_q K_p`` =
    :data:`LOOP_BANDWIDTH`, the PID's crossover) with load-pressure damping of gain
    :data:`P_K_DP` (module docstring); no integral, derivative or feed-forward, so a load leaves a steady error
    ``k_dp p_L / (p_s K_p)``."""

    def __init__(self, nominal: ServoCylinderParams | None = None, error_scale: float = 0.01,
                 bandwidth: float = LOOP_BANDWIDTH) -> None:
        p = nominal or ServoCylinderParams()
        k_q = no_load_velocity(p)
        super().__init__(bandwidth / k_q, math.inf, 0.0, 0.0, stroke=p.stroke, error_scale=error_scale, k_q=k_q,
                         area=p.piston_area, supply_pressure=p.supply_pressure, k_dp=P_K_DP)


#: the plant these controllers are for (its registry name)
PLANT = "servo_cylinder"

# ------------------------------------------------------------------ registry hooks
#: the benchmark's step reference per env id of this plant (None: no step episodes)
_STEP_REFERENCE = {
    "hydro_envs/ServoCylinderPosition-v0": "steps",
    "hydro_envs/ServoCylinderSlowSine-v0": None,
    "hydro_envs/ServoCylinderMicroPosition-v0": "micro_steps",
}


#: friction models the feed-forward controllers use (agents.controllers.friction_models)
FRICTION_MODELS = ("stribeck", "neural", "rbf")


def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory (module
    docstring: ``pid`` / ``pid_vff`` and their friction-model variants)."""
    from agents.controllers.core import ZeroController
    from agents.controllers.friction_models import identified_friction

    out = {
        "zero": lambda: ZeroController(1),
        "p": ProportionalPositionController,
        "pid": ServoPIDController.from_params,
        "pid_vff": lambda: ServoPIDController.from_params(vff=True),
        "pid_vff_dob": ServoObserverController.from_params,
        "pid_vff_lugre": ServoLuGreController.from_params,
        "pid_vff_lugre_observer": ServoLuGreObserverController.from_params,
        "flow": ServoFlowController,
    }
    for kind in FRICTION_MODELS:
        out[f"pid_ff_{kind}"] = lambda kind=kind: ServoPIDController.from_params(
            model=identified_friction(PLANT, kind))
        out[f"pid_vff_{kind}"] = lambda kind=kind: ServoPIDController.from_params(
            vff=True, model=identified_friction(PLANT, kind))
    return out


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (position tracking, encoder-level settling band)."""
    from agents.adapters import EnvAdapter, cyl_output, cyl_pressures, cyl_stroke

    return EnvAdapter(env_id, "position", "m", _STEP_REFERENCE.get(env_id), 1e-4, cyl_output, cyl_pressures,
                      cyl_stroke)


def presliding_points():
    """The pre-sliding test of the nominal rig: ``(x, F)`` of the seals' loading branch."""
    from hydro_envs.plants.servo_cylinder.friction_test import presliding_test

    return presliding_test()


def friction_points():
    from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
    from identification.constant_velocity import friction_points_from_square_wave

    exp = run_friction_experiment(period_max=3.0)
    return friction_points_from_square_wave(exp.data), 0.0, "stribeck"  # LuGre plant: eq (1) with sign(v)
