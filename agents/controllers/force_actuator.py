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

Friction-aware controllers (the small-force task)
-------------------------------------------------

Friction-aware force controllers of the seed-001 actuator: the force PID with a seal-friction
feed-forward identified on the plant's virtual friction test (001 sec. 4.3, Table 2).

Why a feed-forward pays (the small-force task, :mod:`hydro_envs.envs.friction_tasks`): on the free
piston the sensed force is the valve's fluid force less the seals' friction and eq (5)'s damping
(001 eq (2), quasi-static ``F_s = F - F_d - F_f``). Every reversal of the force rate reverses the
piston and swings the friction by up to twice its static level; the PID, blind to it, has to
wind that swing up through its integrator while the piston sticks. The feed-forward adds the
friction the reference's motion will meet to the valve command, ahead of the loop.

Identification (:func:`identify_seal_friction`), on the nominal plant's virtual rig
(:func:`hydro_envs.plants.force_actuator.experiments.breakaway_test`, a push and a pull ramped at
5 N/s on the free piston, a virtual friction cell between piston and cylinder):

* static level ``g0`` and bristle stiffness ``sigma0`` per direction from the loading branch:
  for 001 eq (1) (the family's n = 2 at a constant level) ``F = g0 sigma0 x / (g0 + sigma0 x)``,
  i.e. ``1/F = 1/(sigma0 x) + 1/g0``, a straight line in ``1/x`` fitted below 60 % of the peak;
* Coulomb level ``F_c``: the friction while sliding at the end of the test (tens of mm/s);
* Stribeck velocity ``v_s``: least squares of ``F_c + (g0 - F_c) exp(-(v/v_s)^2)`` on the
  sliding part after the peak (a grid over 0.5-50 mm/s).

Feed-forward: the piston's velocity is what the reference's force rate asks of the environment
spring and the sensor, ``v_r = r' (1/k_env + 1/k_s)`` (``k_env`` the task rig's spring,
:data:`hydro_envs.envs.force_actuator.SMALL_FORCE_RIG`, 0 on the locked rig; ``r'`` from the
reference preview ``(r_{+25} - r_{+10}) / (15 dt)``, 3.5 ms ahead: the valve's 19 Hz stage
lags). Two friction models (the blind twin of both is ``pid``, the same PID without one):

* ``pid_dahl``: the Dahl model of 001 eq (1) (the seal-friction family, n = 2,
  :func:`hydro_envs.laws.seal_friction.seal_friction`) with the identified levels, driven by
  ``v_r``: ``F_ff = sigma0 z``, so the feed-forward also rises through pre-sliding as the seals do;
* ``pid_stribeck``: the static curve ``g(v_r) tanh(v_r / v_eps)``, ``v_eps = 0.5 v_s`` (0.1 and
  2 v_s: 0.83 and 0.93 x PID on the in draws, 0.5: 0.77); without the bristles it asks for the
  full static level right at a reversal, before the seals have taken up their pre-sliding.

``F_ff`` [N] enters the command through the valve's small-signal gain at null, ``G = dF~/dxi x
x_v / i x i_max`` [N per action unit] (sec. 3.1's orifice law at the valve offset, eq (7)'s DC
gain, the hysteresis reversal slope: 58 N/mA), in :meth:`PIDCore.step`'s feed-forward input
(inside the anti-windup).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from agents.controllers.core import BaseController, PIDCore
from hydro_envs.plants.force_actuator.params import ForceActuatorParams

__all__ = ["K_ULTIMATE", "P_ULTIMATE", "ForcePIDController", "force_tuning", "SealFriction", "identify_seal_friction",
           "valve_force_gain", "ForceFrictionFFController", "FRICTION_MODELS"]

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


FRICTION_MODELS = ("dahl", "stribeck")
#: preview steps the reference rate is taken between (obs 5 = +10, obs 6 = +25 steps)
_LEAD = (5, 6, 15)


@functools.lru_cache(maxsize=4)
def identify_seal_friction(params: ForceActuatorParams | None = None) -> dict[str, float]:
    """Seal friction identified on the virtual friction test (module docstring): ``g_push``,
    ``g_pull`` [N] (static levels, push = the piston moving in), ``sigma0`` [N/m], ``f_c`` [N],
    ``v_s`` [m/s], and the breakaway forces ``break_push``, ``break_pull`` [N] the test shows."""
    from hydro_envs.plants.force_actuator.experiments import breakaway_test

    p = params or ForceActuatorParams()
    out: dict[str, float] = {}
    s0s, fcs, sliding = [], [], []
    for d, name in ((1, "push"), (-1, "pull")):
        tr = breakaway_test(p, d)
        f, x, v = tr["friction"], tr["displacement"], tr["velocity"]
        k = int(np.argmax(f))
        m = (f > 0.05 * f[k]) & (f < 0.6 * f[k]) & (np.arange(f.size) < k) & (x > 0.0)
        slope, icpt = np.polyfit(1.0 / x[m], 1.0 / f[m], 1)
        out[f"g_{name}"] = float(1.0 / icpt)
        out[f"break_{name}"] = float(f[k])
        s0s.append(float(1.0 / slope))
        fcs.append(float(np.mean(f[-50:])))
        sliding.append((v[k:], f[k:], 1.0 / icpt))
    out["sigma0"] = float(np.mean(s0s))
    fc = float(np.mean(fcs))
    out["f_c"] = fc
    grid = np.geomspace(5e-4, 5e-2, 200)
    cost = [sum(np.sum((fc + (g0 - fc) * np.exp(-(vv / vs) ** 2) - ff) ** 2) for vv, ff, g0 in sliding)
            for vs in grid]
    out["v_s"] = float(grid[int(np.argmin(cost))])
    return out


