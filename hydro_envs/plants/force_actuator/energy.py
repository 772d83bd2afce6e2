"""Energy balance and guard checks of the force actuator (seed 001), for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.seal_friction import bristle_dissipation
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.force_actuator.model import force_actuator_guard as guard
from hydro_envs.plants.force_actuator.model import force_actuator_rhs as rhs
from hydro_envs.sim.balance import replay_step_lookahead, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 1


@njit_noalloc
def mech_terms(y, p):
    """Sensor mass on its spring (and, free, the piston with its load on the load spring):
    kinetic and spring energy, stop spring and the energy ``sigma0 z^2 / 2`` of the seals'
    bristles. Port: the valve-driven fluid force minus the hydraulic damping (a filtered, not
    pointwise passive, force). Dissipative: the sensor damper, the seal friction (001 eq (1) as
    the family's Dahl case: its power less the bristles' stored-energy rate,
    :func:`~hydro_envs.laws.seal_friction.bristle_dissipation`; the static curve, when selected,
    memoryless) and stop damping."""
    _, xv = fa.valve_position(y, p)
    xi = xv + p[fa.I_XOFF]
    f_damp = p[fa.I_DG] * fa.hydraulic_damping(xi, y[fa.VF], p[fa.I_DA], p[fa.I_DV], p[fa.I_DK], p[fa.I_DLIN])
    vs = y[fa.VS]
    xs = y[fa.XS]
    z = y[fa.Z]
    s0 = p[fa.I_SIG]
    vrel = y[fa.VP] + vs
    q = y[fa.XP] + xs
    u_st, d_st = stop_split(q, vrel, 0.0, p[fa.I_L], p[fa.I_KSTOP], p[fa.I_ASTOP])
    e = 0.5 * p[fa.I_M] * vs * vs + 0.5 * p[fa.I_KS] * xs * xs + u_st + 0.5 * s0 * z * z
    if p[fa.I_LOCK] <= 0.5:
        dxp = y[fa.XP] - 0.5 * p[fa.I_L]
        e += 0.5 * (p[fa.I_MP] + p[fa.I_ML]) * y[fa.VP] ** 2 + 0.5 * p[fa.I_KL] * dxp * dxp - p[fa.I_FLOAD] * y[fa.XP]
    d_sensor = p[fa.I_BS] * vs * vs
    ff, dz = fa.friction_force(vrel, z, p)
    d_f = bristle_dissipation(vrel, z, ff, dz, s0)
    p_in = (y[fa.R0 + 4] - f_damp) * vrel
    return e, p_in, d_sensor + d_f + d_st, d_sensor + abs(ff * vrel) + abs(s0 * z * dz) + abs(d_st), u_st


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (0: no pressure states, the blocked force is a transfer function;
    extension ``x_p + x_s`` past the stroke beyond the penetration bound); updates ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        _, xv = fa.valve_position(y, p)
        xi = xv + p[fa.I_XOFF]
        f_damp = p[fa.I_DG] * fa.hydraulic_damping(xi, y[fa.VF], p[fa.I_DA], p[fa.I_DV], p[fa.I_DK],
                                                   p[fa.I_DLIN])
        f = abs(y[fa.R0 + 4]) + abs(f_damp) + p[fa.I_SIG] * abs(y[fa.Z]) + p[fa.I_KS] * abs(y[fa.XS])
        mass = p[fa.I_M]
        if p[fa.I_LOCK] <= 0.5:
            f += p[fa.I_KL] * abs(y[fa.XP] - 0.5 * p[fa.I_L]) + abs(p[fa.I_FLOAD])
            mass += p[fa.I_MP] + p[fa.I_ML]
        fs, _, _ = stroke_check(y[fa.XP] + y[fa.XS], 0.0, p[fa.I_L], abs(y[fa.VP] + y[fa.VS]), f, mass,
                                p[fa.I_KSTOP], RUN[i], 0)
        flags[i, 0] = 0
        flags[i, 1] = 1 if fs else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step_lookahead` of every copy with the kernels' bristle
    refinement (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        m = fa.dahl_friction_refinement(P[i], dt / NSUB[i])
        replay_step_lookahead(rhs, guard, fa.dahl_friction_substeps, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], m,
                              W[i], Yend[i], out[i])
