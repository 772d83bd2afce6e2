"""Ahead-of-use compilation: fill numba's on-disk cache with the kernels a run will call.

numba compiles a kernel on its first call and, with ``cache=True``, stores it on disk; a later
process loads it in milliseconds. :func:`compile_env_kernels` makes, resets and steps every
registered env id once as a single env and once as a two-copy vector env (the serial and the
parallel step kernels, the observation and reward kernels). Other installed packages add their
own warm-ups under the ``hydro_envs.warmups`` entry points (a function ``compile(say)``);
``hydro compile`` runs them all (:func:`hydro_envs.cli.warmups`). The cache is dropped when a source file changes
(:mod:`hydro_envs._numba_cache`), so the command is run again after an edit.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

__all__ = ["WARMUP_GROUP", "compile_env_kernels"]

#: entry-point group of the warm-ups other packages register: ``name = "module:function"``,
#: the function takes ``say`` (a one-line progress callback) and compiles by running its code paths
WARMUP_GROUP = "hydro_envs.warmups"


def compile_env_kernels(env_ids: Sequence[str] | None = None,
                        say: Callable[[str], None] = lambda msg: None) -> dict[str, float]:
    """Make, reset and step each env id (default: every ``hydro_envs/`` id) as a single env and
    as a two-copy vector env; returns the seconds each took."""
    import gymnasium as gym

    import hydro_envs  # noqa: F401  (registers the env ids)

    ids = list(env_ids) if env_ids is not None else [i for i in gym.registry if i.startswith("hydro_envs/")]
    took: dict[str, float] = {}
    for env_id in ids:
        t0 = time.perf_counter()
        env = gym.make(env_id)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
        venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
        venv.reset(seed=0)
        venv.step(venv.action_space.sample())
        venv.close()
        took[env_id] = time.perf_counter() - t0
        say(f"{env_id}: {took[env_id]:.1f} s")
    return took
