r"""Classical controllers for ``hydro_envs/RodlessCylinder-v0`` (pneumatic rodless cylinder, seed 004).

The observation layout is the servo cylinder's (:mod:`hydro_envs.envs.cylinder_tracking`), so
the PID is :class:`agents.controllers.tracking.TrackingPID` with the rodless stroke and a tuning
from the mid-stroke linearisation of 004 eqs (19)-(24)
(:func:`hydro_envs.plants.rodless_cylinder.linearize_mid_stroke`)::

    y/U = K_q omega_n^2 / (s (s^2 + 2 zeta omega_n s + omega_n^2)),   K_q = K_T k_v (u_max - u_c)

nominal ``K_q = 0.622 m/s`` per unit action, ``omega_n = 154.5 rad/s`` (24.6 Hz),
``zeta = 0.0035`` (eq (23) with the energy correction). With so little damping a P loop is
limited to ``K_q K_p < 2 zeta omega_n = 1.1 1/s``; the derivative (velocity feedback) supplies
the damping, which lets the loop run at a fraction of omega_n:

    K_p = 0.23 omega_n / K_q      (nominal 58 1/m)
    T_d = 3 / omega_n             (19 ms)
    T_f = 2 / omega_n             (13 ms: filter below the resonance)
    T_i = 15 / omega_n            (97 ms)
    T_t = T_i

The gains are fixed on the nominal plant and must keep the loop stable without the seals' dry
friction over the whole randomisation (the moving mass spans 0.4-2 x, the supply 0.5-0.8 MPa;
a loop whose stability rests on friction is not robust): on the plant linearised without dry
friction (:mod:`agents.controllers.margins`), the nominal gain margin is 15 dB and the phase
margin 53 deg at 5.5 Hz crossover, and the gain margin stays >= 5 dB over all 64 corners of the
randomisation and at 10 % and 90 % of the stroke (``tests/test_controller_margins.py``). The
gain of before (``omega_n / (1.5 K_q)``, 3.5 x higher) was stable on only 48 of those 64 corners
without friction.

Friction feedforward (:class:`RodlessFrictionFeedforwardController`): 004 eq (27) gives the
position response to spool ``X_v`` and force ``F``:
``Y = K_T w^2/(s(...)) [X_v - F (V0/(R T kappa) s + c2) / (2 c1 A)]``, so the spool opening that
cancels a force ``F`` is ``X_v = F (c2 + V0/(R T kappa) s) / (2 c1 A)``: a static part (c2, tiny
for the closed-centre valve) and the flow that builds the pressure difference for ``F``
(``dF/dt`` term). ``F`` is the identified friction at the reference velocity (preview).

Pressure-difference loop with friction feed-forward (:class:`RodlessPressureLoopController`,
``pid_dp_stribeck`` / ``pid_dp_neural`` / ``pid_dp_rbf``: the identified Stribeck law, 002 sec. 5's
feed-forward and RBF nets). On this axis friction is carried by the air: at steady speed
``M ydot' ~ 0`` in eq (18), so ``A (p_a - p_b) = F_f`` and a friction reversal at a velocity
reversal needs the pressure difference to swing by ``2 F_f / A`` (1.2 bar for F_s = 35 N, 25 mm
bore). The chambers hold it through their compressibility (eq (16): ``V_0/(kappa p) dp`` per
chamber, about 6 mm of equivalent piston travel at mid-stroke), so the slider stands still while
the valve refills them -- the reversal error a position PID cannot avoid. The controller commands
that pressure difference directly::

    a = PID(e) + v_ref / K_q + k_dp (F^(v_ref) / A - (p_a - p_b)) / p_s,   v_ref = v_ref(t + 15 ms)

with ``F^`` the friction identified on the virtual constant-velocity test
(:mod:`agents.controllers.friction_models`), ``K_q`` the velocity gain of :func:`rodless_tuning`,
``k_dp = 0.7``, the PID's ``K_p`` raised by 1.43 and its ``T_d`` lowered to ``2 / omega_n`` (the
pressure feedback damps the air-spring mode that limits the PID's gain; gain margin >= 9.6 dB
over the randomisation's corners without dry friction; other terms as :func:`rodless_tuning`).
It is :class:`agents.controllers.tracking.PressureLoopPID` with the velocity feed-forward.
``model=None`` keeps the loop with no friction in the target (``pid_dp``: the same controller
blind to friction), and ``k_dp = 0`` leaves the PID with velocity feed-forward (``pid_vff``); the
two isolate what the friction model adds.

Stiction compensation at holds (``pid_dp_stiction``, blind twin ``pid_dp``): the same loop with
the identified law's breakaway level ``F^(0+)`` in the direction of the position error while the
reference holds, faded over :data:`HOLD_BAND` (``PressureLoopPID``'s ``hold_band``): a micro step
builds the breakaway pressure at once instead of through the integral.

Disturbance observer (:class:`RodlessObserverPressureLoopController`, ``pid_dp_dob``): the same
loop with the friction target observed on line from eq (18)'s force balance while the
reference slides, no identification run and no prior (it learns the sliding level, not the
breakaway peak at the reversals). Results against the classical controllers:
``docs/benchmarks/README.md``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.controllers.tracking import FrictionObserver, LuGreFeedforward, PressureLoopPID, TrackingPID
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.model import friction_compensation_gains, linearize_mid_stroke

__all__ = ["RodlessCalibratedPressureLoopController", "RodlessFrictionFeedforwardController",
           "RodlessObserverPressureLoopController", "RodlessPIDController", "RodlessPressureLoopController",
           "rodless_tuning"]

PREVIEW_DT = 0.01
#: gain of the pressure-difference loop [action per supply pressure of error]
K_DP = 0.7
#: position gain of the pressure-loop controller over the PID's
KP_FACTOR = 1.43
#: derivative time of the pressure-loop controller times omega_n
TD_PRESSURE_LOOP = 2.0
#: position-error band [m] over which ``pid_dp_stiction``'s breakaway target fades at a hold:
#: 10 resolutions of the 5 um ruler, a seventh of the seals' 0.35 mm pre-sliding displacement
HOLD_BAND = 5e-5


def rodless_tuning(params: RodlessCylinderParams | None = None) -> dict[str, float]:
    """The module docstring's rule (SI): ``k_q, omega_n, zeta, kp, ti, td, tf``."""
    p = params if params is not None else RodlessCylinderParams()
    lin = linearize_mid_stroke(p)
    k_q = lin.k_t * lin.k_v * (p.command_max - p.command_centre)
    w = lin.omega_n
    return {"k_q": k_q, "omega_n": w, "zeta": lin.zeta_energy, "kp": 0.23 * w / k_q, "ti": 15.0 / w,
            "td": 3.0 / w, "tf": 2.0 / w}


