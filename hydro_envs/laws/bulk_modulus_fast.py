"""IFAS effective bulk modulus with two powers instead of four (same law, for hot loops).

Source: ``003_54985feb8193da53.txt`` eq (13) (reference implementation:
:func:`hydro_envs.laws.bulk_modulus.ifas_bulk_modulus`, which this function equals to
rounding; tested). With ``b = 1 + m (P - P_0)/E_0`` and ``r = P_0 / P`` eq (13) needs
``b^(-1/m)``, ``b^(-(m+1)/m)``, ``r^(1/kappa)`` and ``r^((kappa+1)/kappa)``; the identities

    b^(-(m+1)/m) = b^(-1/m) / b,        r^((kappa+1)/kappa) = r^(1/kappa) * r

halve the number of ``pow`` calls. The shaking-table right-hand side evaluates the law for
both chambers four times per RK4 sub-step, where the powers dominate its cost.
"""

from __future__ import annotations

import numba

__all__ = ["ifas_bulk_modulus_fast"]


@numba.njit(cache=True, error_model="numpy", inline="always")
def ifas_bulk_modulus_fast(p, e0, p0, m, alpha, kappa, p_floor):
    """IFAS effective bulk modulus [Pa], 003 eq (13), two ``pow`` calls.

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
    oil = base ** (-1.0 / m)  # (1 + m (P - P0)/E0)^(-1/m)
    air = r ** (1.0 / kappa)  # (P0/P)^(1/kappa)
    num = (1.0 - alpha) * oil + alpha * air
    den = ((1.0 - alpha) / e0) * (oil / base) + (alpha / (kappa * p0)) * (air * r)
    return num / den
