"""Generic batched environments: one compiled kernel call steps every copy.

A task (servo position tracking, table acceleration tracking, ...) subclasses
:class:`PlantBatch` and implements only what is specific to it: the action-to-input map, the
episode draw (initial state, reference, sensor noise), the observation/reward kernel, the
spaces and the sensor channels. Everything else lives here once:

* parameters: nominal set, declarative randomisation (the plant's ``randomization.yaml``),
  ``reset(options={"params": ...})`` overrides, per-copy RK4 sub-steps from the plant's
  stiffness bound. Parameters given to the constructor (``gym.make(id, params={...})``) are
  kept as given: with randomisation on, a given parameter that the randomisation would draw is
  held fixed (a ``UserWarning`` names it) and only the others are drawn;
* the boundary: every constructor argument and reset option is checked before anything is
  reset, and a bad one raises ``TypeError``/``ValueError`` naming the field, the value and the
  allowed range (``randomize`` a bool, ``episode_steps``/``max_episode_steps``/``num_envs``
  positive ints, ``options`` keys known, ``options["state"]`` within :meth:`PlantBatch.state_limits`,
  ``reset_mask`` a bool array of ``num_envs`` entries). A reset that fails leaves every copy as
  it was;
* seeding: every copy draws from its own ``np.random.Generator``; a vector env reset with seed
  ``s`` seeds copy ``i`` with ``s + i`` (as ``SyncVectorEnv`` does), so copy ``i`` reproduces
  a single env reset with seed ``s + i`` bit for bit;
* stepping: the plant's compiled ``step_serial`` for the single env (entering a parallel
  region costs more than a whole env step), ``step_parallel`` for vector envs;
* bounded and finite: a parameter set that needs more than :data:`MAX_SUBSTEPS` RK4 sub-steps
  per env step (its stiffness bound times the worst-case local refinement) is refused at make
  or reset (:class:`SubstepLimitError`, a ``ValueError`` naming the copy, the count and the
  parameters off nominal) instead of a step that never returns; a state or reward that is not
  finite after a step raises :class:`NonFiniteStateError` naming the copy, the states and the
  parameters (checked every step on the rewards, which every state reaches, and on every state
  every :data:`FINITE_CHECK_EVERY` steps; ``PlantBatch.check_finite = False`` lets a caller that
  scores non-finite copies itself, the benchmark and the soak test, step on);
* :class:`BatchedEnv` (a ``gymnasium.Env`` that is a view on a batch of one) and
  :class:`BatchedVectorEnv` (a ``gymnasium.vector.VectorEnv`` with NEXT_STEP or SAME_STEP
  autoreset and per-copy truncation).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import warnings
from types import ModuleType
from typing import Any, ClassVar, Iterable, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hydro_envs._numba_cache import ensure_fresh_cache
from hydro_envs._openmp import set_spin_time
from hydro_envs.envs.kernel_args import KernelArgs
from hydro_envs.jit import as_python, njit_noalloc
from hydro_envs.params import PhysicalParams
from hydro_envs.randomization import RandomizationSpec, load_randomization
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, substeps_from_stiffness
from hydro_envs.spec import PlantSpec

__all__ = [
    "PlantBatch",
    "BatchedEnv",
    "BatchedVectorEnv",
    "action_array",
    "check_actions",
    "take_actions",
    "check_nonnegative",
    "check_positive_int",
    "PRESSURE_FACTOR",
    "NORMALISED_LIMIT",
    "VELOCITY_FACTOR",
    "MAX_SUBSTEPS",
    "FINITE_CHECK_EVERY",
    "SubstepLimitError",
    "NonFiniteStateError",
]

#: a state pressure may lie in [0, PRESSURE_FACTOR x the plant's pressure parameter] (its supply
#: or relief pressure; the factor leaves room for load-induced pressure intensification and is
#: the one the measured-record checks use, hydro_envs.data.checks)
PRESSURE_FACTOR = 2.0
#: a normalised state (unit "1": spool stroke, coil current / rated current) lies within
#: +-NORMALISED_LIMIT of full scale
NORMALISED_LIMIT = 2.0
#: tasks bound the load's velocity by VELOCITY_FACTOR x the plant's own speed bound (its
#: no-load velocity, or the speed its RK4 sub-step count is sized for)
VELOCITY_FACTOR = 2.0
#: most RK4 sub-steps per env step and copy (the stiffness bound's count times the worst-case
#: local refinement of a plant stepped with ``rk4_advance_lookahead``): about 1000 x a nominal
#: plant's cost (0.4 ms per copy and step); a parameter set that needs more is stiffer than the
#: plant is built for (the ends of some allowed ranges need 1e5-1e7)
MAX_SUBSTEPS = 1000
#: env steps between full finiteness checks of every state (the rewards are checked every step)
FINITE_CHECK_EVERY = 32


class SubstepLimitError(ValueError):
    """A parameter set needs more than :data:`MAX_SUBSTEPS` RK4 sub-steps per env step."""


class NonFiniteStateError(ArithmeticError):
    """A plant state or reward is NaN or infinite after a step (the command line's exit code 1)."""

    exit_code = 1


def params_off_nominal(p: PhysicalParams, limit: int = 6) -> str:
    """``name=value`` of the parameters of ``p`` that differ from its class's defaults (for messages)."""
    nominal = type(p)()
    diff = [f"{n}={getattr(p, n):.6g}" for n in p.names() if getattr(p, n) != getattr(nominal, n)]
    if not diff:
        return "the nominal parameters"
    more = f" and {len(diff) - limit} more" if len(diff) > limit else ""
    return "parameters " + ", ".join(diff[:limit]) + more


def check_positive_int(name: str, value: Any) -> int:
    """``value`` as an int >= 1; ``TypeError`` for a non-integer (bool, float, str),
    ``ValueError`` for one below 1, both naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a positive int (>= 1), got {value!r} ({type(value).__name__})")
    if value < 1:
        raise ValueError(f"{name} must be a positive int (>= 1), got {value}")
    return int(value)


def _check_bool(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r} ({type(value).__name__})")
    return bool(value)


def _real(where: str, value: Any) -> float:
    """``value`` as a finite float; ``TypeError`` unless a real number (not bool/str/array)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{where} must be a real number, got {value!r} ({type(value).__name__})")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{where} must be finite, got {value!r}")
    return x


