"""Pneumatic rodless cylinder (seed 004): plant physics and numerics (the env: ``test_rodless_cylinder_env.py``).

Every check compares against something independent of the code under test: the seed's tables
and equations, the FESTO data sheet's nominal flow, conservation of mass and energy, the
first law for a filling chamber, the isentropic relations, a stiff Radau reference, the
numerical Jacobian, an independent solution of the linear model eq (20) and measured seal
friction (X-ring data, CC0).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import gymnasium as gym
import numba as nb
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the env)
from hydro_envs.laws.friction import stribeck_exponential
from hydro_envs.laws.orifice import circular_orifice_area, iso6358_mass_flow, pneumatic_critical_ratio
from hydro_envs.laws.pneumatic_chamber import chamber_pressure_rate
from hydro_envs.laws.stribeck_lugre import lugre_exponential_rate, stribeck_exponential_curve
from hydro_envs.params import ParameterError
from hydro_envs.plants.rodless_cylinder import experiments as rx
from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder import validation as rv
from hydro_envs import sim
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.randomization import load_randomization
from hydro_envs import registry
from hydro_envs.sim.reference import reference_rollout
from hydro_envs.sim.rk4 import local_substeps, rk4_advance, rk4_advance_lookahead
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, RK4_REAL_STABILITY_LIMIT, substeps_from_stiffness


ENV_ID = "hydro_envs/RodlessCylinder-v0"
NOMINAL = RodlessCylinderParams()
L = NOMINAL.stroke
HALF = 0.5 * L
A = rc.piston_area(NOMINAL)
DT = 1e-3
STATE_KEYS = rc.STATE_NAMES
DATA = Path(__file__).resolve().parent / "data" / "pneumatic_seal_friction"


@pytest.fixture(scope="module")
def spec():
    return load_randomization("rodless_cylinder", RodlessCylinderParams)


def simulate(p, y0, commands, n_sub=None, dt=DT):
    """Fixed-step kernel rollout under per-step commands [V]; (n+1, 9) states."""
    return sim.simulate(registry.get("rodless_cylinder"), p, np.asarray(commands, dtype=float), y0, dt, n_sub=n_sub)


def frictionless(p=NOMINAL, **kw):
    """No friction, and adiabatic walls (the seed's eq (11)) unless ``wall_heat_transfer_coefficient`` is given."""
    kw.setdefault("wall_heat_transfer_coefficient", 0.0)
    return dataclasses.replace(
        p, static_friction=0.0, coulomb_friction=0.0, viscous_friction=0.0, bristle_stiffness=0.0,
        bristle_damping=0.0, **kw,
    )


def sealed(p=NOMINAL, **kw):
    """Zero-lap valve: at the 5 V centre every edge is closed."""
    return dataclasses.replace(frictionless(p, **kw), valve_underlap=0.0, spool_stroke=p.port_radius)


# ============================================================================ parameters
def test_nominal_parameters_are_the_seed_tables():
    p = NOMINAL
    # Table 2 (sigma from the table, not the conclusions' "3.27 mm/s")
    assert (p.static_friction, p.coulomb_friction) == (35.48, 15.31)
    assert p.stribeck_velocity == pytest.approx(3.27e-3)
    assert p.viscous_friction == pytest.approx(0.31 * 1e3)  # 0.31 N s/mm in N s/m
    assert p.viscous_friction != pytest.approx(3.27e-3)
    # Table 1: MYC25G-110L, 0-10 V valve with 5 V centre, 0.6 MPa (gauge) supply
    assert (p.bore, p.stroke) == (0.025, 0.110)
    assert A == pytest.approx(4.9087e-4, rel=1e-4)
    assert (p.command_centre, p.command_max) == (5.0, 10.0)
    assert p.supply_pressure - p.exhaust_pressure == pytest.approx(0.6e6)
    assert p.heat_capacity_ratio == 1.4 and p.gas_constant == 287.0
    # every field documents its source; unknown ones are marked assumed
    for row in RodlessCylinderParams.describe():
        assert row["source"].strip(), row["name"]
    assumed = {r["name"] for r in RodlessCylinderParams.describe() if r["source"].startswith("assumed")}
    assert {"mass", "dead_volume_a", "port_radius", "valve_underlap", "bristle_stiffness"} <= assumed


@pytest.mark.parametrize(
    "field,value,fragment",
    [("mass", 0.0, "mass"), ("bore", -0.01, "bore"), ("stroke", float("nan"), "stroke"),
     ("discharge_coefficient", 1.2, "discharge_coefficient"), ("heat_capacity_ratio", 1.0, "heat_capacity_ratio")],
)
def test_invalid_parameter_names_field_and_range(field, value, fragment):
    with pytest.raises(ParameterError) as exc:
        RodlessCylinderParams(**{field: value})
    assert fragment in str(exc.value) and "allowed range" in str(exc.value)


def test_cross_field_relations_are_checked():
    with pytest.raises(ParameterError, match="static_friction"):
        RodlessCylinderParams(static_friction=10.0)
    with pytest.raises(ParameterError, match="flow_model"):
        RodlessCylinderParams(flow_model=0.5)
    with pytest.raises(ParameterError, match="valve_underlap"):
        RodlessCylinderParams(valve_underlap=2e-3)
    with pytest.raises(ParameterError, match="coulomb_friction"):
        RodlessCylinderParams(static_friction=10.0, coulomb_friction=0.0)  # the level must stay > 0 at speed
    with pytest.raises(ParameterError, match="supply_pressure"):
        RodlessCylinderParams(supply_pressure=9e4)
    RodlessCylinderParams(static_friction=0.0, coulomb_friction=0.0, bristle_stiffness=0.0)  # ok: static
    RodlessCylinderParams(static_friction=0.0, coulomb_friction=0.0)  # ok: no dry friction, viscous only


# ============================================================================ laws
def test_stribeck_form_is_the_exponential_of_the_fig3_construction():
    fc, fs, vs = NOMINAL.coulomb_friction, NOMINAL.static_friction, NOMINAL.stribeck_velocity
    # tangent of the curve at 0+ (no viscous term) meets the Coulomb level exactly at v_s
    h = 1e-9
    slope = (stribeck_exponential_curve(h, fc, fs, vs) - stribeck_exponential_curve(0.0, fc, fs, vs)) / h
    assert fs + slope * vs == pytest.approx(fc, rel=1e-5)
    assert stribeck_exponential_curve(0.0, fc, fs, vs) == fs
    # steady-state curve = 002-style exponential Stribeck with an exact sign
    for v in (-0.2, -1e-3, 2e-3, 0.05):
        assert rc.steady_friction(NOMINAL, v) == pytest.approx(
            stribeck_exponential(v, fc, fs, vs, NOMINAL.viscous_friction, 0.0), rel=1e-12)
    # LuGre steady state z = g sign(v) / sigma0 has zero bristle rate
    s0 = NOMINAL.bristle_stiffness
    for v in (-0.1, 0.004):
        z = stribeck_exponential_curve(v, fc, fs, vs) * np.sign(v) / s0
        assert abs(lugre_exponential_rate(v, z, fc, fs, vs, s0)) < 1e-15


def test_chamber_law_reduces_to_seed_eq_13():
    # eq (13) with T_in = T: mdot = (V dp/dt + kappa p dV/dt) / (R T kappa)
    p, vol, dvol, T, k, R = 5e5, 3e-5, 2e-5, 310.0, 1.4, 287.0
    mdot = 1.3e-3
    dp = chamber_pressure_rate(p, vol, dvol, mdot * T, k, R, 0.0)
    assert (vol * dp + k * p * dvol) / (R * T * k) == pytest.approx(mdot, rel=1e-13)


def test_fast_nozzle_law_equals_the_reference_law():
    from hydro_envs.laws.nozzle_fast import nozzle_flow_constants, nozzle_mass_flow_fast
    from hydro_envs.laws.orifice import pneumatic_mass_flow_laminar

    for kappa, rl in ((1.4, 0.999), (1.3, 0.995), (1.67, 0.9999)):
        consts = nozzle_flow_constants(kappa, rl)
        assert consts[0] == pytest.approx(pneumatic_critical_ratio(kappa), rel=1e-14)
        for p_down in np.concatenate([np.linspace(1.0, 9.9e5, 997), [7e5 * rl, 7e5, 7.0001e5]]):
            for t_up in (180.0, 293.15):
                ref = pneumatic_mass_flow_laminar(0.7, 2e-6, 7e5, p_down, t_up, kappa, 287.0, rl)
                fast = nozzle_mass_flow_fast(0.7 * 2e-6, 7e5, p_down, math.sqrt(287.0 * t_up), rl, *consts)
                assert fast == pytest.approx(ref, rel=1e-12, abs=1e-20)


def test_nozzle_slope_is_the_derivative_of_the_flow():
    """The analytic slope d mdot / d p_1 used by the supply droop's Newton steps against a central
    difference of the flow, on both sides of the critical, subsonic and laminar-tail regimes and
    for back-flow."""
    from hydro_envs.laws.nozzle_fast import nozzle_flow_constants, nozzle_mass_flow_fast, nozzle_mass_flow_slope_fast

    consts = nozzle_flow_constants(1.4, 0.999)
    rt = math.sqrt(287.0 * 293.15)
    for p_1 in (2e5, 4e5, 5.5e5, 6.99e5, 7.0005e5, 7.2e5, 9e5, 1.5e6):
        m, dm = nozzle_mass_flow_slope_fast(1.4e-6, p_1, 7e5, rt, 0.999, *consts)
        assert m == pytest.approx(nozzle_mass_flow_fast(1.4e-6, p_1, 7e5, rt, 0.999, *consts), rel=1e-14)
        h = 1e-3 * abs(p_1 - 7e5) if abs(p_1 - 7e5) > 1e3 else 0.05
        fd = (nozzle_mass_flow_fast(1.4e-6, p_1 + h, 7e5, rt, 0.999, *consts)
              - nozzle_mass_flow_fast(1.4e-6, p_1 - h, 7e5, rt, 0.999, *consts)) / (2 * h)
        assert dm == pytest.approx(fd, rel=1e-5, abs=1e-16), p_1
        assert dm >= 0.0


def test_parameter_array_round_trip_with_derived_columns():
    arr = NOMINAL.to_array()
    assert arr.shape == (rc.N_PARAMS,) and arr[rc.D_AREA] == pytest.approx(A, rel=1e-15)
    assert RodlessCylinderParams.from_array(arr) == NOMINAL
    assert RodlessCylinderParams.from_array(arr[: rc.N_FIELDS]) == NOMINAL
    with pytest.raises(ParameterError, match="expected"):
        RodlessCylinderParams.from_array(arr[:5])


def test_port_area_of_eq_2_at_full_stroke_is_half_a_port():
    r, u, xvm = NOMINAL.port_radius, NOMINAL.valve_underlap, NOMINAL.spool_stroke
    d = r - u  # shoulder half-width of Fig. 8
    assert xvm == pytest.approx(d)
    assert circular_orifice_area(xvm + u, r) == pytest.approx(0.5 * math.pi * r * r, rel=1e-12)
    # eq (2) as printed, at a few x_v in (d - r, d]
    for xv in (d - r + 1e-5, 0.3e-3, d):
        printed = r * r * math.acos((d - xv) / r) - (d - xv) * math.sqrt(r * r - (d - xv) ** 2)
        assert circular_orifice_area(xv + u, r) == pytest.approx(printed, rel=1e-12)
    assert circular_orifice_area(u - xvm, r) == 0.0  # the opposite edge is shut at full stroke


@pytest.mark.parametrize("flow_model", [0.0, 1.0])
def test_nominal_flow_is_the_mpye5_data_sheet_value(flow_model):
    # FESTO MPYE-5-M5-010-B: standard nominal flow 100 L/min (6 -> 5 bar gauge, ANR)
    p = dataclasses.replace(NOMINAL, flow_model=flow_model)
    assert rc.nominal_flow(p) == pytest.approx(100.0, rel=0.01)


def test_iso6358_option_chokes_below_b_and_matches_nozzle_law_shape():
    p = dataclasses.replace(NOMINAL, flow_model=1.0)
    area = circular_orifice_area(p.spool_stroke + p.valve_underlap, p.port_radius)
    ps = p.supply_pressure
    m_choked = rc._edge_flow_py(p, area, ps, 0.1 * ps, 293.15)
    assert rc._edge_flow_py(p, area, ps, 0.29 * ps, 293.15) == pytest.approx(m_choked, rel=1e-12)
    assert m_choked == pytest.approx(p.sonic_conductance * 1.185 * ps, rel=1e-12)  # C rho_ANR p1 at T_ref
    assert iso6358_mass_flow(1.0, 0.3, ps, 0.5 * ps, 293.15, 293.15, 1.185) < 1.185 * ps
    # nozzle law chokes at c_0 = 0.528
    p0 = dataclasses.replace(NOMINAL, flow_model=0.0)
    c0 = pneumatic_critical_ratio(1.4)
    assert rc._edge_flow_py(p0, area, ps, 0.5 * c0 * ps, 293.15) == pytest.approx(
        rc._edge_flow_py(p0, area, ps, c0 * ps, 293.15), rel=1e-12)


# ============================================================================ equilibrium, mass, energy
def test_centre_is_an_equilibrium_with_data_sheet_order_leakage():
    p = frictionless()
    y = rc.rest_state(p, HALF)
    dy = np.empty(rc.N_STATES)
    registry.get("rodless_cylinder").kernels.rhs(y, np.array([p.command_centre]), p.to_array(), dy)
    assert abs(dy[rc.PA]) < 1e-6 * p.supply_pressure and abs(dy[rc.V]) == 0.0
    assert abs(dy[rc.MA]) < 1e-15
    p0 = rc.centre_pressure(p)
    assert 0.75 * p.supply_pressure < p0 < 0.85 * p.supply_pressure
    # leakage P -> A -> R plus P -> B -> R, in L/min ANR: a few L/min (data-sheet order)
    area = circular_orifice_area(p.valve_underlap, p.port_radius)
    leak = 2 * rc._edge_flow_py(p, area, p.supply_pressure, p0, p.supply_temperature) / 1.185 * 60e3
    assert 3.0 < leak < 10.0


def test_closed_valve_conserves_mass_exactly_and_energy():
    p = sealed(load_force=12.0)
    y0 = rc.rest_state(p, 0.4 * L, v=0.3, pa=4e5, pb=6e5, ta=300.0, tb=280.0)
    ys = simulate(p, y0, np.full(400, p.command_centre), n_sub=20)
    # no flow through a closed valve: each chamber's mass is untouched, bit for bit
    assert np.all(ys[:, rc.MA] == y0[rc.MA]) and np.all(ys[:, rc.MB] == y0[rc.MB])
    # kinetic + internal energy + load potential: only boundary work and load work move energy
    e = rc.total_energy(ys, p)
    ke = 0.5 * p.mass * ys[:, rc.V] ** 2
    assert np.max(np.abs(e - e[0])) <= 1e-7 * np.ptp(ke) + 1e-12
    assert np.ptp(ke) > 0.5 * 0.5 * p.mass * 0.3**2  # energy really moved between gas and slider
    assert ys[:, rc.Y].min() > 0.0 and ys[:, rc.Y].max() < L  # away from the stops
    # isentropic chambers (eq (11)): p V^kappa and T V^(kappa-1) stay constant
    va, vb = rc.chamber_volumes(ys, p)
    ta, tb = rc.chamber_temperatures(ys, p)
    k = p.heat_capacity_ratio
    for pr, vol, t in ((ys[:, rc.PA], va, ta), (ys[:, rc.PB], vb, tb)):
        assert np.ptp(pr * vol**k) / np.mean(pr * vol**k) < 1e-7
        assert np.ptp(t * vol ** (k - 1)) / np.mean(t * vol ** (k - 1)) < 1e-7


def test_energy_error_converges_at_rk4_rate():
    p = sealed()
    y0 = rc.rest_state(p, HALF, v=0.3)
    drift = []
    for n_sub in (2, 4):
        e = rc.total_energy(simulate(p, y0, np.full(200, p.command_centre), n_sub=n_sub), p)
        drift.append(np.max(np.abs(e - e[0])))
    assert drift[0] / drift[1] >= 16


def test_filling_obeys_the_first_law_with_supply_enthalpy():
    """Chamber a filled from the supply (A->R shut at full stroke): dU = c_p T_s dm - p dV."""
    p = dataclasses.replace(NOMINAL, mass=1e4, wall_heat_transfer_coefficient=0.0)  # a heavy slider barely moves; adiabatic
    y0 = rc.rest_state(p, HALF, pa=1.5e5, pb=1.5e5)
    dt = 1e-4
    ys = simulate(p, y0, np.full(400, p.command_max), dt=dt)
    ys = ys[30:]  # spool settled: the exhaust edge of chamber a is closed
    xo = ys[:, rc.XV]
    assert np.all(circular_orifice_area(p.valve_underlap - xo.min(), p.port_radius) == 0.0)
    assert np.all(ys[:, rc.PA] < p.supply_pressure)  # inflow only
    va, _ = rc.chamber_volumes(ys, p)
    k, r_gas, ts = p.heat_capacity_ratio, p.gas_constant, p.supply_temperature
    du = (ys[:, rc.PA] * va - ys[0, rc.PA] * va[0]) / (k - 1.0)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (ys[1:, rc.PA] + ys[:-1, rc.PA]) * np.diff(va))])
    h_in = k * r_gas / (k - 1.0) * ts * (ys[:, rc.MA] - ys[0, rc.MA])
    assert np.max(np.abs(du + work - h_in)) <= 1e-6 * np.max(np.abs(h_in))
    assert ys[-1, rc.PA] > 4e5  # really filled
    ta, _ = rc.chamber_temperatures(ys[-1], p)
    assert ta[0] > ts + 30.0  # adiabatic filling heats the chamber


