"""``hydro_envs/ForceActuator-v0``: force tracking with the seed-001 high-bandwidth actuator.

Plant: :mod:`hydro_envs.plants.force_actuator` (jet-pipe valve with hysteresis, valve and
fluid dynamics of eqs (7)-(8), force sensor eqs (2)-(4), seal friction eq (1) as the Dahl case of the seal-friction family with the
stiction levels of Table 2,
hydraulic damping eq (5)), piston locked to the mount (blocked force) unless
``reset(options={"params": {"piston_locked": 0}})``.

**Action** ``Box(-1, 1, (1,), float32)``: valve current as a fraction of the driver range
``current_max`` (45 mA; the current for full jet deflection is ``rated_current`` = 37.5 mA).
Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (8,))`` (forces normalised by the maximum thrust
``A1 p_s = 1340 N``)::

    0     measured force: F_s = k_s x_s (eq (3)) through the feedback conditioning filter
          (``feedback_filter_frequency``), plus optional noise; clipped to [-2, 2]
    1     reference r
    2-6   reference preview at +1, +2, +5, +10, +25 steps (0.2 ... 5 ms)
    7     last action

**Reward** ``-((r - F_s) / error_scale)^2 - action_rate_penalty (a_k - a_{k-1})^2`` with the
true (unfiltered, noise-free) force ``F_s = k_s x_s`` after the step; ``error_scale`` = 100 N.

**Controller delay**: the valve current of an action is applied ``control_delay`` (whole
control periods) after the step that chose it, as a digital controller's computation delay;
observation 7 (last action) is then the command still pending.

**Episode**: 5 kHz control (``dt = 0.2 ms``, the identification rate of 001 sec. 4.5),
truncated after 5000 steps (1 s) by the registered ``max_episode_steps``; no termination.

**References** (``reference=`` kind, or ``options={"reference": kind | array [N]}``):
``square`` (001 figs. 11-13: amplitude 50, 200 or 800 N, 2-20 Hz), ``sine`` (10-800 N,
1-150 Hz, log-uniform), ``chirp`` (1 -> 150 Hz), ``steps`` (levels held 20-200 ms),
``mixed`` (one of them per episode). All stay inside 85 % of the blocked-force range
``[-A2 p_s, A1 p_s]``.

**Info** at every step: ``state`` (the 25 plant states in SI / normalised units, see the plant
module) and ``params`` (this episode's parameter set).

**Numerics**: one compiled kernel call per step; RK4 sub-steps from the drawn parameters'
stiffness bound (:func:`hydro_envs.plants.force_actuator.stiffness_modes`): 2 for the nominal
plant (h = 100 us), set by the fluid resonance; a sub-step along which the seals' bristle state
is stiff (at speed, or across a velocity reversal) is redone in 3 finer ones.

Closed-loop proportional force control of the plant (001 sec. 4.7: bandwidth, limit cycle) is in
:mod:`hydro_envs.plants.force_actuator.closed_loop`.

``hydro_envs/ForceActuatorSmallForce-v0`` (:class:`ForceActuatorSmallForceBatch`) is the
plant's friction-critical task (:mod:`hydro_envs.envs.friction_tasks`): small forces (10-60 N
sines / triangles through zero, smoothed steps) on the free piston pushing the environment
spring of :data:`SMALL_FORCE_RIG`, where the seals' stiction (Table 2) makes most of a PID's
error; same action, observation and reward (error scale 10 N), 1 s episodes.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numba as nb
import numpy as np
from gymnasium import spaces
from numba.experimental import structref

from hydro_envs.envs.base import BatchedEnv, BatchedVectorEnv, PlantBatch, check_nonnegative, fill_reference
from hydro_envs.envs.friction_tasks import (
    SMALL_FORCE_KINDS, SMALL_FORCE_STEPS, SmallForceReference, generate_small_force_reference,
)
from hydro_envs.envs.kernel_args import BATCH_FIELDS, KernelArgs, KernelArgsType, define_kernel_args
from hydro_envs.envs.render import render_cylinder
from hydro_envs.jit import njit_noalloc
from hydro_envs.params import ParameterError
from hydro_envs.plants.force_actuator import model as plant
from hydro_envs.plants.force_actuator.kernels import KERNELS, step_serial
from hydro_envs.plants.force_actuator.params import ForceActuatorParams
from hydro_envs.plants.force_actuator.spec import SPEC
from hydro_envs.sim.rk4 import n_blocks, step_block

__all__ = [
    "ForceActuatorEnv",
    "ForceActuatorVectorEnv",
    "ForceActuatorBatch",
    "ForceActuatorSmallForceEnv",
    "ForceActuatorSmallForceVectorEnv",
    "ForceActuatorSmallForceBatch",
    "SMALL_FORCE_RIG",
    "FORCE_REFERENCE_KINDS",
    "generate_force_reference",
]

DT = 2e-4
EPISODE_STEPS = 5000
PREVIEW_STEPS = (1, 2, 5, 10, 25)
OBS_DIM = 3 + len(PREVIEW_STEPS)
REF_FRACTION = 0.85
FORCE_REFERENCE_KINDS = ("square", "sine", "chirp", "steps")
SQUARE_AMPLITUDES = (50.0, 200.0, 800.0)  # 001 figs. 11-13
#: longest controller delay the env buffers (the parameter's range: 0-10 ms)
MAX_DELAY_STEPS = 50


def delay_steps(control_delay: float) -> int:
    """Whole control periods of the controller's computation delay (``control_delay`` [s])."""
    return min(int(round(control_delay / DT)), MAX_DELAY_STEPS)


