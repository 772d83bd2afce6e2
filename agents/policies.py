"""Trained SB3 agents as policy objects for evaluation and benchmarking.

:func:`load_trained` opens a run folder written by :func:`agents.train.train` and returns a
:class:`TrainedPolicy` with the SB3-style ``predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`` that the classical controllers of
:mod:`agents.controllers` also expose. It applies the run's *frozen* ``VecNormalize``
observation normalisation (the statistics saved at the end of training, or with the best
evaluation for ``which="best"``) and then the model, so callers pass raw env observations.

Run-folder layout (names are the constants below)::

    config.yml          resolved hyperparameters, rl-zoo format keyed by the env id
    args.json           the arguments of the run (env id, algo, seed, randomisation, eval set)
    policy.pt           final policy weights          obs_normalization.npz       its statistics
    best_policy.pt      best evaluated weights        best_obs_normalization.npz  its statistics
    model.zip           final SB3 model (to resume)   vecnormalize.pkl            its statistics
    best_model.zip      best SB3 model                best_vecnormalize.pkl       its statistics
    evaluations.csv/npz periodic evaluation log       tb/                         TensorBoard logs

**Checked on loading.** The observation statistics must be there when the run trained with
observation normalisation (``normalize.norm_obs`` in its ``config.yml``, on by default), their
``mean`` and ``var`` must have the shape of the env's observation space (frame stacks included)
and every variance must be at least :data:`VAR_FLOOR` (a zero variance turns any deviation into
a clipped +-``clip_obs``); a ``policy.pt`` that is not the saved weights of this policy, a
malformed ``config.yml`` / ``args.json`` or statistics written with other weights (their
``policy_sha256``) are one-line errors (``ValueError``) naming the file.

**Written as one unit.** :func:`write_compact` writes the weights and the statistics into a
temporary folder inside the destination, stamps the statistics with the SHA-256 of the weights
they belong to, and renames the statistics and then the weights into place: a kill at any point
leaves the old pair, or a pair whose stamp does not match (refused on loading), never a policy
silently run on the wrong statistics.

**Loading never unpickles by default.** :func:`load_trained` reads the safe layout: the
policy's ``state_dict`` with ``torch.load(weights_only=True)`` and the frozen observation
statistics (mean, var, clip_obs, epsilon) from an ``.npz`` read with ``allow_pickle=False``;
:func:`agents.train.train` writes it at the end of every run (and with every new best
evaluation), next to SB3's zip, which SB3 needs to resume training. SB3 zips (their
``data`` entry is cloudpickled) and ``vecnormalize.pkl`` are pickles: a pickle from someone
else can execute arbitrary code the moment it is loaded. They are read only with
``trust_pickle=True`` (``hydro benchmark --trust-pickle``); without it, a folder that has only
the pickle layout is a :class:`UntrustedPickleError` that says so. Convert a folder you trust
once with ``export_compact(run, dest, trust_pickle=True)``.

Compact folders (:func:`export_compact`, the pre-trained baselines in ``agents/pretrained/``)
hold only the safe layout, about 45 kB for a 64-64 PPO policy instead of 330 kB::

    config.yml, args.json, policy.pt, obs_normalization.npz

Both layouts give bit-identical actions (tested).

An rl_zoo3 run folder (``logs/<algo>/<env>_<n>/``) is read too (:mod:`agents.zoo`); its files
are pickles, so it needs ``trust_pickle=True``, and ``export_compact`` turns it into a compact
folder of this package.

A run trained as a residual on a classical controller (a ``residual`` entry in its
``config.yml``, :mod:`agents.residual`) loads as a :class:`agents.residual.ResidualPolicy`
around the :class:`TrainedPolicy`: its ``predict`` returns the combined action the policy was
trained with.
"""

from __future__ import annotations

import json
import math
import os
import pickle
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # agents.residual imports the controllers; loaded lazily at run time
    from agents.residual import ResidualPolicy

