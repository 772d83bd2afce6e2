r"""Pneumatic mechanical rodless cylinder with a proportional 5/3 valve (seed 004).

Source: ``004_f1423316a055addb.txt`` -- "Experimental Simulation and Verification of Position
Servo Control of Mechanical Rodless Cylinder": Table 1 (SMC MYC25G-110L, bore 25 mm, stroke
110 mm; FESTO MPYE-5-M5-010-B, 0-10 V; supply 0.6 MPa), friction eq (1) and Table 2,
valve port area eq (2), compressible mass flow eqs (3)-(4), chambers eqs (8)-(13), slider
eq (18), linearised model eqs (5)-(7), (14)-(27).

State (SI, pressures absolute)::

    index  name  unit  meaning
    0      y     m     slider position, 0 at the chamber-a end of stroke, stroke at the other
    1      v     m/s   slider velocity (+: chamber a grows)
    2      pa    Pa    chamber-a pressure
    3      pb    Pa    chamber-b pressure
    4      ma    kg    air mass in chamber a (incl. its dead volume)
    5      mb    kg    air mass in chamber b
    6      xv    m     valve spool position (0 at the 5 V centre, +: P->A and B->R open)
    7      vv    m/s   spool velocity
    8      z     m     LuGre bristle deflection of the seals (pre-sliding; 0 in static mode)

Chamber temperatures follow from the state, ``T = p V / (m R)`` (:func:`chamber_temperatures`).

Input: ``u`` [V], valve command 0-10 V, closed centre at 5 V (MPYE-5 data sheet; 004 sec. 2).

Equations (numbers of 004)::

    y' = v
    M v' = A (pa - pb) - F_f - F_L + F_stop                                    (18)
    ma' = mdot(P->A) - mdot(A->R),   mb' = mdot(P->B) - mdot(B->R)              (8)-(9)
    Va pa' = kappa R H_a - kappa pa A v + (kappa-1) Q_a                       (10)-(13)
    Vb pb' = kappa R H_b + kappa pb A v + (kappa-1) Q_b
    Va = A y + V_dead,a,   Vb = A (L - y) + V_dead,b                            (15)
    mdot = C S(x) p_up / sqrt(R T_up) psi(p_down / p_up)                     (3)-(4)
    p_P = p_s - R_s mdot_P(p_P)   (supply droop; R_s = 0, a constant p_s, in 004)
    S(x) = r^2 acos((r - x)/r) - (r - x) sqrt(r^2 - (r - x)^2)                 (2)
    xv'' = -w_v^2 xv - 2 zeta_v w_v xv' + k_v w_v^2 (u - 5 V)                  (28) + lag
    F_f = sigma0 z + sigma1(v) z' + sigma v,  z' = v - sigma0 |v| z / g(v)    Table 2, Fig. 4
    g(v) = F_c + (F_s - F_c) exp(-|v| / v_s)                                   Table 2, Fig. 3

``H = sum mdot_i T_i`` is the enthalpy flow (mass flow into the chamber times the upstream
temperature: T_s from the supply, the chamber's own T for outflow, T_s for air drawn back
from the exhaust). Heat flow from the walls (:func:`chamber_wall_heat_flow`)
``Q = h A_cyl (T_s - T) + h_line(mdot) pi d L (T_s - T)``: the cylinder's wall
``A_cyl = 2 A + 4 (V - V_line) / D`` with the convective coefficient h =
``wall_heat_transfer_coefficient`` (:func:`hydro_envs.laws.pneumatic_chamber.wall_heat_flow`,
:func:`~hydro_envs.laws.pneumatic_chamber.cylinder_chamber_wall_area`), and the inner wall of
the tube to the valve (``line_length`` L, ``line_bore`` d, the part ``V_line = pi d^2 L / 4`` of
the dead volume) with the tube-flow coefficient of the chamber's net mass flow mdot
(:func:`~hydro_envs.laws.pneumatic_chamber.tube_convection_coefficient`, Dittus-Boelter with a
laminar floor): all the gas that fills or vents a chamber passes the tube, whose wall per
volume is ten times the cylinder's. h = 0: adiabatic, the seed's eq (11), the line's exchange
off too. A random-action soak cooled adiabatic chambers to 150-175 K, the cylinder wall alone
(h = 50 W/(m^2 K)) to 166 K (beyond draws: h 6.3 W/(m^2 K), supply 9.5 bar).

Decisions on the extracted text (see ``docs/references.md`` and the law docstrings):

* Eqs (3)-(4) are garbled (root closed early, ``p_b/(R T_b)``); we use the standard
  dimensionally consistent nozzle law, :func:`hydro_envs.laws.orifice.pneumatic_mass_flow`,
  with a linear (laminar) tail above the pressure ratio ``laminar_pressure_ratio`` (0.999,
  Simscape's default) -- the smooth choked/subsonic/zero-flow transition of docs/references.md. ISO 6358
  (C, b) is the alternative (``flow_model = 1``): sonic conductance proportional to the
  uncovered port area.
* Eq (2) is written for one port and one shoulder; ``x`` is the edge travel past the near rim
  of a port, ``x = x_v - (d - r)`` in 004's notation. A symmetric 5/3 valve has four metering
  edges; edge P->A and B->R open by ``x_v + u_lap``, A->R and P->B by ``u_lap - x_v`` with
  the underlap ``u_lap = r - d``. The paper's linearisation needs ``c_1, c_2 != 0`` at the
  centre (eqs (5)-(6)), i.e. an underlapped valve (d < r); a real MPYE-5 does leak at mid
  position. Eq (2) is printed up to x_v = d: the spool's full stroke is d (half a port).
* Eqs (10)-(13) assume the whole chamber gas is isentropic (eq (11)). We integrate the mass
  and the energy balance of each chamber (:mod:`hydro_envs.laws.pneumatic_chamber`): identical
  to eq (13) for a sealed chamber and to eq (16) when linearised at T_s, but filling with
  supply-temperature air is handled correctly. Mass is a state, so with the valve closed each
  chamber's mass is conserved exactly.
* Friction: 004 gives no formula. The construction of sec. 3.1 (tangent from F_s meets F_c
  at v_s) identifies the exponential Stribeck curve (:mod:`hydro_envs.laws.stribeck_lugre`).
  The conclusions' ``sigma = 3.27 mm/s`` is an extraction defect; Table 2's 0.31 N s/mm is
  used. Default: LuGre with that curve as steady state (004 Fig. 4 reports a pre-sliding
  displacement). ``bristle_stiffness = 0`` selects the static curve with a tanh sign
  (``friction_sign_velocity``). Cost: the static curve needs ``v_eps << v_s = 3.27 mm/s``;
  at v_eps = 1 mm/s its slope ``F_s / (M v_eps)`` is 7e4 1/s (34 RK4 sub-steps per 1 ms),
  at v_s/10 about 100, while LuGre with sigma0 = 1e5 N/m needs 5 at the nominal plant (4-6
  over the randomisation ranges; the bristle relaxation ``sigma0 |v| / F_c`` at the top speed
  and the laminar orifice core set it).
* Supply 0.6 MPa is read as gauge (Table 1's compressor "working pressure 0.4~0.7 MPa");
  pressures here are absolute (+101.325 kPa).

Guards (``docs/references.md``, numerics notes, Hopsan): pressures and gas masses never integrate below a floor
(1 Pa, 1e-12 kg: derivative clipped at the floor, state clamped after each sub-step), so
``T = p V / (m R)`` stays positive; chamber volumes never below ``min_chamber_volume``; end
stops at 0 and L act through a continuous Hunt-Crossley force (elastomer bumpers).
"""

