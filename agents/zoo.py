"""rl-baselines3-zoo interop: the native vector env inside a zoo run, and zoo run folders.

**Training with rl_zoo3.** The shipped agent configs (``configs/agents/<algo>.yml``) carry the
zoo's own ``vec_env_wrapper`` key set to :func:`native_vec_env`. rl_zoo3 builds its usual
``DummyVecEnv`` of ``n_envs`` single envs and hands it to this wrapper, which closes it and
returns the package's native batch env (:func:`hydro_envs.envs.sb3.make_sb3_vec_env`: all
copies advanced by one compiled kernel call per step) under a ``VecMonitor`` that writes the
episode log into the zoo's run folder. So a zoo run with the shipped YAML as it is::

    python -m rl_zoo3.train --algo ppo --env hydro_envs/ServoCylinderPosition-v0 \\
        --gym-packages hydro_envs -conf configs/agents/ppo.yml

steps the same kernel as ``python -m agents.train`` (``bench/zoo_step_rate.py`` measures both).

**Reading a zoo run.** A zoo run folder (``logs/<algo>/<env>_<n>/``) holds ``<env>.zip``,
optionally ``best_model.zip``, and ``<env>/{args.yml, config.yml, vecnormalize.pkl}``.
:func:`is_zoo_run` recognises it and :func:`zoo_run_info` reads its files' names and YAML for
:func:`agents.policies.load_trained`, which loads the model. The zoo writes its YAML with Python ``OrderedDict`` tags;
they are read by a safe loader that knows that one tag (nothing is constructed from any other
tag). The models and normalisers are pickles, so a zoo run loads only with ``trust_pickle``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

__all__ = ["native_vec_env", "is_zoo_run", "zoo_run_files", "zoo_run_info", "read_zoo_yaml"]

#: gymnasium's and SB3's own per-env wrappers, which the native batch env applies itself
_STANDARD_WRAPPERS = ("Monitor", "TimeLimit", "OrderEnforcing", "PassiveEnvChecker", "EnvCompatibility")


def _per_copy_wrappers(env: Any) -> list[str]:
    names = []
    while hasattr(env, "env"):
        if not any(c.__name__ in _STANDARD_WRAPPERS for c in type(env).__mro__):  # rl_zoo3 subclasses TimeLimit
            names.append(type(env).__name__)
        env = env.env
    return names


def _monitor_dir(venv: Any) -> str | None:
    """The folder of the zoo's per-copy ``Monitor`` files (``None``: not logged)."""
    envs = getattr(venv, "envs", None)  # DummyVecEnv; a SubprocVecEnv keeps its envs elsewhere
    if not envs:
        return None
    writer = getattr(envs[0], "results_writer", None)
    handler = getattr(writer, "file_handler", None)
    return os.path.dirname(handler.name) if handler is not None else None


def _drop_empty_monitor_files(folder: str, n: int) -> None:
    """Remove the ``0.monitor.csv`` ... files of the closed per-copy envs that logged no episode."""
    for i in range(n):
        path = Path(folder) / f"{i}.monitor.csv"
        if path.is_file() and len(path.read_text(encoding="utf-8").splitlines()) <= 2:
            path.unlink()


def native_vec_env(venv: Any) -> Any:
    """rl_zoo3 ``vec_env_wrapper``: replace the zoo's vector env of single envs by the native
    batch env of the same env id, keyword arguments, number of copies and seeds.

    Raises ``ValueError`` when the copies carry a wrapper the native env cannot apply (a
    config's ``env_wrapper``): use the wrapper or this key, not both."""
    from gymnasium import spec as registered_spec
    from stable_baselines3.common.vec_env import VecMonitor

    from hydro_envs.envs.sb3 import make_sb3_vec_env

    spec = venv.get_attr("spec", [0])[0]
    if spec is None:
        raise ValueError("native_vec_env: the zoo's env has no gymnasium spec; it must be made from an env id")
    envs = getattr(venv, "envs", None)
    extra = _per_copy_wrappers(envs[0]) if envs else []
    if extra:
        raise ValueError(f"native_vec_env: the copies are wrapped in {extra}; the native batch env cannot apply "
                         "per-copy wrappers: drop env_wrapper from the config or drop vec_env_wrapper")
    base = registered_spec(spec.id).kwargs
    kwargs = {k: v for k, v in spec.kwargs.items() if k not in base or base[k] is not v}
    n, seeds, log_dir = venv.num_envs, list(getattr(venv, "_seeds", [None])), _monitor_dir(venv)
    venv.close()
    native = make_sb3_vec_env(spec.id, n_envs=n, **kwargs)
    if seeds and seeds[0] is not None:
        native.seed(int(seeds[0]))  # the zoo's make_vec_env seeded copy i with seed + i; so does this
    if log_dir is not None:
        _drop_empty_monitor_files(log_dir, n)
    return VecMonitor(native, filename=None if log_dir is None else os.path.join(log_dir, "native"))


