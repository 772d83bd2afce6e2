r"""Velocity delivery with a load-sensing pump and the seed-000 flow compensator.

``hydro_envs/LoadSensing-v0``: an axial piston pump controlled by the hydro-mechanical flow
compensator of 000 (margin about 20 bar, 000 sec. 2 and Fig. 1) feeds one cylinder with a
heavy inertial load through a meter-in control valve CV. Plant physics:
:mod:`hydro_envs.plants.load_sensing` (every assumed pump, valve and load number is stated
there with its reason). The agent adds an electro-proportional force on the compensator spool
and corrects the CV opening so the cylinder delivers the demanded velocity while the margin
is kept and the load oscillations that heavy masses excite (000 sec. 2: LS systems "feature
poor behavior in damping high inertial loads") are damped.

**Action** ``Box(-1, 1, (2,), float32)``:

* ``a[0]``: solenoid force command ``a[0] * solenoid_force_max`` (+-20 N = +-5.2 bar of
  margin; positive adds to the spring); it reaches the spool through a 10 ms lag.
* ``a[1]``: CV correction; the CV area is ``clip(A_ff(v_d) + 0.5 a[1] cv_area_max, 0,
  cv_area_max)`` where ``A_ff(v_d)`` is the operator's lever: the area that passes
  ``A_c v_d`` at the *nominal* 20 bar margin (orifice law, nominal parameters -- the truth is
  randomised).

**Action (0, 0) is the classical baseline**: the hydro-mechanical compensator alone with the CV
set from the demand. It is stable at every randomisation corner and keeps the margin in
steady state (tested).

Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (12,))`` (``V = 0.2 m/s``, ``P = 25 MPa``, ``M = 20 bar``)::

    0   demanded velocity v_d / V          1   v_d in 50 ms / V      2   v_d in 200 ms / V
    3   measured velocity / V              4   (v_d - v_meas) / V
    5   p_s / P (absolute)                 6   p_l / P (absolute)
    7   (p_s - p_l - M) / M  (CV drop minus the nominal margin)
    8   A_ff(v_d) / cv_area_max            9-10  last action
    11  actuator position / stroke

**Reward** ``-((v_d - v)/V)^2 - margin_weight ((p_s - p_ls - M)/M)^2 - rate_penalty |a_k -
a_{k-1}|^2`` with true (noise-free) values after the step.

**Episode**: 1 kHz (``dt = 1 ms``), truncated after 2000 steps (2 s); no termination.

**Reset** draws the parameters from the plant's ``randomization.yaml`` (oil temperature
22-40 C, i.e. the compensator's viscous coefficient c = 3.5-9 N s/m of 000 Fig. 14, load mass,
load force, bulk modulus), a demand profile (``steps``, ``ramps`` or ``mixed``: 0.1-0.3 s at
rest, then one to three levels in 0.02-0.15 m/s, reached by steps or 50-300 ms ramps), and the
cylinder position (2-10 cm). The circuit is then settled for 0.1 s with the CV closed (pump at
standby: load pressure + margin), so every episode starts from rest. ``reset(options=...)``
accepts ``params``, ``state`` (applied after settling) and ``reference`` (a kind or an array of
demanded velocities [m/s], one per step, in [0, 0.2]).

**Info**: ``state`` (SI: ``x, v, p_s, p_x, y, vy, p_l, xa, va, q_ls, p_ls, f_sol``) and
``params``.

**Numerics**: 3 RK4 sub-steps per 1 ms step for the nominal plant and at every randomisation
corner (0.33 ms; :func:`hydro_envs.plants.load_sensing.stiffness_modes`: the control pistons'
oil spring, 6.0e3 1/s, sets the bound, then the LS line 5.0e3). A sub-step is taken as two
(:func:`hydro_envs.plants.load_sensing.model.local_mode_substeps`) where the FC spool is on its
seat or stop (9.9e3 1/s) or an orifice's drop is near zero at its start or at the Euler
prediction of its end (the delivery node 7.2e3 nominal, the control chamber 6.4e3):
:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`. Each reset settles the circuit for 0.1 s in
one kernel call (uniform sub-steps at the worst case, 5 per ms; about 0.6 ms).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numba as nb
import numpy as np
from gymnasium import spaces
from numba.experimental import structref

from hydro_envs.envs.base import VELOCITY_FACTOR, BatchedEnv, BatchedVectorEnv, PlantBatch, check_nonnegative, fill_reference
from hydro_envs.envs.kernel_args import BATCH_FIELDS, KernelArgs, KernelArgsType, define_kernel_args
from hydro_envs.jit import njit_noalloc
from hydro_envs.plants.load_sensing import model as plant
from hydro_envs.plants.load_sensing.kernels import KERNELS, step_serial
from hydro_envs.plants.load_sensing.params import LoadSensingParams
from hydro_envs.plants.load_sensing.spec import SPEC
from hydro_envs.sim.rk4 import n_blocks, step_block

__all__ = ["LoadSensingEnv", "LoadSensingVectorEnv", "LoadSensingBatch", "REFERENCE_KINDS", "generate_demand"]

DT = 1e-3
EPISODE_STEPS = 2000
PREVIEW_STEPS = (50, 200)
OBS_DIM = 12
V_SCALE = 0.2
P_SCALE = 25.0e6
V_MAX_DEMAND = 0.2
SETTLE_TIME = 0.1
REFERENCE_KINDS = ("steps", "ramps")


def generate_demand(kind: str, rng: np.random.Generator, n: int, dt: float) -> np.ndarray:
    """Demanded velocity [m/s] per step: rest for 0.1-0.3 s, then 1-3 levels in
    0.02-0.15 m/s (a level may return to 0), each reached by a step (``steps``) or a 50-300 ms
    ramp (``ramps``); ``mixed`` picks per transition."""
    if kind not in REFERENCE_KINDS + ("mixed",):
        raise ValueError(f"reference kind {kind!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
    out = np.zeros(n)
    t0 = min(int(rng.uniform(0.1, 0.3) / dt), n)  # episodes shorter than the rest: all rest
    n_levels = int(rng.integers(1, 4))
    bounds = np.sort(rng.uniform(t0, n, n_levels - 1).astype(int)) if n_levels > 1 else np.array([], dtype=int)
    starts = np.concatenate([[t0], bounds])
    level = 0.0
    for j, s in enumerate(starts):
        new = 0.0 if (j > 0 and rng.uniform() < 0.2) else rng.uniform(0.02, 0.15)
        k_ramp = kind == "ramps" or (kind == "mixed" and rng.uniform() < 0.5)
        ramp = int(rng.uniform(0.05, 0.3) / dt) if k_ramp else 0
        end = starts[j + 1] if j + 1 < len(starts) else n
        seg = np.full(end - s, new)
        if ramp > 0:
            r = min(ramp, end - s)
            seg[:r] = level + (new - level) * (np.arange(1, r + 1) / ramp)
        out[s:end] = seg
        level = new
    return out


@structref.register
class LoadSensingArgsType(KernelArgsType):
    """Numba type of :class:`LoadSensingArgs`."""


class LoadSensingArgs(KernelArgs):
    """The kernel unit of the load-sensing env: the batch's arrays, the velocity demand ``REF``
    and its feed-forward ``FF``, the pre-drawn sensor noise, the margin ``dpm`` and the reward's
    margin and action-rate weights, the preview offsets, the observation bounds and the sensors
    ``meas``."""

    fields = BATCH_FIELDS + ("REF", "FF", "NOISE", "meas", "dpm", "margin_weight", "rate_pen", "preview", "obs_low",
                             "obs_high")


define_kernel_args(LoadSensingArgs, LoadSensingArgsType)


# a call per block of copies, not inlined: the parallel kernels' loop bodies then keep its writes
# through the unit's arrays (numba's parfor passes would treat them as loop-local once inlined),
# and the unit's fields are read once per block, not once per copy
@nb.njit(cache=True, error_model="numpy")
def _observe_block(a, lo, hi):
    """Sensors, observation and reward of copies ``lo:hi``; ``a`` the batch's :class:`LoadSensingArgs`."""
    Y, P, REF, FF, K, NOISE, last_a, prev_a = a.Y, a.P, a.REF, a.FF, a.K, a.NOISE, a.last_a, a.prev_a
    dpm, m_weight, rate_pen, preview, obs_low, obs_high = a.dpm, a.margin_weight, a.rate_pen, a.preview, a.obs_low, a.obs_high
    obs, reward, meas = a.obs, a.reward, a.meas
    n_ref = REF.shape[1]
    for i in range(lo, hi):
        k = min(K[i], n_ref - 1)
        j = K[i] % NOISE.shape[1]
        vd = REF[i, k]
        va_m = Y[i, plant.VA] + NOISE[i, j, 0]
        ps_m = Y[i, plant.PS] + NOISE[i, j, 1]
        pl_m = Y[i, plant.PL] + NOISE[i, j, 2]
        pls_m = Y[i, plant.PLS] + NOISE[i, j, 2]
        meas[i, 0] = va_m
        meas[i, 1] = ps_m
        meas[i, 2] = pl_m
        meas[i, 3] = pls_m
        obs[i, 0] = vd / V_SCALE
        obs[i, 1] = REF[i, min(k + preview[0], n_ref - 1)] / V_SCALE
        obs[i, 2] = REF[i, min(k + preview[1], n_ref - 1)] / V_SCALE
        obs[i, 3] = va_m / V_SCALE
        obs[i, 4] = (vd - va_m) / V_SCALE
        obs[i, 5] = ps_m / P_SCALE
        obs[i, 6] = pl_m / P_SCALE
        obs[i, 7] = (ps_m - pl_m - dpm) / dpm
        obs[i, 8] = FF[i, k] / P[i, plant.I_ACVMAX]
        obs[i, 9] = last_a[i, 0]
        obs[i, 10] = last_a[i, 1]
        obs[i, 11] = Y[i, plant.XA] / P[i, plant.I_STROKE]
        for m in range(obs.shape[1]):
            obs[i, m] = min(max(obs[i, m], obs_low[m]), obs_high[m])
        e = (vd - Y[i, plant.VA]) / V_SCALE
        me = (Y[i, plant.PS] - Y[i, plant.PLS] - dpm) / dpm
        d0 = last_a[i, 0] - prev_a[i, 0]
        d1 = last_a[i, 1] - prev_a[i, 1]
        reward[i] = -(e * e) - m_weight * me * me - rate_pen * (d0 * d0 + d1 * d1)


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
def _apply(last_a, FF, K, P, U):
    n_ref = FF.shape[1]
    for i in range(U.shape[0]):
        amax = P[i, plant.I_ACVMAX]
        a_cv = FF[i, min(K[i], n_ref - 1)] + 0.5 * last_a[i, 1] * amax
        U[i, 0] = last_a[i, 0] * P[i, plant.I_FSMAX]
        U[i, 1] = min(max(a_cv, 0.0), amax)


