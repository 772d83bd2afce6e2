r"""Train Stable-Baselines3 agents (PPO, SAC, TD3) on the hydro-envs tasks.

Command line::

    python -m agents.train --env hydro_envs/ServoCylinderPosition-v0 --algo sac \
        [--config FILE] [--timesteps N] [--seed S] [--no-randomization] [--out DIR] \
        [--name NAME] [--n-envs N] [--eval-freq N] [--n-eval-episodes N] [--eval-seed S] \
        [--hyperparams KEY=VALUE ...] [--no-progress-bar] [--torch-threads N]

and from Python ``train(env_id, algo, ...) -> Path`` (the run folder).

Hyperparameters
---------------
rl-baselines3-zoo style: one file per algorithm, ``configs/agents/<algo>.yml``, whose top-level
keys are env ids; ``--config FILE`` replaces it by another file of the same format (for
example a run folder's ``config.yml``). Keys of an env entry:

* ``n_envs`` (int >= 1), ``n_timesteps`` (int >= 1; ``--timesteps`` overrides),
  ``policy`` (``MlpPolicy``);
* ``policy_kwargs``: the zoo's string ``"dict(net_arch=[...], activation_fn=nn.Tanh, ...)"``
  (the shipped configs, so that rl_zoo3 reads them as they are; parsed here without
  evaluating code, :mod:`agents.policy_kwargs`) or a YAML mapping: ``net_arch`` (list of layer
  widths, or ``{pi: [...], vf: [...]}`` for PPO / ``{pi: [...], qf: [...]}`` for SAC/TD3),
  ``activation_fn`` (``tanh | relu | elu | leaky_relu | gelu | silu``), ``log_std_init``,
  ``ortho_init``, ``full_std``, ``use_expln``, ``clip_mean``, ``n_critics``,
  ``share_features_extractor`` where the policy has them;
* ``normalize``: ``true``/``false`` or a mapping with ``norm_obs``, ``norm_reward``,
  ``clip_obs``, ``clip_reward``, ``epsilon`` (SB3 ``VecNormalize``; its discount is the
  algorithm's ``gamma``);
* ``env_kwargs``: keyword arguments of the env (e.g. ``max_episode_steps``, ``reference``,
  ``action_rate_penalty``); ``--no-randomization`` sets ``randomize: false``;
* ``noise_type`` (``normal | ornstein-uhlenbeck``) and ``noise_std`` (SAC/TD3 action noise);
* ``residual`` (optional, absent or ``null`` by default; not an rl_zoo3 key, so only in
  project-format files such as ``configs/agents/residual/ppo.yml``): ``{controller: NAME,
  scale: FLOAT}`` trains the policy as a residual on the classical controller ``NAME`` of
  :mod:`agents.controllers`, ``action = clip(base + scale * policy, -1, 1)`` with ``scale`` in
  ``(0, 1]`` (:mod:`agents.residual`); the run's ``config.yml`` keeps it, so
  :func:`agents.policies.load_trained` returns the combined policy;
* ``frame_stack`` (optional, rl_zoo3's key): the policy sees the last ``N`` observations
  (SB3 ``VecFrameStack``, :mod:`agents.framestack`); stacked *before* ``VecNormalize`` (the zoo
  stacks after it), so the run's observation statistics cover the stacked vector and
  :func:`agents.policies.load_trained` stacks single observations the same way;
* any keyword of the SB3 algorithm's constructor (``learning_rate`` as a number or
  ``lin_<number>`` for a linear decay to 0, ``gamma``, ``n_steps``, ``batch_size``, ...).

Unknown keys and out-of-range values raise :class:`ConfigError` naming the file, the env id and
the key. The *resolved* entry (file + overrides + SB3's defaults for every omitted constructor
argument) is written to the run folder's ``config.yml`` in the same format, so
``--config runs/<run>/config.yml`` reproduces the run.

Training and evaluation
-----------------------
The training env is :func:`hydro_envs.envs.sb3.make_sb3_vec_env` (all copies advanced by one
compiled kernel call) inside ``VecNormalize``; ``seed`` seeds torch/numpy and copy ``i`` of
the env with ``seed + i``. Every ``eval_freq`` timesteps (and at the end) the deterministic
policy is evaluated on a separate batched env of ``n_eval_episodes`` copies reset with the
fixed seeds ``eval_seed + i`` before every evaluation, so every evaluation sees the same
randomised parameter draws, references and initial states. The evaluation ``VecNormalize``
gets a copy of the training statistics and is frozen (``training=False``,
``norm_reward=False``): evaluation neither updates the statistics nor normalises the reward.
Each copy runs one full episode; returns are sums of raw env rewards.

The run folder (see :mod:`agents.policies` for the layout) is ``<out>/<env>_<algo>_<seed>_
<UTC timestamp>`` unless ``name`` is given. Besides SB3's zip and ``vecnormalize.pkl`` (pickles,
kept to resume training) it holds the safe layout evaluation reads without unpickling:
``policy.pt`` + ``obs_normalization.npz`` (and ``best_`` versions with each new best
evaluation). Same seed, same config, same machine and
``torch.set_num_threads(1)`` give bit-identical runs on CPU (tested).
"""

