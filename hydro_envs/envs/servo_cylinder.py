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

import gymnasium as gym
import numba as nb
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hydro_envs.envs.references import REFERENCE_KINDS, generate_reference
from hydro_envs.envs.render import render_cylinder
from hydro_envs.params import ParameterError
from hydro_envs.plants import servo_cylinder as plant
from hydro_envs.plants.servo_cylinder import STATE_NAMES, ServoCylinderParams
from hydro_envs.randomization import RandomizationSpec, load_randomization
from hydro_envs.sim.kernels import SERVO_CYLINDER, step_batch_parallel, step_batch_serial
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, rk4_substeps

__all__ = ["ServoCylinderPositionEnv", "ServoCylinderPositionVectorEnv", "ServoCylinderBatch"]

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
    obs[i, c + 3] = last_a[i]
    # sensors saturate at their range: the observation never leaves observation_space
    for m in range(obs.shape[1]):
        obs[i, m] = min(max(obs[i, m], obs_low[m]), obs_high[m])
    e = (r - Y[i, plant.X]) / e_scale
    da = last_a[i] - prev_a[i]
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


class ServoCylinderBatch:
    """State of ``n`` independent servo-cylinder episodes, stepped by one kernel call.

    The single env is this batch with ``n = 1`` (serial kernel); the vector env uses the
    parallel kernel. Each copy draws its episode (parameters, reference, initial state,
    sensor noise) from its own ``np.random.Generator``, so copy ``i`` of a vector env reset
    with seed ``s`` reproduces a single env reset with seed ``s + i``.
    """

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        randomize: bool = True,
        randomization: str | RandomizationSpec | None = None,
        params: Mapping[str, float] | ServoCylinderParams | None = None,
        reference: str = "mixed",
        episode_steps: int = EPISODE_STEPS,
        position_quantization: float = 3e-5,
        position_noise_std: float = 0.0,
        pressure_noise_std: float = 0.0,
        error_scale: float = 0.01,
        action_rate_penalty: float = 0.01,
        safety: float = DEFAULT_SAFETY,
    ) -> None:
        if n < 1:
            raise ValueError(f"number of copies must be >= 1, got {n}")
        if reference not in REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
        for name, value in (
            ("position_quantization", position_quantization),
            ("position_noise_std", position_noise_std),
            ("pressure_noise_std", pressure_noise_std),
        ):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if not (math.isfinite(error_scale) and error_scale > 0.0):
            raise ValueError(f"error_scale must be > 0 m, got {error_scale}")
        if not (math.isfinite(action_rate_penalty) and action_rate_penalty >= 0.0):
            raise ValueError(f"action_rate_penalty must be >= 0, got {action_rate_penalty}")
        if int(episode_steps) < 1:
            raise ValueError(f"episode_steps must be >= 1, got {episode_steps}")
        if isinstance(params, ServoCylinderParams):
            self.base_params = params
        else:
            self.base_params = ServoCylinderParams.from_mapping(params or {})
        if randomize:
            self.spec = (
                randomization
                if isinstance(randomization, RandomizationSpec)
                else load_randomization(plant.PLANT, ServoCylinderParams, randomization)
            )
        else:
            self.spec = None
        self.n = n
        self.parallel = parallel
        self.reference_kind = reference
        self.episode_steps = int(episode_steps)
        self.quant = float(position_quantization)
        self.noise_std = (float(position_noise_std), float(pressure_noise_std), float(pressure_noise_std))
        self.error_scale = float(error_scale)
        self.rate_pen = float(action_rate_penalty)
        self.safety = float(safety)

        n_ref = self.episode_steps + max(PREVIEW_STEPS) + 1
        n_noise = n_ref if any(self.noise_std) else 1
        self.Y = np.zeros((n, plant.N_STATES))
        self.U = np.zeros((n, 1))
        self.P = np.tile(self.base_params.to_array(), (n, 1))
        self.W = np.zeros((n, 5, plant.N_STATES))
        self.clamps = np.zeros(n, dtype=np.int64)
        self.NSUB = np.full(n, self.substeps_for(self.base_params), dtype=np.int64)
        self.REF = np.zeros((n, n_ref))
        self.NOISE = np.zeros((n, n_noise, 3))
        self.K = np.zeros(n, dtype=np.int64)
        self.last_a = np.zeros(n)
        self.prev_a = np.zeros(n)
        self.obs = np.zeros((n, OBS_DIM))
        self.reward = np.zeros(n)
        self.meas = np.zeros((n, 3))
        self.preview = np.array(PREVIEW_STEPS, dtype=np.int64)
        space = observation_space(self.base_params.stroke, self.error_scale)
        self.obs_low = space.low.astype(np.float64)
        self.obs_high = space.high.astype(np.float64)
        self.params: list[ServoCylinderParams] = [self.base_params] * n
        self.rngs: list[np.random.Generator | None] = [None] * n

    def substeps_for(self, p: ServoCylinderParams) -> int:
        """RK4 sub-steps per env step for parameter set ``p`` (stiffness bound)."""
        return rk4_substeps(plant.stiffness_modes(p), DT, self.safety)[0]

    # ----------------------------------------------------------------- episodes
    def reset_copy(self, i: int, rng: np.random.Generator, options: Mapping[str, Any] | None) -> None:
        """Draw copy ``i``'s episode from ``rng`` and put it at step 0."""
        options = dict(options or {})
        unknown = set(options) - {"params", "state", "reference"}
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}; allowed: params, state, reference")
        p = self.spec.sample(rng, self.base_params) if self.spec is not None else self.base_params
        if options.get("params"):
            p = ServoCylinderParams.from_mapping(options["params"], base=p)
        self.params[i] = p
        self.NSUB[i] = self.substeps_for(p)
        self.P[i] = p.to_array()
        L = p.stroke
        lo, hi = REF_BAND[0] * L, REF_BAND[1] * L
        # initial rest state: piston in the middle half, chambers at the null pressure
        y = np.zeros(plant.N_STATES)
        y[plant.X] = rng.uniform(0.25 * L, 0.75 * L)
        y[plant.P1] = y[plant.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
        for name, value in (options.get("state") or {}).items():
            if name not in STATE_NAMES:
                raise ValueError(f"options['state'] has unknown state {name!r}; allowed {STATE_NAMES}")
            if not math.isfinite(float(value)):
                raise ValueError(f"options['state'][{name!r}] must be finite, got {value}")
            y[STATE_NAMES.index(name)] = float(value)
        if not (0.0 <= y[plant.X] <= L):
            raise ValueError(f"options['state']['x'] = {y[plant.X]} m lies outside the stroke [0, {L}] m")
        for name in ("p1", "p2"):
            if y[STATE_NAMES.index(name)] < p.pressure_floor:
                raise ValueError(
                    f"options['state'][{name!r}] = {y[STATE_NAMES.index(name)]} Pa is below the "
                    f"pressure floor {p.pressure_floor} Pa (pressures are absolute)"
                )
        self.Y[i] = y
        ref_opt = options.get("reference")
        n_ref = self.REF.shape[1]
        if ref_opt is None or isinstance(ref_opt, str):
            kind = self.reference_kind if ref_opt is None else ref_opt
            rate = REF_RATE_FRACTION * plant.no_load_velocity(p)
            self.REF[i] = generate_reference(kind, rng, n_ref, DT, lo, hi, rate)
        else:
            arr = _check_reference_array(ref_opt, L)
            m = min(arr.size, n_ref)
            self.REF[i, :m] = arr[:m]
            self.REF[i, m:] = arr[m - 1]
        if self.NOISE.shape[1] > 1:
            self.NOISE[i] = rng.standard_normal((self.NOISE.shape[1], 3)) * np.array(self.noise_std)
        self.K[i] = 0
        self.U[i] = 0.0
        self.last_a[i] = 0.0
        self.prev_a[i] = 0.0
        self.clamps[i] = 0
        self.W[i] = 0.0
        self.rngs[i] = rng

    def observe(self) -> None:
        (_observe_parallel if self.parallel else _observe_serial)(
            self.Y, self.P, self.REF, self.K, self.NOISE, self.last_a, self.prev_a, self.quant,
            self.error_scale, self.rate_pen, self.preview, self.obs_low, self.obs_high,
            self.obs, self.reward, self.meas,
        )

    def advance(self, actions: np.ndarray) -> None:
        """Apply ``actions`` (shape ``(n,)``, already checked and clipped) for one env step."""
        self.prev_a[:] = self.last_a
        self.last_a[:] = actions
        self.U[:, 0] = actions * self.P[:, plant.I_UMAX]
        kernel = step_batch_parallel if self.parallel else step_batch_serial
        kernel(SERVO_CYLINDER, self.Y, self.U, self.P, DT, self.NSUB, self.W, self.clamps)
        self.K += 1
        self.observe()

    def state_dict(self, i: int) -> dict[str, float]:
        return dict(zip(STATE_NAMES, self.Y[i].tolist()))

    def channel_values(self, i: int) -> dict[str, float]:
        return {
            "u": float(self.U[i, 0]),
            "x": float(self.meas[i, 0]),
            "p1": float(self.meas[i, 1]),
            "p2": float(self.meas[i, 2]),
        }


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


def _check_actions(action: Any, n: int) -> np.ndarray:
    """Validate and clip actions to ``(n,)`` float64; NaN/inf or a wrong shape raise."""
    arr = np.asarray(action, dtype=np.float64)
    if arr.size != n or (arr.ndim > 1 and arr.shape != (n, 1)) or (n == 1 and arr.ndim > 1):
        raise ValueError(f"action must have shape ({n}, 1) or ({n},) with values in [-1, 1], got shape {arr.shape}")
    arr = arr.reshape(n)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"action must be finite (allowed range [-1, 1]), got {arr[~np.isfinite(arr)][:4]}")
    return np.clip(arr, -1.0, 1.0)


