"""IFAS effective bulk modulus with one exponential and two logarithms (same law, for hot loops).

Source: ``003_54985feb8193da53.txt`` eq (13) (reference implementation:
:func:`hydro_envs.laws.bulk_modulus.ifas_bulk_modulus`, which this function equals to
rounding; tested). With ``b = 1 + m (P - P_0)/E_0`` and ``r = P_0 / P`` eq (13) reads

           (1-a) b^(-1/m)           + a r^(1/kappa)
    E = -----------------------------------------------------
        (1-a)/E_0 b^(-1/m) / b + a/(kappa P_0) r^(1/kappa) r

and, divided above and below by the oil's ``b^(-1/m)``, needs only the ratio of the air's
volume term to the oil's, ``q = r^(1/kappa) b^(1/m) = exp(ln(r)/kappa + ln(b)/m)``:

    E = ((1-a) + a q) / ((1-a)/(E_0 b) + a r q/(kappa P_0)).

One ``exp`` and two ``log`` instead of the four ``pow`` of the printed form: the shaking-table
right-hand side evaluates the law for both chambers four times per RK4 sub-step, where these
calls dominate its cost.
"""

from __future__ import annotations

import math

import numba

__all__ = ["ifas_bulk_modulus_fast"]


@numba.njit(cache=True, error_model="numpy", inline="always")
def ifas_bulk_modulus_fast(p, e0, p0, m, alpha, kappa, p_floor):
    """IFAS effective bulk modulus [Pa], 003 eq (13), one ``exp`` and two ``log`` calls.

    Same arguments, units, pressure floor and oil-base floor (1e-12) as
    :func:`hydro_envs.laws.bulk_modulus.ifas_bulk_modulus`:
    p = P [Pa abs], e0 = E_0 [Pa], p0 = P_0 [Pa], m [-], alpha [-], kappa [-],
    p_floor [Pa] -> E [Pa].
    """
    pp = p
    if pp < p_floor:
        pp = p_floor
    base = 1.0 + m * (pp - p0) / e0
    if base < 1e-12:
        base = 1e-12
    r = p0 / pp
    q = math.exp(math.log(r) / kappa + math.log(base) / m)  # air over oil: r^(1/kappa) b^(1/m)
    return ((1.0 - alpha) + alpha * q) / ((1.0 - alpha) / (e0 * base) + (alpha / (kappa * p0)) * (r * q))
