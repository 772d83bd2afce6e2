"""Cylinder position tracking: the task shared by the servo (002) and rodless (004) envs.

Both tasks observe the same sensors -- a quantised, optionally noisy position encoder and two
absolute chamber-pressure transducers -- and reward the same thing, so the observation/reward
kernel, the sensor ranges, the reference bookkeeping and rendering live here once. A subclass
of :class:`CylinderTrackingBatch` names its plant's state and parameter indices and implements
only its action map and its episode draw (initial state, reference kind).

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``)::

    0     tracking error (r - pos_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 steps, normalised
    7     measured position, normalised
    8-9   measured chamber pressures / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error (sensor noise does not enter the reward).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numba as nb
import numpy as np
from gymnasium import spaces
from numba.experimental import structref

from hydro_envs.envs.base import PlantBatch, check_nonnegative, fill_reference
from hydro_envs.envs.kernel_args import BATCH_FIELDS, KernelArgs, KernelArgsType, define_kernel_args
from hydro_envs.envs.render import render_cylinder
from hydro_envs.sim.rk4 import n_blocks, step_block

__all__ = ["PREVIEW_STEPS", "OBS_DIM", "CylinderTrackingBatch", "observation_space", "check_reference_array",
           "step_observe_blocks"]

PREVIEW_STEPS = (10, 20, 30, 40, 50)
OBS_DIM = 6 + len(PREVIEW_STEPS)


@structref.register
class CylinderTrackingArgsType(KernelArgsType):
    """Numba type of :class:`CylinderTrackingArgs`."""


class CylinderTrackingArgs(KernelArgs):
    """The kernel unit of the cylinder-tracking envs: the batch's arrays, the reference and
    pre-drawn noise, the encoder's quantisation, the error scale, the action-rate penalty, the
    preview offsets, the observation bounds, the sensors ``meas``; ``ix, ip1, ip2`` the state
    indices of position and the two chamber pressures, ``i_stroke, i_supply`` the parameter
    indices of the stroke and the supply pressure."""

    fields = BATCH_FIELDS + ("REF", "NOISE", "meas", "quant", "error_scale", "rate_pen", "preview", "obs_low",
                             "obs_high", "ix", "ip1", "ip2", "i_stroke", "i_supply")


define_kernel_args(CylinderTrackingArgs, CylinderTrackingArgsType)


# a call per block of copies, not inlined: the parallel kernels' loop bodies then keep its writes
# through the unit's arrays (numba's parfor passes would treat them as loop-local once inlined),
# and the unit's fields are read once per block, not once per copy
@nb.njit(cache=True, error_model="numpy")
def _observe_block(a, lo, hi):
    """Sensor outputs, observation and reward of copies ``lo:hi`` after a step (or a reset); ``a`` the
    batch's :class:`CylinderTrackingArgs`."""
    Y, P, REF, K, NOISE, last_a, prev_a = a.Y, a.P, a.REF, a.K, a.NOISE, a.last_a, a.prev_a
    quant, e_scale, rate_pen, preview, obs_low, obs_high = a.quant, a.error_scale, a.rate_pen, a.preview, a.obs_low, a.obs_high
    ix, ip1, ip2, i_stroke, i_supply = a.ix, a.ip1, a.ip2, a.i_stroke, a.i_supply
    obs, reward, meas = a.obs, a.reward, a.meas
    n_ref = REF.shape[1]
    n_noise = NOISE.shape[1]
    for i in range(lo, hi):
        k = K[i]
        half = 0.5 * P[i, i_stroke]
        ps = P[i, i_supply]
        r = REF[i, min(k, n_ref - 1)]
        j = k % n_noise
        x_m = Y[i, ix] + NOISE[i, j, 0]
        if quant > 0.0:
            x_m = quant * math.floor(x_m / quant + 0.5)
        p1_m = Y[i, ip1] + NOISE[i, j, 1]
        p2_m = Y[i, ip2] + NOISE[i, j, 2]
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
        e = (r - Y[i, ix]) / e_scale
        da = last_a[i, 0] - prev_a[i, 0]
        reward[i] = -(e * e) - rate_pen * da * da


