r"""Soak test of the environments: long random rollouts at and beyond the randomisation extremes.

:func:`soak_env` drives one registered env's native vector env (the code path users and the
trainers run) with random actions -- i.i.d. uniform, held uniform levels and bang-bang
switching between -1 and +1 -- on parameter sets drawn at the *corners* of the randomisation
ranges (every randomised parameter at its low or high bound) and *beyond* them (corners of
the ranges widened by ``factor`` about their centre, :meth:`RandomizationSpec.widened`, clipped
into each field's physically allowed interval; a draw that is not a valid parameter set is
replaced by an in-range corner). Draws are passed as the benchmark passes frozen draws:
``reset(options={"reset_mask": copy i, "params": draw})``. It counts, per env:

``nonfinite``
    steps (per copy) with a NaN/inf in the plant state, the observation or the reward.
``pressure``
    steps with a guard breached at an env-step boundary: a hydraulic pressure below the
    cavitation floor ``pressure_floor`` (the guard clamps the state after every RK4 sub-step,
    so any value below the floor is a guard bug); pneumatic chambers: pressure below its
    floor or not > 0, air mass below its floor or not > 0, temperature ``T = p V / (m R)``
    not > 0.
``stroke``
    steps with a position outside its stroke by more than the end-stop tolerance. A body of
    mass ``M`` that reaches the Hunt-Crossley stop (stiffness ``k``) at speed ``v`` while a
    force ``F`` pushes it in penetrates ``delta <= F/k + sqrt((F/k)^2 + M v^2/k) <= 2 F/k +
    v sqrt(M/k)`` (energy: the stop's damping and the friction only remove energy). With
    ``v`` and ``F`` the running maxima (since the episode start) of the body's speed and of the
    force that can push it into the stop, the tolerance is twice that bound (a factor 2 for
    peaks between env-step samples). Bodies: servo piston, table, rodless slider, LS actuator,
    LS flow-compensator spool, LS control piston, force-actuator extension ``x_p + x_s``.
``energy``
    windows of ``ENERGY_WINDOW`` env steps (per copy) in which the bodies gained more
    mechanical energy than the ports delivered (below).
``passivity``
    RK4 sub-steps with a stage at which a dissipative element delivers power (below).
``replay``
    steps at which the instrumented re-integration did not reproduce the env's state bit for
    bit (then the energy check would not be about the env's trajectory).
``guard_clamps``
    how often a guard clamped the state (pressure floor, friction bound): reported, not a
    breach -- clamping at the cavitation floor is the guard doing its job under bang-bang
    valve reversals.

Energy balance (the exact inequality checked)
---------------------------------------------
For every plant the moving bodies have a mechanical energy ``E(y)`` = kinetic energy + spring
and end-stop potentials (``k delta^2/2`` of the stop's elastic part) + potential of constant
loads, and the forces on them split into *ports* whose power ``P_in(y)`` is not sign-definite
(the hydraulic/pneumatic pressure forces, the servo-valve-driven fluid force of the force
actuator, solenoid and flow forces, friction models with internal state: LuGre, Dahl) and
*dissipative elements* whose power ``D(y)`` is >= 0 by construction (memoryless Stribeck
friction with tanh sign, viscous dampers, the damping part of the Hunt-Crossley stops, which
is clipped so the stop never pulls). Along the exact solution ``dE/dt = P_in - D``.

After every env step, :func:`energy_replay` re-integrates each copy from its state before
the step with the same RK4 sub-steps and guards as :func:`hydro_envs.sim.kernels.step_batch_parallel`
(and checks that it lands on the env's state bit for bit), integrating ``W = int P_in dt`` and
``Q = int D dt`` with the RK4 weights on the same stages (RK4 applied to the augmented system).
Two checks:

* **passivity** (exact, pointwise): ``D >= 0`` at every RK4 stage (relative round-off
  ``1e-12``); fails if a friction/damper/stop law pushes the body (e.g. a negative friction
  level or a pulling stop).
* **no energy created**, over windows of ``ENERGY_WINDOW`` = 20 env steps (and the last,
  shorter window of an episode): the mechanical energy gained cannot exceed the work the
  ports delivered, ``E(y_end) - E(y_start) <= sum W + tol`` with
  ``tol = ENERGY_RTOL * sum int(|P_in| + D) dt + ENERGY_ETOL * max |E| + 1e-12 J``,
  ``ENERGY_RTOL = 1e-3``, ``ENERGY_ETOL = 1e-7``. The dissipation is >= 0 by the first check;
  its stage quadrature is reported but not used. Why a window and not every step: near
  v = 0 the friction regularisation (and the stop damping) is integrated at ``h |lambda|``
  up to 2.2 (RK4 stable, not accurate) and the Hunt-Crossley force has a kink at contact
  onset, so a *single* step can show the mass gaining more than the port work (measured at
  the corners and beyond: up to 12 % of that step's turnover at a stop, 5 % in stick-slip);
  these local errors are bounded and are paid back by the friction within a few steps --
  over 20-step windows, in 1e7 steps per env at the corners and beyond (``bench/soak.py``),
  the largest gain was 0.59 of this tolerance (servo cylinder; below 1e-4 for the table,
  force actuator, LS and rodless cylinder), and a piston resting on a stop at full thrust
  gains at most ~5e-9 of the 0.58 J in the stop spring. An instability does not pay
  back: a mode integrated outside RK4's stability region grows by ``|R(h lambda)| > 1`` per
  sub-step (``R(-3) = 1.375``: its energy doubles every sub-step). It also fails on a sign
  error in a force or a port/energy mismatch. It is one-sided because the guards (pressure
  floor, friction bound) only remove energy.

What this check does *not* see: energy created on the fluid side (e.g. an unstable oil-spring
mode) enters the mechanical side as port work ``A (p1 - p2) v`` and balances; such a
blow-up shows up in the ``nonfinite``, ``pressure`` or ``stroke`` counts instead.

Cost: the replay doubles the kernel work; the Python loop around it dominates for small
batches.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, Callable

import gymnasium as gym
import numba as nb
import numpy as np

from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.friction import stribeck_exponential, stribeck_gaussian, tanh_sign
from hydro_envs.laws.stribeck_lugre import lugre_exponential_rate
from hydro_envs.params import ParameterError
from hydro_envs.plants import force_actuator as fa
from hydro_envs.plants import ls_circuit as ls
from hydro_envs.plants import rodless_cylinder as rc
from hydro_envs.plants import servo_cylinder as sc
from hydro_envs.plants import shaking_table as st
from hydro_envs.sim.kernels import (
    FORCE_ACTUATOR,
    LS_CIRCUIT,
    RODLESS_CYLINDER,
    SERVO_CYLINDER,
    SHAKING_TABLE,
    plant_guard,
    plant_rhs,
)

__all__ = [
    "SOAK_ENVS",
    "BREACH_KINDS",
    "ENERGY_RTOL",
    "ENERGY_ETOL",
    "SoakResult",
    "mech_terms",
    "energy_replay",
    "energy_excess",
    "state_breaches",
    "extreme_draw",
    "soak_env",
    "format_table",
]

#: every registered environment (ids of ``hydro_envs._ENVS``)
SOAK_ENVS = (
    "hydro_envs/ServoCylinderPosition-v0",
    "hydro_envs/ShakingTable-v0",
    "hydro_envs/ForceActuator-v0",
    "hydro_envs/LoadSensing-v0",
    "hydro_envs/RodlessCylinder-v0",
)
BREACH_KINDS = ("nonfinite", "pressure", "stroke", "energy", "passivity", "replay")
#: energy tolerance relative to the window's power turnover int(|P_in| + D) dt
ENERGY_RTOL = 1e-3
#: energy tolerance relative to the largest stored mechanical energy in the window
ENERGY_ETOL = 1e-7
#: env steps per energy-balance window
ENERGY_WINDOW = 20
#: draws needing more RK4 sub-steps per env step than this are not used (cost)
MAX_SUBSTEPS = 400
_N_RUN = 6  # running maxima per copy: (speed, force) for up to three bodies


# ============================================================================ energy terms
@nb.njit(cache=True, error_model="numpy", inline="always")
def _stop_split(x, v, lo, hi, k, alpha):
    """End stops at ``lo``/``hi``: (elastic potential k delta^2/2 [J], damping power >= 0 [W])."""
    if x < lo:
        d = lo - x
    elif x > hi:
        d = x - hi
    else:
        return 0.0, 0.0
    f = end_stop_force(x, v, lo, hi, k, alpha)
    f_el = end_stop_force(x, 0.0, lo, hi, k, alpha)  # k delta: the elastic part
    return 0.5 * k * d * d, -(f - f_el) * v


@nb.njit(cache=True, error_model="numpy")
def mech_terms(plant_id, y, p):
    """``(E, P_in, D, D_scale, U_stop)`` of state ``y``: mechanical energy [J], port power
    [W], dissipated power [W] (>= 0 by construction), the magnitude of D's parts (round-off
    scale of the passivity check) and the end stops' elastic energy [J] (> 0: a stop is
    engaged). See the module docstring."""
    if plant_id == SERVO_CYLINDER:
        x = y[sc.X]
        v = y[sc.V]
        dp = y[sc.P1] - y[sc.P2]
        level = 1.0 + p[sc.I_FASYM] * math.tanh(v / p[sc.I_VEPS])
        f_add = p[sc.I_FPC] * abs(dp)
        ff = stribeck_exponential(
            v, level * (p[sc.I_FC] + f_add), level * (p[sc.I_FS] + f_add), p[sc.I_VS], p[sc.I_D], p[sc.I_VEPS]
        )
        u_st, d_st = _stop_split(x, v, 0.0, p[sc.I_L], p[sc.I_KSTOP], p[sc.I_ASTOP])
        e = 0.5 * p[sc.I_M] * v * v + p[sc.I_FL] * x + u_st
        return e, p[sc.I_A] * dp * v, ff * v + d_st, abs(ff * v) + abs(d_st), u_st
    if plant_id == SHAKING_TABLE:
        x = y[st.X]
        v = y[st.V]
        half = 0.5 * p[st.I_L]
        ff = stribeck_gaussian(v, p[st.I_FC], p[st.I_FS], p[st.I_VS], p[st.I_FV], 1.0 / p[st.I_BETA])
        u_st, d_st = _stop_split(x, v, -half, half, p[st.I_KSTOP], p[st.I_ASTOP])
        e = 0.5 * (p[st.I_MB] + p[st.I_MS]) * v * v + u_st
        return e, p[st.I_A] * (y[st.PA] - y[st.PB]) * v, ff * v + d_st, abs(ff * v) + abs(d_st), u_st
    if plant_id == FORCE_ACTUATOR:
        _, xv = fa.valve_position(y, p)
        xi = xv + p[fa.I_XOFF]
        f_damp = p[fa.I_DG] * fa.hydraulic_damping(xi, y[fa.VF], p[fa.I_DA], p[fa.I_DV], p[fa.I_DK], p[fa.I_DLIN])
        vs = y[fa.VS]
        xs = y[fa.XS]
        vrel = y[fa.VP] + vs
        q = y[fa.XP] + xs
        u_st, d_st = _stop_split(q, vrel, 0.0, p[fa.I_L], p[fa.I_KSTOP], p[fa.I_ASTOP])
        e = 0.5 * p[fa.I_M] * vs * vs + 0.5 * p[fa.I_KS] * xs * xs + u_st
        if p[fa.I_LOCK] <= 0.5:
            dxp = y[fa.XP] - 0.5 * p[fa.I_L]
            e += 0.5 * (p[fa.I_MP] + p[fa.I_ML]) * y[fa.VP] ** 2 + 0.5 * p[fa.I_KL] * dxp * dxp
        d_sensor = p[fa.I_BS] * vs * vs
        if p[fa.I_FMOD] > 0.5:  # static friction curve g(v) tanh(v / v_eps): memoryless, passive
            g = fa.stiction_level(vrel, p[fa.I_FC], p[fa.I_FSR], p[fa.I_FSE], p[fa.I_VS])
            d_f = g * math.tanh(vrel / p[fa.I_VEPS]) * vrel
            p_in = (y[fa.R0 + 4] - f_damp) * vrel
        else:  # Dahl friction state (pre-sliding storage): a port
            d_f = 0.0
            p_in = (y[fa.R0 + 4] - f_damp - y[fa.FF]) * vrel
        return e, p_in, d_sensor + d_f + d_st, d_sensor + abs(d_f) + abs(d_st), u_st
    if plant_id == LS_CIRCUIT:
        # flow-compensator spool, 000 eq (4)
        x = y[ls.X]
        v = y[ls.V]
        o_px = min(max(x - p[ls.I_XLAP], 0.0), p[ls.I_LPORT])
        o_xt = min(max(p[ls.I_XLAP] - x, 0.0), p[ls.I_LPORT])
        f_flow = p[ls.D_KFF] * (-o_px * (y[ls.PS] - y[ls.PX]) + o_xt * (y[ls.PX] - p[ls.I_PT]))
        u_s, d_s = _stop_split(x, v, 0.0, p[ls.I_XMAX], p[ls.I_KSS], p[ls.I_ASS])
        e = 0.5 * p[ls.I_MS] * v * v + 0.5 * p[ls.I_K] * x * x + p[ls.I_F0] * x + u_s
        p_in = (p[ls.D_A] * (y[ls.PS] - y[ls.PLS]) - y[ls.FSOL] + f_flow) * v
        d_spool = p[ls.D_C] * v * v
        # control pistons (swash plate)
        yc = y[ls.Y]
        vy = y[ls.VY]
        u_y, d_y = _stop_split(yc, vy, 0.0, p[ls.I_YMAX], p[ls.I_KYS], 0.0)
        e += 0.5 * p[ls.I_MY] * vy * vy + 0.5 * p[ls.I_KB] * yc * yc + p[ls.I_FB0] * yc + u_y
        p_in += (p[ls.I_A1] * y[ls.PX] - p[ls.I_A2] * y[ls.PS]) * vy
        d_piston = p[ls.I_BY] * vy * vy
        # actuator and load
        xa = y[ls.XA]
        va = y[ls.VA]
        u_a, d_a = _stop_split(xa, va, 0.0, p[ls.I_STROKE], p[ls.I_KAS], 0.0)
        e += 0.5 * p[ls.I_M] * va * va + p[ls.I_FL] * xa + u_a
        p_in += p[ls.I_AC] * (y[ls.PL] - p[ls.I_PT]) * va
        d_act = (p[ls.I_BA] * va + p[ls.I_FCA] * tanh_sign(va, p[ls.I_VEPS])) * va
        d = d_spool + d_s + d_piston + d_y + d_act + d_a
        return e, p_in, d, abs(d_spool) + abs(d_s) + abs(d_piston) + abs(d_y) + abs(d_act) + abs(d_a), u_s + u_y + u_a
    if plant_id == RODLESS_CYLINDER:
        pos = y[rc.Y]
        v = y[rc.V]
        u_st, d_st = _stop_split(pos, v, 0.0, p[rc.I_L], p[rc.I_KSTOP], p[rc.I_ASTOP])
        e = 0.5 * p[rc.I_M] * v * v + p[rc.I_FL] * pos + u_st
        p_in = p[rc.D_AREA] * (y[rc.PA] - y[rc.PB]) * v
        sigma0 = p[rc.I_SIG0]
        if sigma0 > 0.0:  # LuGre: the bristle force is a port (not pointwise passive)
            dz = lugre_exponential_rate(v, y[rc.Z], p[rc.I_FC], p[rc.I_FS], p[rc.I_VS], sigma0)
            p_in -= (sigma0 * y[rc.Z] + p[rc.I_SIG1] * dz) * v
            d_f = p[rc.I_SIG2] * v * v
        else:
            d_f = stribeck_exponential(v, p[rc.I_FC], p[rc.I_FS], p[rc.I_VS], p[rc.I_SIG2], p[rc.I_VEPS]) * v
        return e, p_in, d_f + d_st, abs(d_f) + abs(d_st), u_st
    return 0.0, 0.0, 0.0, 0.0, 0.0


@nb.njit(cache=True, error_model="numpy")
def _replay_one(plant_id, y0, u, p, dt, n_sub, w, y, o):
    """One copy of :func:`energy_replay`: ``y0`` -> ``y`` with the energy terms in ``o``."""
    ny = y.shape[0]
    for j in range(ny):
        y[j] = y0[j]
    h = dt / n_sub
    k1 = w[0]
    k2 = w[1]
    k3 = w[2]
    k4 = w[3]
    stage = w[4]
    half = 0.5 * h
    sixth = h / 6.0
    e0, _, _, _, c0 = mech_terms(plant_id, y, p)
    contact = c0 > 0.0
    w_in = 0.0
    q_d = 0.0
    turnover = 0.0
    bad = 0.0
    for _ in range(n_sub):
        plant_rhs(plant_id, y, u, p, k1)
        _, a1, d1, s1, c1 = mech_terms(plant_id, y, p)
        for j in range(ny):
            stage[j] = y[j] + half * k1[j]
        plant_rhs(plant_id, stage, u, p, k2)
        _, a2, d2, s2, c2 = mech_terms(plant_id, stage, p)
        for j in range(ny):
            stage[j] = y[j] + half * k2[j]
        plant_rhs(plant_id, stage, u, p, k3)
        _, a3, d3, s3, c3 = mech_terms(plant_id, stage, p)
        for j in range(ny):
            stage[j] = y[j] + h * k3[j]
        plant_rhs(plant_id, stage, u, p, k4)
        _, a4, d4, s4, c4 = mech_terms(plant_id, stage, p)
        for j in range(ny):
            y[j] += sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        plant_guard(plant_id, y, p)
        w_in += sixth * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        q_d += sixth * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
        turnover += sixth * (abs(a1) + d1 + 2.0 * (abs(a2) + d2 + abs(a3) + d3) + abs(a4) + d4)
        if c1 > 0.0 or c2 > 0.0 or c3 > 0.0 or c4 > 0.0:
            contact = True
        if d1 < -1e-12 * s1 or d2 < -1e-12 * s2 or d3 < -1e-12 * s3 or d4 < -1e-12 * s4:
            bad += 1.0
    e1, _, _, _, c1 = mech_terms(plant_id, y, p)
    contact = contact or c1 > 0.0
    o[0] = e0
    o[1] = e1
    o[2] = w_in
    o[3] = q_d
    o[4] = turnover
    o[5] = bad
    o[6] = 1.0 if contact else 0.0


@nb.njit(cache=True, parallel=True, error_model="numpy")
def energy_replay(plant_id, Y0, U, P, dt, NSUB, W, Yend, out):
    """Re-integrate every copy from ``Y0`` over one env step exactly as
    :func:`hydro_envs.sim.kernels.rk4_substeps` does (same stages, weights and guards) into
    ``Yend``, integrating the port work and the dissipation on the same stages.

    ``out[i]`` = (E_0, E_1, W = int P_in dt, Q = int D dt, int(|P_in| + D) dt, number of
    sub-steps with a stage at which D < 0, 1 if an end stop was engaged at any stage else 0).
    """
    for i in nb.prange(Y0.shape[0]):
        _replay_one(plant_id, Y0[i], U[i], P[i], dt, NSUB[i], W[i], Yend[i], out[i])


def energy_excess(e_start, e_end, work, turnover, scale):
    """Energy gained over a window beyond the port work, in units of the tolerance
    (> 1: a violation): ``(E_end - E_start - W) / (ENERGY_RTOL turnover + ENERGY_ETOL scale
    + 1e-12 J)`` with ``scale`` the largest |E| in the window (arrays or floats)."""
    return (e_end - e_start - work) / (ENERGY_RTOL * turnover + ENERGY_ETOL * scale + 1e-12)


# ============================================================================ state checks
@nb.njit(cache=True, error_model="numpy", inline="always")
def _stroke_check(x, lo, hi, speed, force, mass, k, run, j):
    """Update the running maxima ``run[j], run[j+1]`` and return (penetration beyond the
    tolerance > 0, penetration [m], tolerance [m])."""
    if speed > run[j]:
        run[j] = speed
    if force > run[j + 1]:
        run[j + 1] = force
    pen = 0.0
    if x < lo:
        pen = lo - x
    elif x > hi:
        pen = x - hi
    tol = 2.0 * (2.0 * run[j + 1] / k + run[j] * math.sqrt(mass / k))
    return pen > tol, pen, tol


@nb.njit(cache=True, error_model="numpy")
def state_breaches(plant_id, Y, P, RUN, flags):
    """Guard checks of every copy's state at an env-step boundary into ``flags[i]`` =
    (pressure/mass/temperature breach, stroke breach); updates the running maxima ``RUN``."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        run = RUN[i]
        fp = 0
        fs = False
        if plant_id == SERVO_CYLINDER:
            fl = p[sc.I_PFLOOR]
            fp = int(not (y[sc.P1] >= fl)) + int(not (y[sc.P2] >= fl))
            f = p[sc.I_A] * abs(y[sc.P1] - y[sc.P2]) + abs(p[sc.I_FL])
            fs, _, _ = _stroke_check(y[sc.X], 0.0, p[sc.I_L], abs(y[sc.V]), f, p[sc.I_M], p[sc.I_KSTOP], run, 0)
        elif plant_id == SHAKING_TABLE:
            fl = p[st.I_PFLOOR]
            fp = int(not (y[st.PA] >= fl)) + int(not (y[st.PB] >= fl))
            half = 0.5 * p[st.I_L]
            f = p[st.I_A] * abs(y[st.PA] - y[st.PB])
            fs, _, _ = _stroke_check(y[st.X], -half, half, abs(y[st.V]), f, p[st.I_MB] + p[st.I_MS],
                                     p[st.I_KSTOP], run, 0)
        elif plant_id == RODLESS_CYLINDER:
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
            fs, _, _ = _stroke_check(y[rc.Y], 0.0, p[rc.I_L], abs(y[rc.V]), f, p[rc.I_M], p[rc.I_KSTOP], run, 0)
        elif plant_id == LS_CIRCUIT:
            fl = p[ls.I_PFLOOR]
            for j in (ls.PS, ls.PX, ls.PL, ls.PLS):
                fp += int(not (y[j] >= fl))
            pt = p[ls.I_PT]
            # actuator
            f = p[ls.I_AC] * abs(y[ls.PL] - pt) + abs(p[ls.I_FL])
            b1, _, _ = _stroke_check(y[ls.XA], 0.0, p[ls.I_STROKE], abs(y[ls.VA]), f, p[ls.I_M], p[ls.I_KAS], run, 0)
            # flow-compensator spool: pressure, spring + preload, solenoid and flow forces
            o_px = min(max(y[ls.X] - p[ls.I_XLAP], 0.0), p[ls.I_LPORT])
            o_xt = min(max(p[ls.I_XLAP] - y[ls.X], 0.0), p[ls.I_LPORT])
            f_flow = p[ls.D_KFF] * (-o_px * (y[ls.PS] - y[ls.PX]) + o_xt * (y[ls.PX] - pt))
            f = (p[ls.D_A] * abs(y[ls.PS] - y[ls.PLS]) + abs(p[ls.I_F0]) + p[ls.I_K] * abs(y[ls.X])
                 + abs(y[ls.FSOL]) + abs(f_flow))
            b2, _, _ = _stroke_check(y[ls.X], 0.0, p[ls.I_XMAX], abs(y[ls.V]), f, p[ls.I_MS], p[ls.I_KSS], run, 2)
            # control pistons
            f = (p[ls.I_A1] * abs(y[ls.PX]) + p[ls.I_A2] * abs(y[ls.PS]) + abs(p[ls.I_FB0])
                 + p[ls.I_KB] * abs(y[ls.Y]))
            b3, _, _ = _stroke_check(y[ls.Y], 0.0, p[ls.I_YMAX], abs(y[ls.VY]), f, p[ls.I_MY], p[ls.I_KYS], run, 4)
            fs = b1 or b2 or b3
        elif plant_id == FORCE_ACTUATOR:
            _, xv = fa.valve_position(y, p)
            xi = xv + p[fa.I_XOFF]
            f_damp = p[fa.I_DG] * fa.hydraulic_damping(xi, y[fa.VF], p[fa.I_DA], p[fa.I_DV], p[fa.I_DK],
                                                       p[fa.I_DLIN])
            f = abs(y[fa.R0 + 4]) + abs(f_damp) + abs(y[fa.FF]) + p[fa.I_KS] * abs(y[fa.XS])
            mass = p[fa.I_M]
            if p[fa.I_LOCK] <= 0.5:
                f += p[fa.I_KL] * abs(y[fa.XP] - 0.5 * p[fa.I_L])
                mass += p[fa.I_MP] + p[fa.I_ML]
            fs, _, _ = _stroke_check(y[fa.XP] + y[fa.XS], 0.0, p[fa.I_L], abs(y[fa.VP] + y[fa.VS]), f, mass,
                                     p[fa.I_KSTOP], run, 0)
        flags[i, 0] = fp
        flags[i, 1] = 1 if fs else 0


