r"""Controllers for ``hydro_envs/LoadSensing-v0`` (load-sensing pump + seed-000 flow compensator).

Observation (:mod:`hydro_envs.envs.load_sensing`): ``obs[0] = v_d/V``, ``obs[3] = v_meas/V``,
``obs[4] = (v_d - v_meas)/V`` with ``V = 0.2 m/s``, ``obs[7]`` = CV drop minus the nominal
margin over the margin. Action ``a[0]``: solenoid force on the compensator spool (fraction of
+-20 N); ``a[1]``: CV correction (``0.5 a[1] cv_area_max`` added to the operator's lever).

* :class:`PassiveCompensatorBaseline`: action (0, 0) -- the hydro-mechanical compensator of
  000 alone with the CV set from the demand (the env's documented classical baseline).
* :class:`LoadSensingPIDController`: the passive compensator plus a PID on the velocity error
  acting on the CV correction ``a[1]`` (``a[0] = 0``: the margin stays with the compensator).
  Linearisation: at the nominal margin ``dp_m = 20 bar`` the CV flow gain gives the velocity
  gain per unit ``a[1]``::

      K_cv = 0.5 A_max C_d sqrt(2 dp_m / rho) / A_c       (nominal 0.114 m/s)

  and the load is a 1 t mass on an oil spring ``beta A_c^2 / V_line`` (omega_L = 153 rad/s,
  lightly damped; the pump compensator adds its own 10-30 ms lag). What a CV correction can do
  is damp that load mode: the useful part of this PID is its filtered derivative (acceleration
  feedback into the CV opening); P and I only trim slow offsets (the lever is set on the
  *nominal* margin and load, the truth is randomised)::

      K_cv K_p T_d = 0.7 ms    (derivative time of the velocity loop; T_f = 1 ms, one sample)
      K_cv K_p     = 0.005     (T_d = 0.14 s)
      omega_c      = 0.3 1/s   (K_i = omega_c / K_cv, T_i = K_p / K_i = 16.7 ms), T_t = T_i

  Measured on the nominal plant (8 episodes each of ``steps`` / ``ramps``, RMSE in mm/s):
  passive 11.47 / 4.61, this PID 10.58 / 4.91 -- better on demand steps (less ringing), worse
  on ramps. Larger gains were worse on both: K_cv K_p = 0.2 without D gave 27 / 17; doubling
  the derivative (1.3 ms) gave 11.0 / 5.9.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.core import BaseController, PIDCore
from hydro_envs.plants.load_sensing import model as plant
from hydro_envs.plants.load_sensing.params import LoadSensingParams

__all__ = ["LoadSensingPIDController", "PassiveCompensatorBaseline", "ls_tuning"]

DT = 1e-3
V_SCALE = 0.2
OMEGA_C = 0.3
KP_STATIC = 0.005  # K_cv K_p
TD_VELOCITY = 0.7e-3  # s, K_cv K_p T_d
TF = 1e-3  # s


def ls_tuning(params: LoadSensingParams | None = None, omega_c: float = OMEGA_C) -> dict[str, float]:
    p = params if params is not None else LoadSensingParams()
    dpm = plant.margin(p)
    k_cv = 0.5 * p.cv_area_max * p.discharge_coefficient * math.sqrt(2.0 * dpm / p.oil_density) / p.piston_area
    kp = KP_STATIC / k_cv
    ki = omega_c / k_cv
    return {"k_cv": k_cv, "kp": kp, "ti": kp / ki, "td": TD_VELOCITY / KP_STATIC, "tf": TF}


class PassiveCompensatorBaseline(BaseController):
    """Action (0, 0): the hydro-mechanical flow compensator alone (stateless)."""

    obs_dim = 12
    action_dim = 2

    def _act(self, o: np.ndarray) -> np.ndarray:
        return np.zeros((o.shape[0], 2))


class LoadSensingPIDController(BaseController):
    """PID on the velocity error (derivative on the measured velocity) into the CV correction
    (module docstring); ``a[0] = 0``."""

    obs_dim = 12
    action_dim = 2

    def __init__(self, kp: float, ti: float, td: float = 0.0, tf: float = 0.0, *, dt: float = DT,
                 anti_windup: str = "back_calculation") -> None:
        super().__init__()
        self.pid = PIDCore(kp, ti, td, tf, dt, anti_windup=anti_windup)
        self.reset()

    @classmethod
    def from_params(cls, params: LoadSensingParams | None = None, **kw: Any) -> LoadSensingPIDController:
        t = ls_tuning(params)
        return cls(t["kp"], t["ti"], t["td"], t["tf"], **kw)

    def _allocate(self, n: int) -> None:
        self.pid.allocate(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.pid.reset_rows(mask)

    def _act(self, o: np.ndarray) -> np.ndarray:
        e = o[:, 4] * V_SCALE
        v = o[:, 3] * V_SCALE
        a1 = self.pid.step(e, v)
        return np.stack([np.zeros_like(a1), a1], axis=1)


#: the plant these controllers are for (its registry name)
PLANT = "load_sensing"

# ------------------------------------------------------------------ registry hooks
def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory."""
    return {"passive": PassiveCompensatorBaseline, "zero": PassiveCompensatorBaseline,
            "pid": LoadSensingPIDController.from_params}


def _ls_output(b):
    from agents.adapters import ref_now
    from hydro_envs.plants.load_sensing import model as ls

    return b.Y[:, ls.VA].copy(), ref_now(b)


def _ls_pressures(b):
    from hydro_envs.plants.load_sensing import model as ls

    names = b.params_cls.names()
    floor = b.P[:, names.index("pressure_floor")]
    relief = b.P[:, names.index("relief_pressure")]
    return b.Y[:, [ls.PS, ls.PL]], floor, relief


def _ls_stroke(b):
    from hydro_envs.plants.load_sensing import model as ls

    names = b.params_cls.names()
    x = b.Y[:, ls.XA]
    return (x < 0.0) | (x > b.P[:, names.index("stroke")])


def benchmark_adapter(env_id: str):
    """What the benchmark reads of ``env_id`` (actuator velocity; pressures within the relief)."""
    from agents.adapters import EnvAdapter

    return EnvAdapter(env_id, "velocity", "m/s", "steps", 2e-3, _ls_output, _ls_pressures, _ls_stroke,
                      note="pressure limits: pump and load pressure within [floor, relief]")
