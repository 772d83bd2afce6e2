"""Compiled kernels of the force actuator (seed 001): its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step (the single env uses the
serial one: a parallel region costs more to enter than a whole step); ``trajectories`` runs
whole input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the
right-hand side along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`. All of them
step with :func:`~hydro_envs.sim.rk4.rk4_advance_lookahead`: sub-steps sized by
``stiffness_modes``, each taken as finer ones where the Dahl friction state is stiff at its
start or at the Euler prediction of its end (at speed or across a velocity reversal), as many as
:func:`~.model.dahl_friction_substeps` gives.
"""

from __future__ import annotations

from hydro_envs.plants.force_actuator.model import dahl_friction_refinement, dahl_friction_substeps
from hydro_envs.plants.force_actuator.model import force_actuator_guard as guard
from hydro_envs.plants.force_actuator.model import force_actuator_rhs as rhs
from hydro_envs.sim.binding import bind_rk4

__all__ = ["KERNELS", "step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard"]

#: the compiled kernels (hydro_envs.contract.KernelSet), made by the one factory
KERNELS = bind_rk4("force_actuator", rhs, guard, lookahead=(dahl_friction_substeps, dahl_friction_refinement))
step_serial, step_parallel = KERNELS.step_serial, KERNELS.step_parallel
trajectories, derivatives = KERNELS.trajectories, KERNELS.derivatives