def generate_force_reference(kind: str, rng: np.random.Generator, n: int, dt: float, low: float, high: float) -> np.ndarray:
    """Force reference [N] of ``n`` samples inside ``[low, high]`` (see the module doc)."""
    if kind == "mixed":
        kind = FORCE_REFERENCE_KINDS[int(rng.integers(len(FORCE_REFERENCE_KINDS)))]
    if not (high > low and n > 0 and dt > 0):
        raise ValueError(f"reference needs high > low, n > 0, dt > 0; got {low}, {high}, {n}, {dt}")
    t = dt * np.arange(n)
    half = 0.5 * (high - low)

    def centred(amp: float) -> tuple[float, float]:
        amp = min(amp, half)
        return amp, rng.uniform(low + amp, high - amp)

    if kind == "square":
        amp, mid = centred(float(rng.choice(SQUARE_AMPLITUDES)))
        f = rng.uniform(2.0, 20.0)
        phase = rng.uniform(0.0, 1.0)
        return mid + amp * np.where(((f * t + phase) % 1.0) < 0.5, 1.0, -1.0)
    if kind == "sine":
        amp, mid = centred(math.exp(rng.uniform(math.log(10.0), math.log(800.0))))
        f = math.exp(rng.uniform(math.log(1.0), math.log(150.0)))
        return mid + amp * np.sin(2.0 * math.pi * f * t + rng.uniform(0.0, 2.0 * math.pi))
    if kind == "chirp":
        amp, mid = centred(rng.uniform(50.0, 400.0))
        f0, f1 = 1.0, 150.0
        duration = max(t[-1], dt)
        return mid + amp * np.sin(2.0 * math.pi * (f0 * t + 0.5 * (f1 - f0) / duration * t**2))
    if kind == "steps":
        out = np.empty(n)
        k = 0
        while k < n:
            hold = max(1, int(round(rng.uniform(0.02, 0.2) / dt)))
            out[k : k + hold] = rng.uniform(low, high)
            k += hold
        return out
    raise ValueError(f"unknown reference kind {kind!r}; allowed: {FORCE_REFERENCE_KINDS + ('mixed',)}")


@structref.register
class ForceTrackingArgsType(KernelArgsType):
    """Numba type of :class:`ForceTrackingArgs`."""


class ForceTrackingArgs(KernelArgs):
    """The kernel unit of the force-tracking envs: the batch's arrays, the reference and
    pre-drawn force-sensor noise, the error scale, the action-rate penalty, the preview offsets
    and the sensed force ``meas``."""

    fields = BATCH_FIELDS + ("REF", "NOISE", "meas", "error_scale", "rate_pen", "preview")


define_kernel_args(ForceTrackingArgs, ForceTrackingArgsType)


