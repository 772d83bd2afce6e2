"""hydro-envs: Gymnasium environments for friction-aware control of fluid-power actuators.

Importing the package registers the environments with Gymnasium::

    import gymnasium as gym
    import hydro_envs  # noqa: F401

    env = gym.make("hydro_envs/ServoCylinderPosition-v0")
    venv = gym.make_vec("hydro_envs/ServoCylinderPosition-v0", num_envs=1024,
                        vectorization_mode="vector_entry_point")

Importing changes nothing else in the process: the OpenMP spin setting is applied when the
first vector env is made (:func:`apply_openmp_spin`, which a program that loads torch first
calls itself) and the numba cache is checked against the sources before the first kernel runs
(``hydro_envs/_numba_cache.py``).
"""

from __future__ import annotations

from gymnasium.envs.registration import register
from gymnasium.envs.registration import registry as gym_registry

__version__ = "0.1.0"


def apply_openmp_spin() -> int | None:
    """Bound how long idle OpenMP (libgomp) workers spin: set ``GOMP_SPINCOUNT`` to the count
    that spins about 75 us on this CPU, unless ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is set
    already (a user's setting is kept). libgomp reads the variable once, when it is loaded, so
    this must run before numba's parallel kernels or torch load it: the first vector env made
    calls it, and a program that imports torch before making one (``agents.train``) calls it
    first. Once per process; returns the count set, or None. See ``hydro_envs/_openmp.py``."""
    from hydro_envs._openmp import set_spin_time

    return set_spin_time()


def _register_envs() -> None:
    """Register every env id the plant registry lists (idempotent)."""
    from hydro_envs.registry import env_entries

    for _spec, entry in env_entries():
        if entry.id not in gym_registry:
            register(
                id=entry.id,
                entry_point=entry.entry_point,
                vector_entry_point=entry.vector_entry_point,
                max_episode_steps=entry.max_episode_steps,
            )


_register_envs()

__all__ = ["__version__", "apply_openmp_spin"]