__all__ = [
    "ALGOS",
    "MODEL_FILE",
    "VECNORM_FILE",
    "BEST_MODEL_FILE",
    "BEST_VECNORM_FILE",
    "CONFIG_FILE",
    "ARGS_FILE",
    "EVAL_CSV",
    "EVAL_NPZ",
    "TB_DIR",
    "POLICY_FILE",
    "OBS_NORM_FILE",
    "BEST_POLICY_FILE",
    "BEST_OBS_NORM_FILE",
    "ObsNormalizer",
    "VAR_FLOOR",
    "TrainedPolicy",
    "UntrustedPickleError",
    "write_compact",
    "algo_class",
    "export_compact",
    "load_trained",
]

ALGOS = ("ppo", "sac", "td3")
MODEL_FILE = "model.zip"
VECNORM_FILE = "vecnormalize.pkl"
BEST_MODEL_FILE = "best_model.zip"
BEST_VECNORM_FILE = "best_vecnormalize.pkl"
CONFIG_FILE = "config.yml"
ARGS_FILE = "args.json"
EVAL_CSV = "evaluations.csv"
EVAL_NPZ = "evaluations.npz"
TB_DIR = "tb"
POLICY_FILE = "policy.pt"
OBS_NORM_FILE = "obs_normalization.npz"
BEST_POLICY_FILE = "best_policy.pt"
BEST_OBS_NORM_FILE = "best_obs_normalization.npz"


class UntrustedPickleError(ValueError):
    """A run folder has only pickled files and ``trust_pickle`` was not given."""


#: smallest observation variance accepted from saved statistics (the shipped policies' smallest
#: is 8.7e-4); below it a feature was constant in training and any deviation explodes
VAR_FLOOR = 1e-6


def _compact_files(which: str) -> tuple[str, str]:
    return (POLICY_FILE, OBS_NORM_FILE) if which == "final" else (BEST_POLICY_FILE, BEST_OBS_NORM_FILE)


def algo_class(algo: str) -> type:
    """The SB3 algorithm class of ``algo`` (one of :data:`ALGOS`)."""
    import stable_baselines3 as sb3

    classes = {"ppo": sb3.PPO, "sac": sb3.SAC, "td3": sb3.TD3}
    if algo not in classes:
        raise ValueError(f"algo = {algo!r}; allowed {ALGOS}")
    return classes[algo]


