"""hydro-envs: Gymnasium environments for friction-aware control of fluid-power actuators.

Importing the package registers the environments with Gymnasium::

    import gymnasium as gym
    import hydro_envs  # noqa: F401

    env = gym.make("hydro_envs/ServoCylinderPosition-v0")
    venv = gym.make_vec("hydro_envs/ServoCylinderPosition-v0", num_envs=1024,
                        vectorization_mode="vector_entry_point")
"""

from __future__ import annotations

import os

# Package-wide threading decision: the vector envs step all copies in numba parallel kernels
# (OpenMP layer). libgomp's default wait policy lets its idle workers spin after every env
# step; on a small machine they take the cores from whatever runs between steps (a policy
# network: a SAC gradient step measured 260 ms instead of 13 ms on 2 cores). PASSIVE workers
# sleep instead, at a cost of a few microseconds per parallel step. libgomp reads the variable
# once, when it is loaded (by the first parallel kernel or by torch), so it is set here, before
# either; ``setdefault`` keeps a user's own OMP_WAIT_POLICY.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from gymnasium.envs.registration import register, registry  # noqa: E402

from hydro_envs._numba_cache import purge_stale_numba_cache  # noqa: E402

purge_stale_numba_cache()  # before any kernel is compiled or loaded from the cache

__version__ = "0.1.0"

_ENVS = {
    "hydro_envs/LoadSensing-v0": dict(
        entry_point="hydro_envs.envs.load_sensing:LoadSensingEnv",
        vector_entry_point="hydro_envs.envs.load_sensing:LoadSensingVectorEnv",
        max_episode_steps=2000,
    ),
    "hydro_envs/ServoCylinderPosition-v0": dict(
        entry_point="hydro_envs.envs.servo_cylinder:ServoCylinderPositionEnv",
        vector_entry_point="hydro_envs.envs.servo_cylinder:ServoCylinderPositionVectorEnv",
        max_episode_steps=2000,
    ),
    "hydro_envs/ShakingTable-v0": dict(
        entry_point="hydro_envs.envs.shaking_table:ShakingTableEnv",
        vector_entry_point="hydro_envs.envs.shaking_table:ShakingTableVectorEnv",
        max_episode_steps=6000,
    ),
    "hydro_envs/RodlessCylinder-v0": dict(
        entry_point="hydro_envs.envs.rodless_cylinder:RodlessCylinderEnv",
        vector_entry_point="hydro_envs.envs.rodless_cylinder:RodlessCylinderVectorEnv",
        max_episode_steps=2000,
    ),
    "hydro_envs/ForceActuator-v0": dict(
        entry_point="hydro_envs.envs.force_actuator:ForceActuatorEnv",
        vector_entry_point="hydro_envs.envs.force_actuator:ForceActuatorVectorEnv",
        max_episode_steps=5000,
    ),
}

for _id, _kw in _ENVS.items():
    if _id not in registry:
        register(id=_id, **_kw)

__all__ = ["__version__"]
