"""Elementary functions for the compiled right-hand sides (pure numba scalar kernels).

``tanh_one_exp(x)``: the hyperbolic tangent from one ``exp``,

    tanh(x) = 1 - 2 / (exp(2 x) + 1),

about three times cheaper than libm's ``tanh`` (which goes through ``expm1``; 5.6 against
14.8 ns here). It is evaluated at ``|x|`` and given the sign of ``x``, so it is exactly odd
(a smooth sign built from it is symmetric to the bit, and ``tanh(-k) + tanh(k)`` is 0), and it
saturates at +-1 beyond ``|x| = 20``, where ``tanh`` is +-1 in float64. Its absolute error is at most about 2e-16 for every ``x``;
its relative error grows as ``1e-16 / |x|`` below ``|x|`` of about 0.5, so it suits the
regularised signs and smooth steps of the laws (forces, moduli), not quantities divided by
``x`` afterwards. Tested against ``math.tanh``.
"""

from __future__ import annotations

import numba

from hydro_envs.libm import exp

__all__ = ["tanh_one_exp"]


@numba.njit(cache=True, error_model="numpy")
def tanh_one_exp(x):
    """``tanh(x)`` as ``1 - 2 / (exp(2 |x|) + 1)`` with the sign of ``x``; exactly odd; absolute
    error <= ~2e-16; +-1 beyond |x| = 20."""
    a = abs(x)
    t = 1.0 if a > 20.0 else 1.0 - 2.0 / (exp(2.0 * a) + 1.0)
    return -t if x < 0.0 else t