class ServoCylinderPositionEnv(gym.Env):
    __doc__ = __doc__

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}; allowed {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self._batch = ServoCylinderBatch(1, parallel=False, **kwargs)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)
        self.observation_space = observation_space(self._batch.base_params.stroke, self._batch.error_scale)
        self.dt = DT
        self.plant_name = plant.PLANT
        self._params_info: dict[str, float] = {}
        self._history: list[tuple[float, float]] = []

    @property
    def params(self) -> ServoCylinderParams:
        return self._batch.params[0]

    @property
    def n_substeps(self) -> int:
        """RK4 sub-steps per env step for this episode's parameters."""
        return int(self._batch.NSUB[0])

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        b = self._batch
        b.reset_copy(0, self.np_random, options)
        b.observe()
        self._params_info = b.params[0].as_dict()
        self._history = [(b.REF[0, 0], b.Y[0, plant.X])]
        return b.obs[0].astype(np.float32), {"state": b.state_dict(0), "params": dict(self._params_info)}

    def step(self, action: Any):
        b = self._batch
        if b.rngs[0] is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        # fast path for the common (1,) float array; anything else goes through the checker
        if type(action) is np.ndarray and action.shape == (1,):
            a = float(action[0])
            if not math.isfinite(a):
                raise ValueError(f"action must be finite (allowed range [-1, 1]), got {a}")
            a = -1.0 if a < -1.0 else (1.0 if a > 1.0 else a)
        else:
            a = float(_check_actions(action, 1)[0])
        b.prev_a[0] = b.last_a[0]
        b.last_a[0] = a
        b.U[0, 0] = a * b.P[0, plant.I_UMAX]
        step_batch_serial(SERVO_CYLINDER, b.Y, b.U, b.P, DT, b.NSUB, b.W, b.clamps)
        b.K[0] += 1
        b.observe()
        if self.render_mode is not None:
            self._history.append((b.REF[0, min(b.K[0], b.REF.shape[1] - 1)], b.Y[0, plant.X]))
        info = {"state": dict(zip(STATE_NAMES, b.Y[0].tolist())), "params": dict(self._params_info)}
        return b.obs[0].astype(np.float32), float(b.reward[0]), False, False, info

    def channel_values(self) -> dict[str, float]:
        """Sensor outputs in SI units, keyed by the measured-data channel names."""
        return self._batch.channel_values(0)

    @property
    def guard_clamps(self) -> int:
        """How often the pressure floor had to clamp a chamber this episode."""
        return int(self._batch.clamps[0])

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        b = self._batch
        p = b.params[0]
        hist = np.array(self._history[-500:])
        return render_cylinder(
            x=b.Y[0, plant.X],
            reference=b.REF[0, min(b.K[0], b.REF.shape[1] - 1)],
            stroke=p.stroke,
            p1=b.Y[0, plant.P1] / p.supply_pressure,
            p2=b.Y[0, plant.P2] / p.supply_pressure,
            valve=b.last_a[0],
            history=hist,
        )


