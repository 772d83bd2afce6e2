"""Elementary functions for the compiled right-hand sides (pure numba scalar kernels).

``tanh_one_exp(x)``: the hyperbolic tangent from one ``exp``,

    tanh(x) = 1 - 2 / (exp(2 x) + 1),

about three times cheaper than libm's ``tanh`` (which goes through ``expm1``; 5.6 against
14.8 ns here). It is odd up to rounding and saturates at +-1 beyond ``|x| = 20``,
where ``tanh`` is +-1 in float64. Its absolute error is at most about 2e-16 for every ``x``;
its relative error grows as ``1e-16 / |x|`` below ``|x|`` of about 0.5, so it suits the
regularised signs and smooth steps of the laws (forces, moduli), not quantities divided by
``x`` afterwards. Tested against ``math.tanh``.
"""

from __future__ import annotations

import math

import numba

__all__ = ["tanh_one_exp"]


@numba.njit(cache=True, error_model="numpy")
def tanh_one_exp(x):
    """``tanh(x)`` as ``1 - 2 / (exp(2 x) + 1)``; absolute error <= ~2e-16; +-1 beyond |x| = 20."""
    z = 2.0 * x
    if z > 40.0:
        return 1.0
    if z < -40.0:
        return -1.0
    return 1.0 - 2.0 / (math.exp(z) + 1.0)
