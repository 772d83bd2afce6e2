"""Worst-case rates [1/s] of the shaking table's fast modes, split by where they are stiff.

:func:`stiffness_modes` hold everywhere (the spool, the oil springs on the table, the friction's
slope, the end-stop contact): they set the RK4 sub-step. The spool enters with the sub-step its
*accuracy* needs rather than its stability (:data:`SPOOL_H_OMEGA`): the command changes every env
step and the spool's transient carries the flow. :func:`local_mode_rates` are stiff only in a
small part of the state space, and the kernels take a sub-step there as finer ones
(:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`, :func:`.model.local_mode_substeps`):

* ``orifice``: the laminar core of the regularised orifice law (003 eqs (1)-(2): slope
  ``1/sqrt(dp_tr)`` at zero drop, falling like ``|dp|^(-1/2)`` away from it) and the leaks
  (eqs (8)-(9)) into the smallest chamber: stiff only while a chamber is within a few ``dp_tr``
  of the supply or the tank pressure. Working drops are tens of bar, where the slope is a
  fifth of its zero-drop value or less.
* ``relief``: an open port relief (:mod:`hydro_envs.laws.relief`, above ``relief_pressure``),
  whose slope is up to ``q_rated / p_override`` -- as steep as the open valve's laminar core:
  stiff only while a chamber is above its cracking pressure (braking, a stop).

Three features are not modes a rate bounds, and the kernels refine a sub-step across them too
(:func:`.model.local_mode_substeps`): the kinks of the metering openings (eq (3) at
``x_v = +-U`` and the stroke limit, where the flow's slope in ``x_v`` jumps and RK4 stepping
across loses its order), the edges of the modified-IFAS notch (eq (19), ``h`` moves by
``lambda_2`` over ``1/mu`` = 0.5-2.5 bar of load pressure, which a reversal sweeps in a fraction
of a sub-step) and the air-release band of IFAS (eq (13)) below :func:`air_release_pressure`,
where ``E ~ P^((kappa+1)/kappa)``: a chamber emptying towards cavitation or refilling changes
its pressure by orders of magnitude within a millisecond, a mode of its own pressure whose rate
``(1 + 1/kappa) |dP/dt| / P`` sets the fine steps (:data:`ACCURATE_H_LAMBDA`,
:func:`.model.air_band_substeps`).

Functions of a :class:`~hydro_envs.plants.shaking_table.params.ShakingTableParams`, plain Python.
"""

from __future__ import annotations

import math
from typing import Any

from hydro_envs.jit import as_python
from hydro_envs.laws.bulk_modulus import ifas_bulk_modulus
from hydro_envs.laws.relief import pressure_relief_conductance_bound
from hydro_envs.laws.seal_friction import bristle_stiffness_bound, dissipative_fade_velocity, stribeck_slope_ratio_bound
from hydro_envs.sim.rk4 import STABLE_H_LAMBDA
from hydro_envs.sim.roots import brent_root

__all__ = ["ACCURATE_H_LAMBDA", "SPOOL_H_OMEGA", "AIR_COMPLIANCE_SHARE", "stiffness_modes", "local_mode_rates",
           "modulus_upper_bound", "air_release_pressure", "friction_bounds", "friction_rate", "relief_conductance"]

#: the env's velocity limit in no-load velocities (hydro_envs.envs.base.VELOCITY_FACTOR)
_VELOCITY_FACTOR = 2.0

#: ``h |lambda|`` at which RK4's error per step on a mode ``e^(lambda t)``, about
#: ``(h |lambda|)^5 / 120`` of its value (the leading term of ``R(z) - e^z``), is 1e-4
ACCURATE_H_LAMBDA = (120.0 * 1e-4) ** 0.2
#: ``h w_0`` at which RK4's error per step on the spool's oscillation is 1e-4 of its amplitude
SPOOL_H_OMEGA = ACCURATE_H_LAMBDA
#: share of the chamber compliance the air of IFAS (eq (13)) takes at :func:`air_release_pressure`
AIR_COMPLIANCE_SHARE = 0.01


def relief_conductance(p: Any) -> float:
    """Largest slope [m^3/(s Pa)] of a chamber's port relief over all pressures
    (:func:`~hydro_envs.laws.relief.pressure_relief_conductance_bound`; the law's Python body)."""
    return float(as_python(pressure_relief_conductance_bound)(p.relief_pressure - p.tank_pressure, p.relief_override,
                                                           p.relief_flow))


