"""``simulate()``: batched fixed-step trajectories of any plant, in one compiled call.

Sample-and-hold convention (the one every experiment, record and identification method
uses): input row ``u[k]`` is held over ``[t_k, t_k+1)``; state row ``x[k]`` is the state at
``t_k``. With ``T`` input rows the result has ``T + 1`` state rows, the first being ``x0``.

Sub-steps come from each parameter set's stiffness bound
(:func:`hydro_envs.sim.stiffness.substeps_from_stiffness`) unless ``n_sub`` is given.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hydro_envs._numba_cache import ensure_fresh_cache
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, substeps_from_stiffness

__all__ = ["simulate", "substeps"]


def substeps(spec: Any, params: Any, dt: float, safety: float = DEFAULT_SAFETY) -> int:
    """RK4 sub-steps per ``dt`` for one parameter set of plant ``spec`` (stiffness bound)."""
    return substeps_from_stiffness(spec.stiffness_modes(params), dt, safety)[0]


def _param_rows(spec: Any, params: Any) -> tuple[np.ndarray, list[Any] | None, bool]:
    """Kernel parameter rows ``(n, n_params)``, the parameter objects (None for raw arrays)
    and whether a single set was given."""
    cls = spec.params_cls
    if isinstance(params, cls):
        return params.to_array()[None, :], [params], True
    if isinstance(params, np.ndarray):
        arr = np.atleast_2d(np.asarray(params, dtype=np.float64))
        return np.ascontiguousarray(arr), None, params.ndim == 1
    if isinstance(params, Sequence) and params and all(isinstance(p, cls) for p in params):
        return np.stack([p.to_array() for p in params]), list(params), False
    raise TypeError(
        f"params must be a {cls.__name__}, a sequence of them or an array of kernel parameter rows, "
        f"got {type(params).__name__}"
    )


def simulate(
    spec: Any,
    params: Any,
    u: Any,
    x0: Any,
    dt: float,
    *,
    n_sub: int | Sequence[int] | np.ndarray | None = None,
    safety: float = DEFAULT_SAFETY,
    clamps: np.ndarray | None = None,
) -> np.ndarray:
    """Trajectories of plant ``spec`` (a :class:`hydro_envs.spec.PlantSpec`).

    ``params``: one parameter set, a sequence of ``n`` sets, or kernel rows ``(n, n_params)``
    (then ``n_sub`` is required). ``u``: ``(T,)``, ``(T, n_in)`` shared by every copy, or
    ``(n, T, n_in)``. ``x0``: ``(n_states,)`` or ``(n, n_states)``. ``dt``: hold time [s].
    Returns states ``(T + 1, n_states)`` for one set, one start state and shared inputs,
    else ``(n, T + 1, n_states)``. ``clamps`` (``(n,)`` int64), if given, receives the guard
    counts.
    """
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be finite and > 0, got {dt}")
    ensure_fresh_cache()  # before the first kernel is compiled or loaded from the cache
    P, objs, single_p = _param_rows(spec, params)
    X0 = np.atleast_2d(np.asarray(x0, dtype=np.float64))
    ns = X0.shape[1]
    # a plant whose state width depends on its parameters (its contract's n_states_for, e.g.
    # the number of pipe segments) may use fewer than its n_states columns
    variable = spec.contract.n_states_for is not None
    if ns != spec.n_states and not (variable and 0 < ns <= spec.n_states):
        raise ValueError(
            f"x0 must have {spec.n_states} states ({', '.join(spec.state_names)}), got shape {np.shape(x0)}"
        )
    U = np.asarray(u, dtype=np.float64)
    shared_u = U.ndim <= 2
    if U.ndim == 1:
        U = U[:, None]
    if U.ndim == 2:
        U = U[None, :, :]
    if U.ndim != 3:
        raise ValueError(f"u must be (T,), (T, n_inputs) or (n, T, n_inputs), got shape {np.shape(u)}")
    n = max(P.shape[0], X0.shape[0], U.shape[0])
    for what, arr in (("params", P), ("x0", X0), ("u", U)):
        if arr.shape[0] not in (1, n):
            raise ValueError(f"{what} has {arr.shape[0]} copies, others have {n}")
    if not np.all(np.isfinite(U)):
        raise ValueError("u must be finite")
    if not np.all(np.isfinite(X0)):
        raise ValueError("x0 must be finite")
    P = np.ascontiguousarray(np.broadcast_to(P, (n, P.shape[1])))
    X0 = np.ascontiguousarray(np.broadcast_to(X0, (n, ns)))
    U = np.ascontiguousarray(np.broadcast_to(U, (n,) + U.shape[1:]))
    if n_sub is None:
        if objs is None:
            raise ValueError("n_sub is required when params are given as kernel rows")
        steps = [substeps(spec, p, dt, safety) for p in objs]
        NSUB = np.array(steps * (n if len(steps) == 1 else 1), dtype=np.int64)
    else:
        NSUB = np.broadcast_to(np.asarray(n_sub, dtype=np.int64), (n,)).copy()
        if np.any(NSUB < 1):
            raise ValueError(f"n_sub must be >= 1, got {n_sub}")
    out = np.empty((n, U.shape[1] + 1, ns))
    W = np.zeros((n, 5, ns))
    counts = np.zeros(n, dtype=np.int64)
    spec.kernels.trajectories(X0, U, P, float(dt), NSUB, W, out, counts)
    if clamps is not None:
        clamps[...] = counts
    if single_p and np.ndim(x0) == 1 and shared_u:
        return out[0]
    return out
