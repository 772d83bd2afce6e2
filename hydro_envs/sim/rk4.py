"""The fixed-step integrator: classical RK4 sub-steps with a guard after each, compiled.

``rk4_advance(rhs, guard, y, u, p, h, n_sub, work)`` advances one copy by ``n_sub`` sub-steps
of ``h`` seconds under the held input ``u`` (zero-order hold, as a DAC does) and returns how
often the guard had to project the state back onto the physical set (pressure floor, ...).
``rhs(y, u, p, dy)`` and ``guard(y, p) -> int`` are a plant's compiled functions.

numba caches a compiled function only when its signature holds no function objects (and,
for a callee that receives one, only when the callee is inlined into it), so these loops are
inlined (``inline="always"``) into a few lines of each plant's ``kernels.py`` that bind its
right-hand side (``step_serial``, ``step_parallel``, ``trajectories``, ``derivatives``): the
loops exist once, each plant compiles only its own model, and every binding is cached on disk.
``rhs_along`` evaluates the right-hand side along a recorded trajectory (derivative outputs
such as an acceleration). ``in_blocks`` spreads a batch step over threads in contiguous
blocks of copies, each advanced by the plant's serial step: the separately compiled serial
loop runs 3-25 % faster than the same RK4 sub-steps as the body of a ``prange`` over single
copies (1024-copy envs of every plant, bit-identical states). ``rk4_advance_refined`` is
``rk4_advance`` for a plant with a mode that is stiff only in a small region of the state
space (a regularised friction sign near zero velocity): sub-steps sized for the other modes,
each redone in finer sub-steps where the plant's ``shallow`` test fails along it.

Batch layout: states ``Y (n, n_states)``, inputs ``U (n, n_inputs)``, parameters
``P (n, n_params)``, sub-steps ``NSUB (n,)``, workspace ``W (n, 5, n_states)`` (k1..k4 and the
stage state), guard counters ``clamps (n,)``. Trajectories: ``U (n, T, n_inputs)`` with row
``k`` held over ``[t_k, t_k+1)``, states out ``(n, T + 1, n_states)`` with row ``k`` at ``t_k``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["rk4_advance", "rk4_advance_refined", "rk4_advance_lookahead", "coarse_step_shallow",
           "rk4_trajectory", "rk4_trajectory_refined", "rk4_trajectory_lookahead", "rhs_along", "in_blocks"]

#: most blocks of copies :func:`in_blocks` makes of a batch (copies differ in sub-step count;
#: a fixed number, since the thread count read inside a kernel would keep it out of the cache)
MAX_BLOCKS = 64


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_advance(rhs, guard, y, u, p, h, n_sub, work):
    """Advance ``y`` in place by ``n_sub`` RK4 steps of ``h`` seconds; return guard clamps.

    The four stages run in one loop with a single call of ``rhs`` (stage state ``y``, then
    ``y + h/2 k1``, ``y + h/2 k2``, ``y + h k3``), so a plant's right-hand side is compiled
    into the kernel once rather than four times (compile time; the arithmetic is classical
    RK4's).
    """
    ny = y.shape[0]
    stage = work[4]
    half = 0.5 * h
    sixth = h / 6.0
    clamps = 0
    for _ in range(n_sub):
        for s in range(4):
            if s == 0:
                for j in range(ny):
                    stage[j] = y[j]
            else:
                c = h if s == 3 else half
                prev = work[s - 1]
                for j in range(ny):
                    stage[j] = y[j] + c * prev[j]
            rhs(stage, u, p, work[s])
        k1 = work[0]
        k2 = work[1]
        k3 = work[2]
        k4 = work[3]
        for j in range(ny):
            y[j] += sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        clamps += guard(y, p)
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_advance_refined(rhs, guard, shallow, y, u, p, h, n_sub, m, work, back):
    """``rk4_advance`` with local refinement: each of the ``n_sub`` steps of ``h`` seconds is
    one classical RK4 step where ``shallow(y_start, x, p, h)`` holds at its start state, its
    three stage states and its end state, and is redone as ``m`` steps of ``h / m`` where it
    fails at any of them. ``shallow`` tells whether the plant's locally stiff mode lets an RK4
    step of ``h`` stay stable at ``x`` (for a friction curve: its slope at the velocity of
    ``x`` inside the stability bound of ``h``, and the velocity still of the sign it had at
    ``y_start``); it must read only state components the guard leaves alone. ``m`` must make
    ``h / m`` stable everywhere (``m <= 1``: plain RK4 sub-steps, ``shallow`` is not called).
    ``back (n_states,)`` is scratch. Returns guard clamps. An accepted step is one
    ``rk4_advance`` step (the same arithmetic); its stage states are rebuilt from ``work``.

    Compile time: every step, coarse or fine, runs through the one RK4 body written out here, so
    the right-hand side is compiled into the loop once. With ``rk4_advance`` inlined here
    (nested inlining) and a call site per step kind, a plant's step kernel took about a second
    longer to compile.
    """
    ny = y.shape[0]
    clamps = 0
    for _ in range(n_sub):
        for j in range(ny):
            back[j] = y[j]
        fine = m > 1 and not shallow(back, y, p, h)
        left = m if fine else 1
        while left > 0:
            hh = h / m if fine else h
            stage = work[4]
            for s in range(4):
                if s == 0:
                    for j in range(ny):
                        stage[j] = y[j]
                else:
                    cs = hh if s == 3 else 0.5 * hh
                    prev = work[s - 1]
                    for j in range(ny):
                        stage[j] = y[j] + cs * prev[j]
                rhs(stage, u, p, work[s])
            sixth = hh / 6.0
            for j in range(ny):
                y[j] += sixth * (work[0][j] + 2.0 * work[1][j] + 2.0 * work[2][j] + work[3][j])
            c = guard(y, p)
            if not fine and m > 1:
                if not coarse_step_shallow(shallow, back, y, p, h, work):
                    for j in range(ny):
                        y[j] = back[j]
                    fine = True
                    left = m
                    continue
            clamps += c
            left -= 1
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_advance_lookahead(rhs, guard, shallow, y, u, p, h, n_sub, m, work):
    """``rk4_advance`` with local refinement decided ahead: each of the ``n_sub`` steps of
    ``h`` seconds is one classical RK4 step where ``shallow(y, x, p, h)`` holds at its start
    state ``y`` and at the Euler prediction ``x = y + h k1`` of its end, and ``m`` steps of
    ``h / m`` where it fails at either. ``shallow`` tells whether the plant's locally stiff
    modes let an RK4 step of ``h`` stay stable at ``x``, and whether a stiff point lies between
    ``y`` and ``x`` (a sign change). ``k1`` is computed once for both uses. ``m`` must make
    ``h / m`` stable everywhere (``m <= 1``: plain RK4 sub-steps, ``shallow`` is not called).
    Returns guard clamps. Every step is ``rk4_advance``'s arithmetic: ``m <= 1`` or a
    ``shallow`` that always holds give its numbers bit for bit, one that never holds those of
    ``n_sub m`` sub-steps.

    Against :func:`rk4_advance_refined` (which checks the three stage states and the end state
    and takes a failed step back): no step is taken back, so a plant's step kernel compiles
    about 0.6 s faster; a stiff region entered within one step further than the Euler
    prediction reaches is refined from the next step on.
    """
    ny = y.shape[0]
    stage = work[4]
    clamps = 0
    for _ in range(n_sub):
        rhs(y, u, p, work[0])
        n = 1
        if m > 1:
            for j in range(ny):
                stage[j] = y[j] + h * work[0][j]
            if not (shallow(y, y, p, h) and shallow(y, stage, p, h)):
                n = m
        hh = h / n
        for k in range(n):
            for s in range(4):
                if s == 0:
                    if k > 0:
                        rhs(y, u, p, work[0])
                else:
                    cs = hh if s == 3 else 0.5 * hh
                    prev = work[s - 1]
                    for j in range(ny):
                        stage[j] = y[j] + cs * prev[j]
                    rhs(stage, u, p, work[s])
            sixth = hh / 6.0
            for j in range(ny):
                y[j] += sixth * (work[0][j] + 2.0 * work[1][j] + 2.0 * work[2][j] + work[3][j])
            clamps += guard(y, p)
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def coarse_step_shallow(shallow, back, y, p, h, work):
    """Whether an RK4 step of ``h`` from ``back`` to ``y`` stays where ``shallow`` holds at its
    end state and its three stage states (``work[4]`` holds the last, ``back + h k3``; the two
    before it are rebuilt there from ``k1``, ``k2``): the acceptance test of
    :func:`rk4_advance_refined`."""
    ok = shallow(back, y, p, h)
    stage = work[4]
    ok = ok and shallow(back, stage, p, h)
    for s in range(2):
        if ok:
            for j in range(y.shape[0]):
                stage[j] = back[j] + 0.5 * h * work[s][j]
            ok = shallow(back, stage, p, h)
    return ok


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_trajectory(rhs, guard, y0, u, p, dt, n_sub, work, out):
    """States at ``t_0 .. t_T`` into ``out (T + 1, n_states)`` under inputs ``u (T, n_in)``,
    each held for ``dt`` seconds and integrated in ``n_sub`` sub-steps; returns guard clamps."""
    ny = y0.shape[0]
    for j in range(ny):
        out[0, j] = y0[j]
    h = dt / n_sub
    clamps = 0
    for k in range(u.shape[0]):
        y = out[k + 1]
        for j in range(ny):
            y[j] = out[k, j]
        clamps += rk4_advance(rhs, guard, y, u[k], p, h, n_sub, work)
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_trajectory_refined(rhs, guard, shallow, y0, u, p, dt, n_sub, m, work, back, out):
    """:func:`rk4_trajectory` stepping with :func:`rk4_advance_refined` (``shallow``, ``m``,
    scratch ``back (n_states,)`` as there)."""
    ny = y0.shape[0]
    for j in range(ny):
        out[0, j] = y0[j]
    h = dt / n_sub
    clamps = 0
    for k in range(u.shape[0]):
        y = out[k + 1]
        for j in range(ny):
            y[j] = out[k, j]
        clamps += rk4_advance_refined(rhs, guard, shallow, y, u[k], p, h, n_sub, m, work, back)
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_trajectory_lookahead(rhs, guard, shallow, y0, u, p, dt, n_sub, m, work, out):
    """:func:`rk4_trajectory` stepping with :func:`rk4_advance_lookahead` (``shallow``, ``m``
    as there)."""
    ny = y0.shape[0]
    for j in range(ny):
        out[0, j] = y0[j]
    h = dt / n_sub
    clamps = 0
    for k in range(u.shape[0]):
        y = out[k + 1]
        for j in range(ny):
            y[j] = out[k, j]
        clamps += rk4_advance_lookahead(rhs, guard, shallow, y, u[k], p, h, n_sub, m, work)
    return clamps


@nb.njit(cache=True, error_model="numpy", inline="always")
def rhs_along(rhs, x, u, p, out):
    """``out[k] = rhs(x[k], u[min(k, T - 1)], p)`` for the states ``x (K, n_states)`` of a
    trajectory under inputs ``u (T, n_in)`` (the last state sees the last input)."""
    ns = x.shape[1]
    y = np.empty(ns)
    dy = np.empty(ns)
    for k in range(x.shape[0]):
        for j in range(ns):
            y[j] = x[k, j]
        rhs(y, u[min(k, u.shape[0] - 1)], p, dy)
        for j in range(ns):
            out[k, j] = dy[j]


@nb.njit(cache=True, error_model="numpy", inline="always")
def in_blocks(step, Y, U, P, dt, NSUB, W, clamps):
    """``step(Y, U, P, dt, NSUB, W, clamps)`` (a plant's serial batch step) over contiguous
    blocks of the batch, one ``prange`` iteration per block; inline it into a
    ``parallel=True`` kernel. Every copy's arithmetic is that of ``step``."""
    n = Y.shape[0]
    m = min(n, MAX_BLOCKS)
    for c in nb.prange(m):
        lo = c * n // m
        hi = (c + 1) * n // m
        step(Y[lo:hi], U[lo:hi], P[lo:hi], dt, NSUB[lo:hi], W[lo:hi], clamps[lo:hi])
