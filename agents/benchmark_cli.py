"""``hydro benchmark``: the command line and the YAML configs of :mod:`agents.benchmark`.

A config (``configs/benchmarks/<name>.yaml``, found by name from any working directory,
or any file) gives ``env``, ``controllers``, ``params``, ``n``, ``seed``, ``episode_steps``,
``reference``, ``step_reference``, ``policies`` (run folders, relative to the repository),
``figures``, ``randomization`` (a calibrated spec for the draws) and ``out``; flags override it.
The config is read with :func:`hydro_envs.yamlio.load_yaml` (duplicate keys and alias bombs
refused) and its values are typed (``n: 2.9`` or ``n: true`` is an error naming the field).
Before any controller runs, everything the run reads or writes is checked: the randomisation
spec loads, every policy folder loads and was trained on the env, and ``--out`` is a folder that
is empty (or absent) unless ``--force``. Errors follow the command line's convention
(:mod:`hydro_envs.cli_errors`). ``python -m agents.benchmark_cli`` takes the same options.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.backend import add_backend_args
from hydro_envs.config_files import config_file
from agents.benchmark import PARAM_SETS, run_benchmark

__all__ = ["SHIPPED_CONFIGS", "add_cli", "cli_benchmark", "config_path", "load_config", "main"]


def add_cli(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``hydro benchmark`` on an argparse subparsers object."""
    p = subparsers.add_parser(
        "benchmark",
        help="evaluate classical and learned controllers on frozen parameter draws",
        description="Evaluate controllers on the same seeded parameter draws (nominal, the training "
                    "ranges 'in', or outside them 'out') and write markdown/CSV tables and figures.",
    )
    p.add_argument("--config", metavar="FILE", help="YAML with env, controllers, n, params, episode_steps, ...")
    p.add_argument("--env", metavar="ID", help="env id, e.g. hydro_envs/ServoCylinderPosition-v0")
    p.add_argument("--controllers", metavar="LIST",
                   help="comma-separated: classical names and/or sb3:RUN_DIR (NAME=sb3:RUN_DIR)")
    p.add_argument("--params", metavar="SET", help="nominal|in|out, or a comma-separated list; may include one "
                   "parameter file with units (its rig is the nominal set the others are drawn around)")
    p.add_argument("--n", type=int, metavar="N", help="number of parameter draws (default 20)")
    p.add_argument("--seed", type=int, metavar="S", help="seed of draws and episodes (default 0)")
    p.add_argument("--out", metavar="DIR", help="output folder (tables, figures); a non-empty folder only with --force")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty --out folder (files of the same name are replaced)")
    p.add_argument("--steps", type=int, metavar="K", help="episode length in env steps")
    p.add_argument("--policy", nargs="+", action="extend", metavar="RUN_DIR", default=[],
                   help="trained run folder(s) (several training seeds pool by name)")
    p.add_argument("--trust-pickle", action="store_true",
                   help="also read run folders that have only SB3's pickled files (model.zip, vecnormalize.pkl); "
                        "a pickle can run code on load, so only for folders you trust (default: the safe "
                        "policy.pt + obs_normalization.npz layout only)")
    p.add_argument("--randomization", metavar="FILE",
                   help="randomisation spec of the 'in'/'out' draws instead of the plant's default (e.g. one "
                        "written by hydro identify ... --emit-ranges)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    add_backend_args(p)
    p.add_argument("--chunk-size", type=int, metavar="N", default=None,
                   help="draws per Ray task for classical controllers (default: one task per CPU)")
    p.set_defaults(func=cli_benchmark)
    return p


_CONFIG_KEYS = {"env", "controllers", "n", "params", "episode_steps", "seed", "out", "reference",
                "step_reference", "policies", "figures", "randomization", "note"}


#: folder of the shipped benchmark configs (``configs/benchmarks/``)
SHIPPED_CONFIGS = config_file("benchmarks")


def config_path(name: str | Path) -> Path:
    """A benchmark config: an existing file, else a shipped one by name (``servo_cylinder`` or
    ``servo_cylinder.yaml``, from any working directory)."""
    path = Path(name)
    if path.is_file():
        return path
    shipped = SHIPPED_CONFIGS / (path.name if path.suffix in (".yaml", ".yml") else f"{path.name}.yaml")
    if shipped.is_file():
        return shipped
    names = sorted(f.stem for f in SHIPPED_CONFIGS.glob("*.yaml"))
    raise FileNotFoundError(f"benchmark config {str(name)!r}: no such file, and no shipped config of that name; "
                            f"shipped: {', '.join(names)}")


def _policy_path(entry: str) -> str:
    """A policy run folder named in a config: as given, else relative to the repository/package root."""
    if Path(entry).exists():
        return entry
    rooted = Path(__file__).resolve().parents[1] / entry
    return str(rooted) if rooted.exists() else entry


def load_config(path: str | Path) -> dict[str, Any]:
    """A benchmark config (:func:`config_path`): a mapping of the known keys, each value typed
    (:func:`check_config`)."""
    from hydro_envs.yamlio import load_yaml

    path = config_path(path)
    data = load_yaml(path, what="benchmark config")
    if not isinstance(data, dict):
        raise ValueError(f"benchmark config {path}: top level must be a mapping")  # noqa: TRY004
    extra = set(data) - _CONFIG_KEYS
    if extra:
        raise ValueError(f"benchmark config {path}: unknown key(s) {sorted(map(str, extra))}; allowed {sorted(_CONFIG_KEYS)}")
    return check_config(data, path)


def _names(value: Any, field: str, where: Any) -> list[str]:
    """A comma-separated string or a list of strings."""
    from hydro_envs.yamlio import YamlError, short

    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return [v.strip() for v in value if v.strip()]
    raise YamlError(where, f"{field} = {short(value)}; allowed a list of names or a comma-separated string", key=field)


def check_config(data: dict[str, Any], where: Any = None) -> dict[str, Any]:
    """The config's values typed: ``n`` an integer >= 1, ``seed`` an integer >= 0, ``episode_steps``
    an integer >= 1 or null, ``figures`` true/false, names as lists or strings, paths as strings."""
    from hydro_envs import yamlio as y

    out = dict(data)
    if "env" in out:
        out["env"] = y.text(out["env"], "env", where)
    if "n" in out:
        out["n"] = y.integer(out["n"], "n", where, lo=1)
    if "seed" in out:
        out["seed"] = y.integer(out["seed"], "seed", where, lo=0, hi=2**32 - 1)
    if out.get("episode_steps") is not None:
        out["episode_steps"] = y.integer(out["episode_steps"], "episode_steps", where, lo=1)
    if "figures" in out:
        out["figures"] = y.boolean(out["figures"], "figures", where)
    for key in ("controllers", "params", "policies"):
        if out.get(key) is not None:
            out[key] = _names(out[key], key, where)
    for key in ("randomization", "out", "reference", "step_reference"):
        if out.get(key) is not None:
            out[key] = y.text(out[key], key, where)
    return out


def _positive(name: str, value: int | None) -> int | None:
    if value is not None and value < 1:
        raise ValueError(f"{name} = {value}; allowed an integer >= 1")
    return value


def _preflight_policies(env: str, ctrls: list[str], trust_pickle: bool) -> None:
    """Load every ``sb3:`` run folder once and check it was trained on ``env``: a bad folder is
    an error before any controller runs, not after the others did."""
    from agents.benchmark import _checked_policy, _load_policy, parse_controllers

    for _name, kind, run in parse_controllers(env, ctrls):
        if kind != "sb3":
            continue
        if not Path(run).exists():
            raise FileNotFoundError(f"--policy {run}: no such run folder")
        _checked_policy(_load_policy(run, trust_pickle=trust_pickle), run, env)


def _preflight_randomization(env: str, path: str) -> None:
    """The randomisation spec exists and loads for the env's plant (also when only nominal draws run)."""
    from hydro_envs import registry
    from hydro_envs.randomization import RandomizationSpec

    if not Path(path).is_file():
        raise FileNotFoundError(f"--randomization {path}: no such file")
    spec = registry.spec_for_env(env)
    RandomizationSpec.from_yaml(path, spec.params_cls)


def _rig_file(psets: list[str]) -> tuple[list[str], str | None]:
    """The set names of ``--params`` and the parameter file among them (at most one; an env that
    reads parameter files takes it as its nominal rig): ``(sets or ["nominal"], file or None)``."""
    files = [s for s in psets if s not in PARAM_SETS]
    for s in files:
        if not Path(s).is_file():
            raise ValueError(f"--params: {s!r} is neither a set ({', '.join(PARAM_SETS)}) nor an existing "
                             "parameter file")
    if len(files) > 1:
        raise ValueError(f"--params: one parameter file at most, got {', '.join(files)}")
    sets = [s for s in psets if s in PARAM_SETS] or ["nominal"]
    return sets, (files[0] if files else None)


def cli_benchmark(args: argparse.Namespace) -> int:
    """Run ``hydro benchmark``; errors propagate to the command line's one-line convention."""
    from hydro_envs.outputs import check_output_dir

    cfg: dict[str, Any] = {}
    if args.config:
        cfg = load_config(args.config)
    env = args.env or cfg.get("env")
    if not env:
        raise ValueError("--env (or 'env' in --config) is required")
    ctrls = args.controllers if args.controllers is not None else cfg.get("controllers", "pid")
    ctrls = [c.strip() for c in (ctrls.split(",") if isinstance(ctrls, str) else ctrls) if str(c).strip()]
    ctrls += [f"sb3:{_policy_path(str(r))}" for r in list(cfg.get("policies") or [])]
    ctrls += [f"sb3:{r}" for r in args.policy]
    psets = args.params if args.params is not None else cfg.get("params", "nominal")
    psets = [s.strip() for s in (psets.split(",") if isinstance(psets, str) else psets)]
    psets, rig = _rig_file(psets)
    n = _positive("--n", args.n) if args.n is not None else int(cfg.get("n", 20))
    seed = args.seed if args.seed is not None else int(cfg.get("seed", 0))
    if seed < 0:
        raise ValueError(f"--seed = {seed}; allowed an integer >= 0")
    out = args.out or cfg.get("out")
    steps = _positive("--steps", args.steps) if args.steps is not None else cfg.get("episode_steps")
    figures = (not args.no_figures) and bool(cfg.get("figures", True))
    backend = getattr(args, "backend", "serial")
    chunk = _positive("--chunk-size", getattr(args, "chunk_size", None))
    rand = getattr(args, "randomization", None) or cfg.get("randomization")
    env_kwargs = {"randomization": str(rand)} if rand else None
    if rig:  # the env's nominal rig is the file's; the sets are drawn around it
        env_kwargs = {**(env_kwargs or {}), "params": rig}
    # everything the run reads and writes, before any controller runs
    from agents.benchmark import _adapter, parse_controllers

    _adapter(env)
    parse_controllers(env, ctrls)
    if out:
        inputs = [rand, rig, str(config_path(args.config)) if args.config else None]
        check_output_dir(out, force=bool(getattr(args, "force", False)), inputs=[i for i in inputs if i])
    if rand:
        _preflight_randomization(env, str(rand))
    _preflight_policies(env, ctrls, bool(getattr(args, "trust_pickle", False)))
    for s in psets:
        res = run_benchmark(env, ctrls, s, n, seed, out, episode_steps=steps, reference=cfg.get("reference"),
                            step_reference=cfg.get("step_reference", "auto"), figures=figures,
                            progress=lambda msg: print(msg, file=sys.stderr, flush=True),
                            backend=backend, chunk_size=chunk, ray_address=getattr(args, "ray_address", None),
                            trust_pickle=bool(getattr(args, "trust_pickle", False)), env_kwargs=env_kwargs,
                            num_cpus=getattr(args, "num_cpus", None))
        print(res.markdown())
        print(f"({res.seconds:.1f} s)" + (f"; wrote {', '.join(str(f) for f in res.files)}" if res.files else ""))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m agents.benchmark_cli [options]`` (the same options as ``hydro benchmark``)."""
    from hydro_envs.cli_errors import Parser, guarded

    sub = Parser().add_subparsers()
    parser = add_cli(sub)
    parser.prog = "python -m agents.benchmark_cli"
    args = parser.parse_args(sys.argv[1:] if argv is None else list(argv))
    return guarded(parser.prog, args.func, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
