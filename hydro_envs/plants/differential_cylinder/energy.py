"""Energy balance and guard checks of the differential cylinder, for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.seal_friction import bristle_dissipation, seal_friction
from hydro_envs.plants.differential_cylinder import model as dc
from hydro_envs.plants.differential_cylinder.model import differential_cylinder_guard as guard
from hydro_envs.plants.differential_cylinder.model import differential_cylinder_rhs as rhs
from hydro_envs.sim.balance import replay_step, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 1


@njit_noalloc
def mech_terms(y, p):
    """Piston: kinetic energy, load potential, stop spring and the bristles' ``sigma0 z^2 / 2``;
    port power ``(A1 p1 - A2 p2 - (A1 - A2) p_amb) v``; the seal friction (less the bristles' stored-energy rate)
    and the stop damping dissipate."""
    x = y[dc.X]
    v = y[dc.V]
    z = y[dc.Z]
    s0 = p[dc.I_SIG0]
    ff, dz = seal_friction(v, z, dc.friction_level(v, p), s0, p[dc.I_SIG1], p[dc.I_DFADE], p[dc.I_D], 1,
                           p[dc.I_ZCAP])
    d_f = bristle_dissipation(v, z, ff, dz, s0)
    u_st, d_st = stop_split(x, v, 0.0, p[dc.I_L], p[dc.I_KSTOP], p[dc.I_ASTOP])
    e = 0.5 * p[dc.I_M] * v * v + p[dc.I_FL] * x + u_st + 0.5 * s0 * z * z
    f_fluid = p[dc.I_A1] * y[dc.P1] - p[dc.I_A2] * y[dc.P2] - p[dc.I_FAMB]
    return e, f_fluid * v, d_f + d_st, abs(ff * v) + abs(s0 * z * dz) + abs(d_st), u_st


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (chamber pressures below the cavitation floor, piston past its stops
    beyond the penetration bound); updates the running maxima ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        fl = p[dc.I_PFLOOR]
        fp = int(not (y[dc.P1] >= fl)) + int(not (y[dc.P2] >= fl))
        f = abs(p[dc.I_A1] * y[dc.P1] - p[dc.I_A2] * y[dc.P2] - p[dc.I_FAMB]) + abs(p[dc.I_FL])
        fs, _, _ = stroke_check(y[dc.X], 0.0, p[dc.I_L], abs(y[dc.V]), f, p[dc.I_M], p[dc.I_KSTOP], RUN[i], 0)
        flags[i, 0] = fp
        flags[i, 1] = 1 if fs else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step` of every copy (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        replay_step(rhs, guard, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], W[i], Yend[i], out[i])
