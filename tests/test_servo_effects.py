"""Servo-cylinder effects outside the seed model (valve lap, seal leaks, asymmetric and
pressure-dependent friction): the right-hand side against hand formulas, and 0 = the seed."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hydro_envs.plants.servo_cylinder import model as sc


def _rhs(params, y, u=0.0):
    dy = np.empty(sc.N_STATES)
    sc.servo_cylinder_rhs(np.asarray(y, float), np.array([u]), params.to_array(), dy)
    return dy


def _state(p, x=None, v=0.0, p1=None, p2=None, xv=0.0):
    y = np.zeros(sc.N_STATES)
    y[sc.X] = p.stroke / 2 if x is None else x
    y[sc.V] = v
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    y[sc.P1] = pm if p1 is None else p1
    y[sc.P2] = pm if p2 is None else p2
    y[sc.XV] = xv
    return y


def test_leaks_match_the_laminar_leak_law():
    p = dataclasses.replace(sc.ServoCylinderParams(), internal_leakage=4e-13, external_leakage=1e-13)
    y = _state(p, p1=9e6, p2=3e6)
    dy = _rhs(p, y)
    v1 = p.piston_area * y[sc.X] + p.line_volume_1
    v2 = p.piston_area * (p.stroke - y[sc.X]) + p.line_volume_2
    q_il = 4e-13 * 6e6
    assert dy[sc.P1] == pytest.approx(p.bulk_modulus / v1 * (-q_il - 1e-13 * (9e6 - p.tank_pressure)), rel=1e-12)
    assert dy[sc.P2] == pytest.approx(p.bulk_modulus / v2 * (q_il - 1e-13 * (3e6 - p.tank_pressure)), rel=1e-12)
    # the seed model (no leaks): closed valve, piston at rest -> pressures stay
    dy0 = _rhs(sc.ServoCylinderParams(), y)
    assert dy0[sc.P1] == 0.0 and dy0[sc.P2] == 0.0


def test_overlap_is_a_dead_band_and_underlap_leaks_at_null():
    base = sc.ServoCylinderParams()
    lap = 0.03e-3
    over = dataclasses.replace(base, valve_overlap=lap)
    y = _state(base, p1=5e6, p2=9e6, xv=0.8 * lap)
    assert _rhs(over, y)[sc.P1] == 0.0  # inside the dead band: no flow
    y[sc.XV] = 2 * lap  # past the lap: opening xv - lap, as the critical valve at xv - lap
    crit = _rhs(base, _state(base, p1=5e6, p2=9e6, xv=lap))
    assert _rhs(over, y)[sc.P1] == pytest.approx(crit[sc.P1], rel=1e-12)
    under = dataclasses.replace(base, valve_overlap=-lap)
    y = _state(base, p1=5e6, p2=9e6, xv=0.0)
    dy = _rhs(under, y)
    rho, cd, w = base.oil_density, base.discharge_coefficient, base.area_gradient
    q1 = cd * w * lap * math.sqrt(2 / rho) * (math.sqrt(base.supply_pressure - 5e6) - math.sqrt(5e6 - base.tank_pressure))
    v1 = base.piston_area * y[sc.X] + base.line_volume_1
    # hand sqrt vs the regularised root (laminar core below 1e5 Pa): < 0.1 % apart at MPa drops
    assert dy[sc.P1] == pytest.approx(base.bulk_modulus / v1 * q1, rel=1e-3)
    # null pressure of the underlapped valve: both chambers at (p_s + p_R)/2 stay there
    assert abs(_rhs(under, _state(base, xv=0.0))[sc.P1]) < 1e-6


def test_asymmetric_and_pressure_dependent_friction_levels():
    base = dataclasses.replace(sc.ServoCylinderParams(), viscous_friction=0.0, static_friction=40.0)
    v = 0.05
    a = 0.3
    c_p = 5e-6
    dp = 2e6
    for sign in (1, -1):
        p = dataclasses.replace(base, friction_asymmetry=a, friction_pressure_coefficient=c_p)
        pm = 0.5 * (p.supply_pressure + p.tank_pressure)
        expected = sign * (1 + a * sign) * (40.0 + c_p * dp)
        y = _state(p, v=sign * v, p1=pm + dp / 2, p2=pm - dp / 2)
        y[sc.Z] = expected / p.bristle_stiffness  # the LuGre seals in steady sliding
        dy = _rhs(p, y)
        friction = (p.piston_area * dp - p.mass * dy[sc.V])
        assert dy[sc.Z] == pytest.approx(0.0, abs=1e-15)
        assert friction == pytest.approx(expected, rel=1e-9)


def test_stiffness_bound_covers_the_effects():
    p = dataclasses.replace(sc.ServoCylinderParams(), valve_overlap=-0.05e-3, internal_leakage=1e-11,
                            friction_asymmetry=0.5, friction_pressure_coefficient=1e-5)
    modes = sc.stiffness_modes(p)
    base = sc.stiffness_modes(sc.ServoCylinderParams())
    assert modes["orifice"] > base["orifice"] and modes["friction"] > base["friction"]
    # numerical Jacobian at null with the underlap: its largest eigenvalue is inside the bound
    y = _state(p, xv=0.0)
    J = np.empty((sc.N_STATES, sc.N_STATES))
    f0 = _rhs(p, y)
    for j in range(sc.N_STATES):
        h = 1e-7 * max(1.0, abs(y[j]))
        yp = y.copy()
        yp[j] += h
        J[:, j] = (_rhs(p, yp) - f0) / h
    assert np.max(np.abs(np.linalg.eigvals(J))) <= max(modes.values())