from __future__ import annotations

# registers the envs; train() applies the package's OpenMP spin setting before it loads torch
import hydro_envs  # noqa: F401

import argparse  # noqa: E402
import copy  # noqa: E402
import csv  # noqa: E402
import datetime as _dt  # noqa: E402
import inspect  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable, Mapping, Sequence  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402
from stable_baselines3.common.vec_env import VecFrameStack, VecNormalize, sync_envs_normalization  # noqa: E402

from agents.policy_kwargs import ACTIVATIONS, parse_policy_kwargs, policy_kwargs_object  # noqa: E402
from agents.policies import (  # noqa: E402
    ALGOS,
    ARGS_FILE,
    BEST_MODEL_FILE,
    BEST_VECNORM_FILE,
    CONFIG_FILE,
    EVAL_CSV,
    EVAL_NPZ,
    MODEL_FILE,
    TB_DIR,
    VECNORM_FILE,
    ObsNormalizer,
    algo_class,
    write_compact,
)

__all__ = [
    "ConfigError",
    "DEFAULT_EVAL_SEED",
    "config_path",
    "load_agent_config",
    "resolve_config",
    "make_envs",
    "evaluate",
    "EvalLogCallback",
    "train",
    "main",
]

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_EVAL_SEED = 1_000_000  # far from the training seeds (copy i of a run uses seed + i)
DEFAULT_N_EVAL = 16

# keys of an env entry that are not constructor arguments of the SB3 algorithm
_RUN_KEYS = ("n_envs", "n_timesteps", "policy", "policy_kwargs", "normalize", "env_kwargs", "residual",
             "frame_stack", "vec_env_wrapper")
#: the only ``vec_env_wrapper`` accepted: rl_zoo3's hook that gives a zoo run the native batch env
#: this trainer always uses (:mod:`agents.zoo`)
NATIVE_VEC_ENV_WRAPPER = "agents.zoo.native_vec_env"
_NOISE_KEYS = ("noise_type", "noise_std")
# constructor arguments that the trainer sets itself or that are not YAML values
_RESERVED = {"self", "policy", "env", "seed", "device", "verbose", "tensorboard_log", "_init_setup_model",
             "policy_kwargs", "action_noise", "replay_buffer_class", "replay_buffer_kwargs",
             "rollout_buffer_class", "rollout_buffer_kwargs"}
_POLICIES = ("MlpPolicy",)
_ACTIVATIONS = tuple(ACTIVATIONS)
_POLICY_KWARGS: dict[str, tuple[str, ...]] = {
    "net_arch": ALGOS,
    "activation_fn": ALGOS,
    "share_features_extractor": ALGOS,
    "log_std_init": ("ppo", "sac"),
    "use_expln": ("ppo", "sac"),
    "ortho_init": ("ppo",),
    "full_std": ("ppo",),
    "clip_mean": ("sac",),
    "n_critics": ("sac", "td3"),
}
_NORMALIZE_DEFAULT = {"norm_obs": True, "norm_reward": False, "clip_obs": 10.0, "clip_reward": 10.0,
                      "epsilon": 1e-8}
_NOISE_TYPES = ("normal", "ornstein-uhlenbeck")


class ConfigError(ValueError):
    """A hyperparameter file or override is malformed (the message names the key)."""


# --------------------------------------------------------------------------- value checks
def _num(where: str, key: str, value: Any, *, lo: float | None = None, hi: float | None = None,
         lo_open: bool = False, hi_open: bool = False, integer: bool = False) -> float | int:
    """``value`` as a finite number inside the stated range (YAML 1.1 reads ``3e-4`` as a
    string, so numeric strings are accepted)."""
    v = value
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            v = None
    rng = _range_text(lo, hi, lo_open, hi_open)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"{where}: {key} must be a finite number{rng}, got {value!r}")
    if integer:
        if float(v) != int(v):
            raise ConfigError(f"{where}: {key} must be an integer{rng}, got {value!r}")
        v = int(v)
    else:
        v = float(v)
    too_low = lo is not None and (v < lo or (lo_open and v == lo))
    too_high = hi is not None and (v > hi or (hi_open and v == hi))
    if too_low or too_high:
        raise ConfigError(f"{where}: {key} = {value!r} outside the allowed range{rng}")
    return v


def _range_text(lo, hi, lo_open, hi_open) -> str:
    if lo is None and hi is None:
        return ""
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    return f" in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"


def _bool(where: str, key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where}: {key} must be true or false, got {value!r}")
    return value


def _schedule(where: str, key: str, value: Any, *, hi: float | None = None) -> float | str:
    """A positive number, or ``lin_<number>`` (linear decay from the number to 0)."""
    if isinstance(value, str) and value.startswith("lin_"):
        _num(where, key, value[4:], lo=0.0, hi=hi, lo_open=True)
        return value
    return _num(where, key, value, lo=0.0, hi=hi, lo_open=True)


