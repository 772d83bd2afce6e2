"""Energy balance and guard checks of the shaking table (seed 003), for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.seal_friction import bristle_dissipation
from hydro_envs.plants.shaking_table import model as st
from hydro_envs.plants.shaking_table.model import shaking_table_guard as guard
from hydro_envs.plants.shaking_table.model import shaking_table_rhs as rhs
from hydro_envs.sim.balance import replay_step_lookahead, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 1


@njit_noalloc
def mech_terms(y, p):
    """Table and specimen: kinetic energy, stop spring and the energy ``sigma0 z^2 / 2`` of the
    seals' bristles; port A (p_a - p_b) v; the seal friction (LuGre with 003 eq (11) as its
    steady state: its power less the bristles' stored-energy rate,
    :func:`~hydro_envs.laws.seal_friction.bristle_dissipation`) and stop damping dissipate."""
    x = y[st.X]
    v = y[st.V]
    z = y[st.Z]
    half = 0.5 * p[st.I_L]
    s0 = p[st.I_SIG0]
    ff, dz = st.seal_force(v, z, p)
    d_f = bristle_dissipation(v, z, ff, dz, s0)
    u_st, d_st = stop_split(x, v, -half, half, p[st.I_KSTOP], p[st.I_ASTOP])
    e = 0.5 * (p[st.I_MB] + p[st.I_MS]) * v * v + u_st + 0.5 * s0 * z * z
    return e, p[st.I_A] * (y[st.PA] - y[st.PB]) * v, d_f + d_st, abs(ff * v) + abs(s0 * z * dz) + abs(d_st), u_st


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (chamber pressures below the cavitation floor, table past its end-strokes
    beyond the penetration bound); updates the running maxima ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        fl = p[st.I_PFLOOR]
        fp = int(not (y[st.PA] >= fl)) + int(not (y[st.PB] >= fl))
        half = 0.5 * p[st.I_L]
        f = p[st.I_A] * abs(y[st.PA] - y[st.PB])
        fs, _, _ = stroke_check(y[st.X], -half, half, abs(y[st.V]), f, p[st.I_MB] + p[st.I_MS],
                                p[st.I_KSTOP], RUN[i], 0)
        flags[i, 0] = fp
        flags[i, 1] = 1 if fs else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step_lookahead` of every copy with the kernels' local
    refinement (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        m = st.local_mode_refinement(P[i], dt / NSUB[i])
        replay_step_lookahead(rhs, guard, st.local_mode_substeps, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], m,
                              W[i], Yend[i], out[i])