# ============================================================================ draws
def _clip_to_allowed(params_cls: type, name: str, value: float) -> float:
    """``value`` moved into the field's allowed interval (open ends: just inside)."""
    meta = params_cls.__dataclass_fields__[name].metadata
    lo, hi = meta["allowed"]
    if value < lo or (meta["open_low"] and value <= lo):
        value = np.nextafter(lo, np.inf) if meta["open_low"] else lo
    if value > hi or (meta["open_high"] and value >= hi):
        value = np.nextafter(hi, -np.inf) if meta["open_high"] else hi
    return float(value)


def extreme_draw(batch: Any, rng: np.random.Generator, beyond: bool, factor: float) -> tuple[dict[str, float], str]:
    """One parameter draw at a random corner of the randomisation ranges, or (``beyond``) of
    the ranges widened by ``factor`` and clipped into the allowed intervals. Returns the
    values of the randomised parameters and the kind actually drawn (``corner``,
    ``beyond``; a beyond draw that stays invalid after 20 attempts falls back to a corner)."""
    spec, base = batch.spec, batch.base_params
    n = len(spec.entries)
    wide = spec.widened(factor) if beyond else spec
    for _ in range(20 if beyond else 1):
        flags = rng.integers(0, 2, n).astype(bool)
        values = {}
        for e, hi in zip(wide.entries, flags):
            lo_v, hi_v = e.value_range(getattr(base, e.name))
            values[e.name] = _clip_to_allowed(batch.params_cls, e.name, hi_v if hi else lo_v)
        try:
            p = batch.params_cls.from_mapping(values, base=base)
            if batch.substeps_for(p) > MAX_SUBSTEPS:
                continue
        except (ParameterError, ValueError, ZeroDivisionError, OverflowError):
            continue
        return values, ("beyond" if beyond else "corner")
    return extreme_draw(batch, rng, False, factor)