def test_wall_heat_exchange_returns_a_sealed_chamber_to_wall_temperature():
    p = sealed(wall_heat_transfer_coefficient=80.0)  # time constant m c_v / (h A_wall) ~ 0.3 s
    y0 = rc.rest_state(p, HALF, ta=350.0, tb=250.0)
    ys = simulate(p, y0, np.full(3000, p.command_centre))
    ta, tb = rc.chamber_temperatures(ys[-1], p)
    assert abs(ta[0] - p.supply_temperature) < 1.0 and abs(tb[0] - p.supply_temperature) < 1.0
    assert ys[-1, rc.MA] == y0[rc.MA]


@pytest.mark.parametrize("h", [0.0, 50.0])
def test_fast_compression_ends_between_isothermal_and_adiabatic_then_relaxes_to_the_wall(h):
    """Sealed chambers, no friction: chamber a at supply pressure drives the slider 15 mm into
    chamber b (at the exhaust's) and onto the bumper at y = L within a few ms. Entering the
    bumper, b is at the adiabatic temperature ``T_s (V_0/V)^(kappa-1)`` with adiabatic walls
    (h = 0, 004 eq (11)), and between the isothermal ``T_s`` and it with the walls' heat
    exchange. Held on the bumper (fixed volume), b then cools back to the wall as
    ``T - T_s ~ exp(-t/tau)``, ``tau = m c_v / (h A_wall + h_line pi d L)``, ``A_wall = 2 A + 4 (V -
    V_line) / D``, the tube's laminar ``h_line`` (no flow); with adiabatic walls it stays hot."""
    p = sealed(wall_heat_transfer_coefficient=h)
    ys = simulate(p, rc.rest_state(p, L - 0.015, pa=p.supply_pressure, pb=p.exhaust_pressure),
                  np.full(2500, p.command_centre))
    k = int(np.argmax(ys[:, rc.Y] >= L))  # first sample on the bumper
    assert 0 < k < 20
    _, vb = rc.chamber_volumes(ys[[0, k]], p)
    _, tb = rc.chamber_temperatures(ys, p)
    t_s = p.supply_temperature
    t_ad = t_s * (vb[0] / vb[1]) ** (p.heat_capacity_ratio - 1.0)
    assert t_ad > t_s + 80.0  # a strong compression
    assert np.all(ys[200:, rc.Y] >= L - 1e-6)  # held on the bumper from 0.2 s on
    if h == 0.0:
        assert tb[k] == pytest.approx(t_ad, rel=1e-3)
        assert tb[-1] > t_s + 80.0  # adiabatic walls: still hot
        return
    assert t_s + 0.5 * (t_ad - t_s) < tb[k] < t_ad - 0.5
    excess = tb - t_s
    assert abs(excess[-1]) < 0.02 * excess[k]  # back at the wall's temperature
    _, v_hold = rc.chamber_volumes(ys[-1], p)
    c_v = p.gas_constant / (p.heat_capacity_ratio - 1.0)
    # the cylinder's wall and, at no flow, the line's at the laminar Nu = 3.66 (air k = 0.0257 W/(m K))
    v_line = math.pi / 4.0 * p.line_bore**2 * p.line_length
    h_line = 3.66 * 0.0257 / p.line_bore
    tau = ys[-1, rc.MB] * c_v / (h * (2.0 * A + 4.0 * (v_hold[0] - v_line) / p.bore)
                                 + h_line * math.pi * p.line_bore * p.line_length)
    t = np.arange(len(ys)) * DT
    # 1-5 tau after the stop; later, the slow creep onto the bumper (a still cooling) heats b by 1e-4 K/s
    window = (t > 0.05) & (t < 0.25)
    rate = -np.polyfit(t[window], np.log(excess[window]), 1)[0]
    assert 1.0 / rate == pytest.approx(tau, rel=0.03)


