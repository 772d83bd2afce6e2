"""Generic batched environments: one compiled kernel call steps every copy.

A task (servo position tracking, table acceleration tracking, ...) subclasses
:class:`PlantBatch` and implements only what is specific to it: the action-to-input map, the
episode draw (initial state, reference, sensor noise), the observation/reward kernel, the
spaces and the sensor channels. Everything else lives here once:

* parameters: nominal set, declarative randomisation (the plant's ``randomization.yaml``),
  ``reset(options={"params": ...})`` overrides, per-copy RK4 sub-steps from the plant's
  stiffness bound;
* seeding: every copy draws from its own ``np.random.Generator``; a vector env reset with seed
  ``s`` seeds copy ``i`` with ``s + i`` (as ``SyncVectorEnv`` does), so copy ``i`` reproduces
  a single env reset with seed ``s + i`` bit for bit;
* stepping: the plant's compiled ``step_serial`` for the single env (entering a parallel
  region costs more than a whole env step), ``step_parallel`` for vector envs;
* :class:`BatchedEnv` (a ``gymnasium.Env`` that is a view on a batch of one) and
  :class:`BatchedVectorEnv` (a ``gymnasium.vector.VectorEnv`` with NEXT_STEP or SAME_STEP
  autoreset and per-copy truncation).
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any, ClassVar, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hydro_envs.params import PhysicalParams
from hydro_envs.randomization import RandomizationSpec, load_randomization
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, substeps_from_stiffness
from hydro_envs.spec import PlantSpec

__all__ = ["PlantBatch", "BatchedEnv", "BatchedVectorEnv", "check_actions", "check_nonnegative"]


def check_nonnegative(**values: float) -> None:
    """Raise ``ValueError`` naming the first argument that is negative or not finite."""
    for name, value in values.items():
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {value}")


def check_actions(action: Any, n: int, dim: int) -> np.ndarray:
    """Validate actions for ``n`` copies of a ``dim``-dimensional Box(-1, 1); clip; return
    ``(n, dim)`` float64. Real numbers (float or integer arrays, lists, scalars) are
    accepted; NaN/inf, a wrong shape or anything that is not real numbers (strings, None,
    booleans, complex, objects, ragged lists) raise ``ValueError``."""
    try:
        raw = np.asarray(action)
    except (ValueError, TypeError) as exc:  # e.g. a ragged nested list
        raise ValueError(f"action must be an array of real numbers in [-1, 1], got {action!r} ({exc})") from None
    if raw.dtype.kind not in "fiu":
        raise ValueError(
            f"action must be real numbers (float or integer) in [-1, 1], got dtype {raw.dtype} "
            f"({type(action).__name__}: {action!r})"
        )
    arr = raw.astype(np.float64, copy=False)
    ok_shapes = {(n, dim)} | ({(n,)} if dim == 1 else set()) | ({(dim,)} if n == 1 else set())
    if n == 1 and dim == 1:
        ok_shapes.add(())  # a plain number for a one-dimensional single env
    if arr.shape not in ok_shapes:
        raise ValueError(
            f"action must have shape {(n, dim) if n > 1 else (dim,)} with values in [-1, 1], "
            f"got shape {arr.shape}"
        )
    arr = arr.reshape(n, dim)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"action must be finite (allowed range [-1, 1]), got {arr[~np.isfinite(arr)][:4]}")
    return np.clip(arr, -1.0, 1.0)


class PlantBatch:
    """State of ``n`` independent episodes of one plant, stepped by one kernel call.

    Subclasses set the class attributes and implement the ``task`` hooks below.
    """

    #: the plant's registry entry (hydro_envs.registry)
    plant_spec: ClassVar[PlantSpec]
    #: plant model module: N_STATES, STATE_NAMES, stiffness_modes(params)
    plant: ClassVar[ModuleType]
    #: the plant's validated parameter dataclass
    params_cls: ClassVar[type[PhysicalParams]]
    #: control period [s] and episode length [steps]
    dt: ClassVar[float]
    episode_steps_default: ClassVar[int]
    #: action dimension, plant input dimension, observation dimension
    action_dim: ClassVar[int] = 1
    n_inputs: ClassVar[int] = 1
    obs_dim: ClassVar[int]
    #: reset options this task accepts besides "params" and "state"
    task_options: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        randomize: bool = True,
        randomization: str | RandomizationSpec | None = None,
        params: Mapping[str, float] | PhysicalParams | None = None,
        episode_steps: int | None = None,
        safety: float = DEFAULT_SAFETY,
    ) -> None:
        if n < 1:
            raise ValueError(f"number of copies must be >= 1, got {n}")
        episode_steps = self.episode_steps_default if episode_steps is None else int(episode_steps)
        if episode_steps < 1:
            raise ValueError(f"episode_steps must be >= 1, got {episode_steps}")
        if not (0.0 < safety <= 1.0):
            raise ValueError(f"safety must be in (0, 1], got {safety}")
        if isinstance(params, self.params_cls):
            self.base_params = params
        else:
            self.base_params = self.params_cls.from_mapping(params or {})
        if randomize:
            self.spec: RandomizationSpec | None = (
                randomization
                if isinstance(randomization, RandomizationSpec)
                else load_randomization(self.plant_spec.name, self.params_cls, randomization)
            )
        else:
            self.spec = None
        self.n = n
        self.parallel = parallel
        kernels = self.plant_spec.kernels
        self.step_kernel = kernels.step_parallel if parallel else kernels.step_serial
        self.episode_steps = episode_steps
        self.safety = float(safety)
        ns = self.plant.N_STATES
        self.Y = np.zeros((n, ns))
        self.U = np.zeros((n, self.n_inputs))
        self.P = np.tile(self.base_params.to_array(), (n, 1))
        self.W = np.zeros((n, 5, ns))
        self.clamps = np.zeros(n, dtype=np.int64)
        self.NSUB = np.full(n, self.substeps_for(self.base_params), dtype=np.int64)
        self.K = np.zeros(n, dtype=np.int64)
        self.last_a = np.zeros((n, self.action_dim))
        self.prev_a = np.zeros((n, self.action_dim))
        self.obs = np.zeros((n, self.obs_dim))
        self.reward = np.zeros(n)
        self.params: list[PhysicalParams] = [self.base_params] * n
        self.rngs: list[np.random.Generator | None] = [None] * n

    # ------------------------------------------------------------------ task hooks
    def reset_task(self, i: int, rng: np.random.Generator, p: PhysicalParams, options: Mapping[str, Any]) -> None:
        """Set ``Y[i]`` (initial state, with ``options['state']``), the reference and noise."""
        raise NotImplementedError

    def apply_actions(self) -> None:
        """Fill the plant inputs ``U`` from ``last_a`` (both ``(n, ...)``)."""
        raise NotImplementedError

    def observe(self) -> None:
        """Fill ``obs`` and ``reward`` of every copy (a compiled kernel)."""
        raise NotImplementedError

    def observation_space(self) -> spaces.Box:
        raise NotImplementedError

    def channel_values(self, i: int) -> dict[str, float]:
        """Sensor outputs of copy ``i`` keyed by the plant's measured-data channel names."""
        raise NotImplementedError

    def render(self, i: int, history: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def render_sample(self, i: int) -> tuple[float, ...]:
        """One row of the trace a rendered frame shows (e.g. reference and output)."""
        raise NotImplementedError

    def action_space(self) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, (self.action_dim,), dtype=np.float32)

    # ------------------------------------------------------------------ generic
    def substeps_for(self, p: PhysicalParams) -> int:
        """RK4 sub-steps per env step for parameter set ``p`` (stiffness bound)."""
        return substeps_from_stiffness(self.plant.stiffness_modes(p), self.dt, self.safety)[0]

    def state_from_options(self, y: np.ndarray, options: Mapping[str, Any]) -> None:
        """Overwrite entries of ``y`` from ``options['state']`` (names checked, finite)."""
        names = self.plant.STATE_NAMES
        for name, value in (options.get("state") or {}).items():
            if name not in names:
                raise ValueError(f"options['state'] has unknown state {name!r}; allowed {names}")
            if not math.isfinite(float(value)):
                raise ValueError(f"options['state'][{name!r}] must be finite, got {value}")
            y[names.index(name)] = float(value)

    def reset_copy(self, i: int, rng: np.random.Generator, options: Mapping[str, Any] | None) -> None:
        """Draw copy ``i``'s episode from ``rng`` and put it at step 0."""
        options = dict(options or {})
        allowed = ("params", "state") + self.task_options
        unknown = set(options) - set(allowed)
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}; allowed: {', '.join(allowed)}")
        p = self.spec.sample(rng, self.base_params) if self.spec is not None else self.base_params
        if options.get("params"):
            p = self.params_cls.from_mapping(options["params"], base=p)
        self.params[i] = p
        self.P[i] = p.to_array()
        self.NSUB[i] = self.substeps_for(p)
        self.reset_task(i, rng, p, options)
        self.K[i] = 0
        self.U[i] = 0.0
        self.last_a[i] = 0.0
        self.prev_a[i] = 0.0
        self.clamps[i] = 0
        self.W[i] = 0.0
        self.rngs[i] = rng

    def advance(self, actions: np.ndarray) -> None:
        """Apply checked, clipped ``actions`` ``(n, action_dim)`` for one env step."""
        self.prev_a[:] = self.last_a
        self.last_a[:] = actions
        self.apply_actions()
        self.step_kernel(self.Y, self.U, self.P, self.dt, self.NSUB, self.W, self.clamps)
        self.K += 1
        self.observe()

    def state_dict(self, i: int) -> dict[str, float]:
        return dict(zip(self.plant.STATE_NAMES, self.Y[i].tolist()))