# ============================================================================ driver
@dataclasses.dataclass
class SoakResult:
    env_id: str
    steps: int  # env steps summed over copies
    seconds: float
    draws: dict[str, int]  # number of episodes per draw kind
    counts: dict[str, int]  # breach kind -> count (steps or stages)
    guard_clamps: int
    max_energy_excess: float  # largest (E1 - E0 - W + Q) / tol seen (< 1 passes)
    examples: dict[str, dict[str, Any]]  # first occurrence of every breach kind (energy: the worst)

    @property
    def steps_per_second(self) -> float:
        return self.steps / self.seconds if self.seconds > 0 else float("nan")

    @property
    def breaches(self) -> int:
        return int(sum(self.counts.values()))


def _actions(rng, mode, level, hold, adim, mean_hold):
    """Next actions ``(n, adim)``: mode 0 i.i.d. uniform, 1 held uniform levels, 2 bang-bang
    (+-1 held for geometric dwell times, switching sign)."""
    hold -= 1
    new = hold <= 0
    if new.any():
        k = int(new.sum())
        bang = mode[new] == 2
        lv = rng.uniform(-1.0, 1.0, (k, adim))
        flip = -np.sign(level[new])
        flip[flip == 0] = 1.0
        lv[bang] = flip[bang]
        level[new] = lv
        hold[new] = rng.geometric(1.0 / mean_hold[new])
    a = level.copy()
    iid = mode == 0
    if iid.any():
        a[iid] = rng.uniform(-1.0, 1.0, (int(iid.sum()), adim))
    return a