def _opt_positive(where: str, key: str, value: Any) -> float | None:
    return None if value is None else _num(where, key, value, lo=0.0, lo_open=True)


def _ent_coef(algo: str):
    def check(where: str, key: str, value: Any):
        if algo == "sac" and isinstance(value, str) and (value == "auto" or value.startswith("auto_")):
            if value != "auto":
                _num(where, key, value[5:], lo=0.0, lo_open=True)
            return value
        return _num(where, key, value, lo=0.0)
    return check


def _train_freq(where: str, key: str, value: Any):
    if isinstance(value, (list, tuple)):
        if len(value) != 2 or value[1] not in ("step", "episode"):
            raise ConfigError(f"{where}: {key} must be an integer >= 1 or [n, 'step' | 'episode'], got {value!r}")
        return [_num(where, key, value[0], lo=1, integer=True), value[1]]
    return _num(where, key, value, lo=1, integer=True)


def _gradient_steps(where: str, key: str, value: Any):
    v = _num(where, key, value, lo=-1, integer=True)
    if v == 0:
        raise ConfigError(f"{where}: {key} must be >= 1 or -1 (as many as env steps), got 0")
    return v


def _target_entropy(where: str, key: str, value: Any):
    return value if value == "auto" else _num(where, key, value)


_R = Callable[[str, str, Any], Any]


def _algo_rules(algo: str) -> dict[str, _R]:
    """Checks of the SB3 constructor arguments (every other argument is passed unchecked)."""
    r: dict[str, _R] = {
        "learning_rate": _schedule,
        "gamma": lambda w, k, v: _num(w, k, v, lo=0.0, hi=1.0, lo_open=True),
        "batch_size": lambda w, k, v: _num(w, k, v, lo=2 if algo == "ppo" else 1, integer=True),
        "use_sde": _bool,
        "sde_sample_freq": lambda w, k, v: _num(w, k, v, lo=-1, integer=True),
        "stats_window_size": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
    }
    if algo == "ppo":
        r.update({
            "n_steps": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
            "n_epochs": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
            "gae_lambda": lambda w, k, v: _num(w, k, v, lo=0.0, hi=1.0),
            "clip_range": lambda w, k, v: _schedule(w, k, v),
            "clip_range_vf": lambda w, k, v: None if v is None else _schedule(w, k, v),
            "normalize_advantage": _bool,
            "ent_coef": _ent_coef(algo),
            "vf_coef": lambda w, k, v: _num(w, k, v, lo=0.0),
            "max_grad_norm": lambda w, k, v: _num(w, k, v, lo=0.0, lo_open=True),
            "target_kl": _opt_positive,
        })
    else:
        r.update({
            "buffer_size": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
            "learning_starts": lambda w, k, v: _num(w, k, v, lo=0, integer=True),
            "tau": lambda w, k, v: _num(w, k, v, lo=0.0, hi=1.0, lo_open=True),
            "train_freq": _train_freq,
            "gradient_steps": _gradient_steps,
            "optimize_memory_usage": _bool,
            "n_steps": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
        })
    if algo == "sac":
        r.update({
            "ent_coef": _ent_coef(algo),
            "target_update_interval": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
            "target_entropy": _target_entropy,
            "use_sde_at_warmup": _bool,
        })
    if algo == "td3":
        r.update({
            "policy_delay": lambda w, k, v: _num(w, k, v, lo=1, integer=True),
            "target_policy_noise": lambda w, k, v: _num(w, k, v, lo=0.0),
            "target_noise_clip": lambda w, k, v: _num(w, k, v, lo=0.0),
        })
    return r


def _algo_defaults(algo: str) -> dict[str, Any]:
    """SB3's defaults of the configurable constructor arguments of ``algo``."""
    sig = inspect.signature(algo_class(algo).__init__)
    out = {}
    for k, p in sig.parameters.items():
        if k in _RESERVED or p.default is inspect.Parameter.empty:
            continue
        d = p.default
        out[k] = list(d) if isinstance(d, tuple) else d
    return out


def _check_net_arch(where: str, algo: str, value: Any) -> Any:
    def layers(key: str, v: Any) -> list[int]:
        if not isinstance(v, (list, tuple)):
            raise ConfigError(f"{where}: {key} must be a list of layer widths (integers >= 1), got {v!r}")
        return [_num(where, key, x, lo=1, integer=True) for x in v]

    if isinstance(value, Mapping):
        heads = ("pi", "vf") if algo == "ppo" else ("pi", "qf")
        unknown = set(value) - set(heads)
        if unknown or not value:
            raise ConfigError(f"{where}: policy_kwargs.net_arch has key(s) {sorted(unknown) or '(none)'}; "
                              f"allowed {list(heads)}")
        return {h: layers(f"policy_kwargs.net_arch.{h}", v) for h, v in value.items()}
    return layers("policy_kwargs.net_arch", value)


