r"""Energy bookkeeping of the fixed-step integrator, for the soak test's balance checks.

Each plant's ``energy.py`` gives ``mech_terms(y, p) -> (E, P_in, D, D_scale, U_stop)``: the
mechanical energy of its moving bodies [J], the power its ports deliver [W] (pressure forces
and other sign-indefinite sources), the power its dissipative elements take [W] (>= 0 by
construction), the magnitude of D's parts (the round-off scale of the passivity check) and the
elastic energy in engaged end stops [J]. Along the exact solution ``dE/dt = P_in - D``.

:func:`replay_step` re-integrates one copy over one env step exactly as
:func:`hydro_envs.sim.rk4.rk4_advance` does (same stages, weights and guards) and integrates
``W = int P_in dt`` and ``Q = int D dt`` with the RK4 weights on the same stages (RK4 applied to
the augmented system); :func:`replay_step_lookahead` does the same for kernels with local
refinement (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`). The checks built on it are
described in :mod:`hydro_envs.soak`.
"""

from __future__ import annotations

import math

import numba as nb

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import end_stop_force

__all__ = ["stop_split", "stroke_check", "replay_step", "replay_step_lookahead"]


@nb.njit(cache=True, error_model="numpy", inline="always")
def stop_split(x, v, lo, hi, k, alpha):
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


@nb.njit(cache=True, error_model="numpy", inline="always")
def stroke_check(x, lo, hi, speed, force, mass, k, run, j):
    """Penetration of a body into its end stops against the energy bound.

    A body of mass ``M`` that reaches a Hunt-Crossley stop (stiffness ``k``) at speed ``v``
    while a force ``F`` pushes it in penetrates ``delta <= 2 F/k + v sqrt(M/k)``; with ``v``
    and ``F`` the running maxima ``run[j], run[j+1]`` (updated here) the tolerance is twice
    that. Returns (penetration beyond the tolerance, penetration [m], tolerance [m]).
    """
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


@nb.njit(cache=True, error_model="numpy", inline="always")
def _substep_with_energy(rhs, guard, mech, y, u, p, h, w):
    """One RK4 sub-step of ``h`` in place, as :func:`hydro_envs.sim.rk4.rk4_advance` takes it;
    returns its increments of (W, Q, turnover), whether a stage touched an end stop and
    whether a stage had D < 0. ``w[4]`` ends holding the last stage state ``y + h k3``."""
    ny = y.shape[0]
    stage = w[4]
    dw = dq = dturn = 0.0
    contact = bad = False
    for s in range(4):
        x = y
        if s > 0:
            c = h if s == 3 else 0.5 * h
            prev = w[s - 1]
            for j in range(ny):
                stage[j] = y[j] + c * prev[j]
            x = stage
        rhs(x, u, p, w[s])
        _, a, d, scale, engaged = mech(x, p)
        weight = 2.0 if s == 1 or s == 2 else 1.0  # RK4's 1, 2, 2, 1
        dw += weight * a
        dq += weight * d
        dturn += weight * (abs(a) + d)
        contact = contact or engaged > 0.0
        bad = bad or d < -1e-12 * scale
    sixth = h / 6.0
    for j in range(ny):
        y[j] += sixth * (w[0][j] + 2.0 * w[1][j] + 2.0 * w[2][j] + w[3][j])
    guard(y, p)
    dw *= sixth
    dq *= sixth
    dturn *= sixth
    return dw, dq, dturn, contact, bad


@njit_noalloc
def _no_refinement(y0, y, p, h, m):
    return 1


@nb.njit(cache=True, error_model="numpy", inline="always")
def replay_step(rhs, guard, mech, y0, u, p, dt, n_sub, w, y, o):
    """Re-integrate ``y0`` -> ``y`` over ``dt`` in ``n_sub`` RK4 sub-steps, with the energy terms.

    ``o`` = (E_0, E_1, W = int P_in dt, Q = int D dt, int(|P_in| + D) dt, number of sub-steps
    with a stage at which D < 0, 1 if an end stop was engaged at any stage else 0).
    :func:`replay_step_lookahead` without refinement (``m = 1``).
    """
    replay_step_lookahead(rhs, guard, _no_refinement, mech, y0, u, p, dt, n_sub, 1, w, y, o)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _replay_start(mech, y0, p, dt, n_sub, y):
    """Copy ``y0`` into ``y``; return the sub-step, the start energy and whether an end stop is
    engaged at the start."""
    for j in range(y.shape[0]):
        y[j] = y0[j]
    e0, _, _, _, c0 = mech(y, p)
    return dt / n_sub, e0, c0 > 0.0


@nb.njit(cache=True, error_model="numpy", inline="always")
def replay_step_lookahead(rhs, guard, refinement, mech, y0, u, p, dt, n_sub, m, w, y, o):
    """:func:`replay_step` for kernels that step with
    :func:`hydro_envs.sim.rk4.rk4_advance_lookahead` (same ``refinement`` and ``m``): each
    sub-step is taken as the fine ones ``refinement`` gives, as there."""
    ny = y.shape[0]
    h, e0, contact = _replay_start(mech, y0, p, dt, n_sub, y)
    w_in = q_d = turnover = bad = 0.0
    stage = w[4]
    for _ in range(n_sub):
        n = 1
        if m > 1:
            rhs(y, u, p, w[0])
            for j in range(ny):
                stage[j] = y[j] + h * w[0][j]
            n = refinement(y, stage, p, h, m)
        for _k in range(n):
            dw, dq, dturn, c, b = _substep_with_energy(rhs, guard, mech, y, u, p, h / n, w)
            w_in += dw
            q_d += dq
            turnover += dturn
            contact = contact or c
            if b:
                bad += 1.0
    _finish(mech, y, p, e0, contact, w_in, q_d, turnover, bad, o)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _finish(mech, y, p, e0, contact, w_in, q_d, turnover, bad, o):
    e1, _, _, _, c1 = mech(y, p)
    o[0] = e0
    o[1] = e1
    o[2] = w_in
    o[3] = q_d
    o[4] = turnover
    o[5] = bad
    o[6] = 1.0 if (contact or c1 > 0.0) else 0.0