def given_param_names(params: Any, params_cls: type) -> tuple[str, ...]:
    """The parameters a caller set explicitly: the keys of a mapping, or the fields of a
    parameter instance that differ from the class defaults."""
    if params is None:
        return ()
    if isinstance(params, PhysicalParams):
        nominal = params_cls()
        return tuple(f.name for f in dataclasses.fields(params) if getattr(params, f.name) != getattr(nominal, f.name))
    if isinstance(params, Mapping):
        return tuple(str(k) for k in params)
    raise TypeError(f"params must be a mapping of parameter name -> value or a {params_cls.__name__}, "
                    f"got {type(params).__name__}")


def fill_reference(row: np.ndarray, arr: np.ndarray, episode_steps: int, unit: str) -> None:
    """Copy a user's reference array ``arr`` (one sample per env step) into the episode's
    reference ``row``. It must cover the episode: an array shorter than ``episode_steps`` is an
    error, never silently held. Samples past its end feed only the preview beyond the episode's
    last step and repeat its last value."""
    if arr.size < episode_steps:
        raise ValueError(
            f"options['reference'] has {arr.size} samples [{unit}], the episode runs {episode_steps} steps: "
            f"give at least {episode_steps} (one per step), or a reference kind"
        )
    m = min(arr.size, row.size)
    row[:m] = arr[:m]
    row[m:] = arr[m - 1]


def check_nonnegative(**values: float) -> None:
    """Raise ``ValueError`` naming the first argument that is negative or not finite."""
    for name, value in values.items():
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {value}")


def action_array(action: Any, n: int, dim: int) -> np.ndarray:
    """``action`` for ``n`` copies of a ``dim``-dimensional Box(-1, 1) as an ``(n, dim)`` array of
    real numbers (float or integer; not yet checked for finiteness, not clipped). Strings, None,
    booleans, complex, objects, ragged lists or a wrong shape raise ``ValueError``."""
    try:
        raw = np.asarray(action)
    except (ValueError, TypeError) as exc:  # e.g. a ragged nested list
        raise ValueError(f"action must be an array of real numbers in [-1, 1], got {action!r} ({exc})") from None
    if raw.dtype.kind not in "fiu":
        raise ValueError(
            f"action must be real numbers (float or integer) in [-1, 1], got dtype {raw.dtype} "
            f"({type(action).__name__}: {action!r})"
        )
    if raw.shape != (n, dim):
        ok_shapes = {(n, dim)} | ({(n,)} if dim == 1 else set()) | ({(dim,)} if n == 1 else set())
        if n == 1 and dim == 1:
            ok_shapes.add(())  # a plain number for a one-dimensional single env
        if raw.shape not in ok_shapes:
            raise ValueError(
                f"action must have shape {(n, dim) if n > 1 else (dim,)} with values in [-1, 1], "
                f"got shape {raw.shape}"
            )
        raw = raw.reshape(n, dim)
    return raw


def not_finite_error(arr: np.ndarray) -> ValueError:
    """The error for actions ``arr`` that hold NaN or inf (names up to four of them)."""
    arr = np.asarray(arr, dtype=np.float64)
    return ValueError(f"action must be finite (allowed range [-1, 1]), got {arr[~np.isfinite(arr)][:4]}")


