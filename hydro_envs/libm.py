"""``exp`` and ``log`` for compiled code: the C library's computing routines, called directly.

numba compiles ``math.exp`` to a call of its helper ``numba_exp``, which jumps to the C library's
``exp``; glibc's ``exp`` is a wrapper that calls the routine that computes (chosen for the CPU when
the library loads) and then checks the result, to set ``errno`` on overflow. ``log`` likewise. On
glibc, compiled :func:`exp` and :func:`log` call the computing routines directly, by the names
glibc exports them under (``__exp_finite``, ``__log_finite``, version ``GLIBC_2.15``). The numbers
are the same, since the wrappers return the routine's result (checked when this module loads, and
tested over each function's whole range; only ``log`` of a negative number gives a NaN of the
other sign), in a third less time per call: an ``exp`` and a ``log`` in a loop 7.5 -> 5.2 ns here,
the shaking table's right-hand side, with nine of them, 9 % less. Where those names are missing or
disagree, compiled code calls numba's helpers, as ``math.exp`` and ``math.log`` do. Called from
Python (a law's ``py_func``) they are ``math.exp`` and ``math.log``.

Compiled code reaches the routines through two symbols this module registers with the JIT linker
when it is imported (``hydro_envs_exp``, ``hydro_envs_log``), so that kernels cached on disk that
call them load in any process that imports the laws.
"""

from __future__ import annotations

import ctypes
import math

import llvmlite.binding as ll
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

__all__ = ["exp", "log", "USES_GLIBC_ROUTINES"]

#: arguments of the load-time check: ``exp`` from -700 to 700, ``log`` from 1e-300 to 1e300
_EXP_PROBES = tuple(x / 8.0 for x in range(-5600, 5601, 37))
_LOG_PROBES = tuple(1.37 * 10.0 ** (k / 4.0) for k in range(-1200, 1200, 7)) + (0.5, 1.0, 2.0)


def _glibc_routine(name: str) -> int | None:
    """Address of glibc's ``__<name>_finite`` (version GLIBC_2.15), or None if there is none."""
    try:
        libm = ctypes.CDLL("libm.so.6")
        dlvsym = ctypes.CDLL(None).dlvsym
    except (OSError, AttributeError):  # not glibc
        return None
    dlvsym.restype = ctypes.c_void_p
    dlvsym.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_char_p]
    return dlvsym(libm._handle, f"__{name}_finite".encode(), b"GLIBC_2.15") or None


def _agrees(address: int, reference, args) -> bool:
    """Whether the routine at ``address`` returns ``reference``'s numbers, bit for bit, on ``args``."""
    routine = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(address)
    return all(routine(a).hex() == reference(a).hex() for a in args)


def _numba_helpers() -> tuple[int, int] | None:
    """Addresses of the helpers numba's ``math.exp``/``math.log`` call (numba's C helper table,
    the one numba registers them from), or None if this numba has no such table."""
    try:
        from numba import _helperlib

        return _helperlib.c_helpers["exp"], _helperlib.c_helpers["log"]  # type: ignore[attr-defined]
    except (ImportError, AttributeError, KeyError):
        return None


def _install() -> bool | None:
    """Register ``hydro_envs_exp``/``hydro_envs_log`` with the JIT linker: True if they are glibc's
    routines, False if numba's helpers, None if neither is found (then compiled :func:`exp` and
    :func:`log` are ``math.exp`` and ``math.log``)."""
    exp_at, log_at = _glibc_routine("exp"), _glibc_routine("log")
    direct = (exp_at is not None and log_at is not None
              and _agrees(exp_at, math.exp, _EXP_PROBES) and _agrees(log_at, math.log, _LOG_PROBES))
    if not direct:
        helpers = _numba_helpers()
        if helpers is None:
            return None
        exp_at, log_at = helpers
    ll.add_symbol("hydro_envs_exp", exp_at)
    ll.add_symbol("hydro_envs_log", log_at)
    return direct


#: whether compiled :func:`exp` and :func:`log` call glibc's routines directly (False: numba's
#: helpers; None: ``math.exp``/``math.log``)
USES_GLIBC_ROUTINES = _install()


def _external_call(symbol: str):
    """An intrinsic ``float64 -> float64`` that calls the registered ``symbol``."""

    @intrinsic
    def call(typingctx, x):
        if not isinstance(x, types.Float) or x.bitwidth != 64:
            return None

        def codegen(context, builder, sig, args):
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.DoubleType(), [ir.DoubleType()]),
                                                symbol)
            fn.attributes.add("nounwind")
            fn.attributes.add("readnone")  # as LLVM's llvm.exp/llvm.log, which numba's math.exp/log lower to
            return builder.call(fn, args)

        return types.float64(x), codegen

    return call


_exp_call = _external_call("hydro_envs_exp")
_log_call = _external_call("hydro_envs_log")


def exp(x):
    """``e**x``: ``math.exp`` from Python; compiled, the C library's routine (module docstring)."""
    return math.exp(x)


def log(x):
    """Natural logarithm: ``math.log`` from Python; compiled, the C library's routine (module
    docstring)."""
    return math.log(x)


def _compile_as(function, call, fallback) -> None:
    """Compiled ``function(x)``: ``call`` (an intrinsic) on float64, ``fallback`` (``math``'s) on other
    numbers, or on every number if no routine is registered."""

    @overload(function)
    def compiled(x):
        if isinstance(x, types.Float) and x.bitwidth == 64 and USES_GLIBC_ROUTINES is not None:
            return lambda x: call(x)
        if isinstance(x, (types.Integer, types.Float)):
            return lambda x: fallback(x)
        return None


_compile_as(exp, _exp_call, math.exp)
_compile_as(log, _log_call, math.log)