class ObsNormalizer:
    """Frozen observation normalisation ``clip((o - mean) / sqrt(var + eps), +-clip_obs)``, the
    formula of SB3's ``VecNormalize.normalize_obs``, from plain arrays (no pickle)."""

    norm_obs = True

    def __init__(self, mean: Any, var: Any, clip_obs: float, epsilon: float, policy_sha256: str = "") -> None:
        self.mean = np.asarray(mean, dtype=np.float64)
        self.var = np.asarray(var, dtype=np.float64)
        if self.mean.shape != self.var.shape or not (np.all(np.isfinite(self.mean)) and np.all(self.var >= 0)):
            raise ValueError("obs normalisation: mean and var must be finite arrays of one shape, var >= 0")
        self.clip_obs, self.epsilon = float(clip_obs), float(epsilon)
        self.training, self.norm_reward = False, False
        #: SHA-256 of the policy weights these statistics were written with ("" if unknown)
        self.policy_sha256 = str(policy_sha256)

    def check(self, shape: tuple[int, ...], where: Any = "obs normalisation") -> "ObsNormalizer":
        """Refuse statistics that do not fit an observation space of ``shape``: mean and var of that
        shape, finite, every var >= :data:`VAR_FLOOR`, ``clip_obs`` > 0 and ``epsilon`` >= 0."""
        for name, a in (("mean", self.mean), ("var", self.var)):
            if a.shape != tuple(shape):
                raise ValueError(f"{where}: {name} has shape {a.shape}; allowed {tuple(shape)}, the env's observation "
                                 "space (statistics of another env or a truncated file)")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{where}: {name} is not finite at index {int(np.flatnonzero(~np.isfinite(a.ravel()))[0])}")
        low = np.flatnonzero(self.var.ravel() < VAR_FLOOR)
        if low.size:
            i = int(low[0])
            raise ValueError(f"{where}: var[{i}] = {float(self.var.ravel()[i]):.3g}; allowed >= {VAR_FLOOR:g} (a zero "
                             "variance turns every deviation of that observation into +-clip_obs)")
        if not (math.isfinite(self.clip_obs) and self.clip_obs > 0):
            raise ValueError(f"{where}: clip_obs = {self.clip_obs!r}; allowed a finite number > 0")
        if not (math.isfinite(self.epsilon) and self.epsilon >= 0):
            raise ValueError(f"{where}: epsilon = {self.epsilon!r}; allowed a finite number >= 0")
        return self

    @property
    def obs_rms(self) -> Any:
        """``mean`` and ``var`` under SB3's ``VecNormalize.obs_rms`` names."""
        from types import SimpleNamespace

        return SimpleNamespace(mean=self.mean, var=self.var)

    @classmethod
    def from_vecnormalize(cls, vn: Any) -> "ObsNormalizer":
        return cls(vn.obs_rms.mean, vn.obs_rms.var, vn.clip_obs, vn.epsilon)

    @classmethod
    def load(cls, path: str | Path) -> "ObsNormalizer":
        """Read the statistics (never unpickling); a missing key or a file that is not an ``.npz``
        is a ``ValueError`` naming the file."""
        try:
            with np.load(path, allow_pickle=False) as z:
                missing = [k for k in ("mean", "var", "clip_obs", "epsilon") if k not in z.files]
                if missing:
                    raise ValueError(f"{path}: missing {', '.join(missing)}; an obs_normalization.npz holds mean, "
                                     "var, clip_obs, epsilon")
                sha = str(z["policy_sha256"]) if "policy_sha256" in z.files else ""
                return cls(z["mean"], z["var"], float(z["clip_obs"]), float(z["epsilon"]), sha)
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
        except (OSError, EOFError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: not readable observation statistics (an .npz of mean, var, clip_obs, "
                             f"epsilon): {type(exc).__name__}: {exc}") from None

    def save(self, path: str | Path, policy_sha256: str | None = None) -> None:
        """Write the statistics atomically (``policy_sha256``: the weights they belong to)."""
        from hydro_envs.outputs import atomic_path

        with atomic_path(path) as tmp:
            self._write(tmp, policy_sha256)

    def _write(self, path: str | Path, policy_sha256: str | None = None) -> None:
        sha = self.policy_sha256 if policy_sha256 is None else policy_sha256
        np.savez(path, mean=self.mean, var=self.var, clip_obs=self.clip_obs, epsilon=self.epsilon,
                 **({"policy_sha256": np.asarray(sha)} if sha else {}))

    def normalize_obs(self, obs: Any) -> np.ndarray:
        o = np.asarray(obs)
        return np.clip((o - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip_obs, self.clip_obs).astype(o.dtype)


class TrainedPolicy:
    """An SB3 model behind its frozen observation normalisation.

    ``obs_normalizer`` holds the frozen observation statistics (an :class:`ObsNormalizer`, or
    with a trusted pickle the run's ``VecNormalize`` without its venv; only ``normalize_obs``
    is used, which never updates them) or is ``None`` when the run did not normalise
    observations.
    """

    def __init__(self, model: Any, obs_normalizer: Any | None, *, env_id: str = "", algo: str = "",
                 config: dict[str, Any] | None = None, run_dir: Path | None = None) -> None:
        self.model = model
        self.obs_normalizer = obs_normalizer
        if obs_normalizer is not None:
            obs_normalizer.training = False
            obs_normalizer.norm_reward = False
        self.env_id = env_id
        self.algo = algo
        self.config = dict(config or {})
        self.run_dir = run_dir
        self.observation_space = model.observation_space
        self.action_space = model.action_space

    def normalize(self, obs: Any) -> np.ndarray:
        """Raw observations -> the normalised observations the model was trained on."""
        o = np.asarray(obs, dtype=np.float32)
        if self.obs_normalizer is None or not self.obs_normalizer.norm_obs:
            return o
        return np.asarray(self.obs_normalizer.normalize_obs(o), dtype=np.float32)

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        """SB3-style ``predict`` on raw observations ``(obs_dim,)`` or ``(n, obs_dim)``.

        Returns ``(action, state)``; actions lie in the env's action space (SB3 clips the
        policy output to the Box bounds). The MLP policies are stateless, so ``state`` and
        ``episode_start`` are passed through to the model unchanged.
        """
        o = np.asarray(obs, dtype=np.float32)
        shape = self.observation_space.shape
        if o.shape != shape and (o.ndim != len(shape) + 1 or o.shape[1:] != shape):
            raise ValueError(f"obs must have shape {shape} or (n, *{shape}), got {o.shape}")
        if not np.all(np.isfinite(o)):
            raise ValueError("obs must be finite (NaN or inf given)")
        return self.model.predict(self.normalize(o), state=state, episode_start=episode_start,
                                  deterministic=deterministic)


def load_trained(run_dir: str | Path, which: str = "final", device: str = "cpu", *,
                 trust_pickle: bool = False) -> TrainedPolicy | ResidualPolicy:
    """Load the ``which`` (``"final"`` or ``"best"``) policy of a run folder with its frozen
    observation statistics.

    Reads the safe layout (``policy.pt`` + ``obs_normalization.npz``, or their ``best_``
    versions) when present. The pickled layout (SB3 zip + ``vecnormalize.pkl``) is read only
    with ``trust_pickle=True``, and then in preference (the full SB3 model); without it a
    folder that has only the pickles raises :class:`UntrustedPickleError`.

    Returns a :class:`TrainedPolicy`, or for a residual run (``residual`` in its config) an
    :class:`agents.residual.ResidualPolicy` wrapping it."""
    run = Path(run_dir)
    if which not in ("final", "best"):
        raise ValueError(f"which = {which!r}; allowed ('final', 'best')")
    if not isinstance(trust_pickle, bool):
        raise TypeError(f"trust_pickle must be True or False, got {trust_pickle!r}")
    from agents.zoo import is_zoo_run

    if is_zoo_run(run):
        return _load_zoo(run, which, device, trust_pickle)
    policy_file, _ = _compact_files(which)
    model_file, vn_file = (MODEL_FILE, VECNORM_FILE) if which == "final" else (BEST_MODEL_FILE, BEST_VECNORM_FILE)
    if (run / policy_file).is_file() and not (trust_pickle and (run / model_file).is_file()):
        return _with_residual(_load_compact(run, device, which))
    if (run / model_file).is_file() and not trust_pickle:
        raise UntrustedPickleError(
            f"{run} has no {policy_file}, only the pickled {model_file}"
            f"{' and ' + vn_file if (run / vn_file).is_file() else ''}: loading a pickle can execute "
            "arbitrary code from whoever wrote it, so it is not read by default. If you trust the folder, "
            "pass --trust-pickle (trust_pickle=True), or convert it once with "
            "agents.policies.export_compact(run, dest, trust_pickle=True)")
    for f in (ARGS_FILE, CONFIG_FILE, model_file):
        if not (run / f).is_file():
            raise FileNotFoundError(f"{run / f} not found: not a finished run folder of agents.train")
    env_id, algo = _run_args(run)
    config_all = _run_config(run, env_id, whole=True)
    model, normalizer = _load_pickled(algo, run / model_file, run / vn_file, device)
    return _with_residual(TrainedPolicy(model, normalizer, env_id=env_id, algo=algo,
                                        config=config_all.get(env_id, {}), run_dir=run))


def _load_pickled(algo: str, model_file: Path, vn_file: Path | None, device: str) -> tuple[Any, Any]:
    """The trusted SB3 model zip and, when the file exists, its ``VecNormalize`` state."""
    model = algo_class(algo).load(model_file, device=device)  # trusted: cloudpickle inside
    normalizer = None
    if vn_file is not None and vn_file.is_file():
        with open(vn_file, "rb") as fh:
            normalizer = pickle.load(fh)  # trusted: SB3 VecNormalize state (venv excluded)
    return model, normalizer


def _load_zoo(run: Path, which: str, device: str, trust_pickle: bool) -> TrainedPolicy | ResidualPolicy:
    """An rl_zoo3 run folder (:mod:`agents.zoo`): its models and normaliser are pickles."""
    from agents.zoo import zoo_run_info

    if not trust_pickle:
        raise UntrustedPickleError(
            f"{run} is an rl_zoo3 run folder: its model and vecnormalize.pkl are pickles, which can execute "
            "arbitrary code from whoever wrote them, so they are not read by default. If you trust the folder, "
            "pass --trust-pickle (trust_pickle=True), or convert it once with "
            "agents.policies.export_compact(run, dest, trust_pickle=True)")
    model_file, vn_file, env_id, algo, config = zoo_run_info(run, which)
    if algo not in ALGOS:
        raise ValueError(f"{run}: algo = {algo!r}; allowed {', '.join(ALGOS)}")
    model, normalizer = _load_pickled(algo, model_file, vn_file, device)
    return _with_residual(TrainedPolicy(model, normalizer, env_id=env_id, algo=algo, config=config, run_dir=run))


def _with_residual(policy: TrainedPolicy) -> Any:
    """``policy``, behind :class:`agents.framestack.FrameStackPolicy` when its config has a
    ``frame_stack`` > 1 and wrapped in :class:`agents.residual.ResidualPolicy` when it has a
    ``residual`` entry (imported here: agents.residual needs the controllers, loading a plain
    policy does not)."""
    out: Any = policy
    n_stack = policy.config.get("frame_stack")
    if n_stack and n_stack > 1:
        from agents.framestack import FrameStackPolicy

        obs_dim = int(policy.observation_space.shape[0]) // int(n_stack)
        out = FrameStackPolicy(policy, int(n_stack), obs_dim)
    res = policy.config.get("residual")
    if not res:
        return out
    from agents.residual import ResidualPolicy

    return ResidualPolicy(out, policy.env_id, res.get("controller"), res.get("scale"))


def _policy_class(algo: str, policy: str) -> type:
    cls = algo_class(algo)
    if policy not in cls.policy_aliases:
        raise ValueError(f"policy = {policy!r}; {algo} has {sorted(cls.policy_aliases)}")
    return cls.policy_aliases[policy]


def _sha256(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_compact(policy: Any, obs_normalizer: Any | None, dest: str | Path, which: str = "final") -> None:
    """Write the safe layout of ``policy`` (an SB3 policy module) and its observation
    statistics (an SB3 ``VecNormalize``, an :class:`ObsNormalizer` or None) into ``dest``, as one
    unit (module docstring): both into a temporary folder in ``dest``, the statistics stamped
    with the weights' SHA-256, then renamed into place, statistics first. A failed write (a full
    disk) leaves ``dest``'s previous files as they were and raises ``OSError`` naming the file."""
    import contextlib
    import shutil
    import tempfile

    import hydro_envs

    hydro_envs.apply_openmp_spin()  # before torch loads libgomp (hydro_envs/_openmp.py)
    import torch

    from hydro_envs.outputs import write_failed

    policy_file, norm_file = _compact_files(which)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{which}_policy.", suffix=".tmp", dir=dest))
    current = tmp / policy_file
    try:
        state = {k: v.detach().cpu().clone() for k, v in policy.state_dict().items()}
        torch.save(state, current)
        norm = None
        if obs_normalizer is not None and getattr(obs_normalizer, "norm_obs", False):
            norm = obs_normalizer if isinstance(obs_normalizer, ObsNormalizer) else ObsNormalizer.from_vecnormalize(obs_normalizer)
            current = tmp / norm_file
            norm._write(current, policy_sha256=_sha256(tmp / policy_file))
        # statistics first, weights last: the weights are the folder's mark of a finished pair
        if norm is not None:
            current = dest / norm_file
            os.replace(tmp / norm_file, current)
        elif (dest / norm_file).exists():  # stale statistics of earlier weights
            current = dest / norm_file
            (dest / norm_file).unlink()
        current = dest / policy_file
        os.replace(tmp / policy_file, current)
    except OSError as exc:
        raise write_failed(dest / current.name, exc) from None
    finally:
        with contextlib.suppress(OSError):
            shutil.rmtree(tmp)


def export_compact(run_dir: str | Path, dest: str | Path, which: str = "final", *, trust_pickle: bool = False) -> Path:
    """Write the compact evaluation-only copy of a run folder (module docstring) to ``dest``.

    A folder with the safe layout is copied without unpickling anything; one with only the
    pickled layout needs ``trust_pickle=True``."""
    import shutil

    pol = load_trained(run_dir, which, trust_pickle=trust_pickle)
    dest = Path(dest)
    write_compact(_policy_module(pol.model), pol.obs_normalizer, dest)
    from agents.zoo import is_zoo_run

    if is_zoo_run(run_dir):  # the zoo's YAML becomes this package's run-folder files
        import yaml

        from hydro_envs.outputs import atomic_write

        atomic_write(dest / ARGS_FILE, json.dumps({"env_id": pol.env_id, "algo": pol.algo}) + "\n")
        atomic_write(dest / CONFIG_FILE, yaml.safe_dump({pol.env_id: pol.config}, sort_keys=True))
        return dest
    for f in (CONFIG_FILE, ARGS_FILE, EVAL_CSV):
        if (Path(run_dir) / f).is_file():
            shutil.copyfile(Path(run_dir) / f, dest / f)
    return dest


def _policy_module(model: Any) -> Any:
    return model.policy if hasattr(model, "policy") else model


class _CompactModel:
    """The loaded policy module behind the SB3 model attributes callers use (``policy``,
    ``predict``, the spaces)."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.observation_space = policy.observation_space
        self.action_space = policy.action_space

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        return self.policy.predict(obs, state=state, episode_start=episode_start, deterministic=deterministic)


def _load_compact(run: Path, device: str = "cpu", which: str = "final") -> TrainedPolicy:
    import gymnasium as gym

    import hydro_envs  # registers the env ids

    hydro_envs.apply_openmp_spin()  # before torch loads libgomp (hydro_envs/_openmp.py)
    import torch

    from agents.policy_kwargs import parse_policy_kwargs, policy_kwargs_object

    for f in (ARGS_FILE, CONFIG_FILE):
        if not (run / f).is_file():
            raise FileNotFoundError(f"{run / f} not found: not a compact policy folder (agents.policies.export_compact)")
    env_id, algo = _run_args(run)
    cfg = _run_config(run, env_id)
    if env_id not in gym.registry:
        raise ValueError(f"{run / ARGS_FILE}: env_id = {env_id!r} is not a registered env")
    env = gym.make(env_id)
    obs_space, act_space = env.observation_space, env.action_space
    env.close()
    from agents.framestack import check_frame_stack

    n_stack = int(check_frame_stack(cfg.get("frame_stack"), f"{run / CONFIG_FILE}: frame_stack") or 1)
    if n_stack > 1:  # trained on VecFrameStack: n observations side by side (agents.framestack)
        obs_space = gym.spaces.Box(np.tile(obs_space.low, n_stack), np.tile(obs_space.high, n_stack),
                                   dtype=obs_space.dtype)
    try:
        policy = _policy_class(algo, cfg.get("policy", "MlpPolicy"))(
            obs_space, act_space, lambda _: 0.0, **policy_kwargs_object(parse_policy_kwargs(cfg.get("policy_kwargs"))))
    except (TypeError, KeyError) as exc:
        raise ValueError(f"{run / CONFIG_FILE}: policy / policy_kwargs do not build a policy: {exc}") from None
    policy_file, norm_file = _compact_files(which)
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # torch warns about the pickle protocol before refusing
            state = torch.load(run / policy_file, map_location=device, weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch raises UnpicklingError, RuntimeError, EOFError, ...
        raise ValueError(f"{run / policy_file}: not a weights file ({type(exc).__name__}; a torch state_dict is "
                         "read with weights_only=True, never unpickled); write it with agents.train or "
                         "agents.policies.export_compact") from None
    try:
        policy.load_state_dict(state)
    except Exception as exc:  # noqa: BLE001 - RuntimeError (size mismatch, missing keys), TypeError, ...
        why = " ".join(str(exc).split())[:160]
        raise ValueError(f"{run / policy_file}: not the weights of this {algo} policy ({type(exc).__name__}: {why}); "
                         f"check {CONFIG_FILE}'s policy_kwargs") from None
    policy.set_training_mode(False)
    policy.to(device)
    normalizer = _compact_normalizer(run, norm_file, policy_file, cfg, obs_space.shape)
    return TrainedPolicy(_CompactModel(policy), normalizer, env_id=env_id, algo=algo, config=cfg, run_dir=run)


def _run_args(run: Path) -> tuple[str, str]:
    """``env_id`` and ``algo`` of a run folder's ``args.json`` (one-line ``ValueError`` otherwise)."""
    path = run / ARGS_FILE
    try:
        args = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(args, dict) or not isinstance(args.get("env_id"), str) or args.get("algo") not in ALGOS:
        raise ValueError(f"{path}: needs env_id (an env id) and algo (one of {', '.join(ALGOS)})")
    return args["env_id"], args["algo"]


def _run_config(run: Path, env_id: str, *, whole: bool = False) -> dict[str, Any]:
    """The run's ``config.yml`` (read with :func:`hydro_envs.yamlio.load_yaml`): its entry of
    ``env_id`` (``whole``: every entry)."""
    from hydro_envs.yamlio import load_yaml, short

    path = run / CONFIG_FILE
    data = load_yaml(path, what="run config") or {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: top level = {short(data)}; allowed a mapping of env id -> hyperparameters")
    if whole:
        return data
    entry = data.get(env_id, {})
    if not isinstance(entry, dict):
        raise ValueError(f"{path}: {env_id} = {short(entry)}; allowed a mapping of hyperparameters")
    return entry


def trained_with_obs_normalization(cfg: dict[str, Any]) -> bool:
    """Whether a run's config normalised observations in training (``normalize`` absent: yes, the
    training default)."""
    norm = cfg.get("normalize", True)
    if isinstance(norm, dict):
        return bool(norm.get("norm_obs", True))
    return bool(norm)


def _compact_normalizer(run: Path, norm_file: str, policy_file: str, cfg: dict[str, Any], shape: tuple) -> Any:
    """The folder's observation statistics, checked (module docstring), or None for a run that
    did not normalise its observations."""
    path = run / norm_file
    if not path.is_file():
        if trained_with_obs_normalization(cfg):
            raise ValueError(f"{path}: missing; the policy was trained with observation normalisation "
                             f"(normalize.norm_obs in {CONFIG_FILE}) and runs wrong on raw observations")
        return None
    norm = ObsNormalizer.load(path).check(shape, path)
    if norm.policy_sha256 and norm.policy_sha256 != _sha256(run / policy_file):
        raise ValueError(f"{path}: written with other weights than {policy_file} (its policy_sha256 does not match; "
                         "an interrupted write?); write the pair again")
    return norm