class BatchedEnv(gym.Env):
    """A single environment: a view on a :class:`PlantBatch` of one copy (serial kernel)."""

    batch_cls: ClassVar[type[PlantBatch]]
    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}; allowed {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self._batch = self.batch_cls(1, parallel=False, **kwargs)
        self.action_space = self._batch.action_space()
        self.observation_space = self._batch.observation_space()
        self.dt = self._batch.dt
        self.plant_name = self._batch.plant_spec.name
        self._params_info: dict[str, float] = {}
        self._history: list[tuple[float, ...]] = []
        self._dim = self._batch.action_dim

    @property
    def params(self) -> PhysicalParams:
        """This episode's parameter set."""
        return self._batch.params[0]

    @property
    def n_substeps(self) -> int:
        """RK4 sub-steps per env step for this episode's parameters."""
        return int(self._batch.NSUB[0])

    @property
    def guard_clamps(self) -> int:
        """How often a guard (e.g. the pressure floor) had to clamp the state this episode."""
        return int(self._batch.clamps[0])

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        b = self._batch
        b.reset_copy(0, self.np_random, options)
        b.observe()
        self._params_info = b.params[0].as_dict()
        self._history = [b.render_sample(0)] if self.render_mode is not None else []
        return b.obs[0].astype(np.float32), {"state": b.state_dict(0), "params": dict(self._params_info)}

    def step(self, action: Any):
        b = self._batch
        if b.rngs[0] is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        # fast path for a float array of the action's shape (scalar checks are much cheaper
        # than numpy calls on tiny arrays); anything else is fully checked
        b.prev_a[0] = b.last_a[0]
        if type(action) is np.ndarray and action.shape == (self._dim,) and action.dtype.kind == "f":
            last = b.last_a[0]
            for j in range(self._dim):
                a = float(action[j])
                if not math.isfinite(a):
                    b.last_a[0] = b.prev_a[0]
                    raise ValueError(f"action must be finite (allowed range [-1, 1]), got {action}")
                last[j] = -1.0 if a < -1.0 else (1.0 if a > 1.0 else a)
        else:
            try:
                b.last_a[0] = check_actions(action, 1, self._dim)[0]
            except ValueError:
                b.last_a[0] = b.prev_a[0]
                raise
        b.apply_actions()
        b.step_kernel(b.Y, b.U, b.P, b.dt, b.NSUB, b.W, b.clamps)
        b.K[0] += 1
        b.observe()
        if self.render_mode is not None:
            self._history.append(b.render_sample(0))
        info = {"state": dict(zip(b.plant.STATE_NAMES, b.Y[0].tolist())), "params": dict(self._params_info)}
        return b.obs[0].astype(np.float32), float(b.reward[0]), False, False, info

    def channel_values(self) -> dict[str, float]:
        """Sensor outputs in SI units, keyed by the measured-data channel names."""
        return self._batch.channel_values(0)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self._batch.render(0, np.array(self._history[-500:]))


class BatchedVectorEnv(VectorEnv):
    """``num_envs`` episodes stepped by one parallel kernel call.

    Gymnasium 1.x vector semantics: ``autoreset_mode`` NEXT_STEP (default; the step after a
    copy's episode ended resets it and returns its first observation with reward 0) or
    SAME_STEP (the ending copy is reset in the same step; its last observation is in
    ``info["final_obs"]`` under mask ``info["_final_obs"]``). Each copy is truncated after
    ``max_episode_steps``. ``info`` holds ``state`` and ``params`` as dicts of arrays (the
    ``params`` arrays are read-only). ``reset(options={"reset_mask": mask, ...})`` resets only
    the masked copies.
    """

    batch_cls: ClassVar[type[PlantBatch]]
    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
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
        if max_episode_steps is None:
            max_episode_steps = self.batch_cls.episode_steps_default
        self.max_episode_steps = int(max_episode_steps)
        kwargs.setdefault("episode_steps", self.max_episode_steps)
        self._batch = self.batch_cls(self.num_envs, parallel=True, **kwargs)
        self.single_action_space = self._batch.action_space()
        self.single_observation_space = self._batch.observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.dt = self._batch.dt
        self.plant_name = self._batch.plant_spec.name
        self.render_mode = None
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._params_info: dict[str, np.ndarray] = {}
        self._reset_done = False

    @property
    def n_substeps(self) -> np.ndarray:
        """RK4 sub-steps per env step of every copy."""
        return self._batch.NSUB.copy()

    def _refresh_params_info(self) -> None:
        info = {}
        for j, name in enumerate(self._batch.params_cls.names()):
            col = self._batch.P[:, j].copy()
            col.setflags(write=False)  # shared between steps until the next reset: read-only
            info[name] = col
        self._params_info = info

    def _state_info(self) -> dict[str, np.ndarray]:
        return {name: self._batch.Y[:, j].copy() for j, name in enumerate(self._batch.plant.STATE_NAMES)}

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
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
            if rngs[i] is None:  # never seeded: a seed from the OS entropy pool
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
        b.advance(check_actions(actions, self.num_envs, b.action_dim))
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
        """Sensor outputs of every copy, keyed by channel name (arrays)."""
        rows = [self._batch.channel_values(i) for i in range(self.num_envs)]
        return {k: np.array([r[k] for r in rows]) for k in rows[0]}