def modulus_upper_bound(p: Any, p_hi: float | None = None) -> float:
    """Largest chamber modulus [Pa] for pressures up to ``p_hi`` (default the larger of 1.5 P_s
    and the reliefs' full-flow pressure; IFAS grows with P, h is at most max(lambda_1, h(0)))."""
    if p_hi is None:
        p_hi = max(1.5 * p.supply_pressure, p.relief_pressure + p.relief_override)
    if p.bulk_modulus_model == 0.0:
        return p.e0
    # the law's Python body: the same arithmetic without compiling it when a parameter set is made
    e = float(as_python(ifas_bulk_modulus)(p_hi, p.e0, p.p0, p.oil_exponent, p.air_content, p.polytropic_exponent,
                                        p.pressure_floor))
    if p.bulk_modulus_model == 2.0:
        h_notch = p.lambda_1 - 2.0 * p.lambda_2 * math.tanh(p.mu * p.threshold_pressure)
        e *= max(p.lambda_1, h_notch)
    return e


def _orifice_conductance(p: Any) -> float:
    """Zero-drop slope [m^3/(s Pa)] of the fully open metering edge with the underlap edge,
    and the leaks: ``R (1 + 2U) / sqrt(dp_tr) + 2 C_il + C_el``."""
    return (p.flow_coefficient * (1.0 + 2.0 * p.underlap) / math.sqrt(p.orifice_transition_pressure)
            + 2.0 * p.internal_leakage + p.external_leakage)


def friction_bounds(p: Any) -> dict[str, float]:
    """Bounds of the seals' LuGre friction over the state space (003 eq (11) as the steady
    state): the smallest sliding level ``g_min = F_c``, the largest ``g_max = max(F_s, F_c)``,
    the bristle deflection bound ``z_max = g_max / sigma0`` (LuGre keeps ``|z|`` inside it), the
    bound of ``|v g'| / g`` (Gaussian curve,
    :func:`~hydro_envs.laws.seal_friction.stribeck_slope_ratio_bound`) and the speed bound
    ``v_max`` = 2 x the no-load velocity (the env's velocity limit). ``g_max = 0``: no dry
    friction."""
    g_max = max(p.static_friction, p.coulomb_friction)
    v_nl = p.flow_coefficient * (1.0 + p.underlap) * math.sqrt(0.5 * (p.supply_pressure - p.tank_pressure)) \
        / p.piston_area
    return {"g_min": p.coulomb_friction, "g_max": g_max, "z_max": g_max / p.bristle_stiffness,
            "slope_ratio": stribeck_slope_ratio_bound(p.coulomb_friction, p.static_friction, "gaussian"),
            "v_max": _VELOCITY_FACTOR * v_nl}


def friction_rate(p: Any) -> float:
    """Upper bound [1/s] of the (velocity, bristle) block of the table on its seals over all
    speeds (:func:`~hydro_envs.laws.seal_friction.bristle_stiffness_bound`, the lightest mass
    ``M_b + M_s``, the viscous F_v as the other damping): the pre-sliding oscillation at rest
    and the bristle relaxation at speed, capped at ``bristle_relaxation_cap``."""
    b = friction_bounds(p)
    v_d = dissipative_fade_velocity(p.bristle_damping, p.stribeck_velocity, p.coulomb_friction)
    return bristle_stiffness_bound(b["g_min"], b["g_max"], b["slope_ratio"], p.bristle_stiffness, p.bristle_damping,
                                   v_d, p.viscous_friction, p.platform_mass + p.specimen_mass, 1,
                                   p.bristle_relaxation_cap, b["v_max"])


