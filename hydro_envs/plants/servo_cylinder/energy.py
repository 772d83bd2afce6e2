"""Energy balance and guard checks of the servo cylinder (seed 002), for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.friction import stribeck_exponential, tanh_sign
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.servo_cylinder.model import servo_cylinder_guard as guard
from hydro_envs.plants.servo_cylinder.model import servo_cylinder_rhs as rhs
from hydro_envs.sim.balance import replay_step, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 1


@njit_noalloc
def mech_terms(y, p):
    """Piston: kinetic energy, load potential and stop spring; port A (p1 - p2) v; friction
    (002 eq (1), memoryless: passive) and stop damping dissipate."""
    x = y[sc.X]
    v = y[sc.V]
    dp = y[sc.P1] - y[sc.P2]
    level = 1.0 + p[sc.I_FASYM] * tanh_sign(v, p[sc.I_VEPS])
    f_add = p[sc.I_FPC] * abs(dp)
    ff = stribeck_exponential(
        v, level * (p[sc.I_FC] + f_add), level * (p[sc.I_FS] + f_add), p[sc.I_VS], p[sc.I_D], p[sc.I_VEPS]
    )
    u_st, d_st = stop_split(x, v, 0.0, p[sc.I_L], p[sc.I_KSTOP], p[sc.I_ASTOP])
    e = 0.5 * p[sc.I_M] * v * v + p[sc.I_FL] * x + u_st
    return e, p[sc.I_A] * dp * v, ff * v + d_st, abs(ff * v) + abs(d_st), u_st


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (chamber pressures below the cavitation floor, piston past its stops
    beyond the penetration bound); updates the running maxima ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        fl = p[sc.I_PFLOOR]
        fp = int(not (y[sc.P1] >= fl)) + int(not (y[sc.P2] >= fl))
        f = p[sc.I_A] * abs(y[sc.P1] - y[sc.P2]) + abs(p[sc.I_FL])
        fs, _, _ = stroke_check(y[sc.X], 0.0, p[sc.I_L], abs(y[sc.V]), f, p[sc.I_M], p[sc.I_KSTOP], RUN[i], 0)
        flags[i, 0] = fp
        flags[i, 1] = 1 if fs else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step` of every copy (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        replay_step(rhs, guard, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], W[i], Yend[i], out[i])
