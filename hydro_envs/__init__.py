"""hydro-envs: Gymnasium environments for friction-aware control of fluid-power actuators.

Importing the package registers the environments with Gymnasium::

    import gymnasium as gym
    import hydro_envs  # noqa: F401

    env = gym.make("hydro_envs/ServoCylinderPosition-v0")
    venv = gym.make_vec("hydro_envs/ServoCylinderPosition-v0", num_envs=1024,
                        vectorization_mode="vector_entry_point")
"""

from __future__ import annotations

from hydro_envs._openmp import set_wait_default

set_wait_default()  # before numba or torch load libgomp (hydro_envs/_openmp.py)

from gymnasium.envs.registration import register  # noqa: E402
from gymnasium.envs.registration import registry as gym_registry  # noqa: E402

from hydro_envs._numba_cache import purge_stale_numba_cache  # noqa: E402

purge_stale_numba_cache()  # before any kernel is compiled or loaded from the cache

__version__ = "0.1.0"

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

__all__ = ["__version__"]