def test_stall_against_the_stop_reaches_supply_and_exhaust_pressure():
    p = NOMINAL
    ys = simulate(p, rc.rest_state(p, HALF), np.full(3000, p.command_max))
    assert ys[-1, rc.PA] == pytest.approx(p.supply_pressure, rel=1e-4)
    assert ys[-1, rc.PB] == pytest.approx(p.exhaust_pressure, rel=2e-3)
    # the stop holds the thrust minus the stuck seals' share: penetration <= thrust / k
    thrust = A * (p.supply_pressure - p.exhaust_pressure)
    pen = ys[-1, rc.Y] - L
    assert 0.0 < pen <= thrust / p.stop_stiffness * 1.001
    assert pen >= (thrust - p.static_friction) / p.stop_stiffness * 0.999


# ============================================================================ friction (sec. 3, eq (1))
@pytest.mark.parametrize("command", [5.15, 5.4, 6.5, 8.0, 2.0])
def test_constant_speed_pressure_force_is_the_table2_curve(command):
    v, f, s = rx.constant_command_run(NOMINAL, command)
    assert math.isfinite(v) and abs(v) > 3 * NOMINAL.stribeck_velocity
    assert f == pytest.approx(float(rc.steady_friction(NOMINAL, v)), rel=5e-3)


