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

    K_p = omega_n / (1.5 K_q)     (nominal 166 1/m)
    T_d = 3 / omega_n             (19 ms)
    T_f = 2 / omega_n             (13 ms: filter below the resonance)
    T_i = 15 / omega_n            (97 ms; measured on the nominal plant, smooth/sine references:
                                   T_i = 0.1 s lowered the RMSE by 8-19 % against no integral)
    T_t = T_i

Friction feedforward (:class:`RodlessFrictionFeedforwardController`): 004 eq (27) gives the
position response to spool ``X_v`` and force ``F``:
``Y = K_T w^2/(s(...)) [X_v - F (V0/(R T kappa) s + c2) / (2 c1 A)]``, so the spool opening that
cancels a force ``F`` is ``X_v = F (c2 + V0/(R T kappa) s) / (2 c1 A)``: a static part (c2, tiny
for the closed-centre valve) and the flow that builds the pressure difference for ``F``
(``dF/dt`` term). ``F`` is the identified friction at the reference velocity (preview).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.controllers.tracking import TrackingPID
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.model import linearize_mid_stroke

__all__ = ["RodlessFrictionFeedforwardController", "RodlessPIDController", "rodless_tuning"]

PREVIEW_DT = 0.01


def rodless_tuning(params: RodlessCylinderParams | None = None) -> dict[str, float]:
    """The module docstring's rule (SI): ``k_q, omega_n, zeta, kp, ti, td, tf``."""
    p = params if params is not None else RodlessCylinderParams()
    lin = linearize_mid_stroke(p)
    k_q = lin.k_t * lin.k_v * (p.command_max - p.command_centre)
    w = lin.omega_n
    return {"k_q": k_q, "omega_n": w, "zeta": lin.zeta_energy, "kp": w / (1.5 * k_q), "ti": 15.0 / w,
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
        lin = linearize_mid_stroke(p)
        span = lin.k_v * (p.command_max - p.command_centre)  # spool travel per unit action [m]
        self._static = lin.c2 / (2.0 * lin.c1 * lin.area) / span
        self._dynamic = lin.v0 / (lin.rt * lin.kappa) / (2.0 * lin.c1 * lin.area) / span

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
    }


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (position tracking)."""
    from agents.adapters import EnvAdapter, cyl_output, cyl_pressures, cyl_stroke

    return EnvAdapter(env_id, "position", "m", _STEP_REFERENCE.get(env_id), 2e-4, cyl_output, cyl_pressures,
                      cyl_stroke)


def friction_points():
    from hydro_envs.plants.rodless_cylinder import model as rc

    from hydro_envs.plants.rodless_cylinder.experiments import constant_command_run

    p = rc.RodlessCylinderParams()
    du = np.geomspace(0.03, 2.5, 24)
    vs, fs = [], []
    for c in np.concatenate([p.command_centre + du, p.command_centre - du]):
        v, f, _ = constant_command_run(p, float(c), max_time=10.0)
        if np.isfinite(v):
            vs.append(v)
            fs.append(f)
    return (np.array(vs), np.array(fs)), 0.0, "stribeck"
