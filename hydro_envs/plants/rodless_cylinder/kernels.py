"""Compiled kernels of the rodless cylinder (seed 004): its right-hand side bound to the shared RK4 loops.

``step_serial`` / ``step_parallel`` advance a batch by one env step (the single env uses the
serial one: a parallel region costs more to enter than a whole step); ``trajectories`` runs
whole input sequences (:func:`hydro_envs.sim.simulate`); ``derivatives`` evaluates the
right-hand side along recorded trajectories. Layouts: :mod:`hydro_envs.sim.rk4`. All of them
step with :func:`~hydro_envs.sim.rk4.rk4_advance_refined`: with a bristle state (LuGre, the
default) that is ``rk4_advance``; with the static friction curve a sub-step is redone in finer
ones where the curve is steep along it (near zero velocity).

:func:`for_params` gives an env the step kernels it needs, each bit-identical to the general
ones on the rows it is chosen for: without supply droop in any copy (``supply_line_resistance =
0``, the seed's stiff supply and every default set) bound to
:func:`~.model.rodless_cylinder_rhs_stiff_supply`, whose compilation skips the droop solve (a
cold first step 0.8 s shorter); with a bristle state in every copy (the default) plain
``rk4_advance`` (the refinement's code adds about 1 s to a cold first step).
"""

from __future__ import annotations

import types

import numba as nb
import numpy as np

from hydro_envs.plants.rodless_cylinder.model import I_RSUP, I_SIG0
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs as rhs
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs_stiff_supply as rhs_stiff
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_guard as guard
from hydro_envs.plants.rodless_cylinder.model import static_friction_refinement, static_friction_shallow
from hydro_envs.sim.rk4 import in_blocks, rhs_along, rk4_advance, rk4_advance_refined, rk4_trajectory_refined

__all__ = ["step_serial", "step_parallel", "trajectories", "derivatives", "rhs", "guard", "for_params"]


@nb.njit(cache=True, error_model="numpy", inline="always")
def _advance(f, y, u, p, h, n_sub, work, back):
    """``n_sub`` RK4 sub-steps of ``h`` with right-hand side ``f``; with the static friction
    curve a sub-step is redone finer where the curve is steep along it (the sub-step count
    of ``stiffness_modes`` leaves that region out)."""
    return rk4_advance_refined(f, guard, static_friction_shallow, y, u, p, h, n_sub,
                               static_friction_refinement(p, h), work, back)


@nb.njit(cache=True, error_model="numpy")
def step_serial(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    back = np.empty(Y.shape[1])
    for i in range(Y.shape[0]):
        clamps[i] += _advance(rhs, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i], back)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def step_parallel(Y, U, P, dt, NSUB, W, clamps):
    """``step_serial`` over blocks of copies on threads (bit-identical to it)."""
    in_blocks(step_serial, Y, U, P, dt, NSUB, W, clamps)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def trajectories(Y0, U, P, dt, NSUB, W, OUT, clamps):
    """Whole trajectories ``OUT[i] (T + 1, n_states)`` under inputs ``U[i] (T, n_in)``."""
    for i in nb.prange(Y0.shape[0]):
        m = static_friction_refinement(P[i], dt / NSUB[i])
        clamps[i] += rk4_trajectory_refined(rhs, guard, static_friction_shallow, Y0[i], U[i], P[i], dt, NSUB[i], m,
                                            W[i], np.empty(Y0.shape[1]), OUT[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def derivatives(X, U, P, OUT):
    """``OUT[i, k]`` = the right-hand side at state ``X[i, k]`` under ``U[i, min(k, T - 1)]``."""
    for i in nb.prange(X.shape[0]):
        rhs_along(rhs, X[i], U[i], P[i], OUT[i])


@nb.njit(cache=True, error_model="numpy")
def _step_serial_stiff(Y, U, P, dt, NSUB, W, clamps):
    back = np.empty(Y.shape[1])
    for i in range(Y.shape[0]):
        clamps[i] += _advance(rhs_stiff, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i], back)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_stiff(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(_step_serial_stiff, Y, U, P, dt, NSUB, W, clamps)


# bristle state (LuGre) in every row: plain RK4 sub-steps, which the refinement reduces to
@nb.njit(cache=True, error_model="numpy")
def _step_serial_lugre(Y, U, P, dt, NSUB, W, clamps):
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_lugre(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(_step_serial_lugre, Y, U, P, dt, NSUB, W, clamps)


@nb.njit(cache=True, error_model="numpy")
def _step_serial_stiff_lugre(Y, U, P, dt, NSUB, W, clamps):
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs_stiff, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_parallel_stiff_lugre(Y, U, P, dt, NSUB, W, clamps):
    in_blocks(_step_serial_stiff_lugre, Y, U, P, dt, NSUB, W, clamps)


# (supply droop in some row, static curve in some row) -> step kernels
_KERNELS = {
    (True, True): types.SimpleNamespace(step_serial=step_serial, step_parallel=step_parallel),
    (True, False): types.SimpleNamespace(step_serial=_step_serial_lugre, step_parallel=_step_parallel_lugre),
    (False, True): types.SimpleNamespace(step_serial=_step_serial_stiff, step_parallel=_step_parallel_stiff),
    (False, False): types.SimpleNamespace(step_serial=_step_serial_stiff_lugre,
                                          step_parallel=_step_parallel_stiff_lugre),
}


def for_params(P: np.ndarray) -> types.SimpleNamespace:
    """Step kernels (``step_serial``, ``step_parallel``) for the parameter rows ``P``: without
    the droop solve when no row has supply droop, without the refinement when every row has a
    bristle state; :func:`step_serial` / :func:`step_parallel` need neither condition."""
    return _KERNELS[bool(np.any(P[:, I_RSUP] > 0.0)), bool(np.any(P[:, I_SIG0] <= 0.0))]