def _check_policy_kwargs(where: str, algo: str, value: Any) -> dict[str, Any]:
    try:
        value = parse_policy_kwargs(value, f"{where}: policy_kwargs")
    except ValueError as e:
        raise ConfigError(str(e)) from None
    out: dict[str, Any] = {}
    for k, v in value.items():
        allowed = sorted(kk for kk, algos in _POLICY_KWARGS.items() if algo in algos)
        if k not in allowed:
            raise ConfigError(f"{where}: unknown key policy_kwargs.{k} for {algo}; allowed {allowed}")
        key = f"policy_kwargs.{k}"
        if k == "net_arch":
            out[k] = _check_net_arch(where, algo, v)
        elif k == "activation_fn":
            if v not in _ACTIVATIONS:
                raise ConfigError(f"{where}: {key} = {v!r}; allowed {list(_ACTIVATIONS)}")
            out[k] = v
        elif k in ("share_features_extractor", "use_expln", "ortho_init", "full_std"):
            out[k] = _bool(where, key, v)
        elif k == "log_std_init":
            out[k] = _num(where, key, v, lo=-20.0, hi=2.0)
        elif k == "clip_mean":
            out[k] = _num(where, key, v, lo=0.0, lo_open=True)
        elif k == "n_critics":
            out[k] = _num(where, key, v, lo=1, integer=True)
    return out


def _check_normalize(where: str, value: Any) -> dict[str, Any]:
    out = dict(_NORMALIZE_DEFAULT)
    if isinstance(value, bool):
        out["norm_obs"] = value
        return out
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: normalize must be true, false or a mapping with keys "
                          f"{list(_NORMALIZE_DEFAULT)}, got {value!r}")
    for k, v in value.items():
        if k not in _NORMALIZE_DEFAULT:
            raise ConfigError(f"{where}: unknown key normalize.{k}; allowed {list(_NORMALIZE_DEFAULT)}")
        if k in ("norm_obs", "norm_reward"):
            out[k] = _bool(where, f"normalize.{k}", v)
        else:
            out[k] = _num(where, f"normalize.{k}", v, lo=0.0, lo_open=True)
    return out


def _check_residual(where: str, env_id: str, value: Any) -> dict[str, Any] | None:
    """The ``residual`` entry: ``None`` or ``{controller: NAME, scale: FLOAT}``."""
    if value is None:
        return None
    from agents.residual import RESIDUAL_KEYS, check_residual

    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: residual must be null or a mapping with keys {list(RESIDUAL_KEYS)}, "
                          f"got {value!r}")
    unknown = sorted(set(value) - set(RESIDUAL_KEYS))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {['residual.' + str(k) for k in unknown]}; "
                          f"allowed {list(RESIDUAL_KEYS)}")
    for k in RESIDUAL_KEYS:
        if k not in value:
            raise ConfigError(f"{where}: missing key 'residual.{k}'")
    try:
        scale = _num(where, "residual.scale", value["scale"], lo=0.0, hi=1.0, lo_open=True)  # YAML 1.1 strings
        controller, scale = check_residual(env_id, value["controller"], scale)
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    return {"controller": controller, "scale": scale}


# --------------------------------------------------------------------------- config files
def config_path(algo: str) -> Path:
    """The default hyperparameter file of ``algo``: ``configs/agents/<algo>.yml``."""
    from hydro_envs.config_files import config_file

    if algo not in ALGOS:
        raise ConfigError(f"algo = {algo!r}; allowed {list(ALGOS)}")
    return config_file("agents", f"{algo}.yml")


def _display_path(path: Path) -> str:
    """``path`` relative to the project root when it lies inside it (so run records name
    ``configs/agents/ppo.yml``, not a machine's checkout), else as given."""
    try:
        return str(path.resolve().relative_to(Path(__file__).resolve().parents[1]))
    except ValueError:
        return str(path)


def load_agent_config(source: str | Path | Mapping[str, Any] | None, algo: str, env_id: str) -> dict[str, Any]:
    """The raw entry of ``env_id`` from a zoo-format file (``None``: ``configs/agents/<algo>.yml``)
    or from an already loaded mapping of the same format."""
    if source is None:
        source = config_path(algo)
    if isinstance(source, Mapping):
        data, name = source, "<mapping>"
    else:
        path = Path(source)
        if not path.is_file():
            raise ConfigError(f"config file {path} not found")
        name = _display_path(path)
        from hydro_envs.yamlio import YamlError, load_yaml

        try:
            data = load_yaml(path, what="agent config")
        except YamlError as exc:
            raise ConfigError(str(exc)) from None
    if not isinstance(data, Mapping) or not data:
        raise ConfigError(f"{name}: must map env ids to hyperparameter entries")
    if env_id not in data:
        raise ConfigError(f"{name}: no entry for env {env_id!r}; entries: {sorted(map(str, data))}")
    entry = data[env_id]
    if not isinstance(entry, Mapping):
        from hydro_envs.yamlio import short

        raise ConfigError(f"{name} [{env_id}]: the entry must be a mapping of hyperparameters, got {short(entry)}")
    return {"__source__": name, **copy.deepcopy(dict(entry))}