def stiffness_modes(p: Any) -> dict[str, float]:
    """Upper estimates [1/s] of the modes that are stiff everywhere (module docstring):

    * ``valve``: spool poles ``|lambda| = w_0`` (eq (5)), scaled by ``STABLE_H_LAMBDA /
      SPOOL_H_OMEGA`` so that the stability bound gives the sub-step with ``h w_0 <=``
      :data:`SPOOL_H_OMEGA` (accuracy, not stability: stable up to ``h w_0 = 2.2``).
    * ``hydraulic``: oil springs on the lightest mass at the stroke end,
      ``sqrt(A^2 E_max (1/V_0 + 1/(V_0 + A L)) / M)``.
    * ``friction``: the velocity-bristle block of the LuGre seals (:func:`friction_rate`): the
      table's pre-sliding oscillation on its bristles at rest and the bristle relaxation at
      speed, capped at ``bristle_relaxation_cap``; at least the Stribeck dip's steepest
      (negative) slope of eq (11), ``(F_s - F_c) sqrt(2/e) / v_s / M``.
    * ``end_stop``: contact spring ``sqrt(k/M)`` plus its damping ``alpha F_max / M``.

    Not bounded, by design: a pressure-dependent modulus adds ``dP'/dP = (dE/dP) F / V`` (F the
    net inflow), large only while the pressure sweeps through a band where E changes steeply
    (the notch edges and the air-release band, refined locally; module docstring).
    """
    m = p.platform_mass + p.specimen_mass
    a = p.piston_area
    e_max = modulus_upper_bound(p)
    v0 = max(p.dead_volume, p.min_chamber_volume)
    k_h = a * a * e_max * (1.0 / v0 + 1.0 / (v0 + a * p.stroke))
    dip = (p.static_friction - p.coulomb_friction) * math.sqrt(2.0 / math.e) / p.stribeck_velocity
    f_max = a * (1.5 * p.supply_pressure - p.pressure_floor)
    return {
        "valve": p.valve_natural_frequency * STABLE_H_LAMBDA / SPOOL_H_OMEGA,
        "hydraulic": math.sqrt(k_h / m),
        "friction": max(friction_rate(p), (dip + p.viscous_friction) / m),
        "end_stop": math.sqrt(p.stop_stiffness / m) + p.stop_damping * f_max / m,
    }


def local_mode_rates(p: Any) -> dict[str, float]:
    """Worst cases [1/s] of the modes the kernels refine locally (module docstring):

    * ``orifice``: ``E(P_s) / V_0 (R (1 + 2U) / sqrt(dp_tr) + 2 C_il + C_el)``, the zero-drop
      slope into the smallest chamber with the chamber at supply pressure (E evaluated at
      ``P_s + 10 dp_tr``); above P_s the reverse drop flattens it like ``|dp|^(-1/2)``, and at
      tank pressure E is small.
    * ``relief``: ``E_max / V_0 (G_relief + R (1 + 2U) / (d^2 + dp_tr^2)^(1/4) + 2 C_il + C_el)``
      with :func:`relief_conductance`: an open port relief on the smallest chamber; it is open
      only above ``relief_pressure``, where the metering edges see at least the drop
      ``d = relief_pressure - P_s`` (0 if the relief cracks below the supply).
    """
    e = modulus_upper_bound(p, p.supply_pressure + 10.0 * p.orifice_transition_pressure)
    v0 = max(p.dead_volume, p.min_chamber_volume)
    d = max(p.relief_pressure - p.supply_pressure, 0.0)
    edges = p.flow_coefficient * (1.0 + 2.0 * p.underlap) / math.sqrt(math.sqrt(d * d + p.orifice_transition_pressure**2))
    leak = 2.0 * p.internal_leakage + p.external_leakage
    return {"orifice": e / v0 * _orifice_conductance(p),
            "relief": modulus_upper_bound(p) / v0 * (relief_conductance(p) + edges + leak)}


def air_release_pressure(p: Any) -> float:
    """Pressure [Pa] below which the air of IFAS (eq (13)) takes more than
    :data:`AIR_COMPLIANCE_SHARE` of a chamber's compliance (the term with ``alpha`` in the
    denominator against the oil's); 0 for the constant modulus or no air. 10 bar at the
    modified-IFAS defaults (kappa = 0.49), 2.5 bar at the IFAS column's."""
    if p.bulk_modulus_model == 0.0 or p.air_content == 0.0:
        return 0.0

    def excess(pr: float) -> float:
        base = max(1.0 + p.oil_exponent * (pr - p.p0) / p.e0, 1e-12)
        oil = (1.0 - p.air_content) / p.e0 * base ** (-(p.oil_exponent + 1.0) / p.oil_exponent)
        air = p.air_content / (p.polytropic_exponent * p.p0) * (p.p0 / pr) ** ((p.polytropic_exponent + 1.0)
                                                                                / p.polytropic_exponent)
        return air - AIR_COMPLIANCE_SHARE * oil

    lo, hi = p.pressure_floor, 1.5 * p.supply_pressure
    if excess(lo) <= 0.0:
        return 0.0
    if excess(hi) >= 0.0:
        return hi
    return brent_root(excess, lo, hi, xtol=1.0, rtol=1e-10)
