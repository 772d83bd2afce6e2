r"""Classical controllers for ``hydro_envs/DifferentialCylinderPosition-v0`` and its friction tasks.

The servo plant's loop (:mod:`agents.controllers.servo_cylinder`) adapted to a single-rod
cylinder: the position PID with a load-pressure loop, where the load pressure is the force over
the piston area, ``p_L = p1 - alpha p2`` (``alpha = A2/A1``), and the practitioner's area-ratio
compensation of the asymmetric velocity gain.

Tuning rule (nominal plant linearised without dry friction)
-----------------------------------------------------------
Below its hydraulic resonance the axis is an integrator ``x/a = K_q / s``, ``K_q`` the no-load
speed at full opening (:func:`~hydro_envs.plants.differential_cylinder.model.no_load_velocity`:
0.400 m/s extending, 0.328 m/s retracting for the 63/36 rig), in series with the oil-spring
resonance whose minimum over the stroke is ``omega_h`` (:func:`minimum_natural_frequency`,
nominal 904 rad/s). As for the servo plant::

    a = PID(e) - k_dp (p1 - alpha p2) / p_s   (+ feed-forward)
    k_dp = 0.12,  omega_c = 0.03 omega_h,  K_p = omega_c / K_q,  T_i = 4 / omega_c,
    T_d = 0.1 / omega_c,  T_f = 1 / (0.2 omega_h)

(the P loop: ``K_p = 0.0277 omega_h / K_q``, 25 1/s on the example rig, ``k_dp = 0.06``).
A rig from a parameter file (``controllers(params)``, ``hydro benchmark --params FILE``) is
tuned by the same rule on its own ``K_q`` and ``omega_h``; check its margins with
:mod:`agents.controllers.differential_cylinder_tuning` where its valve is not clearly faster
than its oil spring (the rule assumes it is). On the plant linearised without dry friction,
sampled at 1 ms, at the minimum-frequency position, mid-stroke and 90 % stroke over the
randomisation's corners (``tests/test_differential_cylinder.py``): the PID's gain margin is at
least 13.2 dB (11.5 dB with the area-ratio compensation's retracting gain), the P loop's 22 dB.

Area-ratio compensation (``_arc``): with a symmetric valve the no-load velocity gain of the
retracting stroke is ``sqrt(alpha)`` times the extending one (the orifice law with the force
balance, :func:`~hydro_envs.plants.differential_cylinder.model.speed_ratio`), so a negative
command is scaled up by the ratio ``K_ext / K_ret = 1 / sqrt(alpha)`` (1.22 here): the loop gain
and the velocity feed-forward ``v_ref / K_ext`` are then the same in both directions -- the
electronic equivalent of a valve with a matched asymmetric spool. (A rule of thumb scales by
``alpha`` itself, the flow ratio; for a symmetric valve's pressure split the speed ratio is
``1/sqrt(alpha)``.)

Names: ``p``, ``pid`` (no feed-forward), ``pid_vff`` (velocity feed-forward), ``pid_vff_arc``
(with area-ratio compensation) and the friction-aware ``pid_vff_arc_stribeck``: the same with the
friction feed-forward of the rig's nominal Stribeck law (a model-based controller, not an
identified one); its blind twin is ``pid_vff_arc``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.tracking import PressureLoopPID
from hydro_envs.plants.differential_cylinder.model import minimum_natural_frequency, no_load_velocity, speed_ratio
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams

__all__ = ["K_DP", "CROSSOVER_RATIO", "P_CROSSOVER_RATIO", "P_K_DP", "pid_tuning", "DifferentialPID", "stribeck_law", "controllers",
           "benchmark_adapter"]

#: gain of the load-pressure loop [action per supply pressure]
K_DP = 0.12
#: loop crossover over the smallest hydraulic natural frequency
CROSSOVER_RATIO = 0.03
#: bandwidth of the P loop over the smallest hydraulic natural frequency (25 1/s on the example
#: rig's 904 rad/s) and its load-pressure gain: without the PID's derivative the pressure loop
#: takes less gain (on the plant linearised without dry friction over the randomisation's
#: corners, k_dp = 0.12 leaves 3.9 dB of gain margin, 0.06 leaves 22 dB; tests)
P_CROSSOVER_RATIO = 0.02765
P_K_DP = 0.06


def pid_tuning(params: DifferentialCylinderParams, crossover_ratio: float = CROSSOVER_RATIO) -> dict[str, float]:
    """The module docstring's rule: ``k_q, omega_h, omega_c, kp, ti, td, tf, k_dp`` (SI)."""
    if not (math.isfinite(crossover_ratio) and crossover_ratio > 0):
        raise ValueError(f"crossover_ratio must be > 0, got {crossover_ratio}")
    k_q = no_load_velocity(params, 1)
    omega_h = minimum_natural_frequency(params)
    omega_c = crossover_ratio * omega_h
    return {"k_q": k_q, "omega_h": omega_h, "omega_c": omega_c, "kp": omega_c / k_q, "ti": 4.0 / omega_c,
            "td": 0.1 / omega_c, "tf": 1.0 / (0.2 * omega_h), "k_dp": K_DP}


