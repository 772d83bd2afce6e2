r"""Train one configuration with several seeds, serially or one Ray task per seed.

Command line::

    python -m agents.multiseed --env hydro_envs/ServoCylinderPosition-v0 --algo ppo \
        --seeds 0 1 2 [--backend serial|ray] [--ray-address ADDR] [--num-cpus N] \
        [--name NAME] [--out DIR] [--timesteps N] [--config FILE] [--n-envs N] \
        [--eval-freq N] [--n-eval-episodes N] [--eval-seed S] [--no-randomization] \
        [--hyperparams KEY=VALUE ...] [--torch-threads N]

and from Python ``train_seeds(env_id, algo, seeds, ...) -> list[Path]`` (run folders, in the
order of ``seeds``).

Every seed is exactly one :func:`agents.train.train` call with that seed and the shared
options, so a seed's run equals ``python -m agents.train ... --seed S`` with the same
``--torch-threads``. Why one task per seed: a training run is minutes of work, far above a Ray
task's overhead, and seeds share nothing. Each task reserves one CPU and trains with
``torch_threads`` threads (default 1: the setting under which agents.train documents
bit-identical runs; more threads in several tasks would also oversubscribe the CPUs).

``--name NAME`` names the run folders ``NAME_s<seed>``, the suffix the benchmark strips when it
pools training seeds into one row (``hydro benchmark --policy runs/NAME_s0 runs/NAME_s1 ...``);
without it each run gets agents.train's ``<env>_<algo>_<seed>_<timestamp>`` folder. ``--out``
is made absolute here, so Ray workers write where this process would; on a multi-node
cluster it must be a filesystem every node shares.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.backend import add_backend_args, check_backend, import_ray, run_tasks

__all__ = ["main", "train_seeds"]


def _train_one(env_id: str, algo: str, kwargs: dict[str, Any]) -> Path:
    """Body of one seed's task (module level so Ray can ship it by reference)."""
    from agents.train import train

    return train(env_id, algo, **kwargs)


def train_seeds(
    env_id: str,
    algo: str,
    seeds: Sequence[int],
    *,
    backend: str = "serial",
    address: str | None = None,
    num_cpus: int | None = None,
    name: str | None = None,
    out: str | Path = "runs",
    torch_threads: int = 1,
    **train_kwargs: Any,
) -> list[Path]:
    """Run folders of ``agents.train.train(env_id, algo, seed=s, ...)`` for every ``s`` in ``seeds``.

    ``train_kwargs`` are passed to every call (``config``, ``hyperparams``, ``timesteps``,
    ``randomize``, ``n_envs``, ``eval_freq``, ``n_eval_episodes``, ``eval_seed``, ...; not
    ``seed``). ``name`` -> folders ``<name>_s<seed>``. Errors of a run (a bad config, an
    existing folder) are raised as in a single training.
    """
    if check_backend(backend) == "ray":
        import_ray()  # fail before any work when the extra is missing
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds must name at least one seed")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct, got {seeds}")
    for bad in ("seed", "callbacks"):
        if bad in train_kwargs:
            raise ValueError(f"{bad!r} cannot be passed to train_seeds (seeds are the seed list; "
                             "callbacks are not shipped to Ray workers)")
    if not (isinstance(torch_threads, int) and torch_threads >= 1):
        raise ValueError(f"torch_threads must be an integer >= 1, got {torch_threads!r}")
    base = dict(train_kwargs, out=str(Path(out).resolve()), torch_threads=torch_threads)
    if backend == "ray":
        base["progress_bar"] = False  # tasks' output is interleaved; a bar per task is noise
    calls = []
    for s in seeds:
        kw = dict(base, seed=s, name=None if name is None else f"{name}_s{s}")
        calls.append((env_id, algo, kw))
    return run_tasks(_train_one, calls, backend=backend, address=address, num_cpus=num_cpus,
                     task_cpus=torch_threads)


def main(argv: Sequence[str] | None = None) -> int:
    from agents.train import ALGOS, DEFAULT_EVAL_SEED, DEFAULT_N_EVAL, ConfigError, _parse_hyperparams

    p = argparse.ArgumentParser(prog="python -m agents.multiseed", description=__doc__.split("\n")[0])
    p.add_argument("--env", required=True, help="env id, e.g. hydro_envs/ServoCylinderPosition-v0")
    p.add_argument("--algo", required=True, choices=ALGOS)
    p.add_argument("--seeds", required=True, type=int, nargs="+", metavar="S", help="training seeds")
    add_backend_args(p)
    p.add_argument("--name", help="run folders NAME_s<seed> (default <env>_<algo>_<seed>_<UTC timestamp>)")
    p.add_argument("--out", default="runs", help="parent folder of the run folders (default runs/)")
    p.add_argument("--config", help="zoo-format YAML keyed by env id (default configs/agents/<algo>.yml)")
    p.add_argument("--timesteps", type=int, help="override n_timesteps")
    p.add_argument("--no-randomization", action="store_true", help="train and evaluate on the nominal plant")
    p.add_argument("--n-envs", type=int, help="override n_envs")
    p.add_argument("--eval-freq", type=int, help="timesteps between evaluations (default n_timesteps/10)")
    p.add_argument("--n-eval-episodes", type=int, default=DEFAULT_N_EVAL, help="fixed evaluation draws (0: none)")
    p.add_argument("--eval-seed", type=int, default=DEFAULT_EVAL_SEED, help="evaluation copy i uses eval_seed + i")
    p.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override entries, VALUE parsed as YAML (e.g. learning_rate=1.0e-3)")
    p.add_argument("--torch-threads", type=int, default=1, help="torch threads (and CPUs) per seed (default 1)")
    p.add_argument("--no-progress-bar", action="store_true")
    p.add_argument("--verbose", type=int, default=0)
    a = p.parse_args(argv)
    try:
        runs = train_seeds(a.env, a.algo, a.seeds, backend=a.backend, address=a.ray_address, num_cpus=a.num_cpus,
                           name=a.name, out=a.out, torch_threads=a.torch_threads, config=a.config,
                           hyperparams=_parse_hyperparams(a.hyperparams), timesteps=a.timesteps,
                           randomize=not a.no_randomization, n_envs=a.n_envs, eval_freq=a.eval_freq,
                           n_eval_episodes=a.n_eval_episodes, eval_seed=a.eval_seed,
                           progress_bar=not a.no_progress_bar, verbose=a.verbose,
                           record={"argv": list(sys.argv[1:] if argv is None else argv),
                                   "multiseed": {"seeds": list(a.seeds), "backend": a.backend}})
    except (ConfigError, FileExistsError, ValueError, ImportError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for run in runs:
        print(f"run folder: {run}")
    if a.name:
        print(f"benchmark them as one pooled row: hydro benchmark --env {a.env} --policy "
              + " ".join(str(r) for r in runs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