def soak_env(
    env_id: str,
    steps: int,
    *,
    num_envs: int = 64,
    seed: int = 0,
    factor: float = 2.0,
    beyond_fraction: float = 0.5,
    bang_fraction: float = 0.4,
    episode_steps: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> SoakResult:
    """Run ``steps`` env steps (summed over ``num_envs`` copies, rounded up to whole batch
    steps) of ``env_id``'s native vector env; see the module docstring for what is counted."""
    if steps < 1 or num_envs < 1:
        raise ValueError(f"steps and num_envs must be >= 1, got {steps}, {num_envs}")
    if not (math.isfinite(factor) and factor > 1.0):
        raise ValueError(f"factor must be > 1, got {factor}")
    kw: dict[str, Any] = {"num_envs": num_envs, "vectorization_mode": "vector_entry_point"}
    if episode_steps is not None:
        kw["max_episode_steps"] = int(episode_steps)
    venv = gym.make_vec(env_id, **kw)
    b = venv.unwrapped._batch if hasattr(venv, "unwrapped") else venv._batch
    n, adim = b.n, b.action_dim
    rng = np.random.default_rng([seed, 8])
    counts = {k: 0 for k in BREACH_KINDS}
    examples: dict[str, dict[str, Any]] = {}
    draws = {"corner": 0, "beyond": 0}
    current: list[dict[str, float]] = [{} for _ in range(n)]
    RUN = np.zeros((n, _N_RUN))
    flags = np.zeros((n, 2), dtype=np.int64)
    Y0 = np.empty_like(b.Y)
    Yend = np.empty_like(b.Y)
    W2 = np.zeros_like(b.W)
    out = np.zeros((n, 7))
    mode = np.zeros(n, dtype=np.int64)
    level = np.zeros((n, adim))
    hold = np.zeros(n, dtype=np.int64)
    mean_hold = np.ones(n)
    max_excess = 0.0
    # energy-balance windows (see ENERGY_WINDOW): start energy and state, sums over the window
    win_e0 = np.zeros(n)
    win_y0 = np.zeros_like(b.Y)
    win_w = np.zeros(n)
    win_t = np.zeros(n)
    win_scale = np.zeros(n)
    win_contact = np.zeros(n, dtype=bool)
    win_len = 0
    clamps_total = 0

    def new_episodes() -> None:
        nonlocal clamps_total, win_len
        clamps_total += int(b.clamps.sum())
        for i in range(n):
            beyond = bool(rng.random() < beyond_fraction)
            values, kind = extreme_draw(b, rng, beyond, factor)
            draws[kind] += 1
            current[i] = values
            mask = np.zeros(n, dtype=bool)
            mask[i] = True
            # no seed: copy i continues its own stream (seeded seed + i by the first reset)
            venv.reset(options={"reset_mask": mask, "params": values})
        RUN[:] = 0.0
        win_len = 0
        u = rng.random(n)
        mode[:] = np.where(u < bang_fraction, 2, np.where(u < bang_fraction + 0.5 * (1 - bang_fraction), 1, 0))
        hold[:] = 0
        level[:] = 0.0
        mean_hold[:] = np.where(mode == 2, 100.0, 20.0) * rng.uniform(0.5, 2.0, n)

    def record(kind: str, i: int, k: int, extra: dict[str, Any] | None = None) -> None:
        """Keep the first breach of each kind; for ``energy`` the worst one."""
        worse = kind == "energy" and kind in examples and extra["excess"] > examples[kind]["excess"]
        if kind not in examples or worse:
            examples[kind] = {
                "step": k,
                "copy": i,
                "episode_step": int(b.K[i]),
                "params": dict(current[i]),
                "state": b.state_dict(i),
                "state_before": dict(zip(b.plant.STATE_NAMES, Y0[i].tolist())),
                **(extra or {}),
            }

    venv.reset(seed=int(seed))
    new_episodes()
    batch_steps = -(-int(steps) // n)
    t0 = time.perf_counter()
    for k in range(batch_steps):
        a = _actions(rng, mode, level, hold, adim, mean_hold)
        Y0[:] = b.Y
        obs, reward, _, truncated, _ = venv.step(a)
        # energy replay of this step (same U, P, NSUB as the env's kernel call)
        energy_replay(b.kernel_id, Y0, b.U, b.P, b.dt, b.NSUB, W2, Yend, out)
        same = (Yend == b.Y) | (np.isnan(Yend) & np.isnan(b.Y))
        bad_replay = ~np.all(same, axis=1)
        fin = np.all(np.isfinite(b.Y), axis=1) & np.all(np.isfinite(obs), axis=1) & np.isfinite(reward)
        state_breaches(b.kernel_id, b.Y, b.P, RUN, flags)
        if win_len == 0:
            win_e0[:] = out[:, 0]
            win_y0[:] = Y0
            win_w[:] = 0.0
            win_t[:] = 0.0
            win_scale[:] = np.abs(out[:, 0])
            win_contact[:] = False
        win_len += 1
        win_w += out[:, 2]
        win_t += out[:, 4]
        np.maximum(win_scale, np.abs(out[:, 1]), out=win_scale)
        win_contact |= out[:, 6] > 0
        bad_energy = np.zeros(n, dtype=bool)
        excess = np.zeros(n)
        if win_len == ENERGY_WINDOW or truncated.any():
            excess = energy_excess(win_e0, out[:, 1], win_w, win_t, win_scale)
            fin_e = np.isfinite(excess)
            if fin_e.any():
                max_excess = max(max_excess, float(excess[fin_e].max()))
            bad_energy = fin_e & (excess > 1.0)
            win_len = 0
        per_kind = {
            "nonfinite": ~fin,
            "pressure": flags[:, 0] > 0,
            "stroke": flags[:, 1] > 0,
            "energy": bad_energy,
            "passivity": out[:, 5] > 0,
            "replay": bad_replay,
        }
        for kind, mask in per_kind.items():
            if mask.any():
                counts[kind] += int(out[mask, 5].sum()) if kind == "passivity" else int(mask.sum())
                idx = np.flatnonzero(mask)
                i = int(idx[np.argmax(excess[idx])]) if kind == "energy" else int(idx[0])
                extra = {"excess": float(excess[i])}
                if kind == "energy":
                    extra.update(window_start_state=dict(zip(b.plant.STATE_NAMES, win_y0[i].tolist())),
                                 window_energy=[float(win_e0[i]), float(out[i, 1]), float(win_w[i]), float(win_t[i])],
                                 window_contact=bool(win_contact[i]))
                record(kind, i, k, extra)
        if truncated.any():
            new_episodes()
        if progress is not None and (k + 1) % max(1, batch_steps // 10) == 0:
            progress(f"{env_id}: {(k + 1) * n} steps, {sum(counts.values())} breaches")
    seconds = time.perf_counter() - t0
    clamps_total += int(b.clamps.sum())
    venv.close()
    return SoakResult(env_id, batch_steps * n, seconds, draws, counts, clamps_total, max_excess, examples)


def format_table(results: list[SoakResult]) -> str:
    """Markdown table: env, steps, steps/s, each breach count, guard clamps, draws."""
    head = ["env", "steps", "steps/s", *BREACH_KINDS, "guard_clamps", "max E excess/tol", "draws corner/beyond"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        cells = [r.env_id, f"{r.steps:,}", f"{r.steps_per_second:,.0f}", *(str(r.counts[k]) for k in BREACH_KINDS),
                 str(r.guard_clamps), f"{r.max_energy_excess:.3g}", f"{r.draws['corner']}/{r.draws['beyond']}"]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)