class RodlessPIDController(TrackingPID):
    """:class:`~agents.controllers.tracking.TrackingPID` tuned by :func:`rodless_tuning`."""

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None, *, error_scale: float = 0.01,
                    **kwargs: Any) -> RodlessPIDController:
        p = params if params is not None else RodlessCylinderParams()
        t = rodless_tuning(p)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], stroke=p.stroke, error_scale=error_scale, **kwargs)


class RodlessFrictionFeedforwardController(RodlessPIDController):
    """PID plus the eq (27) friction feedforward (module docstring). ``model``: identified
    friction ``F = model.predict(v)`` [N] (default: the Stribeck fit of
    :func:`agents.controllers.friction_models.identified_friction`)."""

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float, model: Any = None,
                 params: RodlessCylinderParams | None = None, **kwargs: Any) -> None:
        super().__init__(kp, ti, td, tf, stroke=stroke, **kwargs)
        if model is None:
            from agents.controllers.friction_models import identified_friction

            model = identified_friction("rodless_cylinder", "stribeck")
        self._f = model.predict if hasattr(model, "predict") else model
        p = params if params is not None else RodlessCylinderParams()
        static, dynamic = friction_compensation_gains(p)  # eq (27) opening over k_v [V/N, V s/N]
        span = p.command_max - p.command_centre  # volts per unit action
        self._static = static / span
        self._dynamic = dynamic / span

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None, *, error_scale: float = 0.01,
                    model: Any = None, **kwargs: Any) -> RodlessFrictionFeedforwardController:
        p = params if params is not None else RodlessCylinderParams()
        t = rodless_tuning(p)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], stroke=p.stroke, error_scale=error_scale, model=model,
                   params=p, **kwargs)

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        v0 = self.half * (obs[:, 2] - obs[:, 1]) / PREVIEW_DT
        v1 = self.half * (obs[:, 3] - obs[:, 2]) / PREVIEW_DT
        f0 = np.asarray(self._f(v0), dtype=float)
        f1 = np.asarray(self._f(v1), dtype=float)
        return self._static * f0 + self._dynamic * (f1 - f0) / PREVIEW_DT


