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
calls dominate its cost. Multiplied above and below by ``b P`` it needs one division, and its
parameter-only terms (:func:`ifas_constants`) can be computed once per parameter set
(:func:`ifas_bulk_modulus_scaled`, which :func:`ifas_bulk_modulus_fast` calls):

    E = b P ((1-a) + a q) / ((1-a)/E_0 P + a/kappa b q),
    q = exp((ln P_0 - ln P)/kappa + ln(b)/m),  b = 1 + (m/E_0)(P - P_0).

The shape of the modified law (eq (19)) likewise, with one ``exp`` for the two ``tanh``
(:func:`modified_ifas_shape_fast`, :func:`modified_ifas_shape_constants`).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.libm import exp, log

__all__ = ["ifas_bulk_modulus_fast", "ifas_bulk_modulus_scaled", "ifas_constants", "modified_ifas_shape_fast",
           "modified_ifas_shape_constants"]


@numba.njit(cache=True, error_model="numpy", inline="always")
def ifas_constants(e0, p0, m, alpha, kappa):
    """Parameter-only terms of :func:`ifas_bulk_modulus_scaled`: ``(m/E_0, 1/m, 1/kappa, ln P_0,
    (1-alpha)/E_0, alpha/kappa)`` (units 1/Pa, 1, 1, ln Pa, 1/Pa, 1)."""
    return m / e0, 1.0 / m, 1.0 / kappa, math.log(p0), (1.0 - alpha) / e0, alpha / kappa


@numba.njit(cache=True, error_model="numpy")
def ifas_bulk_modulus_scaled(p, p0, p_floor, alpha, m_over_e0, inv_m, inv_kappa, ln_p0, oil_over_e0,
                             alpha_over_kappa):
    """IFAS effective bulk modulus [Pa], 003 eq (13), from the terms of :func:`ifas_constants`
    (module docstring): one ``exp``, two ``log`` and one division per call. Pressure floor and
    oil-base floor (1e-12) as :func:`hydro_envs.laws.bulk_modulus.ifas_bulk_modulus`."""
    pp = p
    if pp < p_floor:
        pp = p_floor
    base = 1.0 + m_over_e0 * (pp - p0)
    if base < 1e-12:
        base = 1e-12
    q = exp(inv_kappa * (ln_p0 - log(pp)) + inv_m * log(base))  # air over oil: r^(1/kappa) b^(1/m)
    return base * pp * ((1.0 - alpha) + alpha * q) / (oil_over_e0 * pp + alpha_over_kappa * (base * q))


@numba.njit(cache=True, error_model="numpy", inline="always")
def ifas_bulk_modulus_fast(p, e0, p0, m, alpha, kappa, p_floor):
    """IFAS effective bulk modulus [Pa], 003 eq (13), one ``exp`` and two ``log`` calls.

    Same arguments, units, pressure floor and oil-base floor (1e-12) as
    :func:`hydro_envs.laws.bulk_modulus.ifas_bulk_modulus`:
    p = P [Pa abs], e0 = E_0 [Pa], p0 = P_0 [Pa], m [-], alpha [-], kappa [-],
    p_floor [Pa] -> E [Pa]. :func:`ifas_bulk_modulus_scaled` with :func:`ifas_constants`.
    """
    m_e0, inv_m, inv_kappa, ln_p0, oil_e0, alpha_kappa = ifas_constants(e0, p0, m, alpha, kappa)
    return ifas_bulk_modulus_scaled(p, p0, p_floor, alpha, m_e0, inv_m, inv_kappa, ln_p0, oil_e0, alpha_kappa)


@numba.njit(cache=True, error_model="numpy", inline="always")
def modified_ifas_shape_constants(lambda_1, lambda_2, mu, p_lt):
    """Parameter-only terms of :func:`modified_ifas_shape_fast`: with ``C = exp(-2 mu |P_Lt|)``,
    ``(2 lambda_2 sign(P_Lt) (1 - C^2), C^2, 1 + C^2, x_far)``. ``x_far`` (>= 0; inf for
    ``lambda_1 <= 0``) is the distance from the notch's edge, in units of ``1/mu``, beyond which
    the shape rounds to ``lambda_1`` exactly: ``x_far = ln(|amp| 2^56 / lambda_1) / 2``, where the
    notch term, at most ``|amp| exp(-2 x)``, is below ``lambda_1 2^-55``, under a quarter of the
    spacing of float64 numbers at ``lambda_1``, with room for the term's own rounding."""
    c = math.exp(-2.0 * mu * abs(p_lt))
    amp = 2.0 * lambda_2 * (1.0 - c * c)
    if lambda_1 <= 0.0:
        x_far = math.inf
    elif amp == 0.0:
        x_far = 0.0
    else:
        x_far = max(0.0, 0.5 * math.log(abs(amp) * 2.0**56 / lambda_1))
    return (amp if p_lt >= 0.0 else -amp), c * c, 1.0 + c * c, x_far


@numba.njit(cache=True, error_model="numpy")
def modified_ifas_shape_fast(p_a, p_b, lambda_1, mu, p_lt, amp, c2, one_plus_c2, x_far):
    """Load-pressure shape h(P_a, P_b) of 003 eq (19) with one ``exp``, from the terms of
    :func:`modified_ifas_shape_constants` (``mu >= 0``).

    The bracket ``tanh(a + k) - tanh(a - k)`` (``a = mu (P_a - P_b)``, ``k = mu |P_Lt|``; its
    sign goes with ``amp``) is ``2 sinh(2k) / (cosh(2a) + cosh(2k))``. With ``C = exp(-2k)`` and
    ``R = exp(-2 |x|)`` of the distance ``x = |a| - k`` from the notch's edge it is
    ``2 R (1 - C^2) / (1 + R (1 + C^2) + R^2 C^2)`` outside the notch (``x >= 0``) and
    ``2 (1 - C^2) / (1 + C^2 + R + C^2 / R)`` inside (``C <= R`` there): every term in [0, 1] or
    at least 1, so no overflow or lost precision for any argument. Beyond ``x_far`` the outside
    form rounds to ``lambda_1`` and is not evaluated (the same number, without its ``exp``).
    Units: p_a, p_b [Pa], lambda_1 [-], mu [1/Pa], p_lt [Pa]; amp, c2, one_plus_c2, x_far [-] -> [-].
    Source: ``003_54985feb8193da53.txt`` eq (19) (reference:
    :func:`hydro_envs.laws.bulk_modulus.modified_ifas_shape`).
    """
    x = mu * (abs(p_a - p_b) - abs(p_lt))
    if x > x_far:
        return lambda_1
    r = exp(-2.0 * abs(x))
    if x >= 0.0:
        return lambda_1 - amp * r / (1.0 + r * (one_plus_c2 + r * c2))
    return lambda_1 - amp / (one_plus_c2 + r + (c2 / r if r > 0.0 else 0.0))
