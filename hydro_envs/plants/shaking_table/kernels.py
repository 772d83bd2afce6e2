"""Compiled kernels of the shaking table (seed 003): its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step (the single env uses the
serial one: a parallel region costs more to enter than a whole step); ``trajectories`` runs
whole input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the
right-hand side along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`. All of them
step with :func:`~hydro_envs.sim.rk4.rk4_advance_lookahead`: sub-steps sized by the modes that
are stiff everywhere (:func:`~.model.stiffness_modes`), each taken as finer ones where an
orifice's laminar core, a kink of the metering openings, a notch edge of the modified IFAS law
or the air-release band lies at its start, at the Euler prediction of its end or between them,
as many as :func:`~.model.local_mode_substeps` gives.
"""

from __future__ import annotations

from hydro_envs.plants.shaking_table.model import local_mode_refinement, local_mode_substeps
from hydro_envs.plants.shaking_table.model import shaking_table_guard as guard
from hydro_envs.plants.shaking_table.model import shaking_table_rhs as rhs
from hydro_envs.sim.binding import bind_rk4

__all__ = ["KERNELS", "step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard"]

#: the compiled kernels (hydro_envs.contract.KernelSet), made by the one factory
KERNELS = bind_rk4("shaking_table", rhs, guard, lookahead=(local_mode_substeps, local_mode_refinement))
step_serial, step_parallel = KERNELS.step_serial, KERNELS.step_parallel
trajectories, derivatives = KERNELS.trajectories, KERNELS.derivatives
