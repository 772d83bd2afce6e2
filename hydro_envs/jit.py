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
"""

from __future__ import annotations

import numba

__all__ = ["NOALLOC_OPTIONS", "njit_noalloc"]

#: numba options of :func:`njit_noalloc`
NOALLOC_OPTIONS = {"cache": True, "error_model": "numpy", "_nrt": False}

#: ``@njit_noalloc``: compile a function that allocates no array and returns no view
njit_noalloc = numba.njit(**NOALLOC_OPTIONS)