from __future__ import annotations

import dataclasses
import math

import numba as nb
import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import as_python, njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.friction import stribeck_exponential, stribeck_exponential_slope_bound
from hydro_envs.laws.nozzle_fast import nozzle_mass_flow_fast, nozzle_mass_flow_slope_fast
from hydro_envs.laws.orifice import circular_orifice_area, iso6358_mass_flow_laminar
from hydro_envs.laws.pneumatic_chamber import (
    chamber_pressure_rate, cylinder_chamber_wall_area, gas_internal_energy, tube_convection_coefficient,
    wall_heat_flow,
)
from hydro_envs.laws.seal_friction import bristle_block_rate_bound, seal_friction, stribeck_curve_exponential
from hydro_envs.laws.valve import second_order_valve_acceleration
from hydro_envs.sim.rk4 import STABLE_H_LAMBDA, local_substeps, worst_case_substeps
from hydro_envs.sim.roots import brent_root
from hydro_envs.sim.stiffness import second_order_pole_magnitude
from hydro_envs.plants.rodless_cylinder.bounds import (
    local_mode_rates as _local_mode_rates, piston_area, smallest_chamber_volume, speed_bound,
)
from hydro_envs.plants.rodless_cylinder.params import (  # noqa: F401  (re-exported)
    D_ALINE, D_AREA, D_COEF, D_CRIT, D_FADE, D_VLINE, D_WALL, D_INVK, I_DLINE, D_KV, D_LOCAL, D_ORIFICE, D_PSIC, D_PSIL, D_SFULL, D_SQRTRTS,
    ATM, I_ASTOP, I_BISO, I_CD, I_CISO, I_D, I_FC, I_FL, I_FLOW, I_FS, I_HW, I_K, I_KSTOP, I_L,
    I_M, I_MFLOOR, I_PE, I_PFLOOR, I_PS, I_R, I_RLAM, I_RP, I_SIG0, I_SIG1, I_SIG2, I_TS, I_UC,
    I_RSUP, I_ULAP, I_UMAX, I_VDA, I_VDB, I_VEPS, I_VMIN, I_VS, I_WV, I_XVM, I_ZV, N_FIELDS, N_PARAMS,
    PLANT, RHO_REF_ISO, RodlessCylinderParams, T_REF_ISO,
)

__all__ = [
    "CONTRACT",
    "RodlessCylinderParams",
    "STATE_NAMES",
    "rodless_cylinder_rhs",
    "rodless_cylinder_rhs_stiff_supply",
    "supply_port_pressure",
    "supply_port_flows",
    "fixed_supply_flows",
    "rodless_cylinder_guard",
    "static_friction_rate",
    "orifice_rate",
    "local_mode_rate",
    "local_mode_shallow",
    "lugre_local_shallow",
    "local_mode_refinement",
    "local_mode_substeps",
    "lugre_local_substeps",
    "local_mode_rates",
    "stiffness_modes",
    "piston_area",
    "centre_pressure",
    "rest_state",
    "chamber_volumes",
    "chamber_temperatures",
    "total_energy",
    "steady_friction",
    "nominal_flow",
    "speed_bound",
    "MidStrokeLinearization",
    "linearize_mid_stroke",
    "friction_compensation_gains",
]

STATE_NAMES = ("y", "v", "pa", "pb", "ma", "mb", "xv", "vv", "z")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "kg", "kg", "m", "m/s", "m")
N_STATES = 9
Y, V, PA, PB, MA, MB, XV, VV, Z = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"y": Y, "pa": PA, "pb": PB}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
#: channels a grey-box fit uses by default
FIT_OUTPUTS = ("y", "pa", "pb")


@njit_noalloc
def _edge_flow(p, area, p_up, p_down, t_up, sqrt_rt_up):
    """Mass flow [kg/s] through one metering edge of uncovered area ``area`` (eqs (3)-(4) or ISO 6358).

    ``t_up`` must be the temperature of the side the gas comes from (the caller compares the
    pressures), ``sqrt_rt_up = sqrt(R t_up)``. Closed edges cost nothing.
    """
    if area <= 0.0:
        return 0.0
    if p[I_FLOW] < 0.5:  # = pneumatic_mass_flow_laminar(C, S, ...) with precomputed constants
        return nozzle_mass_flow_fast(
            p[I_CD] * area, p_up, p_down, sqrt_rt_up, p[I_RLAM],
            p[D_CRIT], p[D_PSIC], p[D_PSIL], p[D_INVK], p[D_COEF],
        )
    # ISO 6358: sonic conductance proportional to the uncovered area, C(full stroke) = C
    return iso6358_mass_flow_laminar(
        p[I_CISO] * area / p[D_SFULL], p[I_BISO], p_up, p_down, t_up, T_REF_ISO, RHO_REF_ISO, p[I_RLAM]
    )


@nb.njit(cache=True, error_model="numpy", inline="always")
def _supply_edge_flow(p, s_in, psv, pc, tc):
    """Mass flow [kg/s] from the valve's P port at ``psv`` into a chamber at ``pc``, ``tc``
    through ``s_in`` (eq (3); back-flow from the chamber negative, at the chamber's temperature)."""
    if psv >= pc:
        return _edge_flow(p, s_in, psv, pc, p[I_TS], p[D_SQRTRTS])
    return _edge_flow(p, s_in, psv, pc, tc, math.sqrt(p[I_R] * tc))


@nb.njit(cache=True, error_model="numpy", inline="always")
def _vented_chamber_flows(p, m_in, s_out, pc, tc):
    """(mass flow, enthalpy flow) into a chamber at pc, tc that receives ``m_in`` [kg/s] from the
    P port (:func:`_supply_edge_flow`) and is vented to R through ``s_out`` (eq (4));
    upstream temperatures follow the flow direction."""
    pe = p[I_PE]
    ts = p[I_TS]
    rts = p[D_SQRTRTS]
    rtc = math.sqrt(p[I_R] * tc)
    m_out = _edge_flow(p, s_out, pc, pe, tc, rtc) if pc >= pe else _edge_flow(p, s_out, pc, pe, ts, rts)  # (4)
    t_in = ts if m_in >= 0.0 else tc
    t_out = tc if m_out >= 0.0 else ts
    return m_in - m_out, m_in * t_in - m_out * t_out


@njit_noalloc
def _port_draw(p, s_plus, s_minus, pa, ta, pb, tb, psv):
    """Net mass flow [kg/s] out of the valve's P port at ``psv`` through its two P edges
    (P->A over ``s_plus``, P->B over ``s_minus``); back-flow from a chamber counts negative."""
    return _supply_edge_flow(p, s_plus, psv, pa, ta) + _supply_edge_flow(p, s_minus, psv, pb, tb)


