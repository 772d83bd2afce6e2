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
blocks of copies (``n_blocks``, ``block_bounds``, ``step_block``), each advanced by the plant's
serial step (an env's step-and-observe kernel does the same and observes each block after
stepping it): the separately compiled serial loop runs 3-25 % faster than the same RK4
sub-steps as the body of a ``prange`` over single copies (1024-copy envs of every plant, bit-identical states). ``rk4_advance_lookahead`` is
``rk4_advance`` for a plant with a mode that is stiff only in a small region of the state
space (a friction state at speed, a regularised friction sign near zero velocity, a flow
law's laminar tail, a stop in contact): sub-steps sized for the other modes, each taken as
finer ones where the plant's ``refinement`` finds those modes stiff at its start or at the
Euler prediction of its end, as many as it gives.

Batch layout: states ``Y (n, n_states)``, inputs ``U (n, n_inputs)``, parameters
``P (n, n_params)``, sub-steps ``NSUB (n,)``, workspace ``W (n, 5, n_states)`` (k1..k4 and the
stage state), guard counters ``clamps (n,)``. Trajectories: ``U (n, T, n_inputs)`` with row
``k`` held over ``[t_k, t_k+1)``, states out ``(n, T + 1, n_states)`` with row ``k`` at ``t_k``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from hydro_envs.sim.stiffness import DEFAULT_SAFETY, RK4_REAL_STABILITY_LIMIT

__all__ = ["rk4_advance", "rk4_advance_lookahead", "local_substeps", "worst_case_substeps", "STABLE_H_LAMBDA",
           "LOCAL_RATE_MARGIN", "rk4_trajectory",
           "rk4_trajectory_lookahead", "rhs_along", "in_blocks", "n_blocks", "block_bounds", "step_block"]

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


#: margin on a locally stiff mode's rate at a sub-step's start and Euler prediction when
#: :func:`local_substeps` sizes its refinement: the rate may grow along the sub-step (a friction
#: state's rate with the speed, a flow law's with the pressure ratio); assumed
LOCAL_RATE_MARGIN = 1.5
#: ``h |lambda|`` within which the sub-step bound keeps every mode (:mod:`hydro_envs.sim.stiffness`)
STABLE_H_LAMBDA = DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT


@nb.njit(cache=True, error_model="numpy", inline="always")
def worst_case_substeps(h_lambda):
    """Fewest RK4 steps of ``h / m`` that keep a mode with ``h |lambda| = h_lambda`` inside
    :data:`STABLE_H_LAMBDA`: ``ceil(h_lambda / STABLE_H_LAMBDA)``, at least 1 (the ``m`` of
    :func:`rk4_advance_lookahead` for a plant's locally refined modes at their worst case)."""
    return max(1, int(math.ceil(h_lambda / STABLE_H_LAMBDA - 1e-12)))


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_substeps(h_lambda, stable, m):
    """Fine sub-steps that take a sub-step whose locally stiff modes have ``h |lambda| =
    h_lambda`` (their largest rate at its start and Euler prediction, times ``h``) inside the
    stable ``stable``: 1 if ``h_lambda <= stable``, else ``ceil(LOCAL_RATE_MARGIN h_lambda /
    stable)``, at least 2 and at most ``m`` (the count that is stable at the worst case)."""
    if h_lambda <= stable:
        return 1
    return min(m, max(2, int(math.ceil(LOCAL_RATE_MARGIN * h_lambda / stable))))


@nb.njit(cache=True, error_model="numpy", inline="always")
def rk4_advance_lookahead(rhs, guard, refinement, y, u, p, h, n_sub, m, work):
    """``rk4_advance`` with local refinement decided ahead: each of the ``n_sub`` steps of ``h``
    seconds is taken as ``n = refinement(y, x, p, h, m)`` classical RK4 steps of ``h / n``, with
    ``y`` its start state and ``x = y + h k1`` the Euler prediction of its end. ``refinement``
    returns 1 where the plant's locally stiff modes let an RK4 step of ``h`` stay stable at both
    (and no stiff point lies between them, such as a sign change), else the count that makes
    them stable (:func:`local_substeps`), at most ``m``, or more where the plant's accuracy asks
    for it (a fast mode refined for accuracy, not stability); ``m`` must make ``h / m`` stable
    everywhere (``m <= 1``: plain RK4 sub-steps, ``refinement`` is not called, so a plant that
    refines for accuracy passes ``m >= 2``). ``k1`` is computed once for both uses. Returns guard
    clamps. Every step is ``rk4_advance``'s arithmetic: ``m <= 1`` or a ``refinement`` that always
    returns 1 give its numbers bit for bit, one that always returns ``m`` those of ``n_sub m``
    sub-steps.

    No step is taken back: a stiff region entered within one step further than the Euler
    prediction reaches is refined from the next step on. Checking the three stage states and
    the end state instead and redoing a failed step took the force actuator's kernel 7 % longer
    and the rodless cylinder's 0.6 s longer to compile. Every stage of every step, coarse or
    fine, runs through one call of ``rhs``: with separate calls for the decision's ``k1`` and
    for the later steps' (three call sites), the force actuator's step kernel ran 1.4x slower
    (1024 copies, interleaved in one process).
    """
    ny = y.shape[0]
    stage = work[4]
    clamps = 0
    for _ in range(n_sub):
        n = 1
        hh = h
        k = 0
        while k < n:
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
                if s == 0 and k == 0 and m > 1:  # k1 at the start: decide the step's refinement
                    for j in range(ny):
                        stage[j] = y[j] + h * work[0][j]
                    n = refinement(y, stage, p, h, m)
                    hh = h / n
            sixth = hh / 6.0
            for j in range(ny):
                y[j] += sixth * (work[0][j] + 2.0 * work[1][j] + 2.0 * work[2][j] + work[3][j])
            clamps += guard(y, p)
            k += 1
    return clamps


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
def rk4_trajectory_lookahead(rhs, guard, refinement, y0, u, p, dt, n_sub, m, work, out):
    """:func:`rk4_trajectory` stepping with :func:`rk4_advance_lookahead` (``refinement``,
    ``m`` as there)."""
    ny = y0.shape[0]
    for j in range(ny):
        out[0, j] = y0[j]
    h = dt / n_sub
    clamps = 0
    for k in range(u.shape[0]):
        y = out[k + 1]
        for j in range(ny):
            y[j] = out[k, j]
        clamps += rk4_advance_lookahead(rhs, guard, refinement, y, u[k], p, h, n_sub, m, work)
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
def n_blocks(n):
    """How many contiguous blocks of copies a batch of ``n`` is stepped in (at most
    :data:`MAX_BLOCKS`)."""
    return min(n, MAX_BLOCKS)


@nb.njit(cache=True, error_model="numpy", inline="always")
def block_bounds(c, n):
    """Copies ``lo:hi`` of block ``c`` of a batch of ``n`` (blocks of :func:`n_blocks`)."""
    m = min(n, MAX_BLOCKS)
    return c * n // m, (c + 1) * n // m


@nb.njit(cache=True, error_model="numpy", inline="always")
def step_block(step, c, Y, U, P, dt, NSUB, W, clamps):
    """Advance block ``c`` of the batch (:func:`block_bounds`) by ``step`` (a plant's serial batch
    step) on its rows; return the block's ``lo, hi``."""
    lo, hi = block_bounds(c, Y.shape[0])
    step(Y[lo:hi], U[lo:hi], P[lo:hi], dt, NSUB[lo:hi], W[lo:hi], clamps[lo:hi])
    return lo, hi


@nb.njit(cache=True, error_model="numpy", inline="always")
def in_blocks(step, Y, U, P, dt, NSUB, W, clamps):
    """``step(Y, U, P, dt, NSUB, W, clamps)`` (a plant's serial batch step) over contiguous
    blocks of the batch, one ``prange`` iteration per block; inline it into a
    ``parallel=True`` kernel. Every copy's arithmetic is that of ``step``."""
    for c in nb.prange(n_blocks(Y.shape[0])):
        step_block(step, c, Y, U, P, dt, NSUB, W, clamps)
