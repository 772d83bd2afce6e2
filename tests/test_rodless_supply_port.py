"""The rodless cylinder's supply droop law (``model.supply_port_pressure``): the pressure at the
valve's P port when the supply line's resistance lowers it with the drawn mass flow, checked
against the law itself, its choked closed form and a bracketing root finder (scipy's brentq)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.optimize import brentq

from hydro_envs.laws.orifice import circular_orifice_area
from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams

NOMINAL = RodlessCylinderParams()


@pytest.mark.parametrize("flow_model", [0.0, 1.0])
def test_supply_port_pressure_solves_the_droop_law(flow_model):
    """p_P = p_s - R mdot_P(p_P): exact p_s at R = 0 or with no draw, the law's root otherwise,
    the choked closed form p_s / (1 + R k) when both P edges are choked, falling with R."""
    p0 = dataclasses.replace(NOMINAL, flow_model=flow_model)
    xvm, r = p0.spool_stroke, p0.port_radius
    s_full = circular_orifice_area(p0.valve_underlap + xvm, r)
    s_half = circular_orifice_area(p0.valve_underlap + 0.3 * xvm, r)
    s_leak = circular_orifice_area(p0.valve_underlap - 0.3 * xvm, r)
    a0 = p0.to_array()
    assert rc.supply_port_pressure(a0, s_full, 0.0, 2e5, 293.15, 6e5, 293.15) == p0.supply_pressure
    last = p0.supply_pressure
    for res in (1e6, 1e7, 1e8, 1e9):
        a = dataclasses.replace(p0, supply_line_resistance=res).to_array()
        for s_p, s_m, pa, pb in ((s_full, 0.0, 2e5, 6e5), (s_half, s_leak, 4e5, 5e5), (s_leak, s_half, 3e5, 6.5e5)):
            psv = rc.supply_port_pressure(a, s_p, s_m, pa, 293.15, pb, 280.0)
            drawn = rc._port_draw(a, s_p, s_m, pa, 293.15, pb, 280.0, psv)
            assert psv == pytest.approx(p0.supply_pressure - res * drawn, abs=1e-6 * p0.supply_pressure)
            assert psv <= p0.supply_pressure
        # no draw: the P edges closed, or a chamber above the supply pushing back only
        assert rc.supply_port_pressure(a, 0.0, 0.0, 2e5, 293.15, 6e5, 293.15) == p0.supply_pressure
        assert rc.supply_port_pressure(a, s_full, 0.0, 8e5, 293.15, 6e5, 293.15) == p0.supply_pressure
        psv = rc.supply_port_pressure(a, s_full, 0.0, 1.2e5, 293.15, 6e5, 293.15)
        assert psv < last
        last = psv
    if flow_model == 0.0:  # chamber A far below the port: choked, mdot = k p
        a = dataclasses.replace(p0, supply_line_resistance=1e8).to_array()
        k = rc._edge_flow_py(p0, s_full, 1e5, 1.0, 293.15) / 1e5
        expected = p0.supply_pressure / (1.0 + 1e8 * k)
        assert rc.supply_port_pressure(a, s_full, 0.0, 1.2e5, 293.15, 6e5, 293.15) == pytest.approx(expected, rel=1e-9)


def _random_ports(p0, rng, n):
    """``n`` random valve openings and chamber states: ``(s_plus, s_minus, pa, ta, pb, tb)``."""
    xvm, r = p0.spool_stroke, p0.port_radius
    for _ in range(n):
        xo = rng.uniform(-xvm, xvm)
        pa, pb = rng.uniform(1.05e5, 7.5e5, 2)
        ta, tb = rng.uniform(250.0, 340.0, 2)
        yield (circular_orifice_area(p0.valve_underlap + xo, r), circular_orifice_area(p0.valve_underlap - xo, r),
               pa, ta, pb, tb)


@pytest.mark.parametrize("flow_model", [0.0, 1.0])
def test_supply_port_pressure_is_the_root(flow_model):
    """The droop solve returns the root of p - p_s + R mdot_P(p) (brentq to machine precision)
    within 1e-10 p_s (7e-5 Pa) over random openings, chamber states and resistances (both flow laws),
    also where the root lies near a chamber pressure and plain Newton hops across it."""
    p0 = dataclasses.replace(NOMINAL, flow_model=flow_model)
    ps = p0.supply_pressure
    rng = np.random.default_rng(7)
    worst = 0.0
    for res in (1e6, 1e8, 4e8, 2e9):
        a = dataclasses.replace(p0, supply_line_resistance=res).to_array()
        for s_p, s_m, pa, ta, pb, tb in _random_ports(p0, rng, 150):
            psv = rc.supply_port_pressure(a, s_p, s_m, pa, ta, pb, tb)
            g = lambda x: x - ps + res * rc._port_draw(a, s_p, s_m, pa, ta, pb, tb, x)  # noqa: E731
            if g(ps) <= 0.0:
                assert psv == ps
                continue
            root = brentq(g, 1e3, ps, xtol=1e-14 * ps, rtol=4 * np.finfo(float).eps)
            worst = max(worst, abs(psv - root) / ps)
    assert worst <= 1e-10, worst


@pytest.mark.parametrize("flow_model", [0.0, 1.0])
def test_port_flows_obey_the_droop_law_at_the_port_pressure(flow_model):
    """The P-edge flows the right-hand side takes from the solve (carried along their slopes over
    its last Newton step) satisfy ``p_P = p_s - R (mdot_PA + mdot_PB)`` to rounding, and equal the
    edges' flows evaluated at ``p_P`` within 1e-6 of the flow through both edges (of the order of
    the last step squared; of the step itself where ``p_P`` lies near a kink of the flow law, the
    start of its laminar tail: 5e-8 there); with a stiff supply they are those flows exactly."""
    p0 = dataclasses.replace(NOMINAL, flow_model=flow_model)
    ps = p0.supply_pressure
    rng = np.random.default_rng(11)
    stiff = p0.to_array()
    worst = 0.0
    for res in (1e8, 4e8, 2e9):
        a = dataclasses.replace(p0, supply_line_resistance=res).to_array()
        for s_p, s_m, pa, ta, pb, tb in _random_ports(p0, rng, 100):
            psv, m_a, m_b = rc.supply_port_flows(a, s_p, s_m, pa, ta, pb, tb)
            assert psv == rc.supply_port_pressure(a, s_p, s_m, pa, ta, pb, tb)
            drawn = rc._port_draw(a, s_p, s_m, pa, ta, pb, tb, psv)
            if psv == ps:  # no net draw: the stiff supply's flows
                assert (m_a + m_b) == drawn
                continue
            assert psv == pytest.approx(ps - res * (m_a + m_b), rel=1e-13, abs=1e-6)
            scale = abs(m_a) + abs(m_b)
            worst = max(worst, abs(m_a - rc._supply_edge_flow(a, s_p, psv, pa, ta)) / scale,
                        abs(m_b - rc._supply_edge_flow(a, s_m, psv, pb, tb)) / scale)
            psv0, m_a0, m_b0 = rc.supply_port_flows(stiff, s_p, s_m, pa, ta, pb, tb)
            assert (psv0, m_a0, m_b0) == (ps, rc._supply_edge_flow(stiff, s_p, ps, pa, ta),
                                          rc._supply_edge_flow(stiff, s_m, ps, pb, tb))
    assert worst <= 1e-6, worst
