r"""Benchmark classical and learned controllers on frozen, seeded parameter draws.

``run_benchmark(env_id, controllers, params, n, seed)`` evaluates every controller on the SAME
``n`` episodes: the plant parameters are drawn once (:func:`draw_parameters`) and passed to
every copy with ``reset(options={"params": ...})``; copy ``i`` is reset with seed ``seed + i``,
so its reference, initial state and sensor noise are identical for every controller.

Parameter sets (``params``):

* ``nominal``: no randomisation (the nominal plant; episodes differ in reference/initial state);
* ``in``: the env's training randomisation (``configs/randomization/<plant>.yaml``);
* ``out``: every randomised parameter drawn from the *outside* of its training range: the range
  widened by ``OUT_FACTOR`` = 2 about its centre
  (:meth:`hydro_envs.randomization.RandomizationSpec.widened`, log centre for log-uniform),
  minus the training range itself; draws that are not valid parameter sets are redrawn.

Per episode (true, noise-free signals after each step):

* ``rmse``, ``max_error`` of the tracked quantity (position [m], acceleration [m/s^2],
  force [N], velocity [m/s]) against the reference;
* ``overshoot`` [%] and ``settling_time`` [s] on a step reference (:func:`step_metrics`; a
  second episode set with the env's step reference kind, see :data:`ADAPTERS`; the shaking
  table has no step reference: n/a);
* ``effort``: RMS of the action (all action components, env units [-1, 1]);
* ``pressure_violations``: steps at which a chamber/line pressure lies outside
  ``[pressure_floor, 1.25 p_supply]`` (LoadSensing: ``[floor, relief]``) plus guard clamps;
* ``endstop_steps``: steps with the position outside the stroke (on the end-stop contact);
* friction metrics (:mod:`agents.metrics`): ``reversal_error`` (mean over the reference's
  velocity reversals of the peak error within 0.2 s after each, the quadrant glitch) and
  ``stick_time`` (fraction of the time the reference moves while the plant rests) of the
  tracking episode; ``steady_state_error`` (mean |error| over the last half of each hold, less
  the last 60 ms the reference preview lets a controller anticipate), ``limit_cycle``
  (peak-to-peak error there) and ``hunting`` (the same over holds of 2 s or more) of the holds of
  the step episode, or of the tracking episode when there is no step episode; n/a when the
  reference has no reversal or hold;
* ``failed``: non-finite state or action, or RMSE not better than holding the output at its
  initial value (``rmse >= rms(ref - y_0)``);
* ``rmse_rel_pid``: the episode's RMSE over the classical PID's RMSE on the same draw and
  episode (paired; only when ``pid`` is among the controllers). The episodes mix reference
  kinds, so the RMSE spread between episodes is large; the paired ratio removes it.
* ``friction_share`` (when the plant declares its dry-friction parameters,
  :attr:`hydro_envs.spec.PlantSpec.dry_friction_parameters`): the share of a controller's mean
  squared tracking error that dry friction causes, ``1 - sum MSE_0 / sum MSE`` over the draws,
  where ``MSE_0`` is the same controller's on the same draws and episodes with the Coulomb,
  static and Stribeck parts of the friction set to zero (viscous friction kept). A task is
  friction-critical when the PID's is >= 0.5 (:data:`FRICTION_CRITICAL`);
  ``reversal_excess`` is the reversal error less that of the same twin episode.

Aggregates per controller (:mod:`agents.benchmark_stats`): mean with a seeded 95 %
percentile-bootstrap interval over the draws (never below zero for a nonnegative metric; for
``rmse_rel_pid`` a paired bootstrap: a resample keeps controller and PID on the same draws),
failure rate with a Wilson interval, CVaR-10 % of the RMSE (mean of the worst ``ceil(0.1 n)``
episodes) with a seeded percentile-bootstrap interval.

Learned agents: a controller spec ``sb3:RUN_DIR`` (or ``NAME=sb3:RUN_DIR``) is loaded with
``agents.policies.load_trained(RUN_DIR)`` from the folder's safe layout (``policy.pt`` +
``obs_normalization.npz``, no unpickling); SB3 zips and ``vecnormalize.pkl`` are pickles that
can run code on load and are read only with ``trust_pickle=True`` (``--trust-pickle``) for
folders you trust. Several specs with the same name (default: the run
folder name without a trailing ``_s<k>`` / ``_seed<k>``) are different training seeds, pooled
into one row (``n`` = draws x seeds).
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import json
import math
import re
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents import metrics as fm
from agents.adapters import EnvAdapter
from agents.backend import check_backend, import_ray
from agents.benchmark_stats import bootstrap_ci, cvar, draw_bootstrap_ci, wilson_ci
from agents.benchmark_stats import summarize as _summarize
from hydro_envs import registry

__all__ = [
    "ADAPTERS",
    "METRICS",
    "OUT_FACTOR",
    "PARAM_SETS",
    "BenchmarkResult",
    "bootstrap_ci",
    "cvar",
    "draw_bootstrap_ci",
    "draw_parameters",
    "dry_friction_free",
    "FRICTION_CRITICAL",
    "rollout",
    "run_benchmark",
    "step_metrics",
    "wilson_ci",
]

PARAM_SETS = ("nominal", "in", "out")
OUT_FACTOR = 2.0
SERIAL_BELOW = 256  # copies: below this the batch is stepped by the serial kernel
#: (key, label) of the reported metrics, in table order
METRICS = (
    ("rmse", "RMSE"),
    ("max_error", "max error"),
    ("overshoot", "overshoot [%]"),
    ("settling_time", "settling [s]"),
    ("reversal_error", "reversal error"),
    ("reversal_excess", "reversal excess"),
    ("steady_state_error", "steady-state error"),
    ("limit_cycle", "limit cycle (p-p)"),
    ("hunting", "hunting (p-p, holds >= 2 s)"),
    ("stick_time", "stick time [-]"),
    ("effort", "effort (RMS a)"),
    ("pressure_violations", "pressure viol. [steps]"),
    ("endstop_steps", "end-stop [steps]"),
    ("failed", "failure rate"),
    ("cvar10_rmse", "CVaR10 RMSE"),
    ("rmse_rel_pid", "RMSE / PID (paired)"),
    ("friction_share", "friction share"),
)
PAIRED_REFERENCE = "pid"
#: ``friction_share`` at or above which a task is friction-critical
FRICTION_CRITICAL = 0.5


# ------------------------------------------------------------------ env adapters
def _discover_adapters() -> dict[str, EnvAdapter]:
    """Every env id of a plant whose controller module declares ``benchmark_adapter``."""
    from agents.controllers import controller_module

    out: dict[str, EnvAdapter] = {}
    for spec in registry.specs():
        mod = controller_module(spec.name) if spec.envs else None
        if mod is not None and hasattr(mod, "benchmark_adapter"):
            for env_id in spec.env_ids:
                out[env_id] = mod.benchmark_adapter(env_id)
    return out


class _Adapters(Mapping):
    """env id -> :class:`EnvAdapter`, discovered on first use (so ``hydro --help`` stays light)."""

    def __init__(self) -> None:
        self._data: dict[str, EnvAdapter] | None = None

    def _load(self) -> dict[str, EnvAdapter]:
        if self._data is None:
            self._data = _discover_adapters()
        return self._data

    def __getitem__(self, key: str) -> EnvAdapter:
        return self._load()[key]

    def __iter__(self):
        return iter(self._load())

    def __len__(self) -> int:
        return len(self._load())


#: env id -> what the benchmark reads of it (from the plants' controller modules)
ADAPTERS: Mapping[str, EnvAdapter] = _Adapters()


def _adapter(env_id: str) -> EnvAdapter:
    if env_id not in ADAPTERS:
        raise ValueError(f"env = {env_id!r}; the benchmark supports {sorted(ADAPTERS)}")
    return ADAPTERS[env_id]


def _rig_params(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """The nominal parameters of the rig ``env_kwargs["params"]`` names (``None``: the seed rig)."""
    if env_kwargs.get("params") is None:
        return None
    venv = _vector_env(env_id, 1, None, False, **dict(env_kwargs))
    base = venv.batch.base_params
    venv.close()
    return base


def _vector_env(env_id: str, n: int, steps: int | None, randomize: bool, **kwargs: Any):
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    import hydro_envs  # noqa: F401  (registers the envs)

    spec = gym.spec(env_id)
    cls = load_env_creator(spec.vector_entry_point)
    if steps is None:
        steps = spec.max_episode_steps
    return cls(num_envs=n, max_episode_steps=int(steps), randomize=randomize, **kwargs)


# ------------------------------------------------------------------ parameter draws
def draw_parameters(env_id: str, params: str, n: int, seed: int = 0,
                    factor: float = OUT_FACTOR, env_kwargs: Mapping[str, Any] | None = None) -> list[dict[str, float]]:
    """``n`` frozen parameter draws (dicts of the randomised parameters; ``{}`` = nominal).

    ``params`` in :data:`PARAM_SETS`. The draws come from ``default_rng([seed, 7])``, so they
    do not depend on the controllers, the episode seeds or the reference. ``env_kwargs`` reach
    the env that holds the randomisation spec (e.g. ``randomization=FILE``: a calibrated spec
    written by ``hydro identify ... --emit-ranges``).
    """
    if params not in PARAM_SETS:
        raise ValueError(f"params = {params!r}; allowed {PARAM_SETS}")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    if params == "nominal":
        return [{} for _ in range(n)]
    if not (math.isfinite(factor) and factor > 1.0):
        raise ValueError(f"factor must be > 1, got {factor}")
    venv = _vector_env(env_id, 1, None, True, **dict(env_kwargs or {}))
    batch = venv.batch
    spec, base = batch.spec, batch.base_params
    venv.close()
    if spec is None or not spec.entries:
        raise ValueError(f"params = {params!r}: {env_id} has no randomisation spec; use 'nominal'")
    rng = np.random.default_rng([int(seed), 7])
    out: list[dict[str, float]] = []
    wide = spec.widened(factor)
    attempts = 0
    while len(out) < n:
        attempts += 1
        if attempts > 1000 * n:
            raise RuntimeError(f"could not draw {n} valid '{params}' parameter sets for {env_id}")
        if params == "in":
            p = spec.sample(rng, base)
            out.append({e.name: float(getattr(p, e.name)) for e in spec.entries})
            continue
        values = {}
        for e, w in zip(spec.entries, wide.entries):
            nom = getattr(base, e.name)
            lo, hi = e.value_range(nom)
            for _ in range(1000):
                v = w.sample(rng, nom)
                if v < lo or v > hi:
                    break
            values[e.name] = float(v)
        try:
            batch.params_cls.from_mapping(values, base=base)
            batch.substeps_for(batch.params_cls.from_mapping(values, base=base))
        except (ValueError, ZeroDivisionError, OverflowError):
            continue
        out.append(values)
    return out


def dry_friction_free(env_id: str, draws: Sequence[Mapping[str, float]]) -> list[dict[str, float]]:
    """The draws with the plant's dry friction removed: every parameter of its
    :attr:`~hydro_envs.spec.PlantSpec.dry_friction_parameters` set to 0 (viscous friction kept)."""
    spec = registry.spec_for_env(env_id)
    return [spec.without_dry_friction(d) for d in draws]


# ------------------------------------------------------------------ metrics
def step_metrics(y: np.ndarray, r: np.ndarray, dt: float, *, settle_frac: float = 0.02,
                 settle_abs: float = 0.0, min_step: float | None = None) -> tuple[float, float, int]:
    """Mean overshoot [%] and settling time [s] over the reference jumps of one episode.

    A jump at index ``j`` (``r[j] != r[j-1]`` by more than ``min_step``, default 10 % of the
    reference's range) starts a segment that ends at the next jump. Overshoot =
    ``max(0, max_seg sgn(D) (y - r_new)) / |D| * 100``; settling time = time from the jump to
    the first sample after which ``|y - r_new|`` stays within ``max(settle_frac |D|,
    settle_abs)`` until the segment ends (a segment that ends outside the band counts its whole
    length: a lower bound). Returns ``(overshoot, settling, n_jumps)``; NaNs without jumps.
    """
    y = np.asarray(y, dtype=float)
    r = np.asarray(r, dtype=float)
    if min_step is None:
        span = float(np.max(r) - np.min(r))
        min_step = 0.1 * span if span > 0 else np.inf
    d = np.diff(r)
    jumps = np.flatnonzero(np.abs(d) > min_step) + 1
    if jumps.size == 0:
        return float("nan"), float("nan"), 0
    ends = np.append(jumps[1:], r.size)
    overs, settles = [], []
    for j, end in zip(jumps, ends):
        delta = r[j] - r[j - 1]
        seg = y[j:end] - r[j]
        overs.append(max(0.0, float(np.max(np.sign(delta) * seg))) / abs(delta) * 100.0)
        band = max(settle_frac * abs(delta), settle_abs)
        outside = np.flatnonzero(np.abs(seg) > band)
        settles.append(0.0 if outside.size == 0 else (outside[-1] + 1) * dt)
    return float(np.mean(overs)), float(np.mean(settles)), int(jumps.size)


# ------------------------------------------------------------------ rollout
@dataclasses.dataclass
class Rollout:
    """Per-step true output, reference and action of a batch, plus per-copy counters."""

    y: np.ndarray  # (steps, n)
    ref: np.ndarray  # (steps, n)
    actions: np.ndarray  # (steps, n, action_dim)
    pressure_violations: np.ndarray  # (n,)
    endstop_steps: np.ndarray  # (n,)
    nonfinite: np.ndarray  # (n,) bool
    params: np.ndarray  # (n, n_params) parameter arrays after reset
    dt: float


def rollout(env_id: str, controller: Any, draws: Sequence[Mapping[str, float]], *, seed: int = 0,
            reference: str | None = None, steps: int | None = None,
            env_kwargs: Mapping[str, Any] | None = None) -> Rollout:
    """Run ``controller`` on ``len(draws)`` copies of the native vector env: copy ``i`` has the
    parameters ``draws[i]`` and is reset with seed ``seed + i`` (and ``reference`` if given)."""
    ad = _adapter(env_id)
    n = len(draws)
    venv = _vector_env(env_id, n, steps, False, **dict(env_kwargs or {}))
    b = venv.batch
    # a few dozen copies: the serial kernel (entering numba's parallel region costs more than
    # stepping 20 copies, 8 ms vs 0.1 ms per step on a loaded 2-core machine)
    b.parallel = n >= SERIAL_BELOW
    b.check_finite = False  # a non-finite copy is scored as failed (episode_metrics), not raised
    steps = venv.max_episode_steps
    # every copy once (the vector env requires it), then each copy with its draw; the second
    # reset reseeds copy i with seed + i, so the first leaves no trace
    venv.reset(seed=int(seed), options={"reference": reference} if reference is not None else None)
    for i, d in enumerate(draws):
        mask = np.zeros(n, dtype=bool)
        mask[i] = True
        opts: dict[str, Any] = {"reset_mask": mask}
        if d:
            opts["params"] = dict(d)
        if reference is not None:
            opts["reference"] = reference
        obs, _ = venv.reset(seed=int(seed), options=opts)
    params = b.P.copy()
    calibrate = getattr(controller, "calibrate", None)
    if callable(calibrate):  # a controller identified on each plant draw it controls
        k = len(b.params_cls.names())
        calibrate([b.params_cls.from_array(row[:k]) for row in params])
    adim = b.action_dim
    Y = np.zeros((steps, n))
    R = np.zeros((steps, n))
    A = np.zeros((steps, n, adim))
    pv = np.zeros(n)
    es = np.zeros(n)
    bad = np.zeros(n, dtype=bool)
    start = np.ones(n, dtype=bool)
    clamps0 = b.clamps.copy()
    for k in range(steps):
        obs_in = np.where(np.isfinite(obs), obs, 0.0)
        a, _ = controller.predict(obs_in, episode_start=start.copy(), deterministic=True)
        start[:] = False
        a = np.asarray(a, dtype=np.float64).reshape(n, adim)
        fin = np.all(np.isfinite(a), axis=1)
        bad |= ~fin
        a = np.where(np.isfinite(a), a, 0.0)
        obs, _, _, _, _ = venv.step(a)
        y, r = ad.output(b)
        Y[k], R[k], A[k] = y, r, np.clip(a, -1, 1)
        bad |= ~np.isfinite(y) | ~np.all(np.isfinite(b.Y), axis=1)
        if ad.pressures is not None:
            p, lo, hi = ad.pressures(b)
            pv += np.any((p <= lo[:, None] * (1 + 1e-9)) | (p > hi[:, None]), axis=1)
        if ad.outside_stroke is not None:
            es += ad.outside_stroke(b)
    if ad.pressures is not None:
        pv += b.clamps - clamps0
    else:
        pv[:] = np.nan
    if ad.outside_stroke is None:
        es[:] = np.nan
    dt = float(b.dt)
    venv.close()
    return Rollout(Y, R, A, pv, es, bad, params, dt)


def episode_metrics(track: Rollout, step: Rollout | None, adapter: EnvAdapter) -> dict[str, np.ndarray]:
    """Per-episode metrics (see the module docstring) from a tracking and a step rollout.

    Every per-episode mean runs over one contiguous row per episode (episodes x steps), so an
    episode's value does not depend on how many other episodes share the batch: numpy sums a
    contiguous row pairwise but accumulates a column of a (steps x episodes) array step by
    step, and the two differ in the last bit. This keeps chunked (Ray) runs bit-identical.
    """
    e = np.ascontiguousarray((track.ref - track.y).T)  # (n, steps)
    with np.errstate(invalid="ignore"):
        rmse = np.sqrt(np.mean(e**2, axis=1))
        max_err = np.max(np.abs(e), axis=1)
        hold = np.sqrt(np.mean(np.ascontiguousarray((track.ref - track.y[0][None, :]).T) ** 2, axis=1))
    acts = np.ascontiguousarray(np.swapaxes(track.actions, 0, 1)).reshape(track.actions.shape[1], -1)
    effort = np.sqrt(np.mean(acts**2, axis=1))
    failed = track.nonfinite | ~np.isfinite(rmse) | (rmse >= hold)
    n = rmse.size
    over = np.full(n, np.nan)
    settle = np.full(n, np.nan)
    if step is not None:
        for i in range(n):
            if step.nonfinite[i]:
                continue
            over[i], settle[i], _ = step_metrics(step.y[:, i], step.ref[:, i], step.dt,
                                                 settle_abs=adapter.settle_abs)
        failed = failed | step.nonfinite
    fric = friction_metrics(track, step)
    return {"rmse": np.where(track.nonfinite, np.nan, rmse), "max_error": np.where(track.nonfinite, np.nan, max_err),
            "overshoot": over, "settling_time": settle, **fric, "effort": effort,
            "pressure_violations": track.pressure_violations + (step.pressure_violations if step is not None else 0),
            "endstop_steps": track.endstop_steps + (step.endstop_steps if step is not None else 0),
            "failed": failed.astype(float)}


def friction_metrics(track: Rollout, step: Rollout | None) -> dict[str, np.ndarray]:
    """Per-episode :mod:`agents.metrics` (module docstring): reversal error and stick time of
    the tracking episodes, steady-state error and limit cycle of the step episodes (of the
    tracking episodes without step episodes). NaN for a non-finite episode."""
    n = track.y.shape[1]
    out = {k: np.full(n, np.nan) for k in ("reversal_error", "stick_time", "steady_state_error", "limit_cycle",
                                           "hunting")}
    hold = step if step is not None else track
    for i in range(n):
        if not track.nonfinite[i]:
            y, r = track.y[:, i], track.ref[:, i]
            out["reversal_error"][i] = fm.reversal_error(y, r, track.dt)
            out["stick_time"][i] = fm.stick_time(y, r, track.dt)
        if not hold.nonfinite[i]:
            y, r = hold.y[:, i], hold.ref[:, i]
            out["steady_state_error"][i] = fm.steady_state_error(y, r, hold.dt)
            out["limit_cycle"][i] = fm.limit_cycle_amplitude(y, r, hold.dt)
            out["hunting"][i] = fm.hunting(y, r, hold.dt)
    return out


def summarize(episodes: Mapping[str, np.ndarray], seed: int = 0,
              n_draws: int | None = None) -> dict[str, tuple[float, float, float, int]]:
    """Metric -> (value, ci_lo, ci_hi, n) for one controller (:func:`agents.benchmark_stats.summarize`
    over :data:`METRICS`; episode ``j`` belongs to draw ``j % n_draws``)."""
    return _summarize(episodes, [k for k, _ in METRICS], seed=seed, n_draws=n_draws)


# ------------------------------------------------------------------ controllers
_SEED_SUFFIX = re.compile(r"[_-](s|seed)\d+$")


def _load_policy(run_dir: str, trust_pickle: bool = False) -> Any:
    """``agents.policies.load_trained(run_dir)`` (imported lazily: training is optional); pickles
    only with ``trust_pickle``."""
    try:
        from agents.policies import load_trained
    except ImportError as exc:  # pragma: no cover - depends on the training package
        raise ValueError(f"controller 'sb3:{run_dir}' needs agents.policies.load_trained: {exc}") from exc
    return load_trained(run_dir, trust_pickle=trust_pickle)


def _checked_policy(policy: Any, run_dir: str, env_id: str) -> Any:
    """Reject a trained policy of another env (``policy.env_id`` when it has one)."""
    trained_on = getattr(policy, "env_id", "")
    if isinstance(trained_on, str) and trained_on and trained_on != env_id:
        raise ValueError(f"controllers: sb3:{run_dir} was trained on {trained_on}, not on {env_id}")
    if not hasattr(policy, "predict"):
        raise ValueError(f"controllers: sb3:{run_dir} loaded an object without predict()")
    return policy


def parse_controllers(env_id: str, specs: Sequence[str] | str) -> list[tuple[str, str, str | None]]:
    """``[(name, kind, payload)]`` (payload: classical name or run folder) from specs: classical names, ``sb3:RUN_DIR`` or
    ``NAME=sb3:RUN_DIR``. Unknown names raise naming the allowed ones."""
    from agents.controllers import controller_names

    if isinstance(specs, str):
        specs = [s for s in specs.split(",")]
    specs = [s.strip() for s in specs if s and s.strip()]
    if not specs:
        raise ValueError("controllers must name at least one controller")
    allowed = controller_names(env_id)
    out = []
    for s in specs:
        name = None
        body = s
        if "=" in s:
            name, body = s.split("=", 1)
        if body.startswith("sb3:"):
            run = body[4:]
            if not run:
                raise ValueError(f"controller spec {s!r}: 'sb3:' needs a run folder")
            label = name or _SEED_SUFFIX.sub("", Path(run.rstrip("/")).name) or "sb3"
            out.append((label, "sb3", run))
        else:
            if body not in allowed:
                raise ValueError(f"controllers: unknown controller {body!r} for {env_id}; allowed "
                                 f"{', '.join(allowed)} or sb3:RUN_DIR")
            out.append((name or body, "classical", body))
    return out


# ------------------------------------------------------------------ benchmark
@dataclasses.dataclass
class BenchmarkResult:
    env_id: str
    params: str
    n: int
    seed: int
    draws: list[dict[str, float]]
    episodes: dict[str, dict[str, np.ndarray]]  # controller -> metric -> per-episode values
    summary: dict[str, dict[str, tuple[float, float, float, int]]]
    members: dict[str, int]  # controller -> number of policies pooled (training seeds)
    param_arrays: dict[str, np.ndarray]  # controller -> (n, n_params) parameters used
    traces: dict[str, tuple[np.ndarray, np.ndarray]]  # controller -> (y, ref) of draw 0
    dt: float
    files: list[Path] = dataclasses.field(default_factory=list)
    seconds: float = 0.0

    def markdown(self) -> str:
        ad = ADAPTERS[self.env_id]
        lines = [f"### {self.env_id}: params = {self.params}, n = {self.n} draws, seed = {self.seed}", ""]
        lines.append(f"Tracked quantity: {ad.quantity} [{ad.unit}]; RMSE, max error, reversal error, "
                     f"steady-state error, limit cycle and CVaR in {ad.unit}. Values: mean [95 % percentile-"
                     "bootstrap interval over the draws; RMSE / PID: paired; failure rate: Wilson].")
        if ad.note:
            lines.append(f"Note: {ad.note}.")
        lines.append("")
        head = ["controller"] + [lab for _, lab in METRICS]
        lines.append("| " + " | ".join(head) + " |")
        lines.append("|" + "---|" * len(head))
        for c, s in self.summary.items():
            label = c if self.members.get(c, 1) == 1 else f"{c} ({self.members[c]} seeds)"
            cells = [label]
            for key, _ in METRICS:
                m, lo, hi, _ = s[key]
                cells.append("n/a" if not np.isfinite(m) and not np.isinf(m) else f"{_fmt(m)} [{_fmt(lo)}, {_fmt(hi)}]")
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"


def _fmt(x: float) -> str:
    if not np.isfinite(x):
        return "inf" if np.isinf(x) else "n/a"
    if x == 0:
        return "0"
    return f"{x:.3g}"


def run_benchmark(
    env_id: str,
    controllers: Sequence[str] | str,
    params: str = "nominal",
    n: int = 20,
    seed: int = 0,
    out_dir: str | Path | None = None,
    *,
    episode_steps: int | None = None,
    reference: str | None = None,
    step_reference: str | None = "auto",
    figures: bool = True,
    policy_loader: Callable[[str], Any] | None = None,
    trust_pickle: bool = False,
    env_kwargs: Mapping[str, Any] | None = None,
    progress: Callable[[str], None] | None = None,
    backend: str = "serial",
    chunk_size: int | None = None,
    ray_address: str | None = None,
    num_cpus: int | None = None,
    friction_share: bool = True,
) -> BenchmarkResult:
    """Evaluate ``controllers`` on ``n`` frozen draws of the ``params`` set (module docstring).

    ``episode_steps`` (default: the env's registered length), ``reference`` (tracking
    reference kind; default the env's default), ``step_reference`` (``"auto"``: the env's step
    kind from :data:`ADAPTERS`; ``None``: skip the step episodes). Writes
    ``<plant>_<params>.md``, ``.json``, ``.csv``, ``_episodes.csv``, ``_draws.csv`` and (``figures``)
    ``_box.png``, ``_traces.png`` to ``out_dir`` if given.

    ``backend="ray"`` evaluates the pieces as Ray core tasks (:mod:`agents.backend`; cluster
    ``ray_address`` or ``$RAY_ADDRESS``, else a local Ray with ``num_cpus``): a classical
    controller on a contiguous chunk of ``chunk_size`` draws per task (default: enough chunks
    to give every CPU one task), a learned policy on all draws in one task. A chunk starting
    at draw ``lo`` resets its copy ``j`` with seed ``seed + lo + j``, the seed of draw
    ``lo + j`` in the serial batch, so every metric is the same bit for bit.

    ``friction_share``: also run every controller on the same draws and tracking episodes without
    dry friction (:func:`dry_friction_free`) and report the share of its mean squared error that
    dry friction causes and its reversal excess (module docstring).
    """
    t0 = time.perf_counter()
    _adapter(env_id)
    if params not in PARAM_SETS:
        raise ValueError(f"params = {params!r}; allowed {PARAM_SETS}")
    if check_backend(backend) == "ray":
        import_ray()  # fail before any work when the extra is missing
    specs = parse_controllers(env_id, controllers)
    draws = draw_parameters(env_id, params, n, seed, env_kwargs=env_kwargs)
    step_kind = ADAPTERS[env_id].step_reference if step_reference == "auto" else step_reference
    loader = policy_loader or (functools.partial(_load_policy, trust_pickle=True) if trust_pickle else _load_policy)
    say = progress or (lambda msg: None)
    dry_free = bool(friction_share and registry.spec_for_env(env_id).dry_friction_parameters)
    common = (env_id, seed, reference, step_kind, episode_steps, dict(env_kwargs or {}), loader, dry_free)

    if backend == "serial":  # one piece per controller spec, all draws in one batch
        parts = []
        for name, kind, run in specs:
            say(f"{env_id} [{params}] {name}{'' if kind == 'classical' else ' <- ' + run} ...")
            parts.append(_evaluate_piece(kind, run, 0, draws, *common))
    else:
        parts = _evaluate_on_ray(specs, draws, common, chunk_size, ray_address, num_cpus, say,
                                 f"{env_id} [{params}]")

    episodes: dict[str, dict[str, list[np.ndarray]]] = {}
    members: dict[str, int] = {}
    param_arrays: dict[str, np.ndarray] = {}
    traces: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    dt = 0.0
    for (name, _kind, _run), part in zip(specs, parts):
        m = part.metrics
        dt = part.dt
        if name in episodes:
            for k, v in m.items():
                episodes[name][k].append(v)
            members[name] += 1
        else:
            episodes[name] = {k: [v] for k, v in m.items()}
            members[name] = 1
            traces[name] = part.trace
        param_arrays.setdefault(name, part.params)
        if not np.array_equal(param_arrays[name], part.params):  # pragma: no cover - invariant
            raise RuntimeError("parameter draws differ between members of one controller")
    pooled = {c: {k: np.concatenate(v) for k, v in d.items()} for c, d in episodes.items()}
    if PAIRED_REFERENCE in pooled:
        ref = pooled[PAIRED_REFERENCE]["rmse"][:n]
        for c, d in pooled.items():  # paired: episode j of every member vs the PID's draw j % n
            with np.errstate(divide="ignore", invalid="ignore"):
                d["rmse_rel_pid"] = d["rmse"] / np.tile(ref, members[c])
    summary = {c: summarize(v, seed, n) for c, v in pooled.items()}
    res = BenchmarkResult(env_id, params, n, seed, draws, pooled, summary, members, param_arrays, traces, dt)
    if out_dir is not None:
        res.files = write_outputs(res, Path(out_dir), figures=figures)
    res.seconds = time.perf_counter() - t0
    return res


# ------------------------------------------------------------------ pieces (serial or Ray tasks)
@dataclasses.dataclass
class _Piece:
    """Metrics of one controller on the draws ``[lo, hi)`` (a whole spec, or one Ray task)."""

    metrics: dict[str, np.ndarray]
    params: np.ndarray  # (hi - lo, n_params)
    trace: tuple[np.ndarray, np.ndarray]  # (y, ref) of the piece's first copy
    dt: float


def _evaluate_piece(kind: str, run: str, lo: int, part: Sequence[Mapping[str, float]], env_id: str,
                    seed: int, reference: str | None, step_kind: str | None, steps: int | None,
                    env_kwargs: Mapping[str, Any], loader: Callable[[str], Any], dry_free: bool = False) -> _Piece:
    """Tracking (and step) episodes of one controller on ``part`` = draws ``lo, lo + 1, ...``.

    Copy ``j`` of the batch is draw ``lo + j`` reset with seed ``seed + lo + j``: the same
    episode as in a batch of all draws, so pieces can run anywhere and be concatenated.
    ``dry_free``: also the tracking episodes on the same draws without dry friction
    (:func:`dry_friction_free`), for ``friction_share`` and ``reversal_excess``.
    """
    from agents.controllers import make_controller

    if kind == "classical":  # a rig from a parameter file: the controllers are tuned on it
        ctrl = make_controller(env_id, run, _rig_params(env_id, env_kwargs))
    else:
        ctrl = _checked_policy(loader(run), run, env_id)
    # one controller object for both episode sets (episode_start resets its state)
    if kind == "classical" and hasattr(ctrl, "reset"):
        ctrl.reset()
    part = list(part)
    track = rollout(env_id, ctrl, part, seed=seed + lo, reference=reference, steps=steps, env_kwargs=env_kwargs)
    step = None
    if step_kind is not None:
        if kind == "classical" and hasattr(ctrl, "reset"):
            ctrl.reset()
        step = rollout(env_id, ctrl, part, seed=seed + lo, reference=step_kind, steps=steps, env_kwargs=env_kwargs)
    m = episode_metrics(track, step, ADAPTERS[env_id])
    if dry_free:
        if kind == "classical" and hasattr(ctrl, "reset"):
            ctrl.reset()
        free = rollout(env_id, ctrl, dry_friction_free(env_id, part), seed=seed + lo, reference=reference,
                       steps=steps, env_kwargs=env_kwargs)
        m.update(dry_free_metrics(track, free))
    return _Piece(m, track.params, (track.y[:, 0].copy(), track.ref[:, 0].copy()), track.dt)


def dry_free_metrics(track: Rollout, free: Rollout) -> dict[str, np.ndarray]:
    """Per episode: ``mse_dry_free`` (the mean squared error of the twin episode without dry
    friction, for ``friction_share``) and ``reversal_excess`` (the reversal error less the
    twin's: what friction adds with the loop's lag removed). NaN for a non-finite episode."""
    n = track.y.shape[1]
    e0 = np.ascontiguousarray((free.ref - free.y).T)
    with np.errstate(invalid="ignore"):
        mse0 = np.where(free.nonfinite, np.nan, np.mean(e0**2, axis=1))
    excess = np.full(n, np.nan)
    for i in range(n):
        if not (track.nonfinite[i] or free.nonfinite[i]):
            excess[i] = (fm.reversal_error(track.y[:, i], track.ref[:, i], track.dt)
                         - fm.reversal_error(free.y[:, i], free.ref[:, i], free.dt))
    return {"mse_dry_free": mse0, "reversal_excess": excess}


def _merge(pieces: Sequence[_Piece]) -> _Piece:
    """Concatenate the pieces of one controller (in draw order) into the whole-batch result."""
    first = pieces[0]
    metrics = {k: np.concatenate([p.metrics[k] for p in pieces]) for k in first.metrics}
    return _Piece(metrics, np.concatenate([p.params for p in pieces]), first.trace, first.dt)


def _evaluate_on_ray(specs: Sequence[tuple[str, str, str]], draws: Sequence[Mapping[str, float]], common: tuple,
                     chunk_size: int | None,
                     address: str | None, num_cpus: int | None, say: Callable[[str], None],
                     label: str) -> list[_Piece]:
    """One Ray task per (controller, chunk of draws); the merged piece of every spec, in order.

    Learned policies are not split: a network's output may depend on the batch size in the
    last bits (BLAS blocking), and loading the policy is the expensive part of its task.
    """
    from agents.backend import chunk_ranges, cluster_cpus, run_tasks

    n = len(draws)
    if chunk_size is None:
        classical = sum(1 for _, kind, _ in specs if kind == "classical")
        cpus = cluster_cpus("ray", address, num_cpus)
        chunk_size = n if classical == 0 else min(n, max(1, math.ceil(classical * n / cpus)))
    calls, owner = [], []
    for s, (_name, kind, run) in enumerate(specs):
        ranges = chunk_ranges(n, chunk_size) if kind == "classical" else [(0, n)]
        for lo, hi in ranges:
            calls.append((kind, run, lo, list(draws[lo:hi]), *common))
            owner.append(s)
    say(f"{label}: {len(calls)} Ray tasks ({len(specs)} controller specs, chunks of <= {chunk_size} draws) ...")
    done = [0] * len(specs)
    total = [owner.count(s) for s in range(len(specs))]

    def report(i: int, _piece: _Piece) -> None:
        s = owner[i]
        done[s] += 1
        if done[s] == total[s]:
            name, kind, run = specs[s]
            say(f"{label} {name}{'' if kind == 'classical' else ' <- ' + run} done")

    pieces = run_tasks(_evaluate_piece, calls, backend="ray", address=address, num_cpus=num_cpus,
                       on_result=report)
    return [_merge([p for p, o in zip(pieces, owner) if o == s]) for s in range(len(specs))]


# ------------------------------------------------------------------ outputs
def _tag(env_id: str) -> str:
    """File stem of an env: its plant's name for the plant's first env, else the id made safe."""
    try:
        spec = registry.spec_for_env(env_id)
    except KeyError:
        spec = None
    if spec is not None and spec.envs and spec.envs[0].id == env_id:
        return spec.name
    return re.sub(r"[^A-Za-z0-9]+", "_", env_id.split("/")[-1])


def write_outputs(res: BenchmarkResult, out_dir: Path, *, figures: bool = True) -> list[Path]:
    """Write the result's tables (and figures) into ``out_dir``; their paths. The files are
    committed together (:class:`hydro_envs.outputs.Staged`): a failed write (a full disk) raises
    ``OSError`` naming the file and leaves none of this result's files."""
    from hydro_envs.outputs import Staged

    out_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{_tag(res.env_id)}_{res.params}"
    with Staged(out_dir) as stage:
        files = [stage.write(f"{stem}.md", res.markdown()),
                 stage.write(f"{stem}.json", json.dumps(result_json(res), indent=1) + "\n")]
        with open(stage.path(f"{stem}.csv"), "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["env", "params", "controller", "seeds", "metric", "value", "ci_low", "ci_high", "n"])
            for c, s in res.summary.items():
                for key, _ in METRICS:
                    v, lo, hi, k = s[key]
                    w.writerow([res.env_id, res.params, c, res.members[c], key, repr(v), repr(lo), repr(hi), k])
        files.append(out_dir / f"{stem}.csv")
        keys = [k for k, _ in METRICS if k not in ("cvar10_rmse", "friction_share")] + ["mse_dry_free"]
        with open(stage.path(f"{stem}_episodes.csv"), "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["controller", "episode", "draw"] + keys)
            for c, d in res.episodes.items():
                for j in range(d["rmse"].size):
                    w.writerow([c, j, j % res.n] + [repr(float(d[k][j])) if k in d else "nan" for k in keys])
        files.append(out_dir / f"{stem}_episodes.csv")
        names = sorted({k for d in res.draws for k in d})
        with open(stage.path(f"{stem}_draws.csv"), "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["draw", "episode_seed"] + names)
            for j, d in enumerate(res.draws):
                w.writerow([j, res.seed + j] + [repr(d[k]) for k in names])
        files.append(out_dir / f"{stem}_draws.csv")
        if figures:
            files += _figures(res, out_dir, stem, stage)
    return files


def _figures(res: BenchmarkResult, out_dir: Path, stem: str, stage: Any = None) -> list[Path]:
    from agents.benchmark_figures import write_figures

    ad = ADAPTERS[res.env_id]
    keys = [(k, lab) for k, lab in METRICS if k not in ("cvar10_rmse", "failed", "friction_share")]
    return write_figures(res, out_dir, stem, keys, ad.quantity, ad.unit, stage)


def result_json(res: BenchmarkResult) -> dict[str, Any]:
    """The summary table as a JSON-ready dict: per controller and metric value, interval, n, unit."""
    from agents.benchmark_figures import metric_unit

    ad = ADAPTERS[res.env_id]

    def num(x: float) -> float | str | None:
        return None if math.isnan(x) else (("inf" if x > 0 else "-inf") if math.isinf(x) else float(x))

    return {
        "env": res.env_id, "params": res.params, "n_draws": res.n, "seed": res.seed,
        "quantity": ad.quantity, "unit": ad.unit, "interval": "95 %: percentile bootstrap over draws "
        "(rmse_rel_pid paired), failure rate Wilson",
        "metrics": {k: {"label": lab, "unit": metric_unit(k, ad.unit)} for k, lab in METRICS},
        "controllers": {c: {"seeds": res.members[c], **{k: {"value": num(v), "ci_low": num(lo), "ci_high": num(hi),
                                                           "n": int(m)} for k, (v, lo, hi, m) in s.items()}}
                        for c, s in res.summary.items()},
    }