def test_static_friction_mode_has_the_same_steady_curve():
    p = dataclasses.replace(NOMINAL, bristle_stiffness=0.0)
    n = substeps_from_stiffness(rc.stiffness_modes(p), DT)[0]
    assert n <= 2  # sized by the valve and gas spring; the steep curve near v = 0 is refined locally
    assert n * rc.local_mode_refinement(p.to_array(), DT / n) > 25  # there: the cost that made LuGre the default
    v, f, _ = rx.constant_command_run(p, 5.4)
    assert f == pytest.approx(float(rc.steady_friction(p, v)), rel=5e-3)


def test_static_curve_refined_substeps_match_uniform_fine_substeps():
    """Static friction curve (no bristle state), valve swept through reversals (stick, breakaway,
    Stribeck dip): the kernels' coarse sub-steps with local refinement agree with uniform
    sub-steps four times finer than the steepest slope needs and with Radau (rtol 1e-10) over the
    first 2 s (1 um encoder, 500 Pa transducers: the differences must be far below); plain RK4 at
    the coarse sub-step is not even stable."""
    from hydro_envs.plants.rodless_cylinder.kernels import guard as k_guard
    from hydro_envs.plants.rodless_cylinder.kernels import rhs as k_rhs
    from hydro_envs.sim.rk4 import rk4_trajectory

    p = dataclasses.replace(NOMINAL, bristle_stiffness=0.0)
    t = DT * np.arange(4000)
    u = 5.0 + 0.25 * np.sin(2 * np.pi * 0.7 * t) + 0.1 * np.sin(2 * np.pi * 2.3 * t)
    y0 = rc.rest_state(p, HALF)
    n = substeps_from_stiffness(rc.stiffness_modes(p), DT)[0]
    fine = 4 * n * rc.local_mode_refinement(p.to_array(), DT / n)
    refined = simulate(p, y0, u)
    ref = simulate(p, y0, u, n_sub=fine)
    assert np.sum(np.diff(np.sign(ref[:, rc.V])) != 0) >= 4  # reversals
    assert np.abs(refined[:, rc.Y] - ref[:, rc.Y]).max() < 0.1e-6  # 0.034 um
    assert np.abs(refined[:, rc.PA] - ref[:, rc.PA]).max() < 5.0  # 0.42 Pa
    assert np.abs(refined[:, rc.PB] - ref[:, rc.PB]).max() < 5.0  # 0.53 Pa
    radau = reference_rollout(registry.get("rodless_cylinder"), y0, u[:2000, None], p.to_array(), DT, atol=ATOL)
    assert np.abs(refined[:2001, rc.Y] - radau[:, rc.Y]).max() < 0.1e-6  # 0.033 um
    assert np.abs(refined[:2001, rc.PA:rc.PB + 1] - radau[:, rc.PA:rc.PB + 1]).max() < 5.0  # 0.53 Pa

    @nb.njit(cache=False)
    def plain(y0, u, p, n, out):
        return rk4_trajectory(k_rhs, k_guard, y0, u, p, DT, n, np.zeros((5, y0.size)), out)

    out = np.zeros((u.size + 1, rc.N_STATES))
    plain(y0, u[:, None].copy(), p.to_array(), n, out)
    assert not np.abs(out[:, rc.Y] - ref[:, rc.Y]).max() < 1e-6  # 503 um


