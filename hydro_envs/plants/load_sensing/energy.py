"""Energy balance and guard checks of the load-sensing circuit, for the soak test (:mod:`hydro_envs.soak`).

``mech_terms(y, p)`` returns ``(E, P_in, D, D_scale, U_stop)`` (:mod:`hydro_envs.sim.balance`);
``state_breaches`` flags guard breaches of a batch at an env-step boundary; ``energy_replay``
re-integrates a batch step with the energy terms.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.seal_friction import bristle_dissipation, seal_friction
from hydro_envs.plants.load_sensing import model as ls
from hydro_envs.plants.load_sensing.model import load_sensing_guard as guard
from hydro_envs.plants.load_sensing.model import load_sensing_rhs as rhs
from hydro_envs.sim.balance import replay_step_lookahead, stop_split, stroke_check

__all__ = ["mech_terms", "state_breaches", "energy_replay", "N_BODIES"]

#: bodies whose running (speed, force) maxima the stroke check keeps
N_BODIES = 3


@njit_noalloc
def mech_terms(y, p):
    """Three bodies: the flow-compensator spool (000 eq (4)) on its spring and preload, the
    swash-plate control pistons on the bias spring, and the actuator with its load. Ports:
    pressure, solenoid and flow forces; dissipative: the spool's viscous friction, the control
    pistons' damping, the actuator's seal friction (LuGre; its bristles store energy) and stop
    damping."""
    # flow-compensator spool, 000 eq (4)
    x = y[ls.X]
    v = y[ls.V]
    o_px = min(max(x - p[ls.I_XLAP], 0.0), p[ls.I_LPORT])
    o_xt = min(max(p[ls.I_XLAP] - x, 0.0), p[ls.I_LPORT])
    f_flow = p[ls.D_KFF] * (-o_px * (y[ls.PS] - y[ls.PX]) + o_xt * (y[ls.PX] - p[ls.I_PT]))
    u_s, d_s = stop_split(x, v, 0.0, p[ls.I_XMAX], p[ls.I_KSS], p[ls.I_ASS])
    e = 0.5 * p[ls.I_MS] * v * v + 0.5 * p[ls.I_K] * x * x + p[ls.I_F0] * x + u_s
    p_in = (p[ls.D_A] * (y[ls.PS] - y[ls.PLS]) - y[ls.FSOL] + f_flow) * v
    d_spool = p[ls.D_C] * v * v
    # control pistons (swash plate)
    yc = y[ls.Y]
    vy = y[ls.VY]
    u_y, d_y = stop_split(yc, vy, 0.0, p[ls.I_YMAX], p[ls.I_KYS], 0.0)
    e += 0.5 * p[ls.I_MY] * vy * vy + 0.5 * p[ls.I_KB] * yc * yc + p[ls.I_FB0] * yc + u_y
    p_in += (p[ls.I_A1] * y[ls.PX] - p[ls.I_A2] * y[ls.PS]) * vy
    d_piston = p[ls.I_BY] * vy * vy
    # actuator and load
    xa = y[ls.XA]
    va = y[ls.VA]
    u_a, d_a = stop_split(xa, va, 0.0, p[ls.I_STROKE], p[ls.I_KAS], 0.0)
    z = y[ls.Z]
    s0 = p[ls.I_SIG0]
    e += 0.5 * p[ls.I_M] * va * va + p[ls.I_FL] * xa + u_a + 0.5 * s0 * z * z
    p_in += p[ls.I_AC] * (y[ls.PL] - p[ls.I_PT]) * va
    ff, dz = seal_friction(va, z, p[ls.I_FCA], s0, p[ls.I_SIG1], p[ls.D_FADE], p[ls.I_BA], 1, p[ls.I_ZCAP])
    d_act = bristle_dissipation(va, z, ff, dz, s0)  # the seals' power less their bristles' stored-energy rate
    d = d_spool + d_s + d_piston + d_y + d_act + d_a
    scale = abs(d_spool) + abs(d_s) + abs(d_piston) + abs(d_y) + abs(ff * va) + abs(s0 * z * dz) + abs(d_a)
    return e, p_in, d, scale, u_s + u_y + u_a


@njit_noalloc
def state_breaches(Y, P, RUN, flags):
    """``flags[i]`` = (delivery, control, load or LS pressure below the cavitation floor; the
    actuator, the spool or the control pistons past their stops beyond the penetration
    bound); updates the running maxima ``RUN`` (three bodies)."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        run = RUN[i]
        fp = 0
        fl = p[ls.I_PFLOOR]
        for j in (ls.PS, ls.PX, ls.PL, ls.PLS):
            fp += int(not (y[j] >= fl))
        pt = p[ls.I_PT]
        # actuator
        f = p[ls.I_AC] * abs(y[ls.PL] - pt) + abs(p[ls.I_FL])
        b1, _, _ = stroke_check(y[ls.XA], 0.0, p[ls.I_STROKE], abs(y[ls.VA]), f, p[ls.I_M], p[ls.I_KAS], run, 0)
        # flow-compensator spool: pressure, spring + preload, solenoid and flow forces
        o_px = min(max(y[ls.X] - p[ls.I_XLAP], 0.0), p[ls.I_LPORT])
        o_xt = min(max(p[ls.I_XLAP] - y[ls.X], 0.0), p[ls.I_LPORT])
        f_flow = p[ls.D_KFF] * (-o_px * (y[ls.PS] - y[ls.PX]) + o_xt * (y[ls.PX] - pt))
        f = (p[ls.D_A] * abs(y[ls.PS] - y[ls.PLS]) + abs(p[ls.I_F0]) + p[ls.I_K] * abs(y[ls.X])
             + abs(y[ls.FSOL]) + abs(f_flow))
        b2, _, _ = stroke_check(y[ls.X], 0.0, p[ls.I_XMAX], abs(y[ls.V]), f, p[ls.I_MS], p[ls.I_KSS], run, 2)
        # control pistons
        f = (p[ls.I_A1] * abs(y[ls.PX]) + p[ls.I_A2] * abs(y[ls.PS]) + abs(p[ls.I_FB0])
             + p[ls.I_KB] * abs(y[ls.Y]))
        b3, _, _ = stroke_check(y[ls.Y], 0.0, p[ls.I_YMAX], abs(y[ls.VY]), f, p[ls.I_MY], p[ls.I_KYS], run, 4)
        flags[i, 0] = fp
        flags[i, 1] = 1 if (b1 or b2 or b3) else 0


@nb.njit(cache=True, error_model="numpy", parallel=True)
def energy_replay(Y0, U, P, dt, NSUB, W, Yend, out):
    """:func:`hydro_envs.sim.balance.replay_step_lookahead` of every copy with the kernels' local
    refinement (see there for ``out``)."""
    for i in nb.prange(Y0.shape[0]):
        m = ls.local_mode_refinement(P[i], dt / NSUB[i])
        replay_step_lookahead(rhs, guard, ls.local_mode_substeps, mech_terms, Y0[i], U[i], P[i], dt, NSUB[i], m,
                              W[i], Yend[i], out[i])