def check_actions(action: Any, n: int, dim: int) -> np.ndarray:
    """Validate actions for ``n`` copies of a ``dim``-dimensional Box(-1, 1); clip; return
    ``(n, dim)`` float64. Real numbers (float or integer arrays, lists, scalars) are
    accepted; NaN/inf, a wrong shape or anything that is not real numbers (strings, None,
    booleans, complex, objects, ragged lists) raise ``ValueError``."""
    arr = action_array(action, n, dim).astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise not_finite_error(arr)
    return np.clip(arr, -1.0, 1.0)


@njit_noalloc
def take_actions(raw, prev_a, last_a):
    """If every entry of ``raw`` ``(n, dim)`` is finite: ``prev_a = last_a`` and ``last_a`` = ``raw``
    clipped to [-1, 1], and return 0; else change nothing and return how many are not finite
    (the vector env's step: :func:`check_actions` and the shift of the last actions in one pass)."""
    n, dim = raw.shape
    bad = 0
    for i in range(n):
        for j in range(dim):
            if not math.isfinite(raw[i, j]):
                bad += 1
    if bad:
        return bad
    for i in range(n):
        for j in range(dim):
            prev_a[i, j] = last_a[i, j]
            last_a[i, j] = min(max(float(raw[i, j]), -1.0), 1.0)
    return 0


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
    #: length states bounded by a parameter (|state| <= parameter), e.g. a spool by its stroke;
    #: entries whose state or parameter the plant lacks are ignored
    state_limit_parameters: ClassVar[Mapping[str, str]] = {"xv": "spool_stroke"}
    #: states a reset may not set (internal filter realisations without a physical meaning)
    fixed_states: ClassVar[tuple[str, ...]] = ()
    #: for a plant stepped with ``rk4_advance_lookahead``: its compiled ``(P_row, h) -> m``, the
    #: fine steps per sub-step at the worst case (the kernels' ``m``); counts in the sub-step cap
    refinement_bound: ClassVar[Any] = None
    #: whether a step checks that every state and reward is finite (module docstring)
    check_finite: bool = True

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
        ensure_fresh_cache()  # before the first kernel is compiled or loaded from the cache
        n = check_positive_int("number of copies", n)
        episode_steps = check_positive_int(
            "episode_steps", self.episode_steps_default if episode_steps is None else episode_steps
        )
        randomize = _check_bool("randomize", randomize)
        if not (0.0 < _real("safety", safety) <= 1.0):
            raise ValueError(f"safety must be in (0, 1], got {safety}")
        if isinstance(params, self.params_cls):
            self.base_params = params
        else:
            given_param_names(params, self.params_cls)  # type check
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
        # the observation space's dtype: the kernels compute in float64 and round once, on storing
        self.obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        self.reward = np.zeros(n)
        self.params: list[PhysicalParams] = [self.base_params] * n
        self.rngs: list[np.random.Generator | None] = [None] * n
        self._reset_params: PhysicalParams = self.base_params
        self._steps_unchecked = 0
        self._kargs: KernelArgs | None = None
        self.select_step_kernel()

    def select_step_kernel(self) -> None:
        """Bind ``step_kernel`` to the plant's serial or parallel step (and ``step_serial`` to the
        serial one, which a step-and-observe kernel runs on each block); a plant whose kernels
        have ``for_params(P)`` (:class:`hydro_envs.contract.KernelSet`) picks them for the current
        parameter rows (called after the rows change: resets, restores)."""
        kernels = self.plant_spec.kernels.pick(self.P)
        self.step_kernel = kernels.step_parallel if self.parallel else kernels.step_serial
        self.step_serial = kernels.step_serial
        self.step_observe = self.step_observe_kernels.get(kernels.name, self.step_observe_general)
        self._kernel_stale = False

    # ------------------------------------------------------------------ task hooks
    def reset_task(self, i: int, rng: np.random.Generator, p: PhysicalParams, options: Mapping[str, Any]) -> None:
        """Set ``Y[i]`` (initial state, with ``options['state']``), the reference and noise."""
        raise NotImplementedError

    def apply_actions(self) -> None:
        """Fill the plant inputs ``U`` from ``last_a`` (both ``(n, ...)``)."""
        raise NotImplementedError

    def observe(self) -> None:
        """Fill ``obs`` and ``reward`` of every copy (a compiled kernel; after resets, and every
        step of the single env). A serial loop over the copies unless the per-copy work is
        heavy (the shaking table's filters); a vector env's step observes in its
        step-and-observe kernel (:meth:`step_and_observe`)."""
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
    def substeps_for(self, p: PhysicalParams, row: np.ndarray | None = None) -> int:
        """RK4 sub-steps per env step for parameter set ``p`` (stiffness bound); raises
        :class:`SubstepLimitError` when they, times the worst-case local refinement, exceed
        :data:`MAX_SUBSTEPS`. ``row``: ``p.to_array()`` when the caller has it."""
        n, h, mode = substeps_from_stiffness(self.plant.stiffness_modes(p), self.dt, self.safety)
        if n > MAX_SUBSTEPS:
            raise SubstepLimitError(
                f"{self.plant_spec.name}: {params_off_nominal(p)} need {n} RK4 sub-steps per env step (stiffness "
                f"mode {mode!r}); allowed at most {MAX_SUBSTEPS}: stiffer than the plant is built for")
        bound = self.refinement_bound
        if bound is not None:
            m = int(as_python(bound)(p.to_array() if row is None else row, h))
            if n * m > MAX_SUBSTEPS:
                raise SubstepLimitError(
                    f"{self.plant_spec.name}: {params_off_nominal(p)} need up to {n * m} RK4 sub-steps per env step "
                    f"({n} sub-steps, each refined up to {m} x where a local mode is stiff); allowed at most "
                    f"{MAX_SUBSTEPS}: stiffer than the plant is built for")
        return n

    def assert_finite(self) -> None:
        """Raise :class:`NonFiniteStateError` naming the first copy whose state or reward is not
        finite (its states, step count and parameters)."""
        self._steps_unchecked = 0
        bad = ~(np.all(np.isfinite(self.Y), axis=1) & np.isfinite(self.reward))
        if not bad.any():
            return
        i = int(np.flatnonzero(bad)[0])
        names = [n for n, v in zip(self.plant.STATE_NAMES, self.Y[i]) if not math.isfinite(v)]
        what = (f"state {', '.join(f'{n} = {float(self.Y[i, self.plant.STATE_NAMES.index(n)])!r}' for n in names[:4])}"
                if names else f"reward = {float(self.reward[i])!r}")
        more = f" ({int(bad.sum())} copies in all)" if bad.sum() > 1 else ""
        raise NonFiniteStateError(
            f"{self.plant_spec.name} copy {i}: {what} after step {int(self.K[i])} with {params_off_nominal(self.params[i])}"
            f"{more}; the plant is not finite there (report the parameters)")

    def _check_step(self) -> None:
        """The finiteness check after a step: the rewards every step, every state every
        :data:`FINITE_CHECK_EVERY` steps."""
        r = self.reward
        total = float(r[0]) if r.shape[0] == 1 else float(np.add.reduce(r))
        self._steps_unchecked += 1
        if not math.isfinite(total) or self._steps_unchecked >= FINITE_CHECK_EVERY:
            self.assert_finite()

    def hold_params(self, names: Iterable[str], *, warn: bool = True) -> None:
        """Take ``names`` out of the randomisation: they keep their ``base_params`` values.

        Checks that every corner of the remaining ranges around the held values is a valid
        parameter set (``ValueError`` naming the held parameters otherwise) and, with ``warn``,
        warns which drawn parameters are now fixed."""
        if self.spec is None:
            return
        held = [e.name for e in self.spec.entries if e.name in set(names)]
        if not held:
            return
        spec = dataclasses.replace(self.spec, entries=tuple(e for e in self.spec.entries if e.name not in held))
        if spec.entries:
            try:
                spec.check_corners(base=self.base_params)
            except ValueError as exc:
                values = ", ".join(f"{k}={getattr(self.base_params, k)!r}" for k in held)
                raise ValueError(f"params ({values}) given with randomisation on: {exc}; "
                                 "pass randomize=False or values consistent with the drawn ranges") from None
        self.spec = spec if spec.entries else None
        if warn:
            values = ", ".join(f"{k}={getattr(self.base_params, k):g}" for k in held)
            warnings.warn(
                f"{self.plant_spec.name}: parameters given to the env ({values}) are held fixed; the "
                f"randomisation ({self.spec.source_file if self.spec else 'none left'}) draws only the others. "
                "Pass randomize=False to fix every parameter.",
                UserWarning,
                stacklevel=4,
            )

    def state_limits(self, p: PhysicalParams) -> dict[str, tuple[float, float, str]]:
        """Allowed range ``(low, high, why)`` of every state a reset may set, for parameters ``p``.

        Derived from the plant's registry entry (``stroke_parameter`` L, ``pressure_parameter``
        p_max), the state units and the control period dt:

        * pressures [Pa]: ``[0, PRESSURE_FACTOR * p_max]`` (tasks add their pressure floor);
        * lengths [m]: ``|x| <= L``, or ``|x| <=`` the parameter :attr:`state_limit_parameters`
          names (a spool within its stroke); tasks check the piston's own stroke interval;
        * normalised states [1]: ``|x| <= NORMALISED_LIMIT`` (full scale is 1);
        * a velocity that follows its position in the state vector (``x, v``; ``xv, vv``):
          ``|v| <= min(width of the position range, L) / dt`` -- faster would cross the whole
          range (the piston's stroke, the spool's travel) within one control step; any other
          velocity [m/s]: ``|v| <= L / dt``;
        * forces [N]: ``|F| <= PRESSURE_FACTOR * p_max * A_max`` (``A_max``: the largest area
          parameter), their rates [N/s] that over dt;
        * anything else (gas masses, flows): finite; tasks may narrow it.
        """
        names, units = self.plant.STATE_NAMES, self.plant_spec.state_units
        ps = self.plant_spec
        L = float(getattr(p, ps.stroke_parameter)) if ps.stroke_parameter else math.inf
        pmax = PRESSURE_FACTOR * float(getattr(p, ps.pressure_parameter)) if ps.pressure_parameter else math.inf
        areas = [getattr(p, r["name"]) for r in type(p).describe() if r["unit"] == "m^2"]
        fmax = pmax * max(areas) if areas else math.inf
        dt = float(self.dt)
        out: dict[str, tuple[float, float, str]] = {}
        for j, (name, unit) in enumerate(zip(names, units)):
            lim = self.state_limit_parameters.get(name)
            if unit == "Pa":
                out[name] = (0.0, pmax, f"absolute pressure, 0 to {PRESSURE_FACTOR:g} x {ps.pressure_parameter}")
            elif unit == "m" and lim is not None and hasattr(p, lim):
                b = float(getattr(p, lim))
                out[name] = (-b, b, f"within +-{lim}")
            elif unit == "m":
                out[name] = (-L, L, f"a length within +-{ps.stroke_parameter}")
            elif unit == "1":
                out[name] = (-NORMALISED_LIMIT, NORMALISED_LIMIT, f"normalised, within +-{NORMALISED_LIMIT:g} x full scale")
            elif unit in ("m/s", "1/s"):
                prev = names[j - 1] if j > 0 else None
                pos_unit = unit[:-2]
                if prev is not None and units[j - 1] == pos_unit and prev in out:
                    width = out[prev][1] - out[prev][0]
                    vmax = min(width, L) / dt if pos_unit == "m" else width / dt
                    why = f"the rate of {prev!r}: at most its range crossed in one control step (dt = {dt:g} s)"
                else:
                    vmax = L / dt
                    why = f"at most the stroke crossed in one control step (dt = {dt:g} s)"
                out[name] = (-vmax, vmax, why)
            elif unit == "N":
                out[name] = (-fmax, fmax, f"at most {PRESSURE_FACTOR:g} x {ps.pressure_parameter} on the largest area")
            elif unit == "N/s":
                out[name] = (-fmax / dt, fmax / dt, "at most the largest force built up in one control step")
            else:
                out[name] = (-math.inf, math.inf, "finite")
        return out

    @staticmethod
    def narrow(limits: dict[str, tuple[float, float, str]], name: str, low: float, high: float, why: str) -> None:
        """Replace ``limits[name]`` by ``[low, high]`` (a task's own, tighter bound)."""
        limits[name] = (float(low), float(high), why)

    def check_state_option(self, options: Mapping[str, Any]) -> dict[str, float]:
        """``options['state']`` type- and name-checked: ``{name: float}`` (no range check)."""
        state = options.get("state")
        if state is None:
            return {}
        if not isinstance(state, Mapping):
            raise TypeError(f"options['state'] must be a mapping of state name -> value, got {type(state).__name__}")
        names = self.plant.STATE_NAMES
        out = {}
        for name, value in state.items():
            if name not in names:
                raise ValueError(f"options['state'] has unknown state {name!r}; allowed {names}")
            if name in self.fixed_states:
                raise ValueError(f"options['state'][{name!r}]: an internal filter state that a reset cannot set; "
                                 f"settable: {tuple(n for n in names if n not in self.fixed_states)}")
            out[name] = _real(f"options['state'][{name!r}]", value)
        return out

    def state_from_options(self, y: np.ndarray, options: Mapping[str, Any]) -> None:
        """Overwrite entries of ``y`` from ``options['state']``: names known, real and finite,
        each within :meth:`state_limits` of this copy's parameters (``ValueError`` naming the
        state, the value and the range)."""
        given = self.check_state_option(options)
        if not given:
            return
        names = self.plant.STATE_NAMES
        limits = self.state_limits(self._reset_params)
        units = self.plant_spec.state_units
        for name, value in given.items():
            lo, hi, why = limits[name]
            if not lo <= value <= hi:
                unit = units[names.index(name)]
                raise ValueError(f"options['state'][{name!r}] = {value!r} {unit} lies outside [{lo:.6g}, {hi:.6g}] {unit} "
                                 f"({why})")
            y[names.index(name)] = value

    def check_options(self, options: Any) -> dict[str, Any]:
        """Reset options as a dict, with keys, ``params`` and ``state`` type-checked."""
        if options is None:
            return {}
        if not isinstance(options, Mapping):
            raise TypeError(f"options must be a dict or None, got {type(options).__name__}")
        options = dict(options)
        allowed = ("params", "state") + self.task_options
        unknown = set(options) - set(allowed)
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(map(str, unknown))}; allowed: {', '.join(allowed)}")
        params = options.get("params")
        if params is not None and not isinstance(params, Mapping):
            raise TypeError(f"options['params'] must be a mapping of parameter name -> value, got {type(params).__name__}")
        self.check_state_option(options)
        return options

    def snapshot(self) -> dict[str, Any]:
        """Everything a reset changes (arrays, parameter list, generator states)."""
        arrays = {k: v.copy() for k, v in vars(self).items() if isinstance(v, np.ndarray)}
        rngs = [None if r is None else r.bit_generator.state for r in self.rngs]
        return {"arrays": arrays, "params": list(self.params), "rngs": list(self.rngs), "rng_states": rngs}

    def restore(self, snap: Mapping[str, Any]) -> None:
        """Undo everything since :meth:`snapshot`."""
        for k, v in snap["arrays"].items():
            cur = getattr(self, k)
            if cur.shape == v.shape and cur.flags.writeable:
                cur[...] = v
            else:
                setattr(self, k, v)
        self.params[:] = snap["params"]
        self.rngs[:] = snap["rngs"]
        self._kernel_stale = True
        self._kargs = None
        for r, st in zip(self.rngs, snap["rng_states"]):
            if r is not None:
                r.bit_generator.state = st

    def reset_copy(self, i: int, rng: np.random.Generator, options: Mapping[str, Any] | None) -> None:
        """Draw copy ``i``'s episode from ``rng`` and put it at step 0."""
        options = self.check_options(options)
        p = self.spec.sample(rng, self.base_params) if self.spec is not None else self.base_params
        if options.get("params"):
            p = self.params_cls.from_mapping(options["params"], base=p)
        self._reset_params = p
        row = p.to_array()
        try:
            nsub = self.substeps_for(p, row)
        except SubstepLimitError as exc:
            raise SubstepLimitError(f"copy {i}: {exc}") from None
        self.params[i] = p
        self.P[i] = row
        self.NSUB[i] = nsub
        self.reset_task(i, rng, p, options)
        self.K[i] = 0
        self.U[i] = 0.0
        self.last_a[i] = 0.0
        self.prev_a[i] = 0.0
        self.clamps[i] = 0
        self.W[i] = 0.0
        self.rngs[i] = rng
        self._kernel_stale = True
        self._kargs = None

    def advance(self) -> None:
        """One env step of every copy under the checked, clipped actions in ``last_a`` (``prev_a``
        holds the step's before)."""
        if self._kernel_stale:
            self.select_step_kernel()
        if self.parallel:
            self.step_and_observe()
        else:
            self.step_then_observe()
        if self.check_finite:
            self._check_step()

    def step_then_observe(self) -> None:
        """:meth:`apply_actions`, step every copy (``step_kernel``), count the step in ``K`` and
        :meth:`observe`."""
        self.apply_actions()
        self.step_kernel(self.Y, self.U, self.P, self.dt, self.NSUB, self.W, self.clamps)
        self.K += 1
        self.observe()

    #: the env's step-and-observe kernels by the name of the plant's kernel set
    #: (:attr:`hydro_envs.contract.KernelSet.name`) whose serial step they run on each block, and
    #: the one for any other set (a ``staticmethod`` of one that runs the plant's general step,
    #: bit-identical to its variants); see :meth:`step_and_observe`
    step_observe_kernels: ClassVar[dict[str, Any]] = {}
    step_observe_general: ClassVar[Any] = None
    #: whether those kernels fill the plant inputs ``U`` from ``last_a`` themselves, each block's
    #: before stepping it (the arithmetic of :meth:`apply_actions`, which then does not run)
    step_observe_applies_actions: ClassVar[bool] = False
    #: the unit of arguments of the env's observation and step-and-observe kernels
    #: (:mod:`hydro_envs.envs.kernel_args`)
    kernel_args_cls: ClassVar[type[KernelArgs]]

    def __getstate__(self) -> dict[str, Any]:
        """Pickle and deepcopy state: everything but the kernel unit (a compiled struct that
        holds references, not data), which the copy builds again over its own arrays."""
        state = dict(self.__dict__)
        state["_kargs"] = None
        return state

    def kernel_constants(self) -> dict[str, Any]:
        """Fields of the kernel unit that are not batch attributes of the same name (indices,
        module constants); the others are read from the batch by name."""
        return {}

    def observe_args(self) -> KernelArgs:
        """The kernel unit (:attr:`kernel_args_cls`) over the batch's current arrays, built again
        after a reset or a restore: :meth:`observe` and the step-and-observe kernel take it."""
        if self._kargs is None:
            extra = self.kernel_constants()
            self._kargs = self.kernel_args_cls.make(
                {f: extra[f] if f in extra else getattr(self, f) for f in self.kernel_args_cls.fields})
        return self._kargs

    def step_and_observe(self) -> None:
        """The parallel batch's step: one kernel that steps and observes each block of copies in
        a single parallel region (:func:`hydro_envs.sim.rk4.step_block`), called as
        ``observe_args().run(kernel)``, so that the observation runs on every thread and the threads
        are woken once per env step, after :meth:`apply_actions` unless the kernel fills the
        inputs itself (:attr:`step_observe_applies_actions`); :meth:`step_then_observe` for a
        plant kernel set without one (:attr:`step_observe_kernels`)."""
        kernel = self.step_observe
        if kernel is None:
            self.step_then_observe()
            return
        if not self.step_observe_applies_actions:
            self.apply_actions()
        self.observe_args().run(kernel)

    def state_dict(self, i: int) -> dict[str, float]:
        return dict(zip(self.plant.STATE_NAMES, self.Y[i].tolist()))