class ServoCylinderPositionVectorEnv(VectorEnv):
    """``num_envs`` servo-cylinder episodes stepped by one parallel kernel call.

    Gymnasium 1.x vector semantics: ``autoreset_mode`` NEXT_STEP (default; the step after a
    copy's episode ended resets it and returns its first observation with reward 0) or
    SAME_STEP (the ending copy is reset in the same step; its last observation is in
    ``info["final_obs"]`` under mask ``info["_final_obs"]``). Each copy is truncated after
    ``max_episode_steps``. ``info`` holds ``state`` and ``params`` as dicts of arrays.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int = EPISODE_STEPS,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode is not None:
            raise ValueError("the vector env does not render; use the single env with render_mode='rgb_array'")
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        if self.autoreset_mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode {self.autoreset_mode} not supported; use NEXT_STEP or SAME_STEP")
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode}
        self.num_envs = int(num_envs)
        self.max_episode_steps = int(max_episode_steps)
        kwargs.setdefault("episode_steps", self.max_episode_steps)
        self._batch = ServoCylinderBatch(self.num_envs, parallel=True, **kwargs)
        self.single_action_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)
        self.single_observation_space = observation_space(
            self._batch.base_params.stroke, self._batch.error_scale
        )
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.dt = DT
        self.plant_name = plant.PLANT
        self.render_mode = None
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._params_info: dict[str, np.ndarray] = {}
        self._reset_done = False

    @property
    def n_substeps(self) -> np.ndarray:
        """RK4 sub-steps per env step of every copy."""
        return self._batch.NSUB.copy()

    def _refresh_params_info(self) -> None:
        names = ServoCylinderParams.names()
        info = {}
        for j, name in enumerate(names):
            col = self._batch.P[:, j].copy()
            col.setflags(write=False)  # shared between steps until the next reset: read-only
            info[name] = col
        self._params_info = info

    def _state_info(self) -> dict[str, np.ndarray]:
        return {name: self._batch.Y[:, j].copy() for j, name in enumerate(STATE_NAMES)}

    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None):
        b = self._batch
        # Copy i seeded with seed + i, as SyncVectorEnv seeds its sub-envs: copy i then equals
        # a single env reset with seed + i. Without a seed, each copy continues its own stream.
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed list must have {self.num_envs} entries, got {len(seed)}")
            rngs = [seeding.np_random(s)[0] if s is not None else b.rngs[i] for i, s in enumerate(seed)]
        elif seed is not None:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
            rngs = [seeding.np_random(seed + i)[0] for i in range(self.num_envs)]
        else:
            rngs = list(b.rngs)
        for i in range(self.num_envs):
            if rngs[i] is None:  # never seeded: draw a seed from the OS entropy pool
                rngs[i] = seeding.np_random(None)[0]
        mask = None if options is None else options.get("reset_mask")
        opts = None if options is None else {k: v for k, v in options.items() if k != "reset_mask"}
        for i in range(self.num_envs):
            if mask is not None and not mask[i]:
                continue
            b.reset_copy(i, rngs[i], opts)
        b.observe()
        self._needs_reset[:] = False
        self._reset_done = True
        self._refresh_params_info()
        return b.obs.astype(np.float32), {"state": self._state_info(), "params": dict(self._params_info)}

    def step(self, actions: Any):
        if not self._reset_done:
            raise gym.error.ResetNeeded("call reset() before step()")
        b = self._batch
        a = _check_actions(actions, self.num_envs)
        b.advance(a)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = b.K >= self.max_episode_steps
        reward = b.reward.copy()
        info: dict[str, Any] = {}
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            redo = np.flatnonzero(self._needs_reset)
            if redo.size:
                for i in redo:
                    b.reset_copy(i, b.rngs[i], None)
                b.observe()
                reward[redo] = 0.0
                truncated[redo] = False
                self._refresh_params_info()
            self._needs_reset = terminated | truncated
            obs = b.obs.astype(np.float32)
            info["state"] = self._state_info()
        else:  # SAME_STEP
            done = np.flatnonzero(terminated | truncated)
            info["state"] = self._state_info()
            obs = b.obs.astype(np.float32)
            if done.size:
                final = np.zeros_like(obs)
                final[done] = obs[done]
                info["final_obs"] = final
                info["_final_obs"] = terminated | truncated
                for i in done:
                    b.reset_copy(i, b.rngs[i], None)
                b.observe()
                obs = b.obs.astype(np.float32)
                self._refresh_params_info()
        info["params"] = dict(self._params_info)
        return obs, reward, terminated, truncated, info

    def channel_values(self) -> dict[str, np.ndarray]:
        b = self._batch
        return {"u": b.U[:, 0].copy(), "x": b.meas[:, 0].copy(), "p1": b.meas[:, 1].copy(), "p2": b.meas[:, 2].copy()}
