"""One factory for every plant's compiled kernels: :func:`bind_rk4`.

A plant's ``kernels.py`` binds its right-hand side and guard (and, for a plant stepped with the
look-ahead integrator, its local refinement rule) to the shared RK4 loops of
:mod:`hydro_envs.sim.rk4`::

    KERNELS = bind_rk4("servo_cylinder", rhs, guard)
    step_serial, step_parallel = KERNELS.step_serial, KERNELS.step_parallel   # module level

The four kernels (``step_serial``, ``step_parallel``, ``trajectories``, ``derivatives``) are the
templates below, compiled per plant. numba's ``cache=True`` does not reuse a closure's cached
code across processes (it hashes the pickled closure cells), so each kernel is a new function
from a template's code with its own globals (the plant's ``rhs``, ``guard``, ...) and its own
qualified name ``<name>.<kernel>``: numba caches it on disk beside this file under that name
(``__pycache__/binding.<name>.<kernel>-<line>.py*.nbi``), one entry per plant and kernel, and
the compiled arithmetic is the template's, the same as a hand-written module-level kernel.
Stale caches are dropped by :mod:`hydro_envs._numba_cache` when any source changes.
"""

from __future__ import annotations

import re
import types
from collections.abc import Callable
from typing import Any

import numba as nb

from hydro_envs.contract import KernelSet
from hydro_envs.jit import NOALLOC_OPTIONS
from hydro_envs.sim.rk4 import in_blocks, rhs_along, rk4_advance, rk4_advance_lookahead, rk4_trajectory
from hydro_envs.sim.rk4 import rk4_trajectory_lookahead

__all__ = ["bind_rk4", "function_instance"]

_PARALLEL = {"cache": True, "error_model": "numpy", "parallel": True}
_njit: Any = nb.njit  # the options are passed as mappings
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.]*")

# ------------------------------------------------------------------ templates (globals bound per plant)
# names a template reads from its globals: rhs, guard, refinement, refinement_count, step_serial,
# nb and the rk4 loops


def _step_serial(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        clamps[i] += rk4_advance(rhs, guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])  # type: ignore[name-defined]  # noqa: F821


def _step_serial_lookahead(Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        h = dt / NSUB[i]
        clamps[i] += rk4_advance_lookahead(rhs, guard, refinement, Y[i], U[i], P[i], h, NSUB[i],  # type: ignore[name-defined]  # noqa: F821
                                           refinement_count(P[i], h), W[i])  # type: ignore[name-defined]  # noqa: F821


def _step_parallel(Y, U, P, dt, NSUB, W, clamps):
    """``step_serial`` over blocks of copies on threads (bit-identical to it)."""
    in_blocks(step_serial, Y, U, P, dt, NSUB, W, clamps)  # type: ignore[name-defined]  # noqa: F821


def _trajectories(Y0, U, P, dt, NSUB, W, OUT, clamps):
    """Whole trajectories ``OUT[i] (T + 1, n_states)`` under inputs ``U[i] (T, n_in)``."""
    for i in nb.prange(Y0.shape[0]):
        clamps[i] += rk4_trajectory(rhs, guard, Y0[i], U[i], P[i], dt, NSUB[i], W[i], OUT[i])  # type: ignore[name-defined]  # noqa: F821


def _trajectories_lookahead(Y0, U, P, dt, NSUB, W, OUT, clamps):
    """Whole trajectories ``OUT[i] (T + 1, n_states)`` under inputs ``U[i] (T, n_in)``."""
    for i in nb.prange(Y0.shape[0]):
        m = refinement_count(P[i], dt / NSUB[i])  # type: ignore[name-defined]  # noqa: F821
        clamps[i] += rk4_trajectory_lookahead(rhs, guard, refinement, Y0[i], U[i], P[i], dt, NSUB[i], m,  # type: ignore[name-defined]  # noqa: F821
                                              W[i], OUT[i])


def _derivatives(X, U, P, OUT):
    """``OUT[i, k]`` = the right-hand side at state ``X[i, k]`` under ``U[i, min(k, T - 1)]``."""
    for i in nb.prange(X.shape[0]):
        rhs_along(rhs, X[i], U[i], P[i], OUT[i])  # type: ignore[name-defined]  # noqa: F821


def function_instance(template: Callable[..., Any], name: str, kernel: str, namespace: dict[str, Any]) -> Any:
    """``template``'s code as a new function reading ``namespace``, qualified ``<name>.<kernel>``."""
    code = template.__code__.replace(co_name=kernel)
    f = types.FunctionType(code, namespace, kernel)
    f.__doc__ = template.__doc__
    f.__qualname__ = f"{name}.{kernel}"
    return f


def bind_rk4(name: str, rhs: Any, guard: Any, lookahead: tuple[Any, Any] | None = None,
             for_params: Callable[[Any], KernelSet] | None = None) -> KernelSet:
    """The compiled kernels of right-hand side ``rhs`` and guard ``guard`` (numba functions
    ``rhs(y, u, p, dy)``, ``guard(y, p) -> clamped``), named ``name`` (letters, digits, '_' and
    '.'; unique per binding: it keys numba's disk cache).

    ``lookahead = (refinement, refinement_count)``: step with
    :func:`~hydro_envs.sim.rk4.rk4_advance_lookahead` (``refinement(y0, x, p, h, m)`` the fine
    steps of one sub-step, ``refinement_count(p, h)`` their worst case ``m``); ``None``:
    :func:`~hydro_envs.sim.rk4.rk4_advance`. ``for_params``: see :class:`KernelSet`."""
    if not isinstance(name, str) or not _NAME_RE.fullmatch(name):
        raise ValueError(f"bind_rk4: name {name!r} is invalid; allowed letters, digits, '_' and '.'")
    ns: dict[str, Any] = {"__name__": __name__, "__builtins__": __builtins__, "nb": nb, "rhs": rhs, "guard": guard,
                          "in_blocks": in_blocks, "rhs_along": rhs_along, "rk4_advance": rk4_advance,
                          "rk4_advance_lookahead": rk4_advance_lookahead, "rk4_trajectory": rk4_trajectory,
                          "rk4_trajectory_lookahead": rk4_trajectory_lookahead}
    if lookahead is not None:
        ns["refinement"], ns["refinement_count"] = lookahead
    serial = _njit(**NOALLOC_OPTIONS)(
        function_instance(_step_serial if lookahead is None else _step_serial_lookahead, name, "step_serial", ns))
    ns["step_serial"] = serial
    return KernelSet(
        step_serial=serial,
        step_parallel=_njit(**_PARALLEL)(function_instance(_step_parallel, name, "step_parallel", ns)),
        trajectories=_njit(**_PARALLEL)(
            function_instance(_trajectories if lookahead is None else _trajectories_lookahead, name, "trajectories", ns)),
        derivatives=_njit(**_PARALLEL)(function_instance(_derivatives, name, "derivatives", ns)),
        rhs=rhs, guard=guard, for_params=for_params, name=name,
    )
