"""Compiled kernels of the rodless cylinder (seed 004): its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step (the single env uses the
serial one: a parallel region costs more to enter than a whole step); ``trajectories`` runs
whole input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the
right-hand side along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`. All of them
step with :func:`~hydro_envs.sim.rk4.rk4_advance_lookahead`: sub-steps sized by the modes that
are stiff everywhere (:func:`~.model.stiffness_modes`), each taken as finer ones where a
locally stiff mode (the flow law's laminar tail, the friction at speed or near v = 0, a bumper
in contact) would make it unstable at its start or at the Euler prediction of its end, as many
as :func:`~.model.local_mode_substeps` gives.

:func:`for_params` gives an env the step kernels it needs, each bit-identical to the general
ones on the rows it is chosen for: without supply droop in any copy (``supply_line_resistance =
0``, the seed's stiff supply and every default set) bound to
:func:`~.model.rodless_cylinder_rhs_stiff_supply`, whose compilation skips the droop solve (a
cold first step 0.8 s shorter); with a bristle state in every copy (the default) with
:func:`~.model.lugre_local_substeps`, compiled without the static curve.
"""

from __future__ import annotations

import numpy as np

from hydro_envs.contract import KernelSet
from hydro_envs.plants.rodless_cylinder.model import I_RSUP, I_SIG0
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs as rhs
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs_stiff_supply as rhs_stiff
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_guard as guard
from hydro_envs.plants.rodless_cylinder.model import local_mode_refinement, local_mode_substeps, lugre_local_substeps
from hydro_envs.sim.binding import bind_rk4

__all__ = ["KERNELS", "step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard", "for_params",
           "step_serial_stiff_supply_lugre", "STIFF_SUPPLY_LUGRE"]


def for_params(P: np.ndarray) -> KernelSet:
    """Step kernels (``step_serial``, ``step_parallel``) for the parameter rows ``P``: without
    the droop solve when no row has supply droop, without the static curve's branch when every
    row has a bristle state; :func:`step_serial` / :func:`step_parallel` serve every row."""
    return _KERNELS[bool(np.any(P[:, I_RSUP] > 0.0)), bool(np.any(P[:, I_SIG0] <= 0.0))]


#: the compiled kernels (hydro_envs.contract.KernelSet) serving every row, made by the one factory
KERNELS = bind_rk4("rodless_cylinder", rhs, guard, lookahead=(local_mode_substeps, local_mode_refinement),
                   for_params=for_params)
step_serial, step_parallel = KERNELS.step_serial, KERNELS.step_parallel
trajectories, derivatives = KERNELS.trajectories, KERNELS.derivatives

# (supply droop in some row, static curve in some row) -> step kernels
_KERNELS = {
    (True, True): KERNELS,
    (True, False): bind_rk4("rodless_cylinder.lugre", rhs, guard, lookahead=(lugre_local_substeps, local_mode_refinement)),
    (False, True): bind_rk4("rodless_cylinder.stiff_supply", rhs_stiff, guard,
                            lookahead=(local_mode_substeps, local_mode_refinement)),
    (False, False): bind_rk4("rodless_cylinder.stiff_supply_lugre", rhs_stiff, guard,
                             lookahead=(lugre_local_substeps, local_mode_refinement)),
}
#: the kernels for rows without supply droop that all have a bristle state (every default set)
STIFF_SUPPLY_LUGRE = _KERNELS[False, False]
step_serial_stiff_supply_lugre = STIFF_SUPPLY_LUGRE.step_serial