@njit_noalloc
def _port_edge_slopes(p, s_plus, s_minus, pa, ta, pb, tb, psv):
    """The two P-edge flows of :func:`_port_draw` and their derivatives with respect to the
    port pressure ``psv`` [kg/(s Pa)]: ``(m_a, dm_a, m_b, dm_b)``; the nozzle law's analytic
    slope (``flow_model = 0``), a central difference of 1e-7 ``psv`` for ISO 6358."""
    if p[I_FLOW] >= 0.5:
        h = 1e-7 * psv
        m_a = _supply_edge_flow(p, s_plus, psv, pa, ta)
        m_b = _supply_edge_flow(p, s_minus, psv, pb, tb)
        dm_a = (_supply_edge_flow(p, s_plus, psv + h, pa, ta) - _supply_edge_flow(p, s_plus, psv - h, pa, ta)) / (2.0 * h)
        dm_b = (_supply_edge_flow(p, s_minus, psv + h, pb, tb) - _supply_edge_flow(p, s_minus, psv - h, pb, tb)) / (2.0 * h)
        return m_a, dm_a, m_b, dm_b
    rts = p[D_SQRTRTS]
    m_a = dm_a = m_b = dm_b = 0.0
    if s_plus > 0.0:
        m_a, dm_a = nozzle_mass_flow_slope_fast(
            p[I_CD] * s_plus, psv, pa, rts if psv >= pa else math.sqrt(p[I_R] * ta),
            p[I_RLAM], p[D_CRIT], p[D_PSIC], p[D_PSIL], p[D_INVK], p[D_COEF],
        )
    if s_minus > 0.0:
        m_b, dm_b = nozzle_mass_flow_slope_fast(
            p[I_CD] * s_minus, psv, pb, rts if psv >= pb else math.sqrt(p[I_R] * tb),
            p[I_RLAM], p[D_CRIT], p[D_PSIC], p[D_PSIL], p[D_INVK], p[D_COEF],
        )
    return m_a, dm_a, m_b, dm_b


# the droop solve ends on a Newton step shorter than this fraction of p_s: Newton's error after
# such a step is of the order of the step squared (a step of 1e-6 p_s leaves ~1e-12 p_s; up to the
# step itself where the root sits on a kink of the flow law) -- one flow evaluation fewer than
# stepping down to 1e-12 p_s, with no change at the sensors' resolution
NEWTON_STOP = 1e-6


@njit_noalloc
def supply_port_pressure(p, s_plus, s_minus, pa, ta, pb, tb):
    """Pressure [Pa] at the valve's P port when the supply droops with the drawn mass flow.

    Law: ``p_P = p_s - R mdot_P(p_P)`` with ``R = supply_line_resistance`` [Pa s/kg] and
    ``mdot_P`` the flow the two P edges of eqs (3)-(4) draw at ``p_P`` (T_s upstream). A
    pressure regulator's flow characteristic and a supply hose both lower the pressure at the
    port roughly in proportion to the flow (assumed linear; 004 takes the supply as constant,
    Table 1's compressor works at 0.4-0.7 MPa). ``R = 0`` or no net draw at ``p_s`` return
    ``p_s`` exactly (the seed model).

    Solution: ``g(p) = p - p_s + R mdot_P(p)`` rises strictly with ``p``, and ``mdot_P(p) / p``
    rises with ``p`` (an edge's flow is ``p_up`` times a flow function that grows as the
    pressure ratio falls), so ``p_lo = p_s / (1 + R mdot_P(p_s) / p_s)`` has ``g <= 0`` and
    ``p_s`` has ``g >= 0``. Newton steps from ``p_s`` with the slope of
    :func:`_port_edge_slopes` (``g' = 1 + R mdot_P' >= 1``), safeguarded by the bracket: a
    step that would leave it, or that follows a Newton step that did not halve ``|g|``, bisects
    it instead. The second rule matters where the root lies near a chamber pressure: ``mdot_P``
    is steepest there (the laminar tail of eqs (3)-(4) around equal pressures), and plain
    Newton hops from side to side, shrinking the bracket by ~1 % per step. Until a Newton
    step is below ``NEWTON_STOP`` of ``p_s`` (or any step below 1e-12 of it): 2-4 flow
    evaluations with the nozzle law, within 1e-10 ``p_s`` of the root.
    """
    return supply_port_flows(p, s_plus, s_minus, pa, ta, pb, tb)[0]


@nb.njit(cache=True, error_model="numpy", inline="always")
def supply_port_flows(p, s_plus, s_minus, pa, ta, pb, tb):
    """``(p_P, mdot_PA, mdot_PB)``: the port pressure of :func:`supply_port_pressure` and the
    flows of the two P edges there. The solve's last Newton step ``d`` from ``x`` carries the
    flows along their slopes, ``mdot(x) + mdot'(x) d``: they satisfy the droop law exactly,
    ``p_P = p_s - R (mdot_PA + mdot_PB)``, and differ from the flows evaluated at ``p_P`` by
    the order of ``d^2`` (of ``d`` where ``p_P`` lies at a kink of the flow law, the start of
    its laminar tail: < 1e-7 of the flow), one evaluation of the two edges fewer per
    right-hand side."""
    if p[I_RSUP] <= 0.0:
        return fixed_supply_flows(p, s_plus, s_minus, pa, ta, pb, tb)
    return _drooping_supply_flows(p, s_plus, s_minus, pa, ta, pb, tb)


@njit_noalloc
def _drooping_supply_flows(p, s_plus, s_minus, pa, ta, pb, tb):
    """:func:`supply_port_flows` with ``supply_line_resistance > 0``: the safeguarded Newton
    solve of :func:`supply_port_pressure`."""
    ps = p[I_PS]
    r = p[I_RSUP]
    ma, dma, mb, dmb = _port_edge_slopes(p, s_plus, s_minus, pa, ta, pb, tb, ps)
    m = ma + mb
    if m <= 0.0:
        return fixed_supply_flows(p, s_plus, s_minus, pa, ta, pb, tb)
    hi = ps
    lo = ps / (1.0 + r * m / ps)
    x = ps
    g = r * m
    g_before = math.inf
    for _ in range(100):
        x_new = x - g / (1.0 + r * (dma + dmb))
        bisect = x_new < lo or x_new > hi or abs(g) > 0.5 * abs(g_before)
        if bisect:  # outside the bracket, or the last Newton step did not halve |g|
            x_new = 0.5 * (lo + hi)
        step = x_new - x
        if abs(step) <= 1e-12 * ps or (abs(step) <= NEWTON_STOP * ps and not bisect):
            return x_new, ma + dma * step, mb + dmb * step
        x = x_new
        ma, dma, mb, dmb = _port_edge_slopes(p, s_plus, s_minus, pa, ta, pb, tb, x)
        g_before = math.inf if bisect else g  # after a bisection, Newton again
        g = x - ps + r * (ma + mb)
        if g > 0.0:
            hi = x
        else:
            lo = x
    return x, ma, mb