class RodlessPressureLoopController(PressureLoopPID):
    """PID + velocity feed-forward + pressure-difference loop with a friction target (module
    docstring): :class:`~agents.controllers.tracking.PressureLoopPID` with ``vff = True``.
    ``model``: identified friction ``F = model.predict(v)`` [N] or ``None`` (no friction in the
    target); ``k_dp``: loop gain (0: PID + velocity feed-forward only)."""

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, stroke: float, k_q: float,
                 area: float, supply_pressure: float, model: Any = None, k_dp: float = K_DP,
                 **kwargs: Any) -> None:
        super().__init__(kp, ti, td, tf, stroke=stroke, k_q=k_q, area=area, supply_pressure=supply_pressure,
                         k_dp=k_dp, vff=True, model=model, preview=1, **kwargs)

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None, *, error_scale: float = 0.01,
                    model: Any = None, k_dp: float = K_DP, kp_factor: float = KP_FACTOR,
                    **kwargs: Any) -> RodlessPressureLoopController:
        from hydro_envs.plants.rodless_cylinder.model import piston_area

        p = params if params is not None else RodlessCylinderParams()
        t = rodless_tuning(p)
        td = TD_PRESSURE_LOOP / t["omega_n"] if k_dp > 0.0 else t["td"]
        factor = kp_factor if k_dp > 0.0 else 1.0
        return cls(factor * t["kp"], t["ti"], td, t["tf"], stroke=p.stroke, error_scale=error_scale,
                   k_q=t["k_q"], area=piston_area(p), supply_pressure=p.supply_pressure, model=model,
                   k_dp=k_dp, **kwargs)

    def _preview_velocity(self, j: int, obs: np.ndarray) -> np.ndarray:
        """Reference velocity [m/s] between previews ``j`` and ``j + 1`` (10 ms apart)."""
        return self.preview_velocity(j, obs)


class RodlessCalibratedPressureLoopController(RodlessPressureLoopController):
    """:class:`RodlessPressureLoopController` whose friction model is identified on each plant
    draw it controls: :meth:`calibrate` (called by the benchmark with the parameter set of every
    copy) runs the virtual constant-command test on each and fits ``kind``
    (:func:`agents.controllers.friction_models.identify_on_draws`); before that it uses the
    model identified on the nominal plant."""

    def __init__(self, *args: Any, kind: str = "stribeck", **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.kind = kind

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None, *, kind: str = "stribeck",
                    **kwargs: Any) -> RodlessCalibratedPressureLoopController:
        from agents.controllers.friction_models import identified_friction

        ctrl = super().from_params(params, model=identified_friction(PLANT, kind), **kwargs)
        ctrl.kind = kind
        return ctrl

    def calibrate(self, params: list[RodlessCylinderParams]) -> None:
        """Identify one friction model per copy on ``params`` (one parameter set per copy)."""
        from agents.controllers.friction_models import identify_on_draws

        self._f = identify_on_draws(PLANT, list(params), self.kind).predict



class RodlessObserverPressureLoopController(FrictionObserver, RodlessPressureLoopController):
    """:class:`RodlessPressureLoopController` whose friction target comes from the disturbance
    observer :class:`~agents.controllers.tracking.FrictionObserver` on the force balance of
    eq (18) instead of an identification run (``M`` the nominal moving mass)."""

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None,
                    **kwargs: Any) -> RodlessObserverPressureLoopController:
        p = params if params is not None else RodlessCylinderParams()
        return super().from_params(p, mass=p.mass, **kwargs)


