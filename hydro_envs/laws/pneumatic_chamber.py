"""Pneumatic chamber laws: ideal-gas control volume with mass and energy balance (numba, SI).

Source: ``004_f1423316a055addb.txt`` eqs (8)-(13) (mass continuity of a chamber, ideal gas,
isentropic state change) and eq (16) (linearised at the supply temperature T_s).

The seed derives its chamber equation (13) by assuming the whole chamber gas follows the
isentropic relation (11) ``T = T0 (p/p0)^((kappa-1)/kappa)``. That is exact for a sealed
chamber, but a chamber that is being filled receives gas at the *supply* temperature, not at
its own. We therefore write the first law for an open, adiabatic control volume of an ideal
gas with constant heat capacities (internal energy ``U = p V / (kappa - 1)``)::

    dm/dt = sum_i mdot_i                                                  (8), (9)
    dU/dt = c_p sum_i mdot_i T_i - p dV/dt + Q
    =>  V dp/dt = kappa R sum_i mdot_i T_i - kappa p dV/dt + (kappa - 1) Q      (10)-(13)

with ``mdot_i`` counted *into* the chamber and ``T_i`` the temperature of the gas crossing the
boundary (the upstream side: T_s for supply inflow, the chamber's own T for outflow). With
``T_i = T`` for every stream this is exactly 004 eq (13) solved for dp/dt; with the valve
closed (no stream, Q = 0) it integrates to ``p V^kappa = const`` and, with the constant mass,
to eq (11) -- the seed's isentropic chamber. Linearised at ``T = T_s`` it is eq (16).
``Q`` is the heat flow from the wall into the gas (0: the seed's adiabatic chamber; a large
wall conductance drives the chamber towards isothermal, in between it is polytropic).
"""

from __future__ import annotations

import numba

__all__ = [
    "chamber_pressure_rate",
    "wall_heat_flow",
    "cylinder_chamber_wall_area",
    "chamber_temperature",
    "gas_internal_energy",
]


@numba.njit(cache=True, error_model="numpy")
def chamber_pressure_rate(p, vol, dvol, enthalpy_flow, kappa, r_gas, heat_flow):
    """Pressure rate of an ideal-gas chamber from its energy balance, 004 eqs (10)-(13).

        dp/dt = (kappa R H - kappa p dV/dt + (kappa - 1) Q) / V,   H = sum_i mdot_i T_i

    Units: p [Pa abs], vol [m^3] (> 0), dvol [m^3/s], enthalpy_flow H [kg K/s] (mass flow
    into the chamber times the temperature of the gas that crosses the boundary, summed over
    all ports), kappa [-], r_gas [J/(kg K)], heat_flow Q [W] (into the gas) -> [Pa/s].
    Source: ``004_f1423316a055addb.txt`` eq (13) (equal to it when every T_i is the chamber
    temperature), generalised by the first law for an open adiabatic control volume.
    """
    return (kappa * r_gas * enthalpy_flow - kappa * p * dvol + (kappa - 1.0) * heat_flow) / vol


@numba.njit(cache=True, error_model="numpy", inline="always")
def wall_heat_flow(h, wall_area, t_wall, t_gas):
    """Convective heat flow ``Q = h A_wall (T_wall - T)`` [W] from the wall into the gas.

    In :func:`chamber_pressure_rate` it enters as ``(kappa - 1) Q / V``; for a sealed chamber it
    is ``dT/dt = h A_wall (T_wall - T) / (m c_v)`` (Newton's law of cooling, the lumped wall
    model of pneumatic-cylinder thermodynamics), which moves the chamber's state change between
    the adiabatic (h = 0, 004 eq (11)) and the isothermal (h -> infinity) path.
    Units: h [W/(m^2 K)], wall_area [m^2], t_wall, t_gas [K] -> [W].
    """
    return h * wall_area * (t_wall - t_gas)


@numba.njit(cache=True, error_model="numpy", inline="always")
def cylinder_chamber_wall_area(vol, piston_area, bore):
    """Wetted wall area [m^2] of a cylinder chamber of volume ``vol``: a cylinder of the bore's
    diameter D holding the volume (its dead volume counted as more length), with its two end
    faces (piston and cover): ``A_wall = 2 A + 4 V / D`` (the lateral wall ``pi D l`` with
    ``l = V / A``, ``A = pi D^2 / 4``).
    Units: vol [m^3], piston_area [m^2], bore [m] -> [m^2].
    """
    return 2.0 * piston_area + 4.0 * vol / bore


@numba.njit(cache=True, error_model="numpy")
def chamber_temperature(p, vol, mass, r_gas):
    """Ideal-gas temperature ``T = p V / (m R)`` of a chamber (004, text before eq (10)).

    Units: p [Pa abs], vol [m^3], mass [kg] (> 0), r_gas [J/(kg K)] -> [K].
    """
    return p * vol / (mass * r_gas)


@numba.njit(cache=True, error_model="numpy")
def gas_internal_energy(p, vol, kappa):
    """Internal energy ``U = c_v m T = p V / (kappa - 1)`` of an ideal gas [J], taking U = 0 at T = 0.

    Units: p [Pa abs], vol [m^3], kappa [-] -> [J]. Used by the energy-balance tests: with the
    valve closed and no friction, kinetic energy plus the chambers' U is conserved (the
    boundary work ``p dV`` only moves energy between gas and slider).
    """
    return p * vol / (kappa - 1.0)