# a call per block of copies, not inlined: the parallel kernels' loop bodies then keep its writes
# through the unit's arrays (numba's parfor passes would treat them as loop-local once inlined),
# and the unit's fields are read once per block, not once per copy
@nb.njit(cache=True, error_model="numpy")
def _observe_block(a, lo, hi):
    """Sensed force, observation and reward of copies ``lo:hi``; ``a`` the batch's :class:`ForceTrackingArgs`."""
    Y, P, REF, K, NOISE, last_a, prev_a = a.Y, a.P, a.REF, a.K, a.NOISE, a.last_a, a.prev_a
    e_scale, rate_pen, preview, obs, reward, meas = a.error_scale, a.rate_pen, a.preview, a.obs, a.reward, a.meas
    n_ref = REF.shape[1]
    for i in range(lo, hi):
        k = K[i]
        fmax = P[i, plant.I_A1] * P[i, plant.I_PS]
        f_true = P[i, plant.I_KS] * Y[i, plant.XS]
        f_m = plant.measured_force(Y[i], P[i]) + NOISE[i, k % NOISE.shape[1]]
        meas[i] = f_m
        r = REF[i, min(k, n_ref - 1)]
        obs[i, 0] = min(max(f_m / fmax, -2.0), 2.0)
        obs[i, 1] = r / fmax
        for m in range(preview.shape[0]):
            obs[i, 2 + m] = REF[i, min(k + preview[m], n_ref - 1)] / fmax
        obs[i, 2 + preview.shape[0]] = last_a[i, 0]
        e = (r - f_true) / e_scale
        da = last_a[i, 0] - prev_a[i, 0]
        reward[i] = -(e * e) - rate_pen * da * da


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel(a):
    """One env step of every copy in one parallel region: each block of copies is stepped by the
    plant's serial step, its step counts advanced, and observed."""
    Y, U, P, dt, NSUB, W, clamps, K = a.Y, a.U, a.P, a.dt, a.NSUB, a.W, a.clamps, a.K
    for c in nb.prange(n_blocks(Y.shape[0])):
        lo, hi = step_block(step_serial, c, Y, U, P, dt, NSUB, W, clamps)
        for i in range(lo, hi):
            K[i] += 1
        _observe_block(a, lo, hi)


@njit_noalloc
def _apply_delayed(last_a, P, pending, head, n_delay, U):
    """Action in [-1, 1] -> valve current [A] into the ring buffer ``pending`` at column ``head``;
    the current applied now, ``U[:, 0]``, is the one computed ``n_delay`` steps ago."""
    slots = pending.shape[1]
    for i in range(U.shape[0]):
        pending[i, head] = last_a[i, 0] * P[i, plant.I_IMAX]
        k = head - n_delay[i]
        U[i, 0] = pending[i, k + slots if k < 0 else k]


def observation_space() -> spaces.Box:
    """Sensed force within twice the thrust (sensor range), reference and action in [-1, 1]."""
    low = np.full(OBS_DIM, -1.0, dtype=np.float32)
    high = np.full(OBS_DIM, 1.0, dtype=np.float32)
    low[0], high[0] = -2.0, 2.0
    return spaces.Box(low, high, dtype=np.float32)