@nb.njit(cache=True, error_model="numpy", inline="always")
def fixed_supply_flows(p, s_plus, s_minus, pa, ta, pb, tb):
    """``(p_s, mdot_PA, mdot_PB)`` of a stiff supply (004 takes it constant): the port at
    ``p_s`` and the flows of the two P edges there."""
    ps = p[I_PS]
    return ps, _supply_edge_flow(p, s_plus, ps, pa, ta), _supply_edge_flow(p, s_minus, ps, pb, tb)


@njit_noalloc
def chamber_wall_heat_flow(p, vol, mdot, t):
    """Heat flow [W] from the walls into a chamber's gas at temperature ``t`` [K], volume ``vol``
    [m^3] and net mass flow ``mdot`` [kg/s] (module doc): the cylinder's wall ``2 A + 4 (V -
    V_line) / D`` at the convective coefficient ``wall_heat_transfer_coefficient``, plus the
    line's inner wall ``pi d L`` at the tube-flow coefficient of ``mdot``; 0 when that
    coefficient is 0 (the seed's adiabatic chamber, 004 eq (11))."""
    hw = p[I_HW]
    if hw <= 0.0:
        return 0.0
    ts = p[I_TS]
    q = wall_heat_flow(hw, 2.0 * p[D_AREA] + p[D_WALL] * max(vol - p[D_VLINE], 0.0), ts, t)
    if p[D_ALINE] > 0.0:
        q += wall_heat_flow(tube_convection_coefficient(mdot, p[I_DLINE]), p[D_ALINE], ts, t)
    return q


@njit_noalloc
def rodless_cylinder_rhs(y, u, p, dy):
    """Time derivative ``dy`` of state ``y`` under valve command ``u[0]`` [V] (004 model)."""
    _rhs(supply_port_flows, y, u, p, dy)


@njit_noalloc
def rodless_cylinder_rhs_stiff_supply(y, u, p, dy):
    """:func:`rodless_cylinder_rhs` for parameter sets without supply droop
    (``supply_line_resistance = 0``, where :func:`supply_port_flows` is :func:`fixed_supply_flows`): the
    same numbers, compiled without the droop solve (the envs' kernels, 0.8 s less to compile)."""
    _rhs(fixed_supply_flows, y, u, p, dy)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _rhs(supply, y, u, p, dy):
    pos = y[Y]
    v = y[V]
    pa = y[PA]
    pb = y[PB]
    r_gas = p[I_R]
    kappa = p[I_K]
    area = p[D_AREA]  # pi D^2 / 4

    # chamber volumes with dead volumes (15), guarded
    vol_a = max(area * pos + p[I_VDA], p[I_VMIN])
    vol_b = max(area * (p[I_L] - pos) + p[I_VDB], p[I_VMIN])
    ta = pa * vol_a / (max(y[MA], p[I_MFLOOR]) * r_gas)
    tb = pb * vol_b / (max(y[MB], p[I_MFLOOR]) * r_gas)

    # valve: the spool opening is limited to +-x_vm; eq (2) for the two edge openings
    xvm = p[I_XVM]
    xo = min(max(y[XV], -xvm), xvm)
    s_plus = circular_orifice_area(p[I_ULAP] + xo, p[I_RP])  # P->A and B->R   (2)
    s_minus = circular_orifice_area(p[I_ULAP] - xo, p[I_RP])  # P->B and A->R  (2)
    _, m_pa, m_pb = supply(p, s_plus, s_minus, pa, ta, pb, tb)  # (3) at the port: p_s unless the supply droops
    mdot_a, h_a = _vented_chamber_flows(p, m_pa, s_minus, pa, ta)  # (3)-(4)
    mdot_b, h_b = _vented_chamber_flows(p, m_pb, s_plus, pb, tb)

    # energy balance of each chamber (10)-(13); dV_a/dt = A v, dV_b/dt = -A v
    q_a = chamber_wall_heat_flow(p, vol_a, mdot_a, ta)
    q_b = chamber_wall_heat_flow(p, vol_b, mdot_b, tb)
    dpa = chamber_pressure_rate(pa, vol_a, area * v, h_a, kappa, r_gas, q_a)
    dpb = chamber_pressure_rate(pb, vol_b, -area * v, h_b, kappa, r_gas, q_b)
    dma = mdot_a  # (8)-(9)
    dmb = mdot_b
    # guards: a chamber at the floor cannot lose more pressure or mass
    if pa <= p[I_PFLOOR] and dpa < 0.0:
        dpa = 0.0
    if pb <= p[I_PFLOOR] and dpb < 0.0:
        dpb = 0.0
    if y[MA] <= p[I_MFLOOR] and dma < 0.0:
        dma = 0.0
    if y[MB] <= p[I_MFLOOR] and dmb < 0.0:
        dmb = 0.0

    # seal friction: LuGre with the Table 2 curve as steady state (hydro_envs.laws.seal_friction),
    # or the static curve
    sigma0 = p[I_SIG0]
    if sigma0 > 0.0:
        g = stribeck_curve_exponential(v, p[I_FC], p[I_FS], p[I_VS]) if p[I_FS] > 0.0 else 0.0
        f_friction, dz = seal_friction(v, y[Z], g, sigma0, p[I_SIG1], p[D_FADE], p[I_SIG2], 1, 0.0)
    else:
        dz = 0.0
        f_friction = stribeck_exponential(v, p[I_FC], p[I_FS], p[I_VS], p[I_SIG2], p[I_VEPS])
    f_stop = end_stop_force(pos, v, 0.0, p[I_L], p[I_KSTOP], p[I_ASTOP])

    dy[Y] = v
    dy[V] = (area * (pa - pb) - f_friction - p[I_FL] + f_stop) / p[I_M]  # (18)
    dy[PA] = dpa
    dy[PB] = dpb
    dy[MA] = dma
    dy[MB] = dmb
    dy[XV] = y[VV]
    # (28): x_v = K_v (U - 5 V), K_v = x_vm / 5 V, behind the spool lag
    dy[VV] = second_order_valve_acceleration(y[XV], y[VV], u[0] - p[I_UC], p[D_KV], p[I_WV], p[I_ZV])
    dy[Z] = dz


# ------------------------------------------------------- sub-steps of the static friction curve


@njit_noalloc
def _stop_damping_at_full_thrust(p):
    """Hunt-Crossley stop damping [N s/m] at full thrust ``alpha A (1.5 p_s - p_floor)`` (as in
    :func:`stiffness_modes`)."""
    return p[I_ASTOP] * p[D_AREA] * (1.5 * p[I_PS] - p[I_PFLOOR])


@njit_noalloc
def static_friction_rate(v, p):
    """Upper bound [1/s] of ``|d vdot / d v|`` from eq (18) with the static curve (no bristle
    state) at velocity ``v``: the curve's slope (sign regularisation, Stribeck dip, viscous
    sigma) plus the Hunt-Crossley stop damping at full thrust ``alpha A (1.5 p_s - p_floor)``,
    over ``M``. Largest at v = 0: ``F_s / (v_eps M)`` and more."""
    slope = stribeck_exponential_slope_bound(v, p[I_FC], p[I_FS], p[I_VS], p[I_SIG2], p[I_VEPS])
    return (slope + _stop_damping_at_full_thrust(p)) / p[I_M]


@nb.njit(cache=True, error_model="numpy", inline="always")
def _pressure_ratio(p1, p2):
    """The lower of two pressures over the higher (1 when equal)."""
    return p1 / p2 if p1 < p2 else p2 / p1


