"""Physics laws of hydro-envs: small pure numba kernels on float64 scalars, SI units.

Every public function is ``@numba.njit(cache=True)``, takes every argument explicitly and
cites its seed paper (seed number + equation number, ``docs/references.md``) in its docstring.

friction (:mod:`hydro_envs.laws.friction`)
    tanh_sign(v, v_eps)                               003 eq (12)
    coulomb_friction(v, f_c, v_eps)                   002 eq (1), 003 eq (11)
    viscous_friction(v, b)                            002 eq (1), 003 eq (11)
    stribeck_exponential(v, f_c, f_s, v_s, b, v_eps)  002 eq (1)
    stribeck_exponential_slope_bound(v, ...)          |dF/dv| of the above (sub-step control)
    stribeck_gaussian(v, f_c, f_s, v_s, b, v_eps)     003 eqs (11)-(12), v_eps = 1/beta
    dahl_friction_rate(v, f, f_c, sigma0)             001 eq (1), sigma0 = gamma f_c^2
    dahl_friction_step_exact(f, v, f_c, sigma0, dt)   001 eq (1), closed form
    lugre_g(v, f_c, f_s, v_s)                         LuGre (003 ref [30], 002 ref [6])
    lugre_bristle_rate(v, z, f_c, f_s, v_s, sigma0)   LuGre
    lugre_friction(v, z, zdot, sigma0, sigma1, sigma2)  LuGre
    lugre_bristle_step_exact(z, v, f_c, f_s, v_s, sigma0, dt)  LuGre, docs/references.md numerics
    karnopp_friction(v, f_applied, f_c, f_s, b, dv)   002 eq (1) stick branch, Karnopp

seal_friction (:mod:`hydro_envs.laws.seal_friction`): the dynamic friction of every sliding seal
    stribeck_curve_exponential(v, f_c, f_s, v_s)      002 eq (1), 004 Table 2 (steady level)
    stribeck_curve_gaussian(v, f_c, f_s, v_s)         003 eq (11) (steady level)
    bristle_rate(v, z, g, sigma0, exponent)           LuGre (n = 1), 001 eq (1) (n = 2)
    micro_damping(v, sigma1, v_d)                     sigma1 fading with speed (dissipative)
    quasi_static_weight(v, z, g, sigma0, exponent, rate_cap)   relaxation faster than rate_cap: static curve
    seal_friction(v, z, g, sigma0, sigma1, v_d, sigma2, exponent, rate_cap) -> (F, dz/dt)
    bristle_dissipation(v, z, F, dz, sigma0)          F v less the bristles' stored-energy rate
    bristle_block_rate_bound(v, z, g, slope_ratio, sigma0, sigma1, v_d, damping, mass, exponent, rate_cap)
    bristle_stiffness_bound(...)                      its maximum over the state space (Python)

orifice (:mod:`hydro_envs.laws.orifice`)
    regularized_signed_sqrt(dp, dp_tr)                Modelica regRoot / Hopsan (docs/references.md)
    regularized_signed_sqrt_slope_bound(dp, dp_tr)    its slope's bound (sub-step control)
    orifice_flow(cd, area, dp, rho, dp_tr)            002 eqs (3)-(4), 003 eqs (1)-(2)
    supply_pressure_at_flow(p_s, p_down, cd, area, rho, r_line)  supply droop (assumed linear)
    spool_edge_opening(x_v, x_lap)                    Hopsan valve laps (docs/references.md)
    underlap_orifice_opening(x_v, u_lap)              003 eq (3)
    circular_orifice_area(x, r)                       004 eq (2)
    pneumatic_critical_ratio(kappa)                   004 c_0 (after eq (4))
    pneumatic_mass_flow(cd, area, p_up, p_down, t_up, kappa, r_gas)      004 eqs (3)-(4)
    pneumatic_mass_flow_laminar(..., ratio_lam)       same, explicit laminar ratio
    iso6358_mass_flow(c_sonic, b_crit, p_up, p_down, t_up, t_ref, rho_ref)  ISO 6358
    iso6358_mass_flow_laminar(..., ratio_lam)         same, explicit laminar ratio

bulk_modulus (:mod:`hydro_envs.laws.bulk_modulus`)
    constant_bulk_modulus(p, e0)                      002 Table 1
    ifas_bulk_modulus(p, e0, p0, m, alpha, kappa, p_floor)               003 eq (13)
    modified_ifas_shape(p_a, p_b, lambda_1, lambda_2, mu, p_lt)          003 eq (19)
    modified_ifas_shape_is_valid(lambda_1, lambda_2, mu, p_lt)           003 eq (19), Table 2
    modified_ifas_bulk_modulus(p, p_a, p_b, e0, p0, m, alpha, kappa,
                               lambda_1, lambda_2, mu, p_lt, p_floor)    003 eqs (15)-(19)
    fluid_density(p, rho0, p0, beta)                  constant-beta liquid

valve (:mod:`hydro_envs.laws.valve`)
    second_order_valve_acceleration(x_v, v_v, u, k_v, omega_v, zeta_v)   002 eqs (2)/(8), 003 eq (5)
    saturate(x, lo, hi)                               Hopsan saturated spool

pipe (:mod:`hydro_envs.laws.pipe`)
    pipe_bore_area(d), pipe_inductance(rho, l, d)     000 eq (1)
    pipe_laminar_resistance(mu, l, d)                 000 eq (2) (printed L = length l)
    hydraulic_capacitance(volume, beta)               000 eq (3)
    rlc_flow_derivative(q, p_up, p_down, L, R)        000 eq (5)
    (pipe.line_transfer_function: exact distributed line, numpy, not re-exported)

relief (:mod:`hydro_envs.laws.relief`): pressure-relief valves (Hopsan / OpenHydraulics steady characteristic)
    relief_valve_opening(dp, p_crack, p_override)     opening linear from cracking to full
    pressure_relief_flow(dp, p_crack, p_override, q_rated)   opening x turbulent root, q_rated at full opening
    pressure_relief_conductance_bound(p_crack, p_override, q_rated)   its largest slope (sub-step control)
    linear_relief_flow(dp, p_crack, gradient)         linear characteristic above cracking

pneumatic_chamber (:mod:`hydro_envs.laws.pneumatic_chamber`)
    chamber_pressure_rate(p, vol, dvol, enthalpy_flow, kappa, r_gas, heat_flow)  004 eqs (10)-(13)
    chamber_temperature(p, vol, mass, r_gas)          ideal gas (004 before eq (10))
    wall_heat_flow(h, wall_area, t_wall, t_gas)       Q = h A_wall (T_wall - T) (Newton cooling)
    cylinder_chamber_wall_area(vol, piston_area, bore)  2 A + 4 V / D
    tube_convection_coefficient(mass_flow, bore)      h of air in a tube (Dittus-Boelter, laminar floor)
    tube_convection_slope_bound(bore)                 its largest dh/d|mdot|
    gas_internal_energy(p, vol, kappa)                U = p V / (kappa - 1)

stribeck_lugre (:mod:`hydro_envs.laws.stribeck_lugre`)
    stribeck_exponential_curve(v, f_c, f_s, v_s)      004 sec. 3.1, Table 2
    lugre_exponential_rate(v, z, f_c, f_s, v_s, sigma0)  LuGre with the 004 curve, Fig. 4

nozzle_fast (:mod:`hydro_envs.laws.nozzle_fast`)
    nozzle_flow_constants(kappa, ratio_lam)           004 eqs (3)-(4), c_0
    nozzle_mass_flow_fast(cd_area, p_up, p_down, sqrt_rt_up, ratio_lam, *constants)  same law, pow-free

bulk_modulus_fast (:mod:`hydro_envs.laws.bulk_modulus_fast`)
    ifas_bulk_modulus_fast(p, e0, p0, m, alpha, kappa, p_floor)          003 eq (13), exp + 2 log
    ifas_constants(e0, p0, m, alpha, kappa)           003 eq (13), parameter-only terms
    ifas_bulk_modulus_scaled(p, p0, p_floor, alpha, *constants)          same law, one division
    modified_ifas_shape_constants(lambda_1, lambda_2, mu, p_lt)          003 eq (19), parameter-only terms
    modified_ifas_shape_fast(p_a, p_b, lambda_1, mu, p_lt, *constants)   same shape, one exp

filters (:mod:`hydro_envs.laws.filters`)
    butterworth_lowpass_sos(order, cutoff_hz, sample_rate_hz)            003 sec. 4 (order 8, 40 Hz);
        a Python/scipy design helper, import it from hydro_envs.laws.filters (not re-exported)
    sos_filter_step(sos, zi, x)                       scipy sosfilt recursion, one sample
    backward_difference(x, x_prev, dt)                003 sec. 4 (differentiated position)

hysteresis (:mod:`hydro_envs.laws.hysteresis`)
    play_operator(p, u, r)                            001 sec. 3.3 (Preisach / Prandtl-Ishlinskii)
    pi_threshold_scale(width, reversal_slope, n)      major-loop width -> play thresholds
    pi_output(u, memory, width, reversal_slope)       Prandtl-Ishlinskii output

elementary (:mod:`hydro_envs.laws.elementary`)
    tanh_one_exp(x)                                   tanh from one exp (hot loops; abs. error <= 2e-16)

viscosity (:mod:`hydro_envs.laws.viscosity`)
    iso_vg_kinematic_viscosity(grade, temperature_c)  ISO 3448 + ASTM D341 + D2270 (VI 100)
    vi100_viscosity_at_100c(nu40_cst)                 ASTM D2270 H column (mm^2/s helper)
    dynamic_viscosity(nu, rho)

The modified-IFAS constants printed in 003 Table 2 give a negative modulus at mid stroke;
the valid default set is documented in :mod:`hydro_envs.laws.bulk_modulus`.
"""

