r"""Acceleration tracking with the servo-hydraulic shaking table (seed 003).

``hydro_envs/ShakingTable-v0``: the agent drives the proportional valve (Bosch-Rexroth 4WS.2E)
of a 650 kg uni-axial table with a 0-500 kg specimen so that the *table acceleration* follows
a reference -- sines 0.5-15 Hz, pulses, amplitude transitions (003 eq (23)) and synthetic
earthquakes (:mod:`hydro_envs.envs.shaking_table.references`) -- while keeping the table inside its
260 mm stroke. It observes only what the rig measures (sec. 2): the potentiometer position,
the accelerometer, the velocity the paper derived from the position (sec. 4: differentiated,
8th-order Butterworth at 40 Hz), plus the reference. Plant physics:
:mod:`hydro_envs.plants.shaking_table`.

**Action** ``Box(-1, 1, (1,), float32)``: valve command as a fraction of +-10 V (full spool
stroke). Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (13,))``, every entry clipped to the sensor ranges::

    0     acceleration error (r - a_meas) / error_scale                    [m/s^2 / m/s^2]
    1     reference acceleration r / accel_scale
    2-6   reference preview at +10, +20, +30, +40, +50 ms, / accel_scale
    7     measured position x_meas / (stroke/2)   (potentiometer, 0 = mid-stroke)
    8     measured acceleration a_meas / accel_scale  (accelerometer, saturates at +-5 g)
    9     velocity estimate / velocity_scale  (backward difference of x_meas, Butterworth 8/40 Hz)
    10    last action
    11    reference velocity v_r / velocity_scale,  v_r(k) = dt sum_{j<k} r_j
    12    reference position x_r / (stroke/2),      x_r(k) = x(0) + dt sum_{j<k} v_r(j)

The reference accelerations belong to a motion that starts at rest where the table starts
(:mod:`~hydro_envs.envs.shaking_table.references`); 11-12 are that motion, the integrals a
controller of an acceleration loop needs (003 sec. 4 drives the table by its velocity and
position; a memoryless policy cannot integrate the reference itself).

Defaults: ``error_scale = 1 m/s^2``, ``accel_scale = 10 m/s^2``, ``velocity_scale = 0.5 m/s``.

**Reward** ``-(e / error_scale)^2 - action_rate_penalty (a_k - a_{k-1})^2 -
position_penalty (x / (stroke/2))^2`` with the *true* acceleration error ``e = r - dv/dt``
after the step (sensor noise does not enter the reward); defaults 0.01 and 0.25.

**Episode**: 1 kHz control (``dt = 1 ms``: 66 samples per period at 15 Hz, above the 4WS.2E's
625 rad/s spool bandwidth), truncated after 6000 steps (6 s, the length of the eq (23) record)
by the registered ``max_episode_steps``; no termination (end stops and guards keep the state
physical; the position penalty discourages drifting into them).

**Reset**: draws the plant from the plant's ``randomization.yaml`` (unless
``randomize=False``) on top of the ``preset`` (``modified_ifas`` default, ``ifas``,
``constant``; 003 Table 2), a reference of kind ``reference`` and a rest state: table within
+-13 mm of mid-stroke, spool centred, both chambers at the valve's null pressure
(:func:`~hydro_envs.plants.shaking_table.null_pressure`). ``specimen_mass=`` (kg, or ``"200kg"``
/ ``"500kg"`` / ``"none"``) fixes the specimen and removes it from the draws.
``reset(options=...)`` accepts ``params`` (overrides after the draw), ``state`` and
``reference`` (a kind, or an array of accelerations [m/s^2], one per step, within the
accelerometer's +-5 g).

**Info** at every step: ``state`` (``x, v, pa, pb, xv, vv, z``; SI, absolute pressures; ``z`` the
seals' bristle deflection, :mod:`hydro_envs.plants.shaking_table.model`) and
``params`` (this episode's parameter set). ``env.unwrapped.sensor_values()`` returns the
measured position, acceleration and velocity estimate; ``channel_values()`` the
measured-data channels ``u`` [V], ``x`` [m], ``a`` [m/s^2].

**Numerics**: one compiled kernel call per env step; RK4 sub-steps from the drawn
parameters' stiffness bound (2 for the nominal plant and every randomisation corner,
h = 0.5 ms, set by the spool's accuracy and the seals' bristle block,
:func:`hydro_envs.plants.shaking_table.stiffness_modes`),
each taken as finer ones (2, up to 4 at the randomisation corners) where a valve orifice's
laminar core, a kink of the metering openings or an edge of the modified-IFAS notch needs them,
and as many as keep RK4 accurate where a chamber empties into or refills from the air-release
band (:func:`hydro_envs.plants.shaking_table.model.local_mode_substeps`). The modulus law sets
the cost: a 1024-copy vector env steps about 1.2x faster with ``preset="ifas"`` and 1.3-1.75x with
``preset="constant"`` than with the default modified IFAS (``docs/speed.md``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

import numba as nb
import numpy as np
from gymnasium import spaces
from numba.experimental import structref

from hydro_envs.envs.base import VELOCITY_FACTOR, BatchedEnv, BatchedVectorEnv, PlantBatch, check_nonnegative, fill_reference
from hydro_envs.envs.kernel_args import BATCH_FIELDS, KernelArgs, KernelArgsType, define_kernel_args
from hydro_envs.envs.render import render_cylinder
from hydro_envs.envs.shaking_table.references import (
    TABLE_REFERENCE_KINDS,
    generate_table_reference,
    low_frequency_reference,
    reference_limits,
)
from hydro_envs.intrinsics import prefetch_row_element
from hydro_envs.laws.filters import butterworth_lowpass_sos, sos_filter_step
from hydro_envs.plants.shaking_table import model as plant
from hydro_envs.plants.shaking_table.kernels import KERNELS, step_serial
from hydro_envs.plants.shaking_table.model import table_acceleration
from hydro_envs.plants.shaking_table.params import SPECIMENS, ShakingTableParams
from hydro_envs.plants.shaking_table.spec import SPEC
from hydro_envs.sim.rk4 import block_bounds, n_blocks, step_block

__all__ = [
    "ShakingTableEnv",
    "ShakingTableVectorEnv",
    "ShakingTableBatch",
    "ACCELEROMETER_RANGE",
    "VELOCITY_FILTER",
    "ShakingTableLowFrequencyEnv",
    "ShakingTableLowFrequencyVectorEnv",
    "ShakingTableLowFrequencyBatch",
    "LOW_FREQUENCY_STEPS",
]

DT = 1e-3
EPISODE_STEPS = 6000
PREVIEW_STEPS = (10, 20, 30, 40, 50)
OBS_DIM = 8 + len(PREVIEW_STEPS)
#: ADXL05 full scale (+-5 g, data sheet); the accelerometer saturates there.
ACCELEROMETER_RANGE = 5.0 * 9.80665
#: Velocity estimate clipped to +-2 m/s (4.6 x the no-load speed): a plausibility range.
VELOCITY_RANGE = 2.0
#: 003 sec. 4: 8th-order Butterworth low-pass, 40 Hz, on the differentiated position.
VELOCITY_FILTER = {"order": 8, "cutoff_hz": 40.0}
#: Gefran PC-M-300 potentiometer read by an assumed 16-bit ADC over 300 mm: 4.6 um steps.
POSITION_QUANTIZATION = 0.3 / 2**16
INITIAL_POSITION_BAND = 0.1  # fraction of the half stroke
#: how far ahead [samples] the observation prefetches each reference stream: one 64-byte cache
#: line of float64 (each copy's reference is a row of its own; :mod:`hydro_envs.intrinsics`)
PREFETCH_SAMPLES = 8


@structref.register
class ShakingTableArgsType(KernelArgsType):
    """Numba type of :class:`ShakingTableArgs`."""


class ShakingTableArgs(KernelArgs):
    """The kernel unit of the shaking-table envs: the batch's arrays, the acceleration reference
    ``REF`` and its integrals ``REFI``, the pre-drawn sensor noise, the velocity filter (``sos``,
    its states ``ZI``, the last position ``XPREV``, its output ``VF``, the step ``KOBS`` it last
    advanced at), the encoder's quantisation, the observation scales, the sensors' ranges
    ``a_range`` and ``v_range``, the reward's weights, the preview offsets, the observation bounds
    and the sensors ``meas``."""

    fields = BATCH_FIELDS + ("REF", "REFI", "NOISE", "sos", "ZI", "XPREV", "VF", "KOBS", "quant", "error_scale",
                             "accel_scale", "velocity_scale", "a_range", "v_range", "rate_pen", "pos_pen", "preview",
                             "obs_low", "obs_high", "meas")


define_kernel_args(ShakingTableArgs, ShakingTableArgsType)


# a call per block of copies, not inlined: the parallel kernels' loop bodies then keep its writes
# through the unit's arrays (numba's parfor passes would treat them as loop-local once inlined),
# and the unit's fields are read once per block, not once per copy
@nb.njit(cache=True, error_model="numpy")
def _observe_block(a, lo, hi):
    """Sensors, observation and reward of copies ``lo:hi`` after a step (or a reset); ``a`` the batch's
    :class:`ShakingTableArgs` (``dt``: the differentiation step of the velocity filter).

    The velocity filter and the reference's integrals ``REFI[i]`` (``v_r``, ``x_r - x_r(0)``,
    ``x_r(0)``) advance once per env step: a repeated call at the same step count (the vector
    env re-observes every copy after resetting some) leaves them unchanged. The integrals are
    running sums over the reference samples passed, ``v_r(k) = dt sum_{j<k} r_j`` and
    ``x_r(k) = x_r(0) + dt sum_{j<k} v_r(j)``, held from the reference's last sample on.
    """
    Y, P, REF, REFI, K, NOISE, last_a, prev_a = a.Y, a.P, a.REF, a.REFI, a.K, a.NOISE, a.last_a, a.prev_a
    sos, ZI, XPREV, VF, KOBS, quant, dt = a.sos, a.ZI, a.XPREV, a.VF, a.KOBS, a.quant, a.dt
    e_scale, a_scale, v_scale, a_range, v_range = a.error_scale, a.accel_scale, a.velocity_scale, a.a_range, a.v_range
    rate_pen, pos_pen, preview, obs_low, obs_high = a.rate_pen, a.pos_pen, a.preview, a.obs_low, a.obs_high
    obs, reward, meas = a.obs, a.reward, a.meas
    n_ref = REF.shape[1]
    n_noise = NOISE.shape[1]
    for i in range(lo, hi):
        k = K[i]
        ahead = min(k + PREFETCH_SAMPLES, n_ref - 1)  # load the lines the reference streams enter next
        prefetch_row_element(REF, i, ahead)
        for m in range(preview.shape[0]):
            prefetch_row_element(REF, i, min(ahead + preview[m], n_ref - 1))
        half = 0.5 * P[i, plant.I_L]
        r = REF[i, min(k, n_ref - 1)]
        j = k % n_noise if n_noise > 1 else 0  # (no noise: one row, and no integer division)
        x_m = Y[i, plant.X] + NOISE[i, j, 0]
        if quant > 0.0:
            x_m = quant * math.floor(x_m / quant + 0.5)
        a_true = table_acceleration(Y[i], P[i])
        a_m = min(max(a_true + NOISE[i, j, 1], -a_range), a_range)
        if KOBS[i] != k:
            if KOBS[i] < 0:  # first observation of an episode: filter at rest
                for s in range(ZI.shape[1]):
                    ZI[i, s, 0] = 0.0
                    ZI[i, s, 1] = 0.0
                VF[i] = 0.0
            else:
                VF[i] = sos_filter_step(sos, ZI[i], (x_m - XPREV[i]) / dt)
                for kk in range(KOBS[i], min(k, n_ref - 1)):  # the reference samples passed
                    REFI[i, 1] += REFI[i, 0] * dt
                    REFI[i, 0] += REF[i, kk] * dt
            XPREV[i] = x_m
            KOBS[i] = k
        v_f = min(max(VF[i], -v_range), v_range)
        meas[i, 0] = x_m
        meas[i, 1] = a_m
        meas[i, 2] = v_f
        obs[i, 0] = (r - a_m) / e_scale
        obs[i, 1] = r / a_scale
        for m in range(preview.shape[0]):
            obs[i, 2 + m] = REF[i, min(k + preview[m], n_ref - 1)] / a_scale
        c = 2 + preview.shape[0]
        obs[i, c] = x_m / half
        obs[i, c + 1] = a_m / a_scale
        obs[i, c + 2] = v_f / v_scale
        obs[i, c + 3] = last_a[i, 0]
        obs[i, c + 4] = REFI[i, 0] / v_scale
        obs[i, c + 5] = (REFI[i, 1] + REFI[i, 2]) / half
        for m in range(obs.shape[1]):
            obs[i, m] = min(max(obs[i, m], obs_low[m]), obs_high[m])
        e = (r - a_true) / e_scale
        da = last_a[i, 0] - prev_a[i, 0]
        xr = Y[i, plant.X] / half
        reward[i] = -(e * e) - rate_pen * da * da - pos_pen * xr * xr


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _observe_parallel(a):
    n = a.Y.shape[0]
    for c in nb.prange(n_blocks(n)):
        lo, hi = block_bounds(c, n)
        _observe_block(a, lo, hi)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel(a):
    """One env step of every copy in one parallel region: each block of copies is stepped by the
    plant's serial step, its step counts advanced, and observed. Each block's valve commands
    ``U`` come from ``last_a`` first (:meth:`ShakingTableBatch.apply_actions`'s arithmetic)."""
    Y, U, P, dt, NSUB, W, clamps, K, last_a = a.Y, a.U, a.P, a.dt, a.NSUB, a.W, a.clamps, a.K, a.last_a
    for c in nb.prange(n_blocks(Y.shape[0])):
        lo, hi = block_bounds(c, Y.shape[0])
        for i in range(lo, hi):
            U[i, 0] = last_a[i, 0] * P[i, plant.I_UMAX]
        step_block(step_serial, c, Y, U, P, dt, NSUB, W, clamps)
        for i in range(lo, hi):
            K[i] += 1
        _observe_block(a, lo, hi)


def observation_space(error_scale: float, accel_scale: float, velocity_scale: float) -> spaces.Box:
    """Finite bounds = the sensors' ranges; observations are clipped to them.

    References (and their preview) and the accelerometer lie within +-5 g; the error spans
    twice that; the position gets a 20 % margin beyond the stroke (stop penetration, noise);
    the velocity estimate is clipped to +-2 m/s; the action is in [-1, 1].
    """
    c = 2 + len(PREVIEW_STEPS)
    ra = ACCELEROMETER_RANGE / accel_scale
    low = np.full(OBS_DIM, -ra, dtype=np.float32)
    high = np.full(OBS_DIM, ra, dtype=np.float32)
    low[0], high[0] = -2.0 * ACCELEROMETER_RANGE / error_scale, 2.0 * ACCELEROMETER_RANGE / error_scale
    low[c], high[c] = -1.2, 1.2
    low[c + 2], high[c + 2] = -VELOCITY_RANGE / velocity_scale, VELOCITY_RANGE / velocity_scale
    low[c + 3], high[c + 3] = -1.0, 1.0
    low[c + 4], high[c + 4] = -VELOCITY_RANGE / velocity_scale, VELOCITY_RANGE / velocity_scale
    low[c + 5], high[c + 5] = -1.2, 1.2
    return spaces.Box(low, high, dtype=np.float32)


def _check_reference_array(ref: Any) -> np.ndarray:
    arr = np.asarray(ref, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"options['reference'] array must be 1-D and non-empty, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("options['reference'] contains NaN or inf")
    if np.max(np.abs(arr)) > ACCELEROMETER_RANGE:
        raise ValueError(
            f"options['reference'] accelerations must lie within the accelerometer range "
            f"+-{ACCELEROMETER_RANGE:.4g} m/s^2, got peak {np.max(np.abs(arr)):.4g}"
        )
    return arr


def _specimen_mass(value: str | float) -> float:
    if isinstance(value, str):
        if value not in SPECIMENS:
            raise ValueError(f"specimen_mass = {value!r}; allowed {sorted(SPECIMENS)} or a mass in kg")
        return SPECIMENS[value]
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"specimen_mass must be a finite mass >= 0 kg, got {value}")
    return value


class ShakingTableBatch(PlantBatch):
    """Shaking-table acceleration-tracking episodes (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    refinement_bound = staticmethod(plant.local_mode_refinement)  # the kernels' m: counts in the sub-step cap
    params_cls = ShakingTableParams
    dt = DT
    episode_steps_default = EPISODE_STEPS
    obs_dim = OBS_DIM
    task_options = ("reference",)

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        preset: str = "modified_ifas",
        specimen_mass: str | float | None = None,
        reference: str = "mixed",
        position_quantization: float = POSITION_QUANTIZATION,
        position_noise_std: float = 0.0,
        acceleration_noise_std: float = 0.0,
        error_scale: float = 1.0,
        accel_scale: float = 10.0,
        velocity_scale: float = 0.5,
        action_rate_penalty: float = 0.01,
        position_penalty: float = 0.25,
        params: Mapping[str, float] | ShakingTableParams | None = None,
        **kwargs: Any,
    ) -> None:
        if reference not in TABLE_REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {TABLE_REFERENCE_KINDS + ('mixed',)}")
        check_nonnegative(
            position_quantization=position_quantization,
            position_noise_std=position_noise_std,
            acceleration_noise_std=acceleration_noise_std,
            action_rate_penalty=action_rate_penalty,
            position_penalty=position_penalty,
        )
        for name, value in (("error_scale", error_scale), ("accel_scale", accel_scale),
                            ("velocity_scale", velocity_scale)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        fixed_specimen = specimen_mass is not None
        base = ShakingTableParams.preset(preset)
        if isinstance(params, ShakingTableParams):
            base = params
        elif params:
            base = ShakingTableParams.from_mapping(params, base=base)
        if fixed_specimen:
            base = dataclasses.replace(base, specimen_mass=_specimen_mass(specimen_mass))
        super().__init__(n, parallel=parallel, params=base, **kwargs)
        if fixed_specimen and self.spec is not None:
            self.spec = dataclasses.replace(
                self.spec, entries=tuple(e for e in self.spec.entries if e.name != "specimen_mass")
            )
        self.reference_kind = reference
        self.quant = float(position_quantization)
        self.noise_std = np.array([position_noise_std, acceleration_noise_std], dtype=float)
        self.error_scale = float(error_scale)
        self.accel_scale = float(accel_scale)
        self.velocity_scale = float(velocity_scale)
        self.rate_pen = float(action_rate_penalty)
        self.pos_pen = float(position_penalty)
        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        self.REF = np.zeros((n, n_ref))
        self.REFI = np.zeros((n, 3))  # reference velocity, position - initial position, initial position
        self.NOISE = np.zeros((n, n_ref if self.noise_std.any() else 1, 2))
        self.meas = np.zeros((n, 3))
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        self.sos = butterworth_lowpass_sos(VELOCITY_FILTER["order"], VELOCITY_FILTER["cutoff_hz"], 1.0 / DT)
        self.ZI = np.zeros((n, self.sos.shape[0], 2))
        self.XPREV = np.zeros(n)
        self.VF = np.zeros(n)
        self.KOBS = np.full(n, -1, dtype=np.int64)
        space = self.observation_space()
        self.obs_low = space.low.astype(np.float64)
        self.obs_high = space.high.astype(np.float64)

    def observation_space(self) -> spaces.Box:
        return observation_space(self.error_scale, self.accel_scale, self.velocity_scale)

    def state_limits(self, p: ShakingTableParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        vmax = VELOCITY_FACTOR * plant.no_load_velocity(p)
        self.narrow(lim, "v", -vmax, vmax, f"{VELOCITY_FACTOR:g} x the no-load velocity")
        return lim

    def reset_task(self, i: int, rng: np.random.Generator, p: ShakingTableParams, options: Mapping[str, Any]) -> None:
        half = 0.5 * p.stroke
        y = plant.rest_state(p, rng.uniform(-INITIAL_POSITION_BAND, INITIAL_POSITION_BAND) * half)
        self.state_from_options(y, options)
        if not (-half <= y[plant.X] <= half):
            raise ValueError(
                f"options['state']['x'] = {y[plant.X]} m lies outside the stroke [{-half}, {half}] m "
                "(0 = mid-stroke)"
            )
        for name, j in (("pa", plant.PA), ("pb", plant.PB)):
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
            self.REF[i] = generate_table_reference(kind, rng, n_ref, DT, reference_limits(p))[0]
        else:
            arr = _check_reference_array(ref_opt)
            fill_reference(self.REF[i], arr, self.episode_steps, "m/s^2")
        self.REFI[i] = (0.0, 0.0, y[plant.X])
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 2)) * self.noise_std
        self.KOBS[i] = -1

    def apply_actions(self) -> None:
        np.multiply(self.last_a[:, 0], self.P[:, plant.I_UMAX], out=self.U[:, 0])  # action -> valve command [V]

    step_observe_kernels = {KERNELS.name: _step_observe_parallel}
    step_observe_applies_actions = True

    kernel_args_cls = ShakingTableArgs

    def kernel_constants(self) -> dict[str, Any]:
        return {"a_range": ACCELEROMETER_RANGE, "v_range": VELOCITY_RANGE}

    def observe(self) -> None:
        if self.parallel:
            self.observe_args().run(_observe_parallel)
        else:
            self.observe_args().run(_observe_block, 0, self.Y.shape[0])

    def channel_values(self, i: int) -> dict[str, float]:
        return {"u": float(self.U[i, 0]), "x": float(self.meas[i, 0]), "a": float(self.meas[i, 1])}

    def sensor_values(self, i: int) -> dict[str, float]:
        return {"x": float(self.meas[i, 0]), "a": float(self.meas[i, 1]), "v_est": float(self.meas[i, 2])}

    def render_sample(self, i: int) -> tuple[float, float]:
        return (float(self.REF[i, min(self.K[i], self.REF.shape[1] - 1)]), float(self.meas[i, 1]))

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        p = self.params[i]
        half = 0.5 * p.stroke
        # the trace shows reference and measured acceleration, +-accel_scale across the stroke
        h = np.asarray(history, dtype=float).reshape(-1, 2)
        h = half + half * np.clip(h / self.accel_scale, -1.0, 1.0)
        return render_cylinder(
            x=self.Y[i, plant.X] + half,
            reference=half + half * float(np.clip(self.render_sample(i)[0] / self.accel_scale, -1, 1)),
            stroke=p.stroke,
            p1=self.Y[i, plant.PA] / p.supply_pressure,
            p2=self.Y[i, plant.PB] / p.supply_pressure,
            valve=self.last_a[i, 0],
            history=h,
        )


class ShakingTableEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ShakingTableBatch

    def sensor_values(self) -> dict[str, float]:
        """Measured position [m], acceleration [m/s^2] and velocity estimate [m/s]."""
        return self._batch.sensor_values(0)


class ShakingTableVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ShakingTableBatch

    def sensor_values(self) -> dict[str, np.ndarray]:
        """Measured position, acceleration and velocity estimate of every copy (arrays)."""
        rows = [self._batch.sensor_values(i) for i in range(self.num_envs)]
        return {k: np.array([r[k] for r in rows]) for k in rows[0]}


# ------------------------------------------------------------------ friction-critical task
#: episode length of the low-frequency task [steps] (8 s: 4-8 reversals)
LOW_FREQUENCY_STEPS = 8000


class ShakingTableLowFrequencyBatch(ShakingTableBatch):
    """``hydro_envs/ShakingTableLowFrequency-v0``: the acceleration-tracking table on a
    low-frequency, low-velocity motion with reversals
    (:func:`~hydro_envs.envs.shaking_table.references.low_frequency_reference`: velocity sine of
    0.25-0.5 Hz, 5-25 mm/s peak, from rest). The reference's accelerations are below 0.08 m/s^2;
    at each reversal the seals stick and break away (003 eq (11) as the LuGre steady state,
    F_s = 1254 N on 850 kg), which puts acceleration spikes of the order of ``F_s / M`` into the
    table's motion: friction, not the oil column, decides the error. Observation, action and
    reward as ``ShakingTable-v0``; 8 s episodes; no domain option beyond the base env's."""

    episode_steps_default = LOW_FREQUENCY_STEPS

    def reset_task(self, i: int, rng: np.random.Generator, p: ShakingTableParams, options: Mapping[str, Any]) -> None:
        opts = dict(options)
        ref = opts.get("reference")
        if ref is None or ref == "low_frequency":
            opts["reference"] = low_frequency_reference(rng, self.REF.shape[1], DT)[0]
        super().reset_task(i, rng, p, opts)


class ShakingTableLowFrequencyEnv(ShakingTableEnv):
    __doc__ = ShakingTableLowFrequencyBatch.__doc__
    batch_cls = ShakingTableLowFrequencyBatch


class ShakingTableLowFrequencyVectorEnv(ShakingTableVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ShakingTableLowFrequencyBatch
