"""Compiled kernels of the differential cylinder: its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step; ``trajectories`` runs whole
input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the right-hand side
along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`.
"""

from __future__ import annotations

from hydro_envs.plants.differential_cylinder.model import differential_cylinder_guard as guard
from hydro_envs.plants.differential_cylinder.model import differential_cylinder_rhs as rhs
from hydro_envs.sim.binding import bind_rk4

__all__ = ["KERNELS", "step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard"]

#: the compiled kernels (hydro_envs.contract.KernelSet), made by the one factory
KERNELS = bind_rk4("differential_cylinder", rhs, guard)
step_serial, step_parallel = KERNELS.step_serial, KERNELS.step_parallel
trajectories, derivatives = KERNELS.trajectories, KERNELS.derivatives