from hydro_envs.laws.bulk_modulus import (
    constant_bulk_modulus,
    fluid_density,
    ifas_bulk_modulus,
    modified_ifas_bulk_modulus,
    modified_ifas_shape,
    modified_ifas_shape_is_valid,
)
from hydro_envs.laws.friction import (
    coulomb_friction,
    dahl_friction_rate,
    dahl_friction_step_exact,
    karnopp_friction,
    lugre_bristle_rate,
    lugre_bristle_step_exact,
    lugre_friction,
    lugre_g,
    stribeck_exponential,
    stribeck_exponential_slope_bound,
    stribeck_gaussian,
    tanh_sign,
    viscous_friction,
)
from hydro_envs.laws.orifice import (
    PNEUMATIC_LAMINAR_RATIO,
    circular_orifice_area,
    iso6358_mass_flow,
    iso6358_mass_flow_laminar,
    orifice_flow,
    pneumatic_critical_ratio,
    pneumatic_mass_flow,
    pneumatic_mass_flow_laminar,
    regularized_signed_sqrt,
    regularized_signed_sqrt_slope_bound,
    spool_edge_opening,
    supply_pressure_at_flow,
    underlap_orifice_opening,
)
from hydro_envs.laws.pipe import (
    hydraulic_capacitance,
    pipe_bore_area,
    pipe_inductance,
    pipe_laminar_resistance,
    rlc_flow_derivative,
)
from hydro_envs.laws.relief import (
    linear_relief_flow,
    pressure_relief_conductance_bound,
    pressure_relief_flow,
    relief_valve_opening,
)
from hydro_envs.laws.pneumatic_chamber import (
    chamber_pressure_rate,
    chamber_temperature,
    cylinder_chamber_wall_area,
    gas_internal_energy,
    tube_convection_coefficient,
    tube_convection_slope_bound,
    wall_heat_flow,
)
from hydro_envs.laws.nozzle_fast import nozzle_flow_constants, nozzle_mass_flow_fast
from hydro_envs.laws.stribeck_lugre import lugre_exponential_rate, stribeck_exponential_curve
from hydro_envs.laws.hysteresis import pi_output, pi_threshold_scale, play_operator
from hydro_envs.laws.valve import saturate, second_order_valve_acceleration
from hydro_envs.laws.bulk_modulus_fast import (
    ifas_bulk_modulus_fast,
    ifas_bulk_modulus_scaled,
    ifas_constants,
    modified_ifas_shape_constants,
    modified_ifas_shape_fast,
)
from hydro_envs.laws.filters import backward_difference, sos_filter_step
from hydro_envs.laws.elementary import tanh_one_exp
from hydro_envs.laws.viscosity import (
    dynamic_viscosity,
    iso_vg_kinematic_viscosity,
    vi100_viscosity_at_100c,
)

