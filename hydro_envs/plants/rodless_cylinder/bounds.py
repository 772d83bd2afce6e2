"""Worst-case rates of the rodless cylinder's stiff modes that the kernels refine locally.

:func:`hydro_envs.plants.rodless_cylinder.model.stiffness_modes` sizes the sub-step from the
modes that are stiff everywhere (spool, gas spring, bristles while stuck, wall heat). Three
modes are stiff only in a small part of the state space, and a sub-step there is taken as
finer ones (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`):

* ``orifice``: the laminar tail of the flow law (eqs (3)-(4) or ISO 6358) when the pressures
  across a metering edge are within ``1 - r_l`` of each other (a chamber filled to supply or
  vented to the exhaust);
* ``friction_slip`` (LuGre) or ``friction_static`` (static curve): the bristle relaxation
  ``sigma0 |v| / F_c`` at speed, or the static curve's steep part near v = 0;
* ``end_stop``: the bumper in contact.

This module gives their worst cases over the state space (pressures up to 1.5 p_s,
temperatures up to 1.5 T_s, the speed bound, full thrust on the bumper): the most fine
sub-steps the kernels take; elsewhere they size them from the local rates. Functions of the parameter set (a
:class:`~hydro_envs.plants.rodless_cylinder.params.RodlessCylinderParams`), plain Python.
"""

from __future__ import annotations

import math
from typing import Any

from hydro_envs.jit import as_python
from hydro_envs.laws.seal_friction import (
    bristle_block_rate_bound, dissipative_fade_velocity, stribeck_slope_ratio_bound,
)

__all__ = ["piston_area", "speed_bound", "full_thrust", "smallest_chamber_volume", "local_mode_rates"]


def piston_area(params: Any) -> float:
    """Piston area ``A = pi D^2 / 4`` [m^2] (4.909 cm^2 for the 25 mm bore)."""
    return 0.25 * math.pi * params.bore**2


def speed_bound(params: Any) -> float:
    """Upper estimate of the slider speed [m/s].

    In sliding the viscous term limits the speed to where ``sigma v + F_c`` balances the
    largest steady pressure force ``A (p_s - p_e) + |F_L|``. Without viscous friction the
    bound is the speed reached by that force acting over the whole stroke.
    """
    a = piston_area(params)
    f_drive = a * (params.supply_pressure - params.exhaust_pressure) + abs(params.load_force)
    v_energy = math.sqrt(2.0 * f_drive * params.stroke / params.mass)
    if params.viscous_friction > 0.0:
        return min(max(f_drive - params.coulomb_friction, 0.0) / params.viscous_friction, v_energy)
    return v_energy


def full_thrust(params: Any) -> float:
    """Largest pressure force [N] on the slider, ``A (1.5 p_s - p_floor)`` (compression above
    supply in a closed chamber)."""
    return piston_area(params) * (1.5 * params.supply_pressure - params.pressure_floor)


def smallest_chamber_volume(params: Any) -> float:
    """Smallest chamber volume [m^3]: the smaller dead volume less the bumper's penetration
    under full thrust plus an impact at the speed bound (not below ``min_chamber_volume``)."""
    m = params.mass
    pen = (full_thrust(params) / params.stop_stiffness
           + speed_bound(params) * math.sqrt(m / params.stop_stiffness))
    return max(min(params.dead_volume_a, params.dead_volume_b) - piston_area(params) * pen,
               params.min_chamber_volume)


def local_mode_rates(params: Any, orifice_rate_volume: float) -> dict[str, float]:
    """Worst-case Jacobian eigenvalue magnitudes [1/s] of the locally refined modes.

    ``orifice_rate_volume`` [m^3/s]: ``kappa R T_max`` times the laminar-tail slope of the
    fully open edge (``D_ORIFICE`` of the kernel parameter array); over the smallest chamber
    volume it is the ``orifice`` rate. Every damping that acts on the slider at once is summed
    (they share the velocity row of the Jacobian): viscous sigma, LuGre's ``2 sigma1`` and the
    Hunt-Crossley stop damping at full thrust ``alpha F_max``.

    * ``friction_slip`` (LuGre): :func:`~hydro_envs.laws.seal_friction.bristle_block_rate_bound`
      at the speed bound with the bristles deflected to ``F_s / sigma0``, viscous sigma and the
      stop damping on the slider;
    * ``friction_static`` (static curve): the regularised sign's slope ``F_s / v_eps``, the
      Stribeck dip ``|F_s - F_c| / v_s``, sigma and the stop damping, over M;
    * ``end_stop``: ``sqrt(k/M)`` (or the bristles' ``sqrt(sigma0/M)`` if larger) plus the
      dampings over M.
    """
    m = params.mass
    stop = params.stop_damping * full_thrust(params)
    damping = params.viscous_friction + stop
    rates = {"orifice": orifice_rate_volume / smallest_chamber_volume(params)}
    s0 = params.bristle_stiffness
    if s0 > 0.0:
        v_d = dissipative_fade_velocity(params.bristle_damping, params.stribeck_velocity, params.coulomb_friction)
        ratio = stribeck_slope_ratio_bound(params.coulomb_friction, params.static_friction, "exponential")
        rates["friction_slip"] = as_python(bristle_block_rate_bound)(
            speed_bound(params), params.static_friction / s0, params.coulomb_friction, ratio, s0,
            params.bristle_damping, v_d, damping, m, 1, 0.0)
        damping += 2.0 * params.bristle_damping
    else:
        rates["friction_static"] = (damping + params.static_friction / params.friction_sign_velocity
                                    + abs(params.static_friction - params.coulomb_friction)
                                    / params.stribeck_velocity) / m
    rates["end_stop"] = max(math.sqrt(params.stop_stiffness / m), math.sqrt(s0 / m)) + damping / m
    return rates
