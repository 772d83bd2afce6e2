"""Energy balance and guard checks of the rodless cylinder (seed 004), for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import math

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.friction import stribeck_exponential
from hydro_envs.laws.seal_friction import bristle_dissipation, seal_friction, stribeck_curve_exponential
from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_guard as guard
from hydro_envs.plants.rodless_cylinder.model import rodless_cylinder_rhs as rhs
from hydro_envs.sim.balance import replay_step_lookahead, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 1


@njit_noalloc
def mech_terms(y, p):
    """Carriage: kinetic energy, load potential, stop spring and the energy ``sigma0 z^2 / 2`` of
    the seals' bristles; port A (p_a - p_b) v; the seal friction (LuGre: its power less the
    bristles' stored-energy rate, :func:`~hydro_envs.laws.seal_friction.bristle_dissipation`; or
    the memoryless static curve of 004 Table 2) and stop damping dissipate."""
    pos = y[rc.Y]
    v = y[rc.V]
    u_st, d_st = stop_split(pos, v, 0.0, p[rc.I_L], p[rc.I_KSTOP], p[rc.I_ASTOP])
    e = 0.5 * p[rc.I_M] * v * v + p[rc.I_FL] * pos + u_st
    p_in = p[rc.D_AREA] * (y[rc.PA] - y[rc.PB]) * v
    sigma0 = p[rc.I_SIG0]
    if sigma0 > 0.0:
        z = y[rc.Z]
        g = stribeck_curve_exponential(v, p[rc.I_FC], p[rc.I_FS], p[rc.I_VS]) if p[rc.I_FS] > 0.0 else 0.0
        ff, dz = seal_friction(v, z, g, sigma0, p[rc.I_SIG1], p[rc.D_FADE], p[rc.I_SIG2], 1, 0.0)
        e += 0.5 * sigma0 * z * z
        d_f = bristle_dissipation(v, z, ff, dz, sigma0)
        scale = abs(ff * v) + abs(sigma0 * z * dz)
    else:
        d_f = stribeck_exponential(v, p[rc.I_FC], p[rc.I_FS], p[rc.I_VS], p[rc.I_SIG2], p[rc.I_VEPS]) * v
        scale = abs(d_f)
    return e, p_in, d_f + d_st, scale + abs(d_st), u_st


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (chamber pressure, air mass or temperature not positive or below its
    floor, carriage past its stops beyond the penetration bound); updates ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        fp = 0
        fl = p[rc.I_PFLOOR]
        mf = p[rc.I_MFLOOR]
        pa = y[rc.PA]
        pb = y[rc.PB]
        area = p[rc.D_AREA]
        vol_a = max(area * y[rc.Y] + p[rc.I_VDA], p[rc.I_VMIN])
        vol_b = max(area * (p[rc.I_L] - y[rc.Y]) + p[rc.I_VDB], p[rc.I_VMIN])
        ta = pa * vol_a / (y[rc.MA] * p[rc.I_R])
        tb = pb * vol_b / (y[rc.MB] * p[rc.I_R])
        for val, lim in ((pa, fl), (pb, fl), (y[rc.MA], mf), (y[rc.MB], mf)):
            fp += int(not (val >= lim and val > 0.0))
        fp += int(not (ta > 0.0 and math.isfinite(ta))) + int(not (tb > 0.0 and math.isfinite(tb)))
        f = area * abs(pa - pb) + abs(p[rc.I_FL])
        fs, _, _ = stroke_check(y[rc.Y], 0.0, p[rc.I_L], abs(y[rc.V]), f, p[rc.I_M], p[rc.I_KSTOP], RUN[i], 0)
        flags[i, 0] = fp
        flags[i, 1] = 1 if fs else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step_lookahead` of every copy with the kernels' local
    refinement (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        m = rc.local_mode_refinement(P[i], dt / NSUB[i])
        replay_step_lookahead(rhs, guard, rc.local_mode_substeps, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], m,
                              W[i], Yend[i], out[i])
