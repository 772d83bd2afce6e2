"""Stiff reference solutions with ``scipy.integrate.solve_ivp`` (Radau), for tests and benches.

The same compiled right-hand side the fixed-step kernel uses is integrated by an implicit,
adaptive, error-controlled method under a zero-order-held input. The solver is restarted at
every change of the input so it never integrates across a discontinuity. This is slow
(milliseconds per env step) and exists only to measure the fixed-step kernel's error.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["reference_rollout"]


def reference_rollout(
    spec: Any,
    y0: np.ndarray,
    inputs: np.ndarray,
    params: np.ndarray,
    dt: float,
    *,
    rtol: float = 1e-10,
    atol: np.ndarray | float = 1e-12,
) -> np.ndarray:
    """States at ``t = 0, dt, ..., n dt`` of plant ``spec`` (a :class:`hydro_envs.spec.PlantSpec`)
    under ``inputs`` of shape ``(n, n_inputs)``, input row ``k`` held over ``[k dt, (k+1) dt)``.

    Consecutive equal input rows are integrated in one solve. Returns ``(n + 1, n_states)``.
    """
    plant_rhs = spec.kernels.rhs
    inputs = np.atleast_2d(np.asarray(inputs, dtype=np.float64))
    params = np.ascontiguousarray(params, dtype=np.float64)
    y = np.array(y0, dtype=np.float64)
    n = inputs.shape[0]
    out = np.empty((n + 1, y.size))
    out[0] = y
    k = 0
    while k < n:
        k_end = k + 1
        while k_end < n and np.array_equal(inputs[k_end], inputs[k]):
            k_end += 1
        u = np.ascontiguousarray(inputs[k])

        def f(_t, state, u=u):
            dy = np.empty_like(state)
            plant_rhs(np.ascontiguousarray(state), u, params, dy)
            return dy

        t_eval = dt * np.arange(k + 1, k_end + 1)
        sol = solve_ivp(
            f, (dt * k, dt * k_end), y, method="Radau", t_eval=t_eval, rtol=rtol, atol=atol
        )
        if not sol.success:
            raise RuntimeError(f"reference solve failed on [{dt * k}, {dt * k_end}] s: {sol.message}")
        out[k + 1 : k_end + 1] = sol.y.T
        y = sol.y[:, -1].copy()
        k = k_end
    return out
