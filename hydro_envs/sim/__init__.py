"""Fixed-step compiled integration (RK4 sub-steps, batched) and stiff reference solves."""

from hydro_envs.sim.kernels import (
    SERVO_CYLINDER,
    plant_guard,
    plant_rhs,
    rk4_substeps,
    step_batch_parallel,
    step_batch_serial,
)
from hydro_envs.sim.stiffness import rk4_substeps as substeps_from_stiffness

__all__ = [
    "SERVO_CYLINDER",
    "plant_guard",
    "plant_rhs",
    "rk4_substeps",
    "step_batch_parallel",
    "step_batch_serial",
    "substeps_from_stiffness",
]