def observation_space() -> spaces.Box:
    """Finite bounds = sensor ranges: demands in [0, 1] (0.2 m/s), measured velocity +-3 (the
    encoder-derived velocity saturates at +-0.6 m/s), pressures 0-1.2 of 25 MPa, CV drop minus
    margin within +-15 margins, position -0.1..1.1 of the stroke, actions in [-1, 1]."""
    low = np.array([0, 0, 0, -3, -4, 0, 0, -15, 0, -1, -1, -0.1], dtype=np.float32)
    high = np.array([1, 1, 1, 3, 4, 1.2, 1.2, 15, 1, 1, 1, 1.1], dtype=np.float32)
    return spaces.Box(low, high, dtype=np.float32)


class LoadSensingBatch(PlantBatch):
    """Load-sensing velocity-delivery episodes (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    refinement_bound = staticmethod(plant.local_mode_refinement)  # the kernels' m: counts in the sub-step cap
    params_cls = LoadSensingParams
    dt = DT
    episode_steps_default = EPISODE_STEPS
    action_dim = 2
    n_inputs = 2
    obs_dim = OBS_DIM
    task_options = ("reference",)
    state_limit_parameters = {"x": "spool_stroke", "y": "control_stroke"}

    def state_limits(self, p: LoadSensingParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        q = p.pump_displacement * p.pump_speed
        vmax = VELOCITY_FACTOR * q / p.piston_area
        self.narrow(lim, "va", -vmax, vmax, f"{VELOCITY_FACTOR:g} x the full pump flow's piston speed")
        self.narrow(lim, "q_ls", -q, q, "at most the full pump flow")
        self.narrow(lim, "f_sol", 0.0, p.solenoid_force_max, "solenoid force within [0, solenoid_force_max]")
        self.narrow(lim, "xa", 0.0, p.stroke, "the piston's stroke [0, stroke]")
        for name in ("p_s", "p_x", "p_l", "p_ls"):
            self.narrow(lim, name, p.pressure_floor, lim[name][1], "absolute pressure above the pressure floor")
        return lim

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        reference: str = "mixed",
        velocity_noise_std: float = 0.0,
        pressure_noise_std: float = 0.0,
        margin_weight: float = 0.05,
        action_rate_penalty: float = 0.01,
        **kwargs: Any,
    ) -> None:
        if reference not in REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
        check_nonnegative(velocity_noise_std=velocity_noise_std, pressure_noise_std=pressure_noise_std,
                          margin_weight=margin_weight, action_rate_penalty=action_rate_penalty)
        super().__init__(n, parallel=parallel, **kwargs)
        self.reference_kind = reference
        self.noise_std = np.array([velocity_noise_std, pressure_noise_std, pressure_noise_std])
        self.margin_weight = float(margin_weight)
        self.rate_pen = float(action_rate_penalty)
        self.dpm = plant.margin(self.base_params)
        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        self.REF = np.zeros((n, n_ref))
        self.FF = np.zeros((n, n_ref))
        self.NOISE = np.zeros((n, n_ref if self.noise_std.any() else 1, 3))
        self.meas = np.zeros((n, 4))
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        space = self.observation_space()
        self.obs_low = space.low.astype(np.float64)
        self.obs_high = space.high.astype(np.float64)
        # CV feed-forward from the nominal plant: area per m/s of demand at the nominal margin
        bp = self.base_params
        self._ff_gain = bp.piston_area / (bp.discharge_coefficient * math.sqrt(2.0 * self.dpm / bp.oil_density))

    def observation_space(self) -> spaces.Box:
        return observation_space()

    def reset_task(self, i: int, rng: np.random.Generator, p: LoadSensingParams, options: Mapping[str, Any]) -> None:
        xa0 = min(rng.uniform(0.02, 0.10), 0.5 * p.stroke)  # 20-100 mm in, mid-stroke on a short one
        self.Y[i] = plant.standby_state(p, xa0)
        # settle at standby (CV closed, no force) so the episode starts from rest
        n_settle = int(round(SETTLE_TIME / DT))
        SPEC.kernels.step_serial(self.Y[i : i + 1], np.zeros((1, 2)), self.P[i : i + 1], SETTLE_TIME,
                                 self.NSUB[i : i + 1] * n_settle, self.W[i : i + 1], np.zeros(1, dtype=np.int64))
        self.Y[i, plant.XA] = xa0
        self.Y[i, plant.VA] = 0.0
        self.state_from_options(self.Y[i], options)
        if not (0.0 <= self.Y[i, plant.XA] <= p.stroke):
            raise ValueError(f"options['state']['xa'] = {self.Y[i, plant.XA]} m lies outside the stroke [0, {p.stroke}] m")
        for name, j in (("p_s", plant.PS), ("p_x", plant.PX), ("p_l", plant.PL), ("p_ls", plant.PLS)):
            if self.Y[i, j] < p.pressure_floor:
                raise ValueError(f"options['state'][{name!r}] = {self.Y[i, j]} Pa is below the pressure floor "
                                 f"{p.pressure_floor} Pa (pressures are absolute)")
        ref_opt = options.get("reference")
        n_ref = self.REF.shape[1]
        if ref_opt is None or isinstance(ref_opt, str):
            kind = self.reference_kind if ref_opt is None else ref_opt
            self.REF[i] = generate_demand(kind, rng, n_ref, DT)
        else:
            arr = np.asarray(ref_opt, dtype=np.float64)
            if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise ValueError("options['reference'] must be a non-empty 1-D array of finite velocities [m/s]")
            if arr.min() < 0.0 or arr.max() > V_MAX_DEMAND:
                raise ValueError(f"options['reference'] velocities must lie in [0, {V_MAX_DEMAND}] m/s, got "
                                 f"[{arr.min():g}, {arr.max():g}]")
            fill_reference(self.REF[i], arr, self.episode_steps, "m/s")
        self.FF[i] = np.minimum(self._ff_gain * self.REF[i], self.base_params.cv_area_max)
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 3)) * self.noise_std

    def apply_actions(self) -> None:
        _apply(self.last_a, self.FF, self.K, self.P, self.U)

    step_observe_kernels = {KERNELS.name: _step_observe_parallel}

    kernel_args_cls = LoadSensingArgs

    def observe(self) -> None:
        self.observe_args().run(_observe_block, 0, self.Y.shape[0])

    def channel_values(self, i: int) -> dict[str, float]:
        return {
            "f_sol": float(self.U[i, 0]),
            "a_cv": float(self.U[i, 1]),
            "p_s": float(self.meas[i, 1]),
            "p_l": float(self.meas[i, 2]),
            "p_ls": float(self.meas[i, 3]),
            "xa": float(self.Y[i, plant.XA]),
            "va": float(self.meas[i, 0]),
        }

    def render_sample(self, i: int) -> tuple[float, float, float]:
        k = min(self.K[i], self.REF.shape[1] - 1)
        return (float(self.REF[i, k]), float(self.Y[i, plant.VA]),
                float((self.Y[i, plant.PS] - self.Y[i, plant.PLS]) / self.dpm))

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        return render_traces(history)


def render_traces(history: np.ndarray, width: int = 480, height: int = 320) -> np.ndarray:
    """Frame with demanded (red) and actual (black) velocity on top, the margin ratio
    (p_s - p_ls)/20 bar (blue, 0-2) below."""
    img = np.full((height, width, 3), 255, dtype=np.uint8)
    left, right = 20, width - 20
    panels = ((15, height // 2 - 10, 0.0, 0.25), (height // 2 + 10, height - 15, 0.0, 2.0))
    for top, bot, _, _ in panels:
        img[top, left:right] = 200
        img[bot, left:right] = 200
    if history.size == 0:
        return img
    h = np.atleast_2d(history)
    n = h.shape[0]
    xs = np.linspace(left, right - 1, max(n, 2))[:n].round().astype(int)

    def plot(vals, top, bot, lo, hi, color):
        ys = (bot - np.clip((vals - lo) / (hi - lo), 0.0, 1.0) * (bot - top)).round().astype(int)
        if n >= 2:
            t = np.linspace(0, n - 1, 4 * n)
            px = np.interp(t, np.arange(n), xs).round().astype(int)
            py = np.interp(t, np.arange(n), ys).round().astype(int)
        else:
            px, py = xs, ys
        img[np.clip(py, 0, height - 1), np.clip(px, 0, width - 1)] = color

    top, bot, lo, hi = panels[0]
    plot(h[:, 0], top, bot, lo, hi, (220, 30, 30))
    plot(h[:, 1], top, bot, lo, hi, (0, 0, 0))
    top, bot, lo, hi = panels[1]
    plot(h[:, 2], top, bot, lo, hi, (30, 60, 220))
    return img


class LoadSensingEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = LoadSensingBatch


class LoadSensingVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = LoadSensingBatch
