"""Compiled kernels of the rodless cylinder (seed 004): its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step (the single env uses the
serial one: a parallel region costs more to enter than a whole step); ``trajectories`` runs
whole input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the
right-hand side along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`.

:func:`for_params` gives an env the step kernels it needs: without supply droop in any copy
(``supply_line_resistance = 0``, the seed's stiff supply and every default set) the same steps
bound to :func:`~.model.rodless_cylinder_rhs_stiff_supply`, whose compilation skips the droop
solve (a cold first step 0.8 s shorter); bit-identical results.
"""

from __future__ import annotations

import types

import numba as nb
import numpy as np

from hydro_envs.plants.rodless_cylinder.model import I_RSUP
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs as rhs
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs_stiff_supply as rhs_stiff
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_guard as guard
from hydro_envs.sim.rk4 import rhs_along, rk4_advance, rk4_trajectory

__all__ = ["step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard", "for_params"]


@nb.njit(cache=True, error_model="numpy")
def step_serial(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def step_parallel(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (threads)."""
    for i in nb.prange(Y.shape[0]):
        clamps[i] += rk4_advance(rhs, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


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


@nb.njit(cache=True, error_model="numpy")
def _step_serial_stiff(Y, U, P, dt, NSUB, W, clamps):
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs_stiff, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_stiff(Y, U, P, dt, NSUB, W, clamps):
    for i in nb.prange(Y.shape[0]):
        clamps[i] += rk4_advance(rhs_stiff, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


_STIFF = types.SimpleNamespace(step_serial=_step_serial_stiff, step_parallel=_step_parallel_stiff)
_DROOP = types.SimpleNamespace(step_serial=step_serial, step_parallel=step_parallel)


def for_params(P: np.ndarray) -> types.SimpleNamespace:
    """Step kernels (``step_serial``, ``step_parallel``) for the parameter rows ``P``: the
    stiff-supply ones when no row has supply droop, else :func:`step_serial` / :func:`step_parallel`."""
    return _DROOP if np.any(P[:, I_RSUP] > 0.0) else _STIFF