class ForceActuatorBatch(PlantBatch):
    """Force-tracking episodes of the seed-001 actuator (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    refinement_bound = staticmethod(plant.dahl_friction_refinement)  # the kernels' m: counts in the sub-step cap
    params_cls = ForceActuatorParams
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
        force_noise_std: float = 0.0,
        error_scale: float = 100.0,
        action_rate_penalty: float = 0.01,
        **kwargs: Any,
    ) -> None:
        if reference not in FORCE_REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {FORCE_REFERENCE_KINDS + ('mixed',)}")
        check_nonnegative(force_noise_std=force_noise_std, action_rate_penalty=action_rate_penalty)
        if not (math.isfinite(error_scale) and error_scale > 0.0):
            raise ValueError(f"error_scale must be > 0 N, got {error_scale}")
        super().__init__(n, parallel=parallel, **kwargs)
        self.reference_kind = reference
        self.noise_std = float(force_noise_std)
        self.error_scale = float(error_scale)
        self.rate_pen = float(action_rate_penalty)
        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        self.REF = np.zeros((n, n_ref))
        self.NOISE = np.zeros((n, n_ref if self.noise_std > 0 else 1))
        self.meas = np.zeros(n)
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        # computation delay of the digital controller: commands wait here control_delay / dt steps
        # (a ring buffer: the newest command in column ``head``, the one of k steps ago in head - k)
        self.n_delay = np.zeros(n, dtype=np.int64)
        self.pending = np.zeros((n, MAX_DELAY_STEPS + 1))
        self.head = 0

    def observation_space(self) -> spaces.Box:
        return observation_space()

    #: realisation states of the transport delay and the fluid resonances: no physical meaning
    fixed_states = ("fa", "fb", "fc", "r1", "r2", "r3", "r4", "r5", "r6")

    def state_limits(self, p: ForceActuatorParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        # the relative velocity vp + vs within the bound the friction's fine sub-steps are sized for
        vmax = plant.velocity_bound(p)
        for name in ("vs", "vp"):
            self.narrow(lim, name, -0.5 * vmax, 0.5 * vmax,
                        "half the relative-velocity bound of the friction's fine sub-steps")
        self.narrow(lim, "vf", -vmax, vmax, "the relative-velocity bound of the friction's fine sub-steps")
        xs = lim["fa"][1] / p.sensor_stiffness
        self.narrow(lim, "xs", -xs, xs, "sensor deflection at most the largest force / sensor_stiffness")
        g = max(p.coulomb_friction, p.stiction_retract, p.stiction_extend)
        zb = g / p.friction_stiffness if g > 0.0 else 0.0
        self.narrow(lim, "z", -zb, zb, "bristle deflection at most the largest static level / sigma0 (the guard's bound)")
        return lim

    def reset_task(self, i: int, rng: np.random.Generator, p: ForceActuatorParams, options: Mapping[str, Any]) -> None:
        y = plant.rest_state(p)
        self.state_from_options(y, options)
        q = y[plant.XP] + y[plant.XS]
        if not (0.0 <= q <= p.stroke):
            raise ValueError(f"options['state']: piston extension xp + xs = {q} m lies outside the stroke [0, {p.stroke}] m")
        self.Y[i] = y
        self.n_delay[i] = delay_steps(p.control_delay)
        self.pending[i] = 0.0
        n_ref = self.REF.shape[1]
        low, high = REF_FRACTION * p.min_thrust, REF_FRACTION * p.max_thrust
        ref_opt = options.get("reference")
        if ref_opt is None or isinstance(ref_opt, str):
            kind = self.reference_kind if ref_opt is None else ref_opt
            self.REF[i] = generate_force_reference(kind, rng, n_ref, DT, low, high)
        else:
            arr = np.asarray(ref_opt, dtype=np.float64)
            if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise ValueError("options['reference'] must be a non-empty 1-D array of finite forces [N]")
            if arr.min() < p.min_thrust or arr.max() > p.max_thrust:
                raise ValueError(
                    f"options['reference'] must lie inside the blocked-force range [{p.min_thrust:.0f}, "
                    f"{p.max_thrust:.0f}] N, got [{arr.min():g}, {arr.max():g}]"
                )
            fill_reference(self.REF[i], arr, self.episode_steps, "N")
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal(self.NOISE.shape[1]) * self.noise_std

    def apply_actions(self) -> None:
        self.head = (self.head + 1) % self.pending.shape[1]
        _apply_delayed(self.last_a, self.P, self.pending, self.head, self.n_delay, self.U)

    step_observe_kernels = {KERNELS.name: _step_observe_parallel}

    kernel_args_cls = ForceTrackingArgs

    def observe(self) -> None:
        self.observe_args().run(_observe_block, 0, self.Y.shape[0])

    def channel_values(self, i: int) -> dict[str, float]:
        return {"i": float(self.U[i, 0]), "f": float(self.meas[i])}

    def render_sample(self, i: int) -> tuple[float, float]:
        fmax = self.params[i].max_thrust
        return (
            float(self.REF[i, min(self.K[i], self.REF.shape[1] - 1)]) / fmax,
            float(self.P[i, plant.I_KS] * self.Y[i, plant.XS]) / fmax,
        )

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        # forces drawn on a [-1, 1] x max-thrust axis mapped onto the sketch's stroke
        ref, f = self.render_sample(i)
        hist = (np.asarray(history) + 1.0) if np.size(history) else np.zeros((0, 2))
        p = self.params[i]
        _, xv = plant.valve_position(self.Y[i], self.P[i])
        xi = min(max(xv + p.valve_offset, -1.0), 1.0)
        return render_cylinder(
            x=f + 1.0,
            reference=ref + 1.0,
            stroke=2.0,
            p1=(1 + xi) ** 2 / (2 * (1 + xi * xi)),
            p2=(1 - xi) ** 2 / (2 * (1 + xi * xi)),
            valve=self.last_a[i, 0],
            history=hist,
        )


class ForceActuatorEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ForceActuatorBatch


class ForceActuatorVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ForceActuatorBatch


#: The small-force task's rig: the free piston pushing a compliant environment (a spring at the
#: rod, relaxed at mid-stroke). 001 sec. 2: "force control resolution is limited by the residual
#: solid friction forces as seen at the piston rod"; sec. 4.4 frees the piston, sec. 6 aims at
#: contact and impedance tasks. Assumed: 2e5 N/m (60 N = 0.3 mm of travel, a few pre-sliding
#: lengths), so every force reversal moves the piston through its seals' stiction.
SMALL_FORCE_RIG = {"piston_locked": 0.0, "load_stiffness": 2.0e5}


class ForceActuatorSmallForceBatch(ForceActuatorBatch):
    """``hydro_envs/ForceActuatorSmallForce-v0``: small-force tracking against the seals'
    stiction (:mod:`hydro_envs.envs.friction_tasks`): the free piston against the environment
    spring of :data:`SMALL_FORCE_RIG` (parameters given to the env or a reset override it),
    references of :func:`~hydro_envs.envs.friction_tasks.generate_small_force_reference`
    (``small`` = a sine, triangle or steps per episode), 1 s episodes, error scale 10 N."""

    episode_steps_default = SMALL_FORCE_STEPS

    def __init__(self, n: int, *, parallel: bool, reference: str = "small", params: Any = None,
                 error_scale: float = 10.0, ranges: SmallForceReference | None = None, **kwargs: Any) -> None:
        if reference not in SMALL_FORCE_KINDS + ("small",):
            raise ValueError(f"reference = {reference!r}; allowed {SMALL_FORCE_KINDS + ('small',)}")
        if not isinstance(params, ForceActuatorParams):
            params = {**SMALL_FORCE_RIG, **dict(params or {})}
        super().__init__(n, parallel=parallel, reference="mixed", params=params, error_scale=error_scale, **kwargs)
        self.small_kind = reference
        self.small_ranges = ranges or SmallForceReference()

    def reset_task(self, i: int, rng: np.random.Generator, p: ForceActuatorParams, options: Mapping[str, Any]) -> None:
        ref = options.get("reference")
        if ref is None or (isinstance(ref, str) and ref in SMALL_FORCE_KINDS + ("small",)):
            reach = self.small_ranges.amplitude[1]
            if min(-p.min_thrust, p.max_thrust) * REF_FRACTION < reach:
                raise ParameterError(
                    f"ForceActuatorSmallForce: supply_pressure = {p.supply_pressure:g} Pa (bore_area "
                    f"{p.bore_area:g}, rod_area {p.rod_area:g} m^2) gives the blocked-force range "
                    f"[{p.min_thrust:.4g}, {p.max_thrust:.4g}] N; the task's references reach +-{reach:g} N "
                    f"within {REF_FRACTION:.0%} of it")
            kind = self.small_kind if ref is None else ref
            arr = generate_small_force_reference(kind, rng, self.REF.shape[1], DT, self.small_ranges)
            options = {**options, "reference": arr}
        super().reset_task(i, rng, p, options)


class ForceActuatorSmallForceEnv(BatchedEnv):
    __doc__ = ForceActuatorSmallForceBatch.__doc__
    batch_cls = ForceActuatorSmallForceBatch


class ForceActuatorSmallForceVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ForceActuatorSmallForceBatch