@nb.njit(cache=True, error_model="numpy", inline="always")
def orifice_rate(y, p):
    """Upper estimate [1/s] of a chamber pressure's rate through the valve's flow law at state
    ``y``: ``D_ORIFICE`` (``kappa R T_max`` times the laminar-tail slope of the fully open
    edge, :mod:`.bounds`) over the smaller chamber volume at ``y``, times
    ``sqrt((1 - r_l) / (1 - r))`` below the laminar ratio ``r_l``, with ``r`` the largest
    pressure ratio across the four metering edges (P-A, P-B at p_s, A-R, B-R at p_e). The flow
    laws' slope grows like ``(1 - r)^(-1/2)`` towards their linear tail (eqs (3)-(4), ISO 6358).
    With supply droop the P-port pressure is not known here: the P edges count as at r = 1."""
    pe = p[I_PE]
    pa = y[PA]
    pb = y[PB]
    r = max(_pressure_ratio(pa, pe), _pressure_ratio(pb, pe))
    if p[I_RSUP] > 0.0:
        r = 1.0
    else:
        r = max(r, max(_pressure_ratio(pa, p[I_PS]), _pressure_ratio(pb, p[I_PS])))
    area = p[D_AREA]
    vol = min(max(area * y[Y] + p[I_VDA], p[I_VMIN]), max(area * (p[I_L] - y[Y]) + p[I_VDB], p[I_VMIN]))
    rl = p[I_RLAM]
    scale = 1.0 if r >= rl else math.sqrt((1.0 - rl) / (1.0 - r))
    return p[D_ORIFICE] / vol * scale


@nb.njit(cache=True, error_model="numpy", inline="always")
def _on_bumper(y, p):
    """Whether the slider at state ``y`` is in contact with an end-stop bumper."""
    return y[Y] <= 0.0 or y[Y] >= p[I_L]


@nb.njit(cache=True, error_model="numpy", inline="always")
def _lugre_rate(y, p):
    """:func:`~hydro_envs.laws.seal_friction.bristle_block_rate_bound` of the slider at state
    ``y`` (velocity, bristle deflection; the Coulomb level as the level's floor, viscous sigma as
    the other damping; no bristle block without dry friction)."""
    fc = p[I_FC]
    ratio = (p[I_FS] - fc) / (math.e * fc) if fc > 0.0 else 0.0
    return bristle_block_rate_bound(y[V], y[Z], fc, ratio, p[I_SIG0], p[I_SIG1], p[D_FADE], p[I_SIG2], p[I_M], 1,
                                    0.0)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _crossed(y0, y, p):
    """Whether a chamber pressure passed the supply or the exhaust pressure between ``y0`` and
    ``y`` (through a metering edge's zero pressure drop, where the flow law is steepest)."""
    ps = p[I_PS]
    pe = p[I_PE]
    return ((y0[PA] - ps) * (y[PA] - ps) < 0.0 or (y0[PB] - ps) * (y[PB] - ps) < 0.0
            or (y0[PA] - pe) * (y[PA] - pe) < 0.0 or (y0[PB] - pe) * (y[PB] - pe) < 0.0)


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_mode_rate(y, p):
    """Upper estimate [1/s] of the locally refined modes at state ``y`` (:mod:`.bounds`): the
    flow law (:func:`orifice_rate`); the friction, i.e. the LuGre block of velocity and bristle
    deflection (:func:`~hydro_envs.laws.seal_friction.bristle_block_rate_bound`) or the
    static curve's slope (:func:`static_friction_rate`); and, with the slider on a bumper, the
    worst case of all (``D_LOCAL``)."""
    if _on_bumper(y, p):
        return p[D_LOCAL]
    friction = _lugre_rate(y, p) if p[I_SIG0] > 0.0 else static_friction_rate(y[V], p)
    return max(orifice_rate(y, p), friction)


@njit_noalloc
def _lugre_local_rate(y, p):
    """The larger of :func:`orifice_rate` and the LuGre block's rate at state ``y`` [1/s]."""
    return max(orifice_rate(y, p), _lugre_rate(y, p))


@njit_noalloc
def lugre_local_shallow(y0, y, p, h):
    """:func:`local_mode_shallow` for parameter sets with a bristle state, compiled without the
    static curve's branch (the envs' kernels when every copy has one)."""
    if _on_bumper(y, p) or _crossed(y0, y, p):
        return False
    return h * _lugre_local_rate(y, p) <= STABLE_H_LAMBDA


@njit_noalloc
def local_mode_shallow(y0, y, p, h):
    """True where an RK4 sub-step of ``h`` seconds stays stable in the locally refined modes at
    state ``y`` (the step's start ``y0``, its Euler prediction ``y``;
    :func:`hydro_envs.sim.rk4.rk4_advance_lookahead`): ``h`` times :func:`local_mode_rate`
    inside RK4's real-axis bound (with the sub-step safety factor), no chamber pressure past the
    supply or exhaust pressure between ``y0`` and ``y``, and on the static curve no velocity
    sign change (the steep zero-velocity region) between them."""
    if p[I_SIG0] > 0.0:
        return lugre_local_shallow(y0, y, p, h)
    if (y[V] > 0.0) != (y0[V] > 0.0) or _crossed(y0, y, p):
        return False
    return h * local_mode_rate(y, p) <= STABLE_H_LAMBDA


@njit_noalloc
def lugre_local_substeps(y0, x, p, h, m):
    """:func:`local_mode_substeps` for parameter sets with a bristle state, compiled without the
    static curve's branch (the envs' kernels when every copy has one). 1 exactly where
    :func:`lugre_local_shallow` holds at ``y0`` and ``x``."""
    if _on_bumper(y0, p) or _on_bumper(x, p) or _crossed(y0, x, p):
        return m
    return local_substeps(h * max(_lugre_local_rate(y0, p), _lugre_local_rate(x, p)), STABLE_H_LAMBDA, m)


@njit_noalloc
def local_mode_substeps(y0, x, p, h, m):
    """RK4 steps of ``h / n`` that take a sub-step of ``h`` from ``y0`` (Euler prediction of its
    end ``x``) stably in the locally refined modes (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`):
    1 where :func:`local_mode_shallow` holds at ``y0`` and ``x``, else ``m`` (the worst case,
    :func:`local_mode_refinement`), except with a bristle state (:func:`lugre_local_substeps`)
    off the bumpers and away from the supply and exhaust pressures: there the count for the
    larger rate of the flow law and the LuGre block at the two
    (:func:`hydro_envs.sim.rk4.local_substeps`). The static curve's slope changes by orders of
    magnitude within a sub-step near v = 0 (``F_s / v_eps`` at v = 0), which its rates at two
    points do not bound, so it keeps the worst case."""
    if p[I_SIG0] > 0.0:
        return lugre_local_substeps(y0, x, p, h, m)
    if local_mode_shallow(y0, y0, p, h) and local_mode_shallow(y0, x, p, h):
        return 1
    return m


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_mode_refinement(p, h):
    """Fine sub-steps per sub-step of ``h`` seconds that keep the locally refined modes stable
    at their worst case (``D_LOCAL``, :func:`local_mode_rates`)."""
    return worst_case_substeps(h * p[D_LOCAL])


