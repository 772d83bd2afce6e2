r"""Position tracking with the valve-controlled servo cylinder (seed 002).

``hydro_envs/ServoCylinderPosition-v0``: the agent commands the servo-valve of a double-rod
cylinder (Moog D765, 6.63 cm^2, 69.6 mm stroke) so the piston follows a reference position.
Plant physics: :mod:`hydro_envs.plants.servo_cylinder` (002 eq (8), Table 1).

**Action** ``Box(-1, 1, (1,), float32)``: valve command as a fraction of +-10 V (full spool
stroke). Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``, so the stroke maps to [-1, 1])::

    0     tracking error (r - x_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 ms, normalised
    7     measured position x_meas, normalised (encoder: 0.03 mm quantisation, 002 sec. 3)
    8-9   measured chamber pressures p1, p2 / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error ``e`` after the step (sensor noise does not enter the reward).

**Episode**: 1 kHz control (``dt = 1 ms``), truncated after 2000 steps (2 s) by the registered
``max_episode_steps``; no termination (the stops and guards keep the state physical).

**Reset**: draws the plant parameters from ``configs/randomization/servo_cylinder.yaml``
(unless ``randomize=False``), a reference (``steps``, ``smooth``, ``sine``, ``chirp`` or
``mixed``) and a rest state with the piston in the middle half of the stroke and both chambers
at the valve's null pressure ``(p_s + p_R)/2``. ``reset(options=...)`` accepts ``params`` (a
mapping of parameter overrides, applied after the draw), ``state`` (mapping of state names to
values) and ``reference`` (a kind name or an array of positions [m], one per step).

**Info** at every step: ``state`` (plant state as SI quantities ``x, v, p1, p2, xv, vv``) and
``params`` (this episode's parameter set).

**Numerics**: every env step is one call of the compiled batch kernel; the number of RK4
sub-steps is chosen each episode from the drawn parameters' stiffness bound
(:func:`hydro_envs.plants.servo_cylinder.stiffness_modes`,
:func:`hydro_envs.sim.stiffness.rk4_substeps`): 3 for the nominal plant (h = 0.33 ms).
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
from hydro_envs.plants import servo_cylinder as plant
from hydro_envs.plants.servo_cylinder import ServoCylinderParams
from hydro_envs.sim.kernels import SERVO_CYLINDER

__all__ = ["ServoCylinderPositionEnv", "ServoCylinderPositionVectorEnv", "ServoCylinderBatch", "observation_space"]

DT = 1e-3
EPISODE_STEPS = 2000
PREVIEW_STEPS = (10, 20, 30, 40, 50)
OBS_DIM = 6 + len(PREVIEW_STEPS)
# Reference band inside the stroke and the largest reference rate (fractions of L and of the
# orifice-law no-load speed), so the task is feasible for every randomised plant.
REF_BAND = (0.1, 0.9)
REF_RATE_FRACTION = 0.6


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
    x_m = Y[i, plant.X] + NOISE[i, j, 0]
    if quant > 0.0:
        x_m = quant * math.floor(x_m / quant + 0.5)
    p1_m = Y[i, plant.P1] + NOISE[i, j, 1]
    p2_m = Y[i, plant.P2] + NOISE[i, j, 2]
    meas[i, 0] = x_m
    meas[i, 1] = p1_m
    meas[i, 2] = p2_m
    obs[i, 0] = (r - x_m) / e_scale
    obs[i, 1] = (r - half) / half
    for m in range(preview.shape[0]):
        obs[i, 2 + m] = (REF[i, min(k + preview[m], n_ref - 1)] - half) / half
    c = 2 + preview.shape[0]
    obs[i, c] = (x_m - half) / half
    obs[i, c + 1] = p1_m / ps
    obs[i, c + 2] = p2_m / ps
    obs[i, c + 3] = last_a[i, 0]
    # sensors saturate at their range: the observation never leaves observation_space
    for m in range(obs.shape[1]):
        obs[i, m] = min(max(obs[i, m], obs_low[m]), obs_high[m])
    e = (r - Y[i, plant.X]) / e_scale
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


def _check_reference_array(ref: Any, stroke: float) -> np.ndarray:
    arr = np.asarray(ref, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"options['reference'] array must be 1-D and non-empty, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("options['reference'] contains NaN or inf")
    if arr.min() < 0.0 or arr.max() > stroke:
        raise ValueError(
            f"options['reference'] must lie inside the stroke [0, {stroke}] m, got "
            f"[{arr.min():g}, {arr.max():g}]"
        )
    return arr


def observation_space(stroke: float, error_scale: float) -> spaces.Box:
    """Finite bounds = the sensors' measuring ranges; observations are clipped to them.

    The reference and its preview lie inside the stroke ([-1, 1] normalised, enforced when a
    reference is generated or passed in); the measured position gets a 20 % margin ([-1.2, 1.2]:
    stop penetration and noise); the error spans that excursion over ``error_scale``; pressure
    transducers read 0 to twice the supply pressure (absolute); the action is in [-1, 1].
    """
    c = 2 + len(PREVIEW_STEPS)
    e_max = 1.2 * stroke / error_scale
    low = np.full(OBS_DIM, -1.0, dtype=np.float32)
    high = np.full(OBS_DIM, 1.0, dtype=np.float32)
    low[0], high[0] = -e_max, e_max
    low[c], high[c] = -1.2, 1.2
    low[c + 1 : c + 3], high[c + 1 : c + 3] = 0.0, 2.0
    low[c + 3], high[c + 3] = -1.0, 1.0
    return spaces.Box(low, high, dtype=np.float32)


class ServoCylinderBatch(PlantBatch):
    """Servo-cylinder position-tracking episodes (see the module docstring)."""

    plant = plant
    params_cls = ServoCylinderParams
    kernel_id = SERVO_CYLINDER
    dt = DT
    episode_steps_default = EPISODE_STEPS
    obs_dim = OBS_DIM
    task_options = ("reference",)

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        reference: str = "mixed",
        position_quantization: float = 3e-5,
        position_noise_std: float = 0.0,
        pressure_noise_std: float = 0.0,
        error_scale: float = 0.01,
        action_rate_penalty: float = 0.01,
        **kwargs: Any,
    ) -> None:
        if reference not in REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
        check_nonnegative(
            position_quantization=position_quantization,
            position_noise_std=position_noise_std,
            pressure_noise_std=pressure_noise_std,
            action_rate_penalty=action_rate_penalty,
        )
        if not (math.isfinite(error_scale) and error_scale > 0.0):
            raise ValueError(f"error_scale must be > 0 m, got {error_scale}")
        super().__init__(n, parallel=parallel, **kwargs)
        self.reference_kind = reference
        self.quant = float(position_quantization)
        self.noise_std = np.array([position_noise_std, pressure_noise_std, pressure_noise_std], dtype=float)
        self.error_scale = float(error_scale)
        self.rate_pen = float(action_rate_penalty)
        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        self.REF = np.zeros((n, n_ref))
        self.NOISE = np.zeros((n, n_ref if self.noise_std.any() else 1, 3))
        self.meas = np.zeros((n, 3))
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        space = self.observation_space()
        self.obs_low = space.low.astype(np.float64)
        self.obs_high = space.high.astype(np.float64)

    def observation_space(self) -> spaces.Box:
        return observation_space(self.base_params.stroke, self.error_scale)

    def reset_task(self, i: int, rng: np.random.Generator, p: ServoCylinderParams, options: Mapping[str, Any]) -> None:
        L = p.stroke
        # initial rest state: piston in the middle half, chambers at the valve's null pressure
        y = np.zeros(plant.N_STATES)
        y[plant.X] = rng.uniform(0.25 * L, 0.75 * L)
        y[plant.P1] = y[plant.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
        self.state_from_options(y, options)
        if not (0.0 <= y[plant.X] <= L):
            raise ValueError(f"options['state']['x'] = {y[plant.X]} m lies outside the stroke [0, {L}] m")
        for name, j in (("p1", plant.P1), ("p2", plant.P2)):
            if y[j] < p.pressure_floor:
                raise ValueError(
                    f"options['state'][{name!r}] = {y[j]} Pa is below the pressure floor "
                    f"{p.pressure_floor} Pa (pressures are absolute)"
                )
        self.Y[i] = y
        ref_opt = options.get("reference")
        n_ref = self.REF.shape[1]
        if ref_opt is None or isinstance(ref_opt, str):
            kind = self.reference_kind if ref_opt is None else ref_opt
            rate = REF_RATE_FRACTION * plant.no_load_velocity(p)
            self.REF[i] = generate_reference(kind, rng, n_ref, DT, REF_BAND[0] * L, REF_BAND[1] * L, rate)
        else:
            arr = _check_reference_array(ref_opt, L)
            m = min(arr.size, n_ref)
            self.REF[i, :m] = arr[:m]
            self.REF[i, m:] = arr[m - 1]
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 3)) * self.noise_std

    def apply_actions(self) -> None:
        # action in [-1, 1] -> valve command in V (full spool stroke at +-command_max)
        np.multiply(self.last_a[:, 0], self.P[:, plant.I_UMAX], out=self.U[:, 0])

    def observe(self) -> None:
        (_observe_parallel if self.parallel else _observe_serial)(
            self.Y, self.P, self.REF, self.K, self.NOISE, self.last_a, self.prev_a, self.quant,
            self.error_scale, self.rate_pen, self.preview, self.obs_low, self.obs_high,
            self.obs, self.reward, self.meas,
        )

    def channel_values(self, i: int) -> dict[str, float]:
        return {
            "u": float(self.U[i, 0]),
            "x": float(self.meas[i, 0]),
            "p1": float(self.meas[i, 1]),
            "p2": float(self.meas[i, 2]),
        }

    def render_sample(self, i: int) -> tuple[float, float]:
        return (float(self.REF[i, min(self.K[i], self.REF.shape[1] - 1)]), float(self.Y[i, plant.X]))

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        p = self.params[i]
        return render_cylinder(
            x=self.Y[i, plant.X],
            reference=self.render_sample(i)[0],
            stroke=p.stroke,
            p1=self.Y[i, plant.P1] / p.supply_pressure,
            p2=self.Y[i, plant.P2] / p.supply_pressure,
            valve=self.last_a[i, 0],
            history=history,
        )


class ServoCylinderPositionEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ServoCylinderBatch


class ServoCylinderPositionVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ServoCylinderBatch
