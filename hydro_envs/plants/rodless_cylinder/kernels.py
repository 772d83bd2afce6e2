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

import types

import numba as nb
import numpy as np

from hydro_envs.jit import njit_noalloc
from hydro_envs.plants.rodless_cylinder.model import I_RSUP, I_SIG0
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs as rhs
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs_stiff_supply as rhs_stiff
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_guard as guard
from hydro_envs.plants.rodless_cylinder.model import local_mode_refinement, local_mode_substeps, lugre_local_substeps
from hydro_envs.sim.rk4 import in_blocks, rhs_along, rk4_advance_lookahead, rk4_trajectory_lookahead

__all__ = ["step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard", "for_params",
           "step_serial_stiff_supply_lugre"]


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


@njit_noalloc
def _step_serial_stiff(Y, U, P, dt, NSUB, W, clamps):
    for i in range(Y.shape[0]):
        h = dt / NSUB[i]
        clamps[i] += rk4_advance_lookahead(rhs_stiff, guard, local_mode_substeps, Y[i], U[i], P[i], h, NSUB[i],
                                           local_mode_refinement(P[i], h), W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_stiff(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(_step_serial_stiff, Y, U, P, dt, NSUB, W, clamps)


@njit_noalloc
def _step_serial_lugre(Y, U, P, dt, NSUB, W, clamps):
    for i in range(Y.shape[0]):
        h = dt / NSUB[i]
        clamps[i] += rk4_advance_lookahead(rhs, guard, lugre_local_substeps, Y[i], U[i], P[i], h, NSUB[i],
                                           local_mode_refinement(P[i], h), W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_lugre(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(_step_serial_lugre, Y, U, P, dt, NSUB, W, clamps)


@njit_noalloc
def step_serial_stiff_supply_lugre(Y, U, P, dt, NSUB, W, clamps):
    """``step_serial`` for rows without supply droop that all have a bristle state (every default set)."""
    for i in range(Y.shape[0]):
        h = dt / NSUB[i]
        clamps[i] += rk4_advance_lookahead(rhs_stiff, guard, lugre_local_substeps, Y[i], U[i], P[i], h, NSUB[i],
                                           local_mode_refinement(P[i], h), W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_stiff_lugre(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(step_serial_stiff_supply_lugre, Y, U, P, dt, NSUB, W, clamps)


# (supply droop in some row, static curve in some row) -> step kernels
_KERNELS = {
    (True, True): types.SimpleNamespace(step_serial=step_serial, step_parallel=step_parallel),
    (True, False): types.SimpleNamespace(step_serial=_step_serial_lugre, step_parallel=_step_parallel_lugre),
    (False, True): types.SimpleNamespace(step_serial=_step_serial_stiff, step_parallel=_step_parallel_stiff),
    (False, False): types.SimpleNamespace(step_serial=step_serial_stiff_supply_lugre,
                                          step_parallel=_step_parallel_stiff_lugre),
}


def for_params(P: np.ndarray) -> types.SimpleNamespace:
    """Step kernels (``step_serial``, ``step_parallel``) for the parameter rows ``P``: without
    the droop solve when no row has supply droop, without the static curve's branch when every
    row has a bristle state; :func:`step_serial` / :func:`step_parallel` serve every row."""
    return _KERNELS[bool(np.any(P[:, I_RSUP] > 0.0)), bool(np.any(P[:, I_SIG0] <= 0.0))]