@nb.njit(cache=True, error_model="numpy", inline="always")
def step_observe_blocks(step, a):
    """One env step of every copy: each block of copies (:func:`hydro_envs.sim.rk4.step_block`)
    is stepped by the plant's serial step ``step``, its step counts advanced, and observed. Inline
    it into a ``parallel=True`` kernel that names the step (an env's ``_step_observe_parallel``);
    ``a`` is the batch's :class:`CylinderTrackingArgs`."""
    Y, U, P, dt, NSUB, W, clamps, K = a.Y, a.U, a.P, a.dt, a.NSUB, a.W, a.clamps, a.K
    for c in nb.prange(n_blocks(Y.shape[0])):
        lo, hi = step_block(step, c, Y, U, P, dt, NSUB, W, clamps)
        for i in range(lo, hi):
            K[i] += 1
        _observe_block(a, lo, hi)


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
    return spaces.Box(low, high, dtype=np.float32)


def check_reference_array(ref: Any, stroke: float) -> np.ndarray:
    """A user reference: 1-D, finite, inside the stroke [0, stroke] m."""
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


class CylinderTrackingBatch(PlantBatch):
    """Position-tracking episodes of a cylinder with a position encoder and two pressure
    transducers. Subclasses set the index class attributes and implement ``reset_task``
    (calling :meth:`set_reference` and :meth:`draw_noise`) and ``apply_actions``."""

    obs_dim = OBS_DIM
    task_options = ("reference",)
    #: state indices of position and the two chamber pressures
    position_index: ClassVar[int]
    pressure_indices: ClassVar[tuple[int, int]]
    #: parameter indices of the stroke and the supply pressure
    stroke_index: ClassVar[int]
    supply_index: ClassVar[int]
    #: measured-data channel names: valve input, position, pressure 1, pressure 2
    channel_names: ClassVar[tuple[str, str, str, str]]

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        position_quantization: float,
        position_noise_std: float = 0.0,
        pressure_noise_std: float = 0.0,
        error_scale: float = 0.01,
        action_rate_penalty: float = 0.01,
        **kwargs: Any,
    ) -> None:
        check_nonnegative(
            position_quantization=position_quantization,
            position_noise_std=position_noise_std,
            pressure_noise_std=pressure_noise_std,
            action_rate_penalty=action_rate_penalty,
        )
        if not (math.isfinite(error_scale) and error_scale > 0.0):
            raise ValueError(f"error_scale must be > 0 m, got {error_scale}")
        super().__init__(n, parallel=parallel, **kwargs)
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

    def set_reference(self, i: int, ref_opt: Any, generate) -> None:
        """Copy ``i``'s reference: ``generate(kind_or_None, n)`` for a kind name or None,
        else the user's array (checked; at least one sample per episode step)."""
        n_ref = self.REF.shape[1]
        if ref_opt is None or isinstance(ref_opt, str):
            self.REF[i] = generate(ref_opt, n_ref)
        else:
            arr = check_reference_array(ref_opt, self.params[i].stroke)
            fill_reference(self.REF[i], arr, self.episode_steps, "m")

    def draw_noise(self, i: int, rng: np.random.Generator) -> None:
        """Pre-draw copy ``i``'s sensor noise for the whole episode (same seed, same noise)."""
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 3)) * self.noise_std

    kernel_args_cls = CylinderTrackingArgs

    def kernel_constants(self) -> dict[str, Any]:
        ip1, ip2 = self.pressure_indices
        return {"ix": self.position_index, "ip1": ip1, "ip2": ip2, "i_stroke": self.stroke_index,
                "i_supply": self.supply_index}

    def observe(self) -> None:
        self.observe_args().run(_observe_block, 0, self.Y.shape[0])

    def channel_values(self, i: int) -> dict[str, float]:
        u, x, p1, p2 = self.channel_names
        return {u: float(self.U[i, 0]), x: float(self.meas[i, 0]), p1: float(self.meas[i, 1]),
                p2: float(self.meas[i, 2])}

    def render_sample(self, i: int) -> tuple[float, float]:
        return (float(self.REF[i, min(self.K[i], self.REF.shape[1] - 1)]),
                float(self.Y[i, self.position_index]))

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        p = self.params[i]
        ip1, ip2 = self.pressure_indices
        return render_cylinder(
            x=self.Y[i, self.position_index],
            reference=self.render_sample(i)[0],
            stroke=p.stroke,
            p1=self.Y[i, ip1] / p.supply_pressure,
            p2=self.Y[i, ip2] / p.supply_pressure,
            valve=self.last_a[i, 0],
            history=history,
        )