def stribeck_law(params: DifferentialCylinderParams):
    """The rig's nominal steady-state friction ``F(v) = sgn(v) (F_C + (F_S - F_C) exp(-|v|/v_S)) + d v``
    [N], the steady state of its LuGre seals."""
    p = params

    def law(v: Any) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        g = p.coulomb_friction + (p.static_friction - p.coulomb_friction) * np.exp(-np.abs(v) / p.stribeck_velocity)
        return np.sign(v) * g + p.viscous_friction * v

    return law


class DifferentialPID(PressureLoopPID):
    """:class:`~agents.controllers.tracking.PressureLoopPID` on the load pressure ``p1 - alpha p2``
    with optional area-ratio compensation (``arc``: negative commands times ``K_ext / K_ret``)."""

    def __init__(self, *args: Any, alpha: float, retract_scale: float = 1.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if not (0.0 < alpha < 1.0 and retract_scale >= 1.0):
            raise ValueError(f"need 0 < alpha < 1 and retract_scale >= 1, got {alpha}, {retract_scale}")
        self.alpha, self.retract_scale = float(alpha), float(retract_scale)

    @classmethod
    def from_params(cls, params: DifferentialCylinderParams | None = None, *, arc: bool = False, vff: bool = False,
                    model: Any = None, integral: bool = True, error_scale: float = 0.01,
                    **kwargs: Any) -> DifferentialPID:
        p = params if params is not None else DifferentialCylinderParams()
        t = pid_tuning(p)
        ti, td = (t["ti"], t["td"]) if integral else (math.inf, 0.0)
        kp = t["kp"] if integral else P_CROSSOVER_RATIO * t["omega_h"] / t["k_q"]
        k_dp = t["k_dp"] if integral else P_K_DP
        return cls(kp, ti, td, t["tf"], stroke=p.stroke, error_scale=error_scale, k_q=t["k_q"], area=p.piston_area,
                   supply_pressure=p.supply_pressure, k_dp=k_dp, vff=vff, model=model, alpha=p.area_ratio,
                   retract_scale=speed_ratio(p) if arc else 1.0, **kwargs)

    def feedforward(self, obs: np.ndarray) -> np.ndarray:
        v = self.preview_velocity(self.preview, obs)
        out = v / self.k_q if self.vff else np.zeros(obs.shape[0])
        p_load = (obs[:, 8] - self.alpha * obs[:, 9]) * self.ps  # force / A1
        target = self.friction_scale * np.asarray(self.friction_target(v, p_load, obs), dtype=float)
        return out + self.k_dp * (target / self.area - p_load) / self.ps

    def _act(self, obs: np.ndarray) -> np.ndarray:
        a = super()._act(obs)
        if self.retract_scale == 1.0:
            return a
        return np.clip(np.where(a < 0.0, self.retract_scale * a, a), -1.0, 1.0)


#: the plant these controllers are for (its registry name)
PLANT = "differential_cylinder"
_STEP_REFERENCE = {
    "hydro_envs/DifferentialCylinderPosition-v0": "steps",
    "hydro_envs/DifferentialCylinderSlowSine-v0": None,
    "hydro_envs/DifferentialCylinderMicroPosition-v0": "micro_steps",
}


def controllers(params: DifferentialCylinderParams | None = None) -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory (module docstring),
    tuned by the docstring's rule on ``params`` (default: the example rig) -- a rig from a
    parameter file (``hydro benchmark --params FILE``) gets its own gains and friction model."""
    from agents.controllers.core import ZeroController

    nominal = params if params is not None else DifferentialCylinderParams()
    if not isinstance(nominal, DifferentialCylinderParams):
        raise TypeError(f"params must be DifferentialCylinderParams, got {type(nominal).__name__}")
    return {
        "zero": lambda: ZeroController(1),
        "p": lambda: DifferentialPID.from_params(nominal, integral=False),
        "pid": lambda: DifferentialPID.from_params(nominal),
        "pid_vff": lambda: DifferentialPID.from_params(nominal, vff=True),
        "pid_vff_arc": lambda: DifferentialPID.from_params(nominal, vff=True, arc=True),
        "pid_vff_arc_stribeck": lambda: DifferentialPID.from_params(nominal, vff=True, arc=True,
                                                                    model=stribeck_law(nominal)),
    }


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (position tracking, a 0.1 mm settling band)."""
    from agents.adapters import EnvAdapter, cyl_output, cyl_pressures, cyl_stroke

    return EnvAdapter(env_id, "position", "m", _STEP_REFERENCE.get(env_id), 1e-4, cyl_output, cyl_pressures,
                      cyl_stroke)
