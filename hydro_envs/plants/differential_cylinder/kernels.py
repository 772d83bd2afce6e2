"""Compiled kernels of the differential cylinder: its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step; ``trajectories`` runs whole
input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the right-hand side
along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.plants.differential_cylinder.model import differential_cylinder_guard as guard
from hydro_envs.plants.differential_cylinder.model import differential_cylinder_rhs as rhs
from hydro_envs.sim.rk4 import in_blocks, rhs_along, rk4_advance, rk4_trajectory

__all__ = ["step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard"]


@njit_noalloc
def step_serial(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def step_parallel(Y, U, P, dt, NSUB, W, clamps):
    """``step_serial`` over blocks of copies on threads (bit-identical to it)."""
    in_blocks(step_serial, Y, U, P, dt, NSUB, W, clamps)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def trajectories(Y0, U, P, dt, NSUB, W, OUT, clamps):
    """Whole trajectories ``OUT[i] (T + 1, n_states)`` under inputs ``U[i] (T, n_in)``."""
    for i in nb.prange(Y0.shape[0]):
        clamps[i] += rk4_trajectory(rhs, guard, Y0[i], U[i], P[i], dt, NSUB[i], W[i], OUT[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def derivatives(X, U, P, OUT):
    """``OUT[i, k]`` = the right-hand side at state ``X[i, k]`` under ``U[i, min(k, T - 1)]``."""
    for i in nb.prange(X.shape[0]):
        rhs_along(rhs, X[i], U[i], P[i], OUT[i])
