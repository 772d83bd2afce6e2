"""The experiments behind the new independent rows measure what they say (known answers)."""

import dataclasses
import math

import numpy as np
import pytest


def test_locked_open_loop_response_follows_eq7_slow_pole():
    """Small current sines into the locked actuator: below the fluid and sensor modes the force
    falls as the valve's slow pole of eq (7) (b = 120.4 1/s, 19.2 Hz) and its zero/fast pole."""
    from hydro_envs.plants.force_actuator import model as fa
    from hydro_envs.plants.force_actuator.experiments import open_loop_force_response
    from hydro_envs.plants.force_actuator.params import ForceActuatorParams

    f = np.array([1.0, 5.0, 10.0, 20.0])
    h = open_loop_force_response(ForceActuatorParams(), f)
    s = 2j * math.pi * f
    g = (s + fa.VALVE_C) / ((s + fa.VALVE_A) * (s + fa.VALVE_B))
    assert np.abs(h / h[0]) == pytest.approx(np.abs(g / g[0]), rel=0.04)


def test_rig_viscous_coefficient_recovers_the_viscosity_law():
    """The method-1 rig at 30 C returns the model's c(30 C) = c40 nu(30)/nu(40) (ISO VG 46)."""
    from hydro_envs.laws.viscosity import iso_vg_kinematic_viscosity
    from hydro_envs.plants.ls_compensator.params import LSCompensatorParams
    from hydro_envs.plants.ls_compensator.validation import rig_viscous_coefficient

    p = LSCompensatorParams()
    c = rig_viscous_coefficient(p, 30.0)
    nu = iso_vg_kinematic_viscosity(46.0, 30.0) / iso_vg_kinematic_viscosity(46.0, 40.0)
    assert c == pytest.approx(p.viscous_friction_40c * nu, rel=0.01)


def test_peak_chamber_pressure_is_the_supply_once_stalled_and_nan_short_of_the_stop():
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.plants.servo_cylinder.validation import peak_chamber_pressure

    p = ServoCylinderParams()
    peak = peak_chamber_pressure(p)
    assert p.supply_pressure - p.tank_pressure - 0.2e6 < peak <= 1.01 * (p.supply_pressure - p.tank_pressure)
    assert math.isnan(peak_chamber_pressure(p, duration=0.02))  # not yet at the far stop


def test_full_opening_flow_scales_with_the_square_root_of_the_drop():
    """Orifice law eqs (1)-(4): four times the valve drop, twice the flow (friction aside)."""
    from hydro_envs.plants.shaking_table.experiments import full_opening_flow
    from hydro_envs.plants.shaking_table.params import ShakingTableParams

    p = dataclasses.replace(ShakingTableParams.preset("modified_ifas", "200kg"), coulomb_friction=0.0,
                            static_friction=0.0, viscous_friction=0.0)
    q1, q4 = full_opening_flow(p, 35e5, seconds=1.2), full_opening_flow(p, 140e5)
    assert q4 / q1 == pytest.approx(2.0, rel=0.03)
