r"""Point-to-point positioning and tracking with the pneumatic rodless cylinder (seed 004).

``hydro_envs/RodlessCylinder-v0``: the agent commands a FESTO MPYE-5 proportional valve
(0-10 V, closed centre at 5 V) driving an SMC MYC25G-110L mechanical rodless cylinder (bore
25 mm, stroke 110 mm, 0.6 MPa supply) so that the slider follows a reference position.
Plant physics: :mod:`hydro_envs.plants.rodless_cylinder` (004 eqs (1)-(18), Tables 1-2).

**Action** ``Box(-1, 1, (1,), float32)``: valve command ``u = 5 V + 5 V * a`` (a = -1 -> 0 V,
0 -> the 5 V centre, +1 -> 10 V). Out-of-range actions are clipped; NaN or inf raise
``ValueError``.

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``, so the stroke maps to [-1, 1])::

    0     tracking error (r - y_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 ms, normalised
    7     measured slider position y_meas, normalised (grating ruler: 5 um quantisation)
    8-9   measured chamber pressures pa, pb / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error ``e`` after the step (sensor noise does not enter the reward).

**Tasks** (constructor ``task``): ``"positioning"`` -- point-to-point: random set points held
0.2-0.6 s (``steps`` references); ``"tracking"`` -- a smooth reference per episode
(``smooth``, ``sine`` or ``chirp``); ``"mixed"`` (default) -- either, drawn per episode.
Smooth references stay below 0.15 m/s, under half the full-opening speed of the weakest
randomised plant (0.35 m/s).

**Episode**: 1 kHz control (``dt = 1 ms``), truncated after 2000 steps (2 s) by the registered
``max_episode_steps``; no termination (stops and guards keep the state physical).

**Reset**: draws the plant parameters from ``configs/randomization/rodless_cylinder.yaml``
(Stribeck parameters +-30 %, slider + payload mass 0.4-2 kg, supply 0.4-0.7 MPa gauge) unless
``randomize=False``, a reference, and a rest state: slider in the middle half of the stroke,
spool at the centre, both chambers at the valve's centre equilibrium pressure p_0 (leakage in
= leakage out, about 0.81 p_s) and at the supply temperature, unloaded seals (z = 0).
``reset(options=...)`` accepts ``params`` (parameter overrides, applied after the draw),
``state`` (state names to values; chamber masses not given are set for the supply
temperature at the final pressures and position) and ``reference`` (a kind name or an array
of positions [m], one per step).

**Info** at every step: ``state`` (``y, v, pa, pb, ma, mb, xv, vv, z`` in SI units; chamber
temperatures follow as ``p V / (m R)``, :func:`hydro_envs.plants.rodless_cylinder.chamber_temperatures`)
and ``params`` (this episode's parameter set).

**Constant-velocity operation** (004 sec. 3, eq (1)): a constant action holds the valve
opening, and the slider settles at a constant speed where ``A (p_a - p_b)`` equals the
Table 2 friction; :func:`hydro_envs.plants.rodless_cylinder.constant_command_run` runs that
experiment on the plant directly.

**Numerics**: every env step is one call of the compiled batch kernel; the RK4 sub-steps come
from the drawn parameters' stiffness bound: 5 per 1 ms for the nominal plant, 4-5 for 90 % of
the draws, at most 10 at the light, low-friction, high-supply corner (the LuGre bristle
relaxation at the speed bound, :func:`hydro_envs.plants.rodless_cylinder.stiffness_modes`).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numba as nb
import numpy as np
from gymnasium import spaces

from hydro_envs.envs.base import BatchedEnv, BatchedVectorEnv, PlantBatch, check_nonnegative
from hydro_envs.envs.references import REFERENCE_KINDS, generate_reference
from hydro_envs.envs.render import render_cylinder
from hydro_envs.plants import rodless_cylinder as plant
from hydro_envs.plants.rodless_cylinder import RodlessCylinderParams
from hydro_envs.sim.kernels import RODLESS_CYLINDER

__all__ = [
    "RodlessCylinderEnv",
    "RodlessCylinderVectorEnv",
    "RodlessCylinderBatch",
    "observation_space",
    "TASKS",
]

DT = 1e-3
EPISODE_STEPS = 2000
PREVIEW_STEPS = (10, 20, 30, 40, 50)
OBS_DIM = 6 + len(PREVIEW_STEPS)
REF_BAND = (0.1, 0.9)
REF_MAX_RATE = 0.15  # m/s
TASKS = ("positioning", "tracking", "mixed")
_TRACKING_KINDS = ("smooth", "sine", "chirp")


@nb.njit(cache=True, error_model="numpy", inline="always")
def _observe_copy(i, Y, P, REF, K, NOISE, last_a, prev_a, quant, e_scale, rate_pen, preview, obs_low, obs_high, obs, reward, meas):
    """Sensor outputs, observation and reward of copy ``i`` after a step (or a reset)."""
    n_ref = REF.shape[1]
    n_noise = NOISE.shape[1]
    k = K[i]
    half = 0.5 * P[i, plant.I_L]
    ps = P[i, plant.I_PS]
    r = REF[i, min(k, n_ref - 1)]
    j = k % n_noise
    y_m = Y[i, plant.Y] + NOISE[i, j, 0]
    if quant > 0.0:
        y_m = quant * math.floor(y_m / quant + 0.5)
    pa_m = Y[i, plant.PA] + NOISE[i, j, 1]
    pb_m = Y[i, plant.PB] + NOISE[i, j, 2]
    meas[i, 0] = y_m
    meas[i, 1] = pa_m
    meas[i, 2] = pb_m
    obs[i, 0] = (r - y_m) / e_scale
    obs[i, 1] = (r - half) / half
    for m in range(preview.shape[0]):
        obs[i, 2 + m] = (REF[i, min(k + preview[m], n_ref - 1)] - half) / half
    c = 2 + preview.shape[0]
    obs[i, c] = (y_m - half) / half
    obs[i, c + 1] = pa_m / ps
    obs[i, c + 2] = pb_m / ps
    obs[i, c + 3] = last_a[i, 0]
    for m in range(obs.shape[1]):  # sensors saturate at their range
        obs[i, m] = min(max(obs[i, m], obs_low[m]), obs_high[m])
    e = (r - Y[i, plant.Y]) / e_scale
    da = last_a[i, 0] - prev_a[i, 0]
    reward[i] = -(e * e) - rate_pen * da * da


@nb.njit(cache=True, error_model="numpy")
def _observe_serial(Y, P, REF, K, NOISE, last_a, prev_a, quant, e_scale, rate_pen, preview, obs_low, obs_high, obs, reward, meas):
    for i in range(Y.shape[0]):
        _observe_copy(i, Y, P, REF, K, NOISE, last_a, prev_a, quant, e_scale, rate_pen, preview, obs_low, obs_high, obs, reward, meas)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _observe_parallel(Y, P, REF, K, NOISE, last_a, prev_a, quant, e_scale, rate_pen, preview, obs_low, obs_high, obs, reward, meas):
    for i in nb.prange(Y.shape[0]):
        _observe_copy(i, Y, P, REF, K, NOISE, last_a, prev_a, quant, e_scale, rate_pen, preview, obs_low, obs_high, obs, reward, meas)


@nb.njit(cache=True, error_model="numpy")
def _apply_actions(last_a, P, U):
    """a in [-1, 1] -> U = centre + a (max - centre): 0..10 V with the 5 V closed centre."""
    for i in range(U.shape[0]):
        uc = P[i, plant.I_UC]
        U[i, 0] = uc + last_a[i, 0] * (P[i, plant.I_UMAX] - uc)


def observation_space(stroke: float, error_scale: float) -> spaces.Box:
    """Finite bounds = the sensors' ranges; observations are clipped to them.

    Reference and preview in [-1, 1] (inside the stroke); measured position [-1.2, 1.2] (stop
    penetration and noise); the error spans that excursion over ``error_scale``; pressures 0 to
    twice the supply pressure (absolute); the action in [-1, 1].
    """
    c = 2 + len(PREVIEW_STEPS)
    e_max = 1.2 * stroke / error_scale
    low = np.full(OBS_DIM, -1.0, dtype=np.float32)
    high = np.full(OBS_DIM, 1.0, dtype=np.float32)
    low[0], high[0] = -e_max, e_max
    low[c], high[c] = -1.2, 1.2
    low[c + 1 : c + 3], high[c + 1 : c + 3] = 0.0, 2.0
    return spaces.Box(low, high, dtype=np.float32)


def _check_reference_array(ref: Any, stroke: float) -> np.ndarray:
    arr = np.asarray(ref, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"options['reference'] array must be 1-D and non-empty, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("options['reference'] contains NaN or inf")
    if arr.min() < 0.0 or arr.max() > stroke:
        raise ValueError(
            f"options['reference'] must lie inside the stroke [0, {stroke}] m, got [{arr.min():g}, {arr.max():g}]"
        )
    return arr


class RodlessCylinderBatch(PlantBatch):
    """Rodless-cylinder positioning / tracking episodes (see the module docstring)."""

    plant = plant
    params_cls = RodlessCylinderParams
    kernel_id = RODLESS_CYLINDER
    dt = DT
    episode_steps_default = EPISODE_STEPS
    obs_dim = OBS_DIM
    task_options = ("reference",)

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        task: str = "mixed",
        position_quantization: float = 5e-6,
        position_noise_std: float = 0.0,
        pressure_noise_std: float = 0.0,
        error_scale: float = 0.01,
        action_rate_penalty: float = 0.01,
        **kwargs: Any,
    ) -> None:
        if task not in TASKS:
            raise ValueError(f"task = {task!r}; allowed {TASKS}")
        check_nonnegative(
            position_quantization=position_quantization,
            position_noise_std=position_noise_std,
            pressure_noise_std=pressure_noise_std,
            action_rate_penalty=action_rate_penalty,
        )
        if not (math.isfinite(error_scale) and error_scale > 0.0):
            raise ValueError(f"error_scale must be > 0 m, got {error_scale}")
        super().__init__(n, parallel=parallel, **kwargs)
        self.task = task
        self.quant = float(position_quantization)
        self.noise_std = np.array([position_noise_std, pressure_noise_std, pressure_noise_std], dtype=float)
        self.error_scale = float(error_scale)
        self.rate_pen = float(action_rate_penalty)
        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        self.REF = np.zeros((n, n_ref))
        self.NOISE = np.zeros((n, n_ref if self.noise_std.any() else 1, 3))
        self.meas = np.zeros((n, 3))
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        self._p0_cache: dict[tuple[float, ...], float] = {}
        space = self.observation_space()
        self.obs_low = space.low.astype(np.float64)
        self.obs_high = space.high.astype(np.float64)

    def observation_space(self) -> spaces.Box:
        return observation_space(self.base_params.stroke, self.error_scale)

    def _centre_pressure(self, p: RodlessCylinderParams) -> float:
        key = (p.supply_pressure, p.exhaust_pressure, p.supply_temperature, p.heat_capacity_ratio,
               p.gas_constant, p.laminar_pressure_ratio, p.flow_model, p.critical_pressure_ratio)
        if key not in self._p0_cache:
            if len(self._p0_cache) > 4096:
                self._p0_cache.clear()
            self._p0_cache[key] = plant.centre_pressure(p)
        return self._p0_cache[key]

    def _reference_kind(self, rng: np.random.Generator) -> str:
        if self.task == "positioning":
            return "steps"
        if self.task == "tracking":
            return _TRACKING_KINDS[int(rng.integers(len(_TRACKING_KINDS)))]
        return REFERENCE_KINDS[int(rng.integers(len(REFERENCE_KINDS)))]

    def reset_task(self, i: int, rng: np.random.Generator, p: RodlessCylinderParams, options: Mapping[str, Any]) -> None:
        L = p.stroke
        p0 = self._centre_pressure(p)
        y = np.zeros(plant.N_STATES)
        y[plant.Y] = rng.uniform(0.25 * L, 0.75 * L)
        y[plant.PA] = y[plant.PB] = p0
        given = set((options.get("state") or {}).keys())
        self.state_from_options(y, options)
        if not (0.0 <= y[plant.Y] <= L):
            raise ValueError(f"options['state']['y'] = {y[plant.Y]} m lies outside the stroke [0, {L}] m")
        for name, j in (("pa", plant.PA), ("pb", plant.PB)):
            if y[j] < p.pressure_floor:
                raise ValueError(
                    f"options['state'][{name!r}] = {y[j]} Pa is below the pressure floor "
                    f"{p.pressure_floor} Pa (pressures are absolute)"
                )
        va, vb = plant.chamber_volumes(y, p)
        rt = p.gas_constant * p.supply_temperature
        if "ma" not in given:
            y[plant.MA] = y[plant.PA] * va[0] / rt
        if "mb" not in given:
            y[plant.MB] = y[plant.PB] * vb[0] / rt
        for name, j in (("ma", plant.MA), ("mb", plant.MB)):
            if not y[j] > p.min_gas_mass:
                raise ValueError(f"options['state'][{name!r}] = {y[j]} kg must exceed min_gas_mass {p.min_gas_mass} kg")
        self.Y[i] = y
        ref_opt = options.get("reference")
        n_ref = self.REF.shape[1]
        if ref_opt is None or isinstance(ref_opt, str):
            kind = self._reference_kind(rng) if ref_opt is None else ref_opt
            self.REF[i] = generate_reference(kind, rng, n_ref, DT, REF_BAND[0] * L, REF_BAND[1] * L, REF_MAX_RATE)
        else:
            arr = _check_reference_array(ref_opt, L)
            m = min(arr.size, n_ref)
            self.REF[i, :m] = arr[:m]
            self.REF[i, m:] = arr[m - 1]
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 3)) * self.noise_std

    def apply_actions(self) -> None:
        _apply_actions(self.last_a, self.P, self.U)

    def observe(self) -> None:
        (_observe_parallel if self.parallel else _observe_serial)(
            self.Y, self.P, self.REF, self.K, self.NOISE, self.last_a, self.prev_a, self.quant,
            self.error_scale, self.rate_pen, self.preview, self.obs_low, self.obs_high,
            self.obs, self.reward, self.meas,
        )

    def channel_values(self, i: int) -> dict[str, float]:
        return {
            "u": float(self.U[i, 0]),
            "y": float(self.meas[i, 0]),
            "pa": float(self.meas[i, 1]),
            "pb": float(self.meas[i, 2]),
        }

    def render_sample(self, i: int) -> tuple[float, float]:
        return (float(self.REF[i, min(self.K[i], self.REF.shape[1] - 1)]), float(self.Y[i, plant.Y]))

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        p = self.params[i]
        return render_cylinder(
            x=self.Y[i, plant.Y],
            reference=self.render_sample(i)[0],
            stroke=p.stroke,
            p1=self.Y[i, plant.PA] / p.supply_pressure,
            p2=self.Y[i, plant.PB] / p.supply_pressure,
            valve=self.last_a[i, 0],
            history=history,
        )


class RodlessCylinderEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = RodlessCylinderBatch


class RodlessCylinderVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = RodlessCylinderBatch
