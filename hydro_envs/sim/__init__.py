"""Fixed-step compiled integration (RK4 sub-steps, batched), sub-steps from the stiffness
bound, batched trajectories (:func:`simulate`), stiff reference solves, and the root finder of
rest states (:mod:`hydro_envs.sim.roots`)."""

from hydro_envs.sim.rk4 import rk4_advance, rk4_trajectory
from hydro_envs.sim.simulate import simulate, substeps
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, substeps_from_stiffness

__all__ = [
    "DEFAULT_SAFETY",
    "rk4_advance",
    "rk4_trajectory",
    "simulate",
    "substeps",
    "substeps_from_stiffness",
]
