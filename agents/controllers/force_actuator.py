r"""PID force controller for ``hydro_envs/ForceActuator-v0`` (jet-pipe force actuator, seed 001).

Observation (:mod:`hydro_envs.envs.force_actuator`): ``obs[0] = F_s/F_max``, ``obs[1] = r/F_max``,
``obs[2..6]`` preview at +1, +2, +5, +10, +25 steps, ``obs[7]`` last action; ``F_max = A_1 p_s``
(1340 N); action = valve current / ``current_max`` (45 mA).

Tuning rule: Tyreus-Luyben from the ultimate gain and period of the proportional loop
``i = K_f (r - F_s)/F_max i_rated`` on the plant's linearisation **without dry friction**
(:meth:`hydro_envs.spec.PlantSpec.without_dry_friction`, :mod:`agents.controllers.margins`):
the nominal plant at rest, sampled at 5 kHz with the env's zero-order hold, its feedback
conditioning filter and its one-period computation delay. There the proportional loop's gain
margin is 10.9 dB at 97.6 Hz: ``K_u = 3.51``, ``P_u = 10.24 ms`` (001 sec. 4.7 observes the
limit cycle from ``K_f = 3.66`` at ~95 Hz). The seals' pre-sliding spring (``sigma0`` beside
``k_s``, 001 eq (1)) raises the ultimate gain to 4.46 with friction; the loop must not need it.
The Tyreus-Luyben rules (the robust variant of Ziegler-Nichols for lightly damped loops)::

    K_f = K_u / 2.2 = 1.60,   T_i = 2.2 P_u = 22.5 ms,   T_d = P_u / 6.3 = 1.63 ms,
    T_f = T_d / 5 = 0.33 ms (derivative filter), T_t = T_i

in action units ``K_p = K_f i_rated / i_max / F_max`` per newton (the PID acts on the error in
newtons, the derivative on the sensed force). Margins on the linearisation without dry friction
(tests/test_controller_margins.py): nominal 4.7 dB / 79 deg (crossover 48 Hz), >= 4.1 dB over
the randomisation's corners. The former gains (``K_f = 2.82`` from ``K_u = 6.2``, ``P_u =
5 ms``, the limit-cycle onset without the controller's lag) kept 2.2 dB / 28 deg without dry
friction (1.7 dB at the worst corner) and 4.3 dB with the seals' pre-sliding spring: part of
their margin was the friction's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.controllers.core import BaseController, PIDCore
from hydro_envs.plants.force_actuator.params import ForceActuatorParams

__all__ = ["K_ULTIMATE", "P_ULTIMATE", "ForcePIDController", "force_tuning"]

DT = 2e-4
K_ULTIMATE = 3.51  # ultimate gain K_f of the proportional loop without dry friction (module docstring)
P_ULTIMATE = 10.24e-3  # s, its period (97.6 Hz)


def force_tuning(params: ForceActuatorParams | None = None, k_u: float = K_ULTIMATE,
                 p_u: float = P_ULTIMATE) -> dict[str, float]:
    """Tyreus-Luyben PID from the ultimate gain/period of the loop without dry friction (module
    docstring), SI / action per N."""
    p = params if params is not None else ForceActuatorParams()
    kf = k_u / 2.2
    f_max = p.max_thrust
    td = p_u / 6.3
    return {"kf": kf, "kp": kf * p.rated_current / p.current_max / f_max, "ti": 2.2 * p_u, "td": td,
            "tf": td / 5.0, "f_max": f_max}


class ForcePIDController(BaseController):
    """PID on the force error, filtered derivative on the sensed force, back-calculation
    anti-windup (:class:`PIDCore`)."""

    obs_dim = 8
    action_dim = 1

    def __init__(self, kp: float, ti: float, td: float, tf: float, *, f_max: float, dt: float = DT,
                 anti_windup: str = "back_calculation") -> None:
        super().__init__()
        self.pid = PIDCore(kp, ti, td, tf, dt, anti_windup=anti_windup)
        self.f_max = float(f_max)
        self.reset()

    @classmethod
    def from_params(cls, params: ForceActuatorParams | None = None, **kw: Any) -> ForcePIDController:
        p = params if params is not None else ForceActuatorParams()
        t = force_tuning(p)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], f_max=p.max_thrust, **kw)

    def _allocate(self, n: int) -> None:
        self.pid.allocate(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.pid.reset_rows(mask)

    def _act(self, o: np.ndarray) -> np.ndarray:
        f = o[:, 0] * self.f_max
        e = o[:, 1] * self.f_max - f
        return self.pid.step(e, f)[:, None]


#: the plant these controllers are for (its registry name)
PLANT = "force_actuator"

# ------------------------------------------------------------------ registry hooks
def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory."""
    from agents.controllers.core import ZeroController

    from agents.controllers.force_friction import controllers as friction_controllers

    return {"zero": lambda: ZeroController(1), "pid": ForcePIDController.from_params, **friction_controllers()}


def _force_output(b):
    from agents.adapters import ref_now
    from hydro_envs.plants.force_actuator import model as fa

    return b.P[:, fa.I_KS] * b.Y[:, fa.XS], ref_now(b)


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (true force k_s x_s; the 001 square references;
    the small-force task: its own reference, a 1 N settling floor)."""
    from agents.adapters import EnvAdapter

    if env_id == "hydro_envs/ForceActuatorSmallForce-v0":
        return EnvAdapter(env_id, "force", "N", None, 1.0, _force_output, None, None,
                          note="small-force task: free piston against the environment spring; no chamber "
                               "pressures in the state: pressure/end-stop columns n/a")
    return EnvAdapter(env_id, "force", "N", "square", 5.0, _force_output, None, None,
                      note="steps = the 001 square references (50/200/800 N); piston locked and no chamber "
                           "pressures in the state: pressure/end-stop columns n/a")
