r"""PID force controller for ``hydro_envs/ForceActuator-v0`` (jet-pipe force actuator, seed 001).

Observation (:mod:`hydro_envs.envs.force_actuator`): ``obs[0] = F_s/F_max``, ``obs[1] = r/F_max``,
``obs[2..6]`` preview at +1, +2, +5, +10, +25 steps, ``obs[7]`` last action; ``F_max = A_1 p_s``
(1340 N); action = valve current / ``current_max`` (45 mA).

Tuning rule: Ziegler-Nichols from an ultimate gain and period. 001 closes a proportional
loop ``i = K_f (r - F_s)/F_max i_rated``; the fixed constants ``K_u = 6.2`` and ``P_u = 5.0
ms`` (200 Hz) are of the order of that loop's limit-cycle onset without the controller's own
lag (feedback filter and computation delay off: ``K_f = 6.4`` at 200 Hz on the nominal plant,
:func:`hydro_envs.plants.force_actuator.closed_loop.limit_cycle_sweep`). The env's nominal
plant has that lag: its proportional limit cycle starts at ``K_f = 3.9`` (95 Hz), so the PID's
``K_f = 2.82`` keeps a gain margin of 1.4 against it (tested). The
ultimate-gain rules of Tyreus-Luyben (the robust variant of Ziegler-Nichols for lightly damped
loops) give the PID::

    K_f = K_u / 2.2 = 2.82,   T_i = 2.2 P_u = 11 ms,   T_d = P_u / 6.3 = 0.79 ms,
    T_f = T_d / 5 = 0.16 ms (derivative filter, below the 2.6 kHz sensor mode of eq (4)),
    T_t = T_i

and in action units ``K_p = K_f i_rated / i_max / F_max`` per newton (the PID acts on the
error in newtons, the derivative on the sensed force). Measured on the nominal plant (6
episodes, seeds 0-5, of 0.5 s per reference kind; RMSE of the true force ``k_s x_s`` against
the reference): mean 203.7 N against 216.8 N for the Tyreus-Luyben PI (``K_u/3.2``, no D);
the derivative helps on chirps (120 vs 182 N), not on squares (382 vs 378 N) or sines (161 vs
153 N).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.controllers.core import BaseController, PIDCore
from hydro_envs.plants.force_actuator.params import ForceActuatorParams

__all__ = ["K_ULTIMATE", "P_ULTIMATE", "ForcePIDController", "force_tuning"]

DT = 2e-4
K_ULTIMATE = 6.2  # order of the limit-cycle onset without loop lag (module docstring)
P_ULTIMATE = 1.0 / 200.0  # s, its period (200 Hz)


def force_tuning(params: ForceActuatorParams | None = None, k_u: float = K_ULTIMATE,
                 p_u: float = P_ULTIMATE) -> dict[str, float]:
    """Tyreus-Luyben PID from the ultimate gain/period (module docstring), SI / action per N."""
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

    return {"zero": lambda: ZeroController(1), "pid": ForcePIDController.from_params}


def _force_output(b):
    from agents.adapters import ref_now
    from hydro_envs.plants.force_actuator import model as fa

    return b.P[:, fa.I_KS] * b.Y[:, fa.XS], ref_now(b)


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (true force k_s x_s; the 001 square references)."""
    from agents.adapters import EnvAdapter

    return EnvAdapter(env_id, "force", "N", "square", 5.0, _force_output, None, None,
                      note="steps = the 001 square references (50/200/800 N); piston locked and no chamber "
                           "pressures in the state: pressure/end-stop columns n/a")
