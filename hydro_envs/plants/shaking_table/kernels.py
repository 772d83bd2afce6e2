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

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.plants.shaking_table.model import local_mode_refinement, local_mode_substeps
from hydro_envs.plants.shaking_table.model import shaking_table_guard as guard
from hydro_envs.plants.shaking_table.model import shaking_table_rhs as rhs
from hydro_envs.sim.rk4 import in_blocks, rhs_along, rk4_advance_lookahead, rk4_trajectory_lookahead

__all__ = ["step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard"]


@njit_noalloc
def step_serial(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        h = dt / NSUB[i]
        clamps[i] += rk4_advance_lookahead(rhs, guard, local_mode_substeps, Y[i], U[i], P[i], h, NSUB[i],
                                           local_mode_refinement(P[i], h), W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def step_parallel(Y, U, P, dt, NSUB, W, clamps):
    """``step_serial`` over blocks of copies on threads (bit-identical to it)."""
    in_blocks(step_serial, Y, U, P, dt, NSUB, W, clamps)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def trajectories(Y0, U, P, dt, NSUB, W, OUT, clamps):
    """Whole trajectories ``OUT[i] (T + 1, n_states)`` under inputs ``U[i] (T, n_in)``."""
    for i in nb.prange(Y0.shape[0]):
        m = local_mode_refinement(P[i], dt / NSUB[i])
        clamps[i] += rk4_trajectory_lookahead(rhs, guard, local_mode_substeps, Y0[i], U[i], P[i], dt, NSUB[i], m,
                                              W[i], OUT[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def derivatives(X, U, P, OUT):
    """``OUT[i, k]`` = the right-hand side at state ``X[i, k]`` under ``U[i, min(k, T - 1)]``."""
    for i in nb.prange(X.shape[0]):
        rhs_along(rhs, X[i], U[i], P[i], OUT[i])
