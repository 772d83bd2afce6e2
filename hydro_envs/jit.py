"""How the package compiles a function that allocates nothing: ``njit_noalloc``.

``njit_noalloc`` is ``numba.njit(cache=True, error_model="numpy", _nrt=False)``: cached on disk,
NumPy's error model (a division by zero gives inf or nan instead of raising), and without
numba's runtime (NRT). The runtime counts references to every array a compiled function
receives or slices: an atomic increment and decrement per array and call of a function that
numba does not inline. Its pruning pass removes such pairs only within simple control flow
(numba issues #2345 and #2350), so a plant's right-hand side, called four times per RK4
sub-step with its state, input, parameter and derivative rows, paid about ten atomic
operations per call. Without the runtime there are none, and numba refuses at compile time
what would need it: allocating an array ("No implementation of function ... empty") or
returning a view ("Only accept returning of array passed into the function as argument").

The plants' step kernels, right-hand sides, guards, refinement rules and energy terms, the
envs' observation kernels and the filter step they use are compiled this way; the serial step
kernels of 1024 copies run 7-21 % faster with the same results to the bit (``docs/speed.md``).
The laws, scalar functions that are also called on arrays from Python, keep the runtime, as do
parallel kernels (``parallel=True``); a function compiled inline (``inline="always"``) takes
the options of the function it is inlined into.

``as_python`` gives a compiled function's plain Python twin for one-off calls from Python
(parameter analysis at make or reset): ``f.py_func`` alone still calls the compiled functions it
names, and each such call from Python compiles that function in a cold process (a law's
compile costs 0.1-0.9 s; the same law in Python takes microseconds per call).
"""

from __future__ import annotations

import types
from typing import Any

import numba
from numba.core.registry import CPUDispatcher

__all__ = ["NOALLOC_OPTIONS", "njit_noalloc", "as_python"]

#: numba options of :func:`njit_noalloc`
NOALLOC_OPTIONS = {"cache": True, "error_model": "numpy", "_nrt": False}

#: ``@njit_noalloc``: compile a function that allocates no array and returns no view
njit_noalloc = numba.njit(**NOALLOC_OPTIONS)


_PYTHON: dict[Any, Any] = {}


def _names(code: types.CodeType) -> set[str]:
    """The global names ``code`` and the code objects nested in it read."""
    names = set(code.co_names)
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            names |= _names(c)
    return names


def as_python(f: Any) -> Any:
    """The plain Python function of the compiled (``numba.njit``) function ``f``: its ``py_func``
    with every compiled function among the globals it reads replaced by theirs, recursively, so
    that calling it compiles nothing (the same arithmetic; ``math`` from Python where numba
    calls the same C library). ``f`` itself when it is not compiled; memoised."""
    if not isinstance(f, CPUDispatcher):
        return f
    py = f.py_func
    if py in _PYTHON:
        return _PYTHON[py]
    namespace = dict(py.__globals__)
    twin = types.FunctionType(py.__code__, namespace, py.__name__, py.__defaults__, py.__closure__)
    twin.__doc__, twin.__qualname__, twin.__module__ = py.__doc__, py.__qualname__, py.__module__
    _PYTHON[py] = twin
    for name in _names(py.__code__):
        if isinstance(namespace.get(name), CPUDispatcher):
            namespace[name] = as_python(namespace[name])
    return twin