class BatchedEnv(gym.Env):
    """A single environment: a view on a :class:`PlantBatch` of one copy (serial kernel).

    ``params`` given to ``gym.make`` are kept: with randomisation on, those the randomisation
    would draw are held fixed at the given values (a ``UserWarning`` names them) and only the
    others are drawn; ``randomize=False`` fixes every parameter. The episode length is
    Gymnasium's ``TimeLimit`` (``gym.make(id, max_episode_steps=K)``; Gymnasium reads ``-1`` as
    "no limit": the episode then never ends by itself, the reference holding its last value).
    """

    batch_cls: ClassVar[type[PlantBatch]]
    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}; allowed {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self._batch = self.batch_cls(1, parallel=False, **kwargs)
        self._batch.hold_params(given_param_names(kwargs.get("params"), self._batch.params_cls))
        self.action_space = self._batch.action_space()
        self.observation_space = self._batch.observation_space()
        self.dt = self._batch.dt
        self.plant_name = self._batch.plant_spec.name
        self._params_info: dict[str, float] = {}
        self._history: list[tuple[float, ...]] = []
        self._dim = self._batch.action_dim

    @property
    def batch(self) -> PlantBatch:
        """The plant batch this env is a view on (one copy): states ``Y``, parameter rows ``P``,
        ``base_params``, randomisation ``spec``, ``dt``, the plant's index attributes. Read it; its
        states change only through the env's ``reset``/``step``."""
        return self._batch

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
        b = self._batch
        options = b.check_options(options)
        snap = b.snapshot() if options else None
        super().reset(seed=seed)
        try:
            b.reset_copy(0, self.np_random, options)
        except Exception:
            if snap is not None:  # a bad option: the episode in progress is left as it was
                b.restore(snap)
            raise
        b.observe()
        self._params_info = b.params[0].as_dict()
        self._history = [b.render_sample(0)] if self.render_mode is not None else []
        return b.obs[0].copy(), {"state": b.state_dict(0), "params": dict(self._params_info)}

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
        b.advance()
        if self.render_mode is not None:
            self._history.append(b.render_sample(0))
        info = {"state": dict(zip(b.plant.STATE_NAMES, b.Y[0].tolist())), "params": dict(self._params_info)}
        return b.obs[0].copy(), float(b.reward[0]), False, False, info

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
    the masked copies: ``mask`` a bool array of exactly ``num_envs`` entries, at least one
    True, checked before any copy is reset (the first reset resets every copy).
    ``max_episode_steps`` and ``num_envs`` are positive ints; ``params`` as for the single env.
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
        self.num_envs = check_positive_int("num_envs", num_envs)
        if max_episode_steps is None:
            max_episode_steps = self.batch_cls.episode_steps_default
        self.max_episode_steps = check_positive_int("max_episode_steps", max_episode_steps)
        kwargs.setdefault("episode_steps", self.max_episode_steps)
        set_spin_time()  # before the first parallel kernel loads libgomp (hydro_envs/_openmp.py)
        self._batch = self.batch_cls(self.num_envs, parallel=True, **kwargs)
        self._batch.hold_params(given_param_names(kwargs.get("params"), self._batch.params_cls))
        self.single_action_space = self._batch.action_space()
        self.single_observation_space = self._batch.observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.dt = self._batch.dt
        self.plant_name = self._batch.plant_spec.name
        self.render_mode = None
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._resets_pending = False  # whether any of _needs_reset is set
        #: at least every copy's step count ``K``: below the episode length no copy can be truncated,
        #: and the step does not read ``K`` (the kernel's threads have just written it)
        self._steps_bound = 0
        self._params_info: dict[str, np.ndarray] = {}
        self._reset_done = False

    @property
    def batch(self) -> PlantBatch:
        """The plant batch behind all copies: states ``Y`` (copies x states), parameter rows
        ``P``, ``base_params``, randomisation ``spec``, ``dt``, the plant's index attributes
        (what the benchmark's adapters read). Read it; its states change only through
        ``reset``/``step`` (its ``parallel`` flag picks the serial or threaded kernel)."""
        return self._batch

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
        """Every state as an array over the copies: columns of one copy of the states (views;
        a contiguous copy per state took 29 us for 1024 copies of 26 states, this 8)."""
        return dict(zip(self._batch.plant.STATE_NAMES, self._batch.Y.copy().T))

    def check_reset_mask(self, mask: Any) -> np.ndarray:
        """``mask`` as a bool array of ``num_envs`` entries with at least one True
        (``TypeError``/``ValueError`` otherwise); copies never reset cannot be left out."""
        if isinstance(mask, (str, bytes)) or not isinstance(mask, (np.ndarray, list, tuple)):
            raise TypeError(f"options['reset_mask'] must be a bool array of {self.num_envs} entries, "
                            f"got {type(mask).__name__} {mask!r}")
        arr = np.asarray(mask)
        if arr.dtype != np.bool_:
            raise TypeError(f"options['reset_mask'] must be a bool array of {self.num_envs} entries, got dtype {arr.dtype}")
        if arr.shape != (self.num_envs,):
            raise ValueError(f"options['reset_mask'] must have shape ({self.num_envs},) (one entry per copy), "
                             f"got shape {arr.shape}")
        if not arr.any():
            raise ValueError("options['reset_mask'] selects no copy; at least one entry must be True")
        never = [i for i in np.flatnonzero(~arr) if self._batch.rngs[i] is None]
        if never:
            raise ValueError(f"options['reset_mask'] leaves out copies {never} that were never reset; "
                             "the first reset must reset every copy")
        return arr

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        b = self._batch
        if options is not None and not isinstance(options, Mapping):
            raise TypeError(f"options must be a dict or None, got {type(options).__name__}")
        mask = None if options is None or "reset_mask" not in options else self.check_reset_mask(options["reset_mask"])
        opts = None if options is None else b.check_options({k: v for k, v in options.items() if k != "reset_mask"})
        snap = b.snapshot() if opts else None
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
        try:
            for i in range(self.num_envs):
                if mask is not None and not mask[i]:
                    continue
                b.reset_copy(i, rngs[i], opts)
        except Exception:
            if snap is not None:  # a bad option: no copy is left half reset
                b.restore(snap)
            raise
        b.observe()
        self._needs_reset[:] = False
        self._resets_pending = False
        self._steps_bound = int(b.K.max())
        self._reset_done = True
        self._refresh_params_info()
        return b.obs.copy(), {"state": self._state_info(), "params": dict(self._params_info)}

    def step(self, actions: Any):
        if not self._reset_done:
            raise gym.error.ResetNeeded("call reset() before step()")
        b = self._batch
        raw = action_array(actions, self.num_envs, b.action_dim)
        if take_actions(raw, b.prev_a, b.last_a):
            raise not_finite_error(raw)
        b.advance()
        self._steps_bound += 1
        may_end = self._steps_bound >= self.max_episode_steps  # (the tasks end by truncation only)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = b.K >= self.max_episode_steps if may_end else np.zeros(self.num_envs, dtype=bool)
        reward = b.reward.copy()
        info: dict[str, Any] = {}
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            if self._resets_pending:
                redo = np.flatnonzero(self._needs_reset)
                for i in redo:
                    b.reset_copy(i, b.rngs[i], None)
                b.observe()
                reward[redo] = 0.0
                truncated[redo] = False
                self._refresh_params_info()
                self._steps_bound = int(b.K.max())
            self._needs_reset = terminated | truncated
            self._resets_pending = may_end and bool(self._needs_reset.any())
            obs = b.obs.copy()
            info["state"] = self._state_info()
        else:  # SAME_STEP
            done = np.flatnonzero(terminated | truncated)
            info["state"] = self._state_info()
            obs = b.obs.copy()
            if done.size:
                final = np.zeros_like(obs)
                final[done] = obs[done]
                info["final_obs"] = final
                info["_final_obs"] = terminated | truncated
                for i in done:
                    b.reset_copy(i, b.rngs[i], None)
                b.observe()
                obs = b.obs.copy()
                self._refresh_params_info()
                self._steps_bound = int(b.K.max())
        info["params"] = dict(self._params_info)
        return obs, reward, terminated, truncated, info

    def channel_values(self) -> dict[str, np.ndarray]:
        """Sensor outputs of every copy, keyed by channel name (arrays)."""
        rows = [self._batch.channel_values(i) for i in range(self.num_envs)]
        return {k: np.array([r[k] for r in rows]) for k in rows[0]}