def test_lugre_presliding_sticks_below_breakaway_and_slides_above():
    """Valve sealed, a slowly rising load below F_s: the seals deflect (004 Fig. 4, displacement
    before sliding) and hold without creep; above F_s the slider breaks away.

    Quasi-static LuGre at v -> 0+ (g = F_s): dz/dy = 1 - sigma0 z / F_s, so
    z(y) = F_s/sigma0 (1 - exp(-sigma0 y / F_s)); the load is shared with the gas spring
    k_gas = kappa p0 A^2 (1/Va + 1/Vb): F = sigma0 z(y) + k_gas y.
    """
    from scipy.optimize import brentq

    base = dataclasses.replace(NOMINAL, valve_underlap=0.0, spool_stroke=NOMINAL.port_radius,
                               wall_heat_transfer_coefficient=0.0)  # adiabatic: the gas spring below
    y = rc.rest_state(base, HALF)
    vol = A * HALF + base.dead_volume_a
    k_gas = base.heat_capacity_ratio * y[rc.PA] * A * A * 2.0 / vol
    s0, fs = base.bristle_stiffness, base.static_friction
    f_final = 20.0  # N, between F_c and F_s
    for f_load in np.linspace(0.2, f_final, 100):  # 2 s ramp: quasi-static
        ys = simulate(dataclasses.replace(base, load_force=f_load), y, np.full(20, 5.0))
        y = ys[-1]
    ys = simulate(dataclasses.replace(base, load_force=f_final), y, np.full(1000, 5.0))
    dy = HALF - ys[:, rc.Y]  # the load pushes towards y = 0
    expected = brentq(lambda d: s0 * fs / s0 * (1 - np.exp(-s0 * d / fs)) + k_gas * d - f_final, 0.0, 1e-2)
    assert dy[-1] == pytest.approx(expected, rel=0.03)
    assert dy[-1] > 1.2 * f_final / (s0 + k_gas)  # more than the elastic share: LuGre slips partly
    assert np.ptp(dy[200:]) < 1e-4 * dy[-1]  # held: no creep over the last 0.8 s
    ys = simulate(dataclasses.replace(base, load_force=45.0), y, np.full(200, 5.0))
    # above F_s: breakaway, the slider runs until the sealed gas spring takes up F - F_c
    assert HALF - ys[-1, rc.Y] > 5 * expected


def test_friction_magnitude_against_measured_xring_seal():
    """Order of magnitude: the rodless cylinder (two piston seals + sealing and dust bands) vs
    one X-ring seal of nearly the same bore, measured at constant speed (CC0 data)."""
    from identification.seal_friction import load_seal_friction

    for bar in (5, 7):
        data = load_seal_friction(DATA / f"X-ring257_{bar}bar.csv", drop_rows=5)
        area = float(data.metadata["piston_area"])
        t, x, pg, f_lc = data.t, data["x"], data["p_gauge"], data["F_load"]
        v = np.gradient(x, t)
        f = pg * area - f_lc
        pos, neg = v > 3e-3, v < -3e-3
        friction = 0.5 * abs(np.median(f[pos]) - np.median(f[neg]))  # load-cell offset cancels
        speed = np.median(np.abs(v[pos | neg]))
        ours = float(rc.steady_friction(NOMINAL, speed))
        assert 2.0 < friction < 30.0
        assert 0.2 < ours / friction < 5.0, (bar, ours, friction)


# ============================================================================ linearisation (eqs (19)-(27))
def test_linearization_matches_the_small_signal_response():
    lin = rc.linearize_mid_stroke(NOMINAL)
    fit = rx.small_signal_response(NOMINAL)
    assert fit["omega_n"] == pytest.approx(lin.omega_n, rel=0.01)
    assert fit["k_t"] == pytest.approx(lin.k_t, rel=0.01)
    assert np.max(np.abs(fit["v"] - fit["v_fit"])) < 1e-3 * np.max(np.abs(fit["v"]))
    # zeta: eq (23) keeps the outflow at T_s; the energy balance adds the isentropic
    # temperature swing of the venting gas, c2 -> c2 + (kappa-1)/(2 kappa) mdot_leak/p0
    # and the walls' heat exchange its thermal damping, (1 - 1/kappa) w tau / (2 (1 + (w tau)^2))
    assert fit["zeta"] == pytest.approx(lin.zeta_energy, rel=0.02)
    adiabatic = dataclasses.replace(NOMINAL, wall_heat_transfer_coefficient=0.0)  # the seed's eq (11)
    fit_ad = rx.small_signal_response(adiabatic)
    assert fit_ad["zeta"] == pytest.approx(rc.linearize_mid_stroke(adiabatic).zeta_energy, rel=0.02)
    assert fit_ad["zeta"] == pytest.approx(lin.zeta, rel=0.10)  # eq (23)
    assert fit["zeta"] > 1.4 * fit_ad["zeta"]  # the walls' share is real (0.0053 vs 0.0035)


def test_linearization_eigenvalues_of_the_nonlinear_jacobian():
    p = frictionless()
    lin = rc.linearize_mid_stroke(p)
    J = numerical_jacobian(rc.rest_state(p, HALF), np.array([p.command_centre]), p.to_array())
    ev = np.linalg.eigvals(J)
    pair = ev[np.argmin(np.abs(np.abs(ev) - lin.omega_n))]
    assert abs(pair) == pytest.approx(lin.omega_n, rel=1e-3)
    assert -pair.real / abs(pair) == pytest.approx(lin.zeta_energy, rel=1e-2)


def test_eq27_equals_an_independent_solution_of_eq20():
    lin = rc.linearize_mid_stroke(NOMINAL)
    rt, k, v0, a, m = lin.rt, lin.kappa, lin.v0, lin.area, lin.mass
    for s in (3.0j, 50.0 + 120.0j, 400.0j):
        xv, f = 1e-5, 2.0
        # unknowns (M_L, p_L, y) of eq (20): three linear equations
        M = np.array([
            [1.0, lin.c2, 0.0],
            [1.0, -v0 * s / (rt * k), -2.0 * lin.p0 * a * s / rt],
            [0.0, a, -m * s * s],
        ], dtype=complex)
        rhs = np.array([2.0 * lin.c1 * xv, 0.0, f], dtype=complex)
        y = np.linalg.solve(M, rhs)[2]
        assert lin.position(s, x_v=xv, f=f) == pytest.approx(y, rel=1e-10)
    num, den = lin.spool_to_position()
    s = 7.0j
    assert np.polyval(num, s) / np.polyval(den, s) == pytest.approx(lin.position(s, x_v=1.0), rel=1e-12)
    num, den = lin.force_to_position()
    assert np.polyval(num, s) / np.polyval(den, s) == pytest.approx(lin.position(s, f=1.0), rel=1e-12)