def resolve_config(entry: Mapping[str, Any], algo: str, env_id: str,
                   overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Check an env entry, apply ``overrides`` (top-level keys replace the entry's) and fill
    SB3's defaults for every omitted constructor argument. Returns the resolved entry (plain
    YAML types; ``normalize`` and ``policy_kwargs`` as full mappings)."""
    if algo not in ALGOS:
        raise ConfigError(f"algo = {algo!r}; allowed {list(ALGOS)}")
    entry = dict(entry)
    where = f"{entry.pop('__source__', '<config>')} [{env_id}]"
    entry.update(dict(overrides or {}))
    defaults = _algo_defaults(algo)
    rules = _algo_rules(algo)
    allowed = set(_RUN_KEYS) | set(defaults) | (set(_NOISE_KEYS) if algo != "ppo" else set())
    unknown = sorted(set(entry) - allowed)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown} for {algo}; allowed {sorted(allowed)}")
    if entry.get("vec_env_wrapper", NATIVE_VEC_ENV_WRAPPER) != NATIVE_VEC_ENV_WRAPPER:
        raise ConfigError(f"{where}: vec_env_wrapper = {entry['vec_env_wrapper']!r}; allowed "
                          f"{NATIVE_VEC_ENV_WRAPPER!r} (this trainer always steps the native batch env)")
    for key in ("n_envs", "n_timesteps", "policy"):
        if key not in entry:
            raise ConfigError(f"{where}: missing key {key!r}")
    out: dict[str, Any] = {
        "n_envs": _num(where, "n_envs", entry["n_envs"], lo=1, integer=True),
        "n_timesteps": _num(where, "n_timesteps", entry["n_timesteps"], lo=1, integer=True),
    }
    if entry["policy"] not in _POLICIES:
        raise ConfigError(f"{where}: policy = {entry['policy']!r}; allowed {list(_POLICIES)}")
    out["policy"] = entry["policy"]
    out["policy_kwargs"] = _check_policy_kwargs(where, algo, entry.get("policy_kwargs"))
    out["normalize"] = _check_normalize(where, entry.get("normalize", True))
    env_kwargs = entry.get("env_kwargs") or {}
    if not isinstance(env_kwargs, Mapping) or not all(isinstance(k, str) for k in env_kwargs):
        raise ConfigError(f"{where}: env_kwargs must be a mapping of keyword names to values, got {env_kwargs!r}")
    out["env_kwargs"] = dict(env_kwargs)
    residual = _check_residual(where, env_id, entry.get("residual"))
    if residual is not None:  # absent by default: zoo entries resolve as before
        out["residual"] = residual
    from agents.framestack import check_frame_stack

    try:
        frame_stack = check_frame_stack(entry.get("frame_stack"))
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    if frame_stack is not None and frame_stack > 1:
        out["frame_stack"] = frame_stack
    if algo != "ppo":
        nt = entry.get("noise_type")
        if nt is not None and nt not in _NOISE_TYPES:
            raise ConfigError(f"{where}: noise_type = {nt!r}; allowed {list(_NOISE_TYPES)} or null")
        out["noise_type"] = nt
        out["noise_std"] = _num(where, "noise_std", entry.get("noise_std", 0.1), lo=0.0)
    for key, default in defaults.items():
        value = entry.get(key, default)
        out[key] = rules[key](where, key, value) if key in rules else value
    if algo == "ppo":
        rollout = out["n_steps"] * out["n_envs"]
        if rollout < 2:
            raise ConfigError(f"{where}: n_steps * n_envs = {rollout} must be >= 2")
        if out["batch_size"] > rollout:
            raise ConfigError(f"{where}: batch_size = {out['batch_size']} exceeds n_steps * n_envs = {rollout}")
    if algo == "sac" and out["use_sde"] is False and "log_std_init" in out["policy_kwargs"]:
        raise ConfigError(f"{where}: policy_kwargs.log_std_init is used by SAC only with use_sde: true")
    return out


def _schedule_value(value: float | str) -> float | Callable[[float], float]:
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return float(value)


def _algo_kwargs(cfg: Mapping[str, Any], algo: str, action_dim: int) -> dict[str, Any]:
    defaults = _algo_defaults(algo)
    kw: dict[str, Any] = {}
    for key in defaults:
        v = cfg[key]
        if key in ("learning_rate", "clip_range", "clip_range_vf") and v is not None:
            v = _schedule_value(v)
        if key == "train_freq" and isinstance(v, list):
            v = tuple(v)
        kw[key] = v
    if algo != "ppo" and cfg.get("noise_type"):
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        cls = NormalActionNoise if cfg["noise_type"] == "normal" else OrnsteinUhlenbeckActionNoise
        kw["action_noise"] = cls(np.zeros(action_dim), cfg["noise_std"] * np.ones(action_dim))
    kw["policy_kwargs"] = policy_kwargs_object(cfg["policy_kwargs"])
    return kw


# --------------------------------------------------------------------------- envs, evaluation
def make_envs(env_id: str, cfg: Mapping[str, Any], *, seed: int, n_eval_episodes: int):
    """Training ``VecNormalize(make_sb3_vec_env(...))`` and the frozen evaluation counterpart
    (``None`` when ``n_eval_episodes == 0``). With a ``residual`` entry both vector envs are
    ``VecNormalize([VecFrameStack](ResidualVecEnv(make_sb3_vec_env(...))))`` (the base controller reads raw
    observations)."""
    from hydro_envs.envs.sb3 import make_sb3_vec_env

    residual = cfg.get("residual")

    def wrap(v: Any) -> Any:
        if residual is not None:
            from agents.residual import ResidualVecEnv

            v = ResidualVecEnv(v, env_id, residual["controller"], residual["scale"])
        if cfg.get("frame_stack"):
            v = VecFrameStack(v, cfg["frame_stack"])
        return v

    norm = cfg["normalize"]
    try:
        venv = make_sb3_vec_env(env_id, n_envs=cfg["n_envs"], seed=seed, **cfg["env_kwargs"])
    except TypeError as exc:
        raise ConfigError(f"[{env_id}] env_kwargs {sorted(cfg['env_kwargs'])} not accepted by the env: {exc}") from exc
    except ValueError as exc:
        raise ConfigError(f"[{env_id}] env_kwargs: {exc}") from exc
    vn_kw = dict(norm_obs=norm["norm_obs"], clip_obs=norm["clip_obs"], clip_reward=norm["clip_reward"],
                 gamma=cfg["gamma"], epsilon=norm["epsilon"])
    train_env = VecNormalize(wrap(venv), training=True, norm_reward=norm["norm_reward"], **vn_kw)
    eval_env = None
    if n_eval_episodes > 0:
        ev = make_sb3_vec_env(env_id, n_envs=n_eval_episodes, **cfg["env_kwargs"])
        eval_env = VecNormalize(wrap(ev), training=False, norm_reward=False, **vn_kw)
    return train_env, eval_env


def evaluate(model: Any, eval_env: Any, seed: int, train_env: Any | None = None,
             max_steps: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One deterministic episode on every copy of ``eval_env`` (reset with seeds ``seed + i``).

    With ``train_env`` given, its ``VecNormalize`` statistics are copied first; the eval env
    is frozen (``training=False``, ``norm_reward=False``) and its returns are sums of raw
    rewards. Returns ``(returns, lengths)`` per copy.
    """
    if train_env is not None:
        sync_envs_normalization(train_env, eval_env)
    eval_env.training = False
    eval_env.norm_reward = False
    n = eval_env.num_envs
    eval_env.seed(seed)
    obs = eval_env.reset()
    returns = np.zeros(n)
    lengths = np.zeros(n, dtype=np.int64)
    done = np.zeros(n, dtype=bool)
    limit = max_steps if max_steps is not None else 10**9
    steps = 0
    while not done.all() and steps < limit:
        actions, _ = model.predict(obs, deterministic=True)
        obs, _, dones, _ = eval_env.step(actions)
        raw = eval_env.get_original_reward()
        live = ~done
        returns[live] += raw[live]
        lengths[live] += 1
        done |= dones
        steps += 1
    return returns, lengths


class EvalLogCallback(BaseCallback):
    """Periodic and final evaluation on the fixed seeded set; writes the CSV/NPZ log,
    TensorBoard scalars ``eval/*`` and the best model with its statistics."""

    def __init__(self, eval_env: Any, run_dir: Path, eval_freq: int, eval_seed: int, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.eval_env = eval_env
        self.run_dir = Path(run_dir)
        self.eval_freq = int(eval_freq)
        self.eval_seed = int(eval_seed)
        self.next_eval = self.eval_freq if self.eval_freq > 0 else None
        self.timesteps: list[int] = []
        self.returns: list[np.ndarray] = []
        self.lengths: list[np.ndarray] = []
        self.best = -np.inf
        self.t0 = time.perf_counter()
        self.last_eval_at = -1
        with open(self.run_dir / EVAL_CSV, "w", newline="") as fh:
            csv.writer(fh).writerow(["timesteps", "mean_return", "std_return", "min_return", "max_return",
                                     "mean_step_reward", "mean_length", "wall_time_s"])

    def _on_step(self) -> bool:
        if self.next_eval is not None and self.num_timesteps >= self.next_eval:
            while self.next_eval <= self.num_timesteps:
                self.next_eval += self.eval_freq
            self.run_evaluation()
        return True

    def _on_training_end(self) -> None:
        if self.last_eval_at != self.num_timesteps:
            self.run_evaluation()

    def run_evaluation(self) -> None:
        train_env = self.model.get_env()
        ret, length = evaluate(self.model, self.eval_env, self.eval_seed, train_env)
        self.last_eval_at = self.num_timesteps
        self.timesteps.append(self.num_timesteps)
        self.returns.append(ret)
        self.lengths.append(length)
        mean, std = float(ret.mean()), float(ret.std())
        step_r = float(ret.sum() / max(length.sum(), 1))
        wall = time.perf_counter() - self.t0
        with open(self.run_dir / EVAL_CSV, "a", newline="") as fh:
            csv.writer(fh).writerow([self.num_timesteps, mean, std, float(ret.min()), float(ret.max()),
                                     step_r, float(length.mean()), round(wall, 3)])
        from hydro_envs.outputs import atomic_path

        with atomic_path(self.run_dir / EVAL_NPZ) as tmp:
            np.savez(tmp, timesteps=np.array(self.timesteps), results=np.array(self.returns),
                     ep_lengths=np.array(self.lengths),
                     eval_seeds=self.eval_seed + np.arange(self.eval_env.num_envs))
        self.logger.record("eval/mean_return", mean)
        self.logger.record("eval/std_return", std)
        self.logger.record("eval/mean_step_reward", step_r)
        self.logger.dump(self.num_timesteps)
        if mean > self.best:
            self.best = mean
            self.model.save(self.run_dir / BEST_MODEL_FILE)
            train_env.save(str(self.run_dir / BEST_VECNORM_FILE))
            write_compact(self.model.policy, _obs_normalizer(train_env), self.run_dir, "best")
        if self.verbose:
            print(f"eval @ {self.num_timesteps} steps: return {mean:.4g} +- {std:.3g} "
                  f"(per step {step_r:.4g}), best {self.best:.4g}", flush=True)


# --------------------------------------------------------------------------- training
def _run_dir(out: str | Path, name: str | None, env_id: str, algo: str, seed: int) -> Path:
    root = Path(out)
    if name is None:
        stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S")
        base = f"{env_id.split('/')[-1]}_{algo}_{seed}_{stamp}"
        run, k = root / base, 1
        while run.exists():
            k += 1
            run = root / f"{base}_{k}"
    else:
        run = root / name
        if run.exists() and any(run.iterdir()):
            raise FileExistsError(f"run folder {run} exists and is not empty")
    run.mkdir(parents=True, exist_ok=True)
    return run


def train(
    env_id: str,
    algo: str,
    *,
    config: str | Path | Mapping[str, Any] | None = None,
    hyperparams: Mapping[str, Any] | None = None,
    timesteps: int | None = None,
    seed: int = 0,
    randomize: bool = True,
    out: str | Path = "runs",
    name: str | None = None,
    n_envs: int | None = None,
    eval_freq: int | None = None,
    n_eval_episodes: int = DEFAULT_N_EVAL,
    eval_seed: int = DEFAULT_EVAL_SEED,
    progress_bar: bool = True,
    verbose: int = 0,
    callbacks: Sequence[Any] = (),
    torch_threads: int | None = None,
    device: str = "cpu",
    record: Mapping[str, Any] | None = None,
) -> Path:
    """Train ``algo`` on ``env_id``; return the run folder (module docstring).

    ``hyperparams`` override top-level keys of the env entry (``timesteps`` and ``n_envs``
    override ``n_timesteps`` and ``n_envs``); ``randomize=False`` trains and evaluates on the
    nominal plant. ``eval_freq`` (timesteps; default ``n_timesteps // 10``, ``0``: only the
    final evaluation); ``n_eval_episodes = 0`` disables evaluation. ``callbacks`` are extra
    SB3 callbacks; ``record`` adds entries to ``args.json``.
    """
    import gymnasium as gym

    hydro_envs.apply_openmp_spin()  # before torch loads libgomp (hydro_envs/_openmp.py)
    import torch

    if algo not in ALGOS:
        raise ConfigError(f"algo = {algo!r}; allowed {list(ALGOS)}")
    if env_id not in gym.registry:
        ids = sorted(k for k in gym.registry if k.startswith("hydro_envs/"))
        raise ConfigError(f"env = {env_id!r} is not registered; hydro-envs ids: {ids}")
    seed = int(_num("arguments", "seed", seed, lo=0, hi=2**32 - 1, integer=True))
    n_eval_episodes = int(_num("arguments", "n_eval_episodes", n_eval_episodes, lo=0, integer=True))
    eval_seed = int(_num("arguments", "eval_seed", eval_seed, lo=0, hi=2**32 - 1, integer=True))
    over = dict(hyperparams or {})
    if timesteps is not None:
        over["n_timesteps"] = timesteps
    if n_envs is not None:
        over["n_envs"] = n_envs
    entry = load_agent_config(config, algo, env_id)
    if not randomize:
        env_kwargs = dict(over.get("env_kwargs", entry.get("env_kwargs")) or {})
        env_kwargs["randomize"] = False
        over["env_kwargs"] = env_kwargs
    cfg = resolve_config(entry, algo, env_id, over)
    if eval_freq is None:
        eval_freq = max(cfg["n_timesteps"] // 10, cfg["n_envs"])
    eval_freq = int(_num("arguments", "eval_freq", eval_freq, lo=0, integer=True))
    if torch_threads is not None:
        torch.set_num_threads(int(_num("arguments", "torch_threads", torch_threads, lo=1, integer=True)))

    train_env, eval_env = make_envs(env_id, cfg, seed=seed, n_eval_episodes=n_eval_episodes)  # before any file
    run = _run_dir(out, name, env_id, algo, seed)
    from hydro_envs.outputs import atomic_write

    atomic_write(run / CONFIG_FILE, yaml.safe_dump({env_id: cfg}, sort_keys=False))
    args = dict(env_id=env_id, algo=algo, seed=seed, randomize=bool(cfg["env_kwargs"].get("randomize", True)),
                config_source=str(entry["__source__"]), hyperparams=_jsonable(dict(hyperparams or {})),
                timesteps=cfg["n_timesteps"], n_envs=cfg["n_envs"], eval_freq=eval_freq,
                n_eval_episodes=n_eval_episodes, eval_seed=eval_seed, device=device,
                torch_threads=torch.get_num_threads(), **dict(record or {}),
                started_utc=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    atomic_write(run / ARGS_FILE, json.dumps(args, indent=2))

    cls = algo_class(algo)
    model = cls(cfg["policy"], train_env, seed=seed, device=device, verbose=verbose,
                tensorboard_log=str(run / TB_DIR), **_algo_kwargs(cfg, algo, train_env.action_space.shape[0]))
    cbs = list(callbacks)
    if eval_env is not None:
        cbs.insert(0, EvalLogCallback(eval_env, run, eval_freq, eval_seed, verbose=verbose))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*rich is experimental.*")
        warnings.filterwarnings("ignore", category=UserWarning, module="tqdm")
        model.learn(total_timesteps=cfg["n_timesteps"], callback=cbs or None, tb_log_name=algo,
                    progress_bar=progress_bar)
    model.save(run / MODEL_FILE)
    train_env.save(str(run / VECNORM_FILE))
    write_compact(model.policy, _obs_normalizer(train_env), run, "final")  # what evaluation reads
    train_env.close()
    if eval_env is not None:
        eval_env.close()
    return run


def _obs_normalizer(env: Any) -> Any | None:
    """The ``VecNormalize`` wrapper of ``env`` (frozen copy of its statistics), or None."""
    return ObsNormalizer.from_vecnormalize(env) if isinstance(env, VecNormalize) and env.norm_obs else None


def _jsonable(x: Any) -> Any:
    return json.loads(json.dumps(x, default=str))


def _parse_hyperparams(items: Sequence[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        if "=" not in item:
            raise ConfigError(f"--hyperparams entry {item!r} must be KEY=VALUE (VALUE in YAML)")
        k, v = item.split("=", 1)
        from hydro_envs.yamlio import YamlError, load_yaml_text

        try:
            out[k.strip()] = load_yaml_text(v, f"--hyperparams {k.strip()}")
        except YamlError as exc:
            raise ConfigError(str(exc)) from None
    return out


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m agents.train", description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True, help="env id, e.g. hydro_envs/ServoCylinderPosition-v0")
    p.add_argument("--algo", required=True, choices=ALGOS)
    p.add_argument("--config", help="zoo-format YAML keyed by env id (default configs/agents/<algo>.yml)")
    p.add_argument("--timesteps", type=int, help="override n_timesteps")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-randomization", action="store_true", help="train and evaluate on the nominal plant")
    p.add_argument("--out", default="runs", help="parent folder of the run folder (default runs/)")
    p.add_argument("--name", help="run folder name (default <env>_<algo>_<seed>_<UTC timestamp>)")
    p.add_argument("--n-envs", type=int, help="override n_envs")
    p.add_argument("--eval-freq", type=int,
                   help="timesteps between evaluations (default n_timesteps/10; 0: final only)")
    p.add_argument("--n-eval-episodes", type=int, default=DEFAULT_N_EVAL, help="fixed evaluation draws (0: none)")
    p.add_argument("--eval-seed", type=int, default=DEFAULT_EVAL_SEED, help="evaluation copy i uses eval_seed + i")
    p.add_argument("--hyperparams", "-params", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override entries, VALUE parsed as YAML (e.g. learning_rate=1.0e-3)")
    p.add_argument("--no-progress-bar", action="store_true")
    p.add_argument("--torch-threads", type=int)
    p.add_argument("--verbose", type=int, default=0)
    a = p.parse_args(argv)
    try:
        run = train(a.env, a.algo, config=a.config, hyperparams=_parse_hyperparams(a.hyperparams),
                    timesteps=a.timesteps, seed=a.seed, randomize=not a.no_randomization, out=a.out,
                    name=a.name, n_envs=a.n_envs, eval_freq=a.eval_freq, n_eval_episodes=a.n_eval_episodes,
                    eval_seed=a.eval_seed, progress_bar=not a.no_progress_bar, verbose=a.verbose,
                    torch_threads=a.torch_threads,
                    record={"argv": list(sys.argv[1:] if argv is None else argv)})
    except (ConfigError, FileExistsError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"run folder: {run}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