@njit_noalloc
def rodless_cylinder_guard(y, p):
    """Project the state back onto the physical set after a sub-step; return #clamps."""
    n = 0
    if y[PA] < p[I_PFLOOR]:
        y[PA] = p[I_PFLOOR]
        n += 1
    if y[PB] < p[I_PFLOOR]:
        y[PB] = p[I_PFLOOR]
        n += 1
    if y[MA] < p[I_MFLOOR]:
        y[MA] = p[I_MFLOOR]
        n += 1
    if y[MB] < p[I_MFLOOR]:
        y[MB] = p[I_MFLOOR]
        n += 1
    return n


# ---------------------------------------------------------------------------- analysis
def _edge_flow_py(params: RodlessCylinderParams, area: float, p_up: float, p_down: float, t_up: float) -> float:
    return float(_edge_flow(params.to_array(), area, p_up, p_down, t_up, math.sqrt(params.gas_constant * t_up)))


def centre_pressure(params: RodlessCylinderParams) -> float:
    """Equilibrium pressure p_0 [Pa] of a chamber at the valve centre (004 eq (14)-(15)).

    At x_v = 0 both edges of a chamber are uncovered by the same underlap, so the leakage
    in from the supply equals the leakage out to the exhaust at a pressure that does not
    depend on the (equal) areas: solve ``mdot(p_s -> p_0) = mdot(p_0 -> p_e)`` at T_s. For a
    zero-lap or overlapped valve the same p_0 is the limit of a vanishing underlap.
    """
    p = params.to_array()
    ts = params.supply_temperature
    rts = math.sqrt(params.gas_constant * ts)
    ps, pe = params.supply_pressure, params.exhaust_pressure
    area = 1e-6

    def f(p0):
        return _edge_flow(p, area, ps, p0, ts, rts) - _edge_flow(p, area, p0, pe, ts, rts)

    return brent_root(f, pe, ps, xtol=1e-9, rtol=1e-14)


def rest_state(params: RodlessCylinderParams, y: float, v: float = 0.0, pa: float | None = None,
               pb: float | None = None, ta: float | None = None, tb: float | None = None) -> np.ndarray:
    """State with the slider at ``y`` (velocity ``v``), spool at rest in the centre, chambers
    at ``pa``, ``pb`` (default: the centre pressure p_0) and ``ta``, ``tb`` (default T_s)."""
    if pa is None or pb is None:
        p0 = centre_pressure(params)
        pa = p0 if pa is None else pa
        pb = p0 if pb is None else pb
    ta = params.supply_temperature if ta is None else ta
    tb = params.supply_temperature if tb is None else tb
    a = piston_area(params)
    va = a * y + params.dead_volume_a
    vb = a * (params.stroke - y) + params.dead_volume_b
    s = np.zeros(N_STATES)
    s[Y], s[V], s[PA], s[PB] = y, v, pa, pb
    s[MA] = pa * va / (params.gas_constant * ta)
    s[MB] = pb * vb / (params.gas_constant * tb)
    return s


def chamber_volumes(states: np.ndarray, params: RodlessCylinderParams) -> tuple[np.ndarray, np.ndarray]:
    """Chamber volumes [m^3] of state rows (eq (15) with dead volumes)."""
    s = np.atleast_2d(states)
    a = piston_area(params)
    va = np.maximum(a * s[:, Y] + params.dead_volume_a, params.min_chamber_volume)
    vb = np.maximum(a * (params.stroke - s[:, Y]) + params.dead_volume_b, params.min_chamber_volume)
    return va, vb


def chamber_temperatures(states: np.ndarray, params: RodlessCylinderParams) -> tuple[np.ndarray, np.ndarray]:
    """Chamber gas temperatures ``T = p V / (m R)`` [K] of state rows."""
    s = np.atleast_2d(states)
    va, vb = chamber_volumes(s, params)
    r = params.gas_constant
    return s[:, PA] * va / (s[:, MA] * r), s[:, PB] * vb / (s[:, MB] * r)