# ============================================================================ numerics
def _step_commands(seconds, hold=120):
    """Steps between levels that drive the slider into both stops and back."""
    n = int(round(seconds / DT))
    return np.repeat([9.5, 0.5, 8.0, 0.0, 6.2, 3.0], hold)[:n]


ATOL = np.array([1e-12, 1e-10, 1e-2, 1e-2, 1e-13, 1e-13, 1e-13, 1e-10, 1e-13])


def test_fixed_step_matches_radau_with_stop_contact():
    p = NOMINAL
    cmds = _step_commands(1.5, hold=250)  # the walls' and the lines' heat exchange slows the strokes
    y0 = rc.rest_state(p, HALF)
    n_sub = substeps_from_stiffness(rc.stiffness_modes(p), DT)[0]
    fixed = simulate(p, y0, cmds, n_sub)
    ref = reference_rollout(registry.get("rodless_cylinder"), y0, cmds[:, None], p.to_array(), DT, rtol=1e-10, atol=ATOL)
    assert (ref[:, rc.Y] > L).any() and (ref[:, rc.Y] < 0.0).any()  # both stops hit

    def nrmse(a, b):
        return float(np.sqrt(np.mean((a - b) ** 2)) / np.ptp(b))

    assert nrmse(fixed[:, rc.Y], ref[:, rc.Y]) <= 1e-4
    assert max(nrmse(fixed[:, j], ref[:, j]) for j in (rc.PA, rc.PB)) <= 1e-3


def numerical_jacobian(y, u, p_arr):
    scale = np.maximum(np.abs(y) * 1e-6, np.array([1e-8, 1e-7, 1e-2, 1e-2, 1e-12, 1e-12, 1e-10, 1e-8, 1e-10]))
    J = np.empty((rc.N_STATES, rc.N_STATES))
    for j in range(rc.N_STATES):
        yp, ym = y.copy(), y.copy()
        yp[j] += scale[j]
        ym[j] -= scale[j]
        fp, fm = np.empty(rc.N_STATES), np.empty(rc.N_STATES)
        registry.get("rodless_cylinder").kernels.rhs(yp, u, p_arr, fp)
        registry.get("rodless_cylinder").kernels.rhs(ym, u, p_arr, fm)
        J[:, j] = (fp - fm) / (2 * scale[j])
    return J


def test_stiffness_bound_covers_the_numerical_jacobian(spec):
    rng = np.random.default_rng(0)
    sets = [NOMINAL, spec.corner(False), spec.corner(True),
            spec.corner(rng.integers(0, 2, len(spec.entries)).astype(bool)),
            dataclasses.replace(NOMINAL, flow_model=1.0), dataclasses.replace(NOMINAL, bristle_stiffness=0.0)]
    for p in sets:
        modes = rc.stiffness_modes(p)
        bound = max(modes.values())
        pa = p.to_array()
        ps, pe = p.supply_pressure, p.exhaust_pressure
        vmax = rc.speed_bound(p)
        pen = A * ps / p.stop_stiffness
        worst = 0.0
        for y in (-pen, 0.5 * L, L + pen):
            for v in (0.0, -1e-3, -vmax):
                for pA, pB in ((ps * 0.9995, pe), (pe * 1.0005, ps * 0.9995), (1.4 * ps, pe)):
                    for tA, tB in ((400.0, 180.0), (180.0, 400.0)):
                        for xv in (p.spool_stroke, -p.spool_stroke):
                            for zf in (1.0, -1.0):
                                s = rc.rest_state(p, y, v, pA, pB, tA, tB)
                                s[rc.XV] = xv
                                if p.bristle_stiffness > 0:
                                    s[rc.Z] = zf * p.static_friction / p.bristle_stiffness
                                lam = np.abs(np.linalg.eigvals(numerical_jacobian(s, np.array([5.0]), pa))).max()
                                # the kernels refine where a locally stiff mode exceeds the modes' bound
                                local = max(bound, rc.local_mode_rate(s, pa))
                                assert lam <= local * 1.02, (lam, local, v, modes)
                                worst = max(worst, lam / local * bound)
        assert worst >= 0.5 * bound  # the bound is not uselessly loose


def test_substeps_for_nominal_and_corners(spec):
    assert substeps_from_stiffness(rc.stiffness_modes(NOMINAL), DT)[0] == 2  # set by the stuck bristles
    for flags in (False, True):
        p = spec.corner(flags)
        modes = rc.stiffness_modes(p)
        n_sub, h, _ = substeps_from_stiffness(modes, DT)
        assert n_sub <= 8
        assert h * max(modes.values()) <= DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT + 1e-12


def test_parallel_and_serial_kernels_are_bit_identical(spec):
    rng = np.random.default_rng(1)
    n = 32
    params = [spec.sample(rng) for _ in range(n)]
    P = np.stack([q.to_array() for q in params])
    Y0 = np.stack([rc.rest_state(q, rng.uniform(0.2, 0.8) * q.stroke) for q in params])
    nsub = np.array([substeps_from_stiffness(rc.stiffness_modes(q), DT)[0] for q in params], dtype=np.int64)
    out = []
    for kernel in (registry.get("rodless_cylinder").kernels.step_serial, registry.get("rodless_cylinder").kernels.step_parallel):
        Y_ = Y0.copy()
        W = np.zeros((n, 5, rc.N_STATES))
        c = np.zeros(n, dtype=np.int64)
        rng_u = np.random.default_rng(2)
        for _ in range(200):
            kernel(Y_, rng_u.uniform(0, 10, (n, 1)), P, DT, nsub, W, c)
        out.append(Y_)
    assert np.array_equal(out[0], out[1])


# ============================================================================ guards
def test_guard_clamps_pressure_and_mass_to_positive_floors():
    p = NOMINAL
    y = rc.rest_state(p, HALF)
    y[rc.PA], y[rc.MB] = -5.0, -1e-9
    assert rc.rodless_cylinder_guard(y, p.to_array()) == 2
    assert y[rc.PA] == p.pressure_floor and y[rc.MB] == p.min_gas_mass
    # at the floor the derivative cannot push further down, and T stays finite and positive
    y = rc.rest_state(p, 0.0, v=-0.5)
    y[rc.PB] = p.pressure_floor
    dy = np.empty(rc.N_STATES)
    registry.get("rodless_cylinder").kernels.rhs(y, np.array([10.0]), p.to_array(), dy)
    assert np.all(np.isfinite(dy)) and dy[rc.PB] >= 0.0


