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

__all__ = ["nozzle_flow_constants", "nozzle_mass_flow_fast"]


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
        q = math.exp(inv_kappa * math.log(ratio))
        t = q * (q - ratio)
        psi = math.sqrt(coef * t) if t > 0.0 else 0.0
    else:
        psi = psi_lam * (1.0 - ratio) / (1.0 - ratio_lam)
    return s * cd_area * pu * psi / sqrt_rt_up
