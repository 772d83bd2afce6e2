"""Relief valves: the law against its hand-computed characteristic, the load-sensing main relief
against its own description, and the port reliefs of the table and the servo cylinder capping a
braking chamber where, without them, it rises far above the supply."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hydro_envs import registry, sim
from hydro_envs.laws import linear_relief_flow, pressure_relief_conductance_bound, pressure_relief_flow, relief_valve_opening
from hydro_envs.plants.load_sensing import model as ls
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.shaking_table import model as st

BAR = 1e5
LPM = 1e-3 / 60.0


def test_relief_flow_is_the_opening_times_the_full_root():
    pc, po, q = 200 * BAR, 20 * BAR, 40 * LPM
    assert pressure_relief_flow(0.0, pc, po, q) == 0.0
    assert pressure_relief_flow(pc, pc, po, q) == 0.0
    assert pressure_relief_flow(-300 * BAR, pc, po, q) == 0.0  # a check backwards
    # half open at 210 bar: 0.5 * q * sqrt(210/220) (by hand: 0.48850 q)
    assert pressure_relief_flow(pc + 0.5 * po, pc, po, q) == pytest.approx(0.48850421 * q, rel=1e-7)
    assert pressure_relief_flow(pc + po, pc, po, q) == pytest.approx(q, rel=1e-14)  # rated at full opening
    # beyond full opening the turbulent root of the full port: 4x the drop over it -> ...
    assert pressure_relief_flow(4 * (pc + po), pc, po, q) == pytest.approx(2.0 * q, rel=1e-14)
    assert relief_valve_opening(pc + 0.25 * po, pc, po) == pytest.approx(0.25)
    assert relief_valve_opening(pc + 5 * po, pc, po) == 1.0
    assert linear_relief_flow(pc + 7 * BAR, pc, 1e-9) == pytest.approx(7e-4, rel=1e-12)
    assert linear_relief_flow(pc - 1.0, pc, 1e-9) == 0.0


def test_relief_conductance_bound_is_the_largest_slope():
    pc, po, q = 230 * BAR, 23 * BAR, 6.7e-4
    dp = np.linspace(pc - 5 * BAR, pc + 3 * po, 200001)
    flow = np.array([pressure_relief_flow(d, pc, po, q) for d in dp])
    assert np.all(np.diff(flow) >= 0.0)  # monotone, continuous (no jump at cracking or full opening)
    assert np.max(np.abs(np.diff(flow))) <= q * (dp[1] - dp[0]) * 1.1 / po
    slope = np.diff(flow) / np.diff(dp)
    bound = pressure_relief_conductance_bound(pc, po, q)
    assert slope.max() <= bound
    assert slope.max() >= bound * (1.0 - 1e-4)  # attained at full opening


def test_load_sensing_main_relief_passes_42_l_min_at_7_bar_override():
    """The field's description: 42 L/min (the pump's full flow) at 7 bar above cracking. Through
    the kernel: the delivery node's pressure rate with and without the relief differ by
    beta / V_s times the relief flow."""
    p = ls.LoadSensingParams()
    assert p.pump_displacement * p.pump_speed == pytest.approx(42 * LPM, rel=1e-12)  # 28 cm^3/rev, 1500 rpm
    y = ls.standby_state(p, 0.1)
    y[ls.PS] = p.relief_pressure + 7 * BAR
    u = np.zeros(2)
    d_with, d_without = np.zeros(ls.N_STATES), np.zeros(ls.N_STATES)
    ls.load_sensing_rhs(y, u, p.to_array(), d_with)
    ls.load_sensing_rhs(y, u, dataclasses.replace(p, relief_gradient=0.0).to_array(), d_without)
    q_relief = (d_without[ls.PS] - d_with[ls.PS]) * p.delivery_volume / p.bulk_modulus
    assert q_relief == pytest.approx(42 * LPM, rel=1e-9)


def _braking(plant, p, y0, command, steps, dt=1e-3):
    return sim.simulate(registry.get(plant), p, np.full(steps, command, dtype=float), y0, dt)


def test_table_port_relief_caps_a_braking_chamber():
    """The loaded table (850 kg) running at its no-load speed, valve slammed shut: the outlet
    chamber a is compressed until its relief passes the displacement flow. Peak between
    cracking and full flow; without the reliefs (relief_flow = 0) it rises past full flow (277 bar)."""
    p = st.ShakingTableParams()
    v0 = -st.no_load_velocity(p)
    y0 = st.rest_state(p, v=v0)
    ys = _braking("shaking_table", p, y0, 0.0, 200)
    peak = ys[:, st.PA].max()
    assert p.relief_pressure < peak < p.relief_pressure + p.relief_override
    # quasi-steady at the peak: the relief passes about the displacement flow A |v|
    k = int(np.argmax(ys[:, st.PA]))
    q = st.relief_flow(ys[k, st.PA], p.to_array())
    assert 0.0 < q <= p.piston_area * abs(v0) * 1.05
    none = _braking("shaking_table", dataclasses.replace(p, relief_flow=0.0), y0, 0.0, 200)
    assert none[:, st.PA].max() > p.relief_pressure + p.relief_override


def test_servo_port_relief_caps_a_braking_chamber():
    """A 200 kg load on the piston at its no-load speed, valve shut: chamber 2 is compressed up
    to its relief; without the reliefs past their full-flow pressure."""
    p = dataclasses.replace(sc.ServoCylinderParams(), mass=200.0)
    v0 = sc.no_load_velocity(p)
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    y0 = np.array([0.02, v0, pm, pm, 0.0, 0.0, 0.0])  # 20 mm from the chamber-1 end, moving out
    ys = _braking("servo_cylinder", p, y0, 0.0, 100)
    assert p.relief_pressure < ys[:, sc.P2].max() < p.relief_pressure + p.relief_override
    none = _braking("servo_cylinder", dataclasses.replace(p, relief_flow=0.0), y0, 0.0, 100)
    assert none[:, sc.P2].max() > p.relief_pressure + p.relief_override
    assert math.isfinite(ys[-1, sc.X])
