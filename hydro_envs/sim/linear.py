"""Linearisation of a plant model: the Jacobians of its compiled right-hand side and their
zero-order-hold discretisation.

``linearize(spec, params, y0, u0)`` returns ``(A, B)`` of ``dy/dt = A (y - y0) + B (u - u0)``
at the state ``y0`` and input ``u0`` [SI], by central differences of the plant's compiled
right-hand side (``kernels.derivatives``), one batched kernel call for all perturbations.
``zoh(A, B, dt)`` gives the sampled model ``y_{k+1} = Ad y_k + Bd u_k`` of an input held over
each step, as the envs apply their actions (the exact exponential of the augmented matrix).

A right-hand side that is not differentiable at ``y0`` (a friction sign at v = 0, a valve
edge at its lap) gives the mean of its one-sided slopes there; linearise where the model is
smooth (e.g. without dry friction, :meth:`hydro_envs.spec.PlantSpec.without_dry_friction`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["linearize", "zoh"]


def linearize(spec: Any, params: Any, y0: Any, u0: Any, *, rel: float = 1e-7,
              scale: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)``: Jacobians of the plant's right-hand side with respect to state and input at
    ``(y0, u0)``, central differences with steps ``rel * max(|y0_j|, scale_j)`` (``scale``
    default 1 per state; 1e-3 of the input range is used for the inputs, ``rel * max(|u0|, 1)``).
    ``spec`` is the plant's :class:`~hydro_envs.spec.PlantSpec`, ``params`` its parameter set."""
    y0 = np.asarray(y0, dtype=np.float64).reshape(-1)
    u0 = np.asarray(u0, dtype=np.float64).reshape(-1)
    ns, ni = y0.size, u0.size
    if ns != spec.n_states:
        raise ValueError(f"y0 has {ns} states; {spec.name} has {spec.n_states}")
    sc = np.ones(ns) if scale is None else np.asarray(scale, dtype=np.float64).reshape(ns)
    hy = rel * np.maximum(np.abs(y0), sc)
    hu = rel * np.maximum(np.abs(u0), 1.0)
    P = np.ascontiguousarray(params.to_array()[None, :])
    # copy 0: the state perturbations (2 ns rows) at u0; copies 1..2 ni: input perturbations at y0
    X = np.repeat(y0[None, None, :], 1 + 2 * ni, axis=0).repeat(2 * ns, axis=1)
    for j in range(ns):
        X[0, 2 * j, j] += hy[j]
        X[0, 2 * j + 1, j] -= hy[j]
    U = np.repeat(u0[None, None, :], 1 + 2 * ni, axis=0)
    for j in range(ni):
        U[1 + 2 * j, 0, j] += hu[j]
        U[2 + 2 * j, 0, j] -= hu[j]
    out = np.zeros_like(X)
    spec.kernels.derivatives(np.ascontiguousarray(X), np.ascontiguousarray(U),
                             np.ascontiguousarray(np.repeat(P, 1 + 2 * ni, axis=0)), out)
    A = np.empty((ns, ns))
    for j in range(ns):
        A[:, j] = (out[0, 2 * j] - out[0, 2 * j + 1]) / (2.0 * hy[j])
    B = np.empty((ns, ni))
    for j in range(ni):
        B[:, j] = (out[1 + 2 * j, 0] - out[2 + 2 * j, 0]) / (2.0 * hu[j])
    return A, B


def zoh(A: Any, B: Any, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Ad, Bd)`` of ``dy/dt = A y + B u`` with ``u`` held over each step of ``dt`` seconds:
    the exponential of ``[[A, B], [0, 0]] dt``."""
    from scipy.linalg import expm

    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = B
    E = expm(M * dt)
    return E[:n, :n], E[:n, n:]