class RodlessLuGrePressureLoopController(LuGreFeedforward, RodlessPressureLoopController):
    """``pid_dp_lugre``: :class:`RodlessPressureLoopController` with a LuGre friction target
    (:class:`~agents.controllers.tracking.LuGreFeedforward`) identified on the rig: its steady state
    the Stribeck law of the 004 sec. 3 constant-command test, its bristle stiffness from the
    pre-sliding test (:func:`~hydro_envs.plants.rodless_cylinder.experiments.presliding_test`), its
    micro-damping critical for the nominal mass. Blind twin: ``pid_dp``."""

    @classmethod
    def from_params(cls, params: RodlessCylinderParams | None = None,
                    **kwargs: Any) -> RodlessLuGrePressureLoopController:
        from agents.controllers.friction_models import identified_friction, identified_presliding

        p = params if params is not None else RodlessCylinderParams()
        sigma0, _ = identified_presliding(PLANT)
        return super().from_params(p, stribeck=identified_friction(PLANT, "stribeck"), sigma0=sigma0,
                                   sigma1=2.0 * np.sqrt(sigma0 * p.mass), **kwargs)


#: the plant these controllers are for (its registry name)
PLANT = "rodless_cylinder"

# ------------------------------------------------------------------ registry hooks
_STEP_REFERENCE = {
    "hydro_envs/RodlessCylinder-v0": "steps",
    "hydro_envs/RodlessCylinderSlowSine-v0": None,
    "hydro_envs/RodlessCylinderMicroPosition-v0": "micro_steps",
}


def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory."""
    from agents.controllers.core import ZeroController
    from agents.controllers.friction_models import identified_friction

    return {
        "zero": lambda: ZeroController(1),
        "pid": RodlessPIDController.from_params,
        "pid_ff_stribeck": lambda: RodlessFrictionFeedforwardController.from_params(
            model=identified_friction(PLANT, "stribeck")),
        "pid_ff_neural": lambda: RodlessFrictionFeedforwardController.from_params(
            model=identified_friction(PLANT, "neural")),
        "pid_vff": lambda: RodlessPressureLoopController.from_params(k_dp=0.0),
        "pid_dp": RodlessPressureLoopController.from_params,
        "pid_dp_stribeck": lambda: RodlessPressureLoopController.from_params(
            model=identified_friction(PLANT, "stribeck")),
        "pid_dp_neural": lambda: RodlessPressureLoopController.from_params(
            model=identified_friction(PLANT, "neural")),
        "pid_dp_rbf": lambda: RodlessPressureLoopController.from_params(
            model=identified_friction(PLANT, "rbf")),
        "pid_dp_stribeck_cal": RodlessCalibratedPressureLoopController.from_params,
        "pid_dp_dob": RodlessObserverPressureLoopController.from_params,
        "pid_dp_lugre": RodlessLuGrePressureLoopController.from_params,
        "pid_dp_stiction": lambda: RodlessPressureLoopController.from_params(
            model=identified_friction(PLANT, "stribeck"), hold_band=HOLD_BAND),
    }


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (position tracking)."""
    from agents.adapters import EnvAdapter, cyl_output, cyl_pressures, cyl_stroke

    return EnvAdapter(env_id, "position", "m", _STEP_REFERENCE.get(env_id), 2e-4, cyl_output, cyl_pressures,
                      cyl_stroke)


def presliding_points():
    """The pre-sliding test of the nominal rig: ``(x, F)`` of the seals' loading branch."""
    from hydro_envs.plants.rodless_cylinder.experiments import presliding_test

    return presliding_test()


def friction_points(params: RodlessCylinderParams | None = None):
    """004 sec. 3 constant-command runs on ``params`` (default nominal): ``((v, F), 0, "stribeck")``."""
    from hydro_envs.plants.rodless_cylinder.experiments import constant_command_run

    p = params if params is not None else RodlessCylinderParams()
    du = np.geomspace(0.03, 2.5, 24)
    vs, fs = [], []
    for c in np.concatenate([p.command_centre + du, p.command_centre - du]):
        v, f, _ = constant_command_run(p, float(c), max_time=10.0)
        if np.isfinite(v):
            vs.append(v)
            fs.append(f)
    return (np.array(vs), np.array(fs)), 0.0, "stribeck"
