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

from hydro_envs.libm import exp, log

__all__ = [
    "chamber_pressure_rate",
    "wall_heat_flow",
    "cylinder_chamber_wall_area",
    "tube_convection_coefficient",
    "tube_convection_slope_bound",
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


#: air at 20 C and 1 bar (Incropera and DeWitt, Fundamentals of Heat and Mass Transfer, 6th ed.,
#: Table A.4): dynamic viscosity [Pa s], thermal conductivity [W/(m K)], Prandtl number
AIR_VISCOSITY = 1.81e-5
AIR_CONDUCTIVITY = 0.0257
AIR_PRANDTL = 0.71
#: Nusselt number of fully developed laminar flow in a tube at constant wall temperature (ibid. eq 8.55)
NU_LAMINAR = 3.66
_DITTUS_BOELTER = 0.023 * AIR_PRANDTL**0.4


@numba.njit(cache=True, error_model="numpy", inline="always")
def tube_convection_coefficient(mass_flow, bore):
    """Convective coefficient h [W/(m^2 K)] of air flowing through a tube of inner diameter
    ``bore`` [m] at mass flow ``mass_flow`` [kg/s] (either sign) to its wall.

    ``h = Nu k / d`` with ``Nu = max(3.66, 0.023 Re^0.8 Pr^0.4)``, ``Re = 4 |mdot| / (pi d mu)``:
    the Dittus-Boelter correlation of turbulent tube flow (Incropera and DeWitt eq 8.60, heating of
    the gas: exponent 0.4) and the fully developed laminar floor (eq 8.55); the larger of the two,
    so the transition (Re 700-1e4, where Gnielinski's correlation lies between them) takes the
    turbulent branch. Air properties at 20 C (Table A.4).
    """
    re = 4.0 * abs(mass_flow) / (3.141592653589793 * bore * AIR_VISCOSITY)
    nu = NU_LAMINAR
    if re > 600.0:
        nu_t = _DITTUS_BOELTER * exp(0.8 * log(re))
        if nu_t > nu:
            nu = nu_t
    return nu * AIR_CONDUCTIVITY / bore


@numba.njit(cache=True, error_model="numpy")
def tube_convection_slope_bound(bore):
    """Largest slope ``dh/d|mdot|`` [W/(m^2 K) per kg/s] of :func:`tube_convection_coefficient`:
    on the Dittus-Boelter branch ``0.8 h / |mdot|``, largest where it meets the laminar floor
    (``Re_c = (3.66 / (0.023 Pr^0.4))^(1/0.8)``, about 670); 0 below."""
    re_c = exp(log(NU_LAMINAR / _DITTUS_BOELTER) / 0.8)
    mdot_c = re_c * 3.141592653589793 * bore * AIR_VISCOSITY / 4.0
    return 0.8 * NU_LAMINAR * AIR_CONDUCTIVITY / bore / mdot_c


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