def _bang_bang(n, rng):
    out = np.empty((n, 1), dtype=np.float32)
    a, k = float(rng.choice([-1.0, 1.0])), 0
    while k < n:
        hold = int(rng.integers(100, 400))
        out[k : k + hold] = a
        a, k = -a, k + hold
    return out


def test_guards_at_randomisation_extremes_with_bang_bang(spec):
    """Default sub-steps, bang-bang valve into both stops: pressures and temperatures stay
    physical without the floors ever being needed, speeds stay below the stiffness bound's."""
    rng = np.random.default_rng(2024)
    n = len(spec.entries)
    corners = [spec.corner(False), spec.corner(True)] + [
        spec.corner(list(rng.integers(0, 2, n).astype(bool))) for _ in range(3)]
    env = gym.make(ENV_ID, randomize=False).unwrapped
    for c in corners:
        pd = c.as_dict()
        obs, info = env.reset(seed=int(rng.integers(1000)), options={"params": pd})
        S = []
        for a in _bang_bang(2000, rng):
            obs, r, _, _, info = env.step(a)
            assert math.isfinite(r) and np.all(np.isfinite(obs))
            S.append([info["state"][k] for k in STATE_KEYS])
        S = np.array(S)
        ta, tb = rc.chamber_temperatures(S, c)
        assert env.guard_clamps == 0
        assert S[:, [rc.PA, rc.PB]].min() > 0.3 * c.exhaust_pressure
        assert S[:, [rc.PA, rc.PB]].max() < 1.5 * c.supply_pressure
        assert min(ta.min(), tb.min()) > 120.0 and max(ta.max(), tb.max()) < 600.0
        # stop penetration: static thrust plus the impact at the speed bound
        pen = A * 1.5 * c.supply_pressure / c.stop_stiffness + rc.speed_bound(c) * math.sqrt(c.mass / c.stop_stiffness)
        assert S[:, rc.Y].min() >= -pen and S[:, rc.Y].max() <= c.stroke + pen
        assert np.ptp(S[:, rc.Y]) > 0.8 * c.stroke  # really travelled into both stops
        assert np.abs(S[:, rc.V]).max() <= rc.speed_bound(c)


# ============================================================================ validation rows
def test_validation_rows():
    rows = {r.name.split(": ", 1)[1]: r for r in rv.rows()}
    assert len(rows) == 7 and all(r.source and r.unit for r in rows.values())
    for name, r in rows.items():
        # the two eq (32) rows run the seed's procedure (independent), the nominal flow checks the
        # valve against its data sheet (table); the rest check the model
        expected = "independent" if "eq (32)" in name else "table" if "data sheet" in name else "consistency"
        assert r.kind == expected and r.passed, (r.name, r.published, r.reproduced, r.tolerance)


def test_linear_damping_with_viscous_friction():
    """The friction-inclusive damping is the eq (23) value at sigma = 0, grows with sigma and
    falls with the moving mass."""
    lin = rc.linearize_mid_stroke(RodlessCylinderParams())
    assert rv.damping_with_viscous_friction(lin, 0.0) == pytest.approx(lin.zeta_energy, rel=1e-12)
    z310 = rv.damping_with_viscous_friction(lin, 310.0)
    assert z310 > 100 * lin.zeta_energy
    heavy = rc.linearize_mid_stroke(RodlessCylinderParams(mass=20.0))
    assert rv.damping_with_viscous_friction(heavy, 310.0) < 0.5 * z310


def test_closed_loop_friction_compensation_is_eq27_opening():
    """Without compensation the ARX input is the valve command (bit for bit as before); with
    it, the valve gets the controller output plus eq (27)'s opening for the Table 2 friction at
    the backward-difference velocity."""
    from hydro_envs.plants.rodless_cylinder.experiments import closed_loop_m_sequence

    p = RodlessCylinderParams()
    plain = closed_loop_m_sequence(p, n_bits=6, position_noise_std=5e-6, seed=1)
    assert np.array_equal(plain["u"], plain["u_valve"])
    static, dynamic = rc.friction_compensation_gains(p)
    lin = rc.linearize_mid_stroke(p)
    assert static > 0 and dynamic > 0
    assert dynamic / static == pytest.approx(lin.v0 / (lin.rt * lin.kappa * lin.c2), rel=1e-12)
    comp = closed_loop_m_sequence(p, n_bits=6, position_noise_std=5e-6, seed=1, friction_compensation=True)
    added = comp["u_valve"] - comp["u"]
    assert added[0] == 0.0  # no velocity before the second sample
    f = rc.steady_friction(p, np.diff(comp["y"]) / 0.01)
    expect = static * f + dynamic * np.diff(np.r_[0.0, f]) / 0.01
    inside = (comp["u_valve"][1:] > 0.0) & (comp["u_valve"][1:] < p.command_max)
    assert inside.all()
    assert np.allclose(added[1:], expect, rtol=1e-12, atol=1e-12)


# ================================================= local refinement of the stiff-in-places modes
@nb.njit(cache=True)
def _coarse(y0, y, p, h, m):
    return 1


@nb.njit(cache=True)
def _finest(y0, y, p, h, m):
    return m


@nb.njit(cache=True)
def _lookahead(refinement, y, u, p, h, n_sub, m, work):
    return rk4_advance_lookahead(rc.rodless_cylinder_rhs, rc.rodless_cylinder_guard, refinement, y, u, p, h, n_sub,
                                 m, work)


@nb.njit(cache=True)
def _plain(y, u, p, h, n_sub, work):
    return rk4_advance(rc.rodless_cylinder_rhs, rc.rodless_cylinder_guard, y, u, p, h, n_sub, work)


def test_lookahead_step_is_plain_rk4_coarse_or_fine():
    """A look-ahead step whose refinement is always 1 is rk4_advance's step bit for bit; one
    whose refinement is always m is m sub-steps of h / m, bit for bit."""
    p = NOMINAL.to_array()
    y0 = rc.rest_state(NOMINAL, 0.3 * L)
    u = np.array([6.5])
    h, n_sub, m = 5e-4, 2, 3
    for refinement, (hh, nn) in ((_coarse, (h, n_sub)), (_finest, (h / m, n_sub * m))):
        a, b = y0.copy(), y0.copy()
        for _ in range(50):
            _lookahead(refinement, a, u, p, h, n_sub, m, np.zeros((5, rc.N_STATES)))
            _plain(b, u, p, hh, nn, np.zeros((5, rc.N_STATES)))
        assert np.array_equal(a, b)