__all__ = [
    # friction
    "tanh_sign",
    "coulomb_friction",
    "viscous_friction",
    "stribeck_exponential",
    "stribeck_exponential_slope_bound",
    "stribeck_gaussian",
    "dahl_friction_rate",
    "dahl_friction_step_exact",
    "lugre_g",
    "lugre_bristle_rate",
    "lugre_friction",
    "lugre_bristle_step_exact",
    "karnopp_friction",
    # orifice
    "regularized_signed_sqrt",
    "regularized_signed_sqrt_slope_bound",
    "orifice_flow",
    "spool_edge_opening",
    "supply_pressure_at_flow",
    "underlap_orifice_opening",
    "circular_orifice_area",
    "pneumatic_critical_ratio",
    "pneumatic_mass_flow",
    "pneumatic_mass_flow_laminar",
    "iso6358_mass_flow",
    "iso6358_mass_flow_laminar",
    "PNEUMATIC_LAMINAR_RATIO",
    # bulk modulus
    "constant_bulk_modulus",
    "ifas_bulk_modulus",
    "modified_ifas_shape",
    "modified_ifas_shape_is_valid",
    "modified_ifas_bulk_modulus",
    "fluid_density",
    "ifas_bulk_modulus_fast",
    "ifas_bulk_modulus_scaled",
    "ifas_constants",
    "modified_ifas_shape_constants",
    "modified_ifas_shape_fast",
    # elementary
    "tanh_one_exp",
    # filters
    "sos_filter_step",
    "backward_difference",
    # valve
    "second_order_valve_acceleration",
    "saturate",
    # pipe
    "pipe_bore_area",
    "pipe_inductance",
    "pipe_laminar_resistance",
    "hydraulic_capacitance",
    "rlc_flow_derivative",
    # relief valves
    "relief_valve_opening",
    "pressure_relief_flow",
    "pressure_relief_conductance_bound",
    "linear_relief_flow",
    # pneumatic chamber
    "chamber_pressure_rate",
    "chamber_temperature",
    "gas_internal_energy",
    "wall_heat_flow",
    "cylinder_chamber_wall_area",
    "tube_convection_coefficient",
    "tube_convection_slope_bound",
    # exponential Stribeck / LuGre
    "stribeck_exponential_curve",
    "lugre_exponential_rate",
    "nozzle_flow_constants",
    "nozzle_mass_flow_fast",
    # hysteresis
    "play_operator",
    "pi_threshold_scale",
    "pi_output",
    # viscosity
    "iso_vg_kinematic_viscosity",
    "vi100_viscosity_at_100c",
    "dynamic_viscosity",
]