def valve_force_gain(params: ForceActuatorParams | None = None) -> float:
    """Small-signal blocked force per action unit [N] at the valve null (module docstring)."""
    from hydro_envs.plants.force_actuator import model as fa

    p = params or ForceActuatorParams()
    a2 = p.bore_area - p.rod_area
    h = 1e-6
    slope = (fa.static_force(p.valve_offset + h, p.supply_pressure, p.bore_area, a2)
             - fa.static_force(p.valve_offset - h, p.supply_pressure, p.bore_area, a2)) / (2.0 * h)
    dc = fa.VALVE_K * fa.VALVE_C / (fa.VALVE_A * fa.VALVE_B)
    return slope * dc * p.hysteresis_reversal_slope * p.current_max / p.rated_current


class SealFriction:
    """Batched friction feed-forward [N] of an identified model (module docstring), driven by the
    piston velocity the reference asks for."""

    def __init__(self, model: str, ident: dict[str, float], dt: float = DT) -> None:
        if model not in FRICTION_MODELS:
            raise ValueError(f"friction model {model!r}; allowed {FRICTION_MODELS}")
        self.model = model
        self.g_push, self.g_pull = ident["g_push"], ident["g_pull"]
        self.s0, self.f_c, self.v_s = ident["sigma0"], ident["f_c"], ident["v_s"]
        self.dt = float(dt)
        self.z = np.zeros(0)

    def allocate(self, n: int) -> None:
        self.z = np.zeros(n)

    def reset_rows(self, mask: np.ndarray) -> None:
        self.z[mask] = 0.0

    def level(self, v: np.ndarray) -> np.ndarray:
        """Stribeck level ``g(v)`` [N]: push (v < 0) or pull static level down to F_c."""
        g0 = np.where(v > 0.0, self.g_pull, self.g_push)
        return self.f_c + (g0 - self.f_c) * np.exp(-(v / self.v_s) ** 2)

    def force(self, v: np.ndarray) -> np.ndarray:
        """Friction [N] opposing the relative velocity ``v`` [m/s] (positive: piston moving out)."""
        g = self.level(v)
        if self.model == "stribeck":
            return g * np.tanh(v / (0.5 * self.v_s))
        s = np.sign(v)
        u = 1.0 - self.s0 * self.z * s / g
        self.z = self.z + self.dt * v * u * np.abs(u)  # 001 eq (1), the family's n = 2
        zmax = np.maximum(self.g_push, self.g_pull) / self.s0
        self.z = np.clip(self.z, -zmax, zmax)
        return self.s0 * self.z


class ForceFrictionFFController(BaseController):
    """The force PID (:func:`agents.controllers.force_actuator.force_tuning`) plus the seal
    friction feed-forward of :class:`SealFriction` (module docstring)."""

    obs_dim = 8
    action_dim = 1

    def __init__(self, model: str, params: ForceActuatorParams | None = None, *, env_stiffness: float = 0.0,
                 ident: dict[str, float] | None = None, dt: float = DT) -> None:
        super().__init__()
        p = params or ForceActuatorParams()
        t = force_tuning(p)
        self.pid = PIDCore(t["kp"], t["ti"], t["td"], t["tf"], dt)
        self.f_max = p.max_thrust
        self.friction = SealFriction(model, ident or identify_seal_friction(p), dt)
        self.compliance = (1.0 / env_stiffness if env_stiffness > 0.0 else 0.0) + 1.0 / p.sensor_stiffness
        self.gain = valve_force_gain(p)
        self.dt = float(dt)
        #: scale of the friction feed-forward (bench/friction_ablation.py; 0: the blind twin pid)
        self.friction_scale = 1.0
        self.reset()

    def _allocate(self, n: int) -> None:
        self.pid.allocate(n)
        self.friction.allocate(n)

    def _reset_rows(self, mask: np.ndarray) -> None:
        self.pid.reset_rows(mask)
        self.friction.reset_rows(mask)

    def _act(self, o: np.ndarray) -> np.ndarray:
        f = o[:, 0] * self.f_max
        e = o[:, 1] * self.f_max - f
        i0, i1, steps = _LEAD
        rate = (o[:, i1] - o[:, i0]) * self.f_max / (steps * self.dt)  # r' [N/s], 3.5 ms ahead
        ff = self.friction_scale * self.friction.force(rate * self.compliance) / self.gain
        return self.pid.step(e, f, ff)[:, None]


def small_force_controller(model: str) -> ForceFrictionFFController:
    """``pid_<model>`` for the small-force task's rig (its environment spring known)."""
    from hydro_envs.envs.force_actuator import SMALL_FORCE_RIG

    return ForceFrictionFFController(model, env_stiffness=SMALL_FORCE_RIG["load_stiffness"])


#: the plant these controllers are for (its registry name)
PLANT = "force_actuator"

# ------------------------------------------------------------------ registry hooks
def controllers() -> dict:
    """Classical controllers of this plant's envs: name -> zero-argument factory."""
    from agents.controllers.core import ZeroController

    friction = {f"pid_{m}": functools.partial(small_force_controller, m) for m in FRICTION_MODELS}
    return {"zero": lambda: ZeroController(1), "pid": ForcePIDController.from_params, **friction}


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
