"""Compressible orifice flow of 004 eqs (3)-(4) with precomputed constants (numba, SI).

:func:`hydro_envs.laws.orifice.pneumatic_mass_flow_laminar` recomputes the critical ratio,
the choked flow function and the laminar-tail constant (four ``pow`` calls) on every call,
and evaluates the subsonic flow function with two more. Inside a right-hand side where kappa
is a run-time parameter the compiler cannot hoist them, and four metering edges per
evaluation make them the plant's largest cost (about 60 ns per edge). Here the constants
come from :func:`nozzle_flow_constants`, computed once per parameter set, and the subsonic
branch uses one ``log`` and one ``exp`` (``q = r^(1/k)``)::

    r^(2/k) - r^((k+1)/k) = q^2 - r q = q (q - r)

The result equals ``pneumatic_mass_flow_laminar`` to round-off (tests: relative 1e-12).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.libm import exp, log

__all__ = ["nozzle_flow_constants", "nozzle_mass_flow_fast", "nozzle_mass_flow_slope_fast"]


@numba.njit(cache=True, error_model="numpy")
def nozzle_flow_constants(kappa, ratio_lam):
    """Constants of the 004 eqs (3)-(4) flow function for :func:`nozzle_mass_flow_fast`.

    Returns ``(crit, psi_choked, psi_lam, inv_kappa, coef)``: the critical ratio
    ``c_0 = (2/(k+1))^(k/(k-1))``, the choked flow function
    ``sqrt(2k/(k+1) (2/(k+1))^(2/(k-1)))``, the subsonic flow function at ``ratio_lam``,
    ``1/k`` and ``coef = 2k/(k-1)``. Units: kappa [-] (> 1), ratio_lam [-] in (c_0, 1).
    Source: ``004_f1423316a055addb.txt`` eqs (3)-(4) and c_0.
    """
    crit = (2.0 / (kappa + 1.0)) ** (kappa / (kappa - 1.0))
    psi_c = math.sqrt(2.0 * kappa / (kappa + 1.0) * (2.0 / (kappa + 1.0)) ** (2.0 / (kappa - 1.0)))
    coef = 2.0 * kappa / (kappa - 1.0)
    q = ratio_lam ** (1.0 / kappa)
    psi_lam = math.sqrt(coef * max(q * (q - ratio_lam), 0.0))
    return crit, psi_c, psi_lam, 1.0 / kappa, coef


@numba.njit(cache=True, error_model="numpy", inline="always")
def nozzle_mass_flow_fast(cd_area, p_up, p_down, sqrt_rt_up, ratio_lam, crit, psi_c, psi_lam, inv_kappa, coef):
    """Mass flow of 004 eqs (3)-(4) with a linear tail above ``ratio_lam`` (constants given).

    Same law, same reverse-flow convention and same laminar tail as
    :func:`hydro_envs.laws.orifice.pneumatic_mass_flow_laminar` (``cd_area`` = C S):
    flow from the higher to the lower pressure, positive for ``p_up > p_down``;
    ``sqrt_rt_up = sqrt(R T_up)`` with T_up the temperature of the side the gas comes from
    (the caller's choice, so a chamber computes its root once for all its edges).
    With ``q = r^(1/k)`` the subsonic bracket is ``r^(2/k) - r^((k+1)/k) = q (q - r)``: one
    ``log`` and one ``exp`` per call.
    Units: cd_area [m^2], p_up, p_down [Pa abs], sqrt_rt_up [m/s], ratio_lam [-] and the
    constants of :func:`nozzle_flow_constants` -> [kg/s].
    """
    if p_up >= p_down:
        s = 1.0
        pu = p_up
        pd = p_down
    else:
        s = -1.0
        pu = p_down
        pd = p_up
    if pu <= 0.0:
        return 0.0
    ratio = max(pd / pu, 0.0)
    if ratio <= crit:
        psi = psi_c
    elif ratio <= ratio_lam:
        q = exp(inv_kappa * log(ratio))
        t = q * (q - ratio)
        psi = math.sqrt(coef * t) if t > 0.0 else 0.0
    else:
        psi = psi_lam * (1.0 - ratio) / (1.0 - ratio_lam)
    return s * cd_area * pu * psi / sqrt_rt_up


@numba.njit(cache=True, error_model="numpy", inline="always")
def nozzle_mass_flow_slope_fast(cd_area, p_1, p_2, sqrt_rt_up, ratio_lam, crit, psi_c, psi_lam, inv_kappa, coef):
    """:func:`nozzle_mass_flow_fast` from ``p_1`` to ``p_2`` and its derivative with respect to
    ``p_1`` at fixed ``p_2`` (same arguments): ``(mdot [kg/s], d mdot / d p_1 [kg/(s Pa)])``.

    With ``K = cd_area / sqrt_rt_up`` and the flow function ``psi(r)``: for ``p_1 >= p_2``,
    ``mdot = K p_1 psi(p_2 / p_1)`` and the slope is ``K (psi(r) - r psi'(r))``; for
    ``p_1 < p_2``, ``mdot = -K p_2 psi(p_1 / p_2)`` and the slope is ``K psi'(r)`` in magnitude
    (positive: more ``p_1`` means less back-flow). ``psi' = 0`` choked, ``coef (q' (2 q - r) - q)
    / (2 psi)`` subsonic with ``q = r^(1/k)``, ``q' = q / (k r)``, ``-psi_lam / (1 - ratio_lam)``
    on the linear tail.
    """
    if p_1 >= p_2:
        pu = p_1
        pd = p_2
        forward = True
    else:
        pu = p_2
        pd = p_1
        forward = False
    if pu <= 0.0:
        return 0.0, 0.0
    k = cd_area / sqrt_rt_up
    r = max(pd / pu, 0.0)
    if r <= crit:
        psi = psi_c
        dpsi = 0.0
    elif r <= ratio_lam:
        q = exp(inv_kappa * log(r))
        t = q * (q - r)
        if t > 0.0:
            psi = math.sqrt(coef * t)
            dpsi = coef * (inv_kappa * q / r * (2.0 * q - r) - q) / (2.0 * psi)
        else:
            psi = 0.0
            dpsi = 0.0
    else:
        psi = psi_lam * (1.0 - r) / (1.0 - ratio_lam)
        dpsi = -psi_lam / (1.0 - ratio_lam)
    if forward:
        return k * pu * psi, k * (psi - r * dpsi)
    return -k * pu * psi, -k * dpsi