# --------------------------------------------------------------------------- zoo run folders
class _ZooLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` plus the one Python tag rl_zoo3 writes (``OrderedDict``), as a dict."""


def _ordered_dict(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
    args = loader.construct_sequence(node, deep=True)  # type: ignore[arg-type]
    pairs = args[0] if len(args) == 1 and isinstance(args[0], list) else []  # OrderedDict(items): one argument
    if not all(isinstance(p, list) and len(p) == 2 for p in pairs):
        raise yaml.constructor.ConstructorError(None, None, "OrderedDict items must be [key, value] pairs",
                                                node.start_mark)
    return {str(k): v for k, v in pairs}


_ZooLoader.add_constructor("tag:yaml.org,2002:python/object/apply:collections.OrderedDict", _ordered_dict)


def read_zoo_yaml(path: Path) -> dict[str, Any]:
    """A zoo ``args.yml`` / ``config.yml`` as a dict (``ValueError`` naming the file otherwise)."""
    try:
        data = yaml.load(path.read_text(encoding="utf-8"), Loader=_ZooLoader)  # noqa: S506 - safe subclass
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ValueError(f"{path}: not a zoo YAML file ({type(exc).__name__}: {str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: top level must be a mapping, got {type(data).__name__}")
    return data


def zoo_run_files(run: Path) -> tuple[Path, Path] | None:
    """``(params folder, final model zip)`` of a zoo run folder, or ``None`` if ``run`` is not one."""
    for sub in sorted(p for p in run.iterdir() if p.is_dir()) if run.is_dir() else []:
        if (sub / "args.yml").is_file() and (sub / "config.yml").is_file() and (run / f"{sub.name}.zip").is_file():
            return sub, run / f"{sub.name}.zip"
    return None


def is_zoo_run(run: str | Path) -> bool:
    """Whether ``run`` is an rl_zoo3 run folder (``<env>.zip`` beside ``<env>/args.yml``)."""
    return zoo_run_files(Path(run)) is not None


def zoo_run_info(run_dir: str | Path, which: str = "final") -> tuple[Path, Path | None, str, str, dict[str, Any]]:
    """``(model zip, vecnormalize.pkl or None, env id, algo, config)`` of a zoo run folder; nothing
    is unpickled here (:func:`agents.policies.load_trained` loads the files). ``which="best"``
    names ``best_model.zip`` (the zoo's evaluation callback keeps one normaliser for both)."""
    run = Path(run_dir)
    found = zoo_run_files(run)
    if found is None:
        raise FileNotFoundError(f"{run}: not an rl_zoo3 run folder (no <env>.zip beside <env>/args.yml)")
    params, final = found
    args = read_zoo_yaml(params / "args.yml")
    env_id, algo = args.get("env"), args.get("algo")
    if not isinstance(env_id, str) or not isinstance(algo, str):
        raise ValueError(f"{params / 'args.yml'}: needs env (an env id) and algo; got env={env_id!r}, algo={algo!r}")
    model_file = final if which == "final" else run / "best_model.zip"
    if not model_file.is_file():
        raise FileNotFoundError(f"{model_file} not found (which = {which!r})")
    vecnorm = params / "vecnormalize.pkl"
    return model_file, vecnorm if vecnorm.is_file() else None, env_id, algo, read_zoo_yaml(params / "config.yml")