def test_local_modes_left_out_of_the_substep_are_refined_where_stiff():
    """The sub-step count ignores the flow law's tail, the LuGre slip and the bumpers (worst
    cases far above the stuck bristles'); the test refines a state on a bumper, one at speed
    and one with a small chamber at supply pressure, and not the slider at rest mid-stroke."""
    p = NOMINAL.to_array()
    n = substeps_from_stiffness(rc.stiffness_modes(NOMINAL), DT)[0]
    h = DT / n
    worst = rc.local_mode_rates(NOMINAL)
    assert min(worst.values()) * h > DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT
    assert rc.local_mode_refinement(p, h) >= max(worst.values()) * h / (DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT)
    rest = rc.rest_state(NOMINAL, HALF)
    assert rc.local_mode_shallow(rest, rest, p, h)
    on_stop = rc.rest_state(NOMINAL, -1e-5)
    fast = rc.rest_state(NOMINAL, HALF, v=-0.8)
    full = rc.rest_state(NOMINAL, 1e-3, pa=NOMINAL.supply_pressure * 0.9999)
    for s in (on_stop, fast, full):
        assert not rc.local_mode_shallow(s, s, p, h)
    # a chamber pressure passing the supply pressure between the start and the prediction
    past = full.copy()
    past[rc.PA] = NOMINAL.supply_pressure * 1.05
    below = full.copy()
    below[rc.PA] = NOMINAL.supply_pressure * 0.95
    assert rc.local_mode_shallow(below, below, p, 1e-9) and not rc.local_mode_shallow(below, past, p, 1e-9)
    # the compact test of the LuGre kernels decides as the general one
    rng = np.random.default_rng(3)
    for _ in range(300):
        a = rc.rest_state(NOMINAL, rng.uniform(-1e-4, L + 1e-4), v=rng.uniform(-0.9, 0.9),
                          pa=rng.uniform(0.9, 1.0) * NOMINAL.supply_pressure,
                          pb=rng.uniform(1.0, 1.2) * NOMINAL.exhaust_pressure)
        b = a.copy()
        b[rc.PA] *= rng.uniform(0.98, 1.02)
        assert rc.lugre_local_shallow(a, b, p, h) == rc.local_mode_shallow(a, b, p, h)


def test_local_substeps_follow_the_local_rates():
    """The look-ahead's fine-step count: 1 where the modes are not stiff; with a bristle state,
    the count that takes the larger local rate at start and Euler prediction stably with the
    1.5x margin, capped by the worst case; the worst case on a bumper, across the supply
    pressure and, for the static curve, wherever the test fails."""
    assert [local_substeps(z, 1.0, 5) for z in (0.5, 1.0, 1.01, 2.0, 3.0)] == [1, 1, 2, 3, 5]
    assert local_substeps(3.0, 1.0, 4) == 4
    p = NOMINAL.to_array()
    n = substeps_from_stiffness(rc.stiffness_modes(NOMINAL), DT)[0]
    h = DT / n
    m = rc.local_mode_refinement(p, h)
    stable = DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT
    rest = rc.rest_state(NOMINAL, HALF)
    assert rc.local_mode_substeps(rest, rest, p, h, m) == 1
    on_stop = rc.rest_state(NOMINAL, -1e-5)
    assert rc.local_mode_substeps(rest, on_stop, p, h, m) == m
    full = rc.rest_state(NOMINAL, 1e-3, pa=NOMINAL.supply_pressure * 0.95)
    past = full.copy()
    past[rc.PA] = NOMINAL.supply_pressure * 1.05
    assert rc.local_mode_substeps(full, past, p, h, m) == m
    counts = []
    for v in (0.1, 0.3, -0.5, 0.8, -1.2):
        a = rc.rest_state(NOMINAL, HALF, v=v)
        b = rc.rest_state(NOMINAL, HALF, v=1.05 * v)
        k = rc.local_mode_substeps(a, b, p, h, m)
        rate = max(rc.local_mode_rate(a, p), rc.local_mode_rate(b, p))
        if h * rate <= stable:
            assert k == 1
        else:
            assert 2 <= k <= m and (k == m or h * rate / k <= stable / 1.5 * 1.0000001)
        counts.append(k)
    assert min(counts) == 1 and 1 < max(counts)
    static = dataclasses.replace(NOMINAL, bristle_stiffness=0.0)
    ps = static.to_array()
    slow = rc.rest_state(static, HALF, v=1e-4)  # on the curve's steep part near v = 0
    assert not rc.local_mode_shallow(slow, slow, ps, h)
    assert rc.local_mode_substeps(slow, slow, ps, h, 7) == 7


def test_lugre_refined_substeps_match_uniform_fine_substeps():
    """LuGre (the default), valve swept through reversals and into both bumpers at full
    opening: the kernels' coarse sub-steps with look-ahead refinement agree with uniform
    sub-steps as fine as the worst case needs, four times over, within the sensors' resolution
    (1 um encoder, 500 Pa transducers: 0.3 um, 8 Pa); plain RK4 at the coarse sub-step is ten
    times further off (3 um, 170 Pa)."""
    p = NOMINAL
    t = DT * np.arange(3000)
    u = 5.0 + 4.9 * np.sign(np.sin(2 * np.pi * 1.5 * t)) + 0.2 * np.sin(2 * np.pi * 7.0 * t)
    y0 = rc.rest_state(p, HALF)
    n = substeps_from_stiffness(rc.stiffness_modes(p), DT)[0]
    fine = 4 * n * rc.local_mode_refinement(p.to_array(), DT / n)
    refined = simulate(p, y0, u)
    ref = simulate(p, y0, u, n_sub=fine)
    assert ref[:, rc.Y].min() < 0.0 and ref[:, rc.Y].max() > L  # both bumpers
    assert np.abs(ref[:, rc.V]).max() > 0.3  # at speed
    err_y = np.abs(refined[:, rc.Y] - ref[:, rc.Y]).max()
    assert err_y < 1e-6
    assert np.abs(refined[:, rc.PA:rc.PB + 1] - ref[:, rc.PA:rc.PB + 1]).max() < 50.0
    y = y0.copy()
    plain = [y.copy()]
    for k in range(len(u)):
        _plain(y, np.array([u[k]]), p.to_array(), DT / n, n, np.zeros((5, rc.N_STATES)))
        plain.append(y.copy())
    assert np.abs(np.array(plain)[:, rc.Y] - ref[:, rc.Y]).max() > 5 * err_y