def soak_temperatures(S: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``(n, 2)`` chamber temperatures ``T = p V / (m R)`` [K] of a batch's states ``S`` under
    the kernel parameter rows ``P`` (the volumes and mass floor of the kernels): what the soak
    test (:mod:`hydro_envs.soak`) bounds below."""
    area = P[:, D_AREA]
    vol_a = np.maximum(area * S[:, Y] + P[:, I_VDA], P[:, I_VMIN])
    vol_b = np.maximum(area * (P[:, I_L] - S[:, Y]) + P[:, I_VDB], P[:, I_VMIN])
    ma = np.maximum(S[:, MA], P[:, I_MFLOOR])
    mb = np.maximum(S[:, MB], P[:, I_MFLOOR])
    return np.stack([S[:, PA] * vol_a / (ma * P[:, I_R]), S[:, PB] * vol_b / (mb * P[:, I_R])], axis=1)


def soak_temperature_floor(P: np.ndarray) -> np.ndarray:
    """``(n,)`` coldest chamber temperature [K] the physics allows per kernel parameter row:
    gas at the wall temperature T_s expanded isentropically from the highest pressure the
    stiffness bounds assume, 1.5 p_s (:func:`stiffness_modes`), to the exhaust,
    ``T_s (p_e / (1.5 p_s))^((kappa - 1)/kappa)`` (the walls only warm a gas colder than them; the
    soak test, :mod:`hydro_envs.soak`)."""
    k = P[:, I_K]
    return P[:, I_TS] * (P[:, I_PE] / (1.5 * P[:, I_PS])) ** ((k - 1.0) / k)


def total_energy(states: np.ndarray, params: RodlessCylinderParams) -> np.ndarray:
    """Kinetic energy + chambers' internal energy + load potential ``F_L y`` [J] of state rows.

    With the valve closed, no friction, no heat exchange and away from the stops this is
    conserved exactly (the boundary work ``p dV`` moves energy between gas and slider only;
    the constant load force F_L does work ``-F_L dy``). LuGre bristles store ``sigma0 z^2/2``,
    not included (use a friction-free parameter set).
    """
    s = np.atleast_2d(states)
    va, vb = chamber_volumes(s, params)
    k = params.heat_capacity_ratio
    return (
        0.5 * params.mass * s[:, V] ** 2
        + gas_internal_energy(s[:, PA], va, k)
        + gas_internal_energy(s[:, PB], vb, k)
        + params.load_force * s[:, Y]
    )


def steady_friction(params: RodlessCylinderParams, v) -> np.ndarray:
    """Steady-state friction force [N] at constant velocity ``v`` (Table 2 Stribeck curve).

    ``F = (F_c + (F_s - F_c) exp(-|v|/v_s)) sign(v) + sigma v`` -- the steady state of both
    friction modes (LuGre exactly; the static mode with tanh(v/v_eps) ~ sign(v) for |v| >> v_eps).
    """
    v = np.asarray(v, dtype=float)
    g = params.coulomb_friction + (params.static_friction - params.coulomb_friction) * np.exp(
        -np.abs(v) / params.stribeck_velocity
    )
    return g * np.sign(v) + params.viscous_friction * v


def nominal_flow(params: RodlessCylinderParams, p1_gauge: float = 6e5, dp: float = 1e5) -> float:
    """Standard nominal flow [L/min, ANR] of one fully open path (P->A at full stroke).

    Festo's definition: p1 = 6 bar gauge, p2 = 5 bar gauge, 20 C supply; ANR = 1.185 kg/m^3.
    """
    p1 = p1_gauge + params.exhaust_pressure
    area = float(circular_orifice_area(params.spool_stroke + params.valve_underlap, params.port_radius))
    m = _edge_flow_py(params, area, p1, p1 - dp, T_REF_ISO)
    return m / RHO_REF_ISO * 60e3


def stiffness_modes(params: RodlessCylinderParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of the modes that are stiff
    everywhere; they set the sub-step count.

    The fixed RK4 sub-step keeps ``h |lambda| <= 0.8 * 2.785`` for all of them
    (:func:`hydro_envs.sim.stiffness.rk4_substeps`); worst cases over the state space:

    * ``valve``: spool poles, ``omega_v`` (the fast real pole when over-damped,
      :func:`~hydro_envs.sim.stiffness.second_order_pole_magnitude`).
    * ``gas_spring``: ``sqrt(kappa p_max A^2 (1/V_min + 1/V_max) / M)`` at the stroke end,
      p_max = 1.5 p_s (compression above supply).
    * ``friction_stick`` (LuGre): the stuck bristles ``sqrt(sigma0/M)`` plus the dampings that
      act on the slider with them, ``(2 sigma1 + sigma)/M``; ``friction`` (static curve): the
      viscous ``sigma/M``.
    * ``heat``: wall exchange ``(kappa - 1) h A_wall/V T_max / (p_e/2)`` with the largest wall
      area per volume ``A_wall/V = 2 A / V_min + 4 / D``, plus the line's
      ``(kappa - 1) h_line pi d L / V_min T_max / p_e`` at the largest mass flow
      (:func:`largest_mass_flow`, into a chamber at the exhaust pressure).

    Stiff only in part of the state space, and left out here (:mod:`.bounds`,
    :func:`local_mode_rates`): the flow law's laminar tail, LuGre's bristle relaxation at speed
    or the static curve's steep part near v = 0, and the bumpers in contact. The kernels
    (:mod:`.kernels`) take a sub-step as :func:`local_mode_substeps` finer ones (at most
    :func:`local_mode_refinement`) where :func:`local_mode_shallow` fails at its start or at the
    Euler prediction of its end (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`).
    """
    a = piston_area(params)
    m = params.mass
    kappa = params.heat_capacity_ratio
    p_max = 1.5 * params.supply_pressure
    t_max = 1.5 * params.supply_temperature
    v_min = smallest_chamber_volume(params)
    v_big = a * params.stroke + max(params.dead_volume_a, params.dead_volume_b)
    modes = {
        "valve": second_order_pole_magnitude(params.valve_natural_frequency, params.valve_damping),
        "gas_spring": math.sqrt(kappa * p_max * a * a * (1.0 / v_min + 1.0 / v_big) / m),
    }
    if params.bristle_stiffness > 0.0:
        modes["friction_stick"] = (math.sqrt(params.bristle_stiffness / m)
                                   + (2.0 * params.bristle_damping + params.viscous_friction) / m)
    else:
        modes["friction"] = params.viscous_friction / m
    if params.wall_heat_transfer_coefficient > 0.0:
        per_volume = 2.0 * a / v_min + 4.0 / params.bore  # laws.pneumatic_chamber.cylinder_chamber_wall_area / V
        # the line's wall at the largest flow (the choked full opening from p_s) into a chamber at
        # the exhaust pressure: a chamber below it draws air back at a small subsonic flow
        h_line = as_python(tube_convection_coefficient)(largest_mass_flow(params), params.line_bore)
        line = h_line * math.pi * params.line_bore * params.line_length / v_min
        modes["heat"] = (kappa - 1.0) * t_max * (params.wall_heat_transfer_coefficient * per_volume
                                                 / (0.5 * params.exhaust_pressure) + line / params.exhaust_pressure)
    return modes


def largest_mass_flow(params: RodlessCylinderParams) -> float:
    """Mass flow [kg/s] of the fully open edge choked from p_s at T_s (``C S p_s sqrt(kappa / (R
    T_s)) (2 / (kappa + 1))^((kappa + 1) / (2 (kappa - 1)))``, the nozzle law of 004 eq (3) at its
    critical ratio): the largest flow into a chamber."""
    kappa = params.heat_capacity_ratio
    s_full = float(params.to_array()[D_SFULL])
    psi = (2.0 / (kappa + 1.0)) ** ((kappa + 1.0) / (2.0 * (kappa - 1.0)))
    return (params.discharge_coefficient * s_full * params.supply_pressure
            * math.sqrt(kappa / (params.gas_constant * params.supply_temperature)) * psi)


def local_mode_rates(params: RodlessCylinderParams) -> dict[str, float]:
    """Worst cases [1/s] of the modes the kernels refine locally (:func:`.bounds.local_mode_rates`:
    ``orifice``, ``friction_slip`` or ``friction_static``, ``end_stop``); the largest is
    ``D_LOCAL`` of the kernel parameter array."""
    return _local_mode_rates(params, float(params.to_array()[D_ORIFICE]))


# ---------------------------------------------------------------------- linearisation
@dataclasses.dataclass(frozen=True)
class MidStrokeLinearization:
    """Linear model of 004 eqs (5)-(7), (14)-(27) at mid-stroke, valve centre.

    Fields: ``p0`` [Pa] centre pressure, ``c1`` [kg/(s m)] mass-flow gain (6), ``c2``
    [kg/(s Pa)] flow-pressure coefficient (6), ``v0`` [m^3] half the total volume incl. dead
    volume, ``area`` [m^2], ``mass`` [kg], ``rt`` = R T_s [J/kg], ``kappa``, ``k_t`` [1/s]
    gain (22), ``zeta`` [-] (23), ``omega_n`` [rad/s] (24), ``k_v`` [m/V] spool gain (28),
    ``zeta_energy`` [-]: eq (23) with the energy-balance correction of c2 (see
    :func:`linearize_mid_stroke`), the damping the nonlinear plant actually has.
    """

    p0: float
    c1: float
    c2: float
    v0: float
    area: float
    mass: float
    rt: float
    kappa: float
    k_t: float
    zeta: float
    omega_n: float
    k_v: float
    zeta_energy: float

    def spool_to_position(self) -> tuple[np.ndarray, np.ndarray]:
        """(num, den) of eq (21): y/x_v = K_T w^2 / (s (s^2 + 2 zeta w s + w^2))."""
        w = self.omega_n
        return np.array([self.k_t * w * w]), np.array([1.0, 2.0 * self.zeta * w, w * w, 0.0])

    def force_to_position(self) -> tuple[np.ndarray, np.ndarray]:
        """(num, den) of eqs (25)-(26): y/F_f = y/F_L = -(K_T w^2/(2 c1 A)) (V0/(R T kappa) s + c2) / (s(...)).

        004 prints ``2 c_f A`` in (25) and ``2 c_I A`` in (26); both are ``2 c_1 A`` (the
        factor follows from eq (20)).
        """
        w = self.omega_n
        g = -self.k_t * w * w / (2.0 * self.c1 * self.area)
        num = g * np.array([self.v0 / (self.rt * self.kappa), self.c2])
        return num, np.array([1.0, 2.0 * self.zeta * w, w * w, 0.0])

    def command_to_position(self) -> tuple[np.ndarray, np.ndarray]:
        """(num, den) of y/U with the spool gain of eq (28), x_v = K_v U (U from the 5 V centre)."""
        num, den = self.spool_to_position()
        return num * self.k_v, den

    def position(self, s: complex, x_v: complex = 0.0, f: complex = 0.0) -> complex:
        """Eq (27): Y(s) for spool X_v(s) and total force F_f(s) + F_L(s)."""
        w = self.omega_n
        den = s * (s * s + 2.0 * self.zeta * w * s + w * w)
        k = self.k_t * w * w
        return (k * x_v - k * f / (2.0 * self.c1 * self.area) * (self.v0 / (self.rt * self.kappa) * s + self.c2)) / den


def linearize_mid_stroke(params: RodlessCylinderParams) -> MidStrokeLinearization:
    """004 eqs (5)-(7) and (19)-(24) at mid-stroke with the valve at its centre.

    ``c1 = d mdot_a / d x_v`` and ``c2 = -d mdot_a / d p_a`` at x_v = 0, p_a = p_0, T = T_s
    (eq (6)) by central differences of the same flow law the plant uses (both edges of
    chamber a: P->A opens and A->R closes with x_v). ``V0`` is half the total volume
    including the dead volumes (the paper's "half the total cylinder volume").

    ``zeta_energy``: eq (16) linearises eq (13) at T = T_s, so the venting gas leaves at a fixed
    temperature. In the energy balance the outflow carries the chamber's own temperature,
    which swings isentropically with the pressure (dT/T = (kappa-1)/kappa dp/p; the throughflow
    relaxes it only over seconds). Linearising ``T_a mdot_out(p_a, T_a)`` with
    ``mdot_out ~ 1/sqrt(T_a)`` adds ``(kappa - 1)/(2 kappa) mdot_out/p_0`` to c2; with the
    corrected c2 eq (23) gives ``zeta_energy`` (about 6 % above eq (23) at the nominal plant,
    where the outflow term is 40 % of c2), plus the wall heat exchange's thermal damping
    ``(1 - 1/kappa) w tau / (2 (1 + (w tau)^2))`` at ``w = omega_n`` with the chambers' thermal
    time constant ``tau = m c_v / (h A_wall)`` (0.5 s at the nominal plant: +0.0018).
    """
    p0 = centre_pressure(params)
    ts = params.supply_temperature
    ps, pe = params.supply_pressure, params.exhaust_pressure
    r = params.port_radius
    u = params.valve_underlap

    def mdot_a(xv, pa):
        s_in = float(circular_orifice_area(u + xv, r))
        s_out = float(circular_orifice_area(u - xv, r))
        return _edge_flow_py(params, s_in, ps, pa, ts) - _edge_flow_py(params, s_out, pa, pe, ts)

    hx = 1e-3 * max(abs(u), 1e-6)
    hp = 1e-4 * p0
    c1 = (mdot_a(hx, p0) - mdot_a(-hx, p0)) / (2.0 * hx)
    c2 = -(mdot_a(0.0, p0 + hp) - mdot_a(0.0, p0 - hp)) / (2.0 * hp)
    a = piston_area(params)
    v0 = 0.5 * (a * params.stroke + params.dead_volume_a + params.dead_volume_b)
    rt = params.gas_constant * ts
    kappa = params.heat_capacity_ratio
    m = params.mass
    k_t = c1 * rt / (p0 * a)  # (22)
    zeta = c2 * rt / (2.0 * a) * math.sqrt(kappa * m / (2.0 * v0 * p0))  # (23)
    omega_n = math.sqrt(2.0 * kappa * p0 * a * a / (v0 * m))  # (24)
    k_v = params.spool_stroke / (params.command_max - params.command_centre)
    m_out = _edge_flow_py(params, float(circular_orifice_area(u, r)), p0, pe, ts)
    c2_energy = c2 + (kappa - 1.0) / (2.0 * kappa) * m_out / p0
    zeta_energy = c2_energy * rt / (2.0 * a) * math.sqrt(kappa * m / (2.0 * v0 * p0))
    # wall heat exchange: each chamber's gas spring relaxes from adiabatic towards isothermal with
    # tau = m c_v / (h A_wall) = p0 V0 / ((kappa - 1) T_s h A_wall); its loss factor at omega_n,
    # (1 - 1/kappa) w tau / (1 + (w tau)^2) (a standard linear solid), adds half of it to zeta
    # (the cylinder's wall and, at the centre's zero net flow, the line's at its laminar coefficient)
    v_line = 0.25 * math.pi * params.line_bore**2 * params.line_length
    h_wall = params.wall_heat_transfer_coefficient * as_python(cylinder_chamber_wall_area)(
        max(v0 - v_line, 0.0), a, params.bore)
    if h_wall > 0.0:
        h_wall += (as_python(tube_convection_coefficient)(0.0, params.line_bore)
                   * math.pi * params.line_bore * params.line_length)
        wt = omega_n * p0 * v0 / ((kappa - 1.0) * params.supply_temperature * h_wall)
        zeta_energy += 0.5 * (1.0 - 1.0 / kappa) * wt / (1.0 + wt * wt)
    return MidStrokeLinearization(p0, c1, c2, v0, a, m, rt, kappa, k_t, zeta, omega_n, k_v, zeta_energy)


def friction_compensation_gains(params: RodlessCylinderParams) -> tuple[float, float]:
    """Valve command per newton of friction to cancel, ``(static [V/N], dynamic [V s/N])``.

    004 eq (27): a force ``F`` enters the position response as the spool opening
    ``F (c2 + V0/(R T_s kappa) s) / (2 c1 A)``; over the valve gain ``k_v`` (eq (28)) that is
    ``static F + dynamic dF/dt``. c1, c2, V0 at mid-stroke (:func:`linearize_mid_stroke`).
    """
    lin = linearize_mid_stroke(params)
    per_newton = 1.0 / (2.0 * lin.c1 * lin.area * lin.k_v)
    return lin.c2 * per_newton, lin.v0 / (lin.rt * lin.kappa) * per_newton


def rest_state_from_measurement(params: RodlessCylinderParams, first: dict) -> np.ndarray:
    """State at a record's first sample: :func:`rest_state` at the measured slider position
    (mid-stroke if not measured) and chamber pressures (the valve's centre pressure p_0 where
    not measured), gas at the supply temperature, spool centred, unloaded seals (z = 0)."""
    return rest_state(params, first.get("y", 0.5 * params.stroke), pa=first.get("pa"), pb=first.get("pb"))


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, rest_state=rest_state, rest_state_from_measurement=rest_state_from_measurement,
    soak_temperatures=soak_temperatures, soak_temperature_floor=soak_temperature_floor, piston_area=piston_area,
)
